//! Take-ups at the quarter points of an arc that run on without a stop:
//! the reversing axis crosses its dead band on a tangent-continuous
//! S-curve, two arcs that the planner joins without a corner
//! (docs/compensation.md, "A take-up where the path runs on").
//!
//! At a quarter point the arc's normal lies along the reversing axis. In a
//! frame local to the point, `x` along the path and `y` along that axis
//! (toward the extreme), the nominal arc is `y_n(x) = √(R² − x²) − R`; the
//! command must go from following it (the old direction's tables) to
//! following it `b` lower (the new direction's tables: `b` the axis' own
//! lag). Under a dead band the tool follows the command until the command
//! peaks, then stands still while the command falls by `b` across the
//! band, then follows it again `b` higher. So with the S-curve `y_c(x)`
//! and its peak `y_p`, the tool is off the path by
//!
//! * `y_c − y_n` before the peak,
//! * `y_p − y_n` while the band is crossed (the tool frozen at the peak),
//! * `y_c + b − y_n` once engaged.
//!
//! The S-curve is the biarc from the arc at `x = −w₁` (old command, the
//! arc's tangent) to the arc `b` lower at `x = w₂` (new command), the
//! joint where both arcs are as far from their ends along their tangents
//! (the equal-distance biarc); under G61, where that one's tighter arc is
//! narrower, the S of two equal radii ([`widest_biarc`]). LinuxCNC runs an
//! arc of radius `ρ` at no
//! more than `√(a_n ρ)` (`pmCircleActualMaxVel`, blendmath.c;
//! `a_n = √0.75 · A`), so a tight S-curve slows the machine: the window is
//! chosen, among lengths growing by ×1.25, as the one that keeps the tool
//! within the tolerance at the least time cost; under G61 (the widest
//! biarc) that window is searched again at ×1.25^(1/8) between its
//! neighbours, since the tighter arc's radius grows with the square of
//! the window and a step of ×1.25 can cost a fifth of the speed.
//!
//! **The least time.** The tool is within `tol` of the nominal path while
//! frozen only where `y_n` stays within a band of `2·tol`: a window of
//! `4√(R·tol)` along the path. Across it the axis must move `b` relative
//! to the path and be at rest relative to it at both ends (outside, it
//! follows the path on one side of the band or the other): at a relative
//! acceleration `a_r`, in no less than `2√(b/a_r)`; the axis' own limit
//! `A` bounds `a_r + v²/R`. So the feed through the point is at most
//! `v* = 2·√(A·R·tol / (b + 4·tol))` ([`least_speed_mm_s`]), and slowing
//! from `v` to `v*` and back at the path acceleration `a_t` costs at least
//! `(v − v*)²/(a_t·v)` ([`least_cost_s`]).

use super::joins::PlannerLimits;

/// A point or vector of the plane.
type P2 = [f64; 2];

fn sub(a: P2, b: P2) -> P2 {
    [a[0] - b[0], a[1] - b[1]]
}

fn dot(a: P2, b: P2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

fn left(a: P2) -> P2 {
    [-a[1], a[0]]
}

/// One arc of a biarc: from `start`, tangent `tangent` there, to `end`;
/// `radius` signed (positive: the centre on the left of the tangent, the
/// arc turns counter-clockwise), infinite for a straight piece.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct BiarcArc {
    pub(super) start: P2,
    pub(super) end: P2,
    pub(super) tangent: P2,
    pub(super) radius: f64,
}

impl BiarcArc {
    /// The arc through `start` with unit tangent `t` there that ends at
    /// `end`.
    fn through(start: P2, t: P2, end: P2) -> BiarcArc {
        let d = sub(end, start);
        let across = dot(d, left(t));
        let radius = if across.abs() <= 1e-15 * dot(d, d).sqrt().max(1e-300) {
            f64::INFINITY
        } else {
            dot(d, d) / (2.0 * across)
        };
        BiarcArc {
            start,
            end,
            tangent: t,
            radius,
        }
    }

    /// The centre (`None` for a straight piece).
    pub(super) fn center(&self) -> Option<P2> {
        self.radius.is_finite().then(|| {
            let n = left(self.tangent);
            [
                self.start[0] + n[0] * self.radius,
                self.start[1] + n[1] * self.radius,
            ]
        })
    }

    /// The signed angle swept (rad; 0 for a straight piece).
    fn sweep(&self) -> f64 {
        let Some(c) = self.center() else { return 0.0 };
        let a0 = (self.start[1] - c[1]).atan2(self.start[0] - c[0]);
        let a1 = (self.end[1] - c[1]).atan2(self.end[0] - c[0]);
        let mut s = a1 - a0;
        // Less than half a turn, in the arc's direction.
        let pi = std::f64::consts::PI;
        if self.radius > 0.0 {
            while s < 0.0 {
                s += 2.0 * pi;
            }
        } else {
            while s > 0.0 {
                s -= 2.0 * pi;
            }
        }
        s
    }

    /// The point at a fraction of the arc, as a function of the fraction
    /// (for speed: the centre, start angle and sweep found once for all
    /// the points sampled, not per point).
    pub(super) fn sampler(&self) -> impl Fn(f64) -> P2 + '_ {
        let arc = self.center().map(|c| {
            let a0 = (self.start[1] - c[1]).atan2(self.start[0] - c[0]);
            (c, a0, self.sweep(), self.radius.abs())
        });
        move |f| match arc {
            None => [
                self.start[0] + (self.end[0] - self.start[0]) * f,
                self.start[1] + (self.end[1] - self.start[1]) * f,
            ],
            Some((c, a0, sweep, r)) => {
                let a = a0 + sweep * f;
                [c[0] + r * a.cos(), c[1] + r * a.sin()]
            }
        }
    }

    /// Its length.
    pub(super) fn length(&self) -> f64 {
        if self.radius.is_finite() {
            (self.radius * self.sweep()).abs()
        } else {
            dot(sub(self.end, self.start), sub(self.end, self.start)).sqrt()
        }
    }

    /// The unit tangent at its end.
    pub(super) fn end_tangent(&self) -> P2 {
        match self.center() {
            None => self.tangent,
            Some(c) => {
                let r = sub(self.end, c);
                let n = dot(r, r).sqrt();
                let t = left([r[0] / n, r[1] / n]);
                if self.radius > 0.0 {
                    t
                } else {
                    [-t[0], -t[1]]
                }
            }
        }
    }
}

/// The equal-distance biarc from `p1` (unit tangent `t1`) to `p2` (unit
/// tangent `t2`): two arcs joined tangent-continuously at the point `d`
/// along `t1` from `p1` and `d` back along `t2` from `p2` meet halfway.
pub(super) fn biarc(p1: P2, t1: P2, p2: P2, t2: P2) -> Option<[BiarcArc; 2]> {
    let v = sub(p2, p1);
    let t = [t1[0] + t2[0], t1[1] + t2[1]];
    let denom = 2.0 * (1.0 - dot(t1, t2));
    let vt = dot(v, t);
    let d = if denom.abs() < 1e-14 {
        let vt2 = dot(v, t2);
        if vt2.abs() < 1e-300 {
            return None;
        }
        dot(v, v) / (4.0 * vt2)
    } else {
        (-vt + (vt * vt + denom * dot(v, v)).sqrt()) / denom
    };
    if !(d > 0.0 && d.is_finite()) {
        return None;
    }
    let joint = [
        0.5 * (p1[0] + d * t1[0] + p2[0] - d * t2[0]),
        0.5 * (p1[1] + d * t1[1] + p2[1] - d * t2[1]),
    ];
    let a1 = BiarcArc::through(p1, t1, joint);
    let tj = a1.end_tangent();
    let a2 = BiarcArc::through(joint, tj, p2);
    Some([a1, a2])
}

/// The S-shaped biarc from `p1` (unit tangent `t1`) to `p2` (unit
/// tangent `t2`) whose two arcs have the same radius and turn opposite
/// ways; `None` where no such biarc leaves `p1` along `t1`. With `n₁`
/// the unit normal at `p1` on the side the first arc turns to and `n₂`
/// the one at `p2` on the side the second turns to, the centres are
/// `c₁ = p1 + ρn₁` and `c₂ = p2 + ρn₂`, and the arcs join
/// tangent-continuously where the circles touch, `|c₁ − c₂| = 2ρ`: with
/// `w = p1 − p2` and `s = n₁ − n₂`,
/// `(s·s − 4)ρ² + 2(w·s)ρ + w·w = 0`, whose one positive root is `ρ`
/// (`s·s < 4`; linear where the tangents are parallel), the joint
/// halfway between the centres. Of the two senses, the one whose arcs
/// each turn by less than a quarter turn (the S, not a loop), the shorter
/// if both do.
pub(super) fn equal_radius_biarc(p1: P2, t1: P2, p2: P2, t2: P2) -> Option<[BiarcArc; 2]> {
    let w = sub(p1, p2);
    let mut best: Option<([BiarcArc; 2], f64)> = None;
    for sense in [1.0, -1.0] {
        // The first arc's centre on the left of t1 for sense +1, the
        // second's on the right of t2.
        let n1 = left(t1);
        let n1 = [sense * n1[0], sense * n1[1]];
        let n2 = left(t2);
        let n2 = [-sense * n2[0], -sense * n2[1]];
        let s = [n1[0] - n2[0], n1[1] - n2[1]];
        // s·s − 4 = −|n₁ + n₂|² for unit normals (no cancellation).
        let m = [n1[0] + n2[0], n1[1] + n2[1]];
        let (qa, qb, qc) = (-dot(m, m), dot(w, s), dot(w, w));
        // The positive root of qa ρ² + 2 qb ρ + qc = 0 (qa ≤ 0 < qc), in
        // the form without cancellation for each sign of qb.
        let d = (qb * qb - qa * qc).sqrt();
        let rho = if qb <= 0.0 {
            qc / (d - qb)
        } else if qa < 0.0 {
            (qb + d) / -qa
        } else {
            continue;
        };
        if !(rho > 0.0 && rho.is_finite()) {
            continue;
        }
        let c1 = [p1[0] + rho * n1[0], p1[1] + rho * n1[1]];
        let c2 = [p2[0] + rho * n2[0], p2[1] + rho * n2[1]];
        let joint = [0.5 * (c1[0] + c2[0]), 0.5 * (c1[1] + c2[1])];
        let a1 = BiarcArc::through(p1, t1, joint);
        let a2 = BiarcArc::through(joint, a1.end_tangent(), p2);
        // Each arc turns its own way by less than a quarter turn (no
        // loop), and the second ends along t2.
        let te = a2.end_tangent();
        let quarter = std::f64::consts::FRAC_PI_2;
        if !(a1.radius * sense > 0.0
            && a2.radius * sense < 0.0
            && a1.sweep().abs() < quarter
            && a2.sweep().abs() < quarter
            && dot(te, t2) > 1.0 - 1e-9)
        {
            continue;
        }
        let len = a1.length() + a2.length();
        if best.is_none_or(|(_, l)| len < l) {
            best = Some(([a1, a2], len));
        }
    }
    best.map(|(arcs, _)| arcs)
}

/// The smaller of a biarc's two radii (mm; infinite for two straight
/// pieces).
pub(super) fn least_radius(arcs: &[BiarcArc; 2]) -> f64 {
    arcs[0].radius.abs().min(arcs[1].radius.abs())
}

/// The biarc from `p1` (unit tangent `t1`) to `p2` (unit tangent `t2`)
/// the planner runs fastest: an arc of radius `ρ` runs at no more than
/// `√(a_n ρ)` (`pmCircleActualMaxVel`, blendmath.c), so of the
/// equal-distance biarc ([`biarc`]) and the equal-radius S
/// ([`equal_radius_biarc`]) the one whose tighter arc is wider.
pub(super) fn widest_biarc(p1: P2, t1: P2, p2: P2, t2: P2) -> Option<[BiarcArc; 2]> {
    let even = biarc(p1, t1, p2, t2);
    match (even, equal_radius_biarc(p1, t1, p2, t2)) {
        (Some(e), Some(s)) if least_radius(&s) > least_radius(&e) => Some(s),
        (None, s) => s,
        (e, _) => e,
    }
}

/// Where the first arc of `arcs` (a biarc drawn in the axes `(u, v)` of a
/// plane whose normal axis is `w`) ends, in 3-D: the plane's coordinates
/// from the biarc, the normal axis shared out from `from` to `to` by the
/// arcs' lengths (each arc then a helix of the same slope). Not rounded
/// to the written grid.
pub(super) fn biarc_joint(
    arcs: &[BiarcArc; 2],
    (from, to): (volcomp_gcode::Vec3, volcomp_gcode::Vec3),
    (u, v, w): (usize, usize, usize),
) -> volcomp_gcode::Vec3 {
    let (l1, l2) = (arcs[0].length(), arcs[1].length());
    let mut joint = from;
    joint[u] = arcs[0].end[0];
    joint[v] = arcs[0].end[1];
    joint[w] = from[w] + (to[w] - from[w]) * l1 / (l1 + l2);
    joint
}

/// The S-curve of a quarter point in its local frame (module
/// documentation): the window before and after the point (mm along the
/// path), the largest distance of the tool from the path under
/// the dead band (mm), the slowest speed the planner runs it at (mm/s),
/// and the time it costs (s) against running through at the feed.
#[derive(Debug, Clone, Copy)]
pub(super) struct Window {
    pub(super) before_mm: f64,
    pub(super) after_mm: f64,
    pub(super) deviation_mm: f64,
    /// The slowest speed on the S-curve (the tests compare it with the
    /// bound).
    #[cfg_attr(not(test), allow(dead_code))]
    pub(super) speed_mm_s: f64,
    pub(super) cost_s: f64,
    /// The biarc family the window was found with: [`widest_biarc`]
    /// (`true`) or the equal-distance [`biarc`] (`false`); the writer
    /// draws the S-curve with the same one.
    pub(super) widest: bool,
}

/// The biarc of the window `w1`, `w2` on an arc of radius `r` for a band
/// `b` (mm); `None` where none fits. With `widest`, the biarc of
/// [`widest_biarc`]; else the equal-distance one ([`biarc`]).
fn window_biarc(r: f64, b: f64, w1: f64, w2: f64, widest: bool) -> Option<[BiarcArc; 2]> {
    if w1 >= r || w2 >= r {
        return None;
    }
    let y_n = |x: f64| (r * r - x * x).sqrt() - r;
    let unit = |x: f64| {
        let dy = -x / (r * r - x * x).sqrt();
        let n = (1.0 + dy * dy).sqrt();
        [1.0 / n, dy / n]
    };
    let p1 = [-w1, y_n(-w1)];
    let p2 = [w2, y_n(w2) - b];
    if widest {
        widest_biarc(p1, unit(-w1), p2, unit(w2))
    } else {
        biarc(p1, unit(-w1), p2, unit(w2))
    }
}

/// Points [`window_deviation`] samples on each arc of a window's biarc.
const SAMPLES_PER_ARC: usize = 200;

/// The tool's largest distance from the path under the dead band on the
/// window's biarc `arcs` ([`window_biarc`]) on an arc of radius `r` for a
/// band `b`, and its root mean square along the window (by the trapezoid
/// rule over the samples, against `x`); `None` where the band is not
/// crossed inside the window. `pts` is room for the sampled points, kept
/// between windows (its contents are overwritten).
fn window_deviation(r: f64, b: f64, arcs: &[BiarcArc; 2], pts: &mut Vec<P2>) -> Option<(f64, f64)> {
    let y_n = |x: f64| (r * r - x * x).sqrt() - r;
    let p1 = arcs[0].start;
    // Sample the command along both arcs, in order; x must advance along
    // the path (stopping at the first point that does not). The highest
    // point is kept as they are sampled (the maximum in the same order).
    const N: usize = SAMPLES_PER_ARC;
    pts.clear();
    pts.push(p1);
    let mut peak = f64::NEG_INFINITY.max(p1[1]);
    let mut last_x = p1[0];
    for a in arcs {
        let point = a.sampler();
        for k in 1..=N {
            let p = point(k as f64 / N as f64);
            if p[0] <= last_x {
                return None;
            }
            last_x = p[0];
            peak = peak.max(p[1]);
            pts.push(p);
        }
    }
    let mut worst: f64 = 0.0;
    let mut state = 0; // 0 rising, 1 frozen, 2 engaged
    let mut last_y = f64::NEG_INFINITY;
    // ∫dev² dx by the trapezoid rule, from the previous sample.
    let (mut square, mut last) = (0.0, None::<(f64, f64)>);
    for p in pts.iter() {
        let (x, y) = (p[0], p[1]);
        if state == 0 && y < last_y {
            state = 1;
        }
        if state == 1 && y <= peak - b {
            state = 2;
        }
        let dev = match state {
            0 => y - y_n(x),
            1 => peak - y_n(x),
            _ => y + b - y_n(x),
        };
        worst = worst.max(dev.abs());
        if let Some((x0, d0)) = last {
            square += 0.5 * (x - x0) * (d0 * d0 + dev * dev);
        }
        last = Some((x, dev));
        last_y = y;
    }
    // Not engaged by the end of the window: the band is not crossed.
    if state != 2 {
        return None;
    }
    let span = pts[pts.len() - 1][0] - pts[0][0];
    Some((worst, (square / span).sqrt()))
}

/// The root mean square of the tool's distance from the path along an
/// equal-distance S-curve window that a G61 search may take
/// ([`families`]): that of a ramp centred on a reversal
/// (`ramp_centre::TOLERANCE_MM`, half of it, as `ramp_band::within` reads
/// a ramp), 0.1 µm. Without it the fastest equal-distance windows stood
/// the tool 0.34 µm off (RMS 0.19 µm) over 0.46 mm at every quarter
/// point, and on the fine map (1.2–1.8 µm bands, F6000) the band RMS
/// reduction fell below 99 % (helix_d24 99.61 → 98.68 %, g3_d16
/// 98.27 %).
const EQUAL_DISTANCE_RMS_MM: f64 = 0.5 * super::ramp_centre::TOLERANCE_MM;

/// The window that takes up a band `b` (mm) at a quarter point of an arc
/// of radius `r` fed at `v` (mm/s) with the tool within `tol` (mm) of the
/// path, at the least time on `planner`'s machine; `None` where no window
/// up to a quarter of the radius keeps it within `tol`. With `after_only`
/// the window starts at the point itself (`before_mm` = 0): the quarter
/// point is the start of the block, the join with a block already written
/// that the original runs through tangentially, so the S-curve lies on
/// this block alone, starting along the tangent both blocks share there.
/// With `widest` (G61) the S-curve is the biarc [`widest_biarc`] gives,
/// as the writer then writes it; else the equal-distance one.
pub(super) fn best_window(
    r: f64,
    b: f64,
    tol: f64,
    v: f64,
    planner: &PlannerLimits,
    after_only: bool,
    widest: bool,
) -> Option<Window> {
    // The search is a function of its arguments alone: a program that
    // turns the same way again (the same radius, band, tolerance and feed,
    // to the bit) gets the window found before, not a new search.
    let key = WindowKey::of([r, b, tol, v], planner, [after_only, widest]);
    if let Some(found) = WINDOWS.with_borrow(|memo| memo.get(&key)) {
        return found;
    }
    let a_min = planner
        .max_acceleration_mm_s2
        .iter()
        .fold(f64::INFINITY, |m, x| m.min(*x));
    let a_n = a_min * 0.75f64.sqrt();
    // The planner runs the arc itself at no more than `√(a_n r)`
    // (`pmCircleActualMaxVel`): the S-curve costs only what it slows below
    // that.
    let v = v.min((a_n * r).sqrt());
    // The path acceleration on the arc (`pmCircleActualMaxVel`).
    let a_t = a_min * (1.0 - ((v * v / r) / a_min).min(1.0).powi(2)).sqrt();
    let lengths: Vec<f64> = (0..40)
        .map(|k| 0.005 * 1.25f64.powi(k))
        .filter(|w| *w <= 0.25 * r)
        .collect();
    let befores: &[f64] = if after_only { &[0.0] } else { &lengths };
    let mut best: Option<Window> = None;
    let mut pts = Vec::with_capacity(2 * SAMPLES_PER_ARC + 1);
    // The window `w1`, `w2` replaces `best` where it keeps the tool within
    // `tol` at less cost.
    let mut consider = |w1: f64, w2: f64, family: bool, best: &mut Option<Window>| {
        {
            let Some(arcs) = window_biarc(r, b, w1, w2, family) else {
                return;
            };
            // Each arc runs at no more than √(a_n ρ), nor than its length
            // per servo period.
            let speed = arcs.iter().fold(v, |m, a| {
                let rho = a.radius.abs();
                let cap = if rho.is_finite() {
                    (a_n * rho).sqrt()
                } else {
                    f64::INFINITY
                };
                m.min(cap).min(a.length() / planner.servo_period_s)
            });
            let len = arcs[0].length() + arcs[1].length();
            let cost = (v - speed).powi(2) / (a_t * v) + len * (1.0 / speed - 1.0 / v);
            // A window that costs more than the best so far
            // (beyond the margin below) cannot replace it whatever its
            // deviation, so the deviation (400 points) is not sampled.
            if best.is_some_and(|b| cost > b.cost_s + 1e-4) {
                return;
            }
            let Some((dev, rms)) = window_deviation(r, b, &arcs, &mut pts) else {
                return;
            };
            if dev > tol || (!family && widest && rms > EQUAL_DISTANCE_RMS_MM) {
                return;
            }
            // Of windows that cost the same (within 0.1 ms: at the feed,
            // typically), the one that keeps the tool closest.
            if best.is_none_or(|b| {
                cost < b.cost_s - 1e-4 || (cost <= b.cost_s + 1e-4 && dev < b.deviation_mm)
            }) {
                *best = Some(Window {
                    before_mm: w1,
                    after_mm: w2,
                    deviation_mm: dev,
                    speed_mm_s: speed,
                    cost_s: cost,
                    widest: family,
                });
            }
        }
    };
    // Under G61 both biarcs of each window are tried ([`families`]).
    for &family in families(widest) {
        for &w1 in befores {
            for &w2 in &lengths {
                consider(w1, w2, family, &mut best);
            }
        }
    }
    // Under G61 the best window of the ×1.25 grid is searched again
    // between its neighbours ([`refined_lengths`]), with both biarcs.
    if let Some(found) = best.filter(|_| widest) {
        let (b1, b2) = (found.before_mm, found.after_mm);
        for &family in families(widest) {
            for w1 in refined_lengths(b1, after_only) {
                for w2 in refined_lengths(b2, false) {
                    if w2 <= 0.25 * r && w1 <= 0.25 * r {
                        consider(w1, w2, family, &mut best);
                    }
                }
            }
        }
    }
    WINDOWS.with_borrow_mut(|memo| memo.put(key, best));
    best
}

/// The biarc families a window search tries: under G61 (`widest`) the
/// widest biarc ([`widest_biarc`], `true`) and the equal-distance one
/// ([`biarc`], `false`), each window taking whichever keeps the tool within
/// the tolerance at less cost; else the equal-distance one alone.
/// [`widest_biarc`] picks by the tighter arc's radius only, but the planner
/// also runs an arc no faster than its length per servo period
/// (`tcClampVelocityByLength`, src/emc/tp/tc.c), and the equal-radius S's
/// second arc is short where the band is small against the window: on R12
/// at F6000 with a 1.5 µm band (0.34 µm) the widest biarcs the search found
/// ran at 55.5 mm/s (a 0.056 mm G2 of R4.73), the equal-distance ones at
/// 87.8 mm/s (R8.9 then R18.4, both turning the arc's way).
fn families(widest: bool) -> &'static [bool] {
    if widest {
        &[true, false]
    } else {
        &[false]
    }
}

/// Steps between the lengths of the ×1.25 grid [`best_window`] and
/// [`join_window`] search first, where the S-curve is the widest biarc
/// (G61).
const REFINE_STEPS: i32 = 8;

/// The lengths between a window length `w` of the ×1.25 grid and its two
/// neighbours, `w·1.25^(k/8)` for `k` in −7…7 (`[0]` where the window
/// starts at the point, `at_point`). An arc of radius `ρ` runs at
/// `√(a_n ρ)` (`pmCircleActualMaxVel`, blendmath.c) and the widest biarc's
/// radius grows with the square of its window, so a window the grid
/// steps over by up to ×1.25 can leave the S-curve up to a fifth slower
/// than the tolerance allows: the window the grid finds is searched again
/// at these lengths (`w` itself among them).
fn refined_lengths(w: f64, at_point: bool) -> Vec<f64> {
    if at_point {
        return vec![0.0];
    }
    (1 - REFINE_STEPS..REFINE_STEPS)
        .map(|k| w * 1.25f64.powf(f64::from(k) / f64::from(REFINE_STEPS)))
        .collect()
}

/// The arguments of [`best_window`], to the bit.
#[derive(Clone, Copy, PartialEq, Eq)]
struct WindowKey([u64; 10]);

impl WindowKey {
    /// The key of `best_window(r, b, tol, v, planner, after_only, widest)`
    /// from `[r, b, tol, v]`, `planner` and `[after_only, widest]`.
    fn of(
        [r, b, tol, v]: [f64; 4],
        planner: &PlannerLimits,
        [after_only, widest]: [bool; 2],
    ) -> WindowKey {
        // Every field, by an exhaustive pattern: a field added to the
        // limits fails to compile here until the key holds it too.
        let PlannerLimits {
            max_acceleration_mm_s2: [ax, ay, az],
            servo_period_s,
        } = *planner;
        WindowKey([
            r.to_bits(),
            b.to_bits(),
            tol.to_bits(),
            v.to_bits(),
            ax.to_bits(),
            ay.to_bits(),
            az.to_bits(),
            servo_period_s.to_bits(),
            u64::from(after_only),
            u64::from(widest),
        ])
    }
}

/// The windows [`best_window`] found last, by their arguments: the
/// 32 most recent searches, the oldest replaced first.
#[derive(Default)]
struct WindowMemo {
    found: Vec<(WindowKey, Option<Window>)>,
    next: usize,
}

impl WindowMemo {
    const SIZE: usize = 32;

    fn get(&self, key: &WindowKey) -> Option<Option<Window>> {
        self.found.iter().find(|(k, _)| k == key).map(|(_, w)| *w)
    }

    fn put(&mut self, key: WindowKey, window: Option<Window>) {
        if self.found.len() < Self::SIZE {
            self.found.push((key, window));
        } else {
            self.found[self.next] = (key, window);
            self.next = (self.next + 1) % Self::SIZE;
        }
    }
}

thread_local! {
    /// [`best_window`]'s searches on this thread ([`WindowMemo`]).
    static WINDOWS: std::cell::RefCell<WindowMemo> = std::cell::RefCell::new(WindowMemo::default());
}

/// The highest feed (mm/s) at which any command takes up a band `b` at a
/// quarter point of radius `r` with the tool within `tol` of the path, on
/// an axis of acceleration `a` (module documentation):
/// `2·√(a·r·tol / (b + 4·tol))`.
pub fn least_speed_mm_s(r: f64, b: f64, tol: f64, a: f64) -> f64 {
    2.0 * (a * r * tol / (b + 4.0 * tol)).sqrt()
}

/// The least time (s) a take-up at a quarter point costs against running
/// through at `v`: slowing to [`least_speed_mm_s`] and back at the path
/// acceleration `a_t` (0 where `v` is below it).
pub fn least_cost_s(v: f64, r: f64, b: f64, tol: f64, a: f64, a_t: f64) -> f64 {
    let vs = least_speed_mm_s(r, b, tol, a);
    if vs >= v {
        0.0
    } else {
        (v - vs).powi(2) / (a_t * v)
    }
}

/// The nominal path of a quarter point at a block join in its local frame
/// (module documentation): the block before is an arc of radius `r1`
/// (`x < 0`; infinite: a line), the block after one of radius `r2`
/// (`x ≥ 0`), both tangent to the `x` axis at the join and curving away
/// from the extreme.
fn join_nominal(r1: f64, r2: f64) -> impl Fn(f64) -> f64 {
    move |x: f64| {
        let r = if x < 0.0 { r1 } else { r2 };
        if r.is_finite() {
            (r * r - x * x).sqrt() - r
        } else {
            0.0
        }
    }
}

/// The unit tangent of [`join_nominal`] at `x`.
fn join_tangent(r1: f64, r2: f64, x: f64) -> P2 {
    let r = if x < 0.0 { r1 } else { r2 };
    if !r.is_finite() {
        return [1.0, 0.0];
    }
    let dy = -x / (r * r - x * x).sqrt();
    let n = (1.0 + dy * dy).sqrt();
    [1.0 / n, dy / n]
}

/// The biarc of the window `w1` (on the block before, radius `r1`), `w2`
/// (on the block after, radius `r2`) of a quarter point at a block join
/// for a band `b` (mm); `None` where none fits. With `widest`, the biarc
/// of [`widest_biarc`]; else the equal-distance one ([`biarc`]). With
/// `r1 = r2` it is the window of one arc.
fn join_biarc(r1: f64, r2: f64, b: f64, w1: f64, w2: f64, widest: bool) -> Option<[BiarcArc; 2]> {
    if w1 >= r1 || w2 >= r2 {
        return None;
    }
    let y_n = join_nominal(r1, r2);
    let p1 = [-w1, y_n(-w1)];
    let p2 = [w2, y_n(w2) - b];
    let (t1, t2) = (join_tangent(r1, r2, -w1), join_tangent(r1, r2, w2));
    if widest {
        widest_biarc(p1, t1, p2, t2)
    } else {
        biarc(p1, t1, p2, t2)
    }
}

/// The tool's largest distance from the path under the dead band on the
/// biarc `arcs` of a join window ([`join_biarc`]) for a band `b`: the
/// same reading as the window of one arc (module documentation), against
/// the two radii of [`join_nominal`]; `None` where the band is not crossed
/// inside the window.
fn join_deviation(r1: f64, r2: f64, b: f64, arcs: &[BiarcArc; 2]) -> Option<f64> {
    let y_n = join_nominal(r1, r2);
    const N: usize = 200;
    let mut pts = [[0.0; 2]; 2 * N + 1];
    pts[0] = arcs[0].start;
    for (i, a) in arcs.iter().enumerate() {
        let point = a.sampler();
        for k in 1..=N {
            let j = i * N + k;
            pts[j] = point(k as f64 / N as f64);
            if pts[j][0] <= pts[j - 1][0] {
                return None;
            }
        }
    }
    let peak = pts.iter().fold(f64::NEG_INFINITY, |m, p| m.max(p[1]));
    let mut worst: f64 = 0.0;
    // Rising (following the command), frozen at the peak while the band
    // is crossed, engaged (`b` above the command).
    let (mut frozen, mut engaged) = (false, false);
    let mut last_y = f64::NEG_INFINITY;
    for &[x, y] in &pts {
        frozen |= y < last_y;
        engaged |= frozen && y <= peak - b;
        let dev = if engaged {
            y + b - y_n(x)
        } else if frozen {
            peak - y_n(x)
        } else {
            y - y_n(x)
        };
        worst = worst.max(dev.abs());
        last_y = y;
    }
    engaged.then_some(worst)
}

/// The shortest part after the join (mm) of a join window run at `v`
/// (mm/s): the length the planner runs at `v` in `TP_MIN_SEGMENT_CYCLES`
/// (1.02, src/emc/tp/tp_types.h) servo periods (tp.c,
/// `tpComputeOptimalVelocity`), plus 10 µm for the rounding of the cut
/// and the written words.
pub(super) fn min_join_after_mm(v: f64, planner: &PlannerLimits) -> f64 {
    const TP_MIN_SEGMENT_CYCLES: f64 = 1.02;
    v * planner.servo_period_s * TP_MIN_SEGMENT_CYCLES + 0.01
}

/// The window of a quarter point that falls on a block join (the block
/// before an arc of radius `r1` or a line, `r1` infinite, the one after an
/// arc of radius `r2`, the original
/// running through tangentially) whose part before the join is `before_mm`
/// — the tail the block before held back for it, chosen there by
/// [`best_window`] on its own radius — and whose part after the join is the
/// one, among lengths growing by ×1.25 up to a quarter of `r2`, that keeps
/// the tool within `tol` at the least time ([`best_window`]'s cost, the
/// feed `v` capped by the tighter block's `√(a_n r)`); `None` where none
/// does.
///
/// The S-curve is cut on the normal through the join and the part after
/// the cut is written as a segment of its own ([`super::arcs::split_at_normal`]),
/// at least as long as the part after the join. LinuxCNC's planner caps a
/// segment's speed at its length per `TP_MIN_SEGMENT_CYCLES` (1.02) servo
/// periods (src/emc/tp/tp.c, `tpComputeOptimalVelocity`: `sample_maxvel =
/// tc->target / (tp->cycleTime * TP_MIN_SEGMENT_CYCLES)`), so a part after
/// the join shorter than [`min_join_after_mm`] would slow the tool below
/// the window's speed: such lengths are not searched.
pub(super) fn join_window(
    (r1, r2): (f64, f64),
    b: f64,
    tol: f64,
    v: f64,
    planner: &PlannerLimits,
    before_mm: f64,
    widest: bool,
) -> Option<Window> {
    let a_min = planner
        .max_acceleration_mm_s2
        .iter()
        .fold(f64::INFINITY, |m, x| m.min(*x));
    let a_n = a_min * 0.75f64.sqrt();
    let r = r1.min(r2);
    let v = v.min((a_n * r).sqrt());
    let a_t = a_min * (1.0 - ((v * v / r) / a_min).min(1.0).powi(2)).sqrt();
    let shortest_mm = min_join_after_mm(v, planner);
    let mut best: Option<Window> = None;
    // The window whose part after the join is `w2` replaces `best` where
    // it keeps the tool within `tol` at less cost.
    let consider = |w2: f64, family: bool, best: &mut Option<Window>| {
        let Some(arcs) = join_biarc(r1, r2, b, before_mm, w2, family) else {
            return;
        };
        let speed = arcs.iter().fold(v, |m, a| {
            let rho = a.radius.abs();
            let cap = if rho.is_finite() {
                (a_n * rho).sqrt()
            } else {
                f64::INFINITY
            };
            m.min(cap).min(a.length() / planner.servo_period_s)
        });
        let len = arcs[0].length() + arcs[1].length();
        let cost = (v - speed).powi(2) / (a_t * v) + len * (1.0 / speed - 1.0 / v);
        if best.is_some_and(|b| cost > b.cost_s + 1e-4) {
            return;
        }
        let Some(dev) = join_deviation(r1, r2, b, &arcs).filter(|d| *d <= tol) else {
            return;
        };
        if best.is_none_or(|b| {
            cost < b.cost_s - 1e-4 || (cost <= b.cost_s + 1e-4 && dev < b.deviation_mm)
        }) {
            *best = Some(Window {
                before_mm,
                after_mm: w2,
                deviation_mm: dev,
                speed_mm_s: speed,
                cost_s: cost,
                widest: family,
            });
        }
    };
    // Under G61 the lengths step by ×1.25^(1/8) ([`refined_lengths`]):
    // the part before the join is fixed, so a grid of one length is
    // searched whole. The equal-distance biarc is tried only where no
    // widest one fits ([`families`]: the tail before the join may have been
    // sized for it, and without a window the take-up is a block, a stop,
    // or an S-curve on the arc alone). Tried on cost alone it also
    // replaced the widest S at the pocket's line → R3 joins, which the
    // planner model ran ~10 ms slower each (pocket_arcs, fine map, F6000:
    // +5.4 → +6.9 %). Where no widest one fits after a line, the
    // equal-distance one costs 6–12 ms more than an S-curve on the arc
    // alone at the fine map's R1 joins (pocket_arcs +5.4 → +6.1 %) but
    // saves more on the example and shop maps (pocket_arcs +15.1 → +12.7 %,
    // +27.9 → +26.0 %; pocket_r4 +9.6 → +7.1 %, +40.4 → +38.5 %).
    let steps = if widest { REFINE_STEPS } else { 1 };
    for &family in families(widest) {
        if best.is_some() {
            break;
        }
        for w2 in (0..40 * steps)
            .map(|k| {
                if widest {
                    0.005 * 1.25f64.powf(f64::from(k) / f64::from(steps))
                } else {
                    0.005 * 1.25f64.powi(k)
                }
            })
            .take_while(|w| *w <= 0.25 * r2)
            .filter(|w| *w >= shortest_mm)
        {
            consider(w2, family, &mut best);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_join_window_from_the_best_windows_start_is_the_best_window() {
        // Second method: on one radius (r₁ = r₂) the best two-sided window
        // (`best_window`, which searches the start and the end) has the
        // same end as the join window searched from its start. R5, a 4 µm
        // band, 0.34 µm, F6000 on the bench machine (1000 mm/s², 1 ms).
        let planner = PlannerLimits::default();
        let (r, b, tol, v) = (5.0, 4e-3, 0.34e-3, 100.0);
        for widest in [false, true] {
            let best = best_window(r, b, tol, v, &planner, false, widest).unwrap();
            let join = join_window((r, r), b, tol, v, &planner, best.before_mm, widest).unwrap();
            // (Equal within the margin both searches break ties by.)
            assert!(
                (join.cost_s - best.cost_s).abs() <= 1e-4,
                "{best:?} {join:?}"
            );
            // Starting at the point (after only), the tool is frozen at the
            // peak while the path falls as x²/2R: the band is crossed within
            // x₀ = √(2 R tol), and a command leaving the peak along the
            // tangent drops b within x₀ only if it bends somewhere at a
            // radius ρ with ρ − √(ρ² − x₀²) ≥ b, ρ ≤ R·tol/b + b/2, which
            // the planner runs at √(a_n ρ) (a_n = √0.75 · 1000 mm/s²,
            // `pmCircleActualMaxVel`).
            let a_n = 1000.0 * 0.75f64.sqrt();
            let ceiling = (a_n * (r * tol / b + 0.5 * b)).sqrt();
            let after_only = best_window(r, b, tol, v, &planner, true, widest).unwrap();
            assert!(
                after_only.speed_mm_s <= ceiling * 1.001,
                "{after_only:?} {ceiling}"
            );
            assert!(join.speed_mm_s > 1.5 * ceiling, "{join:?} {ceiling}");
        }
    }

    #[test]
    fn a_join_windows_part_after_the_join_is_run_at_the_feed() {
        // A line into an R12 arc (the pocket's line→arc joins), a 4 µm
        // band, 0.34 µm, F6000 on the bench machine: the part after the
        // join is written as a segment of its own, which LinuxCNC runs at
        // most at its length per 1.02 servo periods (tp.c,
        // `tpComputeOptimalVelocity`); at 100 mm/s and 1 ms it is at least
        // 100 · 0.001 · 1.02 = 0.102 mm long, so the window runs at the feed.
        let planner = PlannerLimits::default();
        let (b, tol, v) = (4e-3, 0.34e-3, 100.0);
        for before_mm in [0.05, 0.2, 0.5] {
            let w = join_window((f64::INFINITY, 12.0), b, tol, v, &planner, before_mm, true)
                .expect("a window");
            assert!(w.after_mm >= 0.102, "{w:?}");
        }
    }

    #[test]
    fn a_join_window_judges_each_side_on_its_own_radius() {
        // Across the join of an R4 and an R5 arc (the spiral of half
        // circles), the window's deviation is read against the nominal of
        // each side: recomputed here by a dead band of b between command and
        // tool (the tool follows the command up, stays until the command is
        // b below it, then follows b above it) on a ten times finer
        // sampling of the biarc against the two circles, it agrees and
        // stays within the tolerance.
        let planner = PlannerLimits::default();
        let (b, tol, v) = (4e-3, 0.34e-3, 100.0);
        let w = join_window((4.0, 5.0), b, tol, v, &planner, 0.06, true).unwrap();
        let arcs = join_biarc(4.0, 5.0, b, w.before_mm, w.after_mm, true).unwrap();
        let reading = |r2: f64| {
            let y_n = |x: f64| {
                let r = if x < 0.0 { 4.0 } else { r2 };
                r - (r * r - x * x).sqrt()
            };
            let pts: Vec<P2> = arcs
                .iter()
                .flat_map(|a| {
                    let f = a.sampler();
                    (0..=2000).map(move |k| f(f64::from(k) / 2000.0))
                })
                .collect();
            let (mut tool, mut worst) = (pts[0][1], 0.0f64);
            for p in &pts {
                if p[1] > tool {
                    tool = p[1];
                } else if p[1] + b < tool {
                    tool = p[1] + b;
                }
                worst = worst.max((tool + y_n(p[0])).abs());
            }
            worst
        };
        assert!(
            (reading(5.0) - w.deviation_mm).abs() < 2e-6,
            "{} {w:?}",
            reading(5.0)
        );
        assert!(w.deviation_mm <= tol, "{w:?}");
    }

    #[test]
    fn a_biarc_joins_its_ends_tangent_continuously() {
        // From the origin along +x to (4, −1) along +x: an S.
        let [a1, a2] = biarc([0.0, 0.0], [1.0, 0.0], [4.0, -1.0], [1.0, 0.0]).unwrap();
        assert!(a1.radius < 0.0 && a2.radius > 0.0, "{a1:?} {a2:?}");
        let tj = a1.end_tangent();
        assert!((tj[0] - a2.tangent[0]).abs() < 1e-12 && (tj[1] - a2.tangent[1]).abs() < 1e-12);
        let te = a2.end_tangent();
        assert!((te[0] - 1.0).abs() < 1e-12 && te[1].abs() < 1e-12, "{te:?}");
        // Symmetric S: the joint at the middle, both radii equal:
        // ρ = (2² + 0.5²) / (2·0.5) = 4.25.
        assert!((a1.end[0] - 2.0).abs() < 1e-12 && (a1.end[1] + 0.5).abs() < 1e-12);
        assert!((a1.radius + 4.25).abs() < 1e-12 && (a2.radius - 4.25).abs() < 1e-12);
    }

    #[test]
    fn the_equal_radius_s_is_the_widest_biarc_of_the_family() {
        // A quarter point of R20 (local frame: y_n = √(r² − x²) − r) with
        // a 4 µm band over an asymmetric window, as on the Ø40's bottom.
        // Second method: every biarc from p1 along t1 to p2 along t2 is
        // one of the family d₁ = k·d₂ (the joint d₁ from q₁ = p1 + d₁t₁
        // toward q₂ = p2 − d₂t₂, |q₂ − q₁| = d₁ + d₂, solved here by
        // bisection on d₂); scanning k, the largest least radius is the
        // equal-radius S's, and it beats the equal-distance biarc (k = 1).
        let (r, b, w1, w2) = (20.0, 0.004, 0.1, 0.19);
        let y_n = |x: f64| (r * r - x * x).sqrt() - r;
        let unit = |x: f64| {
            let dy = -x / (r * r - x * x).sqrt();
            let n = (1.0 + dy * dy).sqrt();
            [1.0 / n, dy / n]
        };
        let (p1, t1) = ([-w1, y_n(-w1)], unit(-w1));
        let (p2, t2) = ([w2, y_n(w2) - b], unit(w2));
        let s = equal_radius_biarc(p1, t1, p2, t2).unwrap();
        assert!(s[0].radius < 0.0 && s[1].radius > 0.0, "{s:?}");
        assert!(
            (s[0].radius + s[1].radius).abs() < 1e-9 * s[1].radius,
            "{s:?}"
        );
        let tj = s[0].end_tangent();
        assert!((tj[0] - s[1].tangent[0]).abs() < 1e-12 && (tj[1] - s[1].tangent[1]).abs() < 1e-12);
        let te = s[1].end_tangent();
        assert!(
            (te[0] - t2[0]).abs() < 1e-9 && (te[1] - t2[1]).abs() < 1e-9,
            "{te:?}"
        );
        let family = |k: f64| -> Option<f64> {
            let gap = |d2: f64| {
                let d1 = k * d2;
                let q = [
                    p2[0] - d2 * t2[0] - p1[0] - d1 * t1[0],
                    p2[1] - d2 * t2[1] - p1[1] - d1 * t1[1],
                ];
                dot(q, q).sqrt() - (d1 + d2)
            };
            // gap > 0 at d₂ = 0 (the ends apart), < 0 once d₁ + d₂ passes
            // the chord.
            let (mut lo, mut hi) = (0.0, 1.0);
            if gap(hi) > 0.0 {
                return None;
            }
            for _ in 0..200 {
                let m = 0.5 * (lo + hi);
                if gap(m) > 0.0 {
                    lo = m;
                } else {
                    hi = m;
                }
            }
            let d2 = 0.5 * (lo + hi);
            let d1 = k * d2;
            let q1 = [p1[0] + d1 * t1[0], p1[1] + d1 * t1[1]];
            let q2 = [p2[0] - d2 * t2[0], p2[1] - d2 * t2[1]];
            let f = d1 / (d1 + d2);
            let joint = [q1[0] + f * (q2[0] - q1[0]), q1[1] + f * (q2[1] - q1[1])];
            let a1 = BiarcArc::through(p1, t1, joint);
            let a2 = BiarcArc::through(joint, a1.end_tangent(), p2);
            Some(least_radius(&[a1, a2]))
        };
        let best = (0..=4000)
            .filter_map(|i| family(4f64.powf(i as f64 / 1000.0 - 2.0)))
            .fold(0.0f64, f64::max);
        let even = least_radius(&biarc(p1, t1, p2, t2).unwrap());
        assert!((family(1.0).unwrap() - even).abs() < 1e-6 * even);
        let rho = least_radius(&s);
        // The scan steps k by 0.14 %: its best is within 0.1 % of the
        // family's.
        assert!((rho - best).abs() <= 1e-3 * best, "{rho} vs {best}");
        assert!(rho > 1.1 * even, "{rho} vs {even}");
        let w = widest_biarc(p1, t1, p2, t2).unwrap();
        assert_eq!(least_radius(&w), rho);
    }

    #[test]
    fn the_window_keeps_the_tool_within_tolerance_and_no_faster_than_the_bound() {
        // Ø50 at F6000, a 4 µm band, 0.1 µm: the bound v* = 2√(1000·25·1e-4
        // / 0.0044) = 47.67 mm/s; the S-curve found runs no faster, and not
        // much slower.
        let p = PlannerLimits::default();
        let (r, b, tol) = (25.0, 0.004, 1e-4);
        let vs = least_speed_mm_s(r, b, tol, 1000.0);
        assert!((vs - 2.0 * (2.5f64 / 0.0044).sqrt()).abs() < 1e-9);
        let w = best_window(r, b, tol, 100.0, &p, false, false).unwrap();
        assert!(w.deviation_mm <= tol, "{w:?}");
        assert!(w.speed_mm_s <= vs * 1.0001, "{} vs {vs}", w.speed_mm_s);
        assert!(w.speed_mm_s >= 0.6 * vs, "{} vs {vs}", w.speed_mm_s);
    }

    #[test]
    fn on_an_arc_the_planner_runs_below_the_feed_the_window_costs_what_it_slows_below_that() {
        // R4 at F6000: LinuxCNC runs the arc itself at √(0.866·1000·4) =
        // 58.86 mm/s (pmCircleActualMaxVel), so the window must not be
        // judged against 100 mm/s (every window then "costs" the same and
        // the tightest, a near corner, was taken). Both windows keep the
        // tool within the tolerance and run near the arc's own speed.
        let p = PlannerLimits::default();
        let (r, b) = (4.0, 0.004);
        let v_arc = (0.75f64.sqrt() * 1000.0 * r).sqrt();
        assert!((v_arc - 58.856).abs() < 1e-3);
        for after_only in [false, true] {
            let w = best_window(r, b, 0.85 * b, 100.0, &p, after_only, false).unwrap();
            assert!(w.deviation_mm <= 0.85 * b, "{w:?}");
            assert!(w.speed_mm_s >= 0.85 * v_arc, "{after_only}: {w:?}");
            assert!(w.cost_s < 0.01, "{after_only}: {w:?}");
            assert_eq!(w.before_mm == 0.0, after_only, "{w:?}");
        }
    }

    #[test]
    fn under_g61_the_window_is_as_fast_as_a_fine_scan_of_every_window() {
        // R12 at F6000, a 4 µm band, 0.34 µm (G61's S-curve tolerance):
        // a second method, every window on a grid 16 times finer than the
        // search's ×1.25 up to a quarter of the radius, finds the fastest
        // S-curve that keeps the tool within the tolerance. The search
        // must come within 2 % of it (the ×1.25 grid alone ran the
        // S-curve at 52.3 mm/s, 16 % below). Its speed is LinuxCNC's cap
        // on its tighter arc, √(a_n ρ) with a_n = √0.75 · 1000 mm/s²
        // (pmCircleActualMaxVel, blendmath.c).
        let p = PlannerLimits::default();
        let (r, b, tol, v) = (12.0, 0.004, 0.34e-3, 100.0);
        let a_n = 1000.0 * 0.75f64.sqrt();
        let mut pts = Vec::new();
        let fine: Vec<f64> = (0..640)
            .map(|k| 0.005 * 1.25f64.powf(f64::from(k) / 16.0))
            .filter(|w| *w <= 0.25 * r)
            .collect();
        let mut fastest: f64 = 0.0;
        for &w1 in &fine {
            for &w2 in &fine {
                let Some(arcs) = window_biarc(r, b, w1, w2, true) else {
                    continue;
                };
                let speed = (a_n * least_radius(&arcs)).sqrt().min((a_n * r).sqrt());
                if speed <= fastest {
                    continue;
                }
                if window_deviation(r, b, &arcs, &mut pts).is_some_and(|d| d.0 <= tol) {
                    fastest = speed;
                }
            }
        }
        assert!(fastest > 60.0, "{fastest}");
        let w = best_window(r, b, tol, v, &p, false, true).unwrap();
        assert!(w.deviation_mm <= tol, "{w:?}");
        assert!(w.speed_mm_s >= 0.98 * fastest, "{w:?} vs {fastest}");
        assert!(w.speed_mm_s <= fastest * (1.0 + 1e-9), "{w:?} vs {fastest}");
        // At 4 µm the widest biarc is the faster one (the equal-distance
        // biarcs' tighter arc is narrower).
        assert!(w.widest, "{w:?}");
        let arcs = window_biarc(r, b, w.before_mm, w.after_mm, true).unwrap();
        let rho = least_radius(&arcs);
        assert!(
            (w.speed_mm_s - (a_n * rho).sqrt()).abs() < 1e-9,
            "{w:?} {rho}"
        );
    }

    #[test]
    fn under_g61_a_small_band_takes_the_faster_of_both_biarcs_within_the_ramp_rms() {
        // R12 at F6000, a 1.5 µm band (the fine map's Y), 0.34 µm. The
        // widest biarcs of small windows end in a short second arc, which
        // LinuxCNC runs no faster than its length per servo period
        // (tcClampVelocityByLength, tc.c): the search over them alone
        // found a 0.056 mm G2 of R4.73 run at 55.5 mm/s. A second method,
        // every window of both biarcs on a grid 16 times finer, each arc's
        // speed min(√(a_n ρ), length / 1 ms) (pmCircleActualMaxVel,
        // blendmath.c; a_n = √0.75 · 1000 mm/s²), the equal-distance ones
        // only within 0.1 µm RMS: the search comes within 3 % of the
        // fastest, far above 55.5 mm/s, and keeps both bounds.
        let p = PlannerLimits::default();
        let (r, b, tol, v) = (12.0, 0.0015, 0.34e-3, 100.0);
        let a_n = 1000.0 * 0.75f64.sqrt();
        let speed_of = |arcs: &[BiarcArc; 2]| {
            arcs.iter().fold((a_n * r).sqrt().min(v), |m, a| {
                m.min((a_n * a.radius.abs()).sqrt()).min(a.length() / 0.001)
            })
        };
        let mut pts = Vec::new();
        let fine: Vec<f64> = (0..640)
            .map(|k| 0.005 * 1.25f64.powf(f64::from(k) / 16.0))
            .filter(|w| *w <= 0.25 * r)
            .collect();
        let mut fastest: f64 = 0.0;
        for family in [true, false] {
            for &w1 in &fine {
                for &w2 in &fine {
                    let Some(arcs) = window_biarc(r, b, w1, w2, family) else {
                        continue;
                    };
                    let speed = speed_of(&arcs);
                    if speed <= fastest {
                        continue;
                    }
                    if window_deviation(r, b, &arcs, &mut pts)
                        .is_some_and(|(d, rms)| d <= tol && (family || rms <= 1e-4))
                    {
                        fastest = speed;
                    }
                }
            }
        }
        assert!(fastest > 60.0, "{fastest}");
        let w = best_window(r, b, tol, v, &p, false, true).unwrap();
        assert!(w.speed_mm_s >= 0.97 * fastest, "{w:?} vs {fastest}");
        assert!(w.speed_mm_s <= fastest * (1.0 + 1e-9), "{w:?} vs {fastest}");
        let arcs = window_biarc(r, b, w.before_mm, w.after_mm, w.widest).unwrap();
        assert!((w.speed_mm_s - speed_of(&arcs)).abs() < 1e-9, "{w:?}");
        let (dev, rms) = window_deviation(r, b, &arcs, &mut pts).unwrap();
        assert!(dev <= tol && (dev - w.deviation_mm).abs() < 1e-12, "{w:?}");
        assert!(w.widest || rms <= 1e-4, "{w:?} {rms}");
        // Under G64 (the equal-distance biarc alone) nothing changes: the
        // fastest window within the tolerance, whatever its RMS.
        let g64 = best_window(r, b, tol, v, &p, false, false).unwrap();
        assert!(!g64.widest && g64.speed_mm_s > w.speed_mm_s, "{g64:?}");
    }

    /// A search answered from the memo is the search itself: each
    /// argument set (radii of the raster's turns and of a Ø50, bands a bit
    /// apart, both starts, both biarcs) gives, however the calls are
    /// interleaved and after its entry was replaced, the window a search
    /// on an empty memo gives, to the bit.
    #[test]
    fn a_window_found_again_is_the_one_searched() {
        let p = PlannerLimits::default();
        let slow = PlannerLimits {
            max_acceleration_mm_s2: [1000.0, 400.0, 1000.0],
            ..p
        };
        let mut args = Vec::new();
        for (r, v) in [(0.1, 20.0), (1.0, 50.0), (4.0, 100.0), (25.0, 100.0)] {
            for b in [0.003, f64::from_bits(0.003f64.to_bits() + 1), 0.004] {
                for (after_only, widest) in [(false, false), (true, false), (false, true)] {
                    args.push((r, b, 0.85 * b, v, p, after_only, widest));
                }
            }
            args.push((r, 0.004, 1e-4, v, slow, false, false));
        }
        let search = |a: &(f64, f64, f64, f64, PlannerLimits, bool, bool)| {
            best_window(a.0, a.1, a.2, a.3, &a.4, a.5, a.6)
        };
        let fresh: Vec<String> = args
            .iter()
            .map(|a| {
                WINDOWS.with_borrow_mut(|m| *m = WindowMemo::default());
                format!("{:?}", search(a))
            })
            .collect();
        // Windows were found (the memo holds more than `None`s), and the
        // band one bit wider finds its own search, not its neighbour's.
        assert!(fresh.iter().filter(|w| w.starts_with("Some")).count() > 20);
        // More argument sets than the memo holds: entries are replaced.
        assert!(args.len() > WindowMemo::SIZE);
        for round in 0..3 {
            for (i, a) in args.iter().enumerate().rev() {
                assert_eq!(format!("{:?}", search(a)), fresh[i], "{round}: {a:?}");
                let key = WindowKey::of([a.0, a.1, a.2, a.3], &a.4, [a.5, a.6]);
                assert!(WINDOWS.with_borrow(|m| m.get(&key)).is_some());
            }
        }
    }

    #[test]
    fn a_window_from_the_join_starts_along_the_shared_tangent() {
        // After the join only: the biarc leaves the point itself along the
        // arc's tangent (no corner with the block before), ends on the arc
        // b lower along its tangent, and the tool, frozen at the peak while
        // the command falls by b, is off by at least the arc's own drop
        // x²/(2r) at the first point where the command is b below the
        // peak.
        let (r, b, w2) = (10.0, 0.004, 0.3);
        let arcs = window_biarc(r, b, 0.0, w2, false).unwrap();
        let dev = window_deviation(r, b, &arcs, &mut Vec::new()).unwrap().0;
        assert_eq!(arcs[0].start, [0.0, 0.0]);
        assert_eq!(arcs[0].tangent, [1.0, 0.0]);
        let te = arcs[1].end_tangent();
        let slope = -w2 / (r * r - w2 * w2).sqrt();
        assert!((te[1] / te[0] - slope).abs() < 1e-9, "{te:?}");
        // Where the command is b below the peak (0): bisect along the arcs.
        let y_at = |x: f64| -> f64 {
            let (mut lo, mut hi) = (0.0, 1.0);
            let a = if x <= arcs[0].end[0] {
                &arcs[0]
            } else {
                &arcs[1]
            };
            let point = a.sampler();
            for _ in 0..60 {
                let m = 0.5 * (lo + hi);
                if point(m)[0] < x {
                    lo = m;
                } else {
                    hi = m;
                }
            }
            point(lo)[1]
        };
        let (mut lo, mut hi) = (0.0, w2);
        for _ in 0..60 {
            let m = 0.5 * (lo + hi);
            if y_at(m) > -b {
                lo = m;
            } else {
                hi = m;
            }
        }
        // The simulation samples 200 points per arc: it sees the freeze
        // end within one sample step before that point.
        let x = lo - arcs[1].length().max(arcs[0].length()) / 200.0;
        let hand = r - (r * r - x * x).sqrt();
        assert!(dev >= hand, "{dev} vs {hand}");
        assert!(dev <= 2.0 * lo * lo / r, "{dev} vs {lo}");
    }
}
