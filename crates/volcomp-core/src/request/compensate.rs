//! A compensation of a part program, as plain values: the options of
//! [`CompensateOptions`] with their checks, the machine, the limits, and
//! the provenance header of the program it writes.

use super::machine::{Machine, MachineRequest, MACHINE_OPTIONS};
use super::option::{OptionError, Spelling};
use super::positive;
use crate::compensate::solve::Method;
use crate::compensate::{
    file_name, header_for_map, CompensateOptions, Compensator, DirectionPolicy, Segmentation,
    DEFAULT_CONTOUR_TOLERANCE_UM, DEFAULT_EXACT_CONTOUR_TOLERANCE_UM, DEFAULT_MAX_RESIDUAL_UM,
    DEFAULT_MIN_SEGMENT_LENGTH_MM,
};
use crate::io::provenance::{sha256_hex, ProgramHeader};
use crate::io::LoadedModel;
use crate::limits::{
    MAX_CHORD_TOLERANCE_MM, MAX_ILC_ITERATIONS, MAX_SEGMENTS_PER_MOVE, MIN_CHORD_TOLERANCE_MM,
    MIN_CONTOUR_TOLERANCE_UM, MIN_SEGMENT_LENGTH_MM,
};
use crate::model::ErrorModel;
use crate::Error;
use std::path::Path;

/// Default largest output of a compensation (bytes): 256 MiB.
pub const DEFAULT_MAX_OUTPUT_BYTES: u64 = 256 << 20;

/// The ILC gain when none is given.
pub const DEFAULT_ILC_GAIN: f64 = 0.5;

/// The ILC iteration limit when none is given.
pub const DEFAULT_ILC_ITERATIONS: u64 = 20;

request! {
    /// A compensation, as plain values (each field is the option of the same
    /// name in [`COMPENSATE_OPTIONS`] or [`MACHINE_OPTIONS`]).
    pub struct CompensateRequest {
        /// The machine.
        pub machine: MachineRequest,
    }
    /// The options of [`CompensateRequest`] beside the machine's.
    pub const COMPENSATE_OPTIONS;
    options [MACHINE_OPTIONS, COMPENSATE_OPTIONS], unknown "method";

    /// `exact`, `ilc`, `direct` or `pitch`.
    method: String = "exact".into(), Choice.default("exact").value("METHOD").choices(&[
        ("exact", "Solve q + e(q, s) = t to a tolerance (default)"),
        ("ilc", "Iterative learning control, q ← q + γ·(t − actual(q))"),
        ("direct", "One step, q = t − e(t, s)"),
        ("pitch", "Exact, but only with the positioning errors E_XX, E_YY, E_ZZ"),
    ]),
        "Compensation method.";

    /// Fixed segment length (mm).
    segment_length_mm: Option<f64> = None, Number.flag("segment-length").value("MM"),
        "Split feed moves into segments of at most this length (mm) instead of adaptively.";

    /// Fixed number of segments per move.
    segments: Option<u64> = None, Count.value("N"),
        "Split every feed move into this many segments (as the papers do).";

    /// No splitting.
    no_split: bool = false, Switch,
        "Do not split feed moves (only arcs are linearised).";

    /// Adaptive splitting's contour tolerance (µm).
    contour_tolerance_um: Option<f64> = None, Number.value("UM"),
        "Contour tolerance (µm, default 0.1, and 0.05 under G61/G61.1 unless given): feed moves are split adaptively, at the map's table points and where the map bends the path by more than this (the default segmentation).";

    /// Adaptive splitting's shortest segment (mm); `None`: the default.
    min_segment_length_mm: Option<f64> = None,
        Number.flag("min-segment-length").value("MM").default("0.01"),
        "Shortest segment of adaptive splitting (mm).";

    /// ILC gain; an option of ILC only.
    gain: f64 = DEFAULT_ILC_GAIN, Number.value("GAIN").default("0.5"),
        "ILC gain γ, 0 < γ ≤ 1.";

    /// ILC iteration limit; an option of ILC only.
    max_iterations: u64 = DEFAULT_ILC_ITERATIONS, Count.value("N").default("20"),
        "ILC iteration limit (at least 1).";

    /// Largest residual accepted (µm).
    max_residual_um: f64 = DEFAULT_MAX_RESIDUAL_UM, Number.value("UM").default("1"),
        "Largest model residual accepted at a point (µm) with the exact and ILC solvers; a point that is not reached is an error at its line.";

    /// Largest output (bytes); `None`: no limit.
    max_output_bytes: Option<u64> = Some(DEFAULT_MAX_OUTPUT_BYTES),
        Size.flag("max-output-size").value("BYTES").default("256M"),
        "Largest output accepted, in bytes (suffixes K, M, G: powers of 1024), or `none`; a bigger output is refused and nothing is written.";

    /// Chord tolerance (mm).
    chord_tolerance_mm: f64 = 1e-4, Number.flag("chord-tolerance").value("MM").default("0.0001"),
        "Chord tolerance for linearising arcs and splines (mm).";

    /// Arcs as G1 lines.
    arcs_as_lines: bool = false, Switch,
        "Write arcs as G1 lines within {chord_tolerance_mm} instead of as compensated arcs (pieces of the original arc).";

    /// Written decimals.
    decimals: Option<u64> = None, Count.value("DECIMALS"),
        "Decimal places of written coordinates (default 5 in mm, 6 in inch).";

    /// Largest correction accepted (mm).
    max_correction_mm: f64 = 0.1, Number.flag("max-correction").value("MM").default("0.1"),
        "Largest correction accepted (mm); larger ones mean a wrong map unit.";

    /// Tables chosen by the nominal direction.
    nominal_directions: bool = false, Switch,
        "Choose error tables by the nominal move direction, as the papers do, instead of the direction of the compensated command (for comparison).";

    /// Take-up moves at reversals.
    take_up: bool = true, Switch.default("true"),
        "Do not insert backlash take-up moves at reversals.";

    /// Every take-up a block of its own.
    separate_take_ups: bool = false, Switch,
        "Write every take-up as a block of its own, even where the move that reverses can take it up within the contour tolerance (the default folds those, so the controller does not stop for them).";

    /// What a folded take-up may leave (µm).
    take_up_tolerance_um: Option<f64> = None, Number.value("UM"),
        "The contour error a take-up folded into its move may leave (µm), for the whole program instead of the program's path-control mode (default: G61/G61.1 take up exactly, G64 P p folds within p, G64 folds every take-up). Larger folds more take-ups, so the controller stops less, at the price of up to that error at reversals (docs/compensation.md, \"Reversals by path-control mode\").";

    /// See [`CompensateOptions::drill_tolerance_mm`] (µm).
    drill_tolerance_um: f64 = crate::compensate::DEFAULT_DRILL_TOLERANCE_UM,
        Number.value("UM").default("5"),
        "The error a drilling cycle (G73, G81, G82, G83) written as a cycle may leave along its stroke (µm): the map's drift across the stroke and the peck levels inside the hole. The hole's position at the bottom and its depth are compensated exactly either way; a hole past it is written as its moves. Never below the contour tolerance; boring cycles (G85, G86, G89) keep the contour tolerance (docs/compensation.md, \"Canned cycles\").";

    /// `(volcomp Ln)` comments.
    trace: bool = true, Switch.default("true"),
        "Do not tag inserted lines with `(volcomp Ln)` comments.";

    /// Compensate a compensated program again.
    allow_recompensate: bool = false, Switch,
        "Compensate a program that volcomp compensated already (its header or trace comments say so); the corrections are then applied twice.";

    /// Write feed moves on an axis never set without compensation.
    allow_uncompensated_axes: bool = false, Switch,
        "Write feed moves made while an axis has never been set (a 2-D program without Z words, and no `start` in the set-up) without compensation, with a warning and a header that count them, instead of refusing the program.";
}

impl CompensateRequest {
    /// The solver, checked.
    fn method(&self) -> Result<Method, OptionError> {
        let info = <Self as super::Request>::info("method").expect("method is an option");
        let method = info
            .choice(&self.method)
            .map_err(|p| OptionError::new("method", p))?;
        if method != "ilc" {
            // The gain and the iteration limit are ILC's: another value than
            // the default with another method would be silently ignored.
            for (given, name) in [
                (self.gain.to_bits() != DEFAULT_ILC_GAIN.to_bits(), "gain"),
                (
                    self.max_iterations != DEFAULT_ILC_ITERATIONS,
                    "max_iterations",
                ),
            ] {
                if given {
                    return Err(OptionError::new(
                        name,
                        format!("is an option of {{method}} ilc: it means nothing with method {method}; leave it out, or choose ilc"),
                    ));
                }
            }
        }
        match method {
            "direct" => Ok(Method::Direct),
            "pitch" => Ok(Method::Pitch),
            "ilc" => {
                let gain = self.gain;
                if !(gain > 0.0 && gain <= 1.0) {
                    return Err(OptionError::new(
                        "gain",
                        format!("must satisfy 0 < γ ≤ 1; got {gain}"),
                    ));
                }
                let n = self.max_iterations;
                if n == 0 || n > MAX_ILC_ITERATIONS {
                    return Err(OptionError::new(
                        "max_iterations",
                        format!(
                            "must be 1 … {MAX_ILC_ITERATIONS} (ILC needs one step to move a point; past {MAX_ILC_ITERATIONS} steps a point that has not converged will not: raise {{gain}} instead); got {n}"
                        ),
                    ));
                }
                Ok(Method::Ilc {
                    gain,
                    max_iterations: n as u32,
                })
            }
            _ => Ok(Method::Exact),
        }
    }

    /// The splitting of feed moves, checked: at most one way is chosen.
    fn segmentation(&self) -> Result<Segmentation, OptionError> {
        let chosen: Vec<&'static str> = [
            (self.no_split, "no_split"),
            (self.segments.is_some(), "segments"),
            (self.segment_length_mm.is_some(), "segment_length_mm"),
            (self.contour_tolerance_um.is_some(), "contour_tolerance_um"),
        ]
        .into_iter()
        .filter_map(|(given, name)| given.then_some(name))
        .collect();
        if let [first, second, ..] = chosen[..] {
            return Err(OptionError::new(
                first,
                format!(
                    "cannot be given with {{{second}}}: choose one way of splitting feed moves"
                ),
            ));
        }
        let fixed = self.no_split || self.segments.is_some() || self.segment_length_mm.is_some();
        if let (true, Some(_)) = (fixed, self.min_segment_length_mm) {
            return Err(OptionError::new(
                "min_segment_length_mm",
                format!(
                    "is for adaptive splitting; it cannot be given with {{{}}}",
                    chosen[0]
                ),
            ));
        }
        if self.no_split {
            return Ok(Segmentation::Off);
        }
        if let Some(n) = self.segments {
            if n == 0 || n > MAX_SEGMENTS_PER_MOVE {
                return Err(OptionError::new(
                    "segments",
                    format!("must be 1 … {MAX_SEGMENTS_PER_MOVE} segments per move; got {n}"),
                ));
            }
            return Ok(Segmentation::Count(n as u32));
        }
        if let Some(l) = self.segment_length_mm {
            if !(l.is_finite() && l >= MIN_SEGMENT_LENGTH_MM) {
                return Err(OptionError::new(
                    "segment_length_mm",
                    format!("must be a length of at least {MIN_SEGMENT_LENGTH_MM} mm (1 µm: shorter segments only multiply the work); got {l}"),
                ));
            }
            return Ok(Segmentation::MaxLength(l));
        }
        let t = self
            .contour_tolerance_um
            .unwrap_or(DEFAULT_CONTOUR_TOLERANCE_UM);
        let min = self
            .min_segment_length_mm
            .unwrap_or(DEFAULT_MIN_SEGMENT_LENGTH_MM);
        if !(t.is_finite() && t >= MIN_CONTOUR_TOLERANCE_UM) {
            return Err(OptionError::new(
                "contour_tolerance_um",
                format!("must be at least {MIN_CONTOUR_TOLERANCE_UM} µm (1 nm); got {t}"),
            ));
        }
        if !(min.is_finite() && min >= MIN_SEGMENT_LENGTH_MM) {
            return Err(OptionError::new(
                "min_segment_length_mm",
                format!(
                    "must be a length of at least {MIN_SEGMENT_LENGTH_MM} mm (1 µm); got {min}"
                ),
            ));
        }
        Ok(Segmentation::Adaptive {
            tolerance_mm: t * 1e-3,
            min_length_mm: min,
        })
    }

    /// The take-up options, checked.
    fn take_ups(&self) -> Result<(), OptionError> {
        if self.separate_take_ups && !self.take_up {
            return Err(OptionError::new(
                "separate_take_ups",
                "cannot be given with {take_up}: there are no take-ups to write",
            ));
        }
        positive(
            "drill_tolerance_um",
            self.drill_tolerance_um,
            "a positive number of µm",
        )?;
        if let Some(t) = self.take_up_tolerance_um {
            if !self.take_up || self.separate_take_ups {
                let other = if self.take_up {
                    "separate_take_ups"
                } else {
                    "take_up"
                };
                return Err(OptionError::new(
                    "take_up_tolerance_um",
                    format!("cannot be given with {{{other}}}: no take-up is folded"),
                ));
            }
            positive("take_up_tolerance_um", t, "a positive number of µm")?;
        }
        Ok(())
    }

    /// Refuses a method that can correct nothing with the map's controller
    /// setting: `pitch` corrects only the positioning errors, and with
    /// `controller_compensates = positioning` the controller corrects those
    /// already, so the program would come back unchanged with a success.
    pub fn check_map(&self, map: &super::MapRequest) -> Result<(), OptionError> {
        if self.method == "pitch" && map.controller_compensates.is_some() {
            return Err(OptionError::new(
                "method",
                "pitch corrects only the positioning errors, which the controller compensates already ({controller_compensates}): it would correct nothing; use method exact to correct the rest of the map",
            ));
        }
        Ok(())
    }

    /// The library's compensation options, every value checked.
    pub fn options(&self) -> Result<CompensateOptions, OptionError> {
        let method = self.method()?;
        let segmentation = self.segmentation()?;
        if !(self.chord_tolerance_mm.is_finite()
            && (MIN_CHORD_TOLERANCE_MM..=MAX_CHORD_TOLERANCE_MM).contains(&self.chord_tolerance_mm))
        {
            return Err(OptionError::new(
                "chord_tolerance_mm",
                format!(
                    "must be a length of {MIN_CHORD_TOLERANCE_MM} mm (1 nm) to {MAX_CHORD_TOLERANCE_MM} mm; got {}",
                    self.chord_tolerance_mm
                ),
            ));
        }
        positive(
            "max_correction_mm",
            self.max_correction_mm,
            "a positive length in mm",
        )?;
        positive(
            "max_residual_um",
            self.max_residual_um,
            "a positive number of µm",
        )?;
        self.take_ups()?;
        let decimals = match self.decimals {
            None => None,
            Some(d @ 1..=9) => Some(d as u8),
            Some(_) => return Err(OptionError::new("decimals", "must be 1 … 9")),
        };
        Ok(CompensateOptions {
            method,
            segmentation,
            chord_tolerance_mm: self.chord_tolerance_mm,
            arcs_as_arcs: !self.arcs_as_lines,
            decimals,
            max_correction_mm: self.max_correction_mm,
            directions: if self.nominal_directions {
                DirectionPolicy::Nominal
            } else {
                DirectionPolicy::Commanded
            },
            take_up: self.take_up,
            fold_take_ups: !self.separate_take_ups,
            take_up_tolerance_mm: self.take_up_tolerance_um.map(|t| t * 1e-3),
            // A contour tolerance given holds in every path-control mode.
            exact_contour_tolerance_mm: match self.contour_tolerance_um {
                Some(_) => None,
                None => Some(DEFAULT_EXACT_CONTOUR_TOLERANCE_UM * 1e-3),
            },
            drill_tolerance_mm: self.drill_tolerance_um * 1e-3,
            planner: Default::default(),
            trace_comments: self.trace,
            // Direct and pitch do not aim at the full model's target: their
            // residual is the method's own error, checked for finiteness only.
            max_residual_um: matches!(method, Method::Exact | Method::Ilc { .. })
                .then_some(self.max_residual_um),
            allow_uncompensated_axes: self.allow_uncompensated_axes,
        })
    }

    /// The compensation ready to run on `machine` (from
    /// [`MachineRequest::machine`]) with the model from `model`, its header
    /// dated `date_utc` ([`crate::io::provenance::now_utc`]); `spelling`
    /// names the work-offset option in the header as the front end does.
    pub fn prepare(
        &self,
        machine: Machine,
        model: ModelSource<'_>,
        date_utc: String,
        spelling: &dyn Spelling,
    ) -> Result<Compensation, Error> {
        let options = self.options()?;
        let mut machine = machine;
        machine.setup = machine.setup.with_spline_tolerance(self.chord_tolerance_mm);
        let mut header = model.header(&machine, &options, date_utc)?;
        if machine.work_offset_given {
            header.work_offset_note =
                Some(format!("G54 from {}", spelling.option("work_offset_mm")));
        }
        Ok(Compensation {
            machine,
            options,
            header,
            allow_recompensate: self.allow_recompensate,
            max_output_bytes: self.max_output_bytes,
        })
    }
}

/// Where the model of a compensation came from, for the header: a file
/// (hashed with the tables it names) or a model built in memory (hashed as
/// its file text would be).
#[derive(Clone, Copy)]
pub enum ModelSource<'a> {
    /// A map file.
    File(&'a Path),
    /// A model built in memory (from arrays).
    Built(&'a LoadedModel),
}

impl ModelSource<'_> {
    fn header(
        self,
        machine: &Machine,
        options: &CompensateOptions,
        date_utc: String,
    ) -> Result<ProgramHeader, Error> {
        let setup_file = machine.setup_file.as_deref();
        let text = match self {
            ModelSource::File(p) => {
                return header_for_map(p, setup_file, &machine.setup.setup, options, date_utc)
            }
            ModelSource::Built(LoadedModel::AxisTables(t)) => t.to_csv(),
            ModelSource::Built(LoadedModel::Straightness(t)) => t.to_toml(),
            ModelSource::Built(LoadedModel::Kinematic(k)) => {
                let csv = crate::io::model_file::components_to_csv(&k.axes);
                let toml = crate::io::model_file::model_to_toml(k, "arrays.csv", None);
                format!("{toml}{csv}")
            }
        };
        Ok(ProgramHeader::for_compensation(
            vec![("arrays".into(), sha256_hex(text.as_bytes()))],
            setup_file.map(file_name),
            machine.setup.setup.clone(),
            options,
            date_utc,
        ))
    }
}

/// A compensation ready to run: options checked, machine set up, header made.
#[derive(Debug, Clone)]
pub struct Compensation {
    /// The machine.
    pub machine: Machine,
    /// The checked options.
    pub options: CompensateOptions,
    /// The header written at the program's top.
    pub header: ProgramHeader,
    /// Compensate a compensated program again.
    pub allow_recompensate: bool,
    /// Largest output (bytes).
    pub max_output_bytes: Option<u64>,
}

impl Compensation {
    /// The compensator of a program named `file` for `model` (callbacks and
    /// the run are the caller's).
    pub fn compensator<'a>(&self, model: &'a dyn ErrorModel, file: &str) -> Compensator<'a> {
        Compensator::new(model)
            .setup(self.machine.setup.clone())
            .options(self.options)
            .header(self.header.clone())
            .file_name(file)
            .allow_recompensate(self.allow_recompensate)
    }
}
