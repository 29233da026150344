//! Accuracy and repeatability of positioning of one numerically controlled
//! axis, evaluated as ISO 230-2:2014 defines it (clause 3, evaluation of a
//! bidirectional test: `m` target positions `P_i`, each approached `n` times
//! in the positive (↑) and the negative (↓) direction).
//!
//! Input: a CSV, one row per measurement, any column order, `#` comments:
//!
//! ```text
//! target_mm,cycle,direction,deviation_um
//! 0,1,up,0.8
//! 0,1,down,3.1
//! ```
//!
//! * `target_mm`: the target position `P_i`;
//! * `cycle`: the run number `j` (1 … n), used only to find duplicates;
//! * `direction`: `up`, `+`, `forward` (approach in the positive direction)
//!   or `down`, `-`, `reverse`;
//! * `deviation_um`: the positional deviation `x_ij = P_ij − P_i` (actual
//!   minus target, volcomp's sign) — or instead a column `actual_mm` with the
//!   measured position `P_ij`.
//!
//! Figures (per target `i`, then of the axis):
//!
//! ```text
//! x̄_i↑ = (1/n) Σ_j x_ij↑                     mean unidirectional deviation
//! s_i↑ = sqrt( Σ_j (x_ij↑ − x̄_i↑)² / (n − 1) ) estimator of the standard uncertainty
//! B_i  = x̄_i↑ − x̄_i↓                          reversal value
//! x̄_i  = (x̄_i↑ + x̄_i↓) / 2                   mean bidirectional deviation
//! R_i↑ = 4 s_i↑,  R_i↓ = 4 s_i↓                unidirectional repeatability
//! R_i  = max(2 s_i↑ + 2 s_i↓ + |B_i|, R_i↑, R_i↓)  bidirectional repeatability
//! B  = max |B_i|,  B̄ = (1/m) Σ B_i            reversal value, mean reversal value
//! R↑ = max R_i↑,  R↓ = max R_i↓,  R = max R_i
//! E↑ = max x̄_i↑ − min x̄_i↑ (E↓ likewise)     unidirectional systematic deviation
//! E  = max(x̄_i↑, x̄_i↓) − min(x̄_i↑, x̄_i↓)   bidirectional systematic deviation
//! M  = max x̄_i − min x̄_i                     range of the mean bidirectional deviation
//! A↑ = max(x̄_i↑ + 2 s_i↑) − min(x̄_i↑ − 2 s_i↑)   unidirectional accuracy (A↓ likewise)
//! A  = max(x̄_i↑ + 2 s_i↑, x̄_i↓ + 2 s_i↓) − min(x̄_i↑ − 2 s_i↑, x̄_i↓ − 2 s_i↓)
//! ```
//!
//! The standard asks for at least five target positions per metre (and at
//! least five in all) and five approaches per direction; fewer are evaluated
//! all the same and reported in [`Iso230_2Report::notes`].

use crate::error::MapFileError;
use crate::io::table::{CsvTable, Header};
use std::collections::BTreeMap;

/// Statistics at one target position (µm).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TargetStats {
    /// `P_i` (mm).
    pub target_mm: f64,
    /// Approaches ↑ and ↓.
    pub n_up: usize,
    /// Approaches ↓.
    pub n_down: usize,
    /// `x̄_i↑`.
    pub mean_up_um: f64,
    /// `x̄_i↓`.
    pub mean_down_um: f64,
    /// `s_i↑`.
    pub s_up_um: f64,
    /// `s_i↓`.
    pub s_down_um: f64,
    /// `B_i`.
    pub reversal_um: f64,
    /// `x̄_i`.
    pub mean_um: f64,
    /// `R_i↑`.
    pub repeatability_up_um: f64,
    /// `R_i↓`.
    pub repeatability_down_um: f64,
    /// `R_i`.
    pub repeatability_um: f64,
}

/// The axis figures (µm).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AxisFigures {
    /// `B`: reversal value of the axis, `max |B_i|`.
    pub reversal_b_um: f64,
    /// `B̄`: mean reversal value, `(1/m) Σ B_i`.
    pub mean_reversal_um: f64,
    /// `R↑`.
    pub repeatability_up_um: f64,
    /// `R↓`.
    pub repeatability_down_um: f64,
    /// `R`.
    pub repeatability_um: f64,
    /// `E↑`.
    pub systematic_up_um: f64,
    /// `E↓`.
    pub systematic_down_um: f64,
    /// `E`.
    pub systematic_um: f64,
    /// `M`.
    pub mean_range_um: f64,
    /// `A↑`.
    pub accuracy_up_um: f64,
    /// `A↓`.
    pub accuracy_down_um: f64,
    /// `A`.
    pub accuracy_um: f64,
}

/// The evaluation of one test.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Iso230_2Report {
    /// Per target, in increasing position.
    pub targets: Vec<TargetStats>,
    /// Axis figures.
    pub axis: AxisFigures,
    /// Where the test falls short of the standard's minimum extent.
    pub notes: Vec<String>,
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn stdev(v: &[f64], m: f64) -> f64 {
    (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
}

fn max(it: impl Iterator<Item = f64>) -> f64 {
    it.fold(f64::NEG_INFINITY, f64::max)
}

fn min(it: impl Iterator<Item = f64>) -> f64 {
    it.fold(f64::INFINITY, f64::min)
}

/// A test too small to evaluate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TooFewApproaches {
    /// Fewer than two target positions.
    #[error("{targets} target position(s); the test needs at least two (the standard asks for five or more)")]
    Targets {
        /// Target positions in the test.
        targets: usize,
    },
    /// A target with fewer than two approaches in a direction.
    #[error("target {target_mm} mm has {up} approach(es) up and {down} down; each direction needs at least two (the standard asks for five)")]
    Approaches {
        /// The target (mm).
        target_mm: f64,
        /// Approaches from below.
        up: usize,
        /// Approaches from above.
        down: usize,
    },
}

/// The approaches of each target from a matrix of deviations (µm, `rows`
/// targets by `cols` runs, flattened by rows; NaN: no approach in that
/// run); `what` names the matrix in errors.
pub fn approaches(
    values: &[f64],
    (rows, cols): (usize, usize),
    what: &str,
) -> Result<Vec<Vec<f64>>, String> {
    (0..rows).map(|i| {
        let row = &values[i * cols..(i + 1) * cols];
        let present = row.iter().enumerate().filter(|(_, x)| !x.is_nan());
        present
            .map(|(j, x)| match x.is_finite() {
                true => Ok(*x),
                false => Err(format!(
                    "{what}[{i}, {j}] is {x}; give finite deviations in µm (NaN for a missing approach)"
                )),
            })
            .collect()
    })
    .collect()
}

/// Evaluates deviations grouped per target: `(P_i, x_ij↑, x_ij↓)` in mm and µm.
/// Each target needs at least two approaches per direction; at least two targets.
pub fn evaluate(data: &[(f64, Vec<f64>, Vec<f64>)]) -> Result<Iso230_2Report, TooFewApproaches> {
    if data.len() < 2 {
        return Err(TooFewApproaches::Targets {
            targets: data.len(),
        });
    }
    let mut targets = Vec::with_capacity(data.len());
    for (p, up, down) in data {
        if up.len() < 2 || down.len() < 2 {
            return Err(TooFewApproaches::Approaches {
                target_mm: *p,
                up: up.len(),
                down: down.len(),
            });
        }
        let (mu, md) = (mean(up), mean(down));
        let (su, sd) = (stdev(up, mu), stdev(down, md));
        let b = mu - md;
        let (ru, rd) = (4.0 * su, 4.0 * sd);
        targets.push(TargetStats {
            target_mm: *p,
            n_up: up.len(),
            n_down: down.len(),
            mean_up_um: mu,
            mean_down_um: md,
            s_up_um: su,
            s_down_um: sd,
            reversal_um: b,
            mean_um: 0.5 * (mu + md),
            repeatability_up_um: ru,
            repeatability_down_um: rd,
            repeatability_um: (2.0 * su + 2.0 * sd + b.abs()).max(ru).max(rd),
        });
    }
    targets.sort_by(|a, b| a.target_mm.total_cmp(&b.target_mm));
    let t = &targets;
    let both = || t.iter().flat_map(|s| [s.mean_up_um, s.mean_down_um]);
    let axis = AxisFigures {
        reversal_b_um: max(t.iter().map(|s| s.reversal_um.abs())),
        mean_reversal_um: mean(&t.iter().map(|s| s.reversal_um).collect::<Vec<_>>()),
        repeatability_up_um: max(t.iter().map(|s| s.repeatability_up_um)),
        repeatability_down_um: max(t.iter().map(|s| s.repeatability_down_um)),
        repeatability_um: max(t.iter().map(|s| s.repeatability_um)),
        systematic_up_um: max(t.iter().map(|s| s.mean_up_um)) - min(t.iter().map(|s| s.mean_up_um)),
        systematic_down_um: max(t.iter().map(|s| s.mean_down_um))
            - min(t.iter().map(|s| s.mean_down_um)),
        systematic_um: max(both()) - min(both()),
        mean_range_um: max(t.iter().map(|s| s.mean_um)) - min(t.iter().map(|s| s.mean_um)),
        accuracy_up_um: max(t.iter().map(|s| s.mean_up_um + 2.0 * s.s_up_um))
            - min(t.iter().map(|s| s.mean_up_um - 2.0 * s.s_up_um)),
        accuracy_down_um: max(t.iter().map(|s| s.mean_down_um + 2.0 * s.s_down_um))
            - min(t.iter().map(|s| s.mean_down_um - 2.0 * s.s_down_um)),
        accuracy_um: max(t.iter().flat_map(|s| {
            [
                s.mean_up_um + 2.0 * s.s_up_um,
                s.mean_down_um + 2.0 * s.s_down_um,
            ]
        })) - min(t.iter().flat_map(|s| {
            [
                s.mean_up_um - 2.0 * s.s_up_um,
                s.mean_down_um - 2.0 * s.s_down_um,
            ]
        })),
    };
    let mut notes = Vec::new();
    let n_min = t.iter().map(|s| s.n_up.min(s.n_down)).min().unwrap_or(0);
    if n_min < 5 {
        notes.push(format!(
            "some targets were approached only {n_min} times in a direction; ISO 230-2 asks for five"
        ));
    }
    let span = t.last().map(|s| s.target_mm).unwrap_or(0.0) - t[0].target_mm;
    let wanted = ((span / 1000.0 * 5.0).ceil() as usize).max(5);
    if t.len() < wanted {
        notes.push(format!(
            "{} target positions over {span} mm; ISO 230-2 asks for at least five per metre and five in all ({wanted})",
            t.len()
        ));
    }
    Ok(Iso230_2Report {
        targets,
        axis,
        notes,
    })
}

/// Reads a test CSV (layout in the module documentation) and evaluates it.
pub fn from_csv(text: &str, file: &str) -> Result<Iso230_2Report, MapFileError> {
    let layout = "target_mm, cycle, direction and deviation_um (or actual_mm), in any order";
    let t = CsvTable::parse(text, file, &Header::keep_all(layout))?;
    let help = format!("the header names {layout}");
    for (c, name) in t.header.iter().enumerate() {
        match name.as_str() {
            "target_mm" | "cycle" | "run" | "direction" | "deviation_um" | "actual_mm" => {}
            "target" | "deviation" | "actual" | "position" => {
                return Err(t.error_at(
                    t.header_line,
                    c,
                    format!("column `{name}` has no unit"),
                    "write target_mm, deviation_um (µm) or actual_mm (mm)",
                ))
            }
            _ => {
                return Err(t.error_at(
                    t.header_line,
                    c,
                    format!("unknown column `{}`", crate::io::table::shown(name)),
                    help,
                ))
            }
        }
    }
    let twice = |a: &str, b: &str| -> Result<(), MapFileError> {
        if let (Some(_), Some(cb)) = (t.column(a), t.column(b)) {
            return Err(t.error_at(
                t.header_line,
                cb,
                format!("columns `{a}` and `{b}` give the same quantity"),
                "give one of them",
            ));
        }
        Ok(())
    };
    twice("cycle", "run")?;
    twice("deviation_um", "actual_mm")?;
    let actual = t.column("actual_mm").is_some();
    let cols = [
        t.require("target_mm")?,
        t.column_of(&["cycle", "run"])
            .ok_or_else(|| t.missing("cycle", "the run number"))?,
        t.require("direction")?,
        t.column_of(&["deviation_um", "actual_mm"])
            .ok_or_else(|| t.missing("deviation_um", "or actual_mm"))?,
    ];
    let mut groups: BTreeMap<u64, (f64, Vec<f64>, Vec<f64>)> = BTreeMap::new();
    let mut seen: BTreeMap<(u64, i64, bool), usize> = BTreeMap::new();
    for r in t.records()? {
        let target = t.number(r, cols[0])?;
        let cycle: i64 = t.integer(r, cols[1]).map_err(|mut e| {
            e.help = "number the approaches 1, 2, 3 …".into();
            e
        })?;
        let dir_text = t.text(r, cols[2]);
        let up = match dir_text.to_ascii_lowercase().as_str() {
            "up" | "+" | "forward" | "fwd" | "↑" => true,
            "down" | "-" | "reverse" | "rev" | "↓" => false,
            _ => {
                return Err(t.error(
                    r,
                    cols[2],
                    format!("unknown direction `{}`", crate::io::table::shown(dir_text)),
                    "write up (approach in the positive direction) or down",
                ))
            }
        };
        let value = t.number(r, cols[3])?;
        let deviation_um = if actual {
            (value - target) * 1e3
        } else {
            value
        };
        let key = target.to_bits();
        if let Some(first) = seen.insert((key, cycle, up), r.line) {
            return Err(t.error(r, cols[1], format!("target {target} mm, cycle {cycle}, direction {dir_text} was already given on row {first}"), "give each approach once"));
        }
        let g = groups
            .entry(key)
            .or_insert((target, Vec::new(), Vec::new()));
        if up {
            g.1.push(deviation_um);
        } else {
            g.2.push(deviation_um);
        }
    }
    let data: Vec<(f64, Vec<f64>, Vec<f64>)> = groups.into_values().collect();
    evaluate(&data).map_err(|m| {
        MapFileError::new(
            file,
            t.last_line(),
            1,
            m.to_string(),
            "ISO 230-2 approaches every target several times from both sides",
        )
    })
}

impl Iso230_2Report {
    /// The mean unidirectional deviations as a positioning table:
    /// `(P_i, x̄_i↑, x̄_i↓)`, i.e. `E_aa` forward and reverse at the targets.
    pub fn positioning(&self) -> crate::io::linuxcnc_comp::Positioning {
        crate::io::linuxcnc_comp::Positioning {
            positions_mm: self.targets.iter().map(|t| t.target_mm).collect(),
            forward_um: self.targets.iter().map(|t| t.mean_up_um).collect(),
            reverse_um: self.targets.iter().map(|t| t.mean_down_um).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three targets, three approaches per direction (deviations in µm):
    ///
    /// ```text
    /// P = 0:    ↑ 1, 2, 3    x̄↑ = 2,  s↑ = √((1+0+1)/2) = 1
    ///           ↓ 4, 5, 6    x̄↓ = 5,  s↓ = 1
    ///           B = 2 − 5 = −3,  x̄ = 3.5,  R↑ = 4, R↓ = 4,
    ///           R = max(2+2+3, 4, 4) = 7
    /// P = 100:  ↑ 0, 2, 4    x̄↑ = 2,  s↑ = √((4+0+4)/2) = 2
    ///           ↓ 2, 3, 4    x̄↓ = 3,  s↓ = 1
    ///           B = −1,  x̄ = 2.5,  R↑ = 8, R↓ = 4, R = max(4+2+1, 8, 4) = 8
    /// P = 200:  ↑ −2, −1, 0  x̄↑ = −1, s↑ = 1
    ///           ↓ 1, 1, 1    x̄↓ = 1,  s↓ = 0
    ///           B = −2,  x̄ = 0,  R↑ = 4, R↓ = 0, R = max(2+0+2, 4, 0) = 4
    ///
    /// B  = max(3, 1, 2) = 3;   B̄ = (−3 − 1 − 2)/3 = −2
    /// R↑ = 8, R↓ = 4, R = 8
    /// E↑ = 2 − (−1) = 3;  E↓ = 5 − 1 = 4;  E = 5 − (−1) = 6
    /// M  = 3.5 − 0 = 3.5
    /// A↑ = max(2+2, 2+4, −1+2) − min(2−2, 2−4, −1−2) = 6 − (−3) = 9
    /// A↓ = max(5+2, 3+2, 1+0) − min(5−2, 3−2, 1−0)   = 7 − 1 = 6
    /// A  = max(6, 7) − min(−3, 1) = 10
    /// ```
    const RUNS: &str = "# hand example\ncycle,target_mm,direction,deviation_um\n\
        1,0,up,1\n2,0,up,2\n3,0,up,3\n1,0,down,4\n2,0,down,5\n3,0,down,6\n\
        1,100,+,0\n2,100,+,2\n3,100,+,4\n1,100,-,2\n2,100,-,3\n3,100,-,4\n\
        1,200,up,-2\n2,200,up,-1\n3,200,up,0\n1,200,down,1\n2,200,down,1\n3,200,down,1\n";

    fn check(r: &Iso230_2Report) {
        let a = r.axis;
        let eq = |x: f64, y: f64| (x - y).abs() < 1e-12;
        assert!(eq(a.reversal_b_um, 3.0), "{a:?}");
        assert!(eq(a.mean_reversal_um, -2.0), "{a:?}");
        assert!(eq(a.repeatability_up_um, 8.0));
        assert!(eq(a.repeatability_down_um, 4.0));
        assert!(eq(a.repeatability_um, 8.0));
        assert!(eq(a.systematic_up_um, 3.0));
        assert!(eq(a.systematic_down_um, 4.0));
        assert!(eq(a.systematic_um, 6.0));
        assert!(eq(a.mean_range_um, 3.5));
        assert!(eq(a.accuracy_up_um, 9.0));
        assert!(eq(a.accuracy_down_um, 6.0));
        assert!(eq(a.accuracy_um, 10.0));
        let t0 = r.targets[0];
        assert!(eq(t0.reversal_um, -3.0) && eq(t0.repeatability_um, 7.0) && eq(t0.mean_um, 3.5));
        let t2 = r.targets[2];
        assert!(eq(t2.s_down_um, 0.0) && eq(t2.repeatability_um, 4.0));
    }

    #[test]
    fn hand_computed_example() {
        let r = from_csv(RUNS, "runs.csv").unwrap();
        check(&r);
        assert_eq!(r.notes.len(), 2, "{:?}", r.notes);
        let p = r.positioning();
        assert_eq!(p.positions_mm, vec![0.0, 100.0, 200.0]);
        assert_eq!(p.forward_um, vec![2.0, 2.0, -1.0]);
        assert_eq!(p.reverse_um, vec![5.0, 3.0, 1.0]);
    }

    #[test]
    fn actual_positions_give_the_same_figures() {
        // actual = target + deviation/1000 mm.
        let mut csv = String::from("target_mm,cycle,direction,actual_mm\n");
        for line in RUNS.lines().skip(2) {
            let f: Vec<&str> = line.split(',').collect();
            let target: f64 = f[1].parse().unwrap();
            let dev: f64 = f[3].parse().unwrap();
            csv.push_str(&format!(
                "{},{},{},{}\n",
                f[1],
                f[0],
                f[2],
                target + dev * 1e-3
            ));
        }
        let r = from_csv(&csv, "runs.csv").unwrap();
        let a = r.axis;
        // Positions of 200 mm carry 1e-13 mm of rounding: compare to 1e-9 µm.
        assert!((a.accuracy_um - 10.0).abs() < 1e-9 && (a.mean_reversal_um + 2.0).abs() < 1e-9);
    }

    #[test]
    fn bad_files_name_row_and_column() {
        let e = from_csv(&RUNS.replace("2,100,+,2", "2,100,+,nan"), "r.csv").unwrap_err();
        assert_eq!((e.row, e.column), (10, 4), "{e}");
        let e = from_csv(&RUNS.replace("deviation_um", "deviation"), "r.csv").unwrap_err();
        assert_eq!((e.row, e.column), (2, 4), "{e}");
        assert!(e.message.contains("no unit"));
        let e = from_csv(&RUNS.replace("2,100,+,2", "1,100,+,2"), "r.csv").unwrap_err();
        assert_eq!((e.row, e.column), (10, 1), "{e}");
        assert!(e.message.contains("already"));
        let one_run: String = RUNS
            .lines()
            .filter(|l| !l.starts_with("2,") && !l.starts_with("3,"))
            .map(|l| format!("{l}\n"))
            .collect();
        let e = from_csv(&one_run, "r.csv").unwrap_err();
        assert!(e.message.contains("at least two"), "{e}");
        let e = from_csv(&RUNS.replace(",up,", ",sideways,"), "r.csv").unwrap_err();
        assert_eq!((e.row, e.column), (3, 3), "{e}");
    }
}
