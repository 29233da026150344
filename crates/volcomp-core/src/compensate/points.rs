//! Solving the targets of one motion: the command of each target, the
//! take-up move before a reversal, and the checks that refuse a point the
//! solver did not reach.

use super::frame::Frame;
use super::{command_error, model_error, CompensateOptions, DirectionPolicy, PointRecord, State};
use crate::compensate::solve::{solve_consistent, solve_fixed, Method};
use crate::error::{CompensationError, ModelError};
use crate::model::{Directions, ErrorModel};
use crate::simulate::next_state;
use volcomp_gcode::Vec3;

/// The command that takes up the reversing axes' backlash at `q_prev`
/// without moving the tool: for each reversing axis `a`, the position where
/// the new direction's image along `a` equals the old one's.
fn take_up_command(
    model: &dyn ErrorModel,
    q_prev: Vec3,
    s_old: Directions,
    s_new: Directions,
    reversed: [bool; 3],
    toward: Vec3,
    frame: &Frame,
) -> Result<Vec3, ModelError> {
    use crate::model::{actual_mm, Components};
    let held = actual_mm(model, q_prev, s_old, Components::All)?;
    let mut q = q_prev;
    // The reversing axes move, with their new state during the move. The
    // other axes follow too where the tool would otherwise step (the new
    // direction's straightness differs from the old one's), but only
    // toward the segment's own command `toward` and not past it, so no
    // axis reverses for it.
    let mut s = s_old;
    for a in 0..3 {
        if reversed[a] {
            s[a] = s_new[a];
        }
    }
    let mut moves = reversed;
    for _ in 0..8 {
        let img = actual_mm(model, q, s, Components::All)?;
        for a in 0..3 {
            if reversed[a] {
                q[a] += held[a] - img[a];
            } else {
                let next = q[a] + held[a] - img[a];
                let (d, room) = (next - q_prev[a], toward[a] - q_prev[a]);
                moves[a] = d * room > 0.0 && d.abs() <= room.abs();
                q[a] = if moves[a] { next } else { q_prev[a] };
            }
        }
    }
    let mut out = frame.quantize(q, q_prev);
    for a in 0..3 {
        if !reversed[a] {
            if !moves[a] {
                out[a] = q_prev[a];
            }
        } else if (out[a] - q_prev[a]) * s_new[a].sign() <= 0.0 {
            // A negative reversal value needs no take-up: the axis engages at once.
            out[a] = q_prev[a];
        }
    }
    Ok(out)
}

/// The jump of the tool's image at `q_prev` when the `reversed` axes switch
/// from `s_old` to `s_new` (mm): the lag the simulator's dead band starts
/// with, and what a take-up move covers (the written take-up is rounded to
/// the output's step, so it is not used here).
fn switch_lag_mm(
    model: &dyn ErrorModel,
    q_prev: Vec3,
    s_old: Directions,
    s_new: Directions,
    reversed: [bool; 3],
) -> Result<Vec3, ModelError> {
    use crate::model::{actual_mm, Components};
    let mut s = s_old;
    for a in 0..3 {
        if reversed[a] {
            s[a] = s_new[a];
        }
    }
    Ok(actual_mm(model, q_prev, s_old, Components::All)?
        - actual_mm(model, q_prev, s, Components::All)?)
}

/// The contour error (mm) left by folding the take-up of `lag` (see
/// [`switch_lag_mm`]) into the move from `q_prev` to the command `q`,
/// whose nominal travel is `nominal_delta`, under the dead band of the
/// simulator (docs/design.md, "Simulation and metrics"; simulate/mod.rs).
///
/// At the switch the tool stays where it was, `lag` behind the new
/// direction's image, while the command carries the image onto the path
/// linearly over the move: at the fraction `λ` of the move the image is
/// `(1 − λ)·lag` short of the nominal point, so the tool is off it by
/// `lag_k·(λ − p_k(λ))` on axis `k`, where `p_k` is how much of its lag
/// is gone. An axis whose command travels `T_k = |q_k − q_prev_k|` towards
/// its lag `b_k = |lag_k|` (a reversing axis crossing its band) takes it up
/// after the fraction `b_k / T_k`: `|λ − p_k|` peaks at
/// `|T_k − b_k| / max(T_k, b_k)` (at the band's end if the command travels
/// further, at the move's end if less — the rest then carries into the next
/// move). An axis that stands still loses its lag in step with the fastest
/// of those (`r = max T_j / b_j`): at most `|r − 1| / max(r, 1)`; an axis
/// that moves away from its lag loses it at once: all of it. Only the part
/// across the move's direction leaves the path (a lag along it is the tool
/// arriving later). Zero where every command crosses exactly its band.
fn fold_deviation_mm(lag: Vec3, q_prev: Vec3, q: Vec3, nominal_delta: Vec3) -> f64 {
    let dq = q - q_prev;
    let mut rate: f64 = 0.0;
    for k in 0..3 {
        if lag[k] * dq[k] > 0.0 {
            rate = rate.max(dq[k].abs() / lag[k].abs());
        }
    }
    let mut off = Vec3::ZERO;
    for k in 0..3 {
        let share = if lag[k] == 0.0 {
            0.0
        } else if lag[k] * dq[k] > 0.0 {
            let (t, b) = (dq[k].abs(), lag[k].abs());
            (t - b).abs() / t.max(b)
        } else if dq[k] == 0.0 {
            (rate - 1.0).abs() / rate.max(1.0)
        } else {
            1.0
        };
        off[k] = lag[k] * share;
    }
    let length = nominal_delta.norm();
    if length > 0.0 {
        let u = nominal_delta * (1.0 / length);
        (off - u * off.dot(u)).norm()
    } else {
        off.norm()
    }
}

/// Shortest lead piece (mm): LinuxCNC runs a segment no faster than its
/// length per servo period (`tcClampVelocityByLength`, src/emc/tp/tc.c),
/// and a blend may take half of it; 0.2 mm keeps 100 mm/s (F6000) with
/// the default period of 1 ms. A shorter piece would slow the machine as a
/// take-up block does, if less.
const MIN_LEAD_MM: f64 = 0.2;

/// A lead piece for a take-up that the whole move cannot fold (see
/// [`fold_deviation_mm`]): the point at a fraction ½, ¼, … of the move from
/// `t_prev`, on its line or arc, on which the reversing axes, running their new way
/// from the start, take up the lag `lag` with the tool within the fold
/// tolerance of the path; the longest such piece. Over a short piece the
/// command's travel beyond the band (the nominal path's or the
/// compensation's own along the reversing axis) is small, so the tool
/// catches the path again sooner.
///
/// No piece shorter than the shortest segment, than twenty times the lag
/// (the piece then turns from the path by less than 1/20 rad, which a
/// controller blends; a steeper one is a take-up block in all but name),
/// nor than [`MIN_LEAD_MM`].
///
/// `at(f)` is the target at the fraction `f` of the move (of length
/// `length`, mm) from the previous target, on its line or arc; the result
/// is the fraction of the lead piece.
#[allow(clippy::too_many_arguments)]
fn lead_target(
    model: &dyn ErrorModel,
    options: &CompensateOptions,
    quantize: &dyn Fn(Vec3) -> Vec3,
    q_prev: Vec3,
    lag: Vec3,
    t_prev: Vec3,
    at: &dyn Fn(f64) -> Vec3,
    length: f64,
    point: &crate::compensate::solve::PointSolution,
) -> Result<Option<f64>, ModelError> {
    let shortest = match options.segmentation {
        super::Segmentation::Adaptive { min_length_mm, .. } => min_length_mm,
        _ => super::DEFAULT_MIN_SEGMENT_LENGTH_MM,
    }
    .max(20.0 * lag.norm())
    .max(MIN_LEAD_MM);
    let mut piece = 0.5 * length;
    while piece >= shortest && piece > 0.0 {
        let lead = at(piece / length);
        let sol = solve_fixed(model, options.method, lead, point.s, [false; 3], q_prev)?;
        let q = quantize(sol.q_mm);
        let consistent = (0..3).all(|a| {
            !point.reversed[a]
                || crate::model::Direction::of_delta(q[a] - q_prev[a]) == Some(point.s[a])
        });
        if consistent
            && fold_deviation_mm(lag, q_prev, q, lead - t_prev) <= options.fold_tolerance_mm()
        {
            return Ok(Some(piece / length));
        }
        piece *= 0.5;
    }
    Ok(None)
}

/// Where [`State::solve_targets`] may put a lead piece (see [`lead_target`]).
pub(super) enum Leads<'a> {
    /// Nowhere: fixed segmentations, cycles, splines, moves with extra
    /// axes, inverse time.
    Nowhere,
    /// On the straight moves between the targets.
    Lines,
    /// On the pieces of `arc`, whose end parameters `pieces` are kept in
    /// step with the targets.
    Arc {
        arc: &'a volcomp_gcode::Arc,
        pieces: &'a mut Vec<f64>,
    },
}

/// The targets of one motion, in order (the last is the motion's end),
/// and what [`State::solve_targets`] needs to know of the motion: where a
/// lead piece may go, where the motion starts, whether it is a feed move
/// (a rapid gets no take-up).
pub(super) struct Targets<'a> {
    pub(super) points: &'a mut Vec<Vec3>,
    pub(super) leads: Leads<'a>,
    pub(super) start: Vec3,
    pub(super) feed_like: bool,
}

impl State<'_> {
    /// Solves one whole motion of a block written as segments (a canned
    /// cycle's, a spline's): its targets as the segmentation gives them,
    /// without lead pieces ([`State::solve_targets`]).
    pub(super) fn solve_motion(
        &mut self,
        model: &dyn ErrorModel,
        frame: &Frame,
        m: &volcomp_gcode::Motion,
        feed_like: bool,
        line: u64,
    ) -> Result<Vec<(Vec3, Option<Vec3>)>, CompensationError> {
        let (options, file) = (self.walk.options, self.walk.file);
        super::targets::check_target_count(m, options, file, line)?;
        let mut targets =
            super::targets::targets_with_estimate(m, options, model, self.s, &mut self.estimate_mm)
                .map_err(|source| model_error(file, line, source))?;
        self.solve_targets(
            model,
            (frame, frame),
            Targets {
                points: &mut targets,
                leads: Leads::Nowhere,
                start: m.start,
                feed_like,
            },
            line,
        )
    }

    /// Solves the targets of one motion in order; returns each command and
    /// the take-up move written before it, if any. `frames` are the frame
    /// of the motion and the one a take-up before its first command is
    /// written in (the previous line's, where that take-up runs before the
    /// line's own words).
    pub(super) fn solve_targets(
        &mut self,
        model: &dyn ErrorModel,
        frames: (&Frame, &Frame),
        motion: Targets<'_>,
        line: u64,
    ) -> Result<Vec<(Vec3, Option<Vec3>)>, CompensationError> {
        let (options, file) = (self.walk.options, self.walk.file);
        let (frame, first_take_up_frame) = frames;
        let Targets {
            points: targets,
            mut leads,
            start,
            feed_like,
        } = motion;
        let mut commands: Vec<(Vec3, Option<Vec3>)> = Vec::with_capacity(targets.len());
        self.states.clear();
        let mut ramps = std::mem::take(&mut self.ramps);
        let mut next_ramp = 0;
        let mut t_prev = start;
        let mut forced: Option<Directions> = None;
        // The index of the last lead piece inserted: neither it nor the
        // target after it gets another (the work stays bounded).
        let mut last_lead: Option<usize> = None;
        let mut index = 0;
        while index < targets.len() {
            let t = &targets[index];
            let q_from = self.q_out;
            // On a take-up ramp, or a lead piece, the reversing axis runs its
            // new way from the start: the solver starts from that state.
            let mut s_from = forced.take().unwrap_or(self.s);
            if let Some(r) = ramps.get(next_ramp).filter(|r| r.index == index) {
                s_from[r.axis] = r.direction;
                next_ramp += 1;
            }
            let quantize = |q: Vec3| frame.quantize(q, q_from);
            let point = match options.directions {
                DirectionPolicy::Commanded => {
                    solve_consistent(model, options.method, *t, self.q_out, s_from, &quantize).map(
                        |mut p| {
                            p.reversed = [0, 1, 2].map(|a| p.s[a] != self.s[a]);
                            p
                        },
                    )
                }
                DirectionPolicy::Nominal => {
                    let s_nom = next_state(self.s_nominal, *t - t_prev);
                    solve_fixed(model, options.method, *t, s_nom, [false; 3], Vec3::ZERO).map(
                        |sol| {
                            let q = quantize(sol.q_mm);
                            crate::compensate::solve::PointSolution {
                                q_mm: q,
                                s: s_nom,
                                iterations: sol.iterations,
                                residual_um: sol.residual_um,
                                reversed: [false; 3],
                                held: [false; 3],
                            }
                        },
                    )
                }
            }
            .map_err(|source| command_error(model, file, line, *t, source))?;
            check_converged(&point, options, *t, file, line)?;
            let correction = (point.q_mm - *t).norm();
            if correction > options.max_correction_mm {
                return Err(CompensationError::AtLine {
                    file: file.into(),
                    line,
                    message: format!(
                        "the correction here would be {:.1} µm, above the limit of {:.1} µm",
                        correction * 1e3,
                        options.max_correction_mm * 1e3
                    ),
                    help: crate::error::help::CORRECTION_LIMIT.into(),
                });
            }
            let mut take_up = None;
            if options.take_up
                && feed_like
                && options.directions == DirectionPolicy::Commanded
                && point.reversed.iter().any(|r| *r)
            {
                take_up = Some(
                    take_up_command(
                        model,
                        self.q_out,
                        self.s,
                        point.s,
                        point.reversed,
                        point.q_mm,
                        if commands.is_empty() {
                            first_take_up_frame
                        } else {
                            frame
                        },
                    )
                    .map_err(|source| model_error(file, line, source))?,
                );
            }
            // A take-up never goes past the segment's own command: the segment
            // must continue in the new direction, not reverse once more.
            if let Some(tu) = take_up.as_mut() {
                for a in 0..3 {
                    if point.reversed[a] && (tu[a] - point.q_mm[a]) * point.s[a].sign() > 0.0 {
                        tu[a] = point.q_mm[a];
                    }
                }
            }
            // A take-up that does not move (negative reversal value, or one
            // the segment itself covers) is not written and not counted.
            if take_up == Some(self.q_out) {
                take_up = None;
            }
            // Where the dead band keeps the tool on the path while the axis
            // takes up its reversal value, the move itself takes it up.
            if take_up.is_some() && options.fold_take_ups {
                let lag = switch_lag_mm(model, self.q_out, self.s, point.s, point.reversed)
                    .map_err(|source| model_error(file, line, source))?;
                if fold_deviation_mm(lag, self.q_out, point.q_mm, *t - t_prev)
                    <= options.fold_tolerance_mm()
                {
                    take_up = None;
                    self.summary.take_ups_folded += 1;
                } else if feed_like
                    && !matches!(leads, Leads::Nowhere)
                    && last_lead.is_none_or(|l| index > l + 1)
                {
                    let t = *t;
                    let (l_prev, l_end) = match &leads {
                        Leads::Arc { pieces, .. } => (
                            if index == 0 { 0.0 } else { pieces[index - 1] },
                            pieces[index],
                        ),
                        _ => (0.0, 1.0),
                    };
                    let (length, at): (f64, Box<dyn Fn(f64) -> Vec3>) = match &leads {
                        Leads::Arc { arc, .. } => {
                            let arc = **arc;
                            (
                                arc.length() * (l_end - l_prev),
                                Box::new(move |f| arc.point_at(l_prev + (l_end - l_prev) * f)),
                            )
                        }
                        _ => (
                            (t - t_prev).norm(),
                            Box::new(move |f| t_prev + (t - t_prev) * f),
                        ),
                    };
                    let lead = lead_target(
                        model, options, &quantize, self.q_out, lag, t_prev, &*at, length, &point,
                    )
                    .map_err(|source| model_error(file, line, source))?;
                    if let Some(f) = lead {
                        // Solve the lead piece first (it takes the take-up up),
                        // then this target again from there.
                        targets.insert(index, at(f));
                        if let Leads::Arc { pieces, .. } = &mut leads {
                            pieces.insert(index, l_prev + (l_end - l_prev) * f);
                        }
                        for r in ramps.iter_mut().filter(|r| r.index >= index) {
                            r.index += 1;
                        }
                        last_lead = Some(index);
                        // The state the point was solved in: its reversing
                        // axes switched, the others as they were.
                        forced = Some(point.s);
                        continue;
                    }
                }
            }
            if let Some(tu) = take_up {
                self.q_out = tu;
            }
            self.summary.points += 1;
            self.summary.max_residual_um = self.summary.max_residual_um.max(point.residual_um);
            self.summary.max_correction_um = self.summary.max_correction_um.max(correction * 1e3);
            for a in 0..3 {
                if point.held[a] {
                    self.summary.held_count += 1;
                    if self.summary.held.len() < 100 {
                        self.summary.held.push((line, ['X', 'Y', 'Z'][a]));
                    }
                }
            }
            self.summary.take_ups += u64::from(take_up.is_some());
            (self.on_point)(&PointRecord {
                line,
                target_mm: *t,
                command_mm: point.q_mm,
                iterations: point.iterations,
                residual_um: point.residual_um,
                reversed: point.reversed,
                held: point.held,
                take_up: take_up.is_some(),
                rapid: !feed_like,
            });
            commands.push((point.q_mm, take_up));
            self.states.push(point.s);
            self.q_out = point.q_mm;
            self.s = point.s;
            self.s_nominal = next_state(self.s_nominal, *t - t_prev);
            t_prev = *t;
            index += 1;
        }
        self.ramps_written = ramps;
        Ok(commands)
    }
}

/// Refuses a solved point whose command or residual is not finite, or whose
/// residual passes [`CompensateOptions::max_residual_um`] (no held axis).
fn check_converged(
    point: &crate::compensate::solve::PointSolution,
    options: &CompensateOptions,
    target_mm: Vec3,
    file: &str,
    line: u64,
) -> Result<(), CompensationError> {
    let finite = point.residual_um.is_finite() && (0..3).all(|a| point.q_mm[a].is_finite());
    let held = point.held.iter().any(|h| *h);
    // Direct and pitch do not aim at the full model's target: their
    // residual is the method's own error, checked for finiteness only.
    let aims = matches!(options.method, Method::Exact | Method::Ilc { .. });
    let too_far = options
        .max_residual_um
        .is_some_and(|max| aims && !held && point.residual_um > max);
    if finite && !too_far {
        return Ok(());
    }
    Err(CompensationError::AtLine {
        file: file.into(),
        line,
        message: format!(
            "the point X {:.4} Y {:.4} Z {:.4} mm (machine axes) is not reached: the model residual after {} iteration(s) is {} µm{}",
            target_mm[0],
            target_mm[1],
            target_mm[2],
            point.iterations,
            if point.residual_um.is_finite() { format!("{:.3}", point.residual_um) } else { "not finite".into() },
            options.max_residual_um.map_or(String::new(), |m| format!(", above the {m} µm accepted")),
        ),
        help: crate::error::help::RESIDUAL_LIMIT.into(),
    })
}

#[cfg(test)]
mod tests {
    use super::fold_deviation_mm;
    use volcomp_gcode::Vec3;

    const UM: f64 = 1e-3;

    #[test]
    fn a_lag_along_the_move_leaves_the_path_not_at_all() {
        // X reverses by 4 µm and the move goes on along X for 5 mm: the
        // band is crossed after 0.1 % of it, the tool waits on the line.
        let lag = Vec3::new(-4.0 * UM, 0.0, 0.0);
        let q0 = Vec3::new(10.0, 0.0, 0.0);
        let q = Vec3::new(5.0 - 0.004, 0.0, 0.0);
        assert!(fold_deviation_mm(lag, q0, q, Vec3::new(-5.0, 0.0, 0.0)) < 1e-12);
    }

    #[test]
    fn a_still_axis_whose_command_crosses_exactly_its_band_costs_nothing() {
        // Z reverses by 2 µm on a move along X that the nominal path makes
        // at constant Z: the Z command travels exactly the 2 µm.
        let lag = Vec3::new(0.0, 0.0, 2.0 * UM);
        let q0 = Vec3::new(0.0, 0.0, 0.0);
        let q = Vec3::new(4.0, 0.0, 2.0 * UM);
        assert!(fold_deviation_mm(lag, q0, q, Vec3::new(4.0, 0.0, 0.0)) < 1e-12);
    }

    #[test]
    fn travel_past_the_band_leaves_its_share_across_the_path() {
        // The Z command travels 2.5 µm for a 2 µm band: crossed after 4/5 of
        // the move, when the image is still 1/5 of the lag short: 0.4 µm,
        // across a move along X.
        let lag = Vec3::new(0.0, 0.0, 2.0 * UM);
        let q = Vec3::new(4.0, 0.0, 2.5 * UM);
        let d = fold_deviation_mm(lag, Vec3::ZERO, q, Vec3::new(4.0, 0.0, 0.0));
        assert!((d - 0.4 * UM).abs() < 1e-12, "{d}");
        // Travelling only 1.5 µm, 0.5 µm of the band is left at the end.
        let q = Vec3::new(4.0, 0.0, 1.5 * UM);
        let d = fold_deviation_mm(lag, Vec3::ZERO, q, Vec3::new(4.0, 0.0, 0.0));
        assert!((d - 0.5 * UM).abs() < 1e-12, "{d}");
    }

    #[test]
    fn a_reversal_at_45_degrees_leaves_the_lag_times_sin_45() {
        // X reverses by 4 µm onto a move of 5 mm at 45°: the X command
        // travels 5 mm + 4 µm, the share is 5/5.004 of the lag, and its part
        // across the move is that times sin 45°.
        let lag = Vec3::new(-4.0 * UM, 0.0, 0.0);
        let q = Vec3::new(-5.004, 5.0, 0.0);
        let d = fold_deviation_mm(lag, Vec3::ZERO, q, Vec3::new(-5.0, 5.0, 0.0));
        let expected = 4.0 * UM * (5.0 / 5.004) * std::f64::consts::FRAC_1_SQRT_2;
        assert!((d - expected).abs() < 1e-12, "{d} vs {expected}");
    }

    #[test]
    fn a_transverse_lag_of_an_axis_moving_away_counts_in_full() {
        // On a plunge of 1 mm, Y reverses (its command crosses exactly its
        // 4 µm band) and that shifts X by 0.3 µm (the straightness tables
        // differ by direction). X moving away from that lag loses it at
        // once: 0.3 µm across the plunge. X standing still loses it in step
        // with Y's progress, which keeps pace with the command: nothing.
        let lag = Vec3::new(0.3 * UM, 4.0 * UM, 0.0);
        let plunge = Vec3::new(0.0, 0.0, -1.0);
        let q = Vec3::new(-UM, 4.0 * UM, -1.0);
        let d = fold_deviation_mm(lag, Vec3::ZERO, q, plunge);
        assert!((d - 0.3 * UM).abs() < 1e-12, "{d}");
        let q = Vec3::new(0.0, 4.0 * UM, -1.0);
        let d = fold_deviation_mm(lag, Vec3::ZERO, q, plunge);
        assert!(d < 1e-12, "{d}");
    }
}
