//! Cross-checks against the `curvo` crate (an independent NURBS implementation).

use super::*;
use crate::rng::Rng;
use curvo::prelude::{Interpolation, NurbsCurve3D, NurbsSurface3D};
use nalgebra::{Point3, Point4};

fn surfaces() -> (BSplineSurface<3>, NurbsSurface3D<f64>) {
    let knots_u = vec![0.0, 0.0, 0.0, 0.0, 0.25, 0.6, 0.6, 1.0, 1.0, 1.0, 1.0];
    let knots_v = vec![0.0, 0.0, 0.0, 0.3, 0.5, 1.0, 1.0, 1.0];
    let (cu, cv) = (7, 5);
    let mut rng = Rng::new(42);
    let control: Vec<[f64; 3]> = (0..cu * cv)
        .map(|k| {
            let (i, j) = (k / cv, k % cv);
            [
                12.0 * i as f64 + 2.0 * rng.uniform(),
                9.0 * j as f64 + 2.0 * rng.uniform(),
                6.0 * (rng.uniform() - 0.5),
            ]
        })
        .collect();
    let ours = BSplineSurface::new(
        3,
        2,
        knots_u.clone(),
        knots_v.clone(),
        cu,
        cv,
        control.clone(),
    )
    .unwrap();
    let net: Vec<Vec<Point4<f64>>> = (0..cu)
        .map(|i| {
            (0..cv)
                .map(|j| {
                    let c = control[i * cv + j];
                    Point4::new(c[0], c[1], c[2], 1.0)
                })
                .collect()
        })
        .collect();
    let theirs = NurbsSurface3D::new(3, 2, knots_u, knots_v, net);
    (ours, theirs)
}

#[test]
fn points_and_derivatives_agree_with_curvo() {
    let (ours, theirs) = surfaces();
    let mut rng = Rng::new(1);
    for k in 0..300 {
        let (u, v) = if k < 4 {
            ([0.0, 1.0][k % 2], [0.0, 1.0][k / 2])
        } else {
            (rng.uniform(), rng.uniform())
        };
        let p = ours.point(u, v);
        let q = theirs.point_at(u, v);
        for c in 0..3 {
            assert!((p[c] - q[c]).abs() < 1e-10, "point at ({u}, {v})");
        }
        let d = ours.derivatives(u, v, 2);
        let e = theirs.rational_derivatives(u, v, 2);
        for a in 0..=2 {
            for b in 0..=2 - a {
                for c in 0..3 {
                    let (x, y) = (d[a][b][c], e[a][b][c]);
                    assert!(
                        (x - y).abs() < 1e-8 * (1.0 + y.abs()),
                        "S_u{a}v{b} at ({u}, {v}): {x} vs {y}"
                    );
                }
            }
        }
    }
}

#[test]
fn closest_points_are_never_farther_than_curvos() {
    let (ours, theirs) = surfaces();
    let index = ProjectionIndex::new(&ours, 8);
    let mut rng = Rng::new(5);
    for _ in 0..40 {
        let (u, v) = (rng.uniform(), rng.uniform());
        let base = ours.point(u, v);
        let target = [
            base[0] + 4.0 * (rng.uniform() - 0.5),
            base[1] + 4.0 * (rng.uniform() - 0.5),
            base[2] + 4.0 * (rng.uniform() - 0.5),
        ];
        let mine = ours.closest_point(&index, target, 50.0, None).unwrap();
        // curvo's own start (an adaptive tessellation) is slow in tests:
        // start it from the nearest node of a brute-force 41 × 41 grid.
        let mut hint = (0.0, 0.0);
        let mut best = f64::INFINITY;
        for i in 0..=40 {
            for j in 0..=40 {
                let (a, b) = (i as f64 / 40.0, j as f64 / 40.0);
                let p = ours.point(a, b);
                let d = (0..3).map(|c| (p[c] - target[c]).powi(2)).sum::<f64>();
                if d < best {
                    best = d;
                    hint = (a, b);
                }
            }
        }
        let (cu, cv) = theirs
            .find_closest_parameter(&Point3::new(target[0], target[1], target[2]), Some(hint))
            .unwrap();
        let q = theirs.point_at(cu, cv);
        let theirs_d =
            ((q[0] - target[0]).powi(2) + (q[1] - target[1]).powi(2) + (q[2] - target[2]).powi(2))
                .sqrt();
        assert!(
            mine.distance <= theirs_d + 1e-9,
            "{} > curvo's {theirs_d}",
            mine.distance
        );
    }
}

#[test]
fn surface_interpolation_rows_equal_curvos_curve_interpolation() {
    // An extruded mesh: every row along u is the same polyline shifted in
    // y, so A9.3's averaged chord-length parameters are that polyline's,
    // and each iso-curve v = v_l of the A9.4 surface must be the curve
    // curvo interpolates through row l (chord length, averaged knots).
    let xs = [0.0, 3.0, 7.5, 9.0, 14.0, 20.0, 21.0, 30.0];
    let zs = [0.0, 1.5, -0.5, 2.0, 2.5, 0.0, 1.0, -1.0];
    let (cu, cv) = (xs.len(), 4);
    let mut pts = Vec::new();
    for i in 0..cu {
        for j in 0..cv {
            pts.push([xs[i], 10.0 * j as f64, zs[i]]);
        }
    }
    let s = interpolate(&pts, cu, cv, 3, 3, &Parameterization::ChordLength).unwrap();
    let (_, vl) = mesh_params(&pts, cu, cv, &Parameterization::ChordLength).unwrap();
    let row: Vec<Point3<f64>> = (0..cu).map(|i| Point3::new(xs[i], 0.0, zs[i])).collect();
    let curve = NurbsCurve3D::<f64>::interpolate(&row, 3).unwrap();
    for k in 0..=200 {
        let t = k as f64 / 200.0;
        let c = curve.point_at(t);
        for (j, v) in vl.iter().enumerate() {
            let p = s.point(t, *v);
            assert!(
                (p[0] - c[0]).abs() < 1e-9 && (p[2] - c[2]).abs() < 1e-9,
                "t = {t}"
            );
            assert!((p[1] - 10.0 * j as f64).abs() < 1e-9);
        }
    }
}
