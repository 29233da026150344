//! LinuxCNC through `volcomp map export --to linuxcnc`: the comp files of
//! [`crate::io::linuxcnc_comp`] (`x.comp`, `y.comp`, `z.comp`), with the
//! correction LinuxCNC applies from them.

use super::{
    axis_letter, ControllerCorrection, Export, ExportFile, Format, LimitError, Positioning,
    Rounding,
};
use crate::io::linuxcnc_comp::{self, CompFileType, MachineUnits, MAX_ENTRIES};

/// Writes one comp file per axis with a table (LinuxCNC keeps both
/// directions, so nothing is averaged). Values are written with ten
/// decimals of a machine unit: the rounding is reported all the same.
pub fn export(
    p: &[Option<Positioning>; 3],
    ty: CompFileType,
    units: MachineUnits,
) -> Result<Export, LimitError> {
    let mut files = Vec::new();
    let mut applied: [Option<Positioning>; 3] = [None, None, None];
    let mut rounding = Rounding {
        resolution_um: 1e-10 * units.mm_per_unit() * 1e3,
        max_um: 0.0,
    };
    let mut notes = vec![format!(
        "LinuxCNC INI (joints 0, 1, 2 = X, Y, Z with trivkins): COMP_FILE_TYPE = {}; remove BACKLASH, the comp files hold the reversal",
        ty.number()
    )];
    for (a, table) in p.iter().enumerate() {
        let Some(table) = table else { continue };
        let name = format!("{}.comp", axis_letter(a).to_ascii_lowercase());
        let text = linuxcnc_comp::write(table, ty, units).map_err(|e| LimitError {
            format: "linuxcnc",
            axis: axis_letter(a),
            message: e.to_string(),
            help: format!(
                "resample the table with a step of at least {} mm (linear interpolation)",
                crate::io::numfmt::fixed(
                    (table.positions_mm[table.positions_mm.len() - 1] - table.positions_mm[0])
                        / (MAX_ENTRIES - 1) as f64,
                    3
                )
            ),
        })?;
        let back = linuxcnc_comp::parse(&text, &name, ty, units).map_err(|e| LimitError {
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
        notes.push(format!("[JOINT_{a}] COMP_FILE = {name}"));
        applied[a] = Some(back);
        files.push(ExportFile { name, text });
    }
    let mut ini = format!(
        "# volcomp: LinuxCNC compensation (joints 0, 1, 2 = X, Y, Z with trivkins); merge into the machine's INI file\n[TRAJ]\nLINEAR_UNITS = {}\n",
        match units {
            MachineUnits::Mm => "mm",
            MachineUnits::Inch => "inch",
        }
    );
    for f in &files {
        let a = "xyz".find(&f.name[..1]).unwrap_or(0);
        ini.push_str(&format!(
            "\n[JOINT_{a}]\nCOMP_FILE = {}\nCOMP_FILE_TYPE = {}\nBACKLASH = 0\n",
            f.name,
            ty.number()
        ));
    }
    files.push(ExportFile {
        name: "comp.ini".into(),
        text: ini,
    });
    Ok(Export {
        files,
        applied: ControllerCorrection {
            format: Format::Linuxcnc,
            axes: applied,
            squareness_urad: None,
            cross: Vec::new(),
        },
        rounding,
        notes,
    })
}

/// Reads the compensation a LinuxCNC INI file configures: `[TRAJ]
/// LINEAR_UNITS` (`mm`/`metric` or `inch`/`in`/`imperial`) and, for joints
/// 0, 1, 2 (X, Y, Z with trivkins), `COMP_FILE` (relative to the INI's
/// folder) and `COMP_FILE_TYPE`. `read_file` reads a named comp file.
pub fn parse_ini(
    text: &str,
    file: &str,
    mut read_file: impl FnMut(&str) -> Result<(String, String), super::ControllerReadError>,
) -> Result<ControllerCorrection, super::ControllerReadError> {
    let err = |row: usize, m: String, h: &str| super::located(file, text, row, m, h);
    let mut section = String::new();
    let mut units: Option<(String, usize)> = None;
    // Per joint: (COMP_FILE, COMP_FILE_TYPE), each with its row.
    type Entry = Option<(String, usize)>;
    let mut comp: [(Entry, Entry); 3] = Default::default();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if let Some(sname) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            section = sname.trim().to_string();
            continue;
        }
        let Some((k, v)) = line.split_once('=') else {
            continue;
        };
        let (k, v) = (k.trim(), v.trim().to_string());
        match (section.as_str(), k) {
            ("TRAJ", "LINEAR_UNITS") => units = Some((v, i + 1)),
            (sec, "COMP_FILE" | "COMP_FILE_TYPE") => {
                if let Some(j) = sec
                    .strip_prefix("JOINT_")
                    .and_then(|n| n.parse::<usize>().ok())
                    .filter(|&j| j < 3)
                {
                    if k == "COMP_FILE" {
                        comp[j].0 = Some((v, i + 1));
                    } else {
                        comp[j].1 = Some((v, i + 1));
                    }
                }
            }
            _ => {}
        }
    }
    let Some((u, urow)) = units else {
        return Err(err(
            1,
            "no [TRAJ] LINEAR_UNITS".into(),
            "comp files are in machine units: the INI must say LINEAR_UNITS",
        )
        .into());
    };
    let units = match u.to_ascii_lowercase().as_str() {
        "mm" | "metric" => MachineUnits::Mm,
        "inch" | "in" | "imperial" => MachineUnits::Inch,
        _ => {
            return Err(err(
                urow,
                format!("LINEAR_UNITS = {u}"),
                "volcomp reads mm (metric) or inch (imperial)",
            )
            .into())
        }
    };
    let mut axes: [Option<Positioning>; 3] = [None, None, None];
    for (j, (f, t)) in comp.iter().enumerate() {
        let Some((name, row)) = f else { continue };
        let ty = match t {
            Some((n, trow)) => n
                .parse::<u8>()
                .ok()
                .and_then(CompFileType::from_number)
                .ok_or_else(|| {
                    err(
                        *trow,
                        format!("COMP_FILE_TYPE = {n}"),
                        "COMP_FILE_TYPE is 0 or 1",
                    )
                })?,
            None => {
                return Err(err(
                    *row,
                    format!("[JOINT_{j}] has COMP_FILE but no COMP_FILE_TYPE"),
                    "give COMP_FILE_TYPE 0 or 1",
                )
                .into())
            }
        };
        // inputs lane: a comp file that cannot be read is reported at the
        // INI line that names it.
        let (path, body) = read_file(name).map_err(|e| match e {
            super::ControllerReadError::Io { path, source } => {
                super::ControllerReadError::from(err(
                    *row,
                    format!(
                        "cannot read the comp file {}: {source}",
                        crate::io::shown_path(&path)
                    ),
                    "COMP_FILE is read relative to the INI file's folder",
                ))
            }
            other => other,
        })?;
        axes[j] = Some(linuxcnc_comp::parse(&body, &path, ty, units)?);
    }
    if axes.iter().all(Option::is_none) {
        return Err(err(
            1,
            "no [JOINT_0…2] COMP_FILE".into(),
            "the INI configures no screw compensation for joints 0, 1, 2",
        )
        .into());
    }
    Ok(ControllerCorrection {
        format: Format::Linuxcnc,
        axes,
        squareness_urad: None,
        cross: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_1_by_hand() {
        // e = +2 µm forward, +5 µm reverse at 100 mm → trims −0.002, −0.005 mm.
        let p = Positioning {
            positions_mm: vec![0.0, 100.0],
            forward_um: vec![0.0, 2.0],
            reverse_um: vec![3.0, 5.0],
        };
        let e = export(
            &[None, Some(p.clone()), None],
            CompFileType::Type1,
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
