//! The error left to volcomp when the controller compensates part of it:
//! the map minus the controller's own correction, as that controller
//! applies it (docs/controllers.md, "Compensate only what the controller
//! does not").
//!
//! A controller with an active pitch (leadscrew) table commands
//! `q − c(q, s)` when the program says `q`, where `c` is the error its
//! table holds at `q` in the direction of travel, interpolated and rounded
//! as the controller does, plus its backlash compensation
//! ([`ControllerCorrection`]). The tool then lands at
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
//!
//! The types a controller file is read into live here, in the model layer,
//! so that the readers and writers of `io::controllers` depend on the
//! model and never the other way round.

use super::{Components, Direction, Directions, ErrorModel};
use crate::error::ModelError;
pub use crate::model::positioning::Positioning;
use volcomp_gcode::Vec3;

/// The vendor formats of `volcomp map export` and `--controller`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// LinuxCNC `COMP_FILE` (types 0 and 1) and `BACKLASH`.
    Linuxcnc,
    /// Siemens Sinumerik leadscrew/encoder error compensation `%_N_AX_EEC_INI`.
    SiemensEec,
    /// Siemens Sinumerik sag/cross-axis compensation `%_N_NC_CEC_INI` (straightness).
    SiemensCec,
    /// Heidenhain TNC compensation value tables `.COM` and their assignment `.CMA`.
    Heidenhain,
    /// Beckhoff/ISG leadscrew error compensation lists (`kw.ssfk.*`).
    IsgSsfk,
    /// Beckhoff/ISG volumetric compensation ISG CSV.
    IsgCsv,
    /// Fanuc pitch error compensation (parameters 3620–3624, 3605#0/3626/3627 if bidirectional, and data) and backlash (1851, 1852).
    Fanuc,
    /// Klipper `[skew_correction]` profile.
    Klipper,
    /// Marlin `M852`.
    Marlin,
    /// RepRapFirmware `M556`.
    Rrf,
    /// grblHAL backlash settings `$160`–`$162`.
    Grblhal,
}

impl Format {
    /// The name used on the command line and in messages.
    pub fn name(self) -> &'static str {
        match self {
            Format::Linuxcnc => "linuxcnc",
            Format::SiemensEec => "siemens-eec",
            Format::SiemensCec => "siemens-cec",
            Format::Heidenhain => "heidenhain",
            Format::IsgSsfk => "isg-ssfk",
            Format::IsgCsv => "isg-csv",
            Format::Fanuc => "fanuc",
            Format::Klipper => "klipper",
            Format::Marlin => "marlin",
            Format::Rrf => "rrf",
            Format::Grblhal => "grblhal",
        }
    }
}

/// On which travel a controller's backlash (reversal) compensation acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BacklashSide {
    /// Half of it each way: `−B/2` moving forward, `+B/2` in reverse
    /// (LinuxCNC `BACKLASH` without a comp file: `control.c`,
    /// `compute_screw_comp`).
    Split,
    /// All of it on reverse travel, none forward: the controller took its
    /// reference moving forward (Siemens and Fanuc after a reference
    /// approach in +, grblHAL homing towards − (`$23` bit set)).
    Reverse,
    /// All of it on forward travel, none in reverse: the reference was
    /// taken moving in reverse (grblHAL's default homing towards + with
    /// its pull-off in −; Siemens and Fanuc referencing in −).
    Forward,
}

/// A controller's backlash compensation of one axis: the reversal value
/// `B` it corrects, in volcomp's sign (`B = E_reverse − E_forward`, µm:
/// positive for an axis that lags, the usual case; docs/design.md,
/// "Direction state and backlash"), and the travel it acts on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Backlash {
    /// `B` (µm).
    pub value_um: f64,
    /// Where it acts.
    pub side: BacklashSide,
}

impl Backlash {
    /// The part of `c(q, s)` it makes (µm), moving `forward` or in reverse.
    ///
    /// ```
    /// use volcomp_core::model::controller::{Backlash, BacklashSide};
    /// let b = Backlash { value_um: 4.0, side: BacklashSide::Split };
    /// assert_eq!((b.correction_um(true), b.correction_um(false)), (-2.0, 2.0));
    /// let b = Backlash { value_um: 4.0, side: BacklashSide::Forward };
    /// assert_eq!((b.correction_um(true), b.correction_um(false)), (-4.0, 0.0));
    /// ```
    pub fn correction_um(&self, forward: bool) -> f64 {
        let b = self.value_um;
        match (self.side, forward) {
            (BacklashSide::Split, true) => -0.5 * b,
            (BacklashSide::Split, false) => 0.5 * b,
            (BacklashSide::Reverse, true) | (BacklashSide::Forward, false) => 0.0,
            (BacklashSide::Reverse, false) => b,
            (BacklashSide::Forward, true) => -b,
        }
    }
}

/// A cross-axis table `(input axis, output axis, table)`: the error (µm)
/// along the output axis as a function of the input axis' position
/// (Siemens CEC), linearly interpolated, ends held.
pub type CrossTable = (usize, usize, Positioning);

/// The positioning correction a controller applies, in volcomp's sign: the
/// error `c_a(q, s)` (µm) the controller's table and backlash compensation
/// say axis `a` has at the commanded position `q`, which it removes by
/// commanding `q − c`.
///
/// Tables are interpolated linearly between their points and hold their
/// end values outside (LinuxCNC `compute_screw_comp`, Siemens K3 "the first
/// and last compensation values remain active over the entire traversing
/// range", Fanuc and Heidenhain: the compensation accumulated at the last
/// point). An axis without a table is `None`. A controller without
/// direction-dependent tables has `forward_um == reverse_um`.
#[derive(Debug, Clone, PartialEq)]
pub struct ControllerCorrection {
    /// The format the correction was read from or written to.
    pub format: Format,
    /// Per axis X, Y, Z.
    pub axes: [Option<Positioning>; 3],
    /// The backlash compensation per axis, added to the table (`None`:
    /// none, or the controller ignores it).
    pub backlash: [Option<Backlash>; 3],
    /// The squareness the controller corrects, `[S_xy, S_yz, S_zx]` (µrad,
    /// docs/design.md, "The 21-component model"), if any.
    pub squareness_urad: Option<[f64; 3]>,
    /// Cross-axis tables (Siemens CEC).
    pub cross: Vec<CrossTable>,
    /// What reading the file assumed or found ignored by the controller
    /// (a setting the controller overrides, a default taken for a setting
    /// the file does not give), for the front end to show.
    pub notes: Vec<String>,
}

impl ControllerCorrection {
    /// A correction of format `format` with nothing in it.
    pub fn empty(format: Format) -> Self {
        ControllerCorrection {
            format,
            axes: [None, None, None],
            backlash: [None, None, None],
            squareness_urad: None,
            cross: Vec::new(),
            notes: Vec::new(),
        }
    }

    /// `c_a(q, s)` in µm: the table of axis `axis` (0, 1, 2) at `q_mm` in
    /// direction `forward` (or reverse), linearly interpolated, ends held,
    /// plus the axis' backlash compensation; 0 for an axis without either.
    pub fn correction_um(&self, axis: usize, q_mm: f64, forward: bool) -> f64 {
        let table = match &self.axes[axis] {
            None => 0.0,
            Some(p) => {
                let v = if forward {
                    &p.forward_um
                } else {
                    &p.reverse_um
                };
                interpolate_held(&p.positions_mm, v, q_mm)
            }
        };
        table + self.backlash[axis].map_or(0.0, |b| b.correction_um(forward))
    }

    /// Whether the controller corrects anything at all.
    pub fn is_empty(&self) -> bool {
        self.axes.iter().all(Option::is_none)
            && self.backlash.iter().all(Option::is_none)
            && self.squareness_urad.is_none()
            && self.cross.is_empty()
    }
}

/// Linear interpolation in a table with strictly increasing `x`, holding
/// the end values outside it (as the controllers of `io::controllers` do).
///
/// ```
/// use volcomp_core::model::controller::interpolate_held;
/// let x = [0.0, 10.0, 20.0];
/// let v = [0.0, 4.0, 2.0];
/// assert_eq!(interpolate_held(&x, &v, 5.0), 2.0);
/// assert_eq!(interpolate_held(&x, &v, -3.0), 0.0);
/// assert_eq!(interpolate_held(&x, &v, 25.0), 2.0);
/// ```
pub fn interpolate_held(x: &[f64], v: &[f64], at: f64) -> f64 {
    let n = x.len();
    if n == 0 {
        return 0.0;
    }
    if at <= x[0] {
        return v[0];
    }
    if at >= x[n - 1] {
        return v[n - 1];
    }
    let i = x.partition_point(|&p| p <= at) - 1;
    let t = (at - x[i]) / (x[i + 1] - x[i]);
    v[i] + (v[i + 1] - v[i]) * t
}

/// A volumetric compensation as a controller applies it: the 21-component
/// model's whole deviation, with the output axes the configuration negates
/// or sets to zero (ISG `negate` P-VOLC-00009, `set_to_zero`).
#[derive(Debug, Clone, PartialEq)]
pub struct Volumetric {
    /// The model the controller evaluates.
    pub model: crate::model::kinematic::KinematicModel,
    /// Output axes (X, Y, Z) whose compensation value the controller negates.
    pub negate: [bool; 3],
    /// Output axes whose compensation value the controller sets to zero.
    pub zero: [bool; 3],
    /// What reading the configuration assumed (see [`ControllerCorrection::notes`]).
    pub notes: Vec<String>,
}

impl Volumetric {
    /// The model applied as is.
    pub fn plain(model: crate::model::kinematic::KinematicModel) -> Self {
        Volumetric {
            model,
            negate: [false; 3],
            zero: [false; 3],
            notes: Vec::new(),
        }
    }

    fn apply(&self, mut c: Vec3) -> Vec3 {
        for a in 0..3 {
            if self.zero[a] {
                c[a] = 0.0;
            } else if self.negate[a] {
                c[a] = -c[a];
            }
        }
        c
    }
}

/// What the controller compensates.
#[derive(Debug, Clone, PartialEq)]
pub enum ControllerApplies {
    /// The tables (and squareness) of a controller file, as read or exported.
    Tables(Box<ControllerCorrection>),
    /// A full volumetric compensation from a 21-component model (the ISG
    /// volumetric compensation's parameter files): the controller removes
    /// that model's whole deviation (negated or zeroed on the axes its
    /// configuration says).
    Model(Box<Volumetric>),
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

impl ControllerApplies {
    /// What reading the controller's files assumed or found ignored.
    pub fn notes(&self) -> &[String] {
        match self {
            ControllerApplies::Tables(t) => &t.notes,
            ControllerApplies::Model(v) => &v.notes,
            ControllerApplies::MapPositioning => &[],
        }
    }
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
            ControllerApplies::Model(v) => Ok(v.apply(match tool {
                Some(t) => v.model.deviation_with_tool_um(q_mm, s, components, t)?,
                None => v.model.deviation_um(q_mm, s, components)?,
            })),
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
                        c[*o] += interpolate_held(&table.positions_mm, v, q_mm[*i]);
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
    use crate::model::axis_table::AxisTableMap;
    use crate::model::{Direction::Forward as F, Direction::Reverse as R};

    /// The residual of `r` at `q` (mm) with direction state `s` is `want`
    /// (µm).
    fn assert_residual(
        r: &ControllerResidual<AxisTableMap>,
        q: [f64; 3],
        s: Directions,
        want: [f64; 3],
    ) {
        let [x, y, z] = q;
        let v = r
            .deviation_um(Vec3::new(x, y, z), s, Components::All)
            .unwrap();
        let [x, y, z] = want;
        assert!((v - Vec3::new(x, y, z)).norm() < 1e-12, "{v:?}");
    }

    /// The controller applies `tables` to [`map`].
    fn with_tables(tables: ControllerCorrection) -> ControllerResidual<AxisTableMap> {
        ControllerResidual {
            map: map(),
            controller: ControllerApplies::Tables(Box::new(tables)),
        }
    }

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
        let table = Positioning::new(&[0.0, 50.0, 100.0], &[1.0, 6.0, 11.0], &[1.0, 6.0, 11.0]);
        let r = with_tables(ControllerCorrection {
            axes: [Some(table), None, None],
            ..ControllerCorrection::empty(Format::SiemensEec)
        });
        let q = Vec3::new(25.0, 10.0, 10.0);
        // Forward: e = (2.5, 0.75, 0), c = (3.5, 0, 0) → r = (−1, 0.75, 0):
        // the controller's one table is the mean, so forward is 1 µm short.
        assert_residual(&r, q.to_array(), [F, F, F], [-1.0, 0.75, 0.0]);
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
        // e = (7, 1.5, 0) reverse; the positioning part 7 is the controller's.
        assert_residual(&r, [50.0, 0.0, 0.0], [R, F, F], [0.0, 1.5, 0.0]);
    }

    #[test]
    fn a_cross_table_corrects_its_output_axis() {
        // The controller corrects E_YX = 0 → 3 µm over X 0 … 100 (the map's
        // straightness): at x = 50 the residual in Y is 1.5 − 1.5 = 0.
        let r = with_tables(ControllerCorrection {
            cross: vec![(
                0,
                1,
                Positioning::new(&[0.0, 100.0], &[0.0, 3.0], &[0.0, 3.0]),
            )],
            ..ControllerCorrection::empty(Format::SiemensCec)
        });
        assert_residual(&r, [50.0, 0.0, 0.0], [F, F, F], [5.0, 0.0, 0.0]);
    }

    #[test]
    fn squareness_of_a_firmware_is_subtracted() {
        let r = with_tables(ControllerCorrection {
            squareness_urad: Some([10.0, -20.0, 30.0]),
            ..ControllerCorrection::empty(Format::Klipper)
        });
        // At (0, 50, 20): c = (10·50 + 30·20, −20·20, 0)·10⁻³ = (1.1, −0.4, 0) µm; e = 0.
        assert_residual(&r, [0.0, 50.0, 20.0], [F, F, F], [-1.1, 0.4, 0.0]);
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
