//! Queries of a model beyond the deviation: what each axis contributes,
//! the component values and Abbe arms of the 21-component model at a
//! point, and each component as a series over its axis (for plots).

use crate::error::ModelError;
use crate::model::axis_table::{AxisTableMap, Table};
use crate::model::kinematic::{angular_name, linear_name, ComponentValues, Form, KinematicModel};
use crate::model::{Components, Directions, ErrorModel};
use volcomp_gcode::Vec3;
use volcomp_geom::Axis;

impl AxisTableMap {
    /// What each axis' table gives at `q_mm` with direction state `s` (µm),
    /// X, Y, Z: the three vectors whose sum is the deviation. Positions
    /// outside a table are held at its end when the map clamps, refused
    /// otherwise.
    pub fn per_axis_um(&self, q_mm: Vec3, s: Directions) -> Result<[Vec3; 3], ModelError> {
        let mut out = [Vec3::ZERO; 3];
        for (a, o) in out.iter_mut().enumerate() {
            let table = self.axes[a].table(s[a]);
            let [lo, hi] = table.range();
            let x = if self.clamp {
                q_mm[a].clamp(lo, hi)
            } else {
                // Within the rounding of a computed position: at the end.
                crate::model::within_range(q_mm[a], lo, hi).unwrap_or(q_mm[a])
            };
            *o = table.eval(x).ok_or(ModelError::OutOfRange {
                axis: ['X', 'Y', 'Z'][a],
                position_mm: q_mm[a],
                min_mm: lo,
                max_mm: hi,
            })?;
        }
        Ok(out)
    }
}

/// The 21-component model at one point, for one tool: the deviation in
/// both forms and everything it is made of.
#[derive(Debug, Clone, PartialEq)]
pub struct KinematicQuery {
    /// The deviation in the model's own form (µm).
    pub deviation_um: Vec3,
    /// The deviation with homogeneous transformation matrices (µm).
    pub deviation_htm_um: Vec3,
    /// The deviation in the first-order form (µm).
    pub deviation_first_order_um: Vec3,
    /// Only the positioning errors E_XX, E_YY, E_ZZ (µm).
    pub positioning_um: Vec3,
    /// The squareness term `(S_xy·y + S_zx·z, S_yz·z, 0)` (µm).
    pub squareness_um: Vec3,
    /// The 18 component values.
    pub values: ComponentValues,
    /// Abbe arm of each axis (mm).
    pub abbe_arms_mm: [Vec3; 3],
    /// What each axis alone contributes, first-order form (µm).
    pub axis_contributions_um: [Vec3; 3],
}

impl KinematicModel {
    /// The model at `q_mm`, direction state `s`, tool length offset `tool_offset_mm`.
    pub fn query(
        &self,
        q_mm: Vec3,
        s: Directions,
        tool_offset_mm: Vec3,
    ) -> Result<KinematicQuery, ModelError> {
        let k = &self.kinematics;
        let mut abbe_arms_mm = [Vec3::ZERO; 3];
        let mut axis_contributions_um = [Vec3::ZERO; 3];
        for a in 0..3 {
            abbe_arms_mm[a] = k.arm_mm(a, q_mm, tool_offset_mm);
            axis_contributions_um[a] =
                self.axis_contribution_um(a, q_mm, s[a], tool_offset_mm, Form::FirstOrder)?;
        }
        Ok(KinematicQuery {
            deviation_um: self.deviation_with_tool_um(q_mm, s, Components::All, tool_offset_mm)?,
            deviation_htm_um: self.deviation_form_um(q_mm, s, tool_offset_mm, Form::Htm)?,
            deviation_first_order_um: self.deviation_form_um(
                q_mm,
                s,
                tool_offset_mm,
                Form::FirstOrder,
            )?,
            positioning_um: self.deviation_with_tool_um(
                q_mm,
                s,
                Components::PositioningOnly,
                tool_offset_mm,
            )?,
            squareness_um: k.squareness.deviation_um(q_mm),
            values: self.values(q_mm, s)?,
            abbe_arms_mm,
            axis_contributions_um,
        })
    }
}

/// One error component over its axis position: `(position_mm, value)` pairs.
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentSeries {
    /// The component's name (`EXX`, or `EXX forward` / `EXX reverse`).
    pub name: String,
    /// The points, in table order.
    pub points: Vec<(f64, f64)>,
}

/// One series per direction of a component, or one when both directions
/// agree (same positions and values).
pub fn component_series(
    name: String,
    forward: (&[f64], Vec<f64>),
    reverse: (&[f64], Vec<f64>),
) -> Vec<ComponentSeries> {
    let points = |p: &[f64], v: Vec<f64>| p.iter().copied().zip(v).collect();
    if forward.0 == reverse.0 && forward.1 == reverse.1 {
        vec![ComponentSeries {
            name,
            points: points(forward.0, forward.1),
        }]
    } else {
        vec![
            ComponentSeries {
                name: format!("{name} forward"),
                points: points(forward.0, forward.1),
            },
            ComponentSeries {
                name: format!("{name} reverse"),
                points: points(reverse.0, reverse.1),
            },
        ]
    }
}

fn column(t: &Table, d: usize) -> Vec<f64> {
    t.errors_um.iter().map(|e| e[d]).collect()
}

impl AxisTableMap {
    /// The series of axis `a`'s table: the errors along X, Y, Z it causes
    /// (named E_XA, E_YA, E_ZA), per direction where they differ.
    pub fn component_series(&self, axis: Axis) -> Vec<ComponentSeries> {
        let a = axis.index();
        let t = &self.axes[a];
        (0..3)
            .flat_map(|d| {
                component_series(
                    linear_name(d, a),
                    (&t.forward.positions_mm, column(&t.forward, d)),
                    (&t.reverse.positions_mm, column(&t.reverse, d)),
                )
            })
            .collect()
    }
}

impl KinematicModel {
    /// The series of axis `a`: its positioning and straightness errors (µm),
    /// then its angular errors (µrad), per direction where they differ.
    pub fn component_series(&self, axis: Axis) -> (Vec<ComponentSeries>, Vec<ComponentSeries>) {
        let a = axis.index();
        let t = &self.axes[a];
        let mut linear = Vec::new();
        let mut angular = Vec::new();
        for d in 0..3 {
            linear.extend(component_series(
                linear_name(d, a),
                (t.forward.positions_mm(), column(&t.forward.linear_um, d)),
                (t.reverse.positions_mm(), column(&t.reverse.linear_um, d)),
            ));
            angular.extend(component_series(
                angular_name(d, a),
                (t.forward.positions_mm(), column(&t.forward.angular_urad, d)),
                (t.reverse.positions_mm(), column(&t.reverse.angular_urad, d)),
            ));
        }
        (linear, angular)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::axis_table::AxisTables;
    use crate::model::Direction::{Forward as F, Reverse as R};

    fn map(clamp: bool) -> AxisTableMap {
        let t = |e: [f64; 3]| Table {
            positions_mm: vec![0.0, 10.0],
            errors_um: vec![Vec3::ZERO, Vec3::from_array(e)],
        };
        AxisTableMap {
            axes: [
                AxisTables {
                    forward: t([2.0, 0.0, 0.0]),
                    reverse: t([4.0, 0.0, 0.0]),
                },
                AxisTables {
                    forward: t([0.0, 1.0, 1.0]),
                    reverse: t([0.0, 1.0, 1.0]),
                },
                AxisTables {
                    forward: t([0.0, 0.0, -6.0]),
                    reverse: t([0.0, 0.0, -6.0]),
                },
            ],
            clamp,
        }
    }

    #[test]
    fn per_axis_sums_to_the_deviation() {
        let m = map(false);
        let q = Vec3::new(5.0, 10.0, 2.5);
        let p = m.per_axis_um(q, [R, F, F]).unwrap();
        // X reverse half way to 4 → 2; Y at its end (0, 1, 1); Z a quarter of −6.
        assert_eq!(
            p,
            [
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 1.0),
                Vec3::new(0.0, 0.0, -1.5)
            ]
        );
        let e = m.deviation_um(q, [R, F, F], Components::All).unwrap();
        assert_eq!(p[0] + p[1] + p[2], e);
        // Outside a table: refused, or held at the end when clamped.
        let far = Vec3::new(20.0, 0.0, 0.0);
        assert!(m.per_axis_um(far, [F; 3]).is_err());
        assert_eq!(
            map(true).per_axis_um(far, [F; 3]).unwrap()[0],
            Vec3::new(2.0, 0.0, 0.0)
        );
    }

    #[test]
    fn series_merge_equal_directions() {
        let m = map(false);
        let x = m.component_series(Axis::X);
        // E_XX differs by direction (two series); E_YX and E_ZX agree (one each).
        let names: Vec<&str> = x.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["EXX forward", "EXX reverse", "EYX", "EZX"]);
        assert_eq!(x[1].points, vec![(0.0, 0.0), (10.0, 4.0)]);
        let y = m.component_series(Axis::Y);
        assert_eq!(y.len(), 3);
        assert_eq!(y[2].points, vec![(0.0, 0.0), (10.0, 1.0)]);
    }

    #[test]
    fn kinematic_query_of_a_positioning_only_model() {
        use crate::model::topology::Topology;
        // Only positioning errors: both forms, the positioning part and the
        // sum of the axis contributions are all the same vector.
        let km = KinematicModel::from_axis_tables(&map(false), Topology::SEED);
        let q = Vec3::new(5.0, 5.0, 5.0);
        let r = km.query(q, [F; 3], Vec3::new(0.0, 0.0, 100.0)).unwrap();
        // X: 1, Y: (0, 0.5, 0.5), Z: −3 → (1, 0.5, −2.5).
        let want = Vec3::new(1.0, 0.5, -2.5);
        assert!((r.deviation_um - want).norm() < 1e-12);
        assert!((r.deviation_htm_um - want).norm() < 1e-12);
        assert!((r.deviation_first_order_um - want).norm() < 1e-12);
        assert_eq!(r.positioning_um, Vec3::new(1.0, 0.5, -3.0));
        assert_eq!(r.squareness_um, Vec3::ZERO);
        let sum =
            r.axis_contributions_um[0] + r.axis_contributions_um[1] + r.axis_contributions_um[2];
        assert!((sum - want).norm() < 1e-12);
        let (lin, ang) = km.component_series(Axis::Z);
        assert_eq!(lin.len(), 3);
        assert!(ang.iter().all(|s| s.points.iter().all(|p| p.1 == 0.0)));
    }
}
