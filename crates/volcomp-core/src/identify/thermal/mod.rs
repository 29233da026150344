//! Thermally varying volumetric error: ball-array artifact calibration,
//! identification of a 21-component model with Legendre-polynomial
//! components, regression of its parameters on temperatures, and
//! uncertainty (equations and formats in `docs/thermal.md`).
//!
//! Flow: per measurement cycle, measured sphere centres
//! ([`artifact::PlacementMeasurement`]) → [`identify::identify`] (least
//! squares by SVD, rank deficiency reported, covariance) → parameters over
//! time → [`regression::Regression`] on temperatures → parameters for a
//! moment → [`poly::PolyModel::to_kinematic_model`] → the model file that
//! `volcomp compensate --map` reads.

pub mod artifact;
pub mod checks;
pub mod files;
pub mod identify;
pub mod legendre;
pub mod poly;
pub mod regression;
pub mod report;
pub mod uncertainty;

pub use crate::error::domain::{OutsideRange, ThermalError};

impl OutsideRange {
    /// The message, naming the axis-ranges option as `ranges`.
    pub fn describe(&self, ranges: &str) -> String {
        let [lo, hi] = self.range_mm;
        format!(
            "cycle {}, placement {} (in label order), sphere {}: {} = {} mm lies outside \
             the axis range {lo}…{hi} mm; widen {ranges} to the machine's travel",
            self.cycle, self.placement, self.sphere, self.axis, self.value_mm
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outside_range_names_the_option_as_asked() {
        let e = OutsideRange {
            cycle: 0,
            placement: 1,
            sphere: 2,
            axis: 'X',
            value_mm: 160.5,
            range_mm: [0.0, 60.0],
        };
        assert_eq!(
            ThermalError::OutsideRange(e.clone()).to_string(),
            "cycle 0, placement 1 (in label order), sphere 2: X = 160.5 mm lies outside the axis \
             range 0…60 mm; widen the axis ranges ({ranges_mm}) to the machine's travel"
        );
        assert!(e
            .describe("<ranges>")
            .ends_with("widen <ranges> to the machine's travel"));
    }
}
