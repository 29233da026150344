//! Under G61, a corner where several axes reverse and each switch moves
//! another axis' correction against that axis' motion: the take-up is
//! written as one block per reversing axis, in an order where every
//! block keeps the tool on the path (docs/compensation.md, "Several
//! axes reverse at a corner: one take-up block each, in order").
//!
//! The dead band of docs/design.md and bench/eval judge.py: an axis'
//! switch carries its jump `J_a` (its own reversal value and what its
//! straightness tables change across, docs/design.md "The 21-component
//! model") as a lag that fades in proportion to that axis' own travel
//! across its band, whatever the other axes do. One block in which two
//! axes switch therefore leaves the path whenever their commands cross
//! their bands at different rates: each switch also moves the other
//! axes' corrections, so a reversing axis' command travels its band plus
//! what the other switch asks of it (a ratio `r_a ≠ 1`), and its lag's
//! part across the path fades at its own rate (points.rs
//! `fold_deviation_mm`). An axis that keeps its direction follows a
//! switch's step only in that direction (`take_up_command`); a step
//! against it is left on the tool.
//!
//! One switch per block removes the first: the switching axis' command
//! travels exactly its band (`r_a = 1`) and the other axes follow its jump
//! as its lag fades, so the tool stands still. The second is the order's
//! and the line's: an axis may follow a switch's step against its
//! direction only after its own switch, or, where it moves along the next
//! line in its direction, over the path the block advances along the
//! line: its command gains `u_c · δ` over `δ` of path (as
//! [`super::take_up_advance`]). Each block `k` ends at `D_k = Σ δ` along the
//! line, solved in the state after its switch; `δ_k` is the least advance
//! after which every step against a direction is caught up. The order
//! kept is the one whose largest offset from the path, computed for each
//! block from the tables (`block_offset_mm`), is the least.
//!
//! The machine stands at a G61 corner anyway (tp.c `tpSetupTangent`
//! stops where the path is not tangent), but every further block runs
//! from rest to rest: about 8 ms each on bench/cycle_time's machine
//! (`volcomp time`, two 15 µm blocks: +18 ms). So the order is written only
//! where the single block leaves the path by more than
//! [`SINGLE_BLOCK_FROM_MM`] and the order halves that.

use crate::compensate::solve::{solve_fixed_in, Method, PointSolution};
use crate::error::ModelError;
use crate::model::{AxisCells, Components, Directions, ErrorModel};
use volcomp_gcode::Vec3;

use super::frame::Frame;

/// The least step against an axis' direction that counts (mm): the G61
/// contour tolerance (`options::DEFAULT_EXACT_CONTOUR_TOLERANCE_UM`,
/// 0.05 µm), as in [`super::take_up_advance`].
const LEAST_STEP_MM: f64 = 0.05e-3;

/// How far past a step the advance goes (mm of command): one step of
/// five decimals, so that the quantized command does not fall short.
const MARGIN_MM: f64 = 0.01e-3;

/// How far past the piece's end the last block's command may be (mm)
/// and stop at it instead: half the G61 goal of 0.5 µm; a static axis'
/// solution drifts 0.08–0.10 µm over the advance on the coarse map
/// (raster's and rect_rot30's corners). The offset that leaves is
/// counted ([`block_offset_mm`]).
const PAST_MM: f64 = 0.25e-3;

/// The smallest direction cosine an axis may catch a step up with.
const LEAST_COSINE: f64 = 0.02;

/// The single take-up block's offset from the path (mm) above which the
/// blocks in order are tried. **A decision between two measurements**:
/// each further block costs about 8 ms from rest to rest (`volcomp time`
/// on bench/cycle_time's machine: two 15 µm blocks at a corner add
/// 18 ms), against the G61 goal of 0.5 µm. On the coarse map the single
/// blocks leave 1.8–7.6 µm (chords20_cw, spiral_lines, raster); on the
/// example map 0.26 µm (chords17_d24, chords12_d36: bench/eval judge.py's
/// dead band sampled every 1/200 of each short block), which one block
/// each in order brings to 0.06–0.11 µm for +0.1–0.3 % of time. Below the
/// goal less a fifth, time wins: the order only where one block would
/// take the tool near or past the goal.
pub(super) const SINGLE_BLOCK_FROM_MM: f64 = 0.4e-3;

/// Blocks in order (all but the last, then the last: the take-up the
/// piece starts from) and the largest offset they leave (mm).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Ordered {
    pub blocks: Vec<Vec3>,
    pub offset_mm: f64,
}

/// The tool's largest distance (mm) from the path at the corner, the rays
/// `corner + t·u` (`t ≥ 0`: the next line) and `corner − t·u_in` (the line
/// before, where its direction `u_in` is known), over a block from `q0` to `q1` run in
/// state `s1`, the lags `lags` (points.rs `switch_lags_mm`) carried by its
/// switches fading as judge.py's dead band has them: each as its own
/// axis' command crosses its band (`f_a = max(0, 1 − |Δq_a| λ / b_a)`),
/// kept where the axis stands, gone at once where it moves away. The tool
/// is piecewise linear in `λ` (the tables are affine over micrometres), so
/// the largest distance is at a breakpoint: `0`, `1` or a `b_a / |Δq_a|`.
pub(super) fn block_offset_mm(
    (cells, model): (&mut AxisCells, &dyn ErrorModel),
    (q0, q1, s1): (Vec3, Vec3, Directions),
    lags: &[Vec3; 3],
    (corner, u, u_in): (Vec3, Vec3, Option<Vec3>),
) -> Result<f64, ModelError> {
    let dq = q1 - q0;
    let mut lambdas = [0.0, 1.0, 0.0, 0.0, 0.0];
    for a in 0..3 {
        let own = lags[a][a];
        if own != 0.0 && own * dq[a] > 0.0 && own.abs() < dq[a].abs() {
            lambdas[2 + a] = own.abs() / dq[a].abs();
        }
    }
    let mut worst = 0.0_f64;
    for lambda in lambdas {
        let mut tool = cells.actual_mm(model, q0 + dq * lambda, s1, Components::All)?;
        for a in 0..3 {
            let own = lags[a][a];
            let f = if own == 0.0 || own * dq[a] < 0.0 {
                0.0
            } else {
                (1.0 - dq[a].abs() * lambda / own.abs()).max(0.0)
            };
            tool += lags[a] * f;
        }
        let v = tool - corner;
        let ahead = (v - u * v.dot(u).max(0.0)).norm();
        let off = u_in.map_or(ahead, |w| {
            let back = (-v.dot(w)).max(0.0);
            ahead.min((v + w * back).norm())
        });
        if off.is_nan() {
            return Ok(f64::INFINITY);
        }
        worst = worst.max(off);
    }
    Ok(worst)
}

/// The least advance (mm of path) after which every axis but `a` has
/// followed the step the switch of `a` asks of it (`lag[c]`, the command
/// that keeps the tool where it is) in its own direction `s[c]`: the line
/// at unit direction `u` moves axis `c` by `u_c·δ`. `None` where a step
/// against an axis' direction cannot be caught up so (the axis does not
/// move along the line in its direction).
pub(super) fn advance_for_switch_mm(lag: Vec3, a: usize, s: Directions, u: Vec3) -> Option<f64> {
    let mut delta = 0.0_f64;
    for c in (0..3).filter(|c| *c != a) {
        let sign = s[c].sign();
        let step = lag[c] * sign;
        if step.is_nan() {
            return None;
        }
        if step >= -LEAST_STEP_MM {
            continue;
        }
        let gain = u[c] * sign;
        if gain.is_nan() || gain < LEAST_COSINE {
            return None;
        }
        delta = delta.max((-step + MARGIN_MM) / gain);
    }
    Some(delta)
}

/// The take-up at a G61 line corner as one block per reversing axis in
/// the best order (module docs), where the single block `single` leaves
/// the path by more than [`SINGLE_BLOCK_FROM_MM`] and the order at most
/// half as much; `None` otherwise. `q_prev`, `s_old` the command and
/// state before, `t_prev` the corner, `t_end` the piece's end and `u_in`
/// the unit direction of the path into the corner (where known), `point`
/// the solution there (its state and reversing axes); the blocks end at
/// most [`super::take_up_advance::MAX_ADVANCE_MM`] along the piece and
/// leave at least `shortest_mm` of it.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub(super) fn ordered_take_up(
    (cells, model, method): (&mut AxisCells, &dyn ErrorModel, Method),
    (q_prev, s_old): (Vec3, Directions),
    (t_prev, t_end, u_in): (Vec3, Vec3, Option<Vec3>),
    point: &PointSolution,
    single: Vec3,
    shortest_mm: f64,
    frame: &Frame,
) -> Result<Option<Ordered>, ModelError> {
    let (mut switching, mut n) = ([0; 3], 0);
    for a in (0..3).filter(|a| point.reversed[*a] && point.s[*a] != s_old[*a]) {
        (switching[n], n) = (a, n + 1);
    }
    if n == 0 {
        return Ok(None);
    }
    let along = t_end - t_prev;
    let len = along.norm();
    if len.is_nan() || len <= 0.0 {
        return Ok(None);
    }
    let u = along * (1.0 / len);
    let all = super::points::switch_lags_mm(cells, model, q_prev, s_old, point.s, point.reversed)?;
    let single_mm = block_offset_mm(
        (cells, model),
        (q_prev, single, point.s),
        &all,
        (t_prev, u, u_in),
    )?;
    if single_mm.is_nan() || single_mm <= SINGLE_BLOCK_FROM_MM {
        return Ok(None);
    }
    let orders: &[&[usize]] = if n == 1 {
        &[&[0]]
    } else if n == 2 {
        &[&[0, 1], &[1, 0]]
    } else {
        &[
            &[0, 1, 2],
            &[0, 2, 1],
            &[1, 0, 2],
            &[1, 2, 0],
            &[2, 0, 1],
            &[2, 1, 0],
        ]
    };
    let mut best: Option<Ordered> = None;
    for order in orders {
        let mut axes = [0; 3];
        for (i, k) in order.iter().enumerate() {
            axes[i] = switching[*k];
        }
        if let Some(o) = in_order(
            (cells, model, method),
            (q_prev, s_old),
            (t_prev, u, len, u_in),
            point,
            &axes[..order.len()],
            shortest_mm,
            frame,
        )? {
            if best.as_ref().is_none_or(|b| o.offset_mm < b.offset_mm) {
                best = Some(o);
            }
        }
    }
    Ok(best.filter(|b| b.offset_mm <= 0.5 * single_mm))
}

/// The blocks for one order of the switching axes `axes` (module docs):
/// `None` where a block cannot keep every axis in its direction, a
/// switching axis does not cross its band, the advance passes
/// [`super::take_up_advance::MAX_ADVANCE_MM`] or leaves less than
/// `shortest_mm` of the piece, or an axis would pass the piece's end.
#[allow(clippy::too_many_arguments)]
fn in_order(
    (cells, model, method): (&mut AxisCells, &dyn ErrorModel, Method),
    (q_prev, s_old): (Vec3, Directions),
    (t_prev, u, len, u_in): (Vec3, Vec3, f64, Option<Vec3>),
    point: &PointSolution,
    axes: &[usize],
    shortest_mm: f64,
    frame: &Frame,
) -> Result<Option<Ordered>, ModelError> {
    let (mut q, mut s, mut along_mm) = (q_prev, s_old, 0.0_f64);
    let mut blocks = Vec::with_capacity(3);
    let mut offset_mm = 0.0_f64;
    for (k, &a) in axes.iter().enumerate() {
        let mut s_next = s;
        s_next[a] = point.s[a];
        let mut one = [false; 3];
        one[a] = true;
        let lags = super::points::switch_lags_mm(cells, model, q, s, s_next, one)?;
        let Some(delta) = advance_for_switch_mm(lags[a], a, s, u) else {
            return Ok(None);
        };
        along_mm += delta;
        if along_mm > super::take_up_advance::MAX_ADVANCE_MM || len - along_mm < shortest_mm {
            return Ok(None);
        }
        let target = t_prev + u * along_mm;
        let solved = solve_fixed_in(cells, model, method, target, s_next, [false; 3], q)?.q_mm;
        let mut q_next = frame.quantize(solved, q);
        if k + 1 == axes.len() {
            // The last block is the piece's start: no axis past the
            // piece's end (a take-up never passes the segment's own
            // command, points.rs). An axis whose solution drifts past it
            // by a fraction of the contour tolerance (a static axis)
            // stops at it, and the offset below counts that.
            for c in 0..3 {
                let past = (q_next[c] - point.q_mm[c]) * point.s[c].sign();
                if past.is_nan() || past > PAST_MM {
                    return Ok(None);
                }
                if past > 0.0 {
                    q_next[c] = point.q_mm[c];
                }
            }
        }
        for c in 0..3 {
            let sign = s_next[c].sign();
            let moved = (q_next[c] - q[c]) * sign;
            if moved.is_nan() {
                return Ok(None);
            }
            if c == a {
                let band = (lags[a][a] * sign).max(0.0);
                if moved < band - LEAST_STEP_MM {
                    return Ok(None);
                }
            } else if moved < 0.0 {
                // A step against the direction within the contour
                // tolerance: the axis stands (it must not reverse).
                if moved < -LEAST_STEP_MM {
                    return Ok(None);
                }
                q_next[c] = q[c];
            }
        }
        let off = block_offset_mm(
            (cells, model),
            (q, q_next, s_next),
            &lags,
            (t_prev, u, u_in),
        )?;
        offset_mm = offset_mm.max(off);
        // A switch that needs no command (a negative or zero reversal
        // value) writes no block.
        if (0..3).any(|c| q_next[c].to_bits() != q[c].to_bits()) {
            blocks.push(q_next);
        }
        (q, s) = (q_next, s_next);
    }
    Ok((!blocks.is_empty()).then_some(Ordered { blocks, offset_mm }))
}

impl super::State<'_> {
    /// Writes the take-up blocks in order kept for command `i`
    /// ([`ordered_take_up`]) from `from`; returns where they end.
    pub(super) fn write_take_up_blocks(
        &mut self,
        at: &super::walk::Place,
        from: Vec3,
        i: usize,
        mode: super::lines::OutMode,
    ) -> Vec3 {
        let mut pos = from;
        if self.take_up_blocks.is_empty() {
            return pos;
        }
        let blocks = std::mem::take(&mut self.take_up_blocks);
        for (_, q) in blocks.iter().filter(|(k, _)| *k == i) {
            self.write_inserted(at, pos, *q, mode, "take-up");
            pos = *q;
        }
        self.take_up_blocks = blocks;
        pos
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::test_support::um;
    use crate::model::Direction;

    #[test]
    fn a_switch_asks_an_advance_only_of_the_axes_it_steps_against() {
        // bench/eval raster on the coarse map (bench/coarse_map.py), the
        // corner at X 14.4 where Z turns upward and Y, drifting −Y,
        // reverses with it, the pass running +X: Y's switch (reverse to
        // forward) moves X's error by +5 µm (Y's straightness of X,
        // ±2.5 µm) and Z's by +2 µm (±1 µm), so the command that keeps the
        // tool asks X for −5 µm (against +X) and Z for −2 µm (Z still
        // reverse: along it). By hand X catches 5 µm up after
        // (5 + 0.01) / 1.0 µm of path.
        let s = [Direction::Forward, Direction::Reverse, Direction::Reverse];
        let u = Vec3::new(1.0, 0.0, 0.0);
        let lag_y = um(-5.0, 16.29, -2.0);
        let d = advance_for_switch_mm(lag_y, 1, s, u).unwrap();
        assert!((d - 5.01e-3).abs() < 1e-12, "{d}");
        // Along a line at 60° to X: 5.01 / 0.5 µm.
        let slant = Vec3::new(0.5, 0.75_f64.sqrt(), 0.0);
        let d = advance_for_switch_mm(lag_y, 1, s, slant).unwrap();
        assert!((d - 10.02e-3).abs() < 1e-12, "{d}");
        // Z's switch then (reverse to forward): it asks X for −3 µm and Y,
        // now forward, for +4 µm (along it): 3.01 µm.
        let s2 = [Direction::Forward, Direction::Forward, Direction::Reverse];
        let lag_z = um(-3.0, 4.0, 11.49);
        let d = advance_for_switch_mm(lag_z, 2, s2, u).unwrap();
        assert!((d - 3.01e-3).abs() < 1e-12, "{d}");
        // Z's switch first, Y still reverse: Y's +4 µm is against it, and
        // Y does not move along the pass: no advance can do it.
        assert_eq!(advance_for_switch_mm(lag_z, 2, s, u), None);
        // Steps within the contour tolerance ask nothing.
        assert_eq!(
            advance_for_switch_mm(um(-0.04, 16.29, 0.0), 1, s, u),
            Some(0.0)
        );
    }
}
