//! Simulation of a machine with an error model, and the metrics of
//! docs/design.md, "Simulation and metrics".
//!
//! The controller moves linearly in the axis frame between consecutive
//! commands; the tool follows the image of that motion under
//! `q ↦ q + e(q, s)`, where `s` switches at the start of a move
//! (docs/design.md, "Direction state and backlash").
//!
//! A position cannot jump, so backlash is simulated as a *dead band* per
//! axis. When an axis' command reverses, the tool keeps where it was: the
//! switch of that axis' tables is carried as a *lag*, the jump
//! `e(q, s_before) − e(q, s_after)` of the image, all three components of
//! it (the axis' own reversal value and what its tables add across, its
//! straightness changing with the direction). The lag belongs to the
//! reversing axis' carriage and fades as that carriage takes up its band:
//! its own component shrinks by the axis' command travel toward it (the
//! motor crosses the band, the tool stands still along the axis), and the
//! components across shrink in the same proportion (the carriage engages
//! as a whole). A lag stays while its axis does not move, whatever the
//! other axes do, and carries into the next move; it vanishes at once when
//! its axis moves away from it (a negative reversal value: the tables say
//! the tool is ahead, nothing delays it) or when the axis has no reversal
//! value of its own there (it engages at once). An axis that reverses again
//! before its band is crossed adds the new switch to what is left.
//!
//! This is a backlash gap: the carriage of axis `a` sits at a fraction
//! `β_a` across its band and its tables act as `e_old + β_a (e_new − e_old)`,
//! `β_a` growing with the motor's travel over the band width. It is what
//! makes a take-up move (a command that moves only the reversing axis by
//! its reversal value) leave the tool still.

mod front;
pub mod nominal;
pub mod report;

pub use front::{Simulation, DEFAULT_CHORD_TOLERANCE_MM};
pub use report::{SegmentError, SimReport};

use crate::error::ModelError;
use crate::model::{actual_mm, Components, Directions, ErrorModel, WithTool, ALL_FORWARD};
use volcomp_gcode::Vec3;

/// Largest distance between dense samples of the actual path (docs/design.md, "Simulation and metrics").
pub const SAMPLE_SPACING_MM: f64 = 0.05;

/// Simulates the actual tool position along a sequence of commands.
pub struct Simulator<'m> {
    model: &'m dyn ErrorModel,
    tool_length_offset_mm: Vec3,
    s: Directions,
    q: Vec3,
    /// Whether the actual position is known (the last move was evaluated).
    tracked: bool,
    /// The lag each axis' carriage still carries (mm; module documentation).
    lags: [Vec3; 3],
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
            tracked: false,
            lags: [Vec3::ZERO; 3],
        }
    }

    /// Sets the tool length offset of the active tool (G43/G43.1, mm), which
    /// models with Abbe terms evaluate at. A different tool puts the tip
    /// elsewhere: the actual position is re-evaluated, not carried over.
    pub fn set_tool_length_offset(&mut self, tool_length_offset_mm: Vec3) {
        if tool_length_offset_mm != self.tool_length_offset_mm {
            self.tool_length_offset_mm = tool_length_offset_mm;
            self.forget();
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
        self.forget();
    }

    fn forget(&mut self) {
        self.tracked = false;
        self.lags = [Vec3::ZERO; 3];
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
        if self.tracked {
            // Each reversing axis' switch, one axis at a time: the lags
            // add up to the whole jump of the image.
            let mut s = self.s;
            for a in 0..3 {
                if s_new[a] != s[a] {
                    let before = actual_mm(&tool, q0, s, Components::All)?;
                    s[a] = s_new[a];
                    self.lags[a] += before - actual_mm(&tool, q0, s, Components::All)?;
                }
            }
        }
        let bands = [0, 1, 2].map(|a| Band::new(self.lags[a], a, dq[a]));
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
            let mut a = actual_mm(&tool, q, s_new, Components::All)?;
            for (k, band) in bands.iter().enumerate() {
                a += self.lags[k] * band.left(lambda);
            }
            sample(a, q);
            end = a;
        }
        for (k, band) in bands.iter().enumerate() {
            self.lags[k] *= band.left(1.0);
        }
        self.s = s_new;
        self.q = q_end_mm;
        self.tracked = true;
        Ok(end)
    }
}

/// How much of one axis' lag is left along a move (module documentation).
struct Band {
    /// The axis' own lag (mm, absolute), and its command travel toward it
    /// over the whole move; `None`: the lag is gone at once.
    own_mm: f64,
    travel_mm: Option<f64>,
}

impl Band {
    fn new(lag: Vec3, axis: usize, dq: f64) -> Self {
        let own = lag[axis];
        let travel = if own == 0.0 || own * dq < 0.0 {
            None
        } else {
            Some(dq.abs())
        };
        Band {
            own_mm: own.abs(),
            travel_mm: travel,
        }
    }

    /// The fraction of the lag left after the fraction `lambda` of the move.
    fn left(&self, lambda: f64) -> f64 {
        match self.travel_mm {
            None => 0.0,
            Some(t) => ((self.own_mm - t * lambda) / self.own_mm).max(0.0),
        }
    }
}

pub use crate::model::next_state;

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
    use crate::model::{ByDirection, Direction};

    /// Z's reverse error `b_um` above its forward one.
    fn backlash(b_um: f64) -> ByDirection<impl Fn(Directions) -> Vec3 + Send + Sync> {
        ByDirection(move |s: Directions| {
            if s[2] == Direction::Reverse {
                Vec3::new(0.0, 0.0, b_um)
            } else {
                Vec3::ZERO
            }
        })
    }

    #[test]
    fn a_take_up_move_holds_the_tool_still() {
        // Backlash 5 µm on Z. After moving up to Z=1, a take-up of exactly
        // 5 µm down must leave the tool at Z=1 all along.
        let m = backlash(5.0);
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
        let m = backlash(5.0);
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

    /// X with a 4 µm band whose reverse tables also move the tool +1 µm
    /// along Y (its straightness differs by direction).
    fn x_band() -> ByDirection<impl Fn(Directions) -> Vec3 + Send + Sync> {
        ByDirection(|s: Directions| {
            if s[0] == Direction::Reverse {
                Vec3::new(4.0, 1.0, 0.0)
            } else {
                Vec3::ZERO
            }
        })
    }

    #[test]
    fn a_transverse_lag_fades_with_its_own_axis_take_up_only() {
        // X forward to 1 mm, then back by 2 µm: half its band. The switch
        // is the jump (−4, −1) µm; half of it is left, the tool has not
        // moved along X and has moved 0.5 µm along Y.
        let m = x_band();
        let mut sim = Simulator::new(&m, Vec3::ZERO);
        sim.move_to(Vec3::new(1.0, 0.0, 0.0), 0.05, |_, _| {})
            .unwrap();
        let a = sim
            .move_to(Vec3::new(0.998, 0.0, 0.0), f64::INFINITY, |_, _| {})
            .unwrap();
        assert!(
            (a.x - 1.0).abs() < 1e-12 && (a.y - 0.0005).abs() < 1e-12,
            "{a:?}"
        );
        // A move along Y alone: X's carriage stays where it is in its band,
        // so does the half of the Y shift it has not made yet.
        let a = sim
            .move_to(Vec3::new(0.998, 1.0, 0.0), 0.05, |_, _| {})
            .unwrap();
        assert!(
            (a.x - 1.0).abs() < 1e-12 && (a.y - 1.0005).abs() < 1e-12,
            "{a:?}"
        );
        // X moves back 3 µm more: 2 µm close its band (the Y shift fades
        // in step, 0.25 µm per µm), 1 µm moves the tool.
        let mut ys = Vec::new();
        let a = sim
            .move_to(Vec3::new(0.995, 1.0, 0.0), 0.0005, |a, q| {
                ys.push((q.x, a.y))
            })
            .unwrap();
        assert!(
            (a.x - 0.999).abs() < 1e-12 && (a.y - 1.001).abs() < 1e-12,
            "{a:?}"
        );
        for (qx, y) in ys {
            let taken_um = ((0.998 - qx) * 1e3).min(2.0);
            let expected = 1.0005 + 0.00025 * taken_um;
            assert!((y - expected).abs() < 1e-12, "at X {qx}: {y} vs {expected}");
        }
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
