//! A planner segment and its limits: the path speed and acceleration of a
//! straight move or an arc from the axes' limits, as LinuxCNC's canonical
//! layer sets them (src/emc/task/emccanon.cc: `getStraightVelocity`,
//! `getStraightAcceleration`, `ARC_FEED`; [LinuxCNC tp]), and what the
//! planner derives from them per segment (src/emc/tp/tc.c:
//! `tcGetOverallMaxAccel`, `tcGetTangentialMaxAccel`,
//! `tcClampVelocityByLength`, `tcUpdateCircleAccRatio`; blendmath.c:
//! `pmCircleActualMaxVel`).
//!
//! * A straight move's path speed and acceleration are the largest that
//!   keep every moving axis within its own: `v = L / maxᵢ(|dᵢ| / vᵢ)`,
//!   `a = L / maxᵢ(|dᵢ| / aᵢ)` (a 45° XY move of axes limited to 1000 mm/s²
//!   accelerates at 1414 mm/s²).
//! * An arc's speed is limited by its normal acceleration,
//!   `v ≤ √(a_n r)` with `a_n = (√3/2) a` of the plane's slower axis
//!   (canon), and again when the segment is finalised so that the normal
//!   part leaves at least half the acceleration for the tangent
//!   (`pmCircleActualMaxVel`): the tangential acceleration of an arc is
//!   `a √(1 − (v²/(r a))²)`, at most `a/2`.
//! * A segment ending in a parabolic blend (G64), or following one,
//!   accelerates at half its limit, so that the two blended segments
//!   together stay within it; a segment at an approximately tangent joint
//!   gives up the share the kink needs (`kink_accel_reduce`).
//! * No segment runs faster than its length per servo period (so that each
//!   segment lasts at least one cycle).

use super::geometry::{BlendArc, Circle, Line, CART_FUZZ_MM};
use super::Limits;
use volcomp_gcode::Vec3;

/// Tangential share of an arc's acceleration at most
/// (`BLEND_ACC_RATIO_TANGENTIAL`, blendmath.h).
pub(crate) const ACC_RATIO_TANGENTIAL: f64 = 0.5;

/// Normal share of the acceleration (`BLEND_ACC_RATIO_NORMAL`): √(1 − ½²).
pub(crate) fn acc_ratio_normal() -> f64 {
    (1.0 - ACC_RATIO_TANGENTIAL * ACC_RATIO_TANGENTIAL).sqrt()
}

/// The canonical motion type (motion_types.h): what the cycle-time
/// harness counts as cutting is a feed or an arc.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Canon {
    Traverse,
    Feed,
    Arc,
}

/// How a segment ends (`tc_term_cond_t`, tc_types.h).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Term {
    /// At rest (G61.1, a reversal, a change between rapid and feed).
    Stop,
    /// At rest, but tangent joints flow on (G61).
    Exact,
    /// Overlapping the next segment's start (G64 where no blend arc fits).
    Parabolic,
    /// At speed into the next segment (a blend arc, a tangent joint).
    Tangent,
}

/// A segment's path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Shape {
    Line(Line),
    Circle(Circle),
    /// A blend arc in a corner.
    Blend(BlendArc),
}

/// One segment of the planner's queue (the fields of `TC_STRUCT` that
/// time depends on; lengths in mm, speeds in mm/s, accelerations mm/s²).
/// `Copy`: queued by one copy straight into the queue's slot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Seg {
    pub shape: Shape,
    pub canon: Canon,
    /// Program line (for the per-line breakdown and messages).
    pub line: u64,
    pub target: f64,
    pub progress: f64,
    pub nominal_length: f64,
    /// Requested speed (F, or the rapid speed).
    pub reqvel: f64,
    /// Largest speed the geometry and the axes allow.
    pub maxvel: f64,
    pub currentvel: f64,
    /// Speed the look-ahead allows at the end.
    pub finalvel: f64,
    pub term_vel: f64,
    /// Speed through an approximately tangent joint with the next segment
    /// (negative: none).
    pub kink_vel: f64,
    pub kink_accel_reduce: f64,
    pub kink_accel_reduce_prev: f64,
    pub maxaccel: f64,
    pub acc_ratio_tan: f64,
    pub term: Term,
    pub blend_prev: bool,
    pub blending_next: bool,
    pub blend_vel: f64,
    /// G64 P tolerance (0: none).
    pub tolerance: f64,
    pub vel_at_blend_start: f64,
    pub at_max: bool,
    /// The look-ahead has run its step with this segment as the later of
    /// the pair, the segment finalised ([`super::lookahead`]'s `settled`).
    pub walked: bool,
    /// Such a step lowered the speed limit to the length per
    /// `TP_MIN_SEGMENT_CYCLES` servo periods.
    pub walk_clamped: bool,
    pub on_final_decel: bool,
    /// Short segment run on a constant-acceleration ramp.
    pub ramp: bool,
    pub splitting: bool,
    pub remove: bool,
    pub finalized: bool,
    pub active: bool,
    pub is_blending: bool,
    pub cycle_time: f64,
}

impl Seg {
    /// A new segment of `length` mm (`tcInit`, `tcSetupState`,
    /// `tcSetupMotion`, `tcClampVelocityByLength`).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        shape: Shape,
        canon: Canon,
        line: u64,
        length: f64,
        vel: f64,
        ini_maxvel: f64,
        acc: f64,
        term: Term,
        tolerance: f64,
        cycle_time: f64,
    ) -> Seg {
        let mut s = Seg {
            shape,
            canon,
            line,
            target: length,
            progress: 0.0,
            nominal_length: length,
            reqvel: vel,
            maxvel: ini_maxvel,
            currentvel: 0.0,
            finalvel: 0.0,
            term_vel: 0.0,
            kink_vel: -1.0,
            kink_accel_reduce: 0.0,
            kink_accel_reduce_prev: 0.0,
            maxaccel: acc,
            acc_ratio_tan: ACC_RATIO_TANGENTIAL,
            term,
            blend_prev: false,
            blending_next: false,
            blend_vel: 0.0,
            tolerance,
            vel_at_blend_start: 0.0,
            at_max: false,
            walked: false,
            walk_clamped: false,
            on_final_decel: false,
            ramp: false,
            splitting: false,
            remove: false,
            finalized: false,
            active: false,
            is_blending: false,
            cycle_time,
        };
        s.clamp_velocity_by_length();
        s
    }

    pub fn is_circular(&self) -> bool {
        matches!(self.shape, Shape::Circle(_) | Shape::Blend(_))
    }

    /// Acceleration along the path before the arc's normal share
    /// (`tcGetOverallMaxAccel`).
    pub fn overall_max_accel(&self) -> f64 {
        let mut scale = 1.0 - self.kink_accel_reduce.max(self.kink_accel_reduce_prev);
        if self.blend_prev || self.term == Term::Parabolic {
            scale *= 0.5;
        }
        self.maxaccel * scale
    }

    /// Acceleration along the path (`tcGetTangentialMaxAccel`).
    pub fn tangential_max_accel(&self) -> f64 {
        let a = self.overall_max_accel();
        if self.is_circular() {
            a * self.acc_ratio_tan
        } else {
            a
        }
    }

    /// Requested speed at the largest feed override, within the
    /// segment's limit (`tcGetMaxTargetVel`).
    pub fn max_target_vel(&self, max_scale: f64) -> f64 {
        (self.reqvel * max_scale).min(self.maxvel)
    }

    /// No faster than the length per servo period.
    pub fn clamp_velocity_by_length(&mut self) {
        self.maxvel = self.maxvel.min(self.target / self.cycle_time);
    }

    /// Fixes the segment's length: the look-ahead may use it now
    /// (`tcFinalizeLength`): the speed cap by length and, for a circle,
    /// the split of the acceleration between normal and tangent.
    pub fn finalize(&mut self) {
        if self.finalized {
            return;
        }
        self.clamp_velocity_by_length();
        if let Shape::Circle(c) = self.shape {
            let (v, ratio) = circle_max_vel(&c, self.maxvel, self.overall_max_accel());
            self.maxvel = v;
            self.acc_ratio_tan = ratio;
        }
        self.finalized = true;
    }

    /// Unit tangent at the start.
    pub fn start_tangent(&self) -> Vec3 {
        match &self.shape {
            Shape::Line(l) => l.u,
            Shape::Circle(c) => c.start_tangent(),
            Shape::Blend(_) => Vec3::new(1.0, 0.0, 0.0),
        }
    }

    /// Unit tangent at the end.
    pub fn end_tangent(&self) -> Vec3 {
        match &self.shape {
            Shape::Line(l) => l.u,
            Shape::Circle(c) => c.end_tangent(),
            Shape::Blend(_) => Vec3::new(1.0, 0.0, 0.0),
        }
    }

    /// Direction of the acceleration at the start, for the parabolic
    /// blend's angle (`tcGetStartAccelUnitVector`).
    pub fn start_accel_direction(&self) -> Vec3 {
        match &self.shape {
            Shape::Line(l) => l.u,
            Shape::Circle(c) => c.start_accel_direction(self.overall_max_accel(), self.reqvel),
            Shape::Blend(_) => Vec3::ZERO,
        }
    }

    /// Direction of the acceleration at the end (`tcGetEndAccelUnitVector`).
    pub fn end_accel_direction(&self) -> Vec3 {
        match &self.shape {
            Shape::Line(l) => l.u,
            Shape::Circle(c) => c.end_accel_direction(),
            Shape::Blend(_) => Vec3::ZERO,
        }
    }
}

/// The speed limit of a circle from its normal acceleration and the
/// tangential share of `a_max` that remains (`pmCircleActualMaxVel`):
/// `v ≤ √(a_n r)` with `a_n = (√3/2) a_max`; below it the tangent keeps
/// `√(1 − (v²/(r a_max))²)` of `a_max`, at the cap exactly one half.
pub(crate) fn circle_max_vel(c: &Circle, v_max: f64, a_max: f64) -> (f64, f64) {
    let a_n_cutoff = acc_ratio_normal() * a_max;
    let r = c.effective_min_radius_mm();
    let a_n_vmax = v_max * v_max / r.max(super::geometry::DOUBLE_FUZZ);
    if a_n_vmax > a_n_cutoff {
        ((a_n_cutoff * r).sqrt(), ACC_RATIO_TANGENTIAL)
    } else {
        (v_max, (1.0 - (a_n_vmax / a_max).powi(2)).sqrt())
    }
}

/// Per-axis displacement with what is below the planner's resolution
/// dropped (`applyMinDisplacement`).
fn moving(d: Vec3) -> [f64; 3] {
    d.to_array()
        .map(|x| if x.abs() < CART_FUZZ_MM { 0.0 } else { x.abs() })
}

/// The time each axis needs at `per_axis` (speed or acceleration), the
/// largest of them; 0 when nothing moves.
fn slowest(d: &[f64; 3], per_axis: &[f64; 3]) -> f64 {
    d.iter()
        .zip(per_axis)
        .map(|(d, v)| if *d > 0.0 { d / v } else { 0.0 })
        .fold(0.0, f64::max)
}

/// Path speed and acceleration limits of a straight move by `d`
/// (`getStraightVelocity`, `getStraightAcceleration`): `None` for a move
/// below the resolution, which LinuxCNC drops.
pub(crate) fn line_limits(d: Vec3, limits: &Limits) -> Option<(f64, f64)> {
    let m = moving(d);
    let length = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
    if length == 0.0 {
        return None;
    }
    let tv = slowest(&m, &limits.max_velocity_mm_s);
    let ta = slowest(&m, &limits.max_acceleration_mm_s2);
    Some((length / tv, length / ta))
}

/// An arc as the canonical layer sends it (`ARC_FEED`).
pub(crate) struct ArcLimits {
    /// Largest path speed.
    pub v_max: f64,
    /// Path acceleration.
    pub a_max: f64,
}

/// Path speed and acceleration of an arc in the plane of axes `(u, v)`
/// from `start` to `end` with start and end radii `r0`, `r1`, sweep
/// `angle` (radians, absolute) and normal-axis travel `axis_len`.
pub(crate) fn arc_limits(
    planar_axes: (usize, usize),
    d: Vec3,
    r0: f64,
    r1: f64,
    angle: f64,
    axis_len: f64,
    limits: &Limits,
) -> ArcLimits {
    let (u, v) = planar_axes;
    let spiral = r1 - r0;
    let dr = spiral / angle;
    let r_min = r0.min(r1);
    let effective_radius = dr.hypot(r_min);
    let v_axes = limits.max_velocity_mm_s[u].min(limits.max_velocity_mm_s[v]);
    let a_axes = limits.max_acceleration_mm_s2[u].min(limits.max_acceleration_mm_s2[v]);
    let a_normal = a_axes * 3f64.sqrt() / 2.0;
    let v_planar = (a_normal * effective_radius).sqrt().min(v_axes);
    let m = moving(d);
    let t_motion_v = slowest(&m, &limits.max_velocity_mm_s);
    let t_motion_a = slowest(&m, &limits.max_acceleration_mm_s2);
    let spiral_length = (r_min * angle).hypot(spiral);
    let total = spiral_length.hypot(axis_len);
    let t_v = t_motion_v.max(spiral_length / v_planar);
    let t_a = t_motion_a.max(spiral_length / a_axes);
    ArcLimits {
        v_max: total / t_v,
        a_max: total / t_a,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    #[test]
    fn a_diagonal_moves_at_the_slower_axis_pace() {
        let lim = Limits::default();
        // 45° in XY: each axis covers L/√2, so the path may go √2 times
        // faster than one axis (acceleration likewise): 1414.2 mm/s².
        let (v, a) = line_limits(Vec3::new(100.0, 100.0, 0.0), &lim).unwrap();
        assert!((a - 1000.0 * 2f64.sqrt()).abs() < 1e-9, "{a}");
        assert!((v - 166.7 * 2f64.sqrt()).abs() < 1e-9, "{v}");
        assert!(line_limits(Vec3::new(1e-9, 0.0, 0.0), &lim).is_none());
    }

    #[test]
    fn a_circle_is_capped_at_its_normal_acceleration() {
        // r = 10 mm, a = 1000 mm/s²: canon caps v at √(0.866·1000·10)
        // = 93.06 mm/s; the planner then leaves the tangent half of a.
        let lim = Limits::default();
        let l = arc_limits((0, 1), Vec3::ZERO, 10.0, 10.0, TAU, 0.0, &lim);
        let cap = (1000.0 * 3f64.sqrt() / 2.0 * 10.0).sqrt();
        assert!((l.v_max - cap).abs() < 1e-9, "{}", l.v_max);
        assert!((l.a_max - 1000.0).abs() < 1e-9, "{}", l.a_max);
        let s = Vec3::new(10.0, 0.0, 0.0);
        let c = Circle::new(s, s, Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0), TAU);
        let (v, ratio) = circle_max_vel(&c, 1e9, 1000.0);
        assert!((v - cap).abs() < 1e-9 && ratio == 0.5, "{v} {ratio}");
        // At 50 mm/s the normal acceleration is 250 mm/s²: the tangent
        // keeps √(1 − 0.25²) of a.
        let (v, ratio) = circle_max_vel(&c, 50.0, 1000.0);
        assert!(v == 50.0 && (ratio - (1.0f64 - 0.0625).sqrt()).abs() < 1e-12);
    }
}
