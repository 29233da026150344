//! The planar straightness model (docs/straightness.md): its evaluation,
//! its TOML file and its Z-correction table. Identified from measured
//! profiles by `identify::straightness`, which re-exports everything here.

use crate::error::ModelError;
use crate::model::{Components, Directions, ErrorModel};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::fmt::Write as _;
use volcomp_gcode::Vec3;

pub use crate::error::straightness::{Axis, StraightnessError};

impl Axis {
    /// `X` or `Y` (any case).
    pub fn parse(text: &str) -> Option<Axis> {
        match text.trim() {
            "X" | "x" => Some(Axis::X),
            "Y" | "y" => Some(Axis::Y),
            _ => None,
        }
    }

    /// The axis letter.
    pub fn letter(self) -> char {
        match self {
            Axis::X => 'X',
            Axis::Y => 'Y',
        }
    }
}

/// Most harmonics a model file may give per axis: 10 000. Evaluating the
/// series costs one term per harmonic at every point of a program; a fit
/// resolves at most half the samples of its profiles, far fewer than this.
pub const MAX_HARMONICS: usize = 10_000;

/// `e(x) = Σ_{k=1..m} a_k·cos(2πk(x − x_st)/l) + b_k·sin(2πk(x − x_st)/l)` (µm).
#[derive(Debug, Clone, PartialEq)]
pub struct FourierSeries {
    /// `x_st`: start of the modelling length (mm).
    pub start_mm: f64,
    /// `l`: modelling length, the period of the series (mm).
    pub length_mm: f64,
    /// `a_k`, `k = 1 … m` (µm).
    pub cos_um: Vec<f64>,
    /// `b_k`, `k = 1 … m` (µm).
    pub sin_um: Vec<f64>,
}

impl FourierSeries {
    /// `m`, the number of harmonics.
    pub fn harmonics(&self) -> usize {
        self.cos_um.len().min(self.sin_um.len())
    }

    /// The shortest wavelength in the series, `l / m` (mm).
    pub fn cutoff_wavelength_mm(&self) -> f64 {
        self.length_mm / self.harmonics().max(1) as f64
    }

    /// `e(x)` in µm.
    ///
    /// ```
    /// use volcomp_core::identify::straightness::FourierSeries;
    /// let s = FourierSeries { start_mm: 10.0, length_mm: 40.0, cos_um: vec![0.0, 0.5], sin_um: vec![1.0, 0.0] };
    /// // x − x_st = l/4: sin(π/2) = 1, cos(π) = −1
    /// assert!((s.eval_um(20.0) - 0.5).abs() < 1e-12);
    /// ```
    pub fn eval_um(&self, x_mm: f64) -> f64 {
        let theta = 2.0 * PI * (x_mm - self.start_mm) / self.length_mm;
        fourier_sum(&self.cos_um, &self.sin_um, theta)
    }
}

/// How the model of one axis was identified (kept in the model file for
/// traceability).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Identification {
    /// Runs used.
    pub runs: usize,
    /// The feed rates compared (mm/min).
    pub feeds_mm_per_min: Vec<f64>,
    /// Samples per run.
    pub samples: usize,
    /// Sample spacing Δx (mm).
    pub spacing_mm: f64,
    /// Taper fraction (each end).
    pub taper_fraction: f64,
    /// σ_t, threshold of the relative standard deviation across feed rates.
    pub sigma_t: f64,
    /// P_t, threshold of the normalised mean power.
    pub p_t: f64,
    /// `common` or `per-run` (see [`identify::Normalisation`]).
    pub normalisation: String,
    /// `m` was given by the user instead of chosen by the thresholds.
    pub harmonics_forced: bool,
    /// How `m` was chosen: `cross-validation` (the default) or `thresholds`
    /// (the paper's σ_t, P_t; files written before the choice existed).
    #[serde(default = "thresholds_rule")]
    pub cutoff_rule: String,
    /// RMS of measured mean profile − model over the measured range (µm):
    /// what the model leaves out (vibration, noise, short wavelengths).
    pub fit_residual_rms_um: f64,
}

fn thresholds_rule() -> String {
    "thresholds".into()
}

/// The straightness model of one axis.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisModel {
    /// The Fourier series `e_z(x)` (or `e_z(y)`).
    pub series: FourierSeries,
    /// The measured range, where the model may be evaluated (mm).
    pub range_mm: [f64; 2],
    /// The range where the series is trustworthy: the measured range less
    /// one cut-off wavelength at each end (mm).
    pub recommended_range_mm: [f64; 2],
    /// How it was identified.
    pub identification: Option<Identification>,
}

/// The planar straightness model `e_z(x, y) = c + e_z(x) + e_z(y) + α_yz·y + β_zx·x`.
#[derive(Debug, Clone, PartialEq)]
pub struct StraightnessModel {
    /// `c` (µm): makes the model zero-mean over the measured ranges.
    pub offset_um: f64,
    /// `β_zx` (µrad): Z deviation per X travel, the X profile's least-squares slope.
    pub beta_zx_urad: f64,
    /// `α_yz` (µrad): Z deviation per Y travel, the Y profile's least-squares slope.
    pub alpha_yz_urad: f64,
    /// `e_z(x)`, if X was measured.
    pub x: Option<AxisModel>,
    /// `e_z(y)`, if Y was measured.
    pub y: Option<AxisModel>,
    /// Hold positions outside an axis' measured range at its end instead of
    /// refusing them (not stored in the file; `--clamp`).
    pub clamp: bool,
}

/// The `kind` key of a straightness model file.
pub const KIND: &str = "straightness";
/// The format version written.
pub const FORMAT_VERSION: u32 = 1;

/// Positions (mm) and the values there.
pub type Samples = (Vec<f64>, Vec<f64>);

impl StraightnessModel {
    /// The model of one axis.
    pub fn axis(&self, axis: Axis) -> Option<&AxisModel> {
        match axis {
            Axis::X => self.x.as_ref(),
            Axis::Y => self.y.as_ref(),
        }
    }

    fn slope_urad(&self, axis: Axis) -> f64 {
        match axis {
            Axis::X => self.beta_zx_urad,
            Axis::Y => self.alpha_yz_urad,
        }
    }

    /// [`Self::axis_part_um`] at `n` evenly spaced positions over the
    /// axis' measured range, as (positions, values); `None` for an axis
    /// not in the model.
    pub fn sampled_axis_part(&self, axis: Axis, n: usize) -> Option<Result<Samples, ModelError>> {
        let [lo, hi] = self.axis(axis)?.range_mm;
        let p: Vec<f64> = (0..n)
            .map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64)
            .collect();
        let e: Result<Vec<f64>, _> = p.iter().map(|&x| self.axis_part_um(axis, x)).collect();
        Some(e.map(|e| (p, e)))
    }

    /// The part of `e_z` that depends on one axis: `e_z(x) + β_zx·x` for X,
    /// `e_z(y) + α_yz·y` for Y (µm); zero for an axis not in the model.
    /// Outside the measured range: an error, or the end value with `clamp`.
    pub fn axis_part_um(&self, axis: Axis, position_mm: f64) -> Result<f64, ModelError> {
        let Some(m) = self.axis(axis) else {
            return Ok(0.0);
        };
        let [lo, hi] = m.range_mm;
        let p = if self.clamp {
            position_mm.clamp(lo, hi)
        } else if let Some(p) = crate::model::within_range(position_mm, lo, hi) {
            p
        } else {
            return Err(ModelError::OutOfRange {
                axis: axis.letter(),
                position_mm,
                min_mm: lo,
                max_mm: hi,
            });
        };
        Ok(m.series.eval_um(p) + self.slope_urad(axis) * 1e-3 * p)
    }

    /// The predicted Z deviation `e_z(x, y)` (µm).
    ///
    /// ```
    /// use volcomp_core::identify::straightness::*;
    /// let axis = AxisModel {
    ///     series: FourierSeries { start_mm: 0.0, length_mm: 100.0, cos_um: vec![0.0], sin_um: vec![1.0] },
    ///     range_mm: [0.0, 99.0], recommended_range_mm: [10.0, 89.0], identification: None,
    /// };
    /// let m = StraightnessModel { offset_um: 0.0, beta_zx_urad: 10.0, alpha_yz_urad: 0.0, x: Some(axis), y: None, clamp: false };
    /// // sin(2π·25/100) = 1, plus 10 µrad · 25 mm = 0.25 µm
    /// assert!((m.ez_um(25.0, 123.0).unwrap() - 1.25).abs() < 1e-12);
    /// assert!(m.ez_um(150.0, 0.0).is_err());
    /// ```
    pub fn ez_um(&self, x_mm: f64, y_mm: f64) -> Result<f64, ModelError> {
        Ok(
            self.offset_um
                + self.axis_part_um(Axis::X, x_mm)?
                + self.axis_part_um(Axis::Y, y_mm)?,
        )
    }

    /// Is `text` a straightness model file (a TOML table with
    /// `kind = "straightness"`)?
    pub fn is_model_toml(text: &str) -> bool {
        toml::from_str::<toml::Table>(text)
            .ok()
            .and_then(|t| t.get("kind").and_then(|k| k.as_str()).map(|k| k == KIND))
            .unwrap_or(false)
    }

    /// The model file (TOML, units in the key names).
    pub fn to_toml(&self) -> String {
        let axis = |a: &AxisModel| FileAxis {
            start_mm: a.series.start_mm,
            length_mm: a.series.length_mm,
            harmonics: a.series.harmonics(),
            cutoff_wavelength_mm: a.series.cutoff_wavelength_mm(),
            range_mm: a.range_mm,
            recommended_range_mm: a.recommended_range_mm,
            cos_um: a.series.cos_um.clone(),
            sin_um: a.series.sin_um.clone(),
            identification: a.identification.clone(),
        };
        let file = FileModel {
            kind: KIND.to_string(),
            format_version: FORMAT_VERSION,
            offset_um: self.offset_um,
            beta_zx_urad: self.beta_zx_urad,
            alpha_yz_urad: self.alpha_yz_urad,
            x: self.x.as_ref().map(axis),
            y: self.y.as_ref().map(axis),
        };
        let body = toml::to_string_pretty(&file).unwrap_or_else(|e| format!("# {e}\n"));
        format!(
            "# volcomp straightness model (Z deviation from planar motion; docs/straightness.md)\n\
             # e_z(x, y) = offset_um + e_z(x) + e_z(y) + alpha_yz_urad*1e-3*y + beta_zx_urad*1e-3*x   [µm; x, y in mm]\n\
             # e_z(x) = sum over k = 1..harmonics of cos_um[k]*cos(2πk(x − start_mm)/length_mm) + sin_um[k]*sin(2πk(x − start_mm)/length_mm)\n\
             # deviation = actual − commanded (docs/design.md, \"Deviation sign\"): a correction is −e_z.\n\
             # The series is poor within one cut-off wavelength of the measured ends: compensate inside recommended_range_mm.\n\
             {body}"
        )
    }

    /// Reads a model file; `file` names it in errors.
    pub fn from_toml(text: &str, file: &str) -> Result<StraightnessModel, StraightnessError> {
        use crate::text::located::{at_offset, key_error, Scope};
        // Every error is located at the value that is wrong.
        let err = |scope: Scope<'_>, key: &str, message: String, help: &str| {
            StraightnessError::File(key_error(file, text, scope, key, message, help))
        };
        let raw: FileModel = toml::from_str(text).map_err(|e| {
            StraightnessError::File(at_offset(
                file,
                text,
                e.span().map(|s| s.start),
                e.message().trim_end().to_string(),
                "a straightness model is written by `volcomp straightness fit`; see docs/straightness.md for its keys",
            ))
        })?;
        // The top-level keys' errors.
        let top = |key: &str, message: String, help: &str| err(Scope::Top, key, message, help);
        if raw.kind != KIND {
            let kind = crate::text::table::shown(&raw.kind);
            let message = format!("kind is `{kind}`, not `{KIND}`");
            return Err(top(
                "kind",
                message,
                "this file is not a straightness model",
            ));
        }
        if raw.format_version != FORMAT_VERSION {
            return Err(top(
                "format_version",
                format!(
                    "format_version {} is not supported (this volcomp reads {FORMAT_VERSION})",
                    raw.format_version
                ),
                "fit the model again with this volcomp",
            ));
        }
        for (name, v) in [
            ("offset_um", raw.offset_um),
            ("beta_zx_urad", raw.beta_zx_urad),
            ("alpha_yz_urad", raw.alpha_yz_urad),
        ] {
            if !v.is_finite() {
                let message = format!("{name} = {v} is not a finite number");
                return Err(top(name, message, "write a finite number"));
            }
        }
        let axis =
            |name: &str, a: Option<FileAxis>| -> Result<Option<AxisModel>, StraightnessError> {
                let Some(a) = a else { return Ok(None) };
                let bad = |key: &str, what: String| {
                    err(
                        Scope::Table(name),
                        key,
                        format!("[{name}] {what}"),
                        "fit the model again, or correct the value",
                    )
                };
                if !a.start_mm.is_finite() {
                    return Err(bad("start_mm", "start_mm must be a finite number".into()));
                }
                if !(a.length_mm.is_finite() && a.length_mm > 0.0) {
                    return Err(bad(
                        "length_mm",
                        "length_mm must be a positive finite length".into(),
                    ));
                }
                if a.harmonics > MAX_HARMONICS {
                    return Err(bad(
                        "harmonics",
                        format!("harmonics = {} is more than {MAX_HARMONICS}", a.harmonics),
                    ));
                }
                if a.cos_um.len() != a.harmonics || a.sin_um.len() != a.harmonics {
                    let key = if a.cos_um.len() != a.harmonics {
                        "cos_um"
                    } else {
                        "sin_um"
                    };
                    return Err(bad(
                        key,
                        format!(
                            "harmonics = {} but cos_um has {} and sin_um {} values",
                            a.harmonics,
                            a.cos_um.len(),
                            a.sin_um.len()
                        ),
                    ));
                }
                for key in ["cos_um", "sin_um"] {
                    let values = if key == "cos_um" {
                        &a.cos_um
                    } else {
                        &a.sin_um
                    };
                    if values.iter().any(|v| !v.is_finite()) {
                        return Err(bad(key, format!("{key} holds a value that is not finite")));
                    }
                }
                let ordered = |r: [f64; 2]| r[0].is_finite() && r[1].is_finite() && r[0] <= r[1];
                for (key, r) in [
                    ("range_mm", a.range_mm),
                    ("recommended_range_mm", a.recommended_range_mm),
                ] {
                    if !ordered(r) {
                        return Err(bad(
                            key,
                            format!("{key} must be [low, high] with low ≤ high"),
                        ));
                    }
                }
                Ok(Some(AxisModel {
                    series: FourierSeries {
                        start_mm: a.start_mm,
                        length_mm: a.length_mm,
                        cos_um: a.cos_um,
                        sin_um: a.sin_um,
                    },
                    range_mm: a.range_mm,
                    recommended_range_mm: a.recommended_range_mm,
                    identification: a.identification,
                }))
            };
        let x = axis("x", raw.x)?;
        let y = axis("y", raw.y)?;
        if x.is_none() && y.is_none() {
            return Err(err(
                Scope::Top,
                "kind",
                "the model has neither an [x] nor a [y] table".into(),
                "fit the model from runs along X and/or Y",
            ));
        }
        Ok(StraightnessModel {
            offset_um: raw.offset_um,
            beta_zx_urad: raw.beta_zx_urad,
            alpha_yz_urad: raw.alpha_yz_urad,
            x,
            y,
            clamp: false,
        })
    }

    /// The Z-correction table (CSV): for each modelled axis, rows every
    /// `step_mm` over its measured range (ends included) with the axis part
    /// of the deviation and the correction `−e`. The model is separable, so
    /// the Z correction at `(x, y)` is exactly the X row at `x` plus the Y
    /// row at `y` (the X rows carry the constant `offset_um`); between rows,
    /// linear interpolation is good when `step_mm` is well under the cut-off
    /// wavelength.
    pub fn correction_table_csv(&self, step_mm: f64) -> Result<String, StraightnessError> {
        if !(step_mm.is_finite() && step_mm > 0.0) {
            return Err(StraightnessError::Runs {
                message: format!("table step {step_mm} mm is not a positive length"),
                help: "give the step in mm, e.g. 1".into(),
            });
        }
        let mut out = String::new();
        out.push_str("# volcomp straightness Z-correction table\n");
        out.push_str("# Z deviation at (x, y) = ez_um of the X row at x + ez_um of the Y row at y; X rows include offset_um.\n");
        out.push_str("# z_correction_um = −ez_um (deviation sign of docs/design.md): add it to the commanded Z.\n");
        for axis in [Axis::X, Axis::Y] {
            if let Some(m) = self.axis(axis) {
                let [lo, hi] = m.recommended_range_mm;
                let _ = writeln!(
                    out,
                    "# {}: cut-off wavelength {:.4} mm, {} harmonics; trustworthy over {lo:.3} … {hi:.3} mm",
                    axis.letter(),
                    m.series.cutoff_wavelength_mm(),
                    m.series.harmonics()
                );
            }
        }
        out.push_str("base_axis,position_mm,ez_um,z_correction_um\n");
        for axis in [Axis::X, Axis::Y] {
            let Some(m) = self.axis(axis) else { continue };
            let [lo, hi] = m.range_mm;
            let count = ((hi - lo) / step_mm).floor() as usize;
            if count > 10_000_000 {
                return Err(StraightnessError::Runs {
                    message: format!("a step of {step_mm} mm gives more than 10⁷ rows"),
                    help: "choose a coarser step".into(),
                });
            }
            let mut positions: Vec<f64> = (0..=count).map(|i| lo + i as f64 * step_mm).collect();
            if hi - positions[count] > 1e-9 * step_mm.max(1.0) {
                positions.push(hi);
            }
            let c = if axis == Axis::X { self.offset_um } else { 0.0 };
            for p in positions {
                let e = c + self.axis_part_um(axis, p.min(hi))?;
                let _ = writeln!(out, "{},{p:.6},{e:.6},{:.6}", axis.letter(), -e);
            }
        }
        Ok(out)
    }
}

impl From<ModelError> for StraightnessError {
    fn from(e: ModelError) -> Self {
        StraightnessError::Runs {
            message: e.to_string(),
            help: "evaluate the model inside its measured range".into(),
        }
    }
}

impl ErrorModel for StraightnessModel {
    /// `(0, 0, e_z(q_x, q_y))`; zero for [`Components::PositioningOnly`]:
    /// a straightness model has no positioning error.
    fn deviation_um(
        &self,
        q_mm: Vec3,
        _s: Directions,
        components: Components,
    ) -> Result<Vec3, ModelError> {
        match components {
            Components::PositioningOnly => Ok(Vec3::ZERO),
            Components::All => Ok(Vec3::new(0.0, 0.0, self.ez_um(q_mm.x, q_mm.y)?)),
        }
    }

    fn range_mm(&self) -> [[f64; 2]; 3] {
        let all = [f64::NEG_INFINITY, f64::INFINITY];
        let r = |a: Axis| self.axis(a).map(|m| m.range_mm).unwrap_or(all);
        [r(Axis::X), r(Axis::Y), all]
    }
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileModel {
    kind: String,
    format_version: u32,
    offset_um: f64,
    beta_zx_urad: f64,
    alpha_yz_urad: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    x: Option<FileAxis>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    y: Option<FileAxis>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileAxis {
    start_mm: f64,
    length_mm: f64,
    harmonics: usize,
    /// Derived (`length_mm / harmonics`); written for the reader, ignored on input.
    #[serde(default)]
    cutoff_wavelength_mm: f64,
    range_mm: [f64; 2],
    recommended_range_mm: [f64; 2],
    cos_um: Vec<f64>,
    sin_um: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    identification: Option<Identification>,
}

/// Evaluates `Σ_{k=1..m} a_k·cos(kθ) + b_k·sin(kθ)` with the angle-addition
/// recurrence (one `sin_cos` per call; the rounding error grows like `k·ε`).
pub fn fourier_sum(a: &[f64], b: &[f64], theta: f64) -> f64 {
    let (s1, c1) = theta.sin_cos();
    let (mut s, mut c) = (s1, c1);
    let mut sum = 0.0;
    for (ak, bk) in a.iter().zip(b) {
        sum += ak * c + bk * s;
        let next_c = c * c1 - s * s1;
        s = s * c1 + c * s1;
        c = next_c;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ALL_FORWARD;

    fn model() -> StraightnessModel {
        let series = |s: f64| FourierSeries {
            start_mm: s,
            length_mm: 200.0,
            cos_um: vec![0.3, -0.1, 0.05],
            sin_um: vec![0.2, 0.0, -0.4],
        };
        StraightnessModel {
            offset_um: -0.25,
            beta_zx_urad: 2.5,
            alpha_yz_urad: -1.5,
            x: Some(AxisModel {
                series: series(-50.0),
                range_mm: [-50.0, 149.8],
                recommended_range_mm: [16.0, 83.0],
                identification: Some(Identification {
                    runs: 9,
                    feeds_mm_per_min: vec![4800.0, 7200.0, 9600.0],
                    samples: 1000,
                    spacing_mm: 0.2,
                    taper_fraction: 0.1,
                    sigma_t: 0.05,
                    p_t: 0.01,
                    normalisation: "common".into(),
                    harmonics_forced: false,
                    cutoff_rule: "cross-validation".into(),
                    fit_residual_rms_um: 0.07,
                }),
            }),
            y: Some(AxisModel {
                series: series(0.0),
                range_mm: [0.0, 199.0],
                recommended_range_mm: [66.7, 132.3],
                identification: None,
            }),
            clamp: false,
        }
    }

    #[test]
    fn toml_round_trip_is_exact() {
        let m = model();
        let text = m.to_toml();
        assert!(StraightnessModel::is_model_toml(&text));
        assert!(text.contains("beta_zx_urad = 2.5"), "{text}");
        let back = StraightnessModel::from_toml(&text, "m.toml").unwrap();
        assert_eq!(back, m);
        for x in [-50.0, 0.0, 33.3, 149.8] {
            for y in [0.0, 77.7, 199.0] {
                assert_eq!(back.ez_um(x, y).unwrap(), m.ez_um(x, y).unwrap());
            }
        }
    }

    #[test]
    fn evaluation_matches_the_formula() {
        let m = model();
        let (x, y) = (12.5, 40.0);
        let f = |s: f64, p: f64| {
            let t = 2.0 * PI * (p - s) / 200.0;
            0.3 * t.cos() + 0.2 * t.sin() - 0.1 * (2.0 * t).cos() + 0.05 * (3.0 * t).cos()
                - 0.4 * (3.0 * t).sin()
        };
        let expected = -0.25 + f(-50.0, x) + f(0.0, y) + 2.5e-3 * x - 1.5e-3 * y;
        assert!((m.ez_um(x, y).unwrap() - expected).abs() < 1e-12);
        let d = m
            .deviation_um(Vec3::new(x, y, -300.0), ALL_FORWARD, Components::All)
            .unwrap();
        assert_eq!((d.x, d.y), (0.0, 0.0));
        assert!((d.z - expected).abs() < 1e-12);
        let p = m
            .deviation_um(
                Vec3::new(x, y, 0.0),
                ALL_FORWARD,
                Components::PositioningOnly,
            )
            .unwrap();
        assert_eq!(p, Vec3::ZERO);
    }

    #[test]
    fn out_of_range_is_refused_or_clamped() {
        let mut m = model();
        let e = m.ez_um(150.0, 0.0).unwrap_err();
        assert!(matches!(e, ModelError::OutOfRange { axis: 'X', .. }), "{e}");
        let e = m.ez_um(0.0, -0.1).unwrap_err();
        assert!(matches!(e, ModelError::OutOfRange { axis: 'Y', .. }), "{e}");
        m.clamp = true;
        assert_eq!(m.ez_um(400.0, 0.0).unwrap(), m.ez_um(149.8, 0.0).unwrap());
        let r = m.range_mm();
        assert_eq!(r[0], [-50.0, 149.8]);
        assert!(r[2][0].is_infinite());
    }

    #[test]
    fn bad_model_files_are_named() {
        let text = model().to_toml();
        // Each error is located at the line of the value that is wrong
        // (the line that starts with `at`).
        let cases = [
            (text.replace("kind = \"straightness\"", "kind = \"21-component\""), "kind", "kind ="),
            (text.replace("format_version = 1", "format_version = 7"), "format_version", "format_version ="),
            (text.replace("harmonics = 3", "harmonics = 4"), "harmonics = 4", "cos_um ="),
            (text.replace("offset_um", "offset_mm"), "offset_mm", "offset_mm ="),
            (text.replace("offset_um = ", "offset_um = nan #"), "offset_um = NaN", "offset_um ="),
            (text.replacen("length_mm = ", "length_mm = -", 1), "length_mm", "length_mm ="),
            ("kind = \"straightness\"\nformat_version = 1\noffset_um = 0.0\nbeta_zx_urad = 0.0\nalpha_yz_urad = 0.0\n".to_string(), "neither", "kind ="),
        ];
        for (t, needle, at) in cases {
            let e = StraightnessModel::from_toml(&t, "m.toml").unwrap_err();
            let s = e.to_string();
            let StraightnessError::File(f) = &e else {
                panic!("not located: {s}")
            };
            let row = t
                .lines()
                .position(|l| l.trim_start().starts_with(at))
                .unwrap()
                + 1;
            assert_eq!(f.row, row, "{s}");
            assert!(s.starts_with(&format!("m.toml:{row}:")), "{s}");
            assert!(s.contains(needle), "{needle}: {s}");
        }
        assert!(!StraightnessModel::is_model_toml("axis,direction\n"));
        assert!(!StraightnessModel::is_model_toml("kind = \"other\"\n"));
    }

    #[test]
    fn correction_table_is_minus_the_deviation_and_sums_exactly() {
        let m = model();
        let csv = m.correction_table_csv(7.0).unwrap();
        let rows: Vec<Vec<String>> = csv
            .lines()
            .filter(|l| !l.starts_with('#'))
            .skip(1)
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect();
        let xs: Vec<&Vec<String>> = rows.iter().filter(|r| r[0] == "X").collect();
        let ys: Vec<&Vec<String>> = rows.iter().filter(|r| r[0] == "Y").collect();
        assert_eq!(xs.first().unwrap()[1].parse::<f64>().unwrap(), -50.0);
        assert!((xs.last().unwrap()[1].parse::<f64>().unwrap() - 149.8).abs() < 1e-9);
        assert_eq!(ys.len(), 30); // 0, 7, …, 196, then 199
        for (xr, yr) in xs.iter().zip(&ys) {
            let (x, ex, cx): (f64, f64, f64) = (
                xr[1].parse().unwrap(),
                xr[2].parse().unwrap(),
                xr[3].parse().unwrap(),
            );
            let (y, ey, cy): (f64, f64, f64) = (
                yr[1].parse().unwrap(),
                yr[2].parse().unwrap(),
                yr[3].parse().unwrap(),
            );
            assert_eq!(cx, -ex);
            assert_eq!(cy, -ey);
            assert!((ex + ey - m.ez_um(x, y).unwrap()).abs() < 2e-6);
        }
        assert!(m.correction_table_csv(0.0).is_err());
    }
}
