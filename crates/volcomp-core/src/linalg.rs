//! The crate's one linear-algebra choice: dense matrices and their solvers
//! from `nalgebra`, behind small functions so that the numerical code says
//! what it solves, not how a library spells it. Internal (`pub(crate)`).

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

    #[test]
    fn lu_solves_a_system_that_needs_pivoting() {
        // [0 1; 2 1] x = [3; 5]: the first pivot is zero without row
        // exchange. By hand: x2 = 3, 2·x1 + 3 = 5 → x1 = 1.
        let a = Matrix::from_row_slice(2, 2, &[0.0, 1.0, 2.0, 1.0]);
        let b = Matrix::from_row_slice(2, 2, &[3.0, 1.0, 5.0, 4.0]);
        let x = lu_solve(&a, &b).unwrap();
        // Second column: x2 = 1, 2·x1 + 1 = 4 → x1 = 1.5.
        let want = [[1.0, 1.5], [3.0, 1.0]];
        for (r, row) in want.iter().enumerate() {
            for (c, w) in row.iter().enumerate() {
                assert!((x[(r, c)] - w).abs() < 1e-15, "{x}");
            }
        }
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
        let inv = c.inverse();
        let want = [[0.375, -0.25], [-0.25, 0.5]];
        for (r, row) in want.iter().enumerate() {
            for (col, w) in row.iter().enumerate() {
                assert!((inv[(r, col)] - w).abs() < 1e-15, "{inv}");
            }
        }
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
