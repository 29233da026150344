//! From touches to geometry: the probe's calibration on the reference
//! sphere, the centre of every other sphere, and the probe-corrected
//! contact of every touch on a face (docs/probing.md, "The fit").
//!
//! **Touch model.** Commanded to `q` the machine puts the tip's centre at
//! `q + e(q, s)`; near one sphere the geometric part of `e` is a constant
//! (it shifts the sphere's apparent centre, which is what the later
//! identification reads), and the direction-dependent part is the axes'
//! reversal, `b(s) = Σ_a ±B_a/2 ê_a` (− while axis `a` moves forward, +
//! in reverse: a lagging axis, docs/design.md, "Direction state and
//! backlash"). The probe triggers `p_d` after contact along its direction
//! of motion `d` (pre-travel), so a touch on a sphere of radius `R` and
//! centre `c` with a tip of radius `r` satisfies, to first order in `p/R`,
//!
//! ```text
//! |a − c| = R + r − p_d · |d·n|,    a = q + b(s),   n = (a − c)/|a − c|
//! ```
//!
//! (`|d·n| = 1` for a head-on touch, `1/√2` on a 45° shoulder). On the
//! reference sphere (`R` certified) the unknowns are `c`, `r`, `p_d` for
//! every direction touched and `B_a` for every axis touched from both
//! sides; elsewhere `c` and the sphere's radius (unless certified), with
//! `r`, `p`, `B` from the calibration of the same probe (tool length).
//! Least squares by Gauss–Newton, each step the minimum-norm solution on
//! the subspace the touches see (`crate::linalg::pinv_solve`): what they
//! cannot separate keeps its starting value and is reported.
//!
//! Without a reference sphere every sphere gets one effective radius; the
//! pre-travel and the reversals then shift every centre probed with the
//! same pattern by the same amount, which the identification's placement
//! positions absorb, but gauge and square touches cannot be corrected and
//! are refused.

use super::artifact::{Artifact, Feature, Kind};
use super::geometry::AxisDir;
use super::ProbeError;
use crate::io::probe_log::Touch;
use crate::linalg;
use crate::model::Direction;
use nalgebra::DMatrix;
use volcomp_gcode::Vec3;

/// Relative singular-value threshold of the touch fits.
const THRESHOLD: f64 = 1e-6;
/// Largest null-space share of a parameter still counted as seen.
const SEEN: f64 = 1e-6;
/// Tool lengths closer than this (mm) are the same probe.
pub(super) const SAME_TOOL_MM: f64 = 1e-3;

/// A value and its standard uncertainty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// The value.
    pub value: f64,
    /// Its standard uncertainty.
    pub sigma: f64,
}

/// The probe's calibration on the reference sphere.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// The probe's tool length offset (mm).
    pub tool_length_mm: f64,
    /// Effective tip radius (mm; σ in µm).
    pub tip_radius_mm: Estimate,
    /// Pre-travel per direction of motion, in [`AxisDir::ALL`] order (µm);
    /// `None` where no touch moved that way or the touches cannot separate it.
    pub pretravel_um: [Option<Estimate>; 6],
    /// Reversal value of X, Y, Z (µm, positive: the axis lags); `None`
    /// where no touches came from both sides.
    pub reversal_um: [Option<Estimate>; 3],
    /// The reference sphere's centre (machine coordinates, mm).
    pub centre_mm: Vec3,
    /// Probing noise from the residuals (µm per touch).
    pub sigma_um: f64,
    /// Touch residuals (µm), in the order of the reference touches.
    pub residuals_um: Vec<f64>,
    /// Names of what the touches could not separate.
    pub unseen: Vec<String>,
    /// Redundancy of the fit (touches − seen parameters).
    pub dof: usize,
    /// `G` with the covariance of the calibration's parameters `G Gᵀ`
    /// (µm²), one row per parameter in the order [`CAL_PARAMS`]: centre
    /// (3), tip radius, pre-travel in [`AxisDir::ALL`] order (6), reversal
    /// of X, Y, Z (3).
    pub cov_factor_um: Vec<Vec<f64>>,
    /// Standard uncertainty of the reference sphere's certified radius
    /// (µm, half the diameter's). The touches see the sum of the sphere's
    /// and the tip's radius, so the tip radius inherits it whole: it is the
    /// last column of [`Self::cov_factor_um`] and part of the tip radius' σ.
    pub u_reference_radius_um: f64,
}

/// Parameters of a probe calibration, in the order of
/// [`Calibration::cov_factor_um`].
pub const CAL_PARAMS: usize = 13;

impl Calibration {
    /// Pre-travel (µm) for a direction; 0 where unknown.
    pub fn pretravel(&self, d: AxisDir) -> f64 {
        self.pretravel_um[d.index()].map_or(0.0, |e| e.value)
    }

    /// The reversal offset `b(s)` (mm) for direction states `s`.
    pub fn reversal_offset_mm(&self, s: Option<[Direction; 3]>) -> Vec3 {
        let Some(s) = s else { return Vec3::ZERO };
        let mut b = Vec3::ZERO;
        for a in 0..3 {
            if let Some(e) = self.reversal_um[a] {
                b[a] = sign(s[a]) * e.value / 2.0 * 1e-3;
            }
        }
        b
    }

    /// Effective radius (mm) of a touch in direction `d` at obliquity `cos`.
    pub fn effective_radius_mm(&self, d: AxisDir, cos: f64) -> f64 {
        self.tip_radius_mm.value - self.pretravel(d) * 1e-3 * cos
    }
}

/// −1 forward, +1 reverse: the sign of an axis' half reversal.
fn sign(d: Direction) -> f64 {
    match d {
        Direction::Forward => -1.0,
        Direction::Reverse => 1.0,
    }
}

/// The centre of one sphere in one placement.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereFit {
    /// Artifact name.
    pub artifact: String,
    /// Placement name.
    pub placement: String,
    /// Feature label (`s1` …).
    pub feature: String,
    /// Measured centre (machine coordinates, mm): `c − e(c)`.
    pub centre_mm: Vec3,
    /// The sphere's radius (mm): fitted, or certified.
    pub radius_mm: f64,
    /// `(JᵀJ)⁻¹` of the centre (µm² per µm² of touch noise): times σ² it is
    /// the centre's covariance.
    pub unit_cov: [[f64; 3]; 3],
    /// Touch residuals (µm).
    pub residuals_um: Vec<f64>,
    /// Redundancy (touches − unknowns).
    pub dof: usize,
    /// The probe's tool length (mm).
    pub tool_length_mm: f64,
    /// Whether the probe calibration corrected its touches.
    pub calibrated: bool,
    /// How the centre moves with the calibration's parameters (µm per µm,
    /// in [`CAL_PARAMS`] order; zero without a calibration): the centre
    /// fitted with a calibration off by `δ` is off by `S δ`, and every
    /// sphere probed with one probe shares that error.
    pub cal_sensitivity: [[f64; CAL_PARAMS]; 3],
}

/// A touch on a face or an edge, corrected for the probe.
#[derive(Debug, Clone, PartialEq)]
pub struct FaceTouch {
    /// Artifact name.
    pub artifact: String,
    /// Placement name.
    pub placement: String,
    /// Feature label (`f1`, `e2`).
    pub feature: String,
    /// Where the surface was touched (machine coordinates, mm): the tip's
    /// centre moved back along the surface normal by the effective radius.
    pub contact_mm: Vec3,
    /// The commanded position of the trigger (mm), where the machine's
    /// error is evaluated.
    pub q_mm: Vec3,
    /// Outward surface normal (machine coordinates).
    pub normal: Vec3,
    /// The probe's tool length (mm).
    pub tool_length_mm: f64,
    /// The direction the probe moved.
    pub direction: AxisDir,
    /// The axes' direction states at the touch, when known.
    pub states: Option<[Direction; 3]>,
    /// `|d·n|`: 1 for a head-on touch.
    pub cos: f64,
    /// Index of the calibration that corrected it (in [`Fitted::calibrations`]).
    pub calibration: usize,
}

/// Everything the touches give.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Fitted {
    /// One calibration per probe (tool length).
    pub calibrations: Vec<Calibration>,
    /// Sphere centres.
    pub spheres: Vec<SphereFit>,
    /// Face and edge touches.
    pub faces: Vec<FaceTouch>,
    /// Probing noise (µm per touch) pooled over every fit with redundancy.
    pub sigma_um: f64,
    /// What the user should know (no calibration, untripped touches …).
    pub warnings: Vec<String>,
}

fn located(t: &Touch, msg: String, help: &str) -> ProbeError {
    ProbeError::File(crate::error::MapFileError::new(
        t.source.file.clone(),
        t.source.line,
        1,
        msg,
        help,
    ))
}

/// The algebraic sphere through points (`|x|² = 2 c·x + k`), for a start.
fn algebraic_sphere(p: &[Vec3]) -> Option<(Vec3, f64)> {
    if p.len() < 4 {
        return None;
    }
    let o = p[0];
    let a = DMatrix::from_fn(p.len(), 4, |i, j| {
        let v = p[i] - o;
        if j < 3 {
            2.0 * v[j]
        } else {
            1.0
        }
    });
    let b: Vec<f64> = p.iter().map(|x| (*x - o).norm_squared()).collect();
    let s = linalg::pinv_solve(&a, &b, 1e-12)?;
    if s.rank < 4 {
        return None;
    }
    let c = Vec3::new(s.x[0], s.x[1], s.x[2]);
    let r2 = s.x[3] + c.norm_squared();
    (r2 > 0.0).then(|| (o + c, r2.sqrt()))
}

/// The start of a sphere fit when the algebraic sphere is not defined
/// (fewer than four touches, or coplanar ones): the centre one nominal
/// radius behind the touches along their directions.
fn start_centre(pts: &[(Vec3, AxisDir)], rho: f64) -> Vec3 {
    let n = pts.len().max(1) as f64;
    pts.iter().map(|(q, d)| *q + d.vector() * rho).sum::<Vec3>() * (1.0 / n)
}

/// Gauss–Newton on `residual(x) → (r, J)` (µm), minimum-norm steps.
fn gauss_newton(
    n: usize,
    mut residual: impl FnMut(&[f64]) -> (Vec<f64>, DMatrix<f64>),
) -> Result<(Vec<f64>, Vec<f64>, linalg::PinvSolution), ProbeError> {
    let mut x = vec![0.0; n];
    for _ in 0..50 {
        let (r, j) = residual(&x);
        let neg: Vec<f64> = r.iter().map(|v| -v).collect();
        let s = linalg::pinv_solve(&j, &neg, THRESHOLD)
            .ok_or_else(|| ProbeError::Invalid("a sphere fit's SVD did not converge".into()))?;
        let step = s.x.iter().map(|v| v * v).sum::<f64>().sqrt();
        for (xi, d) in x.iter_mut().zip(&s.x) {
            *xi += d;
        }
        if !step.is_finite() {
            return Err(ProbeError::Invalid("a sphere fit diverged".into()));
        }
        if step < 1e-7 {
            let (r, j) = residual(&x);
            let s = linalg::pinv_solve(&j, &vec![0.0; r.len()], THRESHOLD)
                .ok_or_else(|| ProbeError::Invalid("a sphere fit's SVD did not converge".into()))?;
            return Ok((x, r, s));
        }
    }
    Err(ProbeError::Invalid(
        "a sphere fit did not converge in 50 steps: are the touches of one sphere?".into(),
    ))
}

/// The reference sphere's fit for one probe.
fn calibrate(
    touches: &[&Touch],
    offsets_mm: &[Vec3],
    radius_mm: f64,
) -> Result<Calibration, ProbeError> {
    let pts: Vec<(Vec3, AxisDir)> = touches
        .iter()
        .zip(offsets_mm)
        .map(|(t, o)| (t.q_mm + *o, t.direction))
        .collect();
    let qs: Vec<Vec3> = pts.iter().map(|p| p.0).collect();
    let (c0, rho0) = algebraic_sphere(&qs).unwrap_or((start_centre(&pts, radius_mm), radius_mm));
    let r0 = rho0 - radius_mm;
    // Parameters (µm): c (3), r, p for the 6 directions, B for 3 axes.
    let n = 3 + 1 + 6 + 3;
    let states_known = touches.iter().all(|t| t.states.is_some());
    let eval = |x: &[f64]| -> (Vec<f64>, DMatrix<f64>) {
        let c = c0 + Vec3::new(x[0], x[1], x[2]) * 1e-3;
        let r = r0 + x[3] * 1e-3;
        let mut res = Vec::with_capacity(touches.len());
        let mut j = DMatrix::zeros(touches.len(), n);
        for (i, t) in touches.iter().enumerate() {
            let mut b = Vec3::ZERO;
            if let Some(s) = t.states {
                for a in 0..3 {
                    b[a] = sign(s[a]) * x[10 + a] / 2.0 * 1e-3;
                }
            }
            let a = pts[i].0 + b - c;
            let dist = a.norm();
            let nv = a * (1.0 / dist);
            let cos = t.direction.vector().dot(nv).abs();
            let p = x[4 + t.direction.index()] * 1e-3;
            res.push((dist - radius_mm - r + p * cos) * 1e3);
            for k in 0..3 {
                j[(i, k)] = -nv[k];
            }
            j[(i, 3)] = -1.0;
            j[(i, 4 + t.direction.index())] = cos;
            if let Some(s) = t.states {
                for k in 0..3 {
                    j[(i, 10 + k)] = nv[k] * sign(s[k]) / 2.0;
                }
            }
        }
        (res, j)
    };
    let (x, res, sol) = gauss_newton(n, eval)?;
    let m = touches.len();
    let dof = m.saturating_sub(sol.rank);
    let rss: f64 = res.iter().map(|v| v * v).sum();
    let sigma = if dof > 0 {
        (rss / dof as f64).sqrt()
    } else {
        f64::NAN
    };
    let cov = &sol.f * sol.f.transpose() * (sigma * sigma);
    let est = |k: usize| -> Option<Estimate> {
        (sol.null_share[k] < SEEN).then(|| Estimate {
            value: x[k],
            sigma: cov[(k, k)].max(0.0).sqrt(),
        })
    };
    let mut unseen = Vec::new();
    let tip = est(3);
    if tip.is_none() {
        unseen.push("tip radius (apart from the pre-travel)".to_string());
    }
    let mut pretravel_um = [None; 6];
    for d in AxisDir::ALL {
        let used = touches.iter().any(|t| t.direction == d);
        if used {
            pretravel_um[d.index()] = est(4 + d.index());
            if pretravel_um[d.index()].is_none() {
                unseen.push(format!("pre-travel {}", d.label()));
            }
        }
    }
    let mut reversal_um = [None; 3];
    for (a, slot) in reversal_um.iter_mut().enumerate() {
        *slot = if states_known { est(10 + a) } else { None };
        if slot.is_none() {
            unseen.push(format!("reversal of {}", ['X', 'Y', 'Z'][a]));
        }
    }
    let cov_factor_um = (0..n)
        .map(|i| (0..sol.rank).map(|k| sol.f[(i, k)] * sigma).collect())
        .collect();
    Ok(Calibration {
        dof,
        cov_factor_um,
        u_reference_radius_um: 0.0,
        tool_length_mm: touches[0].tool_length_mm,
        tip_radius_mm: Estimate {
            value: r0 + x[3] * 1e-3,
            sigma: tip.map_or(f64::NAN, |t| t.sigma),
        },
        pretravel_um,
        reversal_um,
        centre_mm: c0 + Vec3::new(x[0], x[1], x[2]) * 1e-3,
        sigma_um: sigma,
        residuals_um: res,
        unseen,
    })
}

/// What [`sphere`] finds.
struct SphereSolution {
    centre_mm: Vec3,
    radius_mm: f64,
    unit_cov: [[f64; 3]; 3],
    cal_sensitivity: [[f64; CAL_PARAMS]; 3],
    residuals_um: Vec<f64>,
    dof: usize,
}

/// `∂c/∂p` of a sphere centre fitted by least squares to touches corrected
/// with calibration `cal` (µm per µm; the implicit-function theorem on the
/// normal equations: `∂x/∂p = −J⁺ ∂r/∂p`, `J` the fit's Jacobian at the
/// solution). A touch's residual `|q − c| − ρ − r_eff` moves by −1 per µm
/// of tip radius, by `cos` per µm of pre-travel in its direction, and by
/// `n_a·sign(s_a)/2` per µm of axis `a`'s reversal (the offset the
/// calibration adds to `q`); the reference sphere's own centre does not
/// enter. With a free radius the tip radius only trades with the radius.
///
/// `states` are the touches' direction states, `reversal_seen` which axes'
/// reversals the calibration applied, `n` the fit's unknowns (3, or 4 with
/// a free radius).
fn calibration_sensitivity(
    pts: &[(Vec3, AxisDir)],
    states: &[Option<[Direction; 3]>],
    reversal_seen: [bool; 3],
    centre_mm: Vec3,
    n: usize,
) -> Result<[[f64; CAL_PARAMS]; 3], ProbeError> {
    let mut j = DMatrix::zeros(pts.len(), n);
    let mut d = DMatrix::zeros(pts.len(), CAL_PARAMS);
    for (i, ((q, dir), st)) in pts.iter().zip(states).enumerate() {
        let a = *q - centre_mm;
        let nv = a * (1.0 / a.norm());
        for k in 0..3 {
            j[(i, k)] = -nv[k];
        }
        if n == 4 {
            j[(i, 3)] = -1.0;
        }
        d[(i, 3)] = -1.0;
        d[(i, 4 + dir.index())] = dir.vector().dot(nv).abs();
        if let Some(st) = st {
            for ax in 0..3 {
                if reversal_seen[ax] {
                    d[(i, 10 + ax)] = nv[ax] * sign(st[ax]) / 2.0;
                }
            }
        }
    }
    let mut out = [[0.0; CAL_PARAMS]; 3];
    for p in 3..CAL_PARAMS {
        let b: Vec<f64> = (0..pts.len()).map(|i| -d[(i, p)]).collect();
        if b.iter().all(|v| *v == 0.0) {
            continue;
        }
        let s = linalg::pinv_solve(&j, &b, THRESHOLD)
            .ok_or_else(|| ProbeError::Invalid("a sphere fit's SVD did not converge".into()))?;
        for (c, row) in out.iter_mut().enumerate() {
            row[p] = s.x[c];
        }
    }
    Ok(out)
}

/// Touches of one feature in one placement: (artifact index, placement, feature).
type Group<'a> = ((usize, String, String), Vec<&'a Touch>);

/// The centre (and radius) of one sphere from its touches.
fn sphere(
    touches: &[&Touch],
    offsets_mm: &[Vec3],
    nominal_radius_mm: f64,
    certified_radius_mm: Option<f64>,
    cal: Option<&Calibration>,
) -> Result<SphereSolution, ProbeError> {
    let corr = |t: &Touch, o: Vec3| -> Vec3 {
        t.q_mm + o + cal.map_or(Vec3::ZERO, |c| c.reversal_offset_mm(t.states))
    };
    let pts: Vec<(Vec3, AxisDir)> = touches
        .iter()
        .zip(offsets_mm)
        .map(|(t, o)| (corr(t, *o), t.direction))
        .collect();
    let qs: Vec<Vec3> = pts.iter().map(|p| p.0).collect();
    let tip0 = cal.map_or(0.0, |c| c.tip_radius_mm.value);
    let (c0, _) = algebraic_sphere(&qs)
        .filter(|(c, rho)| {
            (rho - nominal_radius_mm - tip0).abs() < 0.5 * nominal_radius_mm && c.is_finite()
        })
        .unwrap_or((start_centre(&pts, nominal_radius_mm + tip0), 0.0));
    let free_radius = certified_radius_mm.is_none();
    let r_start = certified_radius_mm.unwrap_or(nominal_radius_mm);
    let n = if free_radius { 4 } else { 3 };
    let eval = |x: &[f64]| -> (Vec<f64>, DMatrix<f64>) {
        let c = c0 + Vec3::new(x[0], x[1], x[2]) * 1e-3;
        let radius = r_start + if free_radius { x[3] * 1e-3 } else { 0.0 };
        let mut res = Vec::with_capacity(pts.len());
        let mut j = DMatrix::zeros(pts.len(), n);
        for (i, (q, d)) in pts.iter().enumerate() {
            let a = *q - c;
            let dist = a.norm();
            let nv = a * (1.0 / dist);
            let reff = match cal {
                Some(cl) => cl.effective_radius_mm(*d, d.vector().dot(nv).abs()),
                None => tip0,
            };
            res.push((dist - radius - reff) * 1e3);
            for k in 0..3 {
                j[(i, k)] = -nv[k];
            }
            if free_radius {
                j[(i, 3)] = -1.0;
            }
        }
        (res, j)
    };
    let (x, res, sol) = gauss_newton(n, eval)?;
    if sol.null_share.iter().take(3).any(|s| *s > SEEN) {
        return Err(ProbeError::Invalid(
            "its touches do not fix the centre (too few directions)".into(),
        ));
    }
    let cov = &sol.f * sol.f.transpose();
    let mut unit_cov = [[0.0; 3]; 3];
    for (a, row) in unit_cov.iter_mut().enumerate() {
        for (b, v) in row.iter_mut().enumerate() {
            *v = cov[(a, b)];
        }
    }
    let radius = r_start + if free_radius { x[3] * 1e-3 } else { 0.0 };
    let centre_mm = c0 + Vec3::new(x[0], x[1], x[2]) * 1e-3;
    let cal_sensitivity = match cal {
        Some(cl) => {
            let states: Vec<_> = touches.iter().map(|t| t.states).collect();
            let seen = [0, 1, 2].map(|a| cl.reversal_um[a].is_some());
            calibration_sensitivity(&pts, &states, seen, centre_mm, n)?
        }
        None => [[0.0; CAL_PARAMS]; 3],
    };
    Ok(SphereSolution {
        centre_mm,
        radius_mm: radius,
        unit_cov,
        cal_sensitivity,
        dof: pts.len().saturating_sub(sol.rank),
        residuals_um: res,
    })
}

/// Fits every touch: calibrations from the reference spheres, then sphere
/// centres and probe-corrected face contacts. Touches are checked against
/// the artifacts (artifact, placement and feature must exist; a face is
/// touched against its normal).
///
/// `field` (µm, at an axis position for a tool length), when given, is the
/// machine's geometric deviation as far as it is known: its variation over
/// each sphere (not its value at the centre, which is what the spheres
/// measure) is taken out of the touches first — on the reference sphere
/// the machine's local scale would otherwise pass for pre-travel (a 25 mm
/// sphere on an axis 50 µm/m long reads 1.3 µm small).
pub fn fit_touches(
    artifacts: &[Artifact],
    touches: &[Touch],
    field: Option<&dyn Fn(Vec3, f64) -> Vec3>,
) -> Result<Fitted, ProbeError> {
    // The within-sphere variation of `field` at each touch (mm), about `c`.
    let shape = |ts: &[&Touch], c: Vec3| -> Vec<Vec3> {
        ts.iter()
            .map(|t| match field {
                Some(f) => (f(t.q_mm, t.tool_length_mm) - f(c, t.tool_length_mm)) * 1e-3,
                None => Vec3::ZERO,
            })
            .collect()
    };
    let mut out = Fitted::default();
    let mut skipped = 0usize;
    // Check and group.
    let mut groups: Vec<Group> = Vec::new();
    for t in touches {
        let ai = artifacts
            .iter()
            .position(|a| a.name == t.artifact)
            .ok_or_else(|| {
                located(
                    t,
                    format!(
                        "artifact `{}` is not among the artifacts given ({})",
                        t.artifact,
                        artifacts
                            .iter()
                            .map(|a| a.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                    "give the artifact file of every log",
                )
            })?;
        let art = &artifacts[ai];
        let pl = art.placement(&t.placement).ok_or_else(|| {
            located(
                t,
                format!("artifact `{}` has no placement `{}`", art.name, t.placement),
                "use the placement names of the artifact file",
            )
        })?;
        let f = art.feature(&t.feature).ok_or_else(|| {
            located(
                t,
                format!("artifact `{}` has no feature `{}`", art.name, t.feature),
                "spheres are s1, s2 …, gauge faces f1, f2 …, square edges e1, e2",
            )
        })?;
        if let Feature::Face { facing, .. } = f {
            let nrm = pl.direction(Vec3::new(facing, 0.0, 0.0));
            if t.direction.vector().dot(nrm) > -0.9 {
                return Err(located(
                    t,
                    format!(
                        "face {} looks along ({:.2}, {:.2}, {:.2}) but was touched moving {}",
                        t.feature,
                        nrm.x,
                        nrm.y,
                        nrm.z,
                        t.direction.label()
                    ),
                    "touch a face against its normal",
                ));
            }
        }
        if !t.tripped {
            skipped += 1;
            continue;
        }
        if !t.q_mm.is_finite() {
            return Err(located(
                t,
                "a touch position is not finite".into(),
                "check the log",
            ));
        }
        let key = (ai, t.placement.clone(), t.feature.clone());
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => v.push(t),
            None => groups.push((key, vec![t])),
        }
    }
    if skipped > 0 {
        out.warnings.push(format!(
            "{skipped} touch(es) did not trip (ok=0 after G38.3) and are left out"
        ));
    }
    // Calibrations: the reference sphere, per tool length.
    for ((ai, _, _), ts) in groups
        .iter()
        .filter(|((ai, _, _), _)| artifacts[*ai].is_reference())
    {
        let art = &artifacts[*ai];
        let Kind::ReferenceSphere {
            diameter_mm,
            u_diameter_um,
        } = art.kind
        else {
            continue;
        };
        let mut by_tool: Vec<Vec<&Touch>> = Vec::new();
        for t in ts {
            match by_tool
                .iter_mut()
                .find(|g| (g[0].tool_length_mm - t.tool_length_mm).abs() < SAME_TOOL_MM)
            {
                Some(g) => g.push(t),
                None => by_tool.push(vec![t]),
            }
        }
        for g in by_tool {
            if g.len() < 5 {
                return Err(located(g[0], format!("the reference sphere has {} touches with this probe; its calibration needs the plan's set (17)", g.len()), "probe the reference sphere with the program `volcomp probe plan` writes for it"));
            }
            let fail = |e: ProbeError| {
                located(
                    g[0],
                    format!("reference sphere: {e}"),
                    "check that these are the touches of the reference sphere",
                )
            };
            let mut cal =
                calibrate(&g, &vec![Vec3::ZERO; g.len()], diameter_mm / 2.0).map_err(fail)?;
            if field.is_some() {
                cal = calibrate(&g, &shape(&g, cal.centre_mm), diameter_mm / 2.0).map_err(fail)?;
            }
            cal.u_reference_radius_um = u_diameter_um / 2.0;
            out.calibrations.push(cal);
        }
    }
    let cal_for = |tool: f64| -> Option<&Calibration> {
        out.calibrations
            .iter()
            .find(|c| (c.tool_length_mm - tool).abs() < SAME_TOOL_MM)
    };
    let mut spheres = Vec::new();
    let mut faces = Vec::new();
    let mut uncalibrated = false;
    for ((ai, placement, feature), ts) in &groups {
        let art = &artifacts[*ai];
        if art.is_reference() {
            continue;
        }
        let f = art.feature(feature).expect("checked above");
        let tool = ts[0].tool_length_mm;
        if let Some(t) = ts
            .iter()
            .find(|t| (t.tool_length_mm - tool).abs() >= SAME_TOOL_MM)
        {
            return Err(located(t, format!("feature {feature} of {placement} touched with two tool lengths ({tool} and {} mm)", t.tool_length_mm), "probe a feature with one probe; give each probe its own placement"));
        }
        let cal = cal_for(tool);
        match f {
            Feature::Sphere { radius_mm, .. } => {
                let certified = match &art.kind {
                    Kind::Spheres {
                        certified_diameter: Some((d, _)),
                        ..
                    } => Some(d / 2.0),
                    _ => None,
                };
                if cal.is_none() {
                    uncalibrated = true;
                }
                let need = if certified.is_some() { 3 } else { 4 };
                if ts.len() < need {
                    return Err(located(ts[0], format!("sphere {feature} of {placement} has {} touches; its centre needs at least {need}", ts.len()), "probe every sphere with the plan's touches"));
                }
                let SphereSolution {
                    centre_mm,
                    radius_mm: radius,
                    unit_cov,
                    cal_sensitivity,
                    residuals_um,
                    dof,
                } = {
                    let fail = |e: ProbeError| {
                        located(
                            ts[0],
                            format!("sphere {feature} of {placement}: {e}"),
                            "check the touches of this sphere",
                        )
                    };
                    let first = sphere(ts, &vec![Vec3::ZERO; ts.len()], radius_mm, certified, cal)
                        .map_err(fail)?;
                    if field.is_some() {
                        sphere(ts, &shape(ts, first.centre_mm), radius_mm, certified, cal)
                            .map_err(fail)?
                    } else {
                        first
                    }
                };
                spheres.push(SphereFit {
                    artifact: art.name.clone(),
                    placement: placement.clone(),
                    feature: feature.clone(),
                    centre_mm,
                    radius_mm: radius,
                    unit_cov,
                    residuals_um,
                    dof,
                    tool_length_mm: tool,
                    calibrated: cal.is_some(),
                    cal_sensitivity,
                });
            }
            Feature::Face { .. } | Feature::Edge { .. } => {
                let Some(cal) = cal else {
                    return Err(located(ts[0], format!("{} touches of {} need the probe's calibration (no reference sphere was probed with tool length {tool} mm)", art.kind.word(), art.name), "probe the reference sphere with the same probe first and give its log too"));
                };
                let pl = art.placement(placement).expect("checked above");
                let calibration = out
                    .calibrations
                    .iter()
                    .position(|c| (c.tool_length_mm - tool).abs() < SAME_TOOL_MM)
                    .unwrap_or(0);
                for t in ts {
                    let normal = match f {
                        Feature::Face { facing, .. } => pl.direction(Vec3::new(facing, 0.0, 0.0)),
                        _ => t.direction.opposite().vector(),
                    };
                    let cos = t.direction.vector().dot(normal).abs();
                    let a = t.q_mm + cal.reversal_offset_mm(t.states);
                    faces.push(FaceTouch {
                        artifact: art.name.clone(),
                        placement: placement.clone(),
                        feature: feature.clone(),
                        contact_mm: a - normal * cal.effective_radius_mm(t.direction, cos),
                        q_mm: t.q_mm,
                        normal,
                        tool_length_mm: tool,
                        direction: t.direction,
                        states: t.states,
                        cos,
                        calibration,
                    });
                }
            }
        }
    }
    if uncalibrated {
        out.warnings.push("no reference sphere was probed with the probe of some spheres: their touches are not corrected for pre-travel and reversal; that shifts every centre probed the same way by the same amount, which the placements absorb, but the spheres' radii are not their own".into());
    }
    // Pooled touch noise.
    let (mut rss, mut dof) = (0.0, 0usize);
    for s in &spheres {
        rss += s.residuals_um.iter().map(|v| v * v).sum::<f64>();
        dof += s.dof;
    }
    for c in &out.calibrations {
        if c.sigma_um.is_finite() {
            let d = c.dof.max(1);
            rss += c.sigma_um * c.sigma_um * d as f64;
            dof += d;
        }
    }
    out.sigma_um = if dof > 0 {
        (rss / dof as f64).sqrt()
    } else {
        f64::NAN
    };
    // The probing noise is the probe's: a calibration's own residuals have
    // a few degrees of freedom only (17 touches, 12 unknowns), so its
    // uncertainties are scaled to the pooled noise.
    if out.sigma_um.is_finite() && out.sigma_um > 0.0 {
        for c in &mut out.calibrations {
            if !(c.sigma_um.is_finite() && c.sigma_um > 0.0) {
                continue;
            }
            let k = out.sigma_um / c.sigma_um;
            let scale = |e: &mut Option<Estimate>| {
                if let Some(e) = e {
                    e.sigma *= k;
                }
            };
            c.pretravel_um.iter_mut().for_each(scale);
            c.reversal_um.iter_mut().for_each(scale);
            c.tip_radius_mm.sigma *= k;
            for row in &mut c.cov_factor_um {
                row.iter_mut().for_each(|v| *v *= k);
            }
        }
    }
    for c in &mut out.calibrations {
        let u = c.u_reference_radius_um;
        if u > 0.0 {
            for (i, row) in c.cov_factor_um.iter_mut().enumerate() {
                row.push(if i == 3 { -u } else { 0.0 });
            }
            c.tip_radius_mm.sigma = c.tip_radius_mm.sigma.hypot(u);
        }
    }
    out.spheres = spheres;
    out.faces = faces;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Six head-on touches of a unit sphere at the origin, one per direction
    /// of motion (the touch moving +X lands on the −X side).
    fn six() -> Vec<(Vec3, AxisDir)> {
        AxisDir::ALL
            .iter()
            .map(|d| (d.vector() * -1.0, *d))
            .collect()
    }

    #[test]
    fn a_centre_moves_by_half_the_pre_travel_difference_of_opposite_touches() {
        // Hand calculation, free radius: one µm more pre-travel on +X raises
        // the residual of the touch on the −X side by 1 (cos = 1). Normal
        // equations: x: (dx − dR + 1) − (−dx − dR) = 0 → dx = −½; the four
        // other touches only fix dR = 1/6. Y and Z do not move; the tip
        // radius trades with the radius alone.
        let s = calibration_sensitivity(&six(), &[None; 6], [false; 3], Vec3::ZERO, 4).unwrap();
        let plus_x = 4 + AxisDir::new(0, true).index();
        let minus_x = 4 + AxisDir::new(0, false).index();
        assert!((s[0][plus_x] + 0.5).abs() < 1e-12, "{}", s[0][plus_x]);
        assert!((s[0][minus_x] - 0.5).abs() < 1e-12, "{}", s[0][minus_x]);
        assert!(s[1][plus_x].abs() < 1e-12 && s[2][plus_x].abs() < 1e-12);
        assert!((0..3).all(|c| s[c][3].abs() < 1e-12));
    }

    #[test]
    fn with_a_known_radius_the_tip_radius_moves_a_one_sided_centre() {
        // Touches on the four sides and on top (moving −Z), none from
        // below, radius known. A tip radius one µm larger lowers every
        // residual by 1 µm; ∂c/∂r_tip solves −n_i·dc = 1 in least squares:
        // opposite sides pull ±1 on X and Y and cancel, the top (n = +Z)
        // alone gives dz = −1 µm per µm.
        let pts: Vec<_> = six().into_iter().filter(|(_, d)| d.index() != 4).collect();
        let s = calibration_sensitivity(&pts, &[None; 5], [false; 3], Vec3::ZERO, 3).unwrap();
        assert!((s[2][3] + 1.0).abs() < 1e-12, "{}", s[2][3]);
        assert!(s[0][3].abs() < 1e-12 && s[1][3].abs() < 1e-12);
    }

    #[test]
    fn a_reversal_moves_the_centre_by_half_of_it_when_every_touch_shares_the_state() {
        // Every touch made with X in reverse: the calibration adds +b/2 to
        // every X, so the whole sphere, centre included, moves by +½.
        let st = Some([Direction::Reverse, Direction::Forward, Direction::Forward]);
        let s =
            calibration_sensitivity(&six(), &[st; 6], [true, false, false], Vec3::ZERO, 4).unwrap();
        assert!((s[0][10] - 0.5).abs() < 1e-12, "{}", s[0][10]);
        assert!(s[0][11].abs() < 1e-12);
    }
}
