//! Sections of plain charts, for the commands whose pictures are a list of
//! charts (straightness fits, thermal models): one section (a printed page)
//! per group, each chart with its title as caption.

use super::svg::{self, Chart};
use super::{Block, Section};

/// A chart and what it shows.
#[derive(Debug, Clone, PartialEq)]
pub struct Titled {
    /// The chart's title (its caption).
    pub title: String,
    /// The chart.
    pub chart: Chart,
}

/// One section per `(heading, charts)` group.
pub fn sections(groups: &[(String, Vec<Titled>)]) -> Vec<Section> {
    groups
        .iter()
        .enumerate()
        .map(|(k, (heading, charts))| Section {
            id: format!("charts-{k}"),
            title: heading.clone(),
            blocks: charts
                .iter()
                .map(|t| Block::Figure {
                    svg: svg::chart(&t.chart),
                    caption: t.title.clone(),
                })
                .collect(),
        })
        .collect()
}
