//! What the thermal workflow reports from a fitted model: loading the model
//! file from disk, the regression's fitted parameter curves, the parameters
//! ranked by drift, the confidence-band table (`docs/thermal.md`,
//! "Confidence bands from the command line") and the example input files.

use super::files::{ParamFit, ThermalModelFile};
use super::regression::Regression;
use super::uncertainty::LineBands;
use crate::error::Error;
use std::path::Path;

/// Reads and checks a thermal model file (TOML, [`ThermalModelFile`]).
///
/// Errors: [`Error::Io`] when the file cannot be read, [`Error::Thermal`]
/// (located) when its content is not a thermal model.
pub fn load_model(path: &Path) -> Result<ThermalModelFile, Error> {
    let text = crate::io::inputs::read_to_string(path, "the thermal model")
        .map_err(|source| Error::io(path, source))?;
    Ok(ThermalModelFile::from_toml(
        &text,
        &path.display().to_string(),
    )?)
}

impl ThermalModelFile {
    /// The regression of one parameter as stored in the file.
    pub fn regression_of(&self, p: &ParamFit) -> Regression {
        let mut coefficients = Vec::with_capacity(1 + p.per_kelvin.len());
        coefficients.push(p.intercept);
        coefficients.extend_from_slice(&p.per_kelvin);
        Regression {
            sensors: self.sensors.len(),
            lags: self.lags,
            coefficients: vec![coefficients],
            residual_rms: vec![p.residual_rms],
        }
    }

    /// The regression's value of parameter `p` at every training cycle
    /// whose lags are filled, as `(time_h, value)` in `p.unit`.
    pub fn fitted(&self, p: &ParamFit) -> Vec<(f64, f64)> {
        let reg = self.regression_of(p);
        (self.lags..self.time_h.len())
            .filter_map(|c| {
                let v = reg.predict(&self.temperatures_c, c)?;
                Some((self.time_h[c], v[0]))
            })
            .collect()
    }

    /// Smallest and largest probing noise σ0 over the training cycles (µm);
    /// `(∞, 0)` without cycles, NaN (unknown) cycles ignored.
    pub fn sigma0_range_um(&self) -> (f64, f64) {
        self.sigma0_um
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(l, h), v| (l.min(*v), h.max(*v)))
    }

    /// The parameter whose regression leaves the largest residual RMS (the
    /// last of equal ones).
    pub fn largest_residual(&self) -> Option<&ParamFit> {
        self.params
            .iter()
            .max_by(|a, b| a.residual_rms.total_cmp(&b.residual_rms))
    }

    /// The `top` (at least one) parameters that drift most over the
    /// training cycles relative to their identification uncertainty (range
    /// of the identified values over the mean finite σ): real drifts first.
    pub fn by_drift(&self, top: usize) -> Vec<&ParamFit> {
        let mut order: Vec<&ParamFit> = self.params.iter().collect();
        order.sort_by(|a, b| drift_in_sigma(b).total_cmp(&drift_in_sigma(a)));
        order.truncate(top.max(1));
        order
    }
}

/// Range of a parameter's identified values in units of its mean finite
/// standard uncertainty (the uncertainty floored at 1e-12).
pub fn drift_in_sigma(p: &ParamFit) -> f64 {
    let (lo, hi) = p
        .identified
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(*v), h.max(*v))
        });
    let sigma = p.sigma.iter().filter(|s| s.is_finite()).sum::<f64>() / p.sigma.len().max(1) as f64;
    (hi - lo) / sigma.max(1e-12)
}

/// The confidence-band table:
/// `line,position_mm,component,estimate_um,std_um,lo95_um,hi95_um`, one
/// row per point of each line and deviation component.
pub fn bands_csv(lines: &[LineBands]) -> String {
    let mut csv = String::from("line,position_mm,component,estimate_um,std_um,lo95_um,hi95_um\n");
    for l in lines {
        let name = ['X', 'Y', 'Z'][l.axis];
        for (p, b) in l.points_mm.iter().zip(&l.bands) {
            for c in 0..3 {
                csv.push_str(&format!(
                    "{name},{:.3},{},{:.4},{:.4},{:.4},{:.4}\n",
                    p[l.axis],
                    ['x', 'y', 'z'][c],
                    b.estimate_um[c],
                    b.std_um[c],
                    b.lo_um[c],
                    b.hi_um[c]
                ));
            }
        }
    }
    csv
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::thermal::uncertainty::Band;
    use volcomp_gcode::Vec3;

    fn param(intercept: f64, per_kelvin: Vec<f64>) -> ParamFit {
        ParamFit {
            name: "EXX.P1".into(),
            unit: "um".into(),
            intercept,
            per_kelvin,
            residual_rms: 0.0,
            identified: vec![1.0, 2.0, 4.0],
            sigma: vec![0.5, 0.5, f64::NAN],
        }
    }

    fn file(lags: usize, params: Vec<ParamFit>) -> ThermalModelFile {
        ThermalModelFile {
            model: super::super::files::THERMAL_KIND.into(),
            chain: "w X' Y' b Z t".into(),
            ranges_mm: [[0.0, 1.0]; 3],
            order: 2,
            probe_length_mm: 0.0,
            sensors: vec!["a_C".into(), "b_C".into()],
            lags,
            table_samples: 3,
            time_h: vec![0.0, 1.0, 2.0],
            temperatures_c: vec![vec![20.0, 10.0], vec![21.0, 12.0], vec![23.0, 11.0]],
            sigma0_um: vec![0.1; 3],
            unidentifiable: Vec::new(),
            params,
        }
    }

    #[test]
    fn fitted_is_intercept_plus_slopes_times_temperatures() {
        // 1 + 0.5·Ta − 2·Tb, by hand: 1 + 10 − 20 = −9; 1 + 10.5 − 24 = −12.5;
        // 1 + 11.5 − 22 = −9.5.
        let p = param(1.0, vec![0.5, -2.0]);
        let m = file(0, vec![p.clone()]);
        assert_eq!(m.fitted(&p), vec![(0.0, -9.0), (1.0, -12.5), (2.0, -9.5)]);
    }

    #[test]
    fn fitted_with_a_lag_starts_at_the_first_filled_cycle() {
        // Lag 0 slopes (1, 0), lag 1 slopes (0, 1): Ta(t) + Tb(t − 1).
        // t = 1: 21 + 10 = 31; t = 2: 23 + 12 = 35.
        let p = param(0.0, vec![1.0, 0.0, 0.0, 1.0]);
        let m = file(1, vec![p.clone()]);
        assert_eq!(m.fitted(&p), vec![(1.0, 31.0), (2.0, 35.0)]);
    }

    #[test]
    fn drift_is_range_over_mean_finite_sigma() {
        // Range 4 − 1 = 3; finite σ sum 1.0 over 3 entries → 1/3; 3 / (1/3) = 9.
        let p = param(0.0, vec![]);
        assert!((drift_in_sigma(&p) - 9.0).abs() < 1e-12);
        let mut still = param(0.0, vec![]);
        still.identified = vec![5.0, 5.0, 5.0];
        still.name = "EYY.P1".into();
        let m = file(0, vec![still, p]);
        let ranked: Vec<&str> = m.by_drift(1).iter().map(|p| p.name.as_str()).collect();
        assert_eq!(ranked, ["EXX.P1"]);
        assert_eq!(m.by_drift(0).len(), 1, "at least one parameter");
    }

    #[test]
    fn bands_csv_has_one_row_per_point_and_component() {
        let b = Band {
            estimate_um: Vec3::new(1.0, 2.0, 3.0),
            std_um: Vec3::new(0.1, 0.2, 0.3),
            lo_um: Vec3::new(0.5, 1.5, 2.5),
            hi_um: Vec3::new(1.5, 2.5, 3.5),
        };
        let lines = [LineBands {
            axis: 1,
            points_mm: vec![Vec3::new(0.0, 12.5, 0.0)],
            bands: vec![b],
        }];
        assert_eq!(
            bands_csv(&lines),
            "line,position_mm,component,estimate_um,std_um,lo95_um,hi95_um\n\
             Y,12.500,x,1.0000,0.1000,0.5000,1.5000\n\
             Y,12.500,y,2.0000,0.2000,1.5000,2.5000\n\
             Y,12.500,z,3.0000,0.3000,2.5000,3.5000\n"
        );
    }

    #[test]
    fn noise_range_and_largest_residual() {
        let mut a = param(0.0, vec![]);
        a.residual_rms = 0.3;
        let mut b = param(0.0, vec![]);
        b.name = "EYY.P1".into();
        b.residual_rms = 0.7;
        let mut m = file(0, vec![a, b]);
        m.sigma0_um = vec![0.5, f64::NAN, 0.25, 0.75];
        assert_eq!(m.sigma0_range_um(), (0.25, 0.75));
        assert_eq!(m.largest_residual().unwrap().name, "EYY.P1");
        m.params.clear();
        assert!(m.largest_residual().is_none());
    }

    #[test]
    fn rows_are_found_by_cycle_or_default_to_the_last() {
        let t = super::super::files::Temperatures {
            sensors: vec!["a_C".into()],
            cycles: vec![3, 4, 5],
            time_h: vec![0.0, 1.0, 2.0],
            values: vec![vec![20.0], vec![21.0], vec![22.0]],
        };
        assert_eq!(t.row_of(None, "t.csv"), Ok(2));
        assert_eq!(t.row_of(Some(4), "t.csv"), Ok(1));
        let e = t.row_of(Some(9), "t.csv").unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.csv: no row for cycle 9; cycles there are 3…5"
        );
    }

    #[test]
    fn a_missing_model_file_names_the_path() {
        let e = load_model(Path::new("/nonexistent/thermal.toml")).unwrap_err();
        assert!(matches!(e, Error::Io { .. }));
        assert!(
            e.to_string().starts_with("/nonexistent/thermal.toml: "),
            "{e}"
        );
    }
}
