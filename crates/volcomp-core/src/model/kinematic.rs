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

use crate::model::axis_table::{AxisTableMap, AxisTables, Table};
use crate::error::ModelError;
use crate::model::{Components, Direction, Directions, ErrorModel};
use crate::model::topology::Topology;
use nalgebra::{Matrix3, Rotation3, Vector3};
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

fn na(v: Vec3) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

fn vc(v: Vector3<f64>) -> Vec3 {
    Vec3::new(v.x, v.y, v.z)
}

fn cross(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(
        a.y * b.z - a.z * b.y,
        a.z * b.x - a.x * b.z,
        a.x * b.y - a.y * b.x,
    )
}

impl Kinematics {
    /// The seed machine's chain, measured at the origin with no tool offset,
    /// square, relative angles.
    pub fn new(topology: Topology) -> Self {
        Self {
            topology,
            measuring: [MeasuringLine::default(); 3],
            squareness: Squareness::default(),
            angles: AngleConvention::Relative,
        }
    }

    /// `+1`, or `−1` where a moving-part angle must be inverted to be relative.
    fn angle_sign(&self, a: usize) -> f64 {
        match self.angles {
            AngleConvention::MovingPart if self.topology.carries_workpiece(a) => -1.0,
            _ => 1.0,
        }
    }

    /// The Abbe arm of axis `a` (mm): from the point where its linear errors
    /// were measured to the tool tip, along the nominal (square) axes:
    /// `Σ_{j after a} (q_j − m_j)·e_j + (L_m − L)`.
    ///
    /// ```
    /// use volcomp_core::model::kinematic::Kinematics;
    /// use volcomp_core::model::topology::Topology;
    /// use volcomp_gcode::Vec3;
    /// let k = Kinematics::new(Topology::SEED); // w X' Y' b Z t
    /// let q = Vec3::new(100.0, 50.0, 20.0);
    /// let tool = Vec3::new(0.0, 0.0, 80.0);
    /// // X swings Y, Z and the tool; Z only the tool (80 mm below the gauge point).
    /// assert_eq!(k.arm_mm(0, q, tool), Vec3::new(0.0, 50.0, -60.0));
    /// assert_eq!(k.arm_mm(2, q, tool), Vec3::new(0.0, 0.0, -80.0));
    /// ```
    pub fn arm_mm(&self, a: usize, q_mm: Vec3, tool_offset_mm: Vec3) -> Vec3 {
        let m = &self.measuring[a];
        let mut arm = m.tool_offset_mm - tool_offset_mm;
        for &j in self.topology.after(a) {
            arm[j] += q_mm[j] - m.point_mm[j];
        }
        arm
    }

    /// The Abbe arm along the actual (out-of-square) axis directions, as the
    /// HTM product sees it.
    fn arm_exact_mm(&self, a: usize, q_mm: Vec3, tool_offset_mm: Vec3) -> Vec3 {
        let m = &self.measuring[a];
        let mut arm = m.tool_offset_mm - tool_offset_mm;
        for &j in self.topology.after(a) {
            arm += self.squareness.direction(j) * (q_mm[j] - m.point_mm[j]);
        }
        arm
    }

    /// The relative rotation of axis `a` for the table angles `urad`
    /// (`Rz(E_C)·Ry(E_B)·Rx(E_A)`, inverted for workpiece-side axes under
    /// [`AngleConvention::MovingPart`]).
    pub fn rotation(&self, a: usize, urad: Vec3) -> Matrix3<f64> {
        let r = Rotation3::from_euler_angles(urad.x * 1e-6, urad.y * 1e-6, urad.z * 1e-6);
        let r = if self.angle_sign(a) < 0.0 {
            r.inverse()
        } else {
            r
        };
        r.into_inner()
    }

    /// First-order (small-angle) deviation at the tool tip, µm:
    /// `Σ δ_a + Σ ε_a × r_a + e_⊥` (ISO 230-1 Annex-style rigid-body model
    /// with the products of two errors dropped).
    pub fn first_order_um(&self, v: &ComponentValues, q_mm: Vec3, tool_offset_mm: Vec3) -> Vec3 {
        let mut e = v.linear_um[0] + v.linear_um[1] + v.linear_um[2];
        for a in 0..3 {
            let eps = v.angular_urad[a] * self.angle_sign(a);
            // µrad × mm = 1e-3 µm
            e += cross(eps, self.arm_mm(a, q_mm, tool_offset_mm)) * 1e-3;
        }
        e + self.squareness.deviation_um(q_mm)
    }

    /// Exact deviation at the tool tip by the product of homogeneous
    /// transformations, µm.
    ///
    /// Each joint `k` moves everything between it and the tool rigidly:
    /// `G_k(p) = c_k + δ_k + R_k·(p − c_k)` about its measuring point `c_k`;
    /// the tip is `G_1 ∘ G_2 ∘ G_3` of its nominal position (joints in chain
    /// order from the workpiece). Written as displacements so that nothing
    /// large is subtracted: `d_k = δ_k + (R_k − I)(r'_k + d_{k+1}) + d_{k+1}`.
    pub fn htm_um(&self, v: &ComponentValues, q_mm: Vec3, tool_offset_mm: Vec3) -> Vec3 {
        let linear = v.linear_um[0] + v.linear_um[1] + v.linear_um[2];
        let mut rotational = Vector3::zeros();
        let mut d_after = Vector3::zeros();
        for &k in self.topology.order().iter().rev() {
            let r = self.rotation(k, v.angular_urad[k]) - Matrix3::identity();
            let arm = na(self.arm_exact_mm(k, q_mm, tool_offset_mm));
            let swing = r * (arm + d_after);
            rotational += swing;
            d_after += na(v.linear_um[k] * 1e-3) + swing;
        }
        linear + vc(rotational) * 1e3 + self.squareness.deviation_um(q_mm)
    }

    /// The homogeneous transformation (4×4) of joint `k`'s error motion,
    /// `G_k = T(c_k)·T(δ_k)·R_k·T(−c_k)` in mm, for inspection and tests.
    pub fn joint_htm(
        &self,
        k: usize,
        v: &ComponentValues,
        q_mm: Vec3,
        tool_offset_mm: Vec3,
    ) -> nalgebra::Matrix4<f64> {
        // c_k relative to the nominal tip p: c_k = p − r'_k.
        let p = self.nominal_tip_mm(q_mm, tool_offset_mm);
        let c = p - na(self.arm_exact_mm(k, q_mm, tool_offset_mm));
        let mut g = nalgebra::Matrix4::identity();
        let r = self.rotation(k, v.angular_urad[k]);
        g.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
        let t = c + na(v.linear_um[k] * 1e-3) - r * c;
        g.fixed_view_mut::<3, 1>(0, 3).copy_from(&t);
        g
    }

    /// Nominal tip in workpiece coordinates (mm), with squareness:
    /// `Σ q_j·u_j − L`.
    fn nominal_tip_mm(&self, q_mm: Vec3, tool_offset_mm: Vec3) -> Vector3<f64> {
        let mut p = -na(tool_offset_mm);
        for j in 0..3 {
            p += na(self.squareness.direction(j) * q_mm[j]);
        }
        p
    }

    /// The deviation by the explicit 4×4 product `G_1·G_2·G_3` applied to the
    /// nominal tip (µm). Numerically weaker than [`Kinematics::htm_um`]
    /// (it subtracts positions of hundreds of mm); kept to show that the
    /// displacement form is the same product.
    pub fn htm_product_um(&self, v: &ComponentValues, q_mm: Vec3, tool_offset_mm: Vec3) -> Vec3 {
        let mut g = nalgebra::Matrix4::identity();
        for &k in self.topology.order().iter() {
            g *= self.joint_htm(k, v, q_mm, tool_offset_mm);
        }
        let p = self.nominal_tip_mm(q_mm, tool_offset_mm);
        let actual = g * p.push(1.0);
        let commanded = na(q_mm) - na(tool_offset_mm);
        vc(actual.xyz() - commanded) * 1e3
    }
}

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
        if !(lo..=hi).contains(&xc) {
            return Err(ModelError::OutOfRange {
                axis: AXES[a],
                position_mm: x,
                min_mm: lo,
                max_mm: hi,
            });
        }
        Ok(xc)
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

    /// The axis-table map (docs/design.md, "The axis-table map") that reproduces this model, for one
    /// tool, along the three lines through a reference point `r`.
    ///
    /// Axis `a`'s table in direction `d` at its own table positions `x`:
    ///
    /// ```text
    /// E_a^d(x) = e(r with q_a = x) − e(r) + c_a^d,   c_a^d = what a contributes at r
    /// ```
    ///
    /// (`e` with axis `a` in direction `d`, the others forward), so the
    /// table sum equals the model on the three lines through `r`, exactly in
    /// the first-order form and up to products of errors of two different
    /// axes (nanometres) in the HTM form; it includes the Abbe terms of every
    /// axis at `r` and this tool, and the cross terms `ε_b × (x − r_a)` of the
    /// axes `b` before `a` in the chain. Away from those lines an axis-table
    /// model cannot hold the products of one axis' angle and another axis'
    /// position: that part is lost.
    ///
    /// The positioning column `E_aa` is never touched by the cross terms (a
    /// rotation moves a point across its arm, not along it); at the axis'
    /// measuring point and tool it is exactly the model's `E_aa`.
    pub fn to_axis_tables(
        &self,
        reference_mm: Vec3,
        tool_offset_mm: Vec3,
        form: Form,
    ) -> Result<AxisTableMap, ModelError> {
        let r = reference_mm;
        let mut axes = Vec::with_capacity(3);
        for a in 0..3 {
            let table = |d: Direction| -> Result<Table, ModelError> {
                let mut s = [Direction::Forward; 3];
                s[a] = d;
                let at_r = self.deviation_form_um(r, s, tool_offset_mm, form)?;
                let own = self.axis_contribution_um(a, r, d, tool_offset_mm, form)?;
                let positions = self.axes[a].table(d).positions_mm().to_vec();
                let mut errors = Vec::with_capacity(positions.len());
                for &x in &positions {
                    let mut q = r;
                    q[a] = x;
                    let e = self.deviation_form_um(q, s, tool_offset_mm, form)?;
                    errors.push(e - at_r + own);
                }
                Ok(Table {
                    positions_mm: positions,
                    errors_um: errors,
                })
            };
            axes.push(AxisTables {
                forward: table(Direction::Forward)?,
                reverse: table(Direction::Reverse)?,
            });
        }
        let mut it = axes.into_iter();
        match (it.next(), it.next(), it.next()) {
            (Some(x), Some(y), Some(z)) => Ok(AxisTableMap {
                axes: [x, y, z],
                clamp: self.clamp,
            }),
            _ => unreachable!("three axes were pushed"),
        }
    }

    /// The positioning errors `E_aa` of axis `a` as tabulated (µm), forward
    /// and reverse at the union of both tables' positions (each table held
    /// at its end value outside its range, as a controller's table would).
    pub fn positioning(&self, a: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let positions = self.positions_mm(a);
        let along = |t: &ComponentTable| -> Vec<f64> {
            let [lo, hi] = t.range();
            positions
                .iter()
                .map(|&x| {
                    t.linear_um
                        .eval(x.clamp(lo, hi))
                        .map(|v| v[a])
                        .unwrap_or(0.0)
                })
                .collect()
        };
        let f = along(&self.axes[a].forward);
        let r = along(&self.axes[a].reverse);
        (positions, f, r)
    }

    /// A model with the linear tables of an axis-table map (docs/design.md, "The axis-table map") and
    /// no angular errors: the same deviations everywhere (exactly, see
    /// [`Kinematics::htm_um`]), ready to receive measured angles.
    pub fn from_axis_tables(map: &AxisTableMap, topology: Topology) -> Self {
        let axes = [0, 1, 2].map(|a| {
            let t = |table: &Table| ComponentTable {
                linear_um: table.clone(),
                angular_urad: Table {
                    positions_mm: table.positions_mm.clone(),
                    errors_um: vec![Vec3::ZERO; table.positions_mm.len()],
                },
            };
            AxisComponents {
                forward: t(&map.axes[a].forward),
                reverse: t(&map.axes[a].reverse),
            }
        });
        let mut m = KinematicModel::new(axes, Kinematics::new(topology));
        m.clamp = map.clamp;
        m
    }

    /// The union of the table positions of axis `a` (both directions).
    pub fn positions_mm(&self, a: usize) -> Vec<f64> {
        let mut p: Vec<f64> = self.axes[a]
            .forward
            .positions_mm()
            .iter()
            .chain(self.axes[a].reverse.positions_mm())
            .copied()
            .collect();
        p.sort_by(f64::total_cmp);
        p.dedup();
        p
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{WithTool, ALL_FORWARD};

    const F: Direction = Direction::Forward;
    const R: Direction = Direction::Reverse;

    /// A model whose only non-zero component is `set` on axis `a`, tables
    /// over −500 … 500 mm with two points (constant values).
    fn single(
        topology: &str,
        a: usize,
        linear_um: Vec3,
        angular_urad: Vec3,
        squareness: Squareness,
    ) -> KinematicModel {
        let axes = [0, 1, 2].map(|k| {
            let (l, g) = if k == a {
                (linear_um, angular_urad)
            } else {
                (Vec3::ZERO, Vec3::ZERO)
            };
            AxisComponents::both(
                ComponentTable::new(vec![-500.0, 500.0], vec![l, l], vec![g, g]).unwrap(),
            )
        });
        let mut k = Kinematics::new(topology.parse().unwrap());
        k.squareness = squareness;
        KinematicModel::new(axes, k)
    }

    fn eval(m: &KinematicModel, q: Vec3, tool: Vec3, form: Form) -> Vec3 {
        m.deviation_form_um(q, ALL_FORWARD, tool, form).unwrap()
    }

    fn close(a: Vec3, b: Vec3, tol: f64) -> bool {
        (a - b).max_abs() <= tol
    }

    #[test]
    fn pure_yaw_of_x_at_two_tool_lengths() {
        // ECX = 10 µrad (yaw of X: rotation about Z), chain w X' Y' b Z t,
        // measured at the origin with the reflector at the gauge point.
        // Arm of X = (y − 0)·ŷ + (z − 0)·ẑ + (0 − L)·ẑ.
        // ε × arm = (0, 0, ε) × (0, y, z − L) = (−ε·y, 0, 0): the tool length
        // lies along the rotation axis and does not matter.
        // At y = 200 mm: e_x = −10e-6 · 200 mm = −2.0e-3 mm = −2.0 µm,
        // for L = 0 and for L = 150 mm alike.
        let m = single(
            "w X' Y' b Z t",
            0,
            Vec3::ZERO,
            Vec3::new(0.0, 0.0, 10.0),
            Squareness::default(),
        );
        let q = Vec3::new(300.0, 200.0, 50.0);
        for l in [0.0, 150.0] {
            let tool = Vec3::new(0.0, 0.0, l);
            let fo = eval(&m, q, tool, Form::FirstOrder);
            assert!(
                close(fo, Vec3::new(-2.0, 0.0, 0.0), 1e-12),
                "L = {l}: {fo:?}"
            );
            // HTM: the exact rotation of the arm (0, 200, 50 − L) about Z by
            // 1e-5 rad moves it by (−200·sin ε, 200·(cos ε − 1), 0):
            // e_y = −200 mm · 5e-11 = −1e-8 mm = −1e-5 µm.
            let htm = eval(&m, q, tool, Form::Htm);
            assert!((htm.x - (-200.0 * (1e-5f64).sin() * 1e3)).abs() < 1e-9);
            assert!((htm.y - (-1e-5)).abs() < 1e-9, "{htm:?}");
        }
        // A tool offset with an X–Y part does see the yaw: an angle head whose
        // tip sits 40 mm towards −Y of the gauge point (G43.1 Y40 Z150) has
        // arm_y = 200 − 40 = 160 mm → e_x = −10e-6 · 160 mm = −1.6 µm.
        let angle_head = Vec3::new(0.0, 40.0, 150.0);
        let fo = eval(&m, q, angle_head, Form::FirstOrder);
        assert!(close(fo, Vec3::new(-1.6, 0.0, 0.0), 1e-12), "{fo:?}");
    }

    #[test]
    fn pure_pitch_of_x_sees_the_tool_length() {
        // EBX = 20 µrad (pitch of X: rotation about Y). Arm (0, y, z − L).
        // (0, ε, 0) × (0, y, z − L) = (ε·(z − L), 0, 0).
        // z = 50, L = 0:   e_x = 20e-6 · 50 mm   = +1.0 µm
        // z = 50, L = 150: e_x = 20e-6 · (−100) = −2.0 µm
        let m = single(
            "w X' Y' b Z t",
            0,
            Vec3::ZERO,
            Vec3::new(0.0, 20.0, 0.0),
            Squareness::default(),
        );
        let q = Vec3::new(300.0, 200.0, 50.0);
        let short = eval(&m, q, Vec3::ZERO, Form::FirstOrder);
        let long = eval(&m, q, Vec3::new(0.0, 0.0, 150.0), Form::FirstOrder);
        assert!(close(short, Vec3::new(1.0, 0.0, 0.0), 1e-12), "{short:?}");
        assert!(close(long, Vec3::new(-2.0, 0.0, 0.0), 1e-12), "{long:?}");
    }

    #[test]
    fn pure_pitch_of_z_with_a_tool_offset() {
        // EAZ = 20 µrad (rotation of Z about X), measured with the reflector
        // at the gauge point. Arm of Z = (0, 0, 0 − L) = (0, 0, −150) for a
        // 150 mm tool. (ε, 0, 0) × (0, 0, −L) = (0, ε·L, 0):
        // e_y = 20e-6 · 150 mm = 3.0e-3 mm = +3.0 µm.
        // Exactly: Rx(ε)·(0, 0, −L) = (0, L·sin ε, −L·cos ε), so
        // e_y = 150·sin(2e-5)·1e3 µm and e_z = 150·(1 − cos 2e-5)·1e3 = 3e-5 µm.
        let m = single(
            "w X' Y' b Z t",
            2,
            Vec3::ZERO,
            Vec3::new(20.0, 0.0, 0.0),
            Squareness::default(),
        );
        let q = Vec3::new(100.0, 100.0, 100.0);
        let tool = Vec3::new(0.0, 0.0, 150.0);
        let fo = eval(&m, q, tool, Form::FirstOrder);
        assert!(close(fo, Vec3::new(0.0, 3.0, 0.0), 1e-12), "{fo:?}");
        let htm = eval(&m, q, tool, Form::Htm);
        let eps: f64 = 2e-5;
        assert!((htm.y - 150.0 * eps.sin() * 1e3).abs() < 1e-9, "{htm:?}");
        assert!(
            (htm.z - 150.0 * (1.0 - eps.cos()) * 1e3).abs() < 1e-9,
            "{htm:?}"
        );
        assert!((htm.z - 3e-5).abs() < 1e-8);
        // No tool: the measuring point itself, no Abbe error at all.
        assert!(close(eval(&m, q, Vec3::ZERO, Form::Htm), Vec3::ZERO, 0.0));
        // With the reflector 100 mm long during the measurement, the 150 mm
        // tool is 50 mm further: e_y = 20e-6 · 50 = 1.0 µm.
        let mut m2 = m.clone();
        m2.kinematics.measuring[2].tool_offset_mm = Vec3::new(0.0, 0.0, 100.0);
        let fo = eval(&m2, q, tool, Form::FirstOrder);
        assert!(close(fo, Vec3::new(0.0, 1.0, 0.0), 1e-12), "{fo:?}");
    }

    #[test]
    fn squareness_alone() {
        // S_xy = 10, S_yz = −20, S_zx = 30 µrad; at (100, 200, 300) mm:
        // e_x = S_xy·y + S_zx·z = 10e-6·200 + 30e-6·300 = 2e-3 + 9e-3 mm = 11 µm
        // e_y = S_yz·z = −20e-6·300 = −6e-3 mm = −6 µm,  e_z = 0.
        let sq = Squareness {
            xy_urad: 10.0,
            yz_urad: -20.0,
            zx_urad: 30.0,
        };
        let m = single("w X' Y' b Z t", 0, Vec3::ZERO, Vec3::ZERO, sq);
        let q = Vec3::new(100.0, 200.0, 300.0);
        for form in [Form::Htm, Form::FirstOrder] {
            for tool in [Vec3::ZERO, Vec3::new(0.0, 0.0, 250.0)] {
                let e = eval(&m, q, tool, form);
                assert!(
                    close(e, Vec3::new(11.0, -6.0, 0.0), 1e-12),
                    "{form:?}: {e:?}"
                );
            }
        }
        // Pitch-only compensation sees none of it.
        let e = m
            .deviation_um(q, ALL_FORWARD, Components::PositioningOnly)
            .unwrap();
        assert_eq!(e, Vec3::ZERO);
    }

    #[test]
    fn a_topology_change_moves_the_abbe_arm() {
        // EAY = 10 µrad (roll of Y: rotation about X), z = 200, no tool,
        // measured at the origin.
        // w X' Y' b Z t: after Y in the chain come Z and the tool: arm (0, 0, z)
        //   (ε, 0, 0) × (0, 0, 200) = (0, −ε·200, 0) → e_y = −10e-6·200 mm = −2.0 µm.
        // w Y' b Z X t: after Y come Z and X: arm (x, 0, z) = (100, 0, 200)
        //   (ε, 0, 0) × (100, 0, 200) = (0, −200ε, 0) → still −2.0 µm in y
        //   (x lies along the rotation axis).
        // w Z' Y' b X t: after Y comes only X: arm (x, 0, 0)
        //   (ε, 0, 0) × (100, 0, 0) = 0 → no error: Z now lies on the
        //   workpiece side of Y, so Y's roll tilts the table and Z together.
        let q = Vec3::new(100.0, 50.0, 200.0);
        let eps = Vec3::new(10.0, 0.0, 0.0);
        for chain in ["w X' Y' b Z t", "w Y' b Z X t"] {
            let e1 = eval(
                &single(chain, 1, Vec3::ZERO, eps, Squareness::default()),
                q,
                Vec3::ZERO,
                Form::FirstOrder,
            );
            assert!(
                close(e1, Vec3::new(0.0, -2.0, 0.0), 1e-12),
                "{chain}: {e1:?}"
            );
        }
        let e2 = eval(
            &single("w Z' Y' b X t", 1, Vec3::ZERO, eps, Squareness::default()),
            q,
            Vec3::ZERO,
            Form::FirstOrder,
        );
        assert!(close(e2, Vec3::ZERO, 1e-12), "{e2:?}");
        // EBY = 10 µrad (rotation about Y) in the same two machines:
        // w X' Y' b Z t: (0, ε, 0) × (0, 0, 200) = (200ε, 0, 0) → e_x = +2.0 µm
        // w Y' b X Z t: after Y come X and Z: (0, ε, 0) × (100, 0, 200)
        //   = (ε·200, 0, −ε·100) → e = (+2.0, 0, −1.0) µm: the arm gained x.
        let eps = Vec3::new(0.0, 10.0, 0.0);
        let e3 = eval(
            &single("w X' Y' b Z t", 1, Vec3::ZERO, eps, Squareness::default()),
            q,
            Vec3::ZERO,
            Form::FirstOrder,
        );
        assert!(close(e3, Vec3::new(2.0, 0.0, 0.0), 1e-12), "{e3:?}");
        let e4 = eval(
            &single("w Y' b X Z t", 1, Vec3::ZERO, eps, Squareness::default()),
            q,
            Vec3::ZERO,
            Form::FirstOrder,
        );
        assert!(close(e4, Vec3::new(2.0, 0.0, -1.0), 1e-12), "{e4:?}");
    }

    #[test]
    fn moving_part_angles_flip_only_on_the_workpiece_side() {
        // EBX = 20 µrad recorded on the moving table (X' carries the
        // workpiece): the relative rotation is −20 µrad. At z = 50, L = 0:
        // relative convention e_x = +1.0 µm (see the pitch test), moving-part −1.0 µm.
        let mut m = single(
            "w X' Y' b Z t",
            0,
            Vec3::ZERO,
            Vec3::new(0.0, 20.0, 0.0),
            Squareness::default(),
        );
        let q = Vec3::new(0.0, 0.0, 50.0);
        m.kinematics.angles = AngleConvention::MovingPart;
        // (HTM adds e_z = 50 mm·(cos ε − 1) = −1e-5 µm.)
        for form in [Form::FirstOrder, Form::Htm] {
            let e = eval(&m, q, Vec3::ZERO, form);
            assert!(close(e, Vec3::new(-1.0, 0.0, 0.0), 2e-5), "{e:?}");
        }
        // Z moves the tool: its angles are not flipped.
        let mut z = single(
            "w X' Y' b Z t",
            2,
            Vec3::ZERO,
            Vec3::new(20.0, 0.0, 0.0),
            Squareness::default(),
        );
        z.kinematics.angles = AngleConvention::MovingPart;
        let e = eval(&z, q, Vec3::new(0.0, 0.0, 150.0), Form::FirstOrder);
        assert!(close(e, Vec3::new(0.0, 3.0, 0.0), 1e-12), "{e:?}");
    }

    /// A model with every component non-zero and position dependent; the
    /// linear errors are scaled by `lin`, the angles by `scale`, squareness
    /// by `sq`.
    fn busy_scaled(lin: f64, scale: f64, sq: f64) -> KinematicModel {
        let axes = [0, 1, 2].map(|a| {
            let pos: Vec<f64> = (0..=10).map(|k| -100.0 + 60.0 * k as f64).collect();
            let table = |rev: f64| {
                let lin = pos
                    .iter()
                    .map(|&x| {
                        let u = x / 500.0;
                        Vec3::new(
                            3.0 * u + rev,
                            -2.0 * u * u + 0.3 * a as f64,
                            1.5 * (3.0 * u).sin(),
                        ) * lin
                    })
                    .collect();
                let ang = pos
                    .iter()
                    .map(|&x| {
                        let u = x / 500.0;
                        Vec3::new(
                            scale * (8.0 * u + 2.0),
                            scale * (-6.0 * u * u + 5.0),
                            scale * (4.0 * (2.0 * u).cos() - 1.0 + a as f64),
                        )
                    })
                    .collect();
                ComponentTable::new(pos.clone(), lin, ang).unwrap()
            };
            AxisComponents {
                forward: table(0.0),
                reverse: table(2.5),
            }
        });
        let mut k = Kinematics::new(Topology::SEED);
        k.squareness = Squareness {
            xy_urad: 12.0 * sq,
            yz_urad: -7.0 * sq,
            zx_urad: 5.0 * sq,
        };
        k.measuring = [
            MeasuringLine {
                point_mm: Vec3::new(0.0, 150.0, 200.0),
                tool_offset_mm: Vec3::new(0.0, 0.0, 100.0),
            },
            MeasuringLine {
                point_mm: Vec3::new(250.0, 0.0, 180.0),
                tool_offset_mm: Vec3::new(0.0, 0.0, 100.0),
            },
            MeasuringLine {
                point_mm: Vec3::new(250.0, 150.0, 0.0),
                tool_offset_mm: Vec3::new(0.0, 0.0, 50.0),
            },
        ];
        KinematicModel::new(axes, k)
    }

    fn busy(scale: f64) -> KinematicModel {
        busy_scaled(1.0, scale, 1.0)
    }

    #[test]
    fn zero_angles_reduce_exactly_to_the_axis_tables() {
        let m = busy(0.0);
        let map = AxisTableMap {
            axes: [0, 1, 2].map(|a| AxisTables {
                forward: m.axes[a].forward.linear_um.clone(),
                reverse: m.axes[a].reverse.linear_um.clone(),
            }),
            clamp: false,
        };
        let mut square = m.clone();
        square.kinematics.squareness = Squareness::default();
        for (i, q) in [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(123.4, -56.7, 300.0),
            Vec3::new(499.0, 400.0, -100.0),
            Vec3::new(-100.0, 250.5, 77.7),
        ]
        .into_iter()
        .enumerate()
        {
            let s = [[F, F, F], [R, F, R], [F, R, F], [R, R, R]][i];
            let tables = map.deviation_um(q, s, Components::All).unwrap();
            for tool in [Vec3::ZERO, Vec3::new(0.0, 0.0, 120.0)] {
                for form in [Form::Htm, Form::FirstOrder] {
                    let e = square.deviation_form_um(q, s, tool, form).unwrap();
                    assert_eq!(e, tables, "{q:?} {form:?}");
                    // With squareness: exactly the tables plus e_⊥.
                    let e = m.deviation_form_um(q, s, tool, form).unwrap();
                    let sq = m.kinematics.squareness.deviation_um(q);
                    assert_eq!(e, tables + sq, "{q:?} {form:?}");
                }
            }
            assert_eq!(
                square
                    .deviation_um(q, s, Components::PositioningOnly)
                    .unwrap(),
                map.deviation_um(q, s, Components::PositioningOnly).unwrap()
            );
        }
    }

    #[test]
    fn htm_and_first_order_agree_to_second_order() {
        // Scale every error (linear, angular, squareness) by k: the difference
        // HTM − first order is made of products of two errors, so it grows
        // like k² (a factor 4 per doubling), while the errors grow like k.
        let q = Vec3::new(420.0, -80.0, 260.0);
        let tool = Vec3::new(0.0, 0.0, 180.0);
        let s = [F, R, F];
        let diff = |scale: f64| {
            let m = busy_scaled(scale / 16.0, scale, scale / 16.0);
            let a = m.deviation_form_um(q, s, tool, Form::Htm).unwrap();
            let b = m.deviation_form_um(q, s, tool, Form::FirstOrder).unwrap();
            (a - b).norm()
        };
        let d: Vec<f64> = [4.0, 8.0, 16.0, 32.0].iter().map(|k| diff(*k)).collect();
        for w in d.windows(2) {
            let ratio = w[1] / w[0];
            assert!((ratio - 4.0).abs() < 0.2, "{d:?}");
        }
        // And it is small: at angles of ~100 µrad and arms of ~0.5 m,
        // about ε²·r ≈ 1e-8 · 500 mm = 5 nm.
        assert!(d[1] < 0.05, "{d:?}");
        // The explicit 4×4 product gives the same as the displacement form.
        let m = busy(16.0);
        let v = m.values(q, s).unwrap();
        let a = m.kinematics.htm_um(&v, q, tool);
        let b = m.kinematics.htm_product_um(&v, q, tool);
        assert!((a - b).max_abs() < 1e-6, "{a:?} {b:?}");
    }

    #[test]
    fn the_tool_offset_comes_from_the_caller() {
        let m = single(
            "w X' Y' b Z t",
            2,
            Vec3::ZERO,
            Vec3::new(20.0, 0.0, 0.0),
            Squareness::default(),
        );
        let q = Vec3::new(1.0, 2.0, 3.0);
        let tool = WithTool {
            model: &m,
            tool_length_offset_mm: Vec3::new(0.0, 0.0, 150.0),
        };
        let e = tool.deviation_um(q, ALL_FORWARD, Components::All).unwrap();
        assert!((e.y - 3.0).abs() < 1e-6, "{e:?}");
        assert!(
            m.deviation_um(q, ALL_FORWARD, Components::All)
                .unwrap()
                .y
                .abs()
                < 1e-12
        );
        assert!(tool.uses_tool_offset());
    }

    #[test]
    fn out_of_range_names_the_axis_and_clamp_holds_the_end() {
        let mut m = busy(1.0);
        let e = m
            .deviation_um(Vec3::new(0.0, 600.0, 0.0), ALL_FORWARD, Components::All)
            .unwrap_err();
        assert!(matches!(e, ModelError::OutOfRange { axis: 'Y', .. }), "{e}");
        m.clamp = true;
        let a = m
            .deviation_um(
                Vec3::new(0.0, 600.0, 0.0),
                ALL_FORWARD,
                Components::PositioningOnly,
            )
            .unwrap();
        let b = m
            .deviation_um(
                Vec3::new(0.0, 500.0, 0.0),
                ALL_FORWARD,
                Components::PositioningOnly,
            )
            .unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn axis_tables_from_the_model() {
        let m = busy(10.0);
        // At X's measuring point and tool (0, 150, 200), L = 100, X's Abbe arm
        // is zero, so its positioning column is exactly the model's EXX (in
        // first order; HTM adds products of X's angles and the other axes'
        // linear errors, below a nanometre).
        let mx = m.kinematics.measuring[0];
        let map = m
            .to_axis_tables(mx.point_mm, mx.tool_offset_mm, Form::FirstOrder)
            .unwrap();
        for d in [F, R] {
            let t = m.axes[0].table(d);
            let mt = match d {
                F => &map.axes[0].forward,
                R => &map.axes[0].reverse,
            };
            assert_eq!(mt.positions_mm, t.positions_mm());
            for (k, e) in mt.errors_um.iter().enumerate() {
                assert!((e.x - t.linear_um.errors_um[k].x).abs() < 1e-9);
            }
        }
        // On the lines through a reference point the tables reproduce the
        // model: exactly in first order; with HTM up to the products of two
        // axes' errors, here (angles up to ~100 µrad, arms ~600 mm) at most
        // (1e-4)² · 600 mm ≈ 6e-6 mm = 0.006 µm.
        let r = Vec3::new(200.0, 100.0, 50.0);
        let tool = Vec3::new(0.0, 0.0, 160.0);
        for (form, tol) in [(Form::FirstOrder, 1e-9), (Form::Htm, 1e-2)] {
            let map = m.to_axis_tables(r, tool, form).unwrap();
            for a in 0..3 {
                for x in [-100.0, 17.0, 333.3, 500.0] {
                    let mut q = r;
                    q[a] = x;
                    for s in [[F, F, F], [R, F, R]] {
                        let e = m.deviation_form_um(q, s, tool, form).unwrap();
                        let t = map.deviation_um(q, s, Components::All).unwrap();
                        assert!((e - t).max_abs() < tol, "{form:?} {a} {x}: {e:?} {t:?}");
                    }
                }
            }
        }
        // And back: a model from axis tables has the same deviations.
        let map = m.to_axis_tables(r, tool, Form::Htm).unwrap();
        let back = KinematicModel::from_axis_tables(&map, Topology::SEED);
        let q = Vec3::new(10.0, 20.0, 30.0);
        assert_eq!(
            back.deviation_um(q, [F, R, F], Components::All).unwrap(),
            map.deviation_um(q, [F, R, F], Components::All).unwrap()
        );
    }

    #[test]
    fn axis_contributions_add_up_to_first_order() {
        let m = busy(10.0);
        let q = Vec3::new(100.0, 200.0, 150.0);
        let tool = Vec3::new(0.0, 0.0, 90.0);
        let s = [R, F, R];
        let total = m.deviation_form_um(q, s, tool, Form::FirstOrder).unwrap();
        let mut sum = Vec3::ZERO;
        for (a, d) in s.into_iter().enumerate() {
            sum += m
                .axis_contribution_um(a, q, d, tool, Form::FirstOrder)
                .unwrap();
        }
        assert!((total - sum).max_abs() < 1e-12);
    }
}
