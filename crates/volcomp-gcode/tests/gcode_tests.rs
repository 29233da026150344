//! The G-code engine's integration tests, one binary: every `tests/<name>.rs`
//! is a module here (a new file must be added below), so the crate links once
//! and the tests of every file run side by side. One file alone:
//! `cargo test -p volcomp-gcode --test gcode_tests <name>::`.

mod common;

mod canned_cycles;
mod controller_rules;
mod cutter_comp;
mod diagnostics;
mod frames;
mod lossless;
mod next_line;
mod ngc_robustness;
mod path_mode;
mod probing;
mod splines_and_axes;
