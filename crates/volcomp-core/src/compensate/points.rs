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

impl State {
    /// Solves the targets of one motion in order; returns each command and
    /// the take-up move written before it, if any.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn solve_targets(
        &mut self,
        model: &dyn ErrorModel,
        options: &CompensateOptions,
        frame: &Frame,
        first_take_up_frame: &Frame,
        targets: &[Vec3],
        start: Vec3,
        feed_like: bool,
        file: &str,
        line: u64,
        on_point: &mut dyn FnMut(&PointRecord),
    ) -> Result<Vec<(Vec3, Option<Vec3>)>, CompensationError> {
        let mut commands: Vec<(Vec3, Option<Vec3>)> = Vec::with_capacity(targets.len());
        self.states.clear();
        let mut t_prev = start;
        for t in targets {
            let q_from = self.q_out;
            let quantize = |q: Vec3| frame.quantize(q, q_from);
            let point = match options.directions {
                DirectionPolicy::Commanded => {
                    solve_consistent(model, options.method, *t, self.q_out, self.s, &quantize)
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
            on_point(&PointRecord {
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
        }
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
