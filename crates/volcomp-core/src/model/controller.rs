//! The error left to volcomp when the controller compensates part of it:
//! the map minus the controller's own correction, as that controller
//! applies it (docs/controllers.md, "Compensate only what the controller
//! does not").
//!
//! A controller with an active pitch (leadscrew) table commands
//! `q − c(q, s)` when the program says `q`, where `c` is the error its
//! table holds at `q` in the direction of travel, interpolated and rounded
//! as the controller does ([`ControllerCorrection`]). The tool then lands at
//! `q − c + e(q − c, s)`. volcomp evaluates the residual to first order,
//!
//! ```text
//! r(q, s) = e(q, s) − c(q, s)
//! ```
//!
//! dropping `e(q − c) − e(q) ≈ (∂e/∂q)·c`: with error slopes below
//! 100 µm/m and corrections below 100 µm that is under 0.01 µm.
//!
//! Compensating the full map `e` on such a machine removes the pitch error
//! twice: the tool then lands off by `−c`, the controller's correction with
//! the opposite sign.

use super::{Components, Direction, Directions, ErrorModel};
use crate::error::ModelError;
use crate::io::controllers::ControllerCorrection;
use volcomp_gcode::Vec3;

/// What the controller compensates.
#[derive(Debug, Clone, PartialEq)]
pub enum ControllerApplies {
    /// The tables (and squareness) of a controller file, as read or exported.
    Tables(Box<ControllerCorrection>),
    /// A full volumetric compensation from a 21-component model (the ISG
    /// volumetric compensation's parameter files): the controller removes
    /// that model's whole deviation.
    Model(Box<crate::model::kinematic::KinematicModel>),
    /// The map's own positioning errors `E_XX`, `E_YY`, `E_ZZ`, exactly (an
    /// ideal pitch compensation: what a controller would apply from a table
    /// made from the same measurement at infinite resolution).
    MapPositioning,
}

/// A map seen through a controller that compensates part of it: an
/// [`ErrorModel`] of the residual `r = e − c`.
pub struct ControllerResidual<M> {
    /// The full error map of the machine.
    pub map: M,
    /// What the controller compensates.
    pub controller: ControllerApplies,
}

impl<M: ErrorModel> ControllerResidual<M> {
    /// The controller's correction `c(q, s)` in µm (X, Y, Z) for the tool
    /// offset `tool` (`None`: the map's default tool). `components` is that
    /// of the evaluation: with `PositioningOnly` a controller's squareness
    /// correction is left out, as the map's squareness is.
    pub fn correction_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
        tool: Option<Vec3>,
    ) -> Result<Vec3, ModelError> {
        match &self.controller {
            ControllerApplies::MapPositioning => match tool {
                Some(t) => self
                    .map
                    .deviation_with_tool_um(q_mm, s, Components::PositioningOnly, t),
                None => self.map.deviation_um(q_mm, s, Components::PositioningOnly),
            },
            ControllerApplies::Model(m) => match tool {
                Some(t) => m.deviation_with_tool_um(q_mm, s, components, t),
                None => m.deviation_um(q_mm, s, components),
            },
            ControllerApplies::Tables(t) => {
                let mut c = Vec3::ZERO;
                for a in 0..3 {
                    c[a] = t.correction_um(a, q_mm[a], s[a] == Direction::Forward);
                }
                if components == Components::All {
                    for (i, o, table) in &t.cross {
                        let v = if s[*i] == Direction::Forward {
                            &table.forward_um
                        } else {
                            &table.reverse_um
                        };
                        c[*o] += crate::io::controllers::interpolate_held(
                            &table.positions_mm,
                            v,
                            q_mm[*i],
                        );
                    }
                }
                if let (Some([xy, yz, zx]), Components::All) = (t.squareness_urad, components) {
                    // µrad · mm = 10⁻³ µm (docs/design.md, "The 21-component model").
                    c[0] += (xy * q_mm.y + zx * q_mm.z) * 1e-3;
                    c[1] += yz * q_mm.z * 1e-3;
                }
                Ok(c)
            }
        }
    }
}

impl<M: ErrorModel> ErrorModel for ControllerResidual<M> {
    fn deviation_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
    ) -> Result<Vec3, ModelError> {
        let e = self.map.deviation_um(q_mm, s, components)?;
        Ok(e - self.correction_um(q_mm, s, components, None)?)
    }

    fn range_mm(&self) -> [[f64; 2]; 3] {
        self.map.range_mm()
    }

    fn deviation_with_tool_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
        tool_length_offset_mm: Vec3,
    ) -> Result<Vec3, ModelError> {
        let e = self
            .map
            .deviation_with_tool_um(q_mm, s, components, tool_length_offset_mm)?;
        Ok(e - self.correction_um(q_mm, s, components, Some(tool_length_offset_mm))?)
    }

    fn uses_tool_offset(&self) -> bool {
        self.map.uses_tool_offset()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::controllers::{Format, Positioning};
    use crate::model::axis_table::AxisTableMap;
    use crate::model::{Direction::Forward as F, Direction::Reverse as R};

    fn map() -> AxisTableMap {
        // X: E_XX = 0 → 10 µm over 0 … 100 mm forward, 2 → 12 reverse;
        // E_YX (straightness) 0 → 3 µm. Y, Z: no error.
        let csv = "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
                   X,forward,0,0,0,0\nX,forward,100,10,3,0\n\
                   X,reverse,0,2,0,0\nX,reverse,100,12,3,0\n\
                   Y,both,0,0,0,0\nY,both,100,0,0,0\nZ,both,0,0,0,0\nZ,both,100,0,0,0\n";
        AxisTableMap::from_csv(csv, "m.csv").unwrap()
    }

    #[test]
    fn a_table_is_subtracted_as_the_controller_interpolates_it() {
        // The controller's X table every 50 mm, one table for both directions
        // (the mean 1, 6, 11 µm), rounded to 1 µm as written.
        let table = Positioning {
            positions_mm: vec![0.0, 50.0, 100.0],
            forward_um: vec![1.0, 6.0, 11.0],
            reverse_um: vec![1.0, 6.0, 11.0],
        };
        let r = ControllerResidual {
            map: map(),
            controller: ControllerApplies::Tables(Box::new(ControllerCorrection {
                format: Format::SiemensEec,
                axes: [Some(table), None, None],
                squareness_urad: None,
                cross: Vec::new(),
            })),
        };
        let q = Vec3::new(25.0, 10.0, 10.0);
        // Forward: e = (2.5, 0.75, 0), c = (3.5, 0, 0) → r = (−1, 0.75, 0):
        // the controller's one table is the mean, so forward is 1 µm short.
        let f = r.deviation_um(q, [F, F, F], Components::All).unwrap();
        assert!((f - Vec3::new(-1.0, 0.75, 0.0)).norm() < 1e-12, "{f:?}");
        // Reverse: e_x = 4.5 → r_x = +1.
        let b = r.deviation_um(q, [R, F, F], Components::All).unwrap();
        assert!((b.x - 1.0).abs() < 1e-12);
        // Beyond the table the controller holds its end value 11 µm.
        assert_eq!(r.range_mm(), map().range_mm());
    }

    #[test]
    fn map_positioning_leaves_everything_else() {
        let r = ControllerResidual {
            map: map(),
            controller: ControllerApplies::MapPositioning,
        };
        let v = r
            .deviation_um(Vec3::new(50.0, 0.0, 0.0), [R, F, F], Components::All)
            .unwrap();
        // e = (7, 1.5, 0) reverse; the positioning part 7 is the controller's.
        assert!((v - Vec3::new(0.0, 1.5, 0.0)).norm() < 1e-12, "{v:?}");
    }

    #[test]
    fn a_cross_table_corrects_its_output_axis() {
        // The controller corrects E_YX = 0 → 3 µm over X 0 … 100 (the map's
        // straightness): at x = 50 the residual in Y is 1.5 − 1.5 = 0.
        let r = ControllerResidual {
            map: map(),
            controller: ControllerApplies::Tables(Box::new(ControllerCorrection {
                format: Format::SiemensCec,
                axes: [None, None, None],
                squareness_urad: None,
                cross: vec![(
                    0,
                    1,
                    Positioning {
                        positions_mm: vec![0.0, 100.0],
                        forward_um: vec![0.0, 3.0],
                        reverse_um: vec![0.0, 3.0],
                    },
                )],
            })),
        };
        let v = r
            .deviation_um(Vec3::new(50.0, 0.0, 0.0), [F, F, F], Components::All)
            .unwrap();
        assert!((v - Vec3::new(5.0, 0.0, 0.0)).norm() < 1e-12, "{v:?}");
    }

    #[test]
    fn squareness_of_a_firmware_is_subtracted() {
        let r = ControllerResidual {
            map: map(),
            controller: ControllerApplies::Tables(Box::new(ControllerCorrection {
                format: Format::Klipper,
                axes: [None, None, None],
                squareness_urad: Some([10.0, -20.0, 30.0]),
                cross: Vec::new(),
            })),
        };
        // At (0, 50, 20): c = (10·50 + 30·20, −20·20, 0)·10⁻³ = (1.1, −0.4, 0) µm; e = 0.
        let v = r
            .deviation_um(Vec3::new(0.0, 50.0, 20.0), [F, F, F], Components::All)
            .unwrap();
        assert!((v - Vec3::new(-1.1, 0.4, 0.0)).norm() < 1e-12, "{v:?}");
        // Positioning only: the squareness is not part of it.
        let p = r
            .deviation_um(
                Vec3::new(0.0, 50.0, 20.0),
                [F, F, F],
                Components::PositioningOnly,
            )
            .unwrap();
        assert_eq!(p, Vec3::ZERO);
    }
}
