//! Point inversion: the closest point of a surface to a given point by
//! Newton iteration (§6.1), started from a bucketed sample index.

use super::eval::{cross3, dot3, norm3, sub3};
use super::BSplineSurface;

/// The closest point of a surface to a given point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosestPoint {
    /// Parameter u.
    pub u: f64,
    /// Parameter v.
    pub v: f64,
    /// `S(u, v)`.
    pub point: [f64; 3],
    /// Distance from the given point.
    pub distance: f64,
    /// Whether `P − S` is orthogonal to the surface (an interior foot point);
    /// false when the closest point lies on the boundary and the given point
    /// is beyond the surface's edge.
    pub orthogonal: bool,
    /// Length of the component of `P − S` tangent to the surface (0 for an
    /// interior foot point; how far beyond the edge the point lies otherwise).
    pub tangential: f64,
    /// Newton iterations.
    pub iterations: u32,
}

impl BSplineSurface<3> {
    /// The closest point to `target` by Newton iteration on the orthogonality
    /// conditions `(S − P)·Su = 0`, `(S − P)·Sv = 0` (point inversion, §6.1),
    /// started at `(u0, v0)`. Steps are damped so the distance never grows
    /// (a Newton step towards a saddle or maximum of the distance is replaced
    /// by a gradient step), and parameters are kept inside the domain
    /// (at an edge the iteration continues along it).
    pub fn closest_point_from(&self, target: [f64; 3], u0: f64, v0: f64) -> ClosestPoint {
        let [ua, ub] = self.domain_u();
        let [va, vb] = self.domain_v();
        let (mut u, mut v) = self.clamp(u0, v0);
        let mut iterations = 0;
        let mut d = self.derivatives(u, v, 2);
        let mut r = sub3(d[0][0], target);
        let mut dist2 = dot3(r, r);
        for _ in 0..50 {
            iterations += 1;
            let (su, sv) = (d[1][0], d[0][1]);
            let f = dot3(r, su);
            let g = dot3(r, sv);
            // Hessian of ½|S − P|² (§6.1, eq. 6.6's Jacobian).
            let a11 = dot3(su, su) + dot3(r, d[2][0]);
            let a12 = dot3(su, sv) + dot3(r, d[1][1]);
            let a22 = dot3(sv, sv) + dot3(r, d[0][2]);
            let det = a11 * a22 - a12 * a12;
            let (mut du, mut dv) = if a11 > 0.0 && det > 1e-30 * a11 * a22.abs().max(1e-300) {
                ((-(a22 * f) + a12 * g) / det, (a12 * f - a11 * g) / det)
            } else {
                // Not a minimum locally: steepest descent, scaled by the metric.
                (-f / dot3(su, su).max(1e-300), -g / dot3(sv, sv).max(1e-300))
            };
            // At an edge with the step pointing outwards, move along the edge.
            let at_u_edge = (u <= ua && du < 0.0) || (u >= ub && du > 0.0);
            let at_v_edge = (v <= va && dv < 0.0) || (v >= vb && dv > 0.0);
            if at_u_edge && !at_v_edge {
                du = 0.0;
                dv = if a22 > 0.0 {
                    -g / a22
                } else {
                    -g / dot3(sv, sv).max(1e-300)
                };
            } else if at_v_edge && !at_u_edge {
                dv = 0.0;
                du = if a11 > 0.0 {
                    -f / a11
                } else {
                    -f / dot3(su, su).max(1e-300)
                };
            } else if at_u_edge && at_v_edge {
                break;
            }
            // Damped step: halve until the distance does not grow.
            let mut accepted = false;
            let mut step = 1.0;
            for _ in 0..30 {
                let (nu, nv) = self.clamp(u + step * du, v + step * dv);
                let nd = self.derivatives(nu, nv, 2);
                let nr = sub3(nd[0][0], target);
                let ndist2 = dot3(nr, nr);
                if ndist2 <= dist2 {
                    let moved = norm3(sub3(nd[0][0], d[0][0]));
                    u = nu;
                    v = nv;
                    d = nd;
                    r = nr;
                    dist2 = ndist2;
                    accepted = moved > 1e-12;
                    break;
                }
                step *= 0.5;
            }
            if !accepted {
                break;
            }
        }
        let (su, sv) = (d[1][0], d[0][1]);
        let dist = dist2.sqrt();
        let cos = |t: [f64; 3]| {
            let l = norm3(t) * dist;
            if l > 0.0 {
                dot3(r, t).abs() / l
            } else {
                0.0
            }
        };
        let orthogonal = dist < 1e-9 || (cos(su) < 1e-6 && cos(sv) < 1e-6);
        let n = cross3(su, sv);
        let ln = norm3(n);
        let tangential = if ln > 0.0 {
            let along = dot3(r, n) / ln;
            (dist2 - along * along).max(0.0).sqrt()
        } else {
            dist
        };
        ClosestPoint {
            u,
            v,
            point: d[0][0],
            distance: dist,
            orthogonal,
            tangential,
            iterations,
        }
    }
}

/// Samples of a surface in a uniform 3-D bucket grid, for good starting
/// points of the closest-point iteration (nearest sample within a radius).
#[derive(Debug, Clone)]
pub struct ProjectionIndex {
    samples: Vec<(f64, f64, [f64; 3])>,
    origin: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    /// `cells[c]..cells[c+1]` indexes `order` for cell `c`.
    starts: Vec<usize>,
    order: Vec<usize>,
    /// Largest distance between neighbouring samples.
    spacing: f64,
}

impl ProjectionIndex {
    /// Samples `per_span` points per knot span in each direction (and the
    /// span ends) and buckets them.
    pub fn new(surface: &BSplineSurface<3>, per_span: usize) -> Self {
        let per_span = per_span.max(1);
        let refine = |b: Vec<f64>| -> Vec<f64> {
            let mut out = Vec::with_capacity(b.len() * per_span);
            for w in b.windows(2) {
                for k in 0..per_span {
                    out.push(w[0] + (w[1] - w[0]) * k as f64 / per_span as f64);
                }
            }
            out.push(*b.last().unwrap_or(&0.0));
            out
        };
        let us = refine(surface.breaks_u());
        let vs = refine(surface.breaks_v());
        let mut samples = Vec::with_capacity(us.len() * vs.len());
        for u in &us {
            for v in &vs {
                samples.push((*u, *v, surface.point(*u, *v)));
            }
        }
        let mut spacing: f64 = 0.0;
        let nvs = vs.len();
        for i in 0..us.len() {
            for j in 0..nvs {
                let p = samples[i * nvs + j].2;
                if i + 1 < us.len() {
                    spacing = spacing.max(norm3(sub3(samples[(i + 1) * nvs + j].2, p)));
                }
                if j + 1 < nvs {
                    spacing = spacing.max(norm3(sub3(samples[i * nvs + j + 1].2, p)));
                }
            }
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for (_, _, p) in &samples {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let extent = (0..3).map(|c| hi[c] - lo[c]).fold(0.0, f64::max).max(1e-9);
        // About two samples per occupied cell on a surface, and never more
        // cells than a few per sample (memory stays proportional to the samples).
        let mut cell = (spacing * 1.5).max(extent / 256.0).max(1e-9);
        let max_cells = (4 * samples.len()).clamp(4096, 1 << 22) as f64;
        let cells_for = |c: f64| {
            (0..3)
                .map(|k| ((hi[k] - lo[k]) / c).floor() + 1.0)
                .product::<f64>()
        };
        while cells_for(cell) > max_cells {
            cell *= 1.25;
        }
        let dims: [usize; 3] =
            std::array::from_fn(|c| ((hi[c] - lo[c]) / cell).floor() as usize + 1);
        let cell_of = |p: [f64; 3]| -> usize {
            let k: [usize; 3] = std::array::from_fn(|c| {
                (((p[c] - lo[c]) / cell).floor().max(0.0) as usize).min(dims[c] - 1)
            });
            (k[0] * dims[1] + k[1]) * dims[2] + k[2]
        };
        let ncells = dims[0] * dims[1] * dims[2];
        let mut counts = vec![0usize; ncells + 1];
        let keys: Vec<usize> = samples.iter().map(|s| cell_of(s.2)).collect();
        for k in &keys {
            counts[k + 1] += 1;
        }
        for c in 0..ncells {
            counts[c + 1] += counts[c];
        }
        let starts = counts.clone();
        let mut fill = counts;
        let mut order = vec![0usize; samples.len()];
        for (s, k) in keys.iter().enumerate() {
            order[fill[*k]] = s;
            fill[*k] += 1;
        }
        Self {
            samples,
            origin: lo,
            cell,
            dims,
            starts,
            order,
            spacing,
        }
    }

    /// Largest distance between neighbouring samples (mm): the nearest
    /// sample is at most about this much farther than the surface.
    pub fn spacing(&self) -> f64 {
        self.spacing
    }

    /// The sample nearest to `p` among those within `radius`, as `(u, v, distance)`.
    pub fn nearest(&self, p: [f64; 3], radius: f64) -> Option<(f64, f64, f64)> {
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        for c in 0..3 {
            let a = ((p[c] - radius - self.origin[c]) / self.cell).floor();
            let b = ((p[c] + radius - self.origin[c]) / self.cell).floor();
            if b < 0.0 || a > (self.dims[c] - 1) as f64 || a.is_nan() || b.is_nan() {
                return None;
            }
            lo[c] = a.max(0.0) as usize;
            hi[c] = (b as usize).min(self.dims[c] - 1);
        }
        let mut best: Option<(f64, f64, f64)> = None;
        let r2 = radius * radius;
        for i in lo[0]..=hi[0] {
            for j in lo[1]..=hi[1] {
                for k in lo[2]..=hi[2] {
                    let c = (i * self.dims[1] + j) * self.dims[2] + k;
                    for &s in &self.order[self.starts[c]..self.starts[c + 1]] {
                        let (u, v, q) = self.samples[s];
                        let d2 = dot3(sub3(q, p), sub3(q, p));
                        if d2 <= r2 && best.is_none_or(|b| d2 < b.2) {
                            best = Some((u, v, d2));
                        }
                    }
                }
            }
        }
        best.map(|(u, v, d2)| (u, v, d2.sqrt()))
    }
}

impl BSplineSurface<3> {
    /// The closest point to `target` within `radius` (mm), started from the
    /// nearest sample of `index` and, when given, from `hint`; `None` when no
    /// part of the surface is that close.
    pub fn closest_point(
        &self,
        index: &ProjectionIndex,
        target: [f64; 3],
        radius: f64,
        hint: Option<(f64, f64)>,
    ) -> Option<ClosestPoint> {
        let better = |c: ClosestPoint, best: Option<ClosestPoint>| {
            if best.is_none_or(|b| c.distance < b.distance - 1e-12) {
                Some(c)
            } else {
                best
            }
        };
        let mut best = hint.map(|(u, v)| self.closest_point_from(target, u, v));
        // A hint that converged orthogonally is checked against the nearest
        // sample only when that sample is closer than the hint's foot point
        // (another part of the surface may be nearer).
        if let Some((u, v, d)) = index.nearest(target, radius + index.spacing()) {
            let need = best.is_none_or(|b| !b.orthogonal || d < b.distance);
            if need {
                best = better(self.closest_point_from(target, u, v), best);
            }
        }
        best.filter(|b| b.distance <= radius)
    }
}
