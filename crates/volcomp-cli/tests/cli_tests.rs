//! The command-line tests, one binary: every `tests/<name>.rs` is a module
//! here (a new file must be added below), so the crate links once and the
//! tests of every file run side by side. One file alone:
//! `cargo test -p volcomp-cli --test cli_tests <name>::`.

mod common;
mod rs274;

/// The generator of `examples/data/` (also `cargo run --example example_data`):
/// the documented commands run on its files, and the surface tests use its
/// nominal saddle.
#[allow(dead_code)]
#[path = "../examples/example_data.rs"]
mod example_data;

mod arcs_as_arcs;
mod axis_and_points;
mod ballbar;
mod bounded;
mod cli;
mod compensated_header;
mod control_flow;
mod controllers;
mod cycles_kept;
mod docs_commands;
mod eval_sets;
mod front_snapshots;
mod identify_snapshots;
mod linuxcnc_backlash;
mod map;
mod map_snapshots;
mod output_safety;
mod probe;
mod probe_linuxcnc;
mod progress;
mod readers;
mod report_html;
mod rotated_frame;
mod rs274_agreement;
mod rs274_corpus;
mod straightness;
mod surface_mirror;
mod surface_snapshots;
mod thermal;
mod time;
