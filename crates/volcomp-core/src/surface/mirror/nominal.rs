//! The nominal (ideal finishing) surface `S_F`: its material side, its
//! regularity check, the smallest concave radius, and closest-point queries.

use super::io::PointGrid;
use super::{advice, fmt_point, v3, MirrorError};
use crate::surface::bspline::{self, BSplineSurface, Parameterization, ProjectionIndex};
use volcomp_gcode::Vec3;

/// Which side of the surface the material is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MaterialSide {
    /// Below the surface (−Z): the usual 3-axis case, the tool comes from +Z.
    Below,
    /// Above the surface (+Z).
    Above,
    /// The surface's own normal `Su × Sv` points out of the material.
    NormalOut,
    /// The surface's own normal `Su × Sv` points into the material.
    NormalIn,
}

/// The foot of a point on the nominal surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Foot {
    /// Parameter u.
    pub u: f64,
    /// Parameter v.
    pub v: f64,
    /// The closest surface point (mm).
    pub point: Vec3,
    /// Outward unit normal there.
    pub normal: Vec3,
    /// Signed distance along the outward normal (mm).
    pub height_mm: f64,
    /// Whether the point lies over the surface: its foot is interior, or on
    /// the boundary with the point less than 1 µm beyond the edge (rounding
    /// of written coordinates).
    pub orthogonal: bool,
}

/// The ideal finishing surface `S_F` with its material side, ready for
/// closest-point queries.
#[derive(Debug, Clone)]
pub struct NominalSurface {
    surface: BSplineSurface<3>,
    sign: f64,
    index: ProjectionIndex,
    grid_params: Option<(Vec<f64>, Vec<f64>)>,
    /// Smallest radius of curvature on the concave side (where the surface
    /// bends towards the outward normal), with its parameters.
    concave: Option<(f64, f64, f64)>,
}

/// Parameters with `per_span` samples in every knot span, ends included.
pub(super) fn refine_breaks(breaks: &[f64], per_span: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(breaks.len() * per_span + 1);
    for w in breaks.windows(2) {
        for k in 0..per_span {
            out.push(w[0] + (w[1] - w[0]) * k as f64 / per_span as f64);
        }
    }
    if let Some(l) = breaks.last() {
        out.push(*l);
    }
    out
}
impl NominalSurface {
    /// Prepares `surface`, checking that it is regular (a normal everywhere)
    /// and, for [`MaterialSide::Below`]/[`MaterialSide::Above`], that it
    /// never faces the other way. `file` names it in messages.
    pub fn new(
        surface: BSplineSurface<3>,
        side: MaterialSide,
        file: &str,
    ) -> Result<Self, MirrorError> {
        let us = refine_breaks(&surface.breaks_u(), 4);
        let vs = refine_breaks(&surface.breaks_v(), 4);
        let mut sum_z = 0.0;
        let mut normals = Vec::with_capacity(us.len() * vs.len());
        for u in &us {
            for v in &vs {
                let n = surface.unit_normal(*u, *v).ok_or_else(|| MirrorError::InFile {
                    file: file.into(),
                    message: format!(
                        "the surface has no normal at u = {u:.6}, v = {v:.6}, point {} (a collapsed edge or a fold)",
                        fmt_point(v3(surface.point(*u, *v)))
                    ),
                    help: "export a regular surface (no degenerate edges), or trim it".into(),
                })?;
                sum_z += n[2];
                normals.push((*u, *v, n));
            }
        }
        let sign = match side {
            MaterialSide::NormalOut => 1.0,
            MaterialSide::NormalIn => -1.0,
            MaterialSide::Below | MaterialSide::Above => {
                let want = if side == MaterialSide::Below {
                    1.0
                } else {
                    -1.0
                };
                let sign = if sum_z * want >= 0.0 { 1.0 } else { -1.0 };
                if let Some((u, v, _)) = normals.iter().find(|(_, _, n)| n[2] * sign * want < -0.02)
                {
                    return Err(MirrorError::InFile {
                        file: file.into(),
                        message: format!(
                            "with the material {} it, the surface faces away from the tool at {} (u = {u:.6}, v = {v:.6})",
                            if want > 0.0 { "below" } else { "above" },
                            fmt_point(v3(surface.point(*u, *v)))
                        ),
                        help: advice::OVERHANG.into(),
                    });
                }
                sign
            }
        };
        let mut concave: Option<(f64, f64, f64)> = None;
        for (u, v, _) in &normals {
            if let Some(k) = surface.curvatures(*u, *v) {
                // Curvature towards the outward normal.
                let toward = if sign > 0.0 { k.max } else { -k.min };
                if toward > 0.0 {
                    let r = 1.0 / toward;
                    if concave.is_none_or(|c| r < c.0) {
                        concave = Some((r, *u, *v));
                    }
                }
            }
        }
        let index = ProjectionIndex::new(&surface, 6);
        Ok(Self {
            surface,
            sign,
            index,
            grid_params: None,
            concave,
        })
    }

    /// Interpolates a grid of points (A9.4, degree ≤ 3 each way) into the
    /// nominal surface.
    pub fn from_grid(
        grid: &PointGrid,
        params: &Parameterization,
        side: MaterialSide,
        file: &str,
    ) -> Result<Self, MirrorError> {
        let p = (grid.count_u - 1).min(3);
        let q = (grid.count_v - 1).min(3);
        let surface = bspline::interpolate(&grid.points, grid.count_u, grid.count_v, p, q, params)
            .map_err(|e| MirrorError::InFile {
                file: file.into(),
                message: format!("cannot interpolate the grid: {e}"),
                help: "check for repeated or collapsed rows of points".into(),
            })?;
        let gp = bspline::mesh_params(&grid.points, grid.count_u, grid.count_v, params).map_err(
            |e| MirrorError::InFile {
                file: file.into(),
                message: e.to_string(),
                help: "check the grid".into(),
            },
        )?;
        let mut s = Self::new(surface, side, file)?;
        s.grid_params = Some(gp);
        Ok(s)
    }

    /// The B-spline surface.
    pub fn surface(&self) -> &BSplineSurface<3> {
        &self.surface
    }

    /// The parameters of the grid nodes, when the surface came from a grid.
    pub fn grid_params(&self) -> Option<&(Vec<f64>, Vec<f64>)> {
        self.grid_params.as_ref()
    }

    /// Smallest concave radius of curvature (mm) and where, `None` when the
    /// surface never bends towards the outward normal.
    pub fn min_concave_radius(&self) -> Option<(f64, Vec3)> {
        self.concave
            .map(|(r, u, v)| (r, v3(self.surface.point(u, v))))
    }

    /// `S_F(u, v)`.
    pub fn point(&self, u: f64, v: f64) -> Vec3 {
        v3(self.surface.point(u, v))
    }

    /// Outward unit normal (away from the material).
    pub fn normal(&self, u: f64, v: f64) -> Vec3 {
        let n = self.surface.unit_normal(u, v).unwrap_or([0.0, 0.0, 1.0]);
        v3(n) * self.sign
    }

    /// The closest point of the surface to `p` within `radius` (mm).
    pub fn project(&self, p: Vec3, radius: f64, hint: Option<(f64, f64)>) -> Option<Foot> {
        let c = self
            .surface
            .closest_point(&self.index, p.to_array(), radius, hint)?;
        let point = v3(c.point);
        let normal = self.normal(c.u, c.v);
        Some(Foot {
            u: c.u,
            v: c.v,
            point,
            normal,
            height_mm: (p - point).dot(normal),
            orthogonal: c.orthogonal || c.tangential <= 1e-3,
        })
    }
}
