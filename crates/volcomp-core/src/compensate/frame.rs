//! The program frame of a line (work offset, units, distance mode) and the
//! quantisation of commands to the written decimals.

use super::CompensateOptions;
use volcomp_gcode::lexer::Word;
use volcomp_gcode::number::{NumberStyle, StyleSurvey};
use volcomp_gcode::{Units, Vec3};

/// The program frame of a line and how its numbers are written.
#[derive(Debug, Clone, Copy)]
pub(super) struct Frame {
    pub(super) offset_mm: Vec3,
    pub(super) mm_per_unit: f64,
    pub(super) decimals: u8,
    pub(super) absolute: bool,
}

impl Frame {
    /// The frame and number style of the line just interpreted: its offsets,
    /// units and distance mode; 4 decimals in mm, 5 in inch unless overridden.
    pub(super) fn of(
        interp: &volcomp_gcode::Interpreter,
        options: &CompensateOptions,
        survey: &StyleSurvey,
    ) -> (Frame, NumberStyle) {
        let units = interp.units();
        let decimals = options.decimals.unwrap_or(
            match units {
                Units::Mm => 4,
                Units::Inch => 5,
            }
            .max(survey.max_decimals()),
        );
        let frame = Frame {
            offset_mm: interp.frame_offset_mm(),
            mm_per_unit: units.mm_per_unit(),
            decimals,
            absolute: interp.absolute(),
        };
        (frame, survey.style(decimals))
    }

    /// This frame with at least as many decimals as any X, Y or Z word of
    /// the line (up to [`volcomp_gcode::number::MAX_DECIMALS`]).
    pub(super) fn with_line_decimals<'a>(
        mut self,
        words: impl Iterator<Item = &'a Word>,
        bytes: &[u8],
        style: NumberStyle,
    ) -> (Frame, NumberStyle) {
        let most = words
            .filter(|w| matches!(w.letter, b'X' | b'Y' | b'Z'))
            .map(|w| volcomp_gcode::number::decimals_of(&bytes[w.value_span.clone()]))
            .max()
            .unwrap_or(0)
            .min(volcomp_gcode::number::MAX_DECIMALS);
        if most > self.decimals {
            self.decimals = most;
            return (self, style.with_decimals(most));
        }
        (self, style)
    }

    pub(super) fn round(&self, v: f64) -> f64 {
        let k = 10f64.powi(i32::from(self.decimals));
        (v * k).round() / k
    }

    /// Program-frame value (program units) of axis-frame `q`.
    pub(super) fn program(&self, q: Vec3) -> Vec3 {
        (q - self.offset_mm) * (1.0 / self.mm_per_unit)
    }

    /// The word value to write for axis `a` when moving from `from` to `q`.
    pub(super) fn word_value(&self, q: Vec3, from: Vec3, a: usize) -> f64 {
        if self.absolute {
            self.round(self.program(q)[a])
        } else {
            self.round(self.program(q)[a] - self.program(from)[a])
        }
    }

    /// The command the controller really executes for a wish `q` from `from`.
    pub(super) fn quantize(&self, q: Vec3, from: Vec3) -> Vec3 {
        let mut out = q;
        for a in 0..3 {
            let v = self.word_value(q, from, a);
            out[a] = if self.absolute {
                v * self.mm_per_unit + self.offset_mm[a]
            } else {
                from[a] + v * self.mm_per_unit
            };
            // An axis whose written value would not change stays exactly put.
            if (out[a] - from[a]).abs()
                < 0.5 * 10f64.powi(-i32::from(self.decimals)) * self.mm_per_unit * 1e-3
            {
                out[a] = from[a];
            }
        }
        out
    }
}
