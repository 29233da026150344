//! `volcomp map eval`: print what a map gives at one axis position.

use super::args::EvalArgs;
use super::{directions, load_map, Map, AXES};
use crate::commands::parse_triple;
use crate::output::CliError;
use std::io::Write;
use volcomp_core::model::kinematic::{angular_name, linear_name, Form};
use volcomp_core::model::{direction_letters, Components, Direction};
use volcomp_gcode::Vec3;

fn fmt3(v: Vec3, decimals: usize) -> String {
    format!("{:+.d$}  {:+.d$}  {:+.d$}", v.x, v.y, v.z, d = decimals)
}

fn json3(v: Vec3) -> serde_json::Value {
    serde_json::json!([v.x, v.y, v.z])
}

pub(super) fn eval(a: EvalArgs) -> Result<(), CliError> {
    let map = load_map(&a.map, a.clamp)?;
    let q = parse_triple(&a.at, "--at")?;
    let s = directions(&a.direction)?;
    let tool = a.tool.offset()?.unwrap_or(Vec3::ZERO);
    let model = map.model();
    let e = model.deviation_with_tool_um(q, s, Components::All, tool)?;
    let pitch = model.deviation_with_tool_um(q, s, Components::PositioningOnly, tool)?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let mut w = |text: String| -> Result<(), CliError> {
        writeln!(out, "{text}").map_err(CliError::Stdout)
    };
    match &map {
        Map::Tables(m) => {
            let per_axis = m.per_axis_um(q, s)?;
            if a.json {
                let v = serde_json::json!({
                    "map": a.map.display().to_string(),
                    "kind": "axis-table",
                    "at_mm": json3(q),
                    "directions": direction_letters(s),
                    "deviation_um": json3(e),
                    "positioning_um": json3(pitch),
                    "axes_um": {"X": json3(per_axis[0]), "Y": json3(per_axis[1]), "Z": json3(per_axis[2])},
                });
                w(v.to_string())?;
            } else {
                w(format!(
                    "map          {} (axis tables; the tool does not enter)",
                    a.map.display()
                ))?;
                w(format!(
                    "at           X {:.4}  Y {:.4}  Z {:.4} mm, directions {}",
                    q.x,
                    q.y,
                    q.z,
                    direction_letters(s)
                ))?;
                w(format!(
                    "deviation    {} µm   |e| {:.4} µm",
                    fmt3(e, 4),
                    e.norm()
                ))?;
                w(format!(
                    "positioning  {} µm   (E_XX, E_YY, E_ZZ only)",
                    fmt3(pitch, 4)
                ))?;
                for (name, v) in AXES.iter().zip(&per_axis) {
                    w(format!("  {name} table  {} µm", fmt3(*v, 4)))?;
                }
            }
        }
        Map::Kinematic(m) => {
            let mut m = (**m).clone();
            m.form = a.tool.form()?;
            let r = m.query(q, s, tool)?;
            let v = r.values;
            let k = &m.kinematics;
            if a.json {
                let mut comps = serde_json::Map::new();
                let mut arms = serde_json::Map::new();
                let mut contrib = serde_json::Map::new();
                for (ax, axis) in AXES.iter().enumerate() {
                    for d in 0..3 {
                        comps.insert(linear_name(d, ax), serde_json::json!(v.linear_um[ax][d]));
                    }
                    for d in 0..3 {
                        comps.insert(
                            angular_name(d, ax),
                            serde_json::json!(v.angular_urad[ax][d]),
                        );
                    }
                    arms.insert(axis.to_string(), json3(r.abbe_arms_mm[ax]));
                    contrib.insert(axis.to_string(), json3(r.axis_contributions_um[ax]));
                }
                let j = serde_json::json!({
                    "map": a.map.display().to_string(),
                    "kind": "kinematic-21",
                    "chain": k.topology.to_string(),
                    "form": match m.form { Form::Htm => "htm", Form::FirstOrder => "first-order" },
                    "at_mm": json3(q),
                    "directions": direction_letters(s),
                    "tool_length_offset_mm": json3(tool),
                    "deviation_um": json3(r.deviation_um),
                    "deviation_htm_um": json3(r.deviation_htm_um),
                    "deviation_first_order_um": json3(r.deviation_first_order_um),
                    "positioning_um": json3(r.positioning_um),
                    "squareness_um": json3(r.squareness_um),
                    "components": comps,
                    "abbe_arms_mm": arms,
                    "axis_contributions_um": contrib,
                });
                w(j.to_string())?;
            } else {
                let (e, htm, first) = (
                    r.deviation_um,
                    r.deviation_htm_um,
                    r.deviation_first_order_um,
                );
                w(format!(
                    "map          {} (21-component, chain {}, {})",
                    a.map.display(),
                    k.topology,
                    match m.form {
                        Form::Htm => "HTM",
                        Form::FirstOrder => "first order",
                    }
                ))?;
                w(format!(
                    "at           X {:.4}  Y {:.4}  Z {:.4} mm, directions {}",
                    q.x,
                    q.y,
                    q.z,
                    direction_letters(s)
                ))?;
                w(format!("tool offset  {:.4}, {:.4}, {:.4} mm (G43 length offset; the tip is below the gauge point by it)", tool.x, tool.y, tool.z))?;
                w(format!(
                    "deviation    {} µm   |e| {:.4} µm",
                    fmt3(e, 4),
                    e.norm()
                ))?;
                w(format!("  HTM        {} µm", fmt3(htm, 6)))?;
                w(format!(
                    "  1st order  {} µm   (difference {:.2e} µm)",
                    fmt3(first, 6),
                    (htm - first).norm()
                ))?;
                w(format!(
                    "positioning  {} µm   (E_XX, E_YY, E_ZZ only)",
                    fmt3(r.positioning_um, 4)
                ))?;
                w(format!(
                    "squareness   {} µm   (S_xy·y + S_zx·z, S_yz·z, 0)",
                    fmt3(r.squareness_um, 4)
                ))?;
                for ax in 0..3 {
                    let names_l: Vec<String> = (0..3)
                        .map(|d| format!("{} {:+.3}", linear_name(d, ax), v.linear_um[ax][d]))
                        .collect();
                    let names_a: Vec<String> = (0..3)
                        .map(|d| format!("{} {:+.2}", angular_name(d, ax), v.angular_urad[ax][d]))
                        .collect();
                    let arm = r.abbe_arms_mm[ax];
                    let c = r.axis_contributions_um[ax];
                    w(format!(
                        "{} ({}{}) {} µm   {} µrad",
                        AXES[ax],
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
                    ))?;
                    w(format!(
                        "    Abbe arm {:.3}, {:.3}, {:.3} mm   contribution {} µm",
                        arm.x,
                        arm.y,
                        arm.z,
                        fmt3(c, 4)
                    ))?;
                }
            }
        }
    }
    Ok(())
}
