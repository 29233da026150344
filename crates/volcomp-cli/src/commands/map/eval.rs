//! `volcomp map eval`: print what a map gives at one axis position (the
//! lines are the library's, `volcomp_core::report::map`; JSON is built here).

use super::args::EvalArgs;
use super::{directions, load_map, Map, AXES};
use crate::commands::parse_triple;
use crate::output::CliError;
use std::io::Write;
use volcomp_core::model::kinematic::{angular_name, linear_name, Form, KinematicModel};
use volcomp_core::model::query::KinematicQuery;
use volcomp_core::model::{direction_letters, Components, Directions};
use volcomp_core::report::map::{kinematic_point_lines, table_point_lines};
use volcomp_gcode::Vec3;

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
    let name = a.map.display().to_string();
    let lines = match &map {
        Map::Tables(m) => {
            let per_axis = m.per_axis_um(q, s)?;
            if a.json {
                let v = serde_json::json!({
                    "map": name,
                    "kind": "axis-table",
                    "at_mm": json3(q),
                    "directions": direction_letters(s),
                    "deviation_um": json3(e),
                    "positioning_um": json3(pitch),
                    "axes_um": {"X": json3(per_axis[0]), "Y": json3(per_axis[1]), "Z": json3(per_axis[2])},
                });
                vec![v.to_string()]
            } else {
                table_point_lines(&name, q, s, e, pitch, &per_axis)
            }
        }
        Map::Kinematic(m) => {
            let mut m = (**m).clone();
            m.form = a.tool.form()?;
            let r = m.query(q, s, tool)?;
            if a.json {
                vec![kinematic_json(&name, &m, q, s, tool, &r).to_string()]
            } else {
                kinematic_point_lines(&name, &m, q, s, tool, &r)
            }
        }
    };
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    for line in lines {
        writeln!(out, "{line}").map_err(CliError::Stdout)?;
    }
    Ok(())
}

/// A 21-component model at one point as one JSON object.
fn kinematic_json(
    name: &str,
    m: &KinematicModel,
    q: Vec3,
    s: Directions,
    tool: Vec3,
    r: &KinematicQuery,
) -> serde_json::Value {
    let (v, k) = (&r.values, &m.kinematics);
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
    serde_json::json!({
        "map": name,
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
    })
}
