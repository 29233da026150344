//! Straightness error models from measured profiles, with the geometric
//! error separated from vibration in the frequency domain (docs/straightness.md, after the [Straightness study] of docs/references.md; the
//! method and every choice made here are written up in
//! `docs/straightness.md`).
//!
//! # The model
//!
//! The Z deviation caused by planar motion (`e = actual − commanded`, µm):
//!
//! ```text
//! e_z(x, y) = c + e_z(x) + e_z(y) + α_yz·y + β_zx·x
//! ```
//!
//! with the alignment terms `α_yz`, `β_zx` (least-squares slopes of the
//! measured profiles; stored in µrad, `1 µrad·1 mm = 10⁻³ µm`), a constant
//! `c` that makes the model zero-mean over the measured ranges (straightness
//! has no natural zero), and each straightness a Fourier series over the
//! modelling length `l` from `x_st`:
//!
//! ```text
//! e_z(x) = Σ_{k=1..m} a_k·cos(2πk(x − x_st)/l) + b_k·sin(2πk(x − x_st)/l)
//! ```
//!
//! # Identification ([`identify::fit`])
//!
//! Per axis: runs at several feed rates `v_j`, repeated runs averaged per
//! feed rate; each average is detrended, weighted with the taper window
//! ([`spectrum::taper_window`]) and turned into a power spectrum `P_j(λ)`
//! ([`spectrum::power_spectrum`]). Geometric error sits at the same
//! wavelength at every feed rate; vibration of frequency `f` sits at
//! `λ = v_j / f` and moves. With `P̄(λ)` the mean and `σ(λ)` the relative
//! standard deviation across feed rates, the paper's cut-off `λ_c` is the
//! shortest wavelength with `σ(λ) < σ_t` and `P̄(λ) > P_t`, and
//! `m = l / λ_c`. By default `m` is instead chosen by leave-one-feed-rate-out
//! cross-validation ([`select`]), which follows a lead that is no harmonic
//! of `l` further and still rejects vibration.
//!
//! # Use
//!
//! [`StraightnessModel`] implements [`ErrorModel`] (Z only), reads and
//! writes its TOML file (`kind = "straightness"`) and exports a
//! Z-correction table.

pub mod files;
pub mod identify;
pub mod option_error;
pub mod run;
pub mod select;
pub mod spectrum;

pub use crate::model::straightness::*;
