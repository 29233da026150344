//! Siemens Sinumerik leadscrew and measuring-system error compensation
//! (LEC/EEC): the file `%_N_AX_EEC_INI` with the system variables
//! `$AA_ENC_COMP[e,N,AX]`, `$AA_ENC_COMP_STEP`, `_MIN`, `_MAX` and
//! `_IS_MODULO` ([Siemens K3], "Interpolatory compensation",
//! "Measuring system error compensation"; docs/controllers.md).
//!
//! What the function manual says and this module does:
//!
//! * one table per machine axis and measuring system `e` (0: the first),
//!   equidistant: point `N` lies at `_MIN + N·_STEP`, the last at `_MAX`;
//!   at most `MD38000 $MA_MM_ENC_COMP_MAX_POINTS` points;
//! * values in mm; "a positive compensation value causes the corresponding
//!   machine axis to move in the negative direction": the value is the
//!   measured error `actual − commanded`, volcomp's `e` itself;
//! * linear interpolation between points, the first and last values held
//!   outside the table;
//! * not direction dependent: the reversal belongs to the backlash
//!   compensation `MD32450 $MA_BACKLASH[e]` ("positive if the encoder is
//!   leading the machine part (normal situation)", active after the
//!   reference point approach). volcomp writes it into the same file, the
//!   mean reversal value `B̄` ([`super::mean_reversal_um`]), and the table
//!   [`super::table_beside_backlash`] holds beside it.
//! * *Assumed* (the function manual does not say on which travel MD32450
//!   acts): the axis' backlash is taken up by the reference point approach
//!   (MD34010 `$MA_REFP_CAM_DIR_IS_MINUS`, 0: in +), so the compensation
//!   acts on travel the other way (`--reference-direction` for an approach
//!   in −). The table's own sign is the documented one; the CEC tables',
//!   which no text settles, get a check on the machine
//!   ([`super::signcheck`]).

use super::{
    axis_letter, bidirectional_mean, equidistant, located, points_covering, table_beside_backlash,
    Backlash, ControllerCorrection, Export, ExportFile, Format, LimitError, Positioning, ReadError,
    ReferenceDirection, Rounding,
};
use crate::io::finite;
use crate::io::numfmt::fixed;

/// Options of the EEC export.
#[derive(Debug, Clone, PartialEq)]
pub struct EecOptions {
    /// Machine axis names of X, Y, Z (e.g. `X1`, `Y1`, `Z1`).
    pub axis_names: [String; 3],
    /// Spacing of the interpolation points (`_STEP`, mm).
    pub step_mm: f64,
    /// The NC's resolution of a compensation value (µm): 1 / MD10200
    /// `$MN_INT_INCR_PER_MM` mm, 1 µm with the default 1000.
    pub resolution_um: f64,
    /// `MD38000 $MA_MM_ENC_COMP_MAX_POINTS` of the machine.
    pub max_points: usize,
    /// The direction of the reference point approach (MD34010): the
    /// backlash compensation acts on travel the other way.
    pub reference: ReferenceDirection,
}

impl Default for EecOptions {
    fn default() -> Self {
        EecOptions {
            axis_names: ["X1".into(), "Y1".into(), "Z1".into()],
            step_mm: 10.0,
            resolution_um: 1.0,
            max_points: 5000,
            reference: ReferenceDirection::Positive,
        }
    }
}

/// The file `%_N_AX_EEC_INI` for the positioning tables `p` (X, Y, Z; an
/// axis without a table is left out).
pub fn export(p: &[Option<Positioning>; 3], o: &EecOptions) -> Result<Export, LimitError> {
    let mut rounding = Rounding {
        resolution_um: o.resolution_um,
        max_um: 0.0,
    };
    let mut text = String::from(
        "%_N_AX_EEC_INI\nCHANDATA(1)\n; volcomp: leadscrew error compensation, values in mm = measured error (actual - commanded)\n",
    );
    let mut applied = ControllerCorrection::empty(Format::SiemensEec);
    let mut notes = Vec::new();
    let side = o.reference.backlash_side();
    for (a, table) in p.iter().enumerate() {
        let Some(table) = table else { continue };
        let name = &o.axis_names[a];
        let lo = table.positions_mm[0];
        let hi = table.positions_mm[table.positions_mm.len() - 1];
        let n = points_covering(lo, hi, o.step_mm);
        if n > o.max_points {
            return Err(LimitError {
                format: "siemens-eec",
                axis: axis_letter(a),
                message: format!(
                    "{n} interpolation points every {} mm over {lo} … {hi} mm; MD38000 $MA_MM_ENC_COMP_MAX_POINTS allows {}",
                    o.step_mm, o.max_points
                ),
                help: format!(
                    "choose a step of at least {} mm, or raise MD38000 (and --max-points) if the machine's memory allows",
                    fixed((hi - lo) / (o.max_points - 1) as f64, 3)
                ),
            });
        }
        let (one, b_mean) = table_beside_backlash(table, side);
        let b_written = rounding.round(b_mean);
        let sampled = equidistant(&one, lo, o.step_mm, n);
        let values: Vec<f64> = sampled
            .forward_um
            .iter()
            .map(|&v| rounding.round(v))
            .collect();
        text.push_str(&format!(
            "; axis {} ({name}): E_{}{} every {} mm from {} to {} mm\n",
            axis_letter(a),
            axis_letter(a),
            axis_letter(a),
            fixed(o.step_mm, 6),
            fixed(lo, 6),
            fixed(sampled.positions_mm[n - 1], 6)
        ));
        for (k, v) in values.iter().enumerate() {
            text.push_str(&format!(
                "$AA_ENC_COMP[0,{k},{name}]={}\n",
                fixed(v * 1e-3, 7)
            ));
        }
        text.push_str(&format!(
            "$AA_ENC_COMP_STEP[0,{name}]={}\n$AA_ENC_COMP_MIN[0,{name}]={}\n$AA_ENC_COMP_MAX[0,{name}]={}\n$AA_ENC_COMP_IS_MODULO[0,{name}]=0\n",
            fixed(o.step_mm, 6),
            fixed(lo, 6),
            fixed(sampled.positions_mm[n - 1], 6)
        ));
        text.push_str(&format!(
            "; MD32450: the mean reversal value of {} (machine data: active after NewConfig and a reference point approach)\n$MA_BACKLASH[0,{name}]={}\n",
            axis_letter(a),
            fixed(b_written * 1e-3, 7)
        ));
        notes.push(format!(
            "{name}: {n} points: set MD38000 $MA_MM_ENC_COMP_MAX_POINTS[0] >= {n} and MD32700 $MA_ENC_COMP_ENABLE[0] = 1"
        ));
        notes.push(format!(
            "{name}: MD32450 $MA_BACKLASH[0] = {} mm is in the file: the mean reversal value ({} um; the mean, not the largest, so that the reversal left over averages zero along the axis), assumed to act on travel in {} (reference point approach in {}, MD34010 = {}); the table beside it is the mean of both directions {} half of it",
            fixed(b_written * 1e-3, 7),
            fixed(b_mean, 3),
            match side { super::BacklashSide::Forward => "+", _ => "-" },
            match o.reference { ReferenceDirection::Positive => "+", ReferenceDirection::Negative => "-" },
            match o.reference { ReferenceDirection::Positive => 0, ReferenceDirection::Negative => 1 },
            match side { super::BacklashSide::Forward => "plus", _ => "minus" },
        ));
        applied.axes[a] = Some(Positioning {
            positions_mm: sampled.positions_mm.clone(),
            forward_um: values.clone(),
            reverse_um: values,
        });
        if b_written != 0.0 {
            applied.backlash[a] = Some(Backlash {
                value_um: b_written,
                side,
            });
        }
    }
    text.push_str("M17\n");
    Ok(Export {
        files: vec![ExportFile {
            name: "%_N_AX_EEC_INI".into(),
            text,
        }],
        applied,
        rounding,
        holds: [super::table_error::Holds::OneTable; 3],
        zero_at: None,
        notes,
    })
}

/// One table being read.
#[derive(Default)]
struct Partial {
    values: Vec<Option<f64>>,
    step: Option<f64>,
    min: Option<f64>,
    max: Option<f64>,
    row: usize,
    /// MD32450 (µm).
    backlash_um: Option<f64>,
    /// MD34010 (reference point approach in −).
    refp_minus: Option<bool>,
}

/// Reads a `%_N_AX_EEC_INI` file: the tables of measuring system 0 of the
/// axes named `axis_names` (X, Y, Z; `None`: the machine axis whose name
/// starts with X, Y or Z, such as `X1`), in volcomp's sign (µm). Comments
/// (`;`), `CHANDATA`, `M17` and blank lines are skipped; other machine
/// axes and measuring system 1 are refused by name.
///
/// The backlash compensation is read from the same file: `MD32450
/// $MA_BACKLASH[0,AX]` must be given for every axis with a table (the
/// table alone does not say whether the NC also corrects the reversal; 0
/// if it does not), acting on travel away from the reference point
/// approach (`MD34010 $MA_REFP_CAM_DIR_IS_MINUS[AX]`, its default 0: in +,
/// when the file does not give it).
pub fn parse(
    text: &str,
    file: &str,
    axis_names: Option<&[String; 3]>,
) -> Result<ControllerCorrection, ReadError> {
    let by_letter: [String; 3] = ["X".into(), "Y".into(), "Z".into()];
    let listed = axis_names.unwrap_or(&by_letter);
    let mut tables: [Partial; 3] = Default::default();
    let err = |row: usize, m: String, h: &str| located(file, text, row, m, h);
    for (i, raw) in text.lines().enumerate() {
        let row = i + 1;
        let line = raw.split(';').next().unwrap_or("").trim();
        if line.is_empty()
            || line.starts_with('%')
            || line.starts_with("CHANDATA")
            || line == "M17"
            || line == "M30"
        {
            continue;
        }
        let Some((lhs, rhs)) = line.split_once('=') else {
            return Err(err(
                row,
                format!("`{line}` is not an assignment"),
                "an EEC file holds lines `$AA_ENC_COMP...[...]=value`",
            ));
        };
        let value = finite(rhs.trim()).ok_or_else(|| {
            err(
                row,
                format!("`{}` is not a number", rhs.trim()),
                "write the value in mm, e.g. 0.003",
            )
        })?;
        let lhs = lhs.trim();
        let (var, args) = lhs
            .strip_suffix(']')
            .and_then(|s| s.split_once('['))
            .ok_or_else(|| {
                err(
                    row,
                    format!("`{lhs}` has no index"),
                    "write e.g. $AA_ENC_COMP[0,5,X1]",
                )
            })?;
        let args: Vec<&str> = args.split(',').map(str::trim).collect();
        let axis_of = |name: &str| -> Result<usize, ReadError> {
            let found = match axis_names {
                Some(names) => names.iter().position(|n| n.eq_ignore_ascii_case(name)),
                None => "XYZ".find(name.chars().next().unwrap_or(' ').to_ascii_uppercase()),
            };
            found.ok_or_else(|| {
                err(
                    row,
                    format!("machine axis `{name}` is not one of {}", listed.join(", ")),
                    "pass the machine axis names of X, Y and Z as the file spells them",
                )
            })
        };
        let system = |s: &str| -> Result<(), ReadError> {
            if s == "0" {
                Ok(())
            } else {
                Err(err(
                    row,
                    format!("measuring system {s}"),
                    "volcomp reads the tables of the first measuring system (index 0)",
                ))
            }
        };
        match (var, args.as_slice()) {
            ("$AA_ENC_COMP", [e, n, ax]) => {
                system(e)?;
                let a = axis_of(ax)?;
                let n: usize = n.parse().map_err(|_| {
                    err(
                        row,
                        format!("`{n}` is not a point number"),
                        "point numbers are 0, 1, 2 …",
                    )
                })?;
                if n >= 100_000 {
                    return Err(err(
                        row,
                        format!("point number {n}"),
                        "an EEC table holds at most MD38000 points",
                    ));
                }
                let t = &mut tables[a];
                if t.values.len() <= n {
                    t.values.resize(n + 1, None);
                }
                if t.values[n].replace(value * 1e3).is_some() {
                    return Err(err(
                        row,
                        format!("point {n} of {ax} is given twice"),
                        "give every point once",
                    ));
                }
                t.row = row;
            }
            (
                v @ ("$AA_ENC_COMP_STEP"
                | "$AA_ENC_COMP_MIN"
                | "$AA_ENC_COMP_MAX"
                | "$AA_ENC_COMP_IS_MODULO"),
                [e, ax],
            ) => {
                system(e)?;
                let t = &mut tables[axis_of(ax)?];
                match v {
                    "$AA_ENC_COMP_STEP" => t.step = Some(value),
                    "$AA_ENC_COMP_MIN" => t.min = Some(value),
                    "$AA_ENC_COMP_MAX" => t.max = Some(value),
                    _ if value != 0.0 => {
                        return Err(err(
                            row,
                            "a modulo table (rotary axis)".into(),
                            "volcomp reads tables of linear axes only",
                        ))
                    }
                    _ => {}
                }
            }
            ("$MA_BACKLASH", [e, ax]) => {
                system(e)?;
                tables[axis_of(ax)?].backlash_um = Some(value * 1e3);
            }
            ("$MA_REFP_CAM_DIR_IS_MINUS", [ax]) => {
                tables[axis_of(ax)?].refp_minus = Some(value != 0.0);
            }
            ("$MA_BACKLASH_FACTOR", [_, ax]) if value != 1.0 => {
                let _ = axis_of(ax)?;
                return Err(err(
                    row,
                    format!("MD32452 $MA_BACKLASH_FACTOR = {value}"),
                    "volcomp models MD32450 at the factor 1 of every parameter set: set MD32452 to 1.0, or multiply $MA_BACKLASH by the factor of the parameter set the program runs with",
                ));
            }
            ("$MA_BACKLASH_FACTOR", [_, ax]) => {
                let _ = axis_of(ax)?;
            }
            _ => {
                return Err(err(
                    row,
                    format!("`{lhs}` is not an EEC system variable"),
                    "expected $AA_ENC_COMP[e,N,AX], _STEP[e,AX], _MIN, _MAX, _IS_MODULO, or the machine data $MA_BACKLASH[e,AX], $MA_REFP_CAM_DIR_IS_MINUS[AX]",
                ))
            }
        }
        if var.starts_with("$AA_ENC_COMP") {
            let a = axis_of(args.last().copied().unwrap_or(""))?;
            tables[a].row = tables[a].row.max(row);
        }
    }
    let mut out = ControllerCorrection::empty(Format::SiemensEec);
    let mut axes: [Option<Positioning>; 3] = [None, None, None];
    for (a, t) in tables.iter().enumerate() {
        let name = &listed[a];
        if let Some(b) = t.backlash_um.filter(|b| *b != 0.0) {
            let reference = match t.refp_minus {
                Some(true) => ReferenceDirection::Negative,
                Some(false) => ReferenceDirection::Positive,
                None => {
                    out.notes.push(format!("{name}: no MD34010 $MA_REFP_CAM_DIR_IS_MINUS: its default 0 is taken (reference point approach in +), so MD32450 acts on travel in -"));
                    ReferenceDirection::Positive
                }
            };
            out.backlash[a] = Some(Backlash {
                value_um: b,
                side: reference.backlash_side(),
            });
        }
        if t.values.is_empty() {
            continue;
        }
        let (Some(step), Some(min), Some(max)) = (t.step, t.min, t.max) else {
            return Err(err(
                t.row,
                format!("{name} has values but not all of _STEP, _MIN, _MAX"),
                "give $AA_ENC_COMP_STEP, _MIN and _MAX of the axis",
            ));
        };
        let n = t.values.len();
        if step <= 0.0 || ((max - min) / step - (n - 1) as f64).abs() > 1e-6 {
            return Err(err(
                t.row,
                format!("{name}: {n} points from _MIN {min} every _STEP {step} do not end at _MAX {max}"),
                "the last point N lies at _MIN + N·_STEP = _MAX",
            ));
        }
        let values: Option<Vec<f64>> = t.values.iter().copied().collect();
        let Some(values) = values else {
            let k = t.values.iter().position(Option::is_none).unwrap_or(0);
            return Err(err(
                t.row,
                format!("{name}: point {k} is missing"),
                "give every point 0 … N",
            ));
        };
        if t.backlash_um.is_none() {
            return Err(err(
                t.row,
                format!("{name} has a table but the file does not give its backlash compensation MD32450"),
                &format!("the NC may correct the reversal too: add the machine's value, $MA_BACKLASH[0,{name}]=… in mm (0 if MD32450 is 0), so that volcomp does not correct it a second time"),
            ));
        }
        axes[a] = Some(Positioning {
            positions_mm: (0..n).map(|k| min + step * k as f64).collect(),
            forward_um: values.clone(),
            reverse_um: values,
        });
    }
    if axes.iter().all(Option::is_none) && out.backlash.iter().all(Option::is_none) {
        return Err(err(
            1,
            "no $AA_ENC_COMP values or $MA_BACKLASH for the axes".into(),
            &format!("expected tables of {}", listed.join(", ")),
        ));
    }
    out.axes = axes;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::controllers::test_support::assert_noted;

    fn names() -> [String; 3] {
        ["X1".into(), "Y1".into(), "Z1".into()]
    }

    #[test]
    fn hand_computed_export() {
        // X: forward 0, 2.4, 6.0 µm and reverse 1.0, 3.6, 7.0 µm at 0, 15, 30 mm.
        // Reversal 1.0, 1.2, 1.0 → B̄ = 3.2/3 = 1.0667 µm, written 1 µm
        // (MD32450 = 0.001 mm), acting on travel in − (reference in +), so
        // the table is the mean 0.5, 3.0, 6.5 minus B̄/2: −0.0333, 2.4667,
        // 5.9667. Every 10 mm from 0: −0.0333, −0.0333 + 2.5·10/15 = 1.6333,
        // 2.4667 + 3.5·5/15 = 3.6333, 5.9667 µm → 0, 2, 4, 6 µm.
        let x = Positioning::new(&[0.0, 15.0, 30.0], &[0.0, 2.4, 6.0], &[1.0, 3.6, 7.0]);
        let o = EecOptions::default();
        let e = export(&[Some(x), None, None], &o).unwrap();
        let t = &e.files[0].text;
        assert_eq!(e.files[0].name, "%_N_AX_EEC_INI");
        assert!(t.starts_with("%_N_AX_EEC_INI\nCHANDATA(1)\n"), "{t}");
        for line in [
            "$AA_ENC_COMP[0,0,X1]=0\n",
            "$AA_ENC_COMP[0,1,X1]=0.002\n",
            "$AA_ENC_COMP[0,2,X1]=0.004\n",
            "$AA_ENC_COMP[0,3,X1]=0.006\n",
            "$AA_ENC_COMP_STEP[0,X1]=10\n",
            "$AA_ENC_COMP_MIN[0,X1]=0\n",
            "$AA_ENC_COMP_MAX[0,X1]=30\n",
            "$AA_ENC_COMP_IS_MODULO[0,X1]=0\n",
            "$MA_BACKLASH[0,X1]=0.001\n",
        ] {
            assert!(t.contains(line), "{line} missing in\n{t}");
        }
        assert!(t.ends_with("M17\n"));
        assert!(!t.contains("Y1"));
        // Largest rounding: |2 − 1.6333| = 0.3667 µm.
        assert!(
            (e.rounding.max_um - 0.366667).abs() < 1e-5,
            "{:?}",
            e.rounding
        );
        assert!(
            e.notes
                .iter()
                .any(|n| n.contains("MD32450") && n.contains("1.067")),
            "{:?}",
            e.notes
        );
        assert_noted(&e.notes, ">= 4");
        let back = parse(t, "eec.ini", Some(&names())).unwrap();
        assert_eq!(back.axes, e.applied.axes);
        assert_eq!(back.backlash, e.applied.backlash);
        // Forward 0 + 2·… : at 15 mm forward the NC applies 3 µm (table),
        // in reverse 3 + 1 = 4 µm; the map says 2.4 and 3.6.
        assert!((back.correction_um(0, 15.0, true) - 3.0).abs() < 1e-9);
        assert!((back.correction_um(0, 15.0, false) - 4.0).abs() < 1e-9);
        // A machine referenced in −: MD32450 acts on forward travel, and
        // the table is the mean plus B̄/2.
        let neg = EecOptions {
            reference: ReferenceDirection::Negative,
            ..EecOptions::default()
        };
        let x = Positioning::new(&[0.0, 10.0], &[0.0, 0.0], &[4.0, 4.0]);
        let e = export(&[Some(x), None, None], &neg).unwrap();
        assert!(
            e.files[0].text.contains("$AA_ENC_COMP[0,0,X1]=0.004\n"),
            "{}",
            e.files[0].text
        );
        assert_eq!(e.applied.correction_um(0, 5.0, true), 0.0);
        assert_eq!(e.applied.correction_um(0, 5.0, false), 4.0);
        let with_md = format!("{}$MA_REFP_CAM_DIR_IS_MINUS[X1]=1\n", e.files[0].text);
        let back = parse(&with_md, "eec.ini", Some(&names())).unwrap();
        assert_eq!(back.backlash, e.applied.backlash);
        assert!(back.notes.is_empty(), "{:?}", back.notes);
    }

    #[test]
    fn a_table_without_its_backlash_is_refused() {
        let t = "$AA_ENC_COMP[0,0,X1]=0.003\n$AA_ENC_COMP[0,1,X1]=0.01\n$AA_ENC_COMP_STEP[0,X1]=1.0\n$AA_ENC_COMP_MIN[0,X1]=0\n$AA_ENC_COMP_MAX[0,X1]=1\n";
        let e = parse(t, "eec.ini", Some(&names())).unwrap_err();
        assert_eq!(e.row, 5, "{e}");
        assert!(e.help.contains("$MA_BACKLASH[0,X1]"), "{e}");
        let e = parse(
            &format!("{t}$MA_BACKLASH[0,X1]=0.002\n$MA_BACKLASH_FACTOR[1,X1]=1.5\n"),
            "eec.ini",
            Some(&names()),
        )
        .unwrap_err();
        assert_eq!(e.row, 7, "{e}");
    }

    #[test]
    fn the_manuals_example_reads() {
        // [Siemens K3] "Example" (X1, −200 … 600 mm every 1 mm): the first
        // three values +3, +10, +12 µm; here with only points 0 … 2 and _MAX
        // to match.
        let t = "%_N_AX_EEC_INI\nCHANDATA(1)\n$AA_ENC_COMP[0,0,X1]=0.003 ; +3um\n$AA_ENC_COMP[0,1,X1]=0.01\n$AA_ENC_COMP[0,2,X1]=0.012\n$AA_ENC_COMP_STEP[0,X1]=1.0\n$AA_ENC_COMP_MIN[0,X1]=-200.0\n$AA_ENC_COMP_MAX[0,X1]=-198.0\n$AA_ENC_COMP_IS_MODULO[0,X1]=0\n$MA_BACKLASH[0,X1]=0\nM17\n";
        let c = parse(t, "eec.ini", Some(&names())).unwrap();
        let x = c.axes[0].as_ref().unwrap();
        assert_eq!(x.positions_mm, vec![-200.0, -199.0, -198.0]);
        assert!((x.forward_um[0] - 3.0).abs() < 1e-9 && (x.forward_um[1] - 10.0).abs() < 1e-9);
        // A positive value is an axis that went too far: the controller
        // moves it back; volcomp's correction at −199.5 mm is 6.5 µm.
        assert!((c.correction_um(0, -199.5, true) - 6.5).abs() < 1e-9);
        assert!(c.axes[1].is_none());
    }

    #[test]
    fn limits_and_bad_files_are_refused() {
        let x = Positioning::new(&[0.0, 1000.0], &[0.0, 1.0], &[0.0, 1.0]);
        let o = EecOptions {
            max_points: 200,
            step_mm: 1.0,
            ..EecOptions::default()
        };
        let e = export(&[Some(x), None, None], &o).unwrap_err();
        assert!(e.message.contains("1001 interpolation points"), "{e}");
        assert!(e.help.contains("5.025"), "{e}");
        let bad = "$AA_ENC_COMP[0,0,X1]=0\n$AA_ENC_COMP[0,1,X1]=0\n$AA_ENC_COMP_STEP[0,X1]=10\n$AA_ENC_COMP_MIN[0,X1]=0\n$AA_ENC_COMP_MAX[0,X1]=20\n";
        let e = parse(bad, "eec.ini", None).unwrap_err();
        assert!(e.message.contains("do not end at _MAX"), "{e}");
        let e = parse("$AA_ENC_COMP[0,0,A1]=0\n", "eec.ini", None).unwrap_err();
        assert_eq!(e.row, 1);
        assert!(e.message.contains("A1"));
        let e = parse("$AA_ENC_COMP[0,0,X1]=abc\n", "eec.ini", Some(&names())).unwrap_err();
        assert!(e.message.contains("not a number"));
    }
}

/// The sign of sag/cross compensation values (the function manual's
/// wording does not settle it; a switch).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CecSign {
    /// The measured error `e` (as for the leadscrew tables; default).
    Error,
    /// The correction `−e`.
    Correction,
}

/// One cross-compensation table read back: input axis, output axis and the
/// table (µm in volcomp's sign over the input axis' position).
pub type CecTable = super::CrossTable;

/// The file `%_N_NC_CEC_INI` for straightness tables: one table per
/// `(input axis a, output axis d, E_da)` in `tables` (volcomp's sign, µm,
/// the mean of both directions), equidistant every `o.step_mm`
/// ([Siemens K3], "Sag compensation / cross-axis compensation":
/// `$AN_CEC[t,N]`, `_INPUT_AXIS`, `_OUTPUT_AXIS`, `_STEP`, `_MIN`, `_MAX`,
/// `_DIRECTION` 0 (both directions), `_MULT_BY_TABLE` 0, `_IS_MODULO` 0;
/// at most `MD18342 $MN_MM_CEC_MAX_POINTS` points per table).
pub fn cec_export(
    tables: &[(usize, usize, Positioning)],
    o: &EecOptions,
    sign: CecSign,
) -> Result<Export, LimitError> {
    let mut rounding = Rounding {
        resolution_um: o.resolution_um,
        max_um: 0.0,
    };
    let k = match sign {
        CecSign::Error => 1.0,
        CecSign::Correction => -1.0,
    };
    let mut text = format!(
        "%_N_NC_CEC_INI\nCHANDATA(1)\n; volcomp: straightness as cross-axis compensation, values in mm = {}\n",
        if k > 0.0 { "measured error (actual - commanded)" } else { "correction (commanded - actual)" }
    );
    let mut notes = Vec::new();
    for (t, (a, d, table)) in tables.iter().enumerate() {
        let (inp, out) = (&o.axis_names[*a], &o.axis_names[*d]);
        let lo = table.positions_mm[0];
        let hi = table.positions_mm[table.positions_mm.len() - 1];
        let n = points_covering(lo, hi, o.step_mm);
        if n > o.max_points {
            return Err(LimitError {
                format: "siemens-cec",
                axis: axis_letter(*a),
                message: format!(
                    "{n} points every {} mm for E{}{}; MD18342 $MN_MM_CEC_MAX_POINTS allows {}",
                    o.step_mm,
                    axis_letter(*d),
                    axis_letter(*a),
                    o.max_points
                ),
                help: format!(
                    "choose a step of at least {} mm",
                    fixed((hi - lo) / (o.max_points - 1) as f64, 3)
                ),
            });
        }
        let (mean, _) = bidirectional_mean(table);
        let sampled = equidistant(&mean, lo, o.step_mm, n);
        for (i, v) in sampled.forward_um.iter().enumerate() {
            let r = rounding.round(*v);
            text.push_str(&format!("$AN_CEC[{t},{i}]={}\n", fixed(k * r * 1e-3, 7)));
        }
        text.push_str(&format!(
            "$AN_CEC_INPUT_AXIS[{t}]={inp}\n$AN_CEC_OUTPUT_AXIS[{t}]={out}\n$AN_CEC_STEP[{t}]={}\n$AN_CEC_MIN[{t}]={}\n$AN_CEC_MAX[{t}]={}\n$AN_CEC_DIRECTION[{t}]=0\n$AN_CEC_MULT_BY_TABLE[{t}]=0\n$AN_CEC_IS_MODULO[{t}]=0\n",
            fixed(o.step_mm, 6),
            fixed(lo, 6),
            fixed(sampled.positions_mm[n - 1], 6)
        ));
        notes.push(format!("table {t}: E{}{} ({out} as a function of {inp}), {n} points: MD18342 $MN_MM_CEC_MAX_POINTS[{t}] >= {n}; enable with MD32710 $MA_CEC_ENABLE[{out}] = 1 and $SN_CEC_TABLE_ENABLE[{t}] = 1", axis_letter(*d), axis_letter(*a)));
    }
    text.push_str("M17\n");
    // What the NC applies: the written values read back.
    let cross = cec_parse(&text, "%_N_NC_CEC_INI", sign).map_err(|e| LimitError {
        format: "siemens-cec",
        axis: 'X',
        message: e.to_string(),
        help: "the tables cannot be written as a CEC file".into(),
    })?;
    Ok(Export {
        files: vec![ExportFile {
            name: "%_N_NC_CEC_INI".into(),
            text,
        }],
        applied: ControllerCorrection {
            cross,
            ..ControllerCorrection::empty(Format::SiemensCec)
        },
        rounding,
        holds: [super::table_error::Holds::Nothing; 3],
        zero_at: None,
        notes,
    })
}

/// Reads a `%_N_NC_CEC_INI` as written by [`cec_export`] (machine axes by
/// the first letter of their names): the tables in volcomp's sign (µm).
pub fn cec_parse(text: &str, file: &str, sign: CecSign) -> Result<Vec<CecTable>, ReadError> {
    use std::collections::BTreeMap;
    let err = |row: usize, m: String, h: &str| located(file, text, row, m, h);
    let k = match sign {
        CecSign::Error => 1.0,
        CecSign::Correction => -1.0,
    };
    #[derive(Default)]
    struct T {
        values: BTreeMap<usize, f64>,
        input: Option<usize>,
        output: Option<usize>,
        step: Option<f64>,
        min: Option<f64>,
        max: Option<f64>,
    }
    let mut tables: BTreeMap<usize, T> = BTreeMap::new();
    for (i, raw) in text.lines().enumerate() {
        let row = i + 1;
        let line = raw.split(';').next().unwrap_or("").trim();
        if line.is_empty() || line.starts_with('%') || line.starts_with("CHANDATA") || line == "M17"
        {
            continue;
        }
        let Some((lhs, rhs)) = line.split_once('=') else {
            return Err(err(
                row,
                format!("`{line}` is not an assignment"),
                "a CEC file holds lines `$AN_CEC...[...]=value`",
            ));
        };
        let (var, args) = lhs
            .trim()
            .strip_suffix(']')
            .and_then(|s| s.split_once('['))
            .ok_or_else(|| {
                err(
                    row,
                    format!("`{}` has no index", lhs.trim()),
                    "write e.g. $AN_CEC[0,5]",
                )
            })?;
        let idx: Vec<usize> = args
            .split(',')
            .map(|s| {
                s.trim().parse().map_err(|_| {
                    err(
                        row,
                        format!("`{s}` is not an index"),
                        "indices are 0, 1, 2 …",
                    )
                })
            })
            .collect::<Result<_, _>>()?;
        let t = tables.entry(idx[0]).or_default();
        let rhs = rhs.trim();
        let num = || -> Result<f64, ReadError> {
            finite(rhs).ok_or_else(|| err(row, format!("`{rhs}` is not a number"), "values in mm"))
        };
        let axis = || -> Result<usize, ReadError> {
            "XYZ"
                .find(rhs.chars().next().unwrap_or(' ').to_ascii_uppercase())
                .ok_or_else(|| {
                    err(
                        row,
                        format!("machine axis `{rhs}`"),
                        "machine axes X…, Y…, Z…",
                    )
                })
        };
        match (var, idx.len()) {
            ("$AN_CEC", 2) => {
                t.values.insert(idx[1], num()? * 1e3 * k);
            }
            ("$AN_CEC_INPUT_AXIS", 1) => t.input = Some(axis()?),
            ("$AN_CEC_OUTPUT_AXIS", 1) => t.output = Some(axis()?),
            ("$AN_CEC_STEP", 1) => t.step = Some(num()?),
            ("$AN_CEC_MIN", 1) => t.min = Some(num()?),
            ("$AN_CEC_MAX", 1) => t.max = Some(num()?),
            ("$AN_CEC_DIRECTION" | "$AN_CEC_MULT_BY_TABLE" | "$AN_CEC_IS_MODULO", 1) if num()? == 0.0 => {}
            _ => return Err(err(row, format!("`{}` is not read", lhs.trim()), "volcomp reads CEC tables for both directions, without table multiplication or modulo")),
        }
    }
    let mut out = Vec::new();
    for (t, v) in tables {
        let (Some(i), Some(o), Some(step), Some(min)) = (v.input, v.output, v.step, v.min) else {
            return Err(err(
                1,
                format!("table {t} lacks _INPUT_AXIS, _OUTPUT_AXIS, _STEP or _MIN"),
                "give every table's parameters",
            ));
        };
        let n = v.values.len();
        if v.values.keys().copied().ne(0..n)
            || v.max
                .is_some_and(|m| ((m - min) / step - (n - 1) as f64).abs() > 1e-6)
        {
            return Err(err(
                1,
                format!(
                    "table {t}: points 0 … {} do not match _MIN, _STEP, _MAX",
                    n.saturating_sub(1)
                ),
                "give every point; the last lies at _MAX",
            ));
        }
        let vals: Vec<f64> = v.values.into_values().collect();
        out.push((
            i,
            o,
            Positioning {
                positions_mm: (0..n).map(|k| min + step * k as f64).collect(),
                forward_um: vals.clone(),
                reverse_um: vals,
            },
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod cec_tests {
    use super::*;

    #[test]
    fn straightness_table_by_hand() {
        // E_ZY (Z deviation along Y): 0, −3.4, −1.2 µm at 0, 100, 200 mm,
        // every 100 mm at 1 µm: 0, −0.003, −0.001 mm (−3.4 → −3, −1.2 → −1).
        let ezy = Positioning::new(&[0.0, 100.0, 200.0], &[0.0, -3.4, -1.2], &[0.0, -3.4, -1.2]);
        let o = EecOptions {
            step_mm: 100.0,
            ..EecOptions::default()
        };
        let e = cec_export(&[(1, 2, ezy)], &o, CecSign::Error).unwrap();
        let t = &e.files[0].text;
        for line in [
            "$AN_CEC[0,0]=0\n",
            "$AN_CEC[0,1]=-0.003\n",
            "$AN_CEC[0,2]=-0.001\n",
            "$AN_CEC_INPUT_AXIS[0]=Y1\n",
            "$AN_CEC_OUTPUT_AXIS[0]=Z1\n",
            "$AN_CEC_STEP[0]=100\n",
            "$AN_CEC_MAX[0]=200\n",
            "$AN_CEC_DIRECTION[0]=0\n",
        ] {
            assert!(t.contains(line), "{line} missing in\n{t}");
        }
        assert!((e.rounding.max_um - 0.4).abs() < 1e-9);
        let back = cec_parse(t, "cec.ini", CecSign::Error).unwrap();
        assert_eq!(back, e.applied.cross);
        assert_eq!(back.len(), 1);
        assert_eq!((back[0].0, back[0].1), (1, 2));
        assert_eq!(back[0].2.forward_um, vec![0.0, -3.0, -1.0]);
        // The other sign as a switch.
        let c = cec_export(&[(1, 2, back[0].2.clone())], &o, CecSign::Correction).unwrap();
        assert!(c.files[0].text.contains("$AN_CEC[0,1]=0.003\n"));
        assert_eq!(
            cec_parse(&c.files[0].text, "c", CecSign::Correction).unwrap()[0]
                .2
                .forward_um,
            vec![0.0, -3.0, -1.0]
        );
    }
}
