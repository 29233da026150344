//! A modal RS274/NGC interpreter that turns blocks into motions in the axis
//! frame (machine coordinates, mm).
//!
//! It follows LinuxCNC's semantics and order of execution within a block
//! (feed mode, F, S, T, M6, spindle/coolant, dwell, plane, units, cutter
//! compensation, tool length, coordinate system, path control, distance
//! mode, retract mode, G10/G28/G30/G92, motion, stop). The frame relation is
//! the design contract's: `q = p + work_offset + tool_length_offset + G92`.
//!
//! What it does not interpret faithfully it refuses, naming the column: no
//! guess is ever made about a construct's meaning.

use crate::arc::{sweep_angle, Arc};
use crate::error::{ErrorClass, GcodeError};
use crate::geom::{Plane, Units, Vec3};
use crate::lexer::{Lexed, Word};
use crate::setup::Setup;

/// What a motion is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MotionKind {
    /// G0.
    Rapid,
    /// G1.
    Feed,
    /// G2/G3.
    Arc(Arc),
}

impl MotionKind {
    /// `rapid`, `feed`, `arc_cw` or `arc_ccw`.
    pub fn name(&self) -> &'static str {
        match self {
            MotionKind::Rapid => "rapid",
            MotionKind::Feed => "feed",
            MotionKind::Arc(a) if a.clockwise() => "arc_cw",
            MotionKind::Arc(_) => "arc_ccw",
        }
    }
}

/// Where a motion comes from, which decides how compensation treats it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionSource {
    /// An ordinary G0/G1/G2/G3 in the work coordinate system.
    Program,
    /// A G53 one-shot move in machine coordinates.
    Machine,
    /// A G28/G30 move (intermediate point or reference point).
    Reference,
    /// A move expanded from a canned drilling cycle.
    Cycle,
}

/// One motion, in the axis frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Rapid, feed or arc.
    pub kind: MotionKind,
    /// Where it comes from.
    pub source: MotionSource,
    /// Start point (mm, axis frame).
    pub start: Vec3,
    /// End point (mm, axis frame).
    pub end: Vec3,
    /// 1-based source line.
    pub line: u64,
    /// 1-based column of the motion word, or of the first axis word.
    pub column: usize,
    /// Feed rate in mm/min (or inverse-time value under G93).
    pub feed: f64,
}

/// Something the program left unsaid and volcomp assumed, said once per
/// program so the user can check it (the program is still processed).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Warning {
    /// 1-based line where the assumption was first needed.
    pub line: u64,
    /// 1-based column.
    pub column: usize,
    /// What was assumed and what to do if it is wrong.
    pub message: String,
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}:{}: warning: {}",
            self.line, self.column, self.message
        )
    }
}

/// Options that change interpretation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterpOptions {
    /// Accept `K0` on G17 arcs (FreeCAD writes it; LinuxCNC refuses it).
    /// A non-zero K on a G17 arc is refused either way.
    pub accept_k0_on_xy_arcs: bool,
    /// Interpret arc centres as absolute from the start, as if G90.1 began
    /// the program.
    pub absolute_arc_centers: bool,
}

impl Default for InterpOptions {
    fn default() -> Self {
        Self {
            accept_k0_on_xy_arcs: true,
            absolute_arc_centers: false,
        }
    }
}

/// Feed-rate mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FeedMode {
    /// G93: F is the inverse of the block's duration in minutes.
    InverseTime,
    /// G94: units per minute.
    PerMinute,
    /// G95: units per revolution.
    PerRevolution,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum MotionMode {
    Rapid,
    Feed,
    Cw,
    Ccw,
    /// Canned cycle: G81, G82, G85 or G89 (code × 10).
    Cycle(u16),
}

/// The interpreter's modal state.
#[derive(Debug, Clone)]
pub struct Interpreter {
    setup: Setup,
    options: InterpOptions,
    units: Units,
    absolute: bool,
    arc_absolute: bool,
    plane: Plane,
    motion_mode: Option<MotionMode>,
    feed_mode: FeedMode,
    feed: f64,
    /// Last S word (rev/min); G95 feed moves need it non-zero.
    spindle_rpm: f64,
    /// The plane before the current block's own G17/G18/G19: LinuxCNC checks
    /// polar words against it (`enhance_block` runs before the block).
    plane_before_block: Plane,
    work: usize,
    work_offsets: [Vec3; 9],
    g92: Vec3,
    g92_saved: Vec3,
    tlo: Vec3,
    loaded_tool: u32,
    next_tool: u32,
    position: Vec3,
    retract_to_r: bool,
    /// Sticky R word of the canned cycle (program units, as written).
    cycle_r: Option<f64>,
    /// Sticky Z word of the canned cycle (program units, as written).
    cycle_z: Option<f64>,
    /// Z (axis frame) when the current run of cycle blocks began (`cycle_il`).
    cycle_start_z: Option<f64>,
    /// Sticky dwell P of G82/G89 (seconds).
    cycle_p: Option<f64>,
    finished: bool,
    percent_lines: u32,
    /// Whether the program has said G20 or G21.
    units_given: bool,
    /// Assumptions made so far, in program order.
    warnings: Vec<Warning>,
    warned_units: bool,
    warned_reference: [bool; 2],
    /// The current block's words; `None` only while the block runs.
    words: Option<Box<WordTable>>,
}

/// The words of one block by letter, plus its G and M codes.
#[derive(Debug, Clone, Default)]
struct WordTable {
    /// `A`–`Z`, then LinuxCNC's polar words `@` (radius) and `^` (angle).
    values: [Option<(f64, usize)>; 28],
    /// Column of an `E` word written right after another word's number
    /// (`X1e-05`): scientific notation, read by LinuxCNC as an E word.
    exponent_col: Option<usize>,
    g: Vec<(u16, usize)>,
    m: Vec<(u16, usize)>,
}

/// Slot of a word letter in [`WordTable::values`].
fn slot_of(letter: u8) -> usize {
    match letter {
        b'@' => 26,
        b'^' => 27,
        _ => usize::from(letter - b'A'),
    }
}

impl WordTable {
    fn get(&self, letter: u8) -> Option<f64> {
        self.values[slot_of(letter)].map(|(v, _)| v)
    }
    fn col(&self, letter: u8) -> Option<usize> {
        self.values[slot_of(letter)].map(|(_, c)| c)
    }
    /// Whether the block has a polar word (`@` radius or `^` angle).
    fn has_polar(&self) -> bool {
        self.get(b'@').is_some() || self.get(b'^').is_some()
    }
    fn polar_col(&self) -> Option<usize> {
        self.col(b'@').or(self.col(b'^'))
    }
    fn has_axis(&self) -> bool {
        self.get(b'X').is_some() || self.get(b'Y').is_some() || self.get(b'Z').is_some()
    }
    fn has_g(&self, code: u16) -> bool {
        self.g.iter().any(|(c, _)| *c == code)
    }
    fn g_col(&self, code: u16) -> Option<usize> {
        self.g.iter().find(|(c, _)| *c == code).map(|(_, col)| *col)
    }
    /// `Some(true)` when the block has `on`, `Some(false)` when it has `off`
    /// (two codes of one modal group, so never both).
    fn switch(&self, on: u16, off: u16) -> Option<bool> {
        if self.has_g(on) {
            Some(true)
        } else if self.has_g(off) {
            Some(false)
        } else {
            None
        }
    }
    fn has_m(&self, code: u16) -> bool {
        self.m.iter().any(|(c, _)| *c == code)
    }
}

/// Modal group of a supported G code (×10), or why it is refused.
fn g_group(code: u16) -> Result<u8, &'static str> {
    Ok(match code {
        0 | 10 | 20 | 30 | 800 | 810 | 820 | 850 | 890 => 1,
        170 | 180 | 190 => 2,
        900 | 910 => 3,
        901 | 911 => 4,
        930 | 940 | 950 => 5,
        200 | 210 => 6,
        400 => 7,
        430 | 431 | 490 => 8,
        980 | 990 => 10,
        540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => 12,
        610 | 611 | 640 => 13,
        960 | 970 => 14,
        150 | 500 | 690 => 16, // cancel polar / scaling / rotation: no-ops here
        40 | 100 | 280 | 281 | 300 | 301 | 530 | 920 | 921 | 922 | 923 => 0,
        410 | 411 | 420 | 421 => return Err("cutter radius compensation (G41/G42) changes the path by the tool radius, which volcomp does not model; post the program with compensation computed in CAM (\"in computer\"), or pass it through without volcomp"),
        680 | 681 => return Err("coordinate rotation (G68) is not a pure translation between program and axis frame; post the program without rotation"),
        510 | 511 => return Err("scaling (G51) is not a pure translation between program and axis frame; post the program without scaling"),
        160 => return Err("polar coordinates (G16) are not interpreted; post the program in Cartesian coordinates"),
        520 => return Err("G52 local offsets are not interpreted yet; use G92 or a work offset"),
        730 | 760 | 830 | 840 | 860 | 870 | 880 => return Err("this canned cycle is not expanded by volcomp (G81, G82, G85 and G89 are); post the cycle as explicit moves"),
        50 | 51 | 52 | 53 | 70 | 80 | 330 | 331 | 380..=385 | 430..=439 => return Err("this G code moves the machine in a way volcomp does not model"),
        _ => return Err("unknown G code"),
    })
}

/// Largest absolute machine coordinate volcomp accepts (mm): 100 m, beyond
/// the travel of the largest machine tools (gantry mills reach some tens of
/// metres) and far beyond any error map. A coordinate past it is a typo, a
/// wrong unit or a runaway offset; refusing it here, before any move is split
/// or solved, keeps the work per block bounded. LinuxCNC itself accepts any
/// finite double and stops at the soft limits of the machine's INI file
/// (`[AXIS_n]MIN_LIMIT`/`MAX_LIMIT`); volcomp has no INI file, so it uses
/// this generous fixed bound. In inch programs it is 3937 in.
pub const MAX_COORDINATE_MM: f64 = 100_000.0;

/// Refuses a point (axis frame, mm) with a coordinate beyond
/// [`MAX_COORDINATE_MM`] or not finite.
fn check_reach(line: u64, col: usize, what: &str, p: Vec3) -> Result<(), GcodeError> {
    for (a, letter) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        let v = p[a];
        if v.is_nan() || v.abs() > MAX_COORDINATE_MM {
            return Err(invalid(
                line,
                col,
                format!(
                    "the {what} of this move has {letter} = {v:e} mm in machine coordinates, beyond the ±{MAX_COORDINATE_MM} mm volcomp accepts"
                ),
                "check the coordinate, the units (G20/G21) and the offsets (G92, G10, work offsets) in effect",
            ));
        }
    }
    Ok(())
}

fn invalid(line: u64, col: usize, msg: impl Into<String>, help: impl Into<String>) -> GcodeError {
    GcodeError::new(ErrorClass::Invalid, line, col + 1, msg, help)
}

fn unsupported(
    line: u64,
    col: usize,
    msg: impl Into<String>,
    help: impl Into<String>,
) -> GcodeError {
    GcodeError::new(ErrorClass::Unsupported, line, col + 1, msg, help)
}

fn code_of(value: f64) -> Option<u16> {
    let c = (value * 10.0).round();
    if (value * 10.0 - c).abs() > 1e-6 || !(0.0..=9999.0).contains(&c) {
        return None;
    }
    Some(c as u16)
}

fn code_name(letter: char, code: u16) -> String {
    if code.is_multiple_of(10) {
        format!("{letter}{}", code / 10)
    } else {
        format!("{letter}{}.{}", code / 10, code % 10)
    }
}

impl Interpreter {
    /// A fresh interpreter in LinuxCNC's start state (G17 G21 G90 G91.1 G94
    /// G54 G49, no motion mode) with the machine at `setup.start_mm`.
    pub fn new(setup: Setup, options: InterpOptions) -> Self {
        let work_offsets = setup.work_offsets_mm;
        let position = setup.start_mm;
        Self {
            setup,
            options,
            units: Units::Mm,
            absolute: true,
            arc_absolute: options.absolute_arc_centers,
            plane: Plane::Xy,
            motion_mode: None,
            feed_mode: FeedMode::PerMinute,
            feed: 0.0,
            spindle_rpm: 0.0,
            plane_before_block: Plane::Xy,
            work: 0,
            work_offsets,
            g92: Vec3::ZERO,
            g92_saved: Vec3::ZERO,
            tlo: Vec3::ZERO,
            loaded_tool: 0,
            next_tool: 0,
            position,
            retract_to_r: true,
            cycle_r: None,
            cycle_z: None,
            cycle_start_z: None,
            cycle_p: None,
            finished: false,
            percent_lines: 0,
            units_given: false,
            warnings: Vec::new(),
            warned_units: false,
            warned_reference: [false; 2],
            words: Some(Box::default()),
        }
    }

    /// The current commanded position (mm, axis frame).
    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// `q − p`: what is added to a program position (in mm) to get the axis
    /// position, i.e. work offset + G92 + tool length offset.
    pub fn frame_offset_mm(&self) -> Vec3 {
        self.work_offsets[self.work] + self.g92 + self.tlo
    }

    /// The tool length offset in effect (G43 `(0, 0, L)`, G43.1 any vector,
    /// zero after G49), in mm: the part of [`Interpreter::frame_offset_mm`]
    /// that comes from the tool.
    pub fn tool_length_offset_mm(&self) -> Vec3 {
        self.tlo
    }

    /// Program units in effect.
    pub fn units(&self) -> Units {
        self.units
    }

    /// Whether G90 (absolute) is in effect.
    pub fn absolute(&self) -> bool {
        self.absolute
    }

    /// The canned cycle in effect (81, 82, 85 or 89) and, for G82/G89, the
    /// dwell at the bottom in seconds.
    pub fn canned_cycle(&self) -> Option<(u16, Option<f64>)> {
        match self.motion_mode {
            Some(MotionMode::Cycle(code)) => {
                let dwell = matches!(code, 820 | 890).then_some(self.cycle_p).flatten();
                Some((code / 10, dwell))
            }
            _ => None,
        }
    }

    /// Feed mode in effect.
    pub fn feed_mode(&self) -> FeedMode {
        self.feed_mode
    }

    /// Whether the program has ended (M2, M30 or the closing `%`); later
    /// lines are not executed, as on a controller.
    pub fn finished(&self) -> bool {
        self.finished
    }

    /// What volcomp assumed because the program did not say it (at most one
    /// warning of each kind per program).
    pub fn warnings(&self) -> &[Warning] {
        &self.warnings
    }

    /// Notes a `%` line: the second one ends the program.
    pub fn percent_line(&mut self) {
        self.percent_lines += 1;
        if self.percent_lines >= 2 {
            self.finished = true;
        }
    }

    /// Executes one lexed block, appending its motions to `out`.
    pub fn execute(
        &mut self,
        line: u64,
        lexed: &Lexed,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        if self.finished {
            return Ok(());
        }
        self.collect_words(line, lexed)?;
        let before = out.len();
        self.run_block(line, out)?;
        if out.len() > before && !self.units_given && !self.warned_units {
            self.warned_units = true;
            self.warnings.push(Warning {
                line,
                column: out[before].column,
                message: "the program moves before it selects its units (no G20 or G21 yet): millimetres (G21) are assumed, LinuxCNC's usual start-up state; if the program is in inches, add G20 at its start".into(),
            });
        }
        Ok(())
    }

    fn collect_words(&mut self, line: u64, lexed: &Lexed) -> Result<(), GcodeError> {
        let w = self.words.get_or_insert_with(Box::default);
        w.values = [None; 28];
        w.exponent_col = None;
        w.g.clear();
        w.m.clear();
        let mut prev_number_end = None;
        for word in lexed.words() {
            if word.letter == b'E' && prev_number_end == Some(word.span.start) {
                w.exponent_col = Some(word.span.start);
            }
            prev_number_end = Some(word.span.end);
            let Word {
                letter,
                value,
                span,
                ..
            } = word;
            let col = span.start;
            match letter {
                b'G' => {
                    let code = code_of(*value).ok_or_else(|| {
                        invalid(
                            line,
                            col,
                            format!("G{value} is not a G code"),
                            "G codes have at most one decimal, e.g. G59.1",
                        )
                    })?;
                    let group = g_group(code).map_err(|why| {
                        unsupported(
                            line,
                            col,
                            format!("{} is not supported: {why}", code_name('G', code)),
                            "remove or replace this code; volcomp never guesses what a code means",
                        )
                    })?;
                    // LinuxCNC accepts G80 beside G0/G1 (`G00 G17 G40 G49 G80 G90`,
                    // a common safe-start line): the cycle is cancelled and the
                    // other motion code takes effect.
                    let g80_pair = |a: u16, b: u16| a == 800 || b == 800;
                    if let Some((other, _)) = w.g.iter().find(|(c, _)| {
                        group != 0 && g_group(*c) == Ok(group) && !g80_pair(*c, code)
                    }) {
                        return Err(invalid(
                            line,
                            col,
                            format!(
                                "{} and {} are in the same modal group",
                                code_name('G', *other),
                                code_name('G', code)
                            ),
                            "keep one of them on this line",
                        ));
                    }
                    w.g.push((code, col));
                }
                b'M' => {
                    let code = code_of(*value).filter(|c| c % 10 == 0).ok_or_else(|| {
                        invalid(
                            line,
                            col,
                            format!("M{value} is not an M code"),
                            "M codes are whole numbers",
                        )
                    })?;
                    if matches!(code, 980 | 990) {
                        return Err(unsupported(
                            line,
                            col,
                            "M98/M99 subprogram calls are not interpreted",
                            "expand the subprogram in CAM",
                        ));
                    }
                    w.m.push((code, col));
                }
                b'A' | b'B' | b'C' | b'U' | b'V' | b'W' => {
                    return Err(unsupported(line, col, format!("axis word {} is not supported: volcomp compensates 3-axis (X, Y, Z) machines", *letter as char), "remove rotary/extra axis words or use a 3-axis program"));
                }
                b'N' if w.values[slot_of(b'N')].is_none() => {
                    w.values[slot_of(b'N')] = Some((*value, col));
                }
                _ => {
                    let slot = &mut w.values[slot_of(*letter)];
                    if slot.is_some() {
                        return Err(invalid(
                            line,
                            col,
                            format!("{} word given twice on one line", *letter as char),
                            "remove one of them",
                        ));
                    }
                    *slot = Some((*value, col));
                }
            }
        }
        Ok(())
    }

    /// The motion a block will make, as LinuxCNC's `enhance_block` decides
    /// it: the block's own group-1 code, else the modal motion when the block
    /// has axis or polar words, or arc centre words in an arc mode.
    fn motion_to_be(&self, w: &WordTable) -> Option<MotionMode> {
        for (code, mode) in [
            (0u16, MotionMode::Rapid),
            (10, MotionMode::Feed),
            (20, MotionMode::Cw),
            (30, MotionMode::Ccw),
            (810, MotionMode::Cycle(810)),
            (820, MotionMode::Cycle(820)),
            (850, MotionMode::Cycle(850)),
            (890, MotionMode::Cycle(890)),
        ] {
            if w.has_g(code) {
                return Some(mode);
            }
        }
        if w.has_g(800) || [100u16, 280, 300, 920].iter().any(|c| w.has_g(*c)) {
            return None;
        }
        let ijk = [b'I', b'J', b'K'].iter().any(|l| w.get(*l).is_some());
        match self.motion_mode {
            m if w.has_axis() || w.has_polar() => m,
            m @ Some(MotionMode::Cw | MotionMode::Ccw) if ijk => m,
            _ => None,
        }
    }

    /// Refuses words that no code of the block uses, as LinuxCNC's
    /// `Interp::check_other_codes` (src/emc/rs274ngc/interp_check.cc) does
    /// for the codes volcomp interprets: a stray word is a sign that the
    /// program means something volcomp (and the controller) would not do.
    fn check_word_use(&self, line: u64, w: &WordTable) -> Result<(), GcodeError> {
        let motion = self.motion_to_be(w);
        let arc = matches!(motion, Some(MotionMode::Cw | MotionMode::Ccw));
        let cycle = matches!(motion, Some(MotionMode::Cycle(_)));
        let g10 = w.has_g(100);
        let m_any = |codes: &[u16]| codes.iter().any(|c| w.has_m(*c));
        let used = |letter: u8| -> Result<(), &'static str> {
            let (ok, why) = match letter {
                b'D' => (w.has_g(960), "D word with no G41, G41.1, G42, G42.1 or G96 to use it"),
                b'E' => (m_any(&[660, 670, 680]), "E word with no G70, G76, M66, M67 or M68 to use it"),
                b'H' => (w.has_g(430), "H word with no G43 or G76 to use it"),
                b'I' => (arc || g10, "I word with no G2, G3 or G10 to use it"),
                b'J' => (arc || g10, "J word with no G2, G3 or G10 to use it"),
                b'K' => (arc, "K word with no G2 or G3 to use it"),
                b'L' => (cycle || g10 || m_any(&[660]), "L word with no G10, canned cycle or M66 to use it"),
                b'P' => (
                    g10 || w.has_g(40) || w.has_g(640) || arc
                        || matches!(motion, Some(MotionMode::Cycle(820 | 890)))
                        || m_any(&[500, 510, 520, 530, 620, 630, 640, 650, 660, 190]),
                    "P word with no G2, G3, G4, G10, G64, G82, G89 or M19, M50–M53, M62–M66 to use it",
                ),
                b'Q' => (
                    g10 || w.has_g(640) || m_any(&[660, 670, 680, 610, 190]),
                    "Q word with no G10, G64, M19, M61, M66, M67 or M68 to use it",
                ),
                b'R' => (
                    arc || cycle || g10 || w.has_g(640) || m_any(&[190]),
                    "R word with no G2, G3, canned cycle, G10, G64 or M19 to use it",
                ),
                _ => (true, ""),
            };
            if ok {
                Ok(())
            } else {
                Err(why)
            }
        };
        for letter in *b"DEHIJKLPQR" {
            let Some(col) = w.col(letter) else { continue };
            if let Err(why) = used(letter) {
                if letter == b'E' && w.exponent_col == Some(col) {
                    return Err(invalid(
                        line,
                        col,
                        "scientific notation (such as `1e-05`) is not G-code: the `e` starts an E word, which LinuxCNC refuses here (\"E word with no G70, G76, M66, M67 or M68 to use it\")",
                        "write the number in plain decimals, e.g. X0.00001 instead of X1e-05",
                    ));
                }
                return Err(invalid(
                    line,
                    col,
                    format!("{why}; LinuxCNC refuses it too"),
                    format!(
                        "remove the {} word, or add the code that uses it",
                        letter as char
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Refuses a feed move that LinuxCNC would refuse for want of a feed
    /// rate (`Interp::convert_straight`, `convert_arc` and `convert_cycle` in
    /// interp_convert.cc / interp_cycles.cc): F0 (or no F yet) in G94/G95,
    /// or no F on the block itself under inverse time (G93).
    fn check_feed(&self, line: u64, w: &WordTable, col: usize) -> Result<(), GcodeError> {
        let Some(mode) = self.motion_to_be(w) else {
            return Ok(());
        };
        let what = match mode {
            MotionMode::Rapid => return Ok(()),
            MotionMode::Feed => "Cannot do g1 with zero feed rate",
            MotionMode::Cw | MotionMode::Ccw => "Cannot make arc with zero feed rate",
            MotionMode::Cycle(_) => "Cannot feed with zero feed rate",
        };
        if self.feed_mode == FeedMode::InverseTime {
            if w.get(b'F').is_none() && !matches!(mode, MotionMode::Cycle(_)) {
                return Err(invalid(
                    line,
                    col,
                    "F word missing with an inverse-time (G93) feed move: under G93 every feed move needs its own F",
                    "give F (1 / minutes the move takes) on this line",
                ));
            }
            return Ok(());
        }
        if self.feed == 0.0 {
            let given = match w.col(b'F') {
                Some(_) => "F0 is on this line",
                None => "no F word has set a feed rate yet",
            };
            return Err(invalid(
                line,
                w.col(b'F').unwrap_or(col),
                format!(
                    "a feed move with zero feed rate ({given}); LinuxCNC refuses it: \"{what}\""
                ),
                "set the feed rate with an F word (e.g. F500) on or before this line",
            ));
        }
        if self.feed_mode == FeedMode::PerRevolution && self.spindle_rpm == 0.0 {
            return Err(invalid(
                line,
                col,
                "a feed move in feed per revolution (G95) with zero spindle speed would not move; LinuxCNC refuses it (\"Cannot feed with zero spindle speed in feed per rev mode\")",
                "set the spindle speed with an S word on or before this line, or use G94",
            ));
        }
        Ok(())
    }

    fn to_mm(&self, v: f64) -> f64 {
        v * self.units.mm_per_unit()
    }

    /// Target of axis words in the current coordinate system.
    fn target(&self, w: &WordTable) -> Vec3 {
        let off = self.frame_offset_mm();
        let mut t = self.position;
        for (i, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if let Some(v) = w.get(letter) {
                t[i] = if self.absolute {
                    self.to_mm(v) + off[i]
                } else {
                    t[i] + self.to_mm(v)
                };
            }
        }
        if let Some((x, y)) = self.polar_end(w) {
            t.x = self.to_mm(x) + off.x;
            t.y = self.to_mm(y) + off.y;
        }
        t
    }

    /// The XY end point (program units, current coordinate system) of a
    /// block with polar words, as LinuxCNC's `Interp::find_ends`
    /// (src/emc/rs274ngc/interp_find.cc) computes it: `@` is the radius and
    /// `^` the angle in degrees about the origin of the current coordinate
    /// system. In G90 a missing one is taken from the current point; in G91
    /// `@` is added to the current radius and `^` to the current angle.
    /// `None` when the block has no polar word. [`Self::check_polar`] has
    /// refused the indeterminate cases (at the origin) beforehand.
    fn polar_end(&self, w: &WordTable) -> Option<(f64, f64)> {
        let (radius, theta_deg) = (w.get(b'@'), w.get(b'^'));
        if radius.is_none() && theta_deg.is_none() {
            return None;
        }
        let off = self.frame_offset_mm();
        let k = 1.0 / self.units.mm_per_unit();
        let (cx, cy) = ((self.position.x - off.x) * k, (self.position.y - off.y) * k);
        let polar = |r: f64, theta_rad: f64| (r * theta_rad.cos(), r * theta_rad.sin());
        Some(if self.absolute {
            match (radius, theta_deg) {
                (Some(r), Some(a)) => polar(r, a.to_radians()),
                (Some(r), None) => polar(r, cy.atan2(cx)),
                (None, Some(a)) => polar(cy.hypot(cx), a.to_radians()),
                (None, None) => unreachable!("checked above"),
            }
        } else {
            let (mut px, mut py) = (cx, cy);
            if let Some(r) = radius {
                (px, py) = polar(py.hypot(px) + r, py.atan2(px));
            }
            if let Some(a) = theta_deg {
                (px, py) = polar(py.hypot(px), py.atan2(px) + a.to_radians());
            }
            (px, py)
        })
    }

    /// Refuses polar words where LinuxCNC does (`Interp::enhance_block`,
    /// `Interp::find_ends`): outside G17, beside X or Y, with G53 or a
    /// canned cycle, or where the angle is undefined (at the origin).
    fn check_polar(&self, line: u64, w: &WordTable, mode: MotionMode) -> Result<(), GcodeError> {
        let Some(col) = w.polar_col() else {
            return Ok(());
        };
        let refuse = |msg: &str, help: &str| Err(invalid(line, col, msg, help));
        if self.plane_before_block != Plane::Xy {
            return refuse(
                "polar coordinates (@, ^) are only defined in the XY plane (G17); LinuxCNC refuses them while G18 or G19 is in effect (\"Cannot use polar coordinate except in G17 plane\")",
                "switch to G17 or give X/Y/Z words",
            );
        }
        if let Some(c) = w.col(b'X').or(w.col(b'Y')) {
            return Err(invalid(
                line,
                c,
                "cannot give both polar coordinates (@, ^) and an X or Y word",
                "give the end point either as @ radius and ^ angle or as X and Y",
            ));
        }
        if w.has_g(530) {
            return refuse(
                "polar coordinates cannot be used with G53",
                "give X/Y words with G53",
            );
        }
        if matches!(mode, MotionMode::Cycle(_)) {
            return refuse(
                "polar coordinates are not interpreted in canned cycles",
                "give the hole position as X and Y",
            );
        }
        let off = self.frame_offset_mm();
        let at_origin = self.position.x == off.x && self.position.y == off.y;
        if at_origin && (!self.absolute || w.get(b'^').is_none()) {
            return refuse(
                if self.absolute {
                    "a polar radius without an angle is indeterminate at the origin; LinuxCNC refuses it (\"Must specify angle in polar coordinate if at the origin\")"
                } else {
                    "incremental (G91) polar motion is indeterminate at the origin; LinuxCNC refuses it"
                },
                "give the angle with ^, or start away from the origin",
            );
        }
        Ok(())
    }

    fn run_block(&mut self, line: u64, out: &mut Vec<Motion>) -> Result<(), GcodeError> {
        // The table is moved out and back so its buffers are reused, not cloned.
        // Taken out (no allocation) so the block can be read while the
        // interpreter changes, and put back for the next line to reuse.
        let w = self.words.take().unwrap_or_default();
        let result = self.run_words(line, &w, out);
        self.words = Some(w);
        result
    }

    fn run_words(
        &mut self,
        line: u64,
        w: &WordTable,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        self.plane_before_block = self.plane;
        // 1-3: feed mode, feed rate.
        if w.has_g(930) {
            self.feed_mode = FeedMode::InverseTime;
        } else if w.has_g(940) {
            self.feed_mode = FeedMode::PerMinute;
        } else if w.has_g(950) {
            self.feed_mode = FeedMode::PerRevolution;
        }
        if let Some(f) = w.get(b'F') {
            if f < 0.0 {
                return Err(invalid(
                    line,
                    w.col(b'F').unwrap_or(0),
                    "negative feed rate",
                    "F must be positive",
                ));
            }
            self.feed = f;
        }
        if let Some(s) = w.get(b'S') {
            if s < 0.0 {
                return Err(invalid(
                    line,
                    w.col(b'S').unwrap_or(0),
                    "negative spindle speed",
                    "S must be zero or positive",
                ));
            }
            self.spindle_rpm = s;
        }
        // Checks of the whole block before anything changes state: words
        // nothing uses, feed moves without a feed rate (G93 and F are set).
        self.check_word_use(line, w)?;
        let motion_col = self
            .motion_word_col(w)
            .or_else(|| {
                [b'X', b'Y', b'Z', b'@', b'^']
                    .into_iter()
                    .find_map(|l| w.col(l))
            })
            .unwrap_or(0);
        self.check_feed(line, w, motion_col)?;
        // 5-6: tool select and change.
        if let Some(t) = w.get(b'T') {
            if t < 0.0 || t.fract() != 0.0 {
                return Err(invalid(
                    line,
                    w.col(b'T').unwrap_or(0),
                    "T must be a non-negative whole number",
                    "fix the tool number",
                ));
            }
            self.next_tool = t as u32;
        }
        if w.has_m(60) {
            self.loaded_tool = self.next_tool;
        }
        if w.has_m(610) {
            let q = w
                .get(b'Q')
                .ok_or_else(|| invalid(line, 0, "M61 needs a Q word", "write M61 Qn"))?;
            self.loaded_tool = q.max(0.0) as u32;
        }
        // 10: dwell (passed through).
        if w.has_g(40) && w.get(b'P').is_none() {
            return Err(invalid(
                line,
                w.g_col(40).unwrap_or(0),
                "G4 dwell without P",
                "write G4 Pseconds",
            ));
        }
        // 11-12: plane, units.
        if w.has_g(170) {
            self.plane = Plane::Xy;
        } else if w.has_g(180) {
            self.plane = Plane::Zx;
        } else if w.has_g(190) {
            self.plane = Plane::Yz;
        }
        if w.has_g(200) {
            self.units = Units::Inch;
            self.units_given = true;
        } else if w.has_g(210) {
            self.units = Units::Mm;
            self.units_given = true;
        }
        // 14: tool length offset.
        if w.has_g(430) {
            let col = w.g_col(430).unwrap_or(0);
            let h = match w.get(b'H') {
                // rs274 treats H0 like a missing H: the loaded tool.
                Some(0.0) => self.loaded_tool,
                Some(h) if h > 0.0 && h.fract() == 0.0 => h as u32,
                Some(_) => {
                    return Err(invalid(
                        line,
                        w.col(b'H').unwrap_or(col),
                        "H must be a non-negative whole number",
                        "fix the H word",
                    ))
                }
                None => self.loaded_tool,
            };
            let length = if h == 0 {
                0.0
            } else {
                *self.setup.tool_lengths_mm.get(&h).ok_or_else(|| {
                    invalid(
                        line,
                        col,
                        format!("G43 uses tool {h}, which the setup has no length for"),
                        format!("add `{h} = LENGTH` under [tools] in the setup file (--setup)"),
                    )
                })?
            };
            self.tlo = Vec3::new(0.0, 0.0, length);
        } else if w.has_g(431) {
            let mut tlo = Vec3::ZERO;
            for (i, l) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
                tlo[i] = w.get(l).map(|v| self.to_mm(v)).unwrap_or(0.0);
            }
            self.tlo = tlo;
        } else if w.has_g(490) {
            self.tlo = Vec3::ZERO;
        }
        // 15: coordinate system.
        for (i, code) in [540, 550, 560, 570, 580, 590, 591, 592, 593]
            .into_iter()
            .enumerate()
        {
            if w.has_g(code) {
                self.work = i;
            }
        }
        // 17: distance modes; 18: retract mode.
        if let Some(on) = w.switch(900, 910) {
            self.absolute = on;
        }
        if let Some(on) = w.switch(901, 911) {
            self.arc_absolute = on;
        }
        if let Some(on) = w.switch(990, 980) {
            self.retract_to_r = on;
        }
        // Motion mode changes.
        if w.has_g(800) {
            self.motion_mode = None;
        }
        for (code, mode) in [
            (0u16, MotionMode::Rapid),
            (10, MotionMode::Feed),
            (20, MotionMode::Cw),
            (30, MotionMode::Ccw),
        ] {
            if w.has_g(code) {
                self.motion_mode = Some(mode);
            }
        }
        let mode_before = self.motion_mode;
        for code in [810u16, 820, 850, 890] {
            if w.has_g(code) {
                self.motion_mode = Some(MotionMode::Cycle(code));
            }
        }
        if !matches!(self.motion_mode, Some(MotionMode::Cycle(_))) {
            self.cycle_start_z = None;
        }
        let new_cycle = self.motion_mode != mode_before;
        // 19: non-modal codes that use axis words.
        let axis_user = [100u16, 280, 300, 920, 431]
            .into_iter()
            .find(|c| w.has_g(*c));
        if w.has_g(100) {
            self.g10(line, w)?;
        } else if w.has_g(280) || w.has_g(300) {
            self.home(line, w, w.has_g(280), out)?;
        } else if w.has_g(281) {
            self.setup.g28_mm = self.position;
            self.setup.g28_given = true;
        } else if w.has_g(301) {
            self.setup.g30_mm = self.position;
            self.setup.g30_given = true;
        } else if w.has_g(920) {
            let off = self.work_offsets[self.work] + self.tlo;
            if !w.has_axis() {
                return Err(invalid(
                    line,
                    w.g_col(920).unwrap_or(0),
                    "G92 without axis words",
                    "write G92 X.. Y.. Z..",
                ));
            }
            for (i, l) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
                if let Some(v) = w.get(l) {
                    self.g92[i] = self.position[i] - off[i] - self.to_mm(v);
                }
            }
            self.g92_saved = self.g92;
        } else if w.has_g(921) {
            self.g92 = Vec3::ZERO;
            self.g92_saved = Vec3::ZERO;
        } else if w.has_g(922) {
            self.g92 = Vec3::ZERO;
        } else if w.has_g(923) {
            self.g92 = self.g92_saved;
        }
        // 20: motion.
        if axis_user.is_some() && w.has_polar() {
            return Err(invalid(
                line,
                w.polar_col().unwrap_or(0),
                "polar coordinates (@, ^) can only be used for motion (not with G10, G28, G30 or G92); LinuxCNC refuses them too",
                "give X/Y words instead",
            ));
        }
        if axis_user.is_none()
            && (w.has_axis() || w.has_polar() || self.motion_word_col(w).is_some())
        {
            self.motion(line, w, new_cycle, out)?;
        }
        // 21: stop.
        if w.has_m(20) || w.has_m(300) {
            self.finished = true;
        }
        Ok(())
    }

    fn motion_word_col(&self, w: &WordTable) -> Option<usize> {
        [0u16, 10, 20, 30, 810, 820, 850, 890]
            .into_iter()
            .find_map(|c| w.g_col(c))
    }

    fn motion(
        &mut self,
        line: u64,
        w: &WordTable,
        new_cycle: bool,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        let col = self
            .motion_word_col(w)
            .or_else(|| {
                [b'X', b'Y', b'Z', b'@', b'^']
                    .into_iter()
                    .find_map(|l| w.col(l))
            })
            .unwrap_or(0);
        let motion_word = self.motion_word_col(w).is_some();
        if !w.has_axis() && !w.has_polar() {
            // LinuxCNC moves even without axis words when a motion code is on
            // the line: G0/G1 make a zero-length move, G2/G3 with centre words
            // a full circle; a cycle code alone does nothing.
            match self.motion_mode {
                Some(MotionMode::Rapid | MotionMode::Feed) if motion_word => {}
                Some(MotionMode::Cw | MotionMode::Ccw) if motion_word => {
                    if [b'I', b'J', b'K', b'R'].iter().all(|l| w.get(*l).is_none()) {
                        return Err(invalid(
                            line,
                            col,
                            "arc without end point or centre (R, I, J, K words all missing)",
                            "give the end point and the centre (I/J/K) or radius (R)",
                        ));
                    }
                }
                _ => return Ok(()),
            }
        }
        let Some(mode) = self.motion_mode else {
            return Err(invalid(
                line,
                col,
                "axis words without a motion mode (G80 or no G0/G1/G2/G3 yet)",
                "add G0 or G1 to this line",
            ));
        };
        self.check_polar(line, w, mode)?;
        let feed = self.to_mm(self.feed);
        let machine = w.has_g(530);
        if machine {
            if !matches!(mode, MotionMode::Rapid | MotionMode::Feed) {
                return Err(invalid(
                    line,
                    w.g_col(530).unwrap_or(col),
                    "G53 needs G0 or G1",
                    "use G53 G0 or G53 G1",
                ));
            }
            if !self.absolute {
                return Err(invalid(
                    line,
                    w.g_col(530).unwrap_or(col),
                    "G53 cannot be used in incremental mode (G91)",
                    "switch to G90 before G53",
                ));
            }
            let mut t = self.position;
            for (i, l) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
                if let Some(v) = w.get(l) {
                    t[i] = self.to_mm(v);
                }
            }
            let kind = if mode == MotionMode::Rapid {
                MotionKind::Rapid
            } else {
                MotionKind::Feed
            };
            self.push(out, kind, MotionSource::Machine, t, line, col, feed)?;
            return Ok(());
        }
        match mode {
            MotionMode::Rapid | MotionMode::Feed => {
                let kind = if mode == MotionMode::Rapid {
                    MotionKind::Rapid
                } else {
                    MotionKind::Feed
                };
                let t = self.target(w);
                self.push(out, kind, MotionSource::Program, t, line, col, feed)?;
            }
            MotionMode::Cw | MotionMode::Ccw => {
                let arc = self.arc(line, col, w, mode == MotionMode::Cw)?;
                self.push(
                    out,
                    MotionKind::Arc(arc),
                    MotionSource::Program,
                    arc.end,
                    line,
                    col,
                    feed,
                )?;
            }
            MotionMode::Cycle(code) => self.cycle(line, col, code, w, new_cycle, out)?,
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    fn push(
        &mut self,
        out: &mut Vec<Motion>,
        kind: MotionKind,
        source: MotionSource,
        end: Vec3,
        line: u64,
        column: usize,
        feed: f64,
    ) -> Result<(), GcodeError> {
        check_reach(line, column, "end point", end)?;
        if let MotionKind::Arc(arc) = kind {
            check_reach(line, column, "arc centre", arc.center)?;
        }
        out.push(Motion {
            kind,
            source,
            start: self.position,
            end,
            line,
            column: column + 1,
            feed,
        });
        self.position = end;
        Ok(())
    }

    fn arc(
        &self,
        line: u64,
        col: usize,
        w: &WordTable,
        clockwise: bool,
    ) -> Result<Arc, GcodeError> {
        let start = self.position;
        let end = self.target(w);
        let plane = self.plane;
        let (u, v, _) = plane.axes();
        let letters = [b'I', b'J', b'K'];
        let (lu, lv, lw) = (letters[u], letters[v], letters[plane.axes().2]);
        // LinuxCNC's CENTER_ARC_RADIUS_TOLERANCE, in program units (mm or inch).
        let tol_mm = match self.units {
            Units::Mm => 2.0 * 0.01 * std::f64::consts::SQRT_2,
            Units::Inch => 2.0 * 0.001 * std::f64::consts::SQRT_2 * 25.4,
        };
        let turns = match w.get(b'P') {
            None => 1,
            Some(p) if (1.0..=10_000.0).contains(&p) && p.fract() == 0.0 => p as u32,
            Some(_) => {
                return Err(invalid(
                    line,
                    w.col(b'P').unwrap_or(col),
                    "P on an arc must be a whole number of turns from 1 to 10000",
                    "fix the P word",
                ))
            }
        };
        if let Some(k) = w.get(lw) {
            let ok = k == 0.0 && plane == Plane::Xy && self.options.accept_k0_on_xy_arcs;
            if !ok {
                return Err(invalid(
                    line,
                    w.col(lw).unwrap_or(col),
                    format!(
                        "{} word given for an arc in the {} plane",
                        lw as char,
                        plane_name(plane)
                    ),
                    "remove it: an arc's centre offsets are in its plane only",
                ));
            }
        }
        let mut center = start;
        if let Some(r) = w.get(b'R') {
            if w.get(lu).is_some() || w.get(lv).is_some() {
                return Err(invalid(
                    line,
                    w.col(b'R').unwrap_or(col),
                    "arc has both R and centre words",
                    "use either R or I/J/K",
                ));
            }
            let r_mm = self.to_mm(r);
            let (du, dv) = (end[u] - start[u], end[v] - start[v]);
            if du.hypot(dv) < 1e-12 {
                return Err(invalid(
                    line,
                    w.col(b'R').unwrap_or(col),
                    "an R-format arc cannot end where it starts",
                    "use I/J/K centre words for a full circle",
                ));
            }
            let (mu, mv) = (0.5 * (start[u] + end[u]), 0.5 * (start[v] + end[v]));
            let mut half = (mu - start[u]).hypot(mv - start[v]);
            let abs_r = r_mm.abs();
            let radius_tol = 0.00005 * 25.4;
            if abs_r < half && half - abs_r > radius_tol {
                return Err(invalid(
                    line,
                    w.col(b'R').unwrap_or(col),
                    format!(
                        "radius {r} is too small to reach the end point (half chord {:.4} mm)",
                        half
                    ),
                    "check R and the end point",
                ));
            }
            if half / abs_r > 1.0 - 1e-12 {
                half = abs_r;
            }
            let chord_angle = dv.atan2(du);
            let theta = if clockwise == (r_mm > 0.0) {
                chord_angle - std::f64::consts::FRAC_PI_2
            } else {
                chord_angle + std::f64::consts::FRAC_PI_2
            };
            let offset = abs_r * (half / abs_r).asin().cos();
            center[u] = mu + offset * theta.cos();
            center[v] = mv + offset * theta.sin();
        } else {
            if w.get(lu).is_none() && w.get(lv).is_none() {
                return Err(invalid(
                    line,
                    col,
                    "arc without R or centre words",
                    format!(
                        "give {} and {} (centre) or R (radius)",
                        lu as char, lv as char
                    ),
                ));
            }
            let off = self.frame_offset_mm();
            for (axis, letter) in [(u, lu), (v, lv)] {
                let val = w.get(letter).map(|x| self.to_mm(x));
                center[axis] = if self.arc_absolute {
                    val.map(|x| x + off[axis]).unwrap_or(off[axis])
                } else {
                    start[axis] + val.unwrap_or(0.0)
                };
            }
            let r1 = (start[u] - center[u]).hypot(start[v] - center[v]);
            let r2 = (end[u] - center[u]).hypot(end[v] - center[v]);
            let abs_err = (r1 - r2).abs();
            let rel_err = abs_err / r1.max(r2);
            if r1 < 1e-9 || r2 < 1e-9 {
                return Err(invalid(
                    line,
                    col,
                    "zero-radius arc",
                    "check the centre words",
                ));
            }
            if abs_err > tol_mm * 100.0 || (rel_err > 0.001 && abs_err > tol_mm) {
                let mut help = "check the centre words; LinuxCNC refuses this arc too".to_string();
                if !self.arc_absolute {
                    let mut c_abs = start;
                    for (axis, letter) in [(u, lu), (v, lv)] {
                        c_abs[axis] =
                            w.get(letter).map(|x| self.to_mm(x)).unwrap_or(0.0) + off[axis];
                    }
                    let a1 = (start[u] - c_abs[u]).hypot(start[v] - c_abs[v]);
                    let a2 = (end[u] - c_abs[u]).hypot(end[v] - c_abs[v]);
                    if (a1 - a2).abs() <= tol_mm.max(1e-3 * a1.max(a2)) {
                        help = format!("the centre fits if {}/{} are absolute coordinates (radius {:.4} at both ends): the program was posted for absolute arc centres; add G90.1 at its start or pass --absolute-arc-centers", lu as char, lv as char, a1 / self.units.mm_per_unit());
                    }
                }
                return Err(invalid(line, col, format!("radius to end of arc differs from radius to start: r1={:.4} r2={:.4} (mm), abs_err={:.4} rel_err={:.4}%", r1, r2, abs_err, rel_err * 100.0), help));
            }
        }
        let a0 = (start[v] - center[v]).atan2(start[u] - center[u]);
        let a1 = (end[v] - center[v]).atan2(end[u] - center[u]);
        let sweep = sweep_angle(a0, a1, clockwise, turns);
        Ok(Arc {
            start,
            end,
            center,
            plane,
            sweep_rad: sweep,
        })
    }

    fn g10(&mut self, line: u64, w: &WordTable) -> Result<(), GcodeError> {
        let col = w.g_col(100).unwrap_or(0);
        let l = w
            .get(b'L')
            .ok_or_else(|| invalid(line, col, "G10 without L", "write G10 L2 Pn X.. Y.. Z.."))?;
        if l != 2.0 && l != 20.0 {
            return Err(unsupported(
                line,
                col,
                format!("G10 L{l} is not interpreted (only L2 and L20, work offsets)"),
                "set tool data in the setup file instead",
            ));
        }
        if w.get(b'R').is_some_and(|r| r != 0.0) {
            return Err(unsupported(
                line,
                col,
                "G10 with a rotation R is not a translation",
                "remove the R word",
            ));
        }
        let p = w.get(b'P').ok_or_else(|| {
            invalid(
                line,
                col,
                "G10 L2 without P",
                "write P1 for G54 … P9 for G59.3, P0 for the active system",
            )
        })?;
        if !(0.0..=9.0).contains(&p) || p.fract() != 0.0 {
            return Err(invalid(
                line,
                w.col(b'P').unwrap_or(col),
                "P must be 0 … 9 with G10",
                "P1 is G54, P9 is G59.3, P0 the active system",
            ));
        }
        let idx = if p == 0.0 { self.work } else { p as usize - 1 };
        let vals: Vec<(usize, f64)> = [b'X', b'Y', b'Z']
            .into_iter()
            .enumerate()
            .filter_map(|(i, le)| w.get(le).map(|v| (i, v)))
            .collect();
        for (i, v) in vals {
            let v = self.to_mm(v);
            self.work_offsets[idx][i] = if l == 2.0 {
                v
            } else {
                self.position[i] - self.g92[i] - self.tlo[i] - v
            };
        }
        Ok(())
    }

    fn home(
        &mut self,
        line: u64,
        w: &WordTable,
        g28: bool,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        let code = if g28 { 280 } else { 300 };
        let col = w.g_col(code).unwrap_or(0);
        let (reference, given) = if g28 {
            (self.setup.g28_mm, self.setup.g28_given)
        } else {
            (self.setup.g30_mm, self.setup.g30_given)
        };
        let which = usize::from(!g28);
        if !given && !self.warned_reference[which] {
            self.warned_reference[which] = true;
            let name = if g28 { "G28" } else { "G30" };
            self.warnings.push(Warning {
                line,
                column: col + 1,
                message: format!("{name} goes to the {name} reference point, which the set-up does not give: machine zero (0, 0, 0) is assumed, as LinuxCNC does with an unset {name} point; give it under [reference] in the set-up file (--setup), e.g. {name} = [x, y, z]"),
            });
        }
        let intermediate = self.target(w);
        let feed = self.to_mm(self.feed);
        self.push(
            out,
            MotionKind::Rapid,
            MotionSource::Reference,
            intermediate,
            line,
            col,
            feed,
        )?;
        let mut fin = intermediate;
        for (i, l) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if !w.has_axis() || w.get(l).is_some() {
                fin[i] = reference[i];
            }
        }
        self.push(
            out,
            MotionKind::Rapid,
            MotionSource::Reference,
            fin,
            line,
            col,
            feed,
        )?;
        Ok(())
    }

    /// Expands G81/G82/G85/G89 in the XY plane as LinuxCNC 2.9 does
    /// (`convert_cycle_xy` and its `CYCLE_MACRO`): R and Z are sticky while
    /// the same cycle continues; the Z where the run of cycle blocks began is
    /// the G98 clearance and the base of incremental R.
    #[allow(clippy::too_many_arguments)]
    fn cycle(
        &mut self,
        line: u64,
        col: usize,
        code: u16,
        w: &WordTable,
        new_cycle: bool,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        if self.plane != Plane::Xy {
            return Err(unsupported(
                line,
                col,
                "canned cycles are expanded in the XY plane (G17) only",
                "switch to G17 or post the cycle as explicit moves",
            ));
        }
        if w.get(b'L').is_some_and(|l| l != 1.0) {
            return Err(unsupported(
                line,
                col,
                "canned-cycle repeats (L) are not expanded",
                "post each hole explicitly",
            ));
        }
        if new_cycle {
            if w.get(b'Z').is_none() {
                return Err(invalid(
                    line,
                    col,
                    "Z value unspecified in the first block of a canned cycle",
                    "give the hole bottom Z",
                ));
            }
            if w.get(b'R').is_none() {
                return Err(invalid(
                    line,
                    col,
                    "R clearance plane unspecified in the first block of a canned cycle",
                    "give the R plane",
                ));
            }
            if matches!(code, 820 | 890) && w.get(b'P').is_none() {
                return Err(invalid(
                    line,
                    col,
                    "dwell time P missing in the first block of G82/G89",
                    "give P (seconds)",
                ));
            }
        }
        if let Some(r) = w.get(b'R') {
            self.cycle_r = Some(r);
        }
        if let Some(z) = w.get(b'Z') {
            self.cycle_z = Some(z);
        }
        if let Some(p) = w.get(b'P') {
            self.cycle_p = Some(p);
        }
        let (Some(r_word), Some(z_word)) = (self.cycle_r, self.cycle_z) else {
            return Err(invalid(
                line,
                col,
                "canned cycle without R or Z",
                "give R and Z",
            ));
        };
        let off = self.frame_offset_mm();
        let current_z = self.position.z;
        let start_z = *self.cycle_start_z.get_or_insert(current_z);
        let (r, bottom, x, y) = if self.absolute {
            let r = self.to_mm(r_word) + off.z;
            let x = w
                .get(b'X')
                .map(|v| self.to_mm(v) + off.x)
                .unwrap_or(self.position.x);
            let y = w
                .get(b'Y')
                .map(|v| self.to_mm(v) + off.y)
                .unwrap_or(self.position.y);
            (r, self.to_mm(z_word) + off.z, x, y)
        } else {
            let r = self.to_mm(r_word) + start_z;
            let x = self.position.x + w.get(b'X').map(|v| self.to_mm(v)).unwrap_or(0.0);
            let y = self.position.y + w.get(b'Y').map(|v| self.to_mm(v)).unwrap_or(0.0);
            (r, r + self.to_mm(z_word), x, y)
        };
        if r < bottom {
            return Err(invalid(
                line,
                col,
                "R less than Z in a canned cycle",
                "Z is the bottom of the hole, R the retract plane above it",
            ));
        }
        let feed = self.to_mm(self.feed);
        let mut old_z = start_z;
        let mut cur_z = current_z;
        let at = |x: f64, y: f64, z: f64| Vec3::new(x, y, z);
        if old_z < r {
            let p = at(self.position.x, self.position.y, r);
            self.push(
                out,
                MotionKind::Rapid,
                MotionSource::Cycle,
                p,
                line,
                col,
                feed,
            )?;
            old_z = r;
            cur_z = r;
        }
        let clear = if self.retract_to_r { r } else { old_z };
        if cur_z > r {
            self.push(
                out,
                MotionKind::Rapid,
                MotionSource::Cycle,
                at(x, y, cur_z),
                line,
                col,
                feed,
            )?;
            self.push(
                out,
                MotionKind::Rapid,
                MotionSource::Cycle,
                at(x, y, r),
                line,
                col,
                feed,
            )?;
        } else {
            self.push(
                out,
                MotionKind::Rapid,
                MotionSource::Cycle,
                at(x, y, clear),
                line,
                col,
                feed,
            )?;
            if clear > r {
                self.push(
                    out,
                    MotionKind::Rapid,
                    MotionSource::Cycle,
                    at(x, y, r),
                    line,
                    col,
                    feed,
                )?;
            }
        }
        self.push(
            out,
            MotionKind::Feed,
            MotionSource::Cycle,
            at(x, y, bottom),
            line,
            col,
            feed,
        )?;
        match code {
            810 | 820 => self.push(
                out,
                MotionKind::Rapid,
                MotionSource::Cycle,
                at(x, y, clear),
                line,
                col,
                feed,
            )?,
            850 => {
                self.push(
                    out,
                    MotionKind::Feed,
                    MotionSource::Cycle,
                    at(x, y, r),
                    line,
                    col,
                    feed,
                )?;
                self.push(
                    out,
                    MotionKind::Rapid,
                    MotionSource::Cycle,
                    at(x, y, clear),
                    line,
                    col,
                    feed,
                )?;
            }
            _ => self.push(
                out,
                MotionKind::Feed,
                MotionSource::Cycle,
                at(x, y, clear),
                line,
                col,
                feed,
            )?,
        }
        Ok(())
    }
}

fn plane_name(p: Plane) -> &'static str {
    match p {
        Plane::Xy => "XY (G17)",
        Plane::Zx => "ZX (G18)",
        Plane::Yz => "YZ (G19)",
    }
}
