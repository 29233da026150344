//! Thermally varying volumetric error: ball-array artifact calibration,
//! identification of a 21-component model with Legendre-polynomial
//! components, regression of its parameters on temperatures, and
//! uncertainty (equations and formats in `docs/thermal.md`).
//!
//! Flow: per measurement cycle, measured sphere centres
//! ([`artifact::PlacementMeasurement`]) → [`identify::identify`] (least
//! squares by SVD, rank deficiency reported, covariance) → parameters over
//! time → [`regression::Regression`] on temperatures → parameters for a
//! moment → [`poly::PolyModel::to_kinematic_model`] → the model file that
//! `volcomp compensate --map` reads.

pub mod artifact;
pub mod checks;
pub mod files;
pub mod identify;
pub mod legendre;
pub mod poly;
pub mod regression;
pub mod report;
pub mod uncertainty;

/// Something in the thermal workflow cannot be done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ThermalError {
    /// The inputs do not allow the computation; the message says why and what to do.
    #[error("{0}")]
    Invalid(String),
    /// A malformed input file (located).
    #[error(transparent)]
    File(#[from] crate::error::MapFileError),
}
