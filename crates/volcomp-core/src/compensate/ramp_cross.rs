//! The step a reversal makes across the reversing axis, spread over a G61
//! take-up ramp (docs/compensation.md, "The step across the reversing
//! axis, spread over the ramp").
//!
//! When an axis reverses, its new direction's table moves the tool along
//! the other axes too (its straightness, a few tenths of a micrometre).
//! The take-up command ([`super::points`] `take_up_command`) lets the other
//! axes follow that step only toward the segment's own command; the rest
//! is left to the solution of the next target. On a ramp of 0.2 mm pieces
//! that rest lands on the ramp's first piece: a 0.3 µm step across a
//! 0.2 mm piece turns the path by 1.5 mrad at both of its ends, three
//! times what LinuxCNC's planner takes as tangent between arcs at F6000
//! (0.495 mrad: `tpSetupTangent`, src/emc/tp/tp.c), so it blends there
//! and slows. Here the whole step, on every axis, is taken into the
//! ramp's take-up and caught up with it along the ramp's smooth step.

use super::frame::Frame;
use crate::error::ModelError;
use crate::model::{AxisCells, Components, Directions, ErrorModel};
use volcomp_gcode::Vec3;

/// The command that keeps the tool where it stands at `q_prev` when the
/// `reversed` axes switch from `s_old` to their direction in `s_new`, every
/// axis following the switch (the image under the new state equal to the
/// one under the old). [`super::points`] `take_up_command` is this with the
/// axes that do not reverse held to the segment's own way.
pub(super) fn full_take_up_mm(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    q_prev: Vec3,
    (s_old, s_new): (Directions, Directions),
    reversed: [bool; 3],
    frame: &Frame,
) -> Result<Vec3, ModelError> {
    let held = cells.actual_again_mm(model, q_prev, s_old)?;
    let mut s = s_old;
    for a in 0..3 {
        if reversed[a] {
            s[a] = s_new[a];
        }
    }
    let mut q = q_prev;
    // A fixed point a few rounds away (the tables' slopes are 10⁻⁵); it
    // stops where the command repeats bit for bit.
    for _ in 0..8 {
        let img = cells.actual_mm(model, q, s, Components::All)?;
        let next = q + (held - img);
        if (0..3).all(|a| next[a].to_bits() == q[a].to_bits()) {
            break;
        }
        q = next;
    }
    Ok(frame.quantize(q, q_prev))
}

/// The take-up a ramp spreads: the reversing axes' own `delta`, and on the
/// other axes the whole step of the switch (`full − q_prev`,
/// [`full_take_up_mm`]) in place of the part the take-up command let them
/// follow.
pub(super) fn ramp_delta_mm(delta: Vec3, full: Vec3, q_prev: Vec3, reversed: [bool; 3]) -> Vec3 {
    let mut d = delta;
    for a in 0..3 {
        if !reversed[a] {
            d[a] = full[a] - q_prev[a];
        }
    }
    d
}

/// Whether the step across in a ramp's take-up `d` (beyond the take-up
/// command's own `delta`) moves an axis that does not reverse against its
/// direction in `s`: that axis would reverse for it, there and back
/// (docs/compensation.md, "Take-ups folded into the move"). Such a ramp is
/// bounded with the whole step on top of its bound, as a ramp that may
/// leave the step to a reversal of that axis; one whose step runs with
/// the directions by its bound alone, whose lags carry the step fading
/// with the reversing axis' band.
pub(super) fn step_turns_back(d: Vec3, delta: Vec3, s: Directions, reversed: [bool; 3]) -> bool {
    (0..3).any(|a| !reversed[a] && (d[a] - delta[a]) * s[a].sign() < 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ramp_takes_the_whole_step_across_and_the_reversing_axis_own_take_up() {
        // Z reverses with a take-up of −2 µm; the switch moves the tool by
        // (−0.28, +0.12) µm across, of which the take-up command let only Y
        // follow (toward the segment's own command): the ramp spreads the
        // whole step on X and Y and keeps Z's own take-up.
        let q_prev = Vec3::new(13.742, -6.0, 0.0003);
        let delta = Vec3::new(0.0, 0.00012, -0.002);
        let full = q_prev + Vec3::new(-0.00028, 0.00012, -0.0021);
        let d = ramp_delta_mm(delta, full, q_prev, [false, false, true]);
        assert!((d.x + 0.00028).abs() < 1e-12, "{d:?}");
        assert!((d.y - 0.00012).abs() < 1e-12, "{d:?}");
        assert!((d.z + 0.002).abs() < 1e-15, "{d:?}");
    }

    #[test]
    fn a_step_against_an_axis_direction_turns_it_back() {
        use crate::model::Direction::{Forward, Reverse};
        // Z reverses; X was last moving forward (+), Y backward (−).
        let delta = Vec3::new(0.0, 0.0, -0.002);
        let rev = [false, false, true];
        let s = [Forward, Reverse, Reverse];
        let with = Vec3::new(0.0003, -0.0001, -0.002);
        assert!(!step_turns_back(with, delta, s, rev));
        let against_x = Vec3::new(-0.0003, -0.0001, -0.002);
        assert!(step_turns_back(against_x, delta, s, rev));
        let against_y = Vec3::new(0.0003, 0.0001, -0.002);
        assert!(step_turns_back(against_y, delta, s, rev));
    }
}
