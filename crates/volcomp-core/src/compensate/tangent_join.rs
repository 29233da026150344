//! A join the original runs through tangent, from an arc into a line,
//! stays tangent under G64 without P (docs/compensation.md, "A tangent
//! join from an arc into a line").
//!
//! At such a join the compensation may turn the line's first piece away
//! from the arc's end as written: where the map's correction steps with a
//! direction (a take-up folded into the line, a straightness that changes
//! with an axis' direction) the first piece carries that step, a few mrad
//! on a worn machine (bench/eval's coarse map: 2.9 mrad where Z takes up
//! 11.5 µm over a 4 mm piece). LinuxCNC then blends the join, and where the
//! arc is planar and the line leaves its plane it has no blend arc for it
//! (the corner's binormal is not the arc's normal: tp.c
//! `tpCreateArcLineBlend`, `pmUnitCartsColinear`): a parabolic blend, which
//! runs into the line at no more than `√(a_t · ℓ / 2)` for a piece of `ℓ`
//! (`tpComputeBlendVelocity`).
//!
//! So the line's first `ℓ` is written along the arc's end tangent as
//! written (its rise counted, as `pmCircleTangentVector` gives it): the
//! join is tangent again, and the turn moves to the end of that short
//! piece, between two lines, which LinuxCNC blends with an arc in any plane
//! (`tpCreateLineLineBlend`). The piece's end moves from the join by no
//! more than the planar tolerance (0.4 µm under G64 without P) beyond what
//! the command that keeps the tool on the line in the arc's direction
//! state moves: where an axis reverses at the join it stands in its band
//! while its command moves, so the take-up folded into the first piece then
//! begins at the piece's end. `ℓ` is twice the shortest piece the planner
//! runs at the feed, else once, and never where the rest of the first piece
//! would be shorter than that.

use super::frame::Frame;
use super::lines::ArcWords;
use super::points::Run;
use super::{Segmentation, State, TakeUpRule};
use crate::model::ErrorModel;
use volcomp_gcode::{Motion, MotionKind, Vec3};

/// What a distance measured between two written numbers may exceed the
/// tolerance by: their rounding in binary (mm).
const QUANTUM_MM: f64 = 1e-9;

/// How far an axis of the piece along the tangent may move against the
/// first piece's way and be held at the start instead (mm): two steps of
/// the written grid (10 nm each in mm at five decimals), a turn of 0.2 mrad
/// over the shortest piece at F6000, within the planner's tangency
/// tolerance there (0.495 mrad where an arc takes part).
const GRID_STEPS_MM: f64 = 2e-5;

/// The end of an arc as written: its last command and its unit tangent
/// there (axis frame, the helix' rise counted).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct WrittenArcEnd {
    pub(super) q_mm: Vec3,
    pub(super) tangent: Vec3,
}

/// The unit tangent at `to` of the arc piece written with `words` from
/// `from` to `to` (axis frame): in the plane, normal to the radius to `to`
/// and turning the piece's way; along the normal axis, the piece's rise
/// over its length in the plane. The second arc where the piece is written
/// as two. A chord's own direction. `None` where the piece has no length.
pub(super) fn end_tangent(words: &ArcWords, from: Vec3, to: Vec3) -> Option<Vec3> {
    let (from, center, clockwise) = match words.second {
        Some(s) => (s.joint, s.center, s.clockwise),
        None => (from, words.center, words.clockwise),
    };
    let d = to - from;
    let Some(c) = center else {
        let n = d.norm();
        return (n > 0.0 && n.is_finite()).then(|| d * (1.0 / n));
    };
    let (u, v, w) = words.plane.axes();
    let (du, dv) = (to[u] - c[u], to[v] - c[v]);
    let r = du.hypot(dv);
    if r <= 0.0 || !r.is_finite() {
        return None;
    }
    let angle = |p: Vec3| (p[v] - c[v]).atan2(p[u] - c[u]);
    let sweep = volcomp_gcode::arc::sweep_angle(angle(from), angle(to), clockwise, 1);
    let length = r * sweep.abs();
    let sign = if clockwise { -1.0 } else { 1.0 };
    let mut t = Vec3::ZERO;
    t[u] = sign * -dv / r * length;
    t[v] = sign * du / r * length;
    t[w] = d[w];
    let n = t.norm();
    (n > 0.0 && n.is_finite()).then(|| t * (1.0 / n))
}

/// Whether the motion `m`, run as `run`, is a feed line under G64 without
/// P at a feed per minute that the original joins tangent to the motion
/// before it.
fn tangent_line(m: &Motion, run: &Run, rule: TakeUpRule) -> bool {
    matches!(m.kind, MotionKind::Feed)
        && rule == TakeUpRule::Always
        && run.feed_mm_min.is_some()
        && !run.corner_before
        && m.start != m.end
}

impl State<'_> {
    /// After a line is solved (`commands` for `targets` from `q_start`):
    /// where it follows the arc written to its start (`end`, nothing
    /// written between) through a join the original runs through tangent,
    /// its first piece as solved (no take-up block before it) turns from
    /// the arc's end tangent by more than the planner's tangency tolerance,
    /// and a piece along that tangent keeps within the planar tolerance of
    /// the line's command in the arc's direction state (see the module
    /// documentation), that piece is put first (no axis turns back at its
    /// end). Whether it was.
    pub(super) fn tangent_lead(
        &mut self,
        end: WrittenArcEnd,
        model: &dyn ErrorModel,
        (motion, run): (&Motion, &Run),
        (targets, commands): (&mut Vec<Vec3>, &mut Vec<(Vec3, Option<Vec3>)>),
        (frame, q_start, s_before): (&Frame, Vec3, crate::model::Directions),
    ) -> bool {
        let options = self.walk.options;
        let rule = options.take_up_rule(run.mode);
        let Segmentation::Adaptive { min_length_mm, .. } = options.segmentation else {
            return false;
        };
        let (Some(f), Some(&(c1, take_up))) = (run.feed_mm_min, commands.first()) else {
            return false;
        };
        let n = commands.len();
        if !tangent_line(motion, run, rule)
            || end.q_mm != q_start
            || take_up.is_some()
            || targets.len() != n
            || self.states.len() != n
        {
            return false;
        }
        let first_mm = (c1 - q_start).norm();
        if first_mm <= 0.0 || !first_mm.is_finite() {
            return false;
        }
        let d = (c1 - q_start) * (1.0 / first_mm);
        let planner = &options.planner;
        if planner.kink_ratio(end.tangent, d, f / 60.0, true) < 1.0 {
            return false;
        }
        let tolerance_mm = super::planar::planar_tolerance_mm(options, run.mode);
        let floor_mm = min_length_mm.max(planner.shortest_at_feed_mm(f));
        let u = (motion.end - motion.start) * (1.0 / (motion.end - motion.start).norm());
        // The piece's end against the command that puts the tool on the
        // line in the direction state the arc left (`s_before`): where an
        // axis reverses at the join, the take-up folded into the first
        // piece then begins at the piece's end instead of at the join (the
        // reversing axis stands in its band either way); else it is the
        // first piece's own state.
        let solve = |target: Vec3| {
            super::solve::solve_fixed(
                model,
                options.method,
                target,
                s_before,
                [false; 3],
                Vec3::ZERO,
            )
            .map(|sol| sol.q_mm)
        };
        // Where the tool was left off the path at the join (a hold), that
        // offset carries on: the piece is measured by how it moves.
        let Ok(q_ref0) = solve(motion.start) else {
            return false;
        };
        let mut chosen = None;
        for ell in [2.0 * floor_mm, floor_mm] {
            if ell + floor_mm > first_mm {
                continue;
            }
            let target = motion.start + u * ell;
            let Ok(q_ref) = solve(target) else {
                return false;
            };
            let mut p = frame.quantize(q_start + end.tangent * ell, q_start);
            // No axis turns back at the split (its command would reverse
            // there, against the direction state the first piece was solved
            // in): an axis the tangent moves against the first piece's way
            // by a step of the written grid or so (an arc that ends just
            // past its extreme) stays at the start instead; the join's turn
            // that leaves is that step over the piece.
            for a in 0..3 {
                if (p[a] - q_start[a]) * (c1[a] - p[a]) < 0.0
                    && (p[a] - q_start[a]).abs() <= GRID_STEPS_MM
                {
                    p[a] = q_start[a];
                }
            }
            let turns_back = (0..3).any(|a| (p[a] - q_start[a]) * (c1[a] - p[a]) < 0.0);
            let moved_mm = ((p - q_start) - (q_ref - q_ref0)).norm();
            if moved_mm <= tolerance_mm + QUANTUM_MM && !turns_back {
                chosen = Some((p, target, moved_mm));
                break;
            }
        }
        let Some((p, target, moved_mm)) = chosen else {
            return false;
        };
        targets.insert(0, target);
        commands.insert(0, (p, None));
        self.states.insert(0, self.states[0]);
        if self.ramp_mids.len() == n {
            self.ramp_mids.insert(0, Vec3::ZERO);
        }
        self.estimate_mm = self.estimate_mm.max(moved_mm);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcomp_gcode::Plane;

    fn words(center: Vec3, clockwise: bool) -> ArcWords {
        ArcWords {
            center: Some(center),
            plane: Plane::Xy,
            clockwise,
            radius_style: false,
            absolute_centers: false,
            second: None,
        }
    }

    /// A quarter circle of radius 10 about the origin, counter-clockwise
    /// from (10, 0) to (0, 10), rising 0.01 mm: at its end the tangent
    /// points along −X and rises 0.01 over the quarter's length 5π mm:
    /// (−5π, 0, 0.01) normalised, by hand. Clockwise from (0, 10) to
    /// (10, 0): along −Y at the end.
    #[test]
    fn the_end_tangent_of_a_helix_counts_its_rise() {
        let w = words(Vec3::ZERO, false);
        let t = end_tangent(&w, Vec3::new(10.0, 0.0, 0.0), Vec3::new(0.0, 10.0, 0.01)).unwrap();
        let l = 5.0 * std::f64::consts::PI;
        let n = (l * l + 1e-4).sqrt();
        assert!((t[0] + l / n).abs() < 1e-12, "{t:?}");
        assert!(t[1].abs() < 1e-12, "{t:?}");
        assert!((t[2] - 0.01 / n).abs() < 1e-12, "{t:?}");
        let w = words(Vec3::ZERO, true);
        let t = end_tangent(&w, Vec3::new(0.0, 10.0, 0.0), Vec3::new(10.0, 0.0, 0.0)).unwrap();
        assert!((t[1] + 1.0).abs() < 1e-12 && t[0].abs() < 1e-12, "{t:?}");
    }
}
