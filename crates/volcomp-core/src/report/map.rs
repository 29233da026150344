//! The report of an error map: every component over the axis it depends on
//! (the forward and reverse tables drawn apart where they differ), one chart
//! per quantity so that µm and µrad never share an axis ([ISO 230-1]
//! component names, docs/kinematic.md).

use super::svg::{self, Chart, Mark, Series, PALETTE};
use super::{Block, Section};
use crate::model::query::ComponentSeries;

/// One chart of components.
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentChart {
    /// What it shows.
    pub title: String,
    /// The axis position's label, with its unit.
    pub x_label: String,
    /// The quantity's label, with its unit (µm or µrad).
    pub y_label: String,
    /// The components.
    pub series: Vec<ComponentSeries>,
}

/// One section per axis (consecutive charts over the same axis share a
/// page): the components as lines (a reverse table dashed, in its forward
/// table's colour).
pub fn sections(charts: &[ComponentChart]) -> Vec<Section> {
    let mut out: Vec<(String, Section)> = Vec::new();
    for (k, c) in charts.iter().enumerate() {
        let figure = {
            let mut colour_of: Vec<String> = Vec::new();
            let series = c
                .series
                .iter()
                .map(|s| {
                    let component = s.name.split(' ').next().unwrap_or("").to_string();
                    let i = colour_of
                        .iter()
                        .position(|n| *n == component)
                        .unwrap_or_else(|| {
                            colour_of.push(component);
                            colour_of.len() - 1
                        });
                    let mark = if s.name.ends_with("reverse") {
                        Mark::Dashed
                    } else {
                        Mark::Line
                    };
                    Series::xy(s.name.clone(), PALETTE[i % PALETTE.len()], mark, &s.points)
                })
                .collect();
            Block::Figure {
                svg: svg::chart(&Chart {
                    x_label: c.x_label.clone(),
                    y_label: c.y_label.clone(),
                    plot_height: 230.0,
                    series,
                    rules: vec![],
                    y_from_zero: true,
                    ..Chart::default()
                }),
                caption: format!("{}. Each component over the position of the axis it depends on; where the forward and reverse tables differ, the reverse one is dashed in the same colour.", c.title),
            }
        };
        match out.last_mut() {
            Some((axis, section)) if *axis == c.x_label => section.blocks.push(figure),
            _ => out.push((
                c.x_label.clone(),
                Section {
                    id: format!("map-{k}"),
                    title: format!("Components over {}", c.x_label),
                    blocks: vec![figure],
                },
            )),
        }
    }
    out.into_iter().map(|(_, s)| s).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forward_and_reverse_share_a_colour_and_differ_in_dash() {
        let s = sections(&[ComponentChart {
            title: "X".into(),
            x_label: "X position (mm)".into(),
            y_label: "error (µm)".into(),
            series: vec![
                ComponentSeries {
                    name: "EXX forward".into(),
                    points: vec![(0.0, 0.0), (100.0, 2.0)],
                },
                ComponentSeries {
                    name: "EXX reverse".into(),
                    points: vec![(0.0, 1.0), (100.0, 3.0)],
                },
                ComponentSeries {
                    name: "EYX".into(),
                    points: vec![(0.0, 0.0), (100.0, -1.0)],
                },
            ],
        }]);
        let Block::Figure { svg, .. } = &s[0].blocks[0] else {
            panic!()
        };
        // Two paths in blue (EXX), one dashed; EYX in vermillion.
        assert_eq!(
            svg.matches(r##"stroke="#0072B2" stroke-width="1.5""##)
                .count(),
            2
        );
        assert_eq!(
            svg.matches(r##"stroke="#D55E00" stroke-width="1.5""##)
                .count(),
            1
        );
        assert!(svg.contains("error (µm)") && svg.contains("X position (mm)"));
    }
}
