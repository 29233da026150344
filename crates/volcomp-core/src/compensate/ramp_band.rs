//! A G61 ramp's excursion read from the commands it writes, where the
//! fold bound refuses it (docs/compensation.md, "A ramp judged by its own
//! commands (G61)").
//!
//! [`super::points`] `plan_ramp` bounds a ramp as a fold into a move of
//! its length: the command taken as running linearly from the reversal to
//! the ramp's end, and the ramp's end where the next target falls (up to
//! half as far again as the tangency needs). On a smooth step (G61) the
//! command catches the take-up up along `3u² − 2u³`, so the reversing
//! carriage reaches its new flank before the ramp's end, and the tool
//! stands still only until then; and the tool stands still while the
//! compensation moves the axis its new way, so what it leaves grows with
//! the square of that time near the axis' turning point. Where the fold
//! bound refuses the ramp, a ramp ending where the tangency needs it to is
//! tried, judged by the dead-band reading of its written commands
//! ([`excursion_mm`]): the model of `crate::simulate` (module
//! documentation) and of bench/eval/judge.py's band reading.

use crate::model::Directions;
use volcomp_gcode::Vec3;

/// The ramps to try, in order, as `(floor_mm, judged_by_commands)`: the
/// ramp at the floor, without it where there is one, and under G61
/// (`exact`) last a ramp that ends where the tangency needs it, judged by
/// [`excursion`] (an array, no allocation: this runs at every ramp).
pub(super) fn tries(floor_mm: f64, exact: bool) -> impl Iterator<Item = (f64, bool)> {
    let n = 1 + usize::from(floor_mm > 0.0) + usize::from(exact);
    let skip = usize::from(floor_mm <= 0.0);
    [(floor_mm, false), (0.0, false), (0.0, true)]
        .into_iter()
        .skip(skip)
        .take(n)
}

/// What a ramp's written commands leave, in the dead-band reading
/// ([`excursion`]): the tool's largest distance from the path and its
/// root mean square along the ramp's length (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Excursion {
    pub(super) max_mm: f64,
    pub(super) rms_mm: f64,
}

/// The tool's distance from the path along a ramp's written commands, in
/// the dead-band reading of `crate::simulate` (module documentation,
/// `Band`) and bench/eval/judge.py: at the reversal the switch of the
/// reversing axes' tables is carried as the lags `lags` (per axis, the
/// jump `e(q₀, s_old) − e(q₀, s_new)`, straightness across included);
/// axis `a`'s lag fades, all its components in proportion, as its command
/// travels its own band `|lags[a][a]|` its new way (`s`) from `q_prev`,
/// and is gone at once where its own component points against that way
/// (a negative reversal value). At each point of the ramp the tool is off
/// the nominal point by the command's offset from the new state's
/// solution there plus the lags left. `points` are the ramp's points in
/// order, each as (nominal point, written command, the new state's
/// solution); between two points the command and the solution run
/// linearly, so the distance is taken at the points and where a band is
/// crossed, across the chord from the point before (`t_prev` before the
/// first; the tool is on the path there). The mean square runs along the
/// chords, the distance linear between two readings (`(a² + ab + b²)/3`
/// per unit length). Both infinite where a band is not crossed by the
/// last point (the tool stands on past the ramp).
pub(super) fn excursion(
    lags: &[Vec3; 3],
    q_prev: Vec3,
    s: Directions,
    t_prev: Vec3,
    points: &[(Vec3, Vec3, Vec3)],
) -> Excursion {
    let own = |a: usize| -> f64 {
        let own = lags[a][a];
        if own * s[a].sign() > 0.0 {
            own.abs()
        } else {
            0.0
        }
    };
    // The travel is counted from the farthest the command went its old
    // way (`turn`): an axis whose command follows its target the old way
    // first (a staged ramp's later axis, compensate/ramp_stage.rs) turns
    // there, its carriage on its old flank until then.
    let left = |q: Vec3, turn: Vec3, a: usize| -> f64 {
        let own = own(a);
        if own == 0.0 {
            return 0.0;
        }
        let travel = ((q[a] - turn[a]) * s[a].sign()).max(0.0);
        (1.0 - travel / own).max(0.0)
    };
    let off = |q: Vec3, sol: Vec3, turn: Vec3| -> Vec3 {
        (0..3).fold(q - sol, |o, a| o + lags[a] * left(q, turn, a))
    };
    let mut turn = q_prev;
    let across = |o: Vec3, u: Vec3| (o - u * o.dot(u)).norm();
    let mut worst = 0.0f64;
    // The integral of the squared distance along the chords, their length,
    // and the last reading.
    let (mut sum_sq, mut length, mut last) = (0.0f64, 0.0f64, 0.0f64);
    let mut add = |d: f64, len: f64, last: &mut f64| {
        sum_sq += len * (*last * *last + *last * d + d * d) / 3.0;
        length += len;
        *last = d;
    };
    let (mut t0, mut q0, mut sol0) = (t_prev, q_prev, q_prev);
    for (k, &(t, q, sol)) in points.iter().enumerate() {
        for a in 0..3 {
            if (q[a] - turn[a]) * s[a].sign() < 0.0 {
                turn[a] = q[a];
            }
        }
        let chord = t - t0;
        let n = chord.norm();
        let u = if n > 0.0 { chord * (1.0 / n) } else { chord };
        // Where a band is crossed inside the piece (in order along it):
        // there the lag is gone and the offset turns.
        let mut at = 0.0f64;
        if k > 0 {
            let mut crossings = [f64::INFINITY; 3];
            for (a, c) in crossings.iter_mut().enumerate() {
                let own = own(a);
                let (t_a, t_b) = (
                    (q0[a] - turn[a]) * s[a].sign(),
                    (q[a] - turn[a]) * s[a].sign(),
                );
                if own > 0.0 && t_a < own && t_b > own {
                    *c = (own - t_a) / (t_b - t_a);
                }
            }
            crossings.sort_by(f64::total_cmp);
            for lambda in crossings.into_iter().filter(|l| l.is_finite()) {
                let qc = q0 + (q - q0) * lambda;
                let sc = sol0 + (sol - sol0) * lambda;
                let d = across(off(qc, sc, turn), u);
                worst = worst.max(d);
                add(d, n * (lambda - at), &mut last);
                at = lambda;
            }
        }
        let d = across(off(q, sol, turn), u);
        worst = worst.max(d);
        add(d, n * (1.0 - at), &mut last);
        (t0, q0, sol0) = (t, q, sol);
    }
    // A band the ramp's end has not crossed: the tool stands on past it,
    // by more than this reads; refused.
    if (0..3).any(|a| left(q0, turn, a) > 0.0) {
        return Excursion {
            max_mm: f64::INFINITY,
            rms_mm: f64::INFINITY,
        };
    }
    Excursion {
        max_mm: worst,
        rms_mm: if length > 0.0 {
            (sum_sq / length).sqrt()
        } else {
            0.0
        },
    }
}

/// Whether a judged ramp's excursion `e` is taken under the ramp's
/// tolerance `tolerance_mm` (the run-through tolerance under G61, 0.4 µm):
/// its largest distance from the path within it, and its root mean square
/// along the ramp within half of it. The maximum alone let through ramps
/// that stand off by 0.2–0.3 µm over their whole 5–7 mm (the shop map's
/// 6.8 µm Z band at F6000): RMS 0.237 µm on g2_d60 and 0.263 µm on
/// rect_rot30, whose band RMS reduction fell below the 99 % target
/// (99.10 → 98.98 %, 99.00 → 98.92 %; bench/eval/run.py, set b), while
/// the ramps at 0.12–0.17 µm (g3_d16, helix_cw_d10, spiral_arcs12) cost
/// 0.1 points at most.
pub(super) fn within(e: Excursion, tolerance_mm: f64) -> bool {
    e.max_mm <= tolerance_mm && e.rms_mm <= 0.5 * tolerance_mm
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Direction;

    #[test]
    fn the_tool_stands_while_the_band_is_crossed_then_follows() {
        // Z reverses upward with a 4 µm band and no straightness across; a
        // line along X. The solution rises 0.1 µm per point over four
        // points; the command catches the 4 µm up as 4, 2.5, 0.5, 0 µm
        // behind the solution. Travel from the reversal (solution 4 µm above
        // the old command there): 0.1, 1.7, 3.8, 4.4 µm; the band is
        // crossed between the third and fourth point at λ = 0.2/0.6, where
        // the command is 0.5·(2/3) = 0.333 µm behind the solution and no
        // lag is left: the tool is 0.333 µm low there; at the third point
        // the command is 0.5 µm behind and 0.2/4 of the 4 µm lag is left
        // (0.2 µm up): 0.3 µm low.
        let up = [Direction::Forward; 3];
        let lags = [Vec3::ZERO, Vec3::ZERO, Vec3::new(0.0, 0.0, 4e-3)];
        let q_prev = Vec3::ZERO;
        let sol = |k: f64| Vec3::new(0.0, 0.0, 4e-3 + 1e-4 * k);
        let behind = [4e-3, 2.5e-3, 0.5e-3, 0.0];
        let points: Vec<(Vec3, Vec3, Vec3)> = (0..4)
            .map(|k| {
                let s = sol(f64::from(k + 1));
                let q = s - Vec3::new(0.0, 0.0, behind[k as usize]);
                (Vec3::new(f64::from(k + 1), 0.0, 0.0), q, s)
            })
            .collect();
        let e = excursion(&lags, q_prev, up, Vec3::ZERO, &points);
        assert!((e.max_mm - 0.5e-3 * 2.0 / 3.0).abs() < 1e-9, "{e:?}");
        // The tool is 0, 0.1, 0.2, 0.3 µm low at X = 0…3, 1/3 µm at the
        // crossing (X = 10/3) and on the path at X = 4, linear between:
        // ∫d² = (0.01 + 0.07 + 0.19)/3 + (1/3)(0.09 + 0.1 + 1/9)/3
        // + (2/3)(1/9)/3 = 4/27 µm²·mm over 4 mm, an RMS of 1/√27 µm.
        let rms_um = (1.0f64 / 27.0).sqrt();
        assert!((e.rms_mm * 1e3 - rms_um).abs() < 1e-9, "{e:?}");
    }

    #[test]
    fn the_judged_ramp_is_tried_last_and_only_under_g61() {
        let all = |f: f64, exact: bool| tries(f, exact).collect::<Vec<_>>();
        assert_eq!(all(0.0, false), [(0.0, false)]);
        assert_eq!(all(0.0, true), [(0.0, false), (0.0, true)]);
        assert_eq!(all(2.0, false), [(2.0, false), (0.0, false)]);
        assert_eq!(all(2.0, true), [(2.0, false), (0.0, false), (0.0, true)]);
    }

    #[test]
    fn a_ramp_standing_off_along_its_length_is_refused() {
        // Under the 0.4 µm run-through tolerance: a ramp whose largest
        // distance is 0.37 µm and its RMS 0.24 µm (above 0.2 µm) stands
        // off along its length; at RMS 0.17 µm it is taken; at 0.41 µm
        // largest it is not, whatever its RMS.
        let tol = 0.4e-3;
        let e = |max_um: f64, rms_um: f64| Excursion {
            max_mm: max_um * 1e-3,
            rms_mm: rms_um * 1e-3,
        };
        assert!(!within(e(0.37, 0.24), tol));
        assert!(within(e(0.37, 0.17), tol));
        assert!(!within(e(0.41, 0.1), tol));
    }

    #[test]
    fn the_step_across_fades_with_the_reversing_axis_band() {
        // X reverses (band 4 µm) on a path along Y, and its switch moves
        // the tool 0.3 µm in Z. A command that carries the whole switch
        // (Z 0.3 µm behind the new solution at the start) leaves nothing
        // at the reversal; one that writes Z's new solution at once leaves
        // the 0.3 µm of Z's lag until X has crossed its band.
        let down = [Direction::Reverse; 3];
        let lags = [Vec3::new(-4e-3, 0.0, 0.3e-3), Vec3::ZERO, Vec3::ZERO];
        let sol = Vec3::new(-4e-3, 0.0, 0.3e-3);
        // At the second point X has crossed its band onto the solution.
        let t = Vec3::new(0.0, 0.2, 0.0);
        let end = (Vec3::new(0.0, 0.4, 0.0), sol, sol);
        let carried = excursion(
            &lags,
            Vec3::ZERO,
            down,
            Vec3::ZERO,
            &[(t, Vec3::ZERO, sol), end],
        )
        .max_mm;
        assert!(carried < 1e-12, "{carried}");
        let q = Vec3::new(0.0, 0.0, 0.3e-3);
        let at_once = excursion(&lags, Vec3::ZERO, down, Vec3::ZERO, &[(t, q, sol), end]).max_mm;
        assert!((at_once - 0.3e-3).abs() < 1e-12, "{at_once}");
        // Where X has not crossed its band by the last point, the tool
        // stands on past the ramp: refused.
        let short = excursion(&lags, Vec3::ZERO, down, Vec3::ZERO, &[(t, q, sol)]).max_mm;
        assert!(short.is_infinite(), "{short}");
    }

    #[test]
    fn an_axis_that_follows_its_target_the_old_way_first_turns_where_it_went_farthest() {
        // Y reverses upward with a 2 µm band on a line along X, its target
        // still drifting 0.5 µm down to X 1 (a staged ramp's later axis,
        // ramp_stage.rs): the command follows it down to −0.5 µm (the new
        // state's solution there, 1.5 µm, less the 2 µm lag), then rises to
        // the solution at X 2. By hand: the carriage turns at −0.5 µm and
        // crosses its 2 µm band exactly at X 2; on the way the offset is
        // q − 1.5 + 2·(1 − (q + 0.5)/2) = 0: the tool on the path
        // throughout. Counted from the ramp's start instead, the band
        // would read 1.5 µm crossed at X 2 (a quarter of the lag left, the
        // ramp refused as never crossing).
        let up = [Direction::Forward; 3];
        let lags = [Vec3::ZERO, Vec3::new(0.0, 2e-3, 0.0), Vec3::ZERO];
        let sol = Vec3::new(0.0, 1.5e-3, 0.0);
        let points = [
            (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, -0.5e-3, 0.0), sol),
            (Vec3::new(2.0, 0.0, 0.0), sol, sol),
        ];
        let e = excursion(&lags, Vec3::ZERO, up, Vec3::ZERO, &points);
        assert!(e.max_mm < 1e-12 && e.rms_mm < 1e-12, "{e:?}");
    }

    #[test]
    fn a_cross_lag_is_carried_until_the_standing_axis_crosses_its_band() {
        // A line along X; Y (band 2 µm) and Z (band 6 µm) reverse upward
        // together, and Y's switch moves the Z error by c = 0.4 µm: lags
        // Y (0, 2, 0.4) µm, Z (0, 0, 6) µm. No drift: the new state's
        // solution stands at the take-up Δ = (0, 2, 6.4) µm above the old
        // command. By hand, one step σ for both axes: Y's lag is left
        // 1 − σ, Z's 1 − 6.4σ/6; the tool's Z is off by
        // −6.4(1 − σ) + 0.4(1 − σ) + 6(1 − 6.4σ/6) = −0.4σ until Z
        // crosses its band at σ = 6/6.4, then by −6(1 − σ): largest
        // 0.4·6/6.4 = 0.375 µm, at any ramp length.
        let up = [Direction::Forward; 3];
        let um = |y: f64, z: f64| Vec3::new(0.0, y * 1e-3, z * 1e-3);
        let lags = [Vec3::ZERO, um(2.0, 0.4), um(0.0, 6.0)];
        let sol = um(2.0, 6.4);
        let common = |n: u32| -> Vec<(Vec3, Vec3, Vec3)> {
            (1..=n)
                .map(|k| {
                    let sigma = f64::from(k) / f64::from(n);
                    (Vec3::new(f64::from(k), 0.0, 0.0), sol * sigma, sol)
                })
                .collect()
        };
        for n in [4, 8] {
            let e = excursion(&lags, Vec3::ZERO, up, Vec3::ZERO, &common(n));
            assert!((e.max_mm - 0.375e-3).abs() < 1e-12, "{n} points: {e:?}");
        }
        // Staged: Z's own 6 µm first (points 1–4), then Y's 2 µm with
        // Z's 0.4 µm that Y's switch moves (points 5–8). Z has crossed
        // its band before Y moves, and its command follows Y's lag as it
        // fades: the tool stays on the path (Y: −2(1 − σ) + 2(1 − σ); Z:
        // −0.4(1 − σ) + 0.4(1 − σ)).
        let staged: Vec<(Vec3, Vec3, Vec3)> = (1..=8)
            .map(|k| {
                let (z_own, y) = if k <= 4 {
                    (f64::from(k) / 4.0, 0.0)
                } else {
                    (1.0, f64::from(k - 4) / 4.0)
                };
                let q = um(2.0 * y, 6.0 * z_own + 0.4 * y);
                (Vec3::new(f64::from(k), 0.0, 0.0), q, sol)
            })
            .collect();
        let e = excursion(&lags, Vec3::ZERO, up, Vec3::ZERO, &staged);
        assert!(e.max_mm < 1e-12, "{e:?}");
    }
}
