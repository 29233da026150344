//! How volcomp writes numbers into CSV, TOML and text outputs.
//!
//! Every computed value is rounded to a fixed number of decimals chosen for
//! its unit, then trailing zeros are dropped and `-0` is written `0`. A value
//! such as a mean of measured deviations therefore reads `-0.034`, never
//! `-0.03399999999999999` (the shortest decimal that round-trips the binary
//! value, which shows its rounding noise). The precisions lie far below what
//! any machine-tool measurement resolves, so nothing a user measured is lost:
//!
//! | unit | decimals | resolution |
//! |---|---|---|
//! | mm (positions, lengths) | [`MM_DECIMALS`] = 6 | 1 nm |
//! | µm (deviations) | [`UM_DECIMALS`] = 4 | 0.1 nm |
//! | µrad (angles) | [`URAD_DECIMALS`] = 4 | 0.1 nrad |
//! | °C (temperatures) | [`CELSIUS_DECIMALS`] = 3 | 1 mK |
//! | h (times) | [`HOURS_DECIMALS`] = 6 | 3.6 ms |
//!
//! (G-code words are written by the G-code engine in the program's own
//! number style instead; see `volcomp_gcode::number`.)

/// Decimals of a length or position in millimetres (1 nm).
pub const MM_DECIMALS: usize = 6;
/// Decimals of a deviation in micrometres (0.1 nm).
pub const UM_DECIMALS: usize = 4;
/// Decimals of an angle in microradians.
pub const URAD_DECIMALS: usize = 4;
/// Decimals of a temperature in degrees Celsius (1 mK).
pub const CELSIUS_DECIMALS: usize = 3;
/// Decimals of a time in hours.
pub const HOURS_DECIMALS: usize = 6;

/// `v` rounded to `decimals` places, trailing zeros and a trailing point
/// dropped, `-0` written as `0`. Non-finite values are written as Rust
/// writes them (`NaN`, `inf`); callers validate before writing.
///
/// ```
/// use volcomp_core::io::numfmt::fixed;
/// assert_eq!(fixed(-0.03399999999999999, 4), "-0.034");
/// assert_eq!(fixed(120.0, 6), "120");
/// assert_eq!(fixed(-0.00000001, 6), "0");
/// assert_eq!(fixed(2.5e-7, 6), "0");
/// ```
pub fn fixed(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if !v.is_finite() || !s.contains('.') {
        return if s == "-0" { "0".into() } else { s };
    }
    let t = s.trim_end_matches('0');
    let t = t.strip_suffix('.').unwrap_or(t);
    if t == "-0" || t.is_empty() {
        "0".into()
    } else {
        t.to_string()
    }
}

/// A position or length in mm ([`MM_DECIMALS`]).
///
/// ```
/// assert_eq!(volcomp_core::io::numfmt::mm(37.5), "37.5");
/// ```
pub fn mm(v: f64) -> String {
    fixed(v, MM_DECIMALS)
}

/// A deviation in µm ([`UM_DECIMALS`]).
///
/// ```
/// assert_eq!(volcomp_core::io::numfmt::um(1.0 / 3.0), "0.3333");
/// ```
pub fn um(v: f64) -> String {
    fixed(v, UM_DECIMALS)
}

/// An angle in µrad ([`URAD_DECIMALS`]).
pub fn urad(v: f64) -> String {
    fixed(v, URAD_DECIMALS)
}

/// A temperature in °C ([`CELSIUS_DECIMALS`]).
pub fn celsius(v: f64) -> String {
    fixed(v, CELSIUS_DECIMALS)
}

/// A time in hours ([`HOURS_DECIMALS`]).
pub fn hours(v: f64) -> String {
    fixed(v, HOURS_DECIMALS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_noise_is_not_written() {
        // 0.1 + 0.2 = 0.30000000000000004 in binary floating point.
        assert_eq!(mm(0.1 + 0.2), "0.3");
        assert_eq!(um(-0.034 - 1e-17), "-0.034");
        assert_eq!(um(-0.0), "0");
        assert_eq!(um(-0.00004), "0");
        assert_eq!(um(-0.00005), "-0.0001");
        assert_eq!(mm(1e6), "1000000");
        assert_eq!(urad(19.392_547_2), "19.3925");
    }

    #[test]
    fn written_values_read_back_within_half_a_unit_in_the_last_place() {
        for i in 0..2000 {
            let v = (i as f64 * 0.712_345_678_9).sin() * 10f64.powi(i % 7 - 2);
            let back: f64 = um(v).parse().unwrap();
            assert!((back - v).abs() <= 0.5e-4 + 1e-12, "{v} → {back}");
        }
    }
}
