//! Simulating a whole program and measuring it (docs/design.md, "Simulation and metrics").
//!
//! Every simulated command is paired with the nominal move it was written
//! for (see [`crate::simulate::nominal`]): without a reference program, each move of
//! the program is its own nominal move; with one (a program compensated by
//! volcomp judged against its original), the trace comments and the order of
//! the blocks name the original block of every written line. On that pairing:
//!
//! * **point error** ([`POINT_DEFINITION`]): at the end of every feed move of
//!   the nominal program (G1, the end of G2/G3, the feed moves of an expanded
//!   canned cycle), `‖actual − target‖`, `target` the move's programmed end
//!   point and `actual` the simulated tool position once the machine has
//!   executed the last command written for that move. The same targets with
//!   and without compensation, so rates of improvement compare like with
//!   like; the points a compensation inserts inside a move are not targets of
//!   the program (the contour error judges them);
//! * **contour error** ([`CONTOUR_DEFINITION`]): for each actual tool
//!   position sampled along every feed command (≤ 0.05 mm apart, end
//!   included), the distance to the nominal move that command was written
//!   for (its segment, or its arc); RMS weighted by the command path length
//!   each sample stands for, and max.
//!
//! Rapids are simulated (they change the direction state and the tool's
//! position) but not measured: they do not cut. G53 and G28/G30 moves are
//! followed without evaluating the map (they usually leave the mapped volume),
//! and so are the moves before the program has set all three axes.
//!
//! Uncompensated, every actual sample lies within the map's error of its
//! command (a dead-band lag mixes, axis by axis, errors of the map), and the
//! command lies on its nominal move (within the chord tolerance on arcs): the
//! contour error is bounded by the map's largest error.

use crate::error::CompensationError;
use crate::model::ErrorModel;
use crate::simulate::nominal::{is_feed_like, trace_tag, NominalBlock};
use crate::simulate::{ErrorStats, Simulator, SAMPLE_SPACING_MM};
use std::io::BufRead;
use volcomp_gcode::{Motion, MotionKind, MotionSource, Vec3, Walker};

/// What the point error is, as the reports state it.
pub const POINT_DEFINITION: &str = "at the end of every feed move of the nominal program (G1, G2/G3 end, canned-cycle feed): |actual - programmed end point| once the last command written for that move has run; RMS and max";

/// What the contour error is, as the reports state it.
pub const CONTOUR_DEFINITION: &str = "for every actual position sampled <= 0.05 mm apart along each feed command: distance to the nominal move (segment or arc) that command was written for; RMS weighted by path length, and max";

/// Longest feed move simulated (mm): the actual path is sampled every
/// [`SAMPLE_SPACING_MM`], so a longer move (a unit or coordinate mistake
/// with the clamp option) is refused rather than sampled for minutes.
pub const MAX_MOVE_LENGTH_MM: f64 = 100_000.0;

/// Metrics of one simulated program, in µm.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
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
    /// Where the nominal path comes from: `"program"` (the simulated program
    /// itself) or `"reference"` (the original it was compensated from).
    pub nominal: &'static str,
    /// [`POINT_DEFINITION`].
    pub point_definition: &'static str,
    /// [`CONTOUR_DEFINITION`].
    pub contour_definition: &'static str,
}

/// One measured feed command, for plots.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct SegmentError {
    /// Source line of the simulated program.
    pub line: u64,
    /// Line of the nominal program (the reference, or the program itself)
    /// whose move this command was written for.
    pub nominal_line: u64,
    /// Commanded start point (axis frame, mm).
    pub start_mm: Vec3,
    /// Commanded end point (axis frame, mm).
    pub command_mm: Vec3,
    /// The commanded arc, when the command is a G2/G3 (for drawing it).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub arc: Option<volcomp_gcode::Arc>,
    /// Commanded path length (mm; an arc's length along the arc).
    pub length_mm: f64,
    /// Simulated tool position once the command has run (axis frame, mm):
    /// the command plus the model's error, with the backlash lag of
    /// docs/design.md, "Direction state and backlash".
    pub actual_mm: Vec3,
    /// The nominal move's end point when this command is the last written
    /// for a nominal feed move (a point of the point error).
    pub target_mm: Option<Vec3>,
    /// Point error at its end (µm), when it ends a nominal feed move.
    pub point_um: Option<f64>,
    /// Largest contour error along it (µm).
    pub contour_max_um: f64,
}

fn is_measured(m: &Motion) -> bool {
    !matches!(m.kind, MotionKind::Rapid)
        && matches!(
            m.source,
            MotionSource::Program
                | MotionSource::Cycle
                | MotionSource::Spline
                | MotionSource::CutterComp
        )
}

/// The last measured command, waiting to know whether the next command
/// continues the same nominal move.
struct Pending {
    key: (u64, usize),
    segment: SegmentError,
    actual_end_mm: Vec3,
    target_mm: Option<Vec3>,
}

/// The middle of a written command: an arc's point at half its sweep.
fn command_middle(m: &Motion) -> Vec3 {
    match m.kind {
        MotionKind::Arc(arc) => arc.point_at(0.5),
        _ => (m.start + m.end) * 0.5,
    }
}

fn mismatch(file: &str, line: u64, message: String) -> CompensationError {
    CompensationError::AtLine {
        file: file.to_string(),
        line,
        message,
        help: crate::error::help::REFERENCE_PAIRING.into(),
    }
}

/// The reference program's moving blocks, in order, with one block of
/// look-ahead.
struct RefBlocks<'a, S: BufRead> {
    walker: &'a mut Walker<S>,
    peeked: Option<Option<(NominalBlock, bool)>>,
}

impl<S: BufRead> RefBlocks<'_, S> {
    /// The next block that moves, and whether cutter radius compensation
    /// is on after it (compensation then writes the block as the
    /// tool-centre path, compensate/cutter.rs: its own line carries no
    /// move, even when a zero radius leaves its motions the program's own).
    fn next(&mut self) -> Result<Option<(NominalBlock, bool)>, CompensationError> {
        if let Some(b) = self.peeked.take() {
            return Ok(b);
        }
        while let Some(ev) = self.walker.next_line()? {
            if !ev.motions.is_empty() {
                return Ok(Some((
                    NominalBlock::new(ev.number, ev.motions, false),
                    ev.interp.cutter_comp_on(),
                )));
            }
        }
        Ok(None)
    }

    fn peek(&mut self) -> Result<Option<&mut (NominalBlock, bool)>, CompensationError> {
        if self.peeked.is_none() {
            let b = self.next()?;
            self.peeked = Some(b);
        }
        Ok(self.peeked.as_mut().and_then(|b| b.as_mut()))
    }
}

/// A written command as the pairing sees it: its middle, its end, and
/// whether it is a feed.
type Probe = (Vec3, Vec3, bool);

/// Moves the pairing to the original block of a written line: the block the
/// trace comment names, or (untagged) the original line itself, in order.
///
/// A block run again (a loop or a subroutine called over and over) has the
/// same line number each time. A cutter-compensated block's own line is not
/// written, so where one run's tagged lines end is not seen: a command
/// tagged with the current block's line is paired with the next run of that
/// block instead when it lies nearer to that run's motions (by its middle
/// and its end, [`NominalBlock::nearest_mm`]).
fn advance<S: BufRead>(
    reference: &mut RefBlocks<'_, S>,
    block: &mut Option<NominalBlock>,
    tag: Option<u64>,
    probe: Option<Probe>,
    file: &str,
    line: u64,
) -> Result<(), CompensationError> {
    match tag {
        Some(n) => {
            if let Some(b) = block.as_mut().filter(|b| b.line == n) {
                let (Some((mid, to, feed)), true) = (probe, b.is_cutter()) else {
                    return Ok(());
                };
                let here = b.nearest_mm(Some(mid), to, feed).unwrap_or(f64::INFINITY);
                let next = match reference.peek()? {
                    Some((nb, _)) if nb.line == n && nb.is_cutter() => {
                        nb.nearest_mm(Some(mid), to, feed)
                    }
                    _ => None,
                };
                if !next.is_some_and(|d| d + 1e-6 < here) {
                    return Ok(());
                }
            }
            let Some((mut b, cutter)) = reference.next()? else {
                return Err(mismatch(file, line, format!("this line is marked as written for line {n} of the reference, which has no moving line left")));
            };
            if b.line != n {
                return Err(mismatch(file, line, format!("this line is marked as written for line {n} of the reference, but the reference's next moving line is line {}", b.line)));
            }
            // A canned cycle's, a spline's or a cutter-compensated block's
            // own line is written without its moves.
            b.own_line_written = cutter
                || b.motions.iter().any(|m| {
                    matches!(
                        m.source,
                        MotionSource::Cycle | MotionSource::Spline | MotionSource::CutterComp
                    )
                });
            *block = Some(b);
        }
        None => {
            if let Some(b) = block.as_mut().filter(|b| !b.own_line_written) {
                b.own_line_written = true;
                return Ok(());
            }
            let Some((mut b, _)) = reference.next()? else {
                return Err(mismatch(
                    file,
                    line,
                    "this line moves, but the reference has no moving line left".into(),
                ));
            };
            b.own_line_written = true;
            *block = Some(b);
        }
    }
    Ok(())
}

/// Simulates `program` under `model` and measures it against its nominal
/// path: `reference` (the original of a program compensated by volcomp)
/// when given, else the program itself. `on_segment` receives each measured
/// feed command, in order.
pub fn simulate_program<R: BufRead, S: BufRead>(
    program: &mut Walker<R>,
    file: &str,
    reference: Option<&mut Walker<S>>,
    model: &dyn ErrorModel,
    chord_tolerance_mm: f64,
    mut on_segment: impl FnMut(&SegmentError),
) -> Result<SimReport, CompensationError> {
    let mut reference = reference.map(|walker| RefBlocks {
        walker,
        peeked: None,
    });
    // The set-up's `start` gives every axis a known position (as in
    // compensation).
    let mut known = [program.interpreter().start_given(); 3];
    let mut sim = Simulator::new(model, program.interpreter().position());
    let mut block: Option<NominalBlock> = None;
    let mut pending: Option<Pending> = None;
    let mut point = ErrorStats::default();
    let mut contour = ErrorStats::default();
    let mut report = SimReport {
        nominal: if reference.is_some() {
            "reference"
        } else {
            "program"
        },
        point_definition: POINT_DEFINITION,
        contour_definition: CONTOUR_DEFINITION,
        ..SimReport::default()
    };
    let mut commit = |p: Pending, next: Option<(u64, usize)>, point: &mut ErrorStats| {
        let mut segment = p.segment;
        if next != Some(p.key) {
            if let Some(t) = p.target_mm {
                let um = (p.actual_end_mm - t).norm() * 1e3;
                point.add(um, 1.0);
                segment.target_mm = Some(t);
                segment.point_um = Some(um);
            }
        }
        on_segment(&segment);
    };
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
        crate::compensate::mark_axes_set(ev.lexed, &mut known);
        if ev
            .motions
            .iter()
            .any(|m| m.source == MotionSource::Reference)
        {
            known = [true; 3];
        }
        let all_known = known.iter().all(|k| *k);
        let tag = match reference.as_mut() {
            None => {
                block = Some(NominalBlock::new(ev.number, ev.motions, true));
                None
            }
            Some(r) => {
                let tag = trace_tag(ev.bytes);
                let probe = ev
                    .motions
                    .first()
                    .map(|m| (command_middle(m), m.end, is_feed_like(m)));
                advance(r, &mut block, tag, probe, file, ev.number)?;
                tag
            }
        };
        let Some(blk) = block.as_mut() else {
            continue;
        };
        let by_index = tag.is_none() && blk.motions.len() == ev.motions.len();
        for (i, m) in ev.motions.iter().enumerate() {
            let paired = if by_index {
                blk.pair_index(i)
            } else {
                blk.pair_via(m.start, Some(command_middle(m)), m.end, is_feed_like(m))
            };
            let Some(idx) = paired else {
                return Err(mismatch(
                    file,
                    m.line,
                    format!(
                        "this move does not follow the moves of line {} of the reference",
                        blk.line
                    ),
                ));
            };
            let key = (blk.line, idx);
            if pending.as_ref().is_some_and(|p| p.key != key) {
                if let Some(p) = pending.take() {
                    commit(p, Some(key), &mut point);
                }
            }
            if !all_known || matches!(m.source, MotionSource::Machine | MotionSource::Reference) {
                sim.move_untracked(m.end);
                continue;
            }
            if !is_measured(m) {
                sim.move_to(m.end, f64::INFINITY, |_, _| {})
                    .map_err(|e| model_err(m.line, e))?;
                continue;
            }
            let (length, chords) = match m.kind {
                MotionKind::Arc(arc) => (arc.length(), arc.chord_count(chord_tolerance_mm)),
                _ => ((m.end - m.start).norm(), 1),
            };
            if length.is_nan()
                || length > MAX_MOVE_LENGTH_MM
                || chords as f64 > MAX_MOVE_LENGTH_MM / SAMPLE_SPACING_MM
            {
                return Err(CompensationError::AtLine {
                    file: file.to_string(),
                    line: m.line,
                    message: format!("this feed move is {length:.1} mm long; the simulation samples the tool path every {SAMPLE_SPACING_MM} mm and refuses moves longer than {:.0} m", MAX_MOVE_LENGTH_MM * 1e-3),
                    help: "check the program's units (G20/G21) and coordinates, and the work offset".into(),
                });
            }
            let nominal = blk.motions[idx];
            let mut seg_max: f64 = 0.0;
            let mut end = sim.command();
            let mut prev = m.start;
            for k in 1..=chords {
                let b = match m.kind {
                    MotionKind::Arc(arc) if k < chords => arc.point_at(k as f64 / chords as f64),
                    _ => m.end,
                };
                let piece = (b - prev).norm();
                prev = b;
                let samples = ((piece / SAMPLE_SPACING_MM).ceil() as usize).max(1);
                let weight = piece / samples as f64;
                end = sim
                    .move_to(b, SAMPLE_SPACING_MM, |actual, _| {
                        let um = blk.distance_mm(idx, actual) * 1e3;
                        contour.add(um, weight);
                        seg_max = seg_max.max(um);
                    })
                    .map_err(|e| model_err(m.line, e))?;
                report.samples += samples as u64;
                report.feed_length_mm += piece;
            }
            let segment = SegmentError {
                line: m.line,
                nominal_line: blk.line,
                start_mm: m.start,
                command_mm: m.end,
                arc: match m.kind {
                    MotionKind::Arc(arc) => Some(arc),
                    _ => None,
                },
                length_mm: length,
                actual_mm: end,
                target_mm: None,
                point_um: None,
                contour_max_um: seg_max,
            };
            if let Some(p) = pending.take() {
                commit(p, Some(key), &mut point);
            }
            pending = Some(Pending {
                key,
                segment,
                actual_end_mm: end,
                // A spline is one feed move of the program: its point error
                // is at its end, not at the ends of its chords.
                target_mm: (is_measured(&nominal)
                    && (nominal.source != MotionSource::Spline || idx + 1 == blk.motions.len()))
                .then_some(nominal.end),
            });
        }
    }
    if let Some(p) = pending.take() {
        commit(p, None, &mut point);
    }
    if let Some(mut r) = reference {
        if let Some((b, _)) = r.next()? {
            return Err(CompensationError::AtLine {
                file: file.to_string(),
                line: 0,
                message: format!(
                    "the program ends, but the reference still moves at its line {}",
                    b.line
                ),
                help: crate::error::help::REFERENCE_LEFT.into(),
            });
        }
    }
    report.point_rms_um = point.rms_um();
    report.point_max_um = point.max_um;
    report.contour_rms_um = contour.rms_um();
    report.contour_max_um = contour.max_um;
    report.points = point.count;
    Ok(report)
}
