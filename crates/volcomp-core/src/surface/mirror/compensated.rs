//! The compensated surface `S_C = S_F + δ·n`: grid nodes and a B-spline
//! approximation of it.

use super::method::DeviationField;
use super::nominal::{refine_breaks, NominalSurface};
use super::{method_error, v3, MirrorError};
use crate::surface::bspline::{self, BSplineSurface, Parameterization};
use volcomp_gcode::Vec3;

/// `S_C = S_F + δ·n`: the nominal surface moved by a deviation field.
#[derive(Debug, Clone, Copy)]
pub struct CompensatedSurface<'a> {
    /// `S_F`.
    pub nominal: &'a NominalSurface,
    /// `δ` (µm).
    pub field: &'a DeviationField,
}

/// One node of a surface grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridNode {
    /// Index along u.
    pub i: usize,
    /// Index along v.
    pub j: usize,
    /// Point (mm).
    pub point_mm: Vec3,
    /// Height over `S_F` along the outward normal (µm).
    pub offset_um: f64,
}

impl CompensatedSurface<'_> {
    /// `S_C(u, v)` (mm).
    pub fn point(&self, u: f64, v: f64) -> Vec3 {
        self.nominal.point(u, v) + self.nominal.normal(u, v) * (self.field.offset_um(u, v) * 1e-3)
    }

    /// Grid nodes: at the nominal grid's nodes when it came from a grid,
    /// otherwise `n × n` nodes equally spaced in the parameters.
    pub fn grid(&self, n: usize) -> Vec<GridNode> {
        let n = n.max(2);
        let even = |[a, b]: [f64; 2]| -> Vec<f64> {
            (0..n)
                .map(|k| a + (b - a) * k as f64 / (n - 1) as f64)
                .collect()
        };
        let (us, vs) = match self.nominal.grid_params() {
            Some((u, v)) => (u.clone(), v.clone()),
            None => (
                even(self.nominal.surface().domain_u()),
                even(self.nominal.surface().domain_v()),
            ),
        };
        let mut out = Vec::with_capacity(us.len() * vs.len());
        for (i, u) in us.iter().enumerate() {
            for (j, v) in vs.iter().enumerate() {
                out.push(GridNode {
                    i,
                    j,
                    point_mm: self.point(*u, *v),
                    offset_um: self.field.offset_um(*u, *v),
                });
            }
        }
        out
    }

    /// A B-spline surface approximating `S_C` within `tolerance_mm` in
    /// parameter space (so within it in space too): A9.4 through `S_C`
    /// sampled at `k` points per knot span of `S_F`, `k` doubled until the
    /// error at every cell centre is within the tolerance (or `k = 32`, or 250 000 samples).
    /// Returns the surface and the largest error found (mm).
    pub fn to_bspline(&self, tolerance_mm: f64) -> Result<(BSplineSurface<3>, f64), MirrorError> {
        let s = self.nominal.surface();
        let mut result = None;
        for k in [1usize, 2, 4, 8, 16, 32] {
            let mut us = refine_breaks(&s.breaks_u(), k);
            let mut vs = refine_breaks(&s.breaks_v(), k);
            if us.len() < 4 {
                us = refine_breaks(&s.breaks_u(), 3);
            }
            if vs.len() < 4 {
                vs = refine_breaks(&s.breaks_v(), 3);
            }
            if result.is_some() && us.len() * vs.len() > 250_000 {
                // Finer sampling would not fit in memory sensibly: keep the
                // last surface (its error is reported).
                break;
            }
            let mut pts = Vec::with_capacity(us.len() * vs.len());
            for u in &us {
                for v in &vs {
                    pts.push(self.point(*u, *v).to_array());
                }
            }
            let surf = bspline::interpolate(
                &pts,
                us.len(),
                vs.len(),
                3,
                3,
                &Parameterization::Given(us.clone(), vs.clone()),
            )
            .map_err(|e| {
                method_error(
                    format!("cannot build the compensated B-spline: {e}"),
                    "please report this with the input files",
                )
            })?;
            let mid =
                |t: &[f64]| -> Vec<f64> { t.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect() };
            let mut worst: f64 = 0.0;
            for u in mid(&us).iter().chain(&us) {
                for v in mid(&vs).iter().chain(&vs) {
                    let e = (v3(surf.point(*u, *v)) - self.point(*u, *v)).norm();
                    worst = worst.max(e);
                }
            }
            let done = worst <= tolerance_mm;
            result = Some((surf, worst));
            if done {
                break;
            }
        }
        result.ok_or_else(|| method_error("no compensated surface", "please report this"))
    }
}
