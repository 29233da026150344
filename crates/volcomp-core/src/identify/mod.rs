//! Identification: error models built from measurements.
//!
//! * [`iso230_2`]: accuracy and repeatability of positioning of one axis from
//!   bidirectional laser runs (ISO 230-2:2014, clause 3).
//! * [`straightness`]: guideway straightness from profiles measured at
//!   several feed rates, vibration separated in the Fourier domain.
//! * [`probe`]: a machine calibrated with a touch probe and the artifacts a
//!   shop has: probing programs, probe calibration, sphere centres, the
//!   21-component or a reduced model with its uncertainty.
//! * [`thermal`]: a thermally varying 21-component model from repeated
//!   ball-array artifact measurements, with uncertainty.
//!
//! Each module turns measurement files (read through [`crate::io`]) into a
//! model that [`crate::model`] evaluates.

pub mod build;
pub mod iso230_2;
pub mod probe;
pub mod straightness;
pub mod thermal;
