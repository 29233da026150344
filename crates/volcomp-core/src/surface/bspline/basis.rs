//! Knot vectors and basis functions: the clamped-knot check, knot span
//! search (A2.1), basis functions (A2.2) and their derivatives (A2.3), the
//! distinct knots, and knot vectors by averaging (eq. 9.8) or equal spans.

use super::{BSplineError, MAX_DEGREE, MAX_DERIVATIVE, MAX_ORDER};

/// Checks a clamped knot vector for `count` control points of degree `p`.
pub(super) fn check_knots(
    knots: &[f64],
    count: usize,
    p: usize,
    dir: char,
) -> Result<(), BSplineError> {
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

pub(super) fn breaks(knots: &[f64]) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::with_capacity(knots.len());
    for k in knots {
        if out.last() != Some(k) {
            out.push(*k);
        }
    }
    out
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
