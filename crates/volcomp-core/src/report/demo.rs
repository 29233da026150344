//! The demo's table of every program with every method: on a terminal
//! (at most 100 columns), as Markdown (BENCHMARKS.md takes it as it is, so
//! it cannot go stale) and in the HTML report. One sign convention
//! everywhere, the report's: the change against "before" in percent,
//! negative when the error got smaller (−99.4 % is 99.4 % smaller).

use super::Table;
use crate::simulate::SimReport;
use std::fmt::Write as _;

/// One method's column: its name in full and short (for the terminal).
#[derive(Debug, Clone, Copy)]
pub struct Column {
    /// The full name.
    pub label: &'static str,
    /// At most 12 characters.
    pub short: &'static str,
}

/// One program: its title, its figures before and after each method.
#[derive(Debug, Clone)]
pub struct Row {
    /// The program's title.
    pub title: String,
    /// Simulated as written.
    pub before: SimReport,
    /// Compensated by each method, in the columns' order.
    pub after: Vec<SimReport>,
}

/// A figure read from a simulation.
type Metric = fn(&SimReport) -> f64;

/// The metrics of the table: the RMS point and contour errors (µm).
const METRICS: [(&str, Metric); 2] = [
    ("point", |r| r.point_rms_um),
    ("contour", |r| r.contour_rms_um),
];

/// The change of `after` against `before` in percent (`-99.4%`), `–`
/// where `before` is zero.
pub fn change(before: f64, after: f64) -> String {
    if before > 0.0 {
        format!("{:+.1}%", 100.0 * (after / before - 1.0))
    } else {
        "–".into()
    }
}

/// The table for a terminal: a line per program, a row per metric, a
/// column per method (value and change), at most 100 characters wide.
pub fn console(columns: &[Column], rows: &[Row]) -> String {
    let mut s = format!("{:<24} {:>7}", "", "before");
    for c in columns {
        let _ = write!(s, " {:<12}", c.short);
    }
    s = s.trim_end().to_string() + "\n";
    for r in rows {
        let _ = writeln!(s, "{}", r.title);
        for (name, metric) in METRICS {
            let b = metric(&r.before);
            let _ = write!(s, "  {:<22} {:>7.3}", name, b);
            for a in &r.after {
                let v = metric(a);
                let _ = write!(s, " {:>5.3} {:>6}", v, change(b, v));
            }
            s.push('\n');
        }
    }
    s
}

/// The table in Markdown, as BENCHMARKS.md shows it.
pub fn markdown(columns: &[Column], rows: &[Row]) -> String {
    let mut s = String::from("| program | before |");
    for c in columns {
        let _ = write!(s, " {} |", c.label);
    }
    s.push_str("\n|---|---|");
    s.push_str(&"---|".repeat(columns.len()));
    s.push('\n');
    for r in rows {
        for (k, (name, metric)) in METRICS.iter().enumerate() {
            let b = metric(&r.before);
            let title = if k == 0 {
                format!("{} — ", r.title)
            } else {
                "— ".into()
            };
            let _ = write!(s, "| {title}{name} | {b:.3} |");
            for a in &r.after {
                let v = metric(a);
                let pct = change(b, v).replace('%', "\u{a0}%");
                let _ = write!(s, " {v:.3} ({pct}) |");
            }
            s.push('\n');
        }
    }
    s
}

/// The table of the HTML report's overview.
pub fn overview(columns: &[Column], rows: &[Row]) -> Table {
    let mut t = Table::new(
        &["program", "error RMS (µm)", "before"],
        &[false, false, true],
        Vec::new(),
    );
    for c in columns {
        t.headers.push(c.label.into());
        t.numeric.push(true);
    }
    for r in rows {
        for (k, (name, metric)) in METRICS.iter().enumerate() {
            let b = metric(&r.before);
            let title = if k == 0 {
                r.title.clone()
            } else {
                String::new()
            };
            let mut row = vec![title, (*name).into(), format!("{b:.3}")];
            for a in &r.after {
                let v = metric(a);
                let pct = change(b, v).replace('%', "\u{a0}%");
                row.push(format!("{v:.3} ({pct})"));
            }
            t.rows.push(row);
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_change_is_signed_as_in_the_report_and_the_table_fits_100_columns() {
        assert_eq!(change(8.0, 0.005), "-99.9%");
        assert_eq!(change(2.0, 3.0), "+50.0%");
        let r = |p: f64, c: f64| SimReport {
            point_rms_um: p,
            contour_rms_um: c,
            ..SimReport::default()
        };
        let columns = [Column {
            label: "exact",
            short: "exact",
        }; 5];
        let rows = [Row {
            title: "circle D20, 20 segments".into(),
            before: r(8.13, 5.982),
            after: vec![r(0.005, 0.034); 5],
        }];
        let text = console(&columns, &rows);
        assert!(text.lines().all(|l| l.chars().count() <= 100), "{text}");
        assert!(
            text.contains("  point                    8.130 0.005 -99.9%"),
            "{text}"
        );
        let md = markdown(&columns, &rows);
        assert!(md.contains("| circle D20, 20 segments — point | 8.130 | 0.005 (-99.9\u{a0}%) |"));
    }
}
