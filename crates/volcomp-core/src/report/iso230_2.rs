//! The report of a bidirectional positioning test evaluated by ISO 230-2
//! ([ISO 230-2] clause 3, [`crate::identify::iso230_2`]): the standard's
//! plot of the mean unidirectional positional deviations `x̄↑`, `x̄↓` with
//! their bands `x̄ ± 2s` per direction, and the figures B, R, E, M, A of the
//! axis and of every target.

use super::svg::{self, Chart, Mark, Series, PALETTE};
use super::{Block, Section, Table};
use crate::identify::iso230_2::Iso230_2Report;

/// Colour of the positive direction (↑, Okabe–Ito blue).
pub const UP: &str = PALETTE[0];
/// Colour of the negative direction (↓, Okabe–Ito vermillion).
pub const DOWN: &str = PALETTE[1];

fn um(v: f64) -> String {
    format!("{v:.3}")
}

/// The sections: the bidirectional plot with the axis figures, then the
/// figures per target and the test's shortfalls against the standard.
pub fn sections(r: &Iso230_2Report) -> Vec<Section> {
    use crate::identify::iso230_2::TargetStats;
    let t = &r.targets;
    let line = |f: &dyn Fn(&TargetStats) -> f64| -> Vec<(f64, f64)> {
        t.iter().map(|s| (s.target_mm, f(s))).collect()
    };
    // One direction: its mean, and the band x̄ ± 2s dashed (labelled once).
    let direction = |mean_label: &str,
                     band_label: &str,
                     colour: &str,
                     stats: fn(&TargetStats) -> (f64, f64)| {
        [
            Series::xy(mean_label, colour, Mark::Line, &line(&|s| stats(s).0)),
            Series::xy(
                band_label,
                colour,
                Mark::Dashed,
                &line(&|s| {
                    let (mean, sd) = stats(s);
                    mean + 2.0 * sd
                }),
            ),
            Series::xy(
                "",
                colour,
                Mark::Dashed,
                &line(&|s| {
                    let (mean, sd) = stats(s);
                    mean - 2.0 * sd
                }),
            ),
        ]
    };
    let mut series = Vec::new();
    series.extend(direction(
        "x̄↑ mean, positive direction",
        "x̄↑ ± 2s↑",
        UP,
        |s| (s.mean_up_um, s.s_up_um),
    ));
    series.extend(direction(
        "x̄↓ mean, negative direction",
        "x̄↓ ± 2s↓",
        DOWN,
        |s| (s.mean_down_um, s.s_down_um),
    ));
    series.push(Series::xy(
        "x̄ bidirectional mean",
        PALETTE[6],
        Mark::Markers,
        &line(&|s| s.mean_um),
    ));
    let plot = svg::chart(&Chart {
        x_label: "target position Pᵢ (mm)".into(),
        y_label: "positional deviation x = P − Pᵢ (µm)".into(),
        plot_height: 280.0,
        series,
        rules: vec![],
        y_from_zero: true,
        ..Chart::default()
    });
    let a = &r.axis;
    let figures = Table::new(
        &[
            "figure (ISO 230-2)",
            "↑ (µm)",
            "↓ (µm)",
            "bidirectional (µm)",
        ],
        &[false, true, true, true],
        vec![
            vec![
                "B reversal value (B̄ mean)".into(),
                String::new(),
                String::new(),
                format!("{} ({})", um(a.reversal_b_um), um(a.mean_reversal_um)),
            ],
            vec![
                "R repeatability of positioning".into(),
                um(a.repeatability_up_um),
                um(a.repeatability_down_um),
                um(a.repeatability_um),
            ],
            vec![
                "E systematic positional deviation".into(),
                um(a.systematic_up_um),
                um(a.systematic_down_um),
                um(a.systematic_um),
            ],
            vec![
                "M mean positional deviation (range)".into(),
                String::new(),
                String::new(),
                um(a.mean_range_um),
            ],
            vec![
                "A accuracy of positioning".into(),
                um(a.accuracy_up_um),
                um(a.accuracy_down_um),
                um(a.accuracy_um),
            ],
        ],
    );
    let per_target = Table {
        headers: [
            "Pᵢ (mm)",
            "n↑",
            "n↓",
            "x̄↑ (µm)",
            "x̄↓ (µm)",
            "s↑ (µm)",
            "s↓ (µm)",
            "Bᵢ (µm)",
            "x̄ (µm)",
            "Rᵢ (µm)",
        ]
        .iter()
        .map(|h| h.to_string())
        .collect(),
        rows: t
            .iter()
            .map(|s| {
                vec![
                    format!("{}", s.target_mm),
                    s.n_up.to_string(),
                    s.n_down.to_string(),
                    um(s.mean_up_um),
                    um(s.mean_down_um),
                    um(s.s_up_um),
                    um(s.s_down_um),
                    um(s.reversal_um),
                    um(s.mean_um),
                    um(s.repeatability_um),
                ]
            })
            .collect(),
        numeric: vec![true; 10],
    };
    let mut details = vec![Block::Table(per_target)];
    if r.notes.is_empty() {
        details.push(Block::Text("The test has the standard's minimum extent (five targets per metre, five approaches per direction).".into()));
    } else {
        details.push(Block::Text(
            "Where the test falls short of the standard's minimum extent:".into(),
        ));
        details.push(Block::Lines(
            r.notes
                .iter()
                .enumerate()
                .map(|(i, n)| (i as u64 + 1, n.clone()))
                .collect(),
        ));
    }
    vec![
        Section {
            id: "iso230-2".into(),
            title: "Accuracy and repeatability of positioning (ISO 230-2)".into(),
            blocks: vec![
                Block::Figure {
                    svg: plot,
                    caption: "The standard's bidirectional plot: mean unidirectional positional deviations at each target, x̄↑ (approached in the positive direction) and x̄↓ (negative), with x̄ ± 2s per direction (dashed), and the bidirectional mean x̄.".into(),
                },
                Block::Table(figures),
            ],
        },
        Section {
            id: "iso230-2-targets".into(),
            title: "Figures per target position".into(),
            blocks: details,
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::iso230_2::evaluate;

    #[test]
    fn the_figures_are_the_hand_computed_ones() {
        // Target 0: up 1…5 µm (mean 3, s = √2.5 = 1.5811), down 0 (s 0).
        // Target 100: up 2 (s 0), down 1 (s 0).
        let r = evaluate(&[
            (0.0, vec![1.0, 2.0, 3.0, 4.0, 5.0], vec![0.0; 5]),
            (100.0, vec![2.0; 5], vec![1.0; 5]),
        ])
        .unwrap();
        let s = sections(&r);
        let Block::Table(fig) = &s[0].blocks[1] else {
            panic!()
        };
        // B = max |Bᵢ| = max(3, 1) = 3; B̄ = (3 + 1) / 2 = 2.
        assert_eq!(fig.rows[0][3], "3.000 (2.000)");
        // R↑ = 4 s↑ = 4 · 1.58114 = 6.325; R₀ = max(2·1.58114 + 0 + 3, 6.325) = 6.325.
        assert_eq!(fig.rows[1][1], "6.325");
        assert_eq!(fig.rows[1][3], "6.325");
        // E↑ = 3 − 2 = 1; E↓ = 1 − 0 = 1; E = 3 − 0 = 3.
        assert_eq!(&fig.rows[2][1..], &["1.000", "1.000", "3.000"]);
        // x̄ = 1.5 and 1.5: M = 0.
        assert_eq!(fig.rows[3][3], "0.000");
        // A↑ = max(3 + 3.162, 2) − min(3 − 3.162, 2) = 6.162 + 0.162 = 6.325.
        assert_eq!(fig.rows[4][1], "6.325");
        let Block::Table(per) = &s[1].blocks[0] else {
            panic!()
        };
        assert_eq!(per.rows[0][5], "1.581");
        let Block::Figure { svg, .. } = &s[0].blocks[0] else {
            panic!()
        };
        assert!(svg.contains("positional deviation x = P − Pᵢ (µm)"));
        assert!(svg.contains("target position Pᵢ (mm)"));
    }
}
