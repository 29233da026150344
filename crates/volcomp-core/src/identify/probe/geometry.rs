//! Small geometry of probing: the six axis directions a probe moves along,
//! rotations as column triples, and the rigid fit of an artifact's nominal
//! points to their measured positions.

use volcomp_gcode::Vec3;

pub use crate::io::probe_log::AxisDir;

/// The axis direction `v` points along (within 1e-6), if any.
pub fn axis_direction(v: Vec3) -> Option<AxisDir> {
    let n = v.norm();
    AxisDir::ALL
        .into_iter()
        .find(|d| (v * (1.0 / n) - d.vector()).norm() < 1e-6)
}

/// A rotation as the images of the unit vectors (columns).
pub type Rotation = [Vec3; 3];

/// `R v`.
pub fn rotate(r: &Rotation, v: Vec3) -> Vec3 {
    r[0] * v.x + r[1] * v.y + r[2] * v.z
}

/// The small rotation `(I + [ω]×) R`, re-orthonormalised (ω in rad).
pub fn turn(r: &Rotation, omega: Vec3) -> Rotation {
    let c = r.map(|c| c + omega.cross(c));
    let x = c[0].normalized().unwrap_or(c[0]);
    let y = (c[1] - x * x.dot(c[1])).normalized().unwrap_or(c[1]);
    [x, y, x.cross(y)]
}

/// The rotation that turns unit vector `a` onto unit vector `b` by the
/// smallest angle (Rodrigues).
fn align(a: Vec3, b: Vec3) -> Rotation {
    let v = a.cross(b);
    let c = a.dot(b);
    let s = v.norm();
    let e = [
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
    ];
    if s < 1e-15 {
        return e;
    }
    let k = v * (1.0 / s);
    // R x = x cos θ + (k × x) sin θ + k (k·x)(1 − cos θ)
    e.map(|x| x * c + k.cross(x) * s + k * (k.dot(x) * (1.0 - c)))
}

/// The rigid motion `(R, t)` with `m ≈ R (a − ā) + t` in the least-squares
/// sense (Kabsch's SVD method, Arun, Huang & Blostein 1987), starting from
/// the nominal rotation `nominal` where the points cannot fix it: one point
/// (translation only) or points on a line (the smallest turn of the nominal
/// that aligns the line). `ā` is the mean of `a`; `t` the mean of `m`.
pub fn rigid_fit(a: &[Vec3], m: &[Vec3], nominal: &Rotation) -> (Rotation, Vec3) {
    let n = a.len().min(m.len()).max(1) as f64;
    let abar = a.iter().copied().sum::<Vec3>() * (1.0 / n);
    let mbar = m.iter().copied().sum::<Vec3>() * (1.0 / n);
    let da: Vec<Vec3> = a.iter().map(|p| *p - abar).collect();
    let dm: Vec<Vec3> = m.iter().map(|p| *p - mbar).collect();
    let spread = da.iter().map(|v| v.norm()).fold(0.0, f64::max);
    if a.len() < 2 || spread < 1e-9 {
        return (*nominal, mbar);
    }
    // Collinear artifact points: the largest offset gives the line.
    let far = da
        .iter()
        .copied()
        .fold(Vec3::ZERO, |b, v| if v.norm() > b.norm() { v } else { b });
    let u = far * (1.0 / far.norm());
    let off_line = da
        .iter()
        .map(|v| (*v - u * u.dot(*v)).norm())
        .fold(0.0, f64::max);
    if off_line < 1e-6 * spread {
        // Line: fit the measured direction (least squares along the line).
        let mut dir = Vec3::ZERO;
        for (va, vm) in da.iter().zip(&dm) {
            dir += *vm * u.dot(*va);
        }
        let want = dir.normalized().unwrap_or(rotate(nominal, u));
        let have = rotate(nominal, u);
        let r = align(have, want);
        return (nominal.map(|c| rotate(&r, c)), mbar);
    }
    let (r, _) = crate::linalg::kabsch(&da, &dm);
    (r, mbar)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_read_and_write() {
        for d in AxisDir::ALL {
            assert_eq!(AxisDir::parse(&d.label()), Some(d));
            assert_eq!(AxisDir::ALL[d.index()], d);
            assert_eq!(axis_direction(d.vector() * 3.0), Some(d));
        }
        assert_eq!(AxisDir::parse("z-"), Some(AxisDir::new(2, false)));
        assert_eq!(AxisDir::parse("+W"), None);
        assert_eq!(axis_direction(Vec3::new(1.0, 1.0, 0.0)), None);
    }

    #[test]
    fn the_rigid_fit_recovers_a_rotation_and_a_shift() {
        // Rotation 30° about Z (by hand: x → (cos, sin, 0), y → (−sin, cos, 0)).
        let (s, c) = (0.5f64, 0.75f64.sqrt());
        let r: Rotation = [
            Vec3::new(c, s, 0.0),
            Vec3::new(-s, c, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let a = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(100.0, 0.0, 0.0),
            Vec3::new(0.0, 100.0, 0.0),
            Vec3::new(100.0, 100.0, 0.0),
        ];
        let abar = Vec3::new(50.0, 50.0, 0.0);
        let t = Vec3::new(300.0, 200.0, 50.0);
        let m: Vec<Vec3> = a.iter().map(|p| rotate(&r, *p - abar) + t).collect();
        let id = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let (rf, tf) = rigid_fit(&a, &m, &id);
        assert!((tf - t).norm() < 1e-9);
        for k in 0..3 {
            assert!((rf[k] - r[k]).norm() < 1e-12, "{rf:?}");
        }
        // A line: the nominal turned onto the measured direction only.
        let line = [Vec3::ZERO, Vec3::new(100.0, 0.0, 0.0)];
        let ml: Vec<Vec3> = line.iter().map(|p| rotate(&r, *p)).collect();
        let (rl, _) = rigid_fit(&line, &ml, &id);
        assert!((rl[0] - r[0]).norm() < 1e-12);
        assert!((rl[2] - id[2]).norm() < 1e-12);
    }

    #[test]
    fn a_small_turn_stays_a_rotation() {
        let id = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let r = turn(&id, Vec3::new(0.0, 0.0, 1e-3));
        // First order: x → (1, 1e-3, 0).
        assert!((r[0] - Vec3::new(1.0, 1e-3, 0.0)).norm() < 1e-6);
        assert!(r[0].dot(r[1]).abs() < 1e-15);
        assert!((r[2].norm() - 1.0).abs() < 1e-15);
    }
}
