//! Interpolation and approximation: parameters of a point mesh (A9.3),
//! global surface interpolation (A9.4) and least-squares approximation of
//! scattered data (§9.4).

use super::basis::{averaged_knots, basis_funs, check_knots, find_span};
use super::{BSplineError, BSplineSurface, MAX_ORDER};
use crate::linalg::{lu_solve, Cholesky, Matrix};

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
fn collocation(params: &[f64], knots: &[f64], p: usize) -> Matrix {
    let n = params.len();
    let mut a = Matrix::zeros(n, n);
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
fn solve_dense(a: &Matrix, b: Matrix, what: &str) -> Result<Matrix, BSplineError> {
    let singular = || {
        BSplineError::Singular(format!(
            "{what}: the points do not determine the control points (repeated parameters?)"
        ))
    };
    let x = lu_solve(a, &b).ok_or_else(singular)?;
    // A singular (or nearly singular) system shows as non-finite values or a
    // residual far above rounding.
    let scale = b.amax().max(1e-300);
    let resid = (a * &x - &b).amax();
    if x.iter().any(|v| !v.is_finite()) || resid.is_nan() || resid > 1e-8 * scale {
        return Err(singular());
    }
    Ok(x)
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
    let bu = Matrix::from_fn(count_u, count_v * N, |k, c| {
        points[k * count_v + c / N][c % N]
    });
    let r = solve_dense(&au, bu, "interpolation along u")?;
    // Along v: count_u · N right-hand sides.
    let av = collocation(&vl, &knots_v, q);
    let bv = Matrix::from_fn(count_v, count_u * N, |l, c| r[(c / N, l * N + c % N)]);
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
    let mut ata = Matrix::zeros(unknowns, unknowns);
    let mut atb = Matrix::zeros(unknowns, N);
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
        let mut pen = Matrix::zeros(unknowns, unknowns);
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
            ata += &pen * lambda;
        }
    }
    let llt = Cholesky::new(ata).ok_or_else(|| {
        BSplineError::Singular(format!(
            "{} points do not determine a {nu} × {nv} control net (too few, or all on one curve)",
            uv.len()
        ))
    })?;
    let sol = llt.solve(&atb);
    if sol.iter().any(|x| !x.is_finite()) {
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
