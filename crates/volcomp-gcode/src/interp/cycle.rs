//! Canned drilling cycles G81, G82, G85 and G89, expanded into the rapid
//! and feed moves LinuxCNC makes for them.

use super::words::WordTable;
use super::{invalid, unsupported, Interpreter, Motion, MotionKind, MotionSource};
use crate::error::GcodeError;
use crate::geom::{Plane, Vec3};

impl Interpreter {
    /// Expands G81/G82/G85/G89 in the XY plane as LinuxCNC 2.9 does
    /// (`convert_cycle_xy` and its `CYCLE_MACRO`): R and Z are sticky while
    /// the same cycle continues; the Z where the run of cycle blocks began is
    /// the G98 clearance and the base of incremental R.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn cycle(
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
