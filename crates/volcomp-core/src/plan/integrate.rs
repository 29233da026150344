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

/// The state the motion controller keeps between periods.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Exec {
    pub periods: Periods,
    /// The motion type shown (`tp->motionType`).
    shown: Option<Canon>,
}

fn saturate(x: f64, max: f64) -> f64 {
    x.clamp(-max, max)
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
/// (`tpGetRealFinalVel`).
fn real_final_vel(s: &Seg, next: Option<&Seg>, limits: &Limits) -> f64 {
    if s.term != Term::Tangent {
        return 0.0;
    }
    let next_vel = next.map_or(0.0, |n| real_target_vel(n, limits));
    s.finalvel.min(real_target_vel(s, limits)).min(next_vel)
}

/// `tpCalculateTrapezoidalAccel`: (acceleration, desired speed).
fn trapezoidal(s: &Seg, next: Option<&Seg>, limits: &Limits) -> (f64, f64) {
    let target_vel = real_target_vel(s, limits);
    let finalvel = real_final_vel(s, next, limits);
    let dx = s.target - s.progress;
    let a = s.tangential_max_accel();
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

/// `tpCalculateRampAccel`: a constant rate to the end speed, for short
/// segments run through at speed.
fn ramp(s: &mut Seg, next: Option<&Seg>, limits: &Limits) -> Option<(f64, f64)> {
    let dx = s.target - s.progress;
    if !s.blending_next {
        s.vel_at_blend_start = s.currentvel;
    }
    let vel_final = real_final_vel(s, next, limits);
    if vel_final < VEL_EPSILON {
        return None;
    }
    let vel_avg = (s.currentvel + vel_final) / 2.0;
    let mut dt = 1e-16;
    if vel_avg > VEL_EPSILON {
        dt = (dx / vel_avg).max(1e-16);
    }
    let acc = saturate((vel_final - s.currentvel) / dt, s.tangential_max_accel());
    Some((acc, vel_final))
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
        s.progress = s.progress.clamp(0.0, s.target);
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
/// and how long into it.
fn check_end(s: &mut Seg, next: Option<&Seg>, limits: &Limits) {
    let period = limits.servo_period_s;
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
    let mut v_f = real_final_vel(s, next, limits);
    let v_avg = (s.currentvel + v_f) / 2.0;
    let mut dt = TIME_EPSILON / 2.0;
    if v_avg > VEL_EPSILON {
        dt = dt.max(dx / v_avg);
    } else if dx > v_avg * period && dx > POS_EPSILON {
        return;
    }
    let a_f = (v_f - s.currentvel) / dt;
    let a_max = s.tangential_max_accel();
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

/// `tpUpdateCycle`: one period (or the rest of one) of a segment.
fn update(s: &mut Seg, next: Option<&Seg>, limits: &Limits) {
    if !s.blending_next {
        s.vel_at_blend_start = s.currentvel;
    }
    let mut step = None;
    if s.ramp && s.term == Term::Tangent {
        step = ramp(s, next, limits);
    }
    let (acc, vel_desired) = step.unwrap_or_else(|| trapezoidal(s, next, limits));
    advance(s, acc, vel_desired);
    check_end(s, next, limits);
}

/// `tpActivateSegment`: a segment becomes the active one.
fn activate(s: &mut Seg, limits: &Limits, shown: &mut Option<Canon>) {
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
    *shown = Some(s.canon);
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
    let s = q.make_contiguous();
    if !s[0].active {
        activate(&mut s[0], limits, &mut ex.shown);
    }
    for seg in s.iter_mut().take(2) {
        seg.is_blending = false;
    }
    let (tc, rest) = s.split_first_mut().expect("a segment");
    if tc.splitting {
        split_period(tc, rest, limits, &mut ex.shown);
    } else {
        regular_period(tc, rest, limits, &mut ex.shown);
    }
    if q[0].remove {
        q.pop_front();
    }
    ex.periods.moving += 1;
    match ex.shown {
        Some(Canon::Feed | Canon::Arc) => ex.periods.cutting += 1,
        Some(Canon::Traverse) => ex.periods.rapid += 1,
        None => {}
    }
    true
}

/// `tpHandleRegularCycle`.
fn regular_period(tc: &mut Seg, rest: &mut [Seg], limits: &Limits, shown: &mut Option<Canon>) {
    if tc.remove {
        return;
    }
    tc.cycle_time = limits.servo_period_s;
    update(tc, rest.first(), limits);
    if tc.term == Term::Parabolic {
        tc.blend_vel = match rest.first() {
            Some(n) => {
                blend::parabolic_velocity(
                    tc,
                    n,
                    real_target_vel(tc, limits),
                    real_target_vel(n, limits),
                )
                .0
            }
            None => 0.0,
        };
    }
    let blending = {
        let starts =
            tc.term == Term::Parabolic && tc.on_final_decel && tc.currentvel < tc.blend_vel;
        tc.blending_next |= starts;
        tc.blending_next
    };
    match rest.first_mut() {
        Some(next) if blending => {
            // `tpDoParabolicBlending`: the next segment starts while this
            // one slows down.
            next.is_blending = true;
            update(next, None, limits);
            *shown = Some(if tc.currentvel > next.currentvel {
                tc.canon
            } else {
                next.canon
            });
        }
        _ => *shown = Some(tc.canon),
    }
}

/// `tpHandleSplitCycle`: the segment ends within this period; the next
/// one runs for the rest of it.
fn split_period(tc: &mut Seg, rest: &mut [Seg], limits: &Limits, shown: &mut Option<Canon>) {
    if tc.remove {
        return;
    }
    tc.progress = tc.target;
    tc.remove = true;
    let Some((next, after)) = rest.split_first_mut() else {
        return;
    };
    if tc.term == Term::Tangent {
        next.cycle_time = limits.servo_period_s - tc.cycle_time;
        next.currentvel = tc.term_vel;
    }
    update(next, after.first(), limits);
    *shown = Some(
        if tc.cycle_time > next.cycle_time && tc.term == Term::Tangent {
            tc.canon
        } else {
            next.canon
        },
    );
}
