//! Synthetic machines probed: a 21-component truth with reversal (backlash),
//! a probe with direction-dependent pre-travel and noise, artifacts with
//! errors of their own placed a little off where they were described, and
//! the touches a probing plan would record on them — written as the log
//! LinuxCNC writes. For `volcomp probe example`, the documentation and the
//! tests.

use crate::identify::probe::artifact::{parse_artifact, Artifact, Feature, Kind, Placement};
use crate::identify::probe::geometry::{rotate, turn, AxisDir, Rotation};
use crate::identify::probe::plan::{plan, Plan, PlanOptions, PlannedTouch};
use crate::identify::probe::program::Frame;
use crate::identify::thermal::poly::{Param, PolyModel};
use crate::io::numfmt;
use crate::io::probe_log::{states_label, Source, Touch, LOG_VERSION};
use crate::model::kinematic::Kinematics;
use crate::model::topology::Topology;
use crate::model::{Direction, Directions};
use crate::rng::Rng;
use volcomp_gcode::Vec3;

/// A synthetic machine and probe.
#[derive(Debug, Clone)]
pub struct SyntheticMachine {
    /// Travel (mm).
    pub ranges_mm: [[f64; 2]; 3],
    /// The truth: every component as Legendre polynomials up to its order,
    /// the terms a probe cannot see (offsets, straightness slopes, constant
    /// angles) included; measuring tool at 0.
    pub truth: PolyModel,
    /// The truth's coefficients (µm, µrad).
    pub theta: Vec<f64>,
    /// Reversal values of X, Y, Z (µm, positive: the axis lags).
    pub reversal_um: [f64; 3],
    /// The probe's tip radius (mm).
    pub tip_radius_mm: f64,
    /// Pre-travel per direction of motion, [`AxisDir::ALL`] order (µm).
    pub pretravel_um: [f64; 6],
    /// Probing noise (µm, σ along the direction of motion).
    pub noise_um: f64,
}

/// The truth's parameter list: the model's, plus offsets, straightness
/// slopes and constant angles.
fn truth_model(ranges_mm: [[f64; 2]; 3], order: usize) -> PolyModel {
    let mut m = PolyModel::new(Kinematics::new(Topology::SEED), ranges_mm, order);
    for axis in 0..3 {
        for component in 0..6 {
            m.params.push(Param::Legendre {
                axis,
                component,
                k: 0,
            });
            if component < 3 && component != axis {
                m.params.push(Param::Legendre {
                    axis,
                    component,
                    k: 1,
                });
            }
        }
    }
    m
}

impl SyntheticMachine {
    /// A random machine of Legendre order `order` over `ranges_mm` (seeded):
    /// positioning slopes of 5–15 µm over half the travel, bows and angles
    /// of a few µm and µrad, squareness up to 20 µrad, reversal 1–5 µm,
    /// pre-travel 0.5–3 µm per direction, noise `noise_um`.
    pub fn random(seed: u64, order: usize, ranges_mm: [[f64; 2]; 3], noise_um: f64) -> Self {
        let mut rng = Rng::new(seed);
        let truth = truth_model(ranges_mm, order);
        let mut u = |lo: f64, hi: f64| {
            let s = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            s * (lo + (hi - lo) * rng.uniform())
        };
        let theta = truth
            .params
            .iter()
            .map(|p| match *p {
                Param::Legendre { axis, component, k } => {
                    let linear = component < 3;
                    match (linear, component == axis, k) {
                        (true, _, 0) => u(0.0, 20.0),
                        (true, true, 1) => u(5.0, 15.0),
                        (true, false, 1) => u(0.0, 10.0),
                        (true, _, _) => u(1.0, 4.0),
                        (false, _, 0) => u(0.0, 20.0),
                        (false, _, 1) => u(3.0, 12.0),
                        (false, _, _) => u(1.0, 6.0),
                    }
                }
                Param::Squareness(_) => u(3.0, 20.0),
            })
            .collect();
        let reversal_um = [u(1.0, 5.0).abs(), u(1.0, 5.0).abs(), u(1.0, 5.0).abs()];
        let pretravel_um = [0; 6].map(|_| u(0.5, 3.0).abs());
        Self {
            ranges_mm,
            truth,
            theta,
            reversal_um,
            tip_radius_mm: 1.0 - u(0.0, 0.003).abs(),
            pretravel_um,
            noise_um,
        }
    }

    /// The true deviation at `q` (µm): the truth by HTM, plus the reversal.
    pub fn deviation_um(&self, q_mm: Vec3, s: Directions, tool_mm: f64) -> Vec3 {
        let mut e = self
            .truth
            .deviation_um(&self.theta, q_mm, Vec3::new(0.0, 0.0, tool_mm), true);
        for a in 0..3 {
            e[a] += match s[a] {
                Direction::Forward => -self.reversal_um[a] / 2.0,
                Direction::Reverse => self.reversal_um[a] / 2.0,
            };
        }
        e
    }

    /// The geometric deviation (no reversal, µm) at `q` for a tool.
    pub fn geometric_um(&self, q_mm: Vec3, tool_mm: f64) -> Vec3 {
        self.truth
            .deviation_um(&self.theta, q_mm, Vec3::new(0.0, 0.0, tool_mm), true)
    }

    /// Where the machine reports the probe when a planned touch meets
    /// `surface`: the commanded position along the probe move at which the
    /// actual tip has moved `p_d` beyond first contact, plus noise along the
    /// move. `None` when it does not touch within the move.
    pub fn touch(
        &self,
        t: &PlannedTouch,
        surface: &Surface,
        tool_mm: f64,
        rng: &mut Rng,
    ) -> Option<Vec3> {
        let d = t.direction.vector();
        let len = (t.target_mm - t.start_mm).norm();
        let actual = |lam: f64| {
            let q = t.start_mm + d * lam;
            q + self.deviation_um(q, t.states, tool_mm) * 1e-3
        };
        let gap = |lam: f64| surface.gap_mm(actual(lam), self.tip_radius_mm);
        if gap(0.0) <= 0.0 || gap(len) > 0.0 {
            return None;
        }
        // Bisection to 1e-12 mm: the gap is monotone along a probe move.
        let (mut lo, mut hi) = (0.0, len);
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if gap(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let lam = 0.5 * (lo + hi)
            + self.pretravel_um[t.direction.index()] * 1e-3
            + rng.normal() * self.noise_um * 1e-3;
        Some(t.start_mm + d * lam)
    }
}

/// A true surface an artifact presents.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Surface {
    /// A sphere.
    Sphere {
        /// Centre (machine coordinates, mm).
        centre_mm: Vec3,
        /// Radius (mm).
        radius_mm: f64,
    },
    /// A plane (a face, an edge's face).
    Plane {
        /// A point on it (mm).
        point_mm: Vec3,
        /// Outward normal.
        normal: Vec3,
    },
}

impl Surface {
    /// Distance from the tip's surface to the artifact's (mm; negative
    /// once they overlap) for a tip of radius `r` centred at `a`.
    fn gap_mm(&self, a: Vec3, r: f64) -> f64 {
        match *self {
            Surface::Sphere {
                centre_mm,
                radius_mm,
            } => (a - centre_mm).norm() - radius_mm - r,
            Surface::Plane { point_mm, normal } => normal.dot(a - point_mm) - r,
        }
    }
}

/// An artifact as it really is and where it really sits.
#[derive(Debug, Clone)]
pub struct RealArtifact {
    /// As described (nominal or certified geometry, nominal placements).
    pub described: Artifact,
    /// True sphere centres (artifact frame, mm).
    pub balls_mm: Vec<Vec3>,
    /// True sphere radii (mm).
    pub radii_mm: Vec<f64>,
    /// True face positions along x (mm).
    pub faces_mm: Vec<f64>,
    /// True square angle deviation (µrad).
    pub angle_urad: f64,
    /// True placements, in the described order.
    pub placements: Vec<Placement>,
}

impl RealArtifact {
    /// The artifact with errors of its own: sphere centres off by 1–3 µm
    /// (uncertified) or by the certificate's uncertainty, radii by up to
    /// 1 µm, faces by the certificate's uncertainty, a square 0–20 µrad
    /// off 90° (unless certified); each placement off by up to 0.3 mm and
    /// 0.5 mrad.
    pub fn new(described: Artifact, rng: &mut Rng) -> Self {
        let mut balls_mm = Vec::new();
        let mut radii_mm = Vec::new();
        let mut faces_mm = Vec::new();
        let mut angle_urad = 0.0;
        let dir = |rng: &mut Rng| {
            Vec3::new(rng.normal(), rng.normal(), rng.normal())
                .normalized()
                .unwrap_or(Vec3::new(1.0, 0.0, 0.0))
        };
        match &described.kind {
            Kind::ReferenceSphere { diameter_mm, .. } => {
                balls_mm.push(Vec3::ZERO);
                radii_mm.push(diameter_mm / 2.0);
            }
            Kind::Spheres {
                diameter_mm,
                centres_mm,
                certified_u_um,
                ..
            } => {
                for c in centres_mm {
                    let off = match certified_u_um {
                        Some(u) => Vec3::new(rng.normal(), rng.normal(), rng.normal()) * (u * 1e-3),
                        None => dir(rng) * ((1.0 + 2.0 * rng.uniform()) * 1e-3),
                    };
                    balls_mm.push(*c + off);
                    radii_mm.push(diameter_mm / 2.0 + (rng.uniform() - 0.5) * 2e-3);
                }
            }
            Kind::Gauge {
                faces_mm: f,
                certified_u_um,
                ..
            } => {
                for (i, x) in f.iter().enumerate() {
                    let u = certified_u_um.unwrap_or(2.0) * 1e-3;
                    faces_mm.push(if i == 0 { *x } else { x + rng.normal() * u });
                }
            }
            Kind::Square { certified, .. } => {
                angle_urad = match certified {
                    Some((v, u)) => v + rng.normal() * u,
                    None => (rng.uniform() - 0.5) * 40.0,
                };
            }
        }
        let placements = described
            .placements
            .iter()
            .map(|p| {
                let w = dir(rng) * (0.5e-3 * rng.uniform());
                let rot: Rotation = turn(&p.axes, w);
                Placement {
                    name: p.name.clone(),
                    origin_mm: p.origin_mm + dir(rng) * (0.3 * rng.uniform()),
                    axes: rot,
                }
            })
            .collect();
        Self {
            described,
            balls_mm,
            radii_mm,
            faces_mm,
            angle_urad,
            placements,
        }
    }

    /// The true surface a planned touch meets.
    pub fn surface(&self, t: &PlannedTouch) -> Surface {
        let k = self
            .described
            .placements
            .iter()
            .position(|p| p.name == t.placement)
            .unwrap_or(0);
        let p = &self.placements[k];
        let feature = self.described.feature(&t.feature);
        match feature {
            Some(Feature::Sphere { index, .. }) => Surface::Sphere {
                centre_mm: p.to_machine(self.balls_mm[index]),
                radius_mm: self.radii_mm[index],
            },
            Some(Feature::Face { index, facing, .. }) => {
                let off = match &self.described.kind {
                    Kind::Gauge { offsets_mm, .. } => offsets_mm[index],
                    _ => [0.0, 0.0],
                };
                Surface::Plane {
                    point_mm: p.to_machine(Vec3::new(self.faces_mm[index], off[0], off[1])),
                    normal: p.direction(Vec3::new(facing, 0.0, 0.0)),
                }
            }
            Some(Feature::Edge { index, .. }) => {
                let inner = matches!(self.described.kind, Kind::Square { inner: true, .. });
                let d = self.angle_urad * 1e-6;
                let n_art = match (index, inner) {
                    (0, false) => Vec3::new(0.0, -1.0, 0.0),
                    (0, true) => Vec3::new(0.0, 1.0, 0.0),
                    (_, false) => Vec3::new(-1.0, -d, 0.0),
                    (_, true) => Vec3::new(1.0, d, 0.0),
                };
                Surface::Plane {
                    point_mm: p.origin_mm,
                    normal: rotate(&p.axes, n_art).normalized().unwrap_or(n_art),
                }
            }
            None => Surface::Plane {
                point_mm: Vec3::ZERO,
                normal: Vec3::new(0.0, 0.0, 1.0),
            },
        }
    }
}

/// The touches a plan records on a real artifact (a touch that misses is
/// recorded as not tripped, as G38.3 would).
pub fn simulate(
    machine: &SyntheticMachine,
    real: &RealArtifact,
    plan: &Plan,
    tool_mm: f64,
    file: &str,
    rng: &mut Rng,
) -> Vec<Touch> {
    plan.touches
        .iter()
        .map(|t| {
            let s = real.surface(t);
            let q = machine.touch(t, &s, tool_mm, rng);
            Touch {
                artifact: t.artifact.clone(),
                placement: t.placement.clone(),
                feature: t.feature.clone(),
                direction: t.direction,
                states: Some(t.states),
                q_mm: q.unwrap_or(t.target_mm),
                tool_length_mm: tool_mm,
                target_mm: Some(t.target_mm),
                tripped: q.is_some(),
                source: Source {
                    file: file.to_string(),
                    line: t.n + 2,
                },
            }
        })
        .collect()
}

/// The log LinuxCNC writes for `touches` (program coordinates of `frame`,
/// six decimals, as `(LOG,…)` with `%.6f` prints them).
pub fn log_text(artifact: &str, touches: &[Touch], frame: &Frame) -> String {
    let f6 = |v: f64| numfmt::fixed(if v.abs() < 1e-4 { 0.0 } else { v }, 6);
    let w = frame.work_offset_mm;
    let mut s = format!("volcomp-probe {LOG_VERSION} artifact={artifact}\n");
    s.push_str(&format!(
        "frame g5x={},{},{} r=0.000000 g92on=0.000000 g92=0.000000,0.000000,0.000000 tlo=0.000000,0.000000,{} metric=1.000000 mm=1.000000\n",
        f6(w.x),
        f6(w.y),
        f6(w.z),
        f6(frame.tool_length_mm)
    ));
    for (n, t) in touches.iter().enumerate() {
        let q = frame.program(t.q_mm);
        let at = frame.program(t.target_mm.unwrap_or(t.q_mm));
        s.push_str(&format!(
            "touch n={} p={} f={} d={} st={} at={},{},{} q={},{},{} ok={}\n",
            n + 1,
            t.placement,
            t.feature,
            t.direction.label(),
            states_label(&t.states.unwrap_or([Direction::Forward; 3])),
            f6(at.x),
            f6(at.y),
            f6(at.z),
            f6(q.x),
            f6(q.y),
            f6(q.z),
            if t.tripped { "1.000000" } else { "0.000000" }
        ));
    }
    s
}

// ---------------------------------------------------------------------------
// The example campaign of the documentation.

/// Travel of the example (mm).
pub const RANGES_MM: [[f64; 2]; 3] = [[0.0, 600.0], [0.0, 400.0], [0.0, 300.0]];

/// The example's probe tool length (mm).
pub const PROBE_LENGTH_MM: f64 = 100.0;

/// The reference sphere of the example.
pub const REFERENCE: &str = r#"# The reference sphere: calibrates the probe (tip radius, pre-travel per
# direction) and measures the axes' reversal (docs/probing.md).
artifact = "reference-sphere"
name = "ref"
[certificate]
diameter_mm = 25.0
u_diameter_um = 0.1
[[placements]]
name = "r"
origin_mm = [575, 25, 40]
"#;

/// A placement of the example plate: name, origin, x and y directions.
type Place = (&'static str, [f64; 3], [f64; 3], [f64; 3]);

/// The example's ball plate: 3 × 3 spheres, 120 mm apart, not calibrated.
pub fn plate_toml() -> String {
    let mut s = String::from(
        "# A ball plate made in the shop: 3 x 3 spheres 120 mm apart, no certificate.\n\
         # Measured in eight placements, shifted and turned, it is solved together\n\
         # with the machine (docs/probing.md).\n\
         artifact = \"spheres\"\nname = \"plate\"\nsphere_diameter_mm = 20\n\
         spheres_mm = [[0, 0, 0], [120, 0, 0], [240, 0, 0], [0, 120, 0], [120, 120, 0], [240, 120, 0], [0, 240, 0], [120, 240, 0], [240, 240, 0]]\n",
    );
    let h = std::f64::consts::FRAC_1_SQRT_2;
    // The plate's x and y directions in machine coordinates.
    let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    let (minus_x, minus_y) = ([-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]);
    let (diagonal, across) = ([h, h, 0.0], [-h, h, 0.0]);
    let places: [Place; 8] = [
        ("low", [40.0, 40.0, 20.0], x, y),
        ("low-right", [320.0, 120.0, 20.0], x, y),
        ("high-turned", [500.0, 60.0, 240.0], y, minus_x),
        ("mid-diagonal", [300.0, 30.0, 140.0], diagonal, across),
        ("front", [60.0, 60.0, 30.0], x, z),
        ("back", [300.0, 340.0, 30.0], x, z),
        ("left", [60.0, 60.0, 30.0], y, z),
        ("right", [540.0, 340.0, 30.0], minus_y, z),
    ];
    for (name, o, x, y) in places {
        s.push_str(&format!(
            "[[placements]]\nname = \"{name}\"\norigin_mm = [{}, {}, {}]\nx_axis = [{}, {}, {}]\ny_axis = [{}, {}, {}]\n",
            o[0], o[1], o[2], x[0], x[1], x[2], y[0], y[1], y[2]
        ));
    }
    s
}

/// The example's gauge block: 300 mm along X, certified.
pub const GAUGE: &str = r#"# A 300 mm gauge block along X, calibrated: the length that fixes the
# machine's scale (an uncalibrated plate cannot, docs/probing.md).
artifact = "gauge"
name = "block300"
faces_mm = [0, 300]
facing = ["-", "+"]
height_above_mm = 5
[certificate]
faces_mm = [0, 300.0002]
u_um = 0.1
[[placements]]
name = "x"
origin_mm = [150, 200, 60]
"#;

/// The example's set-up: G54 and the probe's tool length.
pub const SETUP: &str = "# volcomp set-up of the probing example\nunits = \"mm\"\n[work_offsets]\nG54 = [0, 0, 0]\n[tools]\n9 = 100\n";

/// The plan options of the example (probe tool 9).
pub fn plan_options() -> PlanOptions {
    PlanOptions {
        probe_tool: Some(9),
        ..PlanOptions::default()
    }
}

/// The example machine (seed 2026, order 2, 0.4 µm noise).
pub fn machine() -> SyntheticMachine {
    SyntheticMachine::random(2026, 2, RANGES_MM, 0.4)
}

/// Every file of the example: artifacts, set-up and the logs of a run.
pub fn example_files() -> Vec<(String, String)> {
    let m = machine();
    let mut rng = Rng::new(11);
    let frame = Frame {
        work_offset_mm: Vec3::ZERO,
        tool_length_mm: PROBE_LENGTH_MM,
        mm_per_machine_unit: 1.0,
    };
    let mut files = vec![
        ("setup.toml".to_string(), SETUP.to_string()),
        ("reference.toml".to_string(), REFERENCE.to_string()),
        ("plate.toml".to_string(), plate_toml()),
        ("gauge.toml".to_string(), GAUGE.to_string()),
    ];
    let o = plan_options();
    for (name, text) in [
        ("reference", REFERENCE.to_string()),
        ("plate", plate_toml()),
        ("gauge", GAUGE.to_string()),
    ] {
        let art = parse_artifact(&text, name).expect("the example's artifacts are valid");
        let real = RealArtifact::new(art.clone(), &mut rng);
        let p = plan(&art, None, &o).expect("the example's plans are valid");
        let touches = simulate(&m, &real, &p, PROBE_LENGTH_MM, name, &mut rng);
        files.push((format!("{name}.log"), log_text(&art.name, &touches, &frame)));
    }
    files
}

/// The axis direction of a unit vector (re-exported for tests).
pub fn axis_of(v: Vec3) -> Option<AxisDir> {
    crate::identify::probe::geometry::axis_direction(v)
}
