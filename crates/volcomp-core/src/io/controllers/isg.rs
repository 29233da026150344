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
//! * at most `kw_nr_max` entries, 1500 by default (P-COMP-00059).

use super::{
    axis_letter, located, ControllerCorrection, Export, ExportFile, Format, LimitError,
    Positioning, ReadError, Rounding,
};
use crate::io::numfmt::fixed;
use volcomp_gcode::Vec3;

/// Default largest number of entries of an SSFK table (P-COMP-00059).
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
        if n > max_points {
            return Err(LimitError {
                format: "isg-ssfk",
                axis: ax,
                message: format!(
                    "{n} interpolation points; kw_nr_max allows {max_points} (P-COMP-00059)"
                ),
                help: format!(
                    "resample with a step of at least {} mm, or raise P-COMP-00059",
                    fixed(
                        (table.positions_mm[n - 1] - table.positions_mm[0])
                            / (max_points - 1) as f64,
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
        applied: ControllerCorrection { format: Format::IsgSsfk, axes: applied, squareness_urad: None, cross: Vec::new() },
        rounding,
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
        let v: f64 = value
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| {
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
        let y = Positioning {
            positions_mm: vec![0.0, 19.8667],
            forward_um: vec![0.0, 19856.5 - 19866.7],
            reverse_um: vec![0.0, 19874.7 - 19866.7],
        };
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
        let x = Positioning {
            positions_mm: vec![0.0, 10.0],
            forward_um: vec![0.0, 1.26],
            reverse_um: vec![0.0, 1.26],
        };
        let e = ssfk_export(&[Some(x.clone()), None, None], SSFK_MAX_POINTS).unwrap();
        assert!(e.files[0].text.contains("kw.ssfk.table[1].pos        13\n"));
        assert!((e.rounding.max_um - 0.04).abs() < 1e-9);
        let err = ssfk_export(&[Some(x), None, None], 1).unwrap_err();
        assert!(err.message.contains("kw_nr_max allows 1"), "{err}");
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

/// Reads an ISG volumetric compensation configuration list (`*.lis`): its
/// `file[0]` (relative to the list's folder) in `file_format[0]` `ISG_CSV`
/// or `ETALON`, into a 21-component model on the seed chain, measured at
/// the origin (the list's kinematic configuration is not read:
/// docs/controllers.md).
pub fn read_volcomp_lis(
    path: &std::path::Path,
) -> Result<crate::model::kinematic::KinematicModel, super::ControllerReadError> {
    let text = super::read_text(path)?;
    let file = path.display().to_string();
    let mut name = None;
    let mut format = None;
    for (i, raw) in text.lines().enumerate() {
        let mut f = raw.split_whitespace();
        match (f.next(), f.next()) {
            (Some("file[0]"), Some(v)) => name = Some((v.to_string(), i + 1)),
            (Some("file_format[0]"), Some(v)) => format = Some((v.to_string(), i + 1)),
            _ => {}
        }
    }
    let Some((csv, row)) = name else {
        return Err(located(
            &file,
            &text,
            1,
            "no file[0]",
            "the list names its parameter file: file[0] volcomp.csv",
        )
        .into());
    };
    let dir = path.parent().unwrap_or(std::path::Path::new("."));
    let p = dir.join(&csv);
    let body = super::read_named(&p, path).map_err(|e| match e {
        super::ControllerReadError::Io { .. } => located(
            &file,
            &text,
            row,
            format!("cannot read {}", p.display()),
            "file[0] is read relative to the list's folder",
        )
        .into(),
        other => other,
    })?;
    let pname = p.display().to_string();
    let params = match format.as_ref().map(|(f, _)| f.as_str()) {
        Some("ISG_CSV") | None => crate::io::exchange::parse_isg_csv(&body, &pname)?,
        Some("ETALON") => crate::io::exchange::parse_etalon(&body, &pname)?,
        Some(f) => {
            let row = format.as_ref().map_or(1, |x| x.1);
            return Err(located(
                &file,
                &text,
                row,
                format!("file_format[0] {f}"),
                "volcomp reads ISG_CSV and ETALON parameter files",
            )
            .into());
        }
    };
    Ok(crate::io::exchange::to_model(
        &params,
        &pname,
        &body,
        crate::model::topology::Topology::SEED,
    )?
    .model)
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
            format: Format::IsgCsv,
            axes: applied,
            squareness_urad: Some([s.xy_urad, s.yz_urad, s.zx_urad]),
            cross: Vec::new(),
        },
        rounding,
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
