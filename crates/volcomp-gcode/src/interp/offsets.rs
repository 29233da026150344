//! Coordinate systems and offsets: tool length offsets (G43, G43.1, G49),
//! work offsets set by the program (G10 L2/L20), G92 and its variants, and
//! the reference points G28/G30.
//!
//! They only move the frame: `q = p + work_offset + tool_length_offset +
//! G92` (machine = program + offsets), as in LinuxCNC's `Interp`
//! (src/emc/rs274ngc/interp_convert.cc: `convert_tool_length_offset`,
//! `convert_setup`, `convert_axis_offsets`, `convert_home`).

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
            let length = if h == 0 {
                0.0
            } else {
                *self.setup.tool_lengths_mm.get(&h).ok_or_else(|| {
                    invalid(
                        line,
                        col,
                        format!("G43 uses tool {h}, which the setup has no length for"),
                        format!("add `{h} = LENGTH` under [tools] in the set-up file (the tool lengths of the set-up, `Setup::tool_lengths_mm`)"),
                    )
                })?
            };
            self.tlo = Vec3::new(0.0, 0.0, length);
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
        if w.has_g(920) {
            let off = self.work_offsets[self.work] + self.tlo;
            if !w.has_axis() {
                return Err(invalid(
                    line,
                    w.g_col(920).unwrap_or(0),
                    "G92 without axis words",
                    "write G92 X.. Y.. Z..",
                ));
            }
            for (i, l) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
                if let Some(v) = w.get(l) {
                    self.g92[i] = self.position[i] - off[i] - self.to_mm(v);
                }
            }
            self.g92_saved = self.g92;
        } else if w.has_g(921) {
            self.g92 = Vec3::ZERO;
            self.g92_saved = Vec3::ZERO;
        } else if w.has_g(922) {
            self.g92 = Vec3::ZERO;
        } else if w.has_g(923) {
            self.g92 = self.g92_saved;
        }
        Ok(())
    }

    /// G10 L2 (set work offset P to the given machine coordinates) and
    /// G10 L20 (set it so the current point has the given program
    /// coordinates); other L numbers (tool tables) are refused.
    pub(super) fn g10(&mut self, line: u64, w: &WordTable) -> Result<(), GcodeError> {
        let col = w.g_col(100).unwrap_or(0);
        let l = w
            .get(b'L')
            .ok_or_else(|| invalid(line, col, "G10 without L", "write G10 L2 Pn X.. Y.. Z.."))?;
        if l != 2.0 && l != 20.0 {
            return Err(unsupported(
                line,
                col,
                format!("G10 L{l} is not interpreted (only L2 and L20, work offsets)"),
                "set tool data in the setup file instead",
            ));
        }
        if w.get(b'R').is_some_and(|r| r != 0.0) {
            return Err(unsupported(
                line,
                col,
                "G10 with a rotation R is not a translation",
                "remove the R word",
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
        if !(0.0..=9.0).contains(&p) || p.fract() != 0.0 {
            return Err(invalid(
                line,
                w.col(b'P').unwrap_or(col),
                "P must be 0 … 9 with G10",
                "P1 is G54, P9 is G59.3, P0 the active system",
            ));
        }
        let idx = if p == 0.0 { self.work } else { p as usize - 1 };
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
