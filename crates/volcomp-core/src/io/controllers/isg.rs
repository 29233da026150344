//! Beckhoff TwinCAT CNC / ISG kernel: the leadscrew error compensation
//! lists (`kw.ssfk.*` in an axis' compensation value list `achskw*.lis`,
//! [ISG SSFK]) and the volumetric compensation's ISG CSV with ISO 230-1
//! component names ([ISG VolComp]; docs/controllers.md).
//!
//! Leadscrew error compensation, as the ISG/Beckhoff documentation gives it:
//!
//! * `kw.ssfk.unit 1`: positions and values in 0.1 µm (integers, SGN32);
//! * `kw.ssfk.interval 0`: every point's position in
//!   `kw.ssfk.table[i].setpoint` (volcomp writes the points it has);
//! * `kw.ssfk.bilateral 1`: `table[i].pos` for the positive direction of
//!   motion, `table[i].neg` for the negative one;
//! * the value is `Δs = s_actual − s_setpoint`, the measured error: volcomp's
//!   `e` (the documentation's example: setpoint 19866.7 µm, actual
//!   19856.5 µm going positive → −102, 19874.7 µm going negative → 80);
//! * linear interpolation; outside the table the end value is used;
//! * `kw_nr_max` entries (P-COMP-00020), which must be smaller than
//!   P-COMP-00059 `kw.ssfk.max_points` (1500 by default): at most 1499.

use super::{
    axis_letter, located, ControllerCorrection, Export, ExportFile, Format, LimitError,
    Positioning, ReadError, Rounding,
};
use crate::io::finite;
use crate::io::numfmt::fixed;
use volcomp_gcode::Vec3;

/// Default P-COMP-00059 `kw.ssfk.max_points`: a table holds fewer entries
/// (P-COMP-00020: `kw_nr_max < P-COMP-00059`).
pub const SSFK_MAX_POINTS: usize = 1500;

/// The leadscrew compensation lists `achskw_x.lis` … for the axes with a
/// table: bilateral, positions and values in 0.1 µm.
pub fn ssfk_export(p: &[Option<Positioning>; 3], max_points: usize) -> Result<Export, LimitError> {
    let mut rounding = Rounding {
        resolution_um: 0.1,
        max_um: 0.0,
    };
    let mut files = Vec::new();
    let mut applied: [Option<Positioning>; 3] = [None, None, None];
    for (a, table) in p.iter().enumerate() {
        let Some(table) = table else { continue };
        let ax = axis_letter(a);
        let n = table.positions_mm.len();
        // P-COMP-00020: 0 ≤ kw_nr_max < P-COMP-00059 (kw.ssfk.max_points).
        if n >= max_points {
            return Err(LimitError {
                format: "isg-ssfk",
                axis: ax,
                message: format!(
                    "{n} interpolation points; kw_nr_max must be smaller than P-COMP-00059 kw.ssfk.max_points = {max_points}"
                ),
                help: format!(
                    "resample with a step of at least {} mm, or raise P-COMP-00059",
                    fixed(
                        (table.positions_mm[n - 1] - table.positions_mm[0])
                            / (max_points.max(3) - 2) as f64,
                        3
                    )
                ),
            });
        }
        let mut text = format!(
            "# volcomp: leadscrew error compensation of {ax}, positions and values in 0.1 um, value = actual - setpoint\nkopf.achs_nr                 {}\nkopf.log_achs_name           {ax}\nkw.ssfk.interval             0\nkw.ssfk.kw_startpos          {}\nkw.ssfk.kw_nr_max            {n}\nkw.ssfk.unit                 1\nkw.ssfk.bilateral            1\n",
            a + 1,
            (table.positions_mm[0] * 1e4).round() as i64
        );
        let setpoints: Vec<i64> = table
            .positions_mm
            .iter()
            .map(|x| (x * 1e4).round() as i64)
            .collect();
        let pos: Vec<i64> = table
            .forward_um
            .iter()
            .map(|&v| (rounding.round(v) * 10.0).round() as i64)
            .collect();
        let neg: Vec<i64> = table
            .reverse_um
            .iter()
            .map(|&v| (rounding.round(v) * 10.0).round() as i64)
            .collect();
        for (i, s) in setpoints.iter().enumerate() {
            text.push_str(&format!("kw.ssfk.table[{i}].setpoint   {s}\n"));
        }
        for (i, v) in pos.iter().enumerate() {
            text.push_str(&format!("kw.ssfk.table[{i}].pos        {v}\n"));
        }
        for (i, v) in neg.iter().enumerate() {
            text.push_str(&format!("kw.ssfk.table[{i}].neg        {v}\n"));
        }
        applied[a] = Some(Positioning {
            positions_mm: setpoints.iter().map(|&s| s as f64 * 1e-4).collect(),
            forward_um: pos.iter().map(|&v| v as f64 * 0.1).collect(),
            reverse_um: neg.iter().map(|&v| v as f64 * 0.1).collect(),
        });
        files.push(ExportFile {
            name: format!("achskw_{}.lis", ax.to_ascii_lowercase()),
            text,
        });
    }
    Ok(Export {
        files,
        applied: ControllerCorrection { axes: applied, ..ControllerCorrection::empty(Format::IsgSsfk) },
        rounding,
        holds: [super::table_error::Holds::BothDirections; 3],
        zero_at: None,
        notes: vec![
            "activate with lr_param.ssfk 1 (P-AXIS-00175) in each axis' parameter list and name the achskw_*.lis in the start-up description".into(),
        ],
    })
}

/// Reads one axis' leadscrew compensation list (`kw.ssfk.*`, unit 1 =
/// 0.1 µm; equidistant `interval` tables and unilateral ones too) into
/// volcomp's sign (µm). `#` and `;` start comments.
pub fn ssfk_parse(text: &str, file: &str) -> Result<Positioning, ReadError> {
    let err = |row: usize, m: String, h: &str| located(file, text, row, m, h);
    let (mut interval, mut start, mut n_max, mut unit, mut bilateral) =
        (None, None, None, None, None);
    let mut setpoint: Vec<Option<f64>> = Vec::new();
    let mut pos: Vec<Option<f64>> = Vec::new();
    let mut neg: Vec<Option<f64>> = Vec::new();
    let mut last_row = 1;
    for (i, raw) in text.lines().enumerate() {
        let row = i + 1;
        let line = raw.split(['#', ';']).next().unwrap_or("").trim();
        if line.is_empty() || line.starts_with("kopf.") {
            continue;
        }
        let mut f = line.split_whitespace();
        let (Some(key), Some(value), None) = (f.next(), f.next(), f.next()) else {
            return Err(err(
                row,
                format!("`{line}` is not `name value`"),
                "each line of a compensation list is a name and one value",
            ));
        };
        let Some(key) = key.strip_prefix("kw.ssfk.") else {
            return Err(err(
                row,
                format!("`{key}` is not a kw.ssfk entry"),
                "volcomp reads the leadscrew error compensation (kw.ssfk.*) of a list",
            ));
        };
        let v = finite(value).ok_or_else(|| {
            err(
                row,
                format!("`{value}` is not a number"),
                "positions and values are integers in 0.1 µm",
            )
        })?;
        last_row = row;
        let slot = |list: &mut Vec<Option<f64>>, idx: &str| -> Result<(), ReadError> {
            let k: usize = idx.parse().ok().filter(|&k| k < 100_000).ok_or_else(|| {
                err(
                    row,
                    format!("`{idx}` is not a table index"),
                    "indices are 0 … kw_nr_max − 1",
                )
            })?;
            if list.len() <= k {
                list.resize(k + 1, None);
            }
            list[k] = Some(v);
            Ok(())
        };
        match key {
            "interval" => interval = Some(v),
            "kw_startpos" => start = Some(v),
            "kw_nr_max" => n_max = Some(v as usize),
            "unit" => unit = Some(v),
            "bilateral" => bilateral = Some(v != 0.0),
            "modulo" if v != 0.0 => {
                return Err(err(
                    row,
                    "a modulo axis".into(),
                    "volcomp reads tables of linear axes",
                ))
            }
            "modulo" | "manual_activation" | "set_pos_without_comp" => {}
            k => {
                let Some((idx, field)) = k.strip_prefix("table[").and_then(|r| r.split_once("]."))
                else {
                    return Err(err(row, format!("`kw.ssfk.{k}` is not known"), "expected interval, kw_startpos, kw_nr_max, unit, bilateral or table[i].setpoint/pos/neg"));
                };
                match field {
                    "setpoint" => slot(&mut setpoint, idx)?,
                    "pos" => slot(&mut pos, idx)?,
                    "neg" => slot(&mut neg, idx)?,
                    _ => {
                        return Err(err(
                            row,
                            format!("`{field}` is not setpoint, pos or neg"),
                            "table entries are setpoint, pos and neg",
                        ))
                    }
                }
            }
        }
    }
    if unit != Some(1.0) {
        return Err(err(
            last_row,
            "kw.ssfk.unit is not 1 (metric, 0.1 µm)".into(),
            "volcomp reads metric lists (unit 1); encoder increments need the encoder's resolution",
        ));
    }
    let n = n_max.ok_or_else(|| {
        err(
            last_row,
            "no kw.ssfk.kw_nr_max".into(),
            "give the number of entries",
        )
    })?;
    let full = |list: &[Option<f64>], what: &str| -> Result<Vec<f64>, ReadError> {
        if list.len() != n || list.iter().any(Option::is_none) {
            return Err(err(
                last_row,
                format!("{what}: {} of {n} entries", list.iter().flatten().count()),
                "give every entry 0 … kw_nr_max − 1",
            ));
        }
        Ok(list.iter().flatten().copied().collect())
    };
    let positions = match interval {
        Some(iv) if iv != 0.0 => {
            let s = start.ok_or_else(|| {
                err(
                    last_row,
                    "an equidistant table without kw_startpos".into(),
                    "give kw.ssfk.kw_startpos",
                )
            })?;
            (0..n).map(|k| (s + iv * k as f64) * 1e-4).collect()
        }
        _ => full(&setpoint, "setpoint")?
            .iter()
            .map(|s| s * 1e-4)
            .collect::<Vec<f64>>(),
    };
    if positions.windows(2).any(|w| w[1] <= w[0]) || n < 2 {
        return Err(err(
            last_row,
            "the setpoints do not increase".into(),
            "interpolation points are in increasing order, at least two",
        ));
    }
    let fwd: Vec<f64> = full(&pos, "pos")?.iter().map(|v| v * 0.1).collect();
    let rev = if bilateral.unwrap_or(false) {
        full(&neg, "neg")?.iter().map(|v| v * 0.1).collect()
    } else {
        fwd.clone()
    };
    Ok(Positioning {
        positions_mm: positions,
        forward_um: fwd,
        reverse_um: rev,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_documentations_example_point() {
        // [ISG SSFK] example: at setpoint 19866.7 µm the axis reached
        // 19856.5 µm going positive and 19874.7 µm going negative:
        // Δs = −10.2 µm → −102 and +8.0 µm → 80 (0.1 µm units).
        let y = Positioning::new(
            &[0.0, 19.8667],
            &[0.0, 19856.5 - 19866.7],
            &[0.0, 19874.7 - 19866.7],
        );
        let e = ssfk_export(&[None, Some(y), None], SSFK_MAX_POINTS).unwrap();
        assert_eq!(e.files[0].name, "achskw_y.lis");
        let t = &e.files[0].text;
        for line in [
            "kw.ssfk.unit                 1\n",
            "kw.ssfk.bilateral            1\n",
            "kw.ssfk.kw_nr_max            2\n",
            "kw.ssfk.table[1].setpoint   198667\n",
            "kw.ssfk.table[1].pos        -102\n",
            "kw.ssfk.table[1].neg        80\n",
        ] {
            assert!(t.contains(line), "{line} missing in\n{t}");
        }
        let back = ssfk_parse(t, "achskw_y.lis").unwrap();
        assert_eq!(&back, e.applied.axes[1].as_ref().unwrap());
        assert!(
            (back.forward_um[1] - -10.2).abs() < 1e-9 && (back.reverse_um[1] - 8.0).abs() < 1e-9
        );
    }

    #[test]
    fn rounding_limits_and_equidistant_lists() {
        // 1.26 µm → 13 (0.1 µm), 0.04 µm rounding.
        let x = Positioning::new(&[0.0, 10.0], &[0.0, 1.26], &[0.0, 1.26]);
        let e = ssfk_export(&[Some(x.clone()), None, None], SSFK_MAX_POINTS).unwrap();
        assert!(e.files[0].text.contains("kw.ssfk.table[1].pos        13\n"));
        assert!((e.rounding.max_um - 0.04).abs() < 1e-9);
        let err = ssfk_export(&[Some(x), None, None], 1).unwrap_err();
        assert!(err.message.contains("smaller than P-COMP-00059"), "{err}");
        // Two points need max_points 3: kw_nr_max 2 < 3.
        let two = Positioning::new(&[0.0, 10.0], &[0.0, 0.0], &[0.0, 0.0]);
        assert!(ssfk_export(&[Some(two.clone()), None, None], 2).is_err());
        assert!(ssfk_export(&[Some(two), None, None], 3).is_ok());
        // An equidistant, unilateral list: −200 mm every 0.5 mm.
        let t = "kw.ssfk.interval 5000\nkw.ssfk.kw_startpos -2000000\nkw.ssfk.kw_nr_max 3\nkw.ssfk.unit 1\nkw.ssfk.bilateral 0\nkw.ssfk.table[0].pos 0\nkw.ssfk.table[1].pos 24\nkw.ssfk.table[2].pos -102\n";
        let p = ssfk_parse(t, "a.lis").unwrap();
        assert_eq!(p.positions_mm, vec![-200.0, -199.5, -199.0]);
        assert_eq!(p.reverse_um, p.forward_um);
        assert!((p.forward_um[2] - -10.2).abs() < 1e-9);
        let e = ssfk_parse("kw.ssfk.unit 0\nkw.ssfk.kw_nr_max 2\n", "a.lis").unwrap_err();
        assert!(e.message.contains("unit"), "{e}");
    }
}

/// Keys of a volumetric compensation list that do not change the
/// correction volcomp models (axis numbers, start-up behaviour, filters,
/// memory bounds), compared in lower case.
const LIS_NEUTRAL: [&str; 12] = [
    "x",
    "y",
    "z",
    "a",
    "b",
    "c",
    "enable_splicing",
    "filter_steps",
    "manual_activation",
    "associate_to_channel",
    "max_records",
    "vol_comp[0].max_records",
];

/// Reads an ISG volumetric compensation configuration list (`*.lis`) as
/// the controller reads it ([ISG VolComp], P-VOLC-00009 … P-VOLC-00013):
/// every parameter file `file[j]` (0 ≤ j < 10, relative to the list's
/// folder; `read_file` reads one) in its `file_format[j]`, `ISG_CSV` (the
/// default) or `ETALON_EXCHANGE`, merged into one 21-component model on the
/// seed chain measured at the origin; `negate` and `set_to_zero` (the
/// output axes whose compensation value the controller negates or zeroes).
/// A parameter given in two files is refused (no document says which one
/// the controller takes), as are settings volcomp does not model: a
/// `chain` other than `XYZ`, `workpiece_axes` other than 0, an
/// `alternative_model`, an `Interpolation` other than `GRID`, and keys it
/// does not know.
pub fn parse_volcomp_lis(
    text: &str,
    file: &str,
    mut read_file: impl FnMut(&str) -> Result<(String, String), super::ControllerReadError>,
) -> Result<crate::model::controller::Volumetric, super::ControllerReadError> {
    use crate::io::exchange::{self, Parameters};
    let err = |row: usize, m: String, h: &str| located(file, text, row, m, h);
    let mut files: [Option<(String, usize)>; 10] = Default::default();
    let mut formats: [Option<(String, usize)>; 10] = Default::default();
    let mut negate = [false; 3];
    let mut zero = [false; 3];
    let mut notes = Vec::new();
    let axes_of = |v: &str,
                   row: usize,
                   notes: &mut Vec<String>|
     -> Result<[bool; 3], crate::error::MapFileError> {
        let mut out = [false; 3];
        for c in v.chars() {
            match "XYZ".find(c.to_ascii_uppercase()) {
                Some(a) => out[a] = true,
                None if "ABC".contains(c.to_ascii_uppercase()) => notes.push(format!(
                    "{file}:{row}: `{c}` is a rotary axis, which the map does not model"
                )),
                None => {
                    return Err(err(
                        row,
                        format!("`{c}` is not an axis name"),
                        "write the axes as a set of letters, e.g. XY",
                    ))
                }
            }
        }
        Ok(out)
    };
    for (i, raw) in text.lines().enumerate() {
        let row = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let mut f = line.split_whitespace();
        let key = f.next().unwrap_or("");
        let value = f.next().unwrap_or("");
        let lower = key.to_ascii_lowercase();
        let index = |prefix: &str| -> Option<usize> {
            lower
                .strip_prefix(prefix)
                .and_then(|r| r.strip_suffix(']'))
                .and_then(|n| n.parse().ok())
        };
        let listed = match index("file[") {
            Some(j) => Some(("file", j, &mut files)),
            None => index("file_format[").map(|j| ("file_format", j, &mut formats)),
        };
        if let Some((list, j, slots)) = listed {
            if j >= 10 {
                return Err(err(
                    row,
                    format!("{key}: no such parameter file"),
                    &format!("the volumetric compensation reads {list}[0] … {list}[9]"),
                )
                .into());
            }
            slots[j] = Some((value.to_string(), row));
        } else {
            match lower.as_str() {
                "negate" => negate = axes_of(value, row, &mut notes)?,
                "set_to_zero" => zero = axes_of(value, row, &mut notes)?,
                "chain" if value.eq_ignore_ascii_case("XYZ") => {}
                "workpiece_axes" if value == "0" => {}
                "alternative_model" if ["0", "false"].contains(&value.to_ascii_lowercase().as_str()) => {}
                "interpolation" if value.eq_ignore_ascii_case("GRID") => {}
                "chain" | "workpiece_axes" | "alternative_model" | "interpolation" => {
                    return Err(err(row, format!("{key} {value}: volcomp does not model this configuration"), "volcomp models the volumetric compensation as map export --to isg-csv configures it (chain XYZ, workpiece_axes 0, no alternative_model, Interpolation GRID); for another configuration compensate with the whole map instead of --controller").into())
                }
                k if LIS_NEUTRAL.contains(&k) => {}
                _ => {
                    return Err(err(row, format!("`{key}` is not a setting volcomp knows"), "volcomp reads file[j], file_format[j], negate, set_to_zero and the settings that do not change the correction (axis numbers, filter_steps, manual_activation …); if this one does not change the compensation values, leave it out of the copy given to --controller").into())
                }
            }
        }
    }
    for (a, (n, z)) in negate.iter().zip(&zero).enumerate() {
        if *n && *z {
            notes.push(format!(
                "{} is both negated and set to zero: its compensation is zero",
                super::axis_letter(a)
            ));
        }
    }
    if files.iter().all(Option::is_none) {
        return Err(err(
            1,
            "no file[j]".into(),
            "the list names its parameter files: file[0] volcomp.csv",
        )
        .into());
    }
    for (j, f) in formats.iter().enumerate() {
        if let (Some((_, row)), None) = (f, &files[j]) {
            return Err(err(
                *row,
                format!("file_format[{j}] without file[{j}]"),
                "give the file the format is for",
            )
            .into());
        }
    }
    // Every file's parameters, with their rows moved past the files before
    // them, so that an error found in the merged parameters names its file.
    let mut merged = Parameters::default();
    let mut texts: Vec<(String, String, usize)> = Vec::new(); // (name, text, first row)
    let mut combined = String::new();
    let mut seen: std::collections::HashMap<String, (String, usize)> = Default::default();
    for (j, f) in files.iter().enumerate() {
        let Some((name, row)) = f else { continue };
        let format = formats[j].as_ref().map_or("ISG_CSV", |(f, _)| f.as_str());
        let (shown, body) = read_file(name).map_err(|e| match e {
            super::ControllerReadError::Io { .. } => super::ControllerReadError::from(err(
                *row,
                format!("cannot read file[{j}] {name}"),
                "file[j] is read relative to the list's folder",
            )),
            other => other,
        })?;
        let params = match format {
            "ISG_CSV" => exchange::parse_isg_csv(&body, &shown)?,
            "ETALON_EXCHANGE" => exchange::parse_etalon(&body, &shown)?,
            other => {
                let frow = formats[j].as_ref().map_or(*row, |x| x.1);
                let help = if other.eq_ignore_ascii_case("ETALON") {
                    "the controller's name of the Etalon format is ETALON_EXCHANGE (P-VOLC-00013)"
                } else {
                    "the controller reads ISG_CSV and ETALON_EXCHANGE (P-VOLC-00013)"
                };
                return Err(err(frow, format!("file_format[{j}] {other}"), help).into());
            }
        };
        let offset = combined.lines().count();
        for (n, v, r) in params.constants {
            if let Some((other, orow)) = seen.insert(n.clone(), (shown.clone(), r)) {
                return Err(located(&shown, &body, r, format!("{n} is also given in {other}:{orow}"), "give every parameter in one file only: no document says which one the controller takes").into());
            }
            merged.constants.push((n, v, r + offset));
        }
        for (n, pts, r) in params.tables {
            if let Some((other, orow)) = seen.insert(n.clone(), (shown.clone(), r)) {
                return Err(located(&shown, &body, r, format!("{n} is also given in {other}:{orow}"), "give every parameter in one file only: no document says which one the controller takes").into());
            }
            merged.tables.push((n, pts, r + offset));
        }
        texts.push((shown, body.clone(), offset));
        combined.push_str(&body);
        if !body.ends_with('\n') {
            combined.push('\n');
        }
    }
    let imported = exchange::to_model(
        &merged,
        &texts[0].0,
        &combined,
        crate::model::topology::Topology::SEED,
    )
    .map_err(|mut e| {
        // The file the merged row falls in.
        if let Some((name, _, first)) = texts.iter().rev().find(|(_, _, first)| e.row > *first) {
            e.file = name.clone();
            e.row -= first;
        }
        e
    })?;
    Ok(crate::model::controller::Volumetric {
        model: imported.model,
        negate,
        zero,
        notes,
    })
}

/// Reads the ISG volumetric compensation list `path` ([`parse_volcomp_lis`],
/// its files relative to the list's folder).
pub fn read_volcomp_lis(
    path: &std::path::Path,
) -> Result<crate::model::controller::Volumetric, super::ControllerReadError> {
    let text = super::read_text(path)?;
    let file = path.display().to_string();
    let dir = path.parent().unwrap_or(std::path::Path::new("."));
    parse_volcomp_lis(&text, &file, |n| {
        let p = dir.join(n);
        Ok((p.display().to_string(), super::read_named(&p, path)?))
    })
}

/// Decimals of a written length (mm): 10⁻⁷ mm = 0.0001 µm.
const CSV_MM_DECIMALS: usize = 7;
/// Decimals of a written angle (rad): 10⁻¹⁰ rad = 0.0001 µrad.
const CSV_RAD_DECIMALS: usize = 10;

/// The volumetric compensation's ISG CSV (`volcomp.csv`) and its
/// configuration list (`volcomp.lis`) for a 21-component model: the
/// squareness as position errors `C0Y B0Z A0Z` (see
/// [`crate::io::exchange`] for the signs), then per axis a block of its six
/// component errors over its position, in mm and rad. The ISG CSV has one
/// table for both directions: volcomp writes the mean of the forward and
/// reverse tables and reports the largest reversal value.
pub fn csv_export(model: &crate::model::kinematic::KinematicModel) -> Export {
    use crate::model::kinematic::{angular_name, linear_name};
    use volcomp_geom::Axis;
    let mut rounding = Rounding {
        resolution_um: 1e-4,
        max_um: 0.0,
    };
    let s = &model.kinematics.squareness;
    let mut text = format!(
        "// volcomp: 21-component model, lengths in mm, angles in rad (ISO 230-1 names)\nC0Y B0Z A0Z\n{} {} {}\n",
        fixed(-s.xy_urad * 1e-6, CSV_RAD_DECIMALS),
        fixed(s.zx_urad * 1e-6, CSV_RAD_DECIMALS),
        fixed(-s.yz_urad * 1e-6, CSV_RAD_DECIMALS)
    );
    let mut notes = vec![
        "volcomp.lis names volcomp.csv; set the kinematic chain and the tool's zero position (P0X, P0Y, P0Z) to the model's measuring point in the volumetric compensation's configuration".into(),
    ];
    let mut applied: [Option<Positioning>; 3] = [None, None, None];
    for (a, axis) in Axis::ALL.iter().enumerate() {
        let ax = axis_letter(a);
        let positions = model.positions_mm(*axis);
        let t = &model.axes[a];
        let at = |table: &crate::model::kinematic::ComponentTable, x: f64| -> (Vec3, Vec3) {
            let [lo, hi] = table.range();
            let x = x.clamp(lo, hi);
            (
                table.linear_um.eval(x).unwrap_or(Vec3::ZERO),
                table.angular_urad.eval(x).unwrap_or(Vec3::ZERO),
            )
        };
        text.push_str(&format!("#\n{ax}"));
        for d in 0..3 {
            text.push_str(&format!(" {}", linear_name(d, a)));
        }
        for d in 0..3 {
            text.push_str(&format!(" {}", angular_name(d, a)));
        }
        text.push('\n');
        let mut reversal: f64 = 0.0;
        let mut pos_um = Vec::new();
        for &x in &positions {
            let (lf, af) = at(&t.forward, x);
            let (lr, ar) = at(&t.reverse, x);
            reversal = reversal.max((lf[a] - lr[a]).abs());
            let (l, g) = ((lf + lr) * 0.5, (af + ar) * 0.5);
            text.push_str(&fixed(x, 6));
            for d in 0..3 {
                let r = (l[d] * 1e-3 * 10f64.powi(CSV_MM_DECIMALS as i32)).round()
                    / 10f64.powi(CSV_MM_DECIMALS as i32);
                rounding.max_um = rounding.max_um.max((r * 1e3 - l[d]).abs());
                text.push_str(&format!(" {}", fixed(r, CSV_MM_DECIMALS)));
            }
            for d in 0..3 {
                text.push_str(&format!(" {}", fixed(g[d] * 1e-6, CSV_RAD_DECIMALS)));
            }
            text.push('\n');
            pos_um.push(l[a]);
        }
        if reversal > 0.0 {
            notes.push(format!("{ax}: the ISG CSV holds one table for both directions (the mean); the reversal value, up to {} um, is left out", fixed(reversal, 3)));
        }
        applied[a] = Some(Positioning {
            positions_mm: positions,
            forward_um: pos_um.clone(),
            reverse_um: pos_um,
        });
    }
    let lis = "X                        1\nY                        2\nZ                        3\nInterpolation            GRID\nfile[0]                  volcomp.csv\nfile_format[0]           ISG_CSV\n".to_string();
    Export {
        files: vec![
            ExportFile {
                name: "volcomp.csv".into(),
                text,
            },
            ExportFile {
                name: "volcomp.lis".into(),
                text: lis,
            },
        ],
        applied: ControllerCorrection {
            axes: applied,
            squareness_urad: Some([s.xy_urad, s.yz_urad, s.zx_urad]),
            ..ControllerCorrection::empty(Format::IsgCsv)
        },
        rounding,
        holds: [super::table_error::Holds::OneTable; 3],
        zero_at: None,
        notes,
    }
}

#[cfg(test)]
mod csv_tests {
    use super::*;
    use crate::io::exchange;
    use crate::model::topology::Topology;

    #[test]
    fn csv_round_trip_by_hand() {
        // The Etalon example model of `exchange`'s test, written as ISG CSV and read back.
        let text = "[C0Y]\nVALUE = -0.000012\n[B0Z]\nVALUE = 0.000006\n[A0Z]\nVALUE = 0.000008\n[EXX]\nGridpoints = {\n 0 0\n 100 0.005\n}\n[EBX]\nGridpoints = {\n 0 0.00001\n 100 -0.00001\n}\n[EYY]\nGridpoints = {\n 0 0\n 200 -0.004\n}\n[EZZ]\nGridpoints = {\n 0 0\n 100 0.002\n}\n";
        let p = exchange::parse_etalon(text, "e.txt").unwrap();
        let m = exchange::to_model(&p, "e.txt", text, Topology::SEED)
            .unwrap()
            .model;
        let e = csv_export(&m);
        let csv = &e.files[0].text;
        // S_xy = 12 µrad is written as C0Y = −0.000012 rad; EXX 5 µm as 0.005 mm; EBX 10 µrad as 0.00001 rad.
        assert!(
            csv.contains("C0Y B0Z A0Z\n-0.000012 0.000006 0.000008\n"),
            "{csv}"
        );
        assert!(
            csv.contains(
                "#\nX EXX EYX EZX EAX EBX ECX\n0 0 0 0 0 0.00001 0\n100 0.005 0 0 0 -0.00001 0\n"
            ),
            "{csv}"
        );
        assert!(e.files[1].text.contains("file_format[0]           ISG_CSV"));
        let back = exchange::to_model(
            &exchange::parse_isg_csv(csv, "v.csv").unwrap(),
            "v.csv",
            csv,
            Topology::SEED,
        )
        .unwrap()
        .model;
        assert_eq!(back.kinematics.squareness, m.kinematics.squareness);
        for a in 0..3 {
            assert_eq!(
                back.axes[a].forward.positions_mm(),
                m.axes[a].forward.positions_mm()
            );
            for (x, y) in back.axes[a]
                .forward
                .linear_um
                .errors_um
                .iter()
                .zip(&m.axes[a].forward.linear_um.errors_um)
            {
                assert!((*x - *y).norm() < 1e-4, "{x:?} {y:?}");
            }
        }
    }
}

#[cfg(test)]
mod lis_tests {
    use super::*;
    use crate::io::controllers::test_support::reader;
    use crate::model::controller::{ControllerApplies, ControllerResidual};
    use crate::model::{Components, ErrorModel, ALL_FORWARD};

    fn parse(
        lis: &str,
        files: &[(&str, &str)],
    ) -> Result<crate::model::controller::Volumetric, super::super::ControllerReadError> {
        parse_volcomp_lis(lis, "v.lis", reader(files))
    }

    // EXX 0 → 5 µm over X 0 … 100 (ISG CSV); EYY, EZZ zero.
    const POS: &str = "X EXX\n0 0\n100 0.005\n#\nY EYY\n0 0\n100 0\n#\nZ EZZ\n0 0\n100 0\n";
    // The squareness C0Y = −12 µrad (S_xy = 12) in an Etalon exchange file.
    const SQ: &str = "[C0Y]\nVALUE = -0.000012\n";

    #[test]
    fn every_file_and_negate_are_applied() {
        let v = parse(
            "X 1\nY 2\nZ 3\nInterpolation GRID\nnegate X\nset_to_zero Z\nfile[0] pos.csv\nfile_format[0] ISG_CSV\nfile[1] sq.exc\nfile_format[1] ETALON_EXCHANGE\n",
            &[("pos.csv", POS), ("sq.exc", SQ)],
        )
        .unwrap();
        assert_eq!(
            (v.negate, v.zero),
            ([true, false, false], [false, false, true])
        );
        assert_eq!(v.model.kinematics.squareness.xy_urad, 12.0);
        // The controller's correction at (50, 100, 0): E_XX = 2.5 µm and the
        // squareness 12 µrad · 100 mm = 1.2 µm in X, negated: −3.7 µm.
        let zero = crate::model::axis_table::AxisTableMap::from_csv(
            "axis,direction,position_mm,ex_um,ey_um,ez_um\nX,both,0,0,0,0\nX,both,100,0,0,0\nY,both,0,0,0,0\nY,both,100,0,0,0\nZ,both,0,0,0,0\nZ,both,100,0,0,0\n",
            "m.csv",
        )
        .unwrap();
        let r = ControllerResidual {
            map: zero,
            controller: ControllerApplies::Model(Box::new(v)),
        };
        let c = r
            .deviation_um(
                volcomp_gcode::Vec3::new(50.0, 100.0, 0.0),
                ALL_FORWARD,
                Components::All,
            )
            .unwrap();
        assert!((c.x - 3.7).abs() < 1e-9, "{c:?}");
    }

    #[test]
    fn what_the_controller_would_not_read_is_refused() {
        let e = |lis: &str, files: &[(&str, &str)]| match parse(lis, files).unwrap_err() {
            super::super::ControllerReadError::Format(e) => e,
            other => panic!("{other}"),
        };
        // ISG's name of the Etalon format.
        let x = e("file[0] sq.exc\nfile_format[0] ETALON\n", &[("sq.exc", SQ)]);
        assert_eq!(x.row, 2);
        assert!(x.help.contains("ETALON_EXCHANGE"), "{x}");
        // A parameter in two files.
        let x = e("file[0] a.exc\nfile_format[0] ETALON_EXCHANGE\nfile[1] b.exc\nfile_format[1] ETALON_EXCHANGE\n", &[("a.exc", SQ), ("b.exc", SQ)]);
        assert_eq!((x.file.as_str(), x.row), ("b.exc", 1));
        // A chain volcomp does not model, and an unknown key.
        assert_eq!(
            e("chain XYZCA\nfile[0] pos.csv\n", &[("pos.csv", POS)]).row,
            1
        );
        assert!(e("P0X 10\nfile[0] pos.csv\n", &[("pos.csv", POS)])
            .message
            .contains("P0X"));
        // An error inside the second file names that file.
        let x = e(
            "file[0] pos.csv\nfile[1] bad.csv\n",
            &[("pos.csv", POS), ("bad.csv", "A0Y\n0.001\n")],
        );
        assert_eq!(x.file, "bad.csv", "{x}");
    }
}
