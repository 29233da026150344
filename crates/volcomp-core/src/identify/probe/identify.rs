//! The machine identified together with the artifacts' own errors and
//! their placements (docs/probing.md, "Identification").
//!
//! **Observations.** A sphere `j` of an artifact in placement `k` has its
//! true centre at `s = t_k + R_k (b_j − b̄)` (`b_j` in the artifact's frame,
//! `b̄` the artifact's centroid, `t_k` where the centroid sits); the fit
//! measured `m = s − e(s)` (docs/thermal.md, §2). A touch on a plane face
//! with artifact-frame normal `n` at offset `h` measured the contact `c`
//! with `n·(R_k⁻¹(c + e − t_k) + b̄) = h`. Linearised about the current
//! placements and geometry (µm and µrad):
//!
//! ```text
//! sphere:  1e3 (m − ŝ)   =  ω_k × R̂_k(b̂_j − b̄)·1e-3 + δt_k + R̂_k δb_j − B(m) θ
//! face:    −1e3 f̂       = −(v × n̂)·ω_k·1e-3 − n̂·δt_k − δh_f + δ (∂n/∂δ · x)·1e-3 + n̂·B(q) θ
//! ```
//!
//! with `B(q)` the first-order model's columns at the commanded position
//! (the Legendre-polynomial 21-component model of [`crate::identify::thermal::poly`]),
//! `ω_k, δt_k` the placement's small turn and shift, `δb_j`, `δh_f`, `δ`
//! the artifact's own deviations (sphere positions, face offsets, a
//! square's angle). The artifact's deviations are unknowns — several
//! placements of one artifact, shifted and turned, separate them from the
//! machine's errors, the multi-position and reversal methods of coordinate
//! metrology [Evans, Hocken & Estler 1996], [Trapet & Wäldele 1991] — unless
//! a certificate gives them (rows `δ = certified − current ± u`,
//! [ISO 15530-3]).
//!
//! The probe calibration's error `δ = G z` (`z ~ N(0, I)`, `G G^T` its
//! covariance) is a nuisance too: it enters a face row through the
//! effective radius and reversal it corrected, and a sphere's three rows
//! through the centre's sensitivity `S` to it (fit.rs).
//!
//! **Solution.** Rows whitened (a sphere's three by the Cholesky factor of
//! its centre's covariance, a face touch by one touch's noise, certificate
//! rows by their uncertainty in that unit), the placements' and artifacts'
//! unknowns projected out (`J_m ← (I − U Uᵀ) J_m`, `U` an orthonormal basis
//! of their columns), and the machine's parameters solved as in the
//! thermal identification (column scaling, SVD, rank, minimum-norm
//! solution, a parameter identifiable when its unit vector lies outside the
//! null space, covariance `σ0² D⁻¹ V S⁻² Vᵀ D⁻¹` with σ0 from the residuals).
//! Then the placements and the artifact are updated and the whole is
//! linearised again (three times: the geometry moves by µm).
//!
//! **Scale.** An artifact's size and the machine's common scale trade
//! exactly: with no calibrated length among the measurements (a certified
//! artifact or gauge), every uncertified sphere artifact is held at its
//! nominal size (one constraint row, `Σ (b̂_j − b̄)·δb_j = 0`) and the result
//! says that the common scale is the artifact's, not measured.

use super::artifact::{Artifact, Feature, Kind};
use super::fit::{fit_touches, Estimate, FaceTouch, Fitted, SphereFit, CAL_PARAMS, SAME_TOOL_MM};
use super::geometry::{rigid_fit, rotate, turn, Rotation};
use super::ProbeError;
use crate::identify::thermal::identify::{solve_whitened_with_design, Identification};
use crate::identify::thermal::poly::{Param, PolyModel};
use crate::io::probe_log::Touch;
use crate::linalg;
use nalgebra::DMatrix;
use volcomp_gcode::Vec3;

/// Which parameters the model has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelChoice {
    /// The 21-component model (every parameter of the polynomial model).
    Full,
    /// Positioning, straightness and squareness only; angles assumed zero
    /// (for measurements along lines: gauges, squares).
    Reduced,
    /// Full when spheres were measured in two placements or more, else reduced.
    Auto,
}

/// Options of the identification.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifyOptions {
    /// Kinematic chain, workpiece to tool (docs/kinematic.md).
    pub chain: String,
    /// Axis ranges the polynomials live on (mm): the machine's travel.
    pub ranges_mm: [[f64; 2]; 3],
    /// Largest Legendre order of the components.
    pub order: usize,
    /// Which model.
    pub model: ModelChoice,
    /// Relative singular-value threshold (of the largest).
    pub relative_threshold: f64,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        Self {
            chain: "w X' Y' b Z t".into(),
            ranges_mm: [[0.0, 600.0], [0.0, 400.0], [0.0, 300.0]],
            order: 2,
            model: ModelChoice::Auto,
            relative_threshold: crate::identify::thermal::identify::DEFAULT_RELATIVE_THRESHOLD,
        }
    }
}

/// Where a parameter stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Status {
    /// Identified: its value and standard uncertainty.
    Identified(Estimate),
    /// In the model, but these measurements cannot see it (alone): zero,
    /// unknown.
    NotSeen,
    /// Not in the (reduced) model: zero, unknown.
    NotInModel,
}

/// One parameter of the result.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamResult {
    /// Its name (`EXX.P1`, `S_xy`, …).
    pub name: String,
    /// `um` or `urad`.
    pub unit: &'static str,
    /// What is known of it.
    pub status: Status,
}

/// What the measurements of one placement left after the fit.
#[derive(Debug, Clone, PartialEq)]
pub struct Residual {
    /// Artifact name.
    pub artifact: String,
    /// Placement name.
    pub placement: String,
    /// Feature label.
    pub feature: String,
    /// Where (machine coordinates, mm).
    pub at_mm: Vec3,
    /// The residual (µm): a vector for a sphere, along the normal for a
    /// face touch (in `.x`).
    pub residual_um: Vec3,
}

/// Leave-one-placement-out: the machine identified without a placement,
/// then that placement predicted.
#[derive(Debug, Clone, PartialEq)]
pub struct HeldOut {
    /// Artifact name.
    pub artifact: String,
    /// Placement name.
    pub placement: String,
    /// RMS deviation of its sphere centres from the artifact after the
    /// best rigid fit, uncorrected (µm).
    pub before_um: f64,
    /// The same after correcting them with the model identified without it (µm).
    pub after_um: f64,
}

/// The result of an identification.
#[derive(Debug, Clone)]
pub struct Identified {
    /// The polynomial model (its parameter list: the model chosen).
    pub model: PolyModel,
    /// The full parameter list of the order (for the report of what the
    /// reduced model leaves out).
    pub all_params: Vec<Param>,
    /// The solution (thermal identification's form: values, σ, rank,
    /// null space, covariance factor).
    pub ident: Identification,
    /// Per parameter of the full list.
    pub params: Vec<ParamResult>,
    /// Unobservable combinations, as text (`EXX.P2 + 0.41 EBX.P2`).
    pub combinations: Vec<String>,
    /// The probe's length the model's angles refer to (mm).
    pub probe_length_mm: f64,
    /// Whether the scale was held at an artifact's nominal size.
    pub scale_from_artifact: bool,
    /// Residuals of every observation.
    pub residuals: Vec<Residual>,
    /// The artifacts' own deviations from their nominal (or certified)
    /// geometry, as identified: `(artifact, feature, deviation)` — sphere
    /// positions (µm, after removing the best rigid motion), face offsets
    /// (µm, in `.x`), a square's angle (µrad, in `.x`, feature `angle`).
    pub artifact_deviations: Vec<(String, String, Vec3)>,
    /// Number of observations (rows).
    pub observations: usize,
    /// Probing noise (µm per touch) the weights assume.
    pub touch_sigma_um: f64,
    /// What the user should know.
    pub notes: Vec<String>,
    /// The Monte Carlo of the whole chain, when asked for
    /// ([`super::monte_carlo`]): the σ of [`Self::params`] are then the
    /// larger of the two.
    pub monte_carlo: Option<super::monte_carlo::MonteCarlo>,
}

impl Identified {
    /// The parameter vector with unknown parameters as zero.
    pub fn theta(&self) -> Vec<f64> {
        self.ident.theta.iter().map(|t| t.unwrap_or(0.0)).collect()
    }
}

// ---------------------------------------------------------------------------

/// A placement's current pose.
#[derive(Debug, Clone)]
struct Pose {
    artifact: usize,
    name: String,
    rot: Rotation,
    /// Machine position of the artifact's centroid (mm).
    t_mm: Vec3,
}

/// An artifact's current geometry (artifact frame).
#[derive(Debug, Clone)]
struct Geometry {
    /// Sphere centres (mm).
    balls: Vec<Vec3>,
    /// Face / edge offsets along their normal (mm).
    offsets: Vec<f64>,
    /// A square's angle deviation (µrad).
    angle_urad: f64,
    /// The centroid of the features (mm).
    centroid: Vec3,
}

/// What one observation is.
#[derive(Debug, Clone, Copy)]
enum Obs {
    Sphere(usize),
    Face(usize),
}

/// The nuisance columns' layout.
struct Layout {
    /// First column of placement `k`: ω (3), δt (3).
    pose: Vec<usize>,
    /// First column of artifact `a`'s geometry.
    geom: Vec<usize>,
    /// First column of calibration `c`'s unknowns (its covariance factor's
    /// rank of them), for the face touches it corrected.
    cal: Vec<Option<usize>>,
    total: usize,
}

struct Problem<'a> {
    artifacts: &'a [Artifact],
    fitted: &'a Fitted,
    model: PolyModel,
    obs: Vec<Obs>,
    /// Placement index of every observation.
    obs_pose: Vec<usize>,
    /// Machine-model columns of every observation (per parameter, µm).
    basis: Vec<Vec<Vec3>>,
    poses: Vec<Pose>,
    geoms: Vec<Geometry>,
    layout: Layout,
    touch_sigma_um: f64,
    length_reference: bool,
    threshold: f64,
}

fn artifact_centroid(a: &Artifact) -> Vec3 {
    let f = a.features();
    let pts: Vec<Vec3> = f
        .iter()
        .map(|f| match f {
            Feature::Sphere { centre_mm, .. } => *centre_mm,
            Feature::Face { x_mm, .. } => Vec3::new(*x_mm, 0.0, 0.0),
            Feature::Edge { index, length_mm } => {
                if *index == 0 {
                    Vec3::new(length_mm / 2.0, 0.0, 0.0)
                } else {
                    Vec3::new(0.0, length_mm / 2.0, 0.0)
                }
            }
        })
        .collect();
    pts.iter().copied().sum::<Vec3>() * (1.0 / pts.len().max(1) as f64)
}

/// The number of geometry unknowns of an artifact.
fn geometry_columns(a: &Artifact) -> usize {
    match &a.kind {
        Kind::ReferenceSphere { .. } => 0,
        Kind::Spheres { centres_mm, .. } => 3 * centres_mm.len(),
        Kind::Gauge { faces_mm, .. } => faces_mm.len(),
        Kind::Square { .. } => 3,
    }
}

/// The outward normal of a face or edge in the artifact frame for a
/// square angle `angle_urad`, and its derivative by the angle (per rad).
fn face_normal(a: &Artifact, f: &Feature, angle_urad: f64) -> (Vec3, Vec3) {
    match (f, &a.kind) {
        (Feature::Face { facing, .. }, _) => (Vec3::new(*facing, 0.0, 0.0), Vec3::ZERO),
        (Feature::Edge { index: 0, .. }, Kind::Square { inner, .. }) => {
            let s = if *inner { 1.0 } else { -1.0 };
            (Vec3::new(0.0, s, 0.0), Vec3::ZERO)
        }
        (Feature::Edge { .. }, Kind::Square { inner, .. }) => {
            // Edge 2 runs along (−δ, 1, 0): the angle between the edges is
            // 90° + δ. Outer normal (−1, −δ, 0), inner (1, δ, 0).
            let d = angle_urad * 1e-6;
            if *inner {
                (Vec3::new(1.0, d, 0.0), Vec3::new(0.0, 1.0, 0.0))
            } else {
                (Vec3::new(-1.0, -d, 0.0), Vec3::new(0.0, -1.0, 0.0))
            }
        }
        _ => (Vec3::ZERO, Vec3::ZERO),
    }
}

/// The reduced parameter list: positioning, straightness and squareness.
fn reduced(params: &[Param]) -> Vec<Param> {
    params
        .iter()
        .copied()
        .filter(|p| match p {
            Param::Legendre { component, .. } => *component < 3,
            Param::Squareness(_) => true,
        })
        .collect()
}

/// The machine's probe length: the most frequent tool length of the fits.
fn probe_length(fitted: &Fitted) -> f64 {
    let mut lengths: Vec<(f64, usize)> = Vec::new();
    let all = fitted
        .spheres
        .iter()
        .map(|s| s.tool_length_mm)
        .chain(fitted.faces.iter().map(|f| f.tool_length_mm));
    for l in all {
        match lengths.iter_mut().find(|(v, _)| (v - l).abs() < 1e-3) {
            Some(e) => e.1 += 1,
            None => lengths.push((l, 1)),
        }
    }
    lengths
        .iter()
        .max_by_key(|(_, n)| *n)
        .map_or(0.0, |(v, _)| *v)
}

impl<'a> Problem<'a> {
    fn new(
        artifacts: &'a [Artifact],
        fitted: &'a Fitted,
        o: &IdentifyOptions,
    ) -> Result<Self, ProbeError> {
        let l0 = probe_length(fitted);
        let mut model =
            crate::identify::thermal::files::poly_model(&o.chain, o.ranges_mm, o.order, l0)
                .map_err(|e| ProbeError::Invalid(e.to_string()))?;
        // Placements with observations.
        let mut poses: Vec<Pose> = Vec::new();
        let mut obs = Vec::new();
        let mut obs_pose = Vec::new();
        let pose_of =
            |poses: &mut Vec<Pose>, art: &str, placement: &str| -> Result<usize, ProbeError> {
                let ai = artifacts
                    .iter()
                    .position(|a| a.name == art)
                    .ok_or_else(|| ProbeError::Invalid(format!("artifact `{art}` not given")))?;
                if let Some(k) = poses
                    .iter()
                    .position(|p| p.artifact == ai && p.name == placement)
                {
                    return Ok(k);
                }
                let pl = artifacts[ai].placement(placement).ok_or_else(|| {
                    ProbeError::Invalid(format!("placement `{placement}` not in `{art}`"))
                })?;
                let c = artifact_centroid(&artifacts[ai]);
                poses.push(Pose {
                    artifact: ai,
                    name: placement.to_string(),
                    rot: pl.axes,
                    t_mm: pl.to_machine(c),
                });
                Ok(poses.len() - 1)
            };
        for (i, s) in fitted.spheres.iter().enumerate() {
            let k = pose_of(&mut poses, &s.artifact, &s.placement)?;
            obs.push(Obs::Sphere(i));
            obs_pose.push(k);
        }
        for (i, f) in fitted.faces.iter().enumerate() {
            let k = pose_of(&mut poses, &f.artifact, &f.placement)?;
            obs.push(Obs::Face(i));
            obs_pose.push(k);
        }
        if obs.is_empty() {
            return Err(ProbeError::Invalid(
                "nothing to identify from: the logs have touches of the reference sphere only; probe an artifact (spheres, a gauge, a square) too".into(),
            ));
        }
        for (a, r) in o.ranges_mm.iter().enumerate() {
            for s in &fitted.spheres {
                let v = s.centre_mm[a];
                if v < r[0] - 1.0 || v > r[1] + 1.0 {
                    return Err(ProbeError::Invalid(format!(
                        "sphere {} of {} at {}: {} = {v:.3} mm lies outside the axis range {}…{} mm; give the machine's travel as the ranges",
                        s.feature, s.placement, s.artifact, ['X', 'Y', 'Z'][a], r[0], r[1]
                    )));
                }
            }
        }
        // The model.
        let sphere_placements = {
            let mut n = 0;
            for (ai, a) in artifacts.iter().enumerate() {
                if matches!(a.kind, Kind::Spheres { .. }) {
                    n = n.max(poses.iter().filter(|p| p.artifact == ai).count());
                }
            }
            n
        };
        let choice = match o.model {
            ModelChoice::Auto if sphere_placements >= 2 => ModelChoice::Full,
            ModelChoice::Auto => ModelChoice::Reduced,
            m => m,
        };
        if choice == ModelChoice::Reduced {
            model.params = reduced(&model.params);
        }
        // Geometry.
        let geoms: Vec<Geometry> = artifacts
            .iter()
            .map(|a| Geometry {
                balls: match &a.kind {
                    Kind::Spheres { centres_mm, .. } => centres_mm.clone(),
                    _ => Vec::new(),
                },
                offsets: match &a.kind {
                    Kind::Gauge { faces_mm, .. } => vec![0.0; faces_mm.len()],
                    Kind::Square { .. } => vec![0.0; 2],
                    _ => Vec::new(),
                },
                angle_urad: match &a.kind {
                    Kind::Square {
                        certified: Some((v, _)),
                        ..
                    } => *v,
                    _ => 0.0,
                },
                centroid: artifact_centroid(a),
            })
            .collect();
        // Layout.
        let mut col = 0;
        let mut pose = Vec::new();
        for _ in &poses {
            pose.push(col);
            col += 6;
        }
        let mut geom = Vec::new();
        for a in artifacts {
            geom.push(col);
            col += geometry_columns(a);
        }
        // The probe calibration's own uncertainty enters the face touches it
        // corrected (a gauge's length reads the sum of two effective radii
        // and a reversal): its parameters as unknowns `z` with `δ = G z`, `z ~
        // N(0, I)` (rows below).
        let mut cal = vec![None; fitted.calibrations.len()];
        let sphere_cals = fitted
            .spheres
            .iter()
            .filter_map(|s| sphere_calibration(fitted, s));
        for c in fitted
            .faces
            .iter()
            .map(|f| f.calibration)
            .chain(sphere_cals)
        {
            if let Some(slot) = cal.get_mut(c) {
                if slot.is_none() {
                    *slot = Some(col);
                    col += fitted.calibrations[c]
                        .cov_factor_um
                        .first()
                        .map_or(0, Vec::len);
                }
            }
        }
        let length_reference = artifacts.iter().enumerate().any(|(ai, a)| {
            poses.iter().any(|p| p.artifact == ai)
                && match &a.kind {
                    Kind::Spheres {
                        certified_u_um,
                        centres_mm,
                        ..
                    } => certified_u_um.is_some() && centres_mm.len() > 1,
                    Kind::Gauge { certified_u_um, .. } => certified_u_um.is_some(),
                    _ => false,
                }
        });
        let basis = obs
            .iter()
            .map(|o| match *o {
                Obs::Sphere(i) => {
                    let s = &fitted.spheres[i];
                    model.basis_um(s.centre_mm, Vec3::new(0.0, 0.0, s.tool_length_mm))
                }
                Obs::Face(i) => {
                    let f = &fitted.faces[i];
                    model.basis_um(f.q_mm, Vec3::new(0.0, 0.0, f.tool_length_mm))
                }
            })
            .collect();
        let touch_sigma_um = if fitted.sigma_um.is_finite() && fitted.sigma_um > 0.0 {
            fitted.sigma_um
        } else {
            0.5
        };
        let mut p = Self {
            artifacts,
            fitted,
            model,
            obs,
            obs_pose,
            basis,
            poses,
            geoms,
            layout: Layout {
                pose,
                geom,
                cal,
                total: col,
            },
            touch_sigma_um,
            length_reference,
            threshold: o.relative_threshold,
        };
        p.initial_poses();
        Ok(p)
    }

    /// Sphere artifacts: each placement's pose by the rigid fit of the
    /// nominal centres to the measured ones.
    fn initial_poses(&mut self) {
        for k in 0..self.poses.len() {
            let ai = self.poses[k].artifact;
            if !matches!(self.artifacts[ai].kind, Kind::Spheres { .. }) {
                continue;
            }
            let (mut a, mut m) = (Vec::new(), Vec::new());
            for (o, &pk) in self.obs.iter().zip(&self.obs_pose) {
                if let (Obs::Sphere(i), true) = (o, pk == k) {
                    let s = &self.fitted.spheres[*i];
                    if let Some(idx) = sphere_index(&s.feature) {
                        a.push(self.geoms[ai].balls[idx]);
                        m.push(s.centre_mm);
                    }
                }
            }
            if a.is_empty() {
                continue;
            }
            let (rot, mbar) = rigid_fit(&a, &m, &self.poses[k].rot);
            let abar = a.iter().copied().sum::<Vec3>() * (1.0 / a.len() as f64);
            self.poses[k].rot = rot;
            self.poses[k].t_mm = mbar + rotate(&rot, self.geoms[ai].centroid - abar);
        }
    }

    /// The rows (whitened): `(J_machine, J_nuisance, y)`, per observation
    /// its first row and row count, and whether a certificate row weighs
    /// less than one touch. A certificate of uncertainty `u` weighs `σ/u`
    /// touches of noise `σ`; with `design`, at least one (see
    /// [`Self::solve`]).
    #[allow(clippy::type_complexity)]
    fn rows(
        &self,
        skip: Option<usize>,
        design: bool,
    ) -> Result<
        (
            DMatrix<f64>,
            DMatrix<f64>,
            Vec<f64>,
            Vec<(usize, usize)>,
            bool,
        ),
        ProbeError,
    > {
        let mut weak = false;
        let mut certificate_weight = |u: f64| {
            let w = self.touch_sigma_um / u.max(1e-3);
            weak |= w < 1.0;
            if design {
                w.max(1.0)
            } else {
                w
            }
        };
        let nm = self.model.len();
        let nn = self.layout.total;
        let mut jm: Vec<Vec<f64>> = Vec::new();
        let mut jn: Vec<Vec<f64>> = Vec::new();
        let mut y: Vec<f64> = Vec::new();
        let mut at = Vec::new();
        let s_t = self.touch_sigma_um;
        for (oi, (o, &k)) in self.obs.iter().zip(&self.obs_pose).enumerate() {
            if Some(k) == skip {
                at.push((jm.len(), 0));
                continue;
            }
            let pose = &self.poses[k];
            let ai = pose.artifact;
            let g = &self.geoms[ai];
            let pc = self.layout.pose[k];
            let gc = self.layout.geom[ai];
            let b = &self.basis[oi];
            match *o {
                Obs::Sphere(i) => {
                    let s: &SphereFit = &self.fitted.spheres[i];
                    let idx = sphere_index(&s.feature).unwrap_or(0);
                    let arm = rotate(&pose.rot, g.balls[idx] - g.centroid);
                    let shat = pose.t_mm + arm;
                    let r = (s.centre_mm - shat) * 1e3;
                    let mut block_m = DMatrix::zeros(3, nm);
                    let mut block_n = DMatrix::zeros(3, nn);
                    let mut block_y = DMatrix::zeros(3, 1);
                    for c in 0..3 {
                        for (j, bj) in b.iter().enumerate() {
                            block_m[(c, j)] = -bj[c];
                        }
                        for q in 0..3 {
                            let mut e = Vec3::ZERO;
                            e[q] = 1.0;
                            // ω × arm: column q is e_q × arm (µrad·mm = 1e-3 µm).
                            block_n[(c, pc + q)] = e.cross(arm)[c] * 1e-3;
                        }
                        block_n[(c, pc + 3 + c)] = 1.0;
                        if matches!(self.artifacts[ai].kind, Kind::Spheres { .. }) {
                            for q in 0..3 {
                                block_n[(c, gc + 3 * idx + q)] = pose.rot[q][c];
                            }
                        }
                        block_y[(c, 0)] = r[c];
                    }
                    // The probe calibration's error moves every centre it
                    // corrected by `S δ` with `δ = G z` (the face rows' `z`).
                    if let Some((c0, cal)) = sphere_calibration(self.fitted, s).and_then(|ci| {
                        Some((
                            self.layout.cal.get(ci).copied().flatten()?,
                            self.fitted.calibrations.get(ci)?,
                        ))
                    }) {
                        let g_rows = &cal.cov_factor_um;
                        let rank = g_rows.first().map_or(0, Vec::len);
                        for c in 0..3 {
                            for k in 0..rank {
                                block_n[(c, c0 + k)] = -(0..CAL_PARAMS)
                                    .map(|i| s.cal_sensitivity[c][i] * g_rows[i][k])
                                    .sum::<f64>();
                            }
                        }
                    }
                    // Whitening by the centre's covariance (in touch-noise units).
                    let cov = DMatrix::from_fn(3, 3, |a, bb| {
                        s.unit_cov[a][bb] + if a == bb { 1e-12 } else { 0.0 }
                    });
                    let mut stacked = DMatrix::zeros(3, nm + nn + 1);
                    stacked.columns_mut(0, nm).copy_from(&block_m);
                    stacked.columns_mut(nm, nn).copy_from(&block_n);
                    stacked.columns_mut(nm + nn, 1).copy_from(&block_y);
                    linalg::whiten(&cov, &mut stacked).ok_or_else(|| {
                        ProbeError::Invalid(format!(
                            "sphere {} of {}: its centre's covariance is not positive definite",
                            s.feature, s.placement
                        ))
                    })?;
                    at.push((jm.len(), 3));
                    for c in 0..3 {
                        jm.push((0..nm).map(|j| stacked[(c, j)]).collect());
                        jn.push((0..nn).map(|j| stacked[(c, nm + j)]).collect());
                        y.push(stacked[(c, nm + nn)]);
                    }
                }
                Obs::Face(i) => {
                    let f: &FaceTouch = &self.fitted.faces[i];
                    let art = &self.artifacts[ai];
                    let feat = art.feature(&f.feature).expect("checked by the fit");
                    let (n_art, dn) = face_normal(art, &feat, g.angle_urad);
                    let fi = match feat {
                        Feature::Face { index, .. } | Feature::Edge { index, .. } => index,
                        _ => 0,
                    };
                    let h0 = match feat {
                        Feature::Face { x_mm, facing, .. } => x_mm * facing,
                        _ => 0.0,
                    } + g.offsets[fi];
                    let nm_vec = rotate(&pose.rot, n_art);
                    let v = f.contact_mm - pose.t_mm;
                    // Artifact-frame position of the contact.
                    let x_art =
                        Vec3::new(pose.rot[0].dot(v), pose.rot[1].dot(v), pose.rot[2].dot(v))
                            + g.centroid;
                    let fhat = n_art.dot(x_art) - h0;
                    let mut row_m = vec![0.0; nm];
                    for (j, bj) in b.iter().enumerate() {
                        row_m[j] = nm_vec.dot(*bj);
                    }
                    let mut row_n = vec![0.0; nn];
                    let vxn = v.cross(nm_vec);
                    for q in 0..3 {
                        row_n[pc + q] = -vxn[q] * 1e-3;
                        row_n[pc + 3 + q] = -nm_vec[q];
                    }
                    row_n[gc + fi] = -1.0;
                    if matches!(art.kind, Kind::Square { .. }) {
                        row_n[gc + 2] = dn.dot(x_art) * 1e-3;
                    }
                    if let (Some(c0), Some(cal)) = (
                        self.layout.cal.get(f.calibration).copied().flatten(),
                        self.fitted.calibrations.get(f.calibration),
                    ) {
                        // ∂(row)/∂(tip radius, pre-travel, reversal), µm per µm.
                        let mut coef = [0.0; CAL_PARAMS];
                        coef[3] = -nm_vec.dot(f.normal);
                        coef[4 + f.direction.index()] = f.cos;
                        if let Some(st) = f.states {
                            for a in 0..3 {
                                let sgn = match st[a] {
                                    crate::model::Direction::Forward => -1.0,
                                    crate::model::Direction::Reverse => 1.0,
                                };
                                coef[10 + a] = nm_vec[a] * sgn / 2.0;
                            }
                        }
                        let g_rows = &cal.cov_factor_um;
                        let rank = g_rows.first().map_or(0, Vec::len);
                        for k in 0..rank {
                            row_n[c0 + k] = (0..CAL_PARAMS).map(|i| coef[i] * g_rows[i][k]).sum();
                        }
                    }
                    at.push((jm.len(), 1));
                    jm.push(row_m);
                    jn.push(row_n);
                    y.push(-fhat * 1e3);
                }
            }
        }
        // Certificates and the scale constraint.
        for (ai, a) in self.artifacts.iter().enumerate() {
            if !self
                .poses
                .iter()
                .enumerate()
                .any(|(k, p)| p.artifact == ai && Some(k) != skip)
            {
                continue;
            }
            let gc = self.layout.geom[ai];
            let g = &self.geoms[ai];
            match &a.kind {
                Kind::Spheres {
                    centres_mm,
                    certified_u_um: Some(u),
                    ..
                } => {
                    let w = certificate_weight(*u);
                    for (j, c) in centres_mm.iter().enumerate() {
                        for q in 0..3 {
                            let mut row = vec![0.0; nn];
                            row[gc + 3 * j + q] = w;
                            jm.push(vec![0.0; nm]);
                            jn.push(row);
                            y.push((c[q] - g.balls[j][q]) * 1e3 * w);
                        }
                    }
                }
                Kind::Spheres { centres_mm, .. }
                    if !self.length_reference && centres_mm.len() > 1 =>
                {
                    // About the current centroid, so that a shift or turn
                    // of the artifact's frame leaves the row unchanged.
                    let mean = g.balls.iter().copied().sum::<Vec3>() * (1.0 / g.balls.len() as f64);
                    let mut row = vec![0.0; nn];
                    let mut norm = 0.0;
                    for (j, b) in g.balls.iter().enumerate() {
                        let d = *b - mean;
                        for q in 0..3 {
                            row[gc + 3 * j + q] = d[q];
                        }
                        norm += d.norm_squared();
                    }
                    let w = 1e4 / norm.sqrt().max(1e-9);
                    row.iter_mut().for_each(|v| *v *= w);
                    // Current size relative to nominal: Σ d·(b̂ − b₀).
                    let now: f64 = g
                        .balls
                        .iter()
                        .zip(centres_mm)
                        .map(|(b, b0)| (*b - mean).dot(*b - *b0))
                        .sum::<f64>();
                    jm.push(vec![0.0; nm]);
                    jn.push(row);
                    y.push(-now * 1e3 * w);
                }
                Kind::Gauge {
                    facing,
                    certified_u_um: Some(u),
                    faces_mm,
                    ..
                } => {
                    let w = certificate_weight(*u);
                    for f in 1..faces_mm.len() {
                        // Face positions along x: x_f = facing_f·h_f.
                        let mut row = vec![0.0; nn];
                        row[gc + f] = facing[f] * w;
                        row[gc] = -facing[0] * w;
                        let now = facing[f] * g.offsets[f] - facing[0] * g.offsets[0];
                        jm.push(vec![0.0; nm]);
                        jn.push(row);
                        y.push(-now * 1e3 * w);
                    }
                }
                Kind::Square {
                    certified: Some((v, u)),
                    ..
                } => {
                    let w = certificate_weight(*u);
                    let mut row = vec![0.0; nn];
                    row[gc + 2] = w;
                    jm.push(vec![0.0; nm]);
                    jn.push(row);
                    y.push((v - g.angle_urad) * w);
                }
                _ => {}
            }
        }
        for (c, first) in self.layout.cal.iter().enumerate() {
            let Some(c0) = first else { continue };
            let rank = self.fitted.calibrations[c]
                .cov_factor_um
                .first()
                .map_or(0, Vec::len);
            for k in 0..rank {
                let mut row = vec![0.0; nn];
                row[c0 + k] = s_t;
                jm.push(vec![0.0; nm]);
                jn.push(row);
                y.push(0.0);
            }
        }
        let m = y.len();
        let jm = DMatrix::from_fn(m, nm, |i, j| jm[i][j]);
        let jn = DMatrix::from_fn(m, nn, |i, j| jn[i][j]);
        Ok((jm, jn, y, at, weak))
    }

    /// One linear solve: the identification, the nuisance update and the
    /// unwhitened residual of every row.
    ///
    /// What is identifiable is decided on the rows with every certificate
    /// weighing at least one touch: the relative singular-value threshold
    /// would otherwise depend on the probe's noise. A direction seen only
    /// through a certificate (the common scale through a gauge block's
    /// length) has a singular value proportional to `σ/u`; with touches ten
    /// times more repeatable than a certificate's uncertainty and less it
    /// falls below the threshold, and then appears and disappears between
    /// passes as the calibration's residual noise changes. The values and
    /// their uncertainty keep the true weights.
    fn solve(&self, skip: Option<usize>) -> Result<Solve, ProbeError> {
        let (jm, jn, y, at, weak) = self.rows(skip, false)?;
        let m = y.len();
        let (jmp, rn, u) = project_out(&jm, &jn)?;
        let yv = DMatrix::from_column_slice(m, 1, &y);
        let yp = &yv - &u * (u.transpose() * &yv);
        let nm = jm.ncols();
        let mut a = DMatrix::zeros(m, nm + 1);
        a.columns_mut(0, nm).copy_from(&jmp);
        a.columns_mut(nm, 1).copy_from(&yp);
        let design = if weak {
            let (jmd, jnd, ..) = self.rows(skip, true)?;
            Some(project_out(&jmd, &jnd)?.0)
        } else {
            None
        };
        let solved =
            solve_whitened_with_design(&self.model, &a, design.as_ref(), self.threshold, rn)
                .map_err(|e| ProbeError::Invalid(e.to_string()))?;
        let theta: Vec<f64> = solved
            .ident
            .theta
            .iter()
            .map(|t| t.unwrap_or(0.0))
            .collect();
        let th = DMatrix::from_column_slice(nm, 1, &theta);
        let rest: Vec<f64> = (&yv - &jm * &th).iter().copied().collect();
        let nuis = linalg::pinv_solve(&jn, &rest, 1e-10)
            .ok_or_else(|| ProbeError::Invalid("the placements' solve did not converge".into()))?;
        let fitted = &jn * DMatrix::from_column_slice(jn.ncols(), 1, &nuis.x);
        let resid: Vec<f64> = rest.iter().zip(fitted.iter()).map(|(a, b)| a - b).collect();
        let mut ident = solved.ident;
        ident.residuals_um = resid;
        Ok(Solve {
            ident,
            nuisance: nuis.x,
            theta,
            at,
        })
    }

    fn update(&mut self, nuis: &[f64], skip: Option<usize>) {
        for k in 0..self.poses.len() {
            if Some(k) == skip {
                continue;
            }
            let c = self.layout.pose[k];
            let w = Vec3::new(nuis[c], nuis[c + 1], nuis[c + 2]) * 1e-6;
            self.poses[k].rot = turn(&self.poses[k].rot, w);
            self.poses[k].t_mm += Vec3::new(nuis[c + 3], nuis[c + 4], nuis[c + 5]) * 1e-3;
        }
        for (ai, a) in self.artifacts.iter().enumerate() {
            let gc = self.layout.geom[ai];
            let g = &mut self.geoms[ai];
            match &a.kind {
                Kind::Spheres { .. } => {
                    for (j, b) in g.balls.iter_mut().enumerate() {
                        *b +=
                            Vec3::new(nuis[gc + 3 * j], nuis[gc + 3 * j + 1], nuis[gc + 3 * j + 2])
                                * 1e-3;
                    }
                }
                Kind::Gauge { .. } => {
                    for (f, h) in g.offsets.iter_mut().enumerate() {
                        *h += nuis[gc + f] * 1e-3;
                    }
                }
                Kind::Square { .. } => {
                    g.offsets[0] += nuis[gc] * 1e-3;
                    g.offsets[1] += nuis[gc + 1] * 1e-3;
                    g.angle_urad += nuis[gc + 2];
                }
                Kind::ReferenceSphere { .. } => {}
            }
        }
    }

    /// Linearise, solve and update three times, then solve once more.
    fn run(&mut self, skip: Option<usize>) -> Result<Solve, ProbeError> {
        for _ in 0..3 {
            let s = self.solve(skip)?;
            self.update(&s.nuisance, skip);
        }
        self.solve(skip)
    }
}

/// `J_m` with the nuisance columns `J_n` projected out (`(I − U Uᵀ) J_m`,
/// `U` an orthonormal basis of their span), the nuisance rank and `U`.
fn project_out(
    jm: &DMatrix<f64>,
    jn: &DMatrix<f64>,
) -> Result<(DMatrix<f64>, usize, DMatrix<f64>), ProbeError> {
    let svd = linalg::svd_full_v(jn).ok_or_else(|| {
        ProbeError::Invalid("the SVD of the placements' columns did not converge".into())
    })?;
    let smax = svd.s.first().copied().unwrap_or(0.0);
    let rn = svd
        .s
        .iter()
        .filter(|&&s| s > 1e-10 * smax && s > 0.0)
        .count();
    let u = svd.u.columns(0, rn).into_owned();
    Ok((jm - &u * (u.transpose() * jm), rn, u))
}

/// One linear solve's results.
struct Solve {
    /// The machine's identification (residuals: whitened rows).
    ident: Identification,
    /// The placements' and artifacts' unknowns.
    nuisance: Vec<f64>,
    /// The machine's parameters, unknown ones as zero.
    theta: Vec<f64>,
    /// Per observation: first row and row count.
    at: Vec<(usize, usize)>,
}

/// `s3` → 2.
/// The calibration that corrected a sphere's touches (the one of its tool
/// length), if any.
fn sphere_calibration(fitted: &Fitted, s: &SphereFit) -> Option<usize> {
    if !s.calibrated {
        return None;
    }
    fitted
        .calibrations
        .iter()
        .position(|c| (c.tool_length_mm - s.tool_length_mm).abs() < SAME_TOOL_MM)
}

fn sphere_index(label: &str) -> Option<usize> {
    label
        .strip_prefix('s')?
        .parse::<usize>()
        .ok()?
        .checked_sub(1)
}

/// Identifies the machine from the fitted touches.
pub fn identify(
    artifacts: &[Artifact],
    fitted: &Fitted,
    o: &IdentifyOptions,
) -> Result<Identified, ProbeError> {
    if !(o.relative_threshold > 0.0 && o.relative_threshold < 1.0) {
        return Err(ProbeError::Invalid(format!(
            "relative threshold {}: give a number between 0 and 1",
            o.relative_threshold
        )));
    }
    let mut p = Problem::new(artifacts, fitted, o)?;
    let Solve { ident, at, .. } = p.run(None)?;
    let all = crate::identify::thermal::files::poly_model(&o.chain, o.ranges_mm, o.order, 0.0)
        .map_err(|e| ProbeError::Invalid(e.to_string()))?
        .params;
    let names: Vec<String> = p.model.params.iter().map(Param::name).collect();
    let params: Vec<ParamResult> = all
        .iter()
        .map(|q| {
            let name = q.name();
            let status = match names.iter().position(|n| *n == name) {
                None => Status::NotInModel,
                Some(i) => match (ident.theta[i], ident.sigma[i]) {
                    (Some(v), Some(s)) => Status::Identified(Estimate { value: v, sigma: s }),
                    (Some(v), None) => Status::Identified(Estimate {
                        value: v,
                        sigma: f64::NAN,
                    }),
                    _ => Status::NotSeen,
                },
            };
            ParamResult {
                name,
                unit: q.unit(),
                status,
            }
        })
        .collect();
    // A parameter wholly in the null space is not seen at all; the null
    // vectors' other entries are combinations seen only together.
    let mut share = vec![0.0; names.len()];
    for v in &ident.null_space {
        for (j, w) in v {
            share[*j] += w * w;
        }
    }
    let combinations = ident
        .null_space
        .iter()
        .filter_map(|v| {
            let kept: Vec<String> = v
                .iter()
                .filter(|(j, _)| share[*j] < 0.98)
                .map(|(j, w)| format!("{:+.2} {}", w, names[*j]))
                .collect();
            (kept.len() > 1).then(|| kept.join(" "))
        })
        .collect();
    // Residuals per observation (unwhitened: sphere rows back through the
    // Cholesky factor are not needed for the pictures; whitened values
    // times the touch noise are shown).
    let mut residuals = Vec::new();
    for (oi, o_) in p.obs.iter().enumerate() {
        let (first, len) = at[oi];
        if len == 0 {
            continue;
        }
        let k = p.obs_pose[oi];
        let r = &ident.residuals_um;
        match *o_ {
            Obs::Sphere(i) => {
                let s = &fitted.spheres[i];
                // Back to µm: r_white = L⁻¹ r, r = L r_white.
                let cov = DMatrix::from_fn(3, 3, |a, b| {
                    s.unit_cov[a][b] + if a == b { 1e-12 } else { 0.0 }
                });
                let l = nalgebra::Cholesky::new(cov).map(|c| c.unpack());
                let w = nalgebra::DVector::from_vec(vec![r[first], r[first + 1], r[first + 2]]);
                let v = l.map_or(w.clone(), |l| l * w);
                residuals.push(Residual {
                    artifact: s.artifact.clone(),
                    placement: p.poses[k].name.clone(),
                    feature: s.feature.clone(),
                    at_mm: s.centre_mm,
                    residual_um: Vec3::new(v[0], v[1], v[2]),
                });
            }
            Obs::Face(i) => {
                let f = &fitted.faces[i];
                residuals.push(Residual {
                    artifact: f.artifact.clone(),
                    placement: p.poses[k].name.clone(),
                    feature: f.feature.clone(),
                    at_mm: f.q_mm,
                    residual_um: Vec3::new(r[first], 0.0, 0.0),
                });
            }
        }
    }
    // The artifacts' deviations from nominal.
    let mut artifact_deviations = Vec::new();
    for (ai, a) in artifacts.iter().enumerate() {
        if !p.poses.iter().any(|q| q.artifact == ai) {
            continue;
        }
        let g = &p.geoms[ai];
        match &a.kind {
            Kind::Spheres { centres_mm, .. } => {
                let id = [
                    Vec3::new(1.0, 0.0, 0.0),
                    Vec3::new(0.0, 1.0, 0.0),
                    Vec3::new(0.0, 0.0, 1.0),
                ];
                let (r, mbar) = rigid_fit(centres_mm, &g.balls, &id);
                let c0 = centres_mm.iter().copied().sum::<Vec3>() * (1.0 / centres_mm.len() as f64);
                for (j, (b, b0)) in g.balls.iter().zip(centres_mm).enumerate() {
                    let fitted = rotate(&r, *b0 - c0) + mbar;
                    artifact_deviations.push((
                        a.name.clone(),
                        format!("s{}", j + 1),
                        (*b - fitted) * 1e3,
                    ));
                }
            }
            Kind::Gauge { facing, .. } => {
                for (f, h) in g.offsets.iter().enumerate() {
                    let rel = facing[f] * h - facing[0] * g.offsets[0];
                    artifact_deviations.push((
                        a.name.clone(),
                        format!("f{}", f + 1),
                        Vec3::new(rel * 1e3, 0.0, 0.0),
                    ));
                }
            }
            Kind::Square { .. } => {
                artifact_deviations.push((
                    a.name.clone(),
                    "angle".into(),
                    Vec3::new(g.angle_urad, 0.0, 0.0),
                ));
            }
            Kind::ReferenceSphere { .. } => {}
        }
    }
    let mut notes = Vec::new();
    let scale_from_artifact = !p.length_reference
        && artifacts.iter().enumerate().any(|(ai, a)| {
            matches!(&a.kind, Kind::Spheres { centres_mm, .. } if centres_mm.len() > 1)
                && p.poses.iter().any(|q| q.artifact == ai)
        });
    if scale_from_artifact {
        notes.push("no calibrated length was measured (no certified artifact or gauge): the machine's common scale of X, Y and Z cannot be told from the artifact's size, and is taken as the artifact's nominal size — measure a gauge block or give the artifact's certificate to fix it".into());
    }
    let lengths: Vec<f64> = {
        let mut v: Vec<f64> = Vec::new();
        for l in fitted
            .spheres
            .iter()
            .map(|s| s.tool_length_mm)
            .chain(fitted.faces.iter().map(|f| f.tool_length_mm))
        {
            if !v.iter().any(|x| (x - l).abs() < 1e-3) {
                v.push(l);
            }
        }
        v
    };
    if lengths.len() < 2
        && p.model
            .params
            .iter()
            .any(|q| matches!(q, Param::Legendre { component, .. } if *component >= 3))
    {
        notes.push("one probe length only: the angles that act through the tool's length alone (EAZ, EBZ, and the constant parts of every angle) cannot be seen; probe an artifact again with a longer or shorter probe to see them".into());
    }
    Ok(Identified {
        model: p.model.clone(),
        all_params: all,
        params,
        combinations,
        probe_length_mm: probe_length(fitted),
        scale_from_artifact,
        residuals,
        artifact_deviations,
        observations: ident.observations,
        touch_sigma_um: p.touch_sigma_um,
        ident,
        notes,
        monte_carlo: None,
    })
}

/// Leave-one-placement-out prediction: for every placement of a sphere
/// artifact measured in three placements or more, the machine identified
/// without it, then its centres corrected by that model and compared with
/// the artifact (best rigid fit).
pub fn leave_one_out(
    artifacts: &[Artifact],
    fitted: &Fitted,
    o: &IdentifyOptions,
) -> Result<Vec<HeldOut>, ProbeError> {
    let base = Problem::new(artifacts, fitted, o)?;
    let mut out = Vec::new();
    for k in 0..base.poses.len() {
        let ai = base.poses[k].artifact;
        if !matches!(artifacts[ai].kind, Kind::Spheres { .. }) {
            continue;
        }
        if base.poses.iter().filter(|q| q.artifact == ai).count() < 3 {
            continue;
        }
        let mut p = Problem::new(artifacts, fitted, o)?;
        let theta = p.run(Some(k))?.theta;
        let (mut a, mut m, mut corrected) = (Vec::new(), Vec::new(), Vec::new());
        for (oi, (ob, &pk)) in p.obs.iter().zip(&p.obs_pose).enumerate() {
            if let (Obs::Sphere(i), true) = (ob, pk == k) {
                let s = &fitted.spheres[*i];
                let Some(idx) = sphere_index(&s.feature) else {
                    continue;
                };
                let e: Vec3 = p.basis[oi].iter().zip(&theta).map(|(b, t)| *b * *t).sum();
                a.push(p.geoms[ai].balls[idx]);
                m.push(s.centre_mm);
                corrected.push(s.centre_mm + e * 1e-3);
            }
        }
        if a.len() < 3 {
            continue;
        }
        let rms = |pts: &[Vec3]| -> f64 {
            let (r, t) = rigid_fit(&a, pts, &p.poses[k].rot);
            let abar = a.iter().copied().sum::<Vec3>() * (1.0 / a.len() as f64);
            let ss: f64 = a
                .iter()
                .zip(pts)
                .map(|(x, y)| (rotate(&r, *x - abar) + t - *y).norm_squared())
                .sum();
            (ss / a.len() as f64).sqrt() * 1e3
        };
        out.push(HeldOut {
            artifact: artifacts[ai].name.clone(),
            placement: p.poses[k].name.clone(),
            before_um: rms(&m),
            after_um: rms(&corrected),
        });
    }
    Ok(out)
}

/// Fits the touches and identifies the machine, then fits again taking the
/// identified machine's variation over each sphere out of its touches (see
/// [`fit_touches`]) and identifies again, three times: on the reference
/// sphere the machine's local scale passes for pre-travel, and each pass
/// leaves about the sphere's size over the volume's (a tenth) of the
/// previous pass' error.
pub fn fit_and_identify(
    artifacts: &[Artifact],
    touches: &[Touch],
    o: &IdentifyOptions,
) -> Result<(Fitted, Identified), ProbeError> {
    let mut fitted = fit_touches(artifacts, touches, None)?;
    let mut id = identify(artifacts, &fitted, o)?;
    for _ in 0..3 {
        let theta = id.theta();
        let model = id.model.clone();
        let field =
            |q: Vec3, tool: f64| model.deviation_um(&theta, q, Vec3::new(0.0, 0.0, tool), false);
        fitted = fit_touches(artifacts, touches, Some(&field))?;
        id = identify(artifacts, &fitted, o)?;
    }
    Ok((fitted, id))
}
