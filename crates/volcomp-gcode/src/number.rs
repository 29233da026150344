//! Writing numbers back in the program's own style.
//!
//! CAM post-processors differ in how they print numbers: `0.5` or `.5`,
//! `1.2000` or `1.2`, `10.` or `10`. A rewritten word must look like its
//! neighbours, so the style is inferred from the numbers already in the
//! program and only the decimal count is configurable. Scientific notation is
//! never written: controllers do not read it.

/// How a program prints its numbers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NumberStyle {
    /// Digits after the decimal point (before trimming).
    pub decimals: u8,
    /// `0.5` (true) or `.5` (false).
    pub leading_zero: bool,
    /// Drop trailing zeros after the point (`1.2` instead of `1.2000`).
    pub trim_trailing_zeros: bool,
    /// When trimming leaves an integer, keep the point (`10.`), as Fanuc-style posts do.
    pub trailing_dot: bool,
}

impl NumberStyle {
    /// Fixed decimals with a leading zero: `0.5000`, `-12.0000`.
    pub const fn fixed(decimals: u8) -> Self {
        Self {
            decimals,
            leading_zero: true,
            trim_trailing_zeros: false,
            trailing_dot: false,
        }
    }

    /// The same style with another number of decimals.
    pub const fn with_decimals(self, decimals: u8) -> Self {
        Self { decimals, ..self }
    }
}

/// Counts style evidence over the numbers of a program.
#[derive(Debug, Default, Clone)]
pub struct StyleSurvey {
    leading_zero: u32,
    no_leading_zero: u32,
    trailing_zero: u32,
    trimmed_fraction: u32,
    trailing_dot: u32,
    bare_integer: u32,
    max_decimals: u8,
}

/// Most decimals volcomp writes: beyond this an `f64` coordinate of a
/// machine-sized value (metres, in mm) no longer holds the digits exactly.
pub const MAX_DECIMALS: u8 = 9;

/// Digits after the decimal point of a number as written (`0.096205` → 6,
/// `10.` → 0, `12` → 0); blanks inside the number are ignored.
///
/// A rewritten word never carries fewer decimals than the word it replaces:
/// the written value would otherwise be rounded coarser than the program's
/// own, moving the tool even where the correction is zero.
pub fn decimals_of(text: &[u8]) -> u8 {
    match text.iter().position(|b| *b == b'.') {
        None => 0,
        Some(dot) => {
            let n = text[dot + 1..]
                .iter()
                .filter(|b| b.is_ascii_digit())
                .count();
            u8::try_from(n).unwrap_or(u8::MAX)
        }
    }
}

impl StyleSurvey {
    /// Records one number as written (blanks inside it are ignored).
    pub fn record(&mut self, text: &[u8]) {
        self.max_decimals = self.max_decimals.max(decimals_of(text));
        let digits: Vec<u8> = text
            .iter()
            .copied()
            .filter(|b| *b != b' ' && *b != b'\t' && *b != b'+' && *b != b'-')
            .collect();
        match digits.iter().position(|b| *b == b'.') {
            None => self.bare_integer += 1,
            Some(dot) => {
                let (int, frac) = (&digits[..dot], &digits[dot + 1..]);
                if int.is_empty() {
                    self.no_leading_zero += 1;
                } else if int == b"0" {
                    self.leading_zero += 1;
                }
                match frac.last() {
                    None => self.trailing_dot += 1,
                    Some(b'0') => self.trailing_zero += 1,
                    Some(_) => self.trimmed_fraction += 1,
                }
            }
        }
    }

    /// The most decimals seen in one number (up to [`MAX_DECIMALS`]).
    pub fn max_decimals(&self) -> u8 {
        self.max_decimals.min(MAX_DECIMALS)
    }

    /// The style the evidence points to, with `decimals` digits at most.
    pub fn style(&self, decimals: u8) -> NumberStyle {
        let trim = self.trailing_zero == 0 && (self.trimmed_fraction + self.trailing_dot) > 0;
        NumberStyle {
            decimals,
            leading_zero: self.no_leading_zero <= self.leading_zero,
            trim_trailing_zeros: trim,
            trailing_dot: trim && self.trailing_dot > 0 && self.trailing_dot >= self.bare_integer,
        }
    }
}

/// Appends `value` written in `style` to `out`.
///
/// The value is rounded half away from zero to `style.decimals` places; a
/// result of zero is written without a minus sign.
///
/// ```
/// use volcomp_gcode::number::{format_number, NumberStyle};
/// let mut s = String::new();
/// format_number(-0.25, NumberStyle::fixed(4), &mut s);
/// assert_eq!(s, "-0.2500");
/// ```
#[inline]
pub fn format_number(value: f64, style: NumberStyle, out: &mut String) {
    let mut buf = NumberBuf::new();
    match buf.format(value, style) {
        // Digits, point and sign: ASCII, valid UTF-8.
        Some(text) => out.push_str(std::str::from_utf8(text).unwrap_or_default()),
        None => format_number_slow(value, style, out),
    }
}

/// [`format_number`] into bytes (a line being written), without the
/// intermediate `String`.
#[inline]
pub fn format_number_bytes(value: f64, style: NumberStyle, out: &mut Vec<u8>) {
    // The bounds of `NumberBuf::format_at`; what is past them the slow way.
    if style.decimals <= NumberBuf::MAX_DECIMALS {
        let scaled = round_half_away(value * pow10(u32::from(style.decimals)));
        if scaled.is_finite() && scaled.abs() <= 9.0e15 {
            write_scaled(scaled as i64, style, out);
            return;
        }
    }
    let mut text = String::new();
    format_number_slow(value, style, &mut text);
    out.extend_from_slice(text.as_bytes());
}

/// Appends the number `scaled / 10^style.decimals` written in `style`,
/// given as `scaled`, the integer count of the written resolution it
/// already is (a value rounded to the decimals it is written with:
/// `round(v · 10^d)`), without multiplying and rounding it again.
///
/// The same text as [`format_number_bytes`]`(scaled / 10^d, style)`: for
/// `|scaled| < 2^49` the quotient times `10^d` lies within `2^-3` of
/// `scaled` (two roundings of relative error `2^-53` each), so that
/// function rounds it back to `scaled`; past that bound, or for a value
/// that is not an integer count, it is what this calls.
#[inline]
pub fn format_scaled_bytes(scaled: f64, style: NumberStyle, out: &mut Vec<u8>) {
    const EXACT: f64 = (1u64 << 49) as f64;
    // False for NaN too.
    let within = scaled.abs() < EXACT;
    // Within the bound `scaled as i64` is exact for an integer and cuts a
    // fraction off anything else: an integer count is one that converts
    // back to itself (`fract() == 0`, without `trunc`'s libm call).
    if style.decimals > NumberBuf::MAX_DECIMALS || !within || (scaled as i64) as f64 != scaled {
        format_number_bytes(scaled / pow10(u32::from(style.decimals)), style, out);
        return;
    }
    write_scaled(scaled as i64, style, out);
}

/// The text of `scaled / 10^style.decimals` in `style` (decimals at most
/// [`NumberBuf::MAX_DECIMALS`], `|scaled|` at most 9·10^15) appended to
/// `out`: the text [`NumberBuf::scaled_at`] gives.
///
/// The common case — decimals kept (no trimming), a leading zero, 1 to 7
/// decimals and `|scaled|` below 10^8 (below 1,000 mm at 5 decimals) — is
/// [`write_fixed_scaled`], inlined where numbers are written; the rest is
/// [`write_scaled_general`].
#[inline(always)]
fn write_scaled(scaled: i64, style: NumberStyle, out: &mut Vec<u8>) {
    let decimals = usize::from(style.decimals);
    let magnitude = scaled.unsigned_abs();
    if !style.trim_trailing_zeros
        && style.leading_zero
        && (1..=7).contains(&decimals)
        && magnitude < 100_000_000
    {
        // Below 10^8: a `u32`.
        write_fixed_scaled(scaled < 0, magnitude as u32, decimals, out);
        return;
    }
    write_scaled_general(scaled, style, out);
}

/// [`write_scaled`] for any style: the text written where it goes (its
/// length is known from its integer part's digits and its decimals left
/// after trimming) instead of backwards into a zeroed stack buffer and
/// copied: no buffer to clear, no copy, no bounds check per digit pair.
/// The decimals go two at a time, as in [`format_fixed_bytes`].
#[inline(never)]
fn write_scaled_general(scaled: i64, style: NumberStyle, out: &mut Vec<u8>) {
    let decimals = usize::from(style.decimals);
    let magnitude = scaled.unsigned_abs();
    let divisor = POW10_U64[decimals];
    let mut int_part = magnitude / divisor;
    let mut frac_part = magnitude % divisor;
    let mut frac_digits = decimals;
    if style.trim_trailing_zeros {
        while frac_digits > 0 && frac_part.is_multiple_of(10) {
            frac_part /= 10;
            frac_digits -= 1;
        }
    }
    let point =
        frac_digits > 0 || style.trailing_dot || (!style.trim_trailing_zeros && style.decimals > 0);
    let int_digits = if int_part != 0 || style.leading_zero || frac_digits == 0 {
        let mut k = 1;
        while k < POW10_U64.len() && int_part >= POW10_U64[k] {
            k += 1;
        }
        k
    } else {
        0
    };
    let sign = usize::from(scaled < 0);
    let len = sign + int_digits + usize::from(point) + frac_digits;
    // At most 1 + 16 + 1 + 18 bytes (|scaled| ≤ 9·10^15).
    let start = out.len();
    out.extend_from_slice(&[b'-'; 40]);
    let text = &mut out[start..start + 40];
    let mut at = len;
    while frac_digits >= 2 {
        let pair = (frac_part % 100) as usize * 2;
        frac_part /= 100;
        text[at - 2..at].copy_from_slice(&DIGIT_PAIRS[pair..pair + 2]);
        at -= 2;
        frac_digits -= 2;
    }
    if frac_digits == 1 {
        text[at - 1] = b'0' + frac_part as u8;
        at -= 1;
    }
    if point {
        text[at - 1] = b'.';
        at -= 1;
    }
    if int_digits > 0 {
        while int_part >= 10 {
            let pair = (int_part % 100) as usize * 2;
            int_part /= 100;
            text[at - 2..at].copy_from_slice(&DIGIT_PAIRS[pair..pair + 2]);
            at -= 2;
        }
        if at > sign {
            text[at - 1] = b'0' + int_part as u8;
        }
    }
    // The sign is the `-` the text was filled with.
    out.truncate(start + len);
}

/// [`write_scaled`]'s text where the style keeps its `decimals` (1 to 7,
/// no trimming) and writes a leading zero, of a count `magnitude < 10^8`:
/// a `-` if `negative`, the integer part's digits (at least one), the
/// point, then the last `decimals` digits. The count's eight digits
/// (zero-padded) are made at once in one 64-bit word ([`eight_digits`]):
/// the first `8 − decimals` are the integer part's, the rest the decimals.
/// The integer part's leading zeros are the word's trailing zero bytes (its
/// first digit is the lowest byte), all but its last one dropped. The word
/// is stored twice, eight bytes a store: from the integer part's first
/// digit on, then from the first decimal on after the point; what a store
/// writes past the number's end is overwritten or cut off. No loop per
/// digit, no division by the scale, no count of digits by comparisons.
#[inline(always)]
fn write_fixed_scaled(negative: bool, magnitude: u32, decimals: usize, out: &mut Vec<u8>) {
    const ASCII_ZEROS: u64 = 0x3030_3030_3030_3030;
    let digits = eight_digits(magnitude);
    let int_slots = 8 - decimals;
    // Zero is 64 trailing zero bits: eight bytes, the integer part `0`.
    let lead = ((digits.trailing_zeros() / 8) as usize).min(int_slots - 1);
    let sign = usize::from(negative);
    let point = sign + int_slots - lead;
    // At most 1 + 7 + 1 + 7 bytes; the second store reaches 1 + 7 + 1 + 8.
    let start = out.len();
    out.extend_from_slice(&[b'-'; 24]);
    let text: &mut [u8; 24] = (&mut out[start..start + 24])
        .try_into()
        .expect("24 bytes were just appended");
    text[sign..sign + 8].copy_from_slice(&((digits >> (8 * lead)) + ASCII_ZEROS).to_le_bytes());
    text[point] = b'.';
    text[point + 1..point + 9]
        .copy_from_slice(&((digits >> (8 * int_slots)) + ASCII_ZEROS).to_le_bytes());
    out.truncate(start + point + 1 + decimals);
}

/// The eight decimal digits of `n < 10^8` (zero-padded), one a byte, the
/// first (most significant) in the lowest byte: `n` split into halves of
/// four digits (one division by 10^4), each half into two pairs and each
/// pair into two digits, all lanes at once in one word ("SIMD within a
/// register"). The quotients are multiplications by reciprocals,
/// `⌊v·10486 / 2^20⌋ = ⌊v / 100⌋` for `v < 10^4` and
/// `⌊v·103 / 2^10⌋ = ⌊v / 10⌋` for `v < 100` (both checked for every `v`
/// in the tests), and no lane's product reaches the next lane:
/// `10^4 · 10486 < 2^27` in 32-bit lanes, `100 · 103 < 2^14` in 16-bit ones.
#[inline]
fn eight_digits(n: u32) -> u64 {
    debug_assert!(n < 100_000_000);
    let (high, low) = (u64::from(n / 10_000), u64::from(n % 10_000));
    // Lanes of 32 bits: the first four digits, then the last four.
    let x = high | (low << 32);
    let hundreds = ((x * 10_486) >> 20) & 0x0000_007f_0000_007f;
    // Lanes of 16 bits: pairs of digits.
    let pairs = hundreds | ((x - hundreds * 100) << 16);
    let tens = ((pairs * 103) >> 10) & 0x000f_000f_000f_000f;
    // Lanes of 8 bits: digits.
    tens | ((pairs - tens * 10) << 8)
}

/// [`format_number_bytes`] in [`NumberStyle::fixed`]`(DECIMALS)`: the same
/// text, for speed with the style fixed when compiled (a writer of many
/// numbers in one style, such as the rows of `volcomp moves`) and written
/// where it goes: its length is known from the integer part's digits, the
/// decimals go two at a time by divisions by constants. (Written into a
/// buffer and copied over, the digits would be read back wide right after
/// being stored narrow, which stalls the CPU: no store forwarding.)
#[inline]
pub fn format_fixed_bytes<const DECIMALS: u8>(value: f64, out: &mut Vec<u8>) {
    let decimals = usize::from(DECIMALS);
    let scaled = round_half_away(value * pow10(u32::from(DECIMALS)));
    // The bounds of `NumberBuf::format_at`; what is past them the slow way.
    if DECIMALS > NumberBuf::MAX_DECIMALS || !scaled.is_finite() || scaled.abs() > 9.0e15 {
        format_number_bytes(value, NumberStyle::fixed(DECIMALS), out);
        return;
    }
    let scaled = scaled as i64;
    let magnitude = scaled.unsigned_abs();
    let divisor = POW10_U64[decimals];
    let (mut int_part, mut frac_part) = (magnitude / divisor, magnitude % divisor);
    let mut int_digits = 1;
    while int_digits < POW10_U64.len() && int_part >= POW10_U64[int_digits] {
        int_digits += 1;
    }
    let sign = usize::from(scaled < 0);
    let len = sign + int_digits + usize::from(decimals > 0) + decimals;
    // At most 1 + 16 + 1 + 18 bytes (scaled below 9e15).
    let start = out.len();
    out.extend_from_slice(&[b'-'; 40]);
    let text = &mut out[start..start + 40];
    // From the last decimal back: pairs (a single one first when their
    // count is odd; leading zeros included), the point, the integer part.
    let mut at = len;
    let mut left = decimals;
    while left >= 2 {
        let pair = (frac_part % 100) as usize * 2;
        frac_part /= 100;
        text[at - 2..at].copy_from_slice(&DIGIT_PAIRS[pair..pair + 2]);
        at -= 2;
        left -= 2;
    }
    if left == 1 {
        text[at - 1] = b'0' + frac_part as u8;
        at -= 1;
    }
    if decimals > 0 {
        text[at - 1] = b'.';
        at -= 1;
    }
    while int_part >= 10 {
        let pair = (int_part % 100) as usize * 2;
        int_part /= 100;
        text[at - 2..at].copy_from_slice(&DIGIT_PAIRS[pair..pair + 2]);
        at -= 2;
    }
    if at > sign {
        text[at - 1] = b'0' + int_part as u8;
    }
    out.truncate(start + len);
}

/// An unsigned integer's decimal digits into bytes (a line or column
/// number of a row being written): written backwards into a stack buffer
/// and appended by a fixed-size copy, no `memcpy` call per number.
/// (Measured against writing where the text goes, as [`write_scaled`]
/// does: that needs the digits counted first, which cost more here.)
#[inline]
pub fn format_uint_bytes(value: u64, out: &mut Vec<u8>) {
    let mut buf = NumberBuf::new();
    let at = buf.digits_before(value, 1, NumberBuf::END);
    // At most 20 digits: always within one copy.
    buf.push_tail(at, out);
}

/// A number written from its last digit backwards into a stack buffer: no
/// allocation, two digits a step ([`format_number`]'s and
/// [`format_uint_bytes`]'s writer; numbers with decimals are written where
/// the text goes, [`write_scaled`]).
struct NumberBuf {
    /// The text ends at [`NumberBuf::END`]; the bytes after it let a
    /// fixed-size copy of [`NumberBuf::COPY`] bytes start anywhere the
    /// text of up to that length can.
    bytes: [u8; NumberBuf::END + NumberBuf::COPY],
}

/// `"00" "01" … "99"`.
const DIGIT_PAIRS: &[u8; 200] = b"\
0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

impl NumberBuf {
    /// Most decimals written through the buffer; more go the slow way.
    const MAX_DECIMALS: u8 = 18;

    /// Where the text ends.
    const END: usize = 48;
    /// Bytes a fixed-size copy takes (numbers are rarely longer).
    const COPY: usize = 32;

    fn new() -> Self {
        Self {
            bytes: [0; Self::END + Self::COPY],
        }
    }

    /// Appends the text from `at` to the end: a fixed-size copy (a few
    /// register moves, no `memcpy` call for a length known only at run
    /// time), then the tail cut off. The text must fit in one copy.
    #[inline]
    fn push_tail(&self, at: usize, out: &mut Vec<u8>) {
        let len = out.len();
        let chunk: &[u8; Self::COPY] = self.bytes[at..at + Self::COPY]
            .try_into()
            .expect("the buffer holds a copy's length after the text's end");
        out.extend_from_slice(chunk);
        out.truncate(len + Self::END - at);
    }

    /// Writes `v`'s digits, at least `width` of them (zero-padded), so that
    /// they end before `end`; returns where they start.
    #[inline]
    fn digits_before(&mut self, mut v: u64, width: usize, end: usize) -> usize {
        let mut at = end;
        while v >= 100 {
            let pair = (v % 100) as usize * 2;
            v /= 100;
            at -= 2;
            self.bytes[at..at + 2].copy_from_slice(&DIGIT_PAIRS[pair..pair + 2]);
        }
        if v >= 10 {
            let pair = v as usize * 2;
            at -= 2;
            self.bytes[at..at + 2].copy_from_slice(&DIGIT_PAIRS[pair..pair + 2]);
        } else {
            at -= 1;
            self.bytes[at] = b'0' + v as u8;
        }
        while end - at < width {
            at -= 1;
            self.bytes[at] = b'0';
        }
        at
    }

    /// The text of `value` in `style`, or `None` for what the slow path
    /// writes (non-finite or huge values, more than 18 decimals).
    #[inline]
    fn format(&mut self, value: f64, style: NumberStyle) -> Option<&[u8]> {
        let at = self.format_at(value, style)?;
        Some(&self.bytes[at..Self::END])
    }

    /// [`NumberBuf::format`], giving where the text starts (it ends at
    /// [`NumberBuf::END`]).
    #[inline]
    fn format_at(&mut self, value: f64, style: NumberStyle) -> Option<usize> {
        if style.decimals > Self::MAX_DECIMALS {
            return None;
        }
        let scaled = round_half_away(value * pow10(u32::from(style.decimals)));
        // Positions in millimetres or inches never come near 2^53; the
        // guard keeps absurd values readable instead of wrapping.
        if !scaled.is_finite() || scaled.abs() > 9.0e15 {
            return None;
        }
        Some(self.scaled_at(scaled as i64, style))
    }

    /// The text of `scaled / 10^style.decimals` in `style` (decimals at
    /// most [`NumberBuf::MAX_DECIMALS`]), giving where it starts.
    #[inline]
    fn scaled_at(&mut self, scaled: i64, style: NumberStyle) -> usize {
        let magnitude = scaled.unsigned_abs();
        let divisor = POW10_U64[usize::from(style.decimals)];
        let int_part = magnitude / divisor;
        let mut frac_part = magnitude % divisor;
        let mut frac_digits = usize::from(style.decimals);
        if style.trim_trailing_zeros {
            while frac_digits > 0 && frac_part.is_multiple_of(10) {
                frac_part /= 10;
                frac_digits -= 1;
            }
        }
        let end = Self::END;
        let mut at = end;
        if frac_digits > 0 {
            at = self.digits_before(frac_part, frac_digits, at);
            at -= 1;
            self.bytes[at] = b'.';
        } else if style.trailing_dot || (!style.trim_trailing_zeros && style.decimals > 0) {
            at -= 1;
            self.bytes[at] = b'.';
        }
        if int_part != 0 || style.leading_zero || frac_digits == 0 {
            at = self.digits_before(int_part, 1, at);
        }
        if scaled < 0 {
            at -= 1;
            self.bytes[at] = b'-';
        }
        at
    }
}

/// `10^k` for `k` ≤ 18.
const POW10_U64: [u64; 19] = {
    let mut p = [1u64; 19];
    let mut k = 1;
    while k < 19 {
        p[k] = p[k - 1] * 10;
        k += 1;
    }
    p
};

/// [`format_number`] for what [`NumberBuf`] does not write.
#[cold]
fn format_number_slow(value: f64, style: NumberStyle, out: &mut String) {
    let scale = pow10(u32::from(style.decimals));
    let scaled = round_half_away(value * scale);
    if !scaled.is_finite() || scaled.abs() > 9.0e15 {
        out.push_str(&format!(
            "{value:.prec$}",
            prec = usize::from(style.decimals)
        ));
        return;
    }
    let scaled = scaled as i64;
    let negative = scaled < 0;
    let magnitude = scaled.unsigned_abs();
    let divisor = 10u64.pow(u32::from(style.decimals));
    let int_part = magnitude / divisor;
    let mut frac_part = magnitude % divisor;
    let mut frac_digits = usize::from(style.decimals);
    if style.trim_trailing_zeros {
        while frac_digits > 0 && frac_part.is_multiple_of(10) {
            frac_part /= 10;
            frac_digits -= 1;
        }
    }
    if negative {
        out.push('-');
    }
    if int_part != 0 || style.leading_zero || frac_digits == 0 {
        push_digits(int_part, 1, out);
    }
    if frac_digits > 0 {
        out.push('.');
        push_digits(frac_part, frac_digits, out);
    } else if style.trailing_dot || (!style.trim_trailing_zeros && style.decimals > 0) {
        out.push('.');
    }
}

/// `v.round()` (half away from zero) without the libm call that `round`
/// compiles to on baseline x86-64: exact for |v| < 2^52, where `v − trunc(v)`
/// is computed without rounding. Larger or non-finite values use `round`.
fn round_half_away(v: f64) -> f64 {
    if v.is_nan() || v.abs() >= 4.0e15 {
        return v.round();
    }
    let t = v as i64 as f64;
    let frac = v - t;
    if frac >= 0.5 {
        t + 1.0
    } else if frac <= -0.5 {
        t - 1.0
    } else {
        t
    }
}

/// `v.round()` bit for bit (the sign of a zero result included) without
/// the libm call: [`round_half_away`] with `v`'s sign, which a rounded
/// value always keeps.
pub fn round_bits(v: f64) -> f64 {
    round_half_away(v).copysign(v)
}

/// Appends the decimal digits of `v`, zero-padded to at least `width`.
fn push_digits(v: u64, width: usize, out: &mut String) {
    let mut buf = itoa::Buffer::new();
    let digits = buf.format(v);
    push_zeros(width.saturating_sub(digits.len()), out);
    out.push_str(digits);
}

/// Appends `n` zeros.
fn push_zeros(n: usize, out: &mut String) {
    const ZEROS: &str = "00000000000000000000000000000000";
    let mut n = n;
    while n > 0 {
        let k = n.min(ZEROS.len());
        out.push_str(&ZEROS[..k]);
        n -= k;
    }
}

/// `10^k` for the decimal counts used here, exact as `f64`.
pub(crate) fn pow10(k: u32) -> f64 {
    const P: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    P.get(k as usize)
        .copied()
        .unwrap_or_else(|| 10f64.powi(k as i32))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fmt(v: f64, st: NumberStyle) -> String {
        let mut s = String::new();
        format_number(v, st, &mut s);
        s
    }

    /// A value rounded to its decimals and written from its integer count
    /// gives the text [`format_number_bytes`] gives from the value (the
    /// second method): every style, signs, zeros (−0 without its sign),
    /// values at the 2^49 bound and past it, more than 18 decimals.
    #[test]
    fn a_count_of_steps_is_written_as_its_value() {
        let styles = |d: u8| {
            [
                NumberStyle::fixed(d),
                NumberStyle {
                    decimals: d,
                    leading_zero: false,
                    trim_trailing_zeros: true,
                    trailing_dot: true,
                },
                NumberStyle {
                    decimals: d,
                    leading_zero: true,
                    trim_trailing_zeros: true,
                    trailing_dot: false,
                },
            ]
        };
        let mut values = vec![
            0.0, -0.0, 1.0, -1.0, 0.5, -0.00004, -0.00005, 12.3456789, 1e6,
        ];
        let mut x = 0.123_456_789_f64;
        for _ in 0..2000 {
            // A spread of magnitudes and digits.
            x = (x * 7919.0 + 0.123_457).fract();
            values.push((x - 0.5) * 10f64.powi((x * 1e4) as i32 % 9 - 3));
        }
        for d in [0u8, 1, 3, 4, 5, 9, 12, 18, 19] {
            let k = pow10(u32::from(d));
            let mut near = vec![(1u64 << 49) as f64 - 1.0, (1u64 << 49) as f64, 9.0e15];
            near.extend(near.clone().iter().map(|n| -n));
            let counts = values.iter().map(|v| round_bits(v * k)).chain(near);
            for n in counts {
                for st in styles(d) {
                    let (mut want, mut got) = (Vec::new(), Vec::new());
                    format_number_bytes(n / k, st, &mut want);
                    format_scaled_bytes(n, st, &mut got);
                    assert_eq!(got, want, "{n} in {st:?}");
                }
            }
        }
        let mut t = Vec::new();
        format_scaled_bytes(-123450.0, NumberStyle::fixed(4), &mut t);
        assert_eq!(t, b"-12.3450");
    }

    /// A count written where it goes ([`write_scaled`]) is the text the
    /// stack buffer writes backwards ([`NumberBuf::scaled_at`], the second
    /// method, which `format_number` still uses): every decimal count the
    /// fast path takes, every combination of the style's flags, counts of
    /// every length up to the 9·10^15 bound, zeros and powers of ten, their
    /// negatives.
    #[test]
    fn a_count_is_written_in_place_as_the_buffer_writes_it() {
        let mut counts: Vec<i64> = vec![
            0,
            1,
            5,
            9,
            10,
            11,
            99,
            100,
            101,
            1000,
            9_000_000_000_000_000,
        ];
        for &p in &POW10_U64 {
            let p = p as i64;
            counts.extend([
                p - 1,
                p,
                p + 1,
                p.saturating_mul(7),
                p.saturating_mul(10) / 4,
            ]);
        }
        let mut x = 0.618_033_988_749_895_f64;
        for _ in 0..3000 {
            x = (x * 7919.0 + 0.123_457).fract();
            let digits = (x * 1e6) as i32 % 17;
            counts.push((x * 10f64.powi(digits)) as i64);
        }
        counts.retain(|c| c.unsigned_abs() <= 9_000_000_000_000_000);
        let negatives: Vec<i64> = counts.iter().map(|c| -c).collect();
        counts.extend(negatives);
        let mut checked = 0;
        for d in 0..=NumberBuf::MAX_DECIMALS {
            for flags in 0..8u8 {
                let style = NumberStyle {
                    decimals: d,
                    leading_zero: flags & 1 != 0,
                    trim_trailing_zeros: flags & 2 != 0,
                    trailing_dot: flags & 4 != 0,
                };
                for &n in &counts {
                    let mut buf = NumberBuf::new();
                    let at = buf.scaled_at(n, style);
                    let mut got = b"G1 X".to_vec();
                    write_scaled(n, style, &mut got);
                    assert_eq!(&got[..4], b"G1 X");
                    assert_eq!(
                        &got[4..],
                        &buf.bytes[at..NumberBuf::END],
                        "{n} in {style:?}"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 800_000, "{checked}");
        // By hand.
        let mut t = Vec::new();
        write_scaled(-5, NumberStyle::fixed(3), &mut t);
        assert_eq!(t, b"-0.005");
    }

    /// The eight digits of a word are each `n`'s digits as Rust's own
    /// formatting writes them zero-padded (the second method), for every
    /// `n` below 10^8; the reciprocals they rest on give the quotients for
    /// every value they are used for.
    #[test]
    fn eight_digits_are_the_numbers_digits_for_every_number_below_ten_to_the_eight() {
        for v in 0..10_000u64 {
            assert_eq!((v * 10_486) >> 20, v / 100, "{v}");
        }
        for v in 0..100u64 {
            assert_eq!((v * 103) >> 10, v / 10, "{v}");
        }
        // By hand.
        assert_eq!(eight_digits(12_345_678), 0x0807_0605_0403_0201);
        assert_eq!(eight_digits(9), 0x0900_0000_0000_0000);
        // Every number: its digits from the least significant one up.
        for n in 0..100_000_000u32 {
            let word = eight_digits(n);
            let mut m = n;
            let mut expected = 0u64;
            for i in (0..8).rev() {
                expected |= u64::from(m % 10) << (8 * i);
                m /= 10;
            }
            assert_eq!(word, expected, "{n}");
        }
        let mut text = String::new();
        for n in [0u32, 7, 10, 99_999_999, 40_302_010, 1_000_000] {
            text.clear();
            let bytes = eight_digits(n).to_le_bytes();
            text.extend(bytes.iter().map(|d| char::from(b'0' + d)));
            assert_eq!(text, format!("{n:08}"));
        }
    }

    /// A count in a fixed style is the text of its integer and decimal
    /// parts printed by Rust's own formatting (the second method), and the
    /// buffer writer's (the first): every decimal count from 1 to 8 (the
    /// fixed-decimals writer takes 1 to 7), integer parts of every length
    /// up to 10^8 − 1, those on both sides of the writer's bound (a count
    /// of 10^8), decimals of every length, zero, both signs; and after
    /// other text.
    #[test]
    fn a_count_with_fixed_decimals_is_written_as_its_parts_print() {
        let mut ints: Vec<u64> = vec![0, 1, 9, 10, 99, 100, 12_345, 99_999_999];
        let mut x = 0.414_213_562_373_095_f64;
        for _ in 0..400 {
            x = (x * 7919.0 + 0.271_828).fract();
            ints.push((x * 10f64.powi((x * 1e7) as i32 % 9)) as u64);
        }
        let mut checked = 0;
        for d in 1..=8usize {
            let scale = POW10_U64[d];
            let mut fracs: Vec<u64> = vec![0, 1, scale - 1, scale / 10, scale / 2];
            for _ in 0..40 {
                x = (x * 7919.0 + 0.271_828).fract();
                fracs.push((x * scale as f64) as u64 % scale);
            }
            let style = NumberStyle::fixed(d as u8);
            let bound = POW10_U64[8 - d];
            for &i in ints.iter().chain(&[bound - 1, bound]) {
                for &f in &fracs {
                    let magnitude = (i * scale + f) as i64;
                    for n in [magnitude, -magnitude] {
                        let mut got = b"G1 X".to_vec();
                        write_scaled(n, style, &mut got);
                        let sign = if n < 0 { "-" } else { "" };
                        let expected = format!("G1 X{sign}{i}.{f:0d$}");
                        assert_eq!(String::from_utf8_lossy(&got), expected, "{n} {d}");
                        let mut buf = NumberBuf::new();
                        let at = buf.scaled_at(n, style);
                        assert_eq!(&got[4..], &buf.bytes[at..NumberBuf::END]);
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 150_000, "{checked}");
        // By hand.
        let mut t = b"Y".to_vec();
        write_scaled(-184_150, NumberStyle::fixed(5), &mut t);
        write_scaled(9_999_999_999, NumberStyle::fixed(8), &mut t);
        assert_eq!(t, b"Y-1.8415099.99999999");
    }

    /// Unsigned integers are written as Rust's own formatting writes them
    /// (the second method): every length from 1 to 20 digits, the powers
    /// of ten and their neighbours, `u64::MAX`.
    #[test]
    fn unsigned_integers_are_written_as_their_decimal_digits() {
        let mut values = vec![0u64, 1, 9, 10, 11, 99, 100, 101, u64::MAX, u64::MAX - 1];
        for &p in &POW10_U64 {
            values.extend([
                p - 1,
                p,
                p + 1,
                p.saturating_mul(9),
                p.saturating_mul(10) - 1,
            ]);
        }
        values.push(10_000_000_000_000_000_000);
        let mut x = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..5000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            values.push(x >> (x % 64));
        }
        for v in values {
            let mut got = b"L".to_vec();
            format_uint_bytes(v, &mut got);
            assert_eq!(&got[1..], v.to_string().as_bytes(), "{v}");
        }
    }

    #[test]
    fn fixed_style() {
        let st = NumberStyle::fixed(4);
        assert_eq!(fmt(1.0, st), "1.0000");
        assert_eq!(fmt(-0.00004, st), "0.0000");
        assert_eq!(fmt(-0.00005, st), "-0.0001");
        assert_eq!(fmt(12.34567, st), "12.3457");
        assert_eq!(fmt(1e-12, st), "0.0000");
    }

    #[test]
    fn fanuc_style_has_no_leading_zero_and_trailing_dot() {
        let st = NumberStyle {
            decimals: 4,
            leading_zero: false,
            trim_trailing_zeros: true,
            trailing_dot: true,
        };
        assert_eq!(fmt(0.25, st), ".25");
        assert_eq!(fmt(-0.25, st), "-.25");
        assert_eq!(fmt(10.0, st), "10.");
        assert_eq!(fmt(0.0, st), "0.");
    }

    #[test]
    fn survey_infers_styles() {
        let mut s = StyleSurvey::default();
        for t in ["10.", ".25", "-.53", "1.5", "3"] {
            s.record(t.as_bytes());
        }
        let st = s.style(4);
        assert!(!st.leading_zero && st.trim_trailing_zeros && st.trailing_dot);
        let mut s = StyleSurvey::default();
        for t in ["0.2000", "10.0000", "-1.5000"] {
            s.record(t.as_bytes());
        }
        assert_eq!(s.style(4), NumberStyle::fixed(4));
    }

    #[test]
    fn rounding_matches_the_standard_round() {
        for v in [
            0.5,
            -0.5,
            1.5,
            2.5,
            -2.5,
            0.49999999999999994,
            123456.5,
            -7.4999,
            1e15 + 0.5,
            3.0,
            -0.0,
        ] {
            assert_eq!(round_half_away(v), v.round(), "{v}");
        }
    }

    /// `round_bits` is `round` to the bit, zeros' signs and NaN included,
    /// on ties, near-ties, large and random values.
    #[test]
    fn round_bits_is_round() {
        let mut values = vec![
            0.0,
            -0.0,
            0.3,
            -0.3,
            0.5,
            -0.5,
            0.49999999999999994,
            -0.49999999999999994,
            2.5,
            -2.5,
            4.0e15,
            -4.0e15,
            4.5e15,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ];
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let scale = [1e-3, 1.0, 1e3, 1e6, 1e9, 1e14][(x % 6) as usize];
            values.push(((x >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * scale);
            values.push(f64::from_bits(x));
            values.push((x % 20_000) as f64 * 0.5 - 5_000.0);
        }
        for v in values.into_iter().filter(|v| !v.is_nan()) {
            assert_eq!(round_bits(v).to_bits(), v.round().to_bits(), "{v:e}");
        }
        assert!(round_bits(f64::NAN).is_nan());
    }

    #[test]
    fn decimals_are_counted_as_written() {
        assert_eq!(decimals_of(b"0.096205"), 6);
        assert_eq!(decimals_of(b"-.5"), 1);
        assert_eq!(decimals_of(b"10."), 0);
        assert_eq!(decimals_of(b"12"), 0);
        assert_eq!(decimals_of(b"1 . 2 5"), 2);
        let mut s = StyleSurvey::default();
        for t in ["1.5", "0.096205", "2.25"] {
            s.record(t.as_bytes());
        }
        assert_eq!(s.max_decimals(), 6);
        s.record(b"0.1234567890123");
        assert_eq!(s.max_decimals(), MAX_DECIMALS);
    }

    #[test]
    fn six_decimal_word_survives_when_written_with_its_own_decimals() {
        // The vcarve.ngc case: `Y 0.096205` written with 5 decimals loses a
        // digit; with the word's own 6 decimals it comes back as it was.
        let v: f64 = "0.096205".parse().unwrap();
        let mut survey = StyleSurvey::default();
        survey.record(b"0.096205");
        survey.record(b"0.100000");
        assert_ne!(fmt(v, survey.style(5)), "0.096205");
        assert_eq!(fmt(v, survey.style(decimals_of(b"0.096205"))), "0.096205");
    }

    #[test]
    fn the_stack_writer_writes_what_the_reference_writer_writes() {
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            10.0,
            0.25,
            -0.25,
            12.34567,
            1e-12,
            -1e-12,
            123456.0,
            99.999999999,
            0.000049,
            -0.00005,
            9e14,
            -9e14,
            8.9e15,
            1e17,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            250.0001,
            -1.833,
        ];
        let mut x = 0.123_456_789_f64;
        for _ in 0..2000 {
            x = (x * 7919.0 + 0.377).fract();
            values.push((x - 0.5) * 2000.0);
            values.push((x - 0.5) * 0.002);
        }
        for decimals in (0..=9).chain([12, 18, 19]) {
            for bits in 0..8 {
                let style = NumberStyle {
                    decimals,
                    leading_zero: bits & 1 != 0,
                    trim_trailing_zeros: bits & 2 != 0,
                    trailing_dot: bits & 4 != 0,
                };
                for &v in &values {
                    let mut reference = String::new();
                    format_number_slow(v, style, &mut reference);
                    assert_eq!(fmt(v, style), reference, "{v} {style:?}");
                    // Appended after what the line already holds.
                    let mut bytes = b"X".to_vec();
                    format_number_bytes(v, style, &mut bytes);
                    assert_eq!(bytes[1..], *reference.as_bytes(), "{v} {style:?}");
                }
            }
        }
        // The writer with the style fixed when compiled (the slow way's
        // decimals too).
        fn fixed<const D: u8>(values: &[f64]) {
            for &v in values {
                let mut reference = String::new();
                format_number_slow(v, NumberStyle::fixed(D), &mut reference);
                let mut bytes = b"X".to_vec();
                format_fixed_bytes::<D>(v, &mut bytes);
                assert_eq!(bytes[1..], *reference.as_bytes(), "{v} {D}");
            }
        }
        // Values whose rounding carries into one more integer digit, and
        // every decimal count's odd and even digit pairs.
        let mut more = values.clone();
        for k in 0..=16 {
            let p = 10f64.powi(k);
            more.extend([
                p,
                -p,
                p - 0.5e-6,
                -p + 0.5e-6,
                p - 0.4e-6,
                p - 0.05,
                p + 0.5e-6,
            ]);
        }
        fixed::<0>(&more);
        fixed::<1>(&more);
        fixed::<2>(&more);
        fixed::<3>(&more);
        fixed::<4>(&more);
        fixed::<6>(&more);
        fixed::<9>(&more);
        fixed::<17>(&more);
        fixed::<18>(&more);
        fixed::<19>(&more);
    }

    #[test]
    fn integers_are_written_as_the_standard_formatter_writes_them() {
        let mut values = vec![
            0,
            1,
            9,
            10,
            99,
            100,
            101,
            999,
            1000,
            65_535,
            u64::MAX,
            u64::MAX - 1,
        ];
        values.extend((0..19).map(|k| 10u64.pow(k)));
        values.extend((1..20).map(|k| 10u64.pow(k) - 1));
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..2000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            values.push(x >> (x % 64));
        }
        for v in values {
            let mut out = b"row,".to_vec();
            format_uint_bytes(v, &mut out);
            assert_eq!(out, format!("row,{v}").into_bytes(), "{v}");
        }
    }

    #[test]
    fn never_scientific() {
        let st = NumberStyle::fixed(5);
        assert_eq!(fmt(1e-9, st), "0.00000");
        assert_eq!(fmt(123456.0, st), "123456.00000");
    }
}
