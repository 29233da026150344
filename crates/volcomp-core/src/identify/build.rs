//! A 21-component model from measurement runs (`volcomp map build`):
//! one run file per measured component, processed as ISO 230-1 and
//! ISO 230-2 do it (docs/build.md).
//!
//! Every run file has the ISO 230-2 layout of [`crate::identify::iso230_2`]
//! (`target_mm, cycle, direction, deviation_um`; angular components give
//! `deviation_urad`): each target approached several times in both
//! directions. Per target the mean deviation of each direction and their
//! scatter are taken ([ISO 230-2] clause 3); then, per kind of component:
//!
//! * **positioning** (`EXX`, `EYY`, `EZZ`): the mean unidirectional
//!   deviations `x̄↑`, `x̄↓` as the forward and reverse tables (the reversal
//!   is kept for backlash), with the run's ISO 230-2 figures in the summary;
//! * **straightness** (`EYX`, `EZX`, `EXY`, `EZY`, `EXZ`, `EYZ`): the mean
//!   bidirectional deviation `x̄_i` relative to a reference straight line —
//!   least squares by default, the line through the end points on request
//!   ([ISO 230-1] straightness) — the removed slope reported;
//! * **squareness** (ISO 230-1): from the slopes of the two straightness
//!   runs of a plane, both taken against the same square. With the square
//!   turned by `φ` the runs record `EYX − φ·x` and `EXY + S_xy·y + φ·y`, so
//!   `S_xy = slope(EYX) + slope(EXY)` (likewise `S_zx` from `EZX`, `EXZ` and
//!   `S_yz` from `EZY`, `EYZ`); a plane without both runs is square
//!   (reported as assumed);
//! * **angular** (`EAX` … `ECZ`): the mean bidirectional deviation, zeroed
//!   at the reference point (an angle is relative to where the level or the
//!   angular optics were zeroed).
//!
//! The run-to-run scatter (the largest standard uncertainty of a target
//! mean, `s/√n` over both directions) is each component's uncertainty; a
//! squareness' uncertainty follows from its two slopes' standard errors.
//! Components without a run are zero, and reported so.

use crate::error::MapFileError;
use crate::identify::iso230_2::{self, Iso230_2Report};
use crate::model::kinematic::{AxisComponents, ComponentTable, KinematicModel, Kinematics};
use crate::model::topology::Topology;
use volcomp_gcode::Vec3;

/// How the straightness reference line is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReferenceLine {
    /// The least-squares line (ISO 230-1's default).
    LeastSquares,
    /// The line through the first and last target.
    EndPoints,
}

/// One component's run, read.
#[derive(Debug, Clone)]
pub struct ComponentRun {
    /// ISO 230-1 symbol, e.g. `EXX`, `EYX`, `EAX`.
    pub component: String,
    /// The evaluated run (deviations in µm, or µrad for angles).
    pub report: Iso230_2Report,
}

/// What a built model rests on.
#[derive(Debug, Clone)]
pub struct BuildSummary {
    /// Per measured component: symbol, uncertainty (µm or µrad), and for
    /// straightness the removed slope (µrad).
    pub measured: Vec<(String, f64, Option<f64>)>,
    /// Components and squareness errors taken as zero.
    pub assumed_zero: Vec<String>,
    /// Squareness found: `(name, value µrad, standard uncertainty µrad)`.
    pub squareness: Vec<(String, f64, f64)>,
    /// Per positioning run: axis and its ISO 230-2 figures `(A, B, R, E, M)` in µm.
    pub iso230_2: Vec<(char, [f64; 5])>,
}

/// The plan of a build, as the TOML file gives it.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The machine's chain.
    pub chain: Topology,
    /// Where each axis' (X, Y, Z) linear errors were measured: the axis
    /// positions (mm) and the reflector's tool length offset (mm, as G43
    /// applies it).
    pub measuring: [(Vec3, f64); 3],
    /// Where the angular errors are zero (axis positions, mm).
    pub reference_point_mm: Vec3,
    /// Straightness reference line.
    pub reference_line: ReferenceLine,
}

const AXES: [char; 3] = ['X', 'Y', 'Z'];
const DIRS: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];

/// `(direction index 0–5, axis index 0–2)` of an ISO 230-1 component symbol.
pub fn component_indices(symbol: &str) -> Option<(usize, usize)> {
    let b: Vec<char> = symbol.chars().collect();
    match b.as_slice() {
        ['E', d, a] => Some((
            DIRS.iter().position(|x| x == d)?,
            AXES.iter().position(|x| x == a)?,
        )),
        _ => None,
    }
}

/// Reads one run file: the ISO 230-2 layout; `deviation_urad` (angles) is
/// read as the deviation column in µrad.
pub fn read_run(component: &str, text: &str, file: &str) -> Result<ComponentRun, MapFileError> {
    let (d, _) = component_indices(component).ok_or_else(|| {
        MapFileError::new(
            file,
            1,
            1,
            format!("`{component}` is not a component of the 21"),
            "write an ISO 230-1 symbol such as EXX, EYX or EAX",
        )
    })?;
    let header_has = |c: &str| {
        text.lines()
            .find(|l| !l.trim().is_empty() && !l.starts_with('#'))
            .is_some_and(|h| h.split(',').any(|f| f.trim() == c))
    };
    let text = if d >= 3 {
        if !header_has("deviation_urad") {
            return Err(MapFileError::new(
                file,
                1,
                1,
                format!("{component} is an angle: the run needs a deviation_urad column"),
                "write the angular deviations in µrad, column deviation_urad",
            ));
        }
        text.replacen("deviation_urad", "deviation_um", 1)
    } else {
        if header_has("deviation_urad") {
            return Err(MapFileError::new(
                file,
                1,
                1,
                format!("{component} is a displacement: deviation_urad is an angle"),
                "write the deviations in µm, column deviation_um",
            ));
        }
        text.to_string()
    };
    Ok(ComponentRun {
        component: component.to_string(),
        report: iso230_2::from_csv(&text, file)?,
    })
}

/// Least-squares slope and intercept of `v` over `x`, and the slope's standard error.
fn fit_line(x: &[f64], v: &[f64]) -> (f64, f64, f64) {
    let n = x.len() as f64;
    let mx = x.iter().sum::<f64>() / n;
    let mv = v.iter().sum::<f64>() / n;
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    let sxv: f64 = x.iter().zip(v).map(|(a, b)| (a - mx) * (b - mv)).sum();
    let slope = sxv / sxx;
    let intercept = mv - slope * mx;
    (slope, intercept, sxx)
}

/// The standard uncertainty of a target mean, largest over the targets
/// (both directions: `s/√n`).
fn scatter(r: &Iso230_2Report) -> f64 {
    r.targets
        .iter()
        .flat_map(|t| {
            [
                t.s_up_um / (t.n_up as f64).sqrt(),
                t.s_down_um / (t.n_down as f64).sqrt(),
            ]
        })
        .fold(0.0, f64::max)
}

fn interp(x: &[f64], v: &[f64], at: f64) -> f64 {
    crate::io::controllers::interpolate_held(x, v, at)
}

/// Builds the model from the runs (see the module's text). `file` names
/// the plan in errors.
pub fn build(
    plan: &Plan,
    runs: &[ComponentRun],
    file: &str,
) -> Result<(KinematicModel, BuildSummary), MapFileError> {
    let mut summary = BuildSummary {
        measured: Vec::new(),
        assumed_zero: Vec::new(),
        squareness: Vec::new(),
        iso230_2: Vec::new(),
    };
    // (forward, reverse) tables per (direction, axis), µm or µrad, and slopes of straightness runs.
    // Per axis and direction: (targets, forward, reverse).
    type Tables = Option<(Vec<f64>, Vec<f64>, Vec<f64>)>;
    let mut tables: [[Tables; 6]; 3] = Default::default();
    let mut slopes: [[Option<(f64, f64)>; 3]; 3] = Default::default();
    for run in runs {
        let (d, a) = component_indices(&run.component).ok_or_else(|| {
            MapFileError::new(
                file,
                1,
                1,
                format!("`{}` is not a component", run.component),
                "write EXX … ECZ",
            )
        })?;
        if tables[a][d].is_some() {
            return Err(MapFileError::new(
                file,
                1,
                1,
                format!("{} is measured twice", run.component),
                "give each component one run file",
            ));
        }
        let r = &run.report;
        let x: Vec<f64> = r.targets.iter().map(|t| t.target_mm).collect();
        let up: Vec<f64> = r.targets.iter().map(|t| t.mean_up_um).collect();
        let down: Vec<f64> = r.targets.iter().map(|t| t.mean_down_um).collect();
        let mean: Vec<f64> = r.targets.iter().map(|t| t.mean_um).collect();
        let u = scatter(r);
        if d == a {
            let f = &r.axis;
            summary.iso230_2.push((
                AXES[a],
                [
                    f.accuracy_um,
                    f.reversal_b_um,
                    f.repeatability_um,
                    f.systematic_um,
                    f.mean_range_um,
                ],
            ));
            summary.measured.push((run.component.clone(), u, None));
            tables[a][d] = Some((x, up, down));
        } else if d < 3 {
            let (slope, intercept, sxx) = match plan.reference_line {
                ReferenceLine::LeastSquares => fit_line(&x, &mean),
                ReferenceLine::EndPoints => {
                    let n = x.len() - 1;
                    let s = (mean[n] - mean[0]) / (x[n] - x[0]);
                    let (_, _, sxx) = fit_line(&x, &mean);
                    (s, mean[0] - s * x[0], sxx)
                }
            };
            let straight: Vec<f64> = x
                .iter()
                .zip(&mean)
                .map(|(p, v)| v - (intercept + slope * p))
                .collect();
            // µm/mm = 10³ µrad; the slope's standard error from the target means' uncertainty.
            slopes[a][d] = Some((slope * 1e3, u / sxx.sqrt() * 1e3));
            summary
                .measured
                .push((run.component.clone(), u, Some(slope * 1e3)));
            tables[a][d] = Some((x, straight.clone(), straight));
        } else {
            let at = plan.reference_point_mm[a];
            let zero = interp(&x, &mean, at);
            let v: Vec<f64> = mean.iter().map(|m| m - zero).collect();
            summary.measured.push((run.component.clone(), u, None));
            tables[a][d] = Some((x, v.clone(), v));
        }
    }
    // Squareness from the straightness pairs: (name, (dir, axis) of the two runs).
    let mut kin = Kinematics::new(plan.chain);
    for (name, p, q) in [
        ("xy", (1, 0), (0, 1)),
        ("zx", (2, 0), (0, 2)),
        ("yz", (2, 1), (1, 2)),
    ] {
        match (slopes[p.1][p.0], slopes[q.1][q.0]) {
            (Some((s1, u1)), Some((s2, u2))) => {
                let s = s1 + s2;
                let u = (u1 * u1 + u2 * u2).sqrt();
                match name {
                    "xy" => kin.squareness.xy_urad = s,
                    "zx" => kin.squareness.zx_urad = s,
                    _ => kin.squareness.yz_urad = s,
                }
                summary.squareness.push((format!("S_{name}"), s, u));
            }
            _ => summary.assumed_zero.push(format!(
                "S_{name} (needs both straightness runs of the plane)"
            )),
        }
    }
    let mut axes = Vec::new();
    for a in 0..3 {
        let mut pos: Vec<f64> = tables[a]
            .iter()
            .flatten()
            .flat_map(|t| t.0.iter().copied())
            .collect();
        pos.sort_by(f64::total_cmp);
        pos.dedup();
        if pos.len() < 2 {
            return Err(MapFileError::new(
                file,
                1,
                1,
                format!("no run measures axis {}", AXES[a]),
                "measure at least the positioning error of every axis (e.g. EXX)",
            ));
        }
        let mut lin = [vec![Vec3::ZERO; pos.len()], vec![Vec3::ZERO; pos.len()]];
        let mut ang = [vec![Vec3::ZERO; pos.len()], vec![Vec3::ZERO; pos.len()]];
        for d in 0..6 {
            let Some((x, f, r)) = &tables[a][d] else {
                summary
                    .assumed_zero
                    .push(format!("E{}{}", DIRS[d], AXES[a]));
                continue;
            };
            if x[0] > pos[0] + 1e-9 || x[x.len() - 1] < pos[pos.len() - 1] - 1e-9 {
                return Err(MapFileError::new(file, 1, 1, format!("E{}{} covers {} … {} mm, other runs of {} {} … {} mm", DIRS[d], AXES[a], x[0], x[x.len() - 1], AXES[a], pos[0], pos[pos.len() - 1]), "measure every component of an axis over the same range (volcomp does not extrapolate)"));
            }
            for (k, &p) in pos.iter().enumerate() {
                for (dir, v) in [f, r].iter().enumerate() {
                    let val = interp(x, v, p);
                    if d < 3 {
                        lin[dir][k][d] = val;
                    } else {
                        ang[dir][k][d - 3] = val;
                    }
                }
            }
        }
        let [lf, lr] = lin;
        let [af, ar] = ang;
        let t = |l: Vec<Vec3>, g: Vec<Vec3>| {
            ComponentTable::new(pos.clone(), l, g).ok_or_else(|| {
                MapFileError::new(
                    file,
                    1,
                    1,
                    format!("the targets of {} do not increase", AXES[a]),
                    "targets are distinct positions",
                )
            })
        };
        axes.push(AxisComponents {
            forward: t(lf, af)?,
            reverse: t(lr, ar)?,
        });
    }
    for (m, (point, tool)) in kin.measuring.iter_mut().zip(plan.measuring) {
        m.point_mm = point;
        m.tool_offset_mm = Vec3::new(0.0, 0.0, tool);
    }
    let axes: [AxisComponents; 3] = axes
        .try_into()
        .map_err(|_| MapFileError::new(file, 1, 1, "three axes expected", ""))?;
    Ok((KinematicModel::new(axes, kin), summary))
}

/// The plan file (TOML) of `volcomp map build`:
///
/// ```toml
/// model = "build-plan"
/// chain = "w X' Y' b Z t"
/// units = "mm"                       # positions mm, deviations µm / µrad
/// measuring_point_mm = [0, 0, 0]     # the other axes' positions during the runs
/// measuring_tool_length_mm = 0       # the reflector's tool length offset
/// reference_point_mm = [0, 0, 0]     # where the angular errors are zero
/// straightness_reference = "least-squares"   # or "end-points"
///
/// [measuring.Z]                      # optional, per axis: where it was measured
/// point_mm = [200, 150, 0]
/// tool_length_mm = 100
///
/// [runs]                             # component = run file (relative to the plan)
/// EXX = "runs/exx.csv"
/// EYX = "runs/eyx.csv"
/// ```
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanFile {
    model: String,
    chain: String,
    units: String,
    #[serde(default)]
    measuring_point_mm: Option<[f64; 3]>,
    #[serde(default)]
    measuring_tool_length_mm: Option<f64>,
    #[serde(default)]
    reference_point_mm: Option<[f64; 3]>,
    #[serde(default)]
    straightness_reference: Option<String>,
    #[serde(default)]
    measuring: std::collections::BTreeMap<String, AxisMeasuring>,
    runs: std::collections::BTreeMap<String, String>,
}

/// `[measuring.X]`: where one axis was measured, when not at the plan's
/// common measuring point.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct AxisMeasuring {
    point_mm: Option<[f64; 3]>,
    tool_length_mm: Option<f64>,
}

/// Reads a plan: the [`Plan`] and the `(component, run file)` pairs in the
/// order of the components.
pub fn parse_plan(text: &str, file: &str) -> Result<(Plan, Vec<(String, String)>), MapFileError> {
    let at = |span: Option<std::ops::Range<usize>>| -> (usize, usize) {
        let Some(s) = span else { return (1, 1) };
        let before = &text[..s.start.min(text.len())];
        let row = before.matches('\n').count() + 1;
        let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        (row, col)
    };
    let p: PlanFile = toml::from_str(text).map_err(|e| {
        let (row, col) = at(e.span());
        MapFileError::new(
            file,
            row,
            col,
            e.message().to_string(),
            "see docs/build.md for the plan's keys (units carry their names: measuring_point_mm …)",
        )
    })?;
    if p.model != "build-plan" {
        return Err(MapFileError::new(
            file,
            1,
            1,
            format!("model = \"{}\"", p.model),
            "a plan says model = \"build-plan\"",
        ));
    }
    if p.units != "mm" {
        return Err(MapFileError::new(
            file,
            1,
            1,
            format!("units = \"{}\"", p.units),
            "runs are read in mm (positions), µm and µrad (deviations): write units = \"mm\"",
        ));
    }
    let chain: Topology = p.chain.parse().map_err(|e| {
        MapFileError::new(
            file,
            1,
            1,
            format!("chain: {e}"),
            "write the chain as in docs/kinematic.md, e.g. \"w X' Y' b Z t\"",
        )
    })?;
    let reference_line = match p.straightness_reference.as_deref() {
        None | Some("least-squares") => ReferenceLine::LeastSquares,
        Some("end-points") => ReferenceLine::EndPoints,
        Some(o) => {
            return Err(MapFileError::new(
                file,
                1,
                1,
                format!("straightness_reference = \"{o}\""),
                "write least-squares or end-points",
            ))
        }
    };
    for c in p.runs.keys() {
        if component_indices(c).is_none() {
            return Err(MapFileError::new(
                file,
                1,
                1,
                format!("`{c}` in [runs] is not one of the 18 component errors"),
                "write EXX, EYX, EZX, EAX, EBX, ECX and likewise for Y and Z",
            ));
        }
    }
    let v = |a: Option<[f64; 3]>| a.map_or(Vec3::ZERO, |[x, y, z]| Vec3::new(x, y, z));
    let common = (
        v(p.measuring_point_mm),
        p.measuring_tool_length_mm.unwrap_or(0.0),
    );
    let mut measuring = [common; 3];
    for (axis, m) in &p.measuring {
        let a = AXES
            .iter()
            .position(|c| c.to_string() == *axis)
            .ok_or_else(|| {
                MapFileError::new(
                    file,
                    1,
                    1,
                    format!("[measuring.{axis}] is not an axis"),
                    "write [measuring.X], [measuring.Y] or [measuring.Z]",
                )
            })?;
        measuring[a] = (
            m.point_mm.map_or(common.0, |[x, y, z]| Vec3::new(x, y, z)),
            m.tool_length_mm.unwrap_or(common.1),
        );
    }
    Ok((
        Plan {
            chain,
            measuring,
            reference_point_mm: v(p.reference_point_mm),
            reference_line,
        },
        p.runs.into_iter().collect(),
    ))
}

impl BuildSummary {
    /// The summary as text lines.
    pub fn lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        for (c, u, slope) in &self.measured {
            let unit = if c.as_bytes()[1] >= b'A' && c.as_bytes()[1] <= b'C' {
                "µrad"
            } else {
                "µm"
            };
            match slope {
                Some(s) => out.push(format!("measured {c}: uncertainty {u:.3} {unit}, reference-line slope removed {s:.3} µrad")),
                None => out.push(format!("measured {c}: uncertainty {u:.3} {unit}")),
            }
        }
        for (n, s, u) in &self.squareness {
            out.push(format!(
                "squareness {n} = {s:.3} µrad ± {u:.3} µrad (from the straightness slopes)"
            ));
        }
        for (a, [acc, b, r, e, m]) in &self.iso230_2 {
            out.push(format!(
                "ISO 230-2 {a}: A {acc:.3} µm, B {b:.3} µm, R {r:.3} µm, E {e:.3} µm, M {m:.3} µm"
            ));
        }
        if !self.assumed_zero.is_empty() {
            out.push(format!("assumed zero: {}", self.assumed_zero.join(", ")));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::example::build as synthetic;

    #[test]
    fn synthetic_runs_are_built_back_within_their_scatter() {
        let files = synthetic::files();
        let (plan_name, plan_text) = &files[0];
        let (plan, runs) = parse_plan(plan_text, plan_name).unwrap();
        let runs: Vec<ComponentRun> = runs
            .iter()
            .map(|(c, f)| {
                let text = &files
                    .iter()
                    .find(|(n, _)| *n == format!("build/{f}"))
                    .unwrap()
                    .1;
                read_run(c, text, f).unwrap()
            })
            .collect();
        assert_eq!(runs.len(), 18);
        let (model, summary) = build(&plan, &runs, plan_name).unwrap();
        // Every component within four of its reported uncertainties (the
        // largest standard uncertainty of a target mean); straightness and
        // angles also carry the fitted line or the zero through noisy
        // means, and get six.
        for (a, axis) in AXES.iter().enumerate() {
            for (k, &x) in model.axes[a].forward.positions_mm().iter().enumerate() {
                for (d, dir) in DIRS.iter().enumerate() {
                    let name = format!("E{dir}{axis}");
                    let u = summary.measured.iter().find(|m| m.0 == name).unwrap().1;
                    let (f, r) = if d < 3 {
                        (
                            model.axes[a].forward.linear_um.errors_um[k][d],
                            model.axes[a].reverse.linear_um.errors_um[k][d],
                        )
                    } else {
                        (
                            model.axes[a].forward.angular_urad.errors_um[k][d - 3],
                            model.axes[a].reverse.angular_urad.errors_um[k][d - 3],
                        )
                    };
                    let (tf, tr) = synthetic::truth(d, a, x);
                    let tol = if d == a { 4.0 * u } else { 6.0 * u };
                    assert!(
                        (f - tf).abs() <= tol && (r - tr).abs() <= tol,
                        "{name} at {x}: built {f}/{r}, truth {tf}/{tr}, u {u}"
                    );
                }
            }
        }
        // Squareness within three standard uncertainties, despite the squares' misalignment.
        let s = model.kinematics.squareness;
        for ((name, value, u), truth) in
            summary
                .squareness
                .iter()
                .zip([synthetic::S_XY, synthetic::S_ZX, synthetic::S_YZ])
        {
            assert!(
                (value - truth).abs() <= 3.0 * u,
                "{name}: {value} ± {u}, truth {truth}"
            );
        }
        assert!(
            (s.xy_urad - synthetic::S_XY).abs() < 1.0 && (s.yz_urad - synthetic::S_YZ).abs() < 1.0
        );
        // The positioning runs' ISO 230-2 figures: the reversal B is the 2 µm backlash of X.
        let (ax, fig) = summary.iso230_2[0];
        assert_eq!(ax, 'X');
        assert!((fig[1] - 2.0).abs() < 0.3, "{fig:?}");
        assert!(
            summary.assumed_zero.is_empty(),
            "{:?}",
            summary.assumed_zero
        );
    }

    #[test]
    fn bad_plans_and_runs_are_refused() {
        let e = parse_plan(
            "model = \"build-plan\"\nchain = \"w X' Y' b Z t\"\nunits = \"inch\"\n[runs]\n",
            "p.toml",
        )
        .unwrap_err();
        assert!(e.message.contains("inch"));
        let e = parse_plan("model = \"build-plan\"\nchain = \"w X' Y' b Z t\"\nunits = \"mm\"\nmeasuring_point = [0, 0, 0]\n[runs]\n", "p.toml").unwrap_err();
        assert_eq!(e.row, 4, "{e}");
        let e = parse_plan("model = \"build-plan\"\nchain = \"w X' Y' b Z t\"\nunits = \"mm\"\n[runs]\nEXQ = \"a.csv\"\n", "p.toml").unwrap_err();
        assert!(e.message.contains("EXQ"));
        let e = read_run(
            "EAX",
            "target_mm,cycle,direction,deviation_um\n0,1,up,0\n",
            "a.csv",
        )
        .unwrap_err();
        assert!(e.message.contains("deviation_urad"));
    }
}
