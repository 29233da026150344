//! Non-rational B-spline surfaces: evaluation, global interpolation,
//! least-squares approximation and closest-point projection.
//!
//! The algorithms are those of *The NURBS Book* (L. Piegl, W. Tiller, 2nd ed.,
//! Springer 1997), cited by number in each function: knot span search (A2.1),
//! basis functions (A2.2) and their derivatives (A2.3), surface point (A3.5)
//! and derivatives (A3.6), parameters of a point mesh (A9.3, with the
//! chord-length and centripetal parameters of eqs. 9.4–9.6), knots by
//! averaging (eq. 9.8), global surface interpolation (A9.4), least-squares
//! approximation (§9.4, here generalised to scattered data with known
//! parameters) and point inversion by Newton iteration (§6.1).
//!
//! Why a module of its own: the B-spline crates that were checked either lack
//! surface interpolation and scattered least squares, or bring a large
//! geometry stack with them. `curvo` (a NURBS modelling crate) is used as the
//! test oracle for evaluation, derivatives, curve interpolation and closest
//! points; interpolation and approximation are also tested against closed
//! forms (polynomial reproduction, partition of unity, finite differences).
//!
//! A surface is generic over the dimension `N` of its control points: `N = 3`
//! for geometry, `N = 1` for a scalar field over a parameter rectangle (the
//! deviation field of the mirror method). Knot vectors are clamped (open):
//! the surface interpolates its corner control points and is defined on
//! `[U[p], U[n+1]] × [V[q], V[m+1]]`; parameters outside are clamped.
//! Dense linear systems are solved with `faer`.

use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::{Mat, Side};

/// Highest supported degree in each direction.
pub const MAX_DEGREE: usize = 7;
const MAX_ORDER: usize = MAX_DEGREE + 1;
/// Highest derivative order the evaluators return.
pub const MAX_DERIVATIVE: usize = 2;

/// Why a surface could not be built, fitted or evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BSplineError {
    /// The definition is inconsistent (knots, counts, degrees, values).
    #[error("invalid B-spline surface: {0}")]
    Invalid(String),
    /// Not enough data for the requested degree or net.
    #[error("too few points: {0}")]
    TooFewPoints(String),
    /// The linear system has no unique solution.
    #[error("the fitting system is singular: {0}")]
    Singular(String),
}

/// A tensor-product, non-rational B-spline surface with control points in `R^N`.
#[derive(Debug, Clone, PartialEq)]
pub struct BSplineSurface<const N: usize> {
    degree_u: usize,
    degree_v: usize,
    knots_u: Vec<f64>,
    knots_v: Vec<f64>,
    count_u: usize,
    count_v: usize,
    /// Row-major: `P[i][j]` at `i * count_v + j`, `i` along u.
    control: Vec<[f64; N]>,
}

/// Partial derivatives `S_{u^k v^l}` for `k + l ≤ 2`, indexed `[k][l]`
/// (entries with `k + l > 2` are zero).
pub type SurfaceDerivatives<const N: usize> = [[[f64; N]; MAX_DERIVATIVE + 1]; MAX_DERIVATIVE + 1];

/// Checks a clamped knot vector for `count` control points of degree `p`.
fn check_knots(knots: &[f64], count: usize, p: usize, dir: char) -> Result<(), BSplineError> {
    if p == 0 || p > MAX_DEGREE {
        return Err(BSplineError::Invalid(format!(
            "degree_{dir} = {p}: the degree must be 1 … {MAX_DEGREE}"
        )));
    }
    if count < p + 1 {
        return Err(BSplineError::Invalid(format!(
            "{count} control points along {dir} are too few for degree {p} (at least {})",
            p + 1
        )));
    }
    if knots.len() != count + p + 1 {
        return Err(BSplineError::Invalid(format!(
            "knots_{dir} has {} values; {count} control points of degree {p} need {} (count + degree + 1)",
            knots.len(),
            count + p + 1
        )));
    }
    if let Some(k) = knots.iter().position(|k| !k.is_finite()) {
        return Err(BSplineError::Invalid(format!(
            "knots_{dir}[{k}] is not a finite number"
        )));
    }
    if let Some(k) = knots.windows(2).position(|w| w[1] < w[0]) {
        return Err(BSplineError::Invalid(format!(
            "knots_{dir} decreases at index {} ({} after {})",
            k + 1,
            knots[k + 1],
            knots[k]
        )));
    }
    let (a, b) = (knots[p], knots[count]);
    if knots[..=p].iter().any(|k| *k != a) || knots[count..].iter().any(|k| *k != knots[count + p])
    {
        return Err(BSplineError::Invalid(format!(
            "knots_{dir} must be clamped: the first and the last {} values equal",
            p + 1
        )));
    }
    if knots[p + 1] <= a || knots[count - 1] >= b {
        return Err(BSplineError::Invalid(format!(
            "knots_{dir}: an end knot is repeated more than {} times, or the domain is empty",
            p + 1
        )));
    }
    let mut run = 1;
    for k in p + 1..count {
        run = if knots[k] == knots[k - 1] { run + 1 } else { 1 };
        if run > p {
            return Err(BSplineError::Invalid(format!(
                "knots_{dir}: the interior knot {} is repeated more than the degree {p} times",
                knots[k]
            )));
        }
    }
    Ok(())
}

/// Knot span index (A2.1): the `i` with `U[i] ≤ u < U[i+1]`, `p ≤ i ≤ n`,
/// for a clamped knot vector of `n + 1` control points; `u` at or past the
/// end gives `n`, `u` before the start gives `p`.
pub fn find_span(n: usize, p: usize, u: f64, knots: &[f64]) -> usize {
    if u >= knots[n + 1] {
        return n;
    }
    if u <= knots[p] {
        return p;
    }
    let (mut low, mut high) = (p, n + 1);
    let mut mid = (low + high) / 2;
    while u < knots[mid] || u >= knots[mid + 1] {
        if u < knots[mid] {
            high = mid;
        } else {
            low = mid;
        }
        mid = (low + high) / 2;
    }
    mid
}

/// The `p + 1` non-zero basis functions `N_{i−p,p}(u) … N_{i,p}(u)` in span
/// `i` (A2.2), written to `out[0..=p]`.
pub fn basis_funs(i: usize, u: f64, p: usize, knots: &[f64], out: &mut [f64]) {
    let mut left = [0.0; MAX_ORDER];
    let mut right = [0.0; MAX_ORDER];
    out[0] = 1.0;
    for j in 1..=p {
        left[j] = u - knots[i + 1 - j];
        right[j] = knots[i + j] - u;
        let mut saved = 0.0;
        for r in 0..j {
            let temp = out[r] / (right[r + 1] + left[j - r]);
            out[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        out[j] = saved;
    }
}

/// The non-zero basis functions and their derivatives up to order `n` in span
/// `i` (A2.3): `ders[k][j]` is the `k`-th derivative of `N_{i−p+j,p}` at `u`.
/// Orders above `p` are zero.
pub fn ders_basis_funs(
    i: usize,
    u: f64,
    p: usize,
    n: usize,
    knots: &[f64],
    ders: &mut [[f64; MAX_ORDER]; MAX_DERIVATIVE + 1],
) {
    let n = n.min(MAX_DERIVATIVE);
    let mut ndu = [[0.0; MAX_ORDER]; MAX_ORDER];
    let mut left = [0.0; MAX_ORDER];
    let mut right = [0.0; MAX_ORDER];
    ndu[0][0] = 1.0;
    for j in 1..=p {
        left[j] = u - knots[i + 1 - j];
        right[j] = knots[i + j] - u;
        let mut saved = 0.0;
        for r in 0..j {
            // Lower triangle: knot differences; upper: basis functions.
            ndu[j][r] = right[r + 1] + left[j - r];
            let temp = ndu[r][j - 1] / ndu[j][r];
            ndu[r][j] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        ndu[j][j] = saved;
    }
    for row in ders.iter_mut() {
        *row = [0.0; MAX_ORDER];
    }
    for j in 0..=p {
        ders[0][j] = ndu[j][p];
    }
    let nd = n.min(p);
    let mut a = [[0.0; MAX_ORDER]; 2];
    let p_i = p as isize;
    for r in 0..=p {
        let ri = r as isize;
        let (mut s1, mut s2) = (0usize, 1usize);
        a[0][0] = 1.0;
        for k in 1..=nd {
            let ki = k as isize;
            let mut d = 0.0;
            let rk = ri - ki;
            let pk = p_i - ki;
            if ri >= ki {
                a[s2][0] = a[s1][0] / ndu[(pk + 1) as usize][rk as usize];
                d = a[s2][0] * ndu[rk as usize][pk as usize];
            }
            let j1: isize = if rk >= -1 { 1 } else { -rk };
            let j2: isize = if ri - 1 <= pk { ki - 1 } else { p_i - ri };
            let mut j = j1;
            while j <= j2 {
                let ju = j as usize;
                a[s2][ju] = (a[s1][ju] - a[s1][ju - 1]) / ndu[(pk + 1) as usize][(rk + j) as usize];
                d += a[s2][ju] * ndu[(rk + j) as usize][pk as usize];
                j += 1;
            }
            if ri <= pk {
                a[s2][k] = -a[s1][k - 1] / ndu[(pk + 1) as usize][r];
                d += a[s2][k] * ndu[r][pk as usize];
            }
            ders[k][r] = d;
            std::mem::swap(&mut s1, &mut s2);
        }
    }
    let mut factor = p as f64;
    for (k, row) in ders.iter_mut().enumerate().take(nd + 1).skip(1) {
        for v in row.iter_mut().take(p + 1) {
            *v *= factor;
        }
        factor *= (p - k) as f64;
    }
}

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

    fn clamp(&self, u: f64, v: f64) -> (f64, f64) {
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

fn breaks(knots: &[f64]) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::with_capacity(knots.len());
    for k in knots {
        if out.last() != Some(k) {
            out.push(*k);
        }
    }
    out
}

/// How interpolation parameters are chosen.
#[derive(Debug, Clone, PartialEq)]
pub enum Parameterization {
    /// Equally spaced (eq. 9.3).
    Uniform,
    /// Chord length (eqs. 9.4–9.5), averaged over the mesh rows (A9.3).
    ChordLength,
    /// Centripetal, square root of the chord length (eq. 9.6), averaged (A9.3).
    Centripetal,
    /// Given parameters along u and v (strictly increasing).
    Given(Vec<f64>, Vec<f64>),
}

/// Parameters `ū_0 = 0 … ū_n = 1` of one polyline (eqs. 9.4–9.6 with
/// exponent `alpha`: 1 chord length, ½ centripetal), or `None` when all its
/// points coincide.
fn polyline_params<const N: usize>(
    points: impl Iterator<Item = [f64; N]>,
    alpha: f64,
) -> Option<Vec<f64>> {
    let pts: Vec<[f64; N]> = points.collect();
    let mut t = vec![0.0; pts.len()];
    for k in 1..pts.len() {
        let d: f64 = (0..N)
            .map(|c| (pts[k][c] - pts[k - 1][c]).powi(2))
            .sum::<f64>()
            .sqrt();
        t[k] = t[k - 1] + d.powf(alpha);
    }
    let total = *t.last()?;
    if total <= 0.0 || !total.is_finite() {
        return None;
    }
    for x in t.iter_mut() {
        *x /= total;
    }
    *t.last_mut()? = 1.0;
    Some(t)
}

/// Parameters of a `count_u × count_v` point mesh (A9.3): the parameters of
/// every row (column) averaged, rows whose points all coincide skipped.
pub fn mesh_params<const N: usize>(
    points: &[[f64; N]],
    count_u: usize,
    count_v: usize,
    kind: &Parameterization,
) -> Result<(Vec<f64>, Vec<f64>), BSplineError> {
    let uniform = |n: usize| -> Vec<f64> {
        (0..n)
            .map(|k| {
                if n == 1 {
                    0.0
                } else {
                    k as f64 / (n - 1) as f64
                }
            })
            .collect()
    };
    let alpha = match kind {
        Parameterization::Uniform => return Ok((uniform(count_u), uniform(count_v))),
        Parameterization::Given(u, v) => return Ok((u.clone(), v.clone())),
        Parameterization::ChordLength => 1.0,
        Parameterization::Centripetal => 0.5,
    };
    let average = |count: usize, lines: usize, at: &dyn Fn(usize, usize) -> [f64; N]| {
        let mut sum = vec![0.0; count];
        let mut used = 0usize;
        for l in 0..lines {
            if let Some(t) = polyline_params((0..count).map(|k| at(k, l)), alpha) {
                for (s, x) in sum.iter_mut().zip(t) {
                    *s += x;
                }
                used += 1;
            }
        }
        if used == 0 {
            return None;
        }
        let mut t: Vec<f64> = sum.into_iter().map(|s| s / used as f64).collect();
        t[0] = 0.0;
        t[count - 1] = 1.0;
        Some(t)
    };
    let u = average(count_u, count_v, &|k, l| points[k * count_v + l]).ok_or_else(|| {
        BSplineError::Invalid("every row of the mesh collapses to a point along u".into())
    })?;
    let v = average(count_v, count_u, &|k, l| points[l * count_v + k]).ok_or_else(|| {
        BSplineError::Invalid("every row of the mesh collapses to a point along v".into())
    })?;
    Ok((u, v))
}

/// A clamped knot vector for interpolation at `params` with degree `p`,
/// by averaging (eq. 9.8).
pub fn averaged_knots(params: &[f64], p: usize) -> Vec<f64> {
    let n = params.len() - 1;
    let mut knots = vec![params[0]; p + 1];
    for j in 1..=n.saturating_sub(p) {
        let s: f64 = params[j..j + p].iter().sum();
        knots.push(s / p as f64);
    }
    knots.extend(std::iter::repeat_n(params[n], p + 1));
    knots
}

/// A clamped knot vector with `spans` equal spans over `[a, b]`.
pub fn uniform_knots(a: f64, b: f64, spans: usize, p: usize) -> Vec<f64> {
    let mut knots = vec![a; p + 1];
    for k in 1..spans {
        knots.push(a + (b - a) * k as f64 / spans as f64);
    }
    knots.extend(std::iter::repeat_n(b, p + 1));
    knots
}

fn check_params(t: &[f64], count: usize, dir: char) -> Result<(), BSplineError> {
    if t.len() != count {
        return Err(BSplineError::Invalid(format!(
            "{} parameters along {dir} for {count} points",
            t.len()
        )));
    }
    if t.iter().any(|x| !x.is_finite()) || t.windows(2).any(|w| w[1] <= w[0]) {
        return Err(BSplineError::Invalid(format!(
            "the parameters along {dir} must be finite and strictly increasing"
        )));
    }
    Ok(())
}

/// Collocation matrix `N_{j,p}(t_k)` of curve interpolation (A9.1's matrix).
fn collocation(params: &[f64], knots: &[f64], p: usize) -> Mat<f64> {
    let n = params.len();
    let mut a = Mat::<f64>::zeros(n, n);
    let mut b = [0.0; MAX_ORDER];
    for (k, t) in params.iter().enumerate() {
        let span = find_span(n - 1, p, *t, knots);
        basis_funs(span, *t, p, knots, &mut b);
        for (r, w) in b.iter().enumerate().take(p + 1) {
            a[(k, span - p + r)] = *w;
        }
    }
    a
}

/// Solves `A X = B` by LU with partial pivoting and checks the result.
fn solve_dense(a: &Mat<f64>, mut b: Mat<f64>, what: &str) -> Result<Mat<f64>, BSplineError> {
    let lu = a.partial_piv_lu();
    let rhs = b.clone();
    lu.solve_in_place(b.as_mut());
    // A singular (or nearly singular) system shows as non-finite values or a
    // residual far above rounding.
    let scale = rhs.norm_max().max(1e-300);
    let resid = (a * &b - &rhs).norm_max();
    if !b.norm_max().is_finite() || resid > 1e-8 * scale {
        return Err(BSplineError::Singular(format!(
            "{what}: the points do not determine the control points (repeated parameters?)"
        )));
    }
    Ok(b)
}

/// Global surface interpolation (A9.4): the surface of degrees `(p, q)`
/// through a `count_u × count_v` point mesh (row-major, `points[k * count_v + l]`,
/// `k` along u), with parameters by `params` (A9.3) and knots by averaging
/// (eq. 9.8). Curves are interpolated through the mesh rows along u, then
/// through the resulting control points along v.
pub fn interpolate<const N: usize>(
    points: &[[f64; N]],
    count_u: usize,
    count_v: usize,
    p: usize,
    q: usize,
    params: &Parameterization,
) -> Result<BSplineSurface<N>, BSplineError> {
    if points.len() != count_u * count_v {
        return Err(BSplineError::Invalid(format!(
            "{} points for a {count_u} × {count_v} mesh",
            points.len()
        )));
    }
    if count_u < p + 1 || count_v < q + 1 {
        return Err(BSplineError::TooFewPoints(format!(
            "a {count_u} × {count_v} mesh cannot carry degrees ({p}, {q}): at least {} × {} points",
            p + 1,
            q + 1
        )));
    }
    if let Some(k) = points.iter().position(|x| x.iter().any(|c| !c.is_finite())) {
        return Err(BSplineError::Invalid(format!(
            "mesh point [{}][{}] is not finite",
            k / count_v,
            k % count_v
        )));
    }
    let (uk, vl) = mesh_params(points, count_u, count_v, params)?;
    check_params(&uk, count_u, 'u')?;
    check_params(&vl, count_v, 'v')?;
    let knots_u = averaged_knots(&uk, p);
    let knots_v = averaged_knots(&vl, q);
    // Along u: one system, count_v · N right-hand sides.
    let au = collocation(&uk, &knots_u, p);
    let bu = Mat::<f64>::from_fn(count_u, count_v * N, |k, c| {
        points[k * count_v + c / N][c % N]
    });
    let r = solve_dense(&au, bu, "interpolation along u")?;
    // Along v: count_u · N right-hand sides.
    let av = collocation(&vl, &knots_v, q);
    let bv = Mat::<f64>::from_fn(count_v, count_u * N, |l, c| r[(c / N, l * N + c % N)]);
    let s = solve_dense(&av, bv, "interpolation along v")?;
    let mut control = vec![[0.0; N]; count_u * count_v];
    for i in 0..count_u {
        for j in 0..count_v {
            for c in 0..N {
                control[i * count_v + j][c] = s[(j, i * N + c)];
            }
        }
    }
    BSplineSurface::new(p, q, knots_u, knots_v, count_u, count_v, control)
}

/// Result of a least-squares fit.
#[derive(Debug, Clone)]
pub struct LeastSquaresFit<const N: usize> {
    /// The fitted surface.
    pub surface: BSplineSurface<N>,
    /// `S(u_k, v_k) − value_k` at every data point.
    pub residuals: Vec<[f64; N]>,
    /// Leave-one-out residuals `r_k / (1 − h_kk)` (exact for this linear
    /// smoother): the error at point `k` of the fit made without it. `None`
    /// where the point alone determines part of the surface (`h_kk ≈ 1`).
    pub leave_one_out: Vec<Option<[f64; N]>>,
}

/// Least-squares approximation of scattered data with known parameters
/// (the normal equations `(NᵀN) P = NᵀQ` of §9.4, for data that need not lie
/// on a grid), on the given clamped knot vectors, with a small second-difference
/// penalty on the control net (weight `smoothing` relative to the data term)
/// so that control points that no data point reaches are filled in smoothly
/// instead of making the system singular. `smoothing = 0` is plain least squares.
pub fn fit_least_squares<const N: usize>(
    uv: &[(f64, f64)],
    values: &[[f64; N]],
    p: usize,
    q: usize,
    knots_u: Vec<f64>,
    knots_v: Vec<f64>,
    smoothing: f64,
) -> Result<LeastSquaresFit<N>, BSplineError> {
    let nu = knots_u.len().saturating_sub(p + 1);
    let nv = knots_v.len().saturating_sub(q + 1);
    check_knots(&knots_u, nu, p, 'u')?;
    check_knots(&knots_v, nv, q, 'v')?;
    if uv.len() != values.len() {
        return Err(BSplineError::Invalid(
            "as many parameters as values are needed".into(),
        ));
    }
    let unknowns = nu * nv;
    if uv.len() < (p + 1) * (q + 1) {
        return Err(BSplineError::TooFewPoints(format!(
            "{} points cannot determine a surface of degrees ({p}, {q}): at least {} are needed",
            uv.len(),
            (p + 1) * (q + 1)
        )));
    }
    let mut ata = Mat::<f64>::zeros(unknowns, unknowns);
    let mut atb = Mat::<f64>::zeros(unknowns, N);
    let mut rows: Vec<(
        [usize; MAX_ORDER * MAX_ORDER],
        [f64; MAX_ORDER * MAX_ORDER],
        usize,
    )> = Vec::with_capacity(uv.len());
    let mut bu = [0.0; MAX_ORDER];
    let mut bv = [0.0; MAX_ORDER];
    for ((u, v), val) in uv.iter().zip(values) {
        if !(u.is_finite() && v.is_finite()) || val.iter().any(|x| !x.is_finite()) {
            return Err(BSplineError::Invalid("a data point is not finite".into()));
        }
        let su = find_span(nu - 1, p, *u, &knots_u);
        let sv = find_span(nv - 1, q, *v, &knots_v);
        basis_funs(su, *u, p, &knots_u, &mut bu);
        basis_funs(sv, *v, q, &knots_v, &mut bv);
        let mut idx = [0usize; MAX_ORDER * MAX_ORDER];
        let mut w = [0.0; MAX_ORDER * MAX_ORDER];
        let mut m = 0;
        for (a, wa) in bu.iter().enumerate().take(p + 1) {
            for (b, wb) in bv.iter().enumerate().take(q + 1) {
                idx[m] = (su - p + a) * nv + (sv - q + b);
                w[m] = wa * wb;
                m += 1;
            }
        }
        for x in 0..m {
            for y in 0..m {
                ata[(idx[x], idx[y])] += w[x] * w[y];
            }
            for c in 0..N {
                atb[(idx[x], c)] += w[x] * val[c];
            }
        }
        rows.push((idx, w, m));
    }
    if smoothing > 0.0 {
        // Second divided differences of the control net over the Greville
        // abscissae along u, along v, and the mixed difference: a discrete
        // thin-plate energy whose null space is exactly the linear fields
        // (their control points lie on the Greville abscissae).
        let greville = |knots: &[f64], p: usize, n: usize| -> Vec<f64> {
            (0..n)
                .map(|i| knots[i + 1..=i + p].iter().sum::<f64>() / p as f64)
                .collect()
        };
        let (gu, gv) = (greville(&knots_u, p, nu), greville(&knots_v, q, nv));
        let mut pen = Mat::<f64>::zeros(unknowns, unknowns);
        let mut add = |terms: &[(usize, f64)]| {
            for (i, a) in terms {
                for (j, b) in terms {
                    pen[(*i, *j)] += a * b;
                }
            }
        };
        let id = |i: usize, j: usize| i * nv + j;
        let second = |g: &[f64], i: usize| {
            let (w1, w2) = (1.0 / (g[i + 1] - g[i]), 1.0 / (g[i + 2] - g[i + 1]));
            let s = 2.0 / (g[i + 2] - g[i]);
            [s * w1, -s * (w1 + w2), s * w2]
        };
        for i in 0..nu {
            for j in 0..nv {
                if i + 2 < nu {
                    let [a, b, c] = second(&gu, i);
                    add(&[(id(i, j), a), (id(i + 1, j), b), (id(i + 2, j), c)]);
                }
                if j + 2 < nv {
                    let [a, b, c] = second(&gv, j);
                    add(&[(id(i, j), a), (id(i, j + 1), b), (id(i, j + 2), c)]);
                }
                if i + 1 < nu && j + 1 < nv {
                    let w = 2f64.sqrt() / ((gu[i + 1] - gu[i]) * (gv[j + 1] - gv[j]));
                    add(&[
                        (id(i, j), w),
                        (id(i + 1, j), -w),
                        (id(i, j + 1), -w),
                        (id(i + 1, j + 1), w),
                    ]);
                }
            }
        }
        let tr_data: f64 = (0..unknowns).map(|k| ata[(k, k)]).sum();
        let tr_pen: f64 = (0..unknowns).map(|k| pen[(k, k)]).sum();
        if tr_pen > 0.0 {
            let lambda = smoothing * tr_data / tr_pen;
            ata += &pen * faer::Scale(lambda);
        }
    }
    let llt = ata.llt(Side::Lower).map_err(|_| {
        BSplineError::Singular(format!(
            "{} points do not determine a {nu} × {nv} control net (too few, or all on one curve)",
            uv.len()
        ))
    })?;
    let mut sol = atb.clone();
    llt.solve_in_place(sol.as_mut());
    if !sol.norm_max().is_finite() {
        return Err(BSplineError::Singular(
            "the normal equations are singular".into(),
        ));
    }
    let control: Vec<[f64; N]> = (0..unknowns)
        .map(|k| std::array::from_fn(|c| sol[(k, c)]))
        .collect();
    let surface = BSplineSurface::new(p, q, knots_u, knots_v, nu, nv, control)?;
    let inverse = llt.inverse();
    let mut residuals = Vec::with_capacity(uv.len());
    let mut leave_one_out = Vec::with_capacity(uv.len());
    for ((idx, w, m), val) in rows.iter().zip(values) {
        let mut fitted = [0.0; N];
        let mut h = 0.0;
        for x in 0..*m {
            for c in 0..N {
                fitted[c] += w[x] * sol[(idx[x], c)];
            }
            for y in 0..*m {
                h += w[x] * w[y] * inverse[(idx[x], idx[y])];
            }
        }
        let r: [f64; N] = std::array::from_fn(|c| fitted[c] - val[c]);
        residuals.push(r);
        leave_one_out.push(if 1.0 - h > 1e-6 {
            Some(r.map(|x| x / (1.0 - h)))
        } else {
            None
        });
    }
    Ok(LeastSquaresFit {
        surface,
        residuals,
        leave_one_out,
    })
}

// ---- Geometry of 3-D surfaces ---------------------------------------------

fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
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
fn norm3(a: [f64; 3]) -> f64 {
    dot3(a, a).sqrt()
}

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

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic generator for test data (SplitMix64).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            (z >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// A cubic × quadratic surface with non-uniform interior knots.
    fn sample_surface() -> BSplineSurface<3> {
        let knots_u = vec![0.0, 0.0, 0.0, 0.0, 0.3, 0.55, 1.0, 1.0, 1.0, 1.0];
        let knots_v = vec![0.0, 0.0, 0.0, 0.4, 1.0, 1.0, 1.0];
        let (cu, cv) = (6, 4);
        let mut rng = Rng(7);
        let control = (0..cu * cv)
            .map(|k| {
                let (i, j) = (k / cv, k % cv);
                [
                    10.0 * i as f64 + rng.next(),
                    8.0 * j as f64 + rng.next(),
                    5.0 * (rng.next() - 0.5),
                ]
            })
            .collect();
        BSplineSurface::new(3, 2, knots_u, knots_v, cu, cv, control).unwrap()
    }

    #[test]
    fn span_search_matches_the_definition() {
        let knots = [0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 4.0, 5.0, 5.0, 5.0];
        // The book's example 2.3: n = 7, p = 2, u = 5/2 lies in span 4.
        assert_eq!(find_span(7, 2, 2.5, &knots), 4);
        assert_eq!(find_span(7, 2, 0.0, &knots), 2);
        assert_eq!(find_span(7, 2, 4.0, &knots), 7);
        assert_eq!(find_span(7, 2, 5.0, &knots), 7);
        assert_eq!(find_span(7, 2, -1.0, &knots), 2);
    }

    #[test]
    fn basis_matches_the_book_example() {
        // Example 2.3: N_{2,2}(5/2) = 1/8, N_{3,2} = 6/8, N_{4,2} = 1/8.
        let knots = [0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 4.0, 5.0, 5.0, 5.0];
        let mut n = [0.0; MAX_ORDER];
        basis_funs(4, 2.5, 2, &knots, &mut n);
        assert!((n[0] - 0.125).abs() < 1e-15);
        assert!((n[1] - 0.75).abs() < 1e-15);
        assert!((n[2] - 0.125).abs() < 1e-15);
        // Derivatives (eq. 2.9 there): N'_{2,2} = −1/2, N'_{3,2} = 0, N'_{4,2} = 1/2.
        let mut d = [[0.0; MAX_ORDER]; MAX_DERIVATIVE + 1];
        ders_basis_funs(4, 2.5, 2, 2, &knots, &mut d);
        assert!((d[1][0] + 0.5).abs() < 1e-15 && d[1][1].abs() < 1e-15);
        assert!((d[1][2] - 0.5).abs() < 1e-15);
        assert!((d[2][0] - 1.0).abs() < 1e-15 && (d[2][1] + 2.0).abs() < 1e-15);
    }

    #[test]
    fn partition_of_unity_and_derivative_sums() {
        let mut rng = Rng(1);
        let knots = [0.0, 0.0, 0.0, 0.0, 0.2, 0.2, 0.7, 1.0, 1.0, 1.0, 1.0];
        for _ in 0..200 {
            let u = rng.next();
            let i = find_span(6, 3, u, &knots);
            let mut d = [[0.0; MAX_ORDER]; MAX_DERIVATIVE + 1];
            ders_basis_funs(i, u, 3, 2, &knots, &mut d);
            let s0: f64 = d[0][..4].iter().sum();
            let s1: f64 = d[1][..4].iter().sum();
            let s2: f64 = d[2][..4].iter().sum();
            assert!((s0 - 1.0).abs() < 1e-14, "{s0}");
            assert!(s1.abs() < 1e-11 && s2.abs() < 1e-9, "{s1} {s2}");
            assert!(d[0][..4].iter().all(|x| *x >= -1e-15));
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let s = sample_surface();
        let mut rng = Rng(3);
        let h = 1e-6;
        for _ in 0..50 {
            let (u, v) = (0.05 + 0.9 * rng.next(), 0.05 + 0.9 * rng.next());
            let d = s.derivatives(u, v, 2);
            let p = s.point(u, v);
            for c in 0..3 {
                assert!((d[0][0][c] - p[c]).abs() < 1e-12);
            }
            let fd = |du: f64, dv: f64| s.derivatives(u + du, v + dv, 1);
            let (up, um) = (fd(h, 0.0), fd(-h, 0.0));
            let (vp, vm) = (fd(0.0, h), fd(0.0, -h));
            for c in 0..3 {
                let su = (up[0][0][c] - um[0][0][c]) / (2.0 * h);
                let sv = (vp[0][0][c] - vm[0][0][c]) / (2.0 * h);
                let suu = (up[1][0][c] - um[1][0][c]) / (2.0 * h);
                let suv = (vp[1][0][c] - vm[1][0][c]) / (2.0 * h);
                let svv = (vp[0][1][c] - vm[0][1][c]) / (2.0 * h);
                let tol = |x: f64| 1e-5 * (1.0 + x.abs());
                assert!((d[1][0][c] - su).abs() < tol(su), "Su {u} {v}");
                assert!((d[0][1][c] - sv).abs() < tol(sv), "Sv");
                assert!((d[2][0][c] - suu).abs() < tol(suu), "Suu");
                assert!((d[1][1][c] - suv).abs() < tol(suv), "Suv");
                assert!((d[0][2][c] - svv).abs() < tol(svv), "Svv");
            }
        }
    }

    #[test]
    fn interpolation_reproduces_a_biquadratic_exactly() {
        // x, y affine in the parameters and z quadratic in each: any degree ≥ 2
        // interpolant with uniform parameters reproduces it (polynomial
        // reproduction), between the mesh points too.
        let f = |x: f64, y: f64| 0.01 * x * x - 0.02 * x * y + 0.003 * y * y + 0.5 * x - 2.0;
        let (cu, cv) = (7, 5);
        let mut pts = Vec::new();
        for i in 0..cu {
            for j in 0..cv {
                let (x, y) = (
                    100.0 * i as f64 / (cu - 1) as f64,
                    60.0 * j as f64 / (cv - 1) as f64,
                );
                pts.push([x, y, f(x, y)]);
            }
        }
        for (p, q) in [(2, 2), (3, 3), (3, 2)] {
            let s = interpolate(&pts, cu, cv, p, q, &Parameterization::Uniform).unwrap();
            let mut rng = Rng(5);
            for _ in 0..100 {
                let (u, v) = (rng.next(), rng.next());
                let pt = s.point(u, v);
                assert!((pt[0] - 100.0 * u).abs() < 1e-10 && (pt[1] - 60.0 * v).abs() < 1e-10);
                assert!((pt[2] - f(pt[0], pt[1])).abs() < 1e-10, "degree ({p},{q})");
            }
        }
        // A bilinear mesh with degree 1 is reproduced too.
        let s = interpolate(&pts, cu, cv, 1, 1, &Parameterization::Uniform).unwrap();
        for (k, p) in pts.iter().enumerate() {
            let (i, j) = (k / cv, k % cv);
            let q = s.point(i as f64 / (cu - 1) as f64, j as f64 / (cv - 1) as f64);
            assert!((0..3).all(|c| (q[c] - p[c]).abs() < 1e-10));
        }
    }

    #[test]
    fn interpolation_passes_through_every_mesh_point() {
        let mut rng = Rng(11);
        let (cu, cv) = (8, 6);
        let pts: Vec<[f64; 3]> = (0..cu * cv)
            .map(|k| {
                let (i, j) = (k / cv, k % cv);
                [
                    i as f64 * 5.0 + rng.next(),
                    j as f64 * 4.0 + rng.next(),
                    3.0 * rng.next(),
                ]
            })
            .collect();
        for kind in [Parameterization::ChordLength, Parameterization::Centripetal] {
            let s = interpolate(&pts, cu, cv, 3, 3, &kind).unwrap();
            let (uk, vl) = mesh_params(&pts, cu, cv, &kind).unwrap();
            for i in 0..cu {
                for j in 0..cv {
                    let q = s.point(uk[i], vl[j]);
                    let p = pts[i * cv + j];
                    assert!((0..3).all(|c| (q[c] - p[c]).abs() < 1e-9), "{kind:?}");
                }
            }
        }
    }

    #[test]
    fn least_squares_reproduces_what_the_space_contains_and_smooths_noise() {
        // A bicubic polynomial field lies in every bicubic spline space:
        // least squares without penalty recovers it exactly.
        let f = |u: f64, v: f64| 2.0 + u - 3.0 * v * v + u * u * u * v - 0.5 * u * v;
        let mut rng = Rng(21);
        let uv: Vec<(f64, f64)> = (0..200).map(|_| (rng.next(), rng.next())).collect();
        let vals: Vec<[f64; 1]> = uv.iter().map(|(u, v)| [f(*u, *v)]).collect();
        let fit = fit_least_squares(
            &uv,
            &vals,
            3,
            3,
            uniform_knots(0.0, 1.0, 3, 3),
            uniform_knots(0.0, 1.0, 2, 3),
            0.0,
        )
        .unwrap();
        for _ in 0..50 {
            let (u, v) = (rng.next(), rng.next());
            assert!((fit.surface.point(u, v)[0] - f(u, v)).abs() < 1e-9);
        }
        assert!(fit.residuals.iter().all(|r| r[0].abs() < 1e-9));
        // The penalty's null space holds the linear fields: still exact for one.
        let g = |u: f64, v: f64| 1.0 + 2.0 * u - v;
        let vals: Vec<[f64; 1]> = uv.iter().map(|(u, v)| [g(*u, *v)]).collect();
        let fit = fit_least_squares(
            &uv,
            &vals,
            3,
            3,
            uniform_knots(0.0, 1.0, 4, 3),
            uniform_knots(0.0, 1.0, 4, 3),
            1e-3,
        )
        .unwrap();
        assert!(fit.residuals.iter().all(|r| r[0].abs() < 1e-9));
        // Leave-one-out residuals agree with refitting without the point.
        let noisy: Vec<[f64; 1]> = uv
            .iter()
            .map(|(u, v)| [f(*u, *v) + 0.1 * (rng.next() - 0.5)])
            .collect();
        let knots = || (uniform_knots(0.0, 1.0, 3, 3), uniform_knots(0.0, 1.0, 3, 3));
        let (ku, kv) = knots();
        let fit = fit_least_squares(&uv, &noisy, 3, 3, ku, kv, 1e-4).unwrap();
        for k in [0, 17, 123] {
            let mut uv2 = uv.clone();
            let mut v2 = noisy.clone();
            uv2.remove(k);
            v2.remove(k);
            let (ku, kv) = knots();
            let refit = fit_least_squares(&uv2, &v2, 3, 3, ku, kv, 1e-4).unwrap();
            // The penalty weight is relative to the data term, which changes
            // slightly without the point: agreement to that order.
            let direct = refit.surface.point(uv[k].0, uv[k].1)[0] - noisy[k][0];
            let loo = fit.leave_one_out[k].unwrap()[0];
            assert!(
                (direct - loo).abs() < 1e-4 * (1.0 + direct.abs()),
                "{direct} {loo}"
            );
        }
    }

    #[test]
    fn least_squares_refuses_too_few_points() {
        let uv = vec![(0.1, 0.1), (0.5, 0.5), (0.9, 0.2)];
        let vals = vec![[1.0], [2.0], [3.0]];
        let e = fit_least_squares(
            &uv,
            &vals,
            3,
            3,
            uniform_knots(0.0, 1.0, 1, 3),
            uniform_knots(0.0, 1.0, 1, 3),
            0.0,
        )
        .unwrap_err();
        assert!(matches!(e, BSplineError::TooFewPoints(_)), "{e}");
        // Enough points, but all on one line: singular without penalty.
        let uv: Vec<(f64, f64)> = (0..30).map(|k| (k as f64 / 29.0, 0.5)).collect();
        let vals = vec![[1.0]; 30];
        let e = fit_least_squares(
            &uv,
            &vals,
            3,
            3,
            uniform_knots(0.0, 1.0, 1, 3),
            uniform_knots(0.0, 1.0, 1, 3),
            0.0,
        )
        .unwrap_err();
        assert!(matches!(e, BSplineError::Singular(_)), "{e}");
    }

    #[test]
    fn invalid_definitions_are_refused() {
        let ok = uniform_knots(0.0, 1.0, 2, 3);
        let net = vec![[0.0; 3]; 25];
        assert!(BSplineSurface::new(3, 3, ok.clone(), ok.clone(), 5, 5, net.clone()).is_ok());
        let mut bad = ok.clone();
        bad[4] = f64::NAN;
        assert!(BSplineSurface::new(3, 3, bad, ok.clone(), 5, 5, net.clone()).is_err());
        let dec = vec![0.0, 0.0, 0.0, 0.0, 0.6, 0.4, 1.0, 1.0, 1.0, 1.0];
        assert!(BSplineSurface::new(3, 3, dec, ok.clone(), 6, 5, vec![[0.0; 3]; 30]).is_err());
        let unclamped = vec![0.0, 0.1, 0.2, 0.3, 0.5, 0.7, 0.8, 0.9, 1.0];
        assert!(BSplineSurface::new(3, 3, unclamped, ok.clone(), 5, 5, net.clone()).is_err());
        assert!(
            BSplineSurface::new(3, 3, ok.clone(), ok.clone(), 5, 5, vec![[0.0; 3]; 24]).is_err()
        );
        let mut nan_net = net;
        nan_net[7][1] = f64::INFINITY;
        assert!(BSplineSurface::new(3, 3, ok.clone(), ok, 5, 5, nan_net).is_err());
    }

    #[test]
    fn closest_point_is_orthogonal_and_beats_every_sample() {
        let s = sample_surface();
        let index = ProjectionIndex::new(&s, 8);
        let mut rng = Rng(9);
        for _ in 0..100 {
            let (u, v) = (0.05 + 0.9 * rng.next(), 0.05 + 0.9 * rng.next());
            let n = s.unit_normal(u, v).unwrap();
            let h = 3.0 * (rng.next() - 0.5);
            let p = s.point(u, v);
            let target = [p[0] + h * n[0], p[1] + h * n[1], p[2] + h * n[2]];
            let c = s.closest_point(&index, target, 10.0, None).unwrap();
            assert!(c.orthogonal);
            assert!(c.distance <= h.abs() + 1e-9, "{} > {}", c.distance, h.abs());
            // No sample of a fine grid is closer.
            for i in 0..=60 {
                for j in 0..=60 {
                    let q = s.point(i as f64 / 60.0, j as f64 / 60.0);
                    assert!(norm3(sub3(q, target)) >= c.distance - 1e-9);
                }
            }
        }
        // Beyond the edge: the foot is on the boundary and not orthogonal.
        let p = s.point(1.0, 0.5);
        let d = s.derivatives(1.0, 0.5, 1)[1][0];
        let l = norm3(d);
        let target = [
            p[0] + 2.0 * d[0] / l,
            p[1] + 2.0 * d[1] / l,
            p[2] + 2.0 * d[2] / l,
        ];
        let c = s.closest_point(&index, target, 10.0, None).unwrap();
        assert!(!c.orthogonal && (c.u - 1.0).abs() < 1e-12);
        // Nothing within the radius.
        assert!(s
            .closest_point(&index, [1e4, 0.0, 0.0], 10.0, None)
            .is_none());
    }

    #[test]
    fn curvatures_of_a_cylinder_patch() {
        // z = sqrt(R² − x²) approximated closely by interpolation; the
        // curvature across is −1/R (bending away from the +z normal), along 0.
        let r = 50.0;
        let (cu, cv) = (41, 5);
        let mut pts = Vec::new();
        for i in 0..cu {
            let x = -20.0 + 40.0 * i as f64 / (cu - 1) as f64;
            for j in 0..cv {
                pts.push([x, 10.0 * j as f64, (r * r - x * x).sqrt()]);
            }
        }
        let s = interpolate(&pts, cu, cv, 3, 3, &Parameterization::ChordLength).unwrap();
        let n = s.unit_normal(0.5, 0.5).unwrap();
        let k = s.curvatures(0.5, 0.5).unwrap();
        let sign = n[2].signum();
        let (kmin, kmax) = if sign > 0.0 {
            (k.min, k.max)
        } else {
            (-k.max, -k.min)
        };
        assert!((kmin + 1.0 / r).abs() < 1e-5, "{kmin}");
        assert!(kmax.abs() < 1e-6, "{kmax}");
    }
}

/// Cross-checks against the `curvo` crate (an independent NURBS implementation).
#[cfg(test)]
mod curvo_oracle {
    use super::*;
    use curvo::prelude::{Interpolation, NurbsCurve3D, NurbsSurface3D};
    use nalgebra::{Point3, Point4};

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    fn surfaces() -> (BSplineSurface<3>, NurbsSurface3D<f64>) {
        let knots_u = vec![0.0, 0.0, 0.0, 0.0, 0.25, 0.6, 0.6, 1.0, 1.0, 1.0, 1.0];
        let knots_v = vec![0.0, 0.0, 0.0, 0.3, 0.5, 1.0, 1.0, 1.0];
        let (cu, cv) = (7, 5);
        let mut seed = 42;
        let control: Vec<[f64; 3]> = (0..cu * cv)
            .map(|k| {
                let (i, j) = (k / cv, k % cv);
                [
                    12.0 * i as f64 + 2.0 * lcg(&mut seed),
                    9.0 * j as f64 + 2.0 * lcg(&mut seed),
                    6.0 * (lcg(&mut seed) - 0.5),
                ]
            })
            .collect();
        let ours = BSplineSurface::new(
            3,
            2,
            knots_u.clone(),
            knots_v.clone(),
            cu,
            cv,
            control.clone(),
        )
        .unwrap();
        let net: Vec<Vec<Point4<f64>>> = (0..cu)
            .map(|i| {
                (0..cv)
                    .map(|j| {
                        let c = control[i * cv + j];
                        Point4::new(c[0], c[1], c[2], 1.0)
                    })
                    .collect()
            })
            .collect();
        let theirs = NurbsSurface3D::new(3, 2, knots_u, knots_v, net);
        (ours, theirs)
    }

    #[test]
    fn points_and_derivatives_agree_with_curvo() {
        let (ours, theirs) = surfaces();
        let mut seed = 1;
        for k in 0..300 {
            let (u, v) = if k < 4 {
                ([0.0, 1.0][k % 2], [0.0, 1.0][k / 2])
            } else {
                (lcg(&mut seed), lcg(&mut seed))
            };
            let p = ours.point(u, v);
            let q = theirs.point_at(u, v);
            for c in 0..3 {
                assert!((p[c] - q[c]).abs() < 1e-10, "point at ({u}, {v})");
            }
            let d = ours.derivatives(u, v, 2);
            let e = theirs.rational_derivatives(u, v, 2);
            for a in 0..=2 {
                for b in 0..=2 - a {
                    for c in 0..3 {
                        let (x, y) = (d[a][b][c], e[a][b][c]);
                        assert!(
                            (x - y).abs() < 1e-8 * (1.0 + y.abs()),
                            "S_u{a}v{b} at ({u}, {v}): {x} vs {y}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn closest_points_are_never_farther_than_curvos() {
        let (ours, theirs) = surfaces();
        let index = ProjectionIndex::new(&ours, 8);
        let mut seed = 5;
        for _ in 0..40 {
            let (u, v) = (lcg(&mut seed), lcg(&mut seed));
            let base = ours.point(u, v);
            let target = [
                base[0] + 4.0 * (lcg(&mut seed) - 0.5),
                base[1] + 4.0 * (lcg(&mut seed) - 0.5),
                base[2] + 4.0 * (lcg(&mut seed) - 0.5),
            ];
            let mine = ours.closest_point(&index, target, 50.0, None).unwrap();
            // curvo's own start (an adaptive tessellation) is slow in tests:
            // start it from the nearest node of a brute-force 41 × 41 grid.
            let mut hint = (0.0, 0.0);
            let mut best = f64::INFINITY;
            for i in 0..=40 {
                for j in 0..=40 {
                    let (a, b) = (i as f64 / 40.0, j as f64 / 40.0);
                    let p = ours.point(a, b);
                    let d = (0..3).map(|c| (p[c] - target[c]).powi(2)).sum::<f64>();
                    if d < best {
                        best = d;
                        hint = (a, b);
                    }
                }
            }
            let (cu, cv) = theirs
                .find_closest_parameter(&Point3::new(target[0], target[1], target[2]), Some(hint))
                .unwrap();
            let q = theirs.point_at(cu, cv);
            let theirs_d = ((q[0] - target[0]).powi(2)
                + (q[1] - target[1]).powi(2)
                + (q[2] - target[2]).powi(2))
            .sqrt();
            assert!(
                mine.distance <= theirs_d + 1e-9,
                "{} > curvo's {theirs_d}",
                mine.distance
            );
        }
    }

    #[test]
    fn surface_interpolation_rows_equal_curvos_curve_interpolation() {
        // An extruded mesh: every row along u is the same polyline shifted in
        // y, so A9.3's averaged chord-length parameters are that polyline's,
        // and each iso-curve v = v_l of the A9.4 surface must be the curve
        // curvo interpolates through row l (chord length, averaged knots).
        let xs = [0.0, 3.0, 7.5, 9.0, 14.0, 20.0, 21.0, 30.0];
        let zs = [0.0, 1.5, -0.5, 2.0, 2.5, 0.0, 1.0, -1.0];
        let (cu, cv) = (xs.len(), 4);
        let mut pts = Vec::new();
        for i in 0..cu {
            for j in 0..cv {
                pts.push([xs[i], 10.0 * j as f64, zs[i]]);
            }
        }
        let s = interpolate(&pts, cu, cv, 3, 3, &Parameterization::ChordLength).unwrap();
        let (_, vl) = mesh_params(&pts, cu, cv, &Parameterization::ChordLength).unwrap();
        let row: Vec<Point3<f64>> = (0..cu).map(|i| Point3::new(xs[i], 0.0, zs[i])).collect();
        let curve = NurbsCurve3D::<f64>::interpolate(&row, 3).unwrap();
        for k in 0..=200 {
            let t = k as f64 / 200.0;
            let c = curve.point_at(t);
            for (j, v) in vl.iter().enumerate() {
                let p = s.point(t, *v);
                assert!(
                    (p[0] - c[0]).abs() < 1e-9 && (p[2] - c[2]).abs() < 1e-9,
                    "t = {t}"
                );
                assert!((p[1] - 10.0 * j as f64).abs() < 1e-9);
            }
        }
    }
}
