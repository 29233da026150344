//! Canned cycles kept as cycles (docs/compensation.md, "Canned cycles"):
//! each hole of a G73, G81, G82, G83, G85, G86 or G89 block is written as
//! one cycle block whose numbers are compensated — the hole position (the
//! plane's two words) and the bottom at the bottom of the hole, R at the R
//! plane, each with the direction states the machine has there — wherever
//! the map varies little enough over the hole's own motion; elsewhere the
//! hole is written as its moves (compensate/cycle.rs).
//!
//! What the controller does with a written cycle block is LinuxCNC 2.9's
//! `convert_cycle_xy` (and its YZ/ZX twins) with `CYCLE_MACRO` and
//! `convert_cycle_g73` … `convert_cycle_g89`, src/emc/rs274ngc/interp_cycles.cc
//! (commit f1270d6ed7): [`block_moves`] is that sequence for given levels,
//! used twice — with the program's numbers to find each hole's moves among
//! the interpreter's, and with the written numbers to follow the machine.
//!
//! Per hole, with `t` the nominal hole bottom and `q` its command (fixed
//! X/Y for the whole stroke), the written cycle leaves
//! * across the stroke, `q_xy + e_xy(q_xy, z) − t_xy` at each depth `z`
//!   from R to the bottom: `|∂e_xy/∂z|·(R − Z)` to first order (0 at the
//!   bottom, where it is solved);
//! * at each feed end above the bottom (a peck), the level error
//!   `e_n(z_k) − e_n(z_R) + (R' − R) …`: with Q scaled by the stroke's own
//!   ratio `(R' − Z')/(R − Z)` the first-order term `∂e_n/∂z·kQ` cancels and
//!   what is left is second order;
//! * at the levels reached by rapids only (G98's initial level, a peck's
//!   retract), a clearance changed by the map there: reported, not a
//!   contour error.
//!
//! The first two are compared with the contour tolerance for the boring
//! cycles (G85, G86, G89: the feed finishes the wall) and with the drill
//! tolerance, at least the contour tolerance, for the drilling cycles (G73,
//! G81, G82, G83: a twist drill's own run-out and wander are tens of µm, and
//! the bottom is compensated exactly either way); a hole that exceeds it is
//! expanded, and the trace comment of its first move says by how much.

use super::frame::Frame;
use super::walk::Line;
use super::State;
use crate::compensate::solve::{solve_consistent, Method};
use crate::compensate::{PointRecord, Segmentation};
use crate::error::CompensationError;
use crate::model::next_state;
use crate::model::{Components, Direction, Directions};
use volcomp_gcode::interp::{snap_program_value as snap, CycleBlock};
use volcomp_gcode::number::format_number;
use volcomp_gcode::number::NumberStyle;
use volcomp_gcode::{MotionKind, Vec3};

/// Most samples of the map along one stroke (the drift check); strokes are
/// sampled every [`SAMPLE_STEP_MM`] up to this many.
const MAX_SAMPLES: usize = 200;
const SAMPLE_STEP_MM: f64 = 0.1;

/// The run of cycle blocks in the written program: the machine's initial
/// level (LinuxCNC's `cycle_il`, normal axis, axis frame mm) while the
/// written program's motion mode is a canned cycle, `None` otherwise.
#[derive(Debug, Default, Clone, Copy)]
pub(super) struct Series {
    initial_mm: Option<f64>,
}

impl Series {
    /// Called for every line with the interpreter after it: a line after
    /// which no cycle is in effect (G80, G0, G1 …) ends the run in the
    /// original and in the written program alike.
    pub(super) fn follow(&mut self, interp: &volcomp_gcode::Interpreter) {
        if interp.canned_cycle().is_none() {
            self.initial_mm = None;
        }
    }

    /// The written program's motion mode is a canned cycle.
    pub(super) fn active(&self) -> bool {
        self.initial_mm.is_some()
    }

    /// A hole written as moves after `G80`: the run ends.
    pub(super) fn end(&mut self) {
        self.initial_mm = None;
    }
}

/// The levels of one cycle block in program units (normal axis), as
/// `convert_cycle_xy` holds them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Levels {
    pub(super) initial: f64,
    pub(super) current: f64,
    pub(super) r: f64,
    pub(super) bottom: f64,
    pub(super) q: f64,
    pub(super) peck_clear: f64,
}

/// One move of a cycle: feed (true) or rapid, its end (program frame, the
/// plane's first, second and normal coordinates), and the hole it belongs
/// to (`None`: the rapid up to R before the first hole).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct CycleMove {
    pub(super) feed: bool,
    pub(super) end: [f64; 3],
    pub(super) hole: Option<usize>,
}

/// The moves LinuxCNC 2.9 makes for a cycle block `code` (G-code × 10)
/// with `levels`, holes `holes` (in-plane points), starting at in-plane
/// point `start`; G99 when `retract_to_r`. `convert_cycle_xy`'s
/// `CYCLE_MACRO` and `convert_cycle_g73` … `convert_cycle_g89` (G73, G81,
/// G82, G83, G85, G86, G89); `None` for any other code.
pub(super) fn block_moves(
    code: u16,
    levels: Levels,
    start: [f64; 2],
    holes: &[[f64; 2]],
    retract_to_r: bool,
) -> Option<Vec<CycleMove>> {
    let Levels {
        initial,
        mut current,
        r,
        bottom,
        q,
        peck_clear,
    } = levels;
    let mut out = Vec::new();
    let mut push = |feed: bool, a: f64, b: f64, c: f64, hole: Option<usize>| {
        out.push(CycleMove {
            feed,
            end: [a, b, c],
            hole,
        })
    };
    let mut old = initial;
    if old < r {
        push(false, start[0], start[1], r, None);
        old = r;
        current = old;
    }
    let clear = if retract_to_r { r } else { old };
    for (k, &[a, b]) in holes.iter().enumerate() {
        let h = Some(k);
        if k == 0 && current > r {
            push(false, a, b, current, h);
            push(false, a, b, r, h);
        } else {
            push(false, a, b, clear, h);
            if clear > r {
                push(false, a, b, r, h);
            }
        }
        match code {
            810 | 820 | 860 => {
                push(true, a, b, bottom, h);
                push(false, a, b, clear, h);
            }
            890 => {
                push(true, a, b, bottom, h);
                push(true, a, b, clear, h);
            }
            850 => {
                push(true, a, b, bottom, h);
                push(true, a, b, r, h);
                push(false, a, b, clear, h);
            }
            730 | 830 => {
                if q <= 0.0 {
                    return None;
                }
                let mut depth = r - q;
                let mut pecks = 0usize;
                while depth > bottom {
                    pecks += 1;
                    if pecks > 100_000 {
                        return None;
                    }
                    push(true, a, b, depth, h);
                    if code == 830 {
                        push(false, a, b, r, h);
                    }
                    push(false, a, b, depth + peck_clear, h);
                    depth -= q;
                }
                push(true, a, b, bottom, h);
                push(false, a, b, clear, h);
            }
            _ => return None,
        }
    }
    Some(out)
}

/// Why a hole is written as its moves (the trace comment of its first
/// move says it).
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Expand {
    /// The map moves the tool across the stroke by this much (µm).
    Drift(f64),
    /// A feed move (a peck, G85/G89's feed out) ends this far (µm) from
    /// its nominal end.
    Peck(f64),
    /// The written numbers make a different number of pecks.
    PeckCount,
    /// An axis could not be solved consistently at the bottom, or the
    /// correction there is above the limit (the moves report it).
    Held,
    /// Written as a cycle, the hole's moves in the air would not be the
    /// original's (µm off; infinite: other moves): after a hole written as
    /// moves in G99, a G98 hole's initial level is where the written run
    /// restarted; a first hole whose compensated R falls below the level
    /// the machine stands at traverses there instead of at the retract
    /// level.
    Retract(f64),
}

impl Expand {
    fn text(&self, tolerance_um: f64) -> String {
        match self {
            Expand::Drift(um) => format!(
                "cycle expanded: the map moves the tool {um:.3} um across the stroke, above the {tolerance_um:.3} um tolerance"
            ),
            Expand::Peck(um) => format!(
                "cycle expanded: a feed move would end {um:.3} um off its end, above the {tolerance_um:.3} um tolerance"
            ),
            Expand::PeckCount => {
                "cycle expanded: the compensated numbers would make another number of pecks".into()
            }
            Expand::Held => {
                "cycle expanded: the bottom has no consistent direction or too large a correction".into()
            }
            Expand::Retract(um) if um.is_finite() => format!(
                "cycle expanded: written as a cycle it would retract or traverse {:.3} mm off the original's level",
                um * 1e-3
            ),
            Expand::Retract(_) => {
                "cycle expanded: written as a cycle its rapids would not be the original's".into()
            }
        }
    }
}

/// One hole written as a cycle block: its words (program units) and the
/// machine's moves for it.
#[derive(Debug, Clone)]
pub(super) struct KeptHole {
    /// The words after the cycle code: `X.. Y.. Z.. R.. [Q..]`, as written.
    pub(super) words: String,
    /// The machine's moves (axis frame, mm) and whether each is a feed.
    moves: Vec<(bool, Vec3)>,
    /// Bottom and R: target and command, for the point records.
    points: [(Vec3, Vec3, f64); 2],
    /// Largest error the kept cycle leaves on a cut (µm): across the
    /// stroke or at a feed end.
    error_um: f64,
}

/// One way of writing a hole: its words, the machine's moves, the
/// commands read back at the bottom and at R, and the error left at R
/// (mm, + above the plane) in the state the machine reaches it with.
struct Candidate {
    words: String,
    moves: Vec<CycleMove>,
    moves_mm: Vec<(bool, Vec3)>,
    bottom: Vec3,
    r: Vec3,
    r_error_mm: f64,
}

/// What to do with one hole.
#[derive(Debug, Clone)]
pub(super) enum Hole {
    Keep(Box<KeptHole>),
    Expand(Expand),
}

/// The cycle of a line as LinuxCNC computed it, and the range of the
/// line's motions each hole takes (the rapid up to R before the first
/// hole counted with the first).
pub(super) struct Holes {
    pub(super) block: CycleBlock,
    pub(super) nominal: Vec<CycleMove>,
    pub(super) ranges: Vec<std::ops::Range<usize>>,
}

/// The program point of plane coordinates `(a, b, c)` (axes `ax`).
fn program_point(ax: [usize; 3], p: [f64; 3]) -> Vec3 {
    let mut v = Vec3::ZERO;
    v[ax[0]] = p[0];
    v[ax[1]] = p[1];
    v[ax[2]] = p[2];
    v
}

/// The axis point (mm) of program point `p` in an unrotated frame.
fn axis_point(frame: &Frame, p: Vec3) -> Vec3 {
    p * frame.mm_per_unit + frame.offset_mm
}

/// `v` as written with the frame's decimals, and the value the
/// controller reads back from that text.
fn written(frame: &Frame, style: volcomp_gcode::number::NumberStyle, v: f64) -> (String, f64) {
    let mut text = String::new();
    format_number(frame.round(v), style, &mut text);
    let read = text.parse::<f64>().unwrap_or_else(|_| frame.round(v));
    (text, read)
}

impl State<'_> {
    /// The contour tolerance a kept cycle must meet (mm): that of adaptive
    /// segmentation; `None` under a fixed segmentation or none, where
    /// every cycle is written as its moves as before.
    pub(super) fn cycle_tolerance_mm(&self) -> Option<f64> {
        match self.walk.options.segmentation {
            Segmentation::Adaptive { tolerance_mm, .. } => Some(tolerance_mm),
            _ => None,
        }
    }

    /// The tolerance a kept hole of cycle `g` (G number) must meet (mm): the
    /// contour tolerance for the boring cycles, whose feed cuts the wall
    /// (G85, G86, G89), and at least
    /// [`CompensateOptions::drill_tolerance_mm`](super::CompensateOptions::drill_tolerance_mm)
    /// for the drilling cycles (G73, G81, G82, G83), whose drill cuts a wall
    /// of its own; `None` where no cycle is kept.
    pub(super) fn hole_tolerance_mm(&self, g: u16) -> Option<f64> {
        let contour = self.cycle_tolerance_mm()?;
        Some(if matches!(g, 73 | 81 | 82 | 83) {
            contour.max(self.walk.options.drill_tolerance_mm)
        } else {
            contour
        })
    }

    /// The holes of a cycle line; `None` where the line cannot be kept
    /// at all (a fixed segmentation, a rotated frame, G7, extra axes,
    /// G74/G84, or the interpreter's moves not the ones [`block_moves`]
    /// makes).
    pub(super) fn cycle_holes(&self, line: &Line) -> Option<Holes> {
        self.cycle_tolerance_mm()?;
        // Directions taken from the nominal path (an option for studies):
        // the holes are written as moves, solved that way.
        if self.walk.options.directions != super::DirectionPolicy::Commanded {
            return None;
        }
        let ev = line.ev;
        let frame = &line.frame;
        let block = ev.interp.last_cycle()?;
        if frame.rotation_deg != 0.0
            || frame.x_word_scale != 1.0
            || ev.motions.iter().any(|m| m.extra.moves())
        {
            return None;
        }
        let levels = Levels {
            initial: block.initial,
            current: block.current,
            r: block.r,
            bottom: block.bottom,
            q: block.q,
            peck_clear: block.peck_clear,
        };
        let nominal = block_moves(
            block.code,
            levels,
            block.start,
            &block.holes,
            block.retract_to_r,
        )?;
        // The interpreter's moves must be these: otherwise the line is
        // written as its moves.
        if nominal.len() != ev.motions.len()
            || nominal.iter().zip(ev.motions).any(|(n, m)| {
                let p = axis_point(frame, program_point(block.axes, n.end));
                (p - m.end).max_abs() > 1e-6 || n.feed != matches!(m.kind, MotionKind::Feed)
            })
        {
            return None;
        }
        let mut ranges = Vec::with_capacity(block.holes.len());
        let mut from = 0;
        for k in 0..block.holes.len() {
            let to = nominal
                .iter()
                .rposition(|m| m.hole == Some(k))
                .map_or(from, |i| i + 1);
            ranges.push(from..to);
            from = to;
        }
        Some(Holes {
            block: block.clone(),
            nominal,
            ranges,
        })
    }

    /// Plans hole `k` of `block` from the walk's current command and
    /// directions: solves bottom and R, writes the words, follows the
    /// machine through the written block and measures what it leaves.
    pub(super) fn plan_hole(
        &mut self,
        line: &Line,
        block: &CycleBlock,
        k: usize,
        nominal: &[CycleMove],
        tolerance_mm: f64,
    ) -> Result<Hole, CompensationError> {
        let model = line.model();
        let options = self.walk.options;
        let frame = &line.frame;
        let (frame_w, style) = frame.with_line_decimals(line.words(), line.style);
        let ax = block.axes;
        let n = ax[2];
        let comps = if options.method == Method::Pitch {
            Components::PositioningOnly
        } else {
            Components::All
        };
        let [a_nom, b_nom] = block.holes[k];
        let t_b = axis_point(frame, program_point(ax, [a_nom, b_nom, block.bottom]));
        let t_r = axis_point(frame, program_point(ax, [a_nom, b_nom, block.r]));
        let model_err = |e| super::model_error(self.walk.file, line.number(), e);
        // The bottom: the plane's axes as the approach moved them, the
        // normal axis moving down.
        let mut q_prev = self.q_out;
        q_prev[n] = t_b[n] + 1.0;
        let mut s_prev = self.s;
        s_prev[n] = Direction::Reverse;
        let sol = solve_consistent(model, options.method, t_b, q_prev, s_prev, &|q| q)
            .map_err(model_err)?;
        if sol.held.iter().any(|h| *h) {
            return Ok(Hole::Expand(Expand::Held));
        }
        let q_b = sol.q_mm;
        let s_b = sol.s;
        // A correction above the limit: written as moves, where the
        // limit is reported at the line.
        if (q_b - t_b).norm() > options.max_correction_mm {
            return Ok(Hole::Expand(Expand::Held));
        }
        // The machine's numbers (program units) before the block.
        // As LinuxCNC holds them (it compares them exactly with R).
        let cur = frame.program(self.q_out);
        let cur = Vec3::new(snap(cur.x), snap(cur.y), snap(cur.z));
        let initial = match self.cycles.initial_mm {
            Some(z) if z.is_finite() => snap((z - frame.offset_mm[n]) / frame.mm_per_unit),
            _ => cur[n],
        };
        let pb = frame.program(q_b);
        // R: the normal axis at the hole's command, solved for the machine
        // arriving there moving down and moving up, and the level the
        // machine stands at (in G99 the R it retracted to: staying there
        // keeps the cycle's moves those of the original). Each is followed
        // through the block; of those whose moves are the original's (the
        // same moves, each within a correction of its nominal end), the
        // one that leaves R exactly in the state the machine really
        // arrives with, else the one that leaves the tool nearest above
        // the plane.
        let feeds = nominal.iter().filter(|m| m.feed).count();
        let nominal_mm: Vec<(bool, Vec3)> = nominal
            .iter()
            .map(|m| (m.feed, axis_point(frame, program_point(ax, m.end))))
            .collect();
        let mut tries = Vec::with_capacity(3);
        for state in [Direction::Reverse, Direction::Forward] {
            let mut s_try = s_b;
            s_try[n] = state;
            let mut q_r = q_b;
            q_r[n] = t_r[n];
            for _ in 0..8 {
                let e = model.deviation_um(q_r, s_try, comps).map_err(model_err)?;
                q_r[n] = t_r[n] - e[n] * 1e-3;
            }
            tries.push(q_r);
        }
        let mut stay = q_b;
        stay[n] = self.q_out[n];
        if (stay[n] - t_r[n]).abs() <= options.max_correction_mm {
            tries.push(stay);
        }
        let mut candidates: Vec<Candidate> = Vec::with_capacity(3);
        let mut path_off: Option<f64> = None;
        for q_r in tries {
            let pr = frame.program(q_r);
            // Q as scaled, or a step either side where the scaled one
            // would make another number of pecks (a stroke that is a whole
            // number of pecks long).
            let mut found = None;
            for nudge in [0.0, 1.0, -1.0] {
                let (text, levels, hole) = hole_words(
                    block,
                    (&frame_w, style, self.walk.sep),
                    (pb, pr),
                    cur,
                    initial,
                    nudge,
                );
                let Some(m) = block_moves(
                    block.code,
                    levels,
                    [cur[ax[0]], cur[ax[1]]],
                    &[hole],
                    block.retract_to_r,
                ) else {
                    continue;
                };
                if m.iter().filter(|m| m.feed).count() == feeds {
                    found = Some((text, levels, hole, m));
                    break;
                }
            }
            let Some((words, levels, hole, moves)) = found else {
                continue;
            };
            let moves_mm: Vec<(bool, Vec3)> = moves
                .iter()
                .map(|m| (m.feed, axis_point(frame, program_point(ax, m.end))))
                .collect();
            match path_deviation_mm(&nominal_mm, &moves_mm) {
                Some(off) if off <= options.max_correction_mm => {}
                off => {
                    path_off = Some(off.unwrap_or(f64::INFINITY));
                    continue;
                }
            }
            // The state the machine arrives at R with: before the first
            // feed.
            let first_feed = moves_mm.iter().position(|(f, _)| *f).unwrap_or(0);
            let (mut s, mut q) = (self.s, self.q_out);
            for (_, p) in &moves_mm[..first_feed] {
                s = next_state(s, *p - q);
                q = *p;
            }
            let r_read = axis_point(frame, program_point(ax, [hole[0], hole[1], levels.r]));
            let e = model.deviation_um(r_read, s, comps).map_err(model_err)?;
            candidates.push(Candidate {
                words,
                moves,
                moves_mm,
                bottom: axis_point(frame, program_point(ax, [hole[0], hole[1], levels.bottom])),
                r: r_read,
                r_error_mm: r_read[n] + e[n] * 1e-3 - t_r[n],
            });
        }
        // Exact first (within the written rounding), then above the plane
        // and nearest.
        let rank = |c: &Candidate| {
            let exact = c.r_error_mm.abs() <= 1e-5;
            let below = c.r_error_mm < -1e-6;
            (!exact, below, c.r_error_mm.abs())
        };
        let Some(chosen) = candidates
            .iter()
            .enumerate()
            .min_by(|a, b| {
                rank(a.1)
                    .partial_cmp(&rank(b.1))
                    .unwrap_or(std::cmp::Ordering::Equal)
            })
            .map(|(i, _)| i)
        else {
            return Ok(Hole::Expand(match path_off {
                Some(off) => Expand::Retract(off * 1e3),
                None => Expand::PeckCount,
            }));
        };
        let Candidate {
            words,
            moves,
            moves_mm,
            bottom: b_read,
            r: r_read,
            r_error_mm,
        } = candidates.swap_remove(chosen);
        // Feed ends: the written block's against the nominal hole's.
        let feed_ends = |ms: &[CycleMove]| -> Vec<f64> {
            ms.iter().filter(|m| m.feed).map(|m| m.end[2]).collect()
        };
        let nominal_feeds = feed_ends(nominal);
        let written_feeds = feed_ends(&moves);
        if nominal_feeds.len() != written_feeds.len() {
            return Ok(Hole::Expand(Expand::PeckCount));
        }
        // Follow the machine through the block: every feed stroke's drift
        // across the hole, every feed end's level.
        let mut s = self.s;
        let mut q = self.q_out;
        let (mut drift_mm, mut level_mm) = (0.0f64, 0.0f64);
        let mut feed_index = 0;
        for (feed, p) in &moves_mm {
            let from = q;
            s = next_state(s, *p - q);
            q = *p;
            if !feed {
                continue;
            }
            let length = (p[n] - from[n]).abs();
            let samples = ((length / SAMPLE_STEP_MM).ceil() as usize).clamp(1, MAX_SAMPLES);
            for i in 0..=samples {
                let mut x = *p;
                x[n] = from[n] + (p[n] - from[n]) * i as f64 / samples as f64;
                let e = model.deviation_um(x, s, comps).map_err(model_err)?;
                let da = x[ax[0]] + e[ax[0]] * 1e-3 - t_b[ax[0]];
                let db = x[ax[1]] + e[ax[1]] * 1e-3 - t_b[ax[1]];
                drift_mm = drift_mm.max(da.hypot(db));
            }
            // The feed end: the whole distance to its nominal point (a
            // peck's level, and the drift where the stroke ends away from
            // the bottom).
            let e = model.deviation_um(*p, s, comps).map_err(model_err)?;
            let nominal_end = axis_point(
                frame,
                program_point(ax, [a_nom, b_nom, nominal_feeds[feed_index]]),
            );
            level_mm = level_mm.max((*p + e * 1e-3 - nominal_end).norm());
            feed_index += 1;
        }
        if drift_mm > tolerance_mm {
            return Ok(Hole::Expand(Expand::Drift(drift_mm * 1e3)));
        }
        if level_mm > tolerance_mm {
            return Ok(Hole::Expand(Expand::Peck(level_mm * 1e3)));
        }
        let residual = |t: Vec3, q: Vec3, s: Directions| -> Result<f64, CompensationError> {
            let e = model.deviation_um(q, s, comps).map_err(model_err)?;
            Ok((q + e * 1e-3 - t).norm() * 1e3)
        };
        // The commands the controller reads back: the bottom (every axis)
        // and R (its own axis; the plane's are the bottom's).
        let points = [
            (t_b, b_read, residual(t_b, b_read, s_b)?),
            (t_r, r_read, r_error_mm.abs() * 1e3),
        ];
        Ok(Hole::Keep(Box::new(KeptHole {
            words,
            moves: moves_mm,
            points,
            error_um: drift_mm.max(level_mm) * 1e3,
        })))
    }

    /// Writes kept hole `hole`: `words_before` (the line's own text, or
    /// nothing for a hole after the first) already in the buffer or not,
    /// then follows the machine through its moves and records its points.
    pub(super) fn follow_kept(&mut self, line: &Line, hole: &KeptHole) {
        for (i, (target, command, residual)) in hole.points.into_iter().enumerate() {
            // The bottom is a solved point; R is where a rapid ends (its
            // error, at most a reversal above the plane where the machine
            // stands at the R it retracted to, is no solver residual).
            let at_r = i == 1;
            self.summary.points += 1;
            if !at_r {
                self.summary.max_residual_um = self.summary.max_residual_um.max(residual);
            }
            self.summary.max_correction_um = self
                .summary
                .max_correction_um
                .max((command - target).norm() * 1e3);
            (self.on_point)(&PointRecord {
                line: line.number(),
                target_mm: target,
                command_mm: command,
                iterations: 1,
                residual_um: residual,
                reversed: [false; 3],
                held: [false; 3],
                take_up: false,
                rapid: at_r,
            });
        }
        if self.cycles.initial_mm.is_none() {
            self.cycles.initial_mm = Some(self.q_out[line_normal(line)]);
        }
        for (_, q) in &hole.moves {
            self.s = next_state(self.s, *q - self.q_out);
            self.q_out = *q;
        }
        self.s_nominal = self.s;
        self.summary.cycle_holes_kept += 1;
        self.summary.max_cycle_error_um = self.summary.max_cycle_error_um.max(hole.error_um);
    }

    /// The trace text of an expanded hole.
    pub(super) fn expand_note(&self, why: &Expand, g: u16) -> String {
        let tolerance_um = self.hole_tolerance_mm(g).unwrap_or(0.0) * 1e3;
        why.text(tolerance_um)
    }
}

/// The normal axis of the line's cycle.
fn line_normal(line: &Line) -> usize {
    line.ev.interp.last_cycle().map_or(2, |b| b.axes[2])
}

/// The words of one hole written as a cycle block (after the cycle code):
/// the plane's two words and the normal axis' at the bottom command `pb`,
/// R at the R command `pr` (program frame), Q scaled with the stroke for
/// G73/G83 — in G90 as coordinates, in G91 as LinuxCNC reads them there
/// (the plane's words from the current point `cur`, R from the initial
/// level, the bottom from R). Returns the text, the levels the controller
/// reads back from it and the hole's in-plane point.
fn hole_words(
    block: &CycleBlock,
    (frame, style, sep): (&Frame, NumberStyle, &str),
    (pb, pr): (Vec3, Vec3),
    cur: Vec3,
    initial: f64,
    q_nudge: f64,
) -> (String, Levels, [f64; 2]) {
    let ax = block.axes;
    let n = ax[2];
    let w = |v: f64| written(frame, style, v);
    let (ta, tb, tr, tc, a, b, r, c);
    if block.absolute {
        let ((t0, v0), (t1, v1)) = (w(pb[ax[0]]), w(pb[ax[1]]));
        let ((t2, v2), (t3, v3)) = (w(pr[n]), w(pb[n]));
        (ta, tb, tr, tc) = (t0, t1, t2, t3);
        (a, b, r, c) = (v0, v1, v2, v3);
    } else {
        let ((t0, v0), (t1, v1)) = (w(pb[ax[0]] - cur[ax[0]]), w(pb[ax[1]] - cur[ax[1]]));
        let (t2, v2) = w(pr[n] - initial);
        let r_read = initial + v2;
        let (t3, v3) = w(pb[n] - r_read);
        (ta, tb, tr, tc) = (t0, t1, t2, t3);
        (a, b, r, c) = (cur[ax[0]] + v0, cur[ax[1]] + v1, r_read, r_read + v3);
    }
    let letter = |i: usize| (b'X' + i as u8) as char;
    let mut text = String::new();
    for (l, t) in [
        (letter(ax[0]), ta),
        (letter(ax[1]), tb),
        (letter(n), tc),
        ('R', tr),
    ] {
        text.push_str(sep);
        text.push(l);
        text.push_str(&t);
    }
    let mut q = 0.0;
    if block.q > 0.0 {
        // Q scaled with the stroke: the pecks fall where the map puts the
        // nominal ones, to first order.
        let ratio = if block.r > block.bottom {
            (r - c) / (block.r - block.bottom)
        } else {
            1.0
        };
        let step = 10f64.powi(-i32::from(frame.decimals));
        let (tq, vq) = w(block.q * ratio + q_nudge * step);
        text.push_str(sep);
        text.push('Q');
        text.push_str(&tq);
        q = vq;
    }
    let levels = Levels {
        initial,
        current: cur[n],
        r,
        bottom: c,
        q,
        peck_clear: block.peck_clear,
    };
    (text, levels, [a, b])
}

/// How far the machine's moves `machine` are from the original's
/// `nominal` (mm): the largest distance of corresponding ends on any axis,
/// `None` where the two are not the same moves (count or kind) — a move
/// the written block makes that the original does not (LinuxCNC's rise to
/// R where the written run restarted below it) would also leave the
/// pairing of `simulate --reference` without its original.
fn path_deviation_mm(nominal: &[(bool, Vec3)], machine: &[(bool, Vec3)]) -> Option<f64> {
    if nominal.len() != machine.len() || nominal.iter().zip(machine).any(|(x, y)| x.0 != y.0) {
        return None;
    }
    Some(
        nominal
            .iter()
            .zip(machine)
            .fold(0.0, |m, (x, y)| m.max((x.1 - y.1).max_abs())),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn levels(initial: f64, current: f64, r: f64, bottom: f64, q: f64) -> Levels {
        Levels {
            initial,
            current,
            r,
            bottom,
            q,
            peck_clear: 0.254,
        }
    }

    fn ends(moves: &[CycleMove]) -> Vec<(bool, f64)> {
        moves.iter().map(|m| (m.feed, m.end[2])).collect()
    }

    #[test]
    fn g83_pecks_retract_to_r_and_come_back_a_peck_clearance_above() {
        // interp_cycles.cc convert_cycle_g83: R2 Z-8 Q3 from 10 (G98):
        // pecks at -1, -4, -7 (-10 is not above -8), each followed by a
        // rapid to R and one to 0.254 above the peck; then the bottom and
        // the initial level.
        let m = block_moves(
            830,
            levels(10.0, 10.0, 2.0, -8.0, 3.0),
            [0.0, 0.0],
            &[[10.0, 20.0]],
            false,
        )
        .unwrap();
        let f = |z| (true, z);
        let r = |z| (false, z);
        assert_eq!(
            ends(&m),
            vec![
                r(10.0),
                r(2.0),
                f(-1.0),
                r(2.0),
                r(-1.0 + 0.254),
                f(-4.0),
                r(2.0),
                r(-4.0 + 0.254),
                f(-7.0),
                r(2.0),
                r(-7.0 + 0.254),
                f(-8.0),
                r(10.0),
            ]
        );
        assert!(m
            .iter()
            .all(|m| m.hole == Some(0) && m.end[..2] == [10.0, 20.0]));
    }

    #[test]
    fn a_stroke_of_whole_pecks_ends_with_the_bottom_not_another_peck() {
        // G73 R1 Z-9 Q2.5: -1.5, -4, -6.5; -9 is not above -9.
        let m = block_moves(
            730,
            levels(10.0, 1.0, 1.0, -9.0, 2.5),
            [0.0, 0.0],
            &[[0.0, 0.0]],
            true,
        )
        .unwrap();
        let feeds: Vec<f64> = m.iter().filter(|m| m.feed).map(|m| m.end[2]).collect();
        assert_eq!(feeds, vec![-1.5, -4.0, -6.5, -9.0]);
        // G99 from R: the first move goes to R at the hole (no rapid above).
        assert_eq!(ends(&m)[0], (false, 1.0));
    }

    #[test]
    fn below_r_the_cycle_first_rises_to_r_and_g98_retracts_there() {
        // convert_cycle_xy: old_cc < r → rapid up to R at the current
        // point, old_cc = r; G98's clear level is then R.
        let m = block_moves(
            810,
            levels(0.5, 0.5, 2.0, -3.0, 0.0),
            [5.0, 6.0],
            &[[7.0, 8.0], [9.0, 8.0]],
            false,
        )
        .unwrap();
        assert_eq!(
            m[0],
            CycleMove {
                feed: false,
                end: [5.0, 6.0, 2.0],
                hole: None
            }
        );
        assert_eq!(
            m[1..].iter().map(|m| (m.feed, m.end)).collect::<Vec<_>>(),
            vec![
                (false, [7.0, 8.0, 2.0]),
                (true, [7.0, 8.0, -3.0]),
                (false, [7.0, 8.0, 2.0]),
                (false, [9.0, 8.0, 2.0]),
                (true, [9.0, 8.0, -3.0]),
                (false, [9.0, 8.0, 2.0]),
            ]
        );
        assert!(block_moves(
            840,
            levels(0.5, 0.5, 2.0, -3.0, 0.0),
            [0.0; 2],
            &[[0.0; 2]],
            false
        )
        .is_none());
    }

    #[test]
    fn the_written_moves_are_compared_with_the_original_move_by_move() {
        let v = |x: f64, z: f64| Vec3::new(x, 0.0, z);
        let nominal = [
            (false, v(10.0, 2.0)),
            (true, v(10.0, -5.0)),
            (false, v(10.0, 2.0)),
        ];
        // The map moves every end by up to 3 µm.
        let machine = [
            (false, v(10.002, 2.001)),
            (true, v(10.002, -4.997)),
            (false, v(10.002, 2.001)),
        ];
        let off = path_deviation_mm(&nominal, &machine).unwrap();
        assert!((off - 0.003).abs() < 1e-12, "{off}");
        // A feed instead of a rapid, a move more or one missing: not the
        // same moves.
        let mut wrong = machine;
        wrong[2].0 = true;
        assert!(path_deviation_mm(&nominal, &wrong).is_none());
        assert!(path_deviation_mm(&nominal, &machine[..2]).is_none());
        let rise = [(false, v(0.0, 2.003)), machine[0], machine[1], machine[2]];
        assert!(path_deviation_mm(&nominal, &rise).is_none());
    }
}
