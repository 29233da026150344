//! Target points of a motion: feed moves split by the segmentation option,
//! arcs linearised within the chord tolerance, adaptive bisection against
//! the model, and the bound that refuses unbounded work up front.

use super::{CompensateOptions, Segmentation};
use crate::error::{CompensationError, ModelError};
use crate::model::{Directions, ErrorModel};
use crate::simulate::next_state;
use volcomp_gcode::{MotionKind, Vec3};

/// An upper bound of the number of targets [`targets_of`] makes of
/// `motion`, computed in O(1) so that a block asking for unbounded work is
/// refused before any point is generated.
pub fn target_count_bound(motion: &volcomp_gcode::Motion, options: &CompensateOptions) -> f64 {
    let per = |len_mm: f64| -> f64 {
        match options.segmentation {
            Segmentation::Off => 1.0,
            Segmentation::Count(n) => f64::from(n.max(1)),
            Segmentation::MaxLength(l) => (len_mm / l).ceil().max(1.0),
            // `bisect` halves only segments longer than twice the minimum,
            // at most 40 levels deep.
            Segmentation::Adaptive { min_length_mm, .. } => {
                (len_mm / min_length_mm).floor().min(2f64.powi(40)) + 1.0
            }
        }
    };
    match motion.kind {
        MotionKind::Rapid => 1.0,
        MotionKind::Feed => per((motion.end - motion.start).norm()),
        MotionKind::Arc(arc) => {
            let chords = arc.chord_count(options.chord_tolerance_mm) as f64;
            match options.segmentation {
                Segmentation::Count(n) => chords.max(f64::from(n)),
                _ => chords * per(arc.length() / chords),
            }
        }
    }
}

/// Refuses a motion whose targets would pass
/// [`crate::limits::MAX_POINTS_PER_BLOCK`].
pub(super) fn check_target_count(
    motion: &volcomp_gcode::Motion,
    options: &CompensateOptions,
    file: &str,
    line: u64,
) -> Result<(), CompensationError> {
    crate::limits::check_points(target_count_bound(motion, options)).map_err(|message| {
        CompensationError::AtLine {
            file: file.into(),
            line,
            message,
            help: crate::error::help::TOO_MANY_POINTS.into(),
        }
    })
}

/// Target points of a program motion (axis frame), the last one exactly the
/// motion's end. `model` and `s` (the direction state before the motion)
/// are only used by adaptive segmentation.
pub fn targets_of(
    motion: &volcomp_gcode::Motion,
    options: &CompensateOptions,
    model: &dyn ErrorModel,
    s: Directions,
) -> Result<Vec<Vec3>, ModelError> {
    let mut out = Vec::new();
    let seg = options.segmentation;
    match motion.kind {
        MotionKind::Rapid => out.push(motion.end),
        MotionKind::Feed => split(motion.start, motion.end, seg, model, s, &mut out)?,
        MotionKind::Arc(arc) => {
            let chords = arc.chord_count(options.chord_tolerance_mm);
            if let Segmentation::Count(n) = seg {
                let n = chords.max(n as usize);
                for k in 1..n {
                    out.push(arc.point_at(k as f64 / n as f64));
                }
                out.push(arc.end);
            } else {
                let mut prev = arc.start;
                let mut result = Ok(());
                arc.for_each_chord_end(options.chord_tolerance_mm, |p| {
                    if result.is_ok() {
                        result = split(prev, p, seg, model, s, &mut out);
                    }
                    prev = p;
                });
                result?;
            }
        }
    }
    Ok(out)
}

fn split(
    a: Vec3,
    b: Vec3,
    seg: Segmentation,
    model: &dyn ErrorModel,
    s: Directions,
    out: &mut Vec<Vec3>,
) -> Result<(), ModelError> {
    let n = match seg {
        Segmentation::Off => 1,
        Segmentation::Count(n) => n.max(1) as usize,
        Segmentation::MaxLength(l) => (((b - a).norm() / l).ceil() as usize).max(1),
        Segmentation::Adaptive {
            tolerance_mm,
            min_length_mm,
        } => {
            let s = next_state(s, b - a);
            let e = |p: Vec3| -> Result<Vec3, ModelError> {
                Ok(model.deviation_um(p, s, crate::model::Components::All)? * 1e-3)
            };
            let (ea, eb) = (e(a)?, e(b)?);
            return bisect(a, b, ea, eb, tolerance_mm, min_length_mm, &e, 0, out);
        }
    };
    for k in 1..n {
        out.push(a.lerp(b, k as f64 / n as f64));
    }
    out.push(b);
    Ok(())
}

/// Adaptive splitting of `a`–`b` (errors `ea`, `eb` at the ends, mm).
#[allow(clippy::too_many_arguments)]
fn bisect(
    a: Vec3,
    b: Vec3,
    ea: Vec3,
    eb: Vec3,
    tol: f64,
    min_len: f64,
    e: &dyn Fn(Vec3) -> Result<Vec3, ModelError>,
    depth: u32,
    out: &mut Vec<Vec3>,
) -> Result<(), ModelError> {
    let mid = a.lerp(b, 0.5);
    let em = e(mid)?;
    let mut worst = (em - ea.lerp(eb, 0.5)).norm();
    if worst <= tol {
        for t in [0.25, 0.75] {
            worst = worst.max((e(a.lerp(b, t))? - ea.lerp(eb, t)).norm());
        }
    }
    if worst > tol && (b - a).norm() > 2.0 * min_len && depth < 40 {
        bisect(a, mid, ea, em, tol, min_len, e, depth + 1, out)?;
        bisect(mid, b, em, eb, tol, min_len, e, depth + 1, out)
    } else {
        out.push(b);
        Ok(())
    }
}

/// Marks the axes whose position a moving line states: its X, Y and Z words,
/// and X and Y for a polar end point (`@` radius, `^` angle; LinuxCNC reads
/// polar words in the XY plane only). Until a program has stated every axis,
/// the machine is where the program does not say, and neither compensation
/// nor simulation evaluates the map there.
pub(crate) fn mark_axes_set(line: &volcomp_gcode::lexer::Lexed, known: &mut [bool; 3]) {
    for w in line.words() {
        match w.letter {
            b'X' | b'Y' | b'Z' => known[usize::from(w.letter - b'X')] = true,
            b'@' | b'^' => {
                known[0] = true;
                known[1] = true;
            }
            _ => {}
        }
    }
}
