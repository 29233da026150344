//! Machining time before the machine runs: a model of LinuxCNC 2.9's
//! trajectory planner, fed a program's moves, run one servo period at a
//! time ([LinuxCNC tp]: src/emc/tp/tp.c, tc.c, blendmath.c,
//! spherical_arc.c and src/emc/task/emccanon.cc of the 2.9 build this was
//! checked against; docs/planner.md).
//!
//! | module | concern |
//! | --- | --- |
//! | `geometry` | lines, circles (helix, spiral), blend arcs |
//! | `segment` | a segment's speed and acceleration limits from the axes' |
//! | `canon` | moves → segments: rapids, feed moves, arcs; G64 P Q chains |
//! | `blend` | the joint between two segments: tangent, blend arc, parabolic blend, stop |
//! | `lookahead` | queuing a segment and the backward pass over the queue |
//! | `integrate` | the time integral: the queue run period by period |
//! | `program` | a G-code program's moves, waits and dwells |
//! | `compare` | a program's time beside its original's, as summaries say it |
//!
//! Pure functions of the moves and the [`Limits`]: [`estimate`] for a
//! slice of moves, [`Planner`] to feed them one at a time (memory bounded
//! by the look-ahead depth).
//!
//! ```
//! use volcomp_core::plan::{estimate, Limits, Move, PathMode};
//! use volcomp_gcode::Vec3;
//! // 100 mm at F6000 from rest to rest under G61: a trapezoid,
//! // L/v + v/a = 100/100 + 100/1000 = 1.1 s.
//! let m = Move::feed(Vec3::ZERO, Vec3::new(100.0, 0.0, 0.0), 100.0, PathMode::ExactPath);
//! let e = estimate(&[m], &Limits::default());
//! assert!((e.total_s - 1.1).abs() <= 0.002, "{}", e.total_s);
//! ```

mod blend;
mod canon;
mod compare;
mod fed;
mod geometry;
mod integrate;
mod lookahead;
pub mod program;
mod segment;

pub use compare::{
    compare_programs, compare_programs_per_line, compare_while_writing, compare_while_writing_fed,
    TimeComparison,
};
pub use program::{estimate_program, estimate_program_per_line, ProgramEstimate};
/// The path-control mode (G61, G61.1, G64 P Q), as the interpreter gives
/// it with every motion.
pub use volcomp_gcode::PathMode;

use std::collections::VecDeque;
use volcomp_gcode::{Plane, Vec3};

/// The blending settings of LinuxCNC's `[TRAJ]` section (initraj.cc),
/// with LinuxCNC's defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct BlendSettings {
    /// `ARC_BLEND_ENABLE` (default on): blend arcs and tangent joints; off,
    /// every G64 corner is a parabolic blend.
    pub enable: bool,
    /// `ARC_BLEND_OPTIMIZATION_DEPTH` (default 50): segments the
    /// look-ahead walks back.
    pub optimization_depth: usize,
    /// `ARC_BLEND_GAP_CYCLES` (default 4): a line left shorter than this
    /// many servo periods at the blend's speed is absorbed into the arc.
    pub gap_cycles: f64,
    /// `ARC_BLEND_RAMP_FREQ` (default 100 Hz): segments run through at
    /// speed in less than `1/f` s change speed at a constant rate.
    pub ramp_frequency_hz: f64,
    /// `ARC_BLEND_KINK_RATIO` (default 0.1): share of an axis'
    /// acceleration a kink may take and still count as tangent.
    pub kink_ratio: f64,
}

impl Default for BlendSettings {
    fn default() -> Self {
        BlendSettings {
            enable: true,
            optimization_depth: 50,
            gap_cycles: 4.0,
            ramp_frequency_hz: 100.0,
            kink_ratio: 0.1,
        }
    }
}

/// The machine's motion limits, as LinuxCNC's INI file gives them.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Limits {
    /// `[AXIS_X|Y|Z] MAX_VELOCITY`, mm/s. Default 166.7 mm/s (10 m/min).
    pub max_velocity_mm_s: [f64; 3],
    /// `[AXIS_X|Y|Z] MAX_ACCELERATION`, mm/s². Default 1000 mm/s².
    pub max_acceleration_mm_s2: [f64; 3],
    /// `[TRAJ] MAX_LINEAR_VELOCITY`, mm/s: a cap on the path speed.
    /// Default: none (infinite; LinuxCNC then uses the axes' limits).
    pub traj_max_velocity_mm_s: f64,
    /// `[EMCMOT] SERVO_PERIOD`, s. Default 0.001 s.
    pub servo_period_s: f64,
    /// `[DISPLAY] MAX_FEED_OVERRIDE` (default 1.0): blends are planned for
    /// the largest feed override.
    pub max_feed_override: f64,
    /// The `[TRAJ] ARC_BLEND_*` settings.
    pub blend: BlendSettings,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_velocity_mm_s: [166.7; 3],
            max_acceleration_mm_s2: [1000.0; 3],
            traj_max_velocity_mm_s: f64::INFINITY,
            servo_period_s: 0.001,
            max_feed_override: 1.0,
            blend: BlendSettings::default(),
        }
    }
}

impl Limits {
    /// The limits a set-up's `[limits]` table gives, LinuxCNC's defaults
    /// (and [`Limits::default`]'s axis limits) for what it leaves out.
    pub fn from_setup(given: Option<&volcomp_gcode::MotionLimits>) -> Limits {
        let mut l = Limits::default();
        let Some(g) = given else {
            return l;
        };
        if let Some(v) = g.max_velocity_mm_s {
            l.max_velocity_mm_s = v;
        }
        if let Some(a) = g.max_acceleration_mm_s2 {
            l.max_acceleration_mm_s2 = a;
        }
        if let Some(v) = g.traj_max_velocity_mm_s {
            l.traj_max_velocity_mm_s = v;
        }
        if let Some(p) = g.servo_period_s {
            l.servo_period_s = p;
        }
        if let Some(f) = g.max_feed_override {
            l.max_feed_override = f;
        }
        let b = &mut l.blend;
        if let Some(e) = g.arc_blend_enable {
            b.enable = e;
        }
        if let Some(d) = g.arc_blend_optimization_depth {
            b.optimization_depth = d as usize;
        }
        if let Some(c) = g.arc_blend_gap_cycles {
            b.gap_cycles = c;
        }
        if let Some(f) = g.arc_blend_ramp_freq_hz {
            b.ramp_frequency_hz = f;
        }
        if let Some(k) = g.arc_blend_kink_ratio {
            b.kink_ratio = k;
        }
        l
    }

    /// The axis limits in words, for a summary: `X Y Z 166.7 mm/s,
    /// 1000 mm/s²` (per axis where they differ), the path cap, the servo
    /// period.
    pub fn describe(&self) -> String {
        let per = |v: &[f64; 3], unit: &str| {
            if v[0] == v[1] && v[1] == v[2] {
                format!("{} {unit}", fmt_num(v[0]))
            } else {
                format!(
                    "X {} Y {} Z {} {unit}",
                    fmt_num(v[0]),
                    fmt_num(v[1]),
                    fmt_num(v[2])
                )
            }
        };
        let mut s = format!(
            "{} and {} per axis",
            per(&self.max_velocity_mm_s, "mm/s"),
            per(&self.max_acceleration_mm_s2, "mm/s²")
        );
        if self.traj_max_velocity_mm_s.is_finite() {
            s.push_str(&format!(
                ", path at most {} mm/s",
                fmt_num(self.traj_max_velocity_mm_s)
            ));
        }
        s.push_str(&format!(
            ", servo period {} ms",
            fmt_num(self.servo_period_s * 1e3)
        ));
        s
    }

    /// Refuses a value the planner cannot run with, naming the setting.
    pub fn check(&self) -> Result<(), String> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        for (i, a) in ["X", "Y", "Z"].iter().enumerate() {
            if !positive(self.max_velocity_mm_s[i]) {
                return Err(format!(
                    "the maximum velocity of axis {a} must be a positive number; got {}",
                    self.max_velocity_mm_s[i]
                ));
            }
            if !positive(self.max_acceleration_mm_s2[i]) {
                return Err(format!(
                    "the maximum acceleration of axis {a} must be a positive number; got {}",
                    self.max_acceleration_mm_s2[i]
                ));
            }
        }
        if self.traj_max_velocity_mm_s.is_nan() || self.traj_max_velocity_mm_s <= 0.0 {
            return Err(format!(
                "the trajectory's maximum velocity must be positive; got {}",
                self.traj_max_velocity_mm_s
            ));
        }
        if !(positive(self.servo_period_s) && self.servo_period_s <= 0.1) {
            return Err(format!(
                "the servo period must be a positive number of seconds up to 0.1; got {}",
                self.servo_period_s
            ));
        }
        if !positive(self.max_feed_override) {
            return Err(format!(
                "the maximum feed override must be positive; got {}",
                self.max_feed_override
            ));
        }
        let b = &self.blend;
        let fine = b.gap_cycles.is_finite()
            && b.gap_cycles >= 0.0
            && positive(b.ramp_frequency_hz)
            && positive(b.kink_ratio)
            && b.optimization_depth <= 10_000;
        if !fine {
            return Err(
                "the arc blend settings must be finite and positive (depth at most 10000)".into(),
            );
        }
        Ok(())
    }
}

/// A number without trailing zeros (at most 4 decimals).
fn fmt_num(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// What a move is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MoveKind {
    /// G0: at the axes' speed.
    Rapid,
    /// G1.
    Feed,
    /// G2/G3 about `center` in `plane`, signed sweep as
    /// [`volcomp_gcode::Arc::sweep_rad`] (counter-clockwise positive, full
    /// turns included).
    Arc {
        /// Centre (machine coordinates, mm).
        center: Vec3,
        /// The arc's plane (G17, G18, G19).
        plane: Plane,
        /// Signed sweep, radians.
        sweep_rad: f64,
    },
}

/// One move of a program, in machine coordinates (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Move {
    /// Rapid, feed or arc.
    pub kind: MoveKind,
    /// Start point, mm.
    pub start: Vec3,
    /// End point, mm.
    pub end: Vec3,
    /// Requested path speed, mm/s (ignored for rapids).
    pub feed_mm_s: f64,
    /// The path-control mode in effect.
    pub mode: PathMode,
    /// The program line it comes from.
    pub line: u64,
}

impl Move {
    /// A feed move (G1) at `feed_mm_s`.
    pub fn feed(start: Vec3, end: Vec3, feed_mm_s: f64, mode: PathMode) -> Move {
        Move {
            kind: MoveKind::Feed,
            start,
            end,
            feed_mm_s,
            mode,
            line: 0,
        }
    }

    /// A rapid (G0).
    pub fn rapid(start: Vec3, end: Vec3, mode: PathMode) -> Move {
        Move {
            kind: MoveKind::Rapid,
            start,
            end,
            feed_mm_s: 0.0,
            mode,
            line: 0,
        }
    }
}

/// What happened at the joints.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Counts {
    /// Planner segments made from the program's moves (the blend arcs put
    /// into corners are not among them: they are counted in `blend_arcs`).
    pub segments: u64,
    /// Blend arcs put into corners.
    pub blend_arcs: u64,
    /// Corners blended parabolically.
    pub parabolic_blends: u64,
    /// Joints run through as tangent.
    pub tangent_joints: u64,
}

/// The estimated machining time of a program.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Estimate {
    /// From the first motion to the end of the last (dwells and waits for
    /// the spindle or a tool change not included), s.
    pub total_s: f64,
    /// With a feed move or an arc active, s.
    pub cutting_s: f64,
    /// With a rapid active, s.
    pub rapid_s: f64,
    /// Servo periods counted.
    pub periods: u64,
    /// What the planner did at the joints.
    pub counts: Counts,
}

/// The time the planner spends on one program line: the servo periods
/// whose segment shown as active comes from that line, in seconds. A
/// blend arc counts for the line of the segment it leaves; a period shared
/// by two segments (a split, a parabolic blend) for the one shown; moves
/// the canonical layer merges into one line under G64 P Q (naive CAM, an
/// arc piece sent as two lines) for the last line merged.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct LineTime {
    /// The program line (1-based, as in messages).
    pub line: u64,
    /// All its periods, s.
    pub total_s: f64,
    /// Those of feed moves and arcs, s.
    pub cutting_s: f64,
    /// Those of rapids, s.
    pub rapid_s: f64,
    /// The speed at which the line's motion ends (mm/s): its segment's
    /// speed in its last period, where the next segment takes over (0
    /// where the machine stops there, the feed where the join runs
    /// through). A blend arc counts for the line it leaves, so this is the
    /// speed into the next line; of a line of several segments (with its
    /// blend arc, an arc the canonical layer sends as two lines) or run
    /// many times, the lowest at which one of them ends.
    pub end_speed_mm_s: f64,
}

/// Periods per program line, kept by line number: a line run many times
/// (a loop, a subroutine) holds one entry, so the log is bounded by the
/// program's moving lines, not by the lines executed.
#[derive(Debug, Clone, Default)]
struct LineLog {
    lines: std::collections::BTreeMap<u64, LineEntry>,
}

/// What [`LineLog`] keeps of one line: its periods, and the lowest speed
/// one of its segments ended at (mm/s), [`LineTime::end_speed_mm_s`].
#[derive(Debug, Clone, Copy, Default)]
struct LineEntry {
    periods: integrate::Periods,
    end_mm_s: Option<f64>,
}

impl LineLog {
    /// Adds the periods from `before` to `after` to `line`.
    fn add(&mut self, line: u64, before: integrate::Periods, after: integrate::Periods) {
        if after.moving == before.moving {
            return;
        }
        let p = &mut self.lines.entry(line).or_default().periods;
        p.moving += after.moving - before.moving;
        p.cutting += after.cutting - before.cutting;
        p.rapid += after.rapid - before.rapid;
    }

    /// Notes that a segment of `line` ended at `speed_mm_s`.
    fn ended(&mut self, line: u64, speed_mm_s: f64) {
        let e = &mut self.lines.entry(line).or_default().end_mm_s;
        *e = Some(e.map_or(speed_mm_s, |v| v.min(speed_mm_s)));
    }

    /// One [`LineTime`] per line that moved, in line order, with a servo
    /// period of `dt` s: whole periods, rounded to the nanosecond (as
    /// [`Planner::finish`]).
    fn times(self, dt: f64) -> Vec<LineTime> {
        let s = |periods: u64| (periods as f64 * dt * 1e9).round() / 1e9;
        self.lines
            .into_iter()
            .filter(|(_, e)| e.periods.moving > 0)
            .map(|(line, e)| LineTime {
                line,
                total_s: s(e.periods.moving),
                cutting_s: s(e.periods.cutting),
                rapid_s: s(e.periods.rapid),
                end_speed_mm_s: e.end_mm_s.unwrap_or(0.0),
            })
            .collect()
    }
}

/// LinuxCNC's planner fed one move at a time.
#[derive(Debug, Clone)]
pub struct Planner {
    limits: Limits,
    canon: canon::CanonState,
    queue: VecDeque<segment::Seg>,
    exec: integrate::Exec,
    counts: Counts,
    fresh: Vec<segment::Seg>,
    /// The last blend plane's limits ([`blend::PlaneLimits`]).
    planes: blend::PlaneLimits,
    /// The periods per line, when asked for ([`Planner::per_line`]).
    lines: Option<LineLog>,
}

impl Planner {
    /// A planner for a machine with `limits` (checked by the caller with
    /// [`Limits::check`]).
    pub fn new(limits: Limits) -> Planner {
        Planner {
            limits,
            canon: canon::CanonState::new(),
            queue: VecDeque::new(),
            exec: integrate::Exec::default(),
            counts: Counts::default(),
            fresh: Vec::new(),
            planes: blend::PlaneLimits::default(),
            lines: None,
        }
    }

    /// A planner that also counts the time per program line
    /// ([`Planner::finish_per_line`]).
    pub fn per_line(limits: Limits) -> Planner {
        let mut p = Planner::new(limits);
        p.lines = Some(LineLog::default());
        p.exec.per_line = true;
        p
    }

    /// Runs the queue's next period or periods (`false`: the queue is
    /// empty), counting them for the line shown when asked to.
    fn run_next(&mut self) -> bool {
        let before = self.exec.periods;
        let more = integrate::run_next(&mut self.queue, &mut self.exec, &self.limits);
        self.log_since(before);
        more
    }

    /// Counts the periods run since `before` for the line shown, and the
    /// end speed of a segment removed meanwhile, when asked to.
    fn log_since(&mut self, before: integrate::Periods) {
        if let (Some(log), Some(shown)) = (&mut self.lines, self.exec.shown) {
            log.add(shown.line, before, self.exec.periods);
        }
        if let (Some(log), Some((line, speed_mm_s))) = (&mut self.lines, self.exec.removed.take()) {
            log.ended(line, speed_mm_s);
        }
    }

    /// The limits in use.
    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// Queues a move; runs the queue's front once the look-ahead can no
    /// longer change it.
    pub fn push(&mut self, m: &Move) {
        self.canon.push(m, &self.limits, &mut self.fresh);
        self.queue_fresh();
        let keep = self.limits.blend.optimization_depth + 6;
        while self.queue.len() > keep {
            self.run_next();
        }
    }

    fn queue_fresh(&mut self) {
        // By reference: each segment is copied once, into the queue.
        for s in &mut self.fresh {
            self.counts.segments += 1;
            lookahead::add(
                &mut self.queue,
                s,
                &self.limits,
                &mut self.counts,
                &mut self.planes,
            );
        }
        self.fresh.clear();
    }

    /// The machine waits for the motion to end (a dwell, a tool change, a
    /// program stop): the queue runs empty.
    pub fn wait(&mut self) {
        self.canon.finish(&self.limits, &mut self.fresh);
        self.queue_fresh();
        while self.run_next() {}
    }

    /// Runs what is left and gives the time and, for a planner made with
    /// [`Planner::per_line`], the time per line (else empty).
    pub fn finish_per_line(mut self) -> (Estimate, Vec<LineTime>) {
        self.wait();
        let lines = self.lines.take().unwrap_or_default();
        let dt = self.limits.servo_period_s;
        (self.finish(), lines.times(dt))
    }

    /// Runs what is left and gives the time.
    pub fn finish(mut self) -> Estimate {
        self.wait();
        let p = self.exec.periods;
        let dt = self.limits.servo_period_s;
        // Whole periods: rounded to the nanosecond, so that 1 ms × n prints as it is.
        let secs = |n: u64| (n as f64 * dt * 1e9).round() / 1e9;
        Estimate {
            total_s: secs(p.moving),
            cutting_s: secs(p.cutting),
            rapid_s: secs(p.rapid),
            periods: p.moving,
            counts: self.counts,
        }
    }
}

/// The time `moves` take on a machine with `limits`, run as one
/// uninterrupted sequence.
pub fn estimate(moves: &[Move], limits: &Limits) -> Estimate {
    let mut p = Planner::new(*limits);
    for m in moves {
        p.push(m);
    }
    p.finish()
}

#[cfg(test)]
mod tests;
