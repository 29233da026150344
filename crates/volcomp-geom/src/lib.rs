//! The bottom layer of volcomp: the geometric vocabulary every other crate
//! speaks.
//!
//! volcomp is layered like truck's geometry crates: each layer depends only
//! on the ones below it.
//!
//! | layer | crate | what it holds |
//! | --- | --- | --- |
//! | vocabulary | `volcomp-geom` (this crate) | [`Vec3`] points and vectors in mm, the typed machine [`Axis`], the one door every file is read through ([`inputs`]) |
//! | programs | `volcomp-gcode` | lossless G-code reading and writing, the modal RS274/NGC interpreter |
//! | models | `volcomp-core` | error models, identification, compensation, simulation, file formats |
//! | front end | `volcomp-cli` | the `volcomp` command |
//!
//! It has no dependency but `serde`, so a model or a program can share a
//! point or name an axis without pulling in a G-code interpreter or a
//! linear-algebra library. `volcomp-gcode` re-exports both types, so
//! `volcomp_gcode::Vec3` and `volcomp_geom::Vec3` are the same type.
//!
//! ```
//! use volcomp_geom::{Axis, Vec3};
//! let mut p = Vec3::new(1.0, 2.0, 3.0);
//! p[Axis::Z] += 0.5;
//! assert_eq!(p.get(Axis::Z), 3.5);
//! assert_eq!("y".parse::<Axis>(), Ok(Axis::Y));
//! ```
#![warn(missing_docs)]
// Files are read through `volcomp_geom::inputs` only (clippy.toml).
#![cfg_attr(not(test), warn(clippy::disallowed_methods))]

mod axis;
pub mod inputs;
mod vec3;

pub use axis::{Axis, ParseAxisError};
pub use vec3::Vec3;
