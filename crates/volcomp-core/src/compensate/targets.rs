//! Target points of a motion: feed moves split by the segmentation option,
//! arcs linearised within the chord tolerance, adaptive bisection against
//! the model, and the bound that refuses unbounded work up front.

use super::{CompensateOptions, Segmentation};
use crate::error::{CompensationError, ModelError};
use crate::model::next_state;
use crate::model::{AxisCells, Components, Directions, ErrorModel};
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
                floor_via_integer(len_mm / min_length_mm).min(2f64.powi(40)) + 1.0
            }
        }
    };
    match motion.kind {
        MotionKind::Rapid => 1.0,
        MotionKind::Feed => per((motion.end - motion.start).norm()),
        // Arcs as arcs: at least the quarter points; the table points and
        // the bisection depend on the map, so `arcs::arc_pieces` stops
        // generating past the limit and the caller refuses the block then.
        MotionKind::Arc(arc) if options.arcs_as_arcs => {
            4.0 * (arc.sweep_rad.abs() / std::f64::consts::TAU).ceil() + 1.0
        }
        MotionKind::Arc(arc) => {
            let chords = arc.chord_count(options.chord_tolerance_mm) as f64;
            match options.segmentation {
                Segmentation::Count(n) => chords.max(f64::from(n)),
                _ => chords * per(arc.length() / chords),
            }
        }
    }
}

/// `x.floor()`, through an integer where that is exact (`0 < x < 2^52`:
/// every such `f64` converts to the integer below or equal to it, and that
/// integer back to itself), as `floor` is a library call on the baseline
/// x86-64 target; `floor` itself for anything else (negative, huge,
/// infinite, NaN, and zero, whose sign `floor` keeps).
#[inline]
fn floor_via_integer(x: f64) -> f64 {
    const TWO_52: f64 = 4_503_599_627_370_496.0;
    if x > 0.0 && x < TWO_52 {
        x as u64 as f64
    } else {
        x.floor()
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
    let mut worst = 0.0;
    targets_with_estimate(motion, options, model, s, &mut worst)
}

/// [`targets_of`], raising `worst_mm` to the largest contour error the
/// adaptive segmentation estimates it leaves (docs/compensation.md,
/// "Adaptive segmentation"; chords of linearised arcs add the chord
/// tolerance). Other segmentations estimate nothing.
pub(super) fn targets_with_estimate(
    motion: &volcomp_gcode::Motion,
    options: &CompensateOptions,
    model: &dyn ErrorModel,
    s: Directions,
    worst_mm: &mut f64,
) -> Result<Vec<Vec3>, ModelError> {
    targets_in(
        motion,
        options,
        model,
        s,
        worst_mm,
        (&mut AxisCells::default(), Vec::new()),
    )
}

/// [`targets_with_estimate`], the adaptive segmentation evaluating `model`
/// in the table cells `cells` keeps (kept for `model` between calls: the
/// map's values to the bit, [`AxisCells`]). The targets are written into
/// `out` (emptied first: a buffer kept between motions) and given back.
pub(super) fn targets_in(
    motion: &volcomp_gcode::Motion,
    options: &CompensateOptions,
    model: &dyn ErrorModel,
    s: Directions,
    worst_mm: &mut f64,
    (cells, mut out): (&mut AxisCells, Vec<Vec3>),
) -> Result<Vec<Vec3>, ModelError> {
    out.clear();
    let seg = options.segmentation_in(motion.path_mode);
    // Under G64 a departure along the move is no reason to split it (the
    // splits it made cut the planner's blends short). Under G61/G61.1 the
    // machine stops at the program's corners anyway, and the pieces stay
    // as before: there they let a reversal at a corner be taken up while
    // another axis still moves (a 12-chord circle in G61 keeps 99.5 % of its
    // RMS reduction, 98.6 % without them: docs/compensation.md).
    let across_only = matches!(motion.path_mode, volcomp_gcode::PathMode::Blend { .. });
    match motion.kind {
        MotionKind::Rapid => out.push(motion.end),
        MotionKind::Feed => split(
            (motion.start, motion.end),
            seg,
            model,
            s,
            across_only,
            (&mut out, cells),
            worst_mm,
        )?,
        MotionKind::Arc(arc) if options.arcs_as_arcs => {
            let (tolerance_mm, min_length_mm) = options.arc_tolerances_mm(motion.path_mode);
            let normal_mm = super::arcs::normal_tolerance_mm(tolerance_mm, motion.path_mode);
            let pieces = super::arcs::arc_pieces(
                &arc,
                model,
                s,
                (tolerance_mm, normal_mm),
                min_length_mm,
                worst_mm,
            )?;
            for l in pieces {
                out.push(if l >= 1.0 { arc.end } else { arc.point_at(l) });
            }
        }
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
                let mut worst = 0.0;
                arc.for_each_chord_end(options.chord_tolerance_mm, |p| {
                    if result.is_ok() {
                        let to = (&mut out, &mut *cells);
                        result = split((prev, p), seg, model, s, across_only, to, &mut worst);
                    }
                    prev = p;
                });
                result?;
                if matches!(seg, Segmentation::Adaptive { .. }) {
                    *worst_mm = worst_mm.max(worst + options.chord_tolerance_mm);
                }
            }
        }
    }
    Ok(out)
}

/// How far the map departs across the move from its chord on the line
/// `a`–`b` kept as one piece (mm; quarter points and table points, as the
/// adaptive segmentation measures a piece, [`Piece::refine`]): what a piece
/// the planner's blend zone keeps whole leaves. 0 outside the adaptive
/// segmentation.
pub(super) fn whole_piece_departure_mm(
    (a, b): (Vec3, Vec3),
    options: &CompensateOptions,
    model: &dyn ErrorModel,
    s: Directions,
    cells: &mut AxisCells,
) -> Result<f64, ModelError> {
    let Segmentation::Adaptive { min_length_mm, .. } = options.segmentation else {
        return Ok(0.0);
    };
    let whole = Segmentation::Adaptive {
        tolerance_mm: f64::INFINITY,
        min_length_mm,
    };
    let mut worst_mm = 0.0;
    split(
        (a, b),
        whole,
        model,
        s,
        true,
        (&mut Vec::new(), cells),
        &mut worst_mm,
    )?;
    Ok(worst_mm)
}

fn split(
    (a, b): (Vec3, Vec3),
    seg: Segmentation,
    model: &dyn ErrorModel,
    s: Directions,
    across_only: bool,
    (out, cells): (&mut Vec<Vec3>, &mut AxisCells),
    worst_mm: &mut f64,
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
            let knots = |p: Vec3, q: Vec3, cuts: &mut Vec<f64>| {
                knot_cuts(model, p, q, s, min_length_mm, cuts)
            };
            // A piecewise linear map is affine between table points: a
            // move that crosses none needs no split and no evaluation.
            let linear = model.piecewise_linear();
            if linear && within_kept_cells(cells, a, b, s) {
                out.push(b);
                return Ok(());
            }
            // One buffer for the cuts of every piece (a piece's cuts are
            // used up before its halves are refined): no allocation per line.
            return CUTS.with_borrow_mut(|cuts| {
                knots(a, b, cuts);
                if linear && cuts.is_empty() {
                    out.push(b);
                    return Ok(());
                }
                let length = (b - a).norm();
                let piece = Piece {
                    along: if across_only && length > 0.0 {
                        (b - a) * (1.0 / length)
                    } else {
                        Vec3::ZERO
                    },
                    tol: tolerance_mm,
                    min_len: min_length_mm,
                    model,
                    s,
                    knots: &knots,
                    linear,
                };
                // The move's ends: its start was the last move's end, or
                // the first step of the last solve; its end is where the
                // solve of its last target starts
                // ([`AxisCells::deviation_end_um`]).
                let end = |cells: &mut AxisCells, p: Vec3| -> Result<Vec3, ModelError> {
                    Ok(cells.deviation_end_um(model, p, s)? * 1e-3)
                };
                let (ea, eb) = (end(cells, a)?, end(cells, b)?);
                piece.refine(a, b, ea, eb, 0, true, cuts, cells, out, worst_mm)
            });
        }
    };
    for k in 1..n {
        out.push(a.lerp(b, k as f64 / n as f64));
    }
    out.push(b);
    Ok(())
}

thread_local! {
    /// The cuts of the piece being refined ([`knot_cuts`]), kept between
    /// lines.
    static CUTS: std::cell::RefCell<Vec<f64>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Parameters `λ ∈ (0, 1)` (increasing) where the line `a`–`b` crosses a
/// knot of the model's tables ([`ErrorModel::knots_mm`]) for the direction
/// state `s` of the move, leaving out cuts closer than `min_length_mm` to
/// the previous cut or to `b`: at most `|b − a| / min_length_mm` of them.
/// Written over `cuts`.
fn knot_cuts(
    model: &dyn ErrorModel,
    a: Vec3,
    b: Vec3,
    s: Directions,
    min_length_mm: f64,
    cuts: &mut Vec<f64>,
) {
    cuts.clear();
    let length = (b - a).norm();
    if length <= 2.0 * min_length_mm || !length.is_finite() {
        return;
    }
    let mut axes = 0;
    for axis in 0..3 {
        let (lo, hi) = (a[axis].min(b[axis]), a[axis].max(b[axis]));
        if hi <= lo {
            continue;
        }
        let knots = model.knots_mm(axis, s[axis]);
        // Knots closer than the shortest segment along this axis to the
        // last one taken are skipped by binary search (bounded
        // work on tables denser than the shortest segment); the filter
        // below would drop them anyway.
        let step = min_length_mm / length * (hi - lo);
        let mut i = crate::model::axis_table::count_at_or_below(knots, lo);
        let before = cuts.len();
        while let Some(&k) = knots.get(i).filter(|k| **k < hi) {
            cuts.push((k - a[axis]) / (b[axis] - a[axis]));
            // Usually the next knot is already far enough: no search.
            let next = k + step;
            i = if knots.get(i + 1).is_none_or(|v| *v >= next) {
                i + 1
            } else {
                knots.partition_point(|v| *v < next).max(i + 1)
            };
        }
        axes += usize::from(cuts.len() > before);
    }
    // One axis' cuts are already in order (increasing or, for a move in
    // reverse, decreasing); several are merged.
    if axes > 1 {
        cuts.sort_by(f64::total_cmp);
    } else if cuts.first() > cuts.last() {
        cuts.reverse();
    }
    let min_step = min_length_mm / length;
    let mut last = 0.0;
    cuts.retain(|&c| {
        let keep = c - last >= min_step && 1.0 - c >= min_step;
        if keep {
            last = c;
        }
        keep
    });
}

/// Whether the line `a`–`b` crosses no table point of the direction state
/// `s` (strictly between its ends) by the cells `cells` keeps: each
/// moving axis' span lies in one kept cell, whose ends are two neighbouring
/// points of its table ([`AxisCells::spans_mm`]). Then [`knot_cuts`] finds
/// no cut: a move that stays in the cells its start was solved in (most
/// moves of a CAM program, fractions of a millimetre against table
/// points millimetres apart) needs no search of the tables. `false` where
/// the cells do not tell (the tables are searched).
fn within_kept_cells(cells: &AxisCells, a: Vec3, b: Vec3, s: Directions) -> bool {
    (0..3).all(|axis| {
        let (lo, hi) = (a[axis].min(b[axis]), a[axis].max(b[axis]));
        hi <= lo || cells.spans_mm(axis, s[axis], lo, hi)
    })
}

/// What the adaptive splitting of one move needs at every piece.
struct Piece<'a> {
    /// The unit direction of the move under G64 (zero under G61/G61.1): a
    /// departure along it moves the tool along the path, not off it, so
    /// only the rest counts.
    along: Vec3,
    /// Tolerance on the departure of the map from its chord, mm.
    tol: f64,
    /// Shortest piece, mm.
    min_len: f64,
    /// The map, and the direction state of the move.
    model: &'a dyn ErrorModel,
    s: Directions,
    /// [`knot_cuts`] of a piece.
    knots: &'a dyn Fn(Vec3, Vec3, &mut Vec<f64>),
    /// The map is piecewise linear ([`ErrorModel::piecewise_linear`]).
    linear: bool,
}

impl Piece<'_> {
    /// The map's error at `p` (mm), evaluated in the table cells `cells`
    /// keeps: [`ErrorModel::deviation_um`]'s value to the bit.
    #[inline(always)]
    fn e(&self, cells: &mut AxisCells, p: Vec3) -> Result<Vec3, ModelError> {
        Ok(cells.deviation_um(self.model, p, self.s, Components::All)? * 1e-3)
    }

    /// Adaptive splitting of `a`–`b` (errors `ea`, `eb` at the ends, mm).
    ///
    /// The departure of the map from its chord is taken at the quarter points
    /// and at every table point the piece crosses (`knots`: where a piecewise
    /// linear map bends, so the largest departure of such a map lies at one of
    /// them), across the move only: a departure along the move leaves the
    /// tool on the straight path (the contour error is the distance to the
    /// path), so a positioning error of the axis the move runs along is no
    /// reason to split it. A piece within the tolerance is kept whole, even across table
    /// points; otherwise it is cut at the table point that departs most or,
    /// with none, halved — never into pieces shorter than `min_len`.
    /// `cuts` holds the piece's knot cuts already when `have_cuts`.
    #[allow(clippy::too_many_arguments)]
    fn refine(
        &self,
        a: Vec3,
        b: Vec3,
        ea: Vec3,
        eb: Vec3,
        depth: u32,
        have_cuts: bool,
        cuts: &mut Vec<f64>,
        cells: &mut AxisCells,
        out: &mut Vec<Vec3>,
        worst_mm: &mut f64,
    ) -> Result<(), ModelError> {
        let mut e = |p: Vec3| self.e(cells, p);
        let across = |d: Vec3| (d - self.along * d.dot(self.along)).norm();
        let mut worst: f64 = 0.0;
        if !self.linear {
            for t in [0.25, 0.5, 0.75] {
                worst = worst.max(across(e(a.lerp(b, t))? - ea.lerp(eb, t)));
            }
        }
        if !have_cuts {
            (self.knots)(a, b, cuts);
        }
        let mut cut: Option<(f64, f64, Vec3)> = None;
        for &t in cuts.iter() {
            let ep = e(a.lerp(b, t))?;
            let d = across(ep - ea.lerp(eb, t));
            worst = worst.max(d);
            if cut.is_none_or(|(_, dc, _)| d > dc) {
                cut = Some((t, d, ep));
            }
        }
        if worst > self.tol && (b - a).norm() > 2.0 * self.min_len && depth < 64 {
            let (t, em) = match cut {
                Some((t, d, ep)) if d > self.tol => (t, ep),
                _ => (0.5, e(a.lerp(b, 0.5))?),
            };
            let m = a.lerp(b, t);
            self.refine(a, m, ea, em, depth + 1, false, cuts, cells, out, worst_mm)?;
            return self.refine(m, b, em, eb, depth + 1, false, cuts, cells, out, worst_mm);
        }
        *worst_mm = worst_mm.max(worst);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::axis_table::AxisTableMap;
    use crate::model::{Components, ALL_FORWARD};
    use volcomp_gcode::{Motion, MotionSource};

    fn feed(a: Vec3, b: Vec3) -> Motion {
        Motion {
            kind: MotionKind::Feed,
            start: a,
            end: b,
            line: 1,
            column: 1,
            feed: 100.0,
            source: MotionSource::Program,
            extra: Default::default(),
            feed_mode: volcomp_gcode::interp::FeedMode::PerMinute,
            path_mode: Default::default(),
        }
    }

    fn adaptive(tol_um: f64) -> CompensateOptions {
        CompensateOptions {
            segmentation: Segmentation::Adaptive {
                tolerance_mm: tol_um * 1e-3,
                min_length_mm: 0.01,
            },
            ..CompensateOptions::default()
        }
    }

    fn map(x_rows: &str) -> AxisTableMap {
        let csv = format!(
            "axis,direction,position_mm,ex_um,ey_um,ez_um\n{x_rows}\
             Y,both,-100,0,0,0\nY,both,100,0,0,0\nZ,both,-100,0,0,0\nZ,both,100,0,0,0\n"
        );
        AxisTableMap::from_csv(&csv, "m.csv").unwrap()
    }

    /// An error that is affine along the move needs no split at all: the
    /// chord between two compensated points follows the target exactly.
    #[test]
    fn the_floor_through_an_integer_is_the_floor_of_every_value() {
        // By hand: the integer part of a positive value, the value itself
        // for an integer, and the boundary values that `floor` keeps.
        assert_eq!(floor_via_integer(2.999), 2.0);
        assert_eq!(floor_via_integer(7.0), 7.0);
        assert_eq!(floor_via_integer(0.0).to_bits(), 0.0f64.to_bits());
        assert_eq!(floor_via_integer(-0.0).to_bits(), (-0.0f64).to_bits());
        assert_eq!(floor_via_integer(-0.5), -1.0);
        // Second method: `f64::floor`, to the bit, on values around every
        // power of two up to beyond 2^53, their neighbours, the specials and
        // random bit patterns.
        let mut values = vec![
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MIN_POSITIVE,
        ];
        for e in -1074..=1023 {
            let p = 2f64.powi(e);
            for v in [p, p * 1.5, p * 0.75] {
                for w in [
                    v,
                    f64::from_bits(v.to_bits().wrapping_add(1)),
                    f64::from_bits(v.to_bits().wrapping_sub(1)),
                ] {
                    values.extend([w, -w, w + 0.5, w - 0.5]);
                }
            }
        }
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..200_000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            values.push(f64::from_bits(seed));
        }
        for v in values {
            assert_eq!(floor_via_integer(v).to_bits(), v.floor().to_bits(), "{v:e}");
        }
    }

    #[test]
    fn a_linear_map_needs_no_split() {
        let m = map("X,both,-100,-20,5,1\nX,both,100,20,-5,-1\n");
        let (a, b) = (Vec3::new(-80.0, 3.0, 0.0), Vec3::new(90.0, -7.0, 4.0));
        let t = targets_of(&feed(a, b), &adaptive(0.1), &m, ALL_FORWARD).unwrap();
        assert_eq!(t, vec![b]);
    }

    /// A table's points are the only places a piecewise linear map bends:
    /// a move across two of them is cut exactly there and nowhere else,
    /// however large the slope change (here 4 µm/mm).
    #[test]
    fn a_table_is_cut_at_its_points_only() {
        let m = map(
            "X,both,0,0,0,0\nX,both,5,0,20,0\nX,both,10,0,0,0\nX,both,15,0,20,3\nX,both,20,0,0,0\n",
        );
        let (a, b) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(14.0, 0.0, 0.0));
        let t = targets_of(&feed(a, b), &adaptive(0.1), &m, ALL_FORWARD).unwrap();
        assert_eq!(
            t,
            vec![Vec3::new(5.0, 0.0, 0.0), Vec3::new(10.0, 0.0, 0.0), b]
        );
    }

    /// The bow `e_y = 4A·u(1 − u)`, `u = x/80 mm`, of amplitude `A`.
    struct Bow {
        amplitude_um: f64,
    }

    impl ErrorModel for Bow {
        fn deviation_um(&self, q: Vec3, _: Directions, _: Components) -> Result<Vec3, ModelError> {
            let u = q.x / 80.0;
            Ok(Vec3::new(0.0, 4.0 * self.amplitude_um * u * (1.0 - u), 0.0))
        }
        fn range_mm(&self) -> [[f64; 2]; 3] {
            [[-1e3, 1e3]; 3]
        }
    }

    /// A bow `e_y = 4A·u(1 − u)`, `u = x/L`, departs from the chord of a
    /// piece of length `h` by `A·(h/L)²` at its middle (the same for every
    /// piece). With A = 10 µm and a tolerance of 0.1 µm, halving stops at
    /// the first `h = L/2^k` with `10/4^k ≤ 0.1`: k = 4 (10/256 = 0.039;
    /// k = 3 gives 10/64 = 0.156 > 0.1), so exactly 16 equal pieces.
    #[test]
    fn a_quadratic_bow_needs_the_predicted_pieces() {
        let bow = Bow { amplitude_um: 10.0 };
        let (a, b) = (Vec3::ZERO, Vec3::new(80.0, 0.0, 0.0));
        let t = targets_of(&feed(a, b), &adaptive(0.1), &bow, ALL_FORWARD).unwrap();
        let expected: Vec<Vec3> = (1..=16)
            .map(|k| Vec3::new(5.0 * k as f64, 0.0, 0.0))
            .collect();
        assert_eq!(t, expected);
        // A tolerance just above the 8-piece departure keeps 8 pieces.
        let t = targets_of(&feed(a, b), &adaptive(0.16), &bow, ALL_FORWARD).unwrap();
        assert_eq!(t.len(), 8);
    }

    /// Under G61 and G61.1 the default tolerance is halved (0.05 µm): the
    /// bow of A = 5 µm departs `5/4^k` µm from the chords of `2^k` pieces,
    /// so G64 keeps 8 pieces (5/64 = 0.078 ≤ 0.1; 4 pieces leave 0.31) and
    /// G61/G61.1 cut 16 (0.078 > 0.05; 5/256 = 0.020). Without the exact
    /// tolerance (a contour tolerance given) G61 keeps 8 too.
    #[test]
    fn under_g61_a_bow_is_cut_to_half_the_tolerance() {
        let bow = Bow { amplitude_um: 5.0 };
        let (a, b) = (Vec3::ZERO, Vec3::new(80.0, 0.0, 0.0));
        let pieces = |mode: volcomp_gcode::PathMode, options: &CompensateOptions| {
            let m = Motion {
                path_mode: mode,
                ..feed(a, b)
            };
            targets_of(&m, options, &bow, ALL_FORWARD).unwrap().len()
        };
        let defaults = CompensateOptions::default();
        assert_eq!(pieces(Default::default(), &defaults), 8);
        assert_eq!(pieces(volcomp_gcode::PathMode::ExactPath, &defaults), 16);
        assert_eq!(pieces(volcomp_gcode::PathMode::ExactStop, &defaults), 16);
        let given = CompensateOptions {
            exact_contour_tolerance_mm: None,
            ..defaults
        };
        assert_eq!(pieces(volcomp_gcode::PathMode::ExactPath, &given), 8);
    }

    /// A table point is a cut only where the kink matters: the departure
    /// of a kink of slope change `Δs` at the middle of a piece of length
    /// `L` is `Δs·L/4`. Table X at 0, 5, 10 mm with 0, 1, 0 µm bends by
    /// 0.4 µm/mm at 5 mm: a 0.8 mm move across it departs 0.08 µm (kept
    /// whole at 0.1 µm), a 2 mm move 0.2 µm (cut there, and only there).
    #[test]
    fn a_table_point_is_cut_only_where_its_kink_matters() {
        let m = map("X,both,0,0,0,0\nX,both,5,0,1,0\nX,both,10,0,0,0\n");
        let (a, b) = (Vec3::new(4.6, 0.0, 0.0), Vec3::new(5.4, 0.0, 0.0));
        let t = targets_of(&feed(a, b), &adaptive(0.1), &m, ALL_FORWARD).unwrap();
        assert_eq!(t, vec![b]);
        let (a, b) = (Vec3::new(4.0, 0.0, 0.0), Vec3::new(6.0, 0.0, 0.0));
        let t = targets_of(&feed(a, b), &adaptive(0.1), &m, ALL_FORWARD).unwrap();
        assert_eq!(t, vec![Vec3::new(5.0, 0.0, 0.0), b]);
    }

    /// A positioning error of the axis a move runs along moves the tool
    /// along the path, not off it: a bump of 20 µm in E_XX at X = 5 mm
    /// leaves a move along X under G64 whole (under G61 it is cut there, as
    /// before). A move at 45° in XY across the same
    /// bump departs across itself by 20·sin 45° = 14.1 µm at X = 5 mm:
    /// cut there.
    #[test]
    fn a_departure_along_the_move_is_no_reason_to_split_it() {
        let m = map("X,both,0,0,0,0\nX,both,5,20,0,0\nX,both,10,0,0,0\n");
        let (a, b) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(9.0, 0.0, 0.0));
        let t = targets_of(&feed(a, b), &adaptive(0.1), &m, ALL_FORWARD).unwrap();
        assert_eq!(t, vec![b]);
        let (a, b) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(9.0, 8.0, 0.0));
        let t = targets_of(&feed(a, b), &adaptive(0.1), &m, ALL_FORWARD).unwrap();
        assert_eq!(t, vec![Vec3::new(5.0, 4.0, 0.0), b]);
        // Under G61 the move along X is cut at the bump as before.
        let (a, b) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(9.0, 0.0, 0.0));
        let g61 = Motion {
            path_mode: volcomp_gcode::PathMode::ExactPath,
            ..feed(a, b)
        };
        let t = targets_of(&g61, &adaptive(0.1), &m, ALL_FORWARD).unwrap();
        assert_eq!(t, vec![Vec3::new(5.0, 0.0, 0.0), b]);
    }

    /// The map seen without its cells: every evaluation is the map's own
    /// lookup ([`ErrorModel::deviation_um`]), as [`AxisCells`] does for a
    /// model without cells.
    struct Lookups<'a>(&'a AxisTableMap);

    impl ErrorModel for Lookups<'_> {
        fn deviation_um(&self, q: Vec3, s: Directions, c: Components) -> Result<Vec3, ModelError> {
            self.0.deviation_um(q, s, c)
        }
        fn range_mm(&self) -> [[f64; 2]; 3] {
            self.0.range_mm()
        }
        fn knots_mm(&self, axis: usize, d: crate::model::Direction) -> &[f64] {
            self.0.knots_mm(axis, d)
        }
        fn piecewise_linear(&self) -> bool {
            self.0.piecewise_linear()
        }
    }

    /// The split evaluates the map in the table cells kept across moves;
    /// its targets and its estimate are those the map's own lookup at
    /// every point gives, to the bit: random moves over the example map (2 mm
    /// tables, with backlash), short and long, in every direction, under
    /// G61 and G64, at tolerances that split some and not others, and moves
    /// that leave the table (clamped there: the lookup's own values).
    #[test]
    fn the_split_in_kept_cells_is_the_split_of_the_maps_lookups() {
        let map = crate::example::example_map();
        let range = map.range_mm();
        let mut rng = crate::rng::Rng::new(28);
        let (mut pieces, mut split) = (0, 0);
        // One cache for the whole walk, as the compensation keeps it.
        let mut cells = AxisCells::default();
        for i in 0..4000 {
            let mut u = || rng.next_u64() as f64 / u64::MAX as f64;
            let at = |u: f64, a: usize| range[a][0] - 5.0 + u * (range[a][1] - range[a][0] + 10.0);
            let a = Vec3::new(at(u(), 0), at(u(), 1), at(u(), 2));
            let len = [0.05, 0.5, 3.0, 40.0, 400.0][i % 5];
            let d = Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5);
            let b = a + d * (len / d.norm());
            let s = [i & 1, (i >> 1) & 1, (i >> 2) & 1].map(|k| {
                if k == 0 {
                    crate::model::Direction::Forward
                } else {
                    crate::model::Direction::Reverse
                }
            });
            let tol_um = [0.02, 0.1, 0.5][i % 3];
            let mut m = feed(a, b);
            if i % 4 == 0 {
                m.path_mode = volcomp_gcode::PathMode::ExactPath;
            }
            let (mut w1, mut w2) = (0.0, 0.0);
            let kept = targets_in(
                &m,
                &adaptive(tol_um),
                &map,
                s,
                &mut w1,
                (&mut cells, Vec::new()),
            );
            let looked = targets_with_estimate(&m, &adaptive(tol_um), &Lookups(&map), s, &mut w2);
            match (kept, looked) {
                (Ok(t1), Ok(t2)) => {
                    assert_eq!(t1, t2, "{a:?} {b:?}");
                    pieces += t1.len();
                    split += usize::from(t1.len() > 1);
                }
                (Err(e1), Err(e2)) => assert_eq!(e1.to_string(), e2.to_string()),
                (k, l) => panic!("{k:?} vs {l:?}"),
            }
            assert_eq!(w1.to_bits(), w2.to_bits(), "{a:?} {b:?}");
        }
        // Many moves were split, many not.
        assert!(split > 500 && split < 3500, "{split}");
        assert!(pieces > 8000, "{pieces}");
    }

    /// A move that stays inside the cells its start was evaluated in is
    /// not searched for table points, and its split is the split of the
    /// map's lookups to the bit: a walk of chained moves of 0.05 to 2.5 mm
    /// over the example map (2 mm tables), the cells kept as the
    /// compensation keeps them (the targets' solves evaluate the move's end
    /// in them). Where the kept cells say the move crosses no table point,
    /// the table search (`knot_cuts`, the second method) finds none;
    /// asserts that this happened often (more than 1,000 of 3,000 moves)
    /// and that moves across table points were searched too.
    #[test]
    fn a_move_inside_the_kept_cells_crosses_no_table_point() {
        let map = crate::example::example_map();
        let range = map.range_mm();
        let mut rng = crate::rng::Rng::new(2811);
        let mut cells = AxisCells::default();
        let mid = |a: usize| 0.5 * (range[a][0] + range[a][1]);
        let mut a = Vec3::new(mid(0), mid(1), mid(2));
        let (mut inside, mut crossing) = (0, 0);
        for i in 0..3000 {
            let mut u = || rng.next_u64() as f64 / u64::MAX as f64;
            let len = [0.05, 0.3, 1.0, 2.5][i % 4];
            let d = Vec3::new(u() - 0.5, u() - 0.5, 0.3 * (u() - 0.5));
            let mut b = a + d * (len / d.norm());
            for k in 0..3 {
                if !(range[k][0] + 1.0..=range[k][1] - 1.0).contains(&b[k]) {
                    b[k] = mid(k);
                }
            }
            let s = next_state(ALL_FORWARD, b - a);
            if within_kept_cells(&cells, a, b, s) {
                inside += 1;
                let mut cuts = Vec::new();
                knot_cuts(&map, a, b, s, 0.0, &mut cuts);
                assert!(cuts.is_empty(), "{a:?} {b:?}: {cuts:?}");
            } else {
                crossing += 1;
            }
            let (mut w1, mut w2) = (0.0, 0.0);
            let m = feed(a, b);
            let o = adaptive([0.02, 0.1][i % 2]);
            let kept = targets_in(&m, &o, &map, ALL_FORWARD, &mut w1, (&mut cells, Vec::new()));
            let looked = targets_with_estimate(&m, &o, &Lookups(&map), ALL_FORWARD, &mut w2);
            assert_eq!(kept.unwrap(), looked.unwrap(), "{a:?} {b:?}");
            assert_eq!(w1.to_bits(), w2.to_bits(), "{a:?} {b:?}");
            // The solve of the move's end evaluates the map there, in the
            // move's state: its cells are the ones kept for the next move.
            cells.deviation_um(&map, b, s, Components::All).unwrap();
            a = b;
        }
        assert!(inside > 1000 && crossing > 100, "{inside} {crossing}");
    }

    /// Knots closer than the shortest segment to a cut or to the end are
    /// left out, so the count stays within [`target_count_bound`].
    #[test]
    fn knot_cuts_respect_the_shortest_segment() {
        let rows: String = (0..=1000)
            .map(|k| format!("X,both,{},{},0,0\n", f64::from(k) * 0.001, (k % 2) * 5))
            .collect();
        let m = map(&rows);
        let (a, b) = (Vec3::new(0.0005, 0.0, 0.0), Vec3::new(0.9995, 0.0, 0.0));
        let o = adaptive(0.1);
        let t = targets_of(&feed(a, b), &o, &m, ALL_FORWARD).unwrap();
        assert!(t.len() as f64 <= target_count_bound(&feed(a, b), &o));
        for w in t.windows(2) {
            assert!((w[1] - w[0]).norm() >= 0.01 - 1e-12);
        }
    }
}
