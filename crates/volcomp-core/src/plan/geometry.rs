//! The geometry of the planner's segments: straight lines, circles (with
//! a helix along the normal and a spiral in the plane) and the spherical
//! blend arcs the planner puts into corners.
//!
//! A circle is kept as LinuxCNC's posemath keeps it (`pmCircleInit`,
//! `pmCirclePoint`, `pmCircleStretch` in src/libnml/posemath/_posemath.c;
//! the arc-length fit `findSpiralArcLengthFit` and the effective radius
//! `pmCircleEffectiveMinRadius` in src/emc/tp/blendmath.c; [LinuxCNC tp]):
//! the centre in the start's plane, the radius at the start, the spiral as
//! the end radius minus the start radius spread linearly over the angle,
//! the helix as the end's offset along the normal spread likewise. Its path
//! length is the quadratic fit of the planar arc length against the angle
//! (exact for a circle) combined with the helix rise.

use volcomp_gcode::Vec3;

/// Smallest double step (`DOUBLE_FUZZ` in posemath.h).
pub(crate) const DOUBLE_FUZZ: f64 = 2.220_446_049_250_313e-16;
/// Displacements below this are no motion (`CART_FUZZ` in posemath.h, mm).
pub(crate) const CART_FUZZ_MM: f64 = 1e-8;

/// `v` scaled to unit length; `v` itself when it has none.
pub(crate) fn unit(v: Vec3) -> Vec3 {
    let n = v.norm();
    if n > 0.0 {
        v / n
    } else {
        v
    }
}

/// The component of `v` in the plane normal to `n` (unit).
fn plane_part(v: Vec3, n: Vec3) -> Vec3 {
    v - n * (v.dot(n) / n.dot(n))
}

/// A straight segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Line {
    pub start: Vec3,
    pub end: Vec3,
    /// Unit direction (X when the line has no length, as posemath sets it).
    pub u: Vec3,
    pub length_mm: f64,
}

impl Line {
    pub fn new(start: Vec3, end: Vec3) -> Line {
        let d = end - start;
        let length_mm = d.norm();
        let u = if d.max_abs() <= CART_FUZZ_MM {
            Vec3::new(1.0, 0.0, 0.0)
        } else {
            d / length_mm
        };
        Line {
            start,
            end,
            u,
            length_mm,
        }
    }

    /// The line shortened (or lengthened) to `len_mm`, keeping its end
    /// (`keep_end`) or its start.
    pub fn stretched(&self, len_mm: f64, keep_end: bool) -> Line {
        let mut l = *self;
        if keep_end {
            l.start = l.end - l.u * len_mm;
        } else {
            l.end = l.start + l.u * len_mm;
        }
        l.length_mm = len_mm;
        l
    }
}

/// A circle, helix or spiral arc about `center`, turning counter-clockwise
/// about `normal` through `angle_rad`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Circle {
    pub center: Vec3,
    /// Unit normal: the arc turns counter-clockwise about it.
    pub normal: Vec3,
    /// Radius at the start.
    pub radius_mm: f64,
    /// Start minus centre (length `radius_mm`).
    pub r_tan: Vec3,
    /// `normal × r_tan`.
    pub r_perp: Vec3,
    /// The end's offset along the normal.
    pub r_helix: Vec3,
    /// End radius minus start radius.
    pub spiral_mm: f64,
    /// Swept angle (full turns included), > 0.
    pub angle_rad: f64,
}

/// The quadratic fit of a spiral's planar length against its angle,
/// `s(φ) = b0 φ² + b1 φ` (blendmath.c, `findSpiralArcLengthFit`): it
/// matches the slope `√(r² + (dr/dφ)²)` at both ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SpiralFit {
    pub b0: f64,
    pub b1: f64,
    pub planar_length_mm: f64,
}

impl Circle {
    /// The circle from `start` about `center` to `end`, turning
    /// counter-clockwise about `normal` (any length) through `angle_rad`
    /// (full turns included). The centre is moved along the normal into
    /// the start's plane.
    pub fn new(start: Vec3, end: Vec3, center: Vec3, normal: Vec3, angle_rad: f64) -> Circle {
        let normal = unit(normal);
        let center = center + normal * (start - center).dot(normal);
        let r_tan = start - center;
        let radius_mm = r_tan.norm();
        let rel_end = end - center;
        let r_end = plane_part(rel_end, normal);
        let r_helix = rel_end - r_end;
        let spiral_mm = r_end.norm() - radius_mm;
        Circle {
            center,
            normal,
            radius_mm,
            r_tan,
            r_perp: normal.cross(r_tan),
            r_helix,
            spiral_mm,
            angle_rad: if angle_rad == 0.0 {
                1e-6 / 2.0
            } else {
                angle_rad
            },
        }
    }

    /// The point at angle `a` from the start (`pmCirclePoint`).
    pub fn point(&self, a: f64) -> Vec3 {
        let radial = self.r_tan * a.cos() + self.r_perp * a.sin();
        let scale = a / self.angle_rad;
        let p = radial + unit(radial) * (scale * self.spiral_mm) + self.r_helix * scale;
        self.center + p
    }

    /// The arc-length fit of the planar part.
    pub fn fit(&self) -> SpiralFit {
        let mut coef = self.spiral_mm / self.angle_rad;
        let mut r_min = self.radius_mm;
        if self.spiral_mm < 0.0 {
            // Parameterised from the end, where the radius is smallest.
            coef = -coef;
            r_min += self.spiral_mm;
        }
        let slope_start = r_min.hypot(coef);
        let slope_end = (r_min + coef * self.angle_rad).hypot(coef);
        let b0 = (slope_end - slope_start) / (2.0 * self.angle_rad);
        let b1 = slope_start;
        SpiralFit {
            b0,
            b1,
            planar_length_mm: b0 * self.angle_rad * self.angle_rad + b1 * self.angle_rad,
        }
    }

    /// Path length: the planar fit combined with the helix rise
    /// (`pmCircle9Target`, tc.c).
    pub fn length_mm(&self) -> f64 {
        self.fit().planar_length_mm.hypot(self.r_helix.norm())
    }

    /// Unit tangent at angle `a` (`pmCircleTangentVector`, tc.c): the
    /// planar turn, the helix rise and the spiral's radial drift.
    pub fn tangent(&self, a: f64) -> Vec3 {
        let radial = self.point(a) - self.center;
        let turn = self.normal.cross(radial);
        let rise = self.r_helix * (1.0 / self.angle_rad);
        let drift = unit(radial) * (self.spiral_mm / self.angle_rad);
        unit(turn + rise + drift)
    }

    /// Unit tangent at the start.
    pub fn start_tangent(&self) -> Vec3 {
        self.tangent(0.0)
    }

    /// Unit tangent at the end.
    pub fn end_tangent(&self) -> Vec3 {
        self.tangent(self.angle_rad)
    }

    /// The smallest radius of curvature, a spiral's and a helix's larger
    /// than the circle's (`pmCircleEffectiveMinRadius`, blendmath.c).
    pub fn effective_min_radius_mm(&self) -> f64 {
        let dr = self.spiral_mm / self.angle_rad;
        let h2 = self.r_helix.norm_squared();
        let n_inner = dr * dr + self.radius_mm * self.radius_mm;
        let den = n_inner + dr * dr;
        let r_spiral = (n_inner * n_inner * n_inner).sqrt() / den;
        h2 / r_spiral + r_spiral
    }

    /// The circle cut to `new_angle` (radians), keeping its end
    /// (`keep_end`) or its start (`pmCircleStretch`); `None` for a helix,
    /// which LinuxCNC does not cut.
    pub fn stretched(&self, new_angle: f64, keep_end: bool) -> Option<Circle> {
        if new_angle <= DOUBLE_FUZZ || self.r_helix.norm_squared() > 1e-6 {
            return None;
        }
        let mut c = *self;
        if keep_end {
            let new_start = self.point(self.angle_rad - new_angle);
            c.r_tan = new_start - c.center;
            c.r_perp = c.normal.cross(c.r_tan);
            c.radius_mm = c.r_tan.norm();
        }
        c.spiral_mm *= new_angle / self.angle_rad;
        c.angle_rad = new_angle;
        Some(c)
    }

    /// The direction of a segment's acceleration as it starts on this
    /// circle at speed `v_mm_s` with tangential acceleration `a_mm_s2`
    /// (`tcCircleStartAccelUnitVector`, tc.c: the tangential part plus the
    /// normal part at half the speed).
    pub fn start_accel_direction(&self, a_mm_s2: f64, v_mm_s: f64) -> Vec3 {
        let p0 = self.point(0.0);
        let tan = unit(self.normal.cross(p0 - self.center));
        let perp = unit(self.center - p0);
        unit(tan * a_mm_s2 + perp * ((0.5 * v_mm_s).powi(2) / self.radius_mm))
    }

    /// The direction of the acceleration as a segment ends on this circle
    /// (`tcCircleEndAccelUnitVector`: the planar tangent).
    pub fn end_accel_direction(&self) -> Vec3 {
        let p1 = self.point(self.angle_rad);
        unit(self.normal.cross(p1 - self.center))
    }
}

/// A spherical blend arc (src/emc/tp/spherical_arc.c), possibly preceded
/// by the rest of the line it replaced (`line_length_mm`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct BlendArc {
    pub radius_mm: f64,
    pub angle_rad: f64,
    pub line_length_mm: f64,
}

impl BlendArc {
    /// The arc from `start` to `end` about `center` (`arcInitFromPoints`);
    /// `None` where LinuxCNC refuses it (radius or angle too small).
    pub fn from_points(start: Vec3, end: Vec3, center: Vec3, line_length_mm: f64) -> Option<Self> {
        const ARC_MIN_RADIUS: f64 = 1e-12;
        const ARC_MIN_ANGLE: f64 = 1e-6;
        let (r0, r1) = ((start - center).norm(), (end - center).norm());
        if r0 < ARC_MIN_RADIUS || r1 < ARC_MIN_RADIUS {
            return None;
        }
        let dot = ((start - center) / r0).dot((end - center) / r1);
        let angle_rad = dot.clamp(-1.0, 1.0).acos();
        if angle_rad < ARC_MIN_ANGLE {
            return None;
        }
        Some(BlendArc {
            radius_mm: r0,
            angle_rad,
            line_length_mm,
        })
    }

    /// Length along the path (`arcLength`).
    pub fn length_mm(&self) -> f64 {
        self.radius_mm * self.angle_rad + self.line_length_mm
    }
}

/// A blend arc's unit tangent at its start or end (`arcTangent`): the
/// binormal crossed with the radius vector there.
pub(crate) fn arc_tangent(binormal: Vec3, radius_vec: Vec3) -> Vec3 {
    unit(binormal.cross(radius_vec))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI, TAU};

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn a_full_circle_has_length_two_pi_r_and_tangents_along_the_turn() {
        // G2 X25 Y0 I-25 from (25, 0): clockwise about +Z = counter-
        // clockwise about −Z.
        let s = Vec3::new(25.0, 0.0, 0.0);
        let c = Circle::new(s, s, Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), TAU);
        assert!(close(c.length_mm(), TAU * 25.0, 1e-9), "{}", c.length_mm());
        let t = c.start_tangent();
        assert!(close(t.y, -1.0, 1e-12) && close(t.x, 0.0, 1e-12), "{t:?}");
        assert!(close(c.effective_min_radius_mm(), 25.0, 1e-12));
        let q = c.point(FRAC_PI_2);
        assert!(close(q.y, -25.0, 1e-9) && close(q.x, 0.0, 1e-9), "{q:?}");
    }

    #[test]
    fn a_helix_adds_its_rise_and_a_spiral_its_drift() {
        // Half a turn of radius 10 rising 5: length √((10π)² + 5²).
        let c = Circle::new(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(-10.0, 0.0, 5.0),
            Vec3::new(0.0, 0.0, 3.0),
            Vec3::new(0.0, 0.0, 1.0),
            PI,
        );
        assert!(close(c.center.z, 0.0, 1e-12));
        assert!(close(c.length_mm(), (10.0 * PI).hypot(5.0), 1e-9));
        // A spiral from r = 10 to r = 11 over a half turn: the fit lies
        // between the two circles' lengths, above the mean radius' length.
        let sp = Circle::new(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(-11.0, 0.0, 0.0),
            Vec3::ZERO,
            Vec3::new(0.0, 0.0, 1.0),
            PI,
        );
        assert!(close(sp.spiral_mm, 1.0, 1e-12));
        let l = sp.length_mm();
        assert!(l > 10.5 * PI && l < 11.0 * PI, "{l}");
        let e = sp.point(PI);
        assert!(close(e.x, -11.0, 1e-9) && close(e.y, 0.0, 1e-9), "{e:?}");
    }

    #[test]
    fn cutting_a_circle_keeps_the_end_or_the_start() {
        let c = Circle::new(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
            Vec3::ZERO,
            Vec3::new(0.0, 0.0, 1.0),
            FRAC_PI_2,
        );
        let tail = c.stretched(FRAC_PI_2 / 2.0, true).unwrap();
        let e = tail.point(tail.angle_rad);
        assert!(close(e.x, 0.0, 1e-9) && close(e.y, 10.0, 1e-9), "{e:?}");
        let s = tail.point(0.0);
        let h = 10.0 * std::f64::consts::FRAC_1_SQRT_2;
        assert!(close(s.x, h, 1e-9) && close(s.y, h, 1e-9), "{s:?}");
        let head = c.stretched(FRAC_PI_2 / 2.0, false).unwrap();
        assert_eq!(head.point(0.0), c.point(0.0));
    }
}
