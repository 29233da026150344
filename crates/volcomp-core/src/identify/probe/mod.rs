//! Calibrating a machine with a touch probe and the artifacts a shop has
//! (docs/probing.md): a reference sphere, spheres on a plate or a bar,
//! gauge blocks or a step gauge, a square.
//!
//! Flow: artifact description ([`artifact`]) → probing plan and LinuxCNC
//! program ([`plan`], [`program`]) → the machine's log, read by
//! [`crate::io::probe_log`] → probe calibration on the reference sphere and
//! sphere centres from their touches ([`fit`]) → identification of the
//! machine together with the artifact's own errors and its placements
//! ([`identify`]) → the 21-component model file that `compensate` reads,
//! with uncertainties and what the measurements cannot see ([`result`]).
//!
//! The identification is the ball-array method of the thermal study
//! ([`crate::identify::thermal`], [Thermal study]) at one temperature, with
//! the artifact's geometry solved together with the machine from several
//! placements — the multi-position (redundancy, reversal) methods of
//! coordinate metrology [Evans, Hocken & Estler 1996], applied to a ball
//! plate as in [Trapet & Wäldele 1991]; a certificate, where one exists,
//! enters as measured values with their uncertainty ([ISO 15530-3]).

pub mod artifact;
pub mod fit;
pub mod geometry;
pub mod identify;
pub mod monte_carlo;
pub mod plan;
pub mod program;
pub mod request;
pub mod result;
pub mod verify;

pub use crate::error::domain::ProbeError;
