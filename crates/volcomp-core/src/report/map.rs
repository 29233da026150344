//! The report of an error map: every component over the axis it depends on
//! (the forward and reverse tables drawn apart where they differ), one chart
//! per quantity so that µm and µrad never share an axis ([ISO 230-1]
//! component names, docs/kinematic.md).

use super::svg::{self, Chart, Mark, Series, PALETTE};
use super::{Block, Section};
use crate::model::kinematic::{angular_name, linear_name, Form, KinematicModel};
use crate::model::query::{ComponentSeries, KinematicQuery};
use crate::model::{direction_letters, Direction, Directions};
use volcomp_gcode::Vec3;

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

/// Three signed values with `decimals` decimals, two spaces apart.
fn fmt3(v: Vec3, decimals: usize) -> String {
    format!("{:+.d$}  {:+.d$}  {:+.d$}", v.x, v.y, v.z, d = decimals)
}

/// What axis tables give at one point `q` (directions `s`), for a person:
/// the deviation, its positioning part and each axis' table (`volcomp map
/// eval`).
pub fn table_point_lines(
    map_name: &str,
    q: Vec3,
    s: Directions,
    deviation_um: Vec3,
    positioning_um: Vec3,
    per_axis_um: &[Vec3; 3],
) -> Vec<String> {
    let mut lines = vec![
        format!("map          {map_name} (axis tables; the tool does not enter)"),
        at_line(q, s),
        format!(
            "deviation    {} µm   |e| {:.4} µm",
            fmt3(deviation_um, 4),
            deviation_um.norm()
        ),
        format!(
            "positioning  {} µm   (E_XX, E_YY, E_ZZ only)",
            fmt3(positioning_um, 4)
        ),
    ];
    for (name, v) in ['X', 'Y', 'Z'].iter().zip(per_axis_um) {
        lines.push(format!("  {name} table  {} µm", fmt3(*v, 4)));
    }
    lines
}

/// The `at` line of a point report: where, and in which directions.
fn at_line(q: Vec3, s: Directions) -> String {
    format!(
        "at           X {:.4}  Y {:.4}  Z {:.4} mm, directions {}",
        q.x,
        q.y,
        q.z,
        direction_letters(s)
    )
}

/// What a 21-component model gives at one point `q` (directions `s`, tool
/// offset `tool`), for a person: the deviation in both forms, its
/// positioning and squareness parts, every component with the axis' side,
/// Abbe arm and contribution (`volcomp map eval`).
pub fn kinematic_point_lines(
    map_name: &str,
    m: &KinematicModel,
    q: Vec3,
    s: Directions,
    tool: Vec3,
    r: &KinematicQuery,
) -> Vec<String> {
    let k = &m.kinematics;
    let v = &r.values;
    let (e, htm, first) = (
        r.deviation_um,
        r.deviation_htm_um,
        r.deviation_first_order_um,
    );
    let form = match m.form {
        Form::Htm => "HTM",
        Form::FirstOrder => "first order",
    };
    let mut lines = vec![
        format!("map          {map_name} (21-component, chain {}, {form})", k.topology),
        at_line(q, s),
        format!("tool offset  {:.4}, {:.4}, {:.4} mm (G43 length offset; the tip is below the gauge point by it)", tool.x, tool.y, tool.z),
        format!("deviation    {} µm   |e| {:.4} µm", fmt3(e, 4), e.norm()),
        format!("  HTM        {} µm", fmt3(htm, 6)),
        format!(
            "  1st order  {} µm   (difference {:.2e} µm)",
            fmt3(first, 6),
            (htm - first).norm()
        ),
        format!(
            "positioning  {} µm   (E_XX, E_YY, E_ZZ only)",
            fmt3(r.positioning_um, 4)
        ),
        format!(
            "squareness   {} µm   (S_xy·y + S_zx·z, S_yz·z, 0)",
            fmt3(r.squareness_um, 4)
        ),
    ];
    for ax in 0..3 {
        let names_l: Vec<String> = (0..3)
            .map(|d| format!("{} {:+.3}", linear_name(d, ax), v.linear_um[ax][d]))
            .collect();
        let names_a: Vec<String> = (0..3)
            .map(|d| format!("{} {:+.2}", angular_name(d, ax), v.angular_urad[ax][d]))
            .collect();
        let arm = r.abbe_arms_mm[ax];
        lines.push(format!(
            "{} ({}{}) {} µm   {} µrad",
            ['X', 'Y', 'Z'][ax],
            if k.topology.carries_workpiece(ax) {
                "workpiece side"
            } else {
                "tool side"
            },
            if s[ax] == Direction::Reverse {
                ", reverse"
            } else {
                ""
            },
            names_l.join("  "),
            names_a.join("  ")
        ));
        lines.push(format!(
            "    Abbe arm {:.3}, {:.3}, {:.3} mm   contribution {} µm",
            arm.x,
            arm.y,
            arm.z,
            fmt3(r.axis_contributions_um[ax], 4)
        ));
    }
    lines
}

/// The charts of a map's components, titled for the report and the plot
/// (`volcomp map plot`): per axis, its tables (axis tables) or its
/// positioning and straightness and its angular errors (21-component
/// model, with the chain and the squareness in the titles).
pub mod component_charts {
    use super::ComponentChart;
    use crate::model::axis_table::AxisTableMap;
    use crate::model::kinematic::KinematicModel;
    use volcomp_geom::Axis;

    const AXES: [char; 3] = ['X', 'Y', 'Z'];

    /// One chart per axis: the errors its table causes.
    pub fn tables(name: &str, m: &AxisTableMap) -> Vec<ComponentChart> {
        AXES.iter()
            .enumerate()
            .map(|(k, axis)| ComponentChart {
                title: format!("{name}: errors caused by {axis} (axis tables)"),
                x_label: format!("{axis} position (mm)"),
                y_label: "error (µm)".into(),
                series: m.component_series(Axis::ALL[k]),
            })
            .collect()
    }

    /// Two charts per axis: µm and µrad never share one.
    pub fn kinematic(name: &str, m: &KinematicModel) -> Vec<ComponentChart> {
        let k = &m.kinematics;
        let mut charts = Vec::new();
        for (ax, axis) in AXES.iter().enumerate() {
            let (linear, angular) = m.component_series(Axis::ALL[ax]);
            let extra = match ax {
                0 => format!(" (chain {})", k.topology),
                1 => format!(" (squareness S_xy {} µrad)", k.squareness.xy_urad),
                _ => format!(
                    " (squareness S_yz {}, S_zx {} µrad)",
                    k.squareness.yz_urad, k.squareness.zx_urad
                ),
            };
            charts.push(ComponentChart {
                title: format!("{name}: positioning and straightness of {axis}{extra}"),
                x_label: format!("{axis} position (mm)"),
                y_label: "error (µm)".into(),
                series: linear,
            });
            charts.push(ComponentChart {
                title: format!("{name}: angular errors of {axis}"),
                x_label: format!("{axis} position (mm)"),
                y_label: "rotation (µrad)".into(),
                series: angular,
            });
        }
        charts
    }
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
