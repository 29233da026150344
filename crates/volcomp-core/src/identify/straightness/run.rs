//! One measured run: a straightness profile in Z along X or Y at one feed
//! rate, read from CSV.
//!
//! ```text
//! # volcomp straightness run
//! # axis = X
//! # feed_mm_per_min = 4800
//! position_mm,displacement_um
//! 0.0,0.013
//! 0.2,0.021
//! ...
//! ```
//!
//! * `position_mm`: the moving axis' position, strictly increasing and evenly
//!   spaced (every step within 2 % of the median step; samples are taken to
//!   lie on the even grid `x_0 + i·Δx`, `Δx` = span / (N − 1)).
//! * `displacement_um`: the Z deviation `e_z = actual − commanded` of the
//!   tool relative to the workpiece (docs/design.md, "Deviation sign"), in µm.
//! * The feed rate as a header comment `# feed_mm_per_min = F` (`:` works as
//!   well as `=`) or as a column `feed_mm_per_min` with one value in every
//!   row. The axis as `# axis = X` (or `Y`), or given for all files by the
//!   caller.
//!
//! Other `#` lines are comments. Every bad value is reported with file,
//! row and column.

use super::{Axis, StraightnessError};
use crate::error::MapFileError;
use crate::io::table::{comment_lines, shown, CsvTable, Header, UnknownColumns};

/// Fewest samples a run may have.
pub const MIN_SAMPLES: usize = 16;

/// Largest deviation of one position step from the mean step, as a fraction
/// of the mean step.
pub const SPACING_TOLERANCE: f64 = 0.02;

/// One measured straightness run.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// File name (for messages).
    pub file: String,
    /// The moving axis, if the file says.
    pub axis: Option<Axis>,
    /// Feed rate of the run (mm/min).
    pub feed_mm_per_min: f64,
    /// Positions of the moving axis (mm), strictly increasing, evenly spaced.
    pub positions_mm: Vec<f64>,
    /// Z deviation at each position (µm).
    pub displacement_um: Vec<f64>,
}

impl Run {
    /// First position (mm).
    pub fn start_mm(&self) -> f64 {
        self.positions_mm.first().copied().unwrap_or(0.0)
    }

    /// Last position (mm).
    pub fn end_mm(&self) -> f64 {
        self.positions_mm.last().copied().unwrap_or(0.0)
    }

    /// Mean step `Δx` (mm).
    pub fn spacing_mm(&self) -> f64 {
        let n = self.positions_mm.len();
        if n < 2 {
            0.0
        } else {
            (self.end_mm() - self.start_mm()) / (n - 1) as f64
        }
    }

    /// Negates the displacement: for files whose sign is the opposite of
    /// the deviation `actual − commanded` (e.g. workpiece relative to tool).
    pub fn negate(&mut self) {
        self.displacement_um.iter_mut().for_each(|v| *v = -*v);
    }

    /// A run from arrays (positions in mm, Z deviations in µm), checked as
    /// [`Run::from_csv`] checks a file: equal lengths, finite values, a
    /// positive feed rate, at least [`MIN_SAMPLES`] samples, strictly
    /// increasing and evenly spaced positions; `name` names it in errors.
    ///
    /// ```
    /// use volcomp_core::identify::straightness::run::Run;
    /// let x: Vec<f64> = (0..20).map(|i| i as f64 * 0.5).collect();
    /// let z = vec![0.0; 20];
    /// assert!(Run::from_arrays("r", None, 4800.0, x.clone(), z.clone()).is_ok());
    /// let mut uneven = x.clone();
    /// uneven[5] += 0.1;
    /// let e = Run::from_arrays("r", None, 4800.0, uneven, z).unwrap_err();
    /// assert!(e.to_string().contains("sample 5"));
    /// ```
    pub fn from_arrays(
        name: &str,
        axis: Option<Axis>,
        feed_mm_per_min: f64,
        positions_mm: Vec<f64>,
        displacement_um: Vec<f64>,
    ) -> Result<Run, StraightnessError> {
        let fail = |message: String, help: &str| {
            Err(StraightnessError::Runs {
                message: format!("{name}: {message}"),
                help: help.to_string(),
            })
        };
        if !(feed_mm_per_min.is_finite() && feed_mm_per_min > 0.0) {
            return fail(
                format!("feed rate {feed_mm_per_min} is not positive"),
                "give the feed rate of the run in mm/min",
            );
        }
        if positions_mm.len() != displacement_um.len() {
            return fail(
                format!(
                    "{} positions but {} displacements",
                    positions_mm.len(),
                    displacement_um.len()
                ),
                "give one displacement (µm) per position (mm)",
            );
        }
        let n = positions_mm.len();
        if n < MIN_SAMPLES {
            return fail(
                format!("{n} samples; a run needs at least {MIN_SAMPLES}"),
                "sample the profile densely: several samples per shortest wavelength of interest",
            );
        }
        for (i, (x, z)) in positions_mm.iter().zip(&displacement_um).enumerate() {
            if !x.is_finite() || !z.is_finite() {
                return fail(
                    format!("sample {i} is not finite (position {x}, displacement {z})"),
                    "remove or fill the missing samples before fitting",
                );
            }
            if i > 0 && *x <= positions_mm[i - 1] {
                return fail(
                    format!(
                        "sample {i}: position {x} mm does not increase (sample {}: {} mm)",
                        i - 1,
                        positions_mm[i - 1]
                    ),
                    "sort the samples by position and remove repeated positions",
                );
            }
        }
        if let Some((i, d, step)) = unequal_step(&positions_mm) {
            return fail(
                format!("unequal sampling: step {d:.6} mm from sample {} to sample {i}, the run's typical step is {step:.6} mm", i - 1),
                "the spectrum needs evenly spaced samples: resample the run onto an even grid (or fill the missing samples) before fitting",
            );
        }
        Ok(Run {
            file: name.to_string(),
            axis,
            feed_mm_per_min,
            positions_mm,
            displacement_um,
        })
    }

    /// Parses the CSV text of a run; `file` names it in errors.
    ///
    /// ```
    /// use volcomp_core::identify::straightness::run::Run;
    /// use volcomp_core::identify::straightness::Axis;
    /// let mut csv = String::from("# axis = Y\n# feed_mm_per_min: 6000\nposition_mm,displacement_um\n");
    /// for i in 0..20 { csv.push_str(&format!("{},{}\n", i as f64 * 0.5, 0.1 * i as f64)); }
    /// let run = Run::from_csv(&csv, "r.csv").unwrap();
    /// assert_eq!(run.axis, Some(Axis::Y));
    /// assert_eq!(run.feed_mm_per_min, 6000.0);
    /// assert_eq!(run.positions_mm.len(), 20);
    /// ```
    pub fn from_csv(text: &str, file: &str) -> Result<Run, StraightnessError> {
        let err = |row: usize, column: usize, message: String, help: &str| {
            StraightnessError::from(MapFileError::new(file, row, column, message, help))
        };
        let mut axis: Option<(Axis, usize)> = None;
        let mut feed_comment: Option<(f64, usize)> = None;
        for (row, comment) in &comment_lines(text) {
            let row = *row;
            let Some((key, value)) = comment.split_once(['=', ':']) else {
                continue;
            };
            let (key, value) = (key.trim().to_ascii_lowercase(), value.trim());
            // A header comment's error: at its row, first column.
            let refused = |message: String, help: &str| err(row, 1, message, help);
            match key.as_str() {
                "axis" => {
                    let a = Axis::parse(value).ok_or_else(|| {
                        let help = "write `# axis = X` or `# axis = Y`: the axis whose motion the run follows";
                        refused(format!("unknown axis `{}`", shown(value)), help)
                    })?;
                    axis = Some((a, row));
                }
                "feed_mm_per_min" => {
                    let f = parse_feed(value).ok_or_else(|| {
                        let help = "write the feed rate in mm/min, like `# feed_mm_per_min = 4800`";
                        refused(
                            format!("feed rate `{}` is not a positive number", shown(value)),
                            help,
                        )
                    })?;
                    feed_comment = Some((f, row));
                }
                k if k.starts_with("feed") => {
                    let help = "write the feed rate in mm/min as `# feed_mm_per_min = 4800`";
                    return Err(refused(
                        format!("feed rate key `{}` has no known unit", shown(k)),
                        help,
                    ));
                }
                _ => {}
            }
        }
        let t = CsvTable::parse(
            text,
            file,
            &Header {
                known: &["position_mm", "displacement_um", "feed_mm_per_min"],
                unknown: UnknownColumns::Refuse,
                layout: "position_mm,displacement_um and optionally feed_mm_per_min (positions in mm, Z deviation in µm, feed in mm/min)",
            },
        )?;
        let pc = t.require("position_mm")?;
        let dc = t.require("displacement_um")?;
        let fc = t.column("feed_mm_per_min");
        let mut positions = Vec::new();
        let mut values = Vec::new();
        let mut rows = Vec::new();
        let mut feed_column: Option<(f64, usize)> = None;
        for r in t.records()? {
            let row = r.line;
            let x = t.number(r, pc)?;
            let z = t.number(r, dc)?;
            if let Some(fc) = fc {
                let f = t.number(r, fc)?;
                if f <= 0.0 {
                    return Err(t
                        .error(
                            r,
                            fc,
                            format!("feed rate {f} is not positive"),
                            "give the feed rate of the run in mm/min",
                        )
                        .into());
                }
                match feed_column {
                    None => feed_column = Some((f, row)),
                    Some((f0, r0)) if !same_feed(f0, f) => {
                        return Err(t.error(
                            r,
                            fc,
                            format!("feed rate {f} differs from {f0} on row {r0}"),
                            "a run is one pass at one feed rate: split passes at different feeds into separate files",
                        ).into())
                    }
                    _ => {}
                }
            }
            if let Some(&last) = positions.last() {
                if x <= last {
                    return Err(t
                        .error(
                            r,
                            pc,
                            format!(
                                "position {x} mm does not increase (previous row {}: {last} mm)",
                                rows.last().copied().unwrap_or(0)
                            ),
                            "sort the samples by position and remove repeated positions",
                        )
                        .into());
                }
            }
            positions.push(x);
            values.push(z);
            rows.push(row);
        }
        if positions.len() < MIN_SAMPLES {
            return Err(err(
                rows.last().copied().unwrap_or(1),
                1,
                format!(
                    "{} samples; a run needs at least {MIN_SAMPLES}",
                    positions.len()
                ),
                "sample the profile densely: several samples per shortest wavelength of interest",
            ));
        }
        let feed = match (feed_comment, feed_column) {
            (Some((a, ra)), Some((b, rb))) if !same_feed(a, b) => {
                return Err(err(
                    rb,
                    1,
                    format!("feed rate column says {b} mm/min, the header comment on row {ra} says {a}"),
                    "give the feed rate once, or make both agree",
                ))
            }
            (Some((f, _)), _) | (None, Some((f, _))) => f,
            (None, None) => {
                return Err(err(
                    1,
                    1,
                    "the run has no feed rate".into(),
                    "add a header comment `# feed_mm_per_min = 4800` or a column feed_mm_per_min: the method compares runs at different feed rates",
                ))
            }
        };
        // Even spacing.
        if let Some((i, d, step)) = unequal_step(&positions) {
            return Err(err(
                rows[i],
                pc + 1,
                format!(
                    "unequal sampling: step {d:.6} mm from row {} to here, the run's typical step is {step:.6} mm",
                    rows[i - 1]
                ),
                "the spectrum needs evenly spaced samples: resample the run onto an even grid (or fill the missing samples) before fitting",
            ));
        }
        Ok(Run {
            file: file.to_string(),
            axis: axis.map(|(a, _)| a),
            feed_mm_per_min: feed,
            positions_mm: positions,
            displacement_um: values,
        })
    }
}

/// The first step of `positions_mm` (increasing, at least two) off the
/// median step by more than [`SPACING_TOLERANCE`]: `(i, step from sample
/// i − 1 to i, median step)`. Each step is held against the median (a
/// missing sample must not shift the reference).
fn unequal_step(positions_mm: &[f64]) -> Option<(usize, f64, f64)> {
    let mut steps: Vec<f64> = positions_mm.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let step = steps[steps.len() / 2];
    (1..positions_mm.len())
        .map(|i| (i, positions_mm[i] - positions_mm[i - 1], step))
        .find(|&(_, d, step)| (d - step).abs() > SPACING_TOLERANCE * step)
}

fn parse_feed(text: &str) -> Option<f64> {
    text.parse::<f64>()
        .ok()
        .filter(|f| f.is_finite() && *f > 0.0)
}

/// Two feed rates are the same when they agree to 1 ppm.
pub(crate) fn same_feed(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * a.abs().max(b.abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn csv(head: &str, rows: impl Iterator<Item = String>) -> String {
        let mut s = head.to_string();
        for r in rows {
            s.push_str(&r);
            s.push('\n');
        }
        s
    }

    fn good_rows(n: usize) -> impl Iterator<Item = String> {
        (0..n).map(|i| format!("{},{}", i as f64 * 0.25, (i as f64 * 0.3).sin()))
    }

    fn error_of(text: &str) -> MapFileError {
        match Run::from_csv(text, "run.csv") {
            Err(StraightnessError::File(e)) => e,
            other => panic!("expected a located error, got {other:?}"),
        }
    }

    #[test]
    fn reads_comment_feed_and_axis() {
        let text = csv(
            "# volcomp straightness run\n# Axis: x\n# feed_mm_per_min = 7200\nposition_mm, displacement_um\n",
            good_rows(20),
        );
        let r = Run::from_csv(&text, "run.csv").unwrap();
        assert_eq!(r.axis, Some(Axis::X));
        assert_eq!(r.feed_mm_per_min, 7200.0);
        assert_eq!(r.positions_mm.len(), 20);
        assert!((r.spacing_mm() - 0.25).abs() < 1e-12);
    }

    #[test]
    fn reads_feed_column_in_any_order() {
        let rows = (0..20).map(|i| format!("{},9600,{}", 0.1 * i as f64, i as f64));
        let r = Run::from_csv(
            &csv("displacement_um,feed_mm_per_min,position_mm\n", rows),
            "r.csv",
        )
        .unwrap();
        assert_eq!(r.feed_mm_per_min, 9600.0);
        assert_eq!(r.positions_mm[3], 3.0);
        assert!((r.displacement_um[3] - 0.3).abs() < 1e-12);
        assert_eq!(r.axis, None);
    }

    #[test]
    fn nan_is_located() {
        let mut rows: Vec<String> = good_rows(20).collect();
        rows[5] = "1.25,NaN".into();
        let e = error_of(&csv(
            "# feed_mm_per_min = 4800\nposition_mm,displacement_um\n",
            rows.into_iter(),
        ));
        assert_eq!((e.row, e.column), (8, 2));
        assert!(e.message.contains("NaN"), "{e}");
    }

    #[test]
    fn unequal_sampling_is_located() {
        let mut rows: Vec<String> = good_rows(20).collect();
        rows.remove(10); // a missing sample doubles one step
        let e = error_of(&csv(
            "# feed_mm_per_min = 4800\nposition_mm,displacement_um\n",
            rows.into_iter(),
        ));
        assert_eq!((e.row, e.column), (13, 1), "{e}"); // header on row 2, sample 10 on row 13
        assert!(e.message.contains("unequal sampling"), "{e}");
        assert!(e.help.contains("resample"), "{e}");
    }

    #[test]
    fn other_refusals() {
        let head = "# feed_mm_per_min = 4800\nposition_mm,displacement_um\n";
        // no feed
        let e = error_of(&csv("position_mm,displacement_um\n", good_rows(20)));
        assert!(e.message.contains("no feed rate"), "{e}");
        // feed without unit
        let e = error_of(&csv(
            "# feed = 4800\nposition_mm,displacement_um\n",
            good_rows(20),
        ));
        assert!(e.message.contains("no known unit"), "{e}");
        // unknown column (unit mistake)
        let e = error_of(&csv(
            "# feed_mm_per_min = 4800\nposition_mm,displacement_mm\n",
            good_rows(20),
        ));
        assert_eq!((e.row, e.column), (2, 2));
        // too few samples
        let e = error_of(&csv(head, good_rows(5)));
        assert!(e.message.contains("at least"), "{e}");
        // decreasing position
        let mut rows: Vec<String> = good_rows(20).collect();
        rows.swap(3, 4);
        let e = error_of(&csv(head, rows.into_iter()));
        assert_eq!(e.row, 7);
        // wrong field count
        let mut rows: Vec<String> = good_rows(20).collect();
        rows[2].push_str(",1");
        let e = error_of(&csv(head, rows.into_iter()));
        assert_eq!(e.row, 5);
        // axis Z
        let e = error_of(&csv("# axis = Z\n", good_rows(20)));
        assert!(e.help.contains("axis = X"), "{e}");
        // a feed column that changes within the run
        let rows = (0..20).map(|i| format!("{},0,{}", i, if i < 10 { 4800 } else { 7200 }));
        let e = error_of(&csv("position_mm,displacement_um,feed_mm_per_min\n", rows));
        assert_eq!((e.row, e.column), (12, 3));
        // empty
        let e = error_of("# nothing\n");
        assert!(e.message.contains("no header"), "{e}");
    }
}
