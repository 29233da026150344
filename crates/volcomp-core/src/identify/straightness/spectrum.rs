//! Signal processing of one evenly sampled profile: least-squares line,
//! taper window, power spectrum over wavelength and Fourier coefficients.
//!
//! A profile is `z_i = z(x_st + i·Δx)`, `i = 0 … N−1`. Its modelling length
//! is `l = N·Δx` (the period of the discrete Fourier basis, one sample
//! longer than the measured span), so harmonic `k` has the wavelength
//! `λ_k = l / k`, `k = 1 … ⌊N/2⌋`. The FFT is `realfft`'s.

use realfft::num_complex::Complex;
use realfft::RealFftPlanner;

/// Number of samples in each raised-cosine end of the taper window:
/// `N_t = round(fraction · N)`, at most `N/2`.
///
/// ```
/// use volcomp_core::identify::straightness::spectrum::taper_samples;
/// assert_eq!(taper_samples(2001, 0.1), 200);
/// assert_eq!(taper_samples(10, 0.9), 5);
/// ```
pub fn taper_samples(n: usize, fraction: f64) -> usize {
    let t = (fraction.max(0.0) * n as f64).round() as usize;
    t.min(n / 2)
}

/// The taper window `f(i)` of the method: a raised cosine over the first and
/// the last `n_taper` samples, 1 in between.
///
/// ```text
/// f(i) = ½·(1 − cos(π·i / N_t))             0 ≤ i < N_t
/// f(i) = 1                                  N_t ≤ i ≤ N−1−N_t
/// f(i) = f(N−1−i)                           N−N_t < i ≤ N−1
/// ```
///
/// `f(0) = f(N−1) = 0` and the window rises continuously to 1 at `i = N_t`
/// (a Tukey window). `n_taper = 0` gives the rectangular window.
///
/// ```
/// use volcomp_core::identify::straightness::spectrum::taper_window;
/// let w = taper_window(10, 2);
/// let expected = [0.0, 0.5, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.5, 0.0];
/// assert!(w.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-15));
/// ```
pub fn taper_window(n: usize, n_taper: usize) -> Vec<f64> {
    let t = n_taper.min(n / 2);
    (0..n)
        .map(|i| {
            let j = i.min(n - 1 - i);
            if j < t {
                0.5 * (1.0 - (std::f64::consts::PI * j as f64 / t as f64).cos())
            } else {
                1.0
            }
        })
        .collect()
}

/// Least-squares line `z ≈ c + s·x` through `(x_i, z_i)`: returns `(c, s)`
/// with `s` in (unit of z) per (unit of x). Solved about the mean of `x`,
/// so the 2×2 normal equations are diagonal and well conditioned.
///
/// ```
/// use volcomp_core::identify::straightness::spectrum::least_squares_line;
/// let (c, s) = least_squares_line(&[0.0, 1.0, 2.0], &[1.0, 3.0, 5.0]);
/// assert!((c - 1.0).abs() < 1e-12 && (s - 2.0).abs() < 1e-12);
/// ```
pub fn least_squares_line(x: &[f64], z: &[f64]) -> (f64, f64) {
    let n = x.len().min(z.len());
    if n == 0 {
        return (0.0, 0.0);
    }
    let xm = x[..n].iter().sum::<f64>() / n as f64;
    let zm = z[..n].iter().sum::<f64>() / n as f64;
    let (mut sxz, mut sxx) = (0.0, 0.0);
    for i in 0..n {
        let dx = x[i] - xm;
        sxz += dx * (z[i] - zm);
        sxx += dx * dx;
    }
    let s = if sxx > 0.0 { sxz / sxx } else { 0.0 };
    (zm - s * xm, s)
}

fn dft(samples: &[f64]) -> Vec<Complex<f64>> {
    let n = samples.len();
    let mut planner = RealFftPlanner::<f64>::new();
    let r2c = planner.plan_fft_forward(n);
    let mut input = samples.to_vec();
    let mut output = r2c.make_output_vec();
    // Lengths come from the plan itself, so the transform cannot fail.
    if r2c.process(&mut input, &mut output).is_err() {
        output.iter_mut().for_each(|c| *c = Complex::new(0.0, 0.0));
    }
    output
}

/// One-sided power spectrum of `samples` weighted by `window`, in the
/// squared unit of the samples (µm² for a profile in µm), at harmonics
/// `k = 0 … ⌊N/2⌋` (`λ_k = N·Δx / k`).
///
/// ```text
/// X_k = Σ_i f(i)·z_i·exp(−2πj·k·i/N)
/// P_k = c_k·|X_k|² / (N² · mean(f²)),   c_k = 2 for 0 < k < N/2, else 1
/// ```
///
/// Dividing by `mean(f²)` makes the spectrum of a stationary signal
/// independent of the window; Parseval then reads
/// `Σ_k P_k = mean((f·z)²) / mean(f²)`, and `Σ_k P_k = mean(z²)` for the
/// rectangular window. A sine of amplitude `A` on harmonic `k` gives
/// `P_k = A²/2`, its mean square.
///
/// `window` must have the length of `samples`; at least two samples.
///
/// ```
/// use volcomp_core::identify::straightness::spectrum::power_spectrum;
/// let z: Vec<f64> = (0..64).map(|i| 2.0 * (2.0 * std::f64::consts::PI * 4.0 * i as f64 / 64.0).sin()).collect();
/// let p = power_spectrum(&z, &vec![1.0; 64]);
/// assert!((p[4] - 2.0).abs() < 1e-12); // A²/2 at k = 4, λ = l/4
/// ```
pub fn power_spectrum(samples: &[f64], window: &[f64]) -> Vec<f64> {
    assert_eq!(
        samples.len(),
        window.len(),
        "power_spectrum: window and samples differ in length"
    );
    let n = samples.len();
    if n < 2 {
        return vec![0.0; n / 2 + 1];
    }
    let weighted: Vec<f64> = samples.iter().zip(window).map(|(z, f)| z * f).collect();
    let w2 = window.iter().map(|f| f * f).sum::<f64>() / n as f64;
    let norm = (n as f64).powi(2) * if w2 > 0.0 { w2 } else { 1.0 };
    dft(&weighted)
        .iter()
        .enumerate()
        .map(|(k, x)| {
            let c = if k == 0 || 2 * k == n { 1.0 } else { 2.0 };
            c * x.norm_sqr() / norm
        })
        .collect()
}

/// Fourier coefficients `(a_k, b_k)`, `k = 1 … m`, of the samples on the
/// discrete basis of period `N` samples: the least-squares fit of
/// `Σ a_k·cos(2πk·i/N) + b_k·sin(2πk·i/N)` (the basis is orthogonal on the
/// samples, so least squares and the DFT agree):
///
/// ```text
/// a_k = (2/N)·Re X_k,   b_k = −(2/N)·Im X_k     (0 < k < N/2)
/// a_k = (1/N)·Re X_k,   b_k = 0                 (k = N/2)
/// ```
///
/// `m` is limited to `⌊N/2⌋`.
pub fn fourier_coefficients(samples: &[f64], m: usize) -> (Vec<f64>, Vec<f64>) {
    let n = samples.len();
    if n < 2 {
        return (Vec::new(), Vec::new());
    }
    let m = m.min(n / 2);
    let x = dft(samples);
    let nf = n as f64;
    (1..=m)
        .map(|k| {
            if 2 * k == n {
                (x[k].re / nf, 0.0)
            } else {
                (2.0 * x[k].re / nf, -2.0 * x[k].im / nf)
            }
        })
        .unzip()
}

pub use crate::model::straightness::fourier_sum;

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Deterministic pseudo-random numbers in (−1, 1).
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = crate::rng::Rng::new(seed);
        (0..n).map(|_| 2.0 * rng.uniform() - 1.0).collect()
    }

    #[test]
    fn taper_window_shape() {
        let n = 101;
        let t = taper_samples(n, 0.1);
        assert_eq!(t, 10);
        let w = taper_window(n, t);
        assert_eq!(w.len(), n);
        assert_eq!(w[0], 0.0);
        assert_eq!(w[n - 1], 0.0);
        for i in 0..n {
            assert!((w[i] - w[n - 1 - i]).abs() < 1e-15, "symmetric at {i}");
            assert!((0.0..=1.0).contains(&w[i]));
        }
        for i in 1..t {
            assert!(w[i] > w[i - 1], "rising in the taper at {i}");
            let expected = 0.5 * (1.0 - (PI * i as f64 / t as f64).cos());
            assert!((w[i] - expected).abs() < 1e-15);
        }
        assert!((w[t / 2] - 0.5).abs() < 1e-12, "half-way up at N_t/2");
        assert!(w[t..=n - 1 - t].iter().all(|&v| v == 1.0));
        // No taper: rectangular; too much taper: capped at N/2 per end.
        assert!(taper_window(8, 0).iter().all(|&v| v == 1.0));
        assert_eq!(taper_samples(8, 0.5), 4);
        assert_eq!(taper_samples(8, 0.0), 0);
    }

    #[test]
    fn parseval_rectangular_and_tapered() {
        for n in [64usize, 101, 2001] {
            let z = noise(n, n as u64);
            let ms = z.iter().map(|v| v * v).sum::<f64>() / n as f64;
            let p = power_spectrum(&z, &vec![1.0; n]);
            assert_eq!(p.len(), n / 2 + 1);
            let total: f64 = p.iter().sum();
            assert!(
                (total - ms).abs() < 1e-12 * ms.max(1.0),
                "n={n}: Σ P = {total}, mean square = {ms}"
            );
            let w = taper_window(n, taper_samples(n, 0.1));
            let w2 = w.iter().map(|f| f * f).sum::<f64>() / n as f64;
            let wms = z.iter().zip(&w).map(|(a, f)| (a * f).powi(2)).sum::<f64>() / n as f64;
            let total: f64 = power_spectrum(&z, &w).iter().sum();
            assert!((total - wms / w2).abs() < 1e-12 * ms.max(1.0));
        }
    }

    #[test]
    fn pure_sine_peaks_at_its_wavelength() {
        // 400 samples every 0.5 mm: l = 200 mm. A 12.5 mm wavelength is
        // harmonic 16 exactly; 7.3 mm falls between bins 27 and 28.
        let (n, dx) = (400usize, 0.5);
        let l = n as f64 * dx;
        for (lambda, amp) in [(12.5, 0.8), (7.3, 1.3)] {
            let z: Vec<f64> = (0..n)
                .map(|i| amp * (2.0 * PI * i as f64 * dx / lambda + 0.4).sin())
                .collect();
            for taper in [0.0, 0.1] {
                let w = taper_window(n, taper_samples(n, taper));
                let p = power_spectrum(&z, &w);
                let k_peak = (1..p.len()).max_by(|&i, &j| p[i].total_cmp(&p[j])).unwrap();
                let k_true = l / lambda;
                assert!(
                    (k_peak as f64 - k_true).abs() <= 0.5,
                    "λ={lambda}: peak at k={k_peak} (λ={}), expected k≈{k_true}",
                    l / k_peak as f64
                );
                if lambda == 12.5 && taper == 0.0 {
                    assert!((p[16] - amp * amp / 2.0).abs() < 1e-12);
                    let rest: f64 = p.iter().sum::<f64>() - p[16];
                    assert!(rest < 1e-20);
                }
                if lambda == 12.5 {
                    // Tapered: the raised-cosine ends (length N_t = 40) spread
                    // the line over about ±N/N_t = ±10 harmonics, no further.
                    let near: f64 = p[6..=26].iter().sum();
                    assert!(near > 0.999 * p.iter().sum::<f64>());
                }
            }
        }
    }

    #[test]
    fn taper_reduces_leakage_of_an_off_bin_line() {
        // A line between bins leaks far into the spectrum with the
        // rectangular window (1/k² fall-off); the taper confines it.
        let (n, dx, lambda) = (512usize, 1.0, 30.7);
        let z: Vec<f64> = (0..n)
            .map(|i| (2.0 * PI * i as f64 * dx / lambda).sin())
            .collect();
        let far = |p: &[f64]| p[60..].iter().sum::<f64>() / p.iter().sum::<f64>();
        let rect = far(&power_spectrum(&z, &vec![1.0; n]));
        let tuk = far(&power_spectrum(&z, &taper_window(n, taper_samples(n, 0.1))));
        assert!(
            tuk < rect / 10.0,
            "leakage: rectangular {rect}, taper {tuk}"
        );
    }

    #[test]
    fn coefficients_reconstruct_band_limited_profile() {
        let n = 300;
        let z: Vec<f64> = (0..n)
            .map(|i| {
                let t = 2.0 * PI * i as f64 / n as f64;
                0.3 * (t).cos() - 0.7 * (3.0 * t).sin() + 0.1 * (7.0 * t).cos()
            })
            .collect();
        let (a, b) = fourier_coefficients(&z, 10);
        assert!((a[0] - 0.3).abs() < 1e-12 && b[0].abs() < 1e-12);
        assert!((b[2] + 0.7).abs() < 1e-12 && a[2].abs() < 1e-12);
        assert!((a[6] - 0.1).abs() < 1e-12);
        for (i, zi) in z.iter().enumerate() {
            let v = fourier_sum(&a, &b, 2.0 * PI * i as f64 / n as f64);
            assert!((v - zi).abs() < 1e-12);
        }
        // Nyquist harmonic of an even length.
        let alt: Vec<f64> = (0..8)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let (a, b) = fourier_coefficients(&alt, 10);
        assert_eq!(a.len(), 4);
        assert!((a[3] - 1.0).abs() < 1e-12 && b[3] == 0.0);
    }

    #[test]
    fn fourier_sum_matches_direct_evaluation() {
        let a = noise(200, 3);
        let b = noise(200, 4);
        for theta in [0.0, 0.1, 1.7, -2.5, 6.2] {
            let direct: f64 = (0..200)
                .map(|k| {
                    let kt = (k + 1) as f64 * theta;
                    a[k] * kt.cos() + b[k] * kt.sin()
                })
                .sum();
            assert!((fourier_sum(&a, &b, theta) - direct).abs() < 1e-11);
        }
    }

    #[test]
    fn least_squares_line_of_noisy_line() {
        let x: Vec<f64> = (0..50).map(|i| 100.0 + i as f64).collect();
        let z: Vec<f64> = x.iter().map(|x| 3.0 - 0.25 * x).collect();
        let (c, s) = least_squares_line(&x, &z);
        assert!((c - 3.0).abs() < 1e-10 && (s + 0.25).abs() < 1e-12);
        assert_eq!(least_squares_line(&[1.0], &[2.0]), (2.0, 0.0));
    }
}
