//! Geometry both walks share (compensation and simulation): the distance
//! from a point to a programmed arc.

use std::f64::consts::TAU;
use volcomp_gcode::{Arc, Vec3};

/// Distance (mm) from `p` to an arc: to the arc's point at `p`'s angle about
/// the arc's centre (the closest point of a circle), or to the nearer end
/// when that angle lies outside the sweep. On a helix or spiral, whose
/// closest point lies at another angle, the distance is then minimised along
/// the arc (golden-section search) over the stretch that can hold a closer
/// point. On a multi-turn arc the turn nearest to `hint` (the previous
/// sample's parameter) is taken, and `hint` follows.
pub fn arc_distance_mm(p: Vec3, arc: &Arc, hint: &mut f64) -> f64 {
    let (u, v, _) = arc.plane.axes();
    let mut best = (p - arc.start).norm();
    let mut best_t = 0.0;
    let end = (p - arc.end).norm();
    if end < best {
        best = end;
        best_t = 1.0;
    }
    if arc.sweep_rad != 0.0 && arc.sweep_rad.is_finite() {
        let a0 = (arc.start[v] - arc.center[v]).atan2(arc.start[u] - arc.center[u]);
        let ap = (p[v] - arc.center[v]).atan2(p[u] - arc.center[u]);
        let period = TAU / arc.sweep_rad.abs();
        let t0 = ((ap - a0) / arc.sweep_rad).rem_euclid(period);
        let k0 = ((*hint - t0) / period).round();
        for k in [k0 - 1.0, k0, k0 + 1.0] {
            let t = t0 + k * period;
            if (0.0..=1.0).contains(&t) {
                let d = (p - arc.point_at(t)).norm();
                if d < best {
                    best = d;
                    best_t = t;
                }
            }
        }
    }
    let (_, _, w) = arc.plane.axes();
    let circle = arc.start[w] == arc.end[w] && arc.start_radius() == arc.end_radius();
    let length = arc.length();
    if !circle && best > 0.0 && length > 0.0 {
        // Every point of the arc closer than `best` lies within 2·best of
        // the point found, hence within π·best of it along the arc.
        let h = std::f64::consts::PI * best / length;
        let (t, d) = golden_minimum(
            |t| (p - arc.point_at(t)).norm(),
            (best_t - h).max(0.0),
            (best_t + h).min(1.0),
        );
        if d < best {
            best = d;
            best_t = t;
        }
    }
    *hint = best_t;
    best
}

/// Minimum of `f` on `[a, b]` by golden-section search (the distance to a
/// smooth curve near its closest point is unimodal), to 1e-12 of the
/// interval: `(argument, value)`.
fn golden_minimum(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> (f64, f64) {
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let mut c = b - r * (b - a);
    let mut d = a + r * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..60 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    if fc < fd {
        (c, fc)
    } else {
        (d, fd)
    }
}
