//! Rotary and extra axes A, B, C, U, V, W: read, carried through unchanged,
//! never compensated.
//!
//! The error map is of X, Y and Z, so volcomp corrects the tool point only;
//! a rotary axis's own errors (its angular positioning error, the wobble of
//! its axis of rotation) are not modelled and not compensated. The extra
//! axes are tracked so that every motion knows where they start and end:
//! LinuxCNC moves them linearly with the motion, in G1 and G0 and also over
//! an arc (`ARC_FEED` takes the end values of A, B, C, U, V, W and the
//! trajectory planner interpolates them linearly over the arc's length), so
//! when `compensate` splits a motion into segments each segment carries its
//! share of the extra axes' motion.
//!
//! Offsets: volcomp's set-up gives work offsets and reference points for X,
//! Y and Z only; the extra axes have zero work offsets. G92 (`G92 X0 Y0 Z0
//! A0` is common) sets, clears (G92.1, G92.2) and restores (G92.3) an offset
//! of the extra axes as LinuxCNC does for every axis. A G10, G28 or G30 with
//! an extra-axis word is refused (it would set a work offset or a reference
//! point volcomp does not track). As in LinuxCNC
//! (`Interp::convert_cycle`, interp_cycles.cc: "Cannot put an a in canned
//! cycle"), canned cycles refuse them.

use super::words::WordTable;
use super::{invalid, unsupported, Interpreter};
use crate::error::GcodeError;

/// The extra axes' letters, in the order of [`ExtraAxes`]' arrays.
pub const EXTRA_LETTERS: [u8; 6] = *b"ABCUVW";

/// Positions of the extra axes at the start and end of a motion: A, B, C in
/// degrees, U, V, W in mm (axis frame; zero offsets). All zero in a
/// program that never names them.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ExtraAxes {
    /// A, B, C (degrees), U, V, W (mm) where the motion starts.
    pub start: [f64; 6],
    /// A, B, C (degrees), U, V, W (mm) where the motion ends.
    pub end: [f64; 6],
}

impl ExtraAxes {
    /// Whether any extra axis moves: `start != end`, element by element
    /// (an array's `!=` is "some element differs"), written out without the
    /// slice comparison's loop and early exit (no branch per axis).
    #[inline]
    pub fn moves(&self) -> bool {
        let (s, e) = (&self.start, &self.end);
        (s[0] != e[0])
            | (s[1] != e[1])
            | (s[2] != e[2])
            | (s[3] != e[3])
            | (s[4] != e[4])
            | (s[5] != e[5])
    }

    /// The extra axes at fraction `t ∈ [0, 1]` of the motion: linear, as the
    /// controller moves them; exact at `t = 1`.
    pub fn at(&self, t: f64) -> [f64; 6] {
        if t >= 1.0 {
            return self.end;
        }
        let mut p = self.start;
        for (v, e) in p.iter_mut().zip(self.end) {
            *v += (e - *v) * t;
        }
        p
    }
}

impl WordTable {
    /// Column of the block's first extra-axis word (A B C U V W), if any.
    pub(super) fn extra_col(&self) -> Option<usize> {
        EXTRA_LETTERS.iter().filter_map(|l| self.col(*l)).min()
    }
}

impl Interpreter {
    /// The extra axes' target of a motion block: each word absolute (G90) or
    /// added to the current value (G91); U, V, W in program units, A, B, C in
    /// degrees whatever the units. Refuses them where volcomp cannot follow
    /// LinuxCNC (see the module documentation).
    pub(super) fn extra_target(&mut self, line: u64, w: &WordTable) -> Result<(), GcodeError> {
        self.extra_target = self.extra;
        // G92.1 / G92.2 / G92.3 act on every axis, named or not.
        if w.has_g(921) {
            self.extra_g92 = [0.0; 6];
            self.extra_g92_saved = [0.0; 6];
        } else if w.has_g(922) {
            self.extra_g92 = [0.0; 6];
        } else if w.has_g(923) {
            self.extra_g92 = self.extra_g92_saved;
        }
        let Some(col) = w.extra_col() else {
            if w.has_g(920) || w.has_g(520) {
                self.extra_g92_saved = self.extra_g92;
            }
            return Ok(());
        };
        let letter = EXTRA_LETTERS
            .into_iter()
            .find(|l| w.col(*l) == Some(col))
            .unwrap_or(b'A') as char;
        if w.has_g(920) || w.has_g(520) {
            // G92: the current position gets the given program values;
            // G52: the offset is the given value (it shares G92's offset).
            for (i, l) in EXTRA_LETTERS.into_iter().enumerate() {
                if let Some(v) = w.get(l) {
                    let v = if i >= 3 { self.to_mm(v) } else { v };
                    self.extra_g92[i] = if w.has_g(520) { v } else { self.extra[i] - v };
                }
            }
            self.extra_g92_saved = self.extra_g92;
            self.uses_extra_axes = true;
            return Ok(());
        }
        if let Some(code) = [100u16, 280, 300].into_iter().find(|c| w.has_g(*c)) {
            return Err(unsupported(
                line,
                col,
                format!(
                    "{letter} word with G{}: volcomp tracks offsets and reference points of X, Y and Z only, so it cannot follow what this sets for the extra axis",
                    code / 10
                ),
                "set the extra axes' offsets and reference points on the controller, or leave the extra-axis words out of this line",
            ));
        }
        if matches!(
            self.motion_to_be(w),
            Some(super::options::MotionMode::Cycle(_))
        ) {
            return Err(invalid(
                line,
                col,
                format!(
                    "{letter} word in a canned cycle: LinuxCNC refuses it (\"Cannot put an {} in canned cycle\")",
                    letter.to_ascii_lowercase()
                ),
                "move the extra axis on its own line before the cycle",
            ));
        }
        self.uses_extra_axes = true;
        for (i, l) in EXTRA_LETTERS.into_iter().enumerate() {
            if let Some(v) = w.get(l) {
                let v = if i >= 3 { self.to_mm(v) } else { v };
                let g92 = if w.has_g(530) { 0.0 } else { self.extra_g92[i] };
                self.extra_target[i] = if self.absolute {
                    v + g92
                } else {
                    self.extra[i] + v
                };
                if !self.extra_target[i].is_finite()
                    || self.extra_target[i].abs() > super::MAX_COORDINATE_MM * 100.0
                {
                    return Err(invalid(
                        line,
                        w.col(l).unwrap_or(col),
                        format!("{} = {:e} is out of range", l as char, self.extra_target[i]),
                        "check the value and the distance mode (G90/G91)",
                    ));
                }
            }
        }
        Ok(())
    }

    /// Whether the program has named an extra axis (A B C U V W) so far.
    pub fn uses_extra_axes(&self) -> bool {
        self.uses_extra_axes
    }

    /// What is added to an extra axis's program value to get its position
    /// (its G92 offset; the work offsets of the extra axes are zero).
    pub fn extra_offset(&self) -> [f64; 6] {
        self.extra_g92
    }

    /// The extra axes' current position (A, B, C in degrees, U, V, W in mm).
    pub fn extra_position(&self) -> [f64; 6] {
        self.extra
    }
}

#[cfg(test)]
mod tests {
    use super::ExtraAxes;

    #[test]
    fn an_extra_axis_moves_when_its_end_differs_from_its_start_as_f64_compares() {
        let still = ExtraAxes::default();
        assert!(!still.moves());
        // By hand: -0 equals 0 (still), NaN equals nothing (moves). Second
        // method: the arrays' own `!=`.
        for k in 0..6 {
            for (v, moves) in [
                (1e-300, true),
                (-0.0, false),
                (f64::NAN, true),
                (360.0, true),
            ] {
                let mut e = still;
                e.end[k] = v;
                assert_eq!(e.moves(), moves, "axis {k}, {v}");
                assert_eq!(e.moves(), e.start != e.end, "axis {k}, {v}");
                let mut s = still;
                s.start[k] = v;
                assert_eq!(s.moves(), moves, "axis {k}, {v}");
            }
        }
    }
}
