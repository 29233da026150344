//! LinuxCNC screw-compensation files (`[JOINT_n] COMP_FILE`, `COMP_FILE_TYPE`
//! 0 or 1): the positioning error of one joint, per direction, as a table
//! over the commanded position.
//!
//! What LinuxCNC does with them (`src/emc/motion`: `usrmotLoadComp`,
//! `EMCMOT_SET_JOINT_COMP`, `compute_screw_comp`, `output_to_hal`):
//!
//! * every line holds three numbers separated by blanks, in machine units
//!   (`[TRAJ] LINEAR_UNITS`); the first is the nominal (commanded) joint
//!   position, strictly increasing, at most 256 lines;
//! * **type 0**: the second and third numbers are the *actual* positions
//!   reached at that nominal while moving in the positive and in the negative
//!   direction; LinuxCNC stores `trim = nominal − actual`;
//! * **type 1**: they are the trims themselves, `nominal − actual`;
//! * the trim, linearly interpolated at the commanded position and chosen by
//!   the sign of the commanded velocity (kept while the joint stands still),
//!   is *added* to the motor command; outside the table the end values hold;
//! * reading stops at the first line that is not three numbers, so a comment
//!   or blank line in the middle silently cuts the table short.
//!
//! In volcomp's sign (docs/design.md, "Deviation sign": `e = actual − commanded`), with `e` the
//! positioning error `E_aa` of the joint's axis in the matching direction:
//!
//! ```text
//! type 0:  actual = nominal + e        (e = actual − nominal)
//! type 1:  trim   = −e                 (e = −trim)
//! ```
//!
//! so a correct file makes LinuxCNC command `nominal − e(nominal)`: the
//! direct compensation (docs/design.md, "Compensation") for the positioning error alone.

use crate::error::MapFileError;

/// Entries LinuxCNC accepts per joint (`EMCMOT_COMP_SIZE`).
pub const MAX_ENTRIES: usize = 256;

/// `COMP_FILE_TYPE`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CompFileType {
    /// `nominal actual_forward actual_reverse`.
    Type0,
    /// `nominal trim_forward trim_reverse` with `trim = nominal − actual`.
    Type1,
}

impl CompFileType {
    /// From the INI value 0 or 1.
    pub fn from_number(n: u8) -> Option<Self> {
        match n {
            0 => Some(Self::Type0),
            1 => Some(Self::Type1),
            _ => None,
        }
    }

    /// The INI value.
    pub fn number(self) -> u8 {
        match self {
            Self::Type0 => 0,
            Self::Type1 => 1,
        }
    }
}

/// `[TRAJ] LINEAR_UNITS` of the machine the file is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MachineUnits {
    /// Millimetres.
    Mm,
    /// Inches.
    Inch,
}

impl MachineUnits {
    /// Millimetres per machine unit.
    pub fn mm_per_unit(self) -> f64 {
        match self {
            Self::Mm => 1.0,
            Self::Inch => 25.4,
        }
    }
}

pub use crate::model::positioning::Positioning;

/// Byte offset of the next blank-separated field after the one at `at`.
fn next_field(line: &str, at: usize) -> usize {
    let rest = &line[at.min(line.len())..];
    let word = rest.len() - rest.trim_start().len();
    let after = rest[word..]
        .find(char::is_whitespace)
        .map_or(rest.len(), |i| word + i);
    let gap = rest[after..].len() - rest[after..].trim_start().len();
    at + after + gap
}

/// The largest positioning error (mm) a comp file can plausibly describe:
/// screw errors are micrometres to a few tenths of a millimetre; an error of
/// a millimetre or more means the columns were read as the wrong type.
pub const PLAUSIBLE_ERROR_MM: f64 = 1.0;

/// A line whose error, read as `ty`, is implausibly large: the message and
/// help (naming the other type when that reading is plausible).
fn type_mismatch(v: [f64; 3], ty: CompFileType, units: MachineUnits) -> Option<(String, String)> {
    let k = units.mm_per_unit();
    let as0 = (v[1] - v[0]).abs().max((v[2] - v[0]).abs()) * k;
    let as1 = v[1].abs().max(v[2].abs()) * k;
    let (this, other, other_ty) = match ty {
        CompFileType::Type0 => (as0, as1, 1),
        CompFileType::Type1 => (as1, as0, 0),
    };
    if this <= PLAUSIBLE_ERROR_MM {
        return None;
    }
    let what = match ty {
        CompFileType::Type0 => "actual positions",
        CompFileType::Type1 => "trims",
    };
    let message = format!(
        "read as COMP_FILE_TYPE {}, the {what} on this line mean an error of {this:.3} mm at nominal {}",
        ty.number(),
        v[0]
    );
    let help = if other <= PLAUSIBLE_ERROR_MM {
        format!("the file looks like COMP_FILE_TYPE {other_ty} (errors of at most {other:.4} mm): read it as type {other_ty}")
    } else {
        format!("a comp file describes errors of micrometres, not {PLAUSIBLE_ERROR_MM} mm or more: check the file's type (0: nominal actual actual; 1: nominal trim trim) and its machine units")
    };
    Some((message, help))
}

/// Reads a comp file; `file` names it in errors.
///
/// ```
/// use volcomp_core::io::linuxcnc_comp::{parse, CompFileType, MachineUnits};
/// // Type 0: at nominal 100 the axis reaches 100.002 going up, 100.005 going down.
/// let p = parse("0 0 0.003\n100 100.002 100.005\n", "x.comp", CompFileType::Type0, MachineUnits::Mm).unwrap();
/// assert!((p.forward_um[1] - 2.0).abs() < 1e-9 && (p.reverse_um[1] - 5.0).abs() < 1e-9);
/// ```
pub fn parse(
    text: &str,
    file: &str,
    ty: CompFileType,
    units: MachineUnits,
) -> Result<Positioning, MapFileError> {
    let err = |row: usize, column: usize, message: String, help: &str| {
        let src = text.lines().nth(row.wrapping_sub(1)).unwrap_or("");
        let caret = (0..column.saturating_sub(1)).fold(0, |at, _| next_field(src, at));
        MapFileError::new(file, row, column, message, help).with_source(src, caret)
    };
    let k = units.mm_per_unit();
    let mut out = Positioning {
        positions_mm: Vec::new(),
        forward_um: Vec::new(),
        reverse_um: Vec::new(),
    };
    let lines: Vec<&str> = text.lines().collect();
    let mut prev_nominal = f64::NEG_INFINITY;
    for (i, line) in lines.iter().enumerate() {
        let row = i + 1;
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.is_empty() && lines[i..].iter().all(|l| l.trim().is_empty()) {
            break;
        }
        let stops = "LinuxCNC stops reading a comp file at the first line that is not three numbers and ignores the rest; write `nominal forward reverse` in machine units on every line, with no comments or blank lines";
        let mut v = [0.0; 3];
        for (c, slot) in v.iter_mut().enumerate() {
            let Some(text) = fields.get(c) else {
                return Err(err(
                    row,
                    c + 1,
                    format!(
                        "expected three numbers separated by blanks, found {}",
                        fields.len()
                    ),
                    stops,
                ));
            };
            let x: f64 = text
                .parse()
                .map_err(|_| err(row, c + 1, format!("`{text}` is not a number"), stops))?;
            if !x.is_finite() {
                return Err(err(
                    row,
                    c + 1,
                    format!("`{}` is not a finite number", fields[c]),
                    "every line needs a measured value",
                ));
            }
            *slot = x;
        }
        if fields.len() > 3 {
            return Err(err(
                row,
                4,
                format!("expected three numbers, found {}", fields.len()),
                stops,
            ));
        }
        if v[0] <= prev_nominal {
            return Err(err(
                row,
                1,
                format!("nominal {} does not increase after {}", v[0], prev_nominal),
                "LinuxCNC refuses comp tables whose nominal positions do not strictly increase",
            ));
        }
        prev_nominal = v[0];
        if let Some((message, help)) = type_mismatch(v, ty, units) {
            return Err(err(row, 2, message, &help));
        }
        let (fwd, rev) = match ty {
            CompFileType::Type0 => (v[1] - v[0], v[2] - v[0]),
            CompFileType::Type1 => (-v[1], -v[2]),
        };
        out.positions_mm.push(v[0] * k);
        out.forward_um.push(fwd * k * 1e3);
        out.reverse_um.push(rev * k * 1e3);
    }
    if out.positions_mm.len() < 2 {
        return Err(err(
            lines.len().max(1),
            1,
            format!("the file has {} line(s)", out.positions_mm.len()),
            "a comp table needs at least two nominal positions",
        ));
    }
    if out.positions_mm.len() > MAX_ENTRIES {
        return Err(err(
            MAX_ENTRIES + 1,
            1,
            format!(
                "the file has {} lines; LinuxCNC takes at most {MAX_ENTRIES}",
                out.positions_mm.len()
            ),
            "LinuxCNC reports `too many compensation entries` and drops the rest",
        ));
    }
    Ok(out)
}

/// A comp file could not be written.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CompWriteError {
    /// The table has more points than LinuxCNC holds per joint.
    #[error("{points} points: LinuxCNC takes at most {MAX_ENTRIES} per joint")]
    TooManyPoints {
        /// Points in the table.
        points: usize,
    },
}

/// A comp file could not be read.
pub type CompReadError = crate::io::FileReadError;

/// Reads the comp file `path` (see [`parse`]).
pub fn read(
    path: &std::path::Path,
    ty: CompFileType,
    units: MachineUnits,
) -> Result<Positioning, CompReadError> {
    let text = crate::io::read_text(path, "a LinuxCNC compensation file")?;
    Ok(parse(&text, &path.display().to_string(), ty, units)?)
}

/// The axis-table CSV of comp files read as `tables` (positioning errors
/// only), under a comment that says where they came from.
pub fn imported_tables_csv(
    tables: &crate::model::axis_table::AxisTableMap,
    ty: CompFileType,
    units: MachineUnits,
) -> String {
    format!(
        "# imported from LinuxCNC comp files (type {}, {}): positioning errors only\n{}",
        ty.number(),
        match units {
            MachineUnits::Mm => "mm",
            MachineUnits::Inch => "inch",
        },
        tables.to_csv()
    )
}

/// A number with up to ten decimals and no trailing zeros.
fn number(v: f64) -> String {
    crate::io::numfmt::fixed(v, 10)
}

/// Writes a comp file (no comments: LinuxCNC would stop reading at them).
/// Fails when the table has more than [`MAX_ENTRIES`] points.
///
/// ```
/// use volcomp_core::io::linuxcnc_comp::{write, Positioning, CompFileType, MachineUnits};
/// let p = Positioning { positions_mm: vec![0.0, 100.0], forward_um: vec![0.0, 2.0], reverse_um: vec![3.0, 5.0] };
/// assert_eq!(write(&p, CompFileType::Type1, MachineUnits::Mm).unwrap(), "0 0 -0.003\n100 -0.002 -0.005\n");
/// assert_eq!(write(&p, CompFileType::Type0, MachineUnits::Mm).unwrap(), "0 0 0.003\n100 100.002 100.005\n");
/// ```
pub fn write(
    p: &Positioning,
    ty: CompFileType,
    units: MachineUnits,
) -> Result<String, CompWriteError> {
    if p.positions_mm.len() > MAX_ENTRIES {
        return Err(CompWriteError::TooManyPoints {
            points: p.positions_mm.len(),
        });
    }
    let k = units.mm_per_unit();
    let mut s = String::new();
    for i in 0..p.positions_mm.len() {
        let nominal = p.positions_mm[i] / k;
        let fwd = p.forward_um[i] * 1e-3 / k;
        let rev = p.reverse_um[i] * 1e-3 / k;
        let (a, b) = match ty {
            CompFileType::Type0 => (nominal + fwd, nominal + rev),
            CompFileType::Type1 => (-fwd, -rev),
        };
        s.push_str(&format!(
            "{} {} {}\n",
            number(nominal),
            number(a),
            number(b)
        ));
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Positioning {
        Positioning::new(
            &[-50.0, 0.0, 37.5, 120.25],
            &[-1.2345, 0.0, 2.5, 4.125],
            &[1.5, 3.0, 5.75, 6.0625],
        )
    }

    #[test]
    fn round_trip_both_types_and_units() {
        let p = sample();
        for ty in [CompFileType::Type0, CompFileType::Type1] {
            for units in [MachineUnits::Mm, MachineUnits::Inch] {
                let text = write(&p, ty, units).unwrap();
                let back = parse(&text, "x.comp", ty, units).unwrap();
                for i in 0..4 {
                    // Ten decimals of a machine unit: 1e-10 mm = 1e-7 µm (or
                    // 2.54e-6 µm in inch).
                    assert!((back.positions_mm[i] - p.positions_mm[i]).abs() < 1e-8);
                    assert!(
                        (back.forward_um[i] - p.forward_um[i]).abs() < 1e-5,
                        "{ty:?} {units:?}"
                    );
                    assert!((back.reverse_um[i] - p.reverse_um[i]).abs() < 1e-5);
                }
            }
        }
    }

    #[test]
    fn linuxcnc_documentation_examples() {
        // The LinuxCNC INI documentation's type 0 example: at nominal 0.000
        // the joint reaches 0.002 going up and −0.003 going down, so
        // e_forward = +0.002 mm = +2 µm and e_reverse = −3 µm.
        let t0 = "-1.000 -1.005 -0.995\n0.000 0.002 -0.003\n1.000 1.003 0.998\n";
        let p = parse(t0, "x.comp", CompFileType::Type0, MachineUnits::Mm).unwrap();
        assert!((p.forward_um[0] - -5.0).abs() < 1e-9);
        assert!((p.reverse_um[0] - 5.0).abs() < 1e-9);
        assert!((p.forward_um[1] - 2.0).abs() < 1e-9);
        assert!((p.reverse_um[1] - -3.0).abs() < 1e-9);
        // Type 1 holds the trim added to the motor command, −e: a trim of
        // 0.005 in inch means the axis falls 0.005″ = 127 µm short.
        let t1 = "-1.000 0.005 -0.005\n0.000 0.002 -0.003\n";
        let p = parse(t1, "x.comp", CompFileType::Type1, MachineUnits::Inch).unwrap();
        assert!((p.positions_mm[0] - -25.4).abs() < 1e-12);
        assert!((p.forward_um[0] - -127.0).abs() < 1e-9);
        assert!((p.reverse_um[0] - 127.0).abs() < 1e-9);
    }

    #[test]
    fn bad_files_name_row_and_column() {
        let read = |text: &str| parse(text, "x.comp", CompFileType::Type1, MachineUnits::Mm);
        let e = read("0 0 0\n# comment\n10 0 0\n").unwrap_err();
        assert_eq!((e.file.as_str(), e.row, e.column), ("x.comp", 2, 1), "{e}");
        assert!(e.help.contains("stops reading"));
        // A value that is not finite, a nominal position that does not
        // increase, a decimal comma: each at its row and column.
        for (text, at) in [
            ("0 0 0\n10 0 nan\n", (2, 3)),
            ("0 0 0\n0 0 0\n", (2, 1)),
            ("0 0 0\n10 0,0 0\n", (2, 2)),
        ] {
            let e = read(text).unwrap_err();
            assert_eq!((e.row, e.column), at, "{e}");
        }
        assert!(read("0 0 0\n").is_err());
        // Trailing blank lines are harmless.
        assert!(read("0 0 0\n1 0 0\n\n\n").is_ok());
        let many = Positioning {
            positions_mm: (0..300).map(f64::from).collect(),
            forward_um: vec![0.0; 300],
            reverse_um: vec![0.0; 300],
        };
        assert!(write(&many, CompFileType::Type1, MachineUnits::Mm).is_err());
    }

    #[test]
    fn a_file_of_the_other_type_is_refused() {
        // Type 1 (trims of a few µm) read as type 0: "actual" 0.002 at
        // nominal 1000 means errors of 999.998 and 1000.003 mm.
        let t1 = "0 0.001 -0.001\n1000 0.002 -0.003\n";
        let e = parse(t1, "x.comp", CompFileType::Type0, MachineUnits::Mm).unwrap_err();
        assert_eq!((e.row, e.column), (2, 2), "{e}");
        assert!(e.message.contains("1000.003 mm"), "{e}");
        assert!(e.help.contains("type 1"), "{e}");
        // Type 0 read as type 1: trims of 1000 mm.
        let t0 = "0 0.001 -0.001\n1000 1000.002 999.997\n";
        let e = parse(t0, "x.comp", CompFileType::Type1, MachineUnits::Mm).unwrap_err();
        assert!(e.help.contains("type 0"), "{e}");
        // Both readings implausible: no type is suggested.
        let e = parse(
            "0 0 0\n10 5 -5\n",
            "x.comp",
            CompFileType::Type1,
            MachineUnits::Mm,
        )
        .unwrap_err();
        assert!(e.help.contains("machine units"), "{e}");
        // An inch file: 0.05 in = 1.27 mm is refused, 0.03 in is not.
        assert!(parse(
            "0 0 0\n1 0.05 0\n",
            "x.comp",
            CompFileType::Type1,
            MachineUnits::Inch
        )
        .is_err());
        assert!(parse(
            "0 0 0\n1 0.03 0\n",
            "x.comp",
            CompFileType::Type1,
            MachineUnits::Inch
        )
        .is_ok());
    }

    #[test]
    fn too_many_points_is_a_typed_error() {
        let n = MAX_ENTRIES + 1;
        let p = Positioning {
            positions_mm: (0..n).map(|i| i as f64).collect(),
            forward_um: vec![0.0; n],
            reverse_um: vec![0.0; n],
        };
        let e = write(&p, CompFileType::Type1, MachineUnits::Mm).unwrap_err();
        assert_eq!(e, CompWriteError::TooManyPoints { points: 257 });
        assert_eq!(
            e.to_string(),
            "257 points: LinuxCNC takes at most 256 per joint"
        );
    }

    #[test]
    fn read_reads_a_file_and_names_a_missing_one() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.comp");
        // Type 1 in inches: trim −0.0001 in at 1 in → e = +2.54 µm at 25.4 mm.
        std::fs::write(&path, "0 0 0\n1 -0.0001 0\n").unwrap();
        let p = read(&path, CompFileType::Type1, MachineUnits::Inch).unwrap();
        assert_eq!(p.positions_mm, vec![0.0, 25.4]);
        assert!((p.forward_um[1] - 2.54).abs() < 1e-9);
        let e = read(
            &dir.path().join("none.comp"),
            CompFileType::Type1,
            MachineUnits::Mm,
        )
        .unwrap_err();
        assert!(matches!(e, CompReadError::Io { .. }));
    }
}
