//! An axis held across another axis' S-curve, the free axes solved again
//! in its old state (docs/compensation.md, "An axis held across an
//! S-curve").
//!
//! Across an S-curve at an arc's quarter point only the S-curve's own axis
//! reverses: another axis whose target would turn back there (its
//! straightness changing with the S-curve's axis' direction) keeps its
//! command and its direction for the piece (points.rs). Its table then
//! stays the old direction's, and that table moves the other axes too
//! (the transverse columns of the axis-table map, docs/design.md): the
//! free axes solved with the held axis in its new direction leave the tool
//! off by what the held axis' table switches across (bench/coarse_map.py:
//! Z's straightness of X switches by 3 µm, X's by 2.5 µm of Y). Here the
//! free axes are solved again with the held axes at their command in their
//! old state, as a hold does (solve.rs `held_solve`).

use crate::compensate::options::TakeUpRule;
use crate::compensate::solve::{consistent_state, solve_fixed_in, Method, PointSolution};
use crate::error::ModelError;
use crate::model::{AxisCells, Directions, ErrorModel};
use volcomp_gcode::Vec3;

/// Whether the free axes are solved again across an S-curve under `rule`:
/// under G64 P and G64 without P, where the held axis runs on in its old
/// table and is taken up later (folded, on a lead piece or held on);
/// not under G61, where the take-up block right after the S-curve moves
/// the free axes from where the held axis' new table puts them, and
/// re-solving them at the S-curve's end left that block to step them
/// against their motion (docs/compensation.md, "An axis held across an
/// S-curve": measured worse on 16 coarse G61 rows).
pub(super) fn resolves_free_axes(rule: TakeUpRule) -> bool {
    !matches!(rule, TakeUpRule::Exact { .. })
}

/// `point` (solved for `t_mm` from `q_prev` in state `s_prev`) with every
/// axis but `axis` (the S-curve's) that reverses there held at its command
/// in `q_prev`, in its old direction, and the free axes solved again in
/// that state (the solve's written resolution `quantize`); `point` as it
/// was, those axes merely held, where the free axes solved again would not
/// move as their directions say ([`consistent_state`]). Nothing is done
/// where no other axis reverses.
pub(super) fn hold_across(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    (method, quantize): (Method, &dyn Fn(Vec3) -> Vec3),
    (t_mm, q_prev, s_prev): (Vec3, Vec3, Directions),
    point: &mut PointSolution,
    (axis, resolve): (usize, bool),
) -> Result<(), ModelError> {
    let hold = [0, 1, 2].map(|a| a != axis && point.reversed[a]);
    if !hold.iter().any(|h| *h) {
        return Ok(());
    }
    let mut s = point.s;
    for a in (0..3).filter(|a| hold[*a]) {
        s[a] = s_prev[a];
    }
    if resolve {
        let sol = solve_fixed_in(cells, model, method, t_mm, s, hold, q_prev)?;
        let mut q = quantize(sol.q_mm);
        for a in (0..3).filter(|a| hold[*a]) {
            q[a] = q_prev[a];
        }
        if consistent_state(q, q_prev, s, s_prev, hold) {
            point.q_mm = q;
        } else {
            for a in (0..3).filter(|a| hold[*a]) {
                point.q_mm[a] = q_prev[a];
            }
        }
    } else {
        for a in (0..3).filter(|a| hold[*a]) {
            point.q_mm[a] = q_prev[a];
        }
    }
    point.s = s;
    for a in (0..3).filter(|a| hold[*a]) {
        point.reversed[a] = false;
    }
    Ok(())
}

/// How far the next S-curve of the motion (the first of `transitions` at
/// or after `index`) moves the target of an axis that reverses at this
/// point (`point`, solved from state `s_prev`) further along that axis'
/// new direction (mm; 0 where it moves none so): its axis' switch steps
/// the other axes' targets by its straightness across them, and an axis
/// held here keeps its old command to the S-curve and across it, so the
/// offset the hold leaves grows by that step there.
pub(super) fn step_ahead_mm(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    (transitions, targets, index): (&[super::arcs::Transition], &[Vec3], usize),
    point: &PointSolution,
    s_prev: Directions,
) -> Result<f64, ModelError> {
    let Some(tr) = transitions.iter().find(|tr| tr.index >= index) else {
        return Ok(0.0);
    };
    let Some(&at) = targets.get(tr.index) else {
        return Ok(0.0);
    };
    let mut s_old = point.s;
    s_old[tr.axis] = tr.direction.flipped();
    let mut s_new = s_old;
    s_new[tr.axis] = tr.direction;
    let e_old = cells.deviation_again_um(model, at, s_old)?;
    let e_new = cells.deviation_again_um(model, at, s_new)?;
    let mut step: f64 = 0.0;
    for a in (0..3).filter(|a| *a != tr.axis && point.s[*a] != s_prev[*a]) {
        // The command steps by minus the deviation's change.
        step = step.max(-(e_new[a] - e_old[a]) * 1e-3 * point.s[a].sign());
    }
    Ok(step)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::arcs::Transition;
    use crate::compensate::solve::tests::Plain;
    use crate::model::axis_table::AxisTableMap;
    use crate::model::{Components, Direction};
    use Direction::{Forward as F, Reverse as R};

    /// X: reversal 12 µm, its straightness of Z −1.5 µm forward, +1.5 µm
    /// in reverse; Z: reversal 10 µm, its straightness of X +1.5 µm
    /// forward, −1.5 µm in reverse (bench/coarse_map.py's switches, flat
    /// along the axes); Y flat.
    fn map() -> AxisTableMap {
        let csv = "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
                   X,forward,0,0,0,-1.5\nX,forward,100,0,0,-1.5\n\
                   X,reverse,0,12,0,1.5\nX,reverse,100,12,0,1.5\n\
                   Y,both,0,0,0,0\nY,both,100,0,0,0\n\
                   Z,forward,0,1.5,0,0\nZ,forward,100,1.5,0,0\n\
                   Z,reverse,0,-1.5,0,10\nZ,reverse,100,-1.5,0,10\n";
        AxisTableMap::from_csv(csv, "m.csv").unwrap()
    }

    fn um(x: f64, y: f64, z: f64) -> Vec3 {
        crate::compensate::test_support::um(x, y, z)
    }

    /// The tool where the command `q` in state `s` puts it (no dead band).
    fn actual(m: &AxisTableMap, q: Vec3, s: Directions) -> Vec3 {
        q + m.deviation_um(q, s, Components::All).unwrap() * 1e-3
    }

    #[test]
    fn the_free_axes_are_solved_with_the_held_axis_in_its_old_table() {
        // X's S-curve ends at t, X reverse → forward; Z's target turns up
        // there too (Z reverse → forward) and Z is held. Solved with Z
        // forward, X's command is t − 1.5 µm (Z's forward straightness of
        // X, +1.5); with Z held in reverse that table gives −1.5 µm, so
        // the tool stands 3 µm short in X (by hand). Solved again with Z
        // in reverse, X's command is t + 1.5 µm and the tool on t in X.
        let m = map();
        let plain = Plain(&m);
        let t = Vec3::new(50.0, 50.0, 50.0);
        let s_prev = [R, F, R];
        // Where the piece before left the command: on t's X and Z in the
        // old state (X: 12 − 1.5 = 10.5 µm, Z: 1.5 + 10 = 11.5 µm).
        let q_prev = t - um(10.5, 0.0, 11.5);
        let mut cells = AxisCells::default();
        let s_new = [F, F, F];
        let sol =
            solve_fixed_in(&mut cells, &plain, Method::Exact, t, s_new, [false; 3], t).unwrap();
        let point = PointSolution {
            q_mm: sol.q_mm,
            s: s_new,
            iterations: sol.iterations,
            residual_um: 0.0,
            reversed: [true, false, true],
            held: [false; 3],
        };
        assert!((point.q_mm.x - (50.0 - 1.5e-3)).abs() < 1e-9);
        let id = |q: Vec3| q;
        for resolve in [false, true] {
            let mut p = point;
            hold_across(
                &mut cells,
                &plain,
                (Method::Exact, &id),
                (t, q_prev, s_prev),
                &mut p,
                (0, resolve),
            )
            .unwrap();
            assert_eq!(p.s, [F, F, R]);
            assert_eq!(p.reversed, [true, false, false]);
            assert_eq!(p.q_mm.z, q_prev.z);
            let off_x_um = (actual(&m, p.q_mm, p.s).x - t.x) * 1e3;
            let want_um = if resolve { 0.0 } else { -3.0 };
            assert!((off_x_um - want_um).abs() < 1e-6, "{resolve}: {off_x_um}");
        }
    }

    #[test]
    fn under_g64_the_free_axes_are_solved_in_the_held_axis_old_table_under_g61_not() {
        // The case above per path mode. Z held across X's S-curve in its
        // reverse table: under G64 P and G64 the S-curve's end puts the
        // tool on t in X (X's command t + 1.5 µm, Z's reverse straightness
        // of X −1.5 µm, by hand); under G61 X keeps the command solved in
        // Z's forward table (t − 1.5 µm) and the tool stands 3 µm short
        // in X until the take-up block right after.
        let m = map();
        let plain = Plain(&m);
        let t = Vec3::new(50.0, 50.0, 50.0);
        let s_prev = [R, F, R];
        let q_prev = t - um(10.5, 0.0, 11.5);
        let mut cells = AxisCells::default();
        let s_new = [F, F, F];
        let sol =
            solve_fixed_in(&mut cells, &plain, Method::Exact, t, s_new, [false; 3], t).unwrap();
        let id = |q: Vec3| q;
        for (rule, want_x_um) in [
            (TakeUpRule::Within(5e-3), 0.0),
            (TakeUpRule::Always, 0.0),
            (TakeUpRule::Exact { smooth: true }, -3.0),
            (TakeUpRule::Exact { smooth: false }, -3.0),
        ] {
            let mut p = PointSolution {
                q_mm: sol.q_mm,
                s: s_new,
                iterations: sol.iterations,
                residual_um: 0.0,
                reversed: [true, false, true],
                held: [false; 3],
            };
            hold_across(
                &mut cells,
                &plain,
                (Method::Exact, &id),
                (t, q_prev, s_prev),
                &mut p,
                (0, resolves_free_axes(rule)),
            )
            .unwrap();
            let off_x_um = (actual(&m, p.q_mm, p.s).x - t.x) * 1e3;
            assert!(
                (off_x_um - want_x_um).abs() < 1e-6,
                "{rule:?}: {off_x_um} µm"
            );
        }
    }

    #[test]
    fn an_s_curve_ahead_steps_a_held_axis_target_by_its_straightness() {
        // X turns forward at the S-curve ending at target 2: its table of Z
        // goes from +1.5 to −1.5 µm, so Z's command steps up by 3 µm there
        // (by hand). A Z turning up at target 0 (reverse → forward) is
        // held 3 µm further from its target at the S-curve; one turning
        // down is not.
        let m = map();
        let plain = Plain(&m);
        let targets = [Vec3::new(50.0, 50.0, 50.0); 3];
        let tr = Transition {
            index: 2,
            axis: 0,
            direction: F,
            deviation_mm: 4e-3,
            spread: None,
            widest: false,
        };
        let mut cells = AxisCells::default();
        let point = |s: Directions| PointSolution {
            q_mm: targets[0],
            s,
            iterations: 0,
            residual_um: 0.0,
            reversed: [false, false, true],
            held: [false; 3],
        };
        let step = |s: Directions, s_prev: Directions, cells: &mut AxisCells| {
            step_ahead_mm(cells, &plain, (&[tr], &targets, 0), &point(s), s_prev).unwrap()
        };
        let up = step([R, F, F], [R, F, R], &mut cells);
        assert!((up - 3e-3).abs() < 1e-12, "{}", up * 1e3);
        assert_eq!(step([R, F, R], [R, F, F], &mut cells), 0.0);
        // After the S-curve (none ahead) nothing.
        let none = step_ahead_mm(
            &mut cells,
            &plain,
            (&[tr], &targets, 3),
            &point([R, F, F]),
            [R, F, R],
        );
        assert_eq!(none.unwrap(), 0.0);
    }
}
