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

/// Solves a point so that each axis' table direction is the direction of the
/// command actually sent from `q_prev` (after `quantize`, which maps a command
/// onto what the written program will really command).
///
/// The state of an axis is kept while that is consistent; only an axis whose
/// command would contradict its state is flipped; an axis for which neither
/// direction is consistent is held at its previous command and reported.
pub fn solve_consistent(
    model: &dyn ErrorModel,
    method: Method,
    t_mm: Vec3,
    q_prev: Vec3,
    s_prev: Directions,
    quantize: &dyn Fn(Vec3) -> Vec3,
) -> Result<PointSolution, ModelError> {
    let mut s = s_prev;
    let mut hold = [false; 3];
    let mut flipped = [false; 3];
    let mut last = None;
    for _round in 0..4 {
        let sol = solve_fixed(model, method, t_mm, s, hold, q_prev)?;
        let q = quantize(sol.q_mm);
        let mut consistent = true;
        for a in 0..3 {
            if hold[a] {
                continue;
            }
            let d = Direction::of_delta(q[a] - q_prev[a]);
            if let Some(d) = d {
                if d != s[a] {
                    consistent = false;
                    if flipped[a] {
                        // Both directions contradict themselves: hold the axis.
                        hold[a] = true;
                        s[a] = s_prev[a];
                    } else {
                        flipped[a] = true;
                        s[a] = d;
                    }
                }
            }
        }
        last = Some((sol, q));
        if consistent {
            break;
        }
    }
    let (sol, mut q) = last.unwrap_or_else(|| unreachable!("the loop runs at least once"));
    for a in 0..3 {
        if hold[a] {
            q[a] = q_prev[a];
        }
    }
    let reversed = [0, 1, 2].map(|a| s[a] != s_prev[a]);
    let residual_um = (t_mm - actual_mm(model, q, s, Components::All)?).norm() * 1e3;
    Ok(PointSolution {
        q_mm: q,
        s,
        iterations: sol.iterations,
        residual_um,
        reversed,
        held: hold,
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
}
