//! Splines: G5 (cubic), G5.1 (quadratic) and G5.2/G5.3 (NURBS blocks),
//! linearised into feed chords in the axis frame.
//!
//! The reference is LinuxCNC 2.9's `Interp::convert_spline` and
//! `Interp::convert_nurbs` (src/emc/rs274ngc/interp_convert.cc) and the
//! NURBS evaluation of nurbs_additional_functions.cc, as the installed
//! `rs274` (2.9.0~pre1) runs them:
//!
//! * G5 `I J P Q X Y`: a cubic Bézier from the current point `P0` through
//!   the control points `P1 = P0 + (I, J)` and `P2 = P3 + (P, Q)` to the end
//!   `P3` (X, Y as any motion's end, also in G91 and with polar words). I
//!   and J are given both or neither; without them `P1 = P0 − (P, Q)` of the
//!   previous G5 (LinuxCNC keeps `−P, −Q` in `cycle_i`/`cycle_j`), so
//!   consecutive G5 blocks join with a continuous tangent. P and Q are
//!   required.
//! * G5.1 `I J X Y`: a quadratic Bézier `P0`, `P0 + (I, J)`, end.
//! * G5.2 `X Y P L` … G5.3: a NURBS of order L (default 3; an L of 3 or
//!   less is ignored, as LinuxCNC does) whose first control point is the
//!   current point (weight 1, or P of a first G5.2 line without X and Y) and
//!   whose other control points are the X Y of the G5.2 lines that follow
//!   (in G91 each relative to the point where the block began: LinuxCNC
//!   does not move the current point before G5.3), each with its weight P.
//!   G5.3 ends the block and makes the motion; the knot vector is
//!   LinuxCNC's clamped uniform one (`knot_vector_creator`). Changing the
//!   motion mode before G5.3 discards the points, as in LinuxCNC.
//!
//! All three are planar in X and Y: LinuxCNC refuses G5/G5.1 outside G17
//! and with Z, A, B or C words. volcomp also refuses a Z word on a G5.2 line
//! (LinuxCNC reads and ignores it) and U, V, W words (the stand-alone
//! `rs274` has no U, V, W).
//!
//! Linearisation: on the controller, `NURBS_FEED` (src/emc/task/emccanon.cc)
//! splits the curve into `4 × control points` pieces and moves each as a
//! biarc through the exact curve's points and tangents. volcomp follows the
//! exact curve with chords (counted per knot span) no farther than
//! [`InterpOptions::spline_tolerance_mm`](super::InterpOptions) from it (the
//! count from the largest second difference of the curve sampled densely),
//! the last chord ending exactly at the end point. The path therefore
//! differs from the controller's by the biarcs' own deviation plus the
//! chord tolerance.

use super::options::MotionMode;
use super::words::WordTable;
use super::{invalid, Interpreter, Motion, MotionKind, MotionSource};
use crate::error::GcodeError;
use crate::geom::{Plane, Vec3};

/// Most chords one spline block may become: a larger count means a
/// tolerance far below the machine's resolution.
pub const MAX_SPLINE_CHORDS: usize = 100_000;
/// Most control points of one G5.2 block.
pub const MAX_NURBS_POINTS: usize = 10_000;
/// Highest NURBS order (L) accepted.
pub const MAX_NURBS_ORDER: usize = 20;

/// The control points of a G5.2 block being read: `[x, y, weight]` in the
/// axis frame (mm), and the order.
#[derive(Debug, Clone)]
pub(super) struct NurbsBlock {
    points: Vec<[f64; 3]>,
    order: usize,
}

/// A planar rational B-spline with LinuxCNC's clamped uniform knot vector:
/// `k` zeros, then `1 … n − k + 1`, then `k` times `n − k + 2`, for the
/// control points `0 … n` and order `k`.
pub struct Nurbs<'a> {
    points: &'a [[f64; 3]],
    order: usize,
    knots: Vec<f64>,
}

impl<'a> Nurbs<'a> {
    /// `None` unless `2 ≤ order ≤ points.len()`.
    pub fn new(points: &'a [[f64; 3]], order: usize) -> Option<Self> {
        if order < 2 || order > points.len() {
            return None;
        }
        let n = points.len() - 1;
        let knots = (0..=n + order)
            .map(|i| {
                if i < order {
                    0.0
                } else if i <= n {
                    (i - order + 1) as f64
                } else {
                    (n + 2 - order) as f64
                }
            })
            .collect();
        Some(Self {
            points,
            order,
            knots,
        })
    }

    /// The parameter's end, `n − k + 2` (the number of knot spans).
    pub fn u_max(&self) -> f64 {
        (self.points.len() + 1 - self.order) as f64
    }

    /// The point at parameter `u ∈ [0, u_max]` (de Boor's algorithm in
    /// homogeneous coordinates); `None` where the weights sum to zero.
    pub fn point(&self, u: f64) -> Option<(f64, f64)> {
        let p = self.order - 1;
        let n = self.points.len() - 1;
        let u = u.clamp(0.0, self.u_max());
        // The span s with knots[s] ≤ u < knots[s + 1], s ∈ [p, n].
        let s = ((u.floor() as usize) + p).min(n);
        let mut d: Vec<[f64; 3]> = (0..=p)
            .map(|j| {
                let [x, y, w] = self.points[s - p + j];
                [x * w, y * w, w]
            })
            .collect();
        for r in 1..=p {
            for j in (r..=p).rev() {
                let i = s - p + j;
                let den = self.knots[i + p + 1 - r] - self.knots[i];
                let a = if den > 0.0 {
                    (u - self.knots[i]) / den
                } else {
                    0.0
                };
                let prev = d[j - 1];
                for (v, pv) in d[j].iter_mut().zip(prev) {
                    *v = (1.0 - a) * pv + a * *v;
                }
            }
        }
        let [x, y, w] = d[p];
        (w != 0.0 && (x / w).is_finite() && (y / w).is_finite()).then(|| (x / w, y / w))
    }
}

/// Parameters of the chord ends (the last one `u_max`) that keep every
/// chord within `tol` of the curve. Each knot span `[j, j + 1]` gets its own
/// count `⌈1.25 · √(M_j / 8 tol)⌉`, `M_j` the largest `|C''|` estimated from
/// second differences on 32 samples of the span (the sagitta of a chord
/// over `Δu` is at most `Δu² · M / 8`), so a sharp bend in one span does not
/// multiply the chords of the others. `None` when the curve is undefined
/// somewhere or needs more than [`MAX_SPLINE_CHORDS`] chords.
fn chord_params(curve: &Nurbs<'_>, tol: f64) -> Option<Vec<f64>> {
    const SAMPLES: usize = 32;
    let tol = if tol > 0.0 { tol } else { 1e-4 };
    let spans = curve.u_max() as usize;
    let h = 1.0 / SAMPLES as f64;
    let mut params = Vec::new();
    let mut pts = Vec::with_capacity(SAMPLES + 1);
    for j in 0..spans {
        pts.clear();
        for i in 0..=SAMPLES {
            pts.push(curve.point(j as f64 + h * i as f64)?);
        }
        let mut max_dd = 0.0f64;
        for w in pts.windows(3) {
            let ddx = w[0].0 - 2.0 * w[1].0 + w[2].0;
            let ddy = w[0].1 - 2.0 * w[1].1 + w[2].1;
            max_dd = max_dd.max(ddx.hypot(ddy) / (h * h));
        }
        let n = (1.25 * (max_dd / (8.0 * tol)).sqrt()).ceil().max(1.0);
        if params.len() as f64 + n > MAX_SPLINE_CHORDS as f64 {
            return None;
        }
        let n = n as usize;
        for k in 1..=n {
            params.push(j as f64 + k as f64 / n as f64);
        }
    }
    Some(params)
}

impl Interpreter {
    /// Runs a block in a spline mode (`code` 50, 51, 52 or 53 for G5, G5.1,
    /// G5.2, G5.3), appending its chords to `out`.
    pub(super) fn spline(
        &mut self,
        line: u64,
        col: usize,
        w: &WordTable,
        code: u16,
        out: &mut Vec<Motion>,
    ) -> Result<(), GcodeError> {
        if let Some(c) = w.extra_col() {
            return Err(invalid(
                line,
                c,
                "splines may not move the extra axes; LinuxCNC refuses A, B and C in them (\"Splines may not have motion in Z, A, B, or C\")",
                "move the extra axes on a line of their own",
            ));
        }
        if let Some(c) = w.col(b'Z') {
            return Err(invalid(
                line,
                c,
                if code == 52 {
                    "Z word on a NURBS control point: LinuxCNC reads it and ignores it (NURBS are in X and Y), so it does not mean what it says"
                } else {
                    "splines are planar in X and Y; LinuxCNC refuses a Z word on them (\"Splines may not have motion in Z, A, B, or C\")"
                },
                "move Z on a line of its own",
            ));
        }
        if matches!(code, 50 | 51) && self.plane != Plane::Xy {
            return Err(invalid(
                line,
                col,
                "G5 and G5.1 splines are in the XY plane only; LinuxCNC refuses them while G18 or G19 is in effect (\"Splines must be in the XY plane\")",
                "select G17 before the spline",
            ));
        }
        if matches!(code, 50 | 51) {
            self.check_polar(line, w, MotionMode::Spline(code))?;
        }
        let p0 = self.position;
        let k = self.units.mm_per_unit();
        let mm = |v: f64| v * k;
        let need = |letter: u8, msg: &str| -> Result<f64, GcodeError> {
            w.get(letter)
                .ok_or_else(|| invalid(line, col, msg, "add the missing word"))
        };
        let (points, order): (Vec<[f64; 3]>, usize) = match code {
            50 => {
                let (i, j) = match (w.get(b'I'), w.get(b'J')) {
                    (Some(i), Some(j)) => (i, j),
                    (None, None) => self.spline_tangent.unwrap_or((0.0, 0.0)),
                    _ => {
                        return Err(invalid(
                            line,
                            w.col(b'I').or(w.col(b'J')).unwrap_or(col),
                            "G5 needs both I and J, or neither (\"Must specify both I and J, or neither\")",
                            "give both I and J, or leave both out to continue the previous G5's tangent",
                        ))
                    }
                };
                let end = self.target(w);
                let msg = "G5 needs both P and Q (\"Must specify both P and Q with G5\")";
                let (p, q) = (need(b'P', msg)?, need(b'Q', msg)?);
                self.spline_tangent = Some((-p, -q));
                (
                    vec![
                        [p0.x, p0.y, 1.0],
                        [p0.x + mm(i), p0.y + mm(j), 1.0],
                        [end.x + mm(p), end.y + mm(q), 1.0],
                        [end.x, end.y, 1.0],
                    ],
                    4,
                )
            }
            51 => {
                let msg = "G5.1 needs both I and J (\"Must specify both I and J with G5.1\")";
                let (i, j) = (need(b'I', msg)?, need(b'J', msg)?);
                let end = self.target(w);
                (
                    vec![
                        [p0.x, p0.y, 1.0],
                        [p0.x + mm(i), p0.y + mm(j), 1.0],
                        [end.x, end.y, 1.0],
                    ],
                    3,
                )
            }
            52 => return self.nurbs_point(line, col, w),
            _ => {
                if let Some(c) = [0u16, 10, 20, 30, 50, 51, 800, 810, 820, 850, 890]
                    .into_iter()
                    .find_map(|c| w.g_col(c))
                {
                    return Err(invalid(line, c, "between G5.2 and G5.3 only further G5.2 codes are allowed; LinuxCNC refuses another motion code on the G5.3 line", "put this motion on a line of its own after G5.3"));
                }
                let Some(block) = self.nurbs.take() else {
                    return Err(invalid(
                        line,
                        col,
                        "G5.3 without a G5.2 block before it; LinuxCNC refuses it (\"Cannot use G5.3 without G5.2 first\")",
                        "start the NURBS with G5.2 and its control points",
                    ));
                };
                self.motion_mode = None;
                if block.points.len() < block.order {
                    return Err(invalid(
                        line,
                        col,
                        format!("the NURBS has {} control points, fewer than its order L = {}; LinuxCNC refuses it", block.points.len(), block.order),
                        "give at least as many control points as the order",
                    ));
                }
                (block.points, block.order)
            }
        };
        let curve = Nurbs::new(&points, order)
            .ok_or_else(|| invalid(line, col, "degenerate spline", "check the control points"))?;
        let params = chord_params(&curve, self.options.spline_tolerance_mm).ok_or_else(|| {
            invalid(
                line,
                col,
                format!("this spline is undefined somewhere (weights summing to zero) or needs more than {MAX_SPLINE_CHORDS} chords to stay within the spline tolerance"),
                "check the control points and weights, or raise the spline tolerance",
            )
        })?;
        let last = points[points.len() - 1];
        let feed = self.to_mm(self.feed);
        let n = params.len();
        for (k, u) in params.into_iter().enumerate() {
            let (x, y) = if k + 1 == n {
                (last[0], last[1])
            } else {
                curve.point(u).unwrap_or((last[0], last[1]))
            };
            let end = Vec3::new(x, y, p0.z);
            self.push(
                out,
                MotionKind::Feed,
                MotionSource::Spline,
                end,
                line,
                col,
                feed,
            )?;
        }
        Ok(())
    }

    /// A G5.2 line: starts the block or adds a control point.
    fn nurbs_point(&mut self, line: u64, col: usize, w: &WordTable) -> Result<(), GcodeError> {
        let (x, y) = (w.get(b'X').is_some(), w.get(b'Y').is_some());
        if x != y {
            return Err(invalid(
                line,
                w.col(b'X').or(w.col(b'Y')).unwrap_or(col),
                "a NURBS control point needs both X and Y (\"You must specify both X and Y coordinates for Control Points\")",
                "give both X and Y",
            ));
        }
        if w.has_polar() {
            return Err(invalid(
                line,
                w.polar_col().unwrap_or(col),
                "polar words (@, ^) on a NURBS control point are not interpreted",
                "give the control point as X and Y",
            ));
        }
        let p = w.get(b'P');
        let started = self.nurbs.is_some();
        if started && !x && p.is_some_and(|p| p > 0.0) {
            return Err(invalid(line, w.col(b'P').unwrap_or(col), "P without X and Y is only for the first control point (\"Can specify P without X and Y only for the first control point\")", "give the control point's X and Y"));
        }
        if p.is_none_or(|p| p <= 0.0) && (started || x) {
            return Err(invalid(
                line,
                w.col(b'P').unwrap_or(col),
                "every NURBS control point needs a positive weight P (\"Must specify positive weight P for every Control Point\")",
                "add P1 for an ordinary control point",
            ));
        }
        let p0 = self.position;
        let block = self.nurbs.get_or_insert_with(|| {
            let w0 = match p {
                Some(p) if !x && p > 0.0 => p,
                _ => 1.0,
            };
            Box::new(NurbsBlock {
                points: vec![[p0.x, p0.y, w0]],
                order: 3,
            })
        });
        if let Some(l) = w.get(b'L') {
            if l.fract() != 0.0 {
                return Err(invalid(
                    line,
                    w.col(b'L').unwrap_or(col),
                    "the NURBS order L must be a whole number",
                    "fix the L word",
                ));
            }
            if l > 3.0 {
                if l > MAX_NURBS_ORDER as f64 {
                    return Err(invalid(
                        line,
                        w.col(b'L').unwrap_or(col),
                        format!("NURBS order L above {MAX_NURBS_ORDER}: LinuxCNC's evaluation takes time exponential in the order, and CAM writes orders of 3 to 5"),
                        "use a smaller order",
                    ));
                }
                block.order = l as usize;
            }
        }
        if x {
            if block.points.len() >= MAX_NURBS_POINTS {
                return Err(invalid(
                    line,
                    col,
                    format!("more than {MAX_NURBS_POINTS} NURBS control points in one block"),
                    "split the NURBS into several G5.2 … G5.3 blocks",
                ));
            }
            let weight = p.unwrap_or(1.0);
            let t = self.target(w);
            if let Some(b) = self.nurbs.as_mut() {
                b.points.push([t.x, t.y, weight]);
            }
        }
        Ok(())
    }

    /// Whether a G5.2 block is being read (its control-point lines make no
    /// motion; G5.3 makes it).
    pub fn in_nurbs_block(&self) -> bool {
        self.nurbs.is_some()
    }

    /// Drops a G5.2 block whose motion mode changed before G5.3, as
    /// LinuxCNC does.
    /// (Inlined, and the block looked at first: a line outside a G5.2
    /// block has nothing to drop, and the drop was a call per line.)
    #[inline]
    pub(super) fn end_spline_block_unless(&mut self, mode: Option<MotionMode>) {
        if self.nurbs.is_some() && !matches!(mode, Some(MotionMode::Spline(52 | 53))) {
            self.nurbs = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Control points of weight 1.
    fn weight_1(xy: &[[f64; 2]]) -> Vec<[f64; 3]> {
        xy.iter().map(|&[x, y]| [x, y, 1.0]).collect()
    }

    #[test]
    fn cubic_bezier_midpoint_by_hand() {
        // P0 (0,0), P1 (0,3), P2 (5,-2), P3 (1,1): B(½) = (P0 + 3P1 + 3P2 + P3)/8
        // = ((0 + 0 + 15 + 1)/8, (0 + 9 − 6 + 1)/8) = (2, 0.5).
        let pts = weight_1(&[[0.0, 0.0], [0.0, 3.0], [5.0, -2.0], [1.0, 1.0]]);
        let c = Nurbs::new(&pts, 4).unwrap();
        assert_eq!(c.u_max(), 1.0);
        let (x, y) = c.point(0.5).unwrap();
        assert!((x - 2.0).abs() < 1e-12 && (y - 0.5).abs() < 1e-12);
        assert_eq!(c.point(1.0).unwrap(), (1.0, 1.0));
        assert_eq!(c.point(0.0).unwrap(), (0.0, 0.0));
    }

    #[test]
    fn quadratic_midpoint_and_rational_circle() {
        // Quadratic (0,0), (2,2), (4,0): B(½) = (P0 + 2P1 + P2)/4 = (2, 1).
        let pts = [[0.0, 0.0, 1.0], [2.0, 2.0, 1.0], [4.0, 0.0, 1.0]];
        let (x, y) = Nurbs::new(&pts, 3).unwrap().point(0.5).unwrap();
        assert!((x - 2.0).abs() < 1e-12 && (y - 1.0).abs() < 1e-12);
        // A quarter circle as a rational quadratic: weights 1, √½, 1.
        let s = 0.5f64.sqrt();
        let pts = [[1.0, 0.0, 1.0], [1.0, 1.0, s], [0.0, 1.0, 1.0]];
        let c = Nurbs::new(&pts, 3).unwrap();
        for k in 0..=10 {
            let (x, y) = c.point(k as f64 / 10.0).unwrap();
            assert!((x.hypot(y) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn knot_vector_spans() {
        // Five points, order 3: knots 0 0 0 1 2 3 3 3, u_max 3. At u = 1
        // (an interior knot) only P1, P2 contribute: (P1 + P2)/2 for a
        // uniform quadratic B-spline.
        let pts = weight_1(&[[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [4.0, 2.0], [4.0, 4.0]]);
        let c = Nurbs::new(&pts, 3).unwrap();
        assert_eq!(c.u_max(), 3.0);
        let (x, y) = c.point(1.0).unwrap();
        assert!((x - 2.0).abs() < 1e-12 && (y - 1.0).abs() < 1e-12);
        assert_eq!(c.point(3.0).unwrap(), (4.0, 4.0));
    }

    #[test]
    fn chords_stay_within_tolerance() {
        let pts = weight_1(&[[0.0, 0.0], [0.0, 30.0], [50.0, -20.0], [10.0, 10.0]]);
        let c = Nurbs::new(&pts, 4).unwrap();
        let tol = 1e-3;
        let params = chord_params(&c, tol).unwrap();
        let n = params.len();
        let mut worst = 0.0f64;
        for k in 0..n {
            let (u0, u1) = (if k == 0 { 0.0 } else { params[k - 1] }, params[k]);
            let a = c.point(u0).unwrap();
            let b = c.point(u1).unwrap();
            for s in 1..20 {
                let p = c.point(u0 + (u1 - u0) * s as f64 / 20.0).unwrap();
                let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                let d = ((p.0 - a.0) * dy - (p.1 - a.1) * dx).abs() / dx.hypot(dy);
                worst = worst.max(d);
            }
        }
        assert!(worst <= tol, "worst {worst} with {n} chords");
    }
}
