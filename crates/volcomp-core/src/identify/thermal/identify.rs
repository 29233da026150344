//! Identification of the polynomial parameters from ball-array distances by
//! linear least squares (SVD, [`crate::linalg::svd_full_v`]), with rank-deficiency detection and
//! parameter covariance.
//!
//! Observation of sphere `j` of a placement (see [`super::artifact`]):
//!
//! ```text
//! d_j = |m_j − m_1| − D_j ≈ −u_j·(e(s_j) − e(s_1)) = Σ_i J_ji·θ_i
//! ```
//!
//! Column `i` of `J` is the first-order model with parameter `i` set to one
//! ([`PolyModel::basis_um`]). Within a placement the observations share the
//! noise of sphere 1: with independent probing noise `σ` along `u` their
//! covariance is `σ²(I + 11ᵀ)`, and every placement's block is whitened by
//! the Cholesky factor of `I + 11ᵀ` (generalised least squares).
//!
//! The whitened `J` is column-scaled (µrad parameters by the largest axis
//! span, so that every column is in µm of effect) and decomposed,
//! `J = U·S·Vᵀ`. Singular values below `relative_threshold · s_max` span the
//! combinations the placements cannot see; a parameter is *identifiable*
//! when its unit vector has (squared) less than [`NULL_TOLERANCE`] of its
//! length in that null space. Only identifiable parameters get a value and
//! an uncertainty; the others are `None`.

use super::artifact::{observations, BallArray, PlacementMeasurement};
use super::poly::PolyModel;
use super::ThermalError;
use crate::linalg;
use nalgebra::DMatrix;
use volcomp_gcode::Vec3;

/// Default relative singular-value threshold (of the largest, after column
/// scaling): condition numbers above 1000 count as rank loss.
pub const DEFAULT_RELATIVE_THRESHOLD: f64 = 1e-3;

/// Largest squared share of a parameter's unit vector in the null space for
/// which it still counts as identifiable.
pub const NULL_TOLERANCE: f64 = 1e-6;

/// The result of one identification.
#[derive(Debug, Clone, PartialEq)]
pub struct Identification {
    /// Estimated parameters (µm / µrad), `None` where not identifiable.
    pub theta: Vec<Option<f64>>,
    /// Standard uncertainty of each estimate, `None` where not identifiable.
    pub sigma: Vec<Option<f64>>,
    /// Numerical rank of the scaled Jacobian.
    pub rank: usize,
    /// Singular values of the scaled, whitened Jacobian, largest first.
    pub singular_values: Vec<f64>,
    /// The unobservable combinations: for each null-space vector, its
    /// entries above 0.05 in magnitude as `(parameter index, weight)` in
    /// scaled units.
    pub null_space: Vec<Vec<(usize, f64)>>,
    /// Estimated probing noise σ (µm per coordinate along the array) from the
    /// whitened residuals; `None` without redundancy.
    pub sigma0_um: Option<f64>,
    /// Observations minus model (µm), unwhitened, in input order.
    pub residuals_um: Vec<f64>,
    /// Number of observations.
    pub observations: usize,
    /// `F` (row per parameter, column per identifiable direction) with
    /// `cov(θ) = F·Fᵀ` on the identifiable subspace; for Monte Carlo.
    pub cov_factor: Vec<Vec<f64>>,
}

impl Identification {
    /// Indices of the identifiable parameters.
    pub fn identifiable(&self) -> Vec<usize> {
        (0..self.theta.len())
            .filter(|&i| self.theta[i].is_some())
            .collect()
    }
}

/// The Jacobian rows and observations of a set of measured placements (not
/// whitened): `(rows, y, block sizes)`.
pub fn design(
    model: &PolyModel,
    array: &BallArray,
    measurements: &[PlacementMeasurement],
    probe_offset_mm: Vec3,
) -> (Vec<Vec<f64>>, Vec<f64>, Vec<usize>) {
    let mut rows = Vec::new();
    let mut y = Vec::new();
    let mut blocks = Vec::new();
    for m in measurements {
        let obs = observations(array, m);
        if obs.is_empty() {
            continue;
        }
        // The Jacobian is evaluated on the ideal line through the measured
        // sphere 1 towards the measured last sphere, at the calibrated
        // distances: the µm scatter of the measured centres must not leak
        // into the columns of parameters the line cannot see.
        let c = &m.centres_mm;
        let last = c.len().min(array.len()) - 1;
        let dir = c[last] - c[0];
        let u = dir * (1.0 / dir.norm());
        let b1 = model.basis_um(c[0], probe_offset_mm);
        for (j, (d, _)) in obs.iter().enumerate() {
            let p = c[0] + u * array.distances_mm[j + 1];
            let bj = model.basis_um(p, probe_offset_mm);
            rows.push(bj.iter().zip(&b1).map(|(a, b)| -u.dot(*a - *b)).collect());
            y.push(*d);
        }
        blocks.push(obs.len());
    }
    (rows, y, blocks)
}

/// Identifies the parameters from one cycle's measured placements.
pub fn identify(
    model: &PolyModel,
    array: &BallArray,
    measurements: &[PlacementMeasurement],
    probe_offset_mm: Vec3,
    relative_threshold: f64,
) -> Result<Identification, ThermalError> {
    let (rows, y, blocks) = design(model, array, measurements, probe_offset_mm);
    let m = rows.len();
    let n = model.len();
    if m == 0 {
        return Err(ThermalError::Invalid(
            "no distance observations: every placement needs at least two spheres".into(),
        ));
    }
    if y.iter().any(|v| !v.is_finite()) || rows.iter().flatten().any(|v| !v.is_finite()) {
        return Err(ThermalError::Invalid(
            "a measured distance is not finite (two sphere centres coincide?)".into(),
        ));
    }
    // Whitening per placement block: solve L·w = block, L·Lᵀ = I + 11ᵀ.
    let mut a = DMatrix::<f64>::from_fn(m, n + 1, |i, j| if j < n { rows[i][j] } else { y[i] });
    let mut start = 0;
    for &len in &blocks {
        let c = DMatrix::<f64>::from_fn(len, len, |i, j| if i == j { 2.0 } else { 1.0 });
        let mut block = a.rows(start, len).into_owned();
        linalg::whiten(&c, &mut block)
            .ok_or_else(|| ThermalError::Invalid("whitening failed".into()))?;
        a.rows_mut(start, len).copy_from(&block);
        start += len;
    }
    let solved = solve_whitened(model, &a, relative_threshold, 0)?;
    let residuals_um = rows
        .iter()
        .zip(&y)
        .map(|(r, yi)| {
            yi - r
                .iter()
                .zip(&solved.theta_all)
                .map(|(a, b)| a * b)
                .sum::<f64>()
        })
        .collect();
    Ok(Identification {
        residuals_um,
        ..solved.ident
    })
}

/// A whitened least-squares solve and its full minimum-norm vector.
pub(crate) struct Solved {
    /// The identification (its `residuals_um` empty: the caller has the
    /// unwhitened rows).
    pub ident: Identification,
    /// The minimum-norm solution, unidentifiable parameters included
    /// (for the caller's residuals).
    pub theta_all: Vec<f64>,
}

/// The solve of [`identify`] on a whitened system `a = [J | y]` (`m × (n +
/// 1)`, `n` the model's parameters): column scaling, SVD, rank, minimum-norm
/// solution on the identifiable subspace, σ0 from the whitened residuals
/// with `eliminated` further degrees of freedom used up by parameters the
/// caller has already projected out of `a` (nuisance parameters), null
/// space and covariance factor.
pub(crate) fn solve_whitened(
    model: &PolyModel,
    a: &DMatrix<f64>,
    relative_threshold: f64,
    eliminated: usize,
) -> Result<Solved, ThermalError> {
    solve_whitened_with_design(model, a, None, relative_threshold, eliminated)
}

/// [`solve_whitened`], with the rank and the null space decided on
/// `design` (the same `J` with other row weights, `m' × n`) when given: what
/// the measurements can see is a property of where they were taken, not of
/// how precise each kind of row is relative to another. The solution,
/// σ0 and the covariance are those of `a` restricted to the subspace
/// `design` sees (`θ = V_k β`, `β` the least squares of `J V_k β ≈ y`), the
/// singular values reported are `design`'s.
pub(crate) fn solve_whitened_with_design(
    model: &PolyModel,
    a: &DMatrix<f64>,
    design: Option<&DMatrix<f64>>,
    relative_threshold: f64,
    eliminated: usize,
) -> Result<Solved, ThermalError> {
    let (m, n) = (a.nrows(), model.len());
    // Column scaling by physics, not by column norm (a norm would blow up
    // columns that are zero up to rounding): µm parameters as they are,
    // µrad parameters times the largest axis span (µm per µrad at that arm).
    let span_mm = model
        .ranges_mm
        .iter()
        .map(|r| r[1] - r[0])
        .fold(0.0, f64::max);
    let scale: Vec<f64> = model
        .params
        .iter()
        .map(|p| {
            if p.unit() == "um" {
                1.0
            } else {
                span_mm * 1e-3
            }
        })
        .collect();
    let js = DMatrix::<f64>::from_fn(m, n, |i, j| a[(i, j)] / scale[j]);
    let no_svd = || ThermalError::Invalid("the SVD did not converge".into());
    let svd = match design {
        None => linalg::svd_full_v(&js),
        Some(d) => linalg::svd_full_v(&DMatrix::<f64>::from_fn(d.nrows(), n, |i, j| {
            d[(i, j)] / scale[j]
        })),
    }
    .ok_or_else(no_svd)?;
    let (s, v) = (&svd.s, &svd.v);
    let singular_values: Vec<f64> = s.clone();
    let smax = singular_values.first().copied().unwrap_or(0.0);
    let rank = singular_values
        .iter()
        .filter(|&&x| x > relative_threshold * smax && x > 0.0)
        .count();
    // Min-norm solution on the identifiable subspace (scaled): directions
    // `D` (columns), their singular values `σ` and left vectors `U`, so that
    // `θ = D σ⁻¹ Uᵀ y` and `(JᵀJ)⁺ = D σ⁻² Dᵀ` there.
    let (u, dirs, sv) = match design {
        None => (
            svd.u.columns(0, rank).into_owned(),
            v.columns(0, rank).into_owned(),
            s[..rank].to_vec(),
        ),
        Some(_) => {
            let vk = v.columns(0, rank).into_owned();
            let inner = linalg::svd_full_v(&(&js * &vk)).ok_or_else(no_svd)?;
            if inner.s.len() < rank || inner.s.iter().any(|&x| x.is_nan() || x <= 0.0) {
                return Err(ThermalError::Invalid(
                    "the rows do not see what their design sees".into(),
                ));
            }
            (inner.u, vk * inner.v, inner.s)
        }
    };
    let mut sol = vec![0.0; n];
    for k in 0..rank {
        let uty: f64 = (0..m).map(|i| u[(i, k)] * a[(i, n)]).sum::<f64>() / sv[k];
        for (j, x) in sol.iter_mut().enumerate() {
            *x += dirs[(j, k)] * uty;
        }
    }
    // Residuals (whitened for σ0, unwhitened for reporting).
    let mut rss = 0.0;
    for i in 0..m {
        let fit: f64 = (0..n).map(|j| js[(i, j)] * sol[j]).sum();
        rss += (a[(i, n)] - fit).powi(2);
    }
    let dof = m.saturating_sub(rank + eliminated);
    let sigma0_um = (dof > 0).then(|| (rss / dof as f64).sqrt());
    let theta_scaled: Vec<f64> = (0..n).map(|j| sol[j] / scale[j]).collect();
    // Null space and identifiability.
    let null_share: Vec<f64> = (0..n)
        .map(|j| (rank..n).map(|k| v[(j, k)] * v[(j, k)]).sum())
        .collect();
    let null_space = (rank..n)
        .map(|k| {
            (0..n)
                .filter(|&j| v[(j, k)].abs() > 0.05)
                .map(|j| (j, v[(j, k)]))
                .collect()
        })
        .collect();
    let sig0 = sigma0_um.unwrap_or(f64::NAN);
    let cov_factor: Vec<Vec<f64>> = (0..n)
        .map(|j| {
            (0..rank)
                .map(|k| sig0 * dirs[(j, k)] / (sv[k] * scale[j]))
                .collect()
        })
        .collect();
    let mut theta = vec![None; n];
    let mut sigma = vec![None; n];
    for j in 0..n {
        if null_share[j] < NULL_TOLERANCE {
            theta[j] = Some(theta_scaled[j]);
            let var: f64 = cov_factor[j].iter().map(|f| f * f).sum();
            sigma[j] = sigma0_um.map(|_| var.sqrt());
        }
    }
    Ok(Solved {
        theta_all: theta_scaled,
        ident: Identification {
            theta,
            sigma,
            rank,
            singular_values,
            null_space,
            sigma0_um,
            residuals_um: Vec::new(),
            observations: m,
            cov_factor,
        },
    })
}
