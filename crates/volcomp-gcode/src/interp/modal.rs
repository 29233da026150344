//! The path-control mode (G61, G61.1, G64 P… Q…) and
//! M70 (save modal state), M71 (invalidate it) and M72 (restore it), as
//! LinuxCNC 2.9's `Interp::save_settings` / `restore_settings`
//! (src/emc/rs274ngc/interp_convert.cc) do them at the top level of a
//! program. M72 must stand on its line alone (LinuxCNC restores by running
//! generated blocks in place of the current one, so other words on the line
//! would not run as written). The restore sets units first (G20/G21), then plane, distance modes, feed mode, coordinate
//! system, retract mode, the feed rate (rounded to 0.1, `F%.1f`) and the
//! spindle speed (`S%.0f`). Where the restored state includes something
//! volcomp does not replay (a different tool length offset or G92 state
//! than at the save), M72 is refused. M73 (save, restored when a
//! subroutine returns) needs the subroutine's return and stays refused here.

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

/// The state M70 saves.
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
    tlo: Vec3,
    g92: Vec3,
    path_mode: PathMode,
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

    /// M70, M71, M72 of the block (M72 restores before the block's G codes).
    pub(super) fn modal_save_restore(
        &mut self,
        line: u64,
        w: &WordTable,
    ) -> Result<(), GcodeError> {
        let col = |code: u16| w.m.iter().find(|(c, _)| *c == code).map_or(0, |(_, c)| *c);
        if w.has_m(700) {
            self.saved_modes = Some(SavedModes {
                units: self.units,
                plane: self.plane,
                absolute: self.absolute,
                arc_absolute: self.arc_absolute,
                feed_mode: self.feed_mode,
                work: self.work,
                retract_to_r: self.retract_to_r,
                feed: self.feed,
                spindle_rpm: self.spindle_rpm,
                tlo: self.tlo,
                g92: self.g92,
                path_mode: self.path_mode,
            });
        } else if w.has_m(710) {
            if self.saved_modes.take().is_none() {
                return Err(invalid(
                    line,
                    col(710),
                    "M71 without a state saved by M70; LinuxCNC refuses it",
                    "save the state with M70 first",
                ));
            }
        } else if w.has_m(720) {
            let Some(s) = self.saved_modes else {
                return Err(invalid(
                    line,
                    col(720),
                    "M72 without a state saved by M70; LinuxCNC refuses it (\"Cannot restore context from invalid stack frame - missing M70/M73?\")",
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
            if s.tlo != self.tlo || s.g92 != self.g92 {
                return Err(unsupported(
                    line,
                    col(720),
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
            if s.feed != self.feed {
                self.feed = (s.feed * 10.0).round() / 10.0;
            }
            if s.spindle_rpm != self.spindle_rpm {
                self.spindle_rpm = s.spindle_rpm.round();
            }
        }
        Ok(())
    }
}
