//! Under G61, a reversal at a line's end of an axis the line does not
//! move, which the next motion moves its old way: the axis held through
//! the corner instead (docs/compensation.md, "A still axis' reversal at a
//! line's end that the next motion turns back is held").
//!
//! An axis a line does not move (a raster pass' Y) still has its command
//! follow the map, and where its target drifts back by a hundredth of a
//! micrometre at the line's end the consistent solve
//! (compensate/solve.rs `solve_consistent`) reverses it: its whole band is
//! taken up on the line (a fold, a ramp or a block). Under the dead band
//! of docs/design.md that reversal moves no carriage the target asked for
//! (the carriage would stand for a change far below its band, the tool
//! off by the change either way), but the switch moves the tool across
//! the other axes by the switching axis' straightness while its band is
//! crossed, and where the next motion moves the axis its old way it must
//! reverse back at the corner, a second band and a second switch. At a
//! raster's step-over on bench/coarse_map.py's map (straightness that
//! switches by ±1–2.5 µm) that second switch (Y) is one of two at the
//! corner (X reverses there too) whose steps each run against the
//! other's motion, so no order of take-up blocks keeps the tool on the
//! path (compensate/take_up_order.rs): 4.9–5.1 µm.
//!
//! Held at its command in its old direction
//! ([`crate::compensate::solve::hold_small_reversals`]) at the line's
//! last target, the axis does not reverse on the line: the tool is off by
//! the target's change alone, within the G61 contour tolerance
//! (`options::DEFAULT_EXACT_CONTOUR_TOLERANCE_UM`, 0.05 µm: as close as
//! any solved point), and the next motion moves the axis on its old way
//! from the held command, with no reversal at all. Only where the next
//! motion is known to do so: a held tail's next motion (mod.rs
//! `solve_tail`), or the next line's text where it is a plain G0/G1 in
//! absolute coordinates ([`keep_next_line`] and [`direction_of`], a peek that reads and
//! runs nothing: volcomp-gcode `LineEvent::next`). Held without that
//! (the corner deciding), a reversal moved into a corner where another
//! axis reverses too, and the two switches in one take-up block left the
//! tool 0.24–0.29 µm off on the example map's chord circles (bench/eval,
//! set a, F6000, against 0.05 µm). A plunge is left to its own hold.

use crate::model::{Direction, Directions};
use volcomp_gcode::{LineEvent, Vec3};

/// The most a held axis may leave the tool off its target (mm): the
/// contour tolerance of the other modes
/// (`options::DEFAULT_CONTOUR_TOLERANCE_UM`, 0.1 µm, the error a piece may
/// leave between its points), twice G61's own.
pub(super) const HOLD_MM: f64 = super::options::DEFAULT_CONTOUR_TOLERANCE_UM * 1e-3;

/// What a still axis' nominal coordinate may differ by along the motion
/// (mm): far below the written step (0.01 µm), so only an axis the program
/// does not move counts.
const STILL_MM: f64 = 1e-9;

/// Whether some axis reverses (`reversed`) and every reversing axis is one
/// the motion from `start` through `targets` does not move nominally, on a
/// motion that moves X or Y: a plunge (Z alone) is left to the plunge's
/// own hold (points.rs `hold_to_plunge_end`; held here too, a reversal at
/// the plunge's end moved into the corner after it, where Z reverses as
/// well: 0.29 µm on the example map's chord circles, bench/eval set a,
/// F6000, against 0.05 µm).
pub(super) fn only_still_axes_reverse(reversed: [bool; 3], start: Vec3, targets: &[Vec3]) -> bool {
    let moved = |a: usize| targets.iter().any(|t| (t[a] - start[a]).abs() > STILL_MM);
    reversed.iter().any(|r| *r)
        && (moved(0) || moved(1))
        && (0..3)
            .all(|a| !reversed[a] || targets.iter().all(|t| (t[a] - start[a]).abs() <= STILL_MM))
}

/// The least direction cosine along which the next motion must move a held
/// axis its old way (as take_up_advance.rs `LEAST_COSINE`): a motion nearly
/// across the axis moves it by less than the compensation's own drift
/// over a short piece, so its direction there is the map's, not the
/// program's.
pub(super) const LEAST_COSINE: f64 = 0.02;

/// Whether every reversing axis of `reversed` (state before: `s_prev`) is
/// moved its old way by a motion that starts along the unit `next_dir`,
/// and some axis reverses.
pub(super) fn next_turns_back(reversed: [bool; 3], s_prev: Directions, next_dir: Vec3) -> bool {
    reversed.iter().any(|r| *r)
        && (0..3).all(|a| {
            !reversed[a]
                || match s_prev[a] {
                    Direction::Forward => next_dir[a] >= LEAST_COSINE,
                    Direction::Reverse => next_dir[a] <= -LEAST_COSINE,
                }
        })
}

/// Where the next motion starts, as a G61 line is solved: known (a held
/// tail's next motion), or the next line's text kept in `State::next_text`
/// with the program position it starts from, read only where a hold is
/// asked ([`direction_of`]: parsing every line's successor cost 8 % of the
/// instructions of a G61 CAM program, bench/callgrind.sh q20kg61).
#[derive(Clone, Copy, Debug)]
pub(super) enum NextDir {
    Known(Vec3),
    Text(Vec3),
}

impl super::State<'_> {
    /// The unit direction of `next`, reading the kept text where needed.
    pub(super) fn next_direction(&self, next: NextDir) -> Option<Vec3> {
        match next {
            NextDir::Known(u) => Some(u),
            NextDir::Text(from) => direction_of(&self.next_text, from),
        }
    }
}

/// The text of the line after `ev` copied into `buf`, and the program
/// position it starts from, where its direction may be read from it: in
/// absolute coordinates (G90), with no arc modal, no coordinate rotation
/// and no cutter radius compensation in effect after `ev`, the main
/// program's next line already read and run next (volcomp-gcode
/// `LineEvent::next`). `None` otherwise (not known: no hold).
pub(super) fn keep_next_line(ev: &LineEvent, buf: &mut Vec<u8>) -> Option<Vec3> {
    let interp = ev.interp;
    if ev.after_end
        || !interp.absolute()
        || interp.arc_mode()
        || interp.rotation_deg() != 0.0
        || interp.cutter_comp_on()
    {
        return None;
    }
    let bytes = ev.next.bytes()?;
    buf.clear();
    buf.extend_from_slice(bytes);
    Some(interp.program_position())
}

/// The unit direction (program frame, which the axis frame translates
/// without rotation here) of a line's text `bytes` from the program
/// position `from`, where it is a plain straight move: only G0/G1, N, F
/// and X/Y/Z words with plain numbers (and comments), and some axis word
/// that moves. `None` otherwise.
pub(super) fn direction_of(bytes: &[u8], from: Vec3) -> Option<Vec3> {
    let mut to = from;
    let mut moves = false;
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        i += 1;
        match c {
            b' ' | b'\t' | b'\r' | b'\n' => {}
            b'(' => i += memchr_close(&bytes[i..])? + 1,
            b';' => break,
            _ => {
                let letter = c.to_ascii_uppercase();
                let (value, used) = plain_number(&bytes[i..])?;
                i += used;
                match letter {
                    b'G' if value == 0.0 || value == 1.0 => {}
                    b'N' | b'F' => {}
                    b'X' | b'Y' | b'Z' => {
                        let a = usize::from(letter - b'X');
                        to[a] = value;
                        moves |= value != from[a];
                    }
                    _ => return None,
                }
            }
        }
    }
    let d = to - from;
    let n = d.norm();
    (moves && n > 0.0).then(|| d * (1.0 / n))
}

/// The offset of the `)` closing a comment in `rest`.
fn memchr_close(rest: &[u8]) -> Option<usize> {
    rest.iter().position(|c| *c == b')')
}

/// A plain number at the start of `rest` (spaces and tabs before it
/// skipped, an optional sign, digits with at most one point) and the bytes
/// it took; `None` for anything else (a parameter, an expression).
fn plain_number(rest: &[u8]) -> Option<(f64, usize)> {
    let mut i = 0;
    while i < rest.len() && matches!(rest[i], b' ' | b'\t') {
        i += 1;
    }
    let start = i;
    if i < rest.len() && matches!(rest[i], b'+' | b'-') {
        i += 1;
    }
    let digits_from = i;
    let mut point = false;
    while i < rest.len() && (rest[i].is_ascii_digit() || (rest[i] == b'.' && !point)) {
        point |= rest[i] == b'.';
        i += 1;
    }
    if i == digits_from || (i == digits_from + 1 && point) {
        return None;
    }
    let text = std::str::from_utf8(&rest[start..i]).ok()?;
    text.parse::<f64>().ok().map(|v| (v, i))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Direction::{Forward, Reverse};

    #[test]
    fn a_hold_needs_the_next_motion_to_move_every_reversing_axis_its_old_way() {
        // A raster's step-over along +Y (and Z up) after a pass along +X:
        // Y was forward before the line's end turned it back.
        let step_over = Vec3::new(0.0, 3.0, 0.58) * (1.0 / (9.0_f64 + 0.58 * 0.58).sqrt());
        assert!(next_turns_back(
            [false, true, false],
            [Forward, Forward, Forward],
            step_over
        ));
        // Y was reversed: the step-over does not turn it back.
        assert!(!next_turns_back(
            [false, true, false],
            [Forward, Reverse, Forward],
            step_over
        ));
        // X reverses too, and the step-over does not move X: no hold.
        assert!(!next_turns_back(
            [true, true, false],
            [Forward, Forward, Forward],
            step_over
        ));
        // Nothing reverses: nothing to hold.
        assert!(!next_turns_back(
            [false; 3],
            [Forward, Forward, Forward],
            step_over
        ));
        // A motion that moves Y by less than the least cosine.
        let across = Vec3::new(1.0, 0.01, 0.0) * (1.0 / (1.0_f64 + 1e-4).sqrt());
        assert!(!next_turns_back(
            [false, true, false],
            [Forward, Forward, Forward],
            across
        ));
    }

    #[test]
    fn a_plain_straight_line_gives_its_direction_and_anything_else_none() {
        let from = Vec3::new(18.0, -12.0, -0.195);
        // A step-over to Y −9 (by hand: (0, 3, 0) / 3).
        let u = direction_of(b"G1 Y-9.0 (step) F600", from).unwrap();
        assert!((u - Vec3::new(0.0, 1.0, 0.0)).norm() < 1e-12);
        // X and Z together: (−4, 0, 3) / 5.
        let u = direction_of(b"N20 x14 z2.805", from).unwrap();
        assert!((u - Vec3::new(-0.8, 0.0, 0.6)).norm() < 1e-12);
        // No motion, an arc, a parameter, another word: not known.
        assert_eq!(direction_of(b"G1 X18 F300", from).map(|_| ()), None);
        assert_eq!(direction_of(b"G2 X20 Y-10 R2", from).map(|_| ()), None);
        assert_eq!(direction_of(b"G1 X#1", from).map(|_| ()), None);
        assert_eq!(direction_of(b"G1 X20 M8", from).map(|_| ()), None);
        // A comment after `;` is skipped.
        let u = direction_of(b"X20 ; Y5", from).unwrap();
        assert!((u - Vec3::new(1.0, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn a_plain_number_is_read_and_anything_else_refused() {
        assert_eq!(plain_number(b"-9.0000 Z1"), Some((-9.0, 7)));
        assert_eq!(plain_number(b" 1"), Some((1.0, 2)));
        assert_eq!(plain_number(b"#1"), None);
        assert_eq!(plain_number(b"[1+2]"), None);
        assert_eq!(plain_number(b"."), None);
    }

    #[test]
    fn only_a_reversal_of_an_axis_the_line_does_not_move_is_held_at_its_end() {
        // A raster's pass along X at Y −12, Z rising: Y still.
        let start = Vec3::new(16.2, -12.0, -0.2089);
        let targets = [
            Vec3::new(17.1, -12.0, -0.2020),
            Vec3::new(18.0, -12.0, -0.1950),
        ];
        assert!(only_still_axes_reverse(
            [false, true, false],
            start,
            &targets
        ));
        // Z moves along the pass: not held.
        assert!(!only_still_axes_reverse(
            [false, true, true],
            start,
            &targets
        ));
        assert!(!only_still_axes_reverse(
            [false, false, true],
            start,
            &targets
        ));
        // Nothing reverses: nothing to hold.
        assert!(!only_still_axes_reverse([false; 3], start, &targets));
        // A plunge: left to its own hold.
        let plunge = [Vec3::new(16.2, -12.0, -1.0)];
        assert!(!only_still_axes_reverse(
            [false, true, false],
            start,
            &plunge
        ));
        // Y moves by a micrometre on the way: not still.
        let wavy = [
            Vec3::new(17.1, -12.001, -0.2020),
            Vec3::new(18.0, -12.0, -0.1950),
        ];
        assert!(!only_still_axes_reverse([false, true, false], start, &wavy));
    }
}
