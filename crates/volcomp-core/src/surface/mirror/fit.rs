//! Fitting the compensation points: bicubic least squares with the control
//! net chosen by leave-one-out cross-validation, or interpolation of a probe
//! grid.

use super::method::{DeviationField, FitInfo, FitKind, MatchedPoint, MIN_POINTS};
use super::nominal::NominalSurface;
use super::{advice, method_error, MirrorError};
use crate::error::MapFileError;
use crate::surface::bspline::{self, BSplineError, LeastSquaresFit, Parameterization};
use volcomp_gcode::Vec3;

pub(super) type Fitted = (DeviationField, FitInfo, Option<Vec<Option<f64>>>);

fn domain_of(points: &[MatchedPoint]) -> Result<[f64; 4], MirrorError> {
    let (mut u0, mut u1, mut v0, mut v1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in points {
        u0 = u0.min(p.u);
        u1 = u1.max(p.u);
        v0 = v0.min(p.v);
        v1 = v1.max(p.v);
    }
    if !(u1 - u0 > 1e-9 && v1 - v0 > 1e-9) {
        return Err(method_error(
            "the probe points lie along one line of the surface: they cannot determine a surface",
            "probe a two-dimensional pattern covering the surface (a grid of at least 4 × 4 points)",
        ));
    }
    Ok([u0, u1, v0, v1])
}

fn too_few(n: usize) -> MirrorError {
    method_error(
        format!("{n} probe points are too few for a bicubic fit (at least {MIN_POINTS})"),
        "probe at least a 4 × 4 grid over the surface",
    )
}

pub(super) fn fit_least_squares(
    nominal: &NominalSurface,
    points: &[MatchedPoint],
    tolerance_um: Option<f64>,
) -> Result<Fitted, MirrorError> {
    if let Some(tolerance_um) = tolerance_um.filter(|t| !(t.is_finite() && *t > 0.0)) {
        return Err(method_error(
            format!("the fitting tolerance must be positive; got {tolerance_um} µm"),
            advice::TOLERANCE_POSITIVE,
        ));
    }
    if points.len() < MIN_POINTS {
        return Err(too_few(points.len()));
    }
    let dom = domain_of(points)?;
    let uv: Vec<(f64, f64)> = points.iter().map(|p| (p.u, p.v)).collect();
    let vals: Vec<[f64; 1]> = points.iter().map(|p| [p.offset_um]).collect();
    // Spans in proportion to the probed area's extent in space along u and
    // along v (measured on the nominal's mid iso-lines), so that the spans
    // are about square.
    let length = |along_u: bool| {
        let mut l = 0.0;
        let mut prev: Option<Vec3> = None;
        for k in 0..=32 {
            let t = k as f64 / 32.0;
            let p = if along_u {
                nominal.point(dom[0] + t * (dom[1] - dom[0]), 0.5 * (dom[2] + dom[3]))
            } else {
                nominal.point(0.5 * (dom[0] + dom[1]), dom[2] + t * (dom[3] - dom[2]))
            };
            if let Some(q) = prev {
                l += (p - q).norm();
            }
            prev = Some(p);
        }
        l
    };
    let (lu, lv) = (length(true), length(false));
    let ratio = if lu > 0.0 && lv > 0.0 {
        (lv / lu).clamp(0.05, 20.0)
    } else {
        1.0
    };
    // Every net from 4 × 4 up to as many coefficients as points; among those
    // whose residual meets the tolerance, the one with the smallest
    // leave-one-out error (the best predicted compensation) is taken.
    let mut best_residual: Option<(f64, (usize, usize))> = None;
    let mut chosen: Option<(f64, LeastSquaresFit<1>, (usize, usize))> = None;
    let mut last = (0, 0);
    let mut singular = None;
    for s in [1usize, 2, 3, 4, 5, 6, 8, 10, 12, 16, 20, 24, 32] {
        let (su, sv) = if ratio <= 1.0 {
            (s, ((s as f64 * ratio).round() as usize).max(1))
        } else {
            (((s as f64 / ratio).round() as usize).max(1), s)
        };
        if (su, sv) == last {
            continue;
        }
        if (su + 3) * (sv + 3) > points.len() {
            break;
        }
        last = (su, sv);
        let fit: Result<LeastSquaresFit<1>, BSplineError> = bspline::fit_least_squares(
            &uv,
            &vals,
            3,
            3,
            bspline::uniform_knots(dom[0], dom[1], su, 3),
            bspline::uniform_knots(dom[2], dom[3], sv, 3),
            1e-6,
        );
        let fit = match fit {
            Ok(f) => f,
            Err(e) => {
                singular = Some(e);
                break;
            }
        };
        let max = fit.residuals.iter().map(|r| r[0].abs()).fold(0.0, f64::max);
        if best_residual.is_none_or(|b| max < b.0) {
            best_residual = Some((max, (su + 3, sv + 3)));
        }
        if tolerance_um.is_some_and(|t| max > t) {
            continue;
        }
        let loo: Option<f64> = fit
            .leave_one_out
            .iter()
            .map(|l| l.map(|x| x[0] * x[0]))
            .sum::<Option<f64>>()
            .map(|s| (s / points.len() as f64).sqrt());
        let score = loo.unwrap_or(f64::INFINITY);
        if chosen.as_ref().is_none_or(|c| score < c.0) {
            chosen = Some((score, fit, (su + 3, sv + 3)));
        }
    }
    if let Some((score, fit, net)) = chosen {
        let max = fit.residuals.iter().map(|r| r[0].abs()).fold(0.0, f64::max);
        let rss = fit.residuals.iter().map(|r| r[0] * r[0]).sum::<f64>();
        let rms = (rss / fit.residuals.len() as f64).sqrt();
        let dof = fit.residuals.len().saturating_sub(net.0 * net.1);
        let info = FitInfo {
            method: FitKind::LeastSquares,
            degree: (3, 3),
            net,
            tolerance_um,
            max_residual_um: max,
            rms_residual_um: rms,
            noise_estimate_um: (dof > 0).then(|| (rss / dof as f64).sqrt()),
            leave_one_out_rms_um: score.is_finite().then_some(score),
            domain: dom,
        };
        let loo = fit.leave_one_out.iter().map(|l| l.map(|x| x[0])).collect();
        return Ok((DeviationField::new(fit.surface), info, Some(loo)));
    }
    if let (None, Some(e)) = (best_residual, singular) {
        return Err(method_error(
            format!("the probe points do not determine a surface: {e}"),
            "probe a two-dimensional pattern covering the surface (a grid of at least 4 × 4 points)",
        ));
    }
    let (max, net) = best_residual.unwrap_or((f64::NAN, (4, 4)));
    let tol = tolerance_um.map_or("the tolerance".to_string(), |t| format!("±{t} µm"));
    Err(method_error(
        format!(
            "the compensation points cannot be fitted within {tol} with fewer coefficients than points (best: {max:.3} µm with a {} × {} control net, {} points)",
            net.0, net.1, points.len()
        ),
        advice::TOLERANCE_UNMET,
    ))
}

pub(super) fn fit_interpolation(
    points: &[MatchedPoint],
    file: &str,
) -> Result<Fitted, MirrorError> {
    let help = advice::INTERPOLATION_NEEDS_GRID;
    if points.iter().any(|p| p.grid.is_none()) {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: "the probe points have no i,j grid indices".into(),
            help: advice::INTERPOLATION_NEEDS_INDICES.into(),
        });
    }
    let idx: Vec<(i64, i64)> = points.iter().map(|p| p.grid.unwrap_or((0, 0))).collect();
    let i0 = idx.iter().map(|x| x.0).min().unwrap_or(0);
    let j0 = idx.iter().map(|x| x.1).min().unwrap_or(0);
    let ni = (idx.iter().map(|x| x.0).max().unwrap_or(0) - i0 + 1) as usize;
    let nj = (idx.iter().map(|x| x.1).max().unwrap_or(0) - j0 + 1) as usize;
    if ni.saturating_mul(nj) > 4 * points.len() + 16 {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: format!(
                "{} probe points do not fill the {ni} × {nj} grid their i,j indices span",
                points.len()
            ),
            help: help.into(),
        });
    }
    let mut at: Vec<Option<usize>> = vec![None; ni * nj];
    for (k, (i, j)) in idx.iter().enumerate() {
        let c = (i - i0) as usize * nj + (j - j0) as usize;
        if at[c].is_some() {
            return Err(MirrorError::File(MapFileError {
                file: file.into(),
                row: points[k].row,
                column: 1,
                message: format!("a second probe point for grid node ({i}, {j})"),
                help: help.into(),
                source_line: String::new(),
                caret_byte: 0,
            }));
        }
        at[c] = Some(k);
    }
    if ni < 4 || nj < 4 || at.iter().any(Option::is_none) {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: format!(
                "the i,j indices do not form a complete grid of at least 4 × 4 ({} points, {ni} × {nj} nodes)",
                points.len()
            ),
            help: help.into(),
        });
    }
    let node = |i: usize, j: usize| &points[at[i * nj + j].unwrap_or(0)];
    // Does i run along u (or along v)? Pick the assignment whose rows are
    // closest to iso-parameter lines.
    let spread = |f: &dyn Fn(usize, usize) -> f64, a: usize, b: usize| {
        let mut worst: f64 = 0.0;
        for x in 0..a {
            let m = (0..b).map(|y| f(x, y)).sum::<f64>() / b as f64;
            for y in 0..b {
                worst = worst.max((f(x, y) - m).abs());
            }
        }
        worst
    };
    let i_is_u = spread(&|i, j| node(i, j).u, ni, nj) <= spread(&|j, i| node(i, j).u, nj, ni);
    let (nu, nv) = if i_is_u { (ni, nj) } else { (nj, ni) };
    let pt = |a: usize, b: usize| if i_is_u { node(a, b) } else { node(b, a) };
    let mean_u: Vec<f64> = (0..nu)
        .map(|a| (0..nv).map(|b| pt(a, b).u).sum::<f64>() / nv as f64)
        .collect();
    let mean_v: Vec<f64> = (0..nv)
        .map(|b| (0..nu).map(|a| pt(a, b).v).sum::<f64>() / nu as f64)
        .collect();
    let ord_u: Vec<usize> = sorted_order(&mean_u);
    let ord_v: Vec<usize> = sorted_order(&mean_v);
    let us: Vec<f64> = ord_u.iter().map(|a| mean_u[*a]).collect();
    let vs: Vec<f64> = ord_v.iter().map(|b| mean_v[*b]).collect();
    let gap = |t: &[f64]| {
        t.windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min)
    };
    let (gu, gv) = (gap(&us), gap(&vs));
    let dev_u = spread(&|a, b| pt(a, b).u, nu, nv);
    let dev_v = spread(&|b, a| pt(a, b).v, nv, nu);
    if !(gu > 0.0 && gv > 0.0) || dev_u > 0.25 * gu || dev_v > 0.25 * gv {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: "the probe grid does not follow the surface's parameter lines closely enough to interpolate (rows cross or wander by more than a quarter of their spacing)".into(),
            help: advice::GRID_OFF_PARAMETER_LINES.into(),
        });
    }
    let mut vals = Vec::with_capacity(nu * nv);
    for a in &ord_u {
        for b in &ord_v {
            vals.push([pt(*a, *b).offset_um]);
        }
    }
    let surface = bspline::interpolate(
        &vals,
        nu,
        nv,
        3,
        3,
        &Parameterization::Given(us.clone(), vs.clone()),
    )
    .map_err(|e| {
        method_error(
            format!("interpolation failed: {e}"),
            advice::INTERPOLATION_FAILED,
        )
    })?;
    let field = DeviationField::new(surface);
    let res: Vec<f64> = points
        .iter()
        .map(|p| field.offset_um(p.u, p.v) - p.offset_um)
        .collect();
    let max = res.iter().map(|r| r.abs()).fold(0.0, f64::max);
    let rms = (res.iter().map(|r| r * r).sum::<f64>() / res.len() as f64).sqrt();
    let info = FitInfo {
        method: FitKind::Interpolation,
        degree: (3, 3),
        net: (nu, nv),
        tolerance_um: None,
        max_residual_um: max,
        rms_residual_um: rms,
        noise_estimate_um: None,
        leave_one_out_rms_um: None,
        domain: [us[0], us[nu - 1], vs[0], vs[nv - 1]],
    };
    Ok((field, info, None))
}

fn sorted_order(v: &[f64]) -> Vec<usize> {
    let mut o: Vec<usize> = (0..v.len()).collect();
    o.sort_by(|a, b| v[*a].total_cmp(&v[*b]));
    o
}
