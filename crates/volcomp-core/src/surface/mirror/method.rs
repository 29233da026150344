//! The mirror method itself: matching each probe point to the nominal
//! surface, its mirror and compensation points, and the fitted deviation
//! field (the fit is chosen in [`super::fit`]).

use super::fit::{fit_interpolation, fit_least_squares};
use super::io::ProbePoint;
use super::nominal::NominalSurface;
use super::stats::{deviation_stats, DeviationStats};
use super::{advice, fmt_point, method_error, MirrorError};
use crate::error::MapFileError;
use crate::surface::bspline::BSplineSurface;
use volcomp_gcode::Vec3;

/// How the compensation points are fitted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FitMethod {
    /// Bicubic least squares: among the control nets (4 × 4 up to as many
    /// coefficients as points), the one with the smallest leave-one-out
    /// error, i.e. the best predicted compensation (cross-validation: Hastie,
    /// Tibshirani & Friedman, *The Elements of Statistical Learning*, 2009,
    /// §7.10). The complexity is chosen by the data: a net that fits the
    /// probe noise predicts each left-out point badly and is not chosen.
    LeastSquares {
        /// With `Some(t)`, only nets whose residual at every compensation
        /// point is within `t` µm are considered (the probe noise then must
        /// stay within `t`: `t` ≳ 3σ). `None` (the default): every net.
        tolerance_um: Option<f64>,
    },
    /// Bicubic interpolation (A9.4) of a probe grid given by `i, j` columns.
    Interpolate,
}

/// Options of [`mirror`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MirrorOptions {
    /// Stock `D` left by the semi-finishing pass (mm).
    pub stock_mm: f64,
    /// Probe ball radius (mm) when the points are ball centres; `None` when
    /// the probe software already compensated it.
    pub probe_radius_mm: Option<f64>,
    /// Largest accepted `|measured height − D|` (mm): farther points are
    /// refused as mismatched.
    pub max_error_mm: f64,
    /// How the compensation points are fitted.
    pub fit: FitMethod,
}

impl Default for MirrorOptions {
    fn default() -> Self {
        Self {
            stock_mm: 0.2,
            probe_radius_mm: None,
            max_error_mm: 0.1,
            fit: FitMethod::LeastSquares { tolerance_um: None },
        }
    }
}

/// One probe point after matching, mirroring and fitting.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MatchedPoint {
    /// 1-based line in the probe file.
    pub row: usize,
    /// The `id` column.
    pub id: Option<String>,
    /// Grid indices.
    pub grid: Option<(i64, i64)>,
    /// Measured surface point `P_R` (mm; probe radius removed).
    pub measured_mm: Vec3,
    /// Parameter u of the ideal point.
    pub u: f64,
    /// Parameter v of the ideal point.
    pub v: f64,
    /// Ideal point `P_P` on `S_F` (mm).
    pub nominal_mm: Vec3,
    /// Outward unit normal `V_N` at `P_P`.
    pub normal: Vec3,
    /// Semi-finishing error `(P_R − P_P)·V_N − D` (µm, positive = material left).
    pub error_um: f64,
    /// `D_M`: signed distance of `P_R` to the mirror surface (µm).
    pub mirror_distance_um: f64,
    /// Compensation point `P_C = P_R − 2·D_M·V_N` (mm).
    pub compensation_mm: Vec3,
    /// Height of `P_C` over `S_F`, `(P_C − P_P)·V_N` (µm) = −error.
    pub offset_um: f64,
    /// Fitted height minus `offset_um` (µm).
    pub fit_residual_um: f64,
    /// Finishing error predicted for this point by the fit made without it
    /// (leave-one-out, least squares only), µm.
    pub predicted_um: Option<f64>,
}

/// Which fit was made (written `least-squares` or `interpolation`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum FitKind {
    /// Bicubic least squares, net by leave-one-out.
    #[serde(rename = "least-squares")]
    LeastSquares,
    /// Bicubic interpolation of a probe grid.
    #[serde(rename = "interpolation")]
    Interpolation,
}

impl std::fmt::Display for FitKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FitKind::LeastSquares => "least-squares",
            FitKind::Interpolation => "interpolation",
        })
    }
}

/// How the compensation points were fitted.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FitInfo {
    /// Least squares or interpolation.
    pub method: FitKind,
    /// Degrees (u, v).
    pub degree: (usize, usize),
    /// Control net (u, v).
    pub net: (usize, usize),
    /// Tolerance (least squares), µm.
    pub tolerance_um: Option<f64>,
    /// Largest |residual| at the compensation points (µm).
    pub max_residual_um: f64,
    /// RMS residual (µm).
    pub rms_residual_um: f64,
    /// Estimated probe noise `σ̂ = sqrt(Σ r² / (n − p))` (least squares;
    /// `p` the control net's coefficients), µm.
    pub noise_estimate_um: Option<f64>,
    /// RMS of the leave-one-out prediction errors of the chosen net (least
    /// squares), µm: the criterion the net was chosen by.
    pub leave_one_out_rms_um: Option<f64>,
    /// Parameter rectangle the field is defined on (u0, u1, v0, v1).
    pub domain: [f64; 4],
}

/// The fitted height `δ(u, v)` of the compensated surface over `S_F` (µm),
/// defined on the parameter rectangle the probe points cover; outside it the
/// value at the nearest edge is used.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviationField {
    surface: BSplineSurface<1>,
}

impl DeviationField {
    /// A field from a scalar B-spline surface (µm).
    pub fn new(surface: BSplineSurface<1>) -> Self {
        Self { surface }
    }

    /// A constant offset (the tool-radius baseline) over the given rectangle.
    pub fn constant(offset_um: f64, u: [f64; 2], v: [f64; 2]) -> Self {
        Self {
            surface: BSplineSurface::constant([offset_um], u, v),
        }
    }

    /// `δ(u, v)` in µm (clamped to the field's rectangle).
    pub fn offset_um(&self, u: f64, v: f64) -> f64 {
        self.surface.point(u, v)[0]
    }

    /// Whether `(u, v)` lies inside the field's rectangle (1e-9 slack).
    pub fn contains(&self, u: f64, v: f64) -> bool {
        let [u0, u1] = self.surface.domain_u();
        let [v0, v1] = self.surface.domain_v();
        let (su, sv) = (1e-9 * (u1 - u0).max(1e-300), 1e-9 * (v1 - v0).max(1e-300));
        u >= u0 - su && u <= u1 + su && v >= v0 - sv && v <= v1 + sv
    }

    /// An upper bound of `|δ|` (µm): the largest control coefficient.
    pub fn max_abs_um(&self) -> f64 {
        self.surface
            .control_points()
            .iter()
            .map(|c| c[0].abs())
            .fold(0.0, f64::max)
    }

    /// The scalar B-spline.
    pub fn surface(&self) -> &BSplineSurface<1> {
        &self.surface
    }
}

/// Everything the mirror method computed.
#[derive(Debug, Clone)]
pub struct MirrorResult {
    /// Every probe point, in file order.
    pub points: Vec<MatchedPoint>,
    /// The fit.
    pub fit: FitInfo,
    /// The fitted height of the compensated surface.
    pub field: DeviationField,
    /// The measured errors: what an uncompensated finishing pass would leave
    /// if it repeats them.
    pub before: DeviationStats,
    /// The constant offset of the tool-radius baseline (µm, = −mean error).
    pub baseline_offset_um: f64,
    /// Errors after the tool-radius baseline (`error − mean`).
    pub baseline: DeviationStats,
    /// Fit residuals at the probe points (in-sample).
    pub mirror_fit: DeviationStats,
    /// Leave-one-out prediction of the errors after mirror compensation
    /// (least squares only).
    pub mirror_predicted: Option<DeviationStats>,
}

impl MirrorResult {
    /// Whether the leave-one-out prediction of the finishing error after
    /// mirror compensation has a larger standard deviation than the
    /// measured error itself (no compensation): the fit does not predict
    /// the error where it was not probed, and compensating would likely
    /// make the surface worse. `false` when there is no prediction
    /// (interpolation).
    pub fn compensation_predicted_worse(&self) -> bool {
        self.mirror_predicted
            .as_ref()
            .is_some_and(|p| p.std_um > self.before.std_um)
    }
}

/// Fewest probe points of a bicubic least-squares fit.
pub const MIN_POINTS: usize = 16;

/// Matches every probe point to the nominal surface and mirrors it.
pub fn match_points(
    nominal: &NominalSurface,
    probes: &[ProbePoint],
    options: &MirrorOptions,
    file: &str,
) -> Result<Vec<MatchedPoint>, MirrorError> {
    let d = options.stock_mm;
    if !(d.is_finite() && d > 0.0) {
        return Err(method_error(
            format!("the stock must be a positive length in mm; got {d}"),
            advice::STOCK_POSITIVE,
        ));
    }
    let r = options.probe_radius_mm.unwrap_or(0.0);
    if !(r.is_finite() && r >= 0.0) {
        return Err(method_error(
            format!("the probe radius must be a length ≥ 0 in mm; got {r}"),
            "pass the probe ball's radius, or leave it out when the points are already compensated",
        ));
    }
    let max_err = options.max_error_mm;
    if !(max_err.is_finite() && max_err > 0.0) {
        return Err(method_error(
            format!("the largest accepted error must be positive; got {max_err} mm"),
            advice::MAX_ERROR_POSITIVE,
        ));
    }
    if let Some((rho, at)) = nominal.min_concave_radius() {
        if d + r >= 0.9 * rho {
            return Err(method_error(
                format!(
                    "the stock {d} mm{} is too large for the nominal surface's smallest concave radius of curvature, {rho:.4} mm at {}: the offset surfaces fold there and probe points cannot be matched to single points",
                    if r > 0.0 { format!(" plus the probe radius {r} mm") } else { String::new() },
                    fmt_point(at)
                ),
                advice::STOCK_TOO_LARGE,
            ));
        }
    }
    let expected = d + r;
    let mut out = Vec::with_capacity(probes.len());
    let mut hint = None;
    for pp in probes {
        let p = pp.position_mm;
        let at = |message: String, help: String| {
            MirrorError::File(MapFileError {
                file: file.into(),
                row: pp.row,
                column: 1,
                message,
                help,
                source_line: String::new(),
                caret_byte: 0,
            })
        };
        let radius = expected + max_err;
        let foot = nominal
            .project(p, radius, hint)
            .filter(|f| f.orthogonal && (f.height_mm - expected).abs() <= max_err);
        let foot = match foot {
            Some(f) => f,
            None => return Err(far_point(nominal, p, expected, max_err, &at)),
        };
        hint = Some((foot.u, foot.v));
        let n = foot.normal;
        let measured = p - n * r;
        let height = foot.height_mm - r;
        let error = height - d;
        let d_m = height - d / 2.0;
        let compensation = measured - n * (2.0 * d_m);
        let offset = (compensation - foot.point).dot(n);
        out.push(MatchedPoint {
            row: pp.row,
            id: pp.id.clone(),
            grid: pp.grid,
            measured_mm: measured,
            u: foot.u,
            v: foot.v,
            nominal_mm: foot.point,
            normal: n,
            error_um: error * 1e3,
            mirror_distance_um: d_m * 1e3,
            compensation_mm: compensation,
            offset_um: offset * 1e3,
            fit_residual_um: 0.0,
            predicted_um: None,
        });
    }
    Ok(out)
}

/// The error for a point that does not match the surface, with a diagnosis.
fn far_point(
    nominal: &NominalSurface,
    p: Vec3,
    expected: f64,
    max_err: f64,
    at: &dyn Fn(String, String) -> MirrorError,
) -> MirrorError {
    let fits = |q: Vec3| {
        nominal
            .project(q, expected + max_err, None)
            .is_some_and(|f| f.orthogonal && (f.height_mm - expected).abs() <= max_err)
    };
    let window = format!("{:.4} ± {:.4} mm", expected, max_err);
    if fits(p * 25.4) {
        return at(
            format!("point {} does not lie near the surface, but it would if its coordinates were inches", fmt_point(p)),
            "name the columns x_in,y_in,z_in when the file is in inches".into(),
        );
    }
    if fits(p * (1.0 / 25.4)) {
        return at(
            format!("point {} does not lie near the surface, but it would if its coordinates were millimetres", fmt_point(p)),
            "name the columns x_mm,y_mm,z_mm when the file is in millimetres".into(),
        );
    }
    match nominal.project(p, 1e12, None) {
        Some(f) if !f.orthogonal => at(
            format!(
                "point {} lies beyond the edge of the nominal surface (its closest point {} is on the boundary)",
                fmt_point(p),
                fmt_point(f.point)
            ),
            "probe inside the surface, or give a nominal surface that covers the probed area".into(),
        ),
        Some(f) if (f.height_mm + expected).abs() <= max_err => at(
            format!(
                "point {} lies {:.4} mm on the material side of the nominal surface",
                fmt_point(p),
                -f.height_mm
            ),
            advice::MATERIAL_REVERSED.into(),
        ),
        Some(f) => at(
            format!(
                "point {} is {:.4} mm from the nominal surface along its outward normal; a probe point should be {window} from it (stock{})",
                fmt_point(p),
                f.height_mm,
                if expected > 0.0 { " + probe radius" } else { "" }
            ),
            advice::POINT_OFF.into(),
        ),
        None => at(
            format!("point {} is far from the nominal surface", fmt_point(p)),
            "check the frame and units of the points".into(),
        ),
    }
}

/// Runs the mirror method: matches, mirrors and fits.
pub fn mirror(
    nominal: &NominalSurface,
    probes: &[ProbePoint],
    options: &MirrorOptions,
    file: &str,
) -> Result<MirrorResult, MirrorError> {
    let mut points = match_points(nominal, probes, options, file)?;
    let (field, fit, loo) = match options.fit {
        FitMethod::LeastSquares { tolerance_um } => {
            fit_least_squares(nominal, &points, tolerance_um)?
        }
        FitMethod::Interpolate => fit_interpolation(&points, file)?,
    };
    for (k, pt) in points.iter_mut().enumerate() {
        pt.fit_residual_um = field.offset_um(pt.u, pt.v) - pt.offset_um;
        pt.predicted_um = loo.as_ref().and_then(|l| l[k]);
    }
    let before = deviation_stats(points.iter().map(|p| p.error_um));
    let baseline_offset_um = -before.mean_um;
    let baseline = deviation_stats(points.iter().map(|p| p.error_um + baseline_offset_um));
    let mirror_fit = deviation_stats(points.iter().map(|p| p.fit_residual_um));
    let mirror_predicted = loo.as_ref().and_then(|l| {
        l.iter()
            .all(Option::is_some)
            .then(|| deviation_stats(l.iter().flatten().copied()))
    });
    Ok(MirrorResult {
        points,
        fit,
        field,
        before,
        baseline_offset_um,
        baseline,
        mirror_fit,
        mirror_predicted,
    })
}

#[cfg(test)]
mod tests {
    use super::super::finishing::{BallTool, ClPoint, SurfaceModel};
    use super::super::nominal::MaterialSide;
    use super::super::test_support::plane_surface;
    use super::*;
    use crate::surface::bspline::{self, Parameterization};

    /// A probe point of `row` (no id, no grid node) at `position_mm`.
    fn probe(row: usize, position_mm: Vec3) -> ProbePoint {
        ProbePoint {
            row,
            id: None,
            grid: None,
            position_mm,
        }
    }

    #[test]
    fn the_mirror_reflects_the_measured_point_in_the_halfway_surface() {
        // A flat nominal at z = 0, material below, stock 0.2 mm. A point
        // measured at 0.205 mm (5 µm left over) has D_M = 105 µm and its
        // compensation point lies 5 µm below the nominal.
        let nominal = NominalSurface::new(plane_surface(), MaterialSide::Below, "s").unwrap();
        let probes = vec![probe(2, Vec3::new(12.0, 17.0, 0.205))];
        let opts = MirrorOptions {
            stock_mm: 0.2,
            ..MirrorOptions::default()
        };
        let m = match_points(&nominal, &probes, &opts, "p.csv").unwrap();
        let p = &m[0];
        assert!((p.error_um - 5.0).abs() < 1e-9);
        assert!((p.mirror_distance_um - 105.0).abs() < 1e-9);
        assert!((p.offset_um + 5.0).abs() < 1e-9);
        assert!((p.compensation_mm - Vec3::new(12.0, 17.0, -0.005)).norm() < 1e-12);
        assert!((p.nominal_mm - Vec3::new(12.0, 17.0, 0.0)).norm() < 1e-12);
        // With a probe radius the centre is compensated along the normal.
        let probes = vec![ProbePoint {
            position_mm: Vec3::new(12.0, 17.0, 1.0 + 0.195),
            ..probes[0].clone()
        }];
        let opts = MirrorOptions {
            probe_radius_mm: Some(1.0),
            ..opts
        };
        let m = match_points(&nominal, &probes, &opts, "p.csv").unwrap();
        assert!((m[0].error_um + 5.0).abs() < 1e-9 && (m[0].offset_um - 5.0).abs() < 1e-9);
    }

    #[test]
    fn far_points_are_refused_with_a_diagnosis() {
        let nominal = NominalSurface::new(plane_surface(), MaterialSide::Below, "s").unwrap();
        let opts = MirrorOptions::default();
        let one = |p: Vec3| {
            let probes = vec![probe(7, p)];
            match_points(&nominal, &probes, &opts, "p.csv")
                .unwrap_err()
                .to_string()
        };
        let e = one(Vec3::new(10.0, 10.0, 0.5));
        assert!(
            e.starts_with("p.csv:7:1: point") && e.contains("0.5000 mm from the nominal"),
            "{e}"
        );
        let e = one(Vec3::new(10.0, 10.0, -0.2));
        assert!(e.contains("material side"), "{e}");
        let e = one(Vec3::new(45.0, 10.0, 0.2));
        assert!(e.contains("beyond the edge"), "{e}");
        let e = one(Vec3::new(10.0 / 25.4, 10.0 / 25.4, 0.2 / 25.4));
        assert!(e.contains("inches"), "{e}");
    }

    #[test]
    fn a_stock_beyond_the_concave_radius_is_refused() {
        // A trough z = x²/(2·5): radius 5 mm at the bottom, material below.
        let mut pts = Vec::new();
        for i in 0..9 {
            let x = -4.0 + i as f64;
            for j in 0..4 {
                pts.push([x, 3.0 * j as f64, x * x / 10.0]);
            }
        }
        let s = bspline::interpolate(&pts, 9, 4, 3, 3, &Parameterization::Uniform).unwrap();
        let nominal = NominalSurface::new(s, MaterialSide::Below, "s").unwrap();
        let (rho, _) = nominal.min_concave_radius().unwrap();
        assert!((rho - 5.0).abs() < 1e-6, "{rho}");
        let probes = vec![probe(2, Vec3::new(0.0, 4.0, 5.0))];
        let opts = MirrorOptions {
            stock_mm: 5.0,
            ..MirrorOptions::default()
        };
        let e = match_points(&nominal, &probes, &opts, "p")
            .unwrap_err()
            .to_string();
        assert!(e.contains("concave radius"), "{e}");
        let field = DeviationField::constant(0.0, [0.0, 1.0], [0.0, 1.0]);
        let tool = BallTool {
            radius_mm: 6.0,
            cl: ClPoint::Tip,
        };
        let e = SurfaceModel::new(&nominal, &field, tool, Vec3::ZERO, 0.02)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("ball radius"), "{e}");
    }

    #[test]
    fn too_few_points_are_refused() {
        let nominal = NominalSurface::new(plane_surface(), MaterialSide::Below, "s").unwrap();
        let probes: Vec<ProbePoint> = (0..9)
            .map(|k| {
                probe(
                    k + 2,
                    Vec3::new(
                        5.0 + 10.0 * (k / 3) as f64,
                        5.0 + 10.0 * (k % 3) as f64,
                        0.2,
                    ),
                )
            })
            .collect();
        let e = mirror(&nominal, &probes, &MirrorOptions::default(), "p").unwrap_err();
        assert!(e.to_string().contains("too few"), "{e}");
    }
}
