//! G64 P on maps whose reversal values pass P: a take-up inside an arc
//! folded into its piece within P, and a hold that leaves room for it
//! (docs/compensation.md, "A take-up inside an arc folded within P (G64
//! P)").
//!
//! Under `G64 P p` a take-up that no ramp keeps within the contour
//! tolerance went on a short lead piece within `p`, else it was a take-up
//! block (points.rs). On an arc piece the fold into the whole piece was
//! judged by the whole lag of the switch, since the bound along the
//! piece's chord may fall short of what the tool leaves beside the arc. On
//! a map whose reversal values are two or three times `p` (10–15 µm at
//! P0.005, bench/coarse_map.py) the whole lag is above `p` for every
//! take-up, so each one inside an arc became a lead piece of a few tenths
//! of a millimetre (15 µm of Z over 0.36 mm: 40 mrad, a corner the planner
//! slows for) or a block, `G1 Z… (take-up)` between two arc pieces that
//! were tangent: a stop in the middle of the arc (LinuxCNC's
//! `tpSetupTangent`, src/emc/tp/tp.c, blends no 90° corner at speed).
//!
//! Here the fold's offsets (points.rs `fold_deviation_mm`: piecewise
//! linear in the fraction `λ` of the piece) are taken across the arc's own
//! tangent at `λ` (points.rs `fold_deviation_sampled_mm`, 33 fractions and
//! the breakpoints), not across the chord: the tool's offset from the
//! nominal point at `λ` leaves the path only by its part across the path
//! there. The fold is taken where that keeps within `p` (with what a hold
//! left at the start, compensate/turn_back.rs `start_offset_mm`), before a
//! lead piece is tried. The planner then sees the take-up spread over the
//! whole piece, a kink of the take-up over the piece's length.
//!
//! A hold (solve.rs `hold_small_reversals`) leaves the tool up to its
//! bound, `p` less the contour tolerance, off the path, and the take-up
//! that ends it folds from there: its offset starts at the hold's and
//! grows while the carriage crosses its band and the target moves on, so
//! after a hold of the whole bound no fold fits within `p` and the take-up
//! was a block. Where a reversing axis' band passes 1.5 `p`
//! ([`HOLD_BAND_RATIO`]), the hold is kept within half the bound
//! ([`HOLD_SHARE`]), which leaves the other half to
//! the fold that ends it; and a hold along Z at an X or Y quarter point
//! adds its offset to the S-curve's across the path (measured: 8.2 µm on
//! the coarse map's spiral of arcs with the whole bound, 5.9 µm with
//! half).

use crate::error::ModelError;
use crate::model::{AxisCells, Directions, ErrorModel};
use volcomp_gcode::{Arc, Vec3};

use super::options::TakeUpRule;

/// The share of the hold bound (`p` less the contour tolerance) a hold
/// may use under `G64 P p` where a reversing axis' band passes [`HOLD_BAND_RATIO`] times `p`: half,
/// the other half left to the fold that ends the hold. Measured on
/// bench/eval (coarse map, F6000, G64 P0.005): spiral_arcs12 +86.2 →
/// +30.2 %, max 8.16 → 5.90 µm; with the whole bound the take-ups stay
/// blocks (+86.2 %).
pub(super) const HOLD_SHARE: f64 = 0.5;

/// How many times `p` a reversing axis' band must pass for the hold to be
/// kept within [`HOLD_SHARE`]: 1.5, between the shop map's largest band
/// (7 µm, 1.4 × P0.005), where the whole bound stays (measured with half:
/// pocket_arcs shop F6000 +1.6 → +5.1 %, the shorter holds ending in
/// take-ups at its corners), and the coarse map's smallest (Z 9.7 µm,
/// 1.9 × P0.005). A decision, chosen between the two maps, not derived:
/// the rules derived from the fold's own bound (the largest hold whose
/// fold, `(h + ℓ)(h + n)/(ℓ + h + n)`, stays within `p`, with `n` the next
/// piece's rise or `n = h`; or the room the motion's S-curves leave) were
/// measured on the coarse map and lose what the half gains (spiral_arcs12
/// +30.2 % back to +86.2 %, g2_d40 5.13 to 6.96–6.98 µm):
/// docs/compensation.md, "A take-up inside an arc folded within P".
pub(super) const HOLD_BAND_RATIO: f64 = 1.5;

/// The bound (mm) a hold of the reversal `reversed` at `q_prev` (in state
/// `s_prev`) may leave under `rule`, `bound_mm` the mode's own
/// (`CompensateOptions::hold_tolerance_mm`): [`HOLD_SHARE`] of it under
/// `G64 P p` where a reversing axis' band passes [`HOLD_BAND_RATIO`]
/// times `p`, else all of it.
pub(super) fn hold_bound_for_band_mm(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    (rule, bound_mm): (TakeUpRule, f64),
    (q_prev, s_prev): (Vec3, Directions),
    reversed: [bool; 3],
) -> Result<f64, ModelError> {
    let TakeUpRule::Within(p_mm) = rule else {
        return Ok(bound_mm);
    };
    if !reversed.iter().any(|r| *r) {
        return Ok(bound_mm);
    }
    let band_um = super::solve::bands_um(cells, model, (q_prev, s_prev), reversed)?;
    Ok(
        if band_um.iter().any(|b| *b * 1e-3 > HOLD_BAND_RATIO * p_mm) {
            bound_mm * HOLD_SHARE
        } else {
            bound_mm
        },
    )
}

/// The largest excursion (mm) of a take-up of `lags` (every reversing
/// axis' lag, points.rs `switch_lags_mm`) folded into the arc piece of
/// `arc` from parameter `l_prev` to `l_end`, the command running from
/// `q_prev` to `q`, the tool starting off the nominal point by `start_mm`:
/// the fold's offsets counted across the arc's tangent at each fraction.
pub(super) fn fold_bound_on_arc_mm(
    lags: &[Vec3; 3],
    (q_prev, start_mm): (Vec3, Vec3),
    q: Vec3,
    (arc, l_prev, l_end): (&Arc, f64, f64),
) -> f64 {
    let tangent = |f: f64| tangent_at(arc, l_prev + (l_end - l_prev) * f);
    super::points::fold_deviation_sampled_mm(lags, (q_prev, start_mm), q, &tangent, (0.0, 32))
}

/// The unit tangent of `arc` at parameter `l` (0 at its start, 1 at its
/// end), in its direction of travel, helix included.
fn tangent_at(arc: &Arc, l: f64) -> Vec3 {
    let (u, v, w) = arc.plane.axes();
    let p = arc.point_at(l);
    let (ru, rv) = (p[u] - arc.center[u], p[v] - arc.center[v]);
    let mut t = Vec3::ZERO;
    // d/dl of (centre + r(l)·(cos θ, sin θ)) with θ = θ0 + l·sweep; the
    // radius' change (a spiral) and the helix' rise are linear in l.
    let r = ru.hypot(rv).max(1e-15);
    let dr = arc.end_radius() - arc.start_radius();
    t[u] = -rv * arc.sweep_rad + dr * ru / r;
    t[v] = ru * arc.sweep_rad + dr * rv / r;
    t[w] = arc.end[w] - arc.start[w];
    t.normalized().unwrap_or(Vec3::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ByDirection, Direction, ALL_FORWARD};
    use volcomp_gcode::Plane;

    const UM: f64 = 1e-3;

    /// G3 quarter circle of radius 10 about the origin, from (10, 0) to
    /// (0, 10), at Z 0.
    fn quarter() -> Arc {
        Arc {
            start: Vec3::new(10.0, 0.0, 0.0),
            end: Vec3::new(0.0, 10.0, 0.0),
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: std::f64::consts::FRAC_PI_2,
        }
    }

    #[test]
    fn the_tangent_of_a_g3_quarter_circle_turns_with_it() {
        // At the start +Y, at the end −X, halfway (−1, 1)/√2 (by hand).
        let arc = quarter();
        let h = std::f64::consts::FRAC_1_SQRT_2;
        for (l, want) in [
            (0.0, Vec3::new(0.0, 1.0, 0.0)),
            (1.0, Vec3::new(-1.0, 0.0, 0.0)),
            (0.5, Vec3::new(-h, h, 0.0)),
        ] {
            let t = tangent_at(&arc, l);
            assert!((t - want).norm() < 1e-9, "{l}: {t:?}");
        }
        // A helix rising 1 mm over the quarter: the tangent leans up by
        // 1 / (10·π/2) (by hand).
        let mut helix = quarter();
        helix.end[2] = 1.0;
        let t = tangent_at(&helix, 0.0);
        let rise = 1.0 / (10.0 * std::f64::consts::FRAC_PI_2);
        assert!((t[2] / t[1] - rise).abs() < 1e-9, "{t:?}");
    }

    #[test]
    fn a_z_take_up_folded_into_an_arc_piece_leaves_the_target_s_rise_share() {
        // Z reverses up with an 11.5 µm band (the coarse map's size, more
        // than twice P0.005) while the target rises 3 µm over the piece:
        // the command rises 14.5 µm, the carriage stays until it has
        // crossed the band, at λ = 11.5/14.5, where the tool is off by
        // 3 · 11.5/14.5 = 2.379 µm (docs/compensation.md, "Take-ups folded
        // into the move": Δ·ℓ/(Δ + ℓ)). The whole lag, 11.5 µm, was the
        // bound before: above P, a block.
        let lags = [Vec3::ZERO, Vec3::ZERO, Vec3::new(0.0, 0.0, 11.5 * UM)];
        let arc = quarter();
        let q_prev = Vec3::new(10.0, 0.0, 0.0);
        let q = Vec3::new(0.0, 10.0, 14.5 * UM);
        let b = fold_bound_on_arc_mm(&lags, (q_prev, Vec3::ZERO), q, (&arc, 0.0, 1.0));
        assert!((b - 3.0 * 11.5 / 14.5 * UM).abs() < 1e-9, "{}", b / UM);
        // From where a hold left the tool 2 µm low: the offsets add,
        // −2(1 − λ) − 3λ up to λ = 11.5/14.5, the most there (by hand:
        // 2·0.2069 + 2.379 = 2.793 µm).
        let h = Vec3::new(0.0, 0.0, -2.0 * UM);
        let b = fold_bound_on_arc_mm(&lags, (q_prev, h), q, (&arc, 0.0, 1.0));
        let lam = 11.5 / 14.5;
        let want = 2.0 * (1.0 - lam) + 3.0 * lam;
        assert!((b - want * UM).abs() < 1e-9, "{} vs {want}", b / UM);
    }

    #[test]
    fn only_the_part_of_a_lag_across_the_arc_counts() {
        // A 2 µm lag along Y, whose command stands still over the piece,
        // stays whole (f = 1): the offset is 2λ µm along Y. Across the
        // arc's tangent (−sin θ, cos θ), θ = λ·90°, that is 2λ·sin θ, the
        // most at the end, 2 µm (by hand); across the chord's direction
        // (−1, 1)/√2 it would be 2·sin 45° = 1.414 µm there.
        let lags = [Vec3::ZERO, Vec3::new(0.0, 2.0 * UM, 0.0), Vec3::ZERO];
        let arc = quarter();
        let (q_prev, q) = (Vec3::new(10.0, 0.0, 0.0), Vec3::ZERO);
        let b = fold_bound_on_arc_mm(&lags, (q_prev, Vec3::ZERO), q, (&arc, 0.0, 1.0));
        assert!((b - 2.0 * UM).abs() < 1e-9, "{}", b / UM);
        // On the first half of the arc alone: 2·sin 45° at its end.
        let b = fold_bound_on_arc_mm(&lags, (q_prev, Vec3::ZERO), q, (&arc, 0.0, 0.5));
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!((b - 2.0 * h * UM).abs() < 1e-9, "{}", b / UM);
    }

    #[test]
    fn a_band_past_one_and_a_half_p_halves_the_hold_bound_under_g64_p_only() {
        // Z's reverse error 11.5 µm above its forward one: its band.
        let m = ByDirection(|s: [Direction; 3]| {
            Vec3::new(
                0.0,
                0.0,
                if s[2] == Direction::Reverse {
                    11.5
                } else {
                    0.0
                },
            )
        });
        let mut cells = AxisCells::default();
        let q = Vec3::new(1.0, 2.0, 3.0);
        let z = [false, false, true];
        let hold = |cells: &mut AxisCells, rule, reversed| {
            hold_bound_for_band_mm(cells, &m, (rule, 4.9 * UM), (q, ALL_FORWARD), reversed).unwrap()
        };
        // P0.005: 11.5 µm > 1.5 × 5 µm, half of 4.9 µm.
        let b = hold(&mut cells, TakeUpRule::Within(5.0 * UM), z);
        assert!((b - 2.45 * UM).abs() < 1e-12, "{}", b / UM);
        // P0.008: 11.5 µm is less than 1.5 × 8 µm, the whole bound.
        let b = hold(&mut cells, TakeUpRule::Within(8.0 * UM), z);
        assert!((b - 4.9 * UM).abs() < 1e-12, "{}", b / UM);
        // No reversal, or X reversing (no band of its own): the whole bound.
        let b = hold(&mut cells, TakeUpRule::Within(5.0 * UM), [false; 3]);
        assert!((b - 4.9 * UM).abs() < 1e-12);
        let b = hold(
            &mut cells,
            TakeUpRule::Within(5.0 * UM),
            [true, false, false],
        );
        assert!((b - 4.9 * UM).abs() < 1e-12);
        // G64 without P: the bound as given.
        let b = hold(&mut cells, TakeUpRule::Always, z);
        assert!((b - 4.9 * UM).abs() < 1e-12);
    }
}
