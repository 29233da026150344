//! The machine state a program runs in: work offsets, tool lengths, reference
//! points and start position, read from a small TOML file.
//!
//! ```toml
//! units = "mm"                 # required: the unit of every length below
//! start = [0, 0, 0]            # machine position when the program starts
//! [work_offsets]               # G54 … G59, G59.1 … G59.3 (machine coordinates)
//! G54 = [100.0, 50.0, -200.0]
//! [tools]                      # tool number = length (along Z)
//! 1 = 75.0
//! [tool_diameters]             # tool number = diameter (G41/G42)
//! 1 = 6.0
//! [reference]                  # G28 / G30 positions (machine coordinates)
//! G28 = [0, 0, 0]
//! G30 = [0, 0, 0]
//! [limits]                     # motion limits, for time estimates (LinuxCNC's INI)
//! max_velocity = [166.7, 166.7, 166.7]       # X Y Z, units/s
//! max_acceleration = [1000, 1000, 1000]      # X Y Z, units/s²
//! ```
//!
//! Lengths are converted to millimetres on load; a file without `units`
//! is refused rather than guessed.

use crate::error::{ErrorClass, GcodeError};
use crate::geom::{Units, Vec3};
use std::collections::BTreeMap;

/// Work coordinate system names in P-number order (G10 L2 P1 … P9).
pub const WORK_SYSTEMS: [&str; 9] = [
    "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
];

/// Machine state at program start, all lengths in millimetres.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// Work offsets G54 … G59.3 in machine coordinates.
    pub work_offsets_mm: [Vec3; 9],
    /// Which of them the set-up gives (its `[work_offsets]` table, a var
    /// file, `--work-offset`): a program that selects or reads one it does
    /// not give is refused rather than run with 0 (G54 defaults to 0, the
    /// program frame being the machine's when nothing is said).
    pub work_offsets_given: [bool; 9],
    /// Tool lengths by tool number.
    pub tool_lengths_mm: BTreeMap<u32, f64>,
    /// Tool diameters by tool number (LinuxCNC's tool table `D`), for
    /// cutter radius compensation G41/G42. A negative diameter puts the
    /// tool on the other side, as in LinuxCNC.
    pub tool_diameters_mm: BTreeMap<u32, f64>,
    /// G28 reference point.
    pub g28_mm: Vec3,
    /// G30 reference point.
    pub g30_mm: Vec3,
    /// Whether the set-up gives the G28 point (else it is machine zero,
    /// and a program that uses G28 is warned about it).
    pub g28_given: bool,
    /// Whether the set-up gives the G30 point.
    pub g30_given: bool,
    /// Machine position when the program starts.
    pub start_mm: Vec3,
    /// Whether the set-up gives the start position (its `start`): where it
    /// does not, `start_mm` is machine zero, a placeholder, and an axis the
    /// program never sets has no known position.
    pub start_given: bool,
    /// The machine's length units: the units the set-up file is written
    /// in, as LinuxCNC's `[TRAJ]LINEAR_UNITS`. LinuxCNC keeps the offset,
    /// reference-point and tool parameters (#5161–#5409) in them.
    pub machine_units: crate::geom::Units,
    /// G92 offset in effect when the program starts (a `.var` file's #5211…).
    pub g92_mm: Vec3,
    /// Rotation of each coordinate system's XY plane at the start, degrees
    /// (a `.var` file's #5230 + 20·k; G10 L2 R sets it in a program).
    pub rotations_deg: [f64; 9],
    /// The coordinate system in use when the program starts (0 = G54; a
    /// `.var` file's #5220).
    pub work_system: usize,
    /// Numbered parameters preset from a `.var` file (not the ones the
    /// interpreter owns).
    pub parameters: BTreeMap<usize, f64>,
    /// Directories searched for subroutine files (`o<name> call` finds
    /// `name.ngc`), before the program's own directory. Relative entries of
    /// a set-up file are relative to that file.
    pub subroutine_path: Vec<std::path::PathBuf>,
    /// The machine's axes, as LinuxCNC's axis mask (`[TRAJ]COORDINATES`):
    /// a program word for an axis the machine lacks is refused as LinuxCNC
    /// refuses it ("Bad character 'u' used"). The default, X Y Z A B C, is
    /// the stand-alone interpreter's machine (`GET_EXTERNAL_AXIS_MASK` is
    /// 0x3f in saicanon.cc).
    pub axes: AxisLetters,
    /// The machine's motion limits (`[limits]`), for machining-time
    /// estimates; `None` when the set-up gives none.
    pub limits: Option<MotionLimits>,
}

/// The `[limits]` table of a set-up: what LinuxCNC's INI file says about
/// motion, for estimating machining time on its trajectory planner. Each
/// value is optional (the estimate states the default it uses); lengths are
/// in mm here (the file gives them in its `units`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MotionLimits {
    /// `[AXIS_X|Y|Z] MAX_VELOCITY`, mm/s.
    pub max_velocity_mm_s: Option<[f64; 3]>,
    /// `[AXIS_X|Y|Z] MAX_ACCELERATION`, mm/s².
    pub max_acceleration_mm_s2: Option<[f64; 3]>,
    /// `[TRAJ] MAX_LINEAR_VELOCITY`, mm/s.
    pub traj_max_velocity_mm_s: Option<f64>,
    /// `[EMCMOT] SERVO_PERIOD`, s.
    pub servo_period_s: Option<f64>,
    /// `[DISPLAY] MAX_FEED_OVERRIDE`.
    pub max_feed_override: Option<f64>,
    /// `[TRAJ] ARC_BLEND_ENABLE`.
    pub arc_blend_enable: Option<bool>,
    /// `[TRAJ] ARC_BLEND_OPTIMIZATION_DEPTH`.
    pub arc_blend_optimization_depth: Option<u32>,
    /// `[TRAJ] ARC_BLEND_GAP_CYCLES`.
    pub arc_blend_gap_cycles: Option<f64>,
    /// `[TRAJ] ARC_BLEND_RAMP_FREQ`, Hz.
    pub arc_blend_ramp_freq_hz: Option<f64>,
    /// `[TRAJ] ARC_BLEND_KINK_RATIO`.
    pub arc_blend_kink_ratio: Option<f64>,
}

/// A set of the nine axis letters X Y Z A B C U V W.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisLetters(u16);

impl AxisLetters {
    /// The nine letters, in LinuxCNC's order.
    pub const ALL: [u8; 9] = *b"XYZABCUVW";

    /// X Y Z A B C: LinuxCNC's stand-alone interpreter's machine.
    pub const XYZABC: AxisLetters = AxisLetters(0x3f);

    /// Whether the `i`-th letter of [`Self::ALL`] is one of the set's axes.
    #[inline]
    pub(crate) fn has_index(self, i: usize) -> bool {
        self.0 & (1 << i) != 0
    }

    /// Whether `letter` (upper case) is one of the set's axes.
    pub fn contains(self, letter: u8) -> bool {
        Self::ALL
            .iter()
            .position(|l| *l == letter)
            .is_some_and(|i| self.0 & (1 << i) != 0)
    }

    /// The set of the letters of `text` (e.g. `"XYZABCUVW"`, any case, any
    /// order, spaces allowed); `Err` names the first character that is no
    /// axis letter or is given twice.
    pub fn parse(text: &str) -> Result<AxisLetters, (usize, String)> {
        let mut bits = 0u16;
        for (at, c) in text.char_indices() {
            if c == ' ' {
                continue;
            }
            let up = c.to_ascii_uppercase() as u8;
            let Some(i) = Self::ALL
                .iter()
                .position(|l| *l == up)
                .filter(|_| c.is_ascii())
            else {
                return Err((at, format!("`{c}` is not an axis letter")));
            };
            if bits & (1 << i) != 0 {
                return Err((at, format!("axis {} is given twice", up as char)));
            }
            bits |= 1 << i;
        }
        Ok(AxisLetters(bits))
    }

    /// The letters, in LinuxCNC's order (`"XYZABC"`).
    pub fn letters(self) -> String {
        Self::ALL
            .iter()
            .filter(|l| self.contains(**l))
            .map(|l| *l as char)
            .collect()
    }
}

impl Default for AxisLetters {
    fn default() -> Self {
        Self::XYZABC
    }
}

impl Default for Setup {
    fn default() -> Self {
        Self {
            work_offsets_mm: [Vec3::ZERO; 9],
            work_offsets_given: [true, false, false, false, false, false, false, false, false],
            tool_lengths_mm: BTreeMap::new(),
            tool_diameters_mm: BTreeMap::new(),
            g28_mm: Vec3::ZERO,
            g30_mm: Vec3::ZERO,
            g28_given: false,
            g30_given: false,
            start_mm: Vec3::ZERO,
            start_given: false,
            subroutine_path: Vec::new(),
            machine_units: crate::geom::Units::Mm,
            g92_mm: Vec3::ZERO,
            work_system: 0,
            rotations_deg: [0.0; 9],
            parameters: BTreeMap::new(),
            axes: AxisLetters::XYZABC,
            limits: None,
        }
    }
}

/// Why a setup file was refused: a [`GcodeError`] located in the set-up
/// file (file, line, column, the line, what to do) for every case, TOML
/// syntax included. An alias, kept so that code naming it still compiles:
/// volcomp-gcode has one error type.
pub type SetupError = GcodeError;

/// A value with its byte range in the file.
type Sp<T> = toml::Spanned<T>;

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSetup {
    units: Option<Sp<Units>>,
    start: Option<Sp<Vec<f64>>>,
    #[serde(default)]
    subroutine_path: Vec<String>,
    var_file: Option<Sp<String>>,
    axes: Option<Sp<String>>,
    #[serde(default)]
    work_offsets: BTreeMap<Sp<String>, Sp<Vec<f64>>>,
    #[serde(default)]
    tools: BTreeMap<Sp<String>, Sp<f64>>,
    #[serde(default)]
    tool_diameters: BTreeMap<Sp<String>, Sp<f64>>,
    #[serde(default)]
    reference: BTreeMap<Sp<String>, Sp<Vec<f64>>>,
    limits: Option<RawLimits>,
}

/// `[limits]` as written: one value or `[X, Y, Z]` per axis limit.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLimits {
    max_velocity: Option<Sp<PerAxis>>,
    max_acceleration: Option<Sp<PerAxis>>,
    traj_max_velocity: Option<Sp<f64>>,
    servo_period: Option<Sp<f64>>,
    max_feed_override: Option<Sp<f64>>,
    arc_blend_enable: Option<bool>,
    arc_blend_optimization_depth: Option<Sp<i64>>,
    arc_blend_gap_cycles: Option<Sp<f64>>,
    arc_blend_ramp_freq: Option<Sp<f64>>,
    arc_blend_kink_ratio: Option<Sp<f64>>,
}

#[derive(serde::Deserialize)]
#[serde(untagged)]
enum PerAxis {
    All(f64),
    Each(Vec<f64>),
}

/// Builds located errors for one set-up file.
struct At<'a> {
    text: &'a str,
    file: &'a str,
}

impl At<'_> {
    /// A located error at byte `offset` of the text.
    fn error(&self, offset: usize, message: String, help: &str) -> SetupError {
        let offset = offset.min(self.text.len());
        let before = &self.text.as_bytes()[..offset];
        let line = before.iter().filter(|&&b| b == b'\n').count() as u64 + 1;
        let start = before
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |i| i + 1);
        let end = self.text[start..]
            .find('\n')
            .map_or(self.text.len(), |i| start + i);
        let column = offset - start + 1;
        GcodeError::new(ErrorClass::Invalid, line, column, message, help)
            .with_source_line(&self.text.as_bytes()[start..end])
            .with_file(self.file)
    }

    /// A position of three finite numbers, in mm.
    fn vec(&self, name: &str, a: &Sp<Vec<f64>>, mm_per_unit: f64) -> Result<Vec3, SetupError> {
        let v = a.get_ref();
        if v.len() != 3 {
            return Err(self.error(
                a.span().start,
                format!("{name} has {} value(s); a position has three", v.len()),
                "write [X, Y, Z], e.g. [250, 200, 150]",
            ));
        }
        let p = Vec3::new(v[0], v[1], v[2]) * mm_per_unit;
        if p.is_finite() {
            Ok(p)
        } else {
            Err(self.error(
                a.span().start,
                format!("{name} is not a finite position"),
                "write three finite numbers",
            ))
        }
    }
}

impl Setup {
    /// Parses a setup file's text (errors name the file `<setup>`).
    ///
    /// ```
    /// let s = volcomp_gcode::Setup::from_toml("units = \"inch\"\n[tools]\n3 = 2.0\n").unwrap();
    /// assert_eq!(s.tool_lengths_mm[&3], 50.8);
    /// ```
    pub fn from_toml(text: &str) -> Result<Setup, SetupError> {
        Self::from_toml_in(text, "<setup>")
    }

    /// Parses a setup file's text; `file` names it in errors, which carry
    /// line and column.
    ///
    /// ```
    /// let e = volcomp_gcode::Setup::from_toml_in("units = \"mm\"\n[work_offsets]\nG54 = [250, 200, 150, 1]\n", "s.toml").unwrap_err();
    /// assert!(e.to_string().starts_with("s.toml:3:7: G54 has 4 value(s)"));
    /// ```
    pub fn from_toml_in(text: &str, file: &str) -> Result<Setup, SetupError> {
        let at = At { text, file };
        let raw: RawSetup = toml::from_str(text).map_err(|e| {
            let offset = e.span().map_or(0, |s| s.start);
            at.error(
                offset,
                e.message().to_string(),
                "the set-up file has the keys units, start, axes, subroutine_path, var_file, [work_offsets], [tools], [tool_diameters], [reference] and [limits]",
            )
        })?;
        let units = raw.units.ok_or_else(|| {
            at.error(
                0,
                "missing `units = \"mm\"` or `units = \"inch\"`".into(),
                "say the unit of the offsets: volcomp does not guess it",
            )
        })?;
        let k = units.get_ref().mm_per_unit();
        let mut setup = Setup {
            machine_units: *units.get_ref(),
            ..Setup::default()
        };
        if let Some(s) = &raw.start {
            setup.start_mm = at.vec("start", s, k)?;
            setup.start_given = true;
        }
        if let Some(a) = &raw.axes {
            // The value's text starts after its opening quote.
            let axes = AxisLetters::parse(a.get_ref()).map_err(|(at_char, why)| {
                at.error(
                    a.span().start + 1 + at_char,
                    why,
                    "write the machine's axes, e.g. axes = \"XYZA\" or \"XYZABCUVW\"",
                )
            })?;
            if let Some(l) = b"XYZ".iter().find(|l| !axes.contains(**l)) {
                return Err(at.error(
                    a.span().start,
                    format!(
                        "axes has no {}: volcomp compensates machines with X, Y and Z",
                        *l as char
                    ),
                    "list X, Y and Z and the machine's other axes",
                ));
            }
            setup.axes = axes;
        }
        let base = std::path::Path::new(file).parent();
        for dir in &raw.subroutine_path {
            let d = std::path::PathBuf::from(dir);
            setup.subroutine_path.push(match base {
                Some(b) if d.is_relative() => b.join(d),
                _ => d,
            });
        }
        for (name, a) in &raw.work_offsets {
            let upper = name.get_ref().to_ascii_uppercase();
            let i = WORK_SYSTEMS
                .iter()
                .position(|w| *w == upper)
                .ok_or_else(|| {
                    at.error(
                        name.span().start,
                        format!("unknown work offset `{}`", name.get_ref()),
                        &format!("use one of {}", WORK_SYSTEMS.join(", ")),
                    )
                })?;
            setup.work_offsets_mm[i] = at.vec(name.get_ref(), a, k)?;
            setup.work_offsets_given[i] = true;
        }
        setup.tool_lengths_mm = tool_table(&at, &raw.tools, "length", k)?;
        setup.tool_diameters_mm = tool_table(&at, &raw.tool_diameters, "diameter", k)?;
        if let Some(var) = &raw.var_file {
            if !raw.work_offsets.is_empty() || !raw.reference.is_empty() {
                return Err(at.error(
                    var.span().start,
                    "the set-up gives both a var_file and [work_offsets] or [reference]".into(),
                    "give the offsets and reference points in one place: the var file (LinuxCNC's own) or the set-up's tables",
                ));
            }
            let path = std::path::PathBuf::from(var.get_ref());
            let path = match base {
                Some(b) if path.is_relative() => b.join(path),
                _ => path,
            };
            // Recorded as read (volcomp_geom::inputs): no output may replace it.
            let role = format!("the var file named in {}", crate::error::escape_name(file));
            let text = volcomp_geom::inputs::read_to_string(&path, &role).map_err(|e| {
                at.error(
                    var.span().start,
                    format!("cannot read the var file {}: {e}", path.display()),
                    "check the path (relative paths are relative to the set-up file)",
                )
            })?;
            let shown = path.display().to_string();
            let params = crate::varfile::parse(&text, &shown)?;
            crate::varfile::apply(&mut setup, &params, k, &shown)?;
        }
        for (name, a) in &raw.reference {
            match name.get_ref().to_ascii_uppercase().as_str() {
                "G28" => {
                    setup.g28_mm = at.vec("G28", a, k)?;
                    setup.g28_given = true;
                }
                "G30" => {
                    setup.g30_mm = at.vec("G30", a, k)?;
                    setup.g30_given = true;
                }
                _ => {
                    return Err(at.error(
                        name.span().start,
                        format!("unknown reference point `{}`", name.get_ref()),
                        "use G28 or G30",
                    ))
                }
            }
        }
        if let Some(l) = &raw.limits {
            setup.limits = Some(motion_limits(&at, l, k)?);
        }
        Ok(setup)
    }
}

/// The `[limits]` table, each value checked (positive, finite) and located
/// when refused; lengths converted to mm.
fn motion_limits(at: &At<'_>, raw: &RawLimits, k: f64) -> Result<MotionLimits, SetupError> {
    let positive = |name: &str, v: &Sp<f64>| -> Result<f64, SetupError> {
        let x = *v.get_ref();
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(at.error(
                v.span().start,
                format!("limits.{name} must be a positive number; got {x}"),
                "write the value from the machine's LinuxCNC INI file",
            ))
        }
    };
    let per_axis = |name: &str, v: &Sp<PerAxis>| -> Result<[f64; 3], SetupError> {
        let vals = match v.get_ref() {
            PerAxis::All(x) => [*x; 3],
            PerAxis::Each(xs) if xs.len() == 3 => [xs[0], xs[1], xs[2]],
            PerAxis::Each(xs) => {
                return Err(at.error(
                    v.span().start,
                    format!(
                        "limits.{name} has {} value(s); give one for all axes or three (X, Y, Z)",
                        xs.len()
                    ),
                    "write e.g. [166.7, 166.7, 100.0]",
                ))
            }
        };
        if let Some(bad) = vals.iter().find(|x| !(x.is_finite() && **x > 0.0)) {
            return Err(at.error(
                v.span().start,
                format!("limits.{name} must be positive numbers; got {bad}"),
                "write the axes' values from the machine's LinuxCNC INI file",
            ));
        }
        Ok(vals.map(|x| x * k))
    };
    let mut out = MotionLimits {
        arc_blend_enable: raw.arc_blend_enable,
        ..MotionLimits::default()
    };
    if let Some(v) = &raw.max_velocity {
        out.max_velocity_mm_s = Some(per_axis("max_velocity", v)?);
    }
    if let Some(v) = &raw.max_acceleration {
        out.max_acceleration_mm_s2 = Some(per_axis("max_acceleration", v)?);
    }
    if let Some(v) = &raw.traj_max_velocity {
        out.traj_max_velocity_mm_s = Some(positive("traj_max_velocity", v)? * k);
    }
    if let Some(v) = &raw.servo_period {
        let p = positive("servo_period", v)?;
        if p > 0.1 {
            return Err(at.error(
                v.span().start,
                format!(
                    "limits.servo_period is in seconds (LinuxCNC's SERVO_PERIOD is in ns); got {p}"
                ),
                "write e.g. 0.001 for SERVO_PERIOD = 1000000",
            ));
        }
        out.servo_period_s = Some(p);
    }
    if let Some(v) = &raw.max_feed_override {
        out.max_feed_override = Some(positive("max_feed_override", v)?);
    }
    if let Some(v) = &raw.arc_blend_optimization_depth {
        let d = *v.get_ref();
        if !(0..=10_000).contains(&d) {
            return Err(at.error(
                v.span().start,
                format!("limits.arc_blend_optimization_depth must be 0 … 10000; got {d}"),
                "LinuxCNC's default is 50",
            ));
        }
        out.arc_blend_optimization_depth = Some(d as u32);
    }
    if let Some(v) = &raw.arc_blend_gap_cycles {
        let g = *v.get_ref();
        if !(g.is_finite() && g >= 0.0) {
            return Err(at.error(
                v.span().start,
                format!("limits.arc_blend_gap_cycles must be zero or positive; got {g}"),
                "LinuxCNC's default is 4",
            ));
        }
        out.arc_blend_gap_cycles = Some(g);
    }
    if let Some(v) = &raw.arc_blend_ramp_freq {
        out.arc_blend_ramp_freq_hz = Some(positive("arc_blend_ramp_freq", v)?);
    }
    if let Some(v) = &raw.arc_blend_kink_ratio {
        out.arc_blend_kink_ratio = Some(positive("arc_blend_kink_ratio", v)?);
    }
    Ok(out)
}

/// A table of one number per tool (`[tools]` lengths, `[tool_diameters]`),
/// in mm; keys `1` or `T1`, each tool once.
fn tool_table(
    at: &At<'_>,
    raw: &BTreeMap<Sp<String>, Sp<f64>>,
    what: &str,
    mm_per_unit: f64,
) -> Result<BTreeMap<u32, f64>, SetupError> {
    let text = at.text;
    let mut out = BTreeMap::new();
    let mut seen: BTreeMap<u32, &Sp<String>> = BTreeMap::new();
    for (name, value) in raw {
        let n: u32 = name
            .get_ref()
            .trim_start_matches(['T', 't'])
            .parse()
            .map_err(|_| {
                at.error(
                    name.span().start,
                    format!("tool `{}` is not a tool number", name.get_ref()),
                    "write the tool number, such as 1 or T1",
                )
            })?;
        if let Some(first) = seen.insert(n, name) {
            let (a, b) = if first.span().start < name.span().start {
                (first, name)
            } else {
                (name, first)
            };
            let (line, _) = line_col(text, a.span().start);
            return Err(at.error(
                b.span().start,
                format!(
                    "`{}` and `{}` (line {line}) both give the {what} of tool {n}",
                    b.get_ref(),
                    a.get_ref()
                ),
                "give each tool once",
            ));
        }
        if !value.get_ref().is_finite() {
            return Err(at.error(
                value.span().start,
                format!("tool {n} {what} is not finite"),
                &format!("write the tool {what} as a finite number"),
            ));
        }
        out.insert(n, value.get_ref() * mm_per_unit);
    }
    Ok(out)
}

/// 1-based line and byte column of `offset`.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text.as_bytes()[..offset.min(text.len())];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |i| i + 1);
    (line, before.len() - start + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The error of reading the set-up `s.toml` holding `text`.
    fn refused(text: &str) -> SetupError {
        Setup::from_toml_in(text, "s.toml").unwrap_err()
    }

    #[test]
    fn parses_a_full_setup() {
        let s = Setup::from_toml(
            "units = \"mm\"\nstart=[1,2,3]\n[work_offsets]\nG55=[10,20,30]\n\"G59.3\"=[1,1,1]\n[tools]\nT2 = 40.5\n[reference]\nG30=[0,0,-5]\n",
        )
        .unwrap();
        assert_eq!(s.work_offsets_mm[1], Vec3::new(10.0, 20.0, 30.0));
        assert_eq!(s.work_offsets_mm[8], Vec3::new(1.0, 1.0, 1.0));
        assert_eq!(s.tool_lengths_mm[&2], 40.5);
        assert_eq!(s.g30_mm.z, -5.0);
        assert_eq!(s.start_mm, Vec3::new(1.0, 2.0, 3.0));
        assert!(s.start_given);
    }

    #[test]
    fn axes_are_read_checked_and_default_to_xyzabc() {
        assert_eq!(Setup::default().axes.letters(), "XYZABC");
        let s = Setup::from_toml("units = \"mm\"\naxes = \"xyz uvw\"\n").unwrap();
        assert_eq!(s.axes.letters(), "XYZUVW");
        assert!(s.axes.contains(b'U') && !s.axes.contains(b'A'));
        let e = refused("units = \"mm\"\naxes = \"XYZQ\"\n");
        assert!(
            e.to_string()
                .starts_with("s.toml:2:12: `Q` is not an axis letter"),
            "{e}"
        );
        let e = Setup::from_toml("units = \"mm\"\naxes = \"XYZX\"\n").unwrap_err();
        assert!(e.message.contains("axis X is given twice"), "{e}");
        let e = Setup::from_toml("units = \"mm\"\naxes = \"XYA\"\n").unwrap_err();
        assert!(e.message.contains("axes has no Z"), "{e}");
    }

    #[test]
    fn refuses_missing_units_and_unknown_names() {
        assert!(Setup::from_toml("[tools]\n1=5\n")
            .unwrap_err()
            .to_string()
            .contains("units"));
        assert!(Setup::from_toml("units=\"mm\"\n[work_offsets]\nG60=[0,0,0]\n").is_err());
        assert!(Setup::from_toml("units=\"cm\"\n").is_err());
    }

    #[test]
    fn positions_need_exactly_three_values() {
        let e = refused("units = \"mm\"\n[work_offsets]\nG54 = [250, 200, 150, 1]\n");
        assert_eq!((e.line, e.column), (3, 7), "{e}");
        assert!(e.to_string().contains("G54 has 4 value(s)"), "{e}");
        let e = refused("units = \"mm\"\nstart = [1, 2]\n");
        assert_eq!((e.line, e.column), (2, 9), "{e}");
        let e = refused("units = \"mm\"\n[reference]\nG28 = [0,0,0,0]\n");
        assert_eq!(e.line, 3, "{e}");
    }

    #[test]
    fn one_tool_given_twice_is_refused() {
        let e = refused("units = \"mm\"\n[tools]\n1 = 75\nT1 = 80\n");
        assert_eq!(e.line, 4, "{e}");
        assert!(
            e.to_string().contains("both give the length of tool 1"),
            "{e}"
        );
        assert!(e.to_string().contains("(line 3)"), "{e}");
    }

    #[test]
    fn limits_are_read_in_the_set_up_units_and_checked() {
        let s = Setup::from_toml(
            "units = \"inch\"\n[limits]\nmax_velocity = 2\nmax_acceleration = [10, 10, 5]\ntraj_max_velocity = 3\nservo_period = 0.0005\narc_blend_enable = false\n",
        )
        .unwrap();
        let l = s.limits.unwrap();
        assert_eq!(l.max_velocity_mm_s, Some([50.8; 3]));
        assert_eq!(l.max_acceleration_mm_s2, Some([254.0, 254.0, 127.0]));
        assert_eq!(l.traj_max_velocity_mm_s, Some(76.19999999999999));
        assert_eq!(l.servo_period_s, Some(0.0005));
        assert_eq!(l.arc_blend_enable, Some(false));
        assert_eq!(Setup::from_toml("units = \"mm\"\n").unwrap().limits, None);
        let e = refused("units = \"mm\"\n[limits]\nmax_velocity = [1, 2]\n");
        assert_eq!((e.line, e.column), (3, 16), "{e}");
        assert!(e.to_string().contains("has 2 value(s)"), "{e}");
        let e = refused("units = \"mm\"\n[limits]\nservo_period = 1000000\n");
        assert!(e.to_string().contains("in seconds"), "{e}");
        let e = refused("units = \"mm\"\n[limits]\nmax_acceleration = -5\n");
        assert_eq!(e.line, 3, "{e}");
        assert!(Setup::from_toml("units = \"mm\"\n[limits]\nmax_jerk = 5\n").is_err());
    }

    #[test]
    fn errors_are_located() {
        let e = refused("units = \"mm\"\n[work_offsets]\nG60 = [0,0,0]\n");
        assert_eq!((e.line, e.column), (3, 1), "{e}");
        assert!(
            e.to_string().starts_with("s.toml:3:1: unknown work offset"),
            "{e}"
        );
        let e = refused("units = \"mm\"\nbogus = 1\n");
        assert_eq!(e.line, 2, "{e}");
        let e = refused("units = \"cm\"\n");
        assert_eq!(e.line, 1, "{e}");
    }
}
