//! The 21-component kinematic error model of a 3-axis machine (ISO 230-1,
//! docs/design.md, "The 21-component model"), evaluated at the tool tip with homogeneous transformation
//! matrices (HTM) or in its first-order (small-angle) form.
//!
//! Per axis `a ∈ {X, Y, Z}`, six error motions over the axis position
//! (ISO 230-1:2012 symbols `E<direction><axis>`):
//!
//! | axis | positioning | straightness | angular (about X, Y, Z) |
//! |------|-------------|--------------|-------------------------|
//! | X    | EXX         | EYX, EZX     | EAX, EBX, ECX           |
//! | Y    | EYY         | EXY, EZY     | EAY, EBY, ECY           |
//! | Z    | EZZ         | EXZ, EYZ     | EAZ, EBZ, ECZ           |
//!
//! plus three squareness errors (docs/design.md, "The 21-component model": X is the reference, Y moves along
//! `(S_xy, 1, 0)`, Z along `(S_zx, S_yz, 1)`), 21 in all. Linear errors in µm,
//! angles in µrad, all of them *relative*: the motion of the tool with
//! respect to the workpiece that the axis' motion causes (`e = actual −
//! commanded`, docs/design.md, "Deviation sign"), the linear ones as measured at the axis'
//! measuring point.
//!
//! The volumetric deviation at the tool tip (derivation in `docs/kinematic.md`):
//!
//! ```text
//! first order:  e = Σ_a δ_a(q_a) + Σ_a ε_a(q_a) × r_a + e_⊥(q)
//! HTM:          e = Σ_a δ_a + Σ_k (R_k − I)(r'_k + d_k)   (k in chain order)
//! r_a = Σ_{j after a in the chain} (q_j − m_j^a)·u_j + (L_m^a − L)
//! ```
//!
//! `δ_a` are the linear and `ε_a` the angular errors of axis `a`; `r_a` the
//! Abbe arm from the point where `a`'s linear errors were measured (axis
//! positions `m^a`, tool length offset `L_m^a`) to the tool tip (tool length
//! offset `L`); `e_⊥ = (S_xy·y + S_zx·z, S_yz·z, 0)` the squareness term; `R_k`
//! the exact rotation `Rz(E_C)·Ry(E_B)·Rx(E_A)`, `r'_k` the arm along the
//! out-of-square axis directions `u_j`, and `d_k` the displacement the joints
//! after `k` already caused. With every angle zero both forms are exactly the
//! axis-table vector sum of docs/design.md (plus squareness).

use crate::error::ModelError;
use crate::model::axis_table::Table;
use crate::model::topology::Topology;
use crate::model::{Components, Direction, Directions, ErrorModel};
use volcomp_gcode::Vec3;

const AXES: [char; 3] = ['X', 'Y', 'Z'];

/// ISO 230-1 name of the linear error along `dir` caused by `axis` (EXX, EYX …).
pub fn linear_name(dir: usize, axis: usize) -> String {
    format!("E{}{}", AXES[dir], AXES[axis])
}

/// ISO 230-1 name of the rotation about `dir` caused by `axis` (EAX, EBX …).
pub fn angular_name(dir: usize, axis: usize) -> String {
    format!("E{}{}", ['A', 'B', 'C'][dir], AXES[axis])
}

/// The six error motions of one axis in one direction, at strictly
/// increasing positions.
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentTable {
    /// `(E_Xa, E_Ya, E_Za)` in µm at each position: positioning and straightness.
    pub linear_um: Table,
    /// `(E_Aa, E_Ba, E_Ca)` in µrad at each position: rotations about X, Y, Z.
    pub angular_urad: Table,
}

impl ComponentTable {
    /// A table from positions and values; `None` unless the lengths agree,
    /// there are at least two points and the positions strictly increase.
    pub fn new(
        positions_mm: Vec<f64>,
        linear_um: Vec<Vec3>,
        angular_urad: Vec<Vec3>,
    ) -> Option<Self> {
        let n = positions_mm.len();
        if n < 2 || linear_um.len() != n || angular_urad.len() != n {
            return None;
        }
        if positions_mm.iter().any(|p| !p.is_finite())
            || positions_mm.windows(2).any(|w| w[1] <= w[0])
        {
            return None;
        }
        Some(Self {
            linear_um: Table {
                positions_mm: positions_mm.clone(),
                errors_um: linear_um,
            },
            angular_urad: Table {
                positions_mm,
                errors_um: angular_urad,
            },
        })
    }

    /// A table of zeros at `positions_mm`.
    pub fn zeros(positions_mm: Vec<f64>) -> Option<Self> {
        let n = positions_mm.len();
        Self::new(positions_mm, vec![Vec3::ZERO; n], vec![Vec3::ZERO; n])
    }

    /// Positions (mm).
    pub fn positions_mm(&self) -> &[f64] {
        &self.linear_um.positions_mm
    }

    /// `[first, last]` position.
    pub fn range(&self) -> [f64; 2] {
        self.linear_um.range()
    }
}

/// Forward and reverse tables of one axis (equal when measured as `both`).
#[derive(Debug, Clone, PartialEq)]
pub struct AxisComponents {
    /// Used while the axis moves forward.
    pub forward: ComponentTable,
    /// Used while the axis moves in reverse.
    pub reverse: ComponentTable,
}

impl AxisComponents {
    /// The table for direction `d`.
    pub fn table(&self, d: Direction) -> &ComponentTable {
        match d {
            Direction::Forward => &self.forward,
            Direction::Reverse => &self.reverse,
        }
    }

    /// The same table for both directions.
    pub fn both(table: ComponentTable) -> Self {
        Self {
            forward: table.clone(),
            reverse: table,
        }
    }

    /// `[min, max]` where both directions are defined.
    pub fn range(&self) -> [f64; 2] {
        let f = self.forward.range();
        let r = self.reverse.range();
        [f[0].max(r[0]), f[1].min(r[1])]
    }
}

/// The three squareness errors (µrad), docs/design.md, "The 21-component model": Y moves along
/// `(S_xy, 1, 0)`, Z along `(S_zx, S_yz, 1)`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Squareness {
    /// `S_xy` (ISO 230-1 `EC0Y`-like: X–Y squareness), µrad.
    pub xy_urad: f64,
    /// `S_yz`, µrad.
    pub yz_urad: f64,
    /// `S_zx`, µrad.
    pub zx_urad: f64,
}

impl Squareness {
    /// `e_⊥(q) = (S_xy·y + S_zx·z, S_yz·z, 0)` in µm.
    pub fn deviation_um(&self, q_mm: Vec3) -> Vec3 {
        Vec3::new(
            (self.xy_urad * q_mm.y + self.zx_urad * q_mm.z) * 1e-3,
            self.yz_urad * q_mm.z * 1e-3,
            0.0,
        )
    }

    /// The actual direction of motion of axis `a` per unit of its position.
    pub fn direction(&self, a: usize) -> Vec3 {
        match a {
            0 => Vec3::new(1.0, 0.0, 0.0),
            1 => Vec3::new(self.xy_urad * 1e-6, 1.0, 0.0),
            _ => Vec3::new(self.zx_urad * 1e-6, self.yz_urad * 1e-6, 1.0),
        }
    }

    /// The part of `e_⊥` that axis `a`'s position causes (µm): none for X,
    /// `(S_xy·y, 0, 0)` for Y, `(S_zx·z, S_yz·z, 0)` for Z.
    pub fn of_axis_um(&self, a: usize, position_mm: f64) -> Vec3 {
        match a {
            0 => Vec3::ZERO,
            1 => Vec3::new(self.xy_urad * position_mm * 1e-3, 0.0, 0.0),
            _ => Vec3::new(
                self.zx_urad * position_mm * 1e-3,
                self.yz_urad * position_mm * 1e-3,
                0.0,
            ),
        }
    }
}

/// Where the linear errors of one axis were measured.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MeasuringLine {
    /// Positions of the axes (mm) while the axis was measured; the axis' own
    /// entry is not used (its linear errors are a function of it).
    pub point_mm: Vec3,
    /// Tool length offset of the measuring point (the reflector or probe), in
    /// the sense of G43: the point lies at `−tool_offset_mm` from the gauge
    /// point, e.g. `(0, 0, 100)` for a reflector 100 mm below the spindle nose.
    pub tool_offset_mm: Vec3,
}

/// How the angular errors in the tables are signed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum AngleConvention {
    /// Rotations of the tool relative to the workpiece (ISO 230-1's
    /// functional-point view; volcomp's own convention).
    #[default]
    Relative,
    /// Rotations of the moving part as an angular interferometer or level on
    /// that part records them: for axes that carry the workpiece the relative
    /// rotation is the inverse.
    MovingPart,
}

/// Which evaluation the model uses.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Form {
    /// Exact products of homogeneous transformation matrices.
    #[default]
    Htm,
    /// The small-angle (first-order) form.
    FirstOrder,
}

/// The values of the 18 position-dependent components at one configuration.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ComponentValues {
    /// `(E_Xa, E_Ya, E_Za)` per axis `a`, µm.
    pub linear_um: [Vec3; 3],
    /// `(E_Aa, E_Ba, E_Ca)` per axis `a`, µrad, as written in the tables.
    pub angular_urad: [Vec3; 3],
}

/// The geometry that turns component values into a tool-tip deviation: the
/// chain, the measuring lines, squareness and the angle convention. Kept
/// apart from the tables so that other representations of the components
/// (polynomials, identified parameters) reuse the same evaluation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kinematics {
    /// Kinematic chain from workpiece to tool.
    pub topology: Topology,
    /// Where each axis' linear errors were measured.
    pub measuring: [MeasuringLine; 3],
    /// Squareness errors.
    pub squareness: Squareness,
    /// Sign convention of the angular errors.
    pub angles: AngleConvention,
}

mod chain;
mod tables;
#[cfg(test)]
mod tests;

/// The 21-component model: component tables per axis and direction, and
/// the machine's kinematics.
#[derive(Debug, Clone, PartialEq)]
pub struct KinematicModel {
    /// Component tables of X, Y, Z.
    pub axes: [AxisComponents; 3],
    /// Chain, measuring lines, squareness, angle convention.
    pub kinematics: Kinematics,
    /// HTM (default) or first-order evaluation.
    pub form: Form,
    /// Tool length offset used when the caller gives none
    /// ([`ErrorModel::deviation_um`]); compensation passes the active tool's.
    pub tool_offset_mm: Vec3,
    /// Clamp positions outside a table to its end instead of refusing them.
    pub clamp: bool,
}

impl KinematicModel {
    /// A model from tables and kinematics, HTM form, no tool, not clamped.
    pub fn new(axes: [AxisComponents; 3], kinematics: Kinematics) -> Self {
        Self {
            axes,
            kinematics,
            form: Form::Htm,
            tool_offset_mm: Vec3::ZERO,
            clamp: false,
        }
    }

    /// Position of axis `a` at which its tables are read (clamped if asked),
    /// or the out-of-range error.
    fn lookup(&self, a: usize, table: &ComponentTable, x: f64) -> Result<f64, ModelError> {
        let [lo, hi] = table.range();
        let xc = if self.clamp { x.clamp(lo, hi) } else { x };
        crate::model::within_range(xc, lo, hi).ok_or(ModelError::OutOfRange {
            axis: AXES[a],
            position_mm: x,
            min_mm: lo,
            max_mm: hi,
        })
    }

    /// Component values at `q` with direction state `s`.
    pub fn values(&self, q_mm: Vec3, s: Directions) -> Result<ComponentValues, ModelError> {
        let mut v = ComponentValues::default();
        for a in 0..3 {
            let t = self.axes[a].table(s[a]);
            let x = self.lookup(a, t, q_mm[a])?;
            // In range after the check, so eval cannot fail.
            v.linear_um[a] = t.linear_um.eval(x).unwrap_or(Vec3::ZERO);
            v.angular_urad[a] = t.angular_urad.eval(x).unwrap_or(Vec3::ZERO);
        }
        Ok(v)
    }

    /// Deviation (µm) with an explicit form and tool offset.
    pub fn deviation_form_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        tool_offset_mm: Vec3,
        form: Form,
    ) -> Result<Vec3, ModelError> {
        let v = self.values(q_mm, s)?;
        Ok(match form {
            Form::Htm => self.kinematics.htm_um(&v, q_mm, tool_offset_mm),
            Form::FirstOrder => self.kinematics.first_order_um(&v, q_mm, tool_offset_mm),
        })
    }

    /// What axis `a` alone contributes at `q` when it moves in direction `d`
    /// (µm): its linear errors, its angular errors through its Abbe arm, and
    /// its share of squareness (none for X; `S_xy·y` for Y; `S_zx·z`, `S_yz·z`
    /// for Z). The sum over the axes is the model's deviation, up to the
    /// products of errors of two different axes (second order).
    pub fn axis_contribution_um(
        &self,
        a: usize,
        q_mm: Vec3,
        d: Direction,
        tool_offset_mm: Vec3,
        form: Form,
    ) -> Result<Vec3, ModelError> {
        let t = self.axes[a].table(d);
        let x = self.lookup(a, t, q_mm[a])?;
        let mut v = ComponentValues::default();
        v.linear_um[a] = t.linear_um.eval(x).unwrap_or(Vec3::ZERO);
        v.angular_urad[a] = t.angular_urad.eval(x).unwrap_or(Vec3::ZERO);
        let mut k = self.kinematics;
        k.squareness = Squareness::default();
        let e = match form {
            Form::Htm => k.htm_um(&v, q_mm, tool_offset_mm),
            Form::FirstOrder => k.first_order_um(&v, q_mm, tool_offset_mm),
        };
        Ok(e + self.kinematics.squareness.of_axis_um(a, q_mm[a]))
    }
}

impl ErrorModel for KinematicModel {
    fn deviation_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
    ) -> Result<Vec3, ModelError> {
        self.deviation_with_tool_um(q_mm, s, components, self.tool_offset_mm)
    }

    fn range_mm(&self) -> [[f64; 2]; 3] {
        [0, 1, 2].map(|a| self.axes[a].range())
    }

    fn deviation_with_tool_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
        tool_length_offset_mm: Vec3,
    ) -> Result<Vec3, ModelError> {
        match components {
            Components::All => self.deviation_form_um(q_mm, s, tool_length_offset_mm, self.form),
            Components::PositioningOnly => {
                let v = self.values(q_mm, s)?;
                Ok(Vec3::new(
                    v.linear_um[0].x,
                    v.linear_um[1].y,
                    v.linear_um[2].z,
                ))
            }
        }
    }

    fn uses_tool_offset(&self) -> bool {
        true
    }
}
