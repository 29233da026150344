//! Simulation of a machine with an error model, and the metrics of
//! docs/design.md, "Simulation and metrics".
//!
//! The controller moves linearly in the axis frame between consecutive
//! commands; the tool follows the image of that motion under
//! `q ↦ q + e(q, s)`, where `s` switches at the start of a move
//! (docs/design.md, "Direction state and backlash").
//!
//! A position cannot jump, so where a switch of `s` would make the image
//! discontinuous (backlash at a reversal), the simulator keeps the tool where
//! it was and carries the difference as a *lag* `actual − image(q, s)`: a
//! dead band. Each component of the lag shrinks by the command travel of its
//! own axis while that axis moves towards the tool (the axis takes up its
//! reversal value, the tool stands still), and stays 0 once engaged. Lag in a
//! component whose own axis does not catch up (the transverse part of another
//! axis' switch) fades in proportion to the take-up progress of the axes that
//! do. A lag in the direction of motion (negative reversal value) vanishes at
//! once: nothing physical delays it, and the model says it happens. A lag that
//! is not taken up by the end of a move carries into the next one.
//!
//! This is what a real axis with backlash does, and it is what makes a
//! take-up move (a command that moves only the reversing axis by its reversal
//! value) leave the tool still.

mod front;
pub mod nominal;
pub mod report;

pub use front::{Simulation, DEFAULT_CHORD_TOLERANCE_MM};
pub use report::{SegmentError, SimReport};

use crate::error::ModelError;
use crate::model::{
    actual_mm, Components, Direction, Directions, ErrorModel, WithTool, ALL_FORWARD,
};
use volcomp_gcode::Vec3;

/// Largest distance between dense samples of the actual path (docs/design.md, "Simulation and metrics").
pub const SAMPLE_SPACING_MM: f64 = 0.05;

/// Simulates the actual tool position along a sequence of commands.
pub struct Simulator<'m> {
    model: &'m dyn ErrorModel,
    tool_length_offset_mm: Vec3,
    s: Directions,
    q: Vec3,
    actual: Option<Vec3>,
}

impl<'m> Simulator<'m> {
    /// A machine at command `q_start_mm`, every axis forward, the actual
    /// position unknown until the first evaluated move.
    pub fn new(model: &'m dyn ErrorModel, q_start_mm: Vec3) -> Self {
        Self {
            model,
            tool_length_offset_mm: Vec3::ZERO,
            s: ALL_FORWARD,
            q: q_start_mm,
            actual: None,
        }
    }

    /// Sets the tool length offset of the active tool (G43/G43.1, mm), which
    /// models with Abbe terms evaluate at. A different tool puts the tip
    /// elsewhere: the actual position is re-evaluated, not carried over.
    pub fn set_tool_length_offset(&mut self, tool_length_offset_mm: Vec3) {
        if tool_length_offset_mm != self.tool_length_offset_mm {
            self.tool_length_offset_mm = tool_length_offset_mm;
            self.actual = None;
        }
    }

    /// Current command.
    pub fn command(&self) -> Vec3 {
        self.q
    }

    /// Current direction state.
    pub fn directions(&self) -> Directions {
        self.s
    }

    /// Moves to `q_end_mm` without evaluating the model (moves outside the
    /// mapped volume, e.g. G53 retracts); the direction state still follows.
    pub fn move_untracked(&mut self, q_end_mm: Vec3) {
        self.s = next_state(self.s, q_end_mm - self.q);
        self.q = q_end_mm;
        self.actual = None;
    }

    /// Moves to `q_end_mm`, calling `sample(actual, command)` at points no
    /// more than `spacing_mm` apart (the end point included, the start not),
    /// or only at the end when `spacing_mm` is infinite. Returns the actual end.
    pub fn move_to(
        &mut self,
        q_end_mm: Vec3,
        spacing_mm: f64,
        mut sample: impl FnMut(Vec3, Vec3),
    ) -> Result<Vec3, ModelError> {
        let q0 = self.q;
        let dq = q_end_mm - q0;
        let s_new = next_state(self.s, dq);
        let tool = WithTool {
            model: self.model,
            tool_length_offset_mm: self.tool_length_offset_mm,
        };
        let image = |q: Vec3| actual_mm(&tool, q, s_new, Components::All);
        let lag0 = match self.actual {
            Some(prev) => prev - image(q0)?,
            None => Vec3::ZERO,
        };
        let lag = Lag::new(lag0, dq);
        let length = dq.norm();
        let n = if spacing_mm.is_finite() && spacing_mm > 0.0 {
            ((length / spacing_mm).ceil() as usize).max(1)
        } else {
            1
        };
        let mut end = Vec3::ZERO;
        for i in 1..=n {
            let lambda = i as f64 / n as f64;
            let q = if i == n { q_end_mm } else { q0 + dq * lambda };
            let a = image(q)? + lag.at(lambda);
            sample(a, q);
            end = a;
        }
        self.s = s_new;
        self.q = q_end_mm;
        self.actual = Some(end);
        Ok(end)
    }
}

/// The dead-band lag along one move (see the module documentation).
struct Lag {
    lag0: Vec3,
    dq: Vec3,
    catching: [bool; 3],
}

impl Lag {
    fn new(lag0: Vec3, dq: Vec3) -> Self {
        let catching = [0, 1, 2].map(|k| lag0[k] * dq[k] > 0.0);
        Self { lag0, dq, catching }
    }

    /// Lag after the fraction `lambda` of the move.
    fn at(&self, lambda: f64) -> Vec3 {
        let mut progress: f64 = 0.0;
        for k in 0..3 {
            if self.catching[k] {
                progress = progress.max((self.dq[k].abs() * lambda / self.lag0[k].abs()).min(1.0));
            }
        }
        let mut lag = Vec3::ZERO;
        for k in 0..3 {
            lag[k] = if self.catching[k] {
                let left = (self.lag0[k].abs() - self.dq[k].abs() * lambda).max(0.0);
                left.copysign(self.lag0[k])
            } else if self.dq[k] != 0.0 && self.lag0[k] * self.dq[k] < 0.0 {
                0.0
            } else {
                self.lag0[k] * (1.0 - progress)
            };
        }
        lag
    }
}

/// The direction state after a move by `dq` (axes that do not move keep theirs).
pub fn next_state(s: Directions, dq: Vec3) -> Directions {
    let mut out = s;
    for a in 0..3 {
        if let Some(d) = Direction::of_delta(dq[a]) {
            out[a] = d;
        }
    }
    out
}

/// Distance from `p` to the segment `a`–`b`.
pub fn point_segment_distance(p: Vec3, a: Vec3, b: Vec3) -> f64 {
    let ab = b - a;
    let len2 = ab.dot(ab);
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab * t)).norm()
}

/// Running RMS and maximum of an error, optionally weighted.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct ErrorStats {
    sum_sq_weighted: f64,
    weight: f64,
    /// Largest error seen (µm).
    pub max_um: f64,
    /// Number of samples.
    pub count: u64,
}

impl ErrorStats {
    /// Adds an error sample (µm) with a weight (arc length for contour error).
    pub fn add(&mut self, error_um: f64, weight: f64) {
        self.sum_sq_weighted += error_um * error_um * weight;
        self.weight += weight;
        self.max_um = self.max_um.max(error_um);
        self.count += 1;
    }

    /// Root mean square (µm), weighted.
    pub fn rms_um(&self) -> f64 {
        if self.weight > 0.0 {
            (self.sum_sq_weighted / self.weight).sqrt()
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Backlash {
        b_um: f64,
    }

    impl ErrorModel for Backlash {
        fn deviation_um(
            &self,
            _q: Vec3,
            s: Directions,
            _c: Components,
        ) -> Result<Vec3, ModelError> {
            let mut e = Vec3::ZERO;
            if s[2] == Direction::Reverse {
                e.z = self.b_um;
            }
            Ok(e)
        }
        fn range_mm(&self) -> [[f64; 2]; 3] {
            [[-1e3, 1e3]; 3]
        }
    }

    #[test]
    fn a_take_up_move_holds_the_tool_still() {
        // Backlash 5 µm on Z. After moving up to Z=1, a take-up of exactly
        // 5 µm down must leave the tool at Z=1 all along.
        let m = Backlash { b_um: 5.0 };
        let mut sim = Simulator::new(&m, Vec3::ZERO);
        sim.move_to(Vec3::new(0.0, 0.0, 1.0), 0.05, |_, _| {})
            .unwrap();
        let mut zs = Vec::new();
        sim.move_to(Vec3::new(0.0, 0.0, 0.995), 0.001, |a, _| zs.push(a.z))
            .unwrap();
        for z in zs {
            assert!((z - 1.0).abs() < 1e-12, "{z}");
        }
        // Then a move down by 0.1 mm goes exactly 0.1 mm down.
        let end = sim
            .move_to(Vec3::new(0.0, 0.0, 0.895), 0.05, |_, _| {})
            .unwrap();
        assert!((end.z - 0.9).abs() < 1e-12);
    }

    #[test]
    fn a_reversal_without_take_up_lags_then_follows() {
        let m = Backlash { b_um: 5.0 };
        let mut sim = Simulator::new(&m, Vec3::ZERO);
        sim.move_to(Vec3::new(0.0, 0.0, 1.0), 0.05, |_, _| {})
            .unwrap();
        // Reverse by 10 µm: the first 5 µm of command are taken up.
        let mut samples = Vec::new();
        sim.move_to(Vec3::new(0.0, 0.0, 0.99), 0.001, |a, q| {
            samples.push((q.z, a.z))
        })
        .unwrap();
        // While the command is above 0.995 the tool stands at 1.0; below, it
        // follows 5 µm above the command.
        for (q, a) in &samples {
            let expected = if *q >= 0.995 { 1.0 } else { q + 0.005 };
            assert!(
                (a - expected).abs() < 1e-12,
                "command {q}: tool {a}, expected {expected}"
            );
        }
        let (_, a_end) = *samples.last().unwrap();
        assert!((a_end - 0.995).abs() < 1e-12);
    }

    #[test]
    fn stats_are_weighted() {
        let mut s = ErrorStats::default();
        s.add(3.0, 1.0);
        s.add(4.0, 3.0);
        assert!((s.rms_um() - ((9.0 + 48.0) / 4.0f64).sqrt()).abs() < 1e-12);
        assert_eq!(s.max_um, 4.0);
    }
}
