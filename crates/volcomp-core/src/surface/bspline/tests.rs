//! Unit tests of the B-spline module against closed forms (The NURBS Book's
//! worked examples, polynomial reproduction, partition of unity, finite
//! differences).

use super::eval::{norm3, sub3};
use super::*;
use crate::rng::Rng;

/// A cubic × quadratic surface with non-uniform interior knots.
fn sample_surface() -> BSplineSurface<3> {
    let knots_u = vec![0.0, 0.0, 0.0, 0.0, 0.3, 0.55, 1.0, 1.0, 1.0, 1.0];
    let knots_v = vec![0.0, 0.0, 0.0, 0.4, 1.0, 1.0, 1.0];
    let (cu, cv) = (6, 4);
    let mut rng = Rng::new(7);
    let control = (0..cu * cv)
        .map(|k| {
            let (i, j) = (k / cv, k % cv);
            [
                10.0 * i as f64 + rng.uniform(),
                8.0 * j as f64 + rng.uniform(),
                5.0 * (rng.uniform() - 0.5),
            ]
        })
        .collect();
    BSplineSurface::new(3, 2, knots_u, knots_v, cu, cv, control).unwrap()
}

#[test]
fn span_search_matches_the_definition() {
    let knots = [0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 4.0, 5.0, 5.0, 5.0];
    // The book's example 2.3: n = 7, p = 2, u = 5/2 lies in span 4.
    assert_eq!(find_span(7, 2, 2.5, &knots), 4);
    assert_eq!(find_span(7, 2, 0.0, &knots), 2);
    assert_eq!(find_span(7, 2, 4.0, &knots), 7);
    assert_eq!(find_span(7, 2, 5.0, &knots), 7);
    assert_eq!(find_span(7, 2, -1.0, &knots), 2);
}

#[test]
fn basis_matches_the_book_example() {
    // Example 2.3: N_{2,2}(5/2) = 1/8, N_{3,2} = 6/8, N_{4,2} = 1/8.
    let knots = [0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 4.0, 5.0, 5.0, 5.0];
    let mut n = [0.0; MAX_ORDER];
    basis_funs(4, 2.5, 2, &knots, &mut n);
    assert!((n[0] - 0.125).abs() < 1e-15);
    assert!((n[1] - 0.75).abs() < 1e-15);
    assert!((n[2] - 0.125).abs() < 1e-15);
    // Derivatives (eq. 2.9 there): N'_{2,2} = −1/2, N'_{3,2} = 0, N'_{4,2} = 1/2.
    let mut d = [[0.0; MAX_ORDER]; MAX_DERIVATIVE + 1];
    ders_basis_funs(4, 2.5, 2, 2, &knots, &mut d);
    assert!((d[1][0] + 0.5).abs() < 1e-15 && d[1][1].abs() < 1e-15);
    assert!((d[1][2] - 0.5).abs() < 1e-15);
    assert!((d[2][0] - 1.0).abs() < 1e-15 && (d[2][1] + 2.0).abs() < 1e-15);
}

#[test]
fn partition_of_unity_and_derivative_sums() {
    let mut rng = Rng::new(1);
    let knots = [0.0, 0.0, 0.0, 0.0, 0.2, 0.2, 0.7, 1.0, 1.0, 1.0, 1.0];
    for _ in 0..200 {
        let u = rng.uniform();
        let i = find_span(6, 3, u, &knots);
        let mut d = [[0.0; MAX_ORDER]; MAX_DERIVATIVE + 1];
        ders_basis_funs(i, u, 3, 2, &knots, &mut d);
        let s0: f64 = d[0][..4].iter().sum();
        let s1: f64 = d[1][..4].iter().sum();
        let s2: f64 = d[2][..4].iter().sum();
        assert!((s0 - 1.0).abs() < 1e-14, "{s0}");
        assert!(s1.abs() < 1e-11 && s2.abs() < 1e-9, "{s1} {s2}");
        assert!(d[0][..4].iter().all(|x| *x >= -1e-15));
    }
}

#[test]
fn derivatives_match_finite_differences() {
    let s = sample_surface();
    let mut rng = Rng::new(3);
    let h = 1e-6;
    for _ in 0..50 {
        let (u, v) = (0.05 + 0.9 * rng.uniform(), 0.05 + 0.9 * rng.uniform());
        let d = s.derivatives(u, v, 2);
        let p = s.point(u, v);
        for c in 0..3 {
            assert!((d[0][0][c] - p[c]).abs() < 1e-12);
        }
        let fd = |du: f64, dv: f64| s.derivatives(u + du, v + dv, 1);
        let (up, um) = (fd(h, 0.0), fd(-h, 0.0));
        let (vp, vm) = (fd(0.0, h), fd(0.0, -h));
        for c in 0..3 {
            let su = (up[0][0][c] - um[0][0][c]) / (2.0 * h);
            let sv = (vp[0][0][c] - vm[0][0][c]) / (2.0 * h);
            let suu = (up[1][0][c] - um[1][0][c]) / (2.0 * h);
            let suv = (vp[1][0][c] - vm[1][0][c]) / (2.0 * h);
            let svv = (vp[0][1][c] - vm[0][1][c]) / (2.0 * h);
            let tol = |x: f64| 1e-5 * (1.0 + x.abs());
            assert!((d[1][0][c] - su).abs() < tol(su), "Su {u} {v}");
            assert!((d[0][1][c] - sv).abs() < tol(sv), "Sv");
            assert!((d[2][0][c] - suu).abs() < tol(suu), "Suu");
            assert!((d[1][1][c] - suv).abs() < tol(suv), "Suv");
            assert!((d[0][2][c] - svv).abs() < tol(svv), "Svv");
        }
    }
}

#[test]
fn interpolation_reproduces_a_biquadratic_exactly() {
    // x, y affine in the parameters and z quadratic in each: any degree ≥ 2
    // interpolant with uniform parameters reproduces it (polynomial
    // reproduction), between the mesh points too.
    let f = |x: f64, y: f64| 0.01 * x * x - 0.02 * x * y + 0.003 * y * y + 0.5 * x - 2.0;
    let (cu, cv) = (7, 5);
    let mut pts = Vec::new();
    for i in 0..cu {
        for j in 0..cv {
            let (x, y) = (
                100.0 * i as f64 / (cu - 1) as f64,
                60.0 * j as f64 / (cv - 1) as f64,
            );
            pts.push([x, y, f(x, y)]);
        }
    }
    for (p, q) in [(2, 2), (3, 3), (3, 2)] {
        let s = interpolate(&pts, cu, cv, p, q, &Parameterization::Uniform).unwrap();
        let mut rng = Rng::new(5);
        for _ in 0..100 {
            let (u, v) = (rng.uniform(), rng.uniform());
            let pt = s.point(u, v);
            assert!((pt[0] - 100.0 * u).abs() < 1e-10 && (pt[1] - 60.0 * v).abs() < 1e-10);
            assert!((pt[2] - f(pt[0], pt[1])).abs() < 1e-10, "degree ({p},{q})");
        }
    }
    // A bilinear mesh with degree 1 is reproduced too.
    let s = interpolate(&pts, cu, cv, 1, 1, &Parameterization::Uniform).unwrap();
    for (k, p) in pts.iter().enumerate() {
        let (i, j) = (k / cv, k % cv);
        let q = s.point(i as f64 / (cu - 1) as f64, j as f64 / (cv - 1) as f64);
        assert!((0..3).all(|c| (q[c] - p[c]).abs() < 1e-10));
    }
}

#[test]
fn interpolation_passes_through_every_mesh_point() {
    let mut rng = Rng::new(11);
    let (cu, cv) = (8, 6);
    let pts: Vec<[f64; 3]> = (0..cu * cv)
        .map(|k| {
            let (i, j) = (k / cv, k % cv);
            [
                i as f64 * 5.0 + rng.uniform(),
                j as f64 * 4.0 + rng.uniform(),
                3.0 * rng.uniform(),
            ]
        })
        .collect();
    for kind in [Parameterization::ChordLength, Parameterization::Centripetal] {
        let s = interpolate(&pts, cu, cv, 3, 3, &kind).unwrap();
        let (uk, vl) = mesh_params(&pts, cu, cv, &kind).unwrap();
        for i in 0..cu {
            for j in 0..cv {
                let q = s.point(uk[i], vl[j]);
                let p = pts[i * cv + j];
                assert!((0..3).all(|c| (q[c] - p[c]).abs() < 1e-9), "{kind:?}");
            }
        }
    }
}

#[test]
fn least_squares_reproduces_what_the_space_contains_and_smooths_noise() {
    // A bicubic polynomial field lies in every bicubic spline space:
    // least squares without penalty recovers it exactly.
    let f = |u: f64, v: f64| 2.0 + u - 3.0 * v * v + u * u * u * v - 0.5 * u * v;
    let mut rng = Rng::new(21);
    let uv: Vec<(f64, f64)> = (0..200).map(|_| (rng.uniform(), rng.uniform())).collect();
    // Bicubic least squares of `g` at the points, `spans` knot spans per
    // direction, with `penalty`.
    let fit_of = |g: &dyn Fn(f64, f64) -> f64, spans: [usize; 2], penalty: f64| {
        let vals: Vec<[f64; 1]> = uv.iter().map(|(u, v)| [g(*u, *v)]).collect();
        let [su, sv] = spans.map(|n| uniform_knots(0.0, 1.0, n, 3));
        fit_least_squares(&uv, &vals, 3, 3, su, sv, penalty).unwrap()
    };
    let fit = fit_of(&f, [3, 2], 0.0);
    for _ in 0..50 {
        let (u, v) = (rng.uniform(), rng.uniform());
        assert!((fit.surface.point(u, v)[0] - f(u, v)).abs() < 1e-9);
    }
    assert!(fit.residuals.iter().all(|r| r[0].abs() < 1e-9));
    // The penalty's null space holds the linear fields: still exact for one.
    let g = |u: f64, v: f64| 1.0 + 2.0 * u - v;
    let fit = fit_of(&g, [4, 4], 1e-3);
    assert!(fit.residuals.iter().all(|r| r[0].abs() < 1e-9));
    // Leave-one-out residuals agree with refitting without the point.
    let noisy: Vec<[f64; 1]> = uv
        .iter()
        .map(|(u, v)| [f(*u, *v) + 0.1 * (rng.uniform() - 0.5)])
        .collect();
    let knots = || (uniform_knots(0.0, 1.0, 3, 3), uniform_knots(0.0, 1.0, 3, 3));
    let (ku, kv) = knots();
    let fit = fit_least_squares(&uv, &noisy, 3, 3, ku, kv, 1e-4).unwrap();
    for k in [0, 17, 123] {
        let mut uv2 = uv.clone();
        let mut v2 = noisy.clone();
        uv2.remove(k);
        v2.remove(k);
        let (ku, kv) = knots();
        let refit = fit_least_squares(&uv2, &v2, 3, 3, ku, kv, 1e-4).unwrap();
        // The penalty weight is relative to the data term, which changes
        // slightly without the point: agreement to that order.
        let direct = refit.surface.point(uv[k].0, uv[k].1)[0] - noisy[k][0];
        let loo = fit.leave_one_out[k].unwrap()[0];
        assert!(
            (direct - loo).abs() < 1e-4 * (1.0 + direct.abs()),
            "{direct} {loo}"
        );
    }
}

#[test]
fn least_squares_refuses_too_few_points() {
    // Cubic in u and v, one interior knot each, no penalty.
    let fit = |uv: &[(f64, f64)], vals: &[[f64; 1]]| {
        fit_least_squares(
            uv,
            vals,
            3,
            3,
            uniform_knots(0.0, 1.0, 1, 3),
            uniform_knots(0.0, 1.0, 1, 3),
            0.0,
        )
        .unwrap_err()
    };
    let e = fit(
        &[(0.1, 0.1), (0.5, 0.5), (0.9, 0.2)],
        &[[1.0], [2.0], [3.0]],
    );
    assert!(matches!(e, BSplineError::TooFewPoints(_)), "{e}");
    // Enough points, but all on one line: singular without penalty.
    let uv: Vec<(f64, f64)> = (0..30).map(|k| (k as f64 / 29.0, 0.5)).collect();
    let e = fit(&uv, &[[1.0]; 30]);
    assert!(matches!(e, BSplineError::Singular(_)), "{e}");
}

#[test]
fn invalid_definitions_are_refused() {
    let ok = uniform_knots(0.0, 1.0, 2, 3);
    let net = vec![[0.0; 3]; 25];
    assert!(BSplineSurface::new(3, 3, ok.clone(), ok.clone(), 5, 5, net.clone()).is_ok());
    let mut bad = ok.clone();
    bad[4] = f64::NAN;
    assert!(BSplineSurface::new(3, 3, bad, ok.clone(), 5, 5, net.clone()).is_err());
    let dec = vec![0.0, 0.0, 0.0, 0.0, 0.6, 0.4, 1.0, 1.0, 1.0, 1.0];
    assert!(BSplineSurface::new(3, 3, dec, ok.clone(), 6, 5, vec![[0.0; 3]; 30]).is_err());
    let unclamped = vec![0.0, 0.1, 0.2, 0.3, 0.5, 0.7, 0.8, 0.9, 1.0];
    assert!(BSplineSurface::new(3, 3, unclamped, ok.clone(), 5, 5, net.clone()).is_err());
    assert!(BSplineSurface::new(3, 3, ok.clone(), ok.clone(), 5, 5, vec![[0.0; 3]; 24]).is_err());
    let mut nan_net = net;
    nan_net[7][1] = f64::INFINITY;
    assert!(BSplineSurface::new(3, 3, ok.clone(), ok, 5, 5, nan_net).is_err());
}

#[test]
fn closest_point_is_orthogonal_and_beats_every_sample() {
    let s = sample_surface();
    let index = ProjectionIndex::new(&s, 8);
    let mut rng = Rng::new(9);
    for _ in 0..100 {
        let (u, v) = (0.05 + 0.9 * rng.uniform(), 0.05 + 0.9 * rng.uniform());
        let n = s.unit_normal(u, v).unwrap();
        let h = 3.0 * (rng.uniform() - 0.5);
        let p = s.point(u, v);
        let target = [p[0] + h * n[0], p[1] + h * n[1], p[2] + h * n[2]];
        let c = s.closest_point(&index, target, 10.0, None).unwrap();
        assert!(c.orthogonal);
        assert!(c.distance <= h.abs() + 1e-9, "{} > {}", c.distance, h.abs());
        // No sample of a fine grid is closer.
        for i in 0..=60 {
            for j in 0..=60 {
                let q = s.point(i as f64 / 60.0, j as f64 / 60.0);
                assert!(norm3(sub3(q, target)) >= c.distance - 1e-9);
            }
        }
    }
    // Beyond the edge: the foot is on the boundary and not orthogonal.
    let p = s.point(1.0, 0.5);
    let d = s.derivatives(1.0, 0.5, 1)[1][0];
    let l = norm3(d);
    let target = [
        p[0] + 2.0 * d[0] / l,
        p[1] + 2.0 * d[1] / l,
        p[2] + 2.0 * d[2] / l,
    ];
    let c = s.closest_point(&index, target, 10.0, None).unwrap();
    assert!(!c.orthogonal && (c.u - 1.0).abs() < 1e-12);
    // Nothing within the radius.
    assert!(s
        .closest_point(&index, [1e4, 0.0, 0.0], 10.0, None)
        .is_none());
}

#[test]
fn curvatures_of_a_cylinder_patch() {
    // z = sqrt(R² − x²) approximated closely by interpolation; the
    // curvature across is −1/R (bending away from the +z normal), along 0.
    let r = 50.0;
    let (cu, cv) = (41, 5);
    let mut pts = Vec::new();
    for i in 0..cu {
        let x = -20.0 + 40.0 * i as f64 / (cu - 1) as f64;
        for j in 0..cv {
            pts.push([x, 10.0 * j as f64, (r * r - x * x).sqrt()]);
        }
    }
    let s = interpolate(&pts, cu, cv, 3, 3, &Parameterization::ChordLength).unwrap();
    let n = s.unit_normal(0.5, 0.5).unwrap();
    let k = s.curvatures(0.5, 0.5).unwrap();
    let sign = n[2].signum();
    let (kmin, kmax) = if sign > 0.0 {
        (k.min, k.max)
    } else {
        (-k.max, -k.min)
    };
    assert!((kmin + 1.0 / r).abs() < 1e-5, "{kmin}");
    assert!(kmax.abs() < 1e-6, "{kmax}");
}
