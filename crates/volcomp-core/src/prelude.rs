//! What most users of the library need, in one `use volcomp_core::prelude::*;`:
//! loading a model, the set-up, compensating and simulating a program, and
//! the error type.

pub use crate::compensate::MachineSetup;
pub use crate::compensate::{CompensateOptions, CompensateSummary, Compensator, Segmentation};
pub use crate::error::{Error, ErrorKind};
pub use crate::io::{load_model, LoadOptions, LoadedModel};
pub use crate::model::axis_table::AxisTableMap;
pub use crate::model::kinematic::KinematicModel;
pub use crate::model::{Direction, ErrorModel};
pub use crate::simulate::{SimReport, Simulation};
pub use volcomp_geom::{Axis, Vec3};
