//! The identification of a machine from probing logs (docs/probing.md,
//! "The fit"), as plain values: the options `volcomp probe fit` and
//! `volcomp probe verify` share, and the fit's own.

use super::option::{Kind, OptionError, OptionInfo, Value};
use crate::identify::probe::identify::{IdentifyOptions, ModelChoice};

/// The options of every probing identification ([`ProbeIdentifyRequest`]).
pub const PROBE_IDENTIFY_OPTIONS: &[OptionInfo] = &[
    OptionInfo::new(
        "ranges_mm",
        Kind::Ranges,
        "The machine's travel, mm: \"X0:X1,Y0:Y1,Z0:Z1\" (the polynomials live on it).",
    )
    .value("RANGES")
    .required(),
    OptionInfo::new(
        "chain",
        Kind::Text,
        "Kinematic chain, workpiece to tool (docs/kinematic.md).",
    )
    .value("CHAIN")
    .default("w X' Y' b Z t"),
    OptionInfo::new(
        "order",
        Kind::Count,
        "Largest Legendre order of the components.",
    )
    .value("ORDER")
    .default("2"),
    OptionInfo::new("model", Kind::Choice, "Which model to identify.")
        .value("MODEL")
        .default("auto")
        .choices(&[
            (
                "auto",
                "Full when spheres were measured in two placements or more, else reduced (default)",
            ),
            ("full", "The 21-component model"),
            (
                "reduced",
                "Positioning, straightness and squareness; angles zero and unknown",
            ),
        ]),
    OptionInfo::new(
        "threshold",
        Kind::Number,
        "Relative singular-value threshold for what the measurements cannot see.",
    )
    .value("THRESHOLD")
    .default("0.001"),
];

/// The fit's own options ([`ProbeFitRequest`]).
pub const PROBE_FIT_OPTIONS: &[OptionInfo] = &[OptionInfo::new(
    "leave_one_out",
    Kind::Switch,
    "Also predict every placement from a model fitted without it.",
)];

/// A probing identification, as plain values.
#[derive(Debug, Clone, PartialEq)]
#[allow(missing_docs)]
pub struct ProbeIdentifyRequest {
    pub ranges_mm: Option<[[f64; 2]; 3]>,
    pub chain: String,
    pub order: u64,
    pub model: String,
    pub threshold: f64,
}

impl Default for ProbeIdentifyRequest {
    fn default() -> Self {
        Self {
            ranges_mm: None,
            chain: "w X' Y' b Z t".into(),
            order: 2,
            model: "auto".into(),
            threshold: 0.001,
        }
    }
}

impl super::Request for ProbeIdentifyRequest {
    const OPTIONS: &'static [&'static [OptionInfo]] = &[PROBE_IDENTIFY_OPTIONS];

    fn set(&mut self, name: &str, v: Value) -> Result<(), OptionError> {
        match name {
            "ranges_mm" => self.ranges_mm = Some(v.ranges("ranges_mm")?),
            "chain" => self.chain = v.text("chain")?,
            "order" => self.order = v.count("order")?,
            "model" => self.model = v.text("model")?,
            "threshold" => self.threshold = v.number("threshold")?,
            _ => {
                return Err(OptionError::new(
                    "ranges_mm",
                    format!("has no option `{name}`"),
                ))
            }
        }
        Ok(())
    }
}

impl ProbeIdentifyRequest {
    /// The identification's options, checked.
    pub fn options(&self) -> Result<IdentifyOptions, OptionError> {
        let ranges_mm = self
            .ranges_mm
            .ok_or_else(|| OptionError::new("ranges_mm", "is required"))?;
        let info = <Self as super::Request>::info("model").expect("an option");
        let model = match info
            .choice(&self.model)
            .map_err(|p| OptionError::new("model", p))?
        {
            "full" => ModelChoice::Full,
            "reduced" => ModelChoice::Reduced,
            _ => ModelChoice::Auto,
        };
        if !(1..=6).contains(&self.order) {
            return Err(OptionError::new(
                "order",
                format!("must be 1 … 6; got {}", self.order),
            ));
        }
        if !(self.threshold > 0.0 && self.threshold < 1.0) {
            return Err(OptionError::new(
                "threshold",
                format!("must lie between 0 and 1; got {}", self.threshold),
            ));
        }
        Ok(IdentifyOptions {
            chain: self.chain.clone(),
            ranges_mm,
            order: self.order as usize,
            model,
            relative_threshold: self.threshold,
        })
    }
}

/// A probing fit, as plain values: the identification and its own options.
#[derive(Debug, Clone, PartialEq, Default)]
#[allow(missing_docs)]
pub struct ProbeFitRequest {
    pub identify: ProbeIdentifyRequest,
    pub leave_one_out: bool,
}

impl super::Request for ProbeFitRequest {
    const OPTIONS: &'static [&'static [OptionInfo]] = &[PROBE_IDENTIFY_OPTIONS, PROBE_FIT_OPTIONS];

    fn set(&mut self, name: &str, v: Value) -> Result<(), OptionError> {
        match name {
            "leave_one_out" => self.leave_one_out = v.bool("leave_one_out")?,
            _ => self.identify.set(name, v)?,
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::Request;
    use super::*;

    #[test]
    fn the_default_options_are_the_identification_defaults_with_the_travel_given() {
        let mut r = ProbeFitRequest::default();
        r.set_named(
            "ranges_mm",
            Value::Ranges([[0.0, 600.0], [0.0, 400.0], [0.0, 300.0]]),
        )
        .unwrap();
        assert_eq!(r.identify.options().unwrap(), IdentifyOptions::default());
        assert_eq!(
            ProbeIdentifyRequest::default()
                .options()
                .unwrap_err()
                .to_string(),
            "ranges_mm is required"
        );
        r.set_named("model", Value::Text("Reduced".into())).unwrap();
        assert_eq!(r.identify.options().unwrap().model, ModelChoice::Reduced);
        r.set_named("threshold", Value::Number(2.0)).unwrap();
        assert!(r
            .identify
            .options()
            .unwrap_err()
            .to_string()
            .contains("between 0 and 1"));
    }
}
