//! Requests: each job a front end asks of the library, as plain values,
//! checked once here with the library's own messages.
//!
//! A request holds one job's options ([`CompensateRequest`],
//! [`SimulateRequest`], with [`MachineRequest`] and [`MapRequest`] inside
//! or beside them). Each option is described once, in the request's table
//! of [`OptionInfo`] (name, kind, default, help); a front end builds its own
//! arguments from that table (the CLI its flags, the Python package its
//! keyword arguments, signature and docstring), reads values into a
//! [`Value`] and hands them to [`Request::set`]. The request then checks
//! the values together and gives the library's option types, the machine,
//! the provenance header. Messages name options by their names in braces
//! (`{chord_tolerance_mm}`); a front end writes them its own way
//! ([`Spelling`]).
//!
//! A new option: one entry in the request's option list (its field, default,
//! kind, help and flag, declared together by `request!`), its check beside
//! the others; both front ends then take it with its help
//! (docs/architecture.md, "Where a new option goes").

#[macro_use]
mod declare;

pub mod ballbar;
pub mod charts;
mod compensate;
#[cfg(any(test, feature = "examples"))]
pub mod demo;
mod export;
mod machine;
mod map;
mod map_jobs;
mod mirror;
pub mod option;
#[cfg(feature = "plots")]
pub mod plot;
pub mod probe;
mod report;
mod simulate;
mod straightness;
mod thermal;
mod time;

pub use compensate::{
    CompensateRequest, Compensation, ModelSource, COMPENSATE_OPTIONS, DEFAULT_MAX_OUTPUT_BYTES,
};
pub use export::{
    positioning_tables, straightness_tables, CompRequest, Exported, MapExportRequest,
    MapToolRequest, MapView, COMP_OPTIONS, EXPORT_OPTIONS, MAP_TOOL_OPTIONS,
};
pub use machine::{Machine, MachineRequest, MACHINE_OPTIONS, NO_WORK_OFFSET};
pub use map::{MapRequest, MAP_OPTIONS};
pub use map_jobs::{
    import_linuxcnc, import_params, iso230_2_lines, map_charts, map_file_name, map_plot_report,
    model_outputs, read_text, run_facts, ConvertTo, Iso230_2Job, JobFile, JobOutput, MapBuild,
    MapConvert, ParamsFormat,
};
pub use mirror::{MirrorPlan, MirrorRequest, MirrorRun, MIRROR_OPTIONS};
pub use option::{
    did_you_mean, render, Input, Kind, Names, OptionError, OptionInfo, Request, Spelling,
    UnknownOption, Value,
};
pub use probe::{
    ProbeFitRequest, ProbeIdentifyRequest, ProbePlanRequest, PROBE_FIT_OPTIONS,
    PROBE_IDENTIFY_OPTIONS, PROBE_PLAN_OPTIONS,
};
pub use report::{header_inputs, ReportRequest, RunNames, REPORT_OPTIONS};
pub use simulate::{SimulateRequest, SIMULATE_OPTIONS};
pub use straightness::{fit_summary, StraightnessFitRequest, STRAIGHTNESS_OPTIONS};
pub use thermal::{
    unit_symbol, Prediction, ThermalFit, ThermalFitRequest, ThermalPredictRequest,
    DEFAULT_BAND_SAMPLES, THERMAL_FIT_OPTIONS, THERMAL_PREDICT_OPTIONS,
};
pub use time::{Compensated, Simulated, TimeRequest, TIME_OPTIONS};

pub use ballbar::{
    BallbarFitRequest, BallbarMapRequest, BallbarPredictRequest, BALLBAR_FIT_OPTIONS,
    BALLBAR_MAP_OPTIONS, BALLBAR_PREDICT_OPTIONS,
};

/// Every option of every request, for a front end that spells a name it
/// meets in a message.
pub const ALL_OPTIONS: &[&[OptionInfo]] = &[
    MACHINE_OPTIONS,
    MAP_OPTIONS,
    COMPENSATE_OPTIONS,
    SIMULATE_OPTIONS,
    MIRROR_OPTIONS,
    THERMAL_FIT_OPTIONS,
    THERMAL_PREDICT_OPTIONS,
    STRAIGHTNESS_OPTIONS,
    PROBE_IDENTIFY_OPTIONS,
    PROBE_FIT_OPTIONS,
    PROBE_PLAN_OPTIONS,
    TIME_OPTIONS,
    EXPORT_OPTIONS,
    COMP_OPTIONS,
    MAP_TOOL_OPTIONS,
    BALLBAR_PREDICT_OPTIONS,
    BALLBAR_FIT_OPTIONS,
    BALLBAR_MAP_OPTIONS,
    REPORT_OPTIONS,
];

/// Option `name`'s value `v` when it is finite and above zero, else the
/// error `must be {what}; got {v}` (`what`: "a positive length in mm", …).
pub(crate) fn positive(name: &'static str, v: f64, what: &str) -> Result<f64, OptionError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(OptionError::new(name, format!("must be {what}; got {v}")))
    }
}

/// The option named `name` in any request.
pub fn find(name: &str) -> Option<&'static OptionInfo> {
    ALL_OPTIONS
        .iter()
        .flat_map(|g| g.iter())
        .find(|o| o.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every option's shown default is the request's default, every name
    /// is accepted by `set`, and every help names only known options.
    fn consistent<R: Request, T: PartialEq + std::fmt::Debug>(same: fn(&R) -> T) {
        for info in R::OPTIONS.iter().flat_map(|g| g.iter()) {
            if let Some(d) = info.default {
                let mut r = R::default();
                let v = info
                    .parse(d)
                    .unwrap_or_else(|e| panic!("{}: {e}", info.name));
                r.set(info.name, v).unwrap();
                assert_eq!(
                    same(&r),
                    same(&R::default()),
                    "{}: shown default {d}",
                    info.name
                );
            }
            // An option with a shown default was set above; one without is
            // set to a sample of its kind (a default-bearing option may refuse
            // the sample's value, e.g. too few Monte Carlo repeats).
            let sample = match info.kind {
                Kind::Switch => Value::Bool(true),
                Kind::Number => Value::Number(1.0),
                Kind::Count => Value::Count(1),
                Kind::Choice => Value::Text(info.choices[0].0.into()),
                Kind::Path | Kind::Input => Value::Path("f".into()),
                Kind::Triple => Value::Triple([0.0; 3]),
                Kind::Size => Value::Size(None),
                Kind::Text => Value::Text("t".into()),
                Kind::Ranges => Value::Ranges([[0.0, 1.0]; 3]),
            };
            if info.default.is_none() {
                R::default().set(info.name, sample).unwrap();
            }
            struct Known;
            impl Spelling for Known {
                fn option(&self, name: &str) -> String {
                    assert!(find(name).is_some() || name == "clamp", "unknown {name}");
                    name.into()
                }
            }
            render(info.help, &Known);
        }
    }

    #[test]
    fn tables_and_requests_agree() {
        consistent(|r: &CompensateRequest| (r.options(), r.max_output_bytes));
        consistent(|r: &SimulateRequest| r.clone());
        consistent(|r: &ReportRequest| r.clone());
        consistent(|r: &MapRequest| r.clone());
        consistent(|r: &MirrorRequest| r.clone());
        consistent(|r: &ThermalFitRequest| r.clone());
        consistent(|r: &ThermalPredictRequest| r.clone());
        consistent(|r: &StraightnessFitRequest| r.clone());
        consistent(|r: &ProbeFitRequest| r.clone());
        consistent(|r: &ProbePlanRequest| r.clone());
        consistent(|r: &MapExportRequest| r.clone());
        consistent(|r: &CompRequest| r.clone());
        consistent(|r: &MapToolRequest| r.clone());
        consistent(|r: &TimeRequest| r.clone());
        consistent(|r: &BallbarPredictRequest| r.clone());
        consistent(|r: &BallbarFitRequest| r.clone());
        consistent(|r: &BallbarMapRequest| r.clone());
    }

    /// The G61 contour tolerance is a default only: a contour tolerance
    /// given holds in every path-control mode (docs/compensation.md,
    /// "Adaptive segmentation").
    #[test]
    fn a_contour_tolerance_given_holds_under_g61_too() {
        let o = CompensateRequest::default().options().unwrap();
        let exact = o.exact_contour_tolerance_mm.unwrap();
        assert!((exact - 0.05e-3).abs() < 1e-15, "{exact}");
        let mut r = CompensateRequest::default();
        r.set_named("contour_tolerance_um", Value::Number(0.2))
            .unwrap();
        let o = r.options().unwrap();
        assert_eq!(o.exact_contour_tolerance_mm, None);
        assert!(matches!(
            o.segmentation,
            crate::compensate::Segmentation::Adaptive { tolerance_mm, .. } if (tolerance_mm - 0.2e-3).abs() < 1e-15
        ));
    }

    #[test]
    fn the_same_bad_value_gets_the_same_message_whatever_the_spelling() {
        let mut r = CompensateRequest::default();
        r.set_named("method", Value::Text("ilc".into())).unwrap();
        r.set_named("gain", Value::Number(2.0)).unwrap();
        let e = r.options().unwrap_err();
        assert_eq!(e.to_string(), "gain must satisfy 0 < γ ≤ 1; got 2");
        let e = CompensateRequest::default()
            .set_named("mehtod", Value::Text("ilc".into()))
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "there is no option `mehtod` (did you mean `method`?)"
        );
    }

    #[test]
    fn one_way_of_splitting() {
        let r = CompensateRequest {
            segments: Some(3),
            no_split: true,
            ..Default::default()
        };
        assert_eq!(
            r.options().unwrap_err().to_string(),
            "no_split cannot be given with segments: choose one way of splitting feed moves"
        );
        let r = CompensateRequest {
            segments: Some(3),
            min_segment_length_mm: Some(0.1),
            ..Default::default()
        };
        assert!(r.options().is_err());
        let r = CompensateRequest {
            segments: Some(3),
            ..Default::default()
        };
        assert_eq!(
            r.options().unwrap().segmentation,
            crate::Segmentation::Count(3)
        );
    }

    #[test]
    fn the_default_request_is_the_default_options() {
        assert_eq!(
            CompensateRequest::default().options().unwrap(),
            crate::CompensateOptions::default()
        );
    }
}
