//! Plausibility checks of a thermal fit and of a prediction: a fit whose
//! estimated probing noise is far beyond what a touch probe or CMM
//! achieves points at a mis-measured or mislabelled sphere; a prediction at
//! temperatures outside those the regression was trained on is an
//! extrapolation of a linear model and is refused unless asked for.

use super::files::{Cycle, Temperatures, ThermalModelFile};
use super::identify::Identification;
use super::ThermalError;

/// Probing noise (µm, σ per distance) beyond which a fit is suspect: touch
/// probes and CMM probing repeat to about 1 µm; five times that is no
/// longer noise.
pub const PLAUSIBLE_NOISE_UM: f64 = 5.0;

/// Observations named in a noise warning.
const WORST_SHOWN: usize = 3;

/// One warning per cycle whose estimated probing noise σ0 exceeds
/// [`PLAUSIBLE_NOISE_UM`], naming the observations with the largest
/// residuals (cycle, placement in label order, sphere).
///
/// Observations are ordered as [`super::identify::identify`] builds them:
/// per placement, the distance from sphere 1 to sphere 2, 3, ….
pub fn noise_warnings(cycles: &[Cycle], idents: &[Identification]) -> Vec<String> {
    let mut out = Vec::new();
    for (cycle, id) in cycles.iter().zip(idents) {
        let Some(s0) = id.sigma0_um else { continue };
        if s0 <= PLAUSIBLE_NOISE_UM {
            continue;
        }
        let mut names = Vec::new();
        for (p, placement) in cycle.placements.iter().enumerate() {
            for j in 1..placement.centres_mm.len() {
                names.push((p + 1, j + 1));
            }
        }
        let mut order: Vec<usize> = (0..id.residuals_um.len()).collect();
        order.sort_by(|&a, &b| {
            id.residuals_um[b]
                .abs()
                .total_cmp(&id.residuals_um[a].abs())
        });
        let worst: Vec<String> = order
            .iter()
            .take(WORST_SHOWN)
            .filter_map(|&k| {
                names.get(k).map(|(p, s)| {
                    format!("placement {p}, sphere {s}: {:.1} µm", id.residuals_um[k])
                })
            })
            .collect();
        out.push(format!(
            "cycle {}: the probing noise estimated from the residuals is {s0:.1} µm, far beyond a probe's noise (≤ {PLAUSIBLE_NOISE_UM} µm): a sphere may be mis-measured, mislabelled or loose; largest residuals: {}",
            cycle.cycle,
            worst.join("; ")
        ));
    }
    out
}

/// Margin around the training range within which a temperature is still
/// accepted: the larger of 2 K and 20 % of the sensor's training span.
pub fn margin_k(lo_c: f64, hi_c: f64) -> f64 {
    (0.2 * (hi_c - lo_c)).max(2.0)
}

/// Refuses a prediction at row `row` of `temps` (and its lagged rows) when a
/// sensor lies outside the temperatures the model was trained on, widened by
/// [`margin_k`]: the regression is linear and says nothing there.
pub fn check_training_range(
    model: &ThermalModelFile,
    temps: &Temperatures,
    file: &str,
    row: usize,
) -> Result<(), ThermalError> {
    for r in row.saturating_sub(model.lags)..=row {
        let Some(values) = temps.values.get(r) else {
            continue;
        };
        for (s, &t) in values.iter().enumerate() {
            let seen = model
                .temperatures_c
                .iter()
                .filter_map(|v| v.get(s).copied());
            let (lo, hi) = seen.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(v), h.max(v))
            });
            if !lo.is_finite() {
                continue;
            }
            let m = margin_k(lo, hi);
            if t < lo - m || t > hi + m {
                return Err(ThermalError::Invalid(format!(
                    "{file}: cycle {}: sensor `{}` = {t} °C lies outside the temperatures the model was trained on ({lo} … {hi} °C, accepted to ±{m:.1} K beyond): the linear regression would extrapolate; measure the machine at such temperatures and fit again, or allow extrapolation explicitly",
                    temps.cycles.get(r).copied().unwrap_or(r),
                    temps.sensors.get(s).map_or("?", String::as_str),
                )));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn margin_is_two_kelvin_or_a_fifth_of_the_span() {
        assert_eq!(margin_k(20.0, 25.0), 2.0);
        assert_eq!(margin_k(20.0, 40.0), 4.0);
    }
}
