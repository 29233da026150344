//! Point compensation (docs/design.md, "Compensation"): find the command `q` with `q + e(q, s) = t`.
//!
//! * direct ([Seed papers], docs/references.md): `q = t − e(t, s)`
//! * ILC ([Lu & Yeh 2018], docs/references.md): `q₀ = t`, `q_{i+1} = q_i + γ·(t − (q_i + e(q_i, s)))`,
//!   stopped when the residual falls under the tolerance or stops decreasing
//! * exact: the same iteration with γ = 1 (a contraction, since |∂e/∂q| ≪ 1
//!   for any real machine), run to the tolerance; failing to reach it is an error
//! * pitch: exact, with only E_XX, E_YY, E_ZZ
//!
//! [`solve_consistent`] wraps them so that the direction state the tables were
//! chosen by is the direction of the command actually sent (docs/design.md, "Direction state and backlash").

use crate::error::ModelError;
use crate::model::{actual_mm, Components, Direction, Directions, ErrorModel};
use volcomp_gcode::Vec3;

/// How a point is compensated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    /// One step with the error at the target.
    Direct,
    /// Iterative learning control with gain `gain` (0 < γ ≤ 1).
    Ilc {
        /// γ.
        gain: f64,
        /// Iteration limit.
        max_iterations: u32,
    },
    /// Iterate to the tolerance with every component.
    Exact,
    /// Iterate to the tolerance with the positioning errors only.
    Pitch,
}

/// Residual under which a solve has converged (mm): 1 nm, far below any
/// controller's resolution.
pub const TOLERANCE_MM: f64 = 1e-6;

/// Result of one fixed-direction solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solved {
    /// Command (axis frame, mm).
    pub q_mm: Vec3,
    /// Iterations used (1 for direct).
    pub iterations: u32,
    /// `‖t − (q + e(q, s))‖` with the full model, in µm.
    pub residual_um: f64,
}

impl Method {
    fn components(self) -> Components {
        match self {
            Method::Pitch => Components::PositioningOnly,
            _ => Components::All,
        }
    }
}

/// Solves `q + e(q, s) = t` for fixed `s`, keeping the axes in `hold` at
/// `held_q` (their residual is then whatever it is).
pub fn solve_fixed(
    model: &dyn ErrorModel,
    method: Method,
    t_mm: Vec3,
    s: Directions,
    hold: [bool; 3],
    held_q: Vec3,
) -> Result<Solved, ModelError> {
    let comps = method.components();
    let fix = |mut q: Vec3| {
        for a in 0..3 {
            if hold[a] {
                q[a] = held_q[a];
            }
        }
        q
    };
    let residual =
        |q: Vec3| -> Result<Vec3, ModelError> { Ok(t_mm - actual_mm(model, q, s, comps)?) };
    let free_norm = |r: Vec3| {
        let mut r = r;
        for a in 0..3 {
            if hold[a] {
                r[a] = 0.0;
            }
        }
        r.norm()
    };
    let (q, iterations) = match method {
        Method::Direct => {
            let e = model.deviation_um(fix(t_mm), s, comps)? * 1e-3;
            (fix(t_mm - e), 1)
        }
        Method::Ilc {
            gain,
            max_iterations,
        } => {
            let mut q = fix(t_mm);
            let mut r = residual(q)?;
            let mut it = 0;
            while it < max_iterations && free_norm(r) > TOLERANCE_MM {
                let next = fix(q + r * gain);
                let r_next = residual(next)?;
                it += 1;
                if free_norm(r_next) >= free_norm(r) {
                    break;
                }
                q = next;
                r = r_next;
            }
            (q, it)
        }
        Method::Exact | Method::Pitch => {
            let mut q = fix(t_mm);
            let mut r = residual(q)?;
            let mut it = 0;
            while free_norm(r) > TOLERANCE_MM * 1e-3 && it < 60 {
                q = fix(q + r);
                r = residual(q)?;
                it += 1;
            }
            (q, it)
        }
    };
    let full = t_mm - actual_mm(model, q, s, Components::All)?;
    Ok(Solved {
        q_mm: q,
        iterations,
        residual_um: full.norm() * 1e3,
    })
}

/// A compensated point whose directions agree with the tables used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointSolution {
    /// Command (axis frame, mm), already on the output grid.
    pub q_mm: Vec3,
    /// Direction state after the move to `q`.
    pub s: Directions,
    /// Iterations of the last solve.
    pub iterations: u32,
    /// Residual with the full model (µm).
    pub residual_um: f64,
    /// Axes that reversed on this move.
    pub reversed: [bool; 3],
    /// Axes held still because no consistent reversal exists (negative
    /// reversal value smaller than the wanted motion).
    pub held: [bool; 3],
}

/// One candidate of [`solve_consistent`]: a direction state and the axes
/// held, solved.
struct Candidate {
    sol: Solved,
    q: Vec3,
    s: Directions,
    hold: [bool; 3],
    residual_um: f64,
}

/// Whether the command `q` from `q_prev` moves every free axis in the
/// direction its table was chosen for: a moving axis in `s[a]`, an axis
/// that stands still in its previous state (the controller keeps the last
/// direction while an axis stands, as LinuxCNC's `compute_screw_comp`
/// does).
fn consistent(q: Vec3, q_prev: Vec3, s: Directions, s_prev: Directions, hold: [bool; 3]) -> bool {
    (0..3).all(|a| {
        hold[a]
            || match Direction::of_delta(q[a] - q_prev[a]) {
                Some(d) => d == s[a],
                None => s[a] == s_prev[a],
            }
    })
}

/// Residual (µm) two candidates may differ by and still count as equally
/// good: 1 nm, the solver's own tolerance.
const SAME_RESIDUAL_UM: f64 = TOLERANCE_MM * 1e3;

/// Solves a point so that each axis' table direction is the direction of the
/// command actually sent from `q_prev` (after `quantize`, which maps a command
/// onto what the written program will really command).
///
/// The search is exhaustive over the 2³ direction states: the previous state
/// first (kept when it is consistent), then every other one; among the
/// consistent ones the one with the smallest residual wins, and of those
/// within 1 nm of it the one that reverses the fewest axes. Only when no
/// state is consistent is an axis held at its previous command (one axis,
/// then two, then three, each with every state of the free axes): that
/// happens where the compensated model's reverse error lies below its
/// forward one by more than the wanted motion (a negative reversal value),
/// so that no command can reverse by that little.
pub fn solve_consistent(
    model: &dyn ErrorModel,
    method: Method,
    t_mm: Vec3,
    q_prev: Vec3,
    s_prev: Directions,
    quantize: &dyn Fn(Vec3) -> Vec3,
) -> Result<PointSolution, ModelError> {
    let first_error: std::cell::RefCell<Option<ModelError>> = Default::default();
    let solve = |s: Directions, hold: [bool; 3]| -> Option<Candidate> {
        match solve_fixed(model, method, t_mm, s, hold, q_prev) {
            Ok(sol) => {
                let mut q = quantize(sol.q_mm);
                for a in 0..3 {
                    if hold[a] {
                        q[a] = q_prev[a];
                    }
                }
                if !consistent(q, q_prev, s, s_prev, hold) {
                    return None;
                }
                let residual_um = match actual_mm(model, q, s, Components::All) {
                    Ok(actual) => (t_mm - actual).norm() * 1e3,
                    Err(e) => {
                        first_error.borrow_mut().get_or_insert(e);
                        return None;
                    }
                };
                Some(Candidate {
                    sol,
                    q,
                    s,
                    hold,
                    residual_um,
                })
            }
            Err(e) => {
                first_error.borrow_mut().get_or_insert(e);
                None
            }
        }
    };
    let flips = |s: &Directions| (0..3).filter(|&a| s[a] != s_prev[a]).count();
    // Every state, the previous one first, then by the number of flips.
    let mut states: Vec<Directions> = (0..8u8)
        .map(|bits| {
            [0, 1, 2].map(|a| {
                if bits & (1 << a) != 0 {
                    s_prev[a].flipped()
                } else {
                    s_prev[a]
                }
            })
        })
        .collect();
    states.sort_by_key(flips);
    let pick = |found: Vec<Candidate>| -> Option<Candidate> {
        let best = found
            .iter()
            .map(|c| c.residual_um)
            .fold(f64::INFINITY, f64::min);
        found
            .into_iter()
            .filter(|c| c.residual_um <= best + SAME_RESIDUAL_UM)
            .min_by_key(|c| (c.hold.iter().filter(|h| **h).count(), flips(&c.s)))
    };
    // The previous state is kept while it is consistent; otherwise every
    // other state is tried.
    let mut chosen = solve(s_prev, [false; 3]);
    if chosen.is_none() {
        let found: Vec<Candidate> = states[1..]
            .iter()
            .filter_map(|s| solve(*s, [false; 3]))
            .collect();
        chosen = pick(found);
    }
    // A command outside the model's range is an error, not a reason to
    // hold an axis (a held axis would stand far from its target).
    if chosen.is_none() {
        if let Some(e) = first_error.borrow_mut().take() {
            return Err(e);
        }
    }
    // No consistent state: hold one axis, then two, then all three.
    for held in 1..=3 {
        if chosen.is_some() {
            break;
        }
        let mut found = Vec::new();
        for mask in (1..8u8).filter(|m| m.count_ones() == held) {
            let hold = [0, 1, 2].map(|a| mask & (1 << a) != 0);
            let mut seen: Vec<Directions> = Vec::new();
            for s in &states {
                // A held axis keeps its previous state.
                let s = [0, 1, 2].map(|a| if hold[a] { s_prev[a] } else { s[a] });
                if seen.contains(&s) {
                    continue;
                }
                seen.push(s);
                found.extend(solve(s, hold));
            }
        }
        chosen = pick(found);
    }
    let Some(c) = chosen else {
        // Holding every axis is always consistent: only a model error (a
        // command outside the model's range in every state) gets here.
        return Err(first_error
            .into_inner()
            .unwrap_or_else(|| unreachable!("holding every axis is consistent")));
    };
    let reversed = [0, 1, 2].map(|a| c.s[a] != s_prev[a]);
    Ok(PointSolution {
        q_mm: c.q,
        s: c.s,
        iterations: c.sol.iterations,
        residual_um: c.residual_um,
        reversed,
        held: c.hold,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ALL_FORWARD;

    /// A test model: constant offset plus optional backlash on X and a linear term.
    struct Toy {
        offset_um: Vec3,
        backlash_x_um: f64,
        slope_um_per_mm: f64,
    }

    impl ErrorModel for Toy {
        fn deviation_um(&self, q: Vec3, s: Directions, c: Components) -> Result<Vec3, ModelError> {
            let mut e = self.offset_um + Vec3::new(self.slope_um_per_mm * q.x, 0.0, 0.0);
            if s[0] == Direction::Reverse {
                e.x += self.backlash_x_um;
            }
            if c == Components::PositioningOnly {
                e.y = 0.0;
                e.z = 0.0;
            }
            Ok(e)
        }
        fn range_mm(&self) -> [[f64; 2]; 3] {
            [[-1e3, 1e3]; 3]
        }
    }

    /// A constant error on a map measured over 0 … 100 mm on every axis.
    struct Edge;

    impl ErrorModel for Edge {
        fn deviation_um(&self, q: Vec3, _: Directions, _: Components) -> Result<Vec3, ModelError> {
            for (a, v) in [q.x, q.y, q.z].into_iter().enumerate() {
                if !(0.0..=100.0).contains(&v) {
                    return Err(ModelError::OutOfRange {
                        axis: ['X', 'Y', 'Z'][a],
                        position_mm: v,
                        min_mm: 0.0,
                        max_mm: 100.0,
                    });
                }
            }
            Ok(Vec3::new(5.0, 0.0, 0.0))
        }
        fn range_mm(&self) -> [[f64; 2]; 3] {
            [[0.0, 100.0]; 3]
        }
    }

    #[test]
    fn a_command_off_the_map_is_an_error_not_a_held_axis() {
        // X errs +5 µm: the command for the target X0 is X−0.005, off the
        // map in every direction state. Holding X at 50 would be
        // "consistent" 50 mm from the target; the range error is the answer.
        let e = solve_consistent(
            &Edge,
            Method::Exact,
            Vec3::new(0.0, 50.0, 50.0),
            Vec3::new(50.0, 50.0, 50.0),
            ALL_FORWARD,
            &|q| q,
        )
        .unwrap_err();
        let ModelError::OutOfRange {
            axis, position_mm, ..
        } = e;
        assert_eq!(axis, 'X');
        assert!((position_mm + 0.005).abs() < 1e-12, "{position_mm}");
        // Inside the map the same target is met exactly.
        let p = solve_consistent(
            &Edge,
            Method::Exact,
            Vec3::new(10.0, 50.0, 50.0),
            Vec3::new(50.0, 50.0, 50.0),
            ALL_FORWARD,
            &|q| q,
        )
        .unwrap();
        assert!((p.q_mm.x - 9.995).abs() < 1e-12 && p.held == [false; 3]);
    }

    #[test]
    fn constant_offset_is_removed_exactly_by_every_method() {
        let m = Toy {
            offset_um: Vec3::new(5.0, -3.0, 2.0),
            backlash_x_um: 0.0,
            slope_um_per_mm: 0.0,
        };
        let t = Vec3::new(10.0, 20.0, 30.0);
        for method in [
            Method::Direct,
            Method::Exact,
            Method::Ilc {
                gain: 1.0,
                max_iterations: 5,
            },
        ] {
            let s = solve_fixed(&m, method, t, ALL_FORWARD, [false; 3], Vec3::ZERO).unwrap();
            assert!(
                (s.q_mm - Vec3::new(9.995, 20.003, 29.998)).norm() < 1e-12,
                "{method:?}"
            );
        }
        let s = solve_fixed(&m, Method::Pitch, t, ALL_FORWARD, [false; 3], Vec3::ZERO).unwrap();
        // Pitch only removes the X/Y/Z positioning parts of the constant offset,
        // which for this model are e.x only (e.y, e.z are straightness here).
        assert!((s.q_mm.x - 9.995).abs() < 1e-12 && s.q_mm.y == 20.0);
    }

    #[test]
    fn ilc_converges_on_a_contraction_as_the_geometric_series() {
        // e_x = k·q_x with k = 0.01 (10 µm/mm, exaggerated): the exact solution
        // is q = t/(1+k); ILC with gain γ has error factor |1 − γ(1+k)| per step.
        let k = 0.01;
        let m = Toy {
            offset_um: Vec3::ZERO,
            backlash_x_um: 0.0,
            slope_um_per_mm: k * 1e3,
        };
        let t = Vec3::new(100.0, 0.0, 0.0);
        let exact = 100.0 / (1.0 + k);
        let gain = 0.5;
        let s = solve_fixed(
            &m,
            Method::Ilc {
                gain,
                max_iterations: 3,
            },
            t,
            ALL_FORWARD,
            [false; 3],
            Vec3::ZERO,
        )
        .unwrap();
        let factor: f64 = 1.0 - gain * (1.0 + k);
        let expected = exact + (100.0 - exact) * factor.powi(3);
        assert!(
            (s.q_mm.x - expected).abs() < 1e-9,
            "{} vs {}",
            s.q_mm.x,
            expected
        );
        let s = solve_fixed(&m, Method::Exact, t, ALL_FORWARD, [false; 3], Vec3::ZERO).unwrap();
        assert!((s.q_mm.x - exact).abs() < 1e-9);
    }

    #[test]
    fn backlash_reversal_is_taken_in_the_commanded_direction() {
        // Reverse error 4 µm above forward (normal backlash). Coming from
        // q = 10 forward, a target 1 µm lower must be commanded 5 µm lower.
        let m = Toy {
            offset_um: Vec3::ZERO,
            backlash_x_um: 4.0,
            slope_um_per_mm: 0.0,
        };
        let q_prev = Vec3::new(10.0, 0.0, 0.0);
        let t = Vec3::new(9.999, 0.0, 0.0);
        let id = |q: Vec3| q;
        let p = solve_consistent(&m, Method::Exact, t, q_prev, ALL_FORWARD, &id).unwrap();
        assert_eq!(p.s[0], Direction::Reverse);
        assert!((p.q_mm.x - 9.995).abs() < 1e-9);
        assert!(p.reversed[0] && !p.held[0]);
    }

    #[test]
    fn negative_reversal_value_holds_the_axis() {
        // Reverse error 4 µm BELOW forward: a reversal of 1 µm is impossible.
        let m = Toy {
            offset_um: Vec3::ZERO,
            backlash_x_um: -4.0,
            slope_um_per_mm: 0.0,
        };
        let q_prev = Vec3::new(10.0, 0.0, 0.0);
        let t = Vec3::new(9.999, 0.0, 0.0);
        let id = |q: Vec3| q;
        let p = solve_consistent(&m, Method::Exact, t, q_prev, ALL_FORWARD, &id).unwrap();
        assert!(p.held[0]);
        assert_eq!(p.q_mm.x, 10.0);
        assert_eq!(p.s[0], Direction::Forward);
        assert!((p.residual_um - 1.0).abs() < 1e-6);
        // A reversal larger than the reversal value is consistent.
        let t = Vec3::new(9.990, 0.0, 0.0);
        let p = solve_consistent(&m, Method::Exact, t, q_prev, ALL_FORWARD, &id).unwrap();
        assert!(!p.held[0] && p.s[0] == Direction::Reverse);
        assert!((p.q_mm.x - 9.994).abs() < 1e-9);
    }

    /// X's error depends on Y's direction (−3 µm while Y runs in reverse);
    /// X has a reversal value of 1 µm, Y of 2 µm.
    struct Coupled;

    impl ErrorModel for Coupled {
        fn deviation_um(
            &self,
            _q: Vec3,
            s: Directions,
            _c: Components,
        ) -> Result<Vec3, ModelError> {
            let rev = |a: usize| s[a] == Direction::Reverse;
            let ex = if rev(0) { 1.0 } else { 0.0 } + if rev(1) { -3.0 } else { 0.0 };
            let ey = if rev(1) { 2.0 } else { 0.0 };
            Ok(Vec3::new(ex, ey, 0.0))
        }
        fn range_mm(&self) -> [[f64; 2]; 3] {
            [[-1e3, 1e3]; 3]
        }
    }

    #[test]
    fn a_consistent_state_is_found_where_flipping_every_axis_fails() {
        // From q = 0 moving forward (errors 0), targets 1 µm lower in X and Y.
        // (F, F): both move −1 µm, against their state. (R, R): X moves
        // −1 − (1 − 3) = +1 µm, against R: flipping both fails, and holding
        // X would leave it 1 µm off. (F, R) is consistent: X moves
        // −1 + 3 = +2 µm forward, Y −1 − 2 = −3 µm in reverse; exact.
        let id = |q: Vec3| q;
        let t = Vec3::new(-0.001, -0.001, 0.0);
        let p = solve_consistent(&Coupled, Method::Exact, t, Vec3::ZERO, ALL_FORWARD, &id).unwrap();
        assert_eq!(
            p.s,
            [Direction::Forward, Direction::Reverse, Direction::Forward]
        );
        assert_eq!(p.held, [false; 3]);
        assert!(p.residual_um < 1e-6, "{p:?}");
        assert!(
            (p.q_mm.x - 0.002).abs() < 1e-12 && (p.q_mm.y - -0.003).abs() < 1e-12,
            "{p:?}"
        );
        assert_eq!(p.reversed, [false, true, false]);
    }

    #[test]
    fn a_standing_axis_keeps_its_state() {
        // Y does not move: a state that flips it is not consistent, even
        // though the command is the same.
        let m = Toy {
            offset_um: Vec3::ZERO,
            backlash_x_um: 4.0,
            slope_um_per_mm: 0.0,
        };
        let id = |q: Vec3| q;
        let s_prev = [Direction::Forward, Direction::Reverse, Direction::Forward];
        let p = solve_consistent(
            &m,
            Method::Exact,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::ZERO,
            s_prev,
            &id,
        )
        .unwrap();
        assert_eq!(p.s, s_prev);
        assert_eq!(p.reversed, [false; 3]);
    }
}
