//! The last piece of a block that holds back its tail under G61
//! (compensate/arcs.rs, [`super::arcs::HeldEnd`]), kept with the tail
//! until the next block is read.
//!
//! A block whose end may be the start of an S-curve into the next arc
//! ends short of its end point, by the part of the S-curve's window
//! before the join (0.03–0.1 mm at F6000 on the example map). Where the
//! next block takes that tail, the S-curve starts there. Where it does not
//! (the next block is a line, a corner, a rapid), the tail used to be
//! written as a piece of its own. Such a piece costs twice:
//!
//! * LinuxCNC caps a segment's speed so that it lasts at least a few
//!   servo periods (tc.c `tcGetMaxTargetVel` / tp.c `tpAddLine`,
//!   "sample_maxvel"): a 0.06 mm piece at a 1 ms period runs at no more
//!   than about 30 mm/s, a near-stop at F6000 where the original runs on;
//! * a take-up found at the block's end is folded into that one short
//!   piece: under G61 a fold within the contour tolerance is written even
//!   where the planner does not take it as tangent (tp.c
//!   `tpSetupTangent`: the kink's acceleration `a_inst·|Δt|` with
//!   `a_inst = v/T + a` against the axis' limit, slowed to `kink_ratio`
//!   of it), so a 2 µm Z step over 0.06 mm turns the path by 2° and
//!   the planner runs it at a few mm/s.
//!
//! So the block's last piece before the tail is kept back with the tail
//! ([`KeptPiece`]): where the next block takes the tail, it is written as
//! it was; where it does not, the block's end is solved again from the
//! command before that piece to the end, as one piece (the plan the
//! block had without holding its tail back), with lead pieces and ramps
//! on it where a take-up asks for them (compensate/points.rs, `Leads`).
//!
//! A line's tail before an arc that turns, at its start, the axis the line
//! holds still takes that axis' band up on the line itself: the tail is
//! solved with the axis' new direction and written as an S of two arcs
//! tangent to the line at both ends ([`LineS`], [`line_s_words`];
//! docs/compensation.md, "A line into an arc that reverses an axis").

use super::frame::Frame;
use super::lines::{ArcWords, OutMode};
use super::{arcs, scurve};
use super::{CompensateSummary, DirectionPolicy, State, Tail, TailPath};
use crate::error::{CompensationError, ModelError};
use crate::model::{Direction, Directions, ErrorModel};
use volcomp_gcode::number::NumberStyle;
use volcomp_gcode::Vec3;

/// The last piece a block wrote before its held tail, kept back: its text
/// (one line), the output's modal motion before and after it, the command
/// it starts from, and where on the block's path it starts (the arc's
/// parameter, or the point on a line).
#[derive(Debug, Clone)]
pub(super) struct KeptPiece {
    pub(super) text: Vec<u8>,
    pub(super) mode_after: Option<OutMode>,
    pub(super) q_prev: Vec3,
    pub(super) at_prev: f64,
    pub(super) t_prev: Vec3,
}

/// What [`State::keep_last_piece`] needs of the block's last piece: where
/// its text begins in the output buffer and the modal motion before it,
/// the command and the path point it starts from, and the arc parameter
/// it starts at (0 on a line).
pub(super) struct LastPieceAt {
    pub(super) text_at: usize,
    pub(super) mode_before: Option<OutMode>,
    pub(super) q_prev: Vec3,
    pub(super) t_prev: Vec3,
    pub(super) at_prev: f64,
}

/// A command and the take-up block before it, if any.
type Command = (Vec3, Option<Vec3>);

/// A held tail solved ([`State::solve_tail`]): the arc piece it runs on
/// (none on a line) and the end parameters of its pieces on it, the
/// commands (each with its take-up block, if any) and the command it
/// starts from.
pub(super) struct SolvedTail {
    pub(super) piece: Option<volcomp_gcode::Arc>,
    pub(super) piece_ends: Vec<f64>,
    pub(super) commands: Vec<Command>,
    pub(super) from: Vec3,
}

/// What solving a tail changes in the state, kept to go back to.
struct Saved {
    q_out: Vec3,
    s: Directions,
    s_nominal: Directions,
    summary: CompensateSummary,
    plunge_held: [bool; 3],
    mode: Option<OutMode>,
}

/// What follows a held tail that no S-curve takes, as far as merging it
/// with its block's last piece goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum After {
    /// A rapid, or the program's end: the cut ends here, and a reversal
    /// left for the rapid costs no contour error.
    CutEnds,
    /// A straight feed move, or nothing known (a line without motion, the
    /// program's end).
    Line,
    /// An arc (the join stays as it was: a piece fitted over the longer
    /// merged span meets the next arc's start less tangentially,
    /// measured on planes_inch, +6…+9 ms a join).
    Arc,
}

impl After {
    /// What the first motion of `line` is (a line without one: unknown).
    pub(super) fn of(line: &super::walk::Line) -> Self {
        match line.ev.motions.first().map(|m| m.kind) {
            Some(volcomp_gcode::MotionKind::Rapid) => Self::CutEnds,
            Some(volcomp_gcode::MotionKind::Arc(_)) => Self::Arc,
            _ => Self::Line,
        }
    }
}

/// Whether a tail solved over the block's last piece too (`merged`) may
/// replace that piece and the tail solved alone: not before an arc
/// ([`After::Arc`]), no take-up block on it, and every axis left in the
/// direction the tail alone leaves it (`s_merged` against `s_alone`) but
/// where the cut ends ([`After::CutEnds`]): a reversal moved into the next cutting move would be
/// taken up there, off the path the tail alone takes it on (measured on
/// pocket_arcs, example map: a ramp along the next line 0.38 µm off).
pub(super) fn merge_keeps_reversals(
    merged: &[Command],
    (s_merged, s_alone): (Directions, Directions),
    after: After,
) -> bool {
    after != After::Arc
        && merged.iter().all(|c| c.1.is_none())
        && (s_merged == s_alone || after == After::CutEnds)
}

/// Whether the text of a block's last piece may be kept back: one whole
/// line (one line end, at its end) after a line end in the buffer
/// (`before`).
pub(super) fn one_line(before: &[u8], piece: &[u8]) -> bool {
    before.ends_with(b"\n")
        && piece.ends_with(b"\n")
        && piece.iter().filter(|b| **b == b'\n').count() == 1
}

impl State<'_> {
    /// Takes the block's last piece out of the output buffer (from
    /// `at.text_at` to its end), where it is one line: the modal motion
    /// goes back to what it was before it and the line is no longer
    /// counted (it is written again, as it was or merged with the tail).
    pub(super) fn keep_last_piece(&mut self, at: LastPieceAt) -> Option<KeptPiece> {
        let piece = self.buf.get(at.text_at..)?;
        if !one_line(&self.buf[..at.text_at], piece) {
            return None;
        }
        let text = piece.to_vec();
        self.buf.truncate(at.text_at);
        let mode_after = self.mode;
        self.mode = at.mode_before;
        self.summary.lines_out -= 1;
        Some(KeptPiece {
            text,
            mode_after,
            q_prev: at.q_prev,
            at_prev: at.at_prev,
            t_prev: at.t_prev,
        })
    }

    /// Keeps back the last piece of the block just written (its commands,
    /// the targets and, on an arc, the pieces' end parameters and words),
    /// with the tail the block holds back: where the piece is one plain
    /// line after another piece of the block (no take-up block before it,
    /// no reversal, hold or ramp at its end, so the state it ends in is the
    /// one it starts in) and the directions are the commanded ones.
    /// `last` is where the piece's text begins and the modal motion before
    /// it.
    pub(super) fn keep_tail_piece(
        &mut self,
        (targets, pieces, arc_words, commands): (&[Vec3], &[f64], &[ArcWords], &[Command]),
        last: (usize, Option<OutMode>),
    ) {
        let n = commands.len();
        if n < 2 {
            return;
        }
        let Some(path) = self.tail.as_ref().map(|t| t.path) else {
            return;
        };
        let plain = self.records.last().is_some_and(|r| {
            !r.take_up && !r.reversed.iter().any(|r| *r) && !r.held.iter().any(|h| *h)
        });
        let ok = self.walk.options.directions == DirectionPolicy::Commanded
            && n >= 2
            && targets.len() == n
            && commands[n - 1].1.is_none()
            && plain
            && self.states.len() == n
            && self.states[n - 1] == self.s
            && self.ramp_mids.get(n - 1).is_none_or(|m| *m == Vec3::ZERO);
        let at_prev = match path {
            TailPath::Arc(_)
                if pieces.len() == n
                    && arc_words.len() == n
                    && arc_words[n - 1].second.is_none() =>
            {
                pieces[n - 2]
            }
            // A line's tail is not kept: merged before a G61 corner, the
            // longer fold costs more than the short piece it replaces
            // (bench/cycle_time's zigzag_40x30 on the planner model:
            // +1.04 % cutting time with line tails alone, +1.38 % merged).
            TailPath::Line(..) | TailPath::Arc(_) => return,
        };
        if !ok {
            return;
        }
        let kept = self.keep_last_piece(LastPieceAt {
            text_at: last.0,
            mode_before: last.1,
            q_prev: commands[n - 2].0,
            t_prev: targets[n - 2],
            at_prev,
        });
        if let Some(t) = self.tail.as_mut() {
            t.kept = kept;
        }
    }

    fn save(&self) -> Saved {
        Saved {
            q_out: self.q_out,
            s: self.s,
            s_nominal: self.s_nominal,
            summary: self.summary.clone(),
            plunge_held: self.plunge_held,
            mode: self.mode,
        }
    }

    fn restore(&mut self, saved: Saved) {
        self.q_out = saved.q_out;
        self.s = saved.s;
        self.s_nominal = saved.s_nominal;
        self.summary = saved.summary;
        self.plunge_held = saved.plunge_held;
        self.mode = saved.mode;
    }

    /// Writes the tail `t` and the block's last piece `kept` as one piece
    /// where [`merge_keeps_reversals`] allows it (the tail solved alone
    /// first, to compare), and says whether it did; else everything is as
    /// before the call.
    pub(super) fn merge_tail(
        &mut self,
        t: &Tail,
        kept: &KeptPiece,
        (next, after): (Option<&volcomp_gcode::Motion>, After),
    ) -> Result<bool, CompensationError> {
        if after == After::Arc {
            return Ok(false);
        }
        let saved = self.save();
        let defer = self.defer_points;
        self.defer_points = true;
        let alone = self.solve_tail(t, None, next);
        let s_alone = self.s;
        self.restore(Saved {
            summary: saved.summary.clone(),
            ..saved
        });
        let merged = alone.and_then(|_| self.solve_tail(t, Some(kept), next));
        self.defer_points = defer;
        let merged = match merged {
            Ok(m) if merge_keeps_reversals(&m.commands, (self.s, s_alone), after) => m,
            Ok(_) => {
                self.restore(saved);
                return Ok(false);
            }
            Err(e) => return Err(e),
        };
        if !defer {
            for r in &self.records {
                (self.on_point)(r);
            }
        }
        self.write_tail(t, merged)?;
        Ok(true)
    }

    /// Writes a kept piece as it was, after what the buffer holds (no
    /// S-curve takes the tail, and the tail is written alone after it).
    pub(super) fn write_kept(&mut self, kept: KeptPiece) {
        if !self.buf.is_empty() && !self.buf.ends_with(b"\n") {
            self.buf.extend_from_slice(b"\n");
        }
        self.buf.extend_from_slice(&kept.text);
        self.mode = kept.mode_after;
        self.summary.lines_out += 1;
    }

    /// Writes a kept piece back as it was, before everything in the
    /// output buffer (the next block takes the tail: its S-curve starts
    /// where the piece ends).
    pub(super) fn put_back(&mut self, kept: KeptPiece) {
        if self.buf.is_empty() {
            self.mode = kept.mode_after;
        }
        self.buf.splice(0..0, kept.text);
        self.summary.lines_out += 1;
    }
}

/// The largest step (µm) the switch of a line's S-curve ([`LineS`]) may
/// make in the plane's normal axis against that axis' direction: the G61
/// contour tolerance under which the adaptive segmentation keeps the path
/// (a step that small held costs no more than the segmentation leaves).
const LINE_S_NORMAL_STEP_UM: f64 = 0.05;

/// The take-up of a line's held tail on the line itself: the axis the arc
/// after the line reverses at its start (the line does not move it), its
/// new direction, and the line's unit tangent in the arc's plane.
#[derive(Debug, Clone, Copy)]
pub(super) struct LineS {
    pub(super) axis: usize,
    pub(super) direction: Direction,
    pub(super) plane: volcomp_gcode::Plane,
    pub(super) tangent: [f64; 2],
}

impl Tail {
    /// Where this tail is a line's and the arc `arc` after it (which may
    /// start from it, [`Tail::may_start`]) turns the axis the line held its
    /// tail for against its state `s`: the take-up on the line
    /// ([`arcs::line_tail`]; docs/compensation.md, "A line into an arc
    /// that reverses an axis").
    ///
    /// Not where the switch moves the command of the plane's normal axis
    /// against that axis' direction by more than [`LINE_S_NORMAL_STEP_UM`]:
    /// that axis would reverse there, so its step is held across the S
    /// and left to the arc's first piece, a kink the planner slows for
    /// (a pocket's R3 corner at F6000, example map: a 0.32 µm Z step over
    /// 0.2 mm, 1.6 mrad, passed at 31 mm/s against 50 mm/s). The S-curve
    /// across the join ([`arcs::plan_transitions`]) spreads such a step
    /// along the arc instead.
    pub(super) fn line_s_curve(
        &self,
        arc: &volcomp_gcode::Arc,
        s: Directions,
        model: &dyn ErrorModel,
    ) -> Result<Option<LineS>, ModelError> {
        let TailPath::Line(start, end) = self.path else {
            return Ok(None);
        };
        let (u, v, w) = arc.plane.axes();
        let a = self.held.axis;
        let d = end - start;
        let length = d.norm();
        // One target on the tail (its end): the S runs from the tail's
        // start to it.
        if self.targets.len() != 1
            || !(a == u || a == v)
            || d[w].abs() > 1e-12 * length
            || d[a].abs() > 1e-12 * length
        {
            return Ok(None);
        }
        // 10 µm along the arc: its start is the quarter point of `a`.
        let step = 0.01 / arc.length().max(1e-9);
        let turns = Direction::of_delta(arc.point_at(step)[a] - arc.start[a]);
        let tangent = self.end_tangent(arc.plane);
        let along = arcs::plane_tangent(arc, 0.0);
        let tangent_join = (tangent[0] * along[0] + tangent[1] * along[1]) > 1.0 - 1e-9;
        if !(tangent_join && turns == Some(s[a].flipped())) {
            return Ok(None);
        }
        // The command's step in the normal axis where `a` switches (the
        // command is the target less the error, docs/design.md).
        let model = crate::model::WithTool {
            model,
            tool_length_offset_mm: self.tool_length_offset_mm,
        };
        let mut s_new = s;
        s_new[a] = s[a].flipped();
        let e_old = model.deviation_um(end, s, crate::model::Components::All)?;
        let e_new = model.deviation_um(end, s_new, crate::model::Components::All)?;
        let step_um = e_old[w] - e_new[w];
        if step_um.abs() > LINE_S_NORMAL_STEP_UM && Direction::of_delta(step_um) != Some(s[w]) {
            return Ok(None);
        }
        Ok(Some(LineS {
            axis: a,
            direction: s[a].flipped(),
            plane: arc.plane,
            tangent,
        }))
    }
}

/// The words of a line's tail written as an S-curve ([`LineS`]): the
/// biarc from `from` to `q` (axis frame) tangent to the line at both ends,
/// of two arcs of one radius ([`scurve::widest_biarc`]), the plane's
/// normal axis shared out by length; `None` where the command does not move
/// the axis the way its new direction says, or the arcs do not read as
/// written ([`ArcWords::readable`]).
pub(super) fn line_s_words(
    ls: &LineS,
    frame: &Frame,
    style: NumberStyle,
    (from, q): (Vec3, Vec3),
) -> Option<ArcWords> {
    if Direction::of_delta(q[ls.axis] - from[ls.axis]) != Some(ls.direction) {
        return None;
    }
    let (u, v, _) = ls.plane.axes();
    let arcs = scurve::widest_biarc([from[u], from[v]], ls.tangent, [q[u], q[v]], ls.tangent)?;
    super::still_s::s_words(ls.plane, &arcs, frame, style, (from, q))
}

#[cfg(test)]
mod tests {
    use super::{merge_keeps_reversals, one_line, After};
    use crate::model::{Direction, ALL_FORWARD};
    use volcomp_gcode::Vec3;

    #[test]
    fn a_merge_moves_no_reversal_into_the_next_cut_and_writes_no_take_up_block() {
        let plain = [(Vec3::new(1.0, 0.0, 0.0), None)];
        let blocked = [(Vec3::new(1.0, 0.0, 0.0), Some(Vec3::new(0.5, 0.0, 0.0)))];
        let same = (ALL_FORWARD, ALL_FORWARD);
        let mut z_back = ALL_FORWARD;
        z_back[2] = Direction::Reverse;
        // Z reverses in the tail alone, not in the merged piece.
        let moved = (ALL_FORWARD, z_back);
        assert!(merge_keeps_reversals(&plain, same, After::Line));
        assert!(merge_keeps_reversals(&plain, same, After::CutEnds));
        assert!(!merge_keeps_reversals(&plain, moved, After::Line));
        assert!(merge_keeps_reversals(&plain, moved, After::CutEnds));
        assert!(!merge_keeps_reversals(&blocked, same, After::Line));
        assert!(!merge_keeps_reversals(&blocked, same, After::CutEnds));
        assert!(!merge_keeps_reversals(&plain, same, After::Arc));
    }

    #[test]
    fn only_one_whole_line_after_a_line_end_is_kept() {
        assert!(one_line(b"G1 X1\n", b"G3 X2 Y1 I1 J0\n"));
        assert!(one_line(b"G1 X1\r\n", b"G3 X2 Y1 I1 J0\r\n"));
        // Two lines (a path-mode line before the piece).
        assert!(!one_line(b"G1 X1\n", b"G64 P0.0001\nG3 X2 Y1 I1 J0\n"));
        // The piece's line does not end (the program's last line).
        assert!(!one_line(b"G1 X1\n", b"G3 X2 Y1 I1 J0"));
        // The buffer before it ends inside a line.
        assert!(!one_line(b"G1 X1", b"G3 X2 Y1 I1 J0\n"));
        // Nothing written.
        assert!(!one_line(b"G1 X1\n", b""));
    }
}
