//! The thermal model (docs/thermal.md), as plain values: its fit from
//! ball-array cycles and temperatures, and its prediction for a moment.

use super::option::{Input, OptionError};
use crate::identify::thermal::checks::{check_training_range, noise_warnings};
use crate::identify::thermal::files::{
    self, parse_artifact, parse_measurements, parse_temperatures, Cycle, FitOptions, Temperatures,
    ThermalModelFile,
};
use crate::identify::thermal::identify::{Identification, DEFAULT_RELATIVE_THRESHOLD};
use crate::identify::thermal::uncertainty::{
    axis_line_bands_with_progress, band_samples_problem, LineBands,
};
use crate::identify::thermal::ThermalError;
use crate::model::kinematic::KinematicModel;
use crate::Error;

/// Monte Carlo draws of the confidence bands when none are given.
pub const DEFAULT_BAND_SAMPLES: u64 = 400;

request! {
    /// A thermal fit, as plain values.
    #[allow(missing_docs)]
    pub struct ThermalFitRequest {}
    /// The options of [`ThermalFitRequest`].
    pub const THERMAL_FIT_OPTIONS, unknown "chain";

    measurements: Option<Input> = None, Input.value("CSV").required(),
        "Measured sphere centres: cycle,time_h,placement,sphere,x_mm,y_mm,z_mm.";

    temperatures: Option<Input> = None, Input.value("CSV").required(),
        "Temperatures per cycle: cycle,time_h,<sensor>_C,…";

    artifact: Option<Input> = None, Input.value("CSV").required(),
        "Artifact: sphere,distance_mm (calibrated distance from sphere 1).";

    ranges_mm: Option<[[f64; 2]; 3]> = None, Ranges.value("RANGES").required(),
        "Axis ranges the polynomials live on, mm: \"X0:X1,Y0:Y1,Z0:Z1\".";

    chain: String = "w X' Y' b Z t".into(), Text.value("CHAIN").default("w X' Y' b Z t"),
        "Kinematic chain, workpiece to tool (docs/kinematic.md).";

    order: u64 = 2, Count.value("ORDER").default("2"),
        "Maximum Legendre order of the components.";

    probe_length_mm: f64 = 0.0, Number.value("MM").default("0"),
        "Tool length offset of the probe (mm).";

    lags: u64 = 0, Count.value("LAGS").default("0"),
        "Lagged cycles of every sensor in the regression (ARX-style inputs).";

    threshold: f64 = DEFAULT_RELATIVE_THRESHOLD, Number.value("THRESHOLD").default("0.001"),
        "Relative singular-value threshold for rank deficiency.";

    table_samples: u64 = 61, Count.value("N").default("61"),
        "Points per component table in predicted models.";

    bands_samples: Option<u64> = None, Count.flag("samples").value("N"),
        "Monte Carlo draws of the 95 % confidence bands of the last cycle's identified TCP error along lines through the middle of the volume (default 400 where bands are asked for).";
}

/// An input file's text.
fn text(input: &Option<Input>, name: &'static str) -> Result<(String, String), Error> {
    let input = input
        .as_ref()
        .ok_or_else(|| OptionError::new(name, "is required"))?;
    let shown = input.name();
    let text = String::from_utf8(input.bytes()?.into_owned())
        .map_err(|_| ThermalError::Invalid(format!("{shown}: not UTF-8 text")))?;
    Ok((text, shown))
}

fn count(name: &'static str, v: u64) -> Result<usize, OptionError> {
    usize::try_from(v).map_err(|_| OptionError::new(name, format!("is too large: {v}")))
}

/// A fitted thermal model with what the fit found.
pub struct ThermalFit {
    /// The model file.
    pub file: ThermalModelFile,
    /// The identification of every cycle.
    pub idents: Vec<Identification>,
    /// The cycles measured.
    pub cycles: Vec<Cycle>,
    /// What the front end warns of (noise of the probing), naming the
    /// measurements file.
    pub warnings: Vec<String>,
}

impl ThermalFitRequest {
    /// The fit's options, checked.
    pub fn options(&self) -> Result<FitOptions, OptionError> {
        let ranges_mm = self
            .ranges_mm
            .ok_or_else(|| OptionError::new("ranges_mm", "is required"))?;
        if !(self.threshold > 0.0 && self.threshold < 1.0) {
            return Err(OptionError::new(
                "threshold",
                format!(
                    "must be a relative threshold between 0 and 1 (default {DEFAULT_RELATIVE_THRESHOLD}); got {}",
                    self.threshold
                ),
            ));
        }
        if !self.probe_length_mm.is_finite() {
            return Err(OptionError::new(
                "probe_length_mm",
                "must be a finite length in mm",
            ));
        }
        let options = FitOptions {
            chain: self.chain.clone(),
            ranges_mm,
            order: count("order", self.order)?,
            probe_length_mm: self.probe_length_mm,
            lags: count("lags", self.lags)?,
            relative_threshold: self.threshold,
            table_samples: count("table_samples", self.table_samples)?,
        };
        // The bounds on the work (docs/errors.md, "Limits"), before any
        // file is read.
        options
            .problem()
            .map_err(|(name, problem)| OptionError::new(name, problem))?;
        if let Some(n) = self.bands_samples {
            band_samples_problem(n).map_err(|p| OptionError::new("bands_samples", p))?;
        }
        Ok(options)
    }

    /// Reads the inputs and fits the model.
    pub fn fit(&self) -> Result<ThermalFit, Error> {
        let options = self.options()?;
        let (a_text, a_name) = text(&self.artifact, "artifact")?;
        let array = parse_artifact(&a_text, &a_name)?;
        let (m_text, m_name) = text(&self.measurements, "measurements")?;
        let cycles = parse_measurements(&m_text, &m_name, &array)?;
        let (t_text, t_name) = text(&self.temperatures, "temperatures")?;
        let temps = parse_temperatures(&t_text, &t_name)?;
        let (file, idents) = files::fit(&array, &cycles, &temps, &t_name, &options)?;
        let warnings = noise_warnings(&cycles, &idents)
            .into_iter()
            .map(|w| format!("{m_name}: {w}"))
            .collect();
        Ok(ThermalFit {
            file,
            idents,
            cycles,
            warnings,
        })
    }

    /// The 95 % Monte Carlo bands of the last cycle's identified TCP error
    /// along lines through the middle of the volume (docs/thermal.md),
    /// with `samples` draws (10 to 10 000; default [`DEFAULT_BAND_SAMPLES`]).
    pub fn bands(
        &self,
        fit: &ThermalFit,
        progress: &mut dyn crate::progress::Progress,
    ) -> Result<(Vec<LineBands>, usize), Error> {
        let o = self.options()?;
        let last = fit
            .idents
            .last()
            .ok_or_else(|| ThermalError::Invalid("no cycles to draw bands for".into()))?;
        let samples = count(
            "bands_samples",
            self.bands_samples.unwrap_or(DEFAULT_BAND_SAMPLES),
        )?;
        let model = files::poly_model(&o.chain, o.ranges_mm, o.order, o.probe_length_mm)?;
        let lines = axis_line_bands_with_progress(
            &model,
            last,
            o.ranges_mm,
            o.probe_length_mm,
            samples,
            progress,
        );
        Ok((lines, samples))
    }
}

impl ThermalFit {
    /// What the fit found, in lines for a person.
    pub fn summary_lines(&self) -> Vec<String> {
        let first = &self.idents[0];
        let (lo, hi) = self.file.sigma0_range_um();
        let mut lines = vec![
            format!(
                "{} cycles, {} placements, {} observations per cycle; rank {} of {} parameters",
                self.cycles.len(),
                self.cycles[0].placements.len(),
                first.observations,
                first.rank,
                first.theta.len()
            ),
            format!("probing noise estimated from the residuals: {lo:.3} … {hi:.3} µm"),
        ];
        lines.push(if self.file.unidentifiable.is_empty() {
            "every parameter is identifiable".into()
        } else {
            format!(
                "not identifiable from these placements (no values, zero in predicted models): {}",
                self.file.unidentifiable.join(", ")
            )
        });
        if let Some(p) = self.file.largest_residual() {
            lines.push(format!(
                "regression on {}, {}: largest residual RMS {:.3} {} ({})",
                crate::report::text::count(self.file.sensors.len() as u64, "sensor", "sensors"),
                crate::report::text::count(self.file.lags as u64, "lag", "lags"),
                p.residual_rms,
                unit_symbol(&p.unit),
                p.name
            ));
        }
        lines
    }
}

/// A unit as people write it: the files spell `um` and `urad` in ASCII.
pub fn unit_symbol(unit: &str) -> &str {
    match unit {
        "um" => "µm",
        "urad" => "µrad",
        u => u,
    }
}

request! {
    /// A thermal prediction, as plain values.
    #[allow(missing_docs)]
    pub struct ThermalPredictRequest {}
    /// The options of [`ThermalPredictRequest`].
    pub const THERMAL_PREDICT_OPTIONS, unknown "cycle";

    temperatures: Option<Input> = None, Input.value("CSV").required(),
        "Temperatures (same sensor columns as for the fit).";

    cycle: Option<u64> = None, Count.value("CYCLE"),
        "Cycle number of the moment (default: the last row).";

    extrapolate: bool = false, Switch,
        "Predict even at temperatures outside the training range (with a warning) instead of refusing.";
}

/// The model's parameters at one moment.
pub struct Prediction {
    /// The parameters (`None`: not identifiable, zero in the model).
    pub theta: Vec<Option<f64>>,
    /// The temperatures read.
    pub temperatures: Temperatures,
    /// Their file's name.
    pub file: String,
    /// The row of the moment.
    pub row: usize,
    /// Why the prediction extrapolates, when it does.
    pub warning: Option<String>,
}

impl ThermalPredictRequest {
    /// The parameters of `model` at the moment asked for; outside the
    /// training range refused unless extrapolating.
    pub fn predict(&self, model: &ThermalModelFile) -> Result<Prediction, Error> {
        let (text, file) = text(&self.temperatures, "temperatures")?;
        let temps = parse_temperatures(&text, &file)?;
        let cycle = self.cycle.map(|c| count("cycle", c)).transpose()?;
        let row = temps.row_of(cycle, &file)?;
        let (theta, warning) = if self.extrapolate {
            let warning = check_training_range(model, &temps, &file, row)
                .err()
                .map(|e| format!("{e} ({{extrapolate}})"));
            (model.predict_extrapolating(&temps, &file, row)?, warning)
        } else {
            let theta = model.predict(&temps, &file, row).map_err(|e| {
                ThermalError::Invalid(format!("{e}\n  help: predict anyway with {{extrapolate}}"))
            })?;
            (theta, None)
        };
        Ok(Prediction {
            theta,
            temperatures: temps,
            file,
            row,
            warning,
        })
    }
}

impl Prediction {
    /// The 21-component model of the moment, its tables sampled as the
    /// thermal model file says.
    pub fn model(&self, model: &ThermalModelFile) -> Result<KinematicModel, Error> {
        let samples = model.table_samples.max(2);
        Ok(model.poly_model()?.to_kinematic_model(&self.theta, samples))
    }

    /// The 21-component model files of the moment: its TOML (naming the
    /// tables `tables`) and the tables' CSV.
    pub fn model_files(
        &self,
        model: &ThermalModelFile,
        tables: &str,
    ) -> Result<(String, String), Error> {
        let description = format!(
            "volcomp thermal prediction for cycle {} (t = {} h) of {}",
            self.temperatures.cycles[self.row], self.temperatures.time_h[self.row], self.file
        );
        Ok(model.model_files(&self.theta, tables, &description)?)
    }
}
