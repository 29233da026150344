//! Evaluation: building a surface, its accessors, surface points (A3.5) and
//! derivatives (A3.6), and the differential geometry of 3-D surfaces (unit
//! normal, principal curvatures).

use super::basis::{basis_funs, breaks, check_knots, ders_basis_funs, find_span};
use super::{BSplineError, BSplineSurface, SurfaceDerivatives, MAX_DERIVATIVE, MAX_ORDER};

fn axpy<const N: usize>(acc: &mut [f64; N], w: f64, x: &[f64; N]) {
    for c in 0..N {
        acc[c] += w * x[c];
    }
}

impl<const N: usize> BSplineSurface<N> {
    /// Builds a surface, checking degrees, clamped knot vectors, counts and
    /// that every control point is finite.
    pub fn new(
        degree_u: usize,
        degree_v: usize,
        knots_u: Vec<f64>,
        knots_v: Vec<f64>,
        count_u: usize,
        count_v: usize,
        control: Vec<[f64; N]>,
    ) -> Result<Self, BSplineError> {
        check_knots(&knots_u, count_u, degree_u, 'u')?;
        check_knots(&knots_v, count_v, degree_v, 'v')?;
        if control.len() != count_u * count_v {
            return Err(BSplineError::Invalid(format!(
                "{} control points given; a {count_u} × {count_v} net needs {}",
                control.len(),
                count_u * count_v
            )));
        }
        if let Some(k) = control
            .iter()
            .position(|c| c.iter().any(|x| !x.is_finite()))
        {
            return Err(BSplineError::Invalid(format!(
                "control point [{}][{}] is not finite",
                k / count_v,
                k % count_v
            )));
        }
        Ok(Self {
            degree_u,
            degree_v,
            knots_u,
            knots_v,
            count_u,
            count_v,
            control,
        })
    }

    /// A surface of degree (1, 1) over `[u0, u1] × [v0, v1]` with every
    /// control point equal to `value`.
    pub fn constant(value: [f64; N], u: [f64; 2], v: [f64; 2]) -> Self {
        Self {
            degree_u: 1,
            degree_v: 1,
            knots_u: vec![u[0], u[0], u[1], u[1]],
            knots_v: vec![v[0], v[0], v[1], v[1]],
            count_u: 2,
            count_v: 2,
            control: vec![value; 4],
        }
    }

    /// Degree along u.
    pub fn degree_u(&self) -> usize {
        self.degree_u
    }
    /// Degree along v.
    pub fn degree_v(&self) -> usize {
        self.degree_v
    }
    /// Knot vector along u.
    pub fn knots_u(&self) -> &[f64] {
        &self.knots_u
    }
    /// Knot vector along v.
    pub fn knots_v(&self) -> &[f64] {
        &self.knots_v
    }
    /// Control points along u.
    pub fn count_u(&self) -> usize {
        self.count_u
    }
    /// Control points along v.
    pub fn count_v(&self) -> usize {
        self.count_v
    }
    /// Control points, row-major (`[i][j]` at `i * count_v + j`).
    pub fn control_points(&self) -> &[[f64; N]] {
        &self.control
    }
    /// Control point `P[i][j]`.
    pub fn control_point(&self, i: usize, j: usize) -> [f64; N] {
        self.control[i * self.count_v + j]
    }

    /// Parameter domain along u.
    pub fn domain_u(&self) -> [f64; 2] {
        [self.knots_u[self.degree_u], self.knots_u[self.count_u]]
    }
    /// Parameter domain along v.
    pub fn domain_v(&self) -> [f64; 2] {
        [self.knots_v[self.degree_v], self.knots_v[self.count_v]]
    }

    /// Distinct knot values along u (span boundaries, ends included).
    pub fn breaks_u(&self) -> Vec<f64> {
        breaks(&self.knots_u[self.degree_u..=self.count_u])
    }
    /// Distinct knot values along v (span boundaries, ends included).
    pub fn breaks_v(&self) -> Vec<f64> {
        breaks(&self.knots_v[self.degree_v..=self.count_v])
    }

    pub(super) fn clamp(&self, u: f64, v: f64) -> (f64, f64) {
        let [u0, u1] = self.domain_u();
        let [v0, v1] = self.domain_v();
        (u.clamp(u0, u1), v.clamp(v0, v1))
    }

    /// Surface point `S(u, v)` (A3.5); parameters are clamped to the domain.
    pub fn point(&self, u: f64, v: f64) -> [f64; N] {
        let (u, v) = self.clamp(u, v);
        let (p, q) = (self.degree_u, self.degree_v);
        let su = find_span(self.count_u - 1, p, u, &self.knots_u);
        let sv = find_span(self.count_v - 1, q, v, &self.knots_v);
        let mut nu = [0.0; MAX_ORDER];
        let mut nv = [0.0; MAX_ORDER];
        basis_funs(su, u, p, &self.knots_u, &mut nu);
        basis_funs(sv, v, q, &self.knots_v, &mut nv);
        let mut s = [0.0; N];
        for (l, nvl) in nv.iter().enumerate().take(q + 1) {
            let mut temp = [0.0; N];
            let col = sv - q + l;
            for (k, nuk) in nu.iter().enumerate().take(p + 1) {
                axpy(
                    &mut temp,
                    *nuk,
                    &self.control[(su - p + k) * self.count_v + col],
                );
            }
            axpy(&mut s, *nvl, &temp);
        }
        s
    }

    /// Partial derivatives up to total order `d ≤ 2` (A3.6); parameters are
    /// clamped to the domain. One-sided at the domain ends and at knots
    /// (the span containing the parameter, as A2.1 chooses it).
    pub fn derivatives(&self, u: f64, v: f64, d: usize) -> SurfaceDerivatives<N> {
        let d = d.min(MAX_DERIVATIVE);
        let (u, v) = self.clamp(u, v);
        let (p, q) = (self.degree_u, self.degree_v);
        let du = d.min(p);
        let dv = d.min(q);
        let mut skl = [[[0.0; N]; MAX_DERIVATIVE + 1]; MAX_DERIVATIVE + 1];
        let su = find_span(self.count_u - 1, p, u, &self.knots_u);
        let sv = find_span(self.count_v - 1, q, v, &self.knots_v);
        let mut nu = [[0.0; MAX_ORDER]; MAX_DERIVATIVE + 1];
        let mut nv = [[0.0; MAX_ORDER]; MAX_DERIVATIVE + 1];
        ders_basis_funs(su, u, p, du, &self.knots_u, &mut nu);
        ders_basis_funs(sv, v, q, dv, &self.knots_v, &mut nv);
        for k in 0..=du {
            let mut temp = [[0.0; N]; MAX_ORDER];
            for (s, t) in temp.iter_mut().enumerate().take(q + 1) {
                for (r, w) in nu[k].iter().enumerate().take(p + 1) {
                    axpy(
                        t,
                        *w,
                        &self.control[(su - p + r) * self.count_v + sv - q + s],
                    );
                }
            }
            let dd = (d - k).min(dv);
            for l in 0..=dd {
                let mut acc = [0.0; N];
                for (s, t) in temp.iter().enumerate().take(q + 1) {
                    axpy(&mut acc, nv[l][s], t);
                }
                skl[k][l] = acc;
            }
        }
        skl
    }

    /// The same surface with every control point mapped by `f`.
    pub fn map_control<const M: usize>(
        &self,
        f: impl Fn([f64; N]) -> [f64; M],
    ) -> BSplineSurface<M> {
        BSplineSurface {
            degree_u: self.degree_u,
            degree_v: self.degree_v,
            knots_u: self.knots_u.clone(),
            knots_v: self.knots_v.clone(),
            count_u: self.count_u,
            count_v: self.count_v,
            control: self.control.iter().map(|c| f(*c)).collect(),
        }
    }
}

// ---- Geometry of 3-D surfaces ---------------------------------------------

pub(super) fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(super) fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
/// Cross product.
pub fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub(super) fn norm3(a: [f64; 3]) -> f64 {
    dot3(a, a).sqrt()
}

/// Principal curvatures at a point, signed positive where the surface bends
/// towards its normal `Su × Sv` (its centre of curvature is on that side).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Curvatures {
    /// Smallest principal curvature (1/mm).
    pub min: f64,
    /// Largest principal curvature (1/mm).
    pub max: f64,
}

impl BSplineSurface<3> {
    /// Unit normal `Su × Sv / |Su × Sv|`, or `None` at a degenerate point.
    pub fn unit_normal(&self, u: f64, v: f64) -> Option<[f64; 3]> {
        let d = self.derivatives(u, v, 1);
        let n = cross3(d[1][0], d[0][1]);
        let l = norm3(n);
        (l > 1e-300 && l.is_finite()).then(|| n.map(|x| x / l))
    }

    /// Principal curvatures from the first and second fundamental forms
    /// (E, F, G; L, M, N), signed relative to `Su × Sv`.
    pub fn curvatures(&self, u: f64, v: f64) -> Option<Curvatures> {
        let d = self.derivatives(u, v, 2);
        let (su, sv) = (d[1][0], d[0][1]);
        let n = cross3(su, sv);
        let ln = norm3(n);
        if ln <= 1e-300 || !ln.is_finite() {
            return None;
        }
        let n = n.map(|x| x / ln);
        let (e, f, g) = (dot3(su, su), dot3(su, sv), dot3(sv, sv));
        let (l, m, nn) = (dot3(d[2][0], n), dot3(d[1][1], n), dot3(d[0][2], n));
        let det = e * g - f * f;
        if det <= 0.0 {
            return None;
        }
        let k = (l * nn - m * m) / det;
        let h = (e * nn - 2.0 * f * m + g * l) / (2.0 * det);
        let disc = (h * h - k).max(0.0).sqrt();
        Some(Curvatures {
            min: h - disc,
            max: h + disc,
        })
    }
}
