//! Motion generation: straight moves (G0, G1, G53), arcs (G2, G3, with
//! I/J/K centres or R radius), polar end points, and the checks LinuxCNC
//! makes before it moves (feed rate, reach, polar coordinates).

use super::options::{FeedMode, MotionMode};
use super::words::WordTable;
use super::{invalid, Interpreter, Motion, MotionKind, MotionSource};
use crate::arc::{sweep_angle, Arc};
use crate::error::GcodeError;
use crate::geom::{Axis, Plane, Units, Vec3};

/// Help of the refusal of `K0` on an XY arc; a front end may say how its
/// user accepts K0 instead.
pub const K0_HELP: &str =
    "remove the K0 words (a zero K says nothing about an XY arc), or accept K0 on XY arcs ({accept_k0})";

/// Largest absolute machine coordinate volcomp accepts (mm): 100 m, beyond
/// the travel of the largest machine tools (gantry mills reach some tens of
/// metres) and far beyond any error map. A coordinate past it is a typo, a
/// wrong unit or a runaway offset; refusing it here, before any move is split
/// or solved, keeps the work per block bounded. LinuxCNC itself accepts any
/// finite double and stops at the soft limits of the machine's INI file
/// (`[AXIS_n]MIN_LIMIT`/`MAX_LIMIT`); volcomp has no INI file, so it uses
/// this generous fixed bound. In inch programs it is 3937 in.
pub const MAX_COORDINATE_MM: f64 = 100_000.0;

/// Refuses a point (axis frame, mm) with a coordinate beyond
/// [`MAX_COORDINATE_MM`] or not finite.
#[inline]
pub(super) fn check_reach(line: u64, col: usize, what: &str, p: Vec3) -> Result<(), GcodeError> {
    // For speed, one test for the common point (a NaN fails `<=`), inline;
    // the message out of line.
    if p.x.abs() <= MAX_COORDINATE_MM
        && p.y.abs() <= MAX_COORDINATE_MM
        && p.z.abs() <= MAX_COORDINATE_MM
    {
        return Ok(());
    }
    beyond_reach(line, col, what, p)
}

#[cold]
#[inline(never)]
fn beyond_reach(line: u64, col: usize, what: &str, p: Vec3) -> Result<(), GcodeError> {
    for a in Axis::ALL {
        let (v, letter) = (p[a], a.letter());
        if v.is_nan() || v.abs() > MAX_COORDINATE_MM {
            return Err(invalid(
                line,
                col,
                format!(
                    "the {what} of this move has {letter} = {v:e} mm in machine coordinates, beyond the ±{MAX_COORDINATE_MM} mm volcomp accepts"
                ),
                "check the coordinate, the units (G20/G21) and the offsets (G92, G10, work offsets) in effect",
            ));
        }
    }
    Ok(())
}

/// The turns of an arc's P word as LinuxCNC reads it
/// (`check_other_codes`, interp_check.cc; `convert_arc2`,
/// interp_convert.cc): `round_to_int(p)` (half to even), refused when `p`
/// lies more than 0.001 from it or is below 1; volcomp bounds it to
/// 10,000 turns.
pub(super) fn arc_turns(p: f64) -> Result<u32, String> {
    let turns = crate::ngc::expr::round_to_int(p);
    if (turns as f64 - p).abs() > 0.001 {
        return Err(format!("P{p} on an arc is not a whole number of turns; LinuxCNC refuses it (\"P value not an integer with M19 G2 or G3\")"));
    }
    if turns < 1 {
        return Err(format!("P{p} on an arc: at least one turn; LinuxCNC refuses it (\"P value should be 1 or greater with G2 or G3\")"));
    }
    if turns > 10_000 {
        return Err(format!(
            "P{p} on an arc: volcomp makes at most 10,000 turns"
        ));
    }
    Ok(turns as u32)
}

impl Interpreter {
    /// Refuses a feed move that LinuxCNC would refuse for want of a feed
    /// rate (`Interp::convert_straight`, `convert_arc` and `convert_cycle` in
    /// interp_convert.cc / interp_cycles.cc): F0 (or no F yet) in G94/G95,
    /// or no F on the block itself under inverse time (G93).
    pub(super) fn check_feed(
        &self,
        line: u64,
        w: &WordTable,
        col: usize,
    ) -> Result<(), GcodeError> {
        let Some(mode) = self.motion_to_be(w) else {
            return Ok(());
        };
        let what = match mode {
            MotionMode::Rapid => return Ok(()),
            MotionMode::Feed => "Cannot do g1 with zero feed rate",
            MotionMode::Cw | MotionMode::Ccw => "Cannot make arc with zero feed rate",
            MotionMode::Cycle(_) => "Cannot feed with zero feed rate",
            MotionMode::Spline(53) => return Ok(()),
            MotionMode::Spline(52) if self.feed_mode != FeedMode::PerMinute => return Ok(()),
            MotionMode::Spline(52) => "Cannot make a NURBS with 0 feedrate",
            MotionMode::Spline(_) => "Cannot make arc with zero feed rate",
            // The spindle sets the feed (K per revolution).
            MotionMode::Synced(_) => return Ok(()),
            MotionMode::Probe(_) => "Cannot probe with zero feed rate",
        };
        if self.feed_mode == FeedMode::InverseTime {
            if w.get(b'F').is_none() && !matches!(mode, MotionMode::Cycle(_)) {
                return Err(invalid(
                    line,
                    col,
                    "F word missing with an inverse-time (G93) feed move: under G93 every feed move needs its own F",
                    "give F (1 / minutes the move takes) on this line",
                ));
            }
            return Ok(());
        }
        if self.feed == 0.0 {
            let given = match w.col(b'F') {
                Some(_) => "F0 is on this line",
                None => "no F word has set a feed rate yet",
            };
            return Err(invalid(
                line,
                w.col(b'F').unwrap_or(col),
                format!(
                    "a feed move with zero feed rate ({given}); LinuxCNC refuses it: \"{what}\""
                ),
                "set the feed rate with an F word (e.g. F500) on or before this line",
            ));
        }
        if self.feed_mode == FeedMode::PerRevolution && self.spindle_rpm == 0.0 {
            return Err(invalid(
                line,
                col,
                "a feed move in feed per revolution (G95) with zero spindle speed would not move; LinuxCNC refuses it (\"Cannot feed with zero spindle speed in feed per rev mode\")",
                "set the spindle speed with an S word on or before this line, or use G94",
            ));
        }
        Ok(())
    }

    /// Target of axis words in the current coordinate system.
    pub(super) fn target(&self, w: &WordTable) -> Vec3 {
        if self.rotation() != 0.0 {
            return self.rotated_target(w);
        }
        let off = self.frame_offset_mm();
        let mut t = self.words_base();
        for (i, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if let Some(v) = w.get(letter) {
                t[i] = if self.absolute {
                    self.to_mm(v) + off[i]
                } else {
                    t[i] + self.to_mm(v)
                };
            }
        }
        if let Some((x, y)) = self.polar_end(w) {
            t.x = self.to_mm(x) + off.x;
            t.y = self.to_mm(y) + off.y;
        }
        t
    }

    /// The XY end point (program units, current coordinate system) of a
    /// block with polar words, as LinuxCNC's `Interp::find_ends`
    /// (src/emc/rs274ngc/interp_find.cc) computes it: `@` is the radius and
    /// `^` the angle in degrees about the origin of the current coordinate
    /// system. In G90 a missing one is taken from the current point; in G91
    /// `@` is added to the current radius and `^` to the current angle.
    /// `None` when the block has no polar word. [`Self::check_polar`] has
    /// refused the indeterminate cases (at the origin) beforehand.
    pub(super) fn polar_end_of(&self, w: &WordTable) -> Option<(f64, f64)> {
        self.polar_end(w)
    }

    fn polar_end(&self, w: &WordTable) -> Option<(f64, f64)> {
        let (radius, theta_deg) = (w.get(b'@'), w.get(b'^'));
        if radius.is_none() && theta_deg.is_none() {
            return None;
        }
        let here = self.to_program_mm(self.words_base());
        let k = 1.0 / self.units.mm_per_unit();
        let (cx, cy) = (here.x * k, here.y * k);
        let polar = |r: f64, theta_rad: f64| (r * theta_rad.cos(), r * theta_rad.sin());
        Some(if self.absolute {
            match (radius, theta_deg) {
                (Some(r), Some(a)) => polar(r, a.to_radians()),
                (Some(r), None) => polar(r, cy.atan2(cx)),
                (None, Some(a)) => polar(cy.hypot(cx), a.to_radians()),
                (None, None) => unreachable!("checked above"),
            }
        } else {
            let (mut px, mut py) = (cx, cy);
            if let Some(r) = radius {
                (px, py) = polar(py.hypot(px) + r, py.atan2(px));
            }
            if let Some(a) = theta_deg {
                (px, py) = polar(py.hypot(px), py.atan2(px) + a.to_radians());
            }
            (px, py)
        })
    }

    /// Refuses polar words where LinuxCNC does (`Interp::enhance_block`,
    /// `Interp::find_ends`): outside G17, beside X or Y, with G53 or a
    /// canned cycle, or where the angle is undefined (at the origin).
    pub(super) fn check_polar(
        &self,
        line: u64,
        w: &WordTable,
        mode: MotionMode,
    ) -> Result<(), GcodeError> {
        let Some(col) = w.polar_col() else {
            return Ok(());
        };
        let refuse = |msg: &str, help: &str| Err(invalid(line, col, msg, help));
        if self.plane_before_block != Plane::Xy {
            return refuse(
                "polar coordinates (@, ^) are only defined in the XY plane (G17); LinuxCNC refuses them while G18 or G19 is in effect (\"Cannot use polar coordinate except in G17 plane\")",
                "switch to G17 or give X/Y/Z words",
            );
        }
        if let Some(c) = w.col(b'X').or(w.col(b'Y')) {
            return Err(invalid(
                line,
                c,
                "cannot give both polar coordinates (@, ^) and an X or Y word",
                "give the end point either as @ radius and ^ angle or as X and Y",
            ));
        }
        if w.has_g(530) {
            return refuse(
                "polar coordinates cannot be used with G53",
                "give X/Y words with G53",
            );
        }
        if matches!(mode, MotionMode::Cycle(_)) {
            // The cycle places the hole itself (interp/cycle).
            return Ok(());
        }
        let here = self.to_program_mm(self.position);
        let at_origin = here.x == 0.0 && here.y == 0.0;
        if at_origin && (!self.absolute || w.get(b'^').is_none()) {
            return refuse(
                if self.absolute {
                    "a polar radius without an angle is indeterminate at the origin; LinuxCNC refuses it (\"Must specify angle in polar coordinate if at the origin\")"
                } else {
                    "incremental (G91) polar motion is indeterminate at the origin; LinuxCNC refuses it"
                },
                "give the angle with ^, or start away from the origin",
            );
        }
        Ok(())
    }

    pub(super) fn motion(
        &mut self,
        line: u64,
        w: &WordTable,
        new_cycle: bool,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        let col = self.motion_col(w);
        let motion_word = self.motion_word_col(w).is_some();
        let block_spline = [50u16, 51, 53].into_iter().find(|c| w.has_g(*c));
        if let Some(code) = block_spline.or(match self.motion_mode {
            Some(MotionMode::Spline(52)) => Some(52),
            _ => None,
        }) {
            return self.spline(line, col, w, code, out);
        }
        if !w.has_axis() && !w.has_polar() {
            // LinuxCNC moves even without axis words when a motion code is on
            // the line: G0/G1 make a zero-length move, G2/G3 with centre words
            // a full circle; a cycle code alone does nothing.
            // In G2/G3 a line of centre words alone is an arc as well
            // (`enhance_block`, interp_internal.cc).
            let ijk = [b'I', b'J', b'K'].iter().any(|l| w.get(*l).is_some());
            match self.motion_mode {
                Some(MotionMode::Rapid | MotionMode::Feed) if motion_word => {}
                Some(MotionMode::Cw | MotionMode::Ccw) if motion_word || ijk => {
                    if [b'I', b'J', b'K', b'R'].iter().all(|l| w.get(*l).is_none()) {
                        return Err(invalid(
                            line,
                            col,
                            "arc without end point or centre (R, I, J, K words all missing)",
                            "give the end point and the centre (I/J/K) or radius (R)",
                        ));
                    }
                }
                _ => return Ok(()),
            }
        }
        let Some(mode) = self.motion_mode else {
            return Err(invalid(
                line,
                col,
                "axis words without a motion mode (G80 or no G0/G1/G2/G3 yet)",
                "add G0 or G1 to this line",
            ));
        };
        self.check_polar(line, w, mode)?;
        self.check_rotated(line, col, w, mode)?;
        let feed = self.to_mm(self.feed);
        let machine = w.has_g(530);
        if machine && self.comp_active() {
            return Err(invalid(
                line,
                w.g_col(530).unwrap_or(col),
                "G53 with cutter radius compensation on; LinuxCNC refuses it (\"Cannot use g53 with cutter radius comp\")",
                "turn compensation off with G40 before the G53 move",
            ));
        }
        if machine {
            self.arc_not_allowed = false;
            if !matches!(mode, MotionMode::Rapid | MotionMode::Feed) {
                return Err(invalid(
                    line,
                    w.g_col(530).unwrap_or(col),
                    "G53 needs G0 or G1",
                    "use G53 G0 or G53 G1",
                ));
            }
            if !self.absolute {
                return Err(invalid(
                    line,
                    w.g_col(530).unwrap_or(col),
                    "G53 cannot be used in incremental mode (G91)",
                    "switch to G90 before G53",
                ));
            }
            let mut t = self.position;
            for (i, l) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
                if let Some(v) = w.get(l) {
                    t[i] = self.to_mm(v);
                }
            }
            let kind = if mode == MotionMode::Rapid {
                MotionKind::Rapid
            } else {
                MotionKind::Feed
            };
            self.push(out, kind, MotionSource::Machine, t, line, col, feed)?;
            return Ok(());
        }
        match mode {
            MotionMode::Rapid | MotionMode::Feed => {
                let kind = if mode == MotionMode::Rapid {
                    MotionKind::Rapid
                } else {
                    MotionKind::Feed
                };
                let t = self.target(w);
                self.arc_not_allowed = false;
                if self.comp_active() {
                    return self.comp_straight(line, col, mode == MotionMode::Rapid, t, feed, out);
                }
                self.push(out, kind, MotionSource::Program, t, line, col, feed)?;
            }
            MotionMode::Cw | MotionMode::Ccw => {
                if self.arc_not_allowed {
                    return Err(invalid(
                        line,
                        col,
                        "an arc right after G40; LinuxCNC refuses it (\"The move just after exiting cutter compensation mode must be straight, not an arc\")",
                        "make the exit move after G40 a G0 or G1",
                    ));
                }
                if self.comp_active() {
                    return self.comp_arc(line, col, w, mode == MotionMode::Cw, feed, out);
                }
                let arc = self.arc(line, col, w, mode == MotionMode::Cw)?;
                self.push(
                    out,
                    MotionKind::Arc(arc),
                    MotionSource::Program,
                    arc.end,
                    line,
                    col,
                    feed,
                )?;
            }
            MotionMode::Cycle(code) => self.cycle(line, col, code, w, new_cycle, out)?,
            MotionMode::Spline(code) => self.spline(line, col, w, code, out)?,
            MotionMode::Synced(code) => self.synced(line, col, w, code, feed, out)?,
            MotionMode::Probe(code) => self.probe(line, col, w, code, feed, out)?,
        }
        Ok(())
    }

    /// A probing move G38.2–G38.5 (read only with
    /// `InterpOptions::accept_probing`), with the checks of LinuxCNC's
    /// `Interp::convert_probe` (interp_convert.cc): no cutter radius
    /// compensation, no feed per revolution, and for G38.2/G38.4 an end point
    /// that differs from the start. It is read as a feed move to its end
    /// point: the path when the probe never touches (G38.2/G38.4 then stop
    /// the program with an error; G38.3/G38.5 go on from there).
    fn probe(
        &mut self,
        line: u64,
        col: usize,
        w: &WordTable,
        code: u16,
        feed: f64,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        let name = format!("G38.{}", code % 10);
        if self.comp_active() {
            return Err(invalid(
                line,
                col,
                format!("{name} with cutter radius compensation on; LinuxCNC refuses it (\"Cannot probe with cutter radius comp on\")"),
                "turn compensation off with G40 before probing",
            ));
        }
        if self.feed_mode == FeedMode::PerRevolution {
            return Err(invalid(
                line,
                col,
                format!("{name} in feed per revolution (G95); LinuxCNC refuses it (\"Cannot probe with feed per rev mode\")"),
                "probe in G94 (units per minute)",
            ));
        }
        let t = self.target(w);
        if matches!(code, 382 | 384) && t == self.position {
            return Err(invalid(
                line,
                col,
                format!("{name} to where the probe already is; LinuxCNC refuses it (\"Start point too close to probe point\")"),
                "give an end point beyond the surface to be probed",
            ));
        }
        self.arc_not_allowed = false;
        self.push(
            out,
            MotionKind::Feed,
            MotionSource::Program,
            t,
            line,
            col,
            feed,
        )
    }

    /// G33 (a straight move at K per spindle revolution) and G33.1 (rigid
    /// tapping: in to the end point at K per revolution and back out to
    /// the start), as `Interp::convert_straight` (interp_convert.cc) makes
    /// them, with the checks of `check_other_codes` (interp_check.cc): K
    /// required, no F, the spindle turning. The feed of the motions is the
    /// modal F, which the controller does not use for them.
    fn synced(
        &mut self,
        line: u64,
        col: usize,
        w: &WordTable,
        code: u16,
        feed: f64,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        let name = if code == 330 { "G33" } else { "G33.1" };
        if w.get(b'K').is_none() {
            return Err(invalid(
                line,
                col,
                format!("K word missing with {name}: K is the distance per spindle revolution"),
                "give the pitch with K",
            ));
        }
        if let Some(c) = w.col(b'F') {
            return Err(invalid(
                line,
                c,
                format!("F word used with {name}: the spindle sets the feed (K per revolution)"),
                "remove the F word",
            ));
        }
        if self.spindle_dir == 0 {
            return Err(invalid(
                line,
                col,
                format!("Spindle not turning in {name}"),
                "start the spindle with M3 or M4 before this line",
            ));
        }
        let start = self.position;
        let t = self.target(w);
        self.push(
            out,
            MotionKind::Feed,
            MotionSource::SpindleSynced,
            t,
            line,
            col,
            feed,
        )?;
        if code == 331 {
            // RIGID_TAP returns to where it started.
            self.push(
                out,
                MotionKind::Feed,
                MotionSource::SpindleSynced,
                start,
                line,
                col,
                feed,
            )?;
        }
        Ok(())
    }

    /// Appends a motion to `out` and moves there. Inline where it is
    /// called, for speed: with the kind known there (the straight moves of
    /// the fast path), the motion is written straight into `out`; through
    /// a by-reference `kind` it is built on the stack and copied, a copy
    /// that reads back what was just stored and stalls the CPU.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn push(
        &mut self,
        out: &mut Vec<Motion>,
        kind: MotionKind,
        source: MotionSource,
        end: Vec3,
        line: u64,
        column: usize,
        feed: f64,
    ) -> Result<(), GcodeError> {
        check_reach(line, column, "end point", end)?;
        if let MotionKind::Arc(arc) = kind {
            check_reach(line, column, "arc centre", arc.center)?;
        }
        out.push(Motion {
            kind,
            source,
            start: self.motion_start.take().unwrap_or(self.position),
            end,
            line,
            column: column + 1,
            feed,
            feed_mode: self.feed_mode,
            path_mode: self.path_mode,
            extra: super::ExtraAxes {
                start: self.extra,
                end: self.extra_target,
            },
        });
        self.position = end;
        self.extra = self.extra_target;
        Ok(())
    }

    pub(super) fn arc(
        &self,
        line: u64,
        col: usize,
        w: &WordTable,
        clockwise: bool,
    ) -> Result<Arc, GcodeError> {
        let start = self.position;
        let end = self.target(w);
        let plane = self.plane;
        let (u, v, _) = plane.axes();
        let letters = [b'I', b'J', b'K'];
        let (lu, lv, lw) = (letters[u], letters[v], letters[plane.axes().2]);
        // LinuxCNC's CENTER_ARC_RADIUS_TOLERANCE, in program units (mm or inch).
        let tol_mm = match self.units {
            Units::Mm => 2.0 * 0.01 * std::f64::consts::SQRT_2,
            Units::Inch => 2.0 * 0.001 * std::f64::consts::SQRT_2 * 25.4,
        };
        let turns = match w.get(b'P') {
            None => 1,
            Some(p) => arc_turns(p)
                .map_err(|why| invalid(line, w.col(b'P').unwrap_or(col), why, "fix the P word"))?,
        };
        if let Some(k) = w.get(lw) {
            let k0_xy = k == 0.0 && plane == Plane::Xy;
            if k0_xy && !self.options.accept_k0_on_xy_arcs {
                return Err(invalid(
                    line,
                    w.col(lw).unwrap_or(col),
                    "K0 given for an arc in the XY plane; LinuxCNC refuses it (\"K word given for arc in xy plane\")",
                    K0_HELP,
                ));
            }
            if !k0_xy {
                return Err(invalid(
                    line,
                    w.col(lw).unwrap_or(col),
                    format!(
                        "{} word given for an arc in the {} plane",
                        lw as char,
                        plane_name(plane)
                    ),
                    "remove it: an arc's centre offsets are in its plane only",
                ));
            }
        }
        let mut center = start;
        if let Some(r) = w.get(b'R') {
            if w.get(lu).is_some() || w.get(lv).is_some() {
                return Err(invalid(
                    line,
                    w.col(b'R').unwrap_or(col),
                    "arc has both R and centre words",
                    "use either R or I/J/K",
                ));
            }
            let r_mm = self.to_mm(r);
            let (du, dv) = (end[u] - start[u], end[v] - start[v]);
            if du.hypot(dv) < 1e-12 {
                return Err(invalid(
                    line,
                    w.col(b'R').unwrap_or(col),
                    "an R-format arc cannot end where it starts",
                    "use I/J/K centre words for a full circle",
                ));
            }
            let (mu, mv) = (0.5 * (start[u] + end[u]), 0.5 * (start[v] + end[v]));
            let mut half = (mu - start[u]).hypot(mv - start[v]);
            let abs_r = r_mm.abs();
            let radius_tol = 0.00005 * 25.4;
            if abs_r < half && half - abs_r > radius_tol {
                return Err(invalid(
                    line,
                    w.col(b'R').unwrap_or(col),
                    format!(
                        "radius {r} is too small to reach the end point (half chord {:.4} mm)",
                        half
                    ),
                    "check R and the end point",
                ));
            }
            if half / abs_r > 1.0 - 1e-12 {
                half = abs_r;
            }
            let chord_angle = dv.atan2(du);
            let theta = if clockwise == (r_mm > 0.0) {
                chord_angle - std::f64::consts::FRAC_PI_2
            } else {
                chord_angle + std::f64::consts::FRAC_PI_2
            };
            let offset = abs_r * (half / abs_r).asin().cos();
            center[u] = mu + offset * theta.cos();
            center[v] = mv + offset * theta.sin();
        } else {
            if w.get(lu).is_none() && w.get(lv).is_none() {
                return Err(invalid(
                    line,
                    col,
                    "arc without R or centre words",
                    format!(
                        "give {} and {} (centre) or R (radius)",
                        lu as char, lv as char
                    ),
                ));
            }
            if self.rotation() != 0.0 {
                center = self.rotated_center(w, start, [(u, lu), (v, lv)]);
            }
            let off = self.frame_offset_mm();
            for (axis, letter) in [(u, lu), (v, lv)]
                .into_iter()
                .filter(|_| self.rotation() == 0.0)
            {
                let val = w.get(letter).map(|x| self.to_mm(x));
                center[axis] = if self.arc_absolute {
                    val.map(|x| x + off[axis]).unwrap_or(off[axis])
                } else {
                    start[axis] + val.unwrap_or(0.0)
                };
            }
            let r1 = (start[u] - center[u]).hypot(start[v] - center[v]);
            let r2 = (end[u] - center[u]).hypot(end[v] - center[v]);
            let abs_err = (r1 - r2).abs();
            let rel_err = abs_err / r1.max(r2);
            if r1 < 1e-9 || r2 < 1e-9 {
                return Err(invalid(
                    line,
                    col,
                    "zero-radius arc",
                    "check the centre words",
                ));
            }
            if abs_err > tol_mm * 100.0 || (rel_err > 0.001 && abs_err > tol_mm) {
                let mut help = "check the centre words; LinuxCNC refuses this arc too".to_string();
                if !self.arc_absolute {
                    let mut c_abs = start;
                    for (axis, letter) in [(u, lu), (v, lv)] {
                        c_abs[axis] =
                            w.get(letter).map(|x| self.to_mm(x)).unwrap_or(0.0) + off[axis];
                    }
                    let a1 = (start[u] - c_abs[u]).hypot(start[v] - c_abs[v]);
                    let a2 = (end[u] - c_abs[u]).hypot(end[v] - c_abs[v]);
                    if (a1 - a2).abs() <= tol_mm.max(1e-3 * a1.max(a2)) {
                        help = format!("the centre fits if {}/{} are absolute coordinates (radius {:.4} at both ends): the program was posted for absolute arc centres; add G90.1 at its start or read it with absolute arc centres ({{absolute_arc_centers}})", lu as char, lv as char, a1 / self.units.mm_per_unit());
                    }
                }
                return Err(invalid(line, col, format!("radius to end of arc differs from radius to start: r1={:.4} r2={:.4} (mm), abs_err={:.4} rel_err={:.4}%", r1, r2, abs_err, rel_err * 100.0), help));
            }
        }
        let a0 = (start[v] - center[v]).atan2(start[u] - center[u]);
        let a1 = (end[v] - center[v]).atan2(end[u] - center[u]);
        let sweep = sweep_angle(a0, a1, clockwise, turns);
        Ok(Arc {
            start,
            end,
            center,
            plane,
            sweep_rad: sweep,
        })
    }
}

fn plane_name(p: Plane) -> &'static str {
    match p {
        Plane::Xy => "XY (G17)",
        Plane::Zx => "ZX (G18)",
        Plane::Yz => "YZ (G19)",
    }
}
