//! Evaluation of the chain: component values → tool-tip deviation, in the
//! first-order (small-angle) form and with homogeneous transformation
//! matrices (derivation in docs/kinematic.md).

use super::{AngleConvention, ComponentValues, Kinematics, MeasuringLine, Squareness};
use crate::model::topology::Topology;
use nalgebra::{Matrix3, Rotation3, Vector3};
use volcomp_gcode::Vec3;

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
