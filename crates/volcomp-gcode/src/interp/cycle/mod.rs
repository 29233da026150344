//! Canned cycles G73, G74, G81–G89, expanded into the rapid and feed moves
//! LinuxCNC 2.9 makes for them (src/emc/rs274ngc/interp_cycles.cc:
//! `convert_cycle`, `convert_cycle_xy/yz/zx` with their `CYCLE_MACRO` repeat
//! loop, and `convert_cycle_g73` … `convert_cycle_g89`).
//!
//! Everything is computed in program units and the program frame, as
//! LinuxCNC does, and each end point is then carried to the axis frame in mm.

use super::words::WordTable;
use super::{invalid, Interpreter, Motion, MotionKind, MotionSource, PathMode};
use crate::error::GcodeError;
use crate::geom::{Plane, Units, Vec3};

/// Most motions one cycle block may expand to (L repeats × pecks): a bound
/// on memory and time, far above any real program.
const MAX_CYCLE_MOTIONS: usize = 200_000;

/// The axes of a cycle plane: (first, second, normal) as indices into
/// (X, Y, Z), as `cycle_traverse` orders them.
fn axes(plane: Plane) -> [usize; 3] {
    match plane {
        Plane::Xy => [0, 1, 2],
        Plane::Yz => [1, 2, 0],
        Plane::Zx => [2, 0, 1],
    }
}

const AXIS_LETTER: [u8; 3] = [b'X', b'Y', b'Z'];
const CENTRE_LETTER: [u8; 3] = [b'I', b'J', b'K'];

/// The program-unit value LinuxCNC holds for a coordinate volcomp keeps in
/// mm in the axis frame: the round trip (v·k + offset − offset)/k can land
/// one bit off the number the program wrote (0.08 in → 0.07999999999999999),
/// and the cycle compares it exactly with R (LinuxCNC: `old_cc < r`), so the
/// value is snapped to ten decimals when it is that close to them.
pub fn snap(v: f64) -> f64 {
    if v.abs() >= 1e5 {
        return v;
    }
    let s = (v * 1e10).round() / 1e10;
    if (s - v).abs() < 1e-9 {
        s
    } else {
        v
    }
}

fn plane_name(plane: Plane) -> &'static str {
    match plane {
        Plane::Xy => "XY",
        Plane::Yz => "YZ",
        Plane::Zx => "XZ",
    }
}

/// One canned-cycle block as LinuxCNC 2.9's `convert_cycle_xy` (and its
/// YZ/ZX twins) computed it, in program units and the program frame: what
/// a writer needs to write the block back as a cycle with other numbers
/// and to know the moves the controller then makes.
#[derive(Debug, Clone, PartialEq)]
pub struct CycleBlock {
    /// The cycle, G-code × 10 (730, 810 … 890).
    pub code: u16,
    /// The plane's (first, second, normal) axes as indices into (X, Y, Z).
    pub axes: [usize; 3],
    /// G90 (true) or G91.
    pub absolute: bool,
    /// G99: retract to R (true), G98: to the initial level.
    pub retract_to_r: bool,
    /// The initial level of the run of cycle blocks (`cycle_il`), before
    /// it is raised to R.
    pub initial: f64,
    /// The normal-axis coordinate when the block began (`current_cc`).
    pub current: f64,
    /// The in-plane point when the block began.
    pub start: [f64; 2],
    /// The R plane.
    pub r: f64,
    /// The hole bottom.
    pub bottom: f64,
    /// The level the tool retracts to after each hole (R under G99).
    pub clear: f64,
    /// Peck depth (G73, G83; 0 otherwise).
    pub q: f64,
    /// The peck clearance: 0.254 mm or 0.010 in.
    pub peck_clear: f64,
    /// The in-plane point of each repeat (L).
    pub holes: Vec<[f64; 2]>,
}

/// One canned-cycle block being expanded: plane mapping, units, frame.
struct Ctx {
    ax: [usize; 3],
    mm: f64,
    off: Vec3,
    line: u64,
    col: usize,
    feed: f64,
}

impl Ctx {
    /// Program-frame (a, b, c) in program units → axis-frame point in mm.
    fn point(&self, a: f64, b: f64, c: f64) -> Vec3 {
        let mut p = [0.0; 3];
        p[self.ax[0]] = a;
        p[self.ax[1]] = b;
        p[self.ax[2]] = c;
        Vec3::new(
            p[0] * self.mm + self.off.x,
            p[1] * self.mm + self.off.y,
            p[2] * self.mm + self.off.z,
        )
    }
}

impl Interpreter {
    /// The spindle direction as M3 (1), M4 (-1) or M5/none (0) left it:
    /// what G86 restarts after its retract.
    pub fn spindle_direction(&self) -> i8 {
        self.spindle_dir
    }

    /// The last canned-cycle block interpreted, as LinuxCNC computed it;
    /// `None` before the first.
    pub fn last_cycle(&self) -> Option<&CycleBlock> {
        self.last_cycle.as_deref()
    }

    fn cycle_move(
        &mut self,
        cx: &Ctx,
        out: &mut Vec<Motion>,
        feed: bool,
        a: f64,
        b: f64,
        c: f64,
    ) -> Result<(), GcodeError> {
        if out.len() >= MAX_CYCLE_MOTIONS {
            return Err(invalid(
                cx.line,
                cx.col,
                format!("this canned cycle expands to more than {MAX_CYCLE_MOTIONS} moves (L repeats times pecks)"),
                "check L and Q: a tiny peck Q or a huge L is almost certainly a mistake",
            ));
        }
        let kind = if feed {
            MotionKind::Feed
        } else {
            MotionKind::Rapid
        };
        let p = cx.point(a, b, c);
        self.push(out, kind, MotionSource::Cycle, p, cx.line, cx.col, cx.feed)
    }

    /// Expands one block of canned cycle `code` (G-code × 10) in the
    /// selected plane as LinuxCNC 2.9's `convert_cycle` does. `new_cycle`
    /// is LinuxCNC's `settings->motion_mode != motion`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn cycle(
        &mut self,
        line: u64,
        col: usize,
        code: u16,
        w: &WordTable,
        new_cycle: bool,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        if self.feed_mode == super::FeedMode::InverseTime {
            return Err(invalid(
                line,
                col,
                "cannot use inverse time feed with canned cycles; LinuxCNC refuses it too",
                "switch to G94 (units per minute) before the cycle",
            ));
        }
        let plane = self.plane;
        let ax = axes(plane);
        let [la, lb, lc] = ax.map(|i| AXIS_LETTER[i]);
        let gname = format!("G{}", code / 10);
        let col_of = |l: u8| w.col(l).unwrap_or(col);
        // convert_cycle: R, then L.
        let r_word =
            match w.get(b'R') {
                Some(r) => r,
                None => match self.cycle_r {
                    Some(r) if !new_cycle => r,
                    _ => return Err(invalid(
                        line,
                        col,
                        "R clearance plane unspecified in canned cycle; LinuxCNC refuses it too",
                        "give the R plane in the first block of the cycle",
                    )),
                },
            };
        let repeats = match w.get(b'L') {
            None => 1u32,
            Some(l) => {
                let c = col_of(b'L');
                if l < 0.0 {
                    return Err(invalid(
                        line,
                        c,
                        "negative L word used",
                        "L is a repeat count of 1 or more",
                    ));
                }
                let n = l.round();
                if (l - n).abs() > 1e-4 {
                    return Err(invalid(
                        line,
                        c,
                        "L must be a whole number of repeats",
                        "write L as an integer",
                    ));
                }
                if n == 0.0 {
                    return Err(invalid(
                        line,
                        c,
                        "cannot do zero repeats of cycle (L0); LinuxCNC refuses it too",
                        "remove L (one repeat) or give L1 or more",
                    ));
                }
                if n > MAX_CYCLE_MOTIONS as f64 {
                    return Err(invalid(
                        line,
                        c,
                        format!("L{n} is more than {MAX_CYCLE_MOTIONS} repeats"),
                        "check the L word",
                    ));
                }
                n as u32
            }
        };
        // convert_cycle_xy/yz/zx: the normal-axis word.
        if new_cycle && w.get(lc).is_none() {
            return Err(invalid(
                line,
                col,
                format!(
                    "{} value unspecified in {} plane canned cycle; LinuxCNC refuses it too",
                    lc as char,
                    plane_name(plane)
                ),
                format!(
                    "give the hole bottom {} in the first block of the cycle",
                    lc as char
                ),
            ));
        }
        let Some(c_word) = w.get(lc).or(self.cycle_z) else {
            return Err(invalid(
                line,
                col,
                "canned cycle without a hole bottom",
                "give the bottom",
            ));
        };
        let mm = self.units.mm_per_unit();
        let off = self.frame_offset_mm();
        let prog = [
            snap((self.position.x - off.x) / mm),
            snap((self.position.y - off.y) / mm),
            snap((self.position.z - off.z) / mm),
        ];
        let (cur_a, cur_b) = (prog[ax[0]], prog[ax[1]]);
        let mut current_cc = prog[ax[2]];
        let mut old_cc = *self.cycle_start_z.get_or_insert(current_cc);
        let (mut aa, mut bb, r, cc, inc_a, inc_b);
        // Polar words (G17 only, checked before): `@` radius, `^` angle in
        // degrees about the program origin, as in convert_cycle_xy.
        let (polar_r, polar_t) = (w.get(b'@'), w.get(b'^'));
        let (mut inc_radius, mut inc_theta) = (0.0, 0.0);
        if self.absolute {
            r = r_word;
            cc = c_word;
            if polar_r.is_some() || polar_t.is_some() {
                let radius = polar_r.unwrap_or_else(|| cur_b.hypot(cur_a));
                let theta = polar_t
                    .map(f64::to_radians)
                    .unwrap_or_else(|| cur_b.atan2(cur_a));
                aa = radius * theta.cos();
                bb = radius * theta.sin();
            } else {
                aa = w.get(la).unwrap_or(cur_a);
                bb = w.get(lb).unwrap_or(cur_b);
            }
            (inc_a, inc_b) = (0.0, 0.0);
        } else {
            inc_radius = polar_r.unwrap_or(0.0);
            inc_theta = polar_t.map(f64::to_radians).unwrap_or(0.0);
            inc_a = w.get(la).unwrap_or(0.0);
            inc_b = w.get(lb).unwrap_or(0.0);
            r = r_word + old_cc;
            cc = r + c_word;
            (aa, bb) = (cur_a, cur_b);
        }
        if r < cc {
            return Err(invalid(
                line,
                w.col(b'R').unwrap_or(col),
                format!(
                    "R less than {} in cycle in {} plane; LinuxCNC refuses it too",
                    lc as char,
                    plane_name(plane)
                ),
                format!(
                    "{} is the bottom of the hole, R the retract plane above it (R must be at or above {})",
                    lc as char, lc as char
                ),
            ));
        }
        // Per-cycle words, checked and made sticky as in the switch of
        // convert_cycle_xy.
        let dwell_needed = matches!(code, 820 | 860 | 880 | 890);
        if dwell_needed && new_cycle && w.get(b'P').is_none() {
            return Err(invalid(
                line,
                col,
                format!("dwell time P word missing with {gname}; LinuxCNC refuses it too"),
                "give P (seconds) in the first block of the cycle",
            ));
        }
        if matches!(code, 730 | 830) && new_cycle && w.get(b'Q').is_none() {
            return Err(invalid(
                line,
                col,
                format!("Q word missing with {gname}; LinuxCNC refuses it too"),
                "give the peck depth Q in the first block of the cycle",
            ));
        }
        if code == 870 && new_cycle {
            for l in [b'I', b'J', b'K'] {
                if w.get(l).is_none() {
                    return Err(invalid(
                        line,
                        col,
                        format!(
                            "{} word missing with G87; LinuxCNC refuses it too",
                            l as char
                        ),
                        "give I, J and K in the first block of G87",
                    ));
                }
            }
        }
        if matches!(code, 740 | 820 | 840 | 860 | 880 | 890) {
            if let Some(p) = w.get(b'P') {
                self.cycle_p = Some(p);
            }
        }
        let q = if matches!(code, 730 | 830) {
            if let Some(q) = w.get(b'Q') {
                self.cycle_q = Some(q);
            }
            let q = self.cycle_q.unwrap_or(0.0);
            if q <= 0.0 {
                return Err(invalid(
                    line,
                    w.col(b'Q').unwrap_or(col),
                    "negative or zero Q value used; LinuxCNC refuses it too",
                    "Q is the peck depth, a positive distance",
                ));
            }
            q
        } else {
            0.0
        };
        let mut ijk = [0.0; 3];
        if code == 870 {
            for (i, l) in CENTRE_LETTER.iter().enumerate() {
                if let Some(v) = w.get(*l) {
                    self.cycle_ijk[i] = v;
                }
            }
            ijk = self.cycle_ijk;
        }
        match code {
            840 if self.spindle_dir != 1 => {
                return Err(invalid(
                    line,
                    col,
                    if self.spindle_dir == 0 {
                        "spindle not turning in G84; LinuxCNC refuses it too"
                    } else {
                        "spindle turning counterclockwise in G84; LinuxCNC refuses it too"
                    },
                    "start the spindle clockwise (M3) before right-hand tapping",
                ))
            }
            740 if self.spindle_dir != -1 => {
                return Err(invalid(
                    line,
                    col,
                    if self.spindle_dir == 0 {
                        "spindle not turning in G74; LinuxCNC refuses it too"
                    } else {
                        "spindle turning clockwise in G74; LinuxCNC refuses it too"
                    },
                    "start the spindle counterclockwise (M4) before left-hand tapping",
                ))
            }
            860 | 870 | 880 if self.spindle_dir == 0 => {
                return Err(invalid(
                    line,
                    col,
                    format!("spindle not turning in {gname}; LinuxCNC refuses it too"),
                    "start the spindle (M3 or M4) before the cycle",
                ))
            }
            _ => {}
        }
        self.cycle_r = Some(r_word);
        self.cycle_z = Some(c_word);
        let cx = Ctx {
            ax,
            mm,
            off,
            line,
            col,
            feed: self.to_mm(self.feed),
        };
        let mut record = CycleBlock {
            code,
            axes: ax,
            absolute: self.absolute,
            retract_to_r: self.retract_to_r,
            initial: old_cc,
            current: current_cc,
            start: [cur_a, cur_b],
            r,
            bottom: cc,
            clear: 0.0,
            q,
            peck_clear: 0.0,
            holes: Vec::with_capacity(repeats.min(1024) as usize),
        };
        // First motion (maybe): below the R plane, rapid straight up to it.
        if old_cc < r {
            self.cycle_move(&cx, out, false, cur_a, cur_b, r)?;
            old_cc = r;
            current_cc = old_cc;
        }
        let clear = if self.retract_to_r { r } else { old_cc };
        // The rest of the cycle runs in exact path (G61) whatever the
        // program's mode, which is restored after it (`convert_cycle_xy`
        // and its YZ/ZX twins in interp_cycles.cc: SET_MOTION_CONTROL_MODE
        // (CANON_EXACT_PATH) unless already so, then the saved mode and
        // tolerances). An error ends the run, so it needs no restoring.
        let saved_mode = std::mem::replace(&mut self.path_mode, PathMode::ExactPath);
        let peck_clear = match self.units {
            Units::Inch => 0.010,
            Units::Mm => 0.254,
        };
        for rep in 0..repeats {
            aa += inc_a;
            bb += inc_b;
            for (inc, radial) in [(inc_radius, true), (inc_theta, false)] {
                if inc == 0.0 {
                    continue;
                }
                if aa == 0.0 && bb == 0.0 {
                    return Err(invalid(
                        line,
                        w.col(if radial { b'@' } else { b'^' }).unwrap_or(col),
                        "incremental motion with polar coordinates is indeterminate when at the origin; LinuxCNC refuses it too",
                        "start the cycle away from the origin, or give the holes in G90",
                    ));
                }
                let (mut radius, mut theta) = (bb.hypot(aa), bb.atan2(aa));
                if radial {
                    radius += inc;
                } else {
                    theta += inc;
                }
                aa = radius * theta.cos();
                bb = radius * theta.sin();
            }
            record.holes.push([aa, bb]);
            if rep == 0 && current_cc > r {
                self.cycle_move(&cx, out, false, aa, bb, current_cc)?;
                self.cycle_move(&cx, out, false, aa, bb, r)?;
            } else {
                self.cycle_move(&cx, out, false, aa, bb, clear)?;
                if clear > r {
                    self.cycle_move(&cx, out, false, aa, bb, r)?;
                }
            }
            self.cycle_body(&cx, out, code, aa, bb, r, clear, cc, q, peck_clear, ijk)?;
        }
        self.path_mode = saved_mode;
        record.clear = clear;
        record.peck_clear = peck_clear;
        self.last_cycle = Some(Box::new(record));
        // LinuxCNC leaves the current point at (aa, bb, clear) even after
        // G88, where the operator retracts by hand.
        self.position = cx.point(aa, bb, clear);
        Ok(())
    }

    /// The motion of one repeat after CYCLE_MACRO has positioned the tool
    /// at (aa, bb, r): `convert_cycle_g73` … `convert_cycle_g89`.
    #[allow(clippy::too_many_arguments)]
    fn cycle_body(
        &mut self,
        cx: &Ctx,
        out: &mut Vec<Motion>,
        code: u16,
        aa: f64,
        bb: f64,
        r: f64,
        clear: f64,
        bottom: f64,
        q: f64,
        peck_clear: f64,
        ijk: [f64; 3],
    ) -> Result<(), GcodeError> {
        match code {
            // G81, G82 (dwell at the bottom), G86 (dwell, spindle stop,
            // retract, restart): feed down, rapid out.
            810 | 820 | 860 => {
                self.cycle_move(cx, out, true, aa, bb, bottom)?;
                self.cycle_move(cx, out, false, aa, bb, clear)?;
            }
            // G84: feed down, spindle stop and reverse, dwell, feed out,
            // spindle stop and restart. In the YZ and XZ planes LinuxCNC
            // 2.9's `convert_cycle_g74_g84` passes the coordinates to
            // `cycle_feed` in a different order (YZ: `bottom_z, x, y`; XZ:
            // `y, bottom_z, x`), so its feed moves there do not go along
            // the hole axis; volcomp reproduces them as the controller
            // runs them.
            740 | 840 => {
                let (down, up) = match cx.ax[2] {
                    2 => ([aa, bb, bottom], [aa, bb, clear]),
                    0 => ([bottom, aa, bb], [clear, aa, bb]),
                    _ => ([bb, bottom, aa], [bb, clear, aa]),
                };
                self.cycle_move(cx, out, true, down[0], down[1], down[2])?;
                self.cycle_move(cx, out, true, up[0], up[1], up[2])?;
            }
            // G89 (dwell): feed down, feed out.
            890 => {
                self.cycle_move(cx, out, true, aa, bb, bottom)?;
                self.cycle_move(cx, out, true, aa, bb, clear)?;
            }
            850 => {
                self.cycle_move(cx, out, true, aa, bb, bottom)?;
                self.cycle_move(cx, out, true, aa, bb, r)?;
                self.cycle_move(cx, out, false, aa, bb, clear)?;
            }
            // G88: feed down, dwell, spindle stop, program stop.
            880 => self.cycle_move(cx, out, true, aa, bb, bottom)?,
            730 | 830 => {
                let mut depth = r - q;
                while depth > bottom {
                    self.cycle_move(cx, out, true, aa, bb, depth)?;
                    if code == 830 {
                        self.cycle_move(cx, out, false, aa, bb, r)?;
                    }
                    self.cycle_move(cx, out, false, aa, bb, depth + peck_clear)?;
                    depth -= q;
                }
                self.cycle_move(cx, out, true, aa, bb, bottom)?;
                self.cycle_move(cx, out, false, aa, bb, clear)?;
            }
            870 => {
                // Offsets I/J/K are per axis (X, Y, Z); the normal axis's
                // word is the top of the back bore, absolute in G90 and
                // relative to the bottom in G91.
                let (oa, ob) = (aa + ijk[cx.ax[0]], bb + ijk[cx.ax[1]]);
                let mut middle = ijk[cx.ax[2]];
                if !self.absolute {
                    middle += bottom;
                }
                self.cycle_move(cx, out, false, oa, ob, r)?;
                self.cycle_move(cx, out, false, oa, ob, bottom)?;
                self.cycle_move(cx, out, false, aa, bb, bottom)?;
                self.cycle_move(cx, out, true, aa, bb, middle)?;
                self.cycle_move(cx, out, true, aa, bb, bottom)?;
                self.cycle_move(cx, out, false, oa, ob, bottom)?;
                self.cycle_move(cx, out, false, oa, ob, clear)?;
                self.cycle_move(cx, out, false, aa, bb, clear)?;
            }
            _ => {
                return Err(invalid(
                    cx.line,
                    cx.col,
                    "unknown canned cycle",
                    "use G73 or G81–G89",
                ))
            }
        }
        Ok(())
    }
}
