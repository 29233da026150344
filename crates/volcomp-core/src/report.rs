//! Simulating a whole program and measuring it (design §5).
//!
//! * point error: at every commanded point of a feed move (G1, and the chord
//!   ends of G2/G3), `‖actual − nominal‖`. Without a reference program the
//!   nominal point is the command itself; with one (a compensated program
//!   judged against its original) it is the original's vertex (block end,
//!   arc chord end) the point was aimed at when one lies within 0.02 mm,
//!   otherwise the closest point of the original's path (split points);
//! * contour error: the distance from the actual path, sampled every
//!   ≤ 0.05 mm along feed moves, to the nominal path; RMS over arc length.
//!
//! Rapids are simulated (they change the direction state and the tool's
//! position) but not measured: they do not cut. G53 and G28/G30 moves are
//! followed without evaluating the map (they usually leave the mapped volume),
//! and so are the moves before the program has set all three axes.

use crate::error::CompensationError;
use crate::model::ErrorModel;
use crate::simulate::{ErrorStats, NominalWindow, Simulator, SAMPLE_SPACING_MM};
use std::io::BufRead;
use volcomp_gcode::{Motion, MotionKind, MotionSource, Vec3, Walker};

/// Metrics of one simulated program, in µm.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct SimReport {
    /// RMS point error.
    pub point_rms_um: f64,
    /// Largest point error.
    pub point_max_um: f64,
    /// RMS contour error (over arc length).
    pub contour_rms_um: f64,
    /// Largest contour error.
    pub contour_max_um: f64,
    /// Program lines that produced motions.
    pub blocks: u64,
    /// Commanded points measured.
    pub points: u64,
    /// Dense samples measured.
    pub samples: u64,
    /// Length of the measured feed path (mm).
    pub feed_length_mm: f64,
}

/// One measured feed segment, for plots.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentError {
    /// Source line of the simulated program.
    pub line: u64,
    /// Commanded end point (axis frame, mm).
    pub command_mm: Vec3,
    /// Point error at its end (µm).
    pub point_um: f64,
    /// Largest contour error along it (µm).
    pub contour_max_um: f64,
}

/// Calls `f` with each straight piece `(start, end)` of a motion, arcs split
/// into chords within `chord_tolerance_mm`.
fn for_each_piece(m: &Motion, chord_tolerance_mm: f64, mut f: impl FnMut(Vec3, Vec3)) {
    match m.kind {
        MotionKind::Arc(arc) => {
            let mut prev = arc.start;
            arc.for_each_chord_end(chord_tolerance_mm, |p| {
                f(prev, p);
                prev = p;
            });
        }
        _ => f(m.start, m.end),
    }
}

fn is_measured(m: &Motion) -> bool {
    !matches!(m.kind, MotionKind::Rapid)
        && matches!(m.source, MotionSource::Program | MotionSource::Cycle)
}

/// Simulates `program` under `model`; `reference` (the original program) is
/// the nominal path when given. `on_segment` receives each measured piece.
///
/// `targets`, when given, lists `(command, nominal target)` pairs in program
/// order (as recorded by compensation): a measured point whose command is the
/// next pair's command is then judged against that exact target, and points
/// that are not in the list (take-up moves) are not counted as points.
pub fn simulate_program<R: BufRead, S: BufRead>(
    program: &mut Walker<R>,
    file: &str,
    mut reference: Option<&mut Walker<S>>,
    model: &dyn ErrorModel,
    chord_tolerance_mm: f64,
    mut targets: Option<&mut dyn Iterator<Item = (Vec3, Vec3)>>,
    mut on_segment: impl FnMut(&SegmentError),
) -> Result<SimReport, CompensationError> {
    let mut next_target = targets.as_mut().and_then(|t| t.next());
    let mut known = [false; 3];
    let mut sim = Simulator::new(model, program.interpreter().position());
    let mut window = NominalWindow::default();
    let mut point = ErrorStats::default();
    let mut contour = ErrorStats::default();
    let mut report = SimReport::default();
    let model_err = |line: u64, source| CompensationError::Model {
        target_mm: None,
        file: file.to_string(),
        line,
        source,
    };
    while let Some(ev) = program.next_line()? {
        if ev.motions.is_empty() {
            continue;
        }
        report.blocks += 1;
        sim.set_tool_length_offset(ev.interp.tool_length_offset_mm());
        // Until the program has set every axis, the machine is somewhere the
        // program does not say: follow without evaluating (as compensation does).
        for w in ev.lexed.words() {
            if matches!(w.letter, b'X' | b'Y' | b'Z') {
                known[usize::from(w.letter - b'X')] = true;
            }
        }
        if ev
            .motions
            .iter()
            .any(|m| m.source == MotionSource::Reference)
        {
            known = [true; 3];
        }
        let all_known = known.iter().all(|k| *k);
        for m in ev.motions {
            if !all_known || matches!(m.source, MotionSource::Machine | MotionSource::Reference) {
                sim.move_untracked(m.end);
                continue;
            }
            if !is_measured(m) {
                sim.move_to(m.end, f64::INFINITY, |_, _| {})
                    .map_err(|e| model_err(m.line, e))?;
                continue;
            }
            let mut pieces = Vec::new();
            for_each_piece(m, chord_tolerance_mm, |a, b| pieces.push((a, b)));
            for (a, b) in pieces {
                match reference.as_deref_mut() {
                    None => window.push(a, b),
                    Some(r) => {
                        while window.wants_more() {
                            let Some(rev) = r.next_line()? else { break };
                            for rm in rev.motions.iter().filter(|m| is_measured(m)) {
                                for_each_piece(rm, chord_tolerance_mm, |x, y| window.push(x, y));
                            }
                        }
                    }
                }
                let length = (b - a).norm();
                let mut seg_max: f64 = 0.0;
                let mut n = 0usize;
                let samples = ((length / SAMPLE_SPACING_MM).ceil() as usize).max(1);
                let weight = length / samples as f64;
                let mut sample_err = None;
                let end = sim
                    .move_to(b, SAMPLE_SPACING_MM, |actual, _| {
                        n += 1;
                        match window.distance(actual) {
                            Some(d) => {
                                let um = d * 1e3;
                                contour.add(um, weight);
                                seg_max = seg_max.max(um);
                            }
                            None => sample_err = Some(()),
                        }
                    })
                    .map_err(|e| model_err(m.line, e))?;
                if sample_err.is_some() {
                    return Err(CompensationError::AtLine {
                        file: file.to_string(),
                        line: m.line,
                        message: "the reference program has no feed moves to compare with".into(),
                        help:
                            "pass the original program of this compensated program as --reference"
                                .into(),
                    });
                }
                report.samples += n as u64;
                report.feed_length_mm += length;
                let point_um = match (next_target, reference.is_some()) {
                    (Some((command, target)), _) => {
                        if (command - b).max_abs() > 1e-9 {
                            continue;
                        }
                        next_target = targets.as_mut().and_then(|t| t.next());
                        (end - target).norm() * 1e3
                    }
                    (None, false) => (end - b).norm() * 1e3,
                    (None, true) => window.point_error(end).unwrap_or(0.0) * 1e3,
                };
                point.add(point_um, 1.0);
                on_segment(&SegmentError {
                    line: m.line,
                    command_mm: b,
                    point_um,
                    contour_max_um: seg_max,
                });
            }
        }
    }
    if let Some((command, target)) = next_target {
        return Err(CompensationError::AtLine {
            file: file.to_string(),
            line: 0,
            message: format!("the simulated program never commands the compensated point {command:?} (target {target:?})"),
            help: "simulate the program that was written by this compensation run".into(),
        });
    }
    report.point_rms_um = point.rms_um();
    report.point_max_um = point.max_um;
    report.contour_rms_um = contour.rms_um();
    report.contour_max_um = contour.max_um;
    report.points = point.count;
    Ok(report)
}
