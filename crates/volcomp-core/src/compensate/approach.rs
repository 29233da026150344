//! Each axis' dead band brought to a known side before the program cuts
//! (docs/compensation.md, "Each axis approaches from one side before the
//! first cut").
//!
//! Before the program's first motion neither the machine's position nor the
//! side each axis' dead band rests on is known: the model's `forward` before
//! any motion (docs/design.md) is an assumption, and the direction of the
//! first rapid depends on where the machine stood. After a move of at least
//! the band in one direction the band rests on that direction's side
//! whatever it did before (the unidirectional approach of ISO 230-2's
//! positioning tests). So:
//! - a rapid after the first motion, which starts where the program put the
//!   machine, settles each axis it moves by at least `δ = 2·b + 10 µm` for
//!   the axis' reversal value `b` ([`settled`]);
//! - an axis still unsettled at the first feed move gets a short rapid away
//!   from the feed's start against the direction the compensation holds and
//!   back ([`off_line`]), where the machine stands anyway: LinuxCNC's planner
//!   does not blend a rapid into a feed move (src/emc/tp/tp.c
//!   `tpCheckCanonType`), so the two short moves cost about `4·√(δ/A)`
//!   (18 ms for δ = 20 µm at 1,000 mm/s²) and the rapids are written as
//!   they were. The move away goes back along the way the axis came.

use super::walk::{Line, Place};
use super::State;
use crate::error::{CompensationError, ModelError};
use crate::model::{Components, Direction, Directions, ErrorModel};
use volcomp_gcode::Vec3;

impl State<'_> {
    /// The approach before a motion from `from_mm` (the direction state
    /// `s_from` there) to `q_mm` (the state `self.s` after it): the first
    /// motion, where a rapid, leaves every axis with a band unsettled; a
    /// later rapid settles the axes it moves by their `δ`; before the first
    /// feed move the axes still unsettled go to the returned point and back
    /// to `from_mm`. Not where the program's first motion is a feed move,
    /// nor where take-ups are off (`take_up`: no move is written for a
    /// dead band).
    pub(super) fn approach_before(
        &mut self,
        model: &dyn ErrorModel,
        feed_like: bool,
        (from_mm, s_from): (Vec3, Directions),
        q_mm: Vec3,
        take_up: bool,
    ) -> Result<Option<Vec3>, ModelError> {
        let Some(pending) = self.approach_pending else {
            self.approach_pending = Some([!feed_like && take_up; 3]);
            return Ok(None);
        };
        if !pending.iter().any(|a| *a) {
            return Ok(None);
        }
        if feed_like {
            let deltas = deltas_mm(model, from_mm, s_from)?;
            self.approach_pending = Some([false; 3]);
            return Ok(off_line(from_mm, s_from, deltas, pending));
        }
        let deltas = deltas_mm(model, q_mm, self.s)?;
        let settled = settled(from_mm, q_mm, deltas, pending);
        self.approach_pending = Some(std::array::from_fn(|a| pending[a] && !settled[a]));
        Ok(None)
    }

    /// [`State::approach_before`] for the writers of their own (canned
    /// cycles, splines): the approach, where one is due, written at `at`
    /// before the motion of `line` from `from_mm` (state `s_from`) to
    /// `end_mm`.
    pub(super) fn write_approach_before(
        &mut self,
        line: &Line,
        at: &Place,
        feed_like: bool,
        (from_mm, s_from): (Vec3, Directions),
        end_mm: Vec3,
    ) -> Result<(), CompensationError> {
        let take_up = self.walk.options.take_up;
        let away = self
            .approach_before(line.model(), feed_like, (from_mm, s_from), end_mm, take_up)
            .map_err(|source| super::model_error(self.walk.file, line.number(), source))?;
        if let Some(away) = away {
            self.write_approach(at, from_mm, away);
        }
        Ok(())
    }
}

/// A reversal value below which an axis has no band to approach (µm): a
/// nanometre, a tenth of the finest step volcomp writes; what is left of a
/// band a controller takes up itself (a hybrid set-up's tables) is rounding.
pub(super) const NO_BAND_UM: f64 = 1e-3;

/// What an axis is approached by beyond twice its reversal value (µm): a
/// band of zero still gets a move of its own.
pub(super) const MARGIN_UM: f64 = 10.0;

/// The approach distance `δ = 2·b + 10 µm` of each axis at `q_mm` (mm), for
/// its reversal value `b` there: the difference of its own component between
/// its reverse and forward tables (docs/design.md's model), the other axes
/// in the state `s`. `None` where the axis has no band of its own (a
/// controller that takes up backlash itself, or a map without
/// direction-dependent tables).
pub(super) fn deltas_mm(
    model: &dyn ErrorModel,
    q_mm: Vec3,
    s: Directions,
) -> Result<[Option<f64>; 3], ModelError> {
    let mut out = [None; 3];
    for (a, slot) in out.iter_mut().enumerate() {
        let mut fwd = s;
        fwd[a] = Direction::Forward;
        let mut rev = s;
        rev[a] = Direction::Reverse;
        let jump_um = model.deviation_um(q_mm, rev, Components::All)?
            - model.deviation_um(q_mm, fwd, Components::All)?;
        if jump_um[a].abs() >= NO_BAND_UM {
            *slot = Some((2.0 * jump_um[a].abs() + MARGIN_UM) * 1e-3);
        }
    }
    Ok(out)
}

/// The axes in `pending` that a move from `from_mm` to `q_mm` settles: those
/// with a band (`deltas_mm`) that it moves by at least their `δ`.
pub(super) fn settled(
    from_mm: Vec3,
    q_mm: Vec3,
    deltas_mm: [Option<f64>; 3],
    pending: [bool; 3],
) -> [bool; 3] {
    let d = q_mm - from_mm;
    std::array::from_fn(|a| pending[a] && deltas_mm[a].is_some_and(|delta| d[a].abs() >= delta))
}

/// The point a short move away from `q_mm` goes to before it comes back,
/// for the axes in `axes` with a band: `q_a − δ_a·sign(s_a)`, so the move
/// back ends in the direction `s` holds. `None` where no such axis has a
/// band.
pub(super) fn off_line(
    q_mm: Vec3,
    s: Directions,
    deltas_mm: [Option<f64>; 3],
    axes: [bool; 3],
) -> Option<Vec3> {
    let mut p = q_mm;
    for a in 0..3 {
        if let (true, Some(delta)) = (axes[a], deltas_mm[a]) {
            p[a] -= delta * s[a].sign();
        }
    }
    (p != q_mm).then_some(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    const F: Direction = Direction::Forward;
    const R: Direction = Direction::Reverse;

    #[test]
    fn a_move_settles_the_axes_it_moves_by_at_least_their_delta() {
        // δ 16 µm on X and Y, none on Z. X moves 10 mm, Y 0.015 mm (less
        // than δ), Z 5 mm without a band.
        let axes = settled(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(10.0, 0.015, 5.0),
            [Some(0.016), Some(0.016), None],
            [true; 3],
        );
        assert_eq!(axes, [true, false, false]);
        // Backwards counts too; an axis no longer pending is not settled again.
        let axes = settled(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(-0.016, -0.016, 0.0),
            [Some(0.016), Some(0.016), None],
            [false, true, true],
        );
        assert_eq!(axes, [false, true, false]);
    }

    #[test]
    fn off_the_line_each_axis_steps_back_against_its_direction() {
        let p = off_line(
            Vec3::new(1.0, 2.0, 3.0),
            [F, R, F],
            [Some(0.018), Some(0.016), None],
            [true, true, true],
        )
        .unwrap();
        assert!(
            (p - Vec3::new(0.982, 2.016, 3.0)).max_abs() < 1e-12,
            "{p:?}"
        );
        assert!(off_line(Vec3::new(1.0, 2.0, 3.0), [F; 3], [None; 3], [true; 3]).is_none());
    }
}
