//! Choosing the number of harmonics `m` by leave-one-feed-rate-out
//! cross-validation (the default cut-off rule; the paper's fixed thresholds
//! `σ_t`, `P_t` remain available as [`super::identify::CutoffRule::Thresholds`]).
//!
//! Why: the thresholds stop at the shortest line carrying more than `P_t` of
//! the power. A ball-screw lead whose period is no harmonic of the modelling
//! length `l` is not one line but a peak whose leakage falls off like
//! `1/|k − l/p|`; the thresholds cut that tail early, and model − truth can
//! reach 10–15 % of the truth. Cross-validation asks the question the model
//! exists for instead: does harmonic set `1 … m`, fitted to the other feed
//! rates, predict the profile measured at the left-out feed rate? A
//! geometric component (same wavelength in mm at every feed rate) is
//! predicted by the others, so its harmonics lower the error. Vibration of
//! frequency `f` sits at `λ = v/f`, a different harmonic at every feed rate:
//! the others cannot predict it, and admitting the harmonic where it sits at
//! one feed rate adds its share to the prediction of every other feed rate,
//! raising the error. Noise harmonics add the others' noise and raise it too.
//! This is ordinary K-fold cross-validation (Hastie, Tibshirani & Friedman,
//! *The Elements of Statistical Learning*, 2nd ed. 2009, §7.10) with the
//! feed rates as folds.
//!
//! The criterion is computed exactly, without refitting: on the even grid
//! the Fourier basis is orthogonal, and the model (constant, slope `s` and
//! harmonics `1 … m`, fitted jointly) is the projection
//!
//! ```text
//! H_m w = w_0 + Σ_{k≤m} W_k + s·x̃,   x̃ = Σ_{k>m} X_k,   s = ⟨x̃, w⟩ / ⟨x̃, x̃⟩
//! ```
//!
//! (`W_k`, `X_k` the harmonic-`k` parts of the fitted profile `w` and of the
//! ramp `x`), so every `m` costs a prefix and a suffix sum. The held-out
//! error ignores the constant (a profile has no natural zero):
//!
//! ```text
//! CV(m) = Σ_j [ Σ_{1≤k≤m} |Z_jk − W_jk|² + Σ_{k>m} |Z_jk − s_j(m)·X_k|² ]
//! ```
//!
//! with `Z_j` the left-out feed rate's mean profile and `W_j` the mean of the
//! other feed rates' profiles (`|·|²` the harmonic's mean square).

use super::spectrum::fourier_coefficients;

/// The cross-validation curve and its minimum.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossValidation {
    /// `CV(m)/(N·n_v)` for `m = 0 … ⌊N/2⌋ − 1` (µm², mean square per sample
    /// and feed rate); `f64::INFINITY` where `m` leaves too little of the
    /// ramp outside the series to fit the slope jointly.
    pub mean_square_um2: Vec<f64>,
    /// The `m ≥ 1` with the smallest `CV(m)`.
    pub harmonics: usize,
}

/// One profile's harmonics as `(a_k, b_k)`, `k = 0 … ⌊N/2⌋`, weighted so
/// that `Σ_k w_k·(a_k² + b_k²)` is the mean square of the profile less its
/// mean (`w_k = ½`, or 1 at the Nyquist harmonic).
fn harmonics(samples: &[f64]) -> Vec<(f64, f64)> {
    let n = samples.len();
    let (a, b) = fourier_coefficients(samples, n / 2);
    let mut out = vec![(0.0, 0.0)];
    for (k, (a, b)) in a.into_iter().zip(b).enumerate() {
        let w: f64 = if 2 * (k + 1) == n { 1.0 } else { 0.5 };
        let r = w.sqrt();
        out.push((a * r, b * r));
    }
    out
}

fn dot(u: (f64, f64), v: (f64, f64)) -> f64 {
    u.0 * v.0 + u.1 * v.1
}

/// Leave-one-feed-rate-out cross-validation of the harmonic count for the
/// mean profiles `profiles[j]` (one per feed rate, all on the grid
/// `positions_mm`). Needs at least two profiles of at least 4 samples;
/// returns `None` otherwise.
///
/// ```
/// use volcomp_core::identify::straightness::select::cross_validate;
/// use std::f64::consts::PI;
/// // A steady 3rd harmonic plus, at one feed rate only, a 20th (vibration).
/// let x: Vec<f64> = (0..64).map(|i| i as f64).collect();
/// let geo = |x: f64| (2.0 * PI * 3.0 * x / 64.0).sin();
/// let p: Vec<Vec<f64>> = (0..3)
///     .map(|j| x.iter().map(|&x| geo(x) + if j == 1 { 0.5 * (2.0 * PI * 20.0 * x / 64.0).cos() } else { 0.0 }).collect())
///     .collect();
/// let cv = cross_validate(&p, &x).unwrap();
/// assert!((3..20).contains(&cv.harmonics));
/// ```
pub fn cross_validate(profiles: &[Vec<f64>], positions_mm: &[f64]) -> Option<CrossValidation> {
    let nv = profiles.len();
    let n = positions_mm.len();
    if nv < 2 || n < 4 || profiles.iter().any(|p| p.len() != n) {
        return None;
    }
    let half = n / 2;
    let xm = positions_mm.iter().sum::<f64>() / n as f64;
    let xc: Vec<f64> = positions_mm.iter().map(|x| x - xm).collect();
    let hx = harmonics(&xc);
    let hz: Vec<Vec<(f64, f64)>> = profiles.iter().map(|p| harmonics(p)).collect();
    let total_xx: f64 = hx.iter().map(|&v| dot(v, v)).sum();
    let mut cv = vec![0.0; half];
    // Σ_j Z_jk, so that each fold's mean of the others costs O(N).
    let mut sum = vec![(0.0, 0.0); half + 1];
    for h in &hz {
        for (t, v) in sum.iter_mut().zip(h) {
            t.0 += v.0;
            t.1 += v.1;
        }
    }
    let others = (nv - 1) as f64;
    for z in &hz {
        let w: Vec<(f64, f64)> = sum
            .iter()
            .zip(z)
            .map(|(t, v)| ((t.0 - v.0) / others, (t.1 - v.1) / others))
            .collect();
        // Suffix sums over k > m of ⟨X,X⟩, ⟨X,W⟩, ⟨X,Z⟩, ⟨Z,Z⟩.
        let (mut txx, mut txw, mut txz, mut tzz) = (0.0, 0.0, 0.0, 0.0);
        let mut tail = vec![(0.0, 0.0, 0.0, 0.0); half + 1];
        // tail[m] holds the sums over k > m; k = 0 is excluded throughout.
        for k in (1..=half).rev() {
            txx += dot(hx[k], hx[k]);
            txw += dot(hx[k], w[k]);
            txz += dot(hx[k], z[k]);
            tzz += dot(z[k], z[k]);
            tail[k - 1] = (txx, txw, txz, tzz);
        }
        let mut head = 0.0;
        for (m, slot) in cv.iter_mut().enumerate() {
            if m >= 1 {
                let d = (z[m].0 - w[m].0, z[m].1 - w[m].1);
                head += dot(d, d);
            }
            let (xx, xw, xz, zz) = tail[m];
            if xx <= 1e-9 * total_xx {
                *slot = f64::INFINITY;
                continue;
            }
            let s = xw / xx;
            *slot += head + zz - 2.0 * s * xz + s * s * xx;
        }
    }
    let scale = (nv as f64).recip();
    cv.iter_mut().for_each(|v| *v *= scale);
    let harmonics = (1..half).min_by(|&a, &b| cv[a].total_cmp(&cv[b]))?;
    Some(CrossValidation {
        mean_square_um2: cv,
        harmonics,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// The exact criterion against brute force: refit line + series on the
    /// others, predict the left-out profile, sum the squared error less its
    /// mean.
    #[test]
    #[allow(clippy::needless_range_loop)]
    fn matches_brute_force_refits() {
        let n = 48;
        let x: Vec<f64> = (0..n).map(|i| 3.0 + 0.5 * i as f64).collect();
        let profiles: Vec<Vec<f64>> = (0..3)
            .map(|j| {
                x.iter()
                    .map(|&x| {
                        0.4 * (2.0 * PI * x / 7.3).sin()
                            + 0.01 * x
                            + 0.1 * (j as f64 + 1.0) * (1.7 * x * (j as f64 + 2.0)).cos()
                    })
                    .collect()
            })
            .collect();
        let cv = cross_validate(&profiles, &x).unwrap();
        for m in [1usize, 3, 7, 15] {
            let mut total = 0.0;
            for j in 0..3 {
                let w: Vec<f64> = (0..n)
                    .map(|i| {
                        (0..3)
                            .filter(|&k| k != j)
                            .map(|k| profiles[k][i])
                            .sum::<f64>()
                            / 2.0
                    })
                    .collect();
                // Least squares by normal equations on [1, x, cos, sin …].
                let cols: Vec<Vec<f64>> = std::iter::once(vec![1.0; n])
                    .chain(std::iter::once(x.clone()))
                    .chain((1..=m).flat_map(|k| {
                        let t = |i: usize| 2.0 * PI * k as f64 * i as f64 / n as f64;
                        [
                            (0..n).map(|i| t(i).cos()).collect::<Vec<f64>>(),
                            (0..n).map(|i| t(i).sin()).collect::<Vec<f64>>(),
                        ]
                    }))
                    .collect();
                let p = cols.len();
                let mut a = vec![vec![0.0; p + 1]; p];
                for r in 0..p {
                    for c in 0..p {
                        a[r][c] = (0..n).map(|i| cols[r][i] * cols[c][i]).sum();
                    }
                    a[r][p] = (0..n).map(|i| cols[r][i] * w[i]).sum();
                }
                for c in 0..p {
                    let piv = (c..p)
                        .max_by(|&u, &v| a[u][c].abs().total_cmp(&a[v][c].abs()))
                        .unwrap();
                    a.swap(c, piv);
                    for r in 0..p {
                        if r != c {
                            let f = a[r][c] / a[c][c];
                            for q in c..=p {
                                a[r][q] -= f * a[c][q];
                            }
                        }
                    }
                }
                let coef: Vec<f64> = (0..p).map(|r| a[r][p] / a[r][r]).collect();
                let pred: Vec<f64> = (0..n)
                    .map(|i| (0..p).map(|c| coef[c] * cols[c][i]).sum())
                    .collect();
                let e: Vec<f64> = (0..n).map(|i| profiles[j][i] - pred[i]).collect();
                let mean = e.iter().sum::<f64>() / n as f64;
                total += e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
            }
            let want = total / 3.0;
            assert!(
                (cv.mean_square_um2[m] - want).abs() < 1e-9 * want.max(1e-12),
                "m {m}: {} vs brute force {want}",
                cv.mean_square_um2[m]
            );
        }
    }

    #[test]
    fn refuses_too_little() {
        let x: Vec<f64> = (0..8).map(f64::from).collect();
        assert!(cross_validate(std::slice::from_ref(&x), &x).is_none());
        assert!(cross_validate(&[x.clone(), vec![0.0; 7]], &x).is_none());
    }
}
