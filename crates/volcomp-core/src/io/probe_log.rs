//! What a machine recorded while probing: the log a generated LinuxCNC
//! program writes with `(LOG,…)`, and a plain CSV of probed points for
//! other controllers (docs/probing.md, "The log" and "Points from other
//! controllers").
//!
//! **LinuxCNC's log.** `(LOGOPEN,file)` opens (truncates) the file,
//! `(LOGAPPEND,file)` appends, `(LOGCLOSE)` closes; `(LOG,text)` writes
//! `text` and a newline after replacing each `#n` / `#<name>` by the
//! parameter's value, formatted by the last `%.Nf` before it (`%lf`, six
//! decimals, by default; a value within 1e-4 of zero is written as exactly
//! 0; an unknown parameter as `######`). Source: LinuxCNC 2.9
//! `Interp::convert_comment` and `Interp::convert_param_comment`
//! (src/emc/rs274ngc/interp_convert.cc), `LOG`, `LOGOPEN`, `LOGAPPEND`
//! (src/emc/task/emccanon.cc). After a G38.x move the interpreter waits for
//! motion and stores the probed position in #5061–#5063 (program
//! coordinates: work offset, G92 and tool length removed) and whether the
//! probe tripped in #5070 (`Interp::set_probe_data`, interp_internal.cc),
//! so the `(LOG,…)` after a probe move records that touch.
//!
//! The program volcomp writes logs three kinds of line:
//!
//! ```text
//! volcomp-probe 1 artifact=plate
//! frame g5x=250.000000,200.000000,150.000000 r=0.000000 g92on=0.000000 g92=0.000000,0.000000,0.000000 tlo=0.000000,0.000000,75.000000 metric=1.000000 mm=1.000000
//! touch n=3 p=p1 f=s2 d=-Z st=ffr at=10.000000,20.000000,-5.000000 q=10.000000,20.000000,-3.512345 ok=1.000000
//! ```
//!
//! `frame` gives the offsets in effect (G5x of the program's coordinate
//! system, its XY rotation, whether G92 is on and its offsets, the tool
//! offset — all in the machine's units —, `#<_metric>` (the program's
//! units: mm) and `#<_metric_machine>` (the machine's: 1 mm, 0 inch,
//! `interp_namedparams.cc`); a touch's position in machine (axis)
//! coordinates is `q + g5x + g92 (if on) + tlo`, the offsets converted to
//! mm, docs/design.md, "Frames". `d` is the
//! direction the probe moved, `st` the direction state of X, Y, Z at the
//! touch (`f` forward, `r` reverse), `at` the commanded end of the probe
//! move (program coordinates), `ok` #5070.
//!
//! **Points from other controllers**: a CSV with the columns
//! `artifact,placement,feature,direction,x_mm,y_mm,z_mm` (machine
//! coordinates of the probe tip centre at the touch) and optionally
//! `states` (`ffr`) and `tool_length_mm`.

use crate::error::MapFileError;
use crate::io::finite;
use crate::io::table::{CsvTable, Header, UnknownColumns};
use crate::model::{Direction, Directions};
use volcomp_gcode::Vec3;

/// One of the six machine axis directions (the directions a probe moves
/// in when it touches).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct AxisDir {
    /// 0 = X, 1 = Y, 2 = Z.
    pub axis: usize,
    /// Towards + (`true`) or − (`false`).
    pub positive: bool,
}

impl AxisDir {
    /// Every direction, in the order +X −X +Y −Y +Z −Z.
    pub const ALL: [AxisDir; 6] = [
        AxisDir::new(0, true),
        AxisDir::new(0, false),
        AxisDir::new(1, true),
        AxisDir::new(1, false),
        AxisDir::new(2, true),
        AxisDir::new(2, false),
    ];

    /// A direction.
    pub const fn new(axis: usize, positive: bool) -> Self {
        Self { axis, positive }
    }

    /// `+1.0` or `-1.0`.
    pub fn sign(self) -> f64 {
        if self.positive {
            1.0
        } else {
            -1.0
        }
    }

    /// The unit vector.
    pub fn vector(self) -> Vec3 {
        let mut v = Vec3::ZERO;
        v[self.axis] = self.sign();
        v
    }

    /// The opposite direction.
    pub fn opposite(self) -> Self {
        Self::new(self.axis, !self.positive)
    }

    /// `+X`, `-Z`, …
    pub fn label(self) -> String {
        format!(
            "{}{}",
            if self.positive { '+' } else { '-' },
            ['X', 'Y', 'Z'][self.axis]
        )
    }

    /// Reads `+X`, `-z`, `X+` … (sign and letter in either order).
    pub fn parse(text: &str) -> Option<Self> {
        let t = text.trim().to_ascii_uppercase();
        let (sign, letter) = match t.as_bytes() {
            [s @ (b'+' | b'-'), l] => (*s, *l),
            [l, s @ (b'+' | b'-')] => (*s, *l),
            _ => return None,
        };
        let axis = match letter {
            b'X' => 0,
            b'Y' => 1,
            b'Z' => 2,
            _ => return None,
        };
        Some(Self::new(axis, sign == b'+'))
    }

    /// Index in [`AxisDir::ALL`].
    pub fn index(self) -> usize {
        2 * self.axis + usize::from(!self.positive)
    }

    /// The direction state of its axis when moving this way.
    pub fn state(self) -> Direction {
        if self.positive {
            Direction::Forward
        } else {
            Direction::Reverse
        }
    }
}

/// Where a touch was read from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Source {
    /// File name.
    pub file: String,
    /// 1-based line.
    pub line: usize,
}

/// One touch: where the machine said the probe was when it triggered.
#[derive(Debug, Clone, PartialEq)]
pub struct Touch {
    /// Artifact name.
    pub artifact: String,
    /// Placement name.
    pub placement: String,
    /// Feature label (`s3`, `f1`, `e2`).
    pub feature: String,
    /// The direction the probe moved.
    pub direction: AxisDir,
    /// Direction state of X, Y, Z at the touch, when known.
    pub states: Option<Directions>,
    /// Machine (axis) coordinates of the probe tip centre at the trigger (mm).
    pub q_mm: Vec3,
    /// Tool length offset of the probe (mm, along Z).
    pub tool_length_mm: f64,
    /// The commanded end of the probe move (axis coordinates), if logged.
    pub target_mm: Option<Vec3>,
    /// Whether the probe tripped (a G38.3 that did not touch has `false`).
    pub tripped: bool,
    /// Where it was read.
    pub source: Source,
}

/// Largest log or CSV read (bytes): a probing campaign has thousands of
/// touches, a few hundred kilobytes; larger is not a probing log.
pub const MAX_LOG_BYTES: usize = 64 << 20;

/// The `volcomp-probe` version a log says (the first word of its header).
pub const LOG_VERSION: u32 = 1;

fn err(file: &str, line: usize, col: usize, text: &str, msg: String, help: &str) -> MapFileError {
    MapFileError::new(file, line, col, msg, help).with_source(text, col.saturating_sub(1))
}

/// An error of the file as a whole (told at its first line and column).
fn of_the_file(file: &str, message: impl Into<String>, help: &str) -> MapFileError {
    MapFileError::new(file, 1, 1, message, help)
}

fn parse_states(s: &str) -> Option<Directions> {
    let b = s.as_bytes();
    if b.len() != 3 {
        return None;
    }
    let mut out = [Direction::Forward; 3];
    for (k, c) in b.iter().enumerate() {
        out[k] = match c.to_ascii_lowercase() {
            b'f' => Direction::Forward,
            b'r' => Direction::Reverse,
            _ => return None,
        };
    }
    Some(out)
}

/// `f`/`r` letters of a direction state.
pub fn states_label(s: &Directions) -> String {
    s.iter()
        .map(|d| match d {
            Direction::Forward => 'f',
            Direction::Reverse => 'r',
        })
        .collect()
}

/// The offsets a `frame` line gives.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Frame {
    offset_mm: Vec3,
    tool_mm: Vec3,
}

/// Reads a LinuxCNC probing log written by a volcomp program.
///
/// ```
/// use volcomp_core::io::probe_log::read_linuxcnc_log;
/// let log = "volcomp-probe 1 artifact=ref\n\
///   frame g5x=100.000000,0.000000,0.000000 r=0.000000 g92on=0.000000 g92=5.000000,0.000000,0.000000 tlo=0.000000,0.000000,50.000000 metric=1.000000 mm=1.000000\n\
///   touch n=1 p=r f=s1 d=-Z st=ffr at=1.000000,2.000000,-3.000000 q=1.000000,2.000000,-1.250000 ok=1.000000\n";
/// let t = read_linuxcnc_log(log, "probe.log").unwrap();
/// // Machine Z = −1.25 + 0 (G54) + 50 (tool); G92 is off.
/// assert_eq!(t[0].q_mm.z, 48.75);
/// assert_eq!(t[0].q_mm.x, 101.0);
/// ```
pub fn read_linuxcnc_log(text: &str, file: &str) -> Result<Vec<Touch>, MapFileError> {
    if text.len() > MAX_LOG_BYTES {
        return Err(of_the_file(
            file,
            format!(
                "{} bytes: larger than a probing log ({MAX_LOG_BYTES} bytes at most)",
                text.len()
            ),
            "give the log the probing program wrote",
        ));
    }
    let mut artifact: Option<String> = None;
    let mut frame: Option<Frame> = None;
    let mut touches = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let text_line = raw.trim_end_matches('\r');
        let t = text_line.trim();
        if t.is_empty() {
            continue;
        }
        let col_of = |needle: &str| text_line.find(needle).map_or(1, |c| c + 1);
        // An error at column `col` of this line.
        let refuse =
            |col: usize, msg: String, help: &str| err(file, line, col, text_line, msg, help);
        if t.contains("######") {
            return Err(refuse(
                col_of("######"),
                "LinuxCNC wrote ###### for a parameter it did not know".into(),
                "the program was not run by LinuxCNC 2.9 as written: generate it again with `volcomp probe plan` and run it unchanged",
            ));
        }
        let mut words = t.split_whitespace();
        let kind = words.next().unwrap_or("");
        let fields: Vec<(&str, &str)> = words
            .map(|w| w.split_once('=').unwrap_or((w, "")))
            .collect();
        let get = |key: &str| -> Result<&str, MapFileError> {
            fields
                .iter()
                .find(|(k, _)| *k == key)
                .map(|(_, v)| *v)
                .ok_or_else(|| {
                    refuse(
                        1,
                        format!("`{kind}` line without `{key}=`"),
                        "the log is read as the probing program writes it: do not edit it",
                    )
                })
        };
        let number = |key: &str| -> Result<f64, MapFileError> {
            let v = get(key)?;
            finite(v).ok_or_else(|| {
                refuse(
                    col_of(&format!("{key}=")),
                    format!("{key}=`{v}` is not a number"),
                    "the log is read as the probing program writes it: do not edit it",
                )
            })
        };
        let triple = |key: &str| -> Result<Vec3, MapFileError> {
            let v = get(key)?;
            let parts: Vec<Option<f64>> = v.split(',').map(finite).collect();
            match parts.as_slice() {
                [Some(x), Some(y), Some(z)] => Ok(Vec3::new(*x, *y, *z)),
                _ => Err(refuse(
                    col_of(&format!("{key}=")),
                    format!("{key}=`{v}` is not three numbers"),
                    "the log is read as the probing program writes it: do not edit it",
                )),
            }
        };
        match kind {
            "volcomp-probe" => {
                let version = fields.first().map(|(k, _)| *k).unwrap_or("");
                if version != LOG_VERSION.to_string() {
                    return Err(refuse(
                        15,
                        format!(
                            "log version `{version}`: this volcomp reads version {LOG_VERSION}"
                        ),
                        "generate the program again with this volcomp",
                    ));
                }
                artifact = Some(get("artifact")?.to_string());
                frame = None;
            }
            "frame" => {
                if number("metric")? != 1.0 {
                    return Err(refuse(
                        col_of("metric="),
                        "the program ran in inches (#<_metric> = 0)".into(),
                        "run the generated program unchanged: it selects G21",
                    ));
                }
                if number("r")? != 0.0 {
                    return Err(refuse(
                        col_of("r="),
                        "the coordinate system is rotated (G10 L2 R)".into(),
                        "probe in a coordinate system without rotation",
                    ));
                }
                // Offsets are in the machine's units.
                let unit = if number("mm")? == 0.0 { 25.4 } else { 1.0 };
                let g92 = if number("g92on")? != 0.0 {
                    triple("g92")? * unit
                } else {
                    Vec3::ZERO
                };
                let tool = triple("tlo")? * unit;
                frame = Some(Frame {
                    offset_mm: triple("g5x")? * unit + g92 + tool,
                    tool_mm: tool,
                });
            }
            "touch" => {
                let Some(art) = artifact.clone() else {
                    return Err(refuse(
                        1,
                        "a touch before the `volcomp-probe` header".into(),
                        "give the whole log the program wrote",
                    ));
                };
                let Some(fr) = frame else {
                    return Err(refuse(
                        1,
                        "a touch before the `frame` line".into(),
                        "give the whole log the program wrote",
                    ));
                };
                let d = get("d")?;
                let direction = AxisDir::parse(d).ok_or_else(|| {
                    refuse(
                        col_of("d="),
                        format!("d=`{d}` is not a direction"),
                        "write +X, -X, +Y, -Y, +Z or -Z",
                    )
                })?;
                let st = get("st")?;
                let states = parse_states(st).ok_or_else(|| {
                    refuse(
                        col_of("st="),
                        format!("st=`{st}` is not three of f/r"),
                        "the direction states of X, Y, Z: f (forward) or r (reverse)",
                    )
                })?;
                let q = triple("q")?;
                let at = triple("at")?;
                let ok = number("ok")?;
                if fr.tool_mm.x != 0.0 || fr.tool_mm.y != 0.0 {
                    return Err(refuse(
                        1,
                        "the tool offset has X or Y parts".into(),
                        "probe with a tool length offset along Z only (G43 H)",
                    ));
                }
                touches.push(Touch {
                    artifact: art,
                    placement: get("p")?.to_string(),
                    feature: get("f")?.to_string(),
                    direction,
                    states: Some(states),
                    q_mm: q + fr.offset_mm,
                    tool_length_mm: fr.tool_mm.z,
                    target_mm: Some(at + fr.offset_mm),
                    tripped: ok != 0.0,
                    source: Source {
                        file: file.to_string(),
                        line,
                    },
                });
            }
            other => {
                return Err(refuse(1, format!("`{other}` is not a line of a volcomp probing log"),
                    "give the log the generated program wrote (volcomp-probe, frame and touch lines), or a CSV of points",
                ));
            }
        }
    }
    if touches.is_empty() {
        return Err(of_the_file(
            file,
            "no touches in the log",
            "run the probing program to its end; the log is written as it probes",
        ));
    }
    Ok(touches)
}

/// The columns of a CSV of probed points: the first
/// [`REQUIRED_POINT_COLUMNS`] in every file, then the optional ones.
const POINT_COLUMNS: [&str; 9] = [
    "artifact",
    "placement",
    "feature",
    "direction",
    "x_mm",
    "y_mm",
    "z_mm",
    "states",
    "tool_length_mm",
];
const REQUIRED_POINT_COLUMNS: usize = 7;

/// Reads a CSV of probed points (columns in the module documentation).
pub fn read_points_csv(text: &str, file: &str) -> Result<Vec<Touch>, MapFileError> {
    if text.len() > MAX_LOG_BYTES {
        return Err(of_the_file(
            file,
            format!("{} bytes: larger than a probing log", text.len()),
            "give the points of one campaign",
        ));
    }
    let header = Header {
        known: &POINT_COLUMNS,
        unknown: UnknownColumns::Refuse,
        layout: "artifact,placement,feature,direction,x_mm,y_mm,z_mm[,states][,tool_length_mm]",
    };
    let csv = CsvTable::parse(text, file, &header)?;
    let cols: Vec<usize> = POINT_COLUMNS[..REQUIRED_POINT_COLUMNS]
        .iter()
        .map(|c| csv.require(c))
        .collect::<Result<_, _>>()?;
    let states_col = csv.column("states");
    let tool_col = csv.column("tool_length_mm");
    let mut out = Vec::new();
    for r in csv.records()? {
        let d = csv.text(r, cols[3]);
        let direction = AxisDir::parse(d).ok_or_else(|| {
            csv.error(
                r,
                cols[3],
                format!("`{d}` is not a direction"),
                "write +X, -X, +Y, -Y, +Z or -Z: the way the probe moved",
            )
        })?;
        let states = match states_col {
            Some(c) if !csv.text(r, c).is_empty() => {
                let s = csv.text(r, c);
                Some(parse_states(s).ok_or_else(|| {
                    csv.error(
                        r,
                        c,
                        format!("`{s}` is not three of f/r"),
                        "the direction states of X, Y, Z at the touch, e.g. ffr",
                    )
                })?)
            }
            _ => None,
        };
        let q = Vec3::new(
            csv.number(r, cols[4])?,
            csv.number(r, cols[5])?,
            csv.number(r, cols[6])?,
        );
        let tool = match tool_col {
            Some(c) => csv.number(r, c)?,
            None => 0.0,
        };
        for (c, name) in [(0, "artifact"), (1, "placement"), (2, "feature")] {
            if csv.text(r, cols[c]).is_empty() {
                return Err(csv.error(
                    r,
                    cols[c],
                    format!("empty {name}"),
                    "name the artifact, placement and feature as in the artifact file",
                ));
            }
        }
        out.push(Touch {
            artifact: csv.text(r, cols[0]).to_string(),
            placement: csv.text(r, cols[1]).to_string(),
            feature: csv.text(r, cols[2]).to_string(),
            direction,
            states,
            q_mm: q,
            tool_length_mm: tool,
            target_mm: None,
            tripped: true,
            source: Source {
                file: file.to_string(),
                line: r.line,
            },
        });
    }
    if out.is_empty() {
        return Err(of_the_file(
            file,
            "no points",
            "add one row per touch below the header",
        ));
    }
    Ok(out)
}

/// Reads either format: a CSV when the first line that is not blank or
/// a `#` comment names the `artifact` column, else a LinuxCNC log.
pub fn read_touches(text: &str, file: &str) -> Result<Vec<Touch>, MapFileError> {
    let first = text
        .trim_start_matches('\u{feff}')
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .unwrap_or("");
    if first.to_ascii_lowercase().starts_with("artifact,") {
        read_points_csv(text, file)
    } else {
        read_linuxcnc_log(text, file)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LOG: &str = "volcomp-probe 1 artifact=plate\n\
frame g5x=250.000000,200.000000,150.000000 r=0.000000 g92on=1.000000 g92=1.000000,0.000000,0.000000 tlo=0.000000,0.000000,75.000000 metric=1.000000 mm=1.000000\n\
touch n=1 p=p1 f=s2 d=-Z st=ffr at=10.000000,20.000000,-5.000000 q=10.000000,20.000000,-3.512345 ok=1.000000\n\
touch n=2 p=p1 f=s2 d=+X st=frr at=0.000000,20.000000,-5.000000 q=-2.500000,20.000000,-5.000000 ok=0.000000\n";

    #[test]
    fn a_log_is_read_into_machine_coordinates() {
        let t = read_linuxcnc_log(LOG, "p.log").unwrap();
        assert_eq!(t.len(), 2);
        // 10 + 250 + 1 (G92 on), 20 + 200, −3.512345 + 150 + 75.
        assert_eq!(t[0].q_mm, Vec3::new(261.0, 220.0, -3.512345 + 225.0));
        assert_eq!(t[0].tool_length_mm, 75.0);
        assert_eq!(t[0].direction, AxisDir::new(2, false));
        assert_eq!(
            t[0].states,
            Some([Direction::Forward, Direction::Forward, Direction::Reverse])
        );
        assert_eq!(t[0].source.line, 3);
        assert!(t[0].tripped && !t[1].tripped);
        assert_eq!(t[1].feature, "s2");
    }

    #[test]
    fn what_linuxcnc_could_not_write_is_located() {
        let bad = LOG.replace(
            "q=10.000000,20.000000,-3.512345",
            "q=######,20.000000,-3.512345",
        );
        let e = read_linuxcnc_log(&bad, "p.log").unwrap_err();
        assert_eq!(
            (e.row, e.column),
            (3, bad.lines().nth(2).unwrap().find("###").unwrap() + 1)
        );
        let bad = LOG.replace("r=0.000000", "r=30.000000");
        assert!(read_linuxcnc_log(&bad, "p.log")
            .unwrap_err()
            .to_string()
            .contains("rotated"));
        let bad = LOG.replace("metric=1.000000", "metric=0.000000");
        assert!(read_linuxcnc_log(&bad, "p.log")
            .unwrap_err()
            .to_string()
            .contains("inches"));
        let bad = LOG.replace("d=+X", "d=X");
        let e = read_linuxcnc_log(&bad, "p.log").unwrap_err();
        assert_eq!(e.row, 4);
        assert!(e.to_string().contains("not a direction"));
        let e = read_linuxcnc_log("touch n=1\n", "p.log").unwrap_err();
        assert!(
            e.to_string().contains("before the `volcomp-probe` header"),
            "{e}"
        );
        let e = read_linuxcnc_log("G1 X1\n", "p.log").unwrap_err();
        assert!(
            e.to_string()
                .contains("not a line of a volcomp probing log"),
            "{e}"
        );
    }

    #[test]
    fn points_from_a_csv() {
        let csv = "artifact,placement,feature,direction,x_mm,y_mm,z_mm,states\nplate,p1,s1,-Z,1,2,3,ffr\nplate,p1,s1,+X,1,2,3,\n";
        let t = read_touches(csv, "p.csv").unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(t[0].q_mm, Vec3::new(1.0, 2.0, 3.0));
        assert!(t[0].states.is_some() && t[1].states.is_none());
        let bad = csv.replace("+X", "up");
        let e = read_touches(&bad, "p.csv").unwrap_err();
        assert_eq!((e.row, e.column), (3, 4));
    }
}
