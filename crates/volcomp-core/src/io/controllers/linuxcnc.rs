//! LinuxCNC through `volcomp map export --to linuxcnc` and `--controller
//! machine.ini`: the comp files of [`crate::io::linuxcnc_comp`] (`x.comp`,
//! `y.comp`, `z.comp`) or the joints' `BACKLASH`, and the correction
//! LinuxCNC 2.9's motion controller applies from an INI file.
//!
//! What LinuxCNC does (`src/emc/ini/inijoint.cc` `loadJoint`,
//! `src/emc/motion/usrmotintf.cc` `usrmotLoadComp`,
//! `src/emc/motion/control.c` `compute_screw_comp`,
//! `src/emc/kinematics/kins_util.c` `map_coordinates_to_jnumbers`):
//!
//! * each joint `n` below `[KINS] JOINTS` reads `[JOINT_n] BACKLASH`
//!   (default 0), `COMP_FILE_TYPE` (default 0; every value but 0 reads the
//!   file as type 1) and `COMP_FILE` (opened relative to the INI's folder);
//! * with a comp file loaded, the motor command is the joint command plus
//!   the file's trim for the direction of travel, and **`BACKLASH` is not
//!   used**; without one, plus `BACKLASH/2` moving up and `−BACKLASH/2`
//!   moving down (in volcomp's sign `c = −B/2` forward, `+B/2` in reverse:
//!   [`BacklashSide::Split`]); both kept while the joint stands still;
//! * `trivkins coordinates=XYYZ` gives joint `n` the axis of the `n`-th
//!   letter (blanks skipped, any case; default `XYZABCUVW`): a letter named
//!   twice is a gantry, both joints follow the axis, each with its own
//!   compensation.
//!
//! The INI file itself is read as LinuxCNC reads it ([`super::ini`]).

use super::ini::{leading_f64, leading_int, Ini};
use super::{
    axis_letter, mean_reversal_um, Backlash, BacklashSide, ControllerCorrection,
    ControllerReadError, Export, ExportFile, Format, LimitError, Positioning, Rounding,
};
use crate::io::linuxcnc_comp::{self, CompFileType, MachineUnits, MAX_ENTRIES};
use crate::io::numfmt::fixed;

/// What `map export --to linuxcnc` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinuxcncExport {
    /// One comp file per axis, both directions (LinuxCNC then ignores
    /// `BACKLASH`, so the files hold the reversal).
    CompFiles(CompFileType),
    /// `[JOINT_n] BACKLASH` only: the axis' mean reversal value, which
    /// LinuxCNC applies as half of it each way; no comp file.
    BacklashOnly,
}

/// Decimals of a written value in machine units: 10⁻¹⁰ mm = 10⁻⁷ µm.
const DECIMALS: usize = 10;

/// The INI lines of an export: where they go, and the rule that makes
/// appending them wrong.
fn ini_head(units: MachineUnits) -> String {
    format!(
        "# volcomp: LinuxCNC compensation for joints 0, 1, 2 = X, Y, Z (trivkins coordinates=XYZ).\n\
         # Merge these keys into the machine's INI file, into its existing sections:\n\
         # LinuxCNC reads only the first section of a name and the first key of a section,\n\
         # so sections appended below the machine's own are never read.\n\
         # A gantry (coordinates=XYYZ) gives both joints of the axis the same keys.\n\
         [KINS]\nKINEMATICS = trivkins coordinates=XYZ\nJOINTS = 3\n\n[TRAJ]\nLINEAR_UNITS = {}\n",
        match units {
            MachineUnits::Mm => "mm",
            MachineUnits::Inch => "inch",
        }
    )
}

/// Writes the comp files (one per axis with a table, both directions) or
/// the joints' `BACKLASH`, and `comp.ini` with the INI keys that use them.
/// Values are written with ten decimals of a machine unit: the rounding is
/// reported all the same.
pub fn export(
    p: &[Option<Positioning>; 3],
    what: LinuxcncExport,
    units: MachineUnits,
) -> Result<Export, LimitError> {
    let k = units.mm_per_unit();
    let mut files = Vec::new();
    let mut applied = ControllerCorrection::empty(Format::Linuxcnc);
    let mut rounding = Rounding {
        resolution_um: 10f64.powi(-(DECIMALS as i32)) * k * 1e3,
        max_um: 0.0,
    };
    let mut ini = ini_head(units);
    let mut notes = Vec::new();
    let mut holds = [super::table_error::Holds::Nothing; 3];
    for (a, table) in p.iter().enumerate() {
        let Some(table) = table else { continue };
        holds[a] = match what {
            LinuxcncExport::CompFiles(_) => super::table_error::Holds::BothDirections,
            LinuxcncExport::BacklashOnly => super::table_error::Holds::BacklashOnly,
        };
        match what {
            LinuxcncExport::CompFiles(ty) => {
                let name = format!("{}.comp", axis_letter(a).to_ascii_lowercase());
                let text = linuxcnc_comp::write(table, ty, units).map_err(|e| LimitError {
                    format: "linuxcnc",
                    axis: axis_letter(a),
                    message: e.to_string(),
                    help: format!(
                        "resample the table with a step of at least {} mm (linear interpolation)",
                        fixed(
                            (table.positions_mm[table.positions_mm.len() - 1]
                                - table.positions_mm[0])
                                / (MAX_ENTRIES - 1) as f64,
                            3
                        )
                    ),
                })?;
                let back =
                    linuxcnc_comp::parse(&text, &name, ty, units).map_err(|e| LimitError {
                        format: "linuxcnc",
                        axis: axis_letter(a),
                        message: e.to_string(),
                        help: "the table cannot be written as a comp file".into(),
                    })?;
                for (x, y) in back
                    .forward_um
                    .iter()
                    .chain(&back.reverse_um)
                    .zip(table.forward_um.iter().chain(&table.reverse_um))
                {
                    rounding.max_um = rounding.max_um.max((x - y).abs());
                }
                ini.push_str(&format!(
                    "\n[JOINT_{a}]\nCOMP_FILE = {name}\nCOMP_FILE_TYPE = {}\n# LinuxCNC does not use BACKLASH while a comp file is loaded: the file holds the reversal\nBACKLASH = 0\n",
                    ty.number()
                ));
                notes.push(format!(
                    "[JOINT_{a}] COMP_FILE = {name}, COMP_FILE_TYPE = {} (the comp file holds both directions; LinuxCNC ignores BACKLASH while it is loaded)",
                    ty.number()
                ));
                applied.axes[a] = Some(back);
                files.push(ExportFile { name, text });
            }
            LinuxcncExport::BacklashOnly => {
                let b_um = mean_reversal_um(table);
                let written = fixed(b_um * 1e-3 / k, DECIMALS);
                let back_um = written.parse::<f64>().unwrap_or(0.0) * k * 1e3;
                rounding.max_um = rounding.max_um.max((back_um - b_um).abs());
                ini.push_str(&format!(
                    "\n[JOINT_{a}]\n# the mean reversal value of {}, applied as half of it each way; no COMP_FILE (LinuxCNC would not use BACKLASH beside one)\nBACKLASH = {written}\n",
                    axis_letter(a)
                ));
                notes.push(format!(
                    "[JOINT_{a}] BACKLASH = {written}: the mean reversal value of {} ({} um; the mean, not the largest, so that the reversal left over averages zero along the axis); remove COMP_FILE from [JOINT_{a}], LinuxCNC ignores BACKLASH while a comp file is loaded",
                    axis_letter(a),
                    fixed(b_um, 3)
                ));
                applied.backlash[a] = Some(Backlash {
                    value_um: back_um,
                    side: BacklashSide::Split,
                });
            }
        }
    }
    files.push(ExportFile {
        name: "comp.ini".into(),
        text: ini,
    });
    notes.push("comp.ini: merge its keys into the machine's INI sections (LinuxCNC reads only the first section of a name)".into());
    Ok(Export {
        files,
        applied,
        rounding,
        holds,
        zero_at: None,
        notes,
    })
}

/// Most joints LinuxCNC 2.9 has (`EMCMOT_MAX_JOINTS`).
const MAX_JOINTS: usize = 16;

/// What one joint's INI keys make LinuxCNC apply.
#[derive(Debug, Clone, PartialEq)]
struct JointComp {
    table: Option<Positioning>,
    backlash: Option<Backlash>,
}

/// `[TRAJ] LINEAR_UNITS` as LinuxCNC reads it: a number (machine units per
/// mm) or `mm`, `metric`, `in`, `inch`, `imperial` (any case).
fn linear_units(ini: &Ini) -> Result<MachineUnits, ControllerReadError> {
    let Some(f) = ini.find("LINEAR_UNITS", "TRAJ") else {
        return Err(ini
            .error_top(
                "no [TRAJ] LINEAR_UNITS".into(),
                "comp files and BACKLASH are in machine units: the INI must say LINEAR_UNITS (LinuxCNC does not start without it)",
            )
            .into());
    };
    if let Some(v) = leading_f64(&f.value) {
        if (v - 1.0).abs() < 1e-9 {
            return Ok(MachineUnits::Mm);
        }
        if (v * 25.4 - 1.0).abs() < 1e-6 {
            return Ok(MachineUnits::Inch);
        }
        return Err(ini
            .error_at(
                f.line,
                format!("LINEAR_UNITS = {}: {v} machine units per mm", f.value),
                "volcomp reads millimetre (1, mm, metric) and inch (0.03937007874, inch, in, imperial) machines",
            )
            .into());
    }
    match f.value.to_ascii_lowercase().as_str() {
        "mm" | "metric" => Ok(MachineUnits::Mm),
        "in" | "inch" | "imperial" => Ok(MachineUnits::Inch),
        _ => Err(ini
            .error_at(
                f.line,
                format!("LINEAR_UNITS = {}", f.value),
                "LinuxCNC reads a number of units per mm or mm, metric, in, inch, imperial",
            )
            .into()),
    }
}

/// The axis index (0 … 8 of `XYZABCUVW`) of each joint under `[KINS]
/// KINEMATICS`, or the reason the mapping is not known.
fn joint_axes(ini: &Ini) -> Result<Vec<usize>, (Option<usize>, String, String)> {
    let Some(k) = ini.find("KINEMATICS", "KINS") else {
        return Err((None, "no [KINS] KINEMATICS: the joints' axes are not known".into(), "add the kinematics the machine's HAL file loads, e.g. KINEMATICS = trivkins coordinates=XYZ".into()));
    };
    let mut words = k.value.split_whitespace();
    let module = words.next().unwrap_or("");
    if module != "trivkins" {
        return Err((Some(k.line), format!("KINEMATICS = {}: volcomp maps joints to axes for trivkins only", k.value), "with other kinematics a joint's correction moves the tool along several axes, which a per-axis table cannot model: compensate with the whole map instead of --controller".into()));
    }
    let coords = words
        .filter_map(|w| w.strip_prefix("coordinates="))
        .next_back()
        .unwrap_or("XYZABCUVW");
    let mut out = Vec::new();
    for c in coords.chars().filter(|c| !c.is_whitespace()) {
        match "XYZABCUVW".find(c.to_ascii_uppercase()) {
            Some(i) => out.push(i),
            None => {
                return Err((
                    Some(k.line),
                    format!("coordinates={coords}: `{c}` is not an axis letter"),
                    "trivkins takes the letters XYZABCUVW, one per joint (LinuxCNC does not load it otherwise)".into(),
                ))
            }
        }
    }
    Ok(out)
}

/// The compensation of joint `j` (`None`: its section is not there).
fn joint(
    ini: &Ini,
    j: usize,
    units: MachineUnits,
    notes: &mut Vec<String>,
    read_file: &mut impl FnMut(&str) -> Result<(String, String), ControllerReadError>,
) -> Result<Option<(JointComp, usize)>, ControllerReadError> {
    let section = format!("JOINT_{j}");
    let Some(&start) = ini.sections(&section).first() else {
        return Ok(None);
    };
    for key in ["COMP_FILE", "COMP_FILE_TYPE", "BACKLASH"] {
        notes.extend(ini.ignored(key, &section));
    }
    let k = units.mm_per_unit();
    let backlash = match ini.find("BACKLASH", &section) {
        None => 0.0,
        Some(f) => leading_f64(&f.value).ok_or_else(|| {
            ini.error_at(
                f.line,
                format!("BACKLASH = {} is not a number", f.value),
                "LinuxCNC does not start with it: write the backlash in machine units, e.g. BACKLASH = 0.004",
            )
        })?,
    };
    let Some(file) = ini.find("COMP_FILE", &section) else {
        let backlash = (backlash != 0.0).then_some(Backlash {
            value_um: backlash * k * 1e3,
            side: BacklashSide::Split,
        });
        return Ok(Some((
            JointComp {
                table: None,
                backlash,
            },
            start,
        )));
    };
    let ty = match ini.find("COMP_FILE_TYPE", &section) {
        None => {
            notes.push(format!("[{section}] has no COMP_FILE_TYPE: LinuxCNC's default 0 (nominal, actual forward, actual reverse) is read"));
            CompFileType::Type0
        }
        Some(f) => match leading_int(&f.value) {
            None => {
                return Err(ini
                    .error_at(
                        f.line,
                        format!("COMP_FILE_TYPE = {} is not a number", f.value),
                        "LinuxCNC does not start with it: write COMP_FILE_TYPE = 0 or 1",
                    )
                    .into())
            }
            Some(0) => CompFileType::Type0,
            Some(n) => {
                if n != 1 {
                    notes.push(format!("{}: COMP_FILE_TYPE = {}: LinuxCNC reads every type but 0 as type 1 (nominal, trim forward, trim reverse)", ini.place(f.line), f.value));
                }
                CompFileType::Type1
            }
        },
    };
    let (path, body) = read_file(&file.value).map_err(|e| match e {
        ControllerReadError::Io { path, source } => {
            let help = if file.value.contains(['#', ';']) {
                "LinuxCNC takes everything after `=` as the file name, a `#` or `;` comment included (its INI reader has no comments after a value): put the comment on a line of its own"
            } else {
                "LinuxCNC opens COMP_FILE relative to the INI's folder and does not start without it"
            };
            ini.error_at(
                file.line,
                format!(
                    "cannot read the comp file {}: {source}",
                    crate::io::shown_path(&path)
                ),
                help,
            )
            .into()
        }
        other => other,
    })?;
    if backlash != 0.0 {
        notes.push(format!("[{section}] BACKLASH = {} is not applied: LinuxCNC uses only the comp file when one is loaded (control.c, compute_screw_comp)", fixed(backlash, 6)));
    }
    let table = linuxcnc_comp::parse(&body, &path, ty, units)?;
    Ok(Some((
        JointComp {
            table: Some(table),
            backlash: None,
        },
        start,
    )))
}

/// Reads the compensation a LinuxCNC INI file configures, as LinuxCNC
/// applies it: `[TRAJ] LINEAR_UNITS`, `[KINS] JOINTS` and `KINEMATICS`
/// (trivkins and its `coordinates=`), and for every joint of X, Y or Z its
/// `COMP_FILE` (relative to the INI's folder), `COMP_FILE_TYPE` and
/// `BACKLASH`. `read_file` reads a file named in the INI (`#INCLUDE`,
/// `COMP_FILE`). Joints of one axis (a gantry) must be compensated alike.
pub fn parse_ini(
    text: &str,
    file: &str,
    mut read_file: impl FnMut(&str) -> Result<(String, String), ControllerReadError>,
) -> Result<ControllerCorrection, ControllerReadError> {
    let ini = Ini::parse(text, file, &mut read_file)?;
    let units = linear_units(&ini)?;
    let mut notes = Vec::new();
    for (key, section) in [
        ("LINEAR_UNITS", "TRAJ"),
        ("KINEMATICS", "KINS"),
        ("JOINTS", "KINS"),
    ] {
        notes.extend(ini.ignored(key, section));
    }
    let joints_key = ini.find("JOINTS", "KINS");
    let active = match &joints_key {
        None => None,
        Some(f) => Some(
            leading_int(&f.value)
                .filter(|n| (1..=MAX_JOINTS as i64).contains(n))
                .ok_or_else(|| {
                    ini.error_at(
                        f.line,
                        format!("JOINTS = {}", f.value),
                        "LinuxCNC takes 1 to 16 joints",
                    )
                })? as usize,
        ),
    };
    // Every joint's compensation (an absent section: none), with its line.
    let mut comps: Vec<(JointComp, Option<usize>)> = Vec::new();
    for j in 0..MAX_JOINTS {
        let c = joint(&ini, j, units, &mut notes, &mut read_file)?;
        let compensated = c
            .as_ref()
            .is_some_and(|(c, _)| c.table.is_some() || c.backlash.is_some());
        if let (Some(n), true) = (active, compensated) {
            if j >= n {
                notes.push(format!(
                    "[JOINT_{j}] is compensated but not used: [KINS] JOINTS = {n}"
                ));
            }
        }
        comps.push(match c {
            Some((c, line)) => (c, Some(line)),
            None => (
                JointComp {
                    table: None,
                    backlash: None,
                },
                None,
            ),
        });
    }
    let used = active.unwrap_or(MAX_JOINTS);
    let any = comps[..used]
        .iter()
        .any(|(c, _)| c.table.is_some() || c.backlash.is_some());
    let mut out = ControllerCorrection::empty(Format::Linuxcnc);
    if !any {
        notes.push("the INI compensates no joint (no COMP_FILE, BACKLASH 0): volcomp compensates the whole map".into());
        out.notes = notes;
        return Ok(out);
    }
    let Some(active) = active else {
        return Err(ini
            .error_top(
                "no [KINS] JOINTS: which joints LinuxCNC uses is not known".into(),
                "add the number of joints the machine's HAL file loads motmod with, e.g. [KINS] JOINTS = 3",
            )
            .into());
    };
    let axes_of = joint_axes(&ini).map_err(|(line, m, h)| match line {
        Some(l) => ini.error_at(l, m, &h),
        None => ini.error_top(m, &h),
    })?;
    for (j, (c, _)) in comps[..active].iter().enumerate() {
        let compensated = c.table.is_some() || c.backlash.is_some();
        match axes_of.get(j) {
            None if compensated => notes.push(format!(
                "[JOINT_{j}] is compensated but trivkins gives it no axis (coordinates has {} letters)",
                axes_of.len()
            )),
            Some(&a) if a > 2 && compensated => notes.push(format!(
                "[JOINT_{j}] compensates axis {}, which the map does not model",
                &"XYZABCUVW"[a..=a]
            )),
            _ => {}
        }
    }
    for a in 0..3 {
        let joints: Vec<usize> = (0..active.min(axes_of.len()))
            .filter(|&j| axes_of[j] == a)
            .collect();
        let Some(&j0) = joints.first() else { continue };
        let c0 = &comps[j0].0;
        for &j in &joints[1..] {
            if comps[j].0 != *c0 {
                let line = comps[j].1.or(comps[j0].1);
                return Err(differ(&ini, line, a, j0, j).into());
            }
            if c0.table.is_some() || c0.backlash.is_some() {
                notes.push(format!(
                    "joints {j0} and {j} both drive {} (a gantry) with the same compensation",
                    axis_letter(a)
                ));
            }
        }
        out.axes[a] = c0.table.clone();
        out.backlash[a] = c0.backlash;
    }
    out.notes = notes;
    Ok(out)
}

fn differ(
    ini: &Ini,
    line: Option<usize>,
    a: usize,
    j1: usize,
    j2: usize,
) -> crate::error::MapFileError {
    let m = format!(
        "joints {j1} and {j2} both drive {} but are compensated differently",
        axis_letter(a)
    );
    let h = "give every joint of a gantry axis the same COMP_FILE (or BACKLASH): volcomp models one correction per axis, and joints corrected differently rack the gantry";
    match line {
        Some(l) => ini.error_at(l, m, h),
        None => ini.error_top(m, h),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_1_by_hand() {
        // e = +2 µm forward, +5 µm reverse at 100 mm → trims −0.002, −0.005 mm.
        let p = Positioning::new(&[0.0, 100.0], &[0.0, 2.0], &[3.0, 5.0]);
        let e = export(
            &[None, Some(p.clone()), None],
            LinuxcncExport::CompFiles(CompFileType::Type1),
            MachineUnits::Mm,
        )
        .unwrap();
        assert_eq!(e.files.len(), 2);
        assert_eq!(e.files[0].name, "y.comp");
        assert!(
            e.files[1].text.contains(
                "LINEAR_UNITS = mm\n\n[JOINT_1]\nCOMP_FILE = y.comp\nCOMP_FILE_TYPE = 1\n"
            ),
            "{}",
            e.files[1].text
        );
        let back = parse_ini(&e.files[1].text, "comp.ini", |n| {
            assert_eq!(n, "y.comp");
            Ok((n.to_string(), e.files[0].text.clone()))
        })
        .unwrap();
        assert_eq!(back, e.applied);
        assert_eq!(e.files[0].text, "0 0 -0.003\n100 -0.002 -0.005\n");
        assert_eq!(e.applied.axes[1].as_ref(), Some(&p));
        assert!(e.rounding.max_um < 1e-6);
        // LinuxCNC chooses the table by direction: reverse at 50 mm is 4 µm.
        assert!((e.applied.correction_um(1, 50.0, false) - 4.0).abs() < 1e-12);
    }
}

#[cfg(test)]
mod ini_tests {
    use super::*;
    use crate::io::controllers::test_support::{assert_noted, reader};

    /// `parse_ini` with comp files from `files`.
    fn read(
        ini: &str,
        files: &[(&str, &str)],
    ) -> Result<ControllerCorrection, ControllerReadError> {
        parse_ini(ini, "m.ini", reader(files))
    }

    const HEAD: &str =
        "[TRAJ]\nLINEAR_UNITS = mm\n[KINS]\nKINEMATICS = trivkins coordinates=XYZ\nJOINTS = 3\n";
    // Type 1: trims −0.002 / −0.005 mm at 100 mm → e = +2 µm forward, +5 µm reverse.
    const Y1: &str = "0 0 0\n100 -0.002 -0.005\n";

    #[test]
    fn backlash_alone_is_split_and_ignored_beside_a_comp_file() {
        let c = read(&format!("{HEAD}[JOINT_0]\nBACKLASH = 0.004\n[JOINT_1]\nBACKLASH = 0.003\nCOMP_FILE = y.comp\nCOMP_FILE_TYPE = 1\n"), &[("y.comp", Y1)]).unwrap();
        // X: ±2 µm (LinuxCNC adds +B/2 to the motor moving up: c = −B/2).
        assert_eq!(c.correction_um(0, 10.0, true), -2.0);
        assert_eq!(c.correction_um(0, 10.0, false), 2.0);
        // Y: the comp file only; BACKLASH 0.003 is not applied, and said so.
        assert!((c.correction_um(1, 100.0, false) - 5.0).abs() < 1e-9);
        assert!(c.backlash[1].is_none());
        assert_noted(&c.notes, "BACKLASH = 0.003 is not applied");
    }

    #[test]
    fn comp_file_type_defaults_to_0_and_hash_stays_in_the_name() {
        // Type 0: at 100 the axis reaches 100.002 forward, 100.005 reverse.
        let c = read(
            &format!("{HEAD}[JOINT_2]\nCOMP_FILE = z#1.comp\n"),
            &[("z#1.comp", "0 0 0\n100 100.002 100.005\n")],
        )
        .unwrap();
        assert!((c.correction_um(2, 100.0, true) - 2.0).abs() < 1e-9);
        assert_noted(&c.notes, "default 0");
        // A comment after the name is part of the name for LinuxCNC.
        let e = read(
            &format!("{HEAD}[JOINT_2]\nCOMP_FILE = z.comp # Z\n"),
            &[("z.comp", Y1)],
        )
        .unwrap_err();
        let ControllerReadError::Format(e) = e else {
            panic!()
        };
        assert_eq!(e.row, 7);
        assert!(e.help.contains("comment"), "{e}");
    }

    #[test]
    fn an_appended_section_is_not_read() {
        // The machine's own [JOINT_1] first, a comp.ini appended below it.
        let c = read(&format!("{HEAD}[JOINT_1]\nTYPE = LINEAR\n\n[JOINT_1]\nCOMP_FILE = y.comp\nCOMP_FILE_TYPE = 1\n"), &[("y.comp", Y1)]).unwrap();
        assert!(c.axes[1].is_none());
        assert_eq!(c.correction_um(1, 100.0, true), 0.0);
        assert_noted(&c.notes, "second [JOINT_1] section");
    }

    #[test]
    fn gantry_joints_follow_the_kinematics() {
        let head = "[TRAJ]\nLINEAR_UNITS = mm\n[KINS]\nKINEMATICS = trivkins coordinates=XYYZ kinstype=BOTH\nJOINTS = 4\n";
        let same = format!("{head}[JOINT_1]\nCOMP_FILE = y.comp\nCOMP_FILE_TYPE = 1\n[JOINT_2]\nCOMP_FILE = y.comp\nCOMP_FILE_TYPE = 1\n[JOINT_3]\nBACKLASH = 0.002\n");
        let c = read(&same, &[("y.comp", Y1)]).unwrap();
        // Joint 2 is the second Y motor, joint 3 is Z.
        assert!(c.axes[1].is_some() && c.axes[2].is_none());
        assert_eq!(c.correction_um(2, 0.0, true), -1.0);
        assert_noted(&c.notes, "gantry");
        // One Y motor compensated, the other not: refused at its section.
        let one = format!(
            "{head}[JOINT_1]\nCOMP_FILE = y.comp\nCOMP_FILE_TYPE = 1\n[JOINT_2]\nTYPE = LINEAR\n"
        );
        let ControllerReadError::Format(e) = read(&one, &[("y.comp", Y1)]).unwrap_err() else {
            panic!()
        };
        assert_eq!(e.row, 9, "{e}");
        assert!(e.message.contains("joints 1 and 2 both drive Y"), "{e}");
    }

    #[test]
    fn the_kinematics_and_joints_must_be_known() {
        let body = "[JOINT_0]\nBACKLASH = 0.002\n";
        let e = read(
            &format!("[TRAJ]\nLINEAR_UNITS = mm\n[KINS]\nJOINTS = 3\n{body}"),
            &[],
        )
        .unwrap_err();
        assert!(e.to_string().contains("KINEMATICS"), "{e}");
        let e = read(
            &format!(
                "[TRAJ]\nLINEAR_UNITS = mm\n[KINS]\nKINEMATICS = corexykins\nJOINTS = 3\n{body}"
            ),
            &[],
        )
        .unwrap_err();
        let ControllerReadError::Format(e) = e else {
            panic!()
        };
        assert_eq!(e.row, 4);
        // Without compensation nothing needs them.
        let c = read("[TRAJ]\nLINEAR_UNITS = inch\n", &[]).unwrap();
        assert!(c.is_empty());
        // Joints beyond JOINTS are not used.
        let c = read("[TRAJ]\nLINEAR_UNITS = 1.0\n[KINS]\nKINEMATICS = trivkins\nJOINTS = 1\n[JOINT_0]\nBACKLASH = 0.002 # mm\n[JOINT_1]\nBACKLASH = 0.004\n", &[]).unwrap();
        assert_eq!(c.correction_um(0, 0.0, false), 1.0);
        assert!(c.backlash[1].is_none());
        assert_noted(&c.notes, "JOINTS = 1");
    }

    #[test]
    fn backlash_only_export_reads_back() {
        // Reversal 3, 4, 5.2 µm → mean 4.0667 µm, split ±2.0333.
        let x = Positioning::new(&[0.0, 50.0, 100.0], &[0.0, 1.0, 2.0], &[3.0, 5.0, 7.2]);
        let e = export(
            &[Some(x), None, None],
            LinuxcncExport::BacklashOnly,
            MachineUnits::Mm,
        )
        .unwrap();
        assert_eq!(e.files.len(), 1);
        let ini = &e.files[0].text;
        assert!(ini.contains("[JOINT_0]\n# the mean"), "{ini}");
        assert!(ini.contains("BACKLASH = 0.0040666667\n"), "{ini}");
        let back = read(ini, &[]).unwrap();
        assert_eq!(back.backlash, e.applied.backlash);
        assert!((back.correction_um(0, 5.0, false) - 2.03333335).abs() < 1e-9);
    }
}
