//! Under G61, a take-up ramp on a line whose reversing axes catch up their
//! take-ups one after the other (docs/compensation.md, "A staged ramp for
//! the cross lag").
//!
//! Where two axes reverse together and one's switch moves the other's
//! error (the map's straightness: the shop map's Y switch moves Z by
//! 0.357 µm), a common step `σ(u)` for both leaves the tool off by the
//! cross term `c·σ` while the other axis still stands in its band: up to
//! `c·b/Δ` at any ramp length (`ramp_band.rs`, test
//! `a_cross_lag_is_carried_until_the_standing_axis_crosses_its_band`).
//! Staged, the axis whose error the others' switches move first crosses
//! its band on a step of its own, and the next axis' step, its cross term
//! included, comes after it, when that axis' command moves its carriage
//! again: the cross term is followed instead of carried. Each step is the
//! reversing axis' lag ([`super::points`] `switch_lags_mm`: its own
//! component and what it moves across), on the two-parabola step of a
//! line's ramp (`points::parabolic_step`) over its own share of the ramp,
//! the share its own tangency asks for (`points::line_ramp_length_mm`); the
//! rest of the take-up, on the axes not staged (the path's own axis, one
//! with no band to cross), on the common step over the whole ramp. The
//! later axes' commands follow their targets the old way until their own
//! step begins ([`Stages::waiting`]). The ramp is judged by the dead-band
//! reading of its written commands ([`super::ramp_band::excursion`]), as
//! any ramp ending where the tangency needs it.

use crate::model::Directions;
use volcomp_gcode::Vec3;

/// The share of the last step put before the reversal: the hold model's
/// lead `a = s₂L/(2s₁ + s₂)` at equal drifts on both sides (`s₁ = s₂`:
/// `L/3`; compensate/arcs.rs `ramp_lead_share`), which makes the larger of
/// the offset at the reversal `s₁a` and at the step's end `s₂(L − a) − s₁a`
/// least. Measured on zigzag shop (G61, F6000; take-up blocks left of 37,
/// bench/eval/run.py programs): half the step before the reversal 29, a
/// third 20, a fifth 20 (its ramps reading up to 0.15 µm against 0.11 µm),
/// 0.6 34.
const LAST_LEAD_SHARE: f64 = 1.0 / 3.0;

/// The stages of a staged ramp: the axes in the order their steps run,
/// and where (share `u` of the ramp) each step starts and ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Stages {
    axes: [usize; 3],
    n: usize,
    starts: [f64; 3],
    ends: [f64; 3],
    /// The sum of the steps' needs (mm): the shortest the ramp may be.
    need_mm: f64,
}

impl Stages {
    /// The stages of the reversal whose switch lags are `lags` (mm, per
    /// axis, [`super::points`] `switch_lags_mm`), into the directions
    /// `s`: every reversing axis whose own lag points its new way (a band
    /// to cross), at least two, ordered so that the axis whose error the
    /// others' switches move most (less what its own switch moves of
    /// theirs) goes first; each step's share of the ramp in proportion to
    /// `need_mm` of its lag (the length its tangency asks). `None` where
    /// fewer than two axes have a band to cross, or a need is not
    /// positive and finite.
    pub(super) fn plan(
        lags: &[Vec3; 3],
        s: Directions,
        reversed: [bool; 3],
        need_mm: impl Fn(Vec3) -> f64,
    ) -> Option<Stages> {
        let banded = [0, 1, 2].map(|a| reversed[a] && lags[a][a] * s[a].sign() > 0.0);
        let mut axes = [0usize; 3];
        let mut n = 0;
        for a in (0..3).filter(|a| banded[*a]) {
            axes[n] = a;
            n += 1;
        }
        if n < 2 {
            return None;
        }
        // What the other staged axes' switches move of axis `a`'s error,
        // less what `a`'s switch moves of theirs.
        let staged = axes;
        let key = |a: usize| -> f64 {
            staged[..n]
                .iter()
                .filter(|b| **b != a)
                .map(|&b| lags[b][a].abs() - lags[a][b].abs())
                .sum()
        };
        axes[..n].sort_by(|a, b| key(*b).total_cmp(&key(*a)));
        let mut needs = [0.0f64; 3];
        for k in 0..n {
            needs[k] = need_mm(lags[axes[k]]);
            if !(needs[k] > 0.0 && needs[k].is_finite()) {
                return None;
            }
        }
        // One step after the other: an axis' own take-up done before the
        // next axis' lag moves its error, so that lag is followed (its
        // command already on its new flank) instead of carried.
        let total: f64 = needs[..n].iter().sum();
        let mut starts = [0.0f64; 3];
        let mut ends = [1.0f64; 3];
        let mut acc = 0.0;
        for k in 0..n {
            starts[k] = acc / total;
            acc += needs[k];
            ends[k] = if k + 1 == n { 1.0 } else { acc / total };
        }
        Some(Stages {
            axes,
            n,
            starts,
            ends,
            need_mm: total,
        })
    }

    /// The shortest the staged ramp may be (mm): each step over the length
    /// its tangency asks.
    pub(super) fn need_mm(&self) -> f64 {
        self.need_mm
    }

    /// The share of the ramp before the reversal: the earlier steps and
    /// [`LAST_LEAD_SHARE`] of the last. An axis stands (its tool with it)
    /// from where its command turns to where it has crossed its band,
    /// while its target drifts; the last axis follows its target the old
    /// way up to its step, so it stands over its own step only. The axes
    /// before it cross their bands before the reversal, on their own
    /// steps; what their targets drift the old way meanwhile is what they
    /// leave (their command, on its new flank short of that drift, crosses
    /// the rest with the next axis' lag on it).
    pub(super) fn lead_share(&self) -> f64 {
        let last = self.starts[self.n - 1];
        last + LAST_LEAD_SHARE * (1.0 - last)
    }

    /// The axes whose step has not begun at share `u` of the ramp (after
    /// the first): their command follows their target in the old
    /// direction (the new state's solution less their whole lag) until it
    /// does, and turns there.
    pub(super) fn waiting(&self, u: f64) -> [bool; 3] {
        let mut w = [false; 3];
        for k in 1..self.n {
            w[self.axes[k]] = u < self.starts[k];
        }
        w
    }

    /// The take-up still to catch up at share `u` of the ramp: each staged
    /// axis' lag times what its step has left (`1 − step(v)`, `v` the share
    /// of its own stage run), and the rest of `delta` times what the
    /// common step has left.
    pub(super) fn rest(
        &self,
        delta: Vec3,
        lags: &[Vec3; 3],
        u: f64,
        step: impl Fn(f64) -> f64,
    ) -> Vec3 {
        let mut staged = Vec3::ZERO;
        let mut rest = Vec3::ZERO;
        for k in 0..self.n {
            let lag = lags[self.axes[k]];
            staged += lag;
            let (from, to) = (self.starts[k], self.ends[k]);
            let v = ((u - from) / (to - from)).clamp(0.0, 1.0);
            rest += lag * (1.0 - step(v));
        }
        // The rest of the take-up on the axes not staged; a staged axis'
        // own component is its lags' (the take-up command's, cut to the
        // first target's, may fall short of it).
        let mut common = delta - staged;
        for k in 0..self.n {
            common[self.axes[k]] = 0.0;
        }
        rest + common * (1.0 - step(u))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::test_support::um;
    use crate::model::Direction;

    #[test]
    fn the_axis_the_other_switch_moves_goes_first() {
        // The zigzag's reversal (docs/compensation.md): Y's lag
        // (−0.015, −2.707, −0.357) µm, Z's (0.33, −0.010, −6.844) µm, both
        // reversing downward. Y's switch moves Z by 0.357 µm, Z's moves Y
        // by 0.010 µm: Z first. Needs √|Δ| (the tangency's length at one
        // tolerance): √6.8449 : √2.7306, Z's step ends at
        // 2.6163/(2.6163 + 1.6525) = 0.6129 of the ramp.
        let down = [Direction::Reverse; 3];
        let lags = [
            Vec3::ZERO,
            um(-0.015, -2.707, -0.357),
            um(0.33, -0.010, -6.844),
        ];
        let need = |v: Vec3| (v.y.abs().max(v.z.abs()) * 1e3).sqrt();
        let st = Stages::plan(&lags, down, [false, true, true], need).unwrap();
        assert_eq!(st.axes[..st.n], [2, 1]);
        let e = 6.844f64.sqrt() / (6.844f64.sqrt() + 2.707f64.sqrt());
        assert!((st.ends[0] - e).abs() < 1e-12, "{st:?}");
        assert!(
            (st.lead_share() - (e + (1.0 - e) / 3.0)).abs() < 1e-12,
            "{st:?}"
        );
        assert_eq!(st.waiting(0.5 * e), [false, true, false]);
        assert_eq!(st.waiting(e + 1e-9), [false; 3]);
        // Y alone, or Y with a Z whose lag points against its new way (no
        // band to cross): no stages.
        assert_eq!(Stages::plan(&lags, down, [false, true, false], need), None);
        let up_z = [Direction::Reverse, Direction::Reverse, Direction::Forward];
        assert_eq!(Stages::plan(&lags, up_z, [false, true, true], need), None);
    }

    #[test]
    fn each_lag_is_caught_up_on_its_own_stage() {
        // Stages Z then Y, Z's ending at u = 0.5; a take-up of both lags
        // plus 0.1 µm of X on the common step. Linear steps: at u = 0.25
        // half of Z's lag and all of Y's are left, and 0.075 µm of X; at
        // u = 0.75 none of Z's, half of Y's, 0.025 µm of X; at the end
        // nothing.
        let up = [Direction::Forward; 3];
        let lags = [Vec3::ZERO, um(0.0, 2.0, 0.4), um(0.0, 0.0, 6.0)];
        let delta = um(0.1, 2.0, 6.4);
        let st = Stages::plan(&lags, up, [false, true, true], |_| 1.0).unwrap();
        assert_eq!(st.axes[..st.n], [2, 1]);
        let lin = |v: f64| v;
        let close = |a: Vec3, b: Vec3| (a - b).norm() < 1e-15;
        assert!(close(st.rest(delta, &lags, 0.0, lin), delta));
        assert!(close(st.rest(delta, &lags, 0.25, lin), um(0.075, 2.0, 3.4)));
        assert!(close(st.rest(delta, &lags, 0.75, lin), um(0.025, 1.0, 0.2)));
        assert!(close(st.rest(delta, &lags, 1.0, lin), Vec3::ZERO));
    }
}
