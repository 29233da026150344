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
//! Dense linear systems are solved through the crate's one linear-algebra
//! module (nalgebra).
//!
//! Where each part lives: `basis` (knot vectors, A2.1–A2.3, eq. 9.8),
//! `eval` (construction, A3.5, A3.6, normals and curvatures), `fit` (A9.3,
//! A9.4, §9.4), `inversion` (§6.1 and the sample index), and the tests
//! (`tests`: closed forms; `curvo_oracle`: an independent implementation).

mod basis;
#[cfg(test)]
mod curvo_oracle;
mod eval;
mod fit;
mod inversion;
#[cfg(test)]
mod tests;

pub use basis::{averaged_knots, basis_funs, ders_basis_funs, find_span, uniform_knots};
pub use eval::{cross3, Curvatures};
pub use fit::{fit_least_squares, interpolate, mesh_params, LeastSquaresFit, Parameterization};
pub use inversion::{ClosestPoint, ProjectionIndex};

/// Highest supported degree in each direction.
pub const MAX_DEGREE: usize = 7;
const MAX_ORDER: usize = MAX_DEGREE + 1;
/// Highest derivative order the evaluators return.
pub const MAX_DERIVATIVE: usize = 2;

pub use crate::error::domain::BSplineError;

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
