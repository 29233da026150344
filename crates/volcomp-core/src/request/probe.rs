//! Probing (docs/probing.md) as plain values: the probing program's plan
//! ("The probing program"), the options `volcomp probe fit` and `volcomp
//! probe verify` share ("The fit"), and the fit's own.

use super::option::{Kind, OptionError, OptionInfo, Value};
use crate::identify::probe::identify::{IdentifyOptions, ModelChoice};
use crate::identify::probe::plan::{NoContact, PlanOptions, SpherePattern};

request! {
    /// A probing program's plan, as plain values (the artifact and the set-up
    /// are files the front end reads).
    #[allow(missing_docs)]
    pub struct ProbePlanRequest {}
    /// The options of a probing program ([`ProbePlanRequest`]); their ranges
    /// are checked by [`PlanOptions::validate`].
    pub const PROBE_PLAN_OPTIONS, unknown "tip_diameter_mm";

    tip_diameter_mm: Option<f64> = None, Number.value("MM").required(),
        "Diameter of the probe's tip (mm).";

    probe_tool: Option<u64> = None, Count.value("N"),
        "The probe's tool number (G43 H, its length from the set-up's [tools]).";

    work_system: String = "G54".into(), Text.value("WORK_SYSTEM").default("G54"),
        "Coordinate system the program runs in: G54 … G59.3.";

    placement: Option<String> = None, Text.value("PLACEMENT"),
        "Only this placement (default: all, with a pause between them).";

    fast_feed_mm_min: f64 = PlanOptions::default().fast_feed_mm_min,
        Number.value("FAST_FEED_MM_MIN").default("300"),
        "Feed of the searching touch (mm/min).";

    slow_feed_mm_min: f64 = PlanOptions::default().slow_feed_mm_min,
        Number.value("SLOW_FEED_MM_MIN").default("20"),
        "Feed of the recorded touch (mm/min): its trigger lag is this feed × the servo period.";

    approach_mm: f64 = PlanOptions::default().approach_mm, Number.value("APPROACH_MM").default("2"),
        "Start of a touch before the nominal surface (mm).";

    overtravel_mm: f64 = PlanOptions::default().overtravel_mm,
        Number.value("OVERTRAVEL_MM").default("2"),
        "How far past the nominal surface a probe move may go (mm).";

    backoff_mm: f64 = PlanOptions::default().backoff_mm, Number.value("BACKOFF_MM").default("0.5"),
        "Back-off between the fast and the slow touch (mm).";

    clearance_mm: f64 = PlanOptions::default().clearance_mm,
        Number.value("CLEARANCE_MM").default("5"),
        "Height of the travel plane above the artifact (mm).";

    take_up_mm: f64 = PlanOptions::default().take_up_mm, Number.value("TAKE_UP_MM").default("1"),
        "The move that sets an axis' direction before a touch (mm).";

    sphere_touches: String = "5".into(), Choice.value("SPHERE_TOUCHES").default("5").choices(&[
        ("5", "Pole and equator"),
        ("9", "Pole, equator and four 45° shoulders"),
    ]),
        "Touches per sphere (the reference sphere has its own set).";

    repeats: u64 = PlanOptions::default().repeats as u64, Count.value("REPEATS").default("1"),
        "How often each touch is made.";

    reference_repeats: u64 = PlanOptions::default().reference_repeats as u64,
        Count.value("REFERENCE_REPEATS").default("3"),
        "How often each touch of the reference sphere is made.";

    edge_points: u64 = PlanOptions::default().edge_points as u64,
        Count.value("EDGE_POINTS").default("7"),
        "Touches along each edge of a square.";

    edge_margin_mm: f64 = PlanOptions::default().edge_margin_mm,
        Number.value("EDGE_MARGIN_MM").default("10"),
        "Distance of the first and last edge touch from an edge's ends (mm).";

    no_contact: String = "stop".into(), Choice.value("NO_CONTACT").default("stop").choices(&[
        ("stop", "G38.2: the controller stops with an error"),
        (
            "skip",
            "G38.3: the program goes on; the touch is logged as missed",
        ),
    ]),
        "What a probe move that touches nothing does.";

    log_file: String = PlanOptions::default().log_file, Text.value("LOG_FILE").default("probe.log"),
        "The log file the program writes (LOGOPEN), as LinuxCNC opens it.";

    safe_z_mm: Option<f64> = None, Number.value("SAFE_Z_MM"),
        "Machine Z for moves between placements (default: 25 mm above the artifact).";

    rapid_mm_min: f64 = PlanOptions::default().rapid_mm_min,
        Number.value("RAPID_MM_MIN").default("3000"),
        "Rapid speed for the time estimate (mm/min).";

    accel_mm_s2: f64 = PlanOptions::default().accel_mm_s2,
        Number.value("ACCEL_MM_S2").default("500"),
        "Acceleration for the time estimate (mm/s²).";
}

/// The coordinate systems a probing program may run in, G54 first.
const WORK_SYSTEMS: [&str; 9] = [
    "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
];

impl ProbePlanRequest {
    /// The plan's options (their ranges are checked with the artifact, by
    /// the plan).
    pub fn options(&self) -> Result<PlanOptions, OptionError> {
        let tip_diameter_mm = self
            .tip_diameter_mm
            .ok_or_else(|| OptionError::new("tip_diameter_mm", "is required"))?;
        let work_system = WORK_SYSTEMS
            .iter()
            .position(|n| n.eq_ignore_ascii_case(self.work_system.trim()))
            .ok_or_else(|| {
                OptionError::new(
                    "work_system",
                    format!(
                        "`{}`: write G54 … G59, G59.1, G59.2 or G59.3",
                        self.work_system
                    ),
                )
            })?;
        let choice = |name: &'static str, value: &str| {
            let info = <Self as super::Request>::info(name).expect("an option");
            info.choice(value).map_err(|p| OptionError::new(name, p))
        };
        let whole = |name: &'static str, n: u64| {
            usize::try_from(n).map_err(|_| OptionError::new(name, format!("is too large: {n}")))
        };
        let probe_tool = self
            .probe_tool
            .map(|t| {
                u32::try_from(t)
                    .map_err(|_| OptionError::new("probe_tool", format!("is too large: {t}")))
            })
            .transpose()?;
        Ok(PlanOptions {
            tip_diameter_mm,
            fast_feed_mm_min: self.fast_feed_mm_min,
            slow_feed_mm_min: self.slow_feed_mm_min,
            approach_mm: self.approach_mm,
            overtravel_mm: self.overtravel_mm,
            backoff_mm: self.backoff_mm,
            clearance_mm: self.clearance_mm,
            take_up_mm: self.take_up_mm,
            spheres: match choice("sphere_touches", &self.sphere_touches)? {
                "9" => SpherePattern::Nine,
                _ => SpherePattern::Five,
            },
            repeats: whole("repeats", self.repeats)?,
            reference_repeats: whole("reference_repeats", self.reference_repeats)?,
            edge_points: whole("edge_points", self.edge_points)?,
            edge_margin_mm: self.edge_margin_mm,
            no_contact: match choice("no_contact", &self.no_contact)? {
                "skip" => NoContact::Skip,
                _ => NoContact::Stop,
            },
            log_file: self.log_file.clone(),
            work_system,
            probe_tool,
            safe_z_mm: self.safe_z_mm,
            rapid_mm_min: self.rapid_mm_min,
            accel_mm_s2: self.accel_mm_s2,
        })
    }
}

/// The fit's own options ([`ProbeFitRequest`]).
pub const PROBE_FIT_OPTIONS: &[OptionInfo] = &[
    OptionInfo::new(
        "leave_one_out",
        Kind::Switch,
        "Also predict every placement from a model fitted without it.",
    ),
    OptionInfo::new(
        "monte_carlo",
        Kind::Count,
        "Repeat the whole fit N times with the touches perturbed by the probing noise (Monte Carlo, JCGM 101) and report each parameter's larger standard uncertainty of least squares and Monte Carlo; 0: least squares only.",
    )
    .value("N")
    .default("0"),
];

request! {
    /// A probing identification, as plain values.
    #[allow(missing_docs)]
    pub struct ProbeIdentifyRequest {}
    /// The options of every probing identification ([`ProbeIdentifyRequest`]).
    pub const PROBE_IDENTIFY_OPTIONS, unknown "ranges_mm";

    ranges_mm: Option<[[f64; 2]; 3]> = None, Ranges.value("RANGES").required(),
        "The machine's travel, mm: \"X0:X1,Y0:Y1,Z0:Z1\" (the polynomials live on it).";

    chain: String = "w X' Y' b Z t".into(), Text.value("CHAIN").default("w X' Y' b Z t"),
        "Kinematic chain, workpiece to tool (docs/kinematic.md).";

    order: u64 = 2, Count.value("ORDER").default("2"),
        "Largest Legendre order of the components.";

    model: String = "auto".into(), Choice.value("MODEL").default("auto").choices(&[
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
        "Which model to identify.";

    threshold: f64 = 0.001, Number.value("THRESHOLD").default("0.001"),
        "Relative singular-value threshold for what the measurements cannot see.";
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
    pub monte_carlo: u64,
}

impl super::Request for ProbeFitRequest {
    const OPTIONS: &'static [&'static [OptionInfo]] = &[PROBE_IDENTIFY_OPTIONS, PROBE_FIT_OPTIONS];

    fn set(&mut self, name: &str, v: Value) -> Result<(), OptionError> {
        match name {
            "leave_one_out" => self.leave_one_out = v.bool("leave_one_out")?,
            "monte_carlo" => {
                let n = v.count("monte_carlo")?;
                if n != 0 && n < crate::identify::probe::monte_carlo::MIN_DRAWS as u64 {
                    return Err(OptionError::new(
                        "monte_carlo",
                        format!(
                            "{n} repeats are too few for a standard deviation; give {} or more, or 0 for none",
                            crate::identify::probe::monte_carlo::MIN_DRAWS
                        ),
                    ));
                }
                if n > 10_000 {
                    return Err(OptionError::new(
                        "monte_carlo",
                        format!("{n} repeats: give 10000 or fewer (each is a whole fit)"),
                    ));
                }
                self.monte_carlo = n;
            }
            _ => self.identify.set(name, v)?,
        }
        Ok(())
    }
}

/// The first comment of a probing program made from the artifact file
/// `artifact` (what made it).
pub fn plan_title(artifact: &str) -> String {
    format!(
        "volcomp {} probe plan {artifact}",
        env!("CARGO_PKG_VERSION")
    )
}

/// What `probe plan` says once its program is written to `output`: each
/// placement's touches and time, then the whole plan's (probing at
/// `feeds_mm_min`, fast and slow).
pub fn plan_lines(
    out: &crate::identify::probe::request::PlanOutput,
    job: &ProbePlanRequest,
    feeds_mm_min: (f64, f64),
    output: &std::path::Path,
) -> Vec<String> {
    use crate::identify::probe::program::duration;
    let mut lines: Vec<String> = out
        .plan
        .placement_time_s
        .iter()
        .map(|(name, t)| {
            let n = out
                .plan
                .touches
                .iter()
                .filter(|x| &x.placement == name)
                .count();
            format!("placement {name}: {n} touches, about {}", duration(*t))
        })
        .collect();
    lines.push(format!(
        "wrote {}: {} touches, about {} on the machine (probing at F{} / F{}, rapids {} mm/min, {} mm/s²; operator pauses not counted); the log goes to {}",
        output.display(),
        out.plan.touches.len(),
        duration(out.plan.time_s),
        feeds_mm_min.0,
        feeds_mm_min.1,
        job.rapid_mm_min,
        job.accel_mm_s2,
        job.log_file
    ));
    lines
}

/// The probing fit's HTML report: the run's facts (the model written as
/// `model`, of `order` and `chain`), its `inputs`, the library's sections.
pub fn fit_report_html(
    out: &crate::identify::probe::request::FitOutput,
    ranges: [[f64; 2]; 3],
    (order, chain): (usize, &str),
    model: &std::path::Path,
    command: &str,
    inputs: Vec<crate::report::InputFile>,
) -> String {
    let travel = ranges
        .iter()
        .map(|r| format!("{}:{}", r[0], r[1]))
        .collect::<Vec<_>>()
        .join(",");
    crate::report::Document {
        title: "volcomp probing calibration".into(),
        facts: vec![
            ("volcomp".into(), env!("CARGO_PKG_VERSION").into()),
            ("command".into(), command.to_string()),
            ("date".into(), crate::io::provenance::now_utc()),
            (
                "model".into(),
                format!("{} (order {}, chain {})", model.display(), order, chain),
            ),
            ("travel (mm)".into(), travel),
        ],
        inputs,
        sections: crate::report::probe::sections(out, ranges),
        ..Default::default()
    }
    .to_html()
}

/// What `probe verify` says: what is left over the volume and each
/// identified parameter with its standard uncertainty.
pub fn verify_lines(out: &crate::identify::probe::verify::VerifyOutput) -> Vec<String> {
    use crate::identify::probe::identify::Status;
    let mut lines = vec![format!(
        "what is left: RMS {:.2} µm over the volume (modulo a rigid motion); {} parameter(s) beyond three standard uncertainties{}",
        out.left_rms_um,
        out.significant.len(),
        if out.significant.is_empty() { String::new() } else { format!(": {}", out.significant.join(", ")) }
    )];
    for p in &out.identified.params {
        if let Status::Identified(e) = p.status {
            lines.push(format!(
                "  {:<8} {:>9.3} ± {:.3} {}",
                p.name,
                e.value,
                e.sigma,
                if p.unit == "um" { "µm" } else { "µrad" }
            ));
        }
    }
    lines
}

/// What `probe example` says once the campaign is written into `dir`.
pub fn example_lines(dir: &std::path::Path) -> Vec<String> {
    let d = dir.display();
    vec![
        format!("wrote the probing example into {d} (a synthetic machine, 0.4 µm probe noise); try:"),
        format!("  volcomp probe plan {d}/plate.toml --setup {d}/setup.toml --probe-tool 9 --tip-diameter-mm 2 -o plate.ngc"),
        format!("  volcomp probe fit --artifact {d}/reference.toml --artifact {d}/plate.toml --artifact {d}/gauge.toml \\\n      --log {d}/reference.log --log {d}/plate.log --log {d}/gauge.log --ranges-mm 0:600,0:400,0:300 -o model.toml"),
    ]
}

#[cfg(test)]
mod tests {
    use super::super::Request;
    use super::*;

    #[test]
    fn the_default_plan_is_the_plan_defaults_with_the_tip_given() {
        let mut r = ProbePlanRequest::default();
        assert_eq!(
            r.options().unwrap_err().to_string(),
            "tip_diameter_mm is required"
        );
        r.set_named("tip_diameter_mm", Value::Number(2.0)).unwrap();
        assert_eq!(r.options().unwrap(), PlanOptions::default());
        r.set_named("work_system", Value::Text("g59.3".into()))
            .unwrap();
        r.set_named("sphere_touches", Value::Text("9".into()))
            .unwrap();
        let o = r.options().unwrap();
        assert_eq!((o.work_system, o.spheres), (8, SpherePattern::Nine));
        r.set_named("work_system", Value::Text("G60".into()))
            .unwrap();
        assert_eq!(
            r.options().unwrap_err().to_string(),
            "work_system `G60`: write G54 … G59, G59.1, G59.2 or G59.3"
        );
    }

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
        assert!(r
            .set_named("monte_carlo", Value::Count(5))
            .unwrap_err()
            .to_string()
            .contains("give 10 or more, or 0 for none"));
        r.set_named("monte_carlo", Value::Count(20)).unwrap();
        assert_eq!(r.monte_carlo, 20);
        r.set_named("threshold", Value::Number(2.0)).unwrap();
        assert!(r
            .identify
            .options()
            .unwrap_err()
            .to_string()
            .contains("between 0 and 1"));
    }
}

/// A probing plan in figures (Python's `probe_plan` dict): its touches and
/// time on the machine, then each placement's.
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[derive(Debug, Clone, PartialEq)]
pub struct PlanFigures {
    /// Touches of the whole plan.
    pub touches: usize,
    /// Time on the machine (s): probing moves and rapids, no operator pause.
    pub time_s: f64,
    /// Each placement: `name`, `touches`, `time_s`.
    pub placements: Vec<PlacementFigures>,
}

/// One placement of a [`PlanFigures`].
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[derive(Debug, Clone, PartialEq)]
pub struct PlacementFigures {
    /// Its name.
    pub name: String,
    /// Its touches.
    pub touches: usize,
    /// Its time on the machine (s).
    pub time_s: f64,
}

impl PlanFigures {
    /// The figures of `plan`.
    pub fn of(plan: &crate::identify::probe::plan::Plan) -> Self {
        let placements = plan
            .placement_time_s
            .iter()
            .map(|(name, t)| PlacementFigures {
                name: name.clone(),
                touches: plan.touches.iter().filter(|x| &x.placement == name).count(),
                time_s: *t,
            })
            .collect();
        PlanFigures {
            touches: plan.touches.len(),
            time_s: plan.time_s,
            placements,
        }
    }
}

/// A value and its standard uncertainty.
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValueStd {
    /// The value.
    pub value: f64,
    /// Its standard uncertainty (same unit).
    pub std: f64,
}

/// One parameter of a [`FitFigures`].
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[derive(Debug, Clone, PartialEq)]
pub struct ParamFigures {
    /// Its name (`EXX.P1`, `S_xy`, …).
    pub name: String,
    /// `um` or `urad`.
    pub unit: &'static str,
    /// `identified`, `not seen` or `not in model`.
    pub status: &'static str,
    /// Its value, when identified.
    pub value: Option<f64>,
    /// Its standard uncertainty, when identified.
    pub std: Option<f64>,
}

/// One placement left out of the fit and predicted (µm RMS before and after).
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[derive(Debug, Clone, PartialEq)]
pub struct HeldOutFigures {
    /// Artifact name.
    pub artifact: String,
    /// Placement name.
    pub placement: String,
    /// RMS deviation of its sphere centres, uncorrected (µm).
    pub before_um: f64,
    /// The same corrected by the model fitted without it (µm).
    pub after_um: f64,
}

/// A probing fit in figures (Python's `probe_fit` report dict).
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[derive(Debug, Clone, PartialEq)]
pub struct FitFigures {
    /// Every parameter of the model.
    pub params: Vec<ParamFigures>,
    /// Each axis' reversal (µm), where the touches saw it.
    pub reversal_um: Vec<Option<ValueStd>>,
    /// The fit's a-posteriori standard deviation of a touch (µm), where
    /// the fit has more touches than parameters.
    pub sigma0_um: Option<f64>,
    /// What the identification noted.
    pub notes: Vec<String>,
    /// What the fit warned about.
    pub warnings: Vec<String>,
    /// Placements left out one at a time (with leave-one-out only).
    pub held_out: Vec<HeldOutFigures>,
    /// The lines `probe fit` prints.
    pub summary: Vec<String>,
}

impl FitFigures {
    /// The figures of `out`, fitted over the axis ranges `ranges_mm`.
    pub fn of(out: &crate::identify::probe::request::FitOutput, ranges_mm: [[f64; 2]; 3]) -> Self {
        use crate::identify::probe::identify::Status;
        let std = |e: &crate::identify::probe::fit::Estimate| ValueStd {
            value: e.value,
            std: e.sigma,
        };
        let params = out
            .identified
            .params
            .iter()
            .map(|p| {
                let (status, e) = match p.status {
                    Status::Identified(e) => ("identified", Some(std(&e))),
                    Status::NotSeen => ("not seen", None),
                    Status::NotInModel => ("not in model", None),
                };
                ParamFigures {
                    name: p.name.clone(),
                    unit: p.unit,
                    status,
                    value: e.map(|e| e.value),
                    std: e.map(|e| e.std),
                }
            })
            .collect();
        let held_out = out
            .held_out
            .iter()
            .map(|h| HeldOutFigures {
                artifact: h.artifact.clone(),
                placement: h.placement.clone(),
                before_um: h.before_um,
                after_um: h.after_um,
            })
            .collect();
        FitFigures {
            params,
            reversal_um: out
                .reversal_um
                .iter()
                .map(|e| e.as_ref().map(std))
                .collect(),
            sigma0_um: out.identified.ident.sigma0_um,
            notes: out.identified.notes.clone(),
            warnings: out.fitted.warnings.clone(),
            held_out,
            summary: out.summary(ranges_mm),
        }
    }
}
