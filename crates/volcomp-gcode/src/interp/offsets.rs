//! Coordinate systems and offsets: tool length offsets (G43, G43.1, G49),
//! work offsets set by the program (G10 L2/L20), tool table writes (G10
//! L1/L10/L11), G52 local offsets, G92 and its variants, and the reference
//! points G28/G30.
//!
//! They only move the frame: `q = p + work_offset + tool_length_offset +
//! G92` (machine = program + offsets), as in LinuxCNC's `Interp`
//! (src/emc/rs274ngc/interp_convert.cc: `convert_tool_length_offset`,
//! `convert_setup`, `convert_setup_tool`, `convert_axis_offsets`,
//! `convert_home`). G52 is LinuxCNC's G92 offset set directly: both write
//! the one offset `axis_offset` (and #5211–#5219), so G92.1 clears a G52
//! offset and G92.3 restores it.

use super::words::WordTable;
use super::{invalid, unsupported, Interpreter, Motion, MotionKind, MotionSource, Warning};
use crate::error::GcodeError;
use crate::geom::Vec3;

impl Interpreter {
    /// G43 (length of tool H, or of the loaded tool, along Z), G43.1 (any
    /// vector from the axis words) and G49 (cancel).
    pub(super) fn tool_length_offset(
        &mut self,
        line: u64,
        w: &WordTable,
    ) -> Result<(), GcodeError> {
        if w.has_g(430) {
            let col = w.g_col(430).unwrap_or(0);
            let h = match w.get(b'H') {
                // rs274 treats H0 like a missing H: the loaded tool.
                Some(0.0) => self.loaded_tool,
                Some(h) if h > 0.0 && h.fract() == 0.0 => h as u32,
                Some(_) => {
                    return Err(invalid(
                        line,
                        w.col(b'H').unwrap_or(col),
                        "H must be a non-negative whole number",
                        "fix the H word",
                    ))
                }
                None => self.loaded_tool,
            };
            let xy = self.tool_xy_mm.get(&h).copied().unwrap_or([0.0; 2]);
            let length = if h == 0 {
                0.0
            } else {
                *self.setup.tool_lengths_mm.get(&h).ok_or_else(|| {
                    invalid(
                        line,
                        col,
                        format!("G43 uses tool {h}, which the setup has no length for"),
                        format!("add `{h} = LENGTH` under [tools] in the set-up file"),
                    )
                })?
            };
            self.tlo = if h == 0 {
                Vec3::ZERO
            } else {
                Vec3::new(xy[0], xy[1], length)
            };
        } else if w.has_g(431) {
            let mut tlo = Vec3::ZERO;
            for (i, l) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
                tlo[i] = w.get(l).map(|v| self.to_mm(v)).unwrap_or(0.0);
            }
            self.tlo = tlo;
        } else if w.has_g(490) {
            self.tlo = Vec3::ZERO;
        }
        Ok(())
    }

    /// G92 (set the offset so the current point has the given program
    /// coordinates), G92.1 (clear and forget), G92.2 (clear, remember),
    /// G92.3 (restore the remembered one).
    pub(super) fn g92(&mut self, line: u64, w: &WordTable) -> Result<(), GcodeError> {
        if w.has_g(520) {
            // G52: the shared offset gets the given values (program units),
            // the current point keeps its axis position
            // (`convert_axis_offsets`, G_52 branch).
            for (i, l) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
                if let Some(v) = w.get(l) {
                    self.g92[i] = self.to_mm(v);
                }
            }
            self.g92_saved = self.g92;
            self.g92_applied = true;
        } else if w.has_g(920) {
            let off = self.work_offsets[self.work] + self.tlo;
            if !w.has_axis() {
                return Err(invalid(
                    line,
                    w.g_col(920).unwrap_or(0),
                    "G92 without axis words",
                    "write G92 X.. Y.. Z..",
                ));
            }
            let rotated = self.to_program_mm(self.position) + self.g92;
            for (i, l) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
                if let Some(v) = w.get(l) {
                    self.g92[i] = if self.rotation() == 0.0 {
                        self.position[i] - off[i] - self.to_mm(v)
                    } else {
                        rotated[i] - self.to_mm(v)
                    };
                }
            }
            self.g92_saved = self.g92;
            self.g92_applied = true;
        } else if w.has_g(921) {
            self.g92 = Vec3::ZERO;
            self.g92_saved = Vec3::ZERO;
            self.g92_applied = false;
        } else if w.has_g(922) {
            self.g92 = Vec3::ZERO;
            self.g92_applied = false;
        } else if w.has_g(923) {
            self.g92 = self.g92_saved;
            self.g92_applied = true;
        }
        Ok(())
    }

    /// G10 L2 (set work offset P to the given machine coordinates), G10
    /// L20 (set it so the current point has the given program
    /// coordinates), and the tool table writes G10 L1/L10/L11.
    pub(super) fn g10(&mut self, line: u64, w: &WordTable) -> Result<(), GcodeError> {
        let col = w.g_col(100).unwrap_or(0);
        let l = w
            .get(b'L')
            .ok_or_else(|| invalid(line, col, "G10 without L", "write G10 L2 Pn X.. Y.. Z.."))?;
        if l == 1.0 || l == 10.0 || l == 11.0 {
            return self.g10_tool(line, w, l as u8);
        }
        if l != 2.0 && l != 20.0 {
            return Err(invalid(
                line,
                w.col(b'L').unwrap_or(col),
                format!("G10 L{l}: LinuxCNC knows only L1, L2, L10, L11 and L20"),
                "write L1/L10/L11 (tool table) or L2/L20 (work offsets)",
            ));
        }
        if l == 20.0 && w.get(b'R').is_some() {
            return Err(invalid(
                line,
                w.col(b'R').unwrap_or(col),
                "R is not allowed with G10 L20; LinuxCNC refuses it (\"R not allowed in G10 L20\")",
                "set the rotation with G10 L2 P.. R..",
            ));
        }
        let p = w.get(b'P').ok_or_else(|| {
            invalid(
                line,
                col,
                "G10 L2 without P",
                "write P1 for G54 … P9 for G59.3, P0 for the active system",
            )
        })?;
        let pcol = w.col(b'P').unwrap_or(col);
        // `check_g_codes` (interp_check.cc) tests `(int)(p ± 0.5)`: P must
        // not lie more than 0.0001 above it, and it must be 0 … 9; then
        // `convert_setup` (interp_convert.cc) takes `(int)(p + 0.0001)`, so
        // a P a little below a whole number selects the system below.
        let check = if p >= 0.0 {
            (p + 0.5).trunc()
        } else {
            (p - 0.5).trunc()
        };
        if (p + 0.0001) - check > 0.0002 {
            return Err(invalid(
                line,
                pcol,
                format!("G10 L{l} P{p}: P is not a whole number; LinuxCNC refuses it (\"P value not an integer with G10\")"),
                "P1 is G54, P9 is G59.3, P0 the active system",
            ));
        }
        if !(0.0..=9.0).contains(&check) {
            return Err(invalid(
                line,
                pcol,
                format!("G10 L{l} P{p}: P must be 0 … 9; LinuxCNC refuses it (\"P value out of range (0-9) with G10 L{l}\")"),
                "P1 is G54, P9 is G59.3, P0 the active system",
            ));
        }
        let p_int = (p + 0.0001).trunc();
        let idx = if p_int <= 0.0 {
            self.work
        } else {
            p_int as usize - 1
        };
        // The system is known from here on when the program gives all of
        // X, Y and Z (L2), or sets it relative to the known position (L20).
        if [b'X', b'Y', b'Z'].iter().all(|le| w.get(*le).is_some()) {
            self.work_given[idx] = true;
        } else if !self.work_given[idx] {
            let name = crate::setup::WORK_SYSTEMS[idx];
            return Err(invalid(
                line,
                col,
                format!("G10 L{l} sets only some axes of {name}, whose other axes the set-up does not give"),
                format!("give X, Y and Z on this line, or {name} under [work_offsets] in the set-up file"),
            ));
        }
        if l == 20.0 && self.rotation_deg[idx] != 0.0 {
            self.g10_l20_rotated(w, idx);
            return Ok(());
        }
        if let Some(r) = w.get(b'R') {
            self.rotation_deg[idx] = r;
        }
        let vals: Vec<(usize, f64)> = [b'X', b'Y', b'Z']
            .into_iter()
            .enumerate()
            .filter_map(|(i, le)| w.get(le).map(|v| (i, v)))
            .collect();
        for (i, v) in vals {
            let v = self.to_mm(v);
            self.work_offsets[idx][i] = if l == 2.0 {
                v
            } else {
                self.position[i] - self.g92[i] - self.tlo[i] - v
            };
        }
        Ok(())
    }

    /// G10 L20 on a system rotated by `r` (`Interp::convert_setup`): the
    /// current point `c` in that system (`find_current_in_system`:
    /// `Rot(−r)(q − tool − work) − G92`) and the wished point `t` (the words,
    /// or `c` where missing) are both turned back by `r`, and the new work
    /// offset is `Rot(r)c + work − Rot(r)t` in X/Y, `c + work − Z` in Z.
    fn g10_l20_rotated(&mut self, w: &WordTable, idx: usize) {
        let r = self.rotation_deg[idx];
        let wo = self.work_offsets[idx];
        let d = self.position - self.tlo - wo;
        let (cx, cy) = rotate(d.x, d.y, -r);
        let c = Vec3::new(cx, cy, d.z) - self.g92;
        if w.get(b'X').is_some() || w.get(b'Y').is_some() {
            let tx = w.get(b'X').map(|v| self.to_mm(v)).unwrap_or(c.x);
            let ty = w.get(b'Y').map(|v| self.to_mm(v)).unwrap_or(c.y);
            let (ox, oy) = rotate(c.x, c.y, r);
            let (tx, ty) = rotate(tx, ty, r);
            self.work_offsets[idx].x = ox + wo.x - tx;
            self.work_offsets[idx].y = oy + wo.y - ty;
        }
        if let Some(z) = w.get(b'Z') {
            self.work_offsets[idx].z = c.z + wo.z - self.to_mm(z);
        }
    }

    /// G10 L1 (tool P's offsets are the given values), L10 (set them so
    /// the current point has the given program coordinates in the active
    /// system, without the tool offset) and L11 (likewise in G59.3,
    /// ignoring G92), as `Interp::convert_setup_tool`. The tool table is
    /// the set-up's (`tool_lengths_mm`, Z) plus X/Y offsets kept here; it
    /// takes effect at the next G43, as on LinuxCNC.
    fn g10_tool(&mut self, line: u64, w: &WordTable, l: u8) -> Result<(), GcodeError> {
        let col = w.g_col(100).unwrap_or(0);
        let p = w.get(b'P').ok_or_else(|| {
            invalid(
                line,
                col,
                format!("G10 L{l} without P"),
                "write P and the tool number",
            )
        })?;
        let pcol = w.col(b'P').unwrap_or(col);
        // `check_g_codes` refuses `(int)(p ± 0.5)` below 1 ("P value out
        // of range with G10 L1"); `convert_setup_tool` takes the tool
        // `(int)(p + 0.5)` (`is_near_int`, whose verdict it ignores), so
        // P1.7 writes tool 2, as in LinuxCNC.
        let (tool, _) = crate::ngc::expr::near_int(p);
        let check = if p >= 0.0 {
            (p + 0.5).trunc()
        } else {
            (p - 0.5).trunc()
        };
        if check < 1.0 || tool < 1 {
            return Err(invalid(
                line,
                pcol,
                format!("G10 L{l} P{p}: P must be a tool number, 1 or more; LinuxCNC refuses it (\"P value out of range with G10 L{l}\")"),
                "fix the P word",
            ));
        }
        let tool = tool as u32;
        if !self.setup.tool_lengths_mm.contains_key(&tool) {
            return Err(invalid(
                line,
                pcol,
                format!("G10 L{l} writes tool {tool}, which is not in the tool table (LinuxCNC refuses it too)"),
                format!("add `{tool} = LENGTH` under [tools] in the set-up file"),
            ));
        }
        let any = [b'X', b'Y', b'Z', b'R', b'Q', b'I', b'J']
            .into_iter()
            .any(|le| w.get(le).is_some());
        if !any {
            return Err(invalid(
                line,
                col,
                format!("G10 L{l} without offsets has no effect (LinuxCNC refuses it)"),
                "give X, Y, Z (or R, Q, I, J)",
            ));
        }
        // Q (orientation): `is_near_int`, at most 9; -1 is LinuxCNC's "no Q".
        let orientation = match w.get(b'Q').filter(|q| *q != -1.0) {
            Some(q) => {
                let (o, near) = crate::ngc::expr::near_int(q);
                if !near || o > 9 {
                    return Err(invalid(
                        line,
                        w.col(b'Q').unwrap_or(col),
                        if near {
                            "Q in G10 is the tool orientation, at most 9; LinuxCNC refuses it (\"Invalid tool orientation\")"
                        } else {
                            "Q in G10 is the tool orientation, a whole number; LinuxCNC refuses it (\"Q number in G10 is not an integer\")"
                        },
                        "fix the Q word",
                    ));
                }
                Some(o as f64)
            }
            None => None,
        };
        let xy = self.tool_xy_mm.get(&tool).copied().unwrap_or([0.0; 2]);
        let mut off = [xy[0], xy[1], self.setup.tool_lengths_mm[&tool]];
        // The current point in the destination system, without the tool
        // offset (`find_current_in_system_without_tlo`); L11 writes
        // relative to G59.3 and ignores G92.
        let (system, g92) = if l == 11 {
            (8, Vec3::ZERO)
        } else {
            (self.work, self.g92)
        };
        // The current point in the destination system without the tool
        // offset, `Rot(−r)(q − work) − G92` (rotate by 0 is exact).
        let r = self.rotation_deg[system];
        let d = self.position - self.work_offsets[system];
        let (hx, hy) = rotate(d.x, d.y, -r);
        let here = Vec3::new(hx, hy, d.z) - g92;
        let word = |le: u8| w.get(le).map(|v| self.to_mm(v));
        if l != 1 {
            // `convert_setup_tool`: X/Y offsets are set in the rotated
            // frame; with one of X, Y the old offset's component along the
            // other rotated axis is kept.
            let (ox, oy) = rotate(off[0], off[1], -r);
            let (a, b) = match (word(b'X'), word(b'Y')) {
                (Some(x), Some(y)) => rotate(here.x - x, here.y - y, r),
                (Some(x), None) => {
                    let (kx, ky) = rotate(0.0, oy, r);
                    let (tx, ty) = rotate(here.x - x, 0.0, r);
                    (tx + kx, ty + ky)
                }
                (None, Some(y)) => {
                    let (kx, ky) = rotate(ox, 0.0, r);
                    let (tx, ty) = rotate(0.0, here.y - y, r);
                    (tx + kx, ty + ky)
                }
                (None, None) => (off[0], off[1]),
            };
            off[0] = a;
            off[1] = b;
        }
        for (i, le) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if let Some(v) = word(le) {
                if l == 1 {
                    off[i] = v;
                } else if i == 2 {
                    off[i] = here.z - v;
                }
                if !off[i].is_finite() || off[i].abs() > super::MAX_COORDINATE_MM {
                    return Err(invalid(
                        line,
                        w.col(le).unwrap_or(col),
                        "tool offset out of range",
                        "check the value",
                    ));
                }
            }
        }
        self.setup.tool_lengths_mm.insert(tool, off[2]);
        self.tool_xy_mm.insert(tool, [off[0], off[1]]);
        // Writing the loaded tool's entry refreshes #5400–#5413
        // (`convert_setup_tool` copies it to the spindle's slot).
        if tool == self.loaded_tool {
            self.param_tool = tool;
        }
        // R is the radius: the table's diameter becomes 2R (G41/G42 D use
        // it); I, J, Q the lathe tool's angles and orientation.
        if let Some(r) = w.get(b'R') {
            self.setup
                .tool_diameters_mm
                .insert(tool, 2.0 * self.to_mm(r));
        }
        if w.get(b'I').is_some() || w.get(b'J').is_some() || orientation.is_some() {
            let lathe = self.tool_lathe.entry(tool).or_insert([0.0; 3]);
            if let Some(i) = w.get(b'I') {
                lathe[0] = i;
            }
            if let Some(j) = w.get(b'J') {
                lathe[1] = j;
            }
            if let Some(o) = orientation {
                lathe[2] = o;
            }
        }
        Ok(())
    }

    /// LinuxCNC's `Interp::enhance_block` checks of G10, G28, G30, G52 and
    /// G92 (the modal group 0 codes that use axis words): not beside a
    /// motion code, and G52/G92 need an axis word.
    pub(super) fn check_axis_users(
        &self,
        line: u64,
        w: &WordTable,
        axis_user: Option<u16>,
    ) -> Result<(), GcodeError> {
        let Some(code) = axis_user.filter(|c| *c != 431) else {
            return Ok(());
        };
        if let Some(col) = self.motion_word_col(w) {
            return Err(invalid(
                line,
                col,
                format!("G{} and a motion code on one line both use the axis words; LinuxCNC refuses it (\"Cannot use two g codes that both use axis values\")", f64::from(code) / 10.0),
                "put the motion on its own line",
            ));
        }
        if (code == 520 || code == 920) && !w.has_axis() {
            return Err(invalid(
                line,
                w.g_col(code).unwrap_or(0),
                format!("G{} without axis words; LinuxCNC refuses it (\"All axes missing with g52 or g92\")", code / 10),
                format!("write G{} X.. Y.. Z..", code / 10),
            ));
        }
        Ok(())
    }

    /// The rotation about Z of the active coordinate system (degrees).
    pub(super) fn rotation(&self) -> f64 {
        self.rotation_deg[self.work]
    }

    /// The rotation about Z (degrees, counter-clockwise) of the active
    /// coordinate system, set by G10 L2 … R; 0 when not rotated. When it is
    /// not 0, [`Interpreter::frame_offset_mm`] alone does not relate program
    /// and axis coordinates.
    pub fn rotation_deg(&self) -> f64 {
        self.rotation()
    }

    /// The parts of the frame around the rotation, in mm: what is added to
    /// a program point before it is rotated (G92, G52) and after (work
    /// offset + tool length offset), so that
    /// `q = Rot(rotation_deg)·(p + before) + after`.
    pub fn frame_parts_mm(&self) -> (Vec3, Vec3) {
        (self.g92, self.work_offsets[self.work] + self.tlo)
    }

    /// Axis position of program point `p` (mm): LinuxCNC's canonical
    /// `rotate_and_offset_pos` (src/emc/task/emccanon.cc),
    /// `q = Rot(R)·(p + G92) + work_offset + tool_offset`.
    pub(super) fn to_axis(&self, p: Vec3) -> Vec3 {
        let r = self.rotation();
        if r == 0.0 {
            return p + self.frame_offset_mm();
        }
        let (x, y) = rotate(p.x + self.g92.x, p.y + self.g92.y, r);
        Vec3::new(x, y, p.z + self.g92.z) + self.work_offsets[self.work] + self.tlo
    }

    /// Program point (mm) of axis position `q`: the inverse of
    /// [`Self::to_axis`].
    pub(super) fn to_program_mm(&self, q: Vec3) -> Vec3 {
        let r = self.rotation();
        if r == 0.0 {
            return q - self.frame_offset_mm();
        }
        let d = q - self.work_offsets[self.work] - self.tlo;
        let (x, y) = rotate(d.x, d.y, -r);
        Vec3::new(x, y, d.z) - self.g92
    }

    /// The end point of a G0/G1 (or a G28/G30 intermediate point) in a
    /// rotated coordinate system: the words change the program point
    /// (absolute or incremental, in the rotated frame, as LinuxCNC's
    /// `current_x…` are), which is then rotated into the axis frame.
    pub(super) fn rotated_target(&self, w: &WordTable) -> Vec3 {
        let mut p = self.to_program_mm(self.position);
        for (i, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if let Some(v) = w.get(letter) {
                p[i] = if self.absolute {
                    self.to_mm(v)
                } else {
                    p[i] + self.to_mm(v)
                };
            }
        }
        if let Some((x, y)) = self.polar_end_of(w) {
            p.x = self.to_mm(x);
            p.y = self.to_mm(y);
        }
        self.to_axis(p)
    }

    /// An arc's centre (axis frame) from its centre words in a rotated
    /// system: absolute (G90.1) or relative to the start (G91.1) in the
    /// program frame, then rotated like any program point.
    pub(super) fn rotated_center(
        &self,
        w: &WordTable,
        start: Vec3,
        axes: [(usize, u8); 2],
    ) -> Vec3 {
        let mut c = self.to_program_mm(start);
        for (axis, letter) in axes {
            let val = w.get(letter).map(|x| self.to_mm(x)).unwrap_or(0.0);
            c[axis] = if self.arc_absolute {
                val
            } else {
                c[axis] + val
            };
        }
        self.to_axis(c)
    }

    /// In a rotated coordinate system, volcomp follows G0, G1, G2/G3 in
    /// G17, G53 and G28/G30; canned cycles, splines and G18/G19 arcs (which
    /// LinuxCNC turns out of their axis planes) are refused.
    pub(super) fn check_rotated(
        &self,
        line: u64,
        col: usize,
        w: &WordTable,
        mode: super::options::MotionMode,
    ) -> Result<(), GcodeError> {
        use super::options::MotionMode as M;
        if self.rotation() == 0.0 || w.has_g(530) {
            return Ok(());
        }
        let what = match mode {
            M::Cycle(_) => "canned cycles",
            M::Spline(_) => "splines",
            M::Cw | M::Ccw if self.plane != crate::geom::Plane::Xy => {
                "arcs in G18/G19 (LinuxCNC turns their plane with the rotation, out of the axis planes)"
            }
            _ => return Ok(()),
        };
        Err(unsupported(
            line,
            col,
            format!(
                "{what} in a rotated coordinate system (G10 L2 R{}) are not interpreted",
                self.rotation()
            ),
            "post the program without the rotation, or with explicit G1/G2/G3 moves in G17",
        ))
    }

    /// G28/G30: a rapid to the intermediate point given by the axis words,
    /// then to the reference point of the set-up (only on the axes named
    /// when axis words are given), warning once when the set-up gives none.
    pub(super) fn home(
        &mut self,
        line: u64,
        w: &WordTable,
        g28: bool,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        let code = if g28 { 280 } else { 300 };
        let col = w.g_col(code).unwrap_or(0);
        let (reference, given) = if g28 {
            (self.setup.g28_mm, self.setup.g28_given)
        } else {
            (self.setup.g30_mm, self.setup.g30_given)
        };
        let which = usize::from(!g28);
        if !given && !self.warned_reference[which] {
            self.warned_reference[which] = true;
            let name = if g28 { "G28" } else { "G30" };
            self.warnings.push(Warning {
                line,
                column: col + 1,
                message: format!("{name} goes to the {name} reference point, which the set-up does not give: machine zero (0, 0, 0) is assumed, as LinuxCNC does with an unset {name} point; give it under [reference] in the set-up file (the reference points of the set-up), e.g. {name} = [x, y, z]"),
            });
        }
        let intermediate = self.target(w);
        let feed = self.to_mm(self.feed);
        self.push(
            out,
            MotionKind::Rapid,
            MotionSource::Reference,
            intermediate,
            line,
            col,
            feed,
        )?;
        let mut fin = intermediate;
        if !w.has_axis() {
            // All axes go to the reference point; the extra axes' is 0.
            self.extra_target = [0.0; 6];
        }
        for (i, l) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if !w.has_axis() || w.get(l).is_some() {
                fin[i] = reference[i];
            }
        }
        self.push(
            out,
            MotionKind::Rapid,
            MotionSource::Reference,
            fin,
            line,
            col,
            feed,
        )?;
        Ok(())
    }
}

/// LinuxCNC's `Interp::rotate`: `(x, y)` turned by `theta` degrees about
/// the origin, counter-clockwise.
pub(super) fn rotate(x: f64, y: f64, theta_deg: f64) -> (f64, f64) {
    let (sin, cos) = theta_deg.to_radians().sin_cos();
    (x * cos - y * sin, x * sin + y * cos)
}
