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

/// Something in the thermal workflow cannot be done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ThermalError {
    /// The inputs do not allow the computation; the message says why and what to do.
    #[error("{0}")]
    Invalid(String),
    /// A malformed input file (located).
    #[error(transparent)]
    File(#[from] crate::error::MapFileError),
    /// The kinematic chain does not parse.
    #[error(transparent)]
    Chain(#[from] crate::model::topology::TopologyError),
    /// One measurement cycle could not be identified.
    #[error("cycle {cycle}: {source}")]
    Cycle {
        /// Cycle number as in the file.
        cycle: usize,
        /// Why.
        #[source]
        source: Box<ThermalError>,
    },
    /// A temperature file has no row for the cycle asked for.
    #[error("{file}: no row for cycle {cycle}; cycles there are {first}…{last}")]
    NoSuchCycle {
        /// The temperature file.
        file: String,
        /// The cycle asked for.
        cycle: usize,
        /// The file's first cycle.
        first: usize,
        /// The file's last cycle.
        last: usize,
    },
    /// A measured sphere centre lies outside the axis ranges of the model.
    #[error("{}", .0.describe("the axis ranges ({ranges_mm})"))]
    OutsideRange(OutsideRange),
}

/// A measured sphere centre outside the axis ranges the polynomials live on.
#[derive(Debug, Clone, PartialEq)]
pub struct OutsideRange {
    /// Cycle number as in the file.
    pub cycle: usize,
    /// Placement, 1-based in label order.
    pub placement: usize,
    /// Sphere, 1-based.
    pub sphere: usize,
    /// The axis letter.
    pub axis: char,
    /// The coordinate (mm).
    pub value_mm: f64,
    /// The axis range (mm).
    pub range_mm: [f64; 2],
}

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
