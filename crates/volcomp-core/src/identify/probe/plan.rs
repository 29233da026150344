//! Probing plans: which touches measure an artifact in its placements, the
//! moves that make them safely, and how long they take on the machine
//! (docs/probing.md, "The probing program").
//!
//! Every touch is a straight probe move along one machine axis, twice: fast
//! until the probe trips, a short back-off, then slow to the surface again
//! (the slow touch is the one recorded: its trigger lag is `slow feed ×
//! servo period`). Before a touch the tool comes to the touch's start point
//! from the artifact's clearance plane, and every axis' last motion is
//! chosen (the *direction state*, docs/design.md, "Direction state and
//! backlash"): forward for the axes that do not probe, unless the touch is
//! one of the reference sphere's reversal touches, which come from both
//! sides.
//!
//! Touches on a sphere (radius `R`, tip radius `r`, pole `n`: its free
//! side): the pole (moving `−n`), the equator along the axes across `n`
//! (never from below), and with the nine-touch pattern four shoulders at
//! 45° between pole and equator, touched moving `−n` — an oblique contact
//! that separates the tip radius from the pre-travel and fixes the centre
//! along `n`. The reference sphere adds the reversal touches: each
//! shoulder with its lateral axis arriving forward and in reverse (an axis'
//! reversal shifts the contact across the slope, `tan 45° = 1`), and two
//! shoulders touched across `n` with the pole axis arriving from both sides.

use super::artifact::{Artifact, Feature, Kind, Placement};
use super::geometry::{axis_direction, AxisDir};
use super::ProbeError;
use crate::model::{Direction, Directions};
use volcomp_gcode::Vec3;

/// How many touches measure a sphere that is not the reference.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpherePattern {
    /// Pole and equator: enough for the centre and the radius, one
    /// redundant touch (four across the pole for a sphere whose pole is
    /// horizontal: no touch from below).
    Five,
    /// Pole, equator and four shoulders at 45°: redundancy for the
    /// uncertainty of every centre.
    Nine,
}

/// What a G38 move that does not touch does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoContact {
    /// G38.2: the controller stops the program with an error (safe).
    Stop,
    /// G38.3: the program goes on; the log records `ok=0` and the fit
    /// leaves the touch out.
    Skip,
}

/// The options of a probing plan (all lengths mm, feeds mm/min).
#[derive(Debug, Clone, PartialEq)]
pub struct PlanOptions {
    /// Nominal diameter of the probe's tip (the stylus ball).
    pub tip_diameter_mm: f64,
    /// Feed of the first, searching touch.
    pub fast_feed_mm_min: f64,
    /// Feed of the recorded touch: its trigger lag is this feed times the
    /// controller's servo period (6 mm/min × 1 ms = 0.1 µm).
    pub slow_feed_mm_min: f64,
    /// Distance of a touch's start point from the nominal surface.
    pub approach_mm: f64,
    /// How far beyond the nominal surface the probe move may go.
    pub overtravel_mm: f64,
    /// Back-off after the fast touch, before the slow one.
    pub backoff_mm: f64,
    /// Height of the travel plane above the artifact.
    pub clearance_mm: f64,
    /// The short move that sets an axis' direction state before a touch
    /// (smaller than `approach_mm`).
    pub take_up_mm: f64,
    /// Touches per sphere (the reference sphere always gets its own set).
    pub spheres: SpherePattern,
    /// How often each touch is made.
    pub repeats: usize,
    /// How often each touch of the reference sphere is made (its
    /// calibration serves every other touch).
    pub reference_repeats: usize,
    /// Touches along each edge of a square.
    pub edge_points: usize,
    /// Distance of the first and last edge touch from the edge's ends.
    pub edge_margin_mm: f64,
    /// G38.2 or G38.3.
    pub no_contact: NoContact,
    /// The file the program logs into (`(LOGOPEN,…)`), as LinuxCNC opens it.
    pub log_file: String,
    /// The coordinate system the program runs in: 0 = G54 … 8 = G59.3.
    pub work_system: usize,
    /// The probe's tool number (its length from the set-up's tool table,
    /// G43 H); `None`: no tool length offset (G49).
    pub probe_tool: Option<u32>,
    /// Machine Z the program rises to between placements and at the ends
    /// (`None`: 25 mm above the highest travel plane).
    pub safe_z_mm: Option<f64>,
    /// Rapid speed, for the time estimate.
    pub rapid_mm_min: f64,
    /// Acceleration of every axis, for the time estimate (mm/s²).
    pub accel_mm_s2: f64,
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            tip_diameter_mm: 2.0,
            fast_feed_mm_min: 300.0,
            slow_feed_mm_min: 20.0,
            approach_mm: 2.0,
            overtravel_mm: 2.0,
            backoff_mm: 0.5,
            clearance_mm: 5.0,
            take_up_mm: 1.0,
            spheres: SpherePattern::Five,
            repeats: 1,
            reference_repeats: 3,
            edge_points: 7,
            edge_margin_mm: 10.0,
            no_contact: NoContact::Stop,
            log_file: "probe.log".into(),
            work_system: 0,
            probe_tool: None,
            safe_z_mm: None,
            rapid_mm_min: 3000.0,
            accel_mm_s2: 500.0,
        }
    }
}

impl PlanOptions {
    /// Checks the options (messages name the options, not a front end's flags).
    pub fn validate(&self) -> Result<(), ProbeError> {
        let bad = |what: &str, v: f64, want: &str| {
            Err(ProbeError::Invalid(format!("{what} = {v}: {want}")))
        };
        let positive = [
            ("tip diameter (mm)", self.tip_diameter_mm),
            ("fast feed (mm/min)", self.fast_feed_mm_min),
            ("slow feed (mm/min)", self.slow_feed_mm_min),
            ("approach (mm)", self.approach_mm),
            ("overtravel (mm)", self.overtravel_mm),
            ("back-off (mm)", self.backoff_mm),
            ("clearance (mm)", self.clearance_mm),
            ("take-up (mm)", self.take_up_mm),
            ("rapid speed (mm/min)", self.rapid_mm_min),
            ("acceleration (mm/s²)", self.accel_mm_s2),
        ];
        for (what, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return bad(what, v, "give a positive number");
            }
        }
        if self.tip_diameter_mm > 50.0 {
            return bad(
                "tip diameter (mm)",
                self.tip_diameter_mm,
                "a stylus tip is a few mm; give its diameter in mm",
            );
        }
        if self.slow_feed_mm_min > self.fast_feed_mm_min {
            return bad(
                "slow feed (mm/min)",
                self.slow_feed_mm_min,
                "the recorded touch is the slow one: give a slow feed at most the fast feed",
            );
        }
        if self.take_up_mm >= self.approach_mm {
            return bad("take-up (mm)", self.take_up_mm, "the take-up move must stay short of the surface: give less than the approach distance");
        }
        if self.backoff_mm >= self.approach_mm + self.overtravel_mm {
            return bad(
                "back-off (mm)",
                self.backoff_mm,
                "give less than approach + overtravel",
            );
        }
        for (what, r) in [
            ("repeats", self.repeats),
            ("reference repeats", self.reference_repeats),
        ] {
            if !(1..=10).contains(&r) {
                return Err(ProbeError::Invalid(format!("{what} = {r}: give 1 … 10")));
            }
        }
        if !(3..=200).contains(&self.edge_points) {
            return Err(ProbeError::Invalid(format!(
                "edge points = {}: give 3 … 200",
                self.edge_points
            )));
        }
        if !(self.edge_margin_mm.is_finite() && self.edge_margin_mm >= 0.0) {
            return bad(
                "edge margin (mm)",
                self.edge_margin_mm,
                "give zero or a positive number",
            );
        }
        if self.work_system > 8 {
            return Err(ProbeError::Invalid(format!(
                "work system {}: give 0 (G54) … 8 (G59.3)",
                self.work_system
            )));
        }
        let log = &self.log_file;
        if log.is_empty()
            || log.len() > 200
            || log.chars().any(|c| c == '(' || c == ')' || c.is_control())
        {
            return Err(ProbeError::Invalid(format!(
                "log file `{log}`: give a file name of at most 200 characters without parentheses (it is written into a G-code comment)"
            )));
        }
        if let Some(z) = self.safe_z_mm {
            if !z.is_finite() {
                return bad("safe Z (mm)", z, "give a machine Z");
            }
        }
        Ok(())
    }

    /// Tip radius (mm).
    pub fn tip_radius_mm(&self) -> f64 {
        self.tip_diameter_mm / 2.0
    }
}

/// One touch of the plan, in machine (axis) coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedTouch {
    /// 1-based number in the program.
    pub n: usize,
    /// Artifact name.
    pub artifact: String,
    /// Placement name.
    pub placement: String,
    /// Feature label.
    pub feature: String,
    /// Direction of the probe move.
    pub direction: AxisDir,
    /// Direction state of X, Y, Z at the touch.
    pub states: Directions,
    /// Start of the probe move.
    pub start_mm: Vec3,
    /// Commanded end of the probe move (`overtravel` beyond the surface).
    pub target_mm: Vec3,
    /// Where the tip's centre touches the nominal surface.
    pub nominal_mm: Vec3,
    /// Outward normal of the surface at the contact (unit).
    pub normal: Vec3,
}

/// One step of a plan, in machine (axis) coordinates.
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    /// Rapid move.
    Rapid(Vec3),
    /// Rapid move of Z alone in machine coordinates (G53).
    SafeZ(f64),
    /// A touch (fast, back-off, slow), then back to the start point.
    Touch(usize),
    /// A pause for the operator with a message (M0).
    Pause(String),
}

/// A plan: the steps, the touches, and the time it takes.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The artifact's name.
    pub artifact: String,
    /// Steps in order.
    pub steps: Vec<Step>,
    /// The touches (index = `n − 1`).
    pub touches: Vec<PlannedTouch>,
    /// Estimated time on the machine (s): probing moves at their feeds,
    /// rapids at the rapid speed, every move accelerating and braking at
    /// the acceleration given (operator pauses not counted).
    pub time_s: f64,
    /// Estimated time per placement (s), in placement order.
    pub placement_time_s: Vec<(String, f64)>,
    /// Safe machine Z used.
    pub safe_z_mm: f64,
}

/// The touch set of one feature before it is placed into a path.
struct TouchSpec {
    direction: AxisDir,
    nominal: Vec3,
    normal: Vec3,
    /// State wanted for an axis that does not probe (`None`: forward for
    /// lateral axes, the plunge's direction for the clearance axis).
    states: [Option<Direction>; 3],
}

impl TouchSpec {
    /// The touch from `direction` at `nominal` (surface normal `normal`),
    /// no axis state asked for.
    fn plain(direction: AxisDir, nominal: Vec3, normal: Vec3) -> Self {
        TouchSpec {
            direction,
            nominal,
            normal,
            states: [None; 3],
        }
    }
}

/// The touch from `direction` at `nominal` (surface normal `normal`); with
/// `reversal: Some(axis)`, two such touches, `axis` arriving forward, then
/// in reverse.
fn push_touches(
    out: &mut Vec<TouchSpec>,
    direction: AxisDir,
    nominal: Vec3,
    normal: Vec3,
    reversal: Option<usize>,
) {
    let states: Vec<[Option<Direction>; 3]> = match reversal {
        None => vec![[None; 3]],
        Some(axis) => [Direction::Forward, Direction::Reverse]
            .map(|st| {
                let mut states = [None; 3];
                states[axis] = Some(st);
                states
            })
            .to_vec(),
    };
    out.extend(states.into_iter().map(|states| TouchSpec {
        direction,
        nominal,
        normal,
        states,
    }));
}

/// The touches of one sphere (`c` machine centre, `rho` = R + tip radius,
/// `pole`, reference or not).
fn sphere_touches(
    c: Vec3,
    rho: f64,
    pole: AxisDir,
    reference: bool,
    pattern: SpherePattern,
) -> Vec<TouchSpec> {
    let n = pole.vector();
    let lateral: Vec<AxisDir> = AxisDir::ALL
        .into_iter()
        .filter(|e| e.axis != pole.axis)
        // No touch from below: a contact whose normal points −Z would need
        // the probe to move up under the sphere.
        .filter(|e| e.axis != 2 || e.positive)
        .collect();
    let mut out = vec![TouchSpec::plain(pole.opposite(), c + n * rho, n)];
    for e in &lateral {
        out.push(TouchSpec::plain(
            e.opposite(),
            c + e.vector() * rho,
            e.vector(),
        ));
    }
    let h = std::f64::consts::FRAC_1_SQRT_2;
    if reference || pattern == SpherePattern::Nine {
        for e in &lateral {
            let m = (n + e.vector()) * h;
            let reversal = reference.then_some(e.axis);
            push_touches(&mut out, pole.opposite(), c + m * rho, m, reversal);
        }
    }
    if reference {
        // The pole axis' reversal: two shoulders touched across the pole,
        // the pole axis arriving from both sides.
        for e in lateral.iter().filter(|e| e.positive).take(2) {
            let m = (n + e.vector()) * h;
            push_touches(&mut out, e.opposite(), c + m * rho, m, Some(pole.axis));
        }
    }
    out
}

fn unit_axis(v: Vec3, what: &str, placement: &str) -> Result<AxisDir, ProbeError> {
    axis_direction(v).ok_or_else(|| {
        ProbeError::Invalid(format!(
            "placement `{placement}`: {what} points along ({:.3}, {:.3}, {:.3}), not along a machine axis; the probe touches along the axes: turn the artifact by multiples of 90°",
            v.x, v.y, v.z
        ))
    })
}

/// The touches of one placement and its clearance direction.
fn placement_touches(
    art: &Artifact,
    p: &Placement,
    o: &PlanOptions,
) -> Result<(AxisDir, Vec<(String, TouchSpec)>), ProbeError> {
    let r = o.tip_radius_mm();
    let mut list = Vec::new();
    let up = match &art.kind {
        Kind::ReferenceSphere { .. } | Kind::Spheres { .. } => {
            unit_axis(p.axes[2], "the spheres' free side", &p.name)?
        }
        _ => AxisDir::new(2, true),
    };
    for f in art.features() {
        match f {
            Feature::Sphere {
                centre_mm,
                radius_mm,
                ..
            } => {
                let c = p.to_machine(centre_mm);
                for t in sphere_touches(c, radius_mm + r, up, art.is_reference(), o.spheres) {
                    list.push((f.label(), t));
                }
            }
            Feature::Face {
                x_mm,
                facing,
                index,
            } => {
                let normal_art = Vec3::new(facing, 0.0, 0.0);
                let normal = p.direction(normal_art);
                let d = unit_axis(normal, "a face's normal", &p.name)?.opposite();
                let at = match &art.kind {
                    Kind::Gauge { offsets_mm, .. } => {
                        offsets_mm.get(index).copied().unwrap_or([0.0, 0.0])
                    }
                    _ => [0.0, 0.0],
                };
                let point = p.to_machine(Vec3::new(x_mm, at[0], at[1]));
                list.push((f.label(), TouchSpec::plain(d, point + normal * r, normal)));
            }
            Feature::Edge { index, length_mm } => {
                let inner = matches!(&art.kind, Kind::Square { inner: true, .. });
                let s = if inner { 1.0 } else { -1.0 };
                let (along, normal_art) = if index == 0 {
                    (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, s, 0.0))
                } else {
                    (Vec3::new(0.0, 1.0, 0.0), Vec3::new(s, 0.0, 0.0))
                };
                let normal = p.direction(normal_art);
                let d = unit_axis(normal, "an edge's face normal", &p.name)?.opposite();
                let k = o.edge_points;
                let (a, b) = (o.edge_margin_mm, length_mm - o.edge_margin_mm);
                if b <= a {
                    return Err(ProbeError::Invalid(format!(
                        "artifact `{}`: an edge of {length_mm} mm leaves nothing between the edge margins of {} mm",
                        art.name, o.edge_margin_mm
                    )));
                }
                for j in 0..k {
                    let u = a + (b - a) * j as f64 / (k - 1) as f64;
                    let point = p.to_machine(along * u);
                    list.push((f.label(), TouchSpec::plain(d, point + normal * r, normal)));
                }
            }
        }
    }
    Ok((up, list))
}

/// Time (s) of a move of `len_mm` at `speed_mm_min` with acceleration
/// `accel` (trapezoidal or triangular profile, from rest to rest).
pub fn move_time_s(len_mm: f64, speed_mm_min: f64, accel_mm_s2: f64) -> f64 {
    if len_mm <= 0.0 {
        return 0.0;
    }
    let v = speed_mm_min / 60.0;
    if len_mm >= v * v / accel_mm_s2 {
        len_mm / v + v / accel_mm_s2
    } else {
        2.0 * (len_mm / accel_mm_s2).sqrt()
    }
}

/// Where the program starts is not known: its first move is counted as
/// this long (mm) at the rapid speed.
pub const UNKNOWN_START_MM: f64 = 40.0;

/// Time (s) the machine takes for `steps` (of a plan with `touches`) from
/// `from` (`None`: unknown, see [`UNKNOWN_START_MM`]): every rapid along
/// its straight line at the rapid speed; a touch as the program makes it —
/// the search at the fast feed over the approach to the surface, the
/// back-off at the fast feed, the recorded touch over the back-off at the
/// slow feed, a rapid back to the start; every move from rest to rest at
/// the acceleration given; pauses not counted. Also where the steps end.
fn steps_time_s(
    steps: &[Step],
    touches: &[PlannedTouch],
    from: Option<Vec3>,
    o: &PlanOptions,
) -> (f64, Option<Vec3>) {
    let rapid = |len: f64| move_time_s(len, o.rapid_mm_min, o.accel_mm_s2);
    let mut pos = from;
    let mut t = 0.0;
    for s in steps {
        match s {
            Step::Pause(_) => {}
            Step::SafeZ(z) => {
                if let Some(p) = pos.as_mut() {
                    t += rapid((p.z - z).abs());
                    p.z = *z;
                }
            }
            Step::Rapid(to) => {
                t += rapid(pos.map_or(UNKNOWN_START_MM, |p| (*to - p).norm()));
                pos = Some(*to);
            }
            Step::Touch(n) => {
                let touch = &touches[n - 1];
                let approach = (touch.nominal_mm - touch.start_mm).norm();
                t += move_time_s(approach, o.fast_feed_mm_min, o.accel_mm_s2)
                    + move_time_s(o.backoff_mm, o.fast_feed_mm_min, o.accel_mm_s2)
                    + move_time_s(o.backoff_mm, o.slow_feed_mm_min, o.accel_mm_s2)
                    + rapid(approach);
                pos = Some(touch.start_mm);
            }
        }
    }
    (t, pos)
}

/// Plans the probing of `art` in its placements (all, or the one named).
pub fn plan(art: &Artifact, only: Option<&str>, o: &PlanOptions) -> Result<Plan, ProbeError> {
    o.validate()?;
    let places: Vec<&Placement> = match only {
        Some(name) => vec![art.placement(name).ok_or_else(|| {
            ProbeError::Invalid(format!(
                "artifact `{}` has no placement `{name}`; it has {}",
                art.name,
                art.placements
                    .iter()
                    .map(|p| p.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })?],
        None => art.placements.iter().collect(),
    };
    let r = o.tip_radius_mm();
    // Per placement: its touches and its travel plane (level along `up`).
    let mut per = Vec::new();
    for p in &places {
        let (up, list) = placement_touches(art, p, o)?;
        let n = up.vector();
        let height_above = match &art.kind {
            Kind::Gauge {
                height_above_mm, ..
            }
            | Kind::Square {
                height_above_mm, ..
            } => *height_above_mm,
            _ => 0.0,
        };
        let top = match &art.kind {
            Kind::ReferenceSphere { .. } | Kind::Spheres { .. } => art
                .features()
                .iter()
                .map(|f| match f {
                    Feature::Sphere {
                        centre_mm,
                        radius_mm,
                        ..
                    } => n.dot(p.to_machine(*centre_mm)) + radius_mm + r,
                    _ => f64::MIN,
                })
                .fold(f64::MIN, f64::max),
            _ => list
                .iter()
                .map(|(_, t)| n.dot(t.nominal) + height_above + r)
                .fold(f64::MIN, f64::max),
        };
        let level = top + o.clearance_mm;
        per.push((p.name.clone(), up, list, level));
    }
    let highest_z = per
        .iter()
        .map(|(_, up, list, level)| {
            if up.axis == 2 {
                *level
            } else {
                list.iter()
                    .map(|(_, t)| t.nominal.z)
                    .fold(f64::MIN, f64::max)
                    + o.clearance_mm
            }
        })
        .fold(f64::MIN, f64::max);
    let safe_z = o.safe_z_mm.unwrap_or(highest_z + 25.0);
    if safe_z < highest_z {
        return Err(ProbeError::Invalid(format!(
            "safe Z = {safe_z} mm lies below the artifact's travel plane at Z {highest_z:.3} mm: give a higher safe Z"
        )));
    }
    let mut steps = Vec::new();
    let mut touches = Vec::new();
    let mut placement_steps = Vec::new();
    for (k, (pname, up, list, level)) in per.iter().enumerate() {
        let n = up.vector();
        let onto_plane = |x: Vec3| x + n * (level - n.dot(x));
        placement_steps.push((pname.clone(), steps.len()));
        steps.push(Step::SafeZ(safe_z));
        if k > 0 {
            steps.push(Step::Pause(format!(
                "place artifact {} at {pname}, then resume",
                art.name
            )));
        }
        // From the safe Z (position across known only after the first
        // move) to the travel plane above the first start.
        let mut pos: Option<Vec3> = None;
        for (label, spec) in list {
            let repeats = if art.is_reference() {
                o.reference_repeats
            } else {
                o.repeats
            };
            for _ in 0..repeats {
                let d = spec.direction;
                let dv = d.vector();
                let start = spec.nominal - dv * o.approach_mm;
                let target = spec.nominal + dv * o.overtravel_mm;
                // States: lateral axes forward unless asked; the clearance
                // axis arrives along −n (the plunge) unless asked; the
                // probing axis ends in the probe's direction.
                let mut states = [Direction::Forward; 3];
                states[up.axis] = up.opposite().state();
                for (st, want) in states.iter_mut().zip(spec.states) {
                    if let Some(s) = want {
                        *st = s;
                    }
                }
                let above = onto_plane(start);
                // Arrival in the travel plane with the lateral take-ups.
                let mut pre = above;
                for a in 0..3 {
                    if a != up.axis && a != d.axis {
                        pre[a] -= match states[a] {
                            Direction::Forward => o.take_up_mm,
                            Direction::Reverse => -o.take_up_mm,
                        };
                    } else if a == d.axis && a != up.axis {
                        // The probe axis' own state is set by the probe
                        // move; arrive forward like the others.
                        pre[a] -= o.take_up_mm;
                    }
                }
                match pos {
                    None => {
                        // First move from the safe Z: across at safe Z, then down.
                        // (For a horizontal pole: over at safe Z to the
                        // plane's position, then down in the plane.)
                        let mut at_safe = pre;
                        at_safe.z = safe_z;
                        steps.push(Step::Rapid(at_safe));
                        steps.push(Step::Rapid(pre));
                    }
                    Some(p0) => {
                        steps.push(Step::Rapid(onto_plane(p0)));
                        steps.push(Step::Rapid(pre));
                    }
                }
                steps.push(Step::Rapid(above));
                // Plunge along −n to the start; for a reversal touch of the
                // clearance axis, past it and back.
                let plunge_dir = up.opposite();
                if up.axis != d.axis && states[up.axis] != plunge_dir.state() {
                    let past = start - n * o.take_up_mm;
                    steps.push(Step::Rapid(past));
                    steps.push(Step::Rapid(start));
                } else {
                    steps.push(Step::Rapid(start));
                }
                states[d.axis] = d.state();
                let number = touches.len() + 1;
                touches.push(PlannedTouch {
                    n: number,
                    artifact: art.name.clone(),
                    placement: pname.clone(),
                    feature: label.clone(),
                    direction: d,
                    states,
                    start_mm: start,
                    target_mm: target,
                    nominal_mm: spec.nominal,
                    normal: spec.normal,
                });
                steps.push(Step::Touch(number));
                pos = Some(start);
            }
        }
        if let Some(p0) = pos {
            steps.push(Step::Rapid(onto_plane(p0)));
        }
    }
    steps.push(Step::SafeZ(safe_z));
    // Time per placement: from its first step (the rise from the previous
    // placement and the move across) to the next placement's first; the
    // last one's up to the final rise.
    let mut placement_time_s = Vec::new();
    let mut from: Option<Vec3> = None;
    for (k, (name, first)) in placement_steps.iter().enumerate() {
        let last = placement_steps.get(k + 1).map_or(steps.len(), |p| p.1);
        let (t, end) = steps_time_s(&steps[*first..last], &touches, from, o);
        placement_time_s.push((name.clone(), t));
        from = end;
    }
    let time_s = placement_time_s.iter().map(|p| p.1).sum();
    let plan = Plan {
        artifact: art.name.clone(),
        steps,
        touches,
        time_s,
        placement_time_s,
        safe_z_mm: safe_z,
    };
    check_clear_of_spheres(art, &places, &plan, r)?;
    Ok(plan)
}

/// Refuses a plan whose moves (not the probe moves) would pass through a
/// sphere of the artifact (the tip's centre closer to a sphere's centre
/// than its radius plus the tip radius).
fn check_clear_of_spheres(
    art: &Artifact,
    places: &[&Placement],
    plan: &Plan,
    r: f64,
) -> Result<(), ProbeError> {
    let spheres: Vec<(String, Vec3, f64)> = places
        .iter()
        .flat_map(|p| {
            art.features().into_iter().filter_map(move |f| match f {
                Feature::Sphere {
                    centre_mm,
                    radius_mm,
                    ..
                } => Some((p.name.clone(), p.to_machine(centre_mm), radius_mm + r)),
                _ => None,
            })
        })
        .collect();
    if spheres.is_empty() {
        return Ok(());
    }
    let mut placement = places.first().map(|p| p.name.clone()).unwrap_or_default();
    let mut k = 0;
    let mut pos: Option<Vec3> = None;
    for s in &plan.steps {
        match s {
            Step::Pause(_) => {
                k += 1;
                placement = places.get(k).map_or(placement.clone(), |p| p.name.clone());
                pos = None;
            }
            Step::SafeZ(z) => {
                if let Some(p) = pos.as_mut() {
                    p.z = *z;
                }
            }
            Step::Touch(n) => pos = Some(plan.touches[n - 1].start_mm),
            Step::Rapid(to) => {
                if let Some(from) = pos {
                    for (pl, c, rho) in spheres.iter().filter(|(pl, _, _)| *pl == placement) {
                        let d = segment_distance(from, *to, *c);
                        if d < rho - 1e-6 {
                            return Err(ProbeError::Invalid(format!(
                                "placement `{pl}`: a move from ({:.3}, {:.3}, {:.3}) to ({:.3}, {:.3}, {:.3}) would pass {:.3} mm from a sphere's centre, inside it (radius + tip {rho:.3} mm): give a larger clearance or approach",
                                from.x, from.y, from.z, to.x, to.y, to.z, d
                            )));
                        }
                    }
                }
                pos = Some(*to);
            }
        }
    }
    Ok(())
}

/// Distance from `c` to the segment `a`–`b`.
fn segment_distance(a: Vec3, b: Vec3, c: Vec3) -> f64 {
    let ab = b - a;
    let l2 = ab.norm_squared();
    let t = if l2 > 0.0 {
        ((c - a).dot(ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t - c).norm()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::probe::artifact::parse_artifact;

    fn reference() -> Artifact {
        parse_artifact(
            "artifact = \"reference-sphere\"\nname = \"ref\"\n[certificate]\ndiameter_mm = 25\nu_diameter_um = 0.1\n[[placements]]\nname = \"r\"\norigin_mm = [100, 100, 50]\n",
            "ref.toml",
        )
        .unwrap()
    }

    #[test]
    fn a_map_of_a_600_400_300_volume_takes_under_half_an_hour() {
        use crate::example::probe::{plan_options, plate_toml, GAUGE, REFERENCE};
        // By hand, from the plan's moves and the example's feeds (fast 300,
        // slow 20, rapid 3000 mm/min; 500 mm/s²; approach 2 mm, back-off
        // 0.5 mm). A move of L mm at v mm/s from rest to rest takes
        // L/v + v/a when L ≥ v²/a, else 2√(L/a). One touch: the search, 2 mm
        // at 5 mm/s: 0.4 + 0.01 s; the back-off, 0.5 mm at 5 mm/s: 0.1 +
        // 0.01 s; the recorded touch, 0.5 mm at 1/3 mm/s: 1.5 + 1/1500 s;
        // the rapid back, 2 mm < 50²/500 = 5 mm: 2√(2/500) s.
        let touch_s = 0.41 + 0.11 + 1.5 + 1.0 / 1500.0 + 2.0 * (2.0f64 / 500.0).sqrt();
        assert!((touch_s - 2.147158).abs() < 1e-6);
        let rapid_s = |l: f64| {
            let (v, a) = (50.0, 500.0);
            if l <= 0.0 {
                0.0
            } else if l >= v * v / a {
                l / v + v / a
            } else {
                2.0 * (l / a).sqrt()
            }
        };
        let o = plan_options();
        let mut total = 0.0;
        for text in [REFERENCE.to_string(), plate_toml(), GAUGE.to_string()] {
            let art = parse_artifact(&text, "a.toml").unwrap();
            let p = plan(&art, None, &o).unwrap();
            let mut t = p.touches.len() as f64 * touch_s;
            // Rapids: straight lines between the positions the steps name;
            // the first from wherever the machine stands, 40 mm assumed.
            let mut at: Option<Vec3> = None;
            for s in &p.steps {
                match s {
                    Step::Rapid(q) => {
                        t += rapid_s(at.map_or(40.0, |a| (*q - a).norm()));
                        at = Some(*q);
                    }
                    Step::SafeZ(z) => {
                        if let Some(a) = at.as_mut() {
                            t += rapid_s((a.z - z).abs());
                            a.z = *z;
                        }
                    }
                    Step::Touch(n) => at = Some(p.touches[n - 1].start_mm),
                    Step::Pause(_) => {}
                }
            }
            assert!(
                (t - p.time_s).abs() < 1e-9 * t,
                "{}: {t} vs {}",
                art.name,
                p.time_s
            );
            let per: f64 = p.placement_time_s.iter().map(|x| x.1).sum();
            assert!((per - p.time_s).abs() < 1e-9 * t);
            println!("{}: {} touches, {t:.1} s", art.name, p.touches.len());
            total += t;
        }
        assert!(total < 30.0 * 60.0, "{total} s");
    }

    #[test]
    fn a_move_takes_its_trapezoid() {
        // 100 mm at 6000 mm/min (100 mm/s), 500 mm/s²: 1 s + 0.2 s.
        assert!((move_time_s(100.0, 6000.0, 500.0) - 1.2).abs() < 1e-12);
        // 1 mm: triangle, 2·√(1/500) s.
        assert!((move_time_s(1.0, 6000.0, 500.0) - 2.0 * (0.002f64).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn the_reference_sphere_gets_seventeen_touches_from_both_sides() {
        // Each touch three times by default, one after the other.
        let p = plan(&reference(), None, &PlanOptions::default()).unwrap();
        assert_eq!(p.touches.len(), 3 * 17);
        assert_eq!(p.touches[0].nominal_mm, p.touches[2].nominal_mm);
        let once = PlanOptions {
            reference_repeats: 1,
            ..PlanOptions::default()
        };
        let p = plan(&reference(), None, &once).unwrap();
        assert_eq!(p.touches.len(), 17);
        let rho = 12.5 + 1.0;
        // Touch 1: the pole, moving −Z, nominal contact on top.
        let t = &p.touches[0];
        assert_eq!(t.direction, AxisDir::new(2, false));
        assert!((t.nominal_mm - Vec3::new(100.0, 100.0, 50.0 + rho)).norm() < 1e-12);
        assert!((t.start_mm.z - (50.0 + rho + 2.0)).abs() < 1e-12);
        assert!((t.target_mm.z - (50.0 + rho - 2.0)).abs() < 1e-12);
        // X reversal pair on the +X shoulder: same contact, X states differ.
        let pair: Vec<&PlannedTouch> = p
            .touches
            .iter()
            .filter(|t| {
                t.direction == AxisDir::new(2, false) && (t.normal.x - 0.5f64.sqrt()).abs() < 1e-12
            })
            .collect();
        assert_eq!(pair.len(), 2);
        assert_eq!(pair[0].nominal_mm, pair[1].nominal_mm);
        assert_eq!(pair[0].states[0], Direction::Forward);
        assert_eq!(pair[1].states[0], Direction::Reverse);
        // Z reversal pair: touched moving −X with Z forward and in reverse.
        let z: Vec<&PlannedTouch> = p
            .touches
            .iter()
            .filter(|t| t.direction == AxisDir::new(0, false) && t.normal.z > 0.1)
            .collect();
        assert_eq!(z.len(), 2);
        assert_ne!(z[0].states[2], z[1].states[2]);
        assert!(p.time_s > 17.0 && p.time_s < 300.0, "{}", p.time_s);
    }

    #[test]
    fn a_plate_five_touches_a_sphere_and_clears_it() {
        let a = parse_artifact(
            "artifact = \"spheres\"\nname = \"plate\"\nsphere_diameter_mm = 20\nspheres_mm = [[0, 0, 0], [100, 0, 0]]\n[[placements]]\nname = \"a\"\norigin_mm = [100, 100, 50]\n[[placements]]\nname = \"v\"\norigin_mm = [100, 300, 100]\nx_axis = [1, 0, 0]\ny_axis = [0, 0, 1]\n",
            "p.toml",
        )
        .unwrap();
        let p = plan(&a, None, &PlanOptions::default()).unwrap();
        // Horizontal: pole + 4; vertical (free side −Y): pole + ±X + top = 4.
        assert_eq!(p.touches.len(), 2 * 5 + 2 * 4);
        assert!(p.steps.iter().any(|s| matches!(s, Step::Pause(_))));
        let v: Vec<&PlannedTouch> = p.touches.iter().filter(|t| t.placement == "v").collect();
        assert!(v.iter().all(|t| t.direction != AxisDir::new(2, true)));
        assert_eq!(v[0].direction, AxisDir::new(1, true));
        // Too little approach for the take-up is refused before planning.
        let o = PlanOptions {
            approach_mm: 0.5,
            ..PlanOptions::default()
        };
        assert!(plan(&a, None, &o)
            .unwrap_err()
            .to_string()
            .contains("take-up"));
    }
}
