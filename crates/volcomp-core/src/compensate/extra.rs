//! The extra axes A, B, C, U, V, W of a motion that compensation splits
//! into several commands.
//!
//! They are not compensated (the map is of X, Y, Z). The controller moves
//! every axis linearly over a G1 (and over an arc, `ARC_FEED`'s A…W end
//! values), so when one block becomes several G1 segments, each segment
//! carries the extra axes' share of the motion in proportion to its length
//! along the path: the extra axes reach the block's end values exactly at
//! its end, and their motion relative to the tool point is the original's
//! (to the chord tolerance on arcs). Take-up moves leave them where they are.

use super::frame::Frame;
use volcomp_gcode::lexer::Word;
use volcomp_gcode::number::{format_number, NumberStyle};
use volcomp_gcode::{ExtraAxes, Vec3, EXTRA_LETTERS};

/// The extra-axis words of each command of a split motion.
pub(super) struct ExtraPlan {
    extra: ExtraAxes,
    /// Path fraction at the end of each command.
    fractions: Vec<f64>,
    absolute: bool,
    mm_per_unit: f64,
    /// What the commands written so far have sent, per axis (word units).
    sent: [f64; 6],
}

impl ExtraPlan {
    /// `None` unless the motion moves an extra axis and is split. `offset`
    /// is what the interpreter adds to the extra axes' program values
    /// ([`volcomp_gcode::Interpreter::extra_offset`]).
    pub(super) fn new(
        extra: ExtraAxes,
        offset: [f64; 6],
        start: Vec3,
        targets: &[Vec3],
        frame: &Frame,
    ) -> Option<Self> {
        if !extra.moves() || targets.len() < 2 {
            return None;
        }
        // Program values: what the words say.
        let mut extra = extra;
        for (i, off) in offset.iter().enumerate() {
            extra.start[i] -= off;
            extra.end[i] -= off;
        }
        let mut acc = Vec::with_capacity(targets.len());
        let (mut len, mut prev) = (0.0, start);
        for t in targets {
            len += (*t - prev).norm();
            acc.push(len);
            prev = *t;
        }
        let n = targets.len();
        let fractions = acc
            .iter()
            .enumerate()
            .map(|(i, l)| {
                if i + 1 == n {
                    1.0
                } else if len > 0.0 {
                    l / len
                } else {
                    (i + 1) as f64 / n as f64
                }
            })
            .collect();
        let mm_per_unit = frame.mm_per_unit;
        let mut sent = extra.start;
        for v in sent.iter_mut().skip(3) {
            *v /= mm_per_unit;
        }
        Some(Self {
            extra,
            fractions,
            absolute: frame.absolute,
            mm_per_unit,
            sent,
        })
    }

    /// The word value of extra axis `a` for command `k` (absolute, or the
    /// increment from what was sent before), rounded to `decimals`; `None`
    /// for an axis that does not move.
    fn value(&mut self, k: usize, a: usize, decimals: u8) -> Option<f64> {
        if self.extra.start[a] == self.extra.end[a] {
            return None;
        }
        let mut target = self.extra.at(self.fractions[k])[a];
        if a >= 3 {
            target /= self.mm_per_unit;
        }
        let scale = 10f64.powi(i32::from(decimals));
        let v = if self.absolute {
            (target * scale).round() / scale
        } else {
            ((target - self.sent[a]) * scale).round() / scale
        };
        self.sent[a] = if self.absolute { v } else { self.sent[a] + v };
        Some(v)
    }

    /// Replacements of the block's own extra-axis words for command 0:
    /// `(value span, text)`.
    pub(super) fn first_edits(
        &mut self,
        words: &[&Word],
        style: NumberStyle,
    ) -> Vec<(std::ops::Range<usize>, String)> {
        let mut edits = Vec::new();
        for w in words {
            let Some(a) = EXTRA_LETTERS.iter().position(|l| *l == w.letter) else {
                continue;
            };
            let own = w.decimals.min(15);
            let style = style.with_decimals(style.decimals.max(own));
            if let Some(v) = self.value(0, a, style.decimals) {
                let mut text = String::new();
                format_number(v, style, &mut text);
                edits.push((w.value_span.clone(), text));
            }
        }
        edits
    }

    /// The extra-axis words of inserted command `k ≥ 1`, each preceded by
    /// `sep`.
    pub(super) fn words_for(&mut self, k: usize, style: NumberStyle, sep: &str) -> String {
        let mut text = String::new();
        for (a, letter) in EXTRA_LETTERS.iter().enumerate() {
            if let Some(v) = self.value(k, a, style.decimals.max(4)) {
                if self.absolute || v != 0.0 {
                    text.push_str(sep);
                    text.push(*letter as char);
                    format_number(v, style.with_decimals(style.decimals.max(4)), &mut text);
                }
            }
        }
        text
    }
}
