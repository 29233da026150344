//! volcomp's core: error models of 3-axis machine tools, the compensation
//! of part programs for them, simulation and metrics, and the models'
//! identification from measurements. Conventions (units, frames, the
//! deviation sign `e = actual − commanded`) are those of `docs/design.md`;
//! bracketed keys are entries of `docs/references.md`.
//!
//! Data flows one way, and the modules follow it: read ([`io`]) → identify
//! ([`identify`]) → model ([`model`]) → compensate ([`compensate`]) →
//! simulate and measure ([`simulate`]); free-form surfaces from probing
//! have their own path ([`surface`]).
//!
//! # Compensating a program
//!
//! ```
//! use volcomp_core::prelude::*;
//! # fn main() -> Result<(), Error> {
//! let map = AxisTableMap::from_csv(
//!     "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
//!      X,both,0,0,0,0\nX,both,100,10,0,0\nY,both,0,0,0,0\n\
//!      Y,both,100,0,0,0\nZ,both,0,0,0,0\nZ,both,100,0,0,0\n",
//!     "map.csv",
//! )?;
//! let program = "G21 G90\nG0 X0 Y10 Z10\nG1 X50 F100\n";
//! let mut out = Vec::new();
//! Compensator::new(&map).run(program.as_bytes(), &mut out)?;
//! // At X50 the machine is 5 µm long: the command is 5 µm short.
//! assert!(String::from_utf8(out).unwrap().contains("X49.995"));
//! # Ok(())
//! # }
//! ```
//!
//! `examples/compensate.rs` loads the bundled map and set-up from files and
//! simulates the program before and after.
//!
//! # Index
//!
//! **Models** ([`model`]): [`model::ErrorModel`] (what compensation and
//! simulation ask of every model: `e(q, s)`), [`model::axis_table::AxisTableMap`]
//! (per-axis forward/reverse error tables, docs/design.md),
//! [`model::kinematic::KinematicModel`] (the 21 component errors of
//! [ISO 230-1] through the axis chain, [`model::topology::Topology`]),
//! [`model::positioning::Positioning`] (positioning tables as controllers
//! hold them), [`model::query`] (components along an axis).
//!
//! **Identification** ([`identify`]): [`identify::iso230_2`] (accuracy and
//! repeatability of positioning, [ISO 230-2] clause 3),
//! [`identify::straightness`] (straightness from profiles at several feed
//! rates, vibration separated by its spectrum, [Straightness study]),
//! [`identify::thermal`] (ball-array artifact, Legendre-polynomial
//! 21-component model, regression on temperatures, uncertainty, [Thermal
//! study]).
//!
//! **Compensation** ([`compensate`]): [`compensate::Compensator`] (a whole
//! program, written back losslessly), [`compensate::solve`] (one point:
//! direct, iterative learning control [Lu & Yeh 2018], exact),
//! [`compensate::CompensateOptions`].
//!
//! **Simulation** ([`simulate`]): [`simulate::Simulation`] (a program on a
//! machine with a model), [`simulate::SimReport`] (point and contour
//! errors, docs/design.md "Simulation and metrics"), [`simulate::nominal`]
//! (pairing with the nominal program).
//!
//! **Surfaces** ([`surface`]): [`surface::bspline`] (B-spline surfaces,
//! [NURBS Book]), [`surface::mirror`] (compensation of a finishing pass from
//! on-machine probing, [Mirror study]).
//!
//! **Files** ([`io`]): [`io::load_model`] (every model file), [`io::table`]
//! (the located CSV reader), [`io::model_file`], [`io::linuxcnc_comp`]
//! (LinuxCNC screw-compensation files), [`io::grid`], [`io::provenance`]
//! (the header of compensated programs), [`io::output`] (safe output).
//!
//! **Errors**: [`Error`] (one enum, one variant per domain, each keeping its
//! cause) and [`ErrorKind`] (bad input, refused program, I/O, internal).
//!
//! # Features
//!
//! * `serde`: `Serialize` for results ([`SimReport`], [`CompensateSummary`], …).
//! * `examples`: the bundled example machine, maps and programs (`example`).
#![warn(missing_docs)]
// Files are read through `volcomp_geom::inputs` only (clippy.toml).
#![cfg_attr(not(test), warn(clippy::disallowed_methods))]

pub mod ballbar;
pub mod compensate;
pub mod error;
#[cfg(any(test, feature = "examples"))]
pub mod example;
pub mod geometry;
pub mod identify;
pub mod io;
pub mod limits;
pub(crate) mod linalg;
pub mod model;
pub mod plan;
pub mod prelude;
pub mod progress;
pub mod report;
pub mod request;
pub mod rng;
pub mod simulate;
pub mod surface;
pub mod text;

pub use compensate::{
    CompensateOptions, CompensateSummary, Compensator, MachineSetup, Segmentation,
};
pub use error::{Error, ErrorKind};
pub use model::axis_table::AxisTableMap;
pub use model::ErrorModel;
pub use simulate::{SimReport, Simulation};
