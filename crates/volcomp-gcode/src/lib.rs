//! The volcomp G-code engine: a lossless, byte-based reader/writer and a modal
//! RS274/NGC interpreter whose motions are checked against LinuxCNC's `rs274`.
//!
//! Data flows one way: bytes → [`lexer`] (zero-copy tokens) → [`interp`]
//! (motions in the axis frame) → consumers. Rewriting goes through
//! [`edit`]: byte-range edits spliced into the original line, so whatever is
//! not edited is kept byte for byte.
//!
//! It sits on `volcomp-geom` (points and axes, re-exported here as [`Vec3`]
//! and [`Axis`]) and below the models of `volcomp-core`. Every refusal is a
//! [`GcodeError`]: a located [`Diagnostic`] (file, line, column, the line
//! with a caret, what to do) and its [`ErrorClass`].
#![warn(missing_docs)]
// Files are read through `volcomp_geom::inputs` only (clippy.toml).
#![cfg_attr(not(test), warn(clippy::disallowed_methods))]

pub mod arc;
pub mod edit;
pub mod error;
pub mod geom;
pub mod interp;
pub mod lexer;
pub mod ngc;
pub mod number;
pub mod program;
pub mod setup;
pub mod varfile;

pub use arc::Arc;
pub use error::{Diagnostic, ErrorClass, GcodeError};
pub use geom::{Axis, Plane, Units, Vec3};
pub use interp::{
    ExtraAxes, FeedMode, InterpOptions, Interpreter, Motion, MotionKind, MotionSource, PathMode,
    Warning, EXTRA_LETTERS,
};
pub use program::{LineEvent, NextLine, Walker};
pub use setup::{AxisLetters, MotionLimits, Setup};
