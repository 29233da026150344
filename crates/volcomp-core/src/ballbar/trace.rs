//! The ballbar trace file (docs/ballbar.md, "Trace file"): a CSV table of
//! `direction,angle_deg,deviation_um` (`ccw` or `cw`; degrees from the
//! plane's first axis toward its second; the ballbar's length minus its
//! nominal length, µm), the test's set-up in `# key = value` lines:
//! `plane` (XY, YZ, ZX), `radius_mm`, `centre_mm` (three numbers: the
//! pivot in machine coordinates), `feed_mm_per_min`. Rows of one direction
//! are one run, in the order they were taken.
//!
//! The instruments' own export formats (Renishaw's `.b5r`/`.b5s`, API's,
//! Heidenhain's DBB files) have no published layout that volcomp could
//! cite; export the polar data as angle and deviation and add the set-up
//! lines.

use crate::ballbar::{Plane, Run, Sense, Trace};
use crate::error::MapFileError;
use crate::io::numfmt;
use crate::io::table::{CsvTable, Header, UnknownColumns};

const LAYOUT: &str = "direction,angle_deg,deviation_um";

/// The set-up a trace file says (each `None` when the file is silent).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TraceSetup {
    /// `# plane = …`.
    pub plane: Option<Plane>,
    /// `# radius_mm = …`.
    pub radius_mm: Option<f64>,
    /// `# centre_mm = x, y, z`.
    pub centre_mm: Option<[f64; 3]>,
    /// `# feed_mm_per_min = …`.
    pub feed_mm_per_min: Option<f64>,
}

/// A trace file's runs and what it says of the set-up.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceFile {
    /// The set-up lines.
    pub setup: TraceSetup,
    /// The runs (at most one per direction), in file order.
    pub runs: Vec<Run>,
}

fn setup_error(file: &str, line: usize, text: &str, message: String, help: &str) -> MapFileError {
    MapFileError::new(file, line, 1, message, help).with_source(text, 0)
}

/// Reads a trace file's text; `file` names it in errors.
pub fn read(text: &str, file: &str) -> Result<TraceFile, MapFileError> {
    let header = Header {
        known: &["direction", "angle_deg", "deviation_um"],
        unknown: UnknownColumns::Keep,
        layout: LAYOUT,
    };
    let t = CsvTable::parse(text, file, &header)?;
    let mut setup = TraceSetup::default();
    for (line, c) in &t.comments {
        let Some((key, value)) = c.split_once('=') else {
            continue;
        };
        let (key, value) = (key.trim().to_ascii_lowercase(), value.trim());
        let number = |what: &str| -> Result<f64, MapFileError> {
            value
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v > 0.0)
                .ok_or_else(|| {
                    setup_error(
                        file,
                        *line,
                        c,
                        format!("`{key}` must be a number > 0; got `{value}`"),
                        what,
                    )
                })
        };
        match key.as_str() {
            "plane" => {
                setup.plane = Some(Plane::parse(value).ok_or_else(|| {
                    setup_error(
                        file,
                        *line,
                        c,
                        format!("`{value}` is not a test plane"),
                        "write plane = XY, YZ or ZX",
                    )
                })?)
            }
            "radius_mm" => {
                setup.radius_mm = Some(number("write the ballbar's nominal length in mm")?)
            }
            "feed_mm_per_min" => {
                setup.feed_mm_per_min = Some(number("write the programmed feed in mm/min")?)
            }
            "centre_mm" | "center_mm" => {
                setup.centre_mm = Some(crate::io::table::parse_triple(value).ok_or_else(|| {
                    setup_error(
                        file,
                        *line,
                        c,
                        format!("`{value}` is not three numbers"),
                        "write the pivot's machine coordinates in mm: centre_mm = 150, 140, 130",
                    )
                })?)
            }
            _ => {}
        }
    }
    let dir = t.require("direction")?;
    let ang = t.require("angle_deg")?;
    let dev = t.require("deviation_um")?;
    let mut runs: Vec<Run> = Vec::new();
    for r in t.records()? {
        let text = t.text(r, dir);
        let sense = Sense::parse(text).ok_or_else(|| {
            t.error(
                r,
                dir,
                format!("`{}` is not a direction", crate::io::table::shown(text)),
                "write ccw (counter-clockwise, G3) or cw (clockwise, G2)",
            )
        })?;
        let a = t.number(r, ang)?;
        let d = t.number(r, dev)?;
        let run = match runs.iter().position(|x| x.sense == sense) {
            Some(i) => &mut runs[i],
            None => {
                runs.push(Run {
                    sense,
                    angle_deg: Vec::new(),
                    deviation_um: Vec::new(),
                });
                runs.last_mut().expect("just pushed")
            }
        };
        run.angle_deg.push(a.rem_euclid(360.0));
        run.deviation_um.push(d);
    }
    if runs.is_empty() {
        return Err(MapFileError::new(
            file,
            t.header_line.max(1),
            1,
            "the trace has no samples",
            format!("write one row per sample: {LAYOUT}"),
        ));
    }
    Ok(TraceFile { setup, runs })
}

/// The text of a trace file.
pub fn write(trace: &Trace) -> String {
    let c = trace.centre_mm;
    let mut s = format!(
        "# volcomp ballbar trace (docs/ballbar.md)\n# plane = {}\n# radius_mm = {}\n# centre_mm = {}, {}, {}\n# feed_mm_per_min = {}\n{LAYOUT}\n",
        trace.plane.name(),
        numfmt::mm(trace.radius_mm),
        numfmt::mm(c[0]),
        numfmt::mm(c[1]),
        numfmt::mm(c[2]),
        numfmt::mm(trace.feed_mm_per_min),
    );
    for run in &trace.runs {
        for (a, d) in run.angle_deg.iter().zip(&run.deviation_um) {
            s += &format!(
                "{},{},{}\n",
                run.sense.name(),
                numfmt::fixed(*a, 6),
                numfmt::um(*d)
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_trace_reads_back_as_written() {
        let trace = Trace {
            plane: Plane::YZ,
            radius_mm: 150.0,
            centre_mm: [1.0, 2.0, 3.5],
            feed_mm_per_min: 2000.0,
            runs: vec![
                Run {
                    sense: Sense::Ccw,
                    angle_deg: vec![0.0, 90.0, 180.0],
                    deviation_um: vec![1.25, -0.5, 0.0],
                },
                Run {
                    sense: Sense::Cw,
                    angle_deg: vec![359.5, 270.0],
                    deviation_um: vec![0.1, 0.2],
                },
            ],
        };
        let f = read(&write(&trace), "t.csv").unwrap();
        assert_eq!(f.runs, trace.runs);
        assert_eq!(f.setup.plane, Some(Plane::YZ));
        assert_eq!(f.setup.radius_mm, Some(150.0));
        assert_eq!(f.setup.centre_mm, Some([1.0, 2.0, 3.5]));
        assert_eq!(f.setup.feed_mm_per_min, Some(2000.0));
    }

    #[test]
    fn a_bad_row_is_named_by_line_and_column() {
        let e = read(
            "# plane = XY\ndirection,angle_deg,deviation_um\nccw,0,1\nup,1,2\n",
            "t.csv",
        )
        .unwrap_err();
        assert_eq!((e.row, e.column), (4, 1), "{e}");
        assert!(e.to_string().contains("not a direction"), "{e}");
        let e = read(
            "# plane = XZY\ndirection,angle_deg,deviation_um\nccw,0,1\n",
            "t.csv",
        )
        .unwrap_err();
        assert_eq!(e.row, 1);
        let e = read("direction,angle_deg\nccw,0\n", "t.csv").unwrap_err();
        assert!(e.to_string().contains("deviation_um"), "{e}");
        let e = read("direction,angle_deg,deviation_um\nccw,0,x\n", "t.csv").unwrap_err();
        assert_eq!((e.row, e.column), (2, 3));
    }
}
