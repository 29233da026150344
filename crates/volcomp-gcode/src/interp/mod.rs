//! A modal RS274/NGC interpreter that turns blocks into motions in the axis
//! frame (machine coordinates, mm).
//!
//! It follows LinuxCNC's semantics and order of execution within a block
//! (feed mode, F, S, T, M6, spindle/coolant, dwell, plane, units, cutter
//! compensation, tool length, coordinate system, path control, distance
//! mode, retract mode, G10/G28/G30/G92, motion, stop). The frame relation is
//! `q = p + work_offset + tool_length_offset + G92` (axis position = program
//! position + offsets).
//!
//! | file | concern |
//! | --- | --- |
//! | `mod.rs` | the motions it yields, the modal state, the order of execution within a block |
//! | `options.rs` | [`InterpOptions`], feed and motion modes |
//! | `words.rs` | decoding a block: words by letter, G/M codes, modal groups, unused words |
//! | `fast.rs` | the common block (a plain G0/G1 with X, Y, Z, F, N) in one step, mirrored against the general path by a test |
//! | `motion.rs` | straight moves, arcs, polar end points, feed-rate and reach checks |
//! | `comp.rs` | cutter radius compensation G40, G41, G42, G41.1, G42.1: the tool-centre path, as LinuxCNC computes it |
//! | `cycle/` | canned cycles G73, G81–G89 |
//! | `spline.rs` | splines G5, G5.1, G5.2/G5.3, linearised within the spline tolerance |
//! | `extra.rs` | the extra axes A, B, C, U, V, W, carried through (not compensated) |
//! | `offsets.rs` | tool length offsets, G10 (work offsets, tool table writes), G52, G92, G28/G30 |
//! | `lexical.rs` | bytes LinuxCNC's reader sees differently: NUL in a comment, a byte-order mark |
//! | `tape.rs` | the start and end of a program: `%` lines, the required program end |
//! | `warnings.rs` | [`Warning`]: what was assumed |
//!
//! What it does not interpret faithfully it refuses, naming the column: no
//! guess is ever made about a construct's meaning.

mod comp;
mod cycle;
mod extra;
mod fast;
mod lexical;
mod modal;
mod motion;
mod offsets;
mod options;
mod spline;
mod state;
mod tape;
mod warnings;
mod words;

pub use cycle::{snap as snap_program_value, CycleBlock};
pub use extra::{ExtraAxes, EXTRA_LETTERS};
pub use lexical::check_line;
pub use modal::PathMode;
pub use motion::K0_HELP;
pub use motion::MAX_COORDINATE_MM;
pub use options::{FeedMode, InterpOptions};
pub use state::Unanswerable;
pub use tape::PROGRAM_END_HELP;
pub use warnings::Warning;

use crate::arc::Arc;
use crate::error::{ErrorClass, GcodeError};
use crate::geom::{Plane, Units, Vec3};
use crate::lexer::Lexed;
use crate::setup::Setup;
use options::MotionMode;
use words::WordTable;

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
    /// A chord of a G5, G5.1 or G5.2/G5.3 spline.
    Spline,
    /// A spindle-synchronised move: G33, or the stroke in and out of a G33.1
    /// rigid tap. Its feed is the spindle's (pitch × speed), not F.
    SpindleSynced,
    /// A move of the tool-centre path under cutter radius compensation
    /// (G41/G42): LinuxCNC gives it out one block late (it waits for the
    /// next move to know the corner), so it can come with a later line's
    /// motions; its `line` is the block it comes from. Corner arcs come
    /// from the block after the corner.
    CutterComp,
}

impl MotionSource {
    /// `program`, `g53`, `reference`, `cycle`, `spline`, `spindle_synced`
    /// or `cutter_comp`: the name `volcomp moves` prints.
    pub fn name(&self) -> &'static str {
        match self {
            MotionSource::Program => "program",
            MotionSource::Machine => "g53",
            MotionSource::Reference => "reference",
            MotionSource::Cycle => "cycle",
            MotionSource::Spline => "spline",
            MotionSource::SpindleSynced => "spindle_synced",
            MotionSource::CutterComp => "cutter_comp",
        }
    }
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
    /// Feed rate in mm/min (or inverse-time value under G93; a
    /// [`MotionSource::CutterComp`] move computed under G93 has the rate in
    /// mm/min LinuxCNC runs it at, `inverse_time_rate_*`: the programmed
    /// length times the block's F).
    pub feed: f64,
    /// The feed mode (G93, G94, G95) the motion was computed in.
    pub feed_mode: FeedMode,
    /// The path-control mode (G61, G61.1, G64) in effect for the motion.
    pub path_mode: PathMode,
    /// The extra axes A, B, C, U, V, W at its start and end (not
    /// compensated; moved linearly over the motion).
    pub extra: ExtraAxes,
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
    /// Which work offsets are known (given by the set-up, or set by the
    /// program with G10 L2/L20 on X, Y and Z).
    work_given: [bool; 9],
    g92: Vec3,
    /// The G92 parameters #5211…: G92.2 clears [`Interpreter::g92`] but
    /// keeps them, and G92.3 restores from them.
    g92_saved: Vec3,
    /// #5210: whether a G52/G92 offset is applied.
    g92_applied: bool,
    tlo: Vec3,
    /// X and Y offsets of tools written by G10 L1/L10/L11 (the set-up's
    /// tool table has lengths only, Z); G43 applies them.
    tool_xy_mm: std::collections::BTreeMap<u32, [f64; 2]>,
    /// Front angle, back angle and orientation of tools written by G10 L1
    /// I, J, Q (0 for every other tool: the set-up's are mills'); G41/G42
    /// with D take the orientation.
    tool_lathe: std::collections::BTreeMap<u32, [f64; 3]>,
    /// G96 (constant surface speed) in effect rather than G97.
    css_mode: bool,
    /// Mist (M7) and flood (M8) coolant on; M9 turns both off.
    mist: bool,
    flood: bool,
    /// Rotation about Z of each coordinate system (degrees, G10 L2/L20 R).
    rotation_deg: [f64; 9],
    loaded_tool: u32,
    /// The tool whose table entry #5400–#5413 show: set at M6 (and G10
    /// L1/L10/L11 of the loaded tool), not at M61, as LinuxCNC's
    /// `set_tool_parameters` runs before M61's tool reaches the table.
    param_tool: u32,
    next_tool: u32,
    position: Vec3,
    retract_to_r: bool,
    /// Sticky R word of the canned cycle (program units, as written).
    cycle_r: Option<f64>,
    /// Sticky Z word of the canned cycle (program units, as written).
    cycle_z: Option<f64>,
    /// Normal-axis coordinate (program frame and units) when the current
    /// run of cycle blocks began (LinuxCNC's `cycle_il`).
    cycle_start_z: Option<f64>,
    /// Sticky peck depth Q of G73/G83.
    cycle_q: Option<f64>,
    /// The last canned-cycle block as LinuxCNC computed it
    /// ([`Interpreter::last_cycle`]).
    last_cycle: Option<Box<cycle::CycleBlock>>,
    /// Sticky I, J, K of G87.
    cycle_ijk: [f64; 3],
    /// Spindle direction from M3 (1), M4 (-1), M5 (0), for the cycles that
    /// need it turning (G84, G86, G87, G88).
    spindle_dir: i8,
    /// Lathe diameter mode (G7): X words are diameters.
    diameter_mode: bool,
    /// Sticky dwell P of G82/G89 (seconds).
    cycle_p: Option<f64>,
    finished: bool,
    /// Whether the first non-blank line was `%` (the program "uses percents").
    uses_percents: bool,
    /// Whether a non-blank line has been read.
    nonblank_seen: bool,
    /// The first `%` line that neither opened nor closed the tape (its
    /// line, LinuxCNC's message): LinuxCNC stops there.
    stray_percent: Option<(u64, &'static str)>,
    /// Whether the program has said G20 or G21.
    units_given: bool,
    /// Assumptions made so far, in program order.
    warnings: Vec<Warning>,
    warned_units: bool,
    warned_reference: [bool; 2],
    /// Extra axes A, B, C (degrees), U, V, W (mm) now, and at the end of
    /// the current block's motion.
    extra: [f64; 6],
    extra_target: [f64; 6],
    /// The modal state M70 saved (M72 restores it).
    contexts: Vec<modal::Context>,
    /// G61, G61.1 or G64 P… Q… in effect.
    path_mode: PathMode,
    /// G92 offsets of the extra axes, and the ones G92.3 restores.
    extra_g92: [f64; 6],
    extra_g92_saved: [f64; 6],
    uses_extra_axes: bool,
    /// The last G5 block's end tangent (second control point relative to
    /// the end, mm, axis frame), for G5 blocks that omit I and J.
    spline_tangent: Option<(f64, f64)>,
    /// The NURBS block being collected (G5.2 … G5.3).
    nurbs: Option<Box<spline::NurbsBlock>>,
    /// The current block's words; `None` only while the block runs.
    words: Option<Box<WordTable>>,
    /// Cutter radius compensation while G41/G42 is in effect.
    comp: Option<Box<comp::CutterComp>>,
    /// After G40 the next move must be straight (LinuxCNC's
    /// `arc_not_allowed`).
    arc_not_allowed: bool,
    /// Where the next motion starts when that is not `position`: after G40
    /// the tool is on the offset path while the program continues from the
    /// programmed point.
    motion_start: Option<Vec3>,
    /// Plain straight moves take the one-step path (`fast.rs`); its tests
    /// turn it off to compare.
    fast_blocks: bool,
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

impl Interpreter {
    /// A fresh interpreter in LinuxCNC's start state (G17 G21 G90 G91.1 G94
    /// G54 G49, no motion mode) with the machine at `setup.start_mm`.
    pub fn new(setup: Setup, options: InterpOptions) -> Self {
        let work_offsets = setup.work_offsets_mm;
        let position = setup.start_mm;
        let (work, g92, rotation_deg, work_given) = (
            setup.work_system.min(8),
            setup.g92_mm,
            setup.rotations_deg,
            setup.work_offsets_given,
        );
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
            work,
            work_offsets,
            work_given,
            g92,
            g92_saved: g92,
            g92_applied: g92 != Vec3::ZERO,
            tlo: Vec3::ZERO,
            tool_xy_mm: std::collections::BTreeMap::new(),
            tool_lathe: std::collections::BTreeMap::new(),
            css_mode: false,
            mist: false,
            flood: false,
            rotation_deg,
            loaded_tool: 0,
            param_tool: 0,
            next_tool: 0,
            position,
            retract_to_r: true,
            cycle_r: None,
            cycle_z: None,
            cycle_start_z: None,
            cycle_q: None,
            last_cycle: None,
            cycle_ijk: [0.0; 3],
            spindle_dir: 0,
            diameter_mode: false,
            cycle_p: None,
            finished: false,
            uses_percents: false,
            nonblank_seen: false,
            stray_percent: None,
            units_given: false,
            warnings: Vec::new(),
            warned_units: false,
            warned_reference: [false; 2],
            extra: [0.0; 6],
            extra_target: [0.0; 6],
            contexts: Vec::new(),
            path_mode: PathMode::default(),
            extra_g92: [0.0; 6],
            extra_g92_saved: [0.0; 6],
            uses_extra_axes: false,
            spline_tangent: None,
            nurbs: None,
            words: Some(Box::default()),
            comp: None,
            arc_not_allowed: false,
            motion_start: None,
            fast_blocks: true,
        }
    }

    /// The current commanded position (mm, axis frame).
    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// Whether the set-up gave the machine's start position: where it did
    /// not, the position of an axis the program has not set yet is unknown
    /// (the interpreter starts it at machine zero, a placeholder).
    pub fn start_given(&self) -> bool {
        self.setup.start_given
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

    /// The arc plane in effect (G17, G18, G19).
    pub fn plane(&self) -> Plane {
        self.plane
    }

    /// Whether lathe diameter mode (G7) is in effect: a written X word is
    /// twice the program's X coordinate.
    pub fn diameter_mode(&self) -> bool {
        self.diameter_mode
    }

    /// Whether arc centres (I, J, K) are absolute (G90.1) rather than
    /// relative to the arc's start (G91.1).
    pub fn arc_absolute(&self) -> bool {
        self.arc_absolute
    }

    /// Whether the program is read with absolute arc centres by option
    /// (`InterpOptions::absolute_arc_centers`: posted for a controller that
    /// reads I, J, K as absolute without G90.1).
    pub fn arc_absolute_by_option(&self) -> bool {
        self.options.absolute_arc_centers
    }

    /// The canned cycle in effect (73, 81–89) and, for G82/G86/G88/G89 (and
    /// G84 when given), the dwell at the bottom in seconds.
    pub fn canned_cycle(&self) -> Option<(u16, Option<f64>)> {
        match self.motion_mode {
            Some(MotionMode::Cycle(code)) => {
                let dwell = matches!(code, 740 | 820 | 840 | 860 | 880 | 890)
                    .then_some(self.cycle_p)
                    .flatten();
                Some((code / 10, dwell))
            }
            _ => None,
        }
    }

    /// Feed mode in effect.
    pub fn feed_mode(&self) -> FeedMode {
        self.feed_mode
    }

    /// Feed rate in effect (the last F, in the units of the feed mode; 0
    /// until an F word sets it, and again after a G94 or G95, as in
    /// LinuxCNC's `Interp::convert_feed_mode`, src/emc/rs274ngc/interp_convert.cc).
    pub fn feed_rate(&self) -> f64 {
        self.feed
    }

    /// Decimals of computed values in rendered lines in the units in
    /// effect ([`InterpOptions::computed_decimals`]).
    pub fn computed_decimals(&self) -> Option<u8> {
        self.options
            .computed_decimals
            .map(|[mm, inch]| if self.units == Units::Mm { mm } else { inch })
    }

    /// Path-control mode (G61, G61.1, G64) in effect.
    pub fn path_mode(&self) -> PathMode {
        self.path_mode
    }

    /// Whether the modal motion is an arc (G2 or G3): a line with axis
    /// words and no motion code of its own moves along an arc.
    pub fn arc_mode(&self) -> bool {
        matches!(self.motion_mode, Some(MotionMode::Cw | MotionMode::Ccw))
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
        if !lexed.tokens.is_empty() {
            self.nonblank_seen = true;
        }
        self.check_after_stray_percent(line, lexed)?;
        let before = out.len();
        if !self.fast_block(line, lexed, out)? {
            self.collect_words(line, lexed)?;
            self.run_block(line, out)?;
        }
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

    fn to_mm(&self, v: f64) -> f64 {
        v * self.units.mm_per_unit()
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
        // `convert_feed_mode` (interp_convert.cc): G94 and G95 set the feed
        // rate to 0 (even in the mode already in effect), so a feed move
        // needs an F word after them.
        if w.has_g(930) {
            self.feed_mode = FeedMode::InverseTime;
        } else if w.has_g(940) {
            self.feed_mode = FeedMode::PerMinute;
            self.feed = 0.0;
        } else if w.has_g(950) {
            self.feed_mode = FeedMode::PerRevolution;
            self.feed = 0.0;
        }
        let not_negative = |letter: u8, what: &str, help: &str| match w.get(letter) {
            Some(v) if v < 0.0 => Err(invalid(line, w.col(letter).unwrap_or(0), what, help)),
            v => Ok(v),
        };
        if let Some(f) = not_negative(b'F', "negative feed rate", "F must be positive")? {
            self.feed = f;
        }
        if let Some(s) = not_negative(b'S', "negative spindle speed", "S must be zero or positive")?
        {
            self.spindle_rpm = s;
        }
        // Checks of the whole block before anything changes state: words
        // nothing uses, feed moves without a feed rate (G93 and F are set).
        self.check_word_use(line, w)?;
        let motion_col = self.motion_col(w);
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
            self.param_tool = self.loaded_tool;
        }
        if w.has_m(610) {
            let col = w.m_col(610).unwrap_or(0);
            let q = w
                .get(b'Q')
                .ok_or_else(|| invalid(line, col, "M61 needs a Q word", "write M61 Qn"))?;
            // `convert_m`: `round_to_int(q)` (half to even), refused below 0.
            let tool = crate::ngc::expr::round_to_int(q);
            if tool < 0 {
                return Err(invalid(
                    line,
                    w.col(b'Q').unwrap_or(col),
                    "M61 with a negative tool number; LinuxCNC refuses it (\"Need non-negative Q-word to specify tool number with M61\")",
                    "write M61 Q<tool number>, Q0 for no tool",
                ));
            }
            self.loaded_tool = tool as u32;
        }
        // 7: spindle direction (for the canned cycles and #<_spindle_on>).
        if w.has_m(30) {
            self.spindle_dir = 1;
        } else if w.has_m(40) {
            self.spindle_dir = -1;
        } else if w.has_m(50) {
            self.spindle_dir = 0;
        }
        if let Some(css) = w.switch(960, 970) {
            self.css_mode = css;
        }
        // 8: coolant (for #<_mist>, #<_flood>).
        if w.has_m(70) {
            self.mist = true;
        }
        if w.has_m(80) {
            self.flood = true;
        }
        if w.has_m(90) {
            (self.mist, self.flood) = (false, false);
        }
        // M70/M71/M72: save, invalidate, restore the modal state.
        self.modal_save_restore(line, w)?;
        // 10: dwell (passed through).
        if w.has_g(40) && w.get(b'P').is_none() {
            return Err(invalid(
                line,
                w.g_col(40).unwrap_or(0),
                "G4 dwell without P",
                "write G4 Pseconds",
            ));
        }
        // -1 is LinuxCNC's own "no P" value (`check_g_codes`,
        // interp_check.cc, tests `p_number == -1.0`); other negative
        // dwells pass.
        if w.has_g(40) && w.get(b'P') == Some(-1.0) {
            return Err(invalid(
                line,
                w.col(b'P').unwrap_or(0),
                "G4 P-1: LinuxCNC takes P-1 for a missing P and refuses the line (\"Dwell time missing with g4\")",
                "write the dwell in seconds, zero or more",
            ));
        }
        // What LinuxCNC refuses while cutter compensation is on, checked
        // before step 11: `convert_set_plane` compares the plane with the
        // one in effect, before a G40 of the same block (step 13) turns
        // compensation off; the others are made at later steps, after the
        // G40 of the block.
        self.comp_refusals(line, w)?;
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
        // 13: cutter radius compensation.
        if w.has_g(400) {
            self.comp_off(line, w.g_col(400).unwrap_or(0), out)?;
        }
        if let Some(code) = [410u16, 420, 411, 421].into_iter().find(|c| w.has_g(*c)) {
            let d = w.get(b'D').map(|v| (v, w.col(b'D').unwrap_or(0)));
            self.comp_on(line, w.g_col(code).unwrap_or(0), code, d, w.get(b'L'))?;
        }
        // 14: tool length offset.
        self.tool_length_offset(line, w)?;
        // 15: coordinate system.
        for (i, code) in [540, 550, 560, 570, 580, 590, 591, 592, 593]
            .into_iter()
            .enumerate()
        {
            if w.has_g(code) {
                if !self.work_given[i] {
                    let name = crate::setup::WORK_SYSTEMS[i];
                    return Err(invalid(
                        line,
                        w.g_col(code).unwrap_or(0),
                        format!("{name} is selected, but the set-up does not give its offset: volcomp does not take it for 0"),
                        format!("give it under [work_offsets] in the set-up file ({name} = [X, Y, Z], machine coordinates), or name LinuxCNC's var file (var_file = \"linuxcnc.var\"), or set it in the program with G10 L2 P{} X… Y… Z…", i + 1),
                    ));
                }
                self.work = i;
            }
        }
        // 16: path-control mode (G61, G61.1, G64 P Q).
        self.control_mode(w);
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
        // G5 and G5.1 leave the motion mode as it was, and G5.3 is
        // non-modal (`Interp::convert_motion`, interp_convert.cc); the canned
        // cycles set it below.
        for &(code, _) in &w.g {
            match words::motion_of(code) {
                None | Some(MotionMode::Spline(50 | 51 | 53) | MotionMode::Cycle(_)) => {}
                mode => self.motion_mode = mode,
            }
        }
        self.end_spline_block_unless(self.motion_mode);
        let mode_before = self.motion_mode;
        for code in [730u16, 740, 810, 820, 830, 840, 850, 860, 870, 880, 890] {
            if w.has_g(code) {
                self.motion_mode = Some(MotionMode::Cycle(code));
            }
        }
        if !matches!(self.motion_mode, Some(MotionMode::Cycle(_))) {
            self.cycle_start_z = None;
        }
        let new_cycle = self.motion_mode != mode_before;
        self.extra_target(line, w)?;
        // 19: non-modal codes that use axis words.
        let axis_user = [100u16, 280, 300, 520, 920, 431]
            .into_iter()
            .find(|c| w.has_g(*c));
        self.check_axis_users(line, w, axis_user)?;
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
        } else if [520, 920, 921, 922, 923].into_iter().any(|c| w.has_g(c)) {
            self.g92(line, w)?;
        }
        // 20: motion.
        if axis_user.is_some() && w.has_polar() {
            return Err(invalid(
                line,
                w.polar_col().unwrap_or(0),
                "polar coordinates (@, ^) can only be used for motion (not with G10, G28, G30, G52 or G92); LinuxCNC refuses them too",
                "give X/Y words instead",
            ));
        }
        // An arc-centre word alone in G2/G3 (`I-7.5 J0`) is an arc too,
        // back to where it starts (`enhance_block`, interp_internal.cc).
        let ijk_arc = || matches!(self.motion_to_be(w), Some(MotionMode::Cw | MotionMode::Ccw));
        if axis_user.is_none()
            && (w.has_axis() || w.has_polar() || self.motion_word_col(w).is_some() || ijk_arc())
        {
            self.motion(line, w, new_cycle, out)?;
        }
        // 21: stop. LinuxCNC's `convert_stop` gives out the move waiting in
        // the cutter compensation queue, and M2/M30 turn compensation off.
        if let Some(code) = [0u16, 10, 20, 300, 600].into_iter().find(|c| w.has_m(*c)) {
            let col = w.m_col(code).unwrap_or(0);
            self.comp_flush_at_stop(line, col, out)?;
            if code == 20 || code == 300 {
                self.comp = None;
            }
        }
        if w.has_m(20) || w.has_m(300) {
            self.finished = true;
        }
        // After a tool change LinuxCNC reads the position back from the
        // machine (`Interp::read` re-synchronises when `toolchange_flag` is
        // set): after G40 that is where the tool is, on the offset path,
        // not the programmed point.
        if w.has_m(60) {
            if let Some(p) = self.motion_start.take() {
                self.position = p;
            }
        }
        Ok(())
    }
}
