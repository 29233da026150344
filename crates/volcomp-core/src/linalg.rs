//! The crate's one linear-algebra choice: dense matrices and their
//! decompositions from `nalgebra`, behind small crate-internal functions so
//! that the numerical code says what it solves, not how a library spells it,
//! and the choice of library stays in one place.

use nalgebra::DMatrix;

// ---- Dense solves of the B-spline fits (surface::bspline) ------------------

/// A dense matrix of `f64` (column-major, any size).
pub(crate) type Matrix = nalgebra::DMatrix<f64>;

/// Solves `A X = B` for a square `A` by LU decomposition with partial
/// (row) pivoting (Golub & Van Loan, *Matrix Computations*, 4th ed., §3.4).
/// `None` when `A` is not square, the sizes do not match, or a pivot is
/// exactly zero; a nearly singular `A` gives a solution the caller checks
/// (e.g. by its residual).
pub(crate) fn lu_solve(a: &Matrix, b: &Matrix) -> Option<Matrix> {
    if !a.is_square() || a.nrows() != b.nrows() {
        return None;
    }
    a.clone().lu().solve(b)
}

/// The Cholesky factor `A = L Lᵀ` of a symmetric positive definite matrix
/// (Golub & Van Loan, §4.2), for solving normal equations and for the
/// diagonal of their inverse (leave-one-out leverages).
pub(crate) struct Cholesky(nalgebra::Cholesky<f64, nalgebra::Dyn>);

impl Cholesky {
    /// Factors `a` (only its lower triangle is read); `None` when `a` is not
    /// square or not positive definite (a non-positive pivot).
    pub(crate) fn new(a: Matrix) -> Option<Self> {
        if !a.is_square() {
            return None;
        }
        nalgebra::Cholesky::new(a).map(Self)
    }

    /// `X` with `A X = B`.
    pub(crate) fn solve(&self, b: &Matrix) -> Matrix {
        self.0.solve(b)
    }

    /// `A⁻¹`.
    pub(crate) fn inverse(&self) -> Matrix {
        self.0.inverse()
    }
}

#[cfg(test)]
mod bspline_solver_tests {
    use super::*;

    /// `x` is `want` (rows) to 1e-15.
    fn assert_matrix(x: &Matrix, want: [[f64; 2]; 2]) {
        for (r, row) in want.iter().enumerate() {
            for (c, w) in row.iter().enumerate() {
                assert!((x[(r, c)] - w).abs() < 1e-15, "{x}");
            }
        }
    }

    #[test]
    fn lu_solves_a_system_that_needs_pivoting() {
        // [0 1; 2 1] x = [3; 5]: the first pivot is zero without row
        // exchange. By hand: x2 = 3, 2·x1 + 3 = 5 → x1 = 1.
        let a = Matrix::from_row_slice(2, 2, &[0.0, 1.0, 2.0, 1.0]);
        let b = Matrix::from_row_slice(2, 2, &[3.0, 1.0, 5.0, 4.0]);
        let x = lu_solve(&a, &b).unwrap();
        // Second column: x2 = 1, 2·x1 + 1 = 4 → x1 = 1.5.
        assert_matrix(&x, [[1.0, 1.5], [3.0, 1.0]]);
    }

    #[test]
    fn lu_refuses_a_singular_or_mismatched_system() {
        let singular = Matrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 4.0]);
        assert!(lu_solve(&singular, &Matrix::from_element(2, 1, 1.0)).is_none());
        let a = Matrix::identity(2, 2);
        assert!(lu_solve(&a, &Matrix::from_element(3, 1, 1.0)).is_none());
        assert!(lu_solve(&Matrix::zeros(2, 3), &Matrix::zeros(2, 1)).is_none());
    }

    #[test]
    fn cholesky_solves_and_inverts_a_hand_computed_case() {
        // A = [4 2; 2 3]: det 8, A⁻¹ = [3 −2; −2 4] / 8. A x = [2; 1] → x = [0.5, 0].
        let a = Matrix::from_row_slice(2, 2, &[4.0, 2.0, 2.0, 3.0]);
        let c = Cholesky::new(a).unwrap();
        let x = c.solve(&Matrix::from_row_slice(2, 1, &[2.0, 1.0]));
        assert!((x[0] - 0.5).abs() < 1e-15 && x[1].abs() < 1e-15, "{x}");
        assert_matrix(&c.inverse(), [[0.375, -0.25], [-0.25, 0.5]]);
    }

    #[test]
    fn cholesky_refuses_a_matrix_that_is_not_positive_definite() {
        // Eigenvalues 3 and −1.
        let a = Matrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert!(Cholesky::new(a).is_none());
        assert!(Cholesky::new(Matrix::zeros(2, 3)).is_none());
    }
}

// ---- end of the B-spline solves ---------------------------------------------

// ---- identification of thermal models (identify/thermal) ------------------

/// Singular values of `a`, largest first (`min(rows, cols)` of them), or
/// `None` if the iteration does not converge.
pub(crate) fn singular_values(a: &DMatrix<f64>) -> Option<Vec<f64>> {
    let svd = nalgebra::SVD::try_new(a.clone(), false, false, f64::EPSILON, 0)?;
    Some(svd.singular_values.iter().copied().collect())
}

/// Least-squares solution `X` of `A·X ≈ B` (every column of `B` a
/// right-hand side) by Householder QR: `R·X = Qᵀ·B` (Golub & Van Loan,
/// *Matrix Computations*, 4th ed., §5.3.3). `A` must have at least as many
/// rows as columns and full column rank; `None` otherwise or when the row
/// counts differ.
pub(crate) fn least_squares(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let (m, n) = a.shape();
    if m < n || b.nrows() != m {
        return None;
    }
    let qr = a.clone().qr();
    let mut qtb = b.clone();
    qr.q_tr_mul(&mut qtb);
    let r = qr.r();
    let mut x = qtb.rows(0, n).into_owned();
    r.solve_upper_triangular_mut(&mut x).then_some(x)
}

/// Whitening by a covariance `C` (symmetric positive definite): solves
/// `L·X = B` in place, `C = L·Lᵀ` the Cholesky factorisation, so that the
/// rows of `X` have unit covariance when those of `B` have covariance `C`.
/// `None` (and `b` unchanged) if `C` is not positive definite or the sizes
/// differ.
pub(crate) fn whiten(c: &DMatrix<f64>, b: &mut DMatrix<f64>) -> Option<()> {
    if !c.is_square() || c.nrows() != b.nrows() {
        return None;
    }
    let l = nalgebra::Cholesky::new(c.clone())?.unpack();
    let mut x = b.clone();
    if !l.solve_lower_triangular_mut(&mut x) {
        return None;
    }
    *b = x;
    Some(())
}

/// A singular value decomposition `A = U·diag(s)·Vᵀ` with the full right
/// basis: `s` has `min(m, n)` values, largest first, `u` is `m × min(m, n)`,
/// `v` is `n × n` (its columns past the rank span the null space of `A`).
/// Each column of `v` (with its column of `u`) is signed so that its entry
/// of largest magnitude (the first of equal ones) is positive: singular
/// vectors are only defined up to sign, and results built on them (Monte
/// Carlo draws along them) must not depend on the algorithm's choice.
pub(crate) struct Svd {
    /// Left singular vectors (columns).
    pub u: DMatrix<f64>,
    /// Singular values, largest first.
    pub s: Vec<f64>,
    /// Right singular vectors (columns), a complete basis of `ℝⁿ`.
    pub v: DMatrix<f64>,
}

/// The SVD of `a` with a complete right basis ([`Svd`]), or `None` if the
/// iteration does not converge. With fewer rows than columns, `a` is padded
/// with zero rows, which adds zero singular values and leaves `V` a basis of
/// the same row space and null space.
pub(crate) fn svd_full_v(a: &DMatrix<f64>) -> Option<Svd> {
    let (m, n) = a.shape();
    let k = m.min(n);
    let padded = if m < n {
        a.clone().resize_vertically(n, 0.0)
    } else {
        a.clone()
    };
    let svd = nalgebra::SVD::try_new(padded, true, true, f64::EPSILON, 0)?;
    let mut u = svd.u?.rows(0, m).columns(0, k).into_owned();
    let mut v = svd.v_t?.transpose();
    for j in 0..n {
        let col = v.column(j);
        let largest = col.iter().copied().fold(
            0.0f64,
            |best, x| if x.abs() > best.abs() { x } else { best },
        );
        if largest < 0.0 {
            v.column_mut(j).neg_mut();
            if j < k {
                u.column_mut(j).neg_mut();
            }
        }
    }
    let s = svd.singular_values.iter().take(k).copied().collect();
    Some(Svd { u, s, v })
}

#[cfg(test)]
mod thermal_tests {
    use super::*;

    #[test]
    fn singular_values_of_a_scaled_rotation() {
        // [[3, 0], [0, −2], [0, 0]]: singular values 3 and 2, largest first.
        let a = DMatrix::from_row_slice(3, 2, &[0.0, -2.0, 3.0, 0.0, 0.0, 0.0]);
        let s = singular_values(&a).unwrap();
        assert_eq!(s.len(), 2);
        assert!(
            (s[0] - 3.0).abs() < 1e-14 && (s[1] - 2.0).abs() < 1e-14,
            "{s:?}"
        );
    }

    #[test]
    fn least_squares_fits_a_line() {
        // y = 1 + 2x at x = 0, 1, 2 with residuals +0.1, −0.2, +0.1: the
        // normal equations give intercept 1 − 0 and slope 2 exactly (the
        // residuals sum to zero and are orthogonal to x − 1).
        let a = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 1.0, 1.0, 1.0, 2.0]);
        let b = DMatrix::from_row_slice(3, 2, &[1.1, 0.0, 2.8, 1.0, 5.1, 2.0]);
        let x = least_squares(&a, &b).unwrap();
        assert!((x[(0, 0)] - 1.0).abs() < 1e-12, "{x}");
        assert!((x[(1, 0)] - 2.0).abs() < 1e-12, "{x}");
        // Second right-hand side: y = x exactly.
        assert!(
            x[(0, 1)].abs() < 1e-12 && (x[(1, 1)] - 1.0).abs() < 1e-12,
            "{x}"
        );
        assert!(least_squares(&a.transpose(), &b).is_none(), "wide A");
    }

    #[test]
    fn whitening_by_i_plus_ones() {
        // C = [[2, 1], [1, 2]] = L·Lᵀ with L = [[√2, 0], [1/√2, √(3/2)]].
        // L·x = (√2, 1/√2 + √(3/2)) has x = (1, 1).
        let c = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0]);
        let h = 0.5f64.sqrt();
        let mut b = DMatrix::from_column_slice(2, 1, &[2f64.sqrt(), h + 1.5f64.sqrt()]);
        whiten(&c, &mut b).unwrap();
        assert!(
            (b[(0, 0)] - 1.0).abs() < 1e-14 && (b[(1, 0)] - 1.0).abs() < 1e-14,
            "{b}"
        );
        let not_pd = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert!(whiten(&not_pd, &mut b).is_none());
    }

    #[test]
    fn full_right_basis_of_a_wide_matrix() {
        // A = [1, 1, 0]: one singular value √2 along (1, 1, 0)/√2; the
        // null space is spanned by (1, −1, 0)/√2 and (0, 0, 1).
        let a = DMatrix::from_row_slice(1, 3, &[1.0, 1.0, 0.0]);
        let svd = svd_full_v(&a).unwrap();
        assert_eq!(svd.s.len(), 1);
        assert!((svd.s[0] - 2f64.sqrt()).abs() < 1e-14);
        assert_eq!(svd.u.shape(), (1, 1));
        assert_eq!(svd.v.shape(), (3, 3));
        // Signed so that the largest entry is positive: (1, 1, 0)/√2, and
        // U = [1] to match.
        let v0 = svd.v.column(0);
        assert!((v0[0] - 0.5f64.sqrt()).abs() < 1e-14 && v0[2].abs() < 1e-14);
        assert!((svd.u[(0, 0)] - 1.0).abs() < 1e-14);
        for k in 0..3 {
            let col = svd.v.column(k);
            let big = col
                .iter()
                .copied()
                .fold(0.0f64, |b, x| if x.abs() > b.abs() { x } else { b });
            assert!(big > 0.0, "column {k}: {col}");
        }
        // A·v = 0 for the null-space columns, and V is orthonormal.
        for k in 1..3 {
            assert!((&a * svd.v.column(k))[0].abs() < 1e-14);
        }
        let vtv = svd.v.transpose() * &svd.v;
        assert!((vtv - DMatrix::identity(3, 3)).norm() < 1e-14);
        // Reconstruction A = U·s·V₁ᵀ.
        let rebuilt = &svd.u * svd.s[0] * svd.v.column(0).transpose();
        assert!((rebuilt - a).norm() < 1e-14);
    }
}

// ---- end of identify/thermal ----------------------------------------------

// ---- probing (identify/probe) ----------------------------------------------

/// The rotation `R` (as images of the unit vectors) that best turns the
/// centred points `a` onto the centred points `b` (`b ≈ R a`), by the SVD of
/// their covariance (Kabsch 1976; Arun, Huang & Blostein, IEEE PAMI 9(5),
/// 1987), with the reflection case corrected; and the RMS of what is left.
pub(crate) fn kabsch(
    a: &[volcomp_gcode::Vec3],
    b: &[volcomp_gcode::Vec3],
) -> ([volcomp_gcode::Vec3; 3], f64) {
    use nalgebra::{Matrix3, Vector3};
    use volcomp_gcode::Vec3;
    let mut h = Matrix3::<f64>::zeros();
    for (p, q) in a.iter().zip(b) {
        h += Vector3::new(p.x, p.y, p.z) * Vector3::new(q.x, q.y, q.z).transpose();
    }
    let svd = h.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return (
            [
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(0.0, 0.0, 1.0),
            ],
            f64::NAN,
        );
    };
    let v = vt.transpose();
    let d = (v * u.transpose()).determinant().signum();
    let r = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    let cols = [0, 1, 2].map(|k| Vec3::new(r[(0, k)], r[(1, k)], r[(2, k)]));
    let n = a.len().max(1) as f64;
    let rss: f64 = a
        .iter()
        .zip(b)
        .map(|(p, q)| (cols[0] * p.x + cols[1] * p.y + cols[2] * p.z - *q).norm_squared())
        .sum();
    (cols, (rss / n).sqrt())
}

/// What [`pinv_solve`] finds.
pub(crate) struct PinvSolution {
    /// The minimum-norm least-squares solution on the seen subspace.
    pub x: Vec<f64>,
    /// The numerical rank.
    pub rank: usize,
    /// `F` (`n × rank`) with `(AᵀA)⁺ = F Fᵀ`.
    pub f: DMatrix<f64>,
    /// Per column, the squared share of its unit vector in the null space
    /// (0: fully seen, 1: not seen at all).
    pub null_share: Vec<f64>,
}

/// The pseudo-inverse solve of the probe fits: `x` minimising `‖A x − b‖`
/// on the subspace of singular values above `relative · s_max` (by the SVD,
/// Golub & Van Loan §5.5.4), the rank, the covariance factor and each
/// column's share in the null space. `None` if the SVD fails.
pub(crate) fn pinv_solve(a: &DMatrix<f64>, b: &[f64], relative: f64) -> Option<PinvSolution> {
    let svd = svd_full_v(a)?;
    let n = a.ncols();
    let smax = svd.s.first().copied().unwrap_or(0.0);
    let rank = svd
        .s
        .iter()
        .filter(|&&s| s > relative * smax && s > 0.0)
        .count();
    let mut x = vec![0.0; n];
    let mut f = DMatrix::<f64>::zeros(n, rank);
    for k in 0..rank {
        let utb: f64 = (0..a.nrows()).map(|i| svd.u[(i, k)] * b[i]).sum::<f64>() / svd.s[k];
        for j in 0..n {
            x[j] += svd.v[(j, k)] * utb;
            f[(j, k)] = svd.v[(j, k)] / svd.s[k];
        }
    }
    let null_share = (0..n)
        .map(|j| (rank..n).map(|k| svd.v[(j, k)] * svd.v[(j, k)]).sum())
        .collect();
    Some(PinvSolution {
        x,
        rank,
        f,
        null_share,
    })
}

#[cfg(test)]
mod probe_tests {
    use super::*;
    use volcomp_gcode::Vec3;

    #[test]
    fn kabsch_finds_a_quarter_turn() {
        // 90° about Z: (1,0,0) → (0,1,0), (0,1,0) → (−1,0,0).
        let a = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(-1.0, -1.0, 0.0),
        ];
        let b = [
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
        ];
        let (r, rms) = kabsch(&a, &b);
        assert!((r[0] - Vec3::new(0.0, 1.0, 0.0)).norm() < 1e-12, "{r:?}");
        assert!((r[1] - Vec3::new(-1.0, 0.0, 0.0)).norm() < 1e-12);
        assert!((r[2] - Vec3::new(0.0, 0.0, 1.0)).norm() < 1e-12);
        assert!(rms < 1e-12);
    }

    #[test]
    fn pinv_solves_on_the_seen_subspace() {
        // Columns 1 and 2 equal: only their sum is seen; min-norm splits it.
        // [1 1 0; 1 1 1] x = [2; 5]: x3 = 3, x1 + x2 = 2 → (1, 1, 3).
        let a = DMatrix::from_row_slice(2, 3, &[1.0, 1.0, 0.0, 1.0, 1.0, 1.0]);
        let sol = pinv_solve(&a, &[2.0, 5.0], 1e-9).unwrap();
        let (x, rank, f) = (&sol.x, sol.rank, &sol.f);
        assert_eq!(rank, 2);
        // x1 and x2 are half in the null space (1, −1, 0)/√2; x3 not at all.
        assert!((sol.null_share[0] - 0.5).abs() < 1e-12 && sol.null_share[2] < 1e-20);
        for (got, want) in x.iter().zip([1.0, 1.0, 3.0]) {
            assert!((got - want).abs() < 1e-12, "{x:?}");
        }
        // (AᵀA)⁺ by hand: AᵀA = [2 2 1; 2 2 1; 1 1 1]; its pseudo-inverse has
        // entry (3,3) = 2 (the x3 variance with unit noise).
        let c = f * f.transpose();
        assert!((c[(2, 2)] - 2.0).abs() < 1e-9, "{c}");
    }
}

// ---- end of probing -------------------------------------------------------
