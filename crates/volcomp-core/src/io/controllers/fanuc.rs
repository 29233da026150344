//! Fanuc pitch error compensation data as a parameter tape ([Fanuc
//! parameters], parameters 3620–3624 and the pitch error compensation
//! data; docs/controllers.md).
//!
//! What the parameter manual says and this module does:
//!
//! * compensation points are numbered; per axis, 3620 is the number of the
//!   point at the reference position, 3621 the most distant point on the
//!   − side, 3622 on the + side; 3624 the interval between points; 3623
//!   the magnification by which every value is multiplied;
//! * the value stored at point `n` is the compensation *increment* over
//!   the section that ends at `n` (from `n − 1` to `n`), in detection units
//!   times the magnification, "as viewed from the negative direction":
//!   the absolute compensation is zero at the reference position and the
//!   running sum of the increments elsewhere;
//! * a value lies in −128 … 127.
//!
//! Where the public documentation is silent, volcomp assumes, and makes a
//! switch of ([`FanucOptions`]):
//!
//! * **sign**: the values are the correction the control outputs
//!   (`−e`, [`FanucSign::Correction`]); [`FanucSign::Error`] writes `+e`;
//! * **tape numbering**: pitch error data `n` is data number `10000 + n`
//!   (`N10000 P…`), the axis parameters `N3620 A1 P… A2 P… A3 P…`;
//! * **reference position**: at machine coordinate 0 of each axis (param.
//!   1240 = 0), so the table's positions are `(n − 3620)·3624`;
//! * the interval 3624 in detection units; the axes numbered one after the
//!   other from point 0 (X, then Y, then Z).
//!
//! The table is unidirectional (3605#0 = 0): volcomp writes the mean of
//! the forward and reverse errors and reports the reversal for the
//! backlash compensation (parameter 1851).

use super::{
    axis_letter, bidirectional_mean, equidistant, located, ControllerCorrection, Export,
    ExportFile, Format, LimitError, Positioning, ReadError, Rounding,
};
use crate::io::numfmt::fixed;

/// The sign of the written values (undocumented publicly; a switch).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FanucSign {
    /// The correction `−e` (default).
    Correction,
    /// The error `+e`.
    Error,
}

impl FanucSign {
    fn factor(self) -> f64 {
        match self {
            FanucSign::Correction => -1.0,
            FanucSign::Error => 1.0,
        }
    }
}

/// Options of the Fanuc export.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FanucOptions {
    /// Interval between compensation points (mm).
    pub step_mm: f64,
    /// The detection unit (µm): 1 µm for IS-B.
    pub detection_unit_um: f64,
    /// Sign of the values.
    pub sign: FanucSign,
    /// Data number of compensation point 0 on the tape.
    pub data_offset: u32,
    /// The highest compensation point number of the control.
    pub max_number: usize,
}

impl Default for FanucOptions {
    fn default() -> Self {
        FanucOptions {
            step_mm: 10.0,
            detection_unit_um: 1.0,
            sign: FanucSign::Correction,
            data_offset: 10000,
            max_number: 1023,
        }
    }
}

/// The smallest value and the largest of a compensation point.
pub const VALUE_RANGE: (i64, i64) = (-128, 127);

/// The parameter tape for the positioning tables `p` (X, Y, Z).
pub fn export(p: &[Option<Positioning>; 3], o: &FanucOptions) -> Result<Export, LimitError> {
    let unit = o.detection_unit_um;
    let interval = (o.step_mm * 1e3 / unit).round();
    let mut rounding = Rounding {
        resolution_um: unit,
        max_um: 0.0,
    };
    let mut next = 0usize;
    let mut params: [Vec<String>; 5] = Default::default();
    let mut data = String::new();
    let mut applied: [Option<Positioning>; 3] = [None, None, None];
    let mut notes = Vec::new();
    for (a, table) in p.iter().enumerate() {
        let Some(table) = table else { continue };
        let ax = axis_letter(a);
        let limit = |message: String, help: String| LimitError {
            format: "fanuc",
            axis: ax,
            message,
            help,
        };
        if (interval * unit * 1e-3 - o.step_mm).abs() > 1e-9 {
            return Err(limit(
                format!(
                    "the interval {} mm is not a whole number of detection units ({unit} um)",
                    o.step_mm
                ),
                "choose a step that is".into(),
            ));
        }
        let (mean, reversal) = bidirectional_mean(table);
        let lo = table.positions_mm[0];
        let hi = table.positions_mm[table.positions_mm.len() - 1];
        // Points at k·step from the reference position (machine 0) covering lo … hi.
        let k_lo = (lo / o.step_mm + 1e-9).floor() as i64;
        let k_hi = (hi / o.step_mm - 1e-9).ceil() as i64;
        let k_lo = k_lo.min(0);
        let k_hi = k_hi.max(0);
        let count = (k_hi - k_lo + 1) as usize;
        if next + count - 1 > o.max_number {
            return Err(limit(
                format!("{count} compensation points from number {next}: the control numbers points 0 … {}", o.max_number),
                format!("choose a step of at least {} mm", fixed((hi - lo) / (o.max_number.saturating_sub(next).max(2) - 1) as f64, 3)),
            ));
        }
        let sampled = equidistant(&mean, k_lo as f64 * o.step_mm, o.step_mm, count);
        let r_index = (-k_lo) as usize;
        let e_ref = sampled.forward_um[r_index];
        // The absolute correction relative to the reference position, in
        // detection units, rounded; increments between neighbours.
        let c_units: Vec<f64> = sampled
            .forward_um
            .iter()
            .map(|e| o.sign.factor() * (e - e_ref) / unit)
            .collect();
        let abs_rounded: Vec<i64> = c_units.iter().map(|c| c.round() as i64).collect();
        let increments: Vec<i64> = (0..count)
            .map(|i| {
                if i == 0 {
                    0
                } else {
                    abs_rounded[i] - abs_rounded[i - 1]
                }
            })
            .collect();
        let worst = increments.iter().map(|v| v.abs()).max().unwrap_or(0);
        let magnification = (worst + VALUE_RANGE.1 - 1) / VALUE_RANGE.1;
        let magnification = magnification.max(1);
        let values: Vec<i64> = if magnification == 1 {
            increments
        } else {
            // With a magnification the increments are of `magnification` units.
            let abs_m: Vec<i64> = c_units
                .iter()
                .map(|c| (c / magnification as f64).round() as i64)
                .collect();
            (0..count)
                .map(|i| if i == 0 { 0 } else { abs_m[i] - abs_m[i - 1] })
                .collect()
        };
        if magnification > 100 {
            return Err(limit(
                format!("increments of {worst} detection units between points"),
                "a smaller step makes them smaller".into(),
            ));
        }
        // What the control applies: the running sum, zero at the reference.
        let mut absolute = vec![0i64; count];
        for i in (0..r_index).rev() {
            absolute[i] = absolute[i + 1] - values[i + 1];
        }
        for i in r_index + 1..count {
            absolute[i] = absolute[i - 1] + values[i];
        }
        let applied_um: Vec<f64> = absolute
            .iter()
            .map(|&c| o.sign.factor() * (c * magnification) as f64 * unit)
            .collect();
        for (i, v) in applied_um.iter().enumerate() {
            rounding.max_um = rounding
                .max_um
                .max((v - (sampled.forward_um[i] - e_ref)).abs());
        }
        let axis_no = a + 1;
        params[0].push(format!("A{axis_no} P{}", next + r_index));
        params[1].push(format!("A{axis_no} P{next}"));
        params[2].push(format!("A{axis_no} P{}", next + count - 1));
        params[3].push(format!("A{axis_no} P{magnification}"));
        params[4].push(format!("A{axis_no} P{}", interval as i64));
        for (i, v) in values.iter().enumerate() {
            data.push_str(&format!("N{} P{v}\n", o.data_offset as usize + next + i));
        }
        notes.push(format!(
            "{ax}: points {next} … {} (reference {}), every {} mm; the table is relative to the reference position, where the error ({} um) stays",
            next + count - 1,
            next + r_index,
            fixed(o.step_mm, 6),
            fixed(e_ref, 3)
        ));
        if reversal > 0.0 {
            notes.push(format!("{ax}: one table for both directions (the mean); the reversal value, up to {} um, is for the backlash compensation (parameter 1851)", fixed(reversal, 3)));
        }
        applied[a] = Some(Positioning {
            positions_mm: sampled.positions_mm.clone(),
            forward_um: applied_um.iter().map(|v| v + e_ref).collect(),
            reverse_um: applied_um.iter().map(|v| v + e_ref).collect(),
        });
        next += count;
    }
    let mut text = format!(
        "%\n( volcomp: pitch error compensation, {} sign, detection unit {} um )\n",
        match o.sign {
            FanucSign::Correction => "correction = -e",
            FanucSign::Error => "error = +e",
        },
        fixed(unit, 4)
    );
    for (k, no) in [3620, 3621, 3622, 3623, 3624].iter().enumerate() {
        if !params[k].is_empty() {
            text.push_str(&format!("N{no} {}\n", params[k].join(" ")));
        }
    }
    text.push_str(&data);
    text.push_str("%\n");
    Ok(Export {
        files: vec![ExportFile {
            name: "pitch.tap".into(),
            text,
        }],
        applied: ControllerCorrection {
            format: Format::Fanuc,
            axes: applied,
            squareness_urad: None,
            cross: Vec::new(),
        },
        rounding,
        notes,
    })
}

/// Reads a tape written by [`export`] (the same assumptions: reference at
/// machine 0, data numbers from `o.data_offset`, the sign `o.sign`). The
/// absolute compensation is relative to the reference position: the
/// applied table is zero there.
pub fn parse(text: &str, file: &str, o: &FanucOptions) -> Result<ControllerCorrection, ReadError> {
    let err = |row: usize, m: String, h: &str| located(file, text, row, m, h);
    let mut params: std::collections::HashMap<(u32, usize), i64> = Default::default();
    let mut data: std::collections::HashMap<usize, i64> = Default::default();
    for (i, raw) in text.lines().enumerate() {
        let row = i + 1;
        let mut line = raw.split(';').next().unwrap_or("").to_string();
        while let (Some(s), Some(e)) = (line.find('('), line.find(')')) {
            if e < s {
                break;
            }
            line.replace_range(s..=e, "");
        }
        let line = line.trim();
        if line.is_empty() || line == "%" {
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        let Some(n) = words[0]
            .strip_prefix('N')
            .and_then(|n| n.parse::<u32>().ok())
        else {
            return Err(err(
                row,
                format!("`{}` is not a data number", words[0]),
                "each line starts with N and a parameter or data number",
            ));
        };
        let num = |w: &str, p: char| -> Result<i64, ReadError> {
            w.strip_prefix(p)
                .and_then(|v| v.parse().ok())
                .ok_or_else(|| {
                    err(
                        row,
                        format!("`{w}` is not {p} and a whole number"),
                        "write A<axis> P<value> pairs",
                    )
                })
        };
        if (3620..=3624).contains(&n) {
            for pair in words[1..].chunks(2) {
                let [aw, pw] = pair else {
                    return Err(err(
                        row,
                        "an A word without its P".into(),
                        "write A<axis> P<value> pairs",
                    ));
                };
                let axis = num(aw, 'A')?;
                if !(1..=3).contains(&axis) {
                    return Err(err(row, format!("axis {axis}"), "axes 1, 2, 3 are X, Y, Z"));
                }
                params.insert((n, axis as usize - 1), num(pw, 'P')?);
            }
        } else if n >= o.data_offset && (n - o.data_offset) as usize <= o.max_number {
            let [_, pw] = words.as_slice() else {
                return Err(err(
                    row,
                    "expected N… P…".into(),
                    "one value per data number",
                ));
            };
            let v = num(pw, 'P')?;
            if !(VALUE_RANGE.0..=VALUE_RANGE.1).contains(&v) {
                return Err(err(
                    row,
                    format!("value {v} outside −128 … 127"),
                    "a pitch error compensation value lies in −128 … 127",
                ));
            }
            data.insert((n - o.data_offset) as usize, v);
        } else {
            return Err(err(
                row,
                format!("N{n} is not a pitch error compensation parameter or datum"),
                "expected N3620 … N3624 or the data numbers",
            ));
        }
    }
    let mut axes: [Option<Positioning>; 3] = [None, None, None];
    for (a, slot) in axes.iter_mut().enumerate() {
        let get = |p: u32| params.get(&(p, a)).copied();
        let (Some(r), Some(lo), Some(hi), Some(m), Some(iv)) =
            (get(3620), get(3621), get(3622), get(3623), get(3624))
        else {
            continue;
        };
        if !(lo <= r && r <= hi) || iv <= 0 {
            return Err(err(
                1,
                format!(
                    "axis {}: 3621 ≤ 3620 ≤ 3622 and 3624 > 0 do not hold",
                    axis_letter(a)
                ),
                "check the axis' parameters",
            ));
        }
        let step = iv as f64 * o.detection_unit_um * 1e-3;
        let n = (hi - lo + 1) as usize;
        let value = |k: i64| data.get(&(k as usize)).copied().unwrap_or(0);
        let mut absolute = vec![0i64; n];
        let ri = (r - lo) as usize;
        for i in (0..ri).rev() {
            absolute[i] = absolute[i + 1] - value(lo + i as i64 + 1);
        }
        for i in ri + 1..n {
            absolute[i] = absolute[i - 1] + value(lo + i as i64);
        }
        let um: Vec<f64> = absolute
            .iter()
            .map(|&c| o.sign.factor() * (c * m.max(1)) as f64 * o.detection_unit_um)
            .collect();
        *slot = Some(Positioning {
            positions_mm: (0..n)
                .map(|i| (i as i64 - ri as i64) as f64 * step)
                .collect(),
            forward_um: um.clone(),
            reverse_um: um,
        });
    }
    if axes.iter().all(Option::is_none) {
        return Err(err(
            1,
            "no axis with parameters 3620 … 3624".into(),
            "the tape needs N3620 … N3624 for at least one axis",
        ));
    }
    Ok(ControllerCorrection {
        format: Format::Fanuc,
        axes,
        squareness_urad: None,
        cross: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_tape() {
        // X from 0 to 30 mm, reference at 0, every 10 mm: e = 0, 4.4, 6.0, 5.2 µm
        // (both directions). Correction −e relative to the reference:
        // 0, −4.4, −6.0, −5.2 → rounded 0, −4, −6, −5 µm; increments 0, −4,
        // −2, +1 at points 0, 1, 2, 3; 3620 = 0 (reference), 3621 = 0,
        // 3622 = 3, magnification 1, interval 10000 units.
        let x = Positioning {
            positions_mm: vec![0.0, 10.0, 20.0, 30.0],
            forward_um: vec![0.0, 4.4, 6.0, 5.2],
            reverse_um: vec![0.0, 4.4, 6.0, 5.2],
        };
        let e = export(&[Some(x), None, None], &FanucOptions::default()).unwrap();
        let t = &e.files[0].text;
        for line in [
            "N3620 A1 P0\n",
            "N3621 A1 P0\n",
            "N3622 A1 P3\n",
            "N3623 A1 P1\n",
            "N3624 A1 P10000\n",
            "N10000 P0\nN10001 P-4\nN10002 P-2\nN10003 P1\n",
        ] {
            assert!(t.contains(line), "{line} missing in\n{t}");
        }
        // Applied (error sign): 0, 4, 6, 5 µm; the largest rounding 0.4 µm.
        assert_eq!(
            e.applied.axes[0].as_ref().unwrap().forward_um,
            vec![0.0, 4.0, 6.0, 5.0]
        );
        assert!((e.rounding.max_um - 0.4).abs() < 1e-9, "{:?}", e.rounding);
        let back = parse(t, "pitch.tap", &FanucOptions::default()).unwrap();
        assert_eq!(back, e.applied);
        // The other sign, as a switch: the same tape with the signs flipped.
        let o = FanucOptions {
            sign: FanucSign::Error,
            ..FanucOptions::default()
        };
        let x = e.applied.axes[0].clone().unwrap();
        let f = export(&[Some(x), None, None], &o).unwrap();
        assert!(
            f.files[0]
                .text
                .contains("N10001 P4\nN10002 P2\nN10003 P-1\n"),
            "{}",
            f.files[0].text
        );
    }

    #[test]
    fn negative_side_magnification_and_limits() {
        // Y from −20 to 0 (reference at the + end): e = 300, 150, 0 µm every 10 mm.
        // Correction relative to the reference: −300, −150, 0; increments
        // (point 1: −150 − (−300) = 150, point 2: 150) exceed 127: magnification 2,
        // values 75, 75.
        let y = Positioning {
            positions_mm: vec![-20.0, -10.0, 0.0],
            forward_um: vec![300.0, 150.0, 0.0],
            reverse_um: vec![300.0, 150.0, 0.0],
        };
        let e = export(&[None, Some(y), None], &FanucOptions::default()).unwrap();
        let t = &e.files[0].text;
        assert!(
            t.contains("N3620 A2 P2\n")
                && t.contains("N3623 A2 P2\n")
                && t.contains("N10001 P75\nN10002 P75\n"),
            "{t}"
        );
        let back = parse(t, "pitch.tap", &FanucOptions::default()).unwrap();
        assert_eq!(
            back.axes[1].as_ref().unwrap().forward_um,
            vec![300.0, 150.0, 0.0]
        );
        assert_eq!(
            back.axes[1].as_ref().unwrap().positions_mm,
            vec![-20.0, -10.0, 0.0]
        );
        let long = Positioning {
            positions_mm: vec![0.0, 2000.0],
            forward_um: vec![0.0, 0.0],
            reverse_um: vec![0.0, 0.0],
        };
        let err = export(
            &[Some(long), None, None],
            &FanucOptions {
                step_mm: 1.0,
                ..FanucOptions::default()
            },
        )
        .unwrap_err();
        assert!(err.message.contains("2001 compensation points"), "{err}");
        let bad = parse("N3620 A1 P0\nN10000 P200\n", "t", &FanucOptions::default()).unwrap_err();
        assert_eq!(bad.row, 2);
    }
}
