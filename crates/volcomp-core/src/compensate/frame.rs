//! The program frame of a line (work offset, units, distance mode) and the
//! quantisation of commands to the written decimals.
//!
//! In a rotated coordinate system (G10 L2 … R) the frame is LinuxCNC's
//! `q = Rot(R)·(p + G92) + work_offset + tool_offset` (emccanon.cc
//! `rotate_and_offset_pos`): the compensated axis point `q` is written back
//! as the program point `p = Rot(−R)·(q − work_offset − tool_offset) − G92`,
//! so a correction along axis X may change both the X and the Y word (and
//! under G91 both increments, taken in the rotated frame). Without a
//! rotation the frame is the plain translation `p = q − offset`, computed
//! exactly as before.

use super::{CompensateOptions, DEFAULT_DECIMALS_INCH, DEFAULT_DECIMALS_MM};
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
    /// Rotation about Z (degrees), and the offsets added before (G92) and
    /// after (work + tool) it; unused when the rotation is 0.
    pub(super) rotation_deg: f64,
    pub(super) before_mm: Vec3,
    pub(super) after_mm: Vec3,
    /// Written X word per program X: 2 in lathe diameter mode (G7), where
    /// an X word is a diameter, else 1.
    pub(super) x_word_scale: f64,
    /// Arc centres (I, J, K) are absolute (G90.1, or by option
    /// `--absolute-arc-centers`: then written absolute too, for the program's
    /// own controller).
    pub(super) arc_absolute: bool,
}

impl Frame {
    /// The frame and number style of the line just interpreted: its offsets,
    /// units and distance mode; [`DEFAULT_DECIMALS_MM`] in mm,
    /// [`DEFAULT_DECIMALS_INCH`] in inch, unless overridden.
    pub(super) fn of(
        interp: &volcomp_gcode::Interpreter,
        options: &CompensateOptions,
        survey: &StyleSurvey,
    ) -> (Frame, NumberStyle) {
        let units = interp.units();
        let decimals = options.decimals.unwrap_or(
            match units {
                Units::Mm => DEFAULT_DECIMALS_MM,
                Units::Inch => DEFAULT_DECIMALS_INCH,
            }
            .max(survey.max_decimals()),
        );
        // One call for both parts (a copy of the interpreter's offsets).
        let (before_mm, after_mm) = interp.frame_parts_mm();
        let frame = Frame {
            offset_mm: interp.frame_offset_mm(),
            mm_per_unit: units.mm_per_unit(),
            decimals,
            absolute: interp.absolute(),
            rotation_deg: interp.rotation_deg(),
            before_mm,
            after_mm,
            x_word_scale: if interp.diameter_mode() { 2.0 } else { 1.0 },
            arc_absolute: interp.arc_absolute(),
        };
        (frame, survey.style(decimals))
    }

    /// This frame with at least as many decimals as any X, Y or Z word of
    /// the line (up to [`volcomp_gcode::number::MAX_DECIMALS`]).
    pub(super) fn with_line_decimals<'a>(
        mut self,
        words: impl Iterator<Item = &'a Word>,
        style: NumberStyle,
    ) -> (Frame, NumberStyle) {
        let most = words
            .filter(|w| matches!(w.letter, b'X' | b'Y' | b'Z'))
            .map(|w| w.decimals)
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
        let k = pow10(self.decimals);
        round_bits(v * k) / k
    }

    /// Program-frame value (program units) of axis-frame `q`.
    pub(super) fn program(&self, q: Vec3) -> Vec3 {
        if self.rotation_deg != 0.0 {
            return self.program_mm(q) * (1.0 / self.mm_per_unit);
        }
        (q - self.offset_mm) * (1.0 / self.mm_per_unit)
    }

    /// Program point in mm of axis point `q` in a rotated frame.
    fn program_mm(&self, q: Vec3) -> Vec3 {
        let d = q - self.after_mm;
        let (x, y) = rotate(d.x, d.y, -self.rotation_deg);
        Vec3::new(x, y, d.z) - self.before_mm
    }

    /// Axis point of program point `p` (mm) in a rotated frame.
    fn axis(&self, p: Vec3) -> Vec3 {
        let (x, y) = rotate(
            p.x + self.before_mm.x,
            p.y + self.before_mm.y,
            self.rotation_deg,
        );
        Vec3::new(x, y, p.z + self.before_mm.z) + self.after_mm
    }

    /// Whether moving from `from` to `q` changes program coordinate `a`
    /// (so its word must be written): the axis coordinate itself without a
    /// rotation, the rotated-frame coordinate with one.
    pub(super) fn changes(&self, q: Vec3, from: Vec3, a: usize) -> bool {
        if self.rotation_deg == 0.0 {
            return q[a] != from[a];
        }
        (self.program_mm(q)[a] - self.program_mm(from)[a]).abs() > 1e-9
    }

    /// The word value to write for axis `a` when moving from `from` to `q`
    /// (in G7 an X word is the diameter: twice the program coordinate).
    pub(super) fn word_value(&self, q: Vec3, from: Vec3, a: usize) -> f64 {
        self.word_of(self.program(q), from, a)
    }

    /// [`Self::word_value`] of the program point `p = self.program(q)`
    /// (computed once for the three axes).
    fn word_of(&self, p: Vec3, from: Vec3, a: usize) -> f64 {
        // `self.round`: the count of steps over the scale.
        self.scaled_word_of(p, from, a) / pow10(self.decimals)
    }

    /// [`Self::word_value`] as the integer count of the written resolution
    /// it is (`round(word · 10^decimals)`, before the division): what
    /// [`volcomp_gcode::number::format_scaled_bytes`] writes.
    /// (Inlined: every axis word written takes it, about 180,000 a CAM
    /// program of 67,000 lines.)
    #[inline]
    pub(super) fn word_scaled(&self, q: Vec3, from: Vec3, a: usize) -> f64 {
        self.scaled_word_of(self.program(q), from, a)
    }

    #[inline(always)]
    fn scaled_word_of(&self, p: Vec3, from: Vec3, a: usize) -> f64 {
        let k = if a == 0 { self.x_word_scale } else { 1.0 };
        let word = if self.absolute {
            p[a] * k
        } else {
            (p[a] - self.program(from)[a]) * k
        };
        round_bits(word * pow10(self.decimals))
    }

    /// The command the controller really executes for a wish `q` from `from`.
    /// (Inlined: the solves call it a few times a target.)
    #[inline]
    pub(super) fn quantize(&self, q: Vec3, from: Vec3) -> Vec3 {
        if self.rotation_deg != 0.0 {
            return self.quantize_rotated(q, from);
        }
        // `program`, `word_of` and `round` written out once for the three
        // axes (the same operations in the same order: the same bits), the
        // scale and the threshold computed once.
        let scale = pow10(self.decimals);
        if self.absolute && self.mm_per_unit == 1.0 && self.x_word_scale == 1.0 {
            // Absolute millimetres outside G7 (most programs): the products
            // and quotients by 1 below are left out (`x · 1` and `x / 1`
            // are `x`: the same bits).
            let still = 0.5 * (1.0 / scale) * 1e-3;
            let axis = |a: usize| -> f64 {
                let v = round_bits((q[a] - self.offset_mm[a]) * scale) / scale;
                let out = v + self.offset_mm[a];
                if (out - from[a]).abs() < still {
                    from[a]
                } else {
                    out
                }
            };
            return Vec3::new(axis(0), axis(1), axis(2));
        }
        let per_mm = 1.0 / self.mm_per_unit;
        let p = (q - self.offset_mm) * per_mm;
        let p_from = (from - self.offset_mm) * per_mm;
        let still = 0.5 * (1.0 / scale) * self.mm_per_unit * 1e-3;
        let axis = |a: usize, p: f64, p_from: f64| -> f64 {
            let k = if a == 0 { self.x_word_scale } else { 1.0 };
            let word = if self.absolute {
                p * k
            } else {
                (p - p_from) * k
            };
            let v = round_bits(word * scale) / scale / k;
            let out = if self.absolute {
                v * self.mm_per_unit + self.offset_mm[a]
            } else {
                from[a] + v * self.mm_per_unit
            };
            // An axis whose written value would not change stays exactly put.
            if (out - from[a]).abs() < still {
                from[a]
            } else {
                out
            }
        };
        Vec3::new(
            axis(0, p.x, p_from.x),
            axis(1, p.y, p_from.y),
            axis(2, p.z, p_from.z),
        )
    }

    /// [`Self::quantize`] in a rotated frame: the words are rounded in the
    /// program frame and the controller's point is the rotated program
    /// point; a program coordinate whose word would not change stays put.
    /// (Out of line: inlined, its rotation's `sincos` call and spills made
    /// every quantization save registers and reserve stack first.)
    #[cold]
    #[inline(never)]
    fn quantize_rotated(&self, q: Vec3, from: Vec3) -> Vec3 {
        let p_from = self.program_mm(from);
        let mut p = p_from;
        let mut moved = false;
        for a in 0..3 {
            let k = if a == 0 { self.x_word_scale } else { 1.0 };
            let v = self.word_value(q, from, a) / k * self.mm_per_unit;
            let new = if self.absolute { v } else { p_from[a] + v };
            if (new - p_from[a]).abs()
                >= 0.5 * (1.0 / pow10(self.decimals)) * self.mm_per_unit * 1e-3
            {
                p[a] = new;
                moved = true;
            }
        }
        if !moved {
            return from;
        }
        let mut out = self.axis(p);
        if p[2] == p_from[2] {
            out.z = from.z;
        }
        out
    }
}

/// LinuxCNC's `rotate`: `(x, y)` turned by `theta_deg` degrees about the
/// origin, counter-clockwise.
fn rotate(x: f64, y: f64, theta_deg: f64) -> (f64, f64) {
    let (sin, cos) = theta_deg.to_radians().sin_cos();
    (x * cos - y * sin, x * sin + y * cos)
}

/// `v.round()` (half away from zero) bit for bit, as
/// [`volcomp_gcode::number::round_bits`] gives it, in fewer instructions:
/// below 2^51 adding and taking away 2^52 rounds `|v|` to an integer (the
/// floats from 2^52 to 2^53 are the integers; IEEE 754 rounds to the
/// nearest, a tie to the even one, and both operations are exact but for
/// that rounding), and a tie that went down (`r − |v| = −½`, exact as
/// both are within one of each other) goes up instead; the sign is
/// `v`'s, as `round` keeps it (a zero result included). Larger and
/// non-finite values (no fraction, or NaN) are `round`'s own.
#[inline(always)]
pub(super) fn round_bits(v: f64) -> f64 {
    const TWO_52: f64 = 4_503_599_627_370_496.0;
    const TWO_51: f64 = 2_251_799_813_685_248.0;
    let a = v.abs();
    // Also NaN: the comparison is false (one comparison for both).
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(a < TWO_51) {
        return v.round();
    }
    let r = (a + TWO_52) - TWO_52;
    let r = if r - a == -0.5 { r + 1.0 } else { r };
    r.copysign(v)
}

/// `10^d` from a table (a `powi` call per written word cost time):
/// every power up to 10²² is exact in `f64`, as `powi`'s products of exact
/// values are, and `1.0 / pow10(d)` is `powi(−d)`'s one division: the same
/// bits.
pub(super) fn pow10(d: u8) -> f64 {
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    POW10
        .get(usize::from(d))
        .copied()
        .unwrap_or_else(|| 10f64.powi(i32::from(d)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rotated(deg: f64, absolute: bool) -> Frame {
        Frame {
            offset_mm: Vec3::ZERO,
            mm_per_unit: 1.0,
            decimals: 4,
            absolute,
            rotation_deg: deg,
            before_mm: Vec3::new(1.0, 0.0, 0.0),
            after_mm: Vec3::new(10.0, 5.0, 2.0),
            x_word_scale: 1.0,
            arc_absolute: false,
        }
    }

    /// [`round_bits`] is `f64::round` to the bit (the second method; the
    /// sign of a zero result included) on ties, near-ties, the ends of its
    /// range, the written counts of coordinates and random floats: one
    /// value by hand too (`-2.5` rounds away from zero to `-3`).
    #[test]
    fn round_bits_is_round() {
        assert_eq!(round_bits(-2.5), -3.0);
        assert_eq!(round_bits(0.49999999999999994), 0.0);
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            2.5,
            -3.5,
            0.49999999999999994,
            -0.49999999999999994,
            2_251_799_813_685_247.5,
            -2_251_799_813_685_247.5,
            2_251_799_813_685_248.0,
            4_503_599_627_370_495.5,
            4_503_599_627_370_497.0,
            1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            5e-324,
        ];
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut ties = 0;
        for _ in 0..300_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let scale = [1e-3, 1.0, 1e3, 1e6, 1e9, 1e14, 1e16][(x % 7) as usize];
            values.push(((x >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * scale);
            values.push(f64::from_bits(x));
            // Halves (ties) and their neighbours.
            let half = (x % 2_000_000) as f64 * 0.5 - 500_000.0;
            values.extend([
                half,
                f64::from_bits(half.to_bits().wrapping_add(1)),
                f64::from_bits(half.to_bits().wrapping_sub(1)),
            ]);
            ties += usize::from(half.fract().abs() == 0.5);
            // A coordinate's count of 10^-6 mm as quantising makes it.
            values.push((((x >> 20) as f64 / (1u64 << 44) as f64) * 2000.0 - 1000.0) * 1e6);
        }
        assert!(ties > 100_000, "{ties}");
        for v in values.into_iter().filter(|v| !v.is_nan()) {
            assert_eq!(round_bits(v).to_bits(), v.round().to_bits(), "{v:e}");
        }
        assert!(round_bits(f64::NAN).is_nan());
    }

    /// The table gives `powi`'s bits (the rounding of every written word
    /// depends on them), up to and past its end.
    #[test]
    fn pow10_is_powi() {
        for d in 0..=30u8 {
            let e = i32::from(d);
            assert_eq!(pow10(d).to_bits(), 10f64.powi(e).to_bits(), "10^{d}");
            assert_eq!(
                (1.0 / pow10(d)).to_bits(),
                10f64.powi(-e).to_bits(),
                "10^-{d}"
            );
        }
    }

    /// The quantisation of absolute millimetres outside G7 (without the
    /// products and quotients by 1) is the written words' command to the
    /// bit: the second method is the word of each axis
    /// ([`Frame::word_value`]) read back through the frame, an axis whose
    /// word would not change left where it was, on 100,000 random
    /// commands near the previous one (steps from 1 nm to 10 mm, 3 to 6
    /// decimals, work offsets with fractions, the previous command written
    /// or not). Asserts that both kinds of axis occurred.
    #[test]
    fn quantize_in_millimetres_is_the_words_read_back() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut moved, mut still) = (0, 0);
        for k in 0..100_000 {
            let f = Frame {
                offset_mm: Vec3::new(250.0 + rnd(), 200.125, -150.0 - rnd()),
                decimals: 3 + (k % 4) as u8,
                absolute: true,
                ..rotated(0.0, true)
            };
            let raw = Vec3::new(rnd() * 600.0 - 300.0, rnd() * 400.0, -rnd() * 150.0);
            // Every other command from a written one (its words on the
            // grid), as the compensation's are.
            let far = raw + Vec3::new(1.0, 1.0, 1.0);
            let from = if k % 2 == 0 {
                f.quantize(raw, far)
            } else {
                raw
            };
            let step = [1e-6, 1e-4, 1e-2, 10.0][k % 4];
            let q = from + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * step;
            let out = f.quantize(q, from);
            let half_step_mm = 0.5 * (1.0 / pow10(f.decimals)) * 1e-3;
            for a in 0..3 {
                let read = f.word_value(q, from, a) + f.offset_mm[a];
                let expected = if (read - from[a]).abs() < half_step_mm {
                    still += 1;
                    from[a]
                } else {
                    moved += 1;
                    read
                };
                assert_eq!(out[a].to_bits(), expected.to_bits(), "{q:?} from {from:?}");
            }
        }
        assert!(moved > 100_000 && still > 10_000, "{moved} {still}");
    }

    #[test]
    fn r90_program_x_is_axis_y() {
        // q = Rot(90°)(p + (1, 0, 0)) + (10, 5, 2): program (2, 0, 0) is
        // Rot90 (3, 0) = (0, 3), so axis (10, 8, 2); and back.
        let f = rotated(90.0, true);
        let q = Vec3::new(10.0, 8.0, 2.0);
        let p = f.program(q);
        assert!((p.x - 2.0).abs() < 1e-12 && p.y.abs() < 1e-12 && p.z.abs() < 1e-12);
        // An axis-X correction of +0.1 is a program −Y word of 0.1 (R90
        // turns program −Y onto axis +X), X unchanged.
        let q2 = Vec3::new(10.1, 8.0, 2.0);
        assert!(f.changes(q2, q, 1) && !f.changes(q2, q, 0) && !f.changes(q2, q, 2));
        assert_eq!(f.word_value(q2, q, 1), -0.1);
        assert_eq!(f.word_value(q2, q, 0), 2.0);
        // In G91 the increment is in the program frame as well.
        let g91 = rotated(90.0, false);
        assert_eq!(g91.word_value(q2, q, 1), -0.1);
        assert_eq!(g91.word_value(q2, q, 0), 0.0);
        // What the controller executes for the rounded words.
        let out = f.quantize(Vec3::new(10.100004, 8.0, 2.0), q);
        assert!((out.x - 10.1).abs() < 1e-12 && (out.y - 8.0).abs() < 1e-12);
        assert_eq!(out.z, 2.0);
    }
}
