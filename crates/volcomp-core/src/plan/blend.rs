//! What the planner does at a joint between two segments under G64, as
//! LinuxCNC 2.9 decides it when the second segment is queued
//! (src/emc/tp/tp.c: `tpSetupTangent`, `tpHandleBlendArc`,
//! `tpCreateLineLineBlend` and its arc variants, `tpChooseBestBlend`,
//! `tpComputeBlendVelocity`; src/emc/tp/blendmath.c; [LinuxCNC tp]):
//!
//! * **A tangent joint** (the tangents differ so little that the kink's
//!   instantaneous acceleration at the worst-case speed stays under
//!   `ARC_BLEND_KINK_RATIO` of the axes' limits) is run through at speed;
//!   both segments give up that share of their acceleration.
//! * **A reversal** (tangents anti-parallel within 2°) stops.
//! * **A corner** gets a blend arc tangent to both segments: its radius is
//!   the largest the G64 P tolerance (else a quarter of the shorter
//!   segment) and half of each segment allow, its speed `√(a_n R)`; where a
//!   parabolic blend (both segments overlap at half acceleration) or a
//!   slower tangent kink would be faster, that is used instead. A line
//!   left shorter than `ARC_BLEND_GAP_CYCLES` servo cycles is absorbed
//!   into the arc.
//!
//! Under G61 only tangent joints run through; under G61.1 none.

use super::geometry::{arc_tangent, unit, BlendArc, Circle, Line, DOUBLE_FUZZ};
use super::segment::{acc_ratio_normal, Canon, Seg, Shape, Term, ACC_RATIO_TANGENTIAL};
use super::Limits;
use std::f64::consts::{FRAC_PI_2, PI};
use volcomp_gcode::Vec3;

/// `√x` for `x > 0`, else 0 (posemath's `pmSqrt`).
fn psqrt(x: f64) -> f64 {
    if x > 0.0 {
        x.sqrt()
    } else {
        0.0
    }
}

/// Result of the tangency check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Tangency {
    /// No blend at all (a stop or a reversal).
    Fail,
    /// Tangent: run through at speed.
    Tangent,
    /// A corner: try a blend.
    Corner,
}

/// Which blend the planner chose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Chosen {
    None,
    Parabolic,
    Tangent,
    Arc,
}

/// Whether two unit vectors are parallel or anti-parallel within
/// `TP_ANGLE_EPSILON` (`pmUnitCartsColinear`).
fn colinear(u1: Vec3, u2: Vec3) -> bool {
    let tol = 1e-6 * 1e-6;
    (u1 - u2).norm_squared() < tol || (u1 + u2).norm_squared() < tol
}

/// Marks a joint: `prev` ends with `term`, `tc` follows a parabolic blend
/// or not (`tcSetTermCond`).
pub(crate) fn set_term(prev: &mut Seg, tc: &mut Seg, term: Term) {
    tc.blend_prev = term == Term::Parabolic;
    prev.term = term;
}

fn set_kink(prev: &mut Seg, tc: &mut Seg, kink_vel: f64, reduce: f64) {
    prev.kink_vel = kink_vel;
    prev.kink_accel_reduce = reduce.max(prev.kink_accel_reduce);
    tc.kink_accel_reduce_prev = reduce.max(tc.kink_accel_reduce_prev);
}

fn remove_kink(prev: &mut Seg, tc: &mut Seg) {
    prev.kink_vel = -1.0;
    prev.kink_accel_reduce = 0.0;
    tc.kink_accel_reduce_prev = 0.0;
}

/// The tangency check (`tpSetupTangent`): the acceleration a kink between
/// the tangents needs in one servo cycle at the worst-case speed, against
/// each axis' limit.
pub(crate) fn setup_tangent(prev: &mut Seg, tc: &mut Seg, limits: &Limits) -> Tangency {
    if limits.blend.optimization_depth < 2 || prev.term == Term::Stop {
        return Tangency::Fail;
    }
    let prev_tan = prev.end_tangent();
    let this_tan = tc.start_tangent();
    let sharp = (PI * (2.0 / 180.0)).powi(2);
    if (prev_tan + this_tan).norm_squared() < sharp {
        set_term(prev, tc, Term::Stop);
        return Tangency::Fail;
    }
    let scale = limits.max_feed_override;
    let v_max = prev.max_target_vel(scale).min(tc.max_target_vel(scale));
    let a_inst = v_max / limits.servo_period_s + tc.maxaccel;
    let diff = (this_tan - prev_tan) * a_inst;
    let mut acc_scale_max = (0..3)
        .map(|i| {
            let b = limits.max_acceleration_mm_s2[i];
            if b != 0.0 {
                (diff[i] / b).abs()
            } else {
                0.0
            }
        })
        .fold(0.0, f64::max);
    if prev.is_circular() || tc.is_circular() {
        acc_scale_max /= ACC_RATIO_TANGENTIAL;
    }
    // LinuxCNC bounds the ratio to [0.001, 0.7071] (`tpGetTangentKinkRatio`).
    #[allow(clippy::approx_constant)]
    let kink_ratio = limits.blend.kink_ratio.clamp(0.001, 0.7071);
    if acc_scale_max < kink_ratio {
        set_term(prev, tc, Term::Tangent);
        set_kink(prev, tc, v_max, acc_scale_max);
        Tangency::Tangent
    } else {
        set_kink(prev, tc, v_max * kink_ratio / acc_scale_max, kink_ratio);
        Tangency::Corner
    }
}

/// Speeds of a parabolic blend between `tc` and `next`
/// (`tpComputeBlendVelocity`): the speed below which each starts blending
/// and the net speed along the corner's bisector.
pub(crate) fn parabolic_velocity(
    tc: &Seg,
    next: &Seg,
    target_vel_this: f64,
    target_vel_next: f64,
) -> (f64, f64, f64) {
    parabolic_velocity_at(tc, next, target_vel_this, target_vel_next, None)
}

/// A corner's half angle with its sine and cosine, as the blend arc's
/// computation has them (`f64::sin_cos`: glibc's `sincos`, which gives
/// bit for bit `sin` and `cos`, checked in this module's tests).
#[derive(Debug, Clone, Copy)]
struct HalfAngle {
    theta: f64,
    sin: f64,
    cos: f64,
}

impl HalfAngle {
    fn new(theta: f64) -> HalfAngle {
        let (sin, cos) = theta.sin_cos();
        HalfAngle { theta, sin, cos }
    }
}

/// [`parabolic_velocity`] with the corner's half angle given when it is
/// known (that of two lines, whose directions of acceleration are their
/// tangents: the same operations on the same vectors as [`geom_init`]).
fn parabolic_velocity_at(
    tc: &Seg,
    next: &Seg,
    target_vel_this: f64,
    target_vel_next: f64,
    half_angle: Option<HalfAngle>,
) -> (f64, f64, f64) {
    let acc_this = tc.tangential_max_accel();
    let acc_next = next.tangential_max_accel();
    let triangle = |s: &Seg, a: f64| {
        let len = if s.finalized {
            s.target
        } else {
            s.target / 2.0
        };
        (a * len).sqrt()
    };
    let reach_this = triangle(tc, acc_this).min(target_vel_this);
    let reach_next = triangle(next, acc_next).min(target_vel_next);
    let t_max_reachable = (tc.target / reach_this).min(next.target / reach_next);
    let t_max_blend = (reach_this / acc_this).max(reach_next / acc_next);
    let t_blend = t_max_reachable.min(t_max_blend);
    let mut v_this = reach_this.min(t_blend * acc_this);
    let mut v_next = reach_next.min(t_blend * acc_next);
    let (sin_theta, cos_theta) = match half_angle {
        Some(h) => (h.sin, h.cos),
        None => {
            let v1 = tc.end_accel_direction();
            let v2 = next.start_accel_direction();
            let theta = (-v1.dot(v2)).clamp(-1.0, 1.0).acos() / 2.0;
            (theta.sin(), theta.cos())
        }
    };
    if tc.tolerance > 0.0 {
        let min_cos = (FRAC_PI_2 - 1e-3).cos();
        if cos_theta > min_cos {
            let tblend_vel = 2.0 * psqrt(acc_this * tc.tolerance / cos_theta);
            v_this = v_this.min(tblend_vel);
            v_next = v_next.min(tblend_vel);
        }
    }
    let v_net = sin_theta * (v_this + v_next) / 2.0;
    (v_this, v_next, v_net)
}

/// The requested speed at the largest feed override within the
/// segment's and the trajectory's limits (`tpGetMaxTargetVel`).
pub(crate) fn max_target_vel(s: &Seg, limits: &Limits) -> f64 {
    s.max_target_vel(limits.max_feed_override)
        .min(limits.traj_max_velocity_mm_s)
}

/// Chooses among a parabolic blend, a tangent kink and the blend arc
/// (`tpChooseBestBlend`): the fastest, a parabolic blend counted at half
/// its speed since it halves both segments' acceleration.
pub(crate) fn choose_best(
    prev: &mut Seg,
    tc: &mut Seg,
    arc_maxvel: Option<f64>,
    limits: &Limits,
) -> Chosen {
    choose_best_at(prev, tc, arc_maxvel, None, limits)
}

/// [`choose_best`] with the corner's half angle given when it is known
/// (see [`parabolic_velocity_at`]).
fn choose_best_at(
    prev: &mut Seg,
    tc: &mut Seg,
    arc_maxvel: Option<f64>,
    half_angle: Option<HalfAngle>,
    limits: &Limits,
) -> Chosen {
    if matches!(prev.term, Term::Exact | Term::Stop) {
        return Chosen::None;
    }
    let (_, _, v_net) = parabolic_velocity_at(
        prev,
        tc,
        max_target_vel(prev, limits),
        max_target_vel(tc, limits),
        half_angle,
    );
    let perf = [v_net / 2.0, prev.kink_vel, arc_maxvel.unwrap_or(0.0)];
    let mut best = 0;
    for (i, p) in perf.iter().enumerate() {
        if *p > perf[best] {
            best = i;
        }
    }
    match best {
        0 => {
            remove_kink(prev, tc);
            set_term(prev, tc, Term::Parabolic);
            Chosen::Parabolic
        }
        1 => {
            set_term(prev, tc, Term::Tangent);
            Chosen::Tangent
        }
        _ => {
            remove_kink(prev, tc);
            Chosen::Arc
        }
    }
}

/// The corner's geometry (`BlendGeom3`).
#[derive(Debug, Clone, Copy, Default)]
struct Geom {
    u1: Vec3,
    u2: Vec3,
    p: Vec3,
    normal: Vec3,
    binormal: Vec3,
    u_tan1: Vec3,
    u_tan2: Vec3,
    center1: Vec3,
    center2: Vec3,
    radius1: f64,
    radius2: f64,
    theta_tan: f64,
}

/// The blend's parameters (`BlendParameters`).
#[derive(Debug, Clone, Copy, Default)]
struct Params {
    theta: f64,
    phi: f64,
    l1: f64,
    l2: f64,
    tolerance: f64,
    a_max: f64,
    a_n_max: f64,
    v_req: f64,
    v_goal: f64,
    v_plan: f64,
    r_plan: f64,
    d_plan: f64,
    convex1: bool,
    convex2: bool,
    phi1_max: f64,
    phi2_max: f64,
    consume: bool,
    line_length: f64,
}

/// The blend arc's ends and centre, and how much it trims from each
/// segment (a length from a line, an angle from a circle).
#[derive(Debug, Clone, Copy, Default)]
struct Points {
    arc_start: Vec3,
    arc_end: Vec3,
    arc_center: Vec3,
    trim1: f64,
    trim2: f64,
}

/// A blend arc ready to be queued: the new shapes of both segments and
/// whether the first is absorbed into the arc.
pub(crate) struct Blend {
    pub arc: ArcSeg,
    pub prev_shape: Shape,
    pub prev_target: f64,
    pub tc_shape: Shape,
    pub tc_target: f64,
    pub consume: bool,
}

/// The point where two segments meet (`tcGetIntersectionPoint`).
fn intersection(prev: &Seg, tc: &Seg) -> Option<Vec3> {
    match (&prev.shape, &tc.shape) {
        (_, Shape::Line(l)) => Some(l.start),
        (Shape::Line(l), _) => Some(l.end),
        (_, Shape::Circle(c)) => Some(c.point(0.0)),
        _ => None,
    }
}

/// `blendGeom3Init` and `blendCalculateNormals3`.
fn geom_init(prev: &Seg, tc: &Seg) -> Option<Geom> {
    let u_tan1 = prev.end_tangent();
    let u_tan2 = tc.start_tangent();
    let theta_tan = (-u_tan1.dot(u_tan2)).clamp(-1.0, 1.0).acos() / 2.0;
    if FRAC_PI_2 - theta_tan < 1e-6 || theta_tan < 1e-6 {
        return None;
    }
    let mut g = Geom {
        u1: u_tan1,
        u2: u_tan2,
        p: intersection(prev, tc)?,
        u_tan1,
        u_tan2,
        theta_tan,
        ..Geom::default()
    };
    normals(&mut g);
    Some(g)
}

fn normals(g: &mut Geom) {
    g.binormal = unit(g.u_tan1.cross(g.u_tan2));
    g.normal = unit(g.u_tan2 - g.u_tan1);
}

/// Diameter of the circle inscribed in the section through the limits'
/// box by the plane of normal `n` (`calculateInscribedDiameter`): the
/// largest acceleration (or speed) in any direction of that plane.
#[cfg(test)]
fn inscribed_diameter(n: Vec3, bounds: &[f64; 3]) -> Option<f64> {
    planar_norms(n).map(|norms| diameter_of(&norms, bounds))
}

/// The lengths `calculateInscribedDiameter` divides each axis' bound by:
/// the norm of the axis' unit vector projected on the plane of normal
/// `n` (at least `1e-12` along the axis); `None` when `n` is not a unit
/// vector. They depend on the plane alone, so the acceleration's and the
/// speed's diameters of one plane share them.
fn planar_norms(n: Vec3) -> Option<[f64; 3]> {
    if (1.0 - n.norm_squared()).abs() > 1e-6 {
        return None;
    }
    let mut norms = [0.0; 3];
    for (i, l) in norms.iter_mut().enumerate() {
        let mut planar = n * -n[i];
        planar[i] += 1.0;
        let mut planar = planar.abs();
        planar[i] = planar[i].max(1e-12);
        *l = planar.norm();
    }
    Some(norms)
}

/// The inscribed diameters of the acceleration and speed limits
/// ([`planar_norms`], [`diameter_of`]) of the last blend plane asked for,
/// kept with its binormal's bits: a CAM program's corners mostly lie in
/// one plane (a raster's in XZ: the binormal ±Y exactly), whose
/// diameters are the same function of the same bits each time. The
/// limits are the planner's, fixed for its life.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct PlaneLimits {
    /// The binormal the diameters are for (none asked yet: `None`).
    binormal: Option<[u64; 3]>,
    /// (acceleration, speed); `None` when the binormal is no unit vector.
    diameters: Option<(f64, f64)>,
}

impl PlaneLimits {
    /// The acceleration's and the speed's inscribed diameters in the
    /// plane of normal `n` (`calculateInscribedDiameter` of both).
    fn of(&mut self, n: Vec3, limits: &Limits) -> Option<(f64, f64)> {
        let key = [n.x.to_bits(), n.y.to_bits(), n.z.to_bits()];
        if self.binormal != Some(key) {
            self.binormal = Some(key);
            self.diameters = planar_norms(n).map(|norms| {
                (
                    diameter_of(&norms, &limits.max_acceleration_mm_s2),
                    diameter_of(&norms, &limits.max_velocity_mm_s),
                )
            });
        }
        self.diameters
    }
}

/// `calculateInscribedDiameter` with the plane's [`planar_norms`] given.
fn diameter_of(norms: &[f64; 3], bounds: &[f64; 3]) -> f64 {
    let mut extents = [0.0; 3];
    for (i, e) in extents.iter_mut().enumerate() {
        if bounds[i] != 0.0 {
            *e = bounds[i] / norms[i];
        }
    }
    let mut d = extents.iter().copied().fold(0.0, f64::max);
    for i in 0..3 {
        if bounds[i] != 0.0 {
            d = d.min(extents[i]);
        }
    }
    d
}

/// `tcFindBlendTolerance`: the G64 P tolerance, else a quarter of the
/// segment; at most a quarter of either segment.
fn blend_tolerance(prev: &Seg, tc: &Seg) -> f64 {
    let ratio = 0.25;
    let t1 = if prev.tolerance == 0.0 {
        prev.nominal_length * ratio
    } else {
        prev.tolerance
    };
    let t2 = if tc.tolerance == 0.0 {
        tc.nominal_length * ratio
    } else {
        tc.tolerance
    };
    t1.min(t2)
        .min(prev.nominal_length * ratio)
        .min(tc.nominal_length * ratio)
}

/// `blendParamKinematics`: acceleration and speed limits of the blend.
fn kinematics(
    g: &Geom,
    p: &mut Params,
    (prev, tc): (&Seg, &Seg),
    limits: &Limits,
    planes: &mut PlaneLimits,
) -> Option<()> {
    p.phi = PI - p.theta * 2.0;
    p.tolerance = blend_tolerance(prev, tc);
    let (a_max, v_planar_max) = planes.of(g.binormal, limits)?;
    p.a_max = a_max;
    p.a_n_max = p.a_max * acc_ratio_normal();
    p.v_req = prev.max_target_vel(1.0).max(tc.max_target_vel(1.0));
    let scale = limits.max_feed_override;
    p.v_goal = prev.max_target_vel(scale).max(tc.max_target_vel(scale));
    let phi_eff = p.phi.min(PI * 0.49);
    let v_max1 = prev.maxvel.min(tc.maxvel / phi_eff.cos());
    let v_max2 = tc.maxvel.min(prev.maxvel / phi_eff.cos());
    let v_area = v_max1 * v_max2 / 2.0 * p.phi.sin();
    let base = (g.u2 * v_max2 - g.u1 * v_max1).norm();
    let both_lines = matches!(prev.shape, Shape::Line(_)) && matches!(tc.shape, Shape::Line(_));
    let v_max_alt = if both_lines { 2.0 * v_area / base } else { 0.0 };
    p.v_goal = p.v_goal.min(v_max_alt.max(v_planar_max));
    Some(())
}

/// `blendComputeParameters`: the arc's radius and speed.
fn compute(p: &mut Params) -> Option<()> {
    compute_at(p, HalfAngle::new(p.theta))
}

/// [`compute`] with the sine and cosine of `p.theta` given (`h.theta ==
/// p.theta`).
fn compute_at(p: &mut Params, h: HalfAngle) -> Option<()> {
    debug_assert_eq!(h.theta.to_bits(), p.theta.to_bits());
    let h_tol = p.tolerance / (1.0 - h.sin);
    let d_tol = h.cos * h_tol;
    let d_geom = p.l1.min(p.l2).min(d_tol);
    let r_geom = p.theta.tan() * d_geom;
    let v_normal = psqrt(p.a_n_max * r_geom);
    p.v_plan = v_normal.min(p.v_goal);
    let a_parabolic = p.a_max * 0.5;
    let v_triangle = psqrt(2.0 * a_parabolic * d_geom);
    let t_blend = v_triangle.min(p.v_plan) / a_parabolic;
    let s_blend = t_blend * p.v_plan;
    let r_blend = (s_blend / p.phi).min(r_geom);
    p.r_plan = (p.v_plan * p.v_plan / p.a_n_max).max(r_blend);
    p.d_plan = p.r_plan / p.theta.tan();
    let s_arc = p.r_plan * p.phi;
    if p.r_plan < 1e-12 || s_arc < 1e-6 {
        return None;
    }
    Some(())
}

/// `blendFindPoints3`: the arc on the corner's straight approximation,
/// with the half angle `p.theta`'s sine and cosine given.
fn find_points(g: &Geom, p: &Params, h: HalfAngle) -> Points {
    debug_assert_eq!(h.theta.to_bits(), p.theta.to_bits());
    let center_dist = p.r_plan / h.sin;
    Points {
        arc_center: g.p + g.normal * center_dist,
        arc_start: g.p - g.u1 * p.d_plan,
        arc_end: g.p + g.u2 * p.d_plan,
        trim1: p.d_plan,
        trim2: p.d_plan,
    }
}

/// `blendCheckConsume`: a line left shorter than the gap cycles at the
/// arc's speed is absorbed into the arc.
fn check_consume(p: &mut Params, pts: &Points, prev: &Seg, limits: &Limits) {
    p.consume = false;
    p.line_length = 0.0;
    if !matches!(prev.shape, Shape::Line(_)) {
        return;
    }
    let l_prev = prev.target - pts.trim1;
    let prev_seg_time = l_prev / p.v_plan;
    let can_consume = !prev.blend_prev;
    p.consume = prev_seg_time < limits.blend.gap_cycles * prev.cycle_time && can_consume;
    if p.consume {
        p.line_length = l_prev;
    }
}

/// The centre of a spiral's osculating circle at `base` (the centre moved
/// along the tangent by the spiral's drift; `findSpiralApproximation`).
fn spiral_approximation(c: &Circle, base: Vec3, u_tan: Vec3) -> (Vec3, f64) {
    let dr = c.spiral_mm / c.angle_rad;
    let center = c.center + u_tan * dr;
    (center, (base - center).norm())
}

/// `arcConvexTest`.
fn convex(center: Vec3, p: Vec3, u: Vec3, reverse: bool) -> bool {
    let dot = (p - center).dot(u);
    reverse ^ (dot < 0.0)
}

/// `findTrimAngle`: the angle at `center` between the corner and the arc's
/// centre.
fn trim_angle(p: Vec3, arc_center: Vec3, center: Vec3) -> f64 {
    let u_p = unit(p - center);
    let u_c = unit(arc_center - center);
    u_c.dot(u_p).clamp(-1.0, 1.0).acos()
}

/// The blend arc's tangent at its start or end, spiral included
/// (`arcTangent`).
fn blend_tangent(
    start: Vec3,
    end: Vec3,
    center: Vec3,
    arc: &BlendArc,
    binormal: Vec3,
    at_end: bool,
) -> Vec3 {
    let r0 = start - center;
    let r1 = end - center;
    let r = if at_end { r1 } else { r0 };
    let dr = (r1.norm() - r0.norm()) / arc.angle_rad;
    unit(arc_tangent(binormal, r) * r.norm() + unit(r) * dr)
}

/// `checkTangentAngle`: the blend arc meets the circle within the angle a
/// servo cycle's normal-acceleration margin allows.
fn tangent_ok(circle_tan: Vec3, arc_tan: Vec3, p: &Params, limits: &Limits) -> bool {
    let angle = circle_tan.dot(unit(arc_tan)).clamp(-1.0, 1.0).acos();
    let margin = acc_ratio_normal() * 0.25 * p.a_max;
    let dx = p.v_plan / limits.servo_period_s;
    let angle_max = if dx > 0.0 { margin / dx } else { 1e-6 };
    angle <= angle_max
}

/// What the blend arc segment is made of (`tpInitBlendArcFromPrev`):
/// the segment itself is made once the arc is chosen, where it is queued
/// ([`ArcSeg::seg`]), not copied on its way there.
pub(crate) struct ArcSeg {
    arc: BlendArc,
    canon: Canon,
    line: u64,
    length: f64,
    v_req: f64,
    v_plan: f64,
    a_max: f64,
    tolerance: f64,
    cycle_time: f64,
}

impl ArcSeg {
    /// The speed limit of the finalised segment: the planned speed, no
    /// more than the length per servo period (`tcClampVelocityByLength`,
    /// the operation [`Seg::new`] and [`Seg::finalize`] make; a blend arc
    /// is no circle to `tcFinalizeLength`).
    fn maxvel(&self) -> f64 {
        self.v_plan.min(self.length / self.cycle_time)
    }

    /// The finalised blend arc segment (`tpInitBlendArcFromPrev`).
    pub(crate) fn seg(&self) -> Seg {
        let mut s = Seg::new(
            Shape::Blend(self.arc),
            self.canon,
            self.line,
            self.length,
            self.v_req,
            self.v_plan,
            self.a_max,
            Term::Tangent,
            self.tolerance,
            self.cycle_time,
        );
        s.finalize();
        debug_assert_eq!(s.maxvel.to_bits(), self.maxvel().to_bits());
        s
    }
}

/// The blend arc segment's parts (`tpInitBlendArcFromPrev`).
fn blend_seg(prev: &Seg, arc: BlendArc, p: &Params, tolerance: f64, limits: &Limits) -> ArcSeg {
    ArcSeg {
        arc,
        canon: prev.canon,
        line: prev.line,
        length: arc.length_mm(),
        v_req: p.v_req,
        v_plan: p.v_plan,
        a_max: p.a_max,
        tolerance,
        cycle_time: limits.servo_period_s,
    }
}

/// Tries the blend arc between `prev` and `tc` (`tpCreateBlendIfPossible`);
/// the choice among parabolic, tangent and arc is made (and marked on
/// the segments) as LinuxCNC makes it, whatever the outcome.
pub(crate) fn try_blend_arc(
    prev: &mut Seg,
    tc: &mut Seg,
    limits: &Limits,
    planes: &mut PlaneLimits,
) -> Option<Blend> {
    if prev.term != Term::Parabolic || tc.finalized || prev.finalized {
        return None;
    }
    match (&prev.shape, &tc.shape) {
        (Shape::Line(_), Shape::Line(_)) => line_line(prev, tc, limits, planes),
        (Shape::Line(_), Shape::Circle(_)) => line_arc(prev, tc, limits, planes),
        (Shape::Circle(_), Shape::Line(_)) => arc_line(prev, tc, limits, planes),
        (Shape::Circle(_), Shape::Circle(_)) => arc_arc(prev, tc, limits, planes),
        _ => None,
    }
}

fn line_line(
    prev: &mut Seg,
    tc: &mut Seg,
    limits: &Limits,
    planes: &mut PlaneLimits,
) -> Option<Blend> {
    // The two shapes by reference: a copy of the pair is two of the
    // largest shape whatever they are.
    let (Shape::Line(l1), Shape::Line(l2)) = (&prev.shape, &tc.shape) else {
        return None;
    };
    let (l1, l2) = (*l1, *l2);
    let g = geom_init(prev, tc)?;
    let mut p = Params {
        theta: g.theta_tan,
        l1: prev.target.min(prev.nominal_length * 0.5),
        l2: tc.target * 0.5,
        ..Params::default()
    };
    kinematics(&g, &mut p, (prev, tc), limits, planes)?;
    // The half angle's sine and cosine, for the arc and the parabolic
    // blend it is compared with.
    let half = HalfAngle::new(g.theta_tan);
    compute_at(&mut p, half)?;
    let pts = find_points(&g, &p, half);
    check_consume(&mut p, &pts, prev, limits);
    let arc = BlendArc::from_points(pts.arc_start, pts.arc_end, pts.arc_center, p.line_length)?;
    let seg = blend_seg(prev, arc, &p, tc.tolerance, limits);
    if choose_best_at(prev, tc, Some(seg.maxvel()), Some(half), limits) != Chosen::Arc {
        return None;
    }
    let new1 = Line::new(l1.start, pts.arc_start);
    let new2 = Line::new(pts.arc_end, l2.end);
    Some(Blend {
        arc: seg,
        prev_shape: Shape::Line(new1),
        prev_target: new1.length_mm,
        tc_shape: Shape::Line(new2),
        tc_target: new2.length_mm,
        consume: p.consume,
    })
}

/// The quadratic solution of a line–circle blend's centre
/// (`blendLineArcPostProcess` and `blendArcLinePostProcess`): the arc's
/// centre lies `R` from the line and `d` from the circle's centre.
fn line_circle_center(
    g: &Geom,
    p: &Params,
    u_line: Vec3,
    center: Vec3,
    radius: f64,
    convex: bool,
    along_sign: f64,
) -> Option<(Vec3, f64)> {
    let d = if convex { -p.r_plan } else { p.r_plan } + radius;
    let n = unit(g.binormal.cross(u_line));
    let r_pc = center - g.p;
    let (c_u, c_n) = (r_pc.dot(u_line), r_pc.dot(n));
    let b = 2.0 * c_u;
    let c = c_u * c_u - d * d + (p.r_plan - c_n).powi(2);
    let disc = b * b - 4.0 * c;
    if disc < 0.0 {
        return None;
    }
    let t = disc.sqrt();
    let d_l = ((-b + t) / 2.0).abs().min(((-b - t) / 2.0).abs());
    let r_pc = u_line * (along_sign * d_l) + n * p.r_plan;
    if r_pc.norm() - p.r_plan > p.tolerance {
        return None;
    }
    Some((g.p + r_pc, d_l))
}

fn line_arc(
    prev: &mut Seg,
    tc: &mut Seg,
    limits: &Limits,
    planes: &mut PlaneLimits,
) -> Option<Blend> {
    let (Shape::Line(l1), Shape::Circle(c2)) = (&prev.shape, &tc.shape) else {
        return None;
    };
    let (l1, c2) = (*l1, *c2);
    let mut g = geom_init(prev, tc)?;
    (g.center2, g.radius2) = spiral_approximation(&c2, g.p, g.u_tan2);
    let mut p = Params::default();
    p.convex2 = convex(g.center2, g.p, g.u_tan1, true);
    let blend_angle_2 = if p.convex2 { g.theta_tan } else { FRAC_PI_2 };
    p.phi2_max = (c2.angle_rad / 3.0).min(blend_angle_2);
    p.theta = g.theta_tan;
    if p.convex2 {
        let bp = c2.point(p.phi2_max / 2.0);
        g.u2 = unit(bp - g.p);
        p.theta = p.theta.min(g.theta_tan - p.phi2_max / 4.0);
    }
    p.l1 = prev.target.min(prev.nominal_length / 2.0);
    p.l2 = if p.convex2 {
        (p.phi2_max / 4.0).sin() * g.radius2
    } else {
        p.phi2_max * g.radius2
    };
    kinematics(&g, &mut p, (prev, tc), limits, planes)?;
    if !colinear(g.binormal, c2.normal) {
        return None;
    }
    compute(&mut p)?;
    let (center, d_l) = line_circle_center(&g, &p, g.u1, g.center2, g.radius2, p.convex2, -1.0)?;
    let pts = Points {
        arc_center: center,
        trim1: d_l,
        trim2: trim_angle(g.p, center, g.center2),
        ..Points::default()
    };
    if pts.trim2 > p.phi2_max {
        return None;
    }
    check_consume(&mut p, &pts, prev, limits);
    let new_len1 = l1.length_mm - pts.trim1;
    if new_len1 <= DOUBLE_FUZZ {
        return None;
    }
    let line1 = l1.stretched(new_len1, false);
    let circ2 = c2.stretched(c2.angle_rad - pts.trim2, true)?;
    let (a_start, a_end) = (line1.end, circ2.point(0.0));
    let arc = BlendArc::from_points(a_start, a_end, center, p.line_length)?;
    let seg = blend_seg(prev, arc, &p, tc.tolerance, limits);
    let arc_tan = blend_tangent(a_start, a_end, center, &arc, g.binormal, true);
    if !tangent_ok(circ2.start_tangent(), arc_tan, &p, limits) {
        return None;
    }
    if choose_best(prev, tc, Some(seg.maxvel()), limits) != Chosen::Arc {
        return None;
    }
    Some(Blend {
        arc: seg,
        prev_shape: Shape::Line(line1),
        prev_target: line1.length_mm,
        tc_shape: Shape::Circle(circ2),
        tc_target: circ2.length_mm(),
        consume: p.consume,
    })
}

fn arc_line(
    prev: &mut Seg,
    tc: &mut Seg,
    limits: &Limits,
    planes: &mut PlaneLimits,
) -> Option<Blend> {
    let (Shape::Circle(c1), Shape::Line(l2)) = (&prev.shape, &tc.shape) else {
        return None;
    };
    let (c1, l2) = (*c1, *l2);
    let mut g = geom_init(prev, tc)?;
    (g.center1, g.radius1) = spiral_approximation(&c1, g.p, g.u_tan1);
    let mut p = Params::default();
    p.convex1 = convex(g.center1, g.p, g.u_tan2, false);
    let blend_angle_1 = if p.convex1 { g.theta_tan } else { FRAC_PI_2 };
    p.phi1_max = (c1.angle_rad * 2.0 / 3.0).min(blend_angle_1);
    p.theta = g.theta_tan;
    if p.convex1 {
        let bp = c1.point(c1.angle_rad - p.phi1_max / 2.0);
        g.u1 = unit(g.p - bp);
        p.theta = p.theta.min(g.theta_tan - p.phi1_max / 4.0);
    }
    p.l1 = if p.convex1 {
        (p.phi1_max / 4.0).sin() * g.radius1
    } else {
        p.phi1_max * g.radius1
    };
    p.l2 = tc.nominal_length / 2.0;
    kinematics(&g, &mut p, (prev, tc), limits, planes)?;
    if !colinear(g.binormal, c1.normal) {
        return None;
    }
    compute(&mut p)?;
    let (center, d_l) = line_circle_center(&g, &p, g.u2, g.center1, g.radius1, p.convex1, 1.0)?;
    let pts = Points {
        arc_center: center,
        trim1: trim_angle(g.p, center, g.center1),
        trim2: d_l,
        ..Points::default()
    };
    if pts.trim1 > p.phi1_max {
        return None;
    }
    let circ1 = c1.stretched(c1.angle_rad - pts.trim1, false)?;
    let new_len2 = tc.target - pts.trim2;
    if new_len2 <= DOUBLE_FUZZ {
        return None;
    }
    let line2 = l2.stretched(new_len2, true);
    let (a_start, a_end) = (circ1.point(circ1.angle_rad), line2.start);
    let arc = BlendArc::from_points(a_start, a_end, center, 0.0)?;
    let seg = blend_seg(prev, arc, &p, tc.tolerance, limits);
    let arc_tan = blend_tangent(a_start, a_end, center, &arc, g.binormal, false);
    if !tangent_ok(circ1.end_tangent(), arc_tan, &p, limits) {
        return None;
    }
    if choose_best(prev, tc, Some(seg.maxvel()), limits) != Chosen::Arc {
        return None;
    }
    Some(Blend {
        arc: seg,
        prev_shape: Shape::Circle(circ1),
        prev_target: circ1.length_mm(),
        tc_shape: Shape::Line(line2),
        tc_target: line2.length_mm,
        consume: false,
    })
}

fn arc_arc(
    prev: &mut Seg,
    tc: &mut Seg,
    limits: &Limits,
    planes: &mut PlaneLimits,
) -> Option<Blend> {
    let (Shape::Circle(c1), Shape::Circle(c2)) = (&prev.shape, &tc.shape) else {
        return None;
    };
    let (c1, c2) = (*c1, *c2);
    if !colinear(c1.normal, c2.normal) {
        return None;
    }
    let mut g = geom_init(prev, tc)?;
    (g.center1, g.radius1) = spiral_approximation(&c1, g.p, g.u_tan1);
    (g.center2, g.radius2) = spiral_approximation(&c2, g.p, g.u_tan2);
    normals(&mut g);
    g.p = c2.point(0.0);
    let mut p = Params::default();
    p.convex1 = convex(g.center1, g.p, g.u_tan2, false);
    p.convex2 = convex(g.center2, g.p, g.u_tan1, true);
    let blend_angle_1 = if p.convex1 { g.theta_tan } else { FRAC_PI_2 };
    let blend_angle_2 = if p.convex2 { g.theta_tan } else { FRAC_PI_2 };
    p.phi1_max = (c1.angle_rad * 2.0 / 3.0).min(blend_angle_1);
    p.phi2_max = (c2.angle_rad / 3.0).min(blend_angle_2);
    p.theta = g.theta_tan;
    if p.convex1 {
        let bp = c1.point(c1.angle_rad - p.phi1_max / 2.0);
        g.u1 = unit(g.p - bp);
        p.theta = p.theta.min(g.theta_tan - p.phi1_max / 4.0);
    }
    if p.convex2 {
        let bp = c2.point(p.phi2_max / 2.0);
        g.u2 = unit(bp - g.p);
        p.theta = p.theta.min(g.theta_tan - p.phi2_max / 4.0);
    }
    if p.theta < PI / 12.0 {
        return None;
    }
    p.l1 = if p.convex1 {
        (p.phi1_max / 4.0).sin() * g.radius1
    } else {
        p.phi1_max * g.radius1
    };
    p.l2 = if p.convex2 {
        (p.phi2_max / 4.0).sin() * g.radius2
    } else {
        p.phi2_max * g.radius2
    };
    kinematics(&g, &mut p, (prev, tc), limits, planes)?;
    if !colinear(g.binormal, c1.normal) || !colinear(g.binormal, c2.normal) {
        return None;
    }
    compute(&mut p)?;
    // The arc's centre lies d1 from the first circle's centre and d2 from
    // the second's (`blendArcArcPostProcess`).
    let d1 = if p.convex1 { -p.r_plan } else { p.r_plan } + g.radius1;
    let d2 = if p.convex2 { -p.r_plan } else { p.r_plan } + g.radius2;
    let r_c1c2 = g.center2 - g.center1;
    let c2x = r_c1c2.norm();
    let cx = (-d1 * d1 + d2 * d2 - c2x * c2x) / (-2.0 * c2x);
    let cy = psqrt(d1 * d1 - cx * cx);
    if c2x == 0.0 {
        return None;
    }
    let uc = r_c1c2 / c2x;
    let mut nc = g.binormal.cross(uc);
    if g.normal.dot(nc) < 0.0 {
        nc = -nc;
    }
    if nc.norm() == 0.0 {
        return None;
    }
    let nc = unit(nc);
    let c_x = uc * cx;
    let mut c_y = nc * cy;
    let r_pc1 = g.center1 - g.p;
    if (r_pc1 + c_x - c_y).norm() < (r_pc1 + c_x + c_y).norm() {
        c_y = -c_y;
    }
    let center = g.center1 + c_x + c_y;
    if (center - g.p).norm() - p.r_plan > p.tolerance {
        return None;
    }
    let trim1 = trim_angle(g.p, center, g.center1);
    let trim2 = trim_angle(g.p, center, g.center2);
    if trim1 > p.phi1_max || trim2 > p.phi2_max {
        return None;
    }
    let circ1 = c1.stretched(c1.angle_rad - trim1, false)?;
    let circ2 = c2.stretched(c2.angle_rad - trim2, true)?;
    let (a_start, a_end) = (circ1.point(circ1.angle_rad), circ2.point(0.0));
    let arc = BlendArc::from_points(a_start, a_end, center, 0.0)?;
    let seg = blend_seg(prev, arc, &p, tc.tolerance, limits);
    let t1 = blend_tangent(a_start, a_end, center, &arc, g.binormal, false);
    let t2 = blend_tangent(a_start, a_end, center, &arc, g.binormal, true);
    if !tangent_ok(circ1.end_tangent(), t1, &p, limits)
        || !tangent_ok(circ2.start_tangent(), t2, &p, limits)
    {
        return None;
    }
    if choose_best(prev, tc, Some(seg.maxvel()), limits) != Chosen::Arc {
        return None;
    }
    Some(Blend {
        arc: seg,
        prev_shape: Shape::Circle(circ1),
        prev_target: circ1.length_mm(),
        tc_shape: Shape::Circle(circ2),
        tc_target: circ2.length_mm(),
        consume: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line_seg(a: Vec3, b: Vec3, feed: f64, limits: &Limits) -> Seg {
        let l = Line::new(a, b);
        let (v, acc) = crate::plan::segment::line_limits(b - a, limits).unwrap();
        Seg::new(
            Shape::Line(l),
            Canon::Feed,
            1,
            l.length_mm,
            feed.min(v),
            v,
            acc,
            Term::Parabolic,
            0.0,
            limits.servo_period_s,
        )
    }

    #[test]
    fn a_right_angle_corner_gets_a_blend_arc_of_a_quarter_segment_tolerance() {
        // Two 40 mm lines at 90°, F6000 (100 mm/s), 1000 mm/s² per axis.
        // Tolerance: a quarter of 40 = 10 mm, at most half of each line
        // (20 mm) along it. The arc's plane is XY: a_max = 1000 (the
        // inscribed circle of the XY limits), a_n = 866 mm/s². θ = 45°:
        // d_tol = cos θ · T / (1 − sin θ) = 24.1 mm > 20, so d = 20 mm,
        // R_geom = 20 mm, v = min(√(866·20) = 131.6, v_goal = 100) = 100;
        // the radius R = max(v²/a_n = 11.55, R_blend) where R_blend =
        // min(s/φ, 20) with t = min(√(2·500·20), 100)/500 = 0.2 s,
        // s = 20 mm, φ = π/2: 12.73 mm. So R = 12.73 mm, d = R.
        let lim = Limits::default();
        let mut a = line_seg(Vec3::ZERO, Vec3::new(40.0, 0.0, 0.0), 100.0, &lim);
        let mut b = line_seg(
            Vec3::new(40.0, 0.0, 0.0),
            Vec3::new(40.0, 40.0, 0.0),
            100.0,
            &lim,
        );
        assert_eq!(setup_tangent(&mut a, &mut b, &lim), Tangency::Corner);
        let blend =
            try_blend_arc(&mut a, &mut b, &lim, &mut PlaneLimits::default()).expect("a blend arc");
        let arc_seg = blend.arc.seg();
        let r = 20.0 / std::f64::consts::FRAC_PI_2;
        match arc_seg.shape {
            Shape::Blend(arc) => {
                assert!((arc.radius_mm - r).abs() < 1e-9, "{}", arc.radius_mm);
                assert!((arc.angle_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
            }
            _ => panic!("not a blend arc"),
        }
        assert!((blend.prev_target - (40.0 - r)).abs() < 1e-9);
        assert!((arc_seg.maxvel - 100.0).abs() < 1e-9, "{}", arc_seg.maxvel);
        assert!(!blend.consume);
    }

    #[test]
    fn collinear_lines_are_tangent_and_a_reversal_stops() {
        let lim = Limits::default();
        let mut a = line_seg(Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0), 50.0, &lim);
        let mut b = line_seg(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(20.0, 0.0, 0.0),
            50.0,
            &lim,
        );
        assert_eq!(setup_tangent(&mut a, &mut b, &lim), Tangency::Tangent);
        assert_eq!(a.term, Term::Tangent);
        assert_eq!(a.kink_vel, 50.0);
        let mut c = line_seg(
            Vec3::new(20.0, 0.0, 0.0),
            Vec3::new(10.0, 0.0, 0.0),
            50.0,
            &lim,
        );
        assert_eq!(setup_tangent(&mut b, &mut c, &lim), Tangency::Fail);
        assert_eq!(b.term, Term::Stop);
    }

    #[test]
    fn the_inscribed_diameter_of_a_cube_section_is_its_side() {
        let b = [1000.0, 1000.0, 1000.0];
        assert!((inscribed_diameter(Vec3::new(0.0, 0.0, 1.0), &b).unwrap() - 1000.0).abs() < 1e-9);
        // A plane through the XY diagonal and Z: X and Y each see √2.
        let n = Vec3::new(1.0, -1.0, 0.0) / 2f64.sqrt();
        let d = inscribed_diameter(n, &b).unwrap();
        assert!((d - 1000.0).abs() < 1e-9, "{d}");
        let b2 = [1000.0, 500.0, 1000.0];
        assert!((inscribed_diameter(Vec3::new(0.0, 0.0, 1.0), &b2).unwrap() - 500.0).abs() < 1e-9);
    }

    #[test]
    fn a_half_angle_s_sine_and_cosine_together_are_those_taken_one_at_a_time() {
        // The blend arc takes both at once (`sincos`), the parabolic blend
        // it is compared with took them one at a time (`sin`, `cos`): the
        // same bits, on half angles across the range a corner has
        // (1e-6 to π/2 − 1e-6, `geom_init`) and near its ends.
        use std::hint::black_box;
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut unit = || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut angles = vec![
            1e-6,
            FRAC_PI_2 - 1e-6,
            0.5,
            1.0,
            std::f64::consts::FRAC_PI_4,
        ];
        for _ in 0..200_000 {
            angles.push(1e-6 + unit() * (FRAC_PI_2 - 2e-6));
            angles.push(10f64.powf(-6.0 + 6.0 * unit()));
        }
        for theta in angles {
            let h = HalfAngle::new(black_box(theta));
            let sin = black_box(theta).sin();
            let cos = black_box(theta).cos();
            assert_eq!(h.sin.to_bits(), sin.to_bits(), "sin {theta:e}");
            assert_eq!(h.cos.to_bits(), cos.to_bits(), "cos {theta:e}");
        }
    }
}
