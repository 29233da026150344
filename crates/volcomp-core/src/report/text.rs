//! Numbers and counts in sentences for a person (the summaries a front end
//! prints, the reports): a sensible number of digits, one spelling of the
//! units (µm, µrad), singular for one.

/// A value with four significant digits, at most `max_decimals` of them
/// after the point, trailing zeros dropped (`10.77`, `0.0078`, `0`): never
/// the noise of a binary value (`0.00000010000000000000001`).
pub fn sig(v: f64, max_decimals: usize) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let magnitude = if v == 0.0 {
        0
    } else {
        v.abs().log10().floor() as i32
    };
    let decimals = (3 - magnitude).clamp(0, max_decimals as i32) as usize;
    crate::io::numfmt::fixed(v, decimals)
}

/// A length in µm (`10.77 µm`; at most four decimals, 0.1 nm).
pub fn um(v: f64) -> String {
    format!("{} µm", sig(v, 4))
}

/// An angle in µrad (`2.5 µrad`; at most four decimals).
pub fn urad(v: f64) -> String {
    format!("{} µrad", sig(v, 4))
}

/// `n` and its noun, singular for one (`1 take-up move`, `3 take-up
/// moves`, `0 points`).
pub fn count(n: u64, singular: &str, plural: &str) -> String {
    format!("{n} {}", if n == 1 { singular } else { plural })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_significant_digits_at_most_four_decimals() {
        for (v, want) in [
            (10.768, "10.77 µm"),
            (0.0078123, "0.0078 µm"),
            (1.000_000_000_000_000_1e-7, "0 µm"),
            (0.0, "0 µm"),
            (-2.5, "-2.5 µm"),
        ] {
            assert_eq!(um(v), want);
        }
        assert_eq!(urad(1234.56), "1235 µrad");
        assert_eq!(count(1, "take-up move", "take-up moves"), "1 take-up move");
        assert_eq!(count(2, "point", "points"), "2 points");
    }
}
