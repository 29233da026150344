//! Under G61, a take-up ramp on a line centred on its reversal
//! (docs/compensation.md, "A ramp centred on a reversal along a line").
//!
//! An axis that stands still along a line (a zigzag's Y and Z along X)
//! still has its command follow the map, and on a map interpolated
//! between table points that command turns back at a table point with a
//! kink: its slope jumps from `s₁` to `−s₂`. A ramp that starts at the
//! reversal ([`super::points`] `plan_ramp`) holds the tool at the
//! reversal's level while the motor crosses its band over the ramp's
//! length `L`, and the target runs away from it by `s₂·L`. The ramp's
//! length is set by the planner's tangency tolerance (tp.c
//! `tpSetupTangent`, `points::ramp_length_mm`): 3.8 mm for a 7 µm band at
//! F6000, so a slope of 0.1 µm/mm on two axes leaves about 0.5 µm, above
//! the 0.4 µm a G61 ramp may leave (`RUN_THROUGH_TOLERANCE_MM`), and the
//! take-up becomes a block the machine stops at (about `v/a` each).
//!
//! Tried only where the take-up would otherwise be such a block (no fold,
//! plain ramp or hold took it). Started `L/2` before the reversal, the motor begins crossing its band
//! while the target still drifts its old way (the axis stands on the
//! ramp, `points::hold_on_ramp`), and the tool, held at the ramp start's
//! level, is off by at most `max(s₁, s₂)·L/2` (at the reversal, `s₁·L/2`;
//! at the ramp's end `|s₁ − s₂|·L/2`): half. The ramp runs on the
//! machinery of a take-up moved ahead of an S-curve (`points::Ahead`):
//! the targets from the ramp's start are solved again, the reversing axes
//! in their new direction.

use volcomp_gcode::Vec3;

/// How far a centred ramp may leave the tool from the path (mm): half the
/// run-through tolerance of any G61 ramp (`points::RUN_THROUGH_TOLERANCE_MM`,
/// 0.4 µm), so its mean square stays within a quarter of it too
/// (`ramp_band::within`). Measured on the shop map at F6000
/// (bench/eval/run.py, G61, the centred ramp tried first; cutting time Δ
/// and band RMS reduction against
/// 99.63 % / 98.47 % with no centred ramp): at 0.4 µm zigzag +20.2 %
/// 98.91 %, pocket_r4 +38.1 % 98.27 %; at 0.3 µm +36.0 % 99.17 %,
/// +47.1 % 98.34 %; at 0.2 µm +49.4 % 99.34 %, +54.1 % 98.43 %. Each ramp
/// that stands the tool off by a few tenths over its 3 mm adds to the
/// contour's RMS, which the 99 % goal bounds at about 0.075 µm on this
/// map: 0.2 µm keeps it, 0.3 µm takes rows already below it further down.
pub(super) const TOLERANCE_MM: f64 = 0.2e-3;

/// Where a ramp of `length_mm` centred on the reversal at the start of
/// target `index`'s piece begins, on the polyline `start`, `targets[..]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct CentredStart {
    /// The target solved again from (the one whose piece holds the
    /// ramp's start, or the one after a start at a piece's end).
    pub(super) from: usize,
    /// The point inserted before `targets[from]` where the ramp starts
    /// inside that piece; `None` where it starts at a piece's start.
    pub(super) insert: Option<Vec3>,
    /// The ramp's length from where it starts to its end `length_mm −
    /// lead_mm` after the reversal (mm).
    pub(super) ramp_mm: f64,
}

/// The start of a ramp of `length_mm` around the reversal at
/// `targets[index − 1]` (the start of target `index`'s piece), along the
/// polyline from `start`: `lead_mm` before it (`length_mm/2`: centred),
/// moved to the nearer
/// end of its piece where that is closer than `shortest_mm` (no piece
/// shorter than the planner runs at the feed), and to the motion's start
/// where the motion is shorter before the reversal. `None` where the
/// ramp would begin less than `shortest_mm` before the reversal (no lead
/// at all: the plain ramp from the reversal is that).
pub(super) fn centred_start(
    start: Vec3,
    targets: &[Vec3],
    index: usize,
    (lead_mm, length_mm): (f64, f64),
    shortest_mm: f64,
) -> Option<CentredStart> {
    if index == 0
        || index >= targets.len()
        || !(length_mm > 0.0 && length_mm.is_finite())
        || !(lead_mm >= 0.0 && lead_mm <= length_mm)
    {
        return None;
    }
    // Distance along the polyline to each target up to the reversal.
    let mut along = Vec::with_capacity(index);
    let mut prev = start;
    let mut s = 0.0;
    for t in &targets[..index] {
        s += (*t - prev).norm();
        along.push(s);
        prev = *t;
    }
    let s0 = along[index - 1];
    let s_start = (s0 - lead_mm).max(0.0);
    let p = along.iter().position(|a| *a > s_start + 1e-9)?;
    let piece_start = if p == 0 { 0.0 } else { along[p - 1] };
    let (from, insert, s_ramp) = if s_start - piece_start < shortest_mm {
        (p, None, piece_start)
    } else if along[p] - s_start < shortest_mm {
        (p + 1, None, along[p])
    } else {
        let a = if p == 0 { start } else { targets[p - 1] };
        let f = (s_start - piece_start) / (along[p] - piece_start);
        (p, Some(a + (targets[p] - a) * f), s_start)
    };
    if s0 - s_ramp < shortest_mm || from >= index {
        return None;
    }
    Some(CentredStart {
        from,
        insert,
        ramp_mm: (s0 + (length_mm - lead_mm) - s_ramp).max(length_mm),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn x(v: f64) -> Vec3 {
        Vec3::new(v, 0.0, 0.0)
    }

    #[test]
    fn a_ramp_of_4_mm_on_a_line_split_every_10_mm_starts_2_mm_before() {
        // Line from X0, targets at 10, 20, 30; the reversal at X20 (start
        // of target 2's piece). A 4 mm ramp starts at X18, inside the
        // piece 10–20: a point inserted there, solved again from target 1,
        // and the ramp runs 4 mm (X18 to X22).
        let c = centred_start(x(0.0), &[x(10.0), x(20.0), x(30.0)], 2, (2.0, 4.0), 0.2).unwrap();
        assert_eq!(c.from, 1);
        let p = c.insert.unwrap();
        assert!((p.x - 18.0).abs() < 1e-12 && p.y == 0.0, "{p:?}");
        assert!((c.ramp_mm - 4.0).abs() < 1e-12);
    }

    #[test]
    fn a_start_near_a_target_moves_to_it() {
        // Targets at 10, 17.9, 20: the start X18 is 0.1 mm after 17.9,
        // less than the 0.2 mm piece: the ramp starts at 17.9 (target 2
        // solved again, no point inserted), 2.1 + 2 = 4.1 mm long.
        let c = centred_start(
            x(0.0),
            &[x(10.0), x(17.9), x(20.0), x(30.0)],
            3,
            (2.0, 4.0),
            0.2,
        )
        .unwrap();
        assert_eq!((c.from, c.insert), (2, None));
        assert!((c.ramp_mm - 4.1).abs() < 1e-12);
        // Targets at 10, 18.1, 20: 0.1 mm before 18.1: starts at 18.1
        // (target 2 solved again from its start), 1.9 + 2 → at least 4.
        let c = centred_start(
            x(0.0),
            &[x(10.0), x(18.1), x(20.0), x(30.0)],
            3,
            (2.0, 4.0),
            0.2,
        )
        .unwrap();
        assert_eq!((c.from, c.insert), (2, None));
        assert!((c.ramp_mm - 4.0).abs() < 1e-12);
    }

    #[test]
    fn no_room_before_the_reversal_gives_none_or_the_motion_start() {
        // The reversal 0.1 mm after the motion's start: no lead.
        assert_eq!(
            centred_start(x(0.0), &[x(0.1), x(5.0)], 1, (2.0, 4.0), 0.2),
            None
        );
        // The reversal 1 mm after it: the ramp starts at the motion's
        // start and runs 1 + 2 = 3 → at least its 4 mm.
        let c = centred_start(x(0.0), &[x(1.0), x(5.0)], 1, (2.0, 4.0), 0.2).unwrap();
        assert_eq!((c.from, c.insert), (0, None));
        assert!((c.ramp_mm - 4.0).abs() < 1e-12);
        // No reversal before the first target.
        assert_eq!(centred_start(x(0.0), &[x(1.0)], 0, (2.0, 4.0), 0.2), None);
    }
}
