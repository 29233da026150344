//! The figures of the circular test [ISO 230-4], all in µm:
//!
//! * **circular deviation** `G`: the minimum radial separation of two
//!   circles concentric with the least-squares circle (LSC) of the actual
//!   path that enclose it: `max − min` of the radii about the LSC centre.
//!   `G_ccw` and `G_cw` take each run with its own LSC; the bidirectional
//!   `G` takes both runs about the LSC of both together;
//! * **circular hysteresis** `H`: the largest radial difference between the
//!   counter-clockwise and the clockwise path at the same angle, both about
//!   the LSC centre of both runs (each run interpolated linearly at the
//!   other's angles; the larger of the two ways);
//! * **radial deviation** `F`: the deviation of the actual path from the
//!   nominal radius `R`, about the LSC centre of both runs: its largest
//!   (`F_max`) and smallest (`F_min`) value.
//!
//! The LSC minimises the sum of squared distances of the points to the
//! circle (Gauss–Newton from the linearised, "limaçon" solution).

use super::{Run, Sense, Trace};

/// The figures of one trace.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Figures {
    /// Circular deviation of both runs about their common LSC (µm).
    pub g_um: f64,
    /// Circular deviation of the counter-clockwise run (µm).
    pub g_ccw_um: Option<f64>,
    /// Circular deviation of the clockwise run (µm).
    pub g_cw_um: Option<f64>,
    /// Circular hysteresis (µm); `None` with one run.
    pub h_um: Option<f64>,
    /// Largest radial deviation from the nominal radius about the LSC centre (µm).
    pub f_max_um: f64,
    /// Smallest radial deviation from the nominal radius about the LSC centre (µm).
    pub f_min_um: f64,
    /// The LSC centre of both runs relative to the pivot, `(u, v)` (µm).
    pub lsc_centre_um: [f64; 2],
    /// The LSC radius minus the nominal radius (µm).
    pub lsc_radius_um: f64,
}

/// A least-squares circle in the plane: centre `(u, v)` and radius, mm,
/// relative to the pivot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// Centre `(u, v)` relative to the pivot (mm).
    pub centre_mm: [f64; 2],
    /// Radius (mm).
    pub radius_mm: f64,
}

impl Circle {
    /// The distance of `p` to the centre minus the radius (mm).
    pub fn residual_mm(&self, p: [f64; 2]) -> f64 {
        (p[0] - self.centre_mm[0]).hypot(p[1] - self.centre_mm[1]) - self.radius_mm
    }
}

/// The points of a run in the plane, relative to the pivot (mm).
pub fn points(run: &Run, radius_mm: f64) -> Vec<[f64; 2]> {
    run.angle_deg
        .iter()
        .zip(&run.deviation_um)
        .map(|(a, d)| {
            let r = radius_mm + d * 1e-3;
            let t = a.to_radians();
            [r * t.cos(), r * t.sin()]
        })
        .collect()
}

/// The least-squares circle of `p` (at least three points not on a line),
/// starting from the nominal radius `r0_mm` about the pivot.
pub fn least_squares_circle(p: &[[f64; 2]], r0_mm: f64) -> Option<Circle> {
    if p.len() < 3 {
        return None;
    }
    let mut c = Circle {
        centre_mm: [0.0, 0.0],
        radius_mm: r0_mm,
    };
    for _ in 0..50 {
        // Gauss–Newton on ρ_i = |p_i − c| − r: ∂ρ/∂c = −(p_i − c)/|p_i − c|, ∂ρ/∂r = −1.
        let mut n = [[0.0; 3]; 3];
        let mut g = [0.0; 3];
        for q in p {
            let (du, dv) = (q[0] - c.centre_mm[0], q[1] - c.centre_mm[1]);
            let d = du.hypot(dv);
            if d == 0.0 {
                return None;
            }
            let j = [-du / d, -dv / d, -1.0];
            let rho = d - c.radius_mm;
            for a in 0..3 {
                g[a] += j[a] * rho;
                for b in 0..3 {
                    n[a][b] += j[a] * j[b];
                }
            }
        }
        let step = solve3(n, g.map(|x| -x))?;
        c.centre_mm[0] += step[0];
        c.centre_mm[1] += step[1];
        c.radius_mm += step[2];
        if step.iter().all(|s| s.abs() < 1e-13 * r0_mm.max(1.0)) {
            break;
        }
    }
    Some(c)
}

/// Solves a 3×3 system by Cramer's rule; `None` when it is singular.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if d.abs() < 1e-300 || !d.is_finite() {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut m = a;
        for r in 0..3 {
            m[r][k] = b[r];
        }
        *xk = det(m) / d;
    }
    Some(x)
}

/// The radial deviations (µm) of `run` about `c`.
pub fn about(run: &Run, radius_mm: f64, c: &Circle) -> Vec<f64> {
    points(run, radius_mm)
        .iter()
        .map(|p| c.residual_mm(*p) * 1e3)
        .collect()
}

fn spread(values: &[f64]) -> f64 {
    let (lo, hi) = min_max(values);
    hi - lo
}

fn min_max(values: &[f64]) -> (f64, f64) {
    values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}

/// `values` (at `angles_deg`) interpolated linearly, periodically, at `at_deg`.
pub fn interpolate_periodic(angles_deg: &[f64], values: &[f64], at_deg: f64) -> f64 {
    let mut idx: Vec<usize> = (0..angles_deg.len()).collect();
    idx.sort_by(|&a, &b| angles_deg[a].total_cmp(&angles_deg[b]));
    interpolate_sorted(angles_deg, values, &idx, at_deg)
}

fn interpolate_sorted(angles_deg: &[f64], values: &[f64], idx: &[usize], at_deg: f64) -> f64 {
    let a = at_deg.rem_euclid(360.0);
    let n = idx.len();
    let k = idx.partition_point(|&i| angles_deg[i] <= a);
    let (i0, i1) = (idx[(k + n - 1) % n], idx[k % n]);
    let (a0, mut a1) = (angles_deg[i0], angles_deg[i1]);
    let mut x = a;
    if a1 <= a0 {
        a1 += 360.0;
        if x < a0 {
            x += 360.0;
        }
    }
    let w = if a1 > a0 { (x - a0) / (a1 - a0) } else { 0.0 };
    values[i0] + w * (values[i1] - values[i0])
}

/// The largest `|a(θ) − b(θ)|` over `a`'s angles, `b` interpolated there.
fn largest_difference(aa: &[f64], av: &[f64], ba: &[f64], bv: &[f64]) -> f64 {
    let mut idx: Vec<usize> = (0..ba.len()).collect();
    idx.sort_by(|&x, &y| ba[x].total_cmp(&ba[y]));
    aa.iter()
        .zip(av)
        .map(|(&t, &v)| (v - interpolate_sorted(ba, bv, &idx, t)).abs())
        .fold(0.0, f64::max)
}

/// The figures of `trace` (at least three samples in every run).
pub fn figures(trace: &Trace) -> Option<Figures> {
    let r = trace.radius_mm;
    let all: Vec<[f64; 2]> = trace.runs.iter().flat_map(|run| points(run, r)).collect();
    let common = least_squares_circle(&all, r)?;
    let own = |s: Sense| -> Option<Option<f64>> {
        match trace.run(s) {
            None => Some(None),
            Some(run) => {
                let c = least_squares_circle(&points(run, r), r)?;
                Some(Some(spread(&about(run, r, &c))))
            }
        }
    };
    let about_common: Vec<Vec<f64>> = trace
        .runs
        .iter()
        .map(|run| about(run, r, &common))
        .collect();
    let radial: Vec<f64> = about_common.iter().flatten().copied().collect();
    let g_um = spread(&radial);
    let h_um = match (trace.run(Sense::Ccw), trace.run(Sense::Cw)) {
        (Some(a), Some(b)) => {
            let ia = trace.runs.iter().position(|x| x.sense == Sense::Ccw)?;
            let ib = trace.runs.iter().position(|x| x.sense == Sense::Cw)?;
            let (va, vb) = (&about_common[ia], &about_common[ib]);
            Some(
                largest_difference(&a.angle_deg, va, &b.angle_deg, vb).max(largest_difference(
                    &b.angle_deg,
                    vb,
                    &a.angle_deg,
                    va,
                )),
            )
        }
        _ => None,
    };
    // F: about the LSC centre, against the nominal radius.
    let shift_um = (common.radius_mm - r) * 1e3;
    let (f_min_um, f_max_um) = min_max(&radial);
    Some(Figures {
        g_um,
        g_ccw_um: own(Sense::Ccw)?,
        g_cw_um: own(Sense::Cw)?,
        h_um,
        f_max_um: f_max_um + shift_um,
        f_min_um: f_min_um + shift_um,
        lsc_centre_um: [common.centre_mm[0] * 1e3, common.centre_mm[1] * 1e3],
        lsc_radius_um: shift_um,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ballbar::Plane;

    fn trace(runs: Vec<Run>) -> Trace {
        Trace {
            plane: Plane::XY,
            radius_mm: 100.0,
            centre_mm: [0.0; 3],
            feed_mm_per_min: 1000.0,
            runs,
        }
    }

    /// A worked trace by hand: eight points per run at 0°, 45°, …, 315°.
    /// ccw: 2, 1, −1, 0, 2, 1, −1, 0 µm (period 180°: no first harmonic,
    /// so the LSC centre is the pivot; mean 0.5 → LSC radius R + 0.5 µm);
    /// cw: the same plus 1 µm at every point (mean 1.5).
    /// Both together: mean 1.0, no first harmonic. About the common LSC:
    /// ccw 1, 0, −2, −1, …; cw 2, 1, −1, 0, … → G = 2 − (−2) = 4;
    /// G_ccw = G_cw = 2 − (−1) = 3; H = 1 everywhere;
    /// F about the LSC centre against R: max 3, min −1.
    #[test]
    fn a_worked_trace_by_hand() {
        let angles: Vec<f64> = (0..8).map(|k| 45.0 * k as f64).collect();
        let ccw = vec![2.0, 1.0, -1.0, 0.0, 2.0, 1.0, -1.0, 0.0];
        let cw: Vec<f64> = ccw.iter().map(|d| d + 1.0).collect();
        let t = trace(vec![
            Run {
                sense: Sense::Ccw,
                angle_deg: angles.clone(),
                deviation_um: ccw,
            },
            Run {
                sense: Sense::Cw,
                angle_deg: angles,
                deviation_um: cw,
            },
        ]);
        let f = figures(&t).unwrap();
        // The exact LSC differs from the limaçon one by O(e²/R) = 1e-8 µm.
        let near = |a: f64, b: f64| (a - b).abs() < 1e-6;
        assert!(near(f.g_um, 4.0), "{f:?}");
        assert!(near(f.g_ccw_um.unwrap(), 3.0));
        assert!(near(f.g_cw_um.unwrap(), 3.0));
        assert!(near(f.h_um.unwrap(), 1.0));
        assert!(near(f.f_max_um, 3.0) && near(f.f_min_um, -1.0), "{f:?}");
        assert!(near(f.lsc_radius_um, 1.0));
        assert!(f.lsc_centre_um.iter().all(|c| c.abs() < 1e-6));
    }

    /// A circle shifted by (3, −4) µm has G = 0 and its LSC centre there.
    #[test]
    fn an_offset_circle_is_round() {
        let angles: Vec<f64> = (0..360).map(|k| k as f64).collect();
        let (cu, cv, r) = (3e-3, -4e-3, 100.0);
        let dev: Vec<f64> = angles
            .iter()
            .map(|a| {
                let t = a.to_radians();
                // Distance from the pivot of the point at angle t (about the
                // pivot) on the shifted circle.
                let (c, s) = (t.cos(), t.sin());
                let b = cu * c + cv * s;
                let d = b + (b * b - (cu * cu + cv * cv) + r * r).sqrt();
                (d - r) * 1e3
            })
            .collect();
        let t = trace(vec![Run {
            sense: Sense::Ccw,
            angle_deg: angles,
            deviation_um: dev,
        }]);
        let f = figures(&t).unwrap();
        assert!(f.g_um < 1e-6, "{f:?}");
        assert!((f.lsc_centre_um[0] - 3.0).abs() < 1e-6);
        assert!((f.lsc_centre_um[1] + 4.0).abs() < 1e-6);
        assert!(f.h_um.is_none() && f.g_cw_um.is_none());
    }

    #[test]
    fn periodic_interpolation_wraps() {
        let a = [350.0, 10.0, 180.0];
        let v = [1.0, 3.0, 0.0];
        assert!((interpolate_periodic(&a, &v, 0.0) - 2.0).abs() < 1e-12);
        assert!((interpolate_periodic(&a, &v, 355.0) - 1.5).abs() < 1e-12);
        assert!((interpolate_periodic(&a, &v, 95.0) - 1.5).abs() < 1e-12);
    }
}
