//! Circular, helical and spiral arcs, and their linearisation.
//!
//! An arc is kept as RS274/NGC states it: start, end, centre, plane, signed
//! sweep. Where the end radius differs slightly from the start radius (within
//! LinuxCNC's tolerance), the radius changes linearly with the angle (a
//! spiral), as LinuxCNC moves it; the helix axis moves linearly with the angle.

use crate::geom::{Plane, Vec3};
use std::f64::consts::TAU;

/// An arc in the axis frame (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arc {
    /// Start point.
    pub start: Vec3,
    /// End point.
    pub end: Vec3,
    /// Centre; its helix-axis component equals the start's.
    pub center: Vec3,
    /// The plane.
    pub plane: Plane,
    /// Signed sweep angle in radians: positive counter-clockwise (G3) in the
    /// plane's `(u, v)` axes, negative clockwise (G2). Full turns included.
    pub sweep_rad: f64,
}

/// Sweep of an arc from the start and end angles, following LinuxCNC: equal
/// angles make a full circle; `turns ≥ 1` (the P word) adds `turns − 1` circles.
pub fn sweep_angle(start_angle: f64, end_angle: f64, clockwise: bool, turns: u32) -> f64 {
    let extra = f64::from(turns.saturating_sub(1)) * TAU;
    if clockwise {
        let mut end = end_angle;
        if end >= start_angle {
            end -= TAU;
        }
        end - start_angle - extra
    } else {
        let mut end = end_angle;
        if end <= start_angle {
            end += TAU;
        }
        end - start_angle + extra
    }
}

impl Arc {
    /// Radius at the start.
    pub fn start_radius(&self) -> f64 {
        let (u, v, _) = self.plane.axes();
        (self.start[u] - self.center[u]).hypot(self.start[v] - self.center[v])
    }

    /// Radius at the end.
    pub fn end_radius(&self) -> f64 {
        let (u, v, _) = self.plane.axes();
        (self.end[u] - self.center[u]).hypot(self.end[v] - self.center[v])
    }

    /// Whether the arc turns clockwise (G2).
    pub fn clockwise(&self) -> bool {
        self.sweep_rad < 0.0
    }

    /// The point at parameter `t ∈ [0, 1]` (angle fraction); exact at both ends.
    pub fn point_at(&self, t: f64) -> Vec3 {
        if t <= 0.0 {
            return self.start;
        }
        if t >= 1.0 {
            return self.end;
        }
        let (u, v, w) = self.plane.axes();
        let a0 = (self.start[v] - self.center[v]).atan2(self.start[u] - self.center[u]);
        let r0 = self.start_radius();
        let r = r0 + (self.end_radius() - r0) * t;
        let a = a0 + self.sweep_rad * t;
        let mut p = Vec3::ZERO;
        p[u] = self.center[u] + r * a.cos();
        p[v] = self.center[v] + r * a.sin();
        p[w] = self.start[w] + (self.end[w] - self.start[w]) * t;
        p
    }

    /// Approximate length along the path (exact for circles and helices).
    pub fn length(&self) -> f64 {
        let (_, _, w) = self.plane.axes();
        let r = 0.5 * (self.start_radius() + self.end_radius());
        let planar = r * self.sweep_rad.abs();
        planar.hypot(self.end[w] - self.start[w])
    }

    /// Number of chords so that no chord departs from the arc by more than
    /// `chord_tolerance_mm` (sagitta `r·(1 − cos(Δ/2)) ≤ tol`).
    pub fn chord_count(&self, chord_tolerance_mm: f64) -> usize {
        let r = self.start_radius().max(self.end_radius());
        if r <= chord_tolerance_mm || chord_tolerance_mm <= 0.0 {
            return 1.max((self.sweep_rad.abs() / (TAU / 4.0)).ceil() as usize);
        }
        let max_step = 2.0 * (1.0 - chord_tolerance_mm / r).acos();
        let n = (self.sweep_rad.abs() / max_step).ceil();
        n.clamp(1.0, 1.0e9) as usize
    }

    /// Calls `f` with the end point of every chord, in order; the last call
    /// receives exactly [`Arc::end`].
    pub fn for_each_chord_end(&self, chord_tolerance_mm: f64, mut f: impl FnMut(Vec3)) {
        let n = self.chord_count(chord_tolerance_mm);
        for k in 1..n {
            f(self.point_at(k as f64 / n as f64));
        }
        f(self.end);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn sweep_follows_linuxcnc() {
        assert!((sweep_angle(0.0, PI / 2.0, false, 1) - PI / 2.0).abs() < 1e-15);
        assert!((sweep_angle(0.0, PI / 2.0, true, 1) + 1.5 * PI).abs() < 1e-15);
        assert!((sweep_angle(1.0, 1.0, true, 1) + TAU).abs() < 1e-15);
        assert!((sweep_angle(0.0, PI, false, 3) - (PI + 2.0 * TAU)).abs() < 1e-12);
    }

    #[test]
    fn chords_meet_the_tolerance_and_end_exactly() {
        let arc = Arc {
            start: Vec3::new(10.0, 0.0, 0.0),
            end: Vec3::new(10.0, 0.0, -1.0),
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: TAU,
        };
        let tol = 1e-4;
        let n = arc.chord_count(tol);
        // Sagitta of one chord: r(1 − cos(π/n)) must not exceed the tolerance.
        assert!(10.0 * (1.0 - (PI / n as f64).cos()) <= tol);
        assert!(10.0 * (1.0 - (PI / (n - 1) as f64).cos()) > tol);
        let mut last = Vec3::ZERO;
        let mut count = 0;
        arc.for_each_chord_end(tol, |p| {
            last = p;
            count += 1;
        });
        assert_eq!(count, n);
        assert_eq!(last, arc.end);
        let mid = arc.point_at(0.5);
        assert!((mid.x + 10.0).abs() < 1e-12 && mid.y.abs() < 1e-12);
        assert!((mid.z + 0.5).abs() < 1e-12);
    }

    #[test]
    fn zx_plane_g3_is_counter_clockwise_from_z_to_x() {
        // G18: u = Z, v = X. A quarter G3 from Z=1 (X=0) goes to X=1 (Z=0).
        let arc = Arc {
            start: Vec3::new(0.0, 0.0, 1.0),
            end: Vec3::new(1.0, 0.0, 0.0),
            center: Vec3::ZERO,
            plane: Plane::Zx,
            sweep_rad: PI / 2.0,
        };
        let mid = arc.point_at(0.5);
        let s = (0.5f64).sqrt();
        assert!((mid.x - s).abs() < 1e-12 && (mid.z - s).abs() < 1e-12);
    }
}
