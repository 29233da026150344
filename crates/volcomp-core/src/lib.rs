//! volcomp's core: error models, compensation of part programs, simulation
//! and metrics. Data flows one way: an [`model::ErrorModel`] (e.g.
//! [`axis_table::AxisTableMap`]) → [`solve`] (one point) →
//! [`compensate`] (a whole program, written back through the G-code engine)
//! → [`simulate`] (actual tool path and the metrics of docs/design.md,
//! "Simulation and metrics").
#![warn(missing_docs)]

pub mod axis_table;
pub mod bspline;
pub mod compensate;
pub mod error;
pub mod example;
pub mod io;
pub mod iso230_2;
pub mod kinematic;
pub mod kinematic_example;
pub mod limits;
pub mod linuxcnc_comp;
pub mod mirror;
pub mod model;
pub mod model_file;
pub mod nominal;
pub mod numfmt;
pub mod output;
pub mod provenance;
pub mod report;
pub mod simulate;
pub mod solve;
pub mod straightness;
pub mod thermal;
pub mod topology;
