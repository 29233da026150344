//! Cutter radius compensation (G40, G41, G42, G41.1, G42.1) as LinuxCNC 2.9's
//! interpreter computes it: the tool-centre path, one tool radius beside the
//! programmed path, in the XY (G17) or XZ (G18) plane.
//!
//! The reference is LinuxCNC's source, src/emc/rs274ngc/ (docs/references.md,
//! [LinuxCNC interp]): `Interp::convert_cutter_compensation_on/off`,
//! `convert_straight_comp1/comp2` and `convert_arc_comp1/comp2`
//! (interp_convert.cc), the one-move look-ahead queue (`enqueue_*`,
//! `dequeue_canons`, `move_endpoint_and_flush`, `set_endpoint`,
//! interp_queue.cc) and the arc checks of `arc_data_comp_ijk`/`_r`
//! (interp_arc.cc). The computation is LinuxCNC's, step for step, with its
//! tolerances (`TOLERANCE_CONCAVE_CORNER`, interp_internal.hh):
//!
//! * the first move after G41/G42 (the entry move) ends one radius to the
//!   side of its programmed end, perpendicular to the move;
//! * a convex corner gets an arc about the programmed corner (a G0 a
//!   straight traverse instead); a concave corner pulls the end of the
//!   previous move back to the intersection of the two offset paths: this
//!   is why every move waits in the queue until the next one is known;
//! * G40 lets the last move end where it was; the next move (the exit move)
//!   starts there and goes to its programmed end.
//!
//! The computation runs in the axis frame (mm); while compensation is on the
//! offsets between program and axis frame cannot change (LinuxCNC refuses
//! G54…, G92, G43, G10 L2 of the active system, M6 then), so it is a fixed
//! translation and the geometry is the same as LinuxCNC's in program
//! coordinates. Tolerances LinuxCNC gives in program units are converted.

use super::{invalid, ExtraAxes, Interpreter, Motion, MotionKind, MotionSource};
use crate::arc::{sweep_angle, Arc};
use crate::error::GcodeError;
use crate::geom::{Plane, Units, Vec3};
use std::f64::consts::{FRAC_PI_2, PI};

/// LinuxCNC's `TOLERANCE_CONCAVE_CORNER` (radians, interp_internal.hh).
const TOLERANCE_CONCAVE_CORNER: f64 = 0.05;
/// LinuxCNC's `TOLERANCE_EQUAL` (interp_internal.hh).
const TOLERANCE_EQUAL: f64 = 0.0001;

/// The side of the programmed path the tool is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Side {
    /// G41.
    Left,
    /// G42.
    Right,
}

/// LinuxCNC's `TOOL_INSIDE_ARC(side, turn)`: the tool is inside an arc
/// turning `turn` (> 0 counter-clockwise).
fn tool_inside_arc(side: Side, turn: i32) -> bool {
    (side == Side::Left && turn > 0) || (side == Side::Right && turn < 0)
}

/// Signed angle an arc sweeps from `p1` to `p2` about `c` with `turn`
/// (LinuxCNC's `Interp::find_turn`, interp_find.cc; 0 for `turn` 0).
fn find_turn(p1: [f64; 2], c: [f64; 2], turn: i32, p2: [f64; 2]) -> f64 {
    if turn == 0 {
        return 0.0;
    }
    let a = (p1[1] - c[1]).atan2(p1[0] - c[0]);
    let b = (p2[1] - c[1]).atan2(p2[0] - c[0]);
    sweep_angle(a, b, turn < 0, turn.unsigned_abs())
}

#[derive(Debug, Clone, Copy)]
enum QKind {
    Straight {
        rapid: bool,
        /// Direction of the programmed move in the plane (not normalised).
        dir: [f64; 2],
    },
    Arc {
        center: [f64; 2],
        /// Turns, > 0 counter-clockwise (LinuxCNC's ARC_FEED rotation).
        turn: i32,
        /// The arc's sweep when it was queued (0: "does not matter").
        original_turns: f64,
    },
}

/// A move waiting in the queue (LinuxCNC's `queued_canon`).
#[derive(Debug, Clone, Copy)]
struct Queued {
    kind: QKind,
    /// End in plane coordinates: first, second, normal axis (mm).
    end: [f64; 3],
    line: u64,
    column: usize,
    feed: f64,
    feed_mode: super::FeedMode,
    extra_end: [f64; 6],
}

/// The state of cutter radius compensation while it is on.
#[derive(Debug, Clone)]
pub(super) struct CutterComp {
    side: Side,
    /// Tool radius (mm, ≥ 0).
    radius_mm: f64,
    /// Lathe tool orientation (G41.1/G42.1 L; 0 for a mill).
    orientation: i32,
    /// The plane it was turned on in (G17 or G18).
    plane: Plane,
    /// LinuxCNC's `cutter_comp_firstmove`.
    first_move: bool,
    /// The programmed point (LinuxCNC's `program_x…`), axis frame, mm.
    program: Vec3,
    queue: Vec<Queued>,
    /// LinuxCNC's `endpoint` and `endpoint_valid` (plane coordinates).
    endpoint: Option<[f64; 2]>,
    /// Where the last move given out ended (axis frame) and its extra axes.
    emitted: Vec3,
    emitted_extra: [f64; 6],
}

fn plane_of(p: Vec3, plane: Plane) -> [f64; 3] {
    let (u, v, w) = plane.axes();
    [p[u], p[v], p[w]]
}

fn from_plane(c: [f64; 3], plane: Plane) -> Vec3 {
    let (u, v, w) = plane.axes();
    let mut p = Vec3::ZERO;
    p[u] = c[0];
    p[v] = c[1];
    p[w] = c[2];
    p
}

impl CutterComp {
    /// LinuxCNC's `latheorigin_x`/`latheorigin_z` (interp_queue.cc): a lathe
    /// tool's controlled point is not its nose centre. `c` is in plane
    /// coordinates of G18 (first Z, second X).
    fn lathe_origin(&self, mut c: [f64; 2]) -> [f64; 2] {
        if self.plane != Plane::Zx {
            return c;
        }
        let (o, r) = (self.orientation, self.radius_mm);
        if matches!(o, 2 | 6 | 1) {
            c[1] -= r;
        }
        if matches!(o, 3 | 8 | 4) {
            c[1] += r;
        }
        if matches!(o, 2 | 7 | 3) {
            c[0] -= r;
        }
        if matches!(o, 1 | 5 | 4) {
            c[0] += r;
        }
        c
    }
}

/// Errors of the cutter compensation, with LinuxCNC's message.
fn comp_error(line: u64, col: usize, linuxcnc: &str, help: &str) -> GcodeError {
    invalid(
        line,
        col,
        format!("cutter radius compensation: LinuxCNC refuses this (\"{linuxcnc}\")"),
        help,
    )
}

const HELP_GOUGE: &str = "the tool does not fit: use a smaller tool (its diameter in the set-up's [tool_diameters] or the D word), or change the path";

impl Interpreter {
    /// 410 or 420 while G41 or G42 (G41.1, G42.1) is in effect, as
    /// LinuxCNC's `#<_ccomp>` (interp_namedparams.cc; a negative diameter
    /// shows the side actually used).
    pub(super) fn comp_side_code(&self) -> Option<f64> {
        self.comp.as_ref().map(|c| match c.side {
            Side::Left => 410.0,
            Side::Right => 420.0,
        })
    }

    /// Whether G41/G42 is in effect with a radius above 0, so that moves are
    /// offset (and given out one block late).
    pub fn cutter_comp_offsetting(&self) -> bool {
        self.comp_active()
    }

    /// Whether G41/G42 (or G41.1/G42.1) is in effect.
    pub fn cutter_comp_on(&self) -> bool {
        self.comp.is_some()
    }

    /// The point the words of a block are relative to: LinuxCNC's
    /// `find_ends` (interp_find.cc) takes the programmed point, not the
    /// tool's, while compensation is computing a path.
    pub(super) fn words_base(&self) -> Vec3 {
        match &self.comp {
            Some(c) if c.radius_mm > 0.0 && !c.first_move => c.program,
            _ => self.position,
        }
    }

    /// Whether this block's motion goes through the compensation.
    pub(super) fn comp_active(&self) -> bool {
        self.comp.as_ref().is_some_and(|c| c.radius_mm > 0.0)
    }

    /// The feed of a compensated move: under inverse time (G93) LinuxCNC
    /// runs it, corner arcs included, at the programmed length times F
    /// (at least 0.1 units/min; `inverse_time_rate_straight`/`_arc`,
    /// interp_inverse.cc), in mm/min here.
    fn comp_feed_mm(&self, feed_mm: f64, programmed_length_mm: f64) -> f64 {
        if self.feed_mode != super::FeedMode::InverseTime {
            return feed_mm;
        }
        let length = programmed_length_mm / self.units.mm_per_unit();
        self.to_mm((length * self.feed).max(0.1))
    }

    fn mm_tol(&self, program_units: f64) -> f64 {
        program_units * self.units.mm_per_unit()
    }

    /// G41/G42/G41.1/G42.1 (`convert_cutter_compensation_on`).
    pub(super) fn comp_on(
        &mut self,
        line: u64,
        col: usize,
        code: u16,
        d: Option<(f64, usize)>,
        l: Option<f64>,
    ) -> Result<(), GcodeError> {
        let name = match code {
            410 => "G41",
            420 => "G42",
            411 => "G41.1",
            _ => "G42.1",
        };
        if self.plane == Plane::Yz {
            return Err(comp_error(
                line,
                col,
                "Cutter radius compensation allowed only in XY, XZ planes",
                "select G17 (XY) or G18 (XZ) before turning compensation on",
            ));
        }
        if self.comp.is_some() {
            return Err(comp_error(
                line,
                col,
                "Cannot turn cutter radius comp on when on",
                "turn it off with G40 first",
            ));
        }
        if self.rotation() != 0.0 {
            return Err(invalid(
                line,
                col,
                "cutter radius compensation in a rotated coordinate system (G10 L2 R) is not computed by volcomp",
                "post this part without the rotation",
            ));
        }
        let mut side = if code == 410 || code == 411 {
            Side::Left
        } else {
            Side::Right
        };
        let (radius_prog, orientation) = if code == 411 || code == 421 {
            let Some((dv, _)) = d else {
                return Err(comp_error(
                    line,
                    col,
                    &format!("{name} with no D word"),
                    "give the tool diameter with D",
                ));
            };
            let orientation = match l {
                Some(l) => {
                    if self.plane != Plane::Zx {
                        return Err(comp_error(
                            line,
                            col,
                            &format!("{name} with L word, but plane is not G18"),
                            "the L word (lathe tool orientation) needs G18",
                        ));
                    }
                    l as i32
                }
                None => 0,
            };
            (dv / 2.0, orientation)
        } else {
            let tool = match d {
                None => self.loaded_tool,
                Some((dv, dcol)) => {
                    let t = (dv + 0.5) as i64;
                    if (t as f64 - dv).abs() >= 0.0001 {
                        return Err(comp_error(
                            line,
                            dcol,
                            &format!("{name} requires D word to be a whole number"),
                            "D is a tool number with G41/G42 (use G41.1/G42.1 D to give a diameter)",
                        ));
                    }
                    if t < 0 {
                        return Err(comp_error(
                            line,
                            dcol,
                            "Negative d word tool radius index used",
                            "D is a tool number",
                        ));
                    }
                    if t == 0 {
                        self.loaded_tool
                    } else {
                        t as u32
                    }
                }
            };
            let diameter_mm = if tool == 0 {
                // LinuxCNC's tool 0 (no tool in the spindle) has diameter 0:
                // compensation is on but offsets by nothing.
                self.warn_once_no_tool(line, col);
                0.0
            } else {
                match self.setup.tool_diameters_mm.get(&tool) {
                    Some(d) => *d,
                    None => {
                        return Err(invalid(
                            line,
                            d.map_or(col, |(_, c)| c),
                            format!("{name} uses tool {tool}, whose diameter the set-up does not give; LinuxCNC takes it from its tool table"),
                            format!("give tool {tool}'s diameter in the set-up file's [tool_diameters] table"),
                        ))
                    }
                }
            };
            // The orientation from the tool table (G10 L1 Q; 0 for a mill).
            let orientation = self.tool_lathe.get(&tool).map_or(0, |v| v[2] as i32);
            (diameter_mm / 2.0 / self.units.mm_per_unit(), orientation)
        };
        if self.plane != Plane::Zx && orientation != 0 && orientation != 9 {
            return Err(comp_error(
                line,
                col,
                &format!("{name} with lathe tool, but plane is not G18"),
                "select G18",
            ));
        }
        let mut radius_mm = self.to_mm(radius_prog);
        if radius_mm < 0.0 {
            radius_mm = -radius_mm;
            side = if side == Side::Left {
                Side::Right
            } else {
                Side::Left
            };
        }
        self.comp = Some(Box::new(CutterComp {
            side,
            radius_mm,
            orientation,
            plane: self.plane,
            first_move: true,
            program: self.position,
            queue: Vec::new(),
            endpoint: None,
            emitted: self.position,
            emitted_extra: self.extra,
        }));
        Ok(())
    }

    fn warn_once_no_tool(&mut self, line: u64, col: usize) {
        self.warnings.push(super::Warning {
            line,
            column: col + 1,
            message: "cutter radius compensation with no tool in the spindle (no M6 yet) and no D word: the radius is 0, as in LinuxCNC, so the path is not offset".into(),
        });
    }

    /// G40 (`convert_cutter_compensation_off`): the last move keeps its end,
    /// and the next move starts from there toward its programmed end.
    pub(super) fn comp_off(
        &mut self,
        line: u64,
        col: usize,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        let Some(c) = self.comp.as_ref() else {
            return Ok(());
        };
        if c.radius_mm > 0.0 && !c.first_move {
            let cur = plane_of(self.position, c.plane);
            self.move_endpoint_and_flush(line, col, [cur[0], cur[1]], out)?;
            let c = self.comp.as_ref().expect("on");
            let (tool, program) = (c.emitted, c.program);
            self.motion_start = Some(tool);
            self.position = program;
            self.arc_not_allowed = true;
        }
        self.comp = None;
        Ok(())
    }

    /// Gives out the queued moves with their ends moved to the program stop
    /// (M0, M1, M2, M30, M60: `convert_stop` flushes the queue).
    pub(super) fn comp_flush_at_stop(
        &mut self,
        line: u64,
        col: usize,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        let Some(c) = self.comp.as_ref() else {
            return Ok(());
        };
        let cur = plane_of(self.position, c.plane);
        self.move_endpoint_and_flush(line, col, [cur[0], cur[1]], out)
    }

    /// What LinuxCNC refuses while compensation is on (each check where
    /// interp_convert.cc makes it: `convert_set_plane`, `convert_m`,
    /// `convert_tool_length_offset`, `convert_coordinate_system`,
    /// `convert_axis_offsets`, `convert_home`, `convert_savehome`,
    /// `convert_control_mode`, `convert_retract_mode`, `convert_cycle`,
    /// `convert_spline`/`convert_nurbs`, `convert_setup`).
    pub(super) fn comp_refusals(
        &self,
        line: u64,
        w: &super::words::WordTable,
    ) -> Result<(), GcodeError> {
        if self.comp.is_none() {
            return Ok(());
        }
        let g = |codes: &[u16]| codes.iter().find_map(|c| w.g_col(*c));
        // What LinuxCNC checks after step 13 (tool length offsets, work
        // systems, offsets, G28/G30, control and retract modes, motions,
        // G10) passes when the block's own G40 has turned compensation off.
        let g40 = w.has_g(400);
        let after_g40 = |col: Option<usize>| col.filter(|_| !g40);
        let m = |codes: &[u16]| codes.iter().find_map(|c| w.m_col(*c));
        let plane_code = match self.plane {
            Plane::Xy => 170,
            Plane::Zx => 180,
            Plane::Yz => 190,
        };
        let other_plane = [170u16, 180, 190]
            .into_iter()
            .filter(|c| *c != plane_code)
            .find_map(|c| w.g_col(c));
        let p_active = w.get(b'P').map(|p| p.round() as i64);
        let p_nonzero = w.get(b'P') != Some(0.0);
        let checks: [(Option<usize>, &str); 17] = [
            (
                other_plane,
                "Cannot change planes with cutter radius compensation on",
            ),
            (
                after_g40(g(&[410, 420, 411, 421])),
                "Cannot turn cutter radius comp on when on",
            ),
            (
                m(&[60]),
                "Cannot change tools with cutter radius compensation on",
            ),
            (
                after_g40(g(&[430, 431, 490])),
                "Cannot change tool offset with cutter radius compensation on",
            ),
            (
                after_g40(g(&[540, 550, 560, 570, 580, 590, 591, 592, 593])),
                "Cannot change coordinate systems with cutter radius compensation on",
            ),
            (
                after_g40(g(&[520, 920, 921, 922, 923])),
                "Cannot change axis offsets with cutter radius comp",
            ),
            (
                after_g40(g(&[280, 300])),
                "Cannot use g28 or g30 with cutter radius comp",
            ),
            (
                after_g40(g(&[281, 301])),
                "Cannot set reference point with cutter compensation in effect",
            ),
            (
                after_g40(g(&[610, 611, 640])),
                "Cannot change control mode with cutter radius compensation on",
            ),
            (
                after_g40(g(&[980, 990])),
                "Cannot change retract mode with cutter radius compensation on",
            ),
            (
                after_g40(g(&super::words::CYCLE_CODES)),
                "Cannot use canned cycles with cutter compensation on",
            ),
            (
                after_g40(g(&[50, 51, 52, 53])),
                "Cannot convert spline with cutter radius compensation",
            ),
            (
                after_g40(g(&[100]).filter(|_| {
                    matches!(w.get(b'L').map(|l| l.round() as i64), Some(2 | 20))
                        && (p_active == Some(0) || p_active == Some(self.work as i64 + 1))
                })),
                "Cannot change the active coordinate system with cutter radius compensation on",
            ),
            (
                m(&[620, 630]),
                "Cannot set motion output with cutter radius compensation on",
            ),
            (
                m(&[670]),
                "Cannot set motion analog output with cutter radius compensation on",
            ),
            (
                m(&[490]),
                "Cannot disable overrides with cutter radius compensation on",
            ),
            (
                m(&[480]).or(m(&[500, 510, 520, 530]).filter(|_| p_nonzero)),
                "Cannot enable overrides with cutter radius compensation on",
            ),
        ];
        for (col, msg) in checks {
            if let Some(col) = col {
                return Err(comp_error(
                    line,
                    col,
                    msg,
                    "turn compensation off with G40 before this block",
                ));
            }
        }
        Ok(())
    }

    /// Whether a move is still waiting for the next block.
    pub fn comp_pending(&self) -> bool {
        self.comp.as_ref().is_some_and(|c| !c.queue.is_empty())
    }

    fn comp_ref(&self) -> &CutterComp {
        self.comp.as_ref().expect("cutter compensation is on")
    }

    fn comp_mut(&mut self) -> &mut CutterComp {
        self.comp.as_mut().expect("cutter compensation is on")
    }

    fn enqueue(&mut self, kind: QKind, end: [f64; 3], line: u64, column: usize, feed: f64) {
        let extra_end = self.extra_target;
        let feed_mode = self.feed_mode;
        self.comp_mut().queue.push(Queued {
            kind,
            end,
            line,
            column,
            feed,
            feed_mode,
            extra_end,
        });
    }

    fn set_endpoint(&mut self, p: [f64; 2]) {
        self.comp_mut().endpoint = Some(p);
    }

    /// `dequeue_canons`: gives out every queued move.
    fn dequeue(&mut self, out: &mut Vec<Motion>) -> Result<(), GcodeError> {
        // LinuxCNC refuses a path-control mode change while compensation is
        // on: the mode now is the one of every queued move.
        let path_mode = self.path_mode;
        let c = self.comp.as_mut().expect("cutter compensation is on");
        c.endpoint = None;
        let plane = c.plane;
        let queue = std::mem::take(&mut c.queue);
        for q in queue {
            let end2 = c.lathe_origin([q.end[0], q.end[1]]);
            let end = from_plane([end2[0], end2[1], q.end[2]], plane);
            super::motion::check_reach(q.line, q.column, "end point", end)?;
            let start = c.emitted;
            let kind = match q.kind {
                QKind::Straight { rapid: true, .. } => MotionKind::Rapid,
                QKind::Straight { rapid: false, .. } => MotionKind::Feed,
                QKind::Arc { center, turn, .. } => {
                    let cc = c.lathe_origin(center);
                    let s = plane_of(start, plane);
                    let center = from_plane([cc[0], cc[1], s[2]], plane);
                    let a0 = (s[1] - cc[1]).atan2(s[0] - cc[0]);
                    let a1 = (end2[1] - cc[1]).atan2(end2[0] - cc[0]);
                    let sweep_rad = sweep_angle(a0, a1, turn < 0, turn.unsigned_abs());
                    super::motion::check_reach(q.line, q.column, "arc centre", center)?;
                    MotionKind::Arc(Arc {
                        start,
                        end,
                        center,
                        plane,
                        sweep_rad,
                    })
                }
            };
            out.push(Motion {
                kind,
                source: MotionSource::CutterComp,
                start,
                end,
                line: q.line,
                column: q.column + 1,
                feed: q.feed,
                feed_mode: q.feed_mode,
                path_mode,
                extra: ExtraAxes {
                    start: c.emitted_extra,
                    end: q.extra_end,
                },
            });
            c.emitted = end;
            c.emitted_extra = q.extra_end;
        }
        Ok(())
    }

    /// `move_endpoint_and_flush`: moves the end of every queued move to `p`
    /// (a concave corner's intersection), checking that no move turns back
    /// (the tool would gouge), then gives them out.
    fn move_endpoint_and_flush(
        &mut self,
        line: u64,
        col: usize,
        p: [f64; 2],
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        let units = self.units;
        let bug_tol_mm = self.mm_tol(0.01);
        let c = self.comp_mut();
        if c.queue.is_empty() {
            return Ok(());
        }
        let endpoint = c.endpoint;
        for q in c.queue.iter_mut() {
            match &mut q.kind {
                QKind::Arc {
                    center,
                    turn,
                    original_turns,
                } => {
                    let r1 = (q.end[0] - center[0]).hypot(q.end[1] - center[1]);
                    let r2 = (p[0] - center[0]).hypot(p[1] - center[1]);
                    if (r1 - r2).abs() > bug_tol_mm {
                        return Err(comp_error(
                            q.line,
                            col,
                            &format!("BUG: cutter compensation has generated an invalid arc with mismatched radii r1 {:.6} r2 {:.6}", r1 / units.mm_per_unit(), r2 / units.mm_per_unit()),
                            "LinuxCNC refuses this program too; change the path near this corner",
                        ));
                    }
                    if let Some(e) = endpoint {
                        let l2 = find_turn(e, *center, *turn, p);
                        let tol = match units {
                            Units::Mm => 0.0254,
                            Units::Inch => 0.001,
                        };
                        if *original_turns != 0.0 && l2.abs() > original_turns.abs() + tol {
                            return Err(comp_error(
                                line,
                                col,
                                "Arc move in concave corner cannot be reached by the tool without gouging",
                                HELP_GOUGE,
                            ));
                        }
                    }
                }
                QKind::Straight { rapid, dir } => {
                    if let Some(e) = endpoint {
                        let dot = dir[0] * (p[0] - e[0]) + dir[1] * (p[1] - e[1]);
                        if dot < 0.0 {
                            let what = if *rapid {
                                "Straight traverse in concave corner cannot be reached by the tool without gouging"
                            } else {
                                "Straight feed in concave corner cannot be reached by the tool without gouging"
                            };
                            return Err(comp_error(line, col, what, HELP_GOUGE));
                        }
                    }
                }
            }
            q.end[0] = p[0];
            q.end[1] = p[1];
        }
        self.dequeue(out)?;
        self.set_endpoint(p);
        Ok(())
    }

    /// A G0/G1 while compensation is on (`convert_straight_comp1/comp2`).
    pub(super) fn comp_straight(
        &mut self,
        line: u64,
        col: usize,
        rapid: bool,
        target: Vec3,
        feed: f64,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        let feed = self.comp_feed_mm(feed, (target - self.words_base()).norm());
        let c = self.comp_ref();
        let plane = c.plane;
        let (side, radius) = (c.side, c.radius_mm);
        let p = plane_of(target, plane);
        let (px, py, pz) = (p[0], p[1], p[2]);
        let cur = plane_of(self.position, plane);
        let (cx, cy, cz) = (cur[0], cur[1], cur[2]);
        if c.first_move {
            let distance = (px - cx).hypot(py - cy);
            if distance <= radius {
                return Err(comp_error(
                    line,
                    col,
                    "Length of cutter compensation entry move is not greater than the tool radius",
                    "start the entry move further than one tool radius from its end",
                ));
            }
            let alpha = (py - cy).atan2(px - cx)
                + if side == Side::Left {
                    PI / 2.0
                } else {
                    -PI / 2.0
                };
            let end = [px + radius * alpha.cos(), py + radius * alpha.sin(), pz];
            self.set_endpoint([cx, cy]);
            self.enqueue(
                QKind::Straight {
                    rapid,
                    dir: [alpha.cos(), alpha.sin()],
                },
                end,
                line,
                col,
                feed,
            );
            let c = self.comp_mut();
            c.first_move = false;
            c.program = target;
            self.position = from_plane(end, plane);
            self.extra = self.extra_target;
            return Ok(());
        }
        let op = plane_of(c.program, plane);
        let (opx, opy) = (op[0], op[1]);
        let mut end = [cx, cy];
        if py == opy && px == opx {
            // No motion in the plane: along the normal axis only.
            self.enqueue(
                QKind::Straight {
                    rapid,
                    dir: [px - opx, py - opy],
                },
                [cx, cy, pz],
                line,
                col,
                feed,
            );
        } else {
            let mut theta = (cy - opy).atan2(cx - opx);
            let mut alpha = (py - opy).atan2(px - opx);
            let (beta, gamma) = if side == Side::Left {
                if theta < alpha {
                    theta += 2.0 * PI;
                }
                (theta - alpha - FRAC_PI_2, FRAC_PI_2)
            } else {
                if alpha < theta {
                    alpha += 2.0 * PI;
                }
                (alpha - theta - FRAC_PI_2, -FRAC_PI_2)
            };
            end = [
                px + radius * (alpha + gamma).cos(),
                py + radius * (alpha + gamma).sin(),
            ];
            let mut mid = [
                opx + radius * (alpha + gamma).cos(),
                opy + radius * (alpha + gamma).sin(),
            ];
            let small = TOLERANCE_CONCAVE_CORNER;
            let front_arc_turn = match self.comp_ref().queue.first().map(|q| q.kind) {
                Some(QKind::Arc { turn, .. }) => Some(turn),
                _ => None,
            };
            let concave = if beta < -small || beta > PI + small {
                true
            } else {
                // The "h" shape: the previous move is an arc the tool is
                // outside of and the corner is nearly straight back; LinuxCNC
                // forces the concave way round.
                beta > PI - small
                    && front_arc_turn.is_some_and(|t| {
                        (side == Side::Right && t > 0) || (side == Side::Left && t < 0)
                    })
            };
            if !concave && beta > small {
                // Convex corner: an arc about the programmed corner.
                self.move_endpoint_and_flush(line, col, [cx, cy], out)?;
                if !rapid {
                    self.enqueue(
                        QKind::Arc {
                            center: [opx, opy],
                            turn: if side == Side::Left { -1 } else { 1 },
                            original_turns: 0.0,
                        },
                        [mid[0], mid[1], cz],
                        line,
                        col,
                        feed,
                    );
                } else {
                    self.enqueue(
                        QKind::Straight {
                            rapid: true,
                            dir: [0.0, 0.0],
                        },
                        [mid[0], mid[1], cz],
                        line,
                        col,
                        feed,
                    );
                }
                self.dequeue(out)?;
                self.set_endpoint(mid);
            } else if concave {
                match self.comp_ref().queue.first().map(|q| q.kind) {
                    Some(QKind::Arc {
                        center,
                        turn: pturn,
                        ..
                    }) => {
                        // arc → line
                        let prev_end = self.comp_ref().queue[0].end;
                        let oldrad = (center[1] - prev_end[1]).hypot(center[0] - prev_end[0]);
                        let base_dir = (py - opy).atan2(px - opx);
                        let theta = if pturn > 0 {
                            base_dir + FRAC_PI_2
                        } else {
                            base_dir - FRAC_PI_2
                        };
                        let phi = (center[1] - opy).atan2(center[0] - opx);
                        let inside = tool_inside_arc(side, pturn);
                        let oldrad_uncomp = if inside {
                            oldrad + radius
                        } else {
                            oldrad - radius
                        };
                        let d = oldrad_uncomp * (theta - phi).cos();
                        let d2 = if inside { d - radius } else { d + radius };
                        let l = d2 / oldrad;
                        if !(-1.0..=1.0).contains(&l) {
                            return Err(comp_error(
                                line,
                                col,
                                "Arc to straight motion makes a corner the compensated tool can't fit in without gouging",
                                HELP_GOUGE,
                            ));
                        }
                        let angle = if inside == (pturn > 0) {
                            -l.acos() + theta + PI
                        } else {
                            l.acos() + theta + PI
                        };
                        mid = [
                            center[0] + oldrad * angle.cos(),
                            center[1] + oldrad * angle.sin(),
                        ];
                        self.move_endpoint_and_flush(line, col, mid, out)?;
                    }
                    _ => {
                        // line → line
                        let halfcorner = (beta + PI) / 2.0;
                        if halfcorner == 0.0 {
                            return Err(comp_error(
                                line,
                                col,
                                "Zero degree inside corner is invalid for cutter compensation",
                                "the path turns straight back: change it",
                            ));
                        }
                        let retreat = radius / halfcorner.tan();
                        mid = [
                            cx + retreat * (theta + gamma).cos(),
                            cy + retreat * (theta + gamma).sin(),
                        ];
                        self.move_endpoint_and_flush(line, col, mid, out)?;
                    }
                }
            } else {
                // Straight on, or tangent arc → line.
                self.dequeue(out)?;
                self.set_endpoint([cx, cy]);
            }
            self.enqueue(
                QKind::Straight {
                    rapid,
                    dir: [px - opx, py - opy],
                },
                [end[0], end[1], pz],
                line,
                col,
                feed,
            );
        }
        let c = self.comp_mut();
        c.program = target;
        self.position = from_plane([end[0], end[1], pz], plane);
        self.extra = self.extra_target;
        Ok(())
    }

    /// A G2/G3 while compensation is on (`convert_arc_comp1/comp2`).
    pub(super) fn comp_arc(
        &mut self,
        line: u64,
        col: usize,
        w: &super::words::WordTable,
        clockwise: bool,
        feed: f64,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        let c = self.comp_ref();
        let plane = c.plane;
        let (side, radius, first) = (c.side, c.radius_mm, c.first_move);
        let program_start = if first { self.position } else { c.program };
        let turns = match w.get(b'P') {
            None => 1,
            Some(p) => super::motion::arc_turns(p)
                .map_err(|why| invalid(line, w.col(b'P').unwrap_or(0), why, "fix the P word"))?
                as i32,
        };
        let turn = if clockwise { -turns } else { turns };
        // The programmed arc, from the programmed point (the tool's at the
        // entry move), with volcomp's checks, which are LinuxCNC's
        // `arc_data_ijk`/`arc_data_r`.
        let tool_at = self.position;
        self.position = program_start;
        let programmed = self.arc(line, col, w, clockwise);
        self.position = tool_at;
        let programmed = programmed?;
        let helix_mm = plane_of(programmed.end, plane)[2] - plane_of(programmed.start, plane)[2];
        let feed = self.comp_feed_mm(
            feed,
            (programmed.start_radius() * programmed.sweep_rad.abs()).hypot(helix_mm),
        );
        let inside_by_code =
            (side == Side::Left && !clockwise) || (side == Side::Right && clockwise);
        let cur = plane_of(self.position, plane);
        let (cx, cy, cz) = (cur[0], cur[1], cur[2]);
        let e = plane_of(programmed.end, plane);
        let (end_x, end_y, end_z) = (e[0], e[1], e[2]);
        let cen = plane_of(programmed.center, plane);
        let (centerx, centery) = (cen[0], cen[1]);
        let spiral_abs_tol = self.mm_tol(match self.units {
            Units::Mm => 2.0 * 0.01 * std::f64::consts::SQRT_2,
            Units::Inch => 2.0 * 0.001 * std::f64::consts::SQRT_2,
        });
        let not_less = || {
            comp_error(
                line,
                col,
                "Tool radius not less than arc radius with comp",
                "the tool is inside an arc no larger than itself: use a smaller tool or a larger arc",
            )
        };
        if first {
            if (end_x - cx).hypot(end_y - cy) <= radius {
                return Err(comp_error(
                    line,
                    col,
                    "Radius of cutter compensation entry arc is not greater than the tool radius",
                    "start the entry arc further than one tool radius from its end",
                ));
            }
            let arc_radius = match w.get(b'R') {
                Some(r) => self.to_mm(r).abs(),
                None => programmed.start_radius(),
            };
            if arc_radius <= radius && inside_by_code {
                return Err(not_less());
            }
            let gamma = if tool_inside_arc(side, turn) {
                (centery - end_y).atan2(centerx - end_x)
            } else {
                (end_y - centery).atan2(end_x - centerx)
            };
            let c = self.comp_mut();
            c.first_move = false;
            c.program = programmed.end;
            let ex = end_x + radius * gamma.cos();
            let ey = end_y + radius * gamma.sin();
            let b_len = (cy - ey).hypot(cx - ex) / 2.0;
            let ab_ang = (centery - ey).atan2(centerx - ex);
            let a_ang = (cy - ey).atan2(cx - ex) - ab_ang;
            if a_ang.cos().abs() < TOLERANCE_EQUAL {
                return Err(not_less());
            }
            let c_len = b_len / a_ang.cos();
            let ncx = ex + c_len * ab_ang.cos();
            let ncy = ey + c_len * ab_ang.sin();
            if ((ncx - ex).hypot(ncy - ey) - (ncx - cx).hypot(ncy - cy)).abs() > spiral_abs_tol {
                return Err(comp_error(
                    line,
                    col,
                    "Bug in tool radius comp",
                    "LinuxCNC refuses this entry arc too; enter with a straight move",
                ));
            }
            let orientation = self.comp_ref().orientation;
            if orientation != 0 && orientation != 9 {
                self.enqueue(
                    QKind::Straight {
                        rapid: false,
                        dir: [0.0, 0.0],
                    },
                    [cx, cy, cz],
                    line,
                    col,
                    feed,
                );
                self.set_endpoint([cx, cy]);
            }
            self.enqueue(
                QKind::Arc {
                    center: [ncx, ncy],
                    turn,
                    original_turns: find_turn([cx, cy], [ncx, ncy], turn, [ex, ey]),
                },
                [ex, ey, end_z],
                line,
                col,
                feed,
            );
            self.position = from_plane([ex, ey, end_z], plane);
            self.extra = self.extra_target;
            return Ok(());
        }
        let op = plane_of(program_start, plane);
        let (opx, opy) = (op[0], op[1]);
        let arc_radius = (centerx - end_x).hypot(centery - end_y);
        let mut theta = (cy - opy).atan2(cx - opx);
        theta = if side == Side::Left {
            theta - FRAC_PI_2
        } else {
            theta + FRAC_PI_2
        };
        let mut delta = (centery - opy).atan2(centerx - opx);
        let alpha = if !clockwise {
            delta - FRAC_PI_2
        } else {
            delta + FRAC_PI_2
        };
        let mut beta = if side == Side::Left {
            theta - alpha
        } else {
            alpha - theta
        };
        beta = if beta > 1.5 * PI {
            beta - 2.0 * PI
        } else if beta < -FRAC_PI_2 {
            beta + 2.0 * PI
        } else {
            beta
        };
        let gamma;
        if inside_by_code {
            gamma = (centery - end_y).atan2(centerx - end_x);
            if arc_radius <= radius {
                return Err(not_less());
            }
        } else {
            gamma = (end_y - centery).atan2(end_x - centerx);
            delta += PI;
        }
        let new_end = [end_x + radius * gamma.cos(), end_y + radius * gamma.sin()];
        let small = TOLERANCE_CONCAVE_CORNER;
        let main_arc = |this: &mut Self| {
            this.enqueue(
                QKind::Arc {
                    center: [centerx, centery],
                    turn,
                    original_turns: find_turn([opx, opy], [centerx, centery], turn, [end_x, end_y]),
                },
                [new_end[0], new_end[1], end_z],
                line,
                col,
                feed,
            );
        };
        if beta < -small
            || beta > PI + small
            || ((beta - PI).abs() < small && !tool_inside_arc(side, turn))
        {
            // Concave corner.
            let front = self.comp_ref().queue.first().copied();
            match front.map(|q| (q.kind, q.end)) {
                Some((
                    QKind::Arc {
                        center: pc,
                        turn: pturn,
                        ..
                    },
                    pend,
                )) => {
                    // arc → arc
                    let oldrad = (pc[1] - pend[1]).hypot(pc[0] - pend[0]);
                    let newrad = if tool_inside_arc(side, turn) {
                        arc_radius - radius
                    } else {
                        arc_radius + radius
                    };
                    let arc_cc = (pc[1] - centery).hypot(pc[0] - centerx);
                    if oldrad == 0.0 || arc_cc == 0.0 {
                        return Err(comp_error(
                            line,
                            col,
                            "Arc to arc motion is invalid because the arcs have the same center",
                            "change the path near this corner",
                        ));
                    }
                    let a = (oldrad * oldrad + arc_cc * arc_cc - newrad * newrad)
                        / (2.0 * oldrad * arc_cc);
                    if !(-1.0..=1.0).contains(&a) {
                        return Err(comp_error(
                            line,
                            col,
                            "Arc to arc motion makes a corner the compensated tool can't fit in without gouging",
                            HELP_GOUGE,
                        ));
                    }
                    let pullback = a.acos();
                    let cc_dir = (centery - pc[1]).atan2(centerx - pc[0]);
                    let dir = if tool_inside_arc(side, pturn) == (turn > 0) {
                        cc_dir + pullback
                    } else {
                        cc_dir - pullback
                    };
                    let mid = [pc[0] + oldrad * dir.cos(), pc[1] + oldrad * dir.sin()];
                    self.move_endpoint_and_flush(line, col, mid, out)?;
                }
                _ => {
                    // line → arc
                    let ccy = arc_radius * (beta - FRAC_PI_2).sin();
                    let (dist_from_center, angle_from_center);
                    if tool_inside_arc(side, turn) {
                        dist_from_center = arc_radius - radius;
                        let l = (ccy + radius) / dist_from_center;
                        if !(-1.0..=1.0).contains(&l) {
                            return Err(comp_error(
                                line,
                                col,
                                "Arc move in concave corner cannot be reached by the tool without gouging",
                                HELP_GOUGE,
                            ));
                        }
                        angle_from_center = if turn > 0 {
                            theta + l.asin()
                        } else {
                            theta - l.asin()
                        };
                    } else {
                        dist_from_center = arc_radius + radius;
                        let l = (ccy - radius) / dist_from_center;
                        if !(-1.0..=1.0).contains(&l) {
                            return Err(comp_error(
                                line,
                                col,
                                "Arc move in concave corner cannot be reached by the tool without gouging",
                                HELP_GOUGE,
                            ));
                        }
                        angle_from_center = if turn > 0 {
                            theta + PI - l.asin()
                        } else {
                            theta + PI + l.asin()
                        };
                    }
                    let mid = [
                        centerx + dist_from_center * angle_from_center.cos(),
                        centery + dist_from_center * angle_from_center.sin(),
                    ];
                    self.move_endpoint_and_flush(line, col, mid, out)?;
                }
            }
            main_arc(self);
        } else if beta > small {
            // Convex, two arcs: one about the programmed corner, then the arc.
            let mid = [opx + radius * delta.cos(), opy + radius * delta.sin()];
            self.dequeue(out)?;
            self.enqueue(
                QKind::Arc {
                    center: [opx, opy],
                    turn: if side == Side::Left { -1 } else { 1 },
                    original_turns: 0.0,
                },
                [mid[0], mid[1], cz],
                line,
                col,
                feed,
            );
            self.dequeue(out)?;
            self.set_endpoint(mid);
            main_arc(self);
        } else {
            // Convex, tangent: the arc alone.
            self.dequeue(out)?;
            self.set_endpoint([cx, cy]);
            main_arc(self);
        }
        let c = self.comp_mut();
        c.program = programmed.end;
        self.position = from_plane([new_end[0], new_end[1], end_z], plane);
        self.extra = self.extra_target;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn find_turn_is_the_signed_sweep() {
        // A quarter turn counter-clockwise from +X to +Y about the origin.
        let q = find_turn([1.0, 0.0], [0.0, 0.0], 1, [0.0, 1.0]);
        assert!((q - FRAC_PI_2).abs() < 1e-12);
        // The same ends clockwise: three quarters, negative.
        let q = find_turn([1.0, 0.0], [0.0, 0.0], -1, [0.0, 1.0]);
        assert!((q + 1.5 * PI).abs() < 1e-12);
        assert_eq!(find_turn([1.0, 0.0], [0.0, 0.0], 0, [0.0, 1.0]), 0.0);
    }

    #[test]
    fn tool_side_of_an_arc() {
        // G41 (left) on a counter-clockwise arc: the centre is on the left.
        assert!(tool_inside_arc(Side::Left, 1));
        assert!(!tool_inside_arc(Side::Left, -1));
        assert!(tool_inside_arc(Side::Right, -2));
    }
}
