//! volcomp's core: error models, compensation of part programs, simulation
//! and metrics. Data flows one way, and the modules follow it:
//!
//! read ([`io`]) → identify ([`identify`]) → model ([`model`]) →
//! compensate ([`compensate`]) → simulate and measure ([`simulate`]);
//! free-form surfaces from probing have their own path ([`surface`]).
#![warn(missing_docs)]

pub mod compensate;
pub mod error;
#[cfg(any(test, feature = "examples"))]
pub mod example;
pub mod identify;
pub mod io;
pub mod limits;
pub(crate) mod linalg;
pub mod model;
pub mod rng;
pub mod simulate;
pub mod surface;

pub use compensate::{
    CompensateOptions, CompensateSummary, Compensator, MachineSetup, Segmentation,
};
pub use error::{Error, ErrorKind};
pub use model::axis_table::AxisTableMap;
pub use model::ErrorModel;
pub use simulate::{SimReport, Simulation};
