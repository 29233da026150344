//! LinuxCNC's parameter file (`.var`, named by `[RS274NGC]PARAMETER_FILE`):
//! one parameter per line, its number and its value separated by blanks
//! in increasing order of number (LinuxCNC's `Interp::restore_parameters`,
//! rs274ngc_pre.cc, reads it so, refuses a file out of order and ignores
//! the rest of a line). Values of lengths are in the machine's
//! units.
//!
//! The parameters the interpreter owns become its start state: #5161–#5163
//! the G28 point, #5181–#5183 the G30 point, #5211–#5213 the G92 offset,
//! #5220 the coordinate system in use (1–9), #5221 + 20·(k−1) + {0, 1, 2}
//! the offsets of coordinate system k (G54…G59.3) and #5230 + 20·(k−1) its
//! rotation (degrees). Every other parameter is preset for the program to
//! read.

use crate::error::{ErrorClass, GcodeError};
use crate::geom::Vec3;
use crate::setup::Setup;
use std::collections::BTreeMap;

fn error(file: &str, line: u64, col: usize, message: String, help: &str) -> GcodeError {
    GcodeError::new(ErrorClass::Invalid, line, col, message, help).with_file(file.to_string())
}

/// Reads a parameter file's text into number → value.
pub fn parse(text: &str, file: &str) -> Result<BTreeMap<usize, f64>, GcodeError> {
    let mut out = BTreeMap::new();
    for (i, line) in text.lines().enumerate() {
        let n = i as u64 + 1;
        // Every refusal names the file, the line and its column, and shows the line.
        let refuse = |col: usize, message: String, help: &str| {
            error(file, n, col, message, help).with_source_line(line.as_bytes())
        };
        let mut fields = line.split_whitespace();
        let Some(num) = fields.next() else { continue };
        let col = line.find(num).unwrap_or(0) + 1;
        let index: usize = num.parse().map_err(|_| {
            refuse(
                col,
                format!("`{num}` is not a parameter number"),
                "each line holds a parameter number and its value",
            )
        })?;
        if !(1..5602).contains(&index) {
            return Err(refuse(
                col,
                format!("parameter number {index} is out of range"),
                "parameters are #1 to #5601",
            ));
        }
        let Some(value) = fields.next() else {
            return Err(refuse(
                col,
                format!("parameter {index} has no value"),
                "write the value after the number",
            ));
        };
        let vcol = line.rfind(value).unwrap_or(0) + 1;
        let v: f64 = value
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| {
                refuse(
                    vcol,
                    format!("`{value}` is not a number"),
                    "write the value as a number",
                )
            })?;
        if out.keys().next_back().is_some_and(|&last| last >= index) {
            return Err(refuse(col, format!("parameter {index} is out of order: the numbers must increase from line to line"), "sort the file by parameter number, as LinuxCNC requires (\"Parameter file out of order\")"));
        }
        out.insert(index, v);
    }
    Ok(out)
}

/// Applies parameters to a set-up: the interpreter's start state from the
/// parameters it owns, the others preset (lengths in `mm_per_unit` of the
/// machine's units).
pub fn apply(
    setup: &mut Setup,
    params: &BTreeMap<usize, f64>,
    mm_per_unit: f64,
    file: &str,
) -> Result<(), GcodeError> {
    let get = |n: usize| params.get(&n).copied().unwrap_or(0.0);
    let vec = |n: usize| {
        Vec3::new(
            get(n) * mm_per_unit,
            get(n + 1) * mm_per_unit,
            get(n + 2) * mm_per_unit,
        )
    };
    if (5161..=5163).any(|n| params.contains_key(&n)) {
        setup.g28_mm = vec(5161);
        setup.g28_given = true;
    }
    if (5181..=5183).any(|n| params.contains_key(&n)) {
        setup.g30_mm = vec(5181);
        setup.g30_given = true;
    }
    setup.g92_mm = vec(5211);
    if let Some(cs) = params.get(&5220) {
        // LinuxCNC takes `(int)(#5220 + 0.0001)` (`Interp::init`,
        // rs274ngc_pre.cc).
        let index = (cs + 0.0001).trunc();
        if !(1.0..=9.0).contains(&index) {
            return Err(error(
                file,
                0,
                1,
                format!("#5220 = {cs} is not a coordinate system (1 to 9)"),
                "fix #5220",
            ));
        }
        setup.work_system = index as usize - 1;
    }
    // LinuxCNC's var file gives every coordinate system (a missing one is
    // 0, as `restore_parameters` reads it).
    for k in 0..9 {
        let base = 5221 + 20 * k;
        setup.work_offsets_mm[k] = vec(base);
        setup.rotations_deg[k] = get(base + 9);
        setup.work_offsets_given[k] = true;
    }
    for (&n, &v) in params {
        if !(5161..=5428).contains(&n) {
            setup.parameters.insert(n, v);
        }
    }
    Ok(())
}
