//! Statistics of deviations: mean, standard deviation and the ISO 1101
//! profile error (zone centred on the nominal) and range (floating zone).

/// Statistics of a set of deviations (µm).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct DeviationStats {
    /// Number of values.
    pub count: usize,
    /// Mean.
    pub mean_um: f64,
    /// Sample standard deviation (n − 1).
    pub std_um: f64,
    /// Smallest value.
    pub min_um: f64,
    /// Largest value.
    pub max_um: f64,
    /// Profile error: width of the zone centred on the nominal that contains
    /// every deviation, `2·max|d|` (ISO 1101 surface profile, no datum shift).
    pub profile_um: f64,
    /// Range `max − min`: width of the zone when it may float.
    pub range_um: f64,
}

/// Statistics of `values` (µm); all zero for an empty set.
pub fn deviation_stats(values: impl IntoIterator<Item = f64>) -> DeviationStats {
    let v: Vec<f64> = values.into_iter().collect();
    if v.is_empty() {
        return DeviationStats::default();
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = if v.len() > 1 {
        v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)
    } else {
        0.0
    };
    let min = v.iter().copied().fold(f64::INFINITY, f64::min);
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    DeviationStats {
        count: v.len(),
        mean_um: mean,
        std_um: var.sqrt(),
        min_um: min,
        max_um: max,
        profile_um: 2.0 * min.abs().max(max.abs()),
        range_um: max - min,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_follow_their_definitions() {
        let s = deviation_stats([1.0, -3.0, 2.0, 4.0]);
        assert_eq!(s.count, 4);
        assert!((s.mean_um - 1.0).abs() < 1e-15);
        let var = (0.0 + 16.0 + 1.0 + 9.0) / 3.0;
        assert!((s.std_um - f64::sqrt(var)).abs() < 1e-12);
        assert_eq!(
            (s.min_um, s.max_um, s.profile_um, s.range_um),
            (-3.0, 4.0, 8.0, 7.0)
        );
        assert_eq!(deviation_stats([]), DeviationStats::default());
    }
}
