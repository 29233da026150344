//! The planner's queue and its look-ahead, as LinuxCNC 2.9 runs them when
//! a segment is queued (src/emc/tp/tp.c: `tpAddLine`, `tpAddCircle`,
//! `handleModeChange`, `tpHandleBlendArc`, `tpRunOptimization`,
//! `tpComputeOptimalVelocity`; [LinuxCNC tp]).
//!
//! Queuing a segment settles the joint with the one before it (a stop
//! between a rapid and a feed move; else [`super::blend`]), fixes the
//! length of that one (it may have been shortened by a blend arc), then
//! walks the queue backwards from the new end, at most
//! `ARC_BLEND_OPTIMIZATION_DEPTH` segments: each segment's end speed is
//! the largest from which the rest can still stop in time,
//! `v_end(i) = min(√(v_end(i+1)² + 2 a(i+1) L(i+1)), v_max(i), v_max(i+1),
//! kink(i))`. The newest segment's length is not final (the next one may
//! blend into it): the one before it assumes it may stop half-way. The
//! walk stops at the second joint that is not run through at speed, and
//! (LinuxCNC's lazy optimisation) once more than four segments were found
//! at their speed limit.

use super::blend::{self, Tangency};
use super::segment::{Canon, Seg, Term};
use super::Limits;
use std::collections::VecDeque;

/// Segments per servo period at least (`TP_MIN_SEGMENT_CYCLES`).
const MIN_SEGMENT_CYCLES: f64 = 1.02;
/// Peaks after which the look-ahead stops (`TP_OPTIMIZATION_CUTOFF`).
const OPTIMIZATION_CUTOFF: usize = 4;

/// Queues `tc` after the queue's last segment (settled in place, then
/// copied once into the queue).
pub(crate) fn add(
    q: &mut VecDeque<Seg>,
    tc: &mut Seg,
    limits: &Limits,
    stats: &mut super::Counts,
    planes: &mut blend::PlaneLimits,
) {
    let n = q.len();
    let mut consumed = false;
    if let Some(prev) = q.back_mut() {
        // `handleModeChange`: no blend between a rapid and a feed move.
        if (prev.canon == Canon::Traverse) != (tc.canon == Canon::Traverse) {
            blend::set_term(prev, tc, Term::Stop);
        }
        if limits.blend.enable {
            match blend::setup_tangent(prev, tc, limits) {
                Tangency::Fail => {}
                Tangency::Tangent => stats.tangent_joints += 1,
                Tangency::Corner => match blend::try_blend_arc(prev, tc, limits, planes) {
                    Some(b) => {
                        stats.blend_arcs += 1;
                        tc.shape = b.tc_shape;
                        tc.target = b.tc_target;
                        tc.blend_prev = false;
                        if b.consume {
                            q.pop_back();
                            consumed = true;
                        } else {
                            let prev = q.back_mut().expect("the previous segment");
                            prev.shape = b.prev_shape;
                            prev.target = b.prev_target;
                            blend::set_term(prev, tc, Term::Tangent);
                        }
                        q.push_back(b.arc.seg());
                    }
                    None => match blend::choose_best(prev, tc, None, limits) {
                        blend::Chosen::Parabolic => stats.parabolic_blends += 1,
                        blend::Chosen::Tangent => stats.tangent_joints += 1,
                        _ => {}
                    },
                },
            }
        }
        if !consumed {
            q[n - 1].finalize();
        }
    }
    // From the slice straight into the ring's slot: `push_back(*tc)`
    // copies the segment to the stack first (its growth check may call
    // out), then into the slot.
    q.extend(std::slice::from_ref(tc));
    optimize(q, limits);
}

/// Speed a segment that may still be cut to half reaches at most from
/// rest, within its limits (`tpCalculateOptimizationInitialVel`).
fn initial_vel(tc: &Seg, limits: &Limits) -> f64 {
    let triangle = (tc.tangential_max_accel() * tc.target).sqrt();
    triangle.min(blend::max_target_vel(tc, limits))
}

/// One step of the backward pass (`tpComputeOptimalVelocity`); whether
/// it changed a value (the bits of a speed, a flag).
fn optimal_velocity(tc: &mut Seg, prev: &mut Seg, limits: &Limits) -> bool {
    let acc_this = tc.tangential_max_accel();
    let mut vs_back = (tc.finalvel * tc.finalvel + 2.0 * acc_this * tc.target).sqrt();
    let mut vf_limit_prev = prev.maxvel;
    if prev.kink_vel >= 0.0 && prev.term == Term::Tangent {
        vf_limit_prev = vf_limit_prev.min(prev.kink_vel);
    }
    let vf_limit = tc.maxvel.min(vf_limit_prev);
    let mut changed = false;
    if vs_back >= vf_limit {
        vs_back = vf_limit;
        changed |= !prev.at_max;
        prev.at_max = true;
    }
    changed |= prev.finalvel.to_bits() != vs_back.to_bits();
    prev.finalvel = vs_back;
    let maxvel = tc
        .maxvel
        .min(tc.target / (limits.servo_period_s * MIN_SEGMENT_CYCLES));
    if maxvel.to_bits() != tc.maxvel.to_bits() {
        tc.walk_clamped = true;
        changed = true;
    }
    tc.maxvel = maxvel;
    tc.walked = true;
    changed
}

/// Whether the step of the pair `prev`, `tc` would compute what it
/// computed in an earlier pass and change nothing, given that the step
/// of the pair after it (the one that sets `tc.finalvel`) changed nothing
/// in this pass. A step reads `tc`'s end speed, length, acceleration and
/// speed limit and `prev`'s speed limit, kink speed and end condition;
/// of these, between passes only the queue's last segment changes (its
/// joint with a new one, its length trimmed by a blend arc, its
/// finalisation: it has not been `walked`), the end speeds (written by
/// the pass alone: unchanged here, the step after this one having
/// changed nothing) and the speed limits, lowered by a step's length
/// clamp (`walk_clamped`: such pairs are always computed). A pass visits
/// no pair of older segments the pass before it did not visit (it starts
/// one segment later, the peaks it counts only grow, the front only
/// moves on), so the earlier pass computed this pair with the same
/// inputs, finalised, and wrote what this one would; every pair after it
/// is the same case. Skipping such pairs leaves the queue bit for bit as
/// computing them does (tested against the full pass on random programs
/// in plan/tests.rs).
fn settled(tc: &Seg, prev: &Seg) -> bool {
    tc.walked && !tc.walk_clamped && !prev.walk_clamped
}

/// The backward pass over the queue's end (`tpRunOptimization`).
pub(crate) fn optimize(q: &mut VecDeque<Seg>, limits: &Limits) {
    let len = q.len();
    let mut hit_peaks = 0;
    let mut hit_non_tangent = false;
    // Pairs from the back, without making the ring contiguous (a copy of
    // the queue whenever it wraps).
    let mut back = q.iter_mut().rev();
    let Some(mut tc) = back.next() else {
        return;
    };
    // Whether the pair after this one (nearer the end) changed nothing.
    let mut unchanged_after = false;
    let skip = skipping_settled();
    for x in 1..limits.blend.optimization_depth + 2 {
        if x + 1 > len {
            return;
        }
        let prev = back.next().expect("a segment before");
        if prev.term != Term::Tangent {
            if hit_non_tangent {
                return;
            }
            hit_non_tangent = true;
            unchanged_after = false;
        } else {
            // A segment not begun (progress 0: the quotient is 0 or NaN,
            // never at least a quarter) skips the division.
            let quarter_run = prev.progress != 0.0 && prev.progress / prev.target >= 0.25;
            if quarter_run || prev.splitting || prev.blending_next {
                return;
            }
            if !tc.finalized {
                prev.finalvel = prev.maxvel.min(initial_vel(tc, limits));
                if prev.kink_vel >= 0.0 && prev.term == Term::Tangent {
                    prev.finalvel = prev.finalvel.min(prev.kink_vel);
                }
                tc.finalvel = 0.0;
                unchanged_after = false;
            } else if skip && unchanged_after && settled(tc, prev) {
                #[cfg(test)]
                SKIPPED.with(|n| n.set(n.get() + 1));
            } else {
                unchanged_after = !optimal_velocity(tc, prev, limits);
            }
            if tc.at_max {
                hit_peaks += 1;
            }
            if hit_peaks > OPTIMIZATION_CUTOFF {
                return;
            }
        }
        tc = prev;
    }
}

/// Whether [`optimize`] skips the pairs that are [`settled`]: always,
/// but for the test that compares the queue with and without.
#[cfg(not(test))]
fn skipping_settled() -> bool {
    true
}

#[cfg(test)]
thread_local! {
    /// Set by the test that runs the full pass.
    pub(crate) static FULL_PASS: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// Pairs skipped, for that test.
    pub(crate) static SKIPPED: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

#[cfg(test)]
fn skipping_settled() -> bool {
    !FULL_PASS.with(|f| f.get())
}
