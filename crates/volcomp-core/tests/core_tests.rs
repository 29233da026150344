//! The library's integration tests, one binary: every `tests/<name>.rs` is a
//! module here (a new file must be added below), so the crate links once and
//! the tests of every file run side by side. One file alone:
//! `cargo test -p volcomp-core --test core_tests <name>::`.

mod common;

mod arc_ramp;
mod arc_tail_hold;
mod arc_zone;
mod axis_never_set;
mod compensate_cycles;
mod compensation;
mod cutter_comp_write_back;
mod exact_hold;
mod extra_axes_and_splines;
mod folder_imports;
mod g64p_line_hold;
mod helix_normal_step;
mod idle_take_ups;
mod kinematic;
mod line_arc_blend;
mod line_into_arc;
mod line_length;
mod line_tail_hold;
mod mirror_study;
mod planner_linuxcnc;
mod plunge_hold;
mod probe;
mod ramp_centre;
mod ramp_stage;
mod random_programs;
mod simulate_pairing;
mod still_axis_turn;
mod still_s;
mod straightness;
mod tail_merge;
mod take_up_advance;
mod take_up_before;
mod take_up_order;
mod take_up_stand;
mod tangent_join;
mod thermal;
mod zero_map_round_trip;
