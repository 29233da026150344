//! Heidenhain TNC nonlinear axis error compensation: compensation value
//! tables `*.COM` (columns `NR`, `AXISPOS`, `BACKLASH` and one column per
//! compensated axis) and their assignment table `*.CMA` ([Heidenhain TNC],
//! "Nonlinear axis error compensation"; docs/controllers.md).
//!
//! What the technical manuals say and this module does:
//!
//! * `AXISPOS`: the compensation points, in mm from the machine datum;
//!   the points need not be equidistant; at most 256 per table (TNC 407:
//!   module 9095 error 3, "more than 256 entries");
//! * the column named after an axis holds that axis' compensation value as
//!   a function of the table's axis (the `.CMA` column the table is
//!   entered in): `X.COM` in column `X` of the `.CMA` with a column `X` is
//!   the pitch error `X = F(X)`;
//! * `BACKLASH`: "the compensation values measured in the negative
//!   direction of traverse": volcomp writes the reverse table there and the
//!   forward one in the axis' column;
//! * the values are the measured error in mm, positive when the travel is
//!   too long (the sign the manuals give for linear compensation, MP720,
//!   and the error curves of the nonlinear examples): volcomp's `e`;
//! * between points the TNC interpolates linearly.
//!
//! A TNC table is a text file `BEGIN <name> MM`, a header line of column
//! names, one line per row and `[END]`. volcomp writes values with four
//! decimals of a mm (0.1 µm), the resolution the TNC's tables display.

use super::{
    axis_letter, located, ControllerCorrection, Export, ExportFile, Format, LimitError,
    Positioning, ReadError, Rounding,
};
use crate::io::finite;
use crate::io::numfmt::fixed;

/// Points per `.COM` table.
pub const MAX_POINTS: usize = 256;
/// Resolution of a written value (µm): four decimals of a mm.
pub const RESOLUTION_UM: f64 = 0.1;

fn signed(v_mm: f64) -> String {
    let s = format!("{v_mm:.4}");
    if s.starts_with('-') {
        if s.trim_start_matches(['-', '0', '.']).is_empty() {
            "+0.0000".into()
        } else {
            s
        }
    } else {
        format!("+{s}")
    }
}

/// `X.COM`, `Y.COM`, `Z.COM` for the axes with a table and the assignment
/// `volcomp.cma` (one active line: each axis compensated as a function of
/// itself).
pub fn export(p: &[Option<Positioning>; 3]) -> Result<Export, LimitError> {
    let mut rounding = Rounding {
        resolution_um: RESOLUTION_UM,
        max_um: 0.0,
    };
    let mut files = Vec::new();
    let mut applied: [Option<Positioning>; 3] = [None, None, None];
    let mut cma_cols = Vec::new();
    for (a, table) in p.iter().enumerate() {
        let Some(table) = table else { continue };
        let ax = axis_letter(a);
        let n = table.positions_mm.len();
        if n > MAX_POINTS {
            return Err(LimitError {
                format: "heidenhain",
                axis: ax,
                message: format!(
                    "{n} compensation points; a .COM table holds at most {MAX_POINTS}"
                ),
                help: format!(
                    "pass a step of at least {} mm to resample the table",
                    fixed(
                        (table.positions_mm[n - 1] - table.positions_mm[0])
                            / (MAX_POINTS - 1) as f64,
                        3
                    )
                ),
            });
        }
        let name = format!("{ax}.COM");
        let mut text = format!(
            "BEGIN {name} MM\n{:<6}{:<14}{:<14}{}\n",
            "NR", "AXISPOS", "BACKLASH", ax
        );
        let mut fwd = Vec::with_capacity(n);
        let mut rev = Vec::with_capacity(n);
        for k in 0..n {
            let f = rounding.round(table.forward_um[k]);
            let r = rounding.round(table.reverse_um[k]);
            text.push_str(&format!(
                "{:<6}{:<14}{:<14}{}\n",
                k,
                fixed(table.positions_mm[k], 4),
                signed(r * 1e-3),
                signed(f * 1e-3)
            ));
            fwd.push(f);
            rev.push(r);
        }
        text.push_str("[END]\n");
        applied[a] = Some(Positioning {
            positions_mm: table
                .positions_mm
                .iter()
                .map(|&x| (x * 1e4).round() / 1e4)
                .collect(),
            forward_um: fwd,
            reverse_um: rev,
        });
        files.push(ExportFile {
            name: name.clone(),
            text,
        });
        cma_cols.push((ax, name));
    }
    let mut cma = format!("BEGIN VOLCOMP.CMA\n{:<6}{:<8}", "NR", "ACTIVE");
    for (ax, _) in &cma_cols {
        cma.push_str(&format!("{:<12}", ax));
    }
    cma.push_str(&format!("\n{:<6}{:<8}", 0, "*"));
    for (_, name) in &cma_cols {
        cma.push_str(&format!("{:<12}", name));
    }
    cma.push_str("\n[END]\n");
    let cma = cma
        .lines()
        .map(str::trim_end)
        .collect::<Vec<_>>()
        .join("\n")
        + "\n";
    let files_text: Vec<ExportFile> = files
        .into_iter()
        .map(|f| ExportFile {
            text: f
                .text
                .lines()
                .map(str::trim_end)
                .collect::<Vec<_>>()
                .join("\n")
                + "\n",
            name: f.name,
        })
        .chain(std::iter::once(ExportFile {
            name: "VOLCOMP.CMA".into(),
            text: cma,
        }))
        .collect();
    Ok(Export {
        files: files_text,
        applied: ControllerCorrection {
            axes: applied,
            ..ControllerCorrection::empty(Format::Heidenhain)
        },
        rounding,
        holds: [super::table_error::Holds::BothDirections; 3],
        zero_at: None,
        notes: vec![
            "copy the .COM tables and VOLCOMP.CMA to the TNC (PLC partition), activate nonlinear axis error compensation for X, Y, Z and line 0 of VOLCOMP.CMA".into(),
        ],
    })
}

/// Reads one `.COM` table of axis `axis` (0, 1, 2): its `AXISPOS`, the
/// axis' own column (forward) and `BACKLASH` (reverse; the forward values
/// when the column is missing), in volcomp's sign (µm).
pub fn parse_com(text: &str, file: &str, axis: usize) -> Result<Positioning, ReadError> {
    let ax = axis_letter(axis).to_string();
    let err = |row: usize, m: String, h: &str| located(file, text, row, m, h);
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    match lines.next() {
        Some((_, l))
            if l.trim_start().starts_with("BEGIN") && l.to_ascii_uppercase().contains(".COM") =>
        {
            if !l.to_ascii_uppercase().split_whitespace().any(|w| w == "MM") {
                return Err(err(
                    1,
                    "the table is not in MM".into(),
                    "volcomp reads .COM tables in mm",
                ));
            }
        }
        _ => {
            return Err(err(
                1,
                "a .COM table starts with `BEGIN <name>.COM MM`".into(),
                "export the table from the TNC as text",
            ))
        }
    }
    let Some((hrow, header)) = lines.next() else {
        return Err(err(
            2,
            "no header line".into(),
            "the second line names the columns: NR AXISPOS BACKLASH X",
        ));
    };
    let cols = column_names(header);
    let col = |name: &str| cols.iter().position(|c| c == name);
    let (Some(pos_c), Some(val_c)) = (col("AXISPOS"), col(&ax)) else {
        return Err(err(
            hrow + 1,
            format!("the header needs AXISPOS and {ax}"),
            "the table of an axis' pitch error has a column named after the axis",
        ));
    };
    let back_c = col("BACKLASH");
    let mut out = Positioning {
        positions_mm: Vec::new(),
        forward_um: Vec::new(),
        reverse_um: Vec::new(),
    };
    let mut ended = false;
    for (i, line) in lines {
        let row = i + 1;
        if line.trim().starts_with("[END]") {
            ended = true;
            break;
        }
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() != cols.len() {
            return Err(err(
                row,
                format!("{} fields for {} columns", f.len(), cols.len()),
                "every row has a value in every column",
            ));
        }
        let num = |c: usize| -> Result<f64, ReadError> {
            finite(f[c]).ok_or_else(|| {
                err(
                    row,
                    format!("`{}` in column {} is not a number", f[c], cols[c]),
                    "write numbers in mm, e.g. +0.0012",
                )
            })
        };
        let x = num(pos_c)?;
        if out.positions_mm.last().is_some_and(|&p| x <= p) {
            return Err(err(
                row,
                format!("AXISPOS {x} does not increase"),
                "compensation points are in increasing order",
            ));
        }
        let v = num(val_c)? * 1e3;
        let b = match back_c {
            Some(c) => num(c)? * 1e3,
            None => v,
        };
        out.positions_mm.push(x);
        out.forward_um.push(v);
        out.reverse_um.push(b);
    }
    if !ended {
        return Err(err(
            text.lines().count(),
            "the table has no [END] line".into(),
            "a TNC table ends with [END]",
        ));
    }
    if out.positions_mm.len() < 2 || out.positions_mm.len() > MAX_POINTS {
        return Err(err(
            hrow + 1,
            format!("{} compensation points", out.positions_mm.len()),
            "a .COM table holds 2 … 256 points",
        ));
    }
    Ok(out)
}

/// The column names of a table's header line, in upper case (compared
/// so).
fn column_names(header: &str) -> Vec<String> {
    header
        .split_whitespace()
        .map(str::to_ascii_uppercase)
        .collect()
}

/// Reads a `.CMA` assignment table: the `.COM` file names of its active
/// line (`*` in `ACTIVE`; the only line if there is one) in the columns
/// X, Y, Z. A table in column X compensates X as a function of X.
pub fn parse_cma(text: &str, file: &str) -> Result<[Option<String>; 3], ReadError> {
    let err = |row: usize, m: String, h: &str| located(file, text, row, m, h);
    let rows: Vec<(usize, &str)> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| {
            !l.trim().is_empty()
                && !l.trim_start().starts_with("BEGIN")
                && !l.trim_start().starts_with("[END]")
        })
        .collect();
    let Some(&(hrow, header)) = rows.first() else {
        return Err(err(
            1,
            "no header line".into(),
            "a .CMA table names its columns: NR ACTIVE X Y Z",
        ));
    };
    let cols = column_names(header);
    let active_c = cols.iter().position(|c| c == "ACTIVE");
    let data = &rows[1..];
    let chosen: Vec<&(usize, &str)> = match active_c {
        Some(c) => data
            .iter()
            .filter(|(_, l)| l.split_whitespace().nth(c) == Some("*"))
            .collect(),
        None => data.iter().collect(),
    };
    let [(row, line)] = chosen.as_slice() else {
        return Err(err(
            hrow + 1,
            format!("{} active lines", chosen.len()),
            "mark exactly one line active with * in ACTIVE",
        ));
    };
    let f: Vec<&str> = line.split_whitespace().collect();
    if f.len() != cols.len() {
        return Err(err(
            row + 1,
            format!("{} fields for {} columns", f.len(), cols.len()),
            "give a table name in every column",
        ));
    }
    let mut out: [Option<String>; 3] = [None, None, None];
    for (c, name) in cols.iter().enumerate() {
        if let Some(a) = ["X", "Y", "Z"].iter().position(|x| x == name) {
            out[a] = Some(f[c].to_string());
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_tables() {
        // Z at −200, −100, 0 mm: forward e = 0, +3.12, −2.06 µm, reverse
        // +1.0, +4.25, −1.0 µm → +0.0000, +0.0031, −0.0021 and +0.0010,
        // +0.0043 (4.25 rounds away from zero), −0.0010 mm.
        let z = Positioning::new(
            &[-200.0, -100.0, 0.0],
            &[0.0, 3.12, -2.06],
            &[1.0, 4.25, -1.0],
        );
        let e = export(&[None, None, Some(z)]).unwrap();
        assert_eq!(e.files.len(), 2);
        assert_eq!(e.files[0].name, "Z.COM");
        assert_eq!(
            e.files[0].text,
            "BEGIN Z.COM MM\n\
             NR    AXISPOS       BACKLASH      Z\n\
             0     -200          +0.0010       +0.0000\n\
             1     -100          +0.0043       +0.0031\n\
             2     0             -0.0010       -0.0021\n\
             [END]\n"
        );
        assert_eq!(
            e.files[1].text,
            "BEGIN VOLCOMP.CMA\nNR    ACTIVE  Z\n0     *       Z.COM\n[END]\n"
        );
        // The largest rounding: |4.3 − 4.25| = 0.05 µm (and 3.12 → 3.1: 0.02).
        assert!((e.rounding.max_um - 0.05).abs() < 1e-9, "{:?}", e.rounding);
        assert_eq!(
            parse_cma(&e.files[1].text, "VOLCOMP.CMA").unwrap(),
            [None, None, Some("Z.COM".into())]
        );
        let back = parse_com(&e.files[0].text, "Z.COM", 2).unwrap();
        assert_eq!(&back, e.applied.axes[2].as_ref().unwrap());
        assert!((back.forward_um[1] - 3.1).abs() < 1e-9 && (back.reverse_um[1] - 4.3).abs() < 1e-9);
    }

    #[test]
    fn limits_and_bad_tables() {
        let many = Positioning {
            positions_mm: (0..300).map(f64::from).collect(),
            forward_um: vec![0.0; 300],
            reverse_um: vec![0.0; 300],
        };
        let e = export(&[Some(many), None, None]).unwrap_err();
        // 299 mm / 255 intervals = 1.1725 mm.
        assert!(
            e.message.contains("300 compensation points") && e.help.contains("1.173"),
            "{e}"
        );
        let t = "BEGIN X.COM MM\nNR AXISPOS X\n0 0 +0.001\n1 0 +0.002\n[END]\n";
        let e = parse_com(t, "X.COM", 0).unwrap_err();
        assert_eq!(e.row, 4);
        let e = parse_com("BEGIN X.COM MM\nNR AXISPOS Y\n[END]\n", "X.COM", 0).unwrap_err();
        assert!(e.message.contains("AXISPOS and X"));
        let e = parse_com("BEGIN X.COM INCH\nNR AXISPOS X\n", "X.COM", 0).unwrap_err();
        assert!(e.message.contains("MM"));
    }
}
