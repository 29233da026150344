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
use crate::model::{AxisCells, Components, Direction, Directions, ErrorModel};
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

/// The exact iteration's test `‖r‖ > TOLERANCE_MM · 10⁻³` (mm) without the
/// square root: the largest `f64` whose correctly rounded square root
/// (IEEE 754, §5.4.1; `f64::sqrt`) is not above `TOLERANCE_MM · 10⁻³`,
/// two units in the last place above that bound squared. The root is
/// monotone, so `‖r‖² > CONVERGED_SQUARED_MM2` is `‖r‖ > TOLERANCE_MM ·
/// 10⁻³` for every `‖r‖²`, NaN (false) and infinity (true) included: the
/// same decisions to the bit. The square root held back the loop's branch
/// on real cores (its sampled hot spot, BENCHMARKS.md); checked by
/// `the_squared_bound_decides_as_the_root_does`.
const CONVERGED_SQUARED_MM2: f64 = 1.000_000_000_000_000_3e-18;

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
    solve_fixed_in(
        &mut AxisCells::default(),
        model,
        method,
        t_mm,
        s,
        hold,
        held_q,
    )
}

/// [`solve_fixed`] with the model evaluated in `cells` (kept between
/// solves of `model`: the same values to the bit, [`AxisCells`]). The
/// iteration's points lie micrometres apart, so they nearly always fall
/// in the cells the last point used.
pub(crate) fn solve_fixed_in(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    method: Method,
    t_mm: Vec3,
    s: Directions,
    hold: [bool; 3],
    held_q: Vec3,
) -> Result<Solved, ModelError> {
    fixed_inline(cells, model, method, t_mm, s, hold, held_q)
}

/// [`solve_fixed_in`] inlined: for the walk to a consistent state
/// ([`solve_consistent_in`]), which calls it ~113,000 times on a CAM
/// program of 67,000 lines, the held solve ([`held_solve`], ~29,000) and
/// the search of the states ([`search_states`], ~21,000): the call's
/// saving and restoring of registers and its result through memory are
/// saved there.
#[inline(always)]
fn fixed_inline(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    method: Method,
    t_mm: Vec3,
    s: Directions,
    hold: [bool; 3],
    held_q: Vec3,
) -> Result<Solved, ModelError> {
    let comps = method.components();
    // Most solves hold no axis: then `fix` and `free_norm` are the
    // identity and the norm, tested once here instead of per axis and step.
    let none_held = hold == [false; 3];
    let fix = |mut q: Vec3| {
        if none_held {
            return q;
        }
        for a in 0..3 {
            if hold[a] {
                q[a] = held_q[a];
            }
        }
        q
    };
    // The free axes' residual squared: its root is their norm
    // ([`Vec3::norm`], the same sum).
    let free_squared = |r: Vec3| {
        if none_held {
            return r.norm_squared();
        }
        let mut r = r;
        for a in 0..3 {
            if hold[a] {
                r[a] = 0.0;
            }
        }
        r.norm_squared()
    };
    let free_norm = |r: Vec3| free_squared(r).sqrt();
    let residual = |cells: &mut AxisCells, q: Vec3| residual_in(cells, model, t_mm, q, (s, comps));
    // The residual at the final command when the method's model is the
    // full one (then it is the residual this reports: not evaluated again).
    let (q, iterations, full) = match method {
        Method::Direct => {
            let e = cells.deviation_um(model, fix(t_mm), s, comps)? * 1e-3;
            (fix(t_mm - e), 1, None)
        }
        Method::Ilc {
            gain,
            max_iterations,
        } => {
            let mut q = fix(t_mm);
            let mut r = residual(cells, q)?;
            let mut it = 0;
            while it < max_iterations && free_norm(r) > TOLERANCE_MM {
                let next = fix(q + r * gain);
                let r_next = residual(cells, next)?;
                it += 1;
                if free_norm(r_next) >= free_norm(r) {
                    break;
                }
                q = next;
                r = r_next;
            }
            (q, it, Some(r))
        }
        Method::Exact | Method::Pitch => {
            let mut q = fix(t_mm);
            // The first step at the target itself, where the split of its
            // move may have evaluated the map last
            // ([`AxisCells::deviation_end_um`]).
            let kept = (comps == Components::All && none_held)
                .then(|| cells.end_um(q, s))
                .flatten();
            let mut r = match kept {
                Some(e_um) => t_mm - (q + e_um * 1e-3),
                None => residual(cells, q)?,
            };
            let mut it = 0;
            // `free_norm(r) > TOLERANCE_MM * 1e-3`, without the root.
            while free_squared(r) > CONVERGED_SQUARED_MM2 && it < 60 {
                q = fix(q + r);
                r = residual(cells, q)?;
                it += 1;
            }
            (q, it, (comps == Components::All).then_some(r))
        }
    };
    let full = match full {
        Some(r) => r,
        None => t_mm - cells.actual_mm(model, q, s, Components::All)?,
    };
    Ok(Solved {
        q_mm: q,
        iterations,
        residual_um: full.norm() * 1e3,
    })
}

/// `t − (q + e(q, s))` with the method's components (mm), evaluated in
/// `cells` ([`AxisCells::actual_mm`]): inlined into the solve's
/// iterations. As a closure it was a call of its own, whose saving and
/// restoring of registers and result passed through memory cost about a
/// fifth of its instructions (~140 a call, ~600,000 calls on a CAM
/// program of 67,000 lines).
#[inline(always)]
fn residual_in(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    t_mm: Vec3,
    q_mm: Vec3,
    (s, comps): (Directions, Components),
) -> Result<Vec3, ModelError> {
    Ok(t_mm - cells.actual_mm(model, q_mm, s, comps)?)
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
/// command would contradict its state is flipped. Flipping one axis changes
/// the errors the others see (a transverse table depends on the direction of
/// the axis it belongs to), so flipping every inconsistent axis at once can
/// overshoot: when that walk ends with an axis it would hold, or without a
/// consistent state, every direction state is tried (fewest reversals first,
/// then the smallest residual) and the first consistent one is taken. Only
/// when no state is consistent is an axis held at its previous command and
/// reported: that happens where the compensated model's reverse error lies
/// below its forward one by more than the wanted motion (a negative reversal
/// value), so that no command can reverse by that little.
pub fn solve_consistent(
    model: &dyn ErrorModel,
    method: Method,
    t_mm: Vec3,
    q_prev: Vec3,
    s_prev: Directions,
    quantize: &dyn Fn(Vec3) -> Vec3,
) -> Result<PointSolution, ModelError> {
    solve_consistent_in(
        &mut AxisCells::default(),
        model,
        method,
        t_mm,
        (q_prev, s_prev),
        quantize,
    )
}

/// [`solve_consistent`] with the model evaluated in `cells` (kept between
/// solves of `model`, [`AxisCells`]).
///
/// Generic in `quantize`: the walk's closure (the line's
/// [`super::frame::Frame::quantize`]) is inlined into the rounds, not
/// called through a pointer, at ~150,000 solves of a CAM program of 67,000
/// lines; `&dyn Fn` is taken too.
///
/// The first round (the state before, no axis held) is solved here; where
/// its command is consistent with that state (three points in five of a
/// CAM program: 48,114 of the 79,823 points cam20k's motions solve), the
/// point is taken from it.
/// Every other case walks on out of line ([`walk_to_consistent`]): the
/// rounds kept for the state search and the search itself stay out of the
/// caller's stack frame, so that the hot path's data do not move with the
/// layout of what the solves are inlined into (a 16-byte copy of a kept
/// round crossing a cache line cost 3–5 % of the compensating thread's
/// time on real cores, BENCHMARKS.md).
/// The same solves in the same order as one loop over the rounds: the same
/// bits.
pub(crate) fn solve_consistent_in<Q: Fn(Vec3) -> Vec3 + ?Sized>(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    method: Method,
    t_mm: Vec3,
    (q_prev, s_prev): (Vec3, Directions),
    quantize: &Q,
) -> Result<PointSolution, ModelError> {
    let sol = fixed_inline(cells, model, method, t_mm, s_prev, [false; 3], q_prev)?;
    let q = quantize(sol.q_mm);
    // Every moving axis in its state before: then no axis flips, none is
    // held and the state is consistent ([`consistent_state`] with `s` =
    // `s_prev`: an axis standing still keeps its state), so the walk
    // would stop here and search no state.
    let consistent = (0..3).all(|a| match Direction::of_delta(q[a] - q_prev[a]) {
        Some(d) => d == s_prev[a],
        None => true,
    });
    if !consistent {
        return walk_to_consistent(
            cells,
            model,
            method,
            t_mm,
            (q_prev, s_prev),
            quantize,
            (sol, q),
        );
    }
    // The command a reversal after it is taken up from ([`AxisCells::deviation_again_um`]).
    let residual_um = (t_mm - cells.actual_again_mm(model, q, s_prev)?).norm() * 1e3;
    Ok(PointSolution {
        q_mm: q,
        s: s_prev,
        iterations: sol.iterations,
        residual_um,
        reversed: [false; 3],
        held: [false; 3],
    })
}

/// [`solve_consistent_in`] past a first round (`first`: its solve in
/// `s_prev` with no axis held, and its command quantized) whose command
/// contradicts the state before: the axes that contradict their state are
/// flipped, and solved again, for up to four rounds; an axis that
/// contradicts both its directions is held. Where that walk holds an
/// axis, ends inconsistent or flipped several axes, the state search
/// ([`search_states`]) decides. (Out of line: see
/// [`solve_consistent_in`]. Marked cold although two points in five of a
/// CAM program take it: so marked, the caller's hot path keeps the layout
/// measured fastest, `--quiet compensate` of bench's 1,011,376-line CAM
/// program 1,430 against 1,512 ms of task-clock unmarked, with the same
/// instructions (BENCHMARKS.md).)
#[cold]
#[inline(never)]
fn walk_to_consistent<Q: Fn(Vec3) -> Vec3 + ?Sized>(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    method: Method,
    t_mm: Vec3,
    (q_prev, s_prev): (Vec3, Directions),
    quantize: &Q,
    first: (Solved, Vec3),
) -> Result<PointSolution, ModelError> {
    let mut s = s_prev;
    let mut hold = [false; 3];
    let mut flipped = [false; 3];
    let mut last = None;
    let mut first = Some(first);
    // The rounds solved with no axis held: [`search_states`] takes their
    // states' solves from here (the same function of the same arguments).
    let mut tried: [Option<Tried>; 4] = [None; 4];
    for kept in &mut tried {
        let (sol, q) = match first.take() {
            // The first round: `s_prev`, no axis held.
            Some(round) => round,
            None => {
                let sol = fixed_inline(cells, model, method, t_mm, s, hold, q_prev)?;
                (sol, quantize(sol.q_mm))
            }
        };
        if hold == [false; 3] {
            *kept = Some((s, sol, q));
        }
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
    let (mut sol, mut q) = last.unwrap_or_else(|| unreachable!("the loop runs at least once"));
    for a in 0..3 {
        if hold[a] {
            q[a] = q_prev[a];
        }
    }
    let walked_to_consistent = consistent_state(q, q_prev, s, s_prev, hold);
    // A walk that flipped several axes may have flipped one only because
    // another was still in its old state (the other's transverse table
    // changes what it needs): the state with the fewest reversals is the
    // one a dead band holds. An axis whose command reverses by less than
    // its own band never leaves the flank it was pushing, so its carriage
    // runs on the old direction's table (docs/compensation.md, "Directions
    // done right").
    let flips = flipped.iter().filter(|f| **f).count();
    if hold.contains(&true) || !walked_to_consistent || flips > 1 {
        if let Some((found_sol, found_q, found_s)) = search_states(
            cells,
            model,
            method,
            t_mm,
            (q_prev, s_prev),
            (&|q| quantize(q), &tried),
            [false; 3],
        )? {
            sol = found_sol;
            q = found_q;
            s = found_s;
            hold = [false; 3];
        }
    }
    let reversed = [0, 1, 2].map(|a| s[a] != s_prev[a]);
    // The command a reversal after it is taken up from ([`AxisCells::deviation_again_um`]).
    let residual_um = (t_mm - cells.actual_again_mm(model, q, s)?).norm() * 1e3;
    Ok(PointSolution {
        q_mm: q,
        s,
        iterations: sol.iterations,
        residual_um,
        reversed,
        held: hold,
    })
}

/// The point with its reversing axes held where a reversal would only
/// follow a command change smaller than the axis' own reversal value, or
/// `None` where it would not (docs/compensation.md, "Small reversals
/// held").
///
/// An axis whose command turns back by less than its dead band never
/// leaves the flank it was pushing: its carriage stays where it is
/// whatever the command does. Reversing it anyway costs the whole band
/// (the take-up) for a target change of a fraction of it, and the planner
/// sees the take-up as a kink or a lead piece. Holding the axis at its
/// command in its old direction leaves the tool off the target by the
/// change alone: the held point is taken where that error stays within
/// `bound_mm` and within the band of every held axis (beyond it a
/// reversal would move the carriage). Since the next point starts from
/// the held command, the hold lasts until the target has moved back by
/// more than that in total; a target that turns forward again runs on
/// without any reversal.
///
/// Every reversing axis is held together first, then each alone; the
/// axes left free are solved again with the held ones in their old
/// state (a transverse table changes what they need) and must stay
/// consistent ([`consistent_state`]).
pub fn hold_small_reversals(
    model: &dyn ErrorModel,
    method: Method,
    t_mm: Vec3,
    (q_prev, s_prev): (Vec3, Directions),
    quantize: &dyn Fn(Vec3) -> Vec3,
    point: &PointSolution,
    bound_mm: f64,
) -> Result<Option<PointSolution>, ModelError> {
    hold_small_reversals_in(
        &mut AxisCells::default(),
        model,
        method,
        t_mm,
        (q_prev, s_prev),
        quantize,
        (point, bound_mm),
    )
}

/// [`hold_small_reversals`] with the model evaluated in `cells` (kept
/// between solves of `model`, [`AxisCells`]).
pub(crate) fn hold_small_reversals_in(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    method: Method,
    t_mm: Vec3,
    (q_prev, s_prev): (Vec3, Directions),
    quantize: &dyn Fn(Vec3) -> Vec3,
    (point, bound_mm): (&PointSolution, f64),
) -> Result<Option<PointSolution>, ModelError> {
    let reversing = [0, 1, 2].map(|a| point.reversed[a] && !point.held[a]);
    let count = reversing.iter().filter(|r| **r).count();
    if count == 0 || bound_mm <= 0.0 {
        return Ok(None);
    }
    let band_um = bands_um(cells, model, (q_prev, s_prev), reversing)?;
    // Every reversing axis together, then (of several) each alone.
    let alone = (0..3)
        .filter(|a| count > 1 && reversing[*a])
        .map(|a| [0, 1, 2].map(|b| b == a));
    for set in std::iter::once(reversing).chain(alone) {
        let mut s = point.s;
        for a in (0..3).filter(|a| set[*a]) {
            s[a] = s_prev[a];
        }
        let held = held_solve(
            cells,
            model,
            (method, quantize),
            (t_mm, s, set),
            (q_prev, s_prev),
            (bound_mm, band_um, point.residual_um),
        )?;
        if held.is_some() {
            return Ok(held);
        }
    }
    Ok(None)
}

/// The dead band each axis of `axes` crosses if it reverses at `q_prev`
/// (the change of its own deviation between its two tables there), in µm;
/// 0 for the other axes.
pub(crate) fn bands_um(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    (q_prev, s_prev): (Vec3, Directions),
    axes: [bool; 3],
) -> Result<[f64; 3], ModelError> {
    let at_prev = cells.deviation_again_um(model, q_prev, s_prev)?;
    let mut band_um = [0.0; 3];
    for a in (0..3).filter(|a| axes[*a]) {
        let mut s = s_prev;
        s[a] = s[a].flipped();
        band_um[a] = (cells.deviation_again_um(model, q_prev, s)?[a] - at_prev[a]).abs();
    }
    Ok(band_um)
}

/// `t_mm` solved in the states `s` with the axes of `hold` held at their
/// command in `q_prev` (their table unchanged), if the result is one a
/// held reversal may take: the free axes move as their states say
/// ([`consistent_state`]), the tool lands within `bound_mm` of `t_mm`,
/// each held axis within its band `band_um` (it stays inside the dead
/// band, docs/design.md), and the free axes about as close as the
/// unheld solve (`point_residual_um`, the written resolution aside: a
/// solve that did not converge is never hidden behind a hold).
pub(super) fn held_solve(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    (method, quantize): (Method, &dyn Fn(Vec3) -> Vec3),
    (t_mm, s, hold): (Vec3, Directions, [bool; 3]),
    (q_prev, s_prev): (Vec3, Directions),
    (bound_mm, band_um, point_residual_um): (f64, [f64; 3], f64),
) -> Result<Option<PointSolution>, ModelError> {
    let sol = fixed_inline(cells, model, method, t_mm, s, hold, q_prev)?;
    let mut q = quantize(sol.q_mm);
    for a in (0..3).filter(|a| hold[*a]) {
        q[a] = q_prev[a];
    }
    if !consistent_state(q, q_prev, s, s_prev, hold) {
        return Ok(None);
    }
    let r_mm = t_mm - cells.actual_mm(model, q, s, Components::All)?;
    let mut free_mm = r_mm;
    for a in (0..3).filter(|a| hold[*a]) {
        free_mm[a] = 0.0;
    }
    if r_mm.norm() > bound_mm
        || (0..3).any(|a| hold[a] && r_mm[a].abs() * 1e3 >= band_um[a])
        || free_mm.norm() * 1e3 > 2.0 * point_residual_um + 0.05
    {
        return Ok(None);
    }
    Ok(Some(PointSolution {
        q_mm: q,
        s,
        iterations: sol.iterations,
        residual_um: r_mm.norm() * 1e3,
        reversed: [0, 1, 2].map(|a| s[a] != s_prev[a]),
        held: [false; 3],
    }))
}

/// `s_prev` with the axes whose bit is set in `bits` (bit `a` for axis
/// `a`) in their other direction: one of the eight direction states a
/// search over the axes' states tries.
pub(super) fn flipped_where(s_prev: Directions, bits: u8) -> Directions {
    [0, 1, 2].map(|a| {
        if bits & (1 << a) != 0 {
            s_prev[a].flipped()
        } else {
            s_prev[a]
        }
    })
}

/// Whether the command `q` from `q_prev` moves every free axis in the
/// direction its table was chosen for: a moving axis in `s[a]`, an axis that
/// stands still in its previous state (a controller keeps an axis' last
/// direction while it stands, as LinuxCNC's `compute_screw_comp` in
/// src/emc/motion/control.c does).
pub(super) fn consistent_state(
    q: Vec3,
    q_prev: Vec3,
    s: Directions,
    s_prev: Directions,
    hold: [bool; 3],
) -> bool {
    (0..3).all(|a| {
        hold[a]
            || match Direction::of_delta(q[a] - q_prev[a]) {
                Some(d) => d == s[a],
                None => s[a] == s_prev[a],
            }
    })
}

/// The point solved in the consistent direction state with the fewest
/// reversals from `s_prev` in which the `keep` axes keep their direction
/// (the smallest residual among equals), or `None` where no such state is
/// consistent: the state a dead band leaves where a reversal of a `keep`
/// axis would not carry its carriage across its band (docs/compensation.md,
/// "Take-ups folded into the move").
pub(crate) fn solve_keeping_in(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    method: Method,
    t_mm: Vec3,
    (q_prev, s_prev): (Vec3, Directions),
    quantize: &dyn Fn(Vec3) -> Vec3,
    keep: [bool; 3],
) -> Result<Option<PointSolution>, ModelError> {
    let Some((sol, q, s)) = search_states(
        cells,
        model,
        method,
        t_mm,
        (q_prev, s_prev),
        (quantize, &[]),
        keep,
    )?
    else {
        return Ok(None);
    };
    let residual_um = (t_mm - cells.actual_again_mm(model, q, s)?).norm() * 1e3;
    Ok(Some(PointSolution {
        q_mm: q,
        s,
        iterations: sol.iterations,
        residual_um,
        reversed: [0, 1, 2].map(|a| s[a] != s_prev[a]),
        held: [false; 3],
    }))
}

/// The eight bit sets of flipped axes ([`flipped_where`]) by how many
/// axes they flip, then by value.
const BITS_BY_FLIPS: [u8; 8] = [0, 1, 2, 4, 3, 5, 6, 7];

/// A state solved for a target with no axis held: the state, its solve and
/// the solve's command quantized ([`search_states`] takes it as it is).
type Tried = (Directions, Solved, Vec3);

/// The consistent direction state with the fewest reversals from `s_prev`
/// (the smallest residual among equals), with no axis held and no `keep`
/// axis reversed; `None` when no such state of the 2³ is consistent.
/// `tried` holds states already solved for `t_mm` with no axis held, with
/// their solves and quantized commands: taken as they are (a solve is a
/// function of its arguments alone, the kept cells giving the map's
/// values to the bit), not solved again.
fn search_states(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    method: Method,
    t_mm: Vec3,
    (q_prev, s_prev): (Vec3, Directions),
    (quantize, tried): (&dyn Fn(Vec3) -> Vec3, &[Option<Tried>]),
    keep: [bool; 3],
) -> Result<Option<(Solved, Vec3, Directions)>, ModelError> {
    let mut best: Option<(usize, f64, Solved, Vec3, Directions)> = None;
    // Fewest flips first (in the order of their bits within a count): once
    // a state is consistent, none with more flips can be taken, so none is
    // solved. The states taken and the ties' order are those of a search
    // of all eight.
    for bits in BITS_BY_FLIPS {
        if (0..3).any(|a| keep[a] && bits & (1 << a) != 0) {
            continue;
        }
        let s = flipped_where(s_prev, bits);
        let flips = bits.count_ones() as usize;
        if best.as_ref().is_some_and(|b| b.0 < flips) {
            break;
        }
        let known = tried.iter().flatten().find(|(known_s, ..)| *known_s == s);
        let (sol, q) = match known {
            Some((_, sol, q)) => (*sol, *q),
            None => {
                let sol = fixed_inline(cells, model, method, t_mm, s, [false; 3], q_prev)?;
                (sol, quantize(sol.q_mm))
            }
        };
        if !consistent_state(q, q_prev, s, s_prev, [false; 3]) {
            continue;
        }
        let residual_um = (t_mm - cells.actual_mm(model, q, s, Components::All)?).norm() * 1e3;
        let better = match &best {
            None => true,
            Some(b) => flips < b.0 || (flips == b.0 && residual_um < b.1),
        };
        if better {
            best = Some((flips, residual_um, sol, q, s));
        }
    }
    Ok(best.map(|(_, _, sol, q, s)| (sol, q, s)))
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::model::axis_table::AxisTableMap;
    use crate::model::{ByDirection, ALL_FORWARD};

    /// An axis-table map without its cells: every residual looked up
    /// through the whole map (the second method the cell paths are
    /// checked against).
    pub(in crate::compensate) struct Plain<'a>(pub &'a AxisTableMap);
    impl ErrorModel for Plain<'_> {
        fn deviation_um(&self, q: Vec3, s: Directions, c: Components) -> Result<Vec3, ModelError> {
            self.0.deviation_um(q, s, c)
        }
        fn range_mm(&self) -> [[f64; 2]; 3] {
            self.0.range_mm()
        }
    }

    /// Uniform numbers in [0, 1) from a xorshift generator (Marsaglia
    /// 2003): reproducible random cases for the tests.
    pub(in crate::compensate) fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

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

    /// The map of the search tests: reversal values and straightness
    /// that differ with each axis' direction, so that several direction
    /// states are consistent for a small move.
    fn search_map() -> AxisTableMap {
        let csv = "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
                   X,forward,0,0,0,0\nX,forward,10,3,1,0\n\
                   X,reverse,0,4,-1,0\nX,reverse,10,6,2,0\n\
                   Y,forward,0,0,0,0\nY,forward,10,0,2,0.5\n\
                   Y,reverse,0,0,3,0\nY,reverse,10,0.4,4,0\n\
                   Z,forward,0,0,0,0\nZ,forward,10,0,0,1\n\
                   Z,reverse,0,0,0,2\nZ,reverse,10,0,0,2.5\n";
        AxisTableMap::from_csv(csv, "m.csv").unwrap()
    }

    /// A previous command inside the search map's tables, a target within
    /// ±5 µm of it on each axis and a random direction state: the start
    /// of the search tests' cases.
    fn random_start(rnd: &mut impl FnMut() -> f64) -> (Vec3, Vec3, Directions) {
        let q_prev = Vec3::new(1.0 + 8.0 * rnd(), 1.0 + 8.0 * rnd(), 1.0 + 8.0 * rnd());
        let t = q_prev + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 0.01;
        let s_prev = [0, 1, 2].map(|_| {
            if rnd() < 0.5 {
                Direction::Forward
            } else {
                Direction::Reverse
            }
        });
        (q_prev, t, s_prev)
    }

    #[test]
    fn the_search_takes_the_state_a_search_of_all_eight_takes() {
        // The second method: every one of the eight states solved through
        // the whole map (no cells), the consistent ones ranked by flips,
        // then residual, then the bit set's value (the first found wins
        // a tie, as in a search of all eight in the order of their bits).
        let m = search_map();
        let mut rnd = uniform(0x5ea2_c4ed);
        let quantize = |q: Vec3| q.map(|v| (v * 1e5).round() / 1e5);
        let (mut found, mut two_flips, mut kept_out) = (0, 0, 0);
        for case in 0..3000 {
            let (q_prev, t, s_prev) = random_start(&mut rnd);
            let keep = if case % 3 == 0 {
                [0, 1, 2].map(|_| rnd() < 0.3)
            } else {
                [false; 3]
            };
            let mut all = Vec::new();
            for bits in 0..8u8 {
                if (0..3).any(|a| keep[a] && bits & (1 << a) != 0) {
                    continue;
                }
                let s = [0, 1, 2].map(|a| {
                    if bits & (1 << a) != 0 {
                        s_prev[a].flipped()
                    } else {
                        s_prev[a]
                    }
                });
                let sol = solve_fixed(&Plain(&m), Method::Exact, t, s, [false; 3], q_prev).unwrap();
                let q = quantize(sol.q_mm);
                if consistent_state(q, q_prev, s, s_prev, [false; 3]) {
                    let r = (t - (q + m.deviation_um(q, s, Components::All).unwrap() * 1e-3))
                        .norm()
                        * 1e3;
                    all.push((bits.count_ones(), r, bits, q, s));
                }
            }
            all.sort_by(|a, b| (a.0, a.1, a.2).partial_cmp(&(b.0, b.1, b.2)).unwrap());
            let want = all.first().map(|c| (c.3, c.4));
            let got = search_states(
                &mut AxisCells::default(),
                &m,
                Method::Exact,
                t,
                (q_prev, s_prev),
                (&quantize, &[]),
                keep,
            )
            .unwrap()
            .map(|(_, q, s)| (q, s));
            assert_eq!(got, want, "{t:?} from {q_prev:?} {s_prev:?}, keep {keep:?}");
            found += usize::from(got.is_some());
            two_flips += usize::from(all.first().is_some_and(|c| c.0 >= 2));
            kept_out += usize::from(keep.contains(&true) && got.is_some());
        }
        assert!(
            found > 1000 && two_flips > 20 && kept_out > 100,
            "{found} {two_flips} {kept_out}"
        );
    }

    /// The search takes a state's solve from `tried` as the solve itself
    /// gives it: on the axis tables with backlash and a transverse table
    /// that depends on X's direction, 2,000 random targets a few
    /// micrometres from a previous command in random states, the search
    /// with every state's solve given (by `solve_fixed_in`, the second
    /// method) and with none finds the same point, state and solve.
    #[test]
    fn the_search_takes_given_solves_as_solved() {
        let m = search_map();
        let mut rnd = uniform(0x0bad_5eed);
        let quantize = |q: Vec3| q.map(|v| (v * 1e5).round() / 1e5);
        let (mut found, mut given) = (0, 0);
        for _ in 0..2000 {
            let (q_prev, t, s_prev) = random_start(&mut rnd);
            let mut cells = AxisCells::default();
            let mut tried = Vec::new();
            for bits in 0..8u8 {
                if rnd() < 0.5 {
                    let s = [0, 1, 2].map(|a| {
                        if bits & (1 << a) != 0 {
                            s_prev[a].flipped()
                        } else {
                            s_prev[a]
                        }
                    });
                    let sol =
                        solve_fixed_in(&mut cells, &m, Method::Exact, t, s, [false; 3], q_prev)
                            .unwrap();
                    tried.push(Some((s, sol, quantize(sol.q_mm))));
                }
            }
            given += tried.len();
            let args = (q_prev, s_prev);
            let with = search_states(
                &mut cells,
                &m,
                Method::Exact,
                t,
                args,
                (&quantize, &tried),
                [false; 3],
            )
            .unwrap();
            let without = search_states(
                &mut AxisCells::default(),
                &m,
                Method::Exact,
                t,
                args,
                (&quantize, &[]),
                [false; 3],
            )
            .unwrap();
            assert_eq!(with, without, "{t:?} from {q_prev:?} {s_prev:?}");
            found += usize::from(with.is_some());
        }
        assert!(found > 1000 && given > 5000, "{found} {given}");
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

    /// On the axis tables the solve computes its residuals in the cells
    /// and lands on the plain iteration's command to the bit, with its
    /// iteration count, across a table point, with held axes, for both
    /// exact methods. By hand: X's table rises 1 µm per mm (E_XX) and
    /// 0.5 µm per mm across in Y (E_XY) below 6 mm: for t = (5.005,
    /// 2.0025, 0), q_x + 0.001·q_x = 5.005 gives q_x = 5 and q_y + 0.0005·5
    /// = 2.0025 gives q_y = 2.
    #[test]
    fn the_solve_in_the_cells_is_the_plain_iteration() {
        use crate::model::axis_table::AxisTableMap;
        let csv = "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
                   X,both,0,0,0,0\nX,both,6,6,3,0\nX,both,10,2,3,0\n\
                   Y,both,-10,0,0,0\nY,both,10,0,0,0\nZ,both,-10,0,0,0\nZ,both,10,0,0,0\n";
        let m = AxisTableMap::from_csv(csv, "m.csv").unwrap();
        let t = Vec3::new(5.005, 2.0025, 0.0);
        let s = solve_fixed(&m, Method::Exact, t, ALL_FORWARD, [false; 3], Vec3::ZERO).unwrap();
        assert!(
            (s.q_mm - Vec3::new(5.0, 2.0, 0.0)).norm() < 1e-9,
            "{:?}",
            s.q_mm
        );
        let held = Vec3::new(1.0, 1.0, 1.0);
        for (t, hold) in [
            (Vec3::new(5.005, 2.0025, 0.0), [false; 3]),
            // On the table point at 6 mm: the command lies in the cell below.
            (Vec3::new(6.0, 0.0, 0.0), [false; 3]),
            (Vec3::new(7.5, -3.0, 1.0), [false; 3]),
            (Vec3::new(7.5, -3.0, 1.0), [false, true, false]),
            (Vec3::new(2.0, 4.0, -1.0), [true, false, false]),
        ] {
            for method in [Method::Exact, Method::Pitch] {
                let a = solve_fixed(&m, method, t, ALL_FORWARD, hold, held).unwrap();
                let b = solve_fixed(&Plain(&m), method, t, ALL_FORWARD, hold, held).unwrap();
                assert_eq!(a, b, "{t:?} {hold:?} {method:?}");
            }
        }
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

    /// Y's error depends on X's direction (a transverse table of X), with no
    /// negative reversal value anywhere: X's reverse error lies 4 µm above
    /// its forward one, and Y is 2·δ lower while X runs in reverse.
    fn transverse(delta_um: f64) -> ByDirection<impl Fn(Directions) -> Vec3 + Send + Sync> {
        ByDirection(move |s: Directions| {
            let x_reverse = s[0] == Direction::Reverse;
            Vec3::new(
                if x_reverse { 4.0 } else { 0.0 },
                if x_reverse { -2.0 * delta_um } else { 0.0 },
                0.0,
            )
        })
    }

    #[test]
    fn a_consistent_state_is_found_when_flipping_every_inconsistent_axis_overshoots() {
        // Hand calculation. From q = (10, 10), both axes last in reverse, the
        // target is (10.010, 10 − δ), δ = 0.3 µm.
        // Keeping (R, R): e = (4, −0.6) µm → q = (10.006, 10.0003): both axes
        //   would move forward, both inconsistent.
        // Flipping both, (F, F): e = 0 → q = (10.010, 9.9997): Y now moves in
        //   reverse, against its state: a walk that flips every inconsistent
        //   axis at once holds Y here (0.3 µm left).
        // (F, R): e = 0 → q = (10.010, 9.9997): X forward, Y reverse, both as
        //   chosen: consistent, with one reversal and nothing left.
        let m = transverse(0.3);
        let q_prev = Vec3::new(10.0, 10.0, 0.0);
        let s_prev = [Direction::Reverse, Direction::Reverse, Direction::Forward];
        let t = Vec3::new(10.010, 10.0 - 0.3e-3, 0.0);
        let id = |q: Vec3| q;
        let p = solve_consistent(&m, Method::Exact, t, q_prev, s_prev, &id).unwrap();
        assert_eq!(p.held, [false; 3]);
        assert_eq!(
            p.s,
            [Direction::Forward, Direction::Reverse, Direction::Forward]
        );
        assert_eq!(p.reversed, [true, false, false]);
        assert!(
            (p.q_mm - Vec3::new(10.010, 9.9997, 0.0)).norm() < 1e-9,
            "{:?}",
            p.q_mm
        );
        assert!(p.residual_um < 1e-3, "{}", p.residual_um);
    }

    /// X's reverse error 3 µm above its forward one, and Y 0.3 µm higher
    /// while X runs in reverse (a transverse table of X); Y's reverse error
    /// 4 µm above its forward one.
    fn two_bands() -> ByDirection<impl Fn(Directions) -> Vec3 + Send + Sync> {
        ByDirection(|s: Directions| {
            let x_reverse = s[0] == Direction::Reverse;
            let y_reverse = s[1] == Direction::Reverse;
            Vec3::new(
                if x_reverse { 3.0 } else { 0.0 },
                if x_reverse { 0.3 } else { 0.0 } + if y_reverse { 4.0 } else { 0.0 },
                0.0,
            )
        })
    }

    #[test]
    fn an_axis_that_would_reverse_by_less_than_its_band_keeps_its_direction() {
        // Hand calculation. From q = (10, 10) with X in reverse and Y forward,
        // the target is (11, 10.0001).
        // Keeping (R, F): e = (3, 0.3) µm → q = (10.997, 9.9998): X moves
        //   forward and Y back, both against their states; the walk flips
        //   both.
        // (F, R): e = (0, 4) → q = (11, 9.9961): consistent by sign, but
        //   Y's command reverses by 3.9 µm, less than its 4 µm band, so its
        //   carriage never leaves the flank it was pushing forward.
        // (F, F): e = 0 → q = (11, 10.0001): Y moves on forward by 0.1 µm,
        //   consistent with one reversal: the state the dead band holds.
        // (R, R): e = (3, 4.3) → q = (10.997, 9.9958): X forward, inconsistent.
        let m = two_bands();
        let q_prev = Vec3::new(10.0, 10.0, 0.0);
        let s_prev = [Direction::Reverse, Direction::Forward, Direction::Forward];
        let t = Vec3::new(11.0, 10.0001, 0.0);
        let id = |q: Vec3| q;
        let p = solve_consistent(&m, Method::Exact, t, q_prev, s_prev, &id).unwrap();
        assert_eq!(p.s, [Direction::Forward; 3]);
        assert_eq!(p.reversed, [true, false, false]);
        assert!(
            (p.q_mm - Vec3::new(11.0, 10.0001, 0.0)).norm() < 1e-9,
            "{:?}",
            p.q_mm
        );
    }

    /// Z's reverse error 2 µm above its forward one (its band), nothing else.
    fn z_band(band_um: f64) -> ByDirection<impl Fn(Directions) -> Vec3 + Send + Sync> {
        ByDirection(move |s: Directions| {
            Vec3::new(
                0.0,
                0.0,
                if s[2] == Direction::Reverse {
                    band_um
                } else {
                    0.0
                },
            )
        })
    }

    /// Solves `t` from `(q_prev, s_prev)` as the program's points are: the
    /// consistent point, then the hold within `bound_mm`.
    fn solve_with_hold(
        m: &dyn ErrorModel,
        t: Vec3,
        q_prev: Vec3,
        s_prev: Directions,
        bound_mm: f64,
    ) -> (PointSolution, bool) {
        let id = |q: Vec3| q;
        let p = solve_consistent(m, Method::Exact, t, q_prev, s_prev, &id).unwrap();
        match hold_small_reversals(m, Method::Exact, t, (q_prev, s_prev), &id, &p, bound_mm)
            .unwrap()
        {
            Some(h) => (h, true),
            None => (p, false),
        }
    }

    #[test]
    fn a_reversal_smaller_than_the_band_is_held_until_the_change_passes_the_bound() {
        // Hand calculation. Z last moved forward at 5 mm (its error 0 there);
        // X runs on while the target's Z sinks by 0.3 µm, then 0.6 µm, then
        // comes back to 5.0001. Z's band is 2 µm; the bound 0.4 µm.
        // Point 1 without the hold: Z must turn back, its command
        //   5 − 0.0003 − 0.002 = 4.9977 (a take-up of the whole band for
        //   0.3 µm). Held: Z stays at 5 forward, the tool 0.3 µm above the
        //   target (< 0.4 and < 2): held.
        // Point 2: held, it would be 0.6 µm off (> 0.4): Z reverses from 5,
        //   command 5 − 0.0006 − 0.002 = 4.9974.
        // Point 2 from the hold of point 1 instead, with a target back at
        //   5.0001: Z moves on forward to 5.0001, no reversal at all.
        let m = z_band(2.0);
        let q0 = Vec3::new(10.0, 10.0, 5.0);
        let s0 = ALL_FORWARD;
        let bound = 0.4e-3;
        let t1 = Vec3::new(10.1, 10.0, 5.0 - 0.3e-3);
        let (unheld, _) = solve_with_hold(&m, t1, q0, s0, 0.0);
        assert!(unheld.reversed[2] && (unheld.q_mm.z - 4.9977).abs() < 1e-9);
        let (p1, held) = solve_with_hold(&m, t1, q0, s0, bound);
        assert!(held);
        assert_eq!(p1.reversed, [false; 3]);
        assert_eq!(p1.s, ALL_FORWARD);
        assert!(
            (p1.q_mm - Vec3::new(10.1, 10.0, 5.0)).norm() < 1e-12,
            "{:?}",
            p1.q_mm
        );
        assert!((p1.residual_um - 0.3).abs() < 1e-6, "{}", p1.residual_um);
        let t2 = Vec3::new(10.2, 10.0, 5.0 - 0.6e-3);
        let (p2, held) = solve_with_hold(&m, t2, p1.q_mm, p1.s, bound);
        assert!(!held && p2.reversed[2] && p2.s[2] == Direction::Reverse);
        assert!((p2.q_mm.z - 4.9974).abs() < 1e-9, "{:?}", p2.q_mm);
        let t2 = Vec3::new(10.2, 10.0, 5.0001);
        let (p2, held) = solve_with_hold(&m, t2, p1.q_mm, p1.s, bound);
        assert!(!held && p2.reversed == [false; 3]);
        assert!((p2.q_mm.z - 5.0001).abs() < 1e-12);
    }

    #[test]
    fn a_bound_above_the_band_holds_while_the_change_stays_within_the_band() {
        // G64 P0.005: a bound of 4.9 µm, above the band (2 µm). Hand
        // calculation:
        // a target 1.5 µm lower is held (Z stays at 5 forward, the tool
        // 1.5 µm above it: less than the band, so the carriage never left
        // its flank); 2.5 µm lower it reverses, to
        // 5 − 0.0025 − 0.002 = 4.9955.
        let m = z_band(2.0);
        let q0 = Vec3::new(10.0, 10.0, 5.0);
        let t = Vec3::new(10.1, 10.0, 5.0 - 1.5e-3);
        let (p, held) = solve_with_hold(&m, t, q0, ALL_FORWARD, 4.9e-3);
        assert!(held && p.s == ALL_FORWARD && (p.q_mm.z - 5.0).abs() < 1e-12);
        assert!((p.residual_um - 1.5).abs() < 1e-6, "{}", p.residual_um);
        let t = Vec3::new(10.1, 10.0, 5.0 - 2.5e-3);
        let (p, held) = solve_with_hold(&m, t, q0, ALL_FORWARD, 4.9e-3);
        assert!(!held && p.reversed[2]);
        assert!((p.q_mm.z - 4.9955).abs() < 1e-9, "{:?}", p.q_mm);
    }

    #[test]
    fn a_change_as_large_as_the_band_is_taken_as_a_reversal() {
        // Z's band 0.2 µm: turning back by 0.3 µm moves the carriage, so it
        // is no hold even within the bound: the command is
        // 5 − 0.0003 − 0.0002 = 4.9995, in reverse.
        let m = z_band(0.2);
        let t = Vec3::new(10.1, 10.0, 5.0 - 0.3e-3);
        let (p, held) = solve_with_hold(&m, t, Vec3::new(10.0, 10.0, 5.0), ALL_FORWARD, 0.4e-3);
        assert!(!held && p.reversed[2]);
        assert!((p.q_mm.z - 4.9995).abs() < 1e-9, "{:?}", p.q_mm);
    }

    /// The exact iteration's squared bound takes the decisions the
    /// tolerance on the root took: its root is within the tolerance, the
    /// next `f64`'s is not (so no square in between decides otherwise, the
    /// root being monotone), and on squares around it, spread over the
    /// residuals a solve meets, and NaN and infinity, both tests agree.
    /// (The bound squared, `1e-18`, fails: two squares above it have roots
    /// within the tolerance.)
    #[test]
    fn the_squared_bound_decides_as_the_root_does() {
        let tol = TOLERANCE_MM * 1e-3;
        assert!(CONVERGED_SQUARED_MM2.sqrt() <= tol);
        assert!(CONVERGED_SQUARED_MM2.next_up().sqrt() > tol);
        assert!((tol * tol).next_up().sqrt() <= tol);
        let mut x = CONVERGED_SQUARED_MM2;
        for _ in 0..1000 {
            x = x.next_down();
        }
        for _ in 0..2000 {
            assert_eq!(x > CONVERGED_SQUARED_MM2, x.sqrt() > tol, "{x:e}");
            x = x.next_up();
        }
        let mut rnd = uniform(0x9e37_79b9_7f4a_7c15);
        for _ in 0..100_000 {
            let r = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 10f64.powf(-12.0 * rnd());
            let n2 = r.norm_squared();
            assert_eq!(n2 > CONVERGED_SQUARED_MM2, r.norm() > tol, "{r:?}");
        }
        for x in [f64::NAN, f64::INFINITY, 0.0, -0.0, f64::MIN_POSITIVE] {
            assert_eq!(x > CONVERGED_SQUARED_MM2, x.sqrt() > tol, "{x:e}");
        }
    }

    /// The first round's short path in [`solve_consistent_in`] takes the
    /// point the walk over the rounds takes from the same first round (the
    /// second method: [`walk_to_consistent`] run on every point, those
    /// whose first round is consistent included), on 3,000 random starts of
    /// the search map with three methods, the cells kept from one solve to
    /// the next as the compensation keeps them; both paths taken often.
    #[test]
    fn the_first_rounds_short_path_is_the_walks_point() {
        let m = search_map();
        let mut rnd = uniform(0x51de_0f1a_77c3);
        let quantize = |q: Vec3| q.map(|v| (v * 1e5).round() / 1e5);
        let mut cells = AxisCells::default();
        let (mut short, mut walked) = (0, 0);
        for _ in 0..3000 {
            let (q_prev, t, s_prev) = random_start(&mut rnd);
            for method in [Method::Exact, Method::Pitch, Method::Direct] {
                let from = (q_prev, s_prev);
                let a = solve_consistent_in(&mut cells, &m, method, t, from, &quantize).unwrap();
                let sol =
                    fixed_inline(&mut cells, &m, method, t, s_prev, [false; 3], q_prev).unwrap();
                let q = quantize(sol.q_mm);
                let b = walk_to_consistent(&mut cells, &m, method, t, from, &quantize, (sol, q))
                    .unwrap();
                assert_eq!(a, b, "{t:?} {q_prev:?} {s_prev:?} {method:?}");
                if consistent_state(q, q_prev, s_prev, s_prev, [false; 3]) {
                    short += 1;
                } else {
                    walked += 1;
                }
            }
        }
        assert!(short > 1000 && walked > 1000, "{short} {walked}");
    }

    /// Every method's fixed-direction solve with its residuals evaluated
    /// inline in the kept cells ([`residual_in`], [`fixed_inline`]) gives
    /// the plain map lookup's command, iteration count and residual to
    /// the bit (the second method: [`Plain`], the model's own
    /// evaluation), on 500 random targets of the search map in random
    /// states, with and without held axes, the cells kept from one solve
    /// to the next as the compensation keeps them.
    #[test]
    fn the_inlined_solve_is_the_plain_lookups_for_every_method() {
        let m = search_map();
        let mut rnd = uniform(0x1f0e_d5a1);
        let mut cells = AxisCells::default();
        let methods = [
            Method::Direct,
            Method::Exact,
            Method::Pitch,
            Method::Ilc {
                gain: 0.7,
                max_iterations: 20,
            },
        ];
        let mut iterated = 0;
        for k in 0..500 {
            let (q_prev, t, s) = random_start(&mut rnd);
            let hold = [k % 5 == 1, k % 7 == 2, k % 3 == 0 && k % 2 == 0];
            for method in methods {
                let a = fixed_inline(&mut cells, &m, method, t, s, hold, q_prev).unwrap();
                let b = solve_fixed(&Plain(&m), method, t, s, hold, q_prev).unwrap();
                assert_eq!(a, b, "{t:?} {s:?} {hold:?} {method:?}");
                let c = solve_fixed_in(&mut cells, &m, method, t, s, hold, q_prev).unwrap();
                assert_eq!(a, c, "{t:?} {s:?} {hold:?} {method:?}");
                iterated += usize::from(a.iterations > 1);
            }
        }
        // The iterating methods took several steps.
        assert!(iterated > 500, "{iterated}");
    }

    /// The consistent solve, the search over states and the hold compute
    /// their last residuals in the exact solve's cells: the same points,
    /// states, residuals and holds to the bit as through the plain map
    /// lookup, on 2,000 targets micrometres to millimetres from the last
    /// command, from every kind of state, on a map with reversal values,
    /// slopes and transverse terms.
    #[test]
    fn the_residuals_in_the_cells_are_the_plain_lookups() {
        use crate::model::axis_table::AxisTableMap;
        use Direction::{Forward as F, Reverse as R};
        let csv = "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
                   X,forward,0,0,0,0\nX,forward,50,3,1.5,-0.5\nX,forward,100,1,2,0.5\n\
                   X,reverse,0,4,0.3,0\nX,reverse,50,7,1.9,-0.4\nX,reverse,100,5,2.2,0.6\n\
                   Y,forward,0,0,0,0\nY,forward,50,-1,2,0.2\nY,forward,100,0.5,1,0.1\n\
                   Y,reverse,0,0.2,-3,0\nY,reverse,50,-0.7,-1,0.3\nY,reverse,100,0.6,-2,0.2\n\
                   Z,forward,0,0,0,0\nZ,forward,50,0.4,-0.3,1\nZ,forward,100,0.2,0.1,2\n\
                   Z,reverse,0,0.1,0,2\nZ,reverse,50,0.5,-0.2,3\nZ,reverse,100,0.3,0.2,4\n";
        let m = AxisTableMap::from_csv(csv, "m.csv").unwrap();
        let quantize = |q: Vec3| q.map(|v| (v * 1e4).round() / 1e4);
        let mut rnd = uniform(0x2545_f491_4f6c_dd1d);
        let dir = |x: f64| if x < 0.5 { F } else { R };
        let mut held = 0;
        for k in 0..2000 {
            let q_prev = quantize(Vec3::new(
                1.0 + 98.0 * rnd(),
                1.0 + 98.0 * rnd(),
                1.0 + 98.0 * rnd(),
            ));
            let s_prev = [dir(rnd()), dir(rnd()), dir(rnd())];
            let reach = [0.002, 0.01, 1.0][k % 3];
            let t = q_prev + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * reach;
            for method in [Method::Exact, Method::Pitch] {
                let a = solve_consistent(&m, method, t, q_prev, s_prev, &quantize).unwrap();
                let b = solve_consistent(&Plain(&m), method, t, q_prev, s_prev, &quantize).unwrap();
                assert_eq!(a, b, "{t:?} {q_prev:?} {s_prev:?} {method:?}");
                let from = (q_prev, s_prev);
                let ha = hold_small_reversals(&m, method, t, from, &quantize, &a, 5e-3).unwrap();
                let hb =
                    hold_small_reversals(&Plain(&m), method, t, from, &quantize, &b, 5e-3).unwrap();
                assert_eq!(ha, hb, "{t:?} {q_prev:?} {s_prev:?} {method:?}");
                held += usize::from(ha.is_some());
            }
        }
        // The holds were tried, and some taken.
        assert!(held > 0);
    }
}
