//! The path-control mode (G61, G61.1, G64 P… Q…), and M70 (save modal
//! state), M71 (invalidate it), M72 (restore it) and M73 (save it, restored
//! when the subroutine returns), as LinuxCNC 2.9's `Interp::save_settings` /
//! `restore_settings` (src/emc/rs274ngc/interp_convert.cc) and
//! `leave_context` (interp_o_word.cc) do them: the state is kept per call
//! level (the main program, each subroutine call), M73 in a subroutine
//! marks it to be restored when that call returns (`endsub`, `return`,
//! M99), and an M71 in between cancels that. M72 must stand on its line
//! alone (LinuxCNC restores by running generated blocks in place of the
//! current one, so other words on the line would not run as written). The
//! restore sets units first (G20/G21), then plane, distance modes, feed
//! mode, coordinate system, retract mode, path-control mode, the feed rate
//! (rounded to 0.1, `F%.1f`), the spindle speed (`S%.0f`), the spindle
//! direction (M3/M4/M5) and the coolant (M7/M8/M9). Where the restored
//! state includes something volcomp does not replay (a different tool
//! length offset or G92 state than at the save), the restore is refused.

use super::options::FeedMode;
use super::words::WordTable;
use super::{invalid, unsupported, Interpreter};
use crate::error::GcodeError;
use crate::geom::{Plane, Units, Vec3};

/// The path-control mode, as LinuxCNC 2.9 reads it
/// (`Interp::convert_control_mode`, src/emc/rs274ngc/interp_convert.cc) and
/// hands it to the trajectory planner (`SET_MOTION_CONTROL_MODE`,
/// src/emc/task/emccanon.cc): the terminal condition of every feed move
/// queued after it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PathMode {
    /// G61, "exact path" (CANON_EXACT_PATH, the planner's
    /// TC_TERM_COND_EXACT): the planner joins two moves without stopping
    /// only where it takes them as tangent, and never blends a corner.
    ExactPath,
    /// G61.1, "exact stop" (CANON_EXACT_STOP, TC_TERM_COND_STOP): every
    /// move ends at rest.
    ExactStop,
    /// G64, continuous (CANON_CONTINUOUS, TC_TERM_COND_PARABOLIC): corners
    /// blended. `tolerance_mm` is P (mm, converted from the program's units
    /// when G64 was read), 0 without P: LinuxCNC's "no tolerance", the
    /// planner blends as far as speed needs (up to a quarter of a
    /// segment's length). `naive_cam_mm` is Q, or P where Q is not given,
    /// else 0: canon then merges consecutive straight feeds whose points
    /// lie within it of one line (`linkable`, emccanon.cc). A negative P or
    /// Q counts as not given, as LinuxCNC reads them (the block reader
    /// starts both at −1, `init_block`, interp_internal.cc).
    Blend {
        /// G64 P (mm), 0 without P.
        tolerance_mm: f64,
        /// G64 Q (mm), else P, else 0.
        naive_cam_mm: f64,
    },
}

impl Default for PathMode {
    /// LinuxCNC's state at start: G64 without P (canon's `motionMode`
    /// CANON_CONTINUOUS with tolerance 0; tp.c's `tpInit` term condition
    /// parabolic).
    fn default() -> Self {
        PathMode::Blend {
            tolerance_mm: 0.0,
            naive_cam_mm: 0.0,
        }
    }
}

impl PathMode {
    /// The G code that sets this mode: `G61`, `G61.1`, `G64`, or
    /// `G64 P… Q…` with the tolerances in mm.
    pub fn code(&self) -> String {
        match *self {
            PathMode::ExactPath => "G61".into(),
            PathMode::ExactStop => "G61.1".into(),
            PathMode::Blend {
                tolerance_mm,
                naive_cam_mm,
            } if tolerance_mm == 0.0 && naive_cam_mm == 0.0 => "G64".into(),
            PathMode::Blend {
                tolerance_mm,
                naive_cam_mm,
            } => format!("G64 P{tolerance_mm} Q{naive_cam_mm} (mm)"),
        }
    }
}

/// The state M70 and M73 save.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SavedModes {
    units: Units,
    plane: Plane,
    absolute: bool,
    arc_absolute: bool,
    feed_mode: FeedMode,
    work: usize,
    retract_to_r: bool,
    feed: f64,
    spindle_rpm: f64,
    spindle_dir: i8,
    mist: bool,
    flood: bool,
    tlo: Vec3,
    g92: Vec3,
    path_mode: PathMode,
}

/// The saved state of one call level (LinuxCNC's `sub_context[level]`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Context {
    saved: Option<SavedModes>,
    /// M73 in a subroutine: restore when the call returns.
    restore_on_return: bool,
}

impl Interpreter {
    /// G61, G61.1 and G64 of the block (`convert_control_mode`): P and Q
    /// are in program units; a negative or missing P is no tolerance, a
    /// missing Q is P.
    pub(super) fn control_mode(&mut self, w: &WordTable) {
        if w.has_g(610) {
            self.path_mode = PathMode::ExactPath;
        } else if w.has_g(611) {
            self.path_mode = PathMode::ExactStop;
        } else if w.has_g(640) {
            let k = self.units.mm_per_unit();
            let given = |v: Option<f64>| v.filter(|v| *v >= 0.0).map(|v| v * k);
            let (p, q) = (given(w.get(b'P')), given(w.get(b'Q')));
            self.path_mode = PathMode::Blend {
                tolerance_mm: p.unwrap_or(0.0),
                naive_cam_mm: q.or(p).unwrap_or(0.0),
            };
        }
    }

    fn save_modes(&self) -> SavedModes {
        SavedModes {
            units: self.units,
            plane: self.plane,
            absolute: self.absolute,
            arc_absolute: self.arc_absolute,
            feed_mode: self.feed_mode,
            work: self.work,
            retract_to_r: self.retract_to_r,
            feed: self.feed,
            spindle_rpm: self.spindle_rpm,
            spindle_dir: self.spindle_dir,
            mist: self.mist,
            flood: self.flood,
            tlo: self.tlo,
            g92: self.g92,
            path_mode: self.path_mode,
        }
    }

    fn context(&mut self) -> &mut Context {
        if self.contexts.is_empty() {
            self.contexts.push(Context::default());
        }
        let last = self.contexts.len() - 1;
        &mut self.contexts[last]
    }

    /// A subroutine call begins (o… call, M98): a new call level, with
    /// nothing saved.
    pub(crate) fn enter_call(&mut self) {
        self.context();
        self.contexts.push(Context::default());
    }

    /// A subroutine call returns at `line`. When an M73 of the call saved
    /// the state, LinuxCNC restores it by running G-code it generates from
    /// the difference (`leave_context`, `restore_settings`: G20/G21 first,
    /// then F, S and the G codes on one line, then each M code on a line):
    /// those lines, for the caller to run in place of the return.
    pub(crate) fn leave_call(&mut self, line: u64) -> Result<Vec<String>, GcodeError> {
        let Some(ctx) = self.contexts.pop() else {
            return Ok(Vec::new());
        };
        let Some(s) = ctx.saved.filter(|_| ctx.restore_on_return) else {
            return Ok(Vec::new());
        };
        if s.tlo != self.tlo || s.g92 != self.g92 {
            return Err(unsupported(
                line,
                0,
                "the return restores the state M73 saved, with a tool length offset or G92 state that changed since; volcomp does not replay that restore",
                "restate G43/G49 and G92 explicitly instead of restoring them",
            ));
        }
        let mut lines = Vec::new();
        if s.units != self.units {
            lines.push(if s.units == Units::Mm { "G21" } else { "G20" }.to_string());
        }
        let mut words = String::new();
        if s.feed != self.feed {
            words.push_str(&format!(" F{:.1}", s.feed));
        }
        if s.spindle_rpm != self.spindle_rpm {
            words.push_str(&format!(" S{:.0}", s.spindle_rpm));
        }
        let code = |on: bool, a: &'static str, b: &'static str| if on { a } else { b };
        let plane = |p: Plane| match p {
            Plane::Xy => "G17",
            Plane::Zx => "G18",
            Plane::Yz => "G19",
        };
        let feed_mode = |m: FeedMode| match m {
            FeedMode::InverseTime => "G93",
            FeedMode::PerMinute => "G94",
            FeedMode::PerRevolution => "G95",
        };
        let work = |k: usize| {
            [
                "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
            ][k]
        };
        for (saved, now) in [
            (plane(s.plane), plane(self.plane)),
            (
                code(s.absolute, "G90", "G91"),
                code(self.absolute, "G90", "G91"),
            ),
            (feed_mode(s.feed_mode), feed_mode(self.feed_mode)),
            (work(s.work), work(self.work)),
            (
                code(s.retract_to_r, "G99", "G98"),
                code(self.retract_to_r, "G99", "G98"),
            ),
            (
                code(s.arc_absolute, "G90.1", "G91.1"),
                code(self.arc_absolute, "G90.1", "G91.1"),
            ),
        ] {
            if saved != now {
                words.push(' ');
                words.push_str(saved);
            }
        }
        if s.path_mode != self.path_mode {
            let k = s.units.mm_per_unit();
            words.push_str(&match s.path_mode {
                PathMode::ExactPath => " G61".to_string(),
                PathMode::ExactStop => " G61.1".to_string(),
                PathMode::Blend {
                    tolerance_mm,
                    naive_cam_mm,
                } if tolerance_mm == 0.0 && naive_cam_mm == 0.0 => " G64".to_string(),
                PathMode::Blend {
                    tolerance_mm,
                    naive_cam_mm,
                } => format!(" G64 P{:.6} Q{:.6}", tolerance_mm / k, naive_cam_mm / k),
            });
        }
        if !words.is_empty() {
            lines.push(words.trim_start().to_string());
        }
        let spindle = |d: i8| match d {
            1 => "M3",
            -1 => "M4",
            _ => "M5",
        };
        if s.spindle_dir != self.spindle_dir {
            lines.push(spindle(s.spindle_dir).to_string());
        }
        if s.mist != self.mist {
            lines.push(code(s.mist, "M7", "M9").to_string());
        }
        if s.flood != self.flood {
            lines.push(code(s.flood, "M8", "M9").to_string());
        }
        Ok(lines)
    }

    /// M70, M71, M72, M73 of the block (M72 restores before the block's G codes).
    pub(super) fn modal_save_restore(
        &mut self,
        line: u64,
        w: &WordTable,
    ) -> Result<(), GcodeError> {
        let col = |code: u16| w.m.iter().find(|(c, _)| *c == code).map_or(0, |(_, c)| *c);
        if w.has_m(700) || w.has_m(730) {
            let s = self.save_modes();
            // M73 at the top level has nothing to return to: LinuxCNC
            // stores the state anyway (M72 can restore it).
            let in_call = self.contexts.len() > 1;
            let ctx = self.context();
            ctx.saved = Some(s);
            if w.has_m(730) && in_call {
                ctx.restore_on_return = true;
            }
        } else if w.has_m(710) {
            if self.context().saved.take().is_none() {
                return Err(invalid(
                    line,
                    col(710),
                    "M71 without a state saved by M70 or M73; LinuxCNC refuses it",
                    "save the state with M70 first",
                ));
            }
        } else if w.has_m(720) {
            let Some(s) = self.context().saved else {
                return Err(invalid(
                    line,
                    col(720),
                    "M72 without a state saved by M70 or M73; LinuxCNC refuses it (\"Cannot restore context from invalid stack frame - missing M70/M73?\")",
                    "save the state with M70 first",
                ));
            };
            let others = !w.g.is_empty()
                || w.m.len() > 1
                || (b'A'..=b'Z').any(|l| l != b'N' && w.get(l).is_some())
                || w.has_polar();
            if others {
                // LinuxCNC restores by executing generated blocks, which
                // replace the block being run: the rest of the M72 line is lost.
                return Err(unsupported(
                    line,
                    col(720),
                    "M72 with other words on its line: LinuxCNC restores the state by running blocks of its own, and the rest of this line is then not run as written",
                    "put M72 on a line of its own",
                ));
            }
            self.restore_modes(s, line, col(720))?;
        }
        Ok(())
    }

    /// Restores `s` as `restore_settings` does for M72 (at `line`, `col`).
    fn restore_modes(&mut self, s: SavedModes, line: u64, col: usize) -> Result<(), GcodeError> {
        if s.tlo != self.tlo || s.g92 != self.g92 {
            return Err(unsupported(
                line,
                col,
                "M72 would restore a tool length offset or G92 state that changed since M70; volcomp does not replay that restore",
                "restate G43/G49 and G92 explicitly instead of restoring them with M72",
            ));
        }
        if s.units != self.units {
            self.units = s.units;
            self.units_given = true;
        }
        self.plane = s.plane;
        self.absolute = s.absolute;
        self.arc_absolute = s.arc_absolute;
        self.feed_mode = s.feed_mode;
        self.work = s.work;
        self.retract_to_r = s.retract_to_r;
        self.path_mode = s.path_mode;
        // Written back as `F%.1f` and `S%.0f` (`gen_settings`), then read.
        if s.feed != self.feed {
            self.feed = format!("{:.1}", s.feed).parse().unwrap_or(s.feed);
        }
        if s.spindle_rpm != self.spindle_rpm {
            self.spindle_rpm = format!("{:.0}", s.spindle_rpm)
                .parse()
                .unwrap_or(s.spindle_rpm);
        }
        self.spindle_dir = s.spindle_dir;
        (self.mist, self.flood) = (s.mist, s.flood);
        Ok(())
    }
}
