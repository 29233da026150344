//! The 21-component model with Legendre-polynomial component errors.
//!
//! Component `c` of axis `a` (the 18 position-dependent ones) is
//! `E(q_a) = Σ_k c_k·P_k(ξ_a)`, `ξ_a` the axis position mapped from the axis
//! range onto `[−1, 1]`; squareness is constant. The coefficients are µm for
//! linear components and µrad for angular ones and squareness; `P_k` is at
//! most 1 in magnitude, so a coefficient is the amplitude of its shape.
//!
//! Evaluation reuses [`Kinematics::first_order_um`] / [`Kinematics::htm_um`]
//! with a [`ComponentValues`] built from the polynomials: there is no second
//! kinematic chain here.
//!
//! Gauge (what is left out of the parameter vector, because distances between
//! artifact spheres cannot see it — see `docs/thermal.md`):
//! * `k = 0` of every linear component: constant offsets translate the whole
//!   volume;
//! * `k = 1` of the straightness components (`EYX`, `EZX`, `EXY`, …): their
//!   linear trend is squareness (ISO 230-1 reference straight line), which
//!   is a parameter of its own;
//! * `k = 0` of every angular component: a constant angle acts through Abbe
//!   arms that are affine in the axis positions, i.e. like squareness plus a
//!   rigid motion of the volume.

use super::legendre::{legendre, to_xi};
use crate::model::kinematic::{
    angular_name, linear_name, AxisComponents, ComponentTable, ComponentValues, KinematicModel,
    Kinematics, Squareness,
};
use volcomp_gcode::Vec3;

/// What one parameter is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Param {
    /// Coefficient of `P_k` of component `component` of `axis`:
    /// `component` 0–2 are the linear errors along X, Y, Z (µm), 3–5 the
    /// rotations about X, Y, Z (µrad).
    Legendre {
        /// Axis 0 = X, 1 = Y, 2 = Z.
        axis: usize,
        /// Component 0–5.
        component: usize,
        /// Polynomial order.
        k: usize,
    },
    /// Squareness 0 = `S_xy`, 1 = `S_yz`, 2 = `S_zx` (µrad).
    Squareness(usize),
}

impl Param {
    /// Name, e.g. `EXX.P1`, `EBY.P2`, `S_xy`.
    pub fn name(&self) -> String {
        match *self {
            Param::Legendre { axis, component, k } => {
                let c = if component < 3 {
                    linear_name(component, axis)
                } else {
                    angular_name(component - 3, axis)
                };
                format!("{c}.P{k}")
            }
            Param::Squareness(i) => ["S_xy", "S_yz", "S_zx"][i].to_string(),
        }
    }

    /// Unit of the parameter.
    pub fn unit(&self) -> &'static str {
        match *self {
            Param::Legendre { component, .. } if component < 3 => "um",
            _ => "urad",
        }
    }
}

/// The polynomial model's geometry: kinematics (chain, measuring lines,
/// angle convention; its squareness is ignored, squareness is a parameter),
/// the axis ranges the polynomials live on, and the maximum order.
#[derive(Debug, Clone, PartialEq)]
pub struct PolyModel {
    /// Chain and measuring lines.
    pub kinematics: Kinematics,
    /// `[lo, hi]` per axis (mm).
    pub ranges_mm: [[f64; 2]; 3],
    /// Maximum Legendre order `n` (≥ 1).
    pub order: usize,
    /// The parameters, in vector order.
    pub params: Vec<Param>,
}

impl PolyModel {
    /// The model with the gauge described in the module documentation.
    pub fn new(kinematics: Kinematics, ranges_mm: [[f64; 2]; 3], order: usize) -> Self {
        let mut params = Vec::new();
        for axis in 0..3 {
            for component in 0..6 {
                let k_min = match component {
                    c if c == axis => 1,
                    c if c < 3 => 2,
                    _ => 1,
                };
                for k in k_min..=order {
                    params.push(Param::Legendre { axis, component, k });
                }
            }
        }
        params.extend((0..3).map(Param::Squareness));
        let mut k = kinematics;
        k.squareness = Squareness::default();
        Self {
            kinematics: k,
            ranges_mm,
            order,
            params,
        }
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.params.len()
    }

    /// Whether there are no parameters.
    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    /// Index of the parameter named `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.params.iter().position(|p| p.name() == name)
    }

    /// Component values and squareness for parameters `theta` at `q`.
    pub fn values(&self, theta: &[f64], q_mm: Vec3) -> (ComponentValues, Squareness) {
        let mut v = ComponentValues::default();
        let mut s = Squareness::default();
        let p: [Vec<f64>; 3] =
            [0, 1, 2].map(|a| legendre(self.order, to_xi(q_mm[a], self.ranges_mm[a])));
        for (param, &c) in self.params.iter().zip(theta) {
            match *param {
                Param::Legendre { axis, component, k } => {
                    let val = c * p[axis][k];
                    if component < 3 {
                        v.linear_um[axis][component] += val;
                    } else {
                        v.angular_urad[axis][component - 3] += val;
                    }
                }
                Param::Squareness(0) => s.xy_urad = c,
                Param::Squareness(1) => s.yz_urad = c,
                Param::Squareness(_) => s.zx_urad = c,
            }
        }
        (v, s)
    }

    /// Deviation `e = actual − commanded` (µm) at `q` for tool offset `tool`,
    /// first-order (`htm = false`) or HTM form.
    pub fn deviation_um(&self, theta: &[f64], q_mm: Vec3, tool_mm: Vec3, htm: bool) -> Vec3 {
        let (v, s) = self.values(theta, q_mm);
        let mut k = self.kinematics;
        k.squareness = s;
        if htm {
            k.htm_um(&v, q_mm, tool_mm)
        } else {
            k.first_order_um(&v, q_mm, tool_mm)
        }
    }

    /// The first-order deviation of every unit parameter at `q` (µm): the
    /// columns of the model's linear map `θ ↦ e(q)`.
    pub fn basis_um(&self, q_mm: Vec3, tool_mm: Vec3) -> Vec<Vec3> {
        let mut unit = vec![0.0; self.len()];
        (0..self.len())
            .map(|i| {
                unit[i] = 1.0;
                let e = self.deviation_um(&unit, q_mm, tool_mm, false);
                unit[i] = 0.0;
                e
            })
            .collect()
    }

    /// The 21-component table model for `theta`: every component sampled at
    /// `samples` (≥ 2) equally spaced positions over its axis range (same
    /// table for both directions), squareness from `theta`. Unknown
    /// parameters (`None`) count as zero.
    pub fn to_kinematic_model(&self, theta: &[Option<f64>], samples: usize) -> KinematicModel {
        let theta: Vec<f64> = theta.iter().map(|t| t.unwrap_or(0.0)).collect();
        let samples = samples.max(2);
        let axes = [0, 1, 2].map(|a| {
            let [lo, hi] = self.ranges_mm[a];
            let positions: Vec<f64> = (0..samples)
                .map(|i| lo + (hi - lo) * i as f64 / (samples - 1) as f64)
                .collect();
            let mut lin = Vec::with_capacity(samples);
            let mut ang = Vec::with_capacity(samples);
            for &x in &positions {
                let mut q = Vec3::ZERO;
                q[a] = x;
                for b in 0..3 {
                    if b != a {
                        q[b] = self.ranges_mm[b][0];
                    }
                }
                let (v, _) = self.values(&theta, q);
                lin.push(v.linear_um[a]);
                ang.push(v.angular_urad[a]);
            }
            let table = ComponentTable::new(positions, lin, ang)
                .unwrap_or_else(|| unreachable!("positions increase over a valid range"));
            AxisComponents::both(table)
        });
        let (_, s) = self.values(&theta, Vec3::ZERO);
        let mut k = self.kinematics;
        k.squareness = s;
        KinematicModel::new(axes, k)
    }
}
