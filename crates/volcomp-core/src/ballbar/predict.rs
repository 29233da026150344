//! The trace a ballbar records on a machine with an error model: the
//! commanded circle (feed-in arc, the data arc of 360°, feed-out arc, each
//! run after the other without a stop, as the test program runs them) is
//! followed through the dead-band machine simulation of `crate::simulate`
//! (backlash taken up while the tool stands, docs/design.md, "Direction
//! state and backlash"), and the ballbar's length is read at every sample.
//!
//! The controller's arc is followed as chords short enough that their
//! sagitta `R·(1 − cos(δ/2))` stays under 1 nm; samples are read at chord
//! ends, which lie on the commanded circle, so a sample's deviation is the
//! machine's alone: `|actual − pivot| − R`.

use super::{BallbarError, Plane, Run, Sense, Trace};
use crate::error::Error;
use crate::model::ErrorModel;
use crate::simulate::Simulator;
use volcomp_gcode::Vec3;

/// Largest sagitta of the chords the simulation follows (mm).
pub const CHORD_SAGITTA_MM: f64 = 1e-6;

/// A circular test: where, how large, how fast, and how it is sampled.
#[derive(Debug, Clone, PartialEq)]
pub struct TestCircle {
    /// The plane.
    pub plane: Plane,
    /// The pivot: the circle's centre in the axis frame (mm).
    pub centre_mm: Vec3,
    /// The ballbar's nominal length (mm).
    pub radius_mm: f64,
    /// The programmed feed (mm/min).
    pub feed_mm_per_min: f64,
    /// Where the data arc starts, degrees from `u` toward `v`.
    pub start_deg: f64,
    /// The feed-in and feed-out arcs (degrees, > 0).
    pub overshoot_deg: f64,
    /// The angle between samples (degrees; 360 a whole multiple of it).
    pub step_deg: f64,
    /// The runs, in the order they run.
    pub senses: Vec<Sense>,
}

impl Default for TestCircle {
    fn default() -> Self {
        Self {
            plane: Plane::XY,
            centre_mm: Vec3::ZERO,
            radius_mm: 100.0,
            feed_mm_per_min: 1000.0,
            start_deg: 0.0,
            overshoot_deg: 180.0,
            step_deg: 0.1,
            senses: vec![Sense::Ccw, Sense::Cw],
        }
    }
}

impl TestCircle {
    /// Every check of the test's values, with the option named.
    pub fn check(&self) -> Result<(), BallbarError> {
        let bad = |name: &str, why: &str, v: f64| {
            Err(BallbarError::new(format!("{{{name}}} {why}; got {v}")))
        };
        if !(self.radius_mm.is_finite() && self.radius_mm > 0.0) {
            return bad("radius_mm", "must be a length > 0 mm", self.radius_mm);
        }
        if !(self.feed_mm_per_min.is_finite() && self.feed_mm_per_min > 0.0) {
            return bad("feed_mm_per_min", "must be > 0", self.feed_mm_per_min);
        }
        if !self.start_deg.is_finite() {
            return bad("start_deg", "must be a finite angle", self.start_deg);
        }
        if !(self.overshoot_deg.is_finite()
            && self.overshoot_deg > 0.0
            && self.overshoot_deg <= 360.0)
        {
            return bad(
                "overshoot_deg",
                "must satisfy 0 < overshoot ≤ 360°",
                self.overshoot_deg,
            );
        }
        let n = 360.0 / self.step_deg;
        if !(self.step_deg.is_finite() && self.step_deg > 0.0 && self.step_deg <= 10.0)
            || (n - n.round()).abs() > 1e-6
        {
            return bad(
                "step_deg",
                "must divide 360° into whole samples and be at most 10°",
                self.step_deg,
            );
        }
        if !self.centre_mm.to_array().iter().all(|c| c.is_finite()) {
            return Err(BallbarError::new(
                "{centre_mm} must be three finite numbers",
            ));
        }
        if self.senses.is_empty()
            || (self.senses.len() == 2 && self.senses[0] == self.senses[1])
            || self.senses.len() > 2
        {
            return Err(BallbarError::new(
                "{direction} must be ccw, cw or both (one run per sense)",
            ));
        }
        Ok(())
    }

    /// Samples per run.
    pub fn samples(&self) -> usize {
        (360.0 / self.step_deg).round() as usize
    }

    /// Chords per sample step.
    fn chords_per_step(&self) -> usize {
        // R (1 − cos(δ/2)) ≈ R δ²/8 ≤ sagitta.
        let delta = (8.0 * CHORD_SAGITTA_MM / self.radius_mm).sqrt();
        (self.step_deg.to_radians() / delta).ceil().max(1.0) as usize
    }

    /// The commanded path as angles (degrees), each with the sample it
    /// gives (run, index) if any, in the order the machine moves.
    pub fn path_deg(&self) -> Vec<(f64, Option<(usize, usize)>)> {
        let k = self.chords_per_step();
        let delta = self.step_deg / k as f64;
        let n = self.samples();
        let m = (self.overshoot_deg / delta).ceil() as usize;
        let mut out = Vec::with_capacity(self.senses.len() * (2 * m + n * k + 1));
        for (r, sense) in self.senses.iter().enumerate() {
            let s = sense.sign();
            let from = self.start_deg - s * self.overshoot_deg;
            // Feed-in: m chords from `from` to the start (the first run's
            // first point is where the machine stands before the test).
            let first = if r == 0 { 0 } else { 1 };
            for i in first..=m {
                out.push((from + s * self.overshoot_deg * i as f64 / m as f64, None));
            }
            out.last_mut().expect("feed-in").1 = Some((r, 0));
            for i in 1..=n * k {
                let a = self.start_deg + s * delta * i as f64;
                let sample = (i.is_multiple_of(k) && i < n * k).then_some((r, i / k));
                out.push((a, sample));
            }
            let end = self.start_deg + s * 360.0;
            for i in 1..=m {
                out.push((end + s * self.overshoot_deg * i as f64 / m as f64, None));
            }
        }
        out
    }
}

/// The trace of `test` on a machine with `model` (dead-band backlash).
pub fn predict(model: &dyn ErrorModel, test: &TestCircle) -> Result<Trace, Error> {
    predict_commanded(model, test, &mut |q| Ok(q))
}

/// The trace of `test` when the controller is sent `command(q)` instead of
/// each point `q` of the nominal circle (a compensation of the test).
pub fn predict_commanded(
    model: &dyn ErrorModel,
    test: &TestCircle,
    command: &mut dyn FnMut(Vec3) -> Result<Vec3, Error>,
) -> Result<Trace, Error> {
    test.check()?;
    let path = test.path_deg();
    let n = test.samples();
    let mut runs: Vec<Run> = test
        .senses
        .iter()
        .map(|&sense| Run {
            sense,
            angle_deg: vec![0.0; n],
            deviation_um: vec![0.0; n],
        })
        .collect();
    let point = |a: f64| {
        test.plane
            .point(test.centre_mm, test.radius_mm, a.to_radians())
    };
    let mut sim = Simulator::new(model, command(point(path[0].0))?);
    for &(a, sample) in &path[1..] {
        let actual = sim.move_to(command(point(a))?, f64::INFINITY, |_, _| {})?;
        if let Some((r, i)) = sample {
            runs[r].angle_deg[i] = a.rem_euclid(360.0);
            runs[r].deviation_um[i] = ((actual - test.centre_mm).norm() - test.radius_mm) * 1e3;
        }
    }
    Ok(Trace {
        plane: test.plane,
        radius_mm: test.radius_mm,
        centre_mm: test.centre_mm.to_array(),
        feed_mm_per_min: test.feed_mm_per_min,
        runs,
    })
}

/// Spacing of the samples read along a program's moves (mm).
const PROGRAM_SAMPLE_MM: f64 = 0.01;

/// Chord tolerance of a program's arcs (mm): the controller's own chords
/// are far shorter than a ballbar sees.
const PROGRAM_CHORD_MM: f64 = CHORD_SAGITTA_MM;

/// The trace of `test` when the machine runs `program` instead of the
/// test's own (the test's program compensated for a model, say): the
/// program's moves are followed through the same dead-band simulation,
/// the ballbar read every 0.01 mm of the path, and each run's data arc
/// cut out by the angle travelled (the program must run the test's path:
/// its runs, feed-in, whole circle and feed-out, in order) and read at the
/// test's sample angles (linear interpolation along the path).
pub fn predict_program(
    model: &dyn ErrorModel,
    test: &TestCircle,
    program: impl std::io::Read,
    file: &str,
    setup: &crate::compensate::MachineSetup,
) -> Result<Trace, Error> {
    use volcomp_gcode::MotionKind;
    test.check()?;
    let mut walker = setup.walker(std::io::BufReader::new(program), file);
    let mut sim = Simulator::new(model, walker.interpreter().position());
    let (u, v) = test.plane.axes();
    let c = test.centre_mm;
    // (unwrapped angle travelled, degrees; deviation, µm)
    let mut samples: Vec<(f64, f64)> = Vec::new();
    let mut last_angle: Option<f64> = None;
    let mut unwrapped = 0.0;
    let model_err = |line: u64, source| crate::error::CompensationError::Model {
        target_mm: None,
        file: file.to_string(),
        line,
        source,
    };
    while let Some(ev) = walker.next_line()? {
        for m in ev.motions {
            let chords = match m.kind {
                MotionKind::Rapid => {
                    sim.move_untracked(m.end);
                    continue;
                }
                MotionKind::Arc(arc) => arc.chord_count(PROGRAM_CHORD_MM),
                MotionKind::Feed => 1,
            };
            for k in 1..=chords {
                let b = match m.kind {
                    MotionKind::Arc(arc) if k < chords => arc.point_at(k as f64 / chords as f64),
                    _ => m.end,
                };
                sim.move_to(b, PROGRAM_SAMPLE_MM, |actual, _| {
                    let a = (actual[v] - c[v]).atan2(actual[u] - c[u]).to_degrees();
                    unwrapped += match last_angle {
                        None => a,
                        Some(l) => (a - l + 180.0).rem_euclid(360.0) - 180.0,
                    };
                    last_angle = Some(a);
                    samples.push((unwrapped, ((actual - c).norm() - test.radius_mm) * 1e3));
                })
                .map_err(|e| Error::from(model_err(m.line, e)))?;
            }
        }
    }
    let refused = |why: &str| {
        Error::from(BallbarError::new(format!(
            "{file}: the program does not run the test's path ({why}): write it with the test's own values"
        )))
    };
    let Some(&(first, _)) = samples.first() else {
        return Err(refused("no feed move"));
    };
    // The first sample lies at the first run's feed-in start.
    let s0 = test.senses[0].sign();
    let want = test.start_deg - s0 * test.overshoot_deg;
    let shift = want - first + ((first - want + 180.0).rem_euclid(360.0) - 180.0);
    let n = test.samples();
    let span = 2.0 * test.overshoot_deg + 360.0;
    let mut runs = Vec::new();
    let mut from = 0;
    let mut psi0 = want;
    for sense in &test.senses {
        let s = sense.sign();
        let progress = |i: usize| s * (samples[i].0 + shift - psi0);
        // The run's end: near its whole span (the actual angle differs
        // from the commanded by the error, ~e/R), then while it still goes on.
        let near = span - (test.overshoot_deg / 2.0).min(1.0);
        let mut end = (from..samples.len())
            .find(|&i| progress(i) >= near)
            .ok_or_else(|| refused("a run ends before its feed-out arc does"))?;
        while end + 1 < samples.len() && progress(end + 1) > progress(end) {
            end += 1;
        }
        let mut run = Run {
            sense: *sense,
            angle_deg: Vec::with_capacity(n),
            deviation_um: Vec::with_capacity(n),
        };
        for j in 0..n {
            let t = test.overshoot_deg + test.step_deg * j as f64;
            // The first sample at or past `t` (progress grows along a run).
            let (mut lo, mut hi) = (from, end);
            while lo < hi {
                let mid = (lo + hi) / 2;
                if progress(mid) < t {
                    lo = mid + 1;
                } else {
                    hi = mid;
                }
            }
            let k = lo.clamp(from + 1, end);
            let (p0, p1) = (progress(k - 1), progress(k));
            let w = if p1 > p0 {
                ((t - p0) / (p1 - p0)).clamp(0.0, 1.0)
            } else {
                0.0
            };
            run.angle_deg
                .push((test.start_deg + s * (t - test.overshoot_deg)).rem_euclid(360.0));
            run.deviation_um
                .push(samples[k - 1].1 + w * (samples[k].1 - samples[k - 1].1));
        }
        runs.push(run);
        psi0 += s * span;
        from = end;
    }
    Ok(Trace {
        plane: test.plane,
        radius_mm: test.radius_mm,
        centre_mm: c.to_array(),
        feed_mm_per_min: test.feed_mm_per_min,
        runs,
    })
}
