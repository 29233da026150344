//! Under G61, a reversal at a line's end of an axis the line does not
//! move: the axis held to the corner instead (docs/compensation.md, "A
//! still axis' reversal at a line's end is held to the corner").
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
//! any solved point). The corner decides the rest, where G61 stops
//! anyway (LinuxCNC's tp.c `tpSetupTangent` finds no tangency there): a
//! next motion that moves the axis its old way runs on from the held
//! command with no reversal at all; one that moves it the new way takes
//! the reversal up at its start, at the corner.

use volcomp_gcode::Vec3;

/// The most a held axis may leave the tool off its target (mm): the G61
/// contour tolerance (`options::DEFAULT_EXACT_CONTOUR_TOLERANCE_UM`).
pub(super) const HOLD_MM: f64 = super::options::DEFAULT_EXACT_CONTOUR_TOLERANCE_UM * 1e-3;

/// What a still axis' nominal coordinate may differ by along the motion
/// (mm): far below the written step (0.01 µm), so only an axis the program
/// does not move counts.
const STILL_MM: f64 = 1e-9;

/// Whether some axis reverses (`reversed`) and every reversing axis is one
/// the motion from `start` through `targets` does not move nominally.
pub(super) fn only_still_axes_reverse(reversed: [bool; 3], start: Vec3, targets: &[Vec3]) -> bool {
    reversed.iter().any(|r| *r)
        && (0..3).all(|a| {
            !reversed[a] || targets.iter().all(|t| (t[a] - start[a]).abs() <= STILL_MM)
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_reversal_of_an_axis_the_line_does_not_move_is_held_at_its_end() {
        // A raster's pass along X at Y −12, Z rising: Y still.
        let start = Vec3::new(16.2, -12.0, -0.2089);
        let targets = [Vec3::new(17.1, -12.0, -0.2020), Vec3::new(18.0, -12.0, -0.1950)];
        assert!(only_still_axes_reverse([false, true, false], start, &targets));
        // Z moves along the pass: not held.
        assert!(!only_still_axes_reverse([false, true, true], start, &targets));
        assert!(!only_still_axes_reverse([false, false, true], start, &targets));
        // Nothing reverses: nothing to hold.
        assert!(!only_still_axes_reverse([false; 3], start, &targets));
        // Y moves by a micrometre on the way: not still.
        let wavy = [Vec3::new(17.1, -12.001, -0.2020), Vec3::new(18.0, -12.0, -0.1950)];
        assert!(!only_still_axes_reverse([false, true, false], start, &wavy));
    }
}
