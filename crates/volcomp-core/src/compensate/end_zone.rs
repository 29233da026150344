//! The end zone of a line under G64 without P, kept whole from the real
//! corner at its end (docs/compensation.md, "Pieces the planner runs at
//! full speed").
//!
//! When a line is compensated the next motion is not known yet, yet the
//! blend LinuxCNC puts at the line's end takes a length that depends on it:
//! `d = min(L₁/2, L₂/2, d_tol, R/tan θ)` of each line
//! (`blendComputeParameters`, src/emc/tp/blendmath.c). A split nearer the
//! corner than `2d` cuts that blend short and slows it; a split kept out of
//! a longer zone than `2d` leaves the map's error there uncorrected. So the
//! line's pieces beyond its first are held back (a kind of the held tail,
//! [`super::TailKind::BlendZone`]) and settled when the next line is read:
//! only `2d` of the real corner before the end is kept whole.

use super::points::{self, Run};
use super::walk::Line;
use super::{PlannerLimits, State, TailKind, TailPath};
use crate::error::CompensationError;
use crate::model::Directions;
use volcomp_gcode::lexer::LineKind;
use volcomp_gcode::{FeedMode, MotionKind, MotionSource, PathMode, Vec3};

/// Whether a line run as `run` holds its end zone back for the real corner
/// at its end: under G64 without P at a feed per minute, where the block may
/// hold its end at all (`may_hold_end`: no stop word, no inverse time, no
/// extra axes, adaptive segmentation) and its line has an ending (the held
/// pieces are written on lines after it).
pub(super) fn holds_end(run: &Run, may_hold_end: bool, has_ending: bool) -> bool {
    may_hold_end
        && has_ending
        && run.feed_mm_min.is_some()
        && matches!(run.mode, PathMode::Blend { tolerance_mm, .. } if tolerance_mm <= 0.0)
}

/// The distance `d` (mm) LinuxCNC's blend takes of each of two lines, of
/// lengths `l1_mm` and `l2_mm` and unit tangents `t1`, `t2` at the corner,
/// run at `v_mm_s` (the faster of the two: `v_goal` of
/// `blendParamKinematics`, blendmath.c):
/// `d = min(L₁/2, L₂/2, d_tol, R/tan θ)` (`blendComputeParameters`), with
/// `d_tol = T cos θ / (1 − sin θ)` for the blend tolerance `T`, the
/// smallest of the segments' G64 P (`p2_mm` for the second, none for the
/// first) and a quarter of either line (`tcFindBlendTolerance`, tc.c), and
/// `R = v²/a_n` ([`PlannerLimits::blend_distance_at_mm`]). 0 where the
/// planner does not blend: a join it takes as tangent (`kink`: below 1,
/// [`PlannerLimits::kink_ratio`]) or a reversal, whose tangents are
/// anti-parallel within 2° (`tpSetupTangent`, tp.c), where it stops.
pub(super) fn corner_reach_mm(
    planner: &PlannerLimits,
    (t1, t2): (Vec3, Vec3),
    (l1_mm, l2_mm): (f64, f64),
    v_mm_s: f64,
    p2_mm: f64,
    kink: f64,
) -> f64 {
    let phi = super::joins::deflection_rad(t1, t2);
    let theta = 0.5 * (std::f64::consts::PI - phi);
    if kink < 1.0 || theta < super::joins::REVERSAL_HALF_ANGLE_RAD {
        return 0.0;
    }
    let quarter = 0.25 * l1_mm.min(l2_mm);
    let tolerance_mm = if p2_mm > 0.0 {
        p2_mm.min(quarter)
    } else {
        quarter
    };
    let speed_mm = if v_mm_s.is_finite() {
        planner.blend_distance_at_mm(phi, v_mm_s)
    } else {
        f64::INFINITY
    };
    speed_mm
        .min(planner.blend_distance_within_at_mm(phi, tolerance_mm))
        .min(0.5 * l1_mm)
        .min(0.5 * l2_mm)
}

/// The length (mm) before the end of the line `(a, b)` run as `run` that
/// its pieces leave whole for the corner into `next`'s first motion: twice
/// [`corner_reach_mm`] of that corner. After the program's end, before a
/// line that stops the machine (M0, M1, M2, M30, M60), or before a rapid,
/// nothing: the planner does not blend into a stop, nor a feed move into a
/// rapid (it ends the feed move in a stop, `handleModeChange`,
/// src/emc/tp/tp.c). Where the next motion is not one
/// the corner can be read from (a line without motion, a canned cycle,
/// cutter compensation, an axis not known yet) the zone is the one taken
/// alike at the start (`Run::split_end_mm`), as before the next line was
/// read.
fn end_zone_mm(planner: &PlannerLimits, run: &Run, (a, b): (Vec3, Vec3), next: &Line) -> f64 {
    let ev = next.ev;
    if ev.after_end || super::lines::stop_m_word(next.words()).is_some() {
        return 0.0;
    }
    let program_motion = matches!(ev.motions, [m, ..] if m.source == MotionSource::Program);
    if ev.kind != LineKind::Block
        || !program_motion
        || !next.all_known
        || ev.interp.cutter_comp_on()
    {
        return run.split_end_mm;
    }
    let m = ev.motions[0];
    if m.kind == MotionKind::Rapid {
        return 0.0;
    }
    let l1_mm = (b - a).norm();
    let t1 = (b - a) * (1.0 / l1_mm);
    let (t2, _) = points::tangents(&m);
    let l2_mm = points::length_mm(&m);
    let v1_mm_s = run.feed_mm_min.unwrap_or(f64::INFINITY) / 60.0;
    // A feed not per minute runs at a speed not known here: the blend is
    // taken as fast as the lengths and the tolerance let it be.
    let v2_mm_s = match m.feed_mode {
        FeedMode::PerMinute if m.feed > 0.0 => m.feed / 60.0,
        _ => f64::INFINITY,
    };
    let v_mm_s = v1_mm_s.max(v2_mm_s);
    let kink = planner.kink_ratio(
        t1,
        t2,
        v1_mm_s.min(v2_mm_s),
        matches!(m.kind, MotionKind::Arc(_)),
    );
    let p2_mm = match m.path_mode {
        PathMode::Blend { tolerance_mm, .. } => tolerance_mm,
        _ => 0.0,
    };
    2.0 * corner_reach_mm(planner, (t1, t2), (l1_mm, l2_mm), v_mm_s, p2_mm, kink)
}

/// The command a target `p_mm` needs with every axis in the state `s`
/// (`p − e(p, s)`, the error taken at the target: it changes by a
/// negligible share of itself over the few micrometres between target and
/// command) and each axis' band there (`|e_a(p, s with a flipped) −
/// e_a(p, s)|`, the reversal value the dead-band model gives; mm).
fn command_and_band_mm(
    model: &dyn crate::model::ErrorModel,
    cells: &mut crate::model::AxisCells,
    p_mm: Vec3,
    s: Directions,
) -> Result<(Vec3, Vec3), crate::error::ModelError> {
    let e_um = cells.deviation_again_um(model, p_mm, s)?;
    let mut band_mm = Vec3::ZERO;
    for a in 0..3 {
        let mut flipped = s;
        flipped[a] = flipped[a].flipped();
        band_mm[a] = (cells.deviation_again_um(model, p_mm, flipped)?[a] - e_um[a]).abs() * 1e-3;
    }
    Ok((p_mm - e_um * 1e-3, band_mm))
}

/// The turns along the commands `c` (the first the tail's start), axis by
/// axis from the state `s`, of the axes with a band at the point they turn
/// at (`bands_mm`): each step of such an axis against its direction is a
/// reversal of its carriage that the straight pieces between the points do
/// not ask for, which the solver either holds (solve.rs
/// `hold_small_reversals`, leaving the turn as an error) or takes up
/// (leaving up to the band under G64); steps below a nanometre turn
/// nothing. An axis without a band turns at no cost and is not counted.
fn turns(c: &[Vec3], bands_mm: &[Vec3], s: Directions) -> usize {
    let mut turns = 0;
    for a in 0..3 {
        let mut dir = s[a].sign();
        for i in 1..c.len() {
            let d = c[i][a] - c[i - 1][a];
            if d.abs() <= 1e-6 {
                continue;
            }
            if d * dir < 0.0 {
                if bands_mm[i - 1][a] > 0.0 {
                    turns += 1;
                }
                dir = -dir;
            }
        }
    }
    turns
}

impl State<'_> {
    /// Keeps the split points of the line `(start, end)` run as `run` out
    /// of its blend zones ([`points::protect_blends`]). Where the line
    /// holds its end (`hold`, [`holds_end`]) only its start zone is kept
    /// now, and the pieces after its first are returned with the share of
    /// the line where the first ends, to be held until the corner at the
    /// end is known ([`TailKind::BlendZone`]). The first piece ends where
    /// it ended when the corner at the end was taken as the one at the
    /// start (`Run::split_end_mm`): at its first split outside that zone,
    /// else at that zone's edge. Where that zone covers the line nothing is
    /// held and the line is protected as before. What the pieces kept whole
    /// leave is added to the estimate (the held ones' when settled).
    pub(super) fn protect_line(
        &mut self,
        targets: &mut Vec<Vec3>,
        (start, end): (Vec3, Vec3),
        run: &Run,
        mut hold: bool,
        line: u64,
    ) -> Result<Option<(Vec<Vec3>, f64)>, CompensationError> {
        // A line whose zones drop no split is left as it is, without a copy
        // of its targets (the common case: most lines are one piece).
        let Some((_, splits)) = targets.split_last() else {
            return Ok(None);
        };
        let along = |p: &Vec3| (*p - start).norm();
        let edge_mm = run.length_mm - run.split_end_mm;
        let start_drops = run.protect_mm > 0.0 && splits.iter().any(|p| along(p) <= run.protect_mm);
        let end_drops = run.split_end_mm > 0.0 && splits.iter().any(|p| along(p) >= edge_mm);
        if !start_drops && !end_drops {
            return Ok(None);
        }
        // Only a line whose zone taken at the start drops a split waits for
        // the real corner; elsewhere its pieces are the same either way and
        // the line is solved whole, as before.
        hold = hold && end_drops;
        let split = (targets.len() > 1).then(|| targets.clone());
        let end_mm = if hold { 0.0 } else { run.split_end_mm };
        points::protect_blends(targets, start, (run.protect_mm, end_mm));
        let mut first_mm = (targets[0] - start).norm();
        if hold && targets.len() > 1 && first_mm > edge_mm && run.protect_mm < edge_mm {
            first_mm = edge_mm;
            let u = (end - start) * (1.0 / run.length_mm);
            targets.insert(0, start + u * edge_mm);
        }
        if hold && !(targets.len() > 1 && first_mm <= edge_mm) {
            hold = false;
            points::protect_blends(targets, start, (run.protect_mm, run.split_end_mm));
        }
        if let Some(split) = split.filter(|s| s != targets) {
            // The held pieces are estimated when they are settled.
            self.estimate_whole_pieces(start, &split, targets, line)?;
        }
        Ok(hold.then(|| (targets.split_off(1), first_mm / run.length_mm)))
    }

    /// Settles the end zone of a held line tail ([`TailKind::BlendZone`])
    /// now that `next` (`None`: the program's end) is known: its pieces
    /// keep out of the real corner's zone ([`end_zone_mm`],
    /// [`points::protect_blends`]), and what the whole piece there leaves
    /// is added to the estimate of the contour error left.
    pub(super) fn settle_end_zone(&mut self, next: Option<&Line>) -> Result<(), CompensationError> {
        let options = self.walk.options;
        let Some(t) = self.tail.as_mut() else {
            return Ok(());
        };
        let (TailKind::BlendZone, TailPath::Line(a, b)) = (t.kind, t.path) else {
            return Ok(());
        };
        t.kind = TailKind::Settled;
        let zone_mm = next.map_or(0.0, |line| {
            end_zone_mm(&options.planner, &t.run, (a, b), line)
        });
        let from = a + (b - a) * t.held.at;
        let before = t.targets.clone();
        points::protect_blends(&mut t.targets, from, (0.0, zone_mm));
        // The cuts the real corner's zone keeps and the zone taken at the
        // start dropped are made only where they turn no axis' command back
        // more often than the pieces of that zone do ([`turns`]): a cut is
        // made to bring the tool onto the map's curve between its
        // neighbours, and a turn it adds costs a reversal (a hold or a
        // take-up) where the old pieces had none.
        if zone_mm < t.run.split_end_mm && t.targets.len() > 1 {
            // The first piece ends at that zone's edge or beyond (within a
            // nanometre: no piece of rounding).
            let mut proxy = before.clone();
            if (b - from).norm() <= t.run.split_end_mm + 1e-6 {
                proxy.drain(..proxy.len() - 1);
            } else {
                points::protect_blends(&mut proxy, from, (0.0, t.run.split_end_mm));
            }
            let model = crate::model::WithTool {
                model: self.walk.model,
                tool_length_offset_mm: t.tool_length_offset_mm,
            };
            let (line, s) = (t.line, self.s);
            let cells = self.cells.get_or_insert_with(Box::default);
            let file = self.walk.file;
            let mut count = |targets: &[Vec3]| -> Result<usize, CompensationError> {
                let mut commands = Vec::with_capacity(targets.len() + 1);
                let mut bands_mm = Vec::with_capacity(targets.len() + 1);
                for p in std::iter::once(&from).chain(targets) {
                    let (c, band) = command_and_band_mm(&model, cells, *p, s)
                        .map_err(|source| super::model_error(file, line, source))?;
                    commands.push(c);
                    bands_mm.push(band);
                }
                Ok(turns(&commands, &bands_mm, s))
            };
            let t = self.tail.as_mut().expect("the tail settled above");
            if count(&t.targets)? > count(&proxy)? {
                t.targets = proxy;
            }
        }
        let t = self.tail.as_ref().expect("the tail settled above");
        if t.targets != before {
            let (targets, line) = (t.targets.clone(), t.line);
            self.estimate_whole_pieces(from, &before, &targets, line)?;
        }
        Ok(())
    }

    /// Raises the estimate of the contour error left by what the pieces
    /// of a line from `start` through `kept` leave where they are longer
    /// than the adaptive segmentation's (`split`: its points, of which
    /// [`points::protect_blends`] kept `kept`): the map's departure from
    /// the chord across the move on each piece that dropped a point
    /// ([`super::targets::whole_piece_departure_mm`]).
    pub(super) fn estimate_whole_pieces(
        &mut self,
        start: Vec3,
        split: &[Vec3],
        kept: &[Vec3],
        line: u64,
    ) -> Result<(), CompensationError> {
        let Some(&end) = kept.last() else {
            return Ok(());
        };
        let length = (end - start).norm();
        if length <= 0.0 {
            return Ok(());
        }
        let u = (end - start) * (1.0 / length);
        let along = |p: &Vec3| (*p - start).dot(u);
        let mut from = start;
        for to in kept {
            let (lo, hi) = (along(&from), along(to));
            let dropped = split
                .iter()
                .any(|p| along(p) > lo + 1e-9 && along(p) < hi - 1e-9);
            if dropped {
                let d_mm = super::targets::whole_piece_departure_mm(
                    (from, *to),
                    self.walk.options,
                    self.walk.model,
                    self.s,
                    self.cells.get_or_insert_with(Box::default),
                )
                .map_err(|source| super::model_error(self.walk.file, line, source))?;
                self.estimate_mm = self.estimate_mm.max(d_mm);
            }
            from = *to;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 30 mm X line, then a 2.5 mm Y line, both at F6000 under G64:
    /// blendmath.c's `d = min(L₁/2, L₂/2, d_tol, R/tan θ)` at this right
    /// angle (`θ = 45°`) is `min(15, 1.25, T·cos 45°/(1 − sin 45°) with
    /// T = 2.5/4 = 0.625 → 1.5089, R/tan 45° = R)`, `R = v²/a_n` =
    /// 100²/(1000·√(1 − 0.5²)) = 11.547 mm: 1.25 mm, the half of the short
    /// line.
    #[test]
    fn a_right_angle_into_a_short_step_takes_half_the_step() {
        let p = PlannerLimits::default();
        let (x, y) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        let kink = p.kink_ratio(x, y, 100.0, false);
        let d = corner_reach_mm(&p, (x, y), (30.0, 2.5), 100.0, 0.0, kink);
        assert!((d - 1.25).abs() < 1e-12, "{d}");
        // Into a 10 mm step the tolerance rule binds: T = 2.5 mm,
        // d_tol = 2.5 · 0.70711/(1 − 0.70711) = 6.0355 mm; R = 11.547 mm;
        // half the step 5 mm: 5 mm.
        let d = corner_reach_mm(&p, (x, y), (30.0, 10.0), 100.0, 0.0, kink);
        assert!((d - 5.0).abs() < 1e-12, "{d}");
        // At F3000 (R = 2.8868 mm) the speed binds: R/tan 45° = 2.8868.
        let kink = p.kink_ratio(x, y, 50.0, false);
        let d = corner_reach_mm(&p, (x, y), (30.0, 10.0), 50.0, 0.0, kink);
        let r = 50.0 * 50.0 / (1000.0 * 0.75f64.sqrt());
        assert!((d - r).abs() < 1e-9, "{d} {r}");
    }

    /// A sharp corner (150° deflection, `θ = 15°`) is limited by the
    /// tolerance rule: `d_tol = T cos 15°/(1 − sin 15°)` = 1.30323 T, with
    /// `T` a quarter of the shorter line (8 mm → 2 mm): 2.6065 mm, below
    /// half of either line and below `R/tan 15°` = 43.09 mm.
    #[test]
    fn a_sharp_corner_is_limited_by_a_quarter_of_the_shorter_line() {
        let p = PlannerLimits::default();
        let phi = 150f64.to_radians();
        let (t1, t2) = (
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(phi.cos(), phi.sin(), 0.0),
        );
        let kink = p.kink_ratio(t1, t2, 100.0, false);
        let d = corner_reach_mm(&p, (t1, t2), (30.0, 8.0), 100.0, 0.0, kink);
        let th = 15f64.to_radians();
        let expected = 2.0 * th.cos() / (1.0 - th.sin());
        assert!((d - expected).abs() < 1e-9, "{d} {expected}");
        assert!((expected - 2.606_46).abs() < 1e-4);
    }

    /// Commands along X with Z's turning: up 1 µm, back 0.5 µm, up
    /// 0.7 µm against a 3 µm band: two turns (by hand); without the middle
    /// point (up 1 µm, up 0.2 µm) none. Z without a band (the ripple
    /// map's tables, `both`) turns at no cost: none counted.
    #[test]
    fn turns_are_counted_on_the_axes_with_a_band() {
        use crate::model::Direction::{Forward, Reverse};
        let s = [Forward; 3];
        let c = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(10.0, 0.0, 0.001),
            Vec3::new(20.0, 0.0, 0.0005),
            Vec3::new(30.0, 0.0, 0.0012),
        ];
        let band = [Vec3::new(0.0, 0.0, 0.003); 4];
        assert_eq!(turns(&c, &band, s), 2);
        assert_eq!(turns(&[c[0], c[1], c[3]], &band, s), 0);
        // From Z's reverse state the first step up is a turn too.
        assert_eq!(turns(&c, &band, [Forward, Forward, Reverse]), 3);
        assert_eq!(turns(&c, &[Vec3::ZERO; 4], s), 0);
    }

    /// No blend, no zone: a join the planner takes as tangent, and a
    /// reversal within 2°, where it stops.
    #[test]
    fn tangent_joins_and_reversals_have_no_zone() {
        let p = PlannerLimits::default();
        let x = Vec3::new(1.0, 0.0, 0.0);
        let back = Vec3::new(-1.0, 0.001, 0.0);
        let back = back * (1.0 / back.norm());
        let d = corner_reach_mm(&p, (x, back), (30.0, 30.0), 100.0, 0.0, 10.0);
        assert_eq!(d, 0.0);
        let d = corner_reach_mm(&p, (x, x), (30.0, 30.0), 100.0, 0.0, 0.0);
        assert_eq!(d, 0.0);
    }
}
