//! The ballbar jobs as plain values, checked here (docs/architecture.md,
//! "How a request flows"): `predict` (a map → the trace, its figures, the
//! test's program), `fit` (a trace file → figures and causes), `map`
//! (traces in three planes → the quick model).

use crate::ballbar::fit::{fit, FitOptions, TraceFit};
use crate::ballbar::predict::{predict, predict_program, TestCircle};
use crate::ballbar::quick_map::{quick_model, QuickModel};
use crate::ballbar::trace as ballbar_trace;
use crate::ballbar::{figures, BallbarError, Figures, Plane, Sense, Trace};
use crate::request::option::Input;
use crate::Error;
use std::path::Path;
use volcomp_gcode::Vec3;

const PLANES: &[(&str, &str)] = &[
    ("XY", "X and Y (G17)"),
    ("YZ", "Y and Z (G19)"),
    ("ZX", "Z and X (G18)"),
];

request! {
    /// A prediction of the circular test, as plain values.
    pub struct BallbarPredictRequest {}
    /// The options of [`BallbarPredictRequest`].
    pub const BALLBAR_PREDICT_OPTIONS, unknown "plane";

    /// The pivot (mm).
    centre_mm: Option<[f64; 3]> = None, Triple.value("X,Y,Z").required(),
        "The ballbar's pivot: the circle's centre in machine coordinates (mm, X,Y,Z).";

    /// `XY`, `YZ` or `ZX`.
    plane: String = "XY".into(), Choice.value("PLANE").default("XY").choices(PLANES),
        "The test plane.";

    /// The radius (mm).
    radius_mm: f64 = TestCircle::default().radius_mm, Number.value("MM").default("100"),
        "The ballbar's nominal length: the circle's radius (mm).";

    /// The feed (mm/min).
    feed_mm_per_min: f64 = TestCircle::default().feed_mm_per_min, Number.value("F").default("1000"),
        "The programmed feed (mm/min).";

    /// `both`, `ccw` or `cw`.
    direction: String = "both".into(), Choice.value("DIR").default("both").choices(&[
        ("both", "Counter-clockwise (G3), then clockwise (G2)"),
        ("ccw", "Counter-clockwise only (G3)"),
        ("cw", "Clockwise only (G2)"),
    ]),
        "The runs: counter-clockwise then clockwise (`both`), or one of them.";

    /// The data arc's start (degrees).
    start_deg: f64 = TestCircle::default().start_deg, Number.value("DEG").default("0"),
        "Where the data arc starts: degrees from the plane's first axis toward its second.";

    /// The feed-in and feed-out arcs (degrees).
    overshoot_deg: f64 = TestCircle::default().overshoot_deg, Number.value("DEG").default("180"),
        "The feed-in and feed-out arcs before and after the data arc (degrees).";

    /// The sample step (degrees).
    step_deg: f64 = TestCircle::default().step_deg, Number.value("DEG").default("0.1"),
        "The angle between samples (degrees; 360 a whole multiple of it).";

    /// A program run instead of the test's own.
    program: Option<Input> = None, Input.value("PROGRAM"),
        "The program the machine runs instead of the test's own (the test's program after `volcomp compensate`): the trace after compensation.";

    /// Clamp the map.
    clamp: bool = false, Switch,
        "Clamp positions outside the map's range to its end instead of refusing.";
}

/// A predicted test: the trace, its figures, the test's program.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Prediction {
    /// The trace.
    pub trace: Trace,
    /// Its ISO 230-4 figures.
    pub figures: Figures,
    /// The program that runs the test (LinuxCNC, mm).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub program: String,
}

fn plane_of(text: &str, option: &str) -> Result<Plane, BallbarError> {
    Plane::parse(text).ok_or_else(|| {
        BallbarError::new(format!("{{{option}}} must be XY, YZ or ZX; got `{text}`"))
    })
}

impl BallbarPredictRequest {
    /// The test, every value checked.
    pub fn test(&self) -> Result<TestCircle, BallbarError> {
        let centre = self.centre_mm.ok_or_else(|| {
            BallbarError::new("{centre_mm} is required: name the pivot's machine coordinates")
        })?;
        let senses = match self.direction.to_ascii_lowercase().as_str() {
            "both" => vec![Sense::Ccw, Sense::Cw],
            "ccw" => vec![Sense::Ccw],
            "cw" => vec![Sense::Cw],
            d => {
                return Err(BallbarError::new(format!(
                    "{{direction}} must be both, ccw or cw; got `{d}`"
                )))
            }
        };
        let t = TestCircle {
            plane: plane_of(&self.plane, "plane")?,
            centre_mm: Vec3::new(centre[0], centre[1], centre[2]),
            radius_mm: self.radius_mm,
            feed_mm_per_min: self.feed_mm_per_min,
            start_deg: self.start_deg,
            overshoot_deg: self.overshoot_deg,
            step_deg: self.step_deg,
            senses,
        };
        t.check()?;
        Ok(t)
    }

    /// The test's program (LinuxCNC dialect).
    pub fn test_program(&self) -> Result<String, Error> {
        Ok(crate::ballbar::program::program(&self.test()?)?)
    }

    /// Predicts the test on the machine of the error map `map`.
    pub fn run(&self, map: &Path) -> Result<Prediction, Error> {
        let test = self.test()?;
        let model =
            crate::io::load_model(map, &crate::io::LoadOptions { clamp: self.clamp })?.into_model();
        let trace = match &self.program {
            None => predict(model.as_ref(), &test)?,
            Some(p) => predict_program(
                model.as_ref(),
                &test,
                p.reader()?,
                &p.name(),
                &crate::compensate::MachineSetup::default(),
            )?,
        };
        let figures = figures(&trace)
            .ok_or_else(|| BallbarError::new("the trace's least-squares circle is undetermined"))?;
        Ok(Prediction {
            trace,
            figures,
            program: crate::ballbar::program::program(&test)?,
        })
    }
}

request! {
    /// A fit of a trace file, as plain values.
    pub struct BallbarFitRequest {}
    /// The options of [`BallbarFitRequest`] (the set-up options fill what a
    /// trace file does not say).
    pub const BALLBAR_FIT_OPTIONS, unknown "pitch_mm";

    /// Pitches of X, Y, Z (0: none).
    pitch_mm: Option<[f64; 3]> = None, Triple.value("X,Y,Z"),
        "Lead-screw pitch of X, Y, Z for the cyclic error (mm; 0: none).";

    /// A spike's decay angle (degrees).
    spike_width_deg: f64 = FitOptions::default().spike_width_deg, Number.value("DEG").default("2"),
        "How fast a reversal spike decays: its angle of decay to 1/e (degrees).";

    /// The plane, when the file does not say it.
    trace_plane: Option<String> = None, Choice.value("PLANE").choices(PLANES),
        "The test plane, when the trace file does not say it (`# plane = XY`).";

    /// The radius, when the file does not say it.
    trace_radius_mm: Option<f64> = None, Number.value("MM"),
        "The ballbar's nominal length, when the trace file does not say it (`# radius_mm = …`).";

    /// The pivot, when the file does not say it.
    trace_centre_mm: Option<[f64; 3]> = None, Triple.value("X,Y,Z"),
        "The pivot in machine coordinates, when the trace file does not say it (`# centre_mm = …`; only cyclic errors need it).";

    /// The feed, when the file does not say it.
    trace_feed_mm_per_min: Option<f64> = None, Number.value("F"),
        "The test's feed, when the trace file does not say it (`# feed_mm_per_min = …`; only the servo mismatch needs it).";
}

impl BallbarFitRequest {
    /// The fit's options, checked.
    pub fn options(&self) -> Result<FitOptions, BallbarError> {
        let pitch_mm = match self.pitch_mm {
            None => [None; 3],
            Some(p) => {
                let mut out = [None; 3];
                for (a, v) in p.iter().enumerate() {
                    if !(v.is_finite() && *v >= 0.0) {
                        return Err(BallbarError::new(format!(
                            "{{pitch_mm}} must be pitches ≥ 0 mm (0: no cyclic error); got {v} for {}",
                            ["X", "Y", "Z"][a]
                        )));
                    }
                    out[a] = (*v > 0.0).then_some(*v);
                }
                out
            }
        };
        if !(self.spike_width_deg.is_finite()
            && self.spike_width_deg > 0.0
            && self.spike_width_deg <= 90.0)
        {
            return Err(BallbarError::new(format!(
                "{{spike_width_deg}} must satisfy 0 < width ≤ 90°; got {}",
                self.spike_width_deg
            )));
        }
        Ok(FitOptions {
            pitch_mm,
            spike_width_deg: self.spike_width_deg,
        })
    }

    /// The trace in the file text `text` (named `name`), its set-up
    /// completed by the options.
    pub fn trace(&self, text: &str, name: &str) -> Result<Trace, Error> {
        let f = ballbar_trace::read(text, name)?;
        let missing = |what: &str, option: &str| {
            BallbarError::new(format!(
                "{name}: the trace does not say its {what}: add a `# {what} = …` line or give {{{option}}}"
            ))
        };
        let plane = match (&f.setup.plane, &self.trace_plane) {
            (Some(p), _) => *p,
            (None, Some(t)) => plane_of(t, "trace_plane")?,
            (None, None) => return Err(missing("plane", "trace_plane").into()),
        };
        let radius_mm = f
            .setup
            .radius_mm
            .or(self.trace_radius_mm)
            .ok_or_else(|| missing("radius_mm", "trace_radius_mm"))?;
        if !(radius_mm.is_finite() && radius_mm > 0.0) {
            return Err(BallbarError::new(format!(
                "{{trace_radius_mm}} must be > 0 mm; got {radius_mm}"
            ))
            .into());
        }
        Ok(Trace {
            plane,
            radius_mm,
            centre_mm: f
                .setup
                .centre_mm
                .or(self.trace_centre_mm)
                .unwrap_or([0.0; 3]),
            feed_mm_per_min: f
                .setup
                .feed_mm_per_min
                .or(self.trace_feed_mm_per_min)
                .unwrap_or(0.0),
            runs: f.runs,
        })
    }

    /// The trace in the file text `text` and its figures (a trace drawn
    /// beside another in a report).
    pub fn figured(&self, text: &str, name: &str) -> Result<(Trace, Figures), Error> {
        let trace = self.trace(text, name)?;
        let f = figures(&trace).ok_or_else(|| {
            BallbarError::new(format!(
                "{name}: the trace's least-squares circle is undetermined"
            ))
        })?;
        Ok((trace, f))
    }

    /// Fits the trace file `text` (named `name`).
    pub fn run(&self, text: &str, name: &str) -> Result<TraceFit, Error> {
        let options = self.options()?;
        let trace = self.trace(text, name)?;
        if options.pitch_mm.iter().any(Option::is_some)
            && self.trace_centre_mm.is_none()
            && trace.centre_mm == [0.0; 3]
        {
            // A cyclic error is a function of the axis position: the pivot must be known.
            let f = ballbar_trace::read(text, name)?;
            if f.setup.centre_mm.is_none() {
                return Err(BallbarError::new(format!(
                    "{name}: a cyclic error needs the pivot's position: add `# centre_mm = x, y, z` or give {{trace_centre_mm}}"
                ))
                .into());
            }
        }
        if trace.runs.len() == 2 && trace.feed_mm_per_min <= 0.0 {
            return Err(BallbarError::new(format!(
                "{name}: the servo mismatch needs the feed: add `# feed_mm_per_min = …` or give {{trace_feed_mm_per_min}}"
            ))
            .into());
        }
        Ok(fit(&trace, &options)?)
    }
}

request! {
    /// The quick model from traces in three planes, as plain values.
    pub struct BallbarMapRequest {
        /// How each trace is fitted.
        pub fit: BallbarFitRequest,
    }
    /// The options of [`BallbarMapRequest`] beside the fit's.
    pub const BALLBAR_MAP_OPTIONS;
    options [BALLBAR_MAP_OPTIONS, BALLBAR_FIT_OPTIONS], unknown "range_mm";

    /// The map's range per axis (mm).
    range_mm: Option<[[f64; 2]; 3]> = None, Ranges.value("RANGES").required(),
        "The quick map's range per axis (mm): X0:X1,Y0:Y1,Z0:Z1, the volume programs will be compensated in.";
}

/// A quick model: its values, the fit of each trace, the map file's text.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct QuickMap {
    /// The values.
    pub model: QuickModel,
    /// Each trace's name and fit.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub fits: Vec<(String, TraceFit)>,
    /// The axis-table CSV.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub csv: String,
}

impl BallbarMapRequest {
    /// The quick model from the trace files `(text, name)`, one per plane.
    pub fn run(&self, traces: &[(String, String)]) -> Result<QuickMap, Error> {
        let range = self.range_mm.ok_or_else(|| {
            BallbarError::new("{range_mm} is required: the volume the map covers")
        })?;
        let options = self.fit.options()?;
        let mut fits = Vec::new();
        let mut planes = Vec::new();
        for (text, name) in traces {
            let trace = self.fit.trace(text, name)?;
            planes.push((trace.plane, trace.radius_mm));
            fits.push((name.clone(), self.fit.run(text, name)?));
        }
        let refs: Vec<(Plane, f64, &TraceFit)> = planes
            .iter()
            .zip(&fits)
            .map(|((p, r), (_, f))| (*p, *r, f))
            .collect();
        let model = quick_model(&refs, options.pitch_mm)?;
        let map = model.map(range)?;
        let mut csv = String::from(
            "# volcomp ballbar quick map (docs/ballbar.md): scale, squareness, backlash, lateral play",
        );
        if options.pitch_mm.iter().any(Option::is_some) {
            csv.push_str(", cyclic errors");
        }
        csv.push('\n');
        for (_, name) in traces {
            csv += &format!("# from {}\n", name.replace(['\n', '\r'], " "));
        }
        csv += &map.to_csv();
        Ok(QuickMap { model, fits, csv })
    }
}

/// The HTML report of `trace` (named `name`, with its figures and, for a
/// fit, its causes), the trace file `before` drawn dashed beside it.
pub fn report_html(
    title: &str,
    name: &str,
    trace: &Trace,
    figures: &Figures,
    before: Option<&Input>,
    fit: Option<&TraceFit>,
) -> Result<String, Error> {
    let before = match before {
        Some(b) => {
            let bytes = b.bytes()?;
            let text = crate::io::table::utf8(&bytes, &b.name())?;
            Some(BallbarFitRequest::default().figured(text, &b.name())?)
        }
        None => None,
    };
    let mut traces = vec![(name, trace, figures)];
    traces.extend(before.as_ref().map(|(t, f)| ("before", t, f)));
    let facts = vec![("trace".into(), name.to_string())];
    Ok(crate::ballbar::report::document(
        title,
        facts,
        crate::ballbar::report::sections(&traces, fit),
    )
    .to_html())
}
