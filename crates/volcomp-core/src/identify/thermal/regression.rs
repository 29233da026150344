//! Multiple linear regression from temperatures to parameters, optionally
//! with lagged inputs (ARX-style: exogenous inputs at cycles `t, t−1 … t−L`).
//!
//! ```text
//! θ_i(t) = β_i0 + Σ_s Σ_{l=0..L} β_i,s,l · T_s(t − l)
//! ```
//!
//! The intercept carries the parameter's value at 0 °C of every sensor (in
//! practice, the cold state); the slopes its change per kelvin. One least
//! squares problem with every parameter as a right-hand side, solved by QR
//! ([`crate::linalg::least_squares`]).

use super::ThermalError;
use crate::linalg;
use nalgebra::DMatrix;

/// A fitted regression.
#[derive(Debug, Clone, PartialEq)]
pub struct Regression {
    /// Number of sensors.
    pub sensors: usize,
    /// Number of lags `L` (0 = static regression).
    pub lags: usize,
    /// Per output: `[β_0, β_{s=0,l=0}, …, β_{s=S−1,l=0}, β_{s=0,l=1}, …]`.
    pub coefficients: Vec<Vec<f64>>,
    /// RMS of the training residuals per output.
    pub residual_rms: Vec<f64>,
}

/// The regressors at cycle `t`: `[1, T(t), T(t−1), …, T(t−L)]`, or `None`
/// for `t < L`.
pub fn features(temperatures: &[Vec<f64>], t: usize, lags: usize) -> Option<Vec<f64>> {
    if t < lags || t >= temperatures.len() {
        return None;
    }
    let mut f = vec![1.0];
    for l in 0..=lags {
        f.extend_from_slice(&temperatures[t - l]);
    }
    Some(f)
}

impl Regression {
    /// Fits `outputs[t][i]` (cycle `t`, output `i`) on the temperatures
    /// `temperatures[t][s]`.
    pub fn fit(
        temperatures: &[Vec<f64>],
        outputs: &[Vec<f64>],
        lags: usize,
    ) -> Result<Regression, ThermalError> {
        let cycles = temperatures.len().min(outputs.len());
        let sensors = temperatures.first().map_or(0, Vec::len);
        if sensors == 0 || temperatures.iter().any(|t| t.len() != sensors) {
            return Err(ThermalError::Invalid(
                "every cycle needs the same, non-zero number of temperatures".into(),
            ));
        }
        let outs = outputs.first().map_or(0, Vec::len);
        let p = 1 + sensors * (lags + 1);
        let rows: Vec<Vec<f64>> = (lags..cycles)
            .filter_map(|t| features(temperatures, t, lags))
            .collect();
        let m = rows.len();
        if m < p + 1 {
            return Err(ThermalError::Invalid(format!(
                "{m} usable cycles for {p} regression coefficients ({sensors} sensors, {lags} lags): \
                 measure more cycles or use fewer sensors/lags"
            )));
        }
        let x = DMatrix::<f64>::from_fn(m, p, |i, j| rows[i][j]);
        // Collinearity check on the column-scaled regressors.
        let xs = DMatrix::<f64>::from_fn(m, p, |i, j| {
            let n = (0..m).map(|r| rows[r][j] * rows[r][j]).sum::<f64>().sqrt();
            if n > 0.0 {
                rows[i][j] / n
            } else {
                0.0
            }
        });
        let sv = linalg::singular_values(&xs)
            .ok_or_else(|| ThermalError::Invalid("the SVD did not converge".into()))?;
        let (smax, smin) = (sv[0], sv[sv.len() - 1]);
        if smin.is_nan() || smin <= 1e-8 * smax {
            return Err(ThermalError::Invalid(
                "the temperature inputs are collinear (e.g. two sensors always equal, or a \
                 sensor constant over the whole test): drop sensors or lags"
                    .into(),
            ));
        }
        let y = DMatrix::<f64>::from_fn(m, outs, |i, j| outputs[i + lags][j]);
        let beta = linalg::least_squares(&x, &y).ok_or_else(|| {
            ThermalError::Invalid("the regression's least-squares problem is singular".into())
        })?;
        let coefficients: Vec<Vec<f64>> = (0..outs)
            .map(|j| (0..p).map(|i| beta[(i, j)]).collect())
            .collect();
        let residual_rms = (0..outs)
            .map(|j| {
                let ss: f64 = (0..m)
                    .map(|i| {
                        let fit: f64 = (0..p).map(|c| rows[i][c] * coefficients[j][c]).sum();
                        (outputs[i + lags][j] - fit).powi(2)
                    })
                    .sum();
                (ss / m as f64).sqrt()
            })
            .collect();
        Ok(Regression {
            sensors,
            lags,
            coefficients,
            residual_rms,
        })
    }

    /// Predicted outputs at cycle `t` of a temperature history, or `None`
    /// before the lags are filled.
    pub fn predict(&self, temperatures: &[Vec<f64>], t: usize) -> Option<Vec<f64>> {
        let f = features(temperatures, t, self.lags)?;
        if f.len() != 1 + self.sensors * (self.lags + 1) {
            return None;
        }
        Some(
            self.coefficients
                .iter()
                .map(|c| c.iter().zip(&f).map(|(a, b)| a * b).sum())
                .collect(),
        )
    }
}
