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
}

impl Interpreter {
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
