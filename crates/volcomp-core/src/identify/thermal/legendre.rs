//! Legendre polynomials on `ξ ∈ [−1, 1]` and the map from an axis range.

/// `P_0(ξ) … P_n(ξ)` by Bonnet's recursion
/// `(k + 1)·P_{k+1} = (2k + 1)·ξ·P_k − k·P_{k−1}`.
///
/// ```
/// use volcomp_core::identify::thermal::legendre::legendre;
/// let p = legendre(3, 0.5);
/// // P2(0.5) = (3·0.25 − 1)/2 = −0.125; P3(0.5) = (5·0.125 − 3·0.5)/2 = −0.4375
/// assert_eq!(p, vec![1.0, 0.5, -0.125, -0.4375]);
/// ```
pub fn legendre(n: usize, xi: f64) -> Vec<f64> {
    let mut p = Vec::with_capacity(n + 1);
    p.push(1.0);
    if n >= 1 {
        p.push(xi);
    }
    for k in 1..n {
        let kf = k as f64;
        let next = ((2.0 * kf + 1.0) * xi * p[k] - kf * p[k - 1]) / (kf + 1.0);
        p.push(next);
    }
    p
}

/// `ξ = (2q − lo − hi)/(hi − lo)`: the axis range `[lo, hi]` (mm) onto `[−1, 1]`.
pub fn to_xi(q_mm: f64, range_mm: [f64; 2]) -> f64 {
    let [lo, hi] = range_mm;
    (2.0 * q_mm - lo - hi) / (hi - lo)
}
