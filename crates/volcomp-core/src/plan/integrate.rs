//! The time integral: the queue run one servo period at a time, as
//! LinuxCNC 2.9's motion controller runs it (src/emc/tp/tp.c:
//! `tpRunCycle`, `tpActivateSegment`, `tpHandleRegularCycle`,
//! `tpHandleSplitCycle`, `tpUpdateCycle`, `tpCalculateTrapezoidalAccel`,
//! `tpCalculateRampAccel`, `tcUpdateDistFromAccel`, `tpCheckEndCondition`,
//! `tpDoParabolicBlending`; tc.c: `tcIsBlending`; [LinuxCNC tp]).
//!
//! Each period the active segment takes the speed of a discrete
//! trapezoid: the largest `v'` within the requested speed from which it
//! can still slow to its end speed at its acceleration,
//! `v' = −aΔt/2 + √(v_f² + a(2d − vΔt) + (aΔt/2)²)`, reached within
//! `±aΔt` of the present speed; it advances by the mean of both speeds.
//! Within one period of its end a segment hands the rest of the period to
//! the next ("split cycle") at the speed it ends with; a segment ending in
//! a parabolic blend starts the next one while it decelerates, both
//! running at once. A short segment run through at speed (under
//! `1/ARC_BLEND_RAMP_FREQ` s) changes speed at a constant rate instead.
//!
//! Counting periods gives exactly what LinuxCNC's HAL timers count in
//! bench/cycle_time: the periods with a segment in the queue, and those
//! whose active segment is a feed move or an arc.

use super::blend;
use super::segment::{Canon, Seg, Term};
use super::Limits;
use std::collections::VecDeque;

const VEL_EPSILON: f64 = 1e-8;
const POS_EPSILON: f64 = 1e-12;
const TIME_EPSILON: f64 = 1e-12;

/// What the periods have added up to.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Periods {
    /// Periods with a segment in the queue.
    pub moving: u64,
    /// Periods whose segment shown as active is a feed move or an arc.
    pub cutting: u64,
    /// Periods whose segment shown as active is a rapid.
    pub rapid: u64,
}

/// The segment shown as active: its motion type (`tp->motionType`) and
/// the program line it comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Shown {
    pub canon: Canon,
    pub line: u64,
}

impl Seg {
    fn shown(&self) -> Option<Shown> {
        Some(Shown {
            canon: self.canon,
            line: self.line,
        })
    }
}

/// The state the motion controller keeps between periods.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Exec {
    pub periods: Periods,
    /// The segment shown as active.
    pub shown: Option<Shown>,
    /// Which way of running the next period [`run_next`] tries first.
    first: First,
    /// Periods are counted per program line ([`super::Planner::per_line`]):
    /// each call of [`run_next`] ends where the segment shown may change,
    /// so [`run_steps`] leaves a split period to [`run_period`].
    pub per_line: bool,
    /// Under `per_line`, the segment the last call of [`run_next`] removed
    /// from the queue (at most one a call): its program line and the speed
    /// it ends at (mm/s, [`end_speed_mm_s`]).
    pub removed: Option<(u64, f64)>,
}

/// The speed (mm/s) at which a segment being removed ends: 0 where it was
/// planned to end at rest (its final speed 0: a stop, the program's end;
/// its last period still moves at a fraction of a mm/s), else its speed in
/// its last period, which the next segment takes over.
fn end_speed_mm_s(s: &Seg) -> f64 {
    if s.finalvel <= VEL_EPSILON {
        0.0
    } else {
        s.currentvel
    }
}

/// Removes the front segment of `q`, noting its line and end speed in
/// `ex.removed` when periods are counted per line.
fn remove_front(q: &mut VecDeque<Seg>, ex: &mut Exec) {
    if let Some(s) = q.pop_front() {
        if ex.per_line {
            ex.removed = Some((s.line, end_speed_mm_s(&s)));
        }
    }
}

/// The ways of running periods, from the one that runs most at once:
/// [`run_cruise`], [`run_steps`], [`run_period`]. Each gives bit for bit
/// what [`run_period`] gives or runs nothing, so which is tried first
/// changes only the work: after a cruise run in one step the segment
/// speeds up or slows down (the cruise is not tried again), after the
/// tight loop stopped at a period that takes a decision that period is
/// run at once, and after a period the front segment's state tells which
/// can run it ([`first_after`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
enum First {
    #[default]
    Cruise,
    Steps,
    Period,
}

/// Runs the queue's next period or periods; `false` when the queue is
/// empty (the machine is in position).
pub(crate) fn run_next(q: &mut VecDeque<Seg>, ex: &mut Exec, limits: &Limits) -> bool {
    match ex.first {
        First::Cruise => {
            run_cruise(q, ex, limits) || run_steps(q, ex, limits) || run_period(q, ex, limits)
        }
        First::Steps => run_steps(q, ex, limits) || run_period(q, ex, limits),
        First::Period => run_period(q, ex, limits),
    }
}

/// `x` within `±max` (`saturate`, tp.c): as `f64::clamp`, without its
/// check that the bounds are ordered (`max` is a speed or an
/// acceleration, never negative).
fn saturate(x: f64, max: f64) -> f64 {
    if x > max {
        max
    } else if x < -max {
        -max
    } else {
        x
    }
}

/// Requested speed within the limits (`tpGetRealTargetVel` at 100 % feed
/// override).
fn real_target_vel(s: &Seg, limits: &Limits) -> f64 {
    let max_scale = if s.is_blending {
        limits.max_feed_override.min(1.0)
    } else {
        limits.max_feed_override
    };
    s.reqvel
        .min(s.max_target_vel(max_scale))
        .min(limits.traj_max_velocity_mm_s)
}

/// End speed: zero unless the segment runs through at speed into the next
/// (`tpGetRealFinalVel`), with the segment's [`real_target_vel`] given
/// (computed once per period).
fn final_vel_at(s: &Seg, target_vel: f64, next: Option<&Seg>, limits: &Limits) -> f64 {
    if s.term != Term::Tangent {
        return 0.0;
    }
    let next_vel = next.map_or(0.0, |n| real_target_vel(n, limits));
    s.finalvel.min(target_vel).min(next_vel)
}

/// `tpCalculateTrapezoidalAccel`: (acceleration, desired speed), with the
/// segment's requested and end speeds and acceleration given.
fn trapezoidal(s: &Seg, target_vel: f64, finalvel: f64, a: f64) -> (f64, f64) {
    let dx = s.target - s.progress;
    let dt = s.cycle_time;
    let half = a * dt * 0.5;
    let disc = finalvel * finalvel + a * (2.0 * dx - s.currentvel * dt) + half * half;
    let mut maxnewvel = -half;
    if disc > half * half {
        maxnewvel += disc.sqrt();
    }
    let newvel = saturate(maxnewvel, target_vel);
    let acc = saturate((newvel - s.currentvel) / dt.max(TIME_EPSILON), a);
    (acc, maxnewvel)
}

/// `tpCalculateRampAccel`: a constant rate to the end speed `vel_final`
/// (at least `VEL_EPSILON`: below it the trapezoid is used), for short
/// segments run through at speed.
fn ramp(s: &Seg, vel_final: f64, a: f64) -> (f64, f64) {
    let dx = s.target - s.progress;
    let vel_avg = (s.currentvel + vel_final) / 2.0;
    let mut dt = 1e-16;
    if vel_avg > VEL_EPSILON {
        dt = (dx / vel_avg).max(1e-16);
    }
    let acc = saturate((vel_final - s.currentvel) / dt, a);
    (acc, vel_final)
}

/// `tcUpdateDistFromAccel`.
fn advance(s: &mut Seg, acc: f64, vel_desired: f64) {
    let dt = s.cycle_time;
    let mut v_next = s.currentvel + acc * dt;
    if v_next < 0.0 {
        v_next = 0.0;
        if s.target - s.progress < s.currentvel * dt {
            s.progress = s.target;
        }
    } else {
        s.progress += (v_next + s.currentvel) * 0.5 * dt;
        if s.progress < 0.0 {
            s.progress = 0.0;
        } else if s.progress > s.target {
            s.progress = s.target;
        }
    }
    s.currentvel = v_next;
    s.on_final_decel = (vel_desired - s.currentvel).abs() < VEL_EPSILON && acc < 0.0;
}

fn set_split(s: &mut Seg, split_time: f64, v_f: f64) {
    s.splitting = true;
    s.cycle_time = split_time;
    s.term_vel = v_f;
}

/// `tpCheckEndCondition`: whether the segment ends within the next period
/// and how long into it (`final_vel` and `a_max` the segment's end speed
/// and acceleration).
fn check_end(s: &mut Seg, final_vel: f64, a_max: f64, period: f64) {
    s.cycle_time = period;
    let dx = s.target - s.progress;
    if dx <= POS_EPSILON {
        s.progress = s.target;
        set_split(s, 0.0, s.currentvel);
        if matches!(s.term, Term::Stop | Term::Exact) {
            s.remove = true;
        }
        return;
    }
    if matches!(s.term, Term::Stop | Term::Exact) {
        return;
    }
    let mut v_f = final_vel;
    let v_avg = (s.currentvel + v_f) / 2.0;
    let mut dt = TIME_EPSILON / 2.0;
    if v_avg > VEL_EPSILON {
        dt = dt.max(dx / v_avg);
    } else if dx > v_avg * period && dx > POS_EPSILON {
        return;
    }
    let a_f = (v_f - s.currentvel) / dt;
    if a_f.abs() > a_max {
        let a = saturate(a_f, a_max);
        let v = s.currentvel;
        let disc = (v / a).powi(2) + 2.0 / a * dx;
        if disc < 0.0 {
            return;
        }
        dt = if disc < TIME_EPSILON * TIME_EPSILON {
            -v / a
        } else if a > 0.0 {
            -v / a + disc.sqrt()
        } else {
            -v / a - disc.sqrt()
        };
        v_f = v + dt * a;
    }
    if dt < TIME_EPSILON {
        s.progress = s.target;
        set_split(s, 0.0, v_f);
    } else if dt < period {
        set_split(s, dt, v_f);
    }
}

/// `tpUpdateCycle`: one period (or the rest of one) of a segment. The
/// requested speed, the end speed and the acceleration, which every step
/// of it reads and none changes, are computed once; gives the requested
/// speed.
fn update(s: &mut Seg, next: Option<&Seg>, limits: &Limits) -> f64 {
    let target_vel = real_target_vel(s, limits);
    let final_vel = final_vel_at(s, target_vel, next, limits);
    let a = s.tangential_max_accel();
    update_with(s, target_vel, final_vel, a, limits);
    target_vel
}

/// [`update`] with the segment's requested speed, end speed and
/// acceleration given (none of which a period changes).
fn update_with(s: &mut Seg, target_vel: f64, final_vel: f64, a: f64, limits: &Limits) {
    if !s.blending_next {
        s.vel_at_blend_start = s.currentvel;
    }
    // `tpCalculateRampAccel` fails below `VEL_EPSILON`: the trapezoid then.
    let (acc, vel_desired) = if s.ramp && s.term == Term::Tangent && final_vel >= VEL_EPSILON {
        ramp(s, final_vel, a)
    } else {
        trapezoidal(s, target_vel, final_vel, a)
    };
    advance(s, acc, vel_desired);
    check_end(s, final_vel, a, limits.servo_period_s);
}

/// `tpActivateSegment`: a segment becomes the active one.
fn activate(s: &mut Seg, limits: &Limits, shown: &mut Option<Shown>) {
    let cutoff = 1.0 / limits.blend.ramp_frequency_hz.max(TIME_EPSILON);
    let length = s.target - s.progress;
    let reach = s.finalvel.min(real_target_vel(s, limits));
    let segment_time = 2.0 * length / (s.currentvel + reach);
    if segment_time < cutoff
        && s.canon != Canon::Traverse
        && s.term == Term::Tangent
        && length != 0.0
    {
        s.ramp = true;
    }
    s.active = true;
    *shown = s.shown();
    s.blending_next = false;
    s.on_final_decel = false;
}

/// Runs one servo period; `false` when the queue is empty (the machine is
/// in position).
pub(crate) fn run_period(q: &mut VecDeque<Seg>, ex: &mut Exec, limits: &Limits) -> bool {
    if q.is_empty() {
        ex.shown = None;
        return false;
    }
    // The three front segments, without making the ring contiguous (a
    // copy of the queue whenever it wraps).
    let mut front = q.iter_mut();
    let tc = front.next().expect("a segment");
    if !tc.active {
        activate(tc, limits, &mut ex.shown);
    }
    let mut next = front.next();
    let after = front.next();
    tc.is_blending = false;
    if let Some(n) = next.as_deref_mut() {
        n.is_blending = false;
    }
    if tc.splitting {
        split_period(tc, next, after.as_deref(), limits, &mut ex.shown);
    } else {
        regular_period(tc, next, limits, &mut ex.shown);
    }
    if q[0].remove {
        remove_front(q, ex);
    }
    count_period(ex);
    ex.first = first_after(q);
    true
}

/// Runs, in one step, the periods in which the front segment cruises:
/// its speed a fixed point of the trapezoid (the requested speed reached,
/// the end far enough that `v'` stays above it), no blend, no split, no
/// ramp. Each such period of [`run_period`] only adds the same step to the
/// progress and counts itself; this adds the step the same way, period by
/// period, so the progress is bit for bit what stepping gives, and stops
/// a safe margin before the first period in which the segment would start
/// to slow down or end. `false` (no period run) when the segment is not
/// cruising, or cruises for fewer than two periods.
pub(crate) fn run_cruise(q: &mut VecDeque<Seg>, ex: &mut Exec, limits: &Limits) -> bool {
    let period = limits.servo_period_s;
    let cruising = |tc: &Seg| {
        let ramping = tc.ramp && tc.term == Term::Tangent;
        let settled = tc.active && tc.cycle_time == period;
        settled && !(tc.splitting || tc.remove || tc.blending_next || ramping)
    };
    if !q.front().is_some_and(cruising) {
        return false;
    }
    // Every period starts by clearing the blending flags of the two front
    // segments (of an active segment: changing nothing before
    // `run_period` would); the speeds below are those it then computes.
    for s in q.iter_mut().take(2) {
        s.is_blending = false;
    }
    let Some(periods) = cruise_periods(&q[0], q.get(1), limits) else {
        return false;
    };
    let tc = q.front_mut().expect("a segment");
    cruise(tc, periods, period);
    ex.shown = tc.shown();
    ex.first = First::Steps;
    ex.periods.moving += periods;
    match tc.canon {
        Canon::Feed | Canon::Arc => ex.periods.cutting += periods,
        Canon::Traverse => ex.periods.rapid += periods,
    }
    true
}

/// The `periods` cruise periods of `tc` (see [`cruise_periods`]):
/// `advance` with `v_next == v`, as many times (the clamp to the target
/// never acts: the cruise stops short of it).
fn cruise(tc: &mut Seg, periods: u64, period: f64) {
    let v = tc.currentvel;
    let step = (v + v) * 0.5 * period;
    tc.progress = add_repeated(tc.progress, step, periods);
    tc.vel_at_blend_start = v;
    tc.on_final_decel = false;
}

/// `x` after `n` floating-point additions of `step` (`x += step`, `n`
/// times), bit for bit, without making them one by one. While the sum
/// stays within one binade `[2^e, 2^(e+1))` every addition rounds to the
/// same grid (multiples of `ulp(x)`), so each adds the same increment
/// `fl(x + step) − x` (exact, by Sterbenz's lemma) unless `step` falls
/// exactly half-way between two grid points (then round-half-even
/// alternates: those additions are made one by one). The increments up to
/// the binade's end are added at once (`x + m·inc`: a multiple of the grid
/// within the binade, so exact), the crossing one by one. Non-negative
/// `x` and `step` only (the progress along a segment).
fn add_repeated(mut x: f64, step: f64, mut n: u64) -> f64 {
    debug_assert!(x >= 0.0 && step >= 0.0);
    if n <= FEW_ADDITIONS {
        // A short cruise (a raster's half-millimetre moves: about twenty
        // periods, a CAM program's third of a millimetre: about 65): the
        // additions themselves cost less than the binade bookkeeping
        // below.
        for _ in 0..n {
            x += step;
        }
        return x;
    }
    // A tie (`step` half-way between two grid points of `x`'s binade:
    // an odd multiple of half its spacing) is a step whose lowest set bit
    // is worth half the spacing: that bit's exponent, found once.
    let tie_binade = lowest_bit_exponent(step).map(|e| e + 1);
    while n > 0 {
        let next = x + step;
        n -= 1;
        let inc = next - x;
        let binade = exponent_field(x);
        x = next;
        // Zero and subnormal sums (no fixed spacing), the last addition, a
        // sum that left its binade: one by one.
        if n == 0 || inc <= 0.0 || !(1..0x7ff).contains(&binade) || exponent_field(next) != binade {
            continue;
        }
        // The spacing of binade `b` is `2^(b − 1075)`.
        if tie_binade == Some(binade as i32 - 1075) {
            continue;
        }
        // Additions whose exact sum stays below the binade's end (with a
        // margin of one for the rounded quotient): `x + step < end` for
        // each while `x + m·inc < end − inc`, as `step < inc + ulp`. The
        // quotient is not negative: its conversion is its floor.
        let end = 2.0 * binade_start(next);
        let room = (((end - next) / inc) as u64).saturating_sub(2);
        if room >= 1 {
            let m = room.min(n);
            x = next + m as f64 * inc;
            n -= m;
        }
        // The few additions left in the binade (about three): one by
        // one, without another quotient.
        while n > 0 && exponent_field(x) == binade {
            x += step;
            n -= 1;
        }
    }
    x
}

/// The biased exponent of a non-negative float (0 for zero and
/// subnormal numbers).
fn exponent_field(x: f64) -> u64 {
    x.to_bits() >> 52
}

/// The exponent of the lowest set bit of positive finite `x`
/// (`x = m·2^e` with `m` odd); `None` for zero.
fn lowest_bit_exponent(x: f64) -> Option<i32> {
    let bits = x.to_bits();
    let (field, fraction) = (bits >> 52, bits & ((1 << 52) - 1));
    let (mantissa, scale) = match field {
        0 => (fraction, -1074),
        f => (fraction | (1 << 52), f as i32 - 1075),
    };
    (mantissa != 0).then(|| scale + mantissa.trailing_zeros() as i32)
}

/// Up to this many additions [`add_repeated`] makes one by one: the loop
/// costs about 1.25 instructions an addition (unrolled by eight), a binade
/// of the way below about 70, and a cruise from near the segment's start
/// crosses about `log2(n)` binades, so one by one costs fewer instructions
/// up to about 500 additions (a 0.33 mm CAM move at 5 mm/s cruises for
/// about 65 periods).
const FEW_ADDITIONS: u64 = 512;

/// The spacing of the floating-point numbers at positive normal `x` (0
/// for zero and subnormal numbers: those are added one by one).
fn grid(x: f64) -> f64 {
    if x < f64::MIN_POSITIVE || !x.is_finite() {
        return 0.0;
    }
    binade_start(x) * f64::EPSILON
}

/// The power of two at or below positive normal `x`.
fn binade_start(x: f64) -> f64 {
    f64::from_bits(x.to_bits() & 0xfff0_0000_0000_0000)
}

/// The number of periods `tc` cruises at its present speed before the
/// trapezoid would change it or the segment would end within a period;
/// `None` when it is not cruising or for fewer than two periods.
///
/// Every cruise period must leave the stepped one nothing to decide:
/// before it, `v' ≥ w`, where `w` is the requested speed and the present
/// speed plus a margin that keeps `on_final_decel` false (`v'` more than
/// `VEL_EPSILON` above `v`), i.e. `dx ≥ dx_min`, the square of
/// `tpCalculateTrapezoidalAccel`'s root solved for `dx`; after it, at
/// least `v·Δt` left, so that `tpCheckEndCondition` finds no end within
/// the next period (its end time `dx/v̄` with `v̄ ≤ v`, or the smaller root
/// of `A/2·t² − v·t + dx = 0`, both at least `dx/v`). The progress after
/// `k` periods is bounded from `x + k·step` by the rounding of `k`
/// additions (half a grid step of the target each) plus a relative
/// margin for the few operations of each test.
fn cruise_periods(tc: &Seg, next: Option<&Seg>, limits: &Limits) -> Option<u64> {
    let target_vel = real_target_vel(tc, limits);
    let a = tc.tangential_max_accel();
    let vf = final_vel_at(tc, target_vel, next, limits);
    cruise_periods_with(tc, target_vel, vf, a)
}

/// [`cruise_periods`] with the segment's requested speed, end speed and
/// acceleration given.
fn cruise_periods_with(tc: &Seg, target_vel: f64, vf: f64, a: f64) -> Option<u64> {
    let dt = tc.cycle_time;
    let v = tc.currentvel;
    // With `v' ≥ target_vel` the trapezoid asks for `target_vel`: a fixed
    // point when the acceleration that follows leaves `v` as it is.
    let acc = saturate((target_vel - v) / dt.max(TIME_EPSILON), a);
    if !(v > VEL_EPSILON && a > 0.0) || v + acc * dt != v {
        return None;
    }
    let half = a * dt * 0.5;
    let w = target_vel.max(v) + 4.0 * VEL_EPSILON;
    let dx_min = ((w + half).powi(2) - half * half - vf * vf + a * v * dt) / (2.0 * a);
    let step = (v + v) * 0.5 * dt;
    let dx_end = v * dt * (1.0 + 1e-9);
    let left = tc.target - tc.progress;
    if !(left > 0.0 && step > 0.0) {
        return None;
    }
    // Rounding of the additions (at most `left/step + 2` of them), of
    // the subtraction `target − progress` and of the tests themselves.
    let additions = left / step + 2.0;
    let tol = (additions + 4.0) * grid(tc.target.abs())
        + 1e-12 * (dx_min.abs() + (w + half).powi(2) / a + tc.target.abs() + left)
        + POS_EPSILON;
    // After the last of `k` periods `dx_end` is left; before it, `dx_min`.
    let by_end = floor_or_below_zero((left - dx_end - tol) / step);
    let by_trapezoid = floor_or_below_zero((left - dx_min - tol) / step) + 1.0;
    let k = by_end.min(by_trapezoid);
    (k >= 2.0).then_some(k as u64)
}

/// What the front segment's next period gives when it takes no decision:
/// its new speed and progress and `on_final_decel`.
struct Step {
    v: f64,
    progress: f64,
    on_final_decel: bool,
}

/// The per-segment values every period of [`update`] recomputes from
/// fields the periods do not change (the requested and end speeds, the
/// acceleration): computed once, with the same operations, so the same
/// bits.
struct Hoisted {
    target: f64,
    target_vel: f64,
    final_vel: f64,
    a: f64,
    dt: f64,
    half: f64,
    /// `tpCalculateRampAccel` instead of the trapezoid.
    ramping: bool,
    /// `tpCheckEndCondition` never splits a segment that ends at rest.
    stops: bool,
    /// The parabolic blend's speed (`tpComputeBlendVelocity`) when the
    /// segment ends in one.
    blend_vel: Option<f64>,
}

impl Hoisted {
    fn new(tc: &Seg, next: Option<&Seg>, limits: &Limits) -> Hoisted {
        let a = tc.tangential_max_accel();
        let dt = tc.cycle_time;
        let target_vel = real_target_vel(tc, limits);
        let final_vel = final_vel_at(tc, target_vel, next, limits);
        // `tpCalculateRampAccel` fails below this end speed.
        let too_slow = final_vel < VEL_EPSILON;
        let blend_vel = (tc.term == Term::Parabolic).then(|| match next {
            Some(n) => blend::parabolic_velocity(tc, n, target_vel, real_target_vel(n, limits)).0,
            None => 0.0,
        });
        Hoisted {
            target: tc.target,
            target_vel,
            final_vel,
            a,
            dt,
            half: a * dt * 0.5,
            ramping: tc.ramp && tc.term == Term::Tangent && !too_slow,
            stops: matches!(tc.term, Term::Stop | Term::Exact),
            blend_vel,
        }
    }

    /// The period [`update`] runs from speed `v` at `progress`, or `None`
    /// when it takes a decision: the speed would fall below zero, the
    /// progress reach the target, the segment end within the next period
    /// (or may: a sufficient bound, see below), a parabolic blend start.
    /// The operations are those of `tpCalculateTrapezoidalAccel` /
    /// `tpCalculateRampAccel` and `tcUpdateDistFromAccel`, in their order.
    fn step(&self, v: f64, progress: f64) -> Option<Step> {
        let dx = self.target - progress;
        let dt = self.dt;
        let (acc, vel_desired) = if self.ramping {
            let vel_avg = (v + self.final_vel) / 2.0;
            let mut t = 1e-16;
            if vel_avg > VEL_EPSILON {
                t = (dx / vel_avg).max(1e-16);
            }
            (saturate((self.final_vel - v) / t, self.a), self.final_vel)
        } else {
            let half = self.half;
            let disc = self.final_vel * self.final_vel + self.a * (2.0 * dx - v * dt) + half * half;
            let mut maxnewvel = -half;
            if disc > half * half {
                maxnewvel += disc.sqrt();
            }
            let newvel = saturate(maxnewvel, self.target_vel);
            let acc = saturate((newvel - v) / dt.max(TIME_EPSILON), self.a);
            (acc, maxnewvel)
        };
        let v_next = v + acc * dt;
        if v_next < 0.0 {
            return None;
        }
        let progress = progress + (v_next + v) * 0.5 * dt;
        if !(0.0..=self.target).contains(&progress) {
            return None;
        }
        let on_final_decel = (vel_desired - v_next).abs() < VEL_EPSILON && acc < 0.0;
        // `tpCheckEndCondition` after the step: it ends the segment when
        // no more than `POS_EPSILON` is left; a segment that ends at
        // speed it splits when the time to its end, `dx/v̄` (`v̄` the mean
        // of the present and the end speed) or the root of
        // `A/2·t² + v·t = dx` (`|A|` the acceleration limit), is below a
        // period. Either time is below a period only if less than
        // `(max(v, v_f) + |A|·Δt)·Δt` is left (`dx/v̄ < Δt` needs
        // `dx < v̄·Δt`; the root, `dx < v·Δt + |A|·Δt²/2`), so with more
        // left than that (a relative margin for the roundings) it does
        // not split; closer to its end the period is left to
        // `run_period`.
        let left = self.target - progress;
        if left <= POS_EPSILON {
            return None;
        }
        if !self.stops {
            let reach = (v_next.max(self.final_vel) + self.a * dt) * dt;
            let far = left >= reach * (1.0 + 1e-9) + POS_EPSILON;
            if !far {
                return None;
            }
        }
        if let Some(blend_vel) = self.blend_vel {
            if on_final_decel && v_next < blend_vel {
                return None;
            }
        }
        Some(Step {
            v: v_next,
            progress,
            on_final_decel,
        })
    }

    /// The periods of a ramp already at its end speed (`ramping`, `v ==
    /// final_vel`), run as [`Hoisted::step`] runs them, up to the first
    /// that takes a decision (not run): `tpCalculateRampAccel` asks for
    /// `(v_f − v)/t = 0`, so the speed stays `v`, `on_final_decel` false,
    /// and each period adds the same step `(v + v)·½·Δt` to the progress
    /// (the expression `tcUpdateDistFromAccel` evaluates) and tests what
    /// [`Hoisted::step`] tests after it, with the same values: the
    /// progress within `[0, target]`, more than `POS_EPSILON` left, and
    /// left at least the same `reach` margin (a ramp ends at speed, never
    /// at rest, and never in a parabolic blend). Gives the periods run
    /// and the progress after them.
    fn flat_ramp(&self, v: f64, mut progress: f64) -> (u64, f64) {
        debug_assert!(self.ramping && v == self.final_vel);
        let dt = self.dt;
        let step = (v + v) * 0.5 * dt;
        let reach = (v.max(self.final_vel) + self.a * dt) * dt;
        let need = reach * (1.0 + 1e-9) + POS_EPSILON;
        let mut k = 0;
        loop {
            let next = progress + step;
            if !(0.0..=self.target).contains(&next) {
                break;
            }
            let left = self.target - next;
            let far = left >= need;
            if left <= POS_EPSILON || !far {
                break;
            }
            progress = next;
            k += 1;
        }
        #[cfg(test)]
        FLAT_RAMP_PERIODS.with(|n| n.set(n.get() + k));
        (k, progress)
    }
}

#[cfg(test)]
thread_local! {
    /// Periods [`Hoisted::flat_ramp`] ran, for the test that compares them
    /// with stepping.
    pub(crate) static FLAT_RAMP_PERIODS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// Runs, one after the other in a tight loop, the regular periods of the
/// front segment that take no decision (see [`Hoisted::step`]): the
/// speeding up, the slowing down, the ramps and the cruise periods
/// [`run_cruise`] leaves to stepping, each with the operations of
/// [`run_period`] on the same values, so bit for bit what it gives. A
/// segment not yet active is activated first, as [`run_period`] does at
/// the start of its first period (and the first period after it is
/// counted as a change of speed). A cruise that follows a change of
/// speed runs in one step as [`run_cruise`] runs it, and the stepping
/// goes on after it. Runs the first period that takes a decision as
/// [`run_period`]'s regular period (`tpHandleRegularCycle`) with the
/// values computed once, and stops after it; a segment ending in a
/// parabolic blend leaves that period to [`run_period`] (it may show the
/// next segment, to which the periods of one call are counted per line).
/// `false` when no period was run.
pub(crate) fn run_steps(q: &mut VecDeque<Seg>, ex: &mut Exec, limits: &Limits) -> bool {
    let period = limits.servo_period_s;
    let Some(front) = q.front() else {
        return false;
    };
    if front.splitting || front.remove || front.blending_next {
        return false;
    }
    let fresh = !front.active;
    if !fresh && front.cycle_time != period {
        return false;
    }
    let mut front = q.iter_mut();
    let tc = front.next().expect("a segment");
    // What every period does first (see `run_period`): activation with
    // the blending flags as they are, then the flags cleared.
    if fresh {
        activate(tc, limits, &mut ex.shown);
    }
    let mut next = front.next();
    tc.is_blending = false;
    if let Some(n) = next.as_deref_mut() {
        n.is_blending = false;
    }
    // `tpHandleRegularCycle` runs the period with the whole servo period.
    tc.cycle_time = period;
    let h = Hoisted::new(tc, next.as_deref(), limits);
    let (mut v, mut progress) = (tc.currentvel, tc.progress);
    let mut on_final_decel = tc.on_final_decel;
    let mut vel_at_blend_start = tc.vel_at_blend_start;
    let mut n = 0u64;
    let mut changing = fresh;
    // `run_cruise`'s test of the segment's state (the others hold here).
    let may_cruise = !(tc.ramp && tc.term == Term::Tangent);
    // A segment activated at its cruising speed (a CAM move entered at
    // speed from a blend arc) cruises from its first period: that cruise
    // runs at once, as `run_cruise` runs it (the segment is active, at the
    // whole servo period, neither splitting nor removed nor blending, no
    // ramp), instead of after a first period stepped to see that the speed
    // stays. Not cruising, it costs the first test of `cruise_periods_with`.
    if fresh && may_cruise {
        if let Some(k) = cruise_periods_with(tc, h.target_vel, h.final_vel, h.a) {
            cruise(tc, k, period);
            (progress, vel_at_blend_start, on_final_decel) = (tc.progress, v, false);
            n += k;
            changing = false;
        }
    }
    loop {
        // Whether the steps stopped at a cruise that follows a change of
        // speed (else at a period that takes a decision).
        let mut cruising = false;
        loop {
            if h.ramping && v == h.final_vel {
                // A ramp at its end speed: the rest of its periods that
                // take no decision, without the ramp's two divisions.
                let (k, p) = h.flat_ramp(v, progress);
                if k > 0 {
                    vel_at_blend_start = v;
                    (progress, on_final_decel) = (p, false);
                    n += k;
                    // What the periods' cruise test below leaves (a ramp
                    // does not cruise in one step).
                    changing = false;
                }
            }
            let Some(s) = h.step(v, progress) else {
                break;
            };
            let cruise = s.v == v;
            vel_at_blend_start = v;
            (v, progress, on_final_decel) = (s.v, s.progress, s.on_final_decel);
            n += 1;
            if cruise && changing {
                cruising = true;
                break;
            }
            changing |= !cruise;
        }
        if !cruising {
            break;
        }
        // The cruise as `run_cruise` runs it, then the periods after it
        // as a new call of this function (nothing they read has changed).
        if may_cruise {
            (tc.currentvel, tc.progress) = (v, progress);
            if let Some(k) = cruise_periods_with(tc, h.target_vel, h.final_vel, h.a) {
                cruise(tc, k, period);
                (progress, vel_at_blend_start, on_final_decel) = (tc.progress, v, false);
                n += k;
            }
        }
        changing = false;
    }
    let deciding_here = h.blend_vel.is_none();
    if n == 0 && !deciding_here {
        return false;
    }
    tc.currentvel = v;
    tc.progress = progress;
    tc.on_final_decel = on_final_decel;
    tc.vel_at_blend_start = vel_at_blend_start;
    if let Some(b) = h.blend_vel {
        tc.blend_vel = b;
    }
    ex.shown = tc.shown();
    ex.periods.moving += n;
    match tc.canon {
        Canon::Feed | Canon::Arc => ex.periods.cutting += n,
        Canon::Traverse => ex.periods.rapid += n,
    }
    if !deciding_here {
        ex.first = First::Period;
        return true;
    }
    // The period that takes a decision: `run_period`'s regular period
    // (the segment neither splits nor is removed nor blends yet, and it
    // does not end in a parabolic blend, so it shows itself).
    update_with(tc, h.target_vel, h.final_vel, h.a, limits);
    blend_or_show(tc, next.as_deref_mut(), limits, &mut ex.shown);
    count_period(ex);
    // A segment that now ends within the next period (at speed: one that
    // stops is removed instead) runs that period here as `run_period`
    // runs it (`tpHandleSplitCycle`: the segment is active, the two front
    // segments' blending flags are cleared first), unless the periods
    // are counted per line (the split period may show the next segment).
    if tc.splitting && !tc.remove && !ex.per_line {
        let after = front.next();
        tc.is_blending = false;
        if let Some(n) = next.as_deref_mut() {
            n.is_blending = false;
        }
        split_period(tc, next, after.as_deref(), limits, &mut ex.shown);
        count_period(ex);
    }
    if q[0].remove {
        remove_front(q, ex);
    }
    ex.first = first_after(q);
    true
}

/// Counts one period of [`run_period`] by the segment shown as active.
fn count_period(ex: &mut Exec) {
    ex.periods.moving += 1;
    match ex.shown.map(|s| s.canon) {
        Some(Canon::Feed | Canon::Arc) => ex.periods.cutting += 1,
        Some(Canon::Traverse) => ex.periods.rapid += 1,
        None => {}
    }
}

/// Which way of running the next period to try first after a period
/// that may have changed the front segment's state: [`run_period`] for
/// a segment that ends within the period, is removed or blends
/// (neither [`run_cruise`] nor [`run_steps`] runs those), [`run_steps`]
/// for one not yet active ([`run_cruise`] runs only active ones),
/// [`run_cruise`] else.
fn first_after(q: &VecDeque<Seg>) -> First {
    match q.front() {
        Some(f) if f.splitting || f.remove || f.blending_next => First::Period,
        Some(f) if !f.active => First::Steps,
        _ => First::Cruise,
    }
}

/// `⌊x⌋` for `x ≥ 0`, and −1 for any other `x` (NaN included): through
/// integers, as `floor` is a library call on the baseline x86-64 target.
/// Only a count of at least two periods matters to [`cruise_periods`].
fn floor_or_below_zero(x: f64) -> f64 {
    if x >= 0.0 {
        x as u64 as f64
    } else {
        -1.0
    }
}

/// `tpHandleRegularCycle`.
fn regular_period(
    tc: &mut Seg,
    next: Option<&mut Seg>,
    limits: &Limits,
    shown: &mut Option<Shown>,
) {
    if tc.remove {
        return;
    }
    tc.cycle_time = limits.servo_period_s;
    let target_vel = update(tc, next.as_deref(), limits);
    if tc.term == Term::Parabolic {
        tc.blend_vel = match next.as_deref() {
            Some(n) => blend::parabolic_velocity(tc, n, target_vel, real_target_vel(n, limits)).0,
            None => 0.0,
        };
    }
    blend_or_show(tc, next, limits, shown);
}

/// The end of `tpHandleRegularCycle` after the segment's update: a
/// parabolic blend starts or goes on (the next segment runs too), and the
/// segment shown as active.
fn blend_or_show(tc: &mut Seg, next: Option<&mut Seg>, limits: &Limits, shown: &mut Option<Shown>) {
    let blending = {
        let starts =
            tc.term == Term::Parabolic && tc.on_final_decel && tc.currentvel < tc.blend_vel;
        tc.blending_next |= starts;
        tc.blending_next
    };
    match next {
        Some(next) if blending => {
            // `tpDoParabolicBlending`: the next segment starts while this
            // one slows down.
            next.is_blending = true;
            update(next, None, limits);
            *shown = if tc.currentvel > next.currentvel {
                tc.shown()
            } else {
                next.shown()
            };
        }
        _ => *shown = tc.shown(),
    }
}

/// `tpHandleSplitCycle`: the segment ends within this period; the next
/// one runs for the rest of it.
fn split_period(
    tc: &mut Seg,
    next: Option<&mut Seg>,
    after: Option<&Seg>,
    limits: &Limits,
    shown: &mut Option<Shown>,
) {
    if tc.remove {
        return;
    }
    tc.progress = tc.target;
    tc.remove = true;
    let Some(next) = next else {
        return;
    };
    if tc.term == Term::Tangent {
        next.cycle_time = limits.servo_period_s - tc.cycle_time;
        next.currentvel = tc.term_vel;
    }
    update(next, after, limits);
    *shown = if tc.cycle_time > next.cycle_time && tc.term == Term::Tangent {
        tc.shown()
    } else {
        next.shown()
    };
}

#[cfg(test)]
mod tests {
    use super::add_repeated;

    fn one_by_one(mut x: f64, step: f64, n: u64) -> f64 {
        for _ in 0..n {
            x += step;
        }
        x
    }

    #[test]
    fn repeated_additions_are_bit_for_bit_those_made_one_by_one() {
        // A small linear congruential generator: progress and speeds of
        // every magnitude a segment meets, steps that tie with the grid.
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut unit = || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut cases = vec![
            (0.0, 0.005, 20_000),
            (0.0, 0.1, 1_000),
            (0.0, 0.5 * f64::EPSILON, 10),
            (1.0, 0.5 * f64::EPSILON, 1_000),
            (1.0, 1.5 * f64::EPSILON, 1_000),
            (3.0, 0.75, 100),
            (0.0, 1e-300, 100),
        ];
        for _ in 0..2_000 {
            let x = if unit() < 0.2 {
                0.0
            } else {
                10f64.powf(unit() * 6.0 - 3.0)
            };
            let step = 10f64.powf(unit() * 6.0 - 5.0);
            let n = (unit() * 30_000.0) as u64;
            cases.push((x, step, n));
        }
        // Ties: an odd multiple of half the spacing at `x` (or at the
        // binades above it), where round-half-even alternates.
        for _ in 0..1_000 {
            let x = 10f64.powf(unit() * 4.0 - 2.0);
            let half = super::grid(x) / 2.0 * (1u64 << (unit() * 4.0) as u32) as f64;
            let odd = 2.0 * ((unit() * 1e9) as u64) as f64 + 1.0;
            cases.push((
                x,
                odd * half,
                super::FEW_ADDITIONS + 1 + (unit() * 50_000.0) as u64,
            ));
        }
        for (x, step, n) in cases {
            let want = one_by_one(x, step, n);
            let got = add_repeated(x, step, n);
            assert_eq!(
                got.to_bits(),
                want.to_bits(),
                "{x:e} + {n} × {step:e}: {got:e}, one by one {want:e}"
            );
        }
    }
}
