//! Fanuc pitch error compensation data as a parameter tape ([Fanuc
//! parameters], parameters 3620–3624, for bidirectional tables 3605#0,
//! 3626, 3627, and the pitch error compensation data; docs/controllers.md).
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
//! Direction ([`FanucBidirectional`], the bidirectional pitch error
//! compensation report of [Fanuc parameters]): where the forward and
//! reverse errors differ by more than the detection unit (or always, or
//! never), the axis gets 3605#0 = 1 and a second table for travel in the
//! − direction, points 3626 … 3626 + (3622 − 3621), with the same
//! reference point offset, magnification and interval; 3627 is the
//! absolute compensation at the reference position for the direction
//! opposite to the reference position return. The reader gives each
//! direction its table ([`ControllerCorrection`]'s `forward_um`,
//! `reverse_um`). Otherwise the table is unidirectional (3605#0 = 0) and
//! the reversal goes to the backlash compensation, written on the tape:
//! parameter 1851 (and 1852, the backlash for rapid traverse used when
//! 1800#4 RBK = 1, the same value, so that every move gets one
//! correction) = the mean reversal value `B̄` in detection units; the
//! table then holds the mean of both directions shifted by half of it
//! ([`super::table_beside_backlash`]). *Assumed*: the backlash
//! compensation acts on travel opposite to the reference position return
//! (the return takes the backlash up); with a bidirectional table 1851 is
//! written 0 (the tables hold the reversal), and read back only as 0.
//! Assumed where the report is
//! silent: the − table follows the + table's points; 3627 in detection
//! units (not magnified) with the values' sign; 3605 written as the whole
//! byte (`P00000001`, its other bits 0); the reference position return
//! direction (1006#5) a switch ([`FanucReturn`], + by default).

use super::{
    axis_letter, bidirectional_mean, equidistant, located, table_beside_backlash, Backlash,
    BacklashSide, ControllerCorrection, Export, ExportFile, Format, LimitError, Positioning,
    ReadError, Rounding,
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
    /// One table per direction (3605#0).
    pub bidirectional: FanucBidirectional,
    /// The direction of the reference position return (1006#5).
    pub reference_return: FanucReturn,
}

impl Default for FanucOptions {
    fn default() -> Self {
        FanucOptions {
            step_mm: 10.0,
            detection_unit_um: 1.0,
            sign: FanucSign::Correction,
            data_offset: 10000,
            max_number: 1023,
            bidirectional: FanucBidirectional::Auto,
            reference_return: FanucReturn::Positive,
        }
    }
}

/// The smallest value and the largest of a compensation point.
pub const VALUE_RANGE: (i64, i64) = (-128, 127);

/// Whether the tape holds one table per direction (3605#0, 3626, 3627).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FanucBidirectional {
    /// Bidirectional for an axis whose forward and reverse errors differ
    /// by more than the detection unit anywhere (default).
    Auto,
    /// Always bidirectional.
    On,
    /// Never: one table, the mean of both directions.
    Off,
}

/// The direction of the reference position return (parameter 1006#5,
/// ZMIx): the direction whose table is zero at the reference position;
/// the other direction's value there is parameter 3627.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FanucReturn {
    /// The + direction (1006#5 = 0, default).
    Positive,
    /// The − direction (1006#5 = 1).
    Negative,
}

impl FanucReturn {
    /// The travel the backlash compensation (1851) acts on: the one away
    /// from the reference position return.
    pub fn backlash_side(self) -> BacklashSide {
        match self {
            FanucReturn::Positive => BacklashSide::Reverse,
            FanucReturn::Negative => BacklashSide::Forward,
        }
    }
}

/// The range of parameters 1851 and 1852 (detection units).
pub const BACKLASH_RANGE: (i64, i64) = (-9999, 9999);

/// The range of parameter 3627 (detection units).
pub const REFERENCE_RANGE: (i64, i64) = (-32768, 32767);

/// One direction's table: the values written at its points (the
/// increments in `magnification` units, 0 at the first point) and the
/// absolute compensation the control applies (detection units), for the
/// wanted absolute correction `c` (detection units) with `base` at the
/// reference point `r` (`c[r]` rounds to `base`).
fn increments(c: &[f64], r: usize, base: i64, m: i64) -> (Vec<i64>, Vec<i64>) {
    let mut abs_m: Vec<i64> = c
        .iter()
        .map(|c| ((c - base as f64) / m as f64).round() as i64)
        .collect();
    // The reference point holds `base` (3627 or 0) by definition, even
    // where `c[r]` lies half a unit from it.
    abs_m[r] = 0;
    let values = (0..c.len())
        .map(|i| if i == 0 { 0 } else { abs_m[i] - abs_m[i - 1] })
        .collect();
    // What the control applies: the running sum from the reference point.
    let mut absolute = vec![0i64; c.len()];
    for i in (0..r).rev() {
        absolute[i] = absolute[i + 1] - (abs_m[i + 1] - abs_m[i]);
    }
    for i in r + 1..c.len() {
        absolute[i] = absolute[i - 1] + (abs_m[i] - abs_m[i - 1]);
    }
    (values, absolute.iter().map(|a| base + m * a).collect())
}

/// The parameter tape for the positioning tables `p` (X, Y, Z).
pub fn export(p: &[Option<Positioning>; 3], o: &FanucOptions) -> Result<Export, LimitError> {
    let unit = o.detection_unit_um;
    let interval = (o.step_mm * 1e3 / unit).round();
    let mut rounding = Rounding {
        resolution_um: unit,
        max_um: 0.0,
    };
    let mut next = 0usize;
    // 1851, 1852, 3605, 3620 … 3624, 3626, 3627.
    let mut params: [Vec<String>; 10] = Default::default();
    let mut data = String::new();
    let mut applied = ControllerCorrection::empty(Format::Fanuc);
    let mut notes = Vec::new();
    let side = o.reference_return.backlash_side();
    let mut holds = [super::table_error::Holds::Nothing; 3];
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
        let both = match o.bidirectional {
            FanucBidirectional::On => true,
            FanucBidirectional::Off => false,
            FanucBidirectional::Auto => reversal > unit,
        };
        let lo = table.positions_mm[0];
        let hi = table.positions_mm[table.positions_mm.len() - 1];
        // Points at k·step from the reference position (machine 0) covering lo … hi.
        let k_lo = (lo / o.step_mm + 1e-9).floor() as i64;
        let k_hi = (hi / o.step_mm - 1e-9).ceil() as i64;
        let k_lo = k_lo.min(0);
        let k_hi = k_hi.max(0);
        let count = (k_hi - k_lo + 1) as usize;
        let tables = if both { 2 } else { 1 };
        holds[a] = if both {
            super::table_error::Holds::BothDirections
        } else {
            super::table_error::Holds::OneTable
        };
        if next + tables * count - 1 > o.max_number {
            let what = if both {
                format!("{count} compensation points per direction (the − direction's table after the + one) from number {next}")
            } else {
                format!("{count} compensation points from number {next}")
            };
            return Err(limit(
                format!("{what}: the control numbers points 0 … {}", o.max_number),
                format!(
                    "choose a step of at least {} mm",
                    fixed(
                        tables as f64 * (hi - lo)
                            / (o.max_number.saturating_sub(next).max(2 * tables) - tables) as f64,
                        3
                    )
                ),
            ));
        }
        let _ = mean;
        let (beside, b_mean) = table_beside_backlash(table, side);
        let b_units = if both {
            0
        } else {
            (b_mean / unit).round() as i64
        };
        if !(BACKLASH_RANGE.0..=BACKLASH_RANGE.1).contains(&b_units) {
            return Err(limit(
                format!("a mean reversal value of {b_units} detection units exceeds parameter 1851's range"),
                "check the direction columns of the map".into(),
            ));
        }
        rounding.max_um = rounding
            .max_um
            .max((b_units as f64 * unit - if both { 0.0 } else { b_mean }).abs());
        let source = if both { table } else { &beside };
        let sampled = equidistant(source, k_lo as f64 * o.step_mm, o.step_mm, count);
        let r_index = (-k_lo) as usize;
        // The error of the reference-return direction at the reference
        // position stays: both tables are relative to it.
        let e_ref = match o.reference_return {
            FanucReturn::Positive => sampled.forward_um[r_index],
            FanucReturn::Negative => sampled.reverse_um[r_index],
        };
        // The absolute correction relative to it, in detection units.
        let units = |v: &[f64]| -> Vec<f64> {
            v.iter()
                .map(|e| o.sign.factor() * (e - e_ref) / unit)
                .collect()
        };
        let c_fwd = units(&sampled.forward_um);
        let c_rev = units(&sampled.reverse_um);
        // 3627: the other direction's value at the reference position.
        let (base_fwd, base_rev) = match (both, o.reference_return) {
            (false, _) => (0, 0),
            (true, FanucReturn::Positive) => (0, c_rev[r_index].round() as i64),
            (true, FanucReturn::Negative) => (c_fwd[r_index].round() as i64, 0),
        };
        let p3627 = base_fwd + base_rev;
        if !(REFERENCE_RANGE.0..=REFERENCE_RANGE.1).contains(&p3627) {
            return Err(limit(
                format!("the reversal at the reference position, {p3627} detection units, exceeds parameter 3627's range"),
                "check the reverse table".into(),
            ));
        }
        // The smallest magnification that keeps every value in range.
        let mut magnification = 1i64;
        let (values_fwd, abs_fwd, values_rev, abs_rev) = loop {
            let (vf, af) = increments(&c_fwd, r_index, base_fwd, magnification);
            let (vr, ar) = increments(&c_rev, r_index, base_rev, magnification);
            let worst = vf
                .iter()
                .chain(if both { &vr } else { &vf })
                .map(|v| v.abs())
                .max()
                .unwrap_or(0);
            if worst <= VALUE_RANGE.1 {
                break (vf, af, vr, ar);
            }
            if magnification >= 100 {
                return Err(limit(
                    format!(
                        "increments of {} detection units between points",
                        worst * magnification
                    ),
                    "a smaller step makes them smaller".into(),
                ));
            }
            magnification = (magnification + 1)
                .max((worst * magnification + VALUE_RANGE.1 - 1) / VALUE_RANGE.1)
                .min(100);
        };
        let to_um = |abs: &[i64]| -> Vec<f64> {
            abs.iter()
                .map(|&c| o.sign.factor() * c as f64 * unit)
                .collect()
        };
        let applied_fwd = to_um(&abs_fwd);
        let applied_rev = if both {
            to_um(&abs_rev)
        } else {
            applied_fwd.clone()
        };
        for i in 0..count {
            rounding.max_um = rounding
                .max_um
                .max((applied_fwd[i] - (sampled.forward_um[i] - e_ref)).abs())
                .max((applied_rev[i] - (sampled.reverse_um[i] - e_ref)).abs());
        }
        let axis_no = a + 1;
        params[0].push(format!("A{axis_no} P{b_units}"));
        params[1].push(format!("A{axis_no} P{b_units}"));
        params[3].push(format!("A{axis_no} P{}", next + r_index));
        params[4].push(format!("A{axis_no} P{next}"));
        params[5].push(format!("A{axis_no} P{}", next + count - 1));
        params[6].push(format!("A{axis_no} P{magnification}"));
        params[7].push(format!("A{axis_no} P{}", interval as i64));
        for (i, v) in values_fwd.iter().enumerate() {
            data.push_str(&format!("N{} P{v}\n", o.data_offset as usize + next + i));
        }
        if both {
            params[2].push(format!("A{axis_no} P00000001"));
            params[8].push(format!("A{axis_no} P{}", next + count));
            params[9].push(format!("A{axis_no} P{p3627}"));
            for (i, v) in values_rev.iter().enumerate() {
                data.push_str(&format!(
                    "N{} P{v}\n",
                    o.data_offset as usize + next + count + i
                ));
            }
        }
        notes.push(format!(
            "{ax}: points {next} … {} (reference {}), every {} mm; the table is relative to the reference position, where the error ({} um) stays",
            next + count - 1,
            next + r_index,
            fixed(o.step_mm, 6),
            fixed(e_ref, 3)
        ));
        if both {
            notes.push(format!(
                "{ax}: bidirectional (3605#0 = 1): the - direction's table at points {} … {} (3626), {p3627} at the reference position (3627, reference position return in the {} direction, 1006#5 = {}); the backlash compensation 1851 (and 1852) is written 0, the tables hold the reversal (up to {} um)",
                next + count,
                next + 2 * count - 1,
                match o.reference_return {
                    FanucReturn::Positive => "+",
                    FanucReturn::Negative => "-",
                },
                match o.reference_return {
                    FanucReturn::Positive => 0,
                    FanucReturn::Negative => 1,
                },
                fixed(reversal, 3)
            ));
        } else {
            notes.push(format!("{ax}: one table for both directions; the backlash compensation 1851 (and 1852 for rapid traverse) = {b_units} detection units is on the tape: the mean reversal value ({} um; the mean, not the largest, so that the reversal left over averages zero along the axis; it varies up to {} um), assumed to act on travel away from the reference position return; the table is the mean of both directions {} half of it", fixed(b_mean, 3), fixed(reversal, 3), match side { BacklashSide::Forward => "plus", _ => "minus" }));
            if b_units != 0 {
                applied.backlash[a] = Some(Backlash {
                    value_um: b_units as f64 * unit,
                    side,
                });
            }
        }
        // What the control applies: relative to the reference position,
        // where the reference return direction's error stays.
        applied.axes[a] = Some(Positioning {
            positions_mm: sampled.positions_mm.clone(),
            forward_um: applied_fwd,
            reverse_um: applied_rev,
        });
        next += tables * count;
    }
    let mut text = format!(
        "%\n( volcomp: pitch error compensation, {} sign, detection unit {} um )\n",
        match o.sign {
            FanucSign::Correction => "correction = -e",
            FanucSign::Error => "error = +e",
        },
        fixed(unit, 4)
    );
    for (k, no) in [1851, 1852, 3605, 3620, 3621, 3622, 3623, 3624, 3626, 3627]
        .iter()
        .enumerate()
    {
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
        applied,
        rounding,
        holds,
        zero_at: Some((0.0, o.reference_return == FanucReturn::Positive)),
        notes,
    })
}

/// Reads a tape written by [`export`] (the same assumptions: reference at
/// machine 0, data numbers from `o.data_offset`, the sign `o.sign`, the
/// reference position return `o.reference_return`). The absolute
/// compensation is relative to the reference position: the applied table
/// is zero there. Every axis with a table must give its backlash
/// compensation 1851 (it changes what the control applies); 1852, where
/// given, must equal it, and a bidirectional axis must have it 0.
pub fn parse(text: &str, file: &str, o: &FanucOptions) -> Result<ControllerCorrection, ReadError> {
    let err = |row: usize, m: String, h: &str| located(file, text, row, m, h);
    let mut params: std::collections::HashMap<(u32, usize), i64> = Default::default();
    let mut rows: std::collections::HashMap<u32, usize> = Default::default();
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
        if (3620..=3624).contains(&n) || [1851, 1852, 3605, 3626, 3627].contains(&n) {
            rows.insert(n, row);
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
                let v = if n == 3605 {
                    // A bit parameter: eight binary digits #7 … #0.
                    let bits = pw.strip_prefix('P').unwrap_or("");
                    if bits.is_empty()
                        || bits.len() > 8
                        || !bits.chars().all(|c| c == '0' || c == '1')
                    {
                        return Err(err(
                            row,
                            format!("`{pw}` is not P and the bits #7 … #0"),
                            "write a bit parameter as P and eight binary digits, e.g. P00000001",
                        ));
                    }
                    i64::from(bits.ends_with('1'))
                } else {
                    num(pw, 'P')?
                };
                params.insert((n, axis as usize - 1), v);
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
                "expected N1851, N1852, N3605, N3620 … N3624, N3626, N3627 or the data numbers",
            ));
        }
    }
    let mut axes: [Option<Positioning>; 3] = [None, None, None];
    let mut out = ControllerCorrection::empty(Format::Fanuc);
    for (a, slot) in axes.iter_mut().enumerate() {
        let get = |p: u32| params.get(&(p, a)).copied();
        let row_of = |p: u32| rows.get(&p).copied().unwrap_or(1);
        let b1851 = get(1851);
        if let (Some(b), Some(r)) = (b1851, get(1852)) {
            if b != r {
                return Err(err(
                    row_of(1852),
                    format!("axis {}: 1852 (backlash for rapid traverse) = {r} differs from 1851 = {b}", axis_letter(a)),
                    "volcomp models one backlash per axis: set 1852 equal to 1851 (or 1800#4 RBK = 0 and leave 1852 out)",
                ));
            }
        }
        let (Some(r), Some(lo), Some(hi), Some(m), Some(iv)) =
            (get(3620), get(3621), get(3622), get(3623), get(3624))
        else {
            continue;
        };
        if !(lo <= r && r <= hi) || iv <= 0 || lo < 0 || hi > o.max_number as i64 {
            return Err(err(
                1,
                format!(
                    "axis {}: 0 ≤ 3621 ≤ 3620 ≤ 3622 ≤ {} and 3624 > 0 do not hold",
                    axis_letter(a),
                    o.max_number
                ),
                "check the axis' parameters",
            ));
        }
        let step = iv as f64 * o.detection_unit_um * 1e-3;
        let n = (hi - lo + 1) as usize;
        let ri = (r - lo) as usize;
        let value = |k: i64| data.get(&(k as usize)).copied().unwrap_or(0);
        // The absolute compensation of the table whose − end is point
        // `first`, `base` at the reference position (detection units).
        let table = |first: i64, base: i64| -> Vec<f64> {
            let mut absolute = vec![0i64; n];
            for i in (0..ri).rev() {
                absolute[i] = absolute[i + 1] - value(first + i as i64 + 1);
            }
            for i in ri + 1..n {
                absolute[i] = absolute[i - 1] + value(first + i as i64);
            }
            absolute
                .iter()
                .map(|&c| o.sign.factor() * (base + c * m.max(1)) as f64 * o.detection_unit_um)
                .collect()
        };
        let Some(b1851) = b1851 else {
            return Err(err(
                row_of(3620),
                format!("axis {}: the tape does not give its backlash compensation (parameter 1851)", axis_letter(a)),
                &format!("the control may correct the reversal too: add N1851 A{} P… with the machine's value in detection units (0 if none), so that volcomp does not correct it a second time", a + 1),
            ));
        };
        let bidirectional = get(3605) == Some(1);
        if bidirectional && b1851 != 0 {
            return Err(err(
                row_of(1851),
                format!("axis {}: 1851 = {b1851} beside a bidirectional pitch error compensation", axis_letter(a)),
                "the bidirectional tables hold the reversal, and no public document says how 1851 adds to them: set 1851 (and 1852) to 0",
            ));
        }
        if b1851 != 0 {
            out.backlash[a] = Some(Backlash {
                value_um: b1851 as f64 * o.detection_unit_um,
                side: o.reference_return.backlash_side(),
            });
        }
        let (forward_um, reverse_um) = if bidirectional {
            let Some(neg) = get(3626) else {
                return Err(err(
                    1,
                    format!(
                        "axis {}: bidirectional (3605#0 = 1) without parameter 3626",
                        axis_letter(a)
                    ),
                    "give 3626, the number of the − direction's most distant point on the − side",
                ));
            };
            if neg < 0 || neg + (hi - lo) > o.max_number as i64 {
                return Err(err(
                    1,
                    format!(
                        "axis {}: the − direction's points {neg} … {} (3626 + 3622 − 3621) lie beyond the table's 0 … {}",
                        axis_letter(a),
                        neg + (hi - lo),
                        o.max_number
                    ),
                    "3626 + (3622 − 3621) must be a compensation point of the control",
                ));
            }
            let p3627 = get(3627).unwrap_or(0);
            let (bf, br) = match o.reference_return {
                FanucReturn::Positive => (0, p3627),
                FanucReturn::Negative => (p3627, 0),
            };
            (table(lo, bf), table(neg, br))
        } else {
            let um = table(lo, 0);
            (um.clone(), um)
        };
        *slot = Some(Positioning {
            positions_mm: (0..n)
                .map(|i| (i as i64 - ri as i64) as f64 * step)
                .collect(),
            forward_um,
            reverse_um,
        });
    }
    if axes.iter().all(Option::is_none) {
        return Err(err(
            1,
            "no axis with parameters 3620 … 3624".into(),
            "the tape needs N3620 … N3624 for at least one axis",
        ));
    }
    out.axes = axes;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::controllers::test_support::assert_noted;

    #[test]
    fn hand_computed_tape() {
        // X from 0 to 30 mm, reference at 0, every 10 mm: e = 0, 4.4, 6.0, 5.2 µm
        // (both directions). Correction −e relative to the reference:
        // 0, −4.4, −6.0, −5.2 → rounded 0, −4, −6, −5 µm; increments 0, −4,
        // −2, +1 at points 0, 1, 2, 3; 3620 = 0 (reference), 3621 = 0,
        // 3622 = 3, magnification 1, interval 10000 units.
        let x = Positioning::new(
            &[0.0, 10.0, 20.0, 30.0],
            &[0.0, 4.4, 6.0, 5.2],
            &[0.0, 4.4, 6.0, 5.2],
        );
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
        let y = Positioning::new(
            &[-20.0, -10.0, 0.0],
            &[300.0, 150.0, 0.0],
            &[300.0, 150.0, 0.0],
        );
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
        let long = Positioning::new(&[0.0, 2000.0], &[0.0, 0.0], &[0.0, 0.0]);
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

    #[test]
    fn bidirectional_hand_computed_tape() {
        // X from −10 to 10 mm, reference at 0, every 10 mm.
        // Forward e = −3.0, 0.0, 4.4 µm; reverse e = 1.0, 5.0, 9.6 µm.
        // The reference return is in the + direction: the + table is zero
        // at the reference, where the forward error 0 stays.
        // + table: correction −e = 3.0, 0, −4.4 → 3, 0, −4; values at
        //   points 0, 1, 2: 0, −3, −4.
        // − table: correction −e = −1.0, −5.0, −9.6; 3627 = −5 (its value at
        //   the reference); relative to it 4, 0, −4.6 → 4, 0, −5; values at
        //   points 3, 4, 5: 0, −4, −5; absolute −1, −5, −10.
        // 3626 = 3 (the − table follows the + table's points 0 … 2).
        let x = Positioning::new(&[-10.0, 0.0, 10.0], &[-3.0, 0.0, 4.4], &[1.0, 5.0, 9.6]);
        let e = export(&[Some(x.clone()), None, None], &FanucOptions::default()).unwrap();
        let t = &e.files[0].text;
        let expected = "%\n\
            ( volcomp: pitch error compensation, correction = -e sign, detection unit 1 um )\n\
            N1851 A1 P0\n\
            N1852 A1 P0\n\
            N3605 A1 P00000001\n\
            N3620 A1 P1\n\
            N3621 A1 P0\n\
            N3622 A1 P2\n\
            N3623 A1 P1\n\
            N3624 A1 P10000\n\
            N3626 A1 P3\n\
            N3627 A1 P-5\n\
            N10000 P0\nN10001 P-3\nN10002 P-4\n\
            N10003 P0\nN10004 P-4\nN10005 P-5\n\
            %\n";
        assert_eq!(t, expected);
        let applied = e.applied.axes[0].as_ref().unwrap();
        assert_eq!(applied.forward_um, vec![-3.0, 0.0, 4.0]);
        assert_eq!(applied.reverse_um, vec![1.0, 5.0, 10.0]);
        assert!((e.rounding.max_um - 0.4).abs() < 1e-9, "{:?}", e.rounding);
        assert_noted(&e.notes, "1851 (and 1852) is written 0");
        // Read back: each direction its own table, as the control applies it.
        let back = parse(t, "pitch.tap", &FanucOptions::default()).unwrap();
        assert_eq!(back, e.applied);
        assert_eq!(back.correction_um(0, 5.0, true), 2.0);
        assert_eq!(back.correction_um(0, 5.0, false), 7.5);
        // Off: the unidirectional tape of the mean, no 3605, 3626, 3627.
        let off = FanucOptions {
            bidirectional: FanucBidirectional::Off,
            ..FanucOptions::default()
        };
        let u = export(&[Some(x.clone()), None, None], &off).unwrap();
        let ut = &u.files[0].text;
        assert!(
            !ut.contains("N3605") && !ut.contains("N3626") && !ut.contains("N3627"),
            "{ut}"
        );
        // Off: the reversal 4, 5, 5.2 µm → B̄ = 4.7333 → 1851 = 5 units,
        // acting on travel in − (reference return in +).
        assert!(ut.contains("N1851 A1 P5\nN1852 A1 P5\n"), "{ut}");
        assert_noted(&u.notes, "1851 (and 1852 for rapid traverse) = 5");
        let back = parse(ut, "pitch.tap", &off).unwrap();
        assert_eq!(back.backlash, u.applied.backlash);
        assert_eq!(back.backlash[0].unwrap().side, BacklashSide::Reverse);
        // Auto: a reversal within the detection unit stays unidirectional.
        let close = Positioning {
            reverse_um: vec![-2.5, 0.5, 4.9],
            ..x.clone()
        };
        let c = export(&[Some(close), None, None], &FanucOptions::default()).unwrap();
        assert!(!c.files[0].text.contains("N3605"), "{}", c.files[0].text);
        // A reversal of 2.5 units: 3627 = round(−2.5) = −3 (halves away
        // from zero); relative to it the − table wants +0.5 everywhere:
        // 1, 0 (the reference holds 3627), 1 → values 0, −1, +1; the
        // control applies −2, −3, −2 units, each 0.5 from −2.5.
        let tie = Positioning::new(&[-10.0, 0.0, 10.0], &[0.0, 0.0, 0.0], &[2.5, 2.5, 2.5]);
        let t = export(&[Some(tie), None, None], &FanucOptions::default()).unwrap();
        assert!(
            t.files[0].text.contains("N3627 A1 P-3\n")
                && t.files[0]
                    .text
                    .contains("N10003 P0\nN10004 P-1\nN10005 P1\n"),
            "{}",
            t.files[0].text
        );
        assert!((t.rounding.max_um - 0.5).abs() < 1e-9, "{:?}", t.rounding);
        // The reference return in the − direction: the − table is zero at
        // the reference (where the reverse error 5 stays), 3627 holds the +
        // table's value there: −(0 − 5) = 5.
        let neg = FanucOptions {
            reference_return: FanucReturn::Negative,
            ..FanucOptions::default()
        };
        let n = export(&[Some(x), None, None], &neg).unwrap();
        assert!(
            n.files[0].text.contains("N3627 A1 P5\n"),
            "{}",
            n.files[0].text
        );
        let back = parse(&n.files[0].text, "pitch.tap", &neg).unwrap();
        let b = back.axes[0].as_ref().unwrap();
        assert_eq!(b.forward_um, vec![-8.0, -5.0, -1.0]);
        assert_eq!(b.reverse_um, vec![-4.0, 0.0, 5.0]);
    }

    #[test]
    fn bidirectional_limits() {
        // Three points per direction need 6 numbers: 0 … 4 is too few.
        let x = Positioning::new(&[-10.0, 0.0, 10.0], &[0.0, 0.0, 0.0], &[5.0, 5.0, 5.0]);
        let small = FanucOptions {
            max_number: 4,
            ..FanucOptions::default()
        };
        let err = export(&[Some(x.clone()), None, None], &small).unwrap_err();
        assert!(
            err.message.contains("3 compensation points per direction"),
            "{err}"
        );
        assert!(err.message.contains("0 … 4"), "{err}");
        let five = FanucOptions {
            max_number: 5,
            ..FanucOptions::default()
        };
        assert!(export(&[Some(x), None, None], &five).is_ok());
        // Read: the − table's points 3626 … 3626 + 3622 − 3621 must exist.
        let tape = |p3626: &str| {
            format!(
                "N1851 A1 P0\nN3605 A1 P00000001\nN3620 A1 P1\nN3621 A1 P0\nN3622 A1 P2\nN3623 A1 P1\nN3624 A1 P10000\n{p3626}N3627 A1 P4\n"
            )
        };
        let o = FanucOptions::default();
        let ok = parse(&tape("N3626 A1 P1021\n"), "t", &o).unwrap();
        assert_eq!(ok.axes[0].as_ref().unwrap().reverse_um, vec![-4.0; 3]);
        let bad = parse(&tape("N3626 A1 P1022\n"), "t", &o).unwrap_err();
        assert!(bad.to_string().contains("1022 … 1024"), "{bad}");
        let missing = parse(&tape(""), "t", &o).unwrap_err();
        assert!(missing.to_string().contains("3626"), "{missing}");
        // A bit parameter is written in binary.
        let bits = parse("N3605 A1 P2\n", "t", &o).unwrap_err();
        assert_eq!(bits.row, 1);
        // Beyond the table on the + side too.
        let over = parse(
            "N1851 A1 P0\nN3620 A1 P1000\nN3621 A1 P1000\nN3622 A1 P1030\nN3623 A1 P1\nN3624 A1 P1000\n",
            "t",
            &o,
        )
        .unwrap_err();
        assert!(over.to_string().contains("3622"), "{over}");
    }

    #[test]
    fn bidirectional_round_trip_within_the_resolution() {
        // Smooth errors with a varying reversal on three axes (Y on the −
        // side, Z across machine 0), both reference return directions.
        let axis = |lo: f64, hi: f64, k: f64| {
            let positions_mm: Vec<f64> = (0..=((hi - lo) / 5.0) as usize)
                .map(|i| lo + 5.0 * i as f64)
                .collect();
            Positioning {
                forward_um: positions_mm
                    .iter()
                    .map(|x| k * (x * 0.031).sin() * 20.0 + 0.05 * x)
                    .collect(),
                reverse_um: positions_mm
                    .iter()
                    .map(|x| k * (x * 0.031).sin() * 20.0 + 0.05 * x + 6.0 + 3.0 * (x * 0.02).cos())
                    .collect(),
                positions_mm,
            }
        };
        let p = [
            Some(axis(0.0, 300.0, 1.0)),
            Some(axis(-200.0, 0.0, -0.7)),
            Some(axis(-150.0, 100.0, 0.4)),
        ];
        for (ret, sign) in [
            (FanucReturn::Positive, FanucSign::Correction),
            (FanucReturn::Negative, FanucSign::Error),
        ] {
            let o = FanucOptions {
                reference_return: ret,
                sign,
                ..FanucOptions::default()
            };
            let e = export(&p, &o).unwrap();
            let back = parse(&e.files[0].text, "pitch.tap", &o).unwrap();
            for (a, orig) in p.iter().enumerate() {
                let orig = orig.as_ref().unwrap();
                let at =
                    |v: &[f64], x: f64| super::super::interpolate_held(&orig.positions_mm, v, x);
                let e_ref = match ret {
                    FanucReturn::Positive => at(&orig.forward_um, 0.0),
                    FanucReturn::Negative => at(&orig.reverse_um, 0.0),
                };
                let b = back.axes[a].as_ref().unwrap();
                for (i, &x) in b.positions_mm.iter().enumerate() {
                    for (v, w) in [
                        (&b.forward_um, &orig.forward_um),
                        (&b.reverse_um, &orig.reverse_um),
                    ] {
                        let d = v[i] + e_ref - at(w, x);
                        assert!(d.abs() <= 0.5 + 1e-9, "axis {a} at {x}: {d} ({ret:?})");
                    }
                }
                // The applied correction of the export is the tape read back.
                let ap = e.applied.axes[a].as_ref().unwrap();
                for i in 0..ap.positions_mm.len() {
                    assert!((ap.forward_um[i] - b.forward_um[i]).abs() < 1e-9);
                    assert!((ap.reverse_um[i] - b.reverse_um[i]).abs() < 1e-9);
                }
            }
            assert!(e.rounding.max_um <= 0.5 + 1e-9, "{:?}", e.rounding);
            assert!(e.files[0]
                .text
                .contains("N3605 A1 P00000001 A2 P00000001 A3 P00000001\n"));
        }
    }
}
