//! Which nominal move each simulated command was written for, and the
//! distance of an actual tool position from that move.
//!
//! Nothing here searches the nominal path for the closest part: a program
//! that volcomp wrote says where each of its lines comes from. Every line
//! that volcomp inserts carries a trace comment `(volcomp Ln)`,
//! `(volcomp Ln take-up)` or `(volcomp Ln cycle)` naming the original line
//! `n`; every other line is an original line, rewritten in place, in the
//! original's order. A program judged against itself is paired line by line.
//! The path a command was meant to follow is then the original block's
//! motion, known exactly (its straight segment, or its arc as RS274/NGC
//! states it, see [`volcomp_gcode::Arc`]).

pub use crate::geometry::arc_distance_mm;
use crate::simulate::point_segment_distance;
use volcomp_gcode::{Motion, MotionKind, Vec3};

/// How far (mm) a compensated spline command may end from the chord it was
/// written for (corrections are micrometres), and how much farther the
/// pairing looks ahead.
const SPLINE_PAIRING_MM: f64 = 1.0;

/// The trace comment of a line written by volcomp, if it carries one:
/// the original line number it names.
///
/// ```
/// use volcomp_core::simulate::nominal::trace_tag;
/// assert_eq!(trace_tag(b"G1 X1 (volcomp L12 take-up)\n"), Some(12));
/// assert_eq!(trace_tag(b"G1 X1 (cut)\n"), None);
/// ```
pub fn trace_tag(line: &[u8]) -> Option<u64> {
    const TAG: &[u8] = b"(volcomp L";
    let at = line.windows(TAG.len()).position(|w| w == TAG)? + TAG.len();
    let digits = line[at..].iter().take_while(|b| b.is_ascii_digit()).count();
    if digits == 0 || digits > 18 {
        return None;
    }
    let text = std::str::from_utf8(&line[at..at + digits]).ok()?;
    text.parse().ok()
}

/// Whether a motion moves at feed (a straight feed or an arc), as opposed to
/// a rapid.
pub fn is_feed_like(m: &Motion) -> bool {
    !matches!(m.kind, MotionKind::Rapid)
}

/// One original block and how far its written commands have got through it.
#[derive(Debug, Clone)]
pub struct NominalBlock {
    /// 1-based line of the original program.
    pub line: u64,
    /// The block's motions in the original program, in order.
    pub motions: Vec<Motion>,
    /// Index of the motion the last written command was paired with.
    current: Option<usize>,
    /// The original line itself (rewritten) has been seen in the written
    /// program: later untagged lines belong to later blocks.
    pub own_line_written: bool,
    /// Arc parameter of the last sample judged against the current motion
    /// (which turn of a multi-turn arc a sample is on).
    arc_hint: f64,
}

impl NominalBlock {
    /// A block of the original program with its motions.
    pub fn new(line: u64, motions: &[Motion], own_line_written: bool) -> Self {
        Self {
            line,
            motions: motions.to_vec(),
            current: None,
            own_line_written,
            arc_hint: 0.0,
        }
    }

    /// Pairs the next written motion, which moves the command from `from`
    /// to `to` at feed (`feed`) or rapid, with one of the block's motions,
    /// in order; `None` when the block has no such motion left.
    ///
    /// A block with one motion takes every command written for it (its
    /// splits, take-ups and arc chords). A block with several (an expanded
    /// canned cycle) is followed in order: a written rapid takes the next
    /// rapid; a written feed move stays with the current feed motion unless
    /// it moves against that motion's direction, and otherwise takes the
    /// next feed motion it does not move against (a take-up at the reversal
    /// of G85/G89 moves in the direction of the return feed; one that moves
    /// only an axis across the feed stays with it).
    pub fn pair(&mut self, from: Vec3, to: Vec3, feed: bool) -> Option<usize> {
        self.pair_via(from, None, to, feed)
    }

    /// [`Self::pair`], knowing also the command's middle point `mid` (an
    /// arc command's point at half its sweep): in a cutter-compensated
    /// block the command is paired by its end and its middle, so one whose
    /// end lies at a corner, where two motions meet, pairs with the motion
    /// it runs along, not with the one that starts there.
    pub fn pair_via(
        &mut self,
        from: Vec3,
        mid: Option<Vec3>,
        to: Vec3,
        feed: bool,
    ) -> Option<usize> {
        if self.motions.len() == 1 {
            self.set_current(0);
            return Some(0);
        }
        if feed && self.motions[0].source == volcomp_gcode::MotionSource::Spline {
            if let Some(j) = self.pair_spline(to) {
                self.set_current(j);
                return Some(j);
            }
        }
        if self
            .motions
            .iter()
            .any(|m| m.source == volcomp_gcode::MotionSource::CutterComp)
        {
            if let Some(j) = self.pair_nearest(mid, to, feed) {
                self.set_current(j);
                return Some(j);
            }
        }
        let d = to - from;
        let along =
            |m: &Motion| is_feed_like(m) == feed && (!feed || d.dot(m.end - m.start) >= 0.0);
        if let Some(i) = self.current {
            if feed && along(&self.motions[i]) {
                return Some(i);
            }
        }
        let start = self.current.map_or(0, |i| i + 1);
        let j = (start..self.motions.len()).find(|&j| {
            let m = &self.motions[j];
            along(m) && !(feed && m.start == m.end)
        })?;
        self.set_current(j);
        Some(j)
    }

    /// A spline's chords all run the same way, so a command is paired by
    /// position: with the chord, from the current one on, that minimises
    /// its distance to the chord plus half its distance to the chord's end
    /// (so a command ending at a chord's end pairs with that chord, not the
    /// next one that starts there). The scan stops once the chords are
    /// [`SPLINE_PAIRING_MM`] farther than the best.
    fn pair_spline(&self, to: Vec3) -> Option<usize> {
        let mut best: Option<(f64, usize)> = None;
        for j in self.current.unwrap_or(0)..self.motions.len() {
            let m = &self.motions[j];
            let seg = point_segment_distance(to, m.start, m.end);
            if best.is_some_and(|(b, _)| seg > b + SPLINE_PAIRING_MM) {
                break;
            }
            let score = seg + 0.5 * (to - m.end).norm();
            if best.is_none_or(|(b, _)| score < b) {
                best = Some((score, j));
            }
        }
        best.filter(|(b, _)| *b <= SPLINE_PAIRING_MM)
            .map(|(_, j)| j)
    }

    /// A block of the cutter-compensated tool-centre path (a released move,
    /// a corner arc, a move along the normal axis, in any mix) is paired by
    /// position: the motion of the command's kind (feed or rapid), from the
    /// current one on, nearest to the command's end (arcs measured to the
    /// arc), the earlier one where two
    /// are as near (a command at a corner belongs to the move it ends).
    /// With the command's middle `mid`, the score is the mean of the
    /// distances of the end and the middle.
    fn pair_nearest(&mut self, mid: Option<Vec3>, to: Vec3, feed: bool) -> Option<usize> {
        self.nearest(mid, to, feed).map(|(_, j)| j)
    }

    /// Whether this is a block of the cutter-compensated tool-centre path.
    pub fn is_cutter(&self) -> bool {
        self.motions
            .iter()
            .any(|m| m.source == volcomp_gcode::MotionSource::CutterComp)
    }

    /// The score (mm) by which a command would pair with this block's
    /// nearest motion ([`Self::pair_via`] on a cutter-compensated block),
    /// or `None` when none is near enough; the block's pairing state is
    /// left as it was.
    pub fn nearest_mm(&mut self, mid: Option<Vec3>, to: Vec3, feed: bool) -> Option<f64> {
        let hint = self.arc_hint;
        let d = self.nearest(mid, to, feed).map(|(d, _)| d);
        self.arc_hint = hint;
        d
    }

    fn nearest(&mut self, mid: Option<Vec3>, to: Vec3, feed: bool) -> Option<(f64, usize)> {
        let mut best: Option<(f64, usize)> = None;
        for j in self.current.unwrap_or(0)..self.motions.len() {
            if is_feed_like(&self.motions[j]) != feed {
                continue;
            }
            let score = match mid {
                Some(p) => 0.5 * (self.distance_mm(j, p) + self.distance_mm(j, to)),
                None => self.distance_mm(j, to),
            };
            if best.is_none_or(|(b, _)| score < b - 1e-9) {
                best = Some((score, j));
            }
        }
        best.filter(|(b, _)| *b <= SPLINE_PAIRING_MM)
    }

    /// Pairs written motion `i` of a line that is this block's own line,
    /// unchanged in its number of motions, with the block's motion `i`.
    pub fn pair_index(&mut self, i: usize) -> Option<usize> {
        (i < self.motions.len()).then(|| {
            self.set_current(i);
            i
        })
    }

    fn set_current(&mut self, i: usize) {
        if self.current != Some(i) {
            self.current = Some(i);
            self.arc_hint = 0.0;
        }
    }

    /// Distance (mm) from `p` to motion `i` of the block.
    pub fn distance_mm(&mut self, i: usize, p: Vec3) -> f64 {
        let m = self.motions[i];
        match m.kind {
            MotionKind::Arc(arc) => arc_distance_mm(p, &arc, &mut self.arc_hint),
            _ => point_segment_distance(p, m.start, m.end),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;
    use volcomp_gcode::{Arc, MotionSource, Plane};

    fn quarter() -> Arc {
        // Centre (0,0,0), radius 10, from (10,0) counter-clockwise to (0,10).
        Arc {
            start: Vec3::new(10.0, 0.0, 0.0),
            end: Vec3::new(0.0, 10.0, 0.0),
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: TAU / 4.0,
        }
    }

    #[test]
    fn distance_to_a_circle_is_radial_inside_the_sweep_and_to_the_end_outside() {
        let arc = quarter();
        let mut hint = 0.0;
        // At 45°, 3 µm outside the radius and 4 µm above the plane: 5 µm.
        let c = std::f64::consts::FRAC_1_SQRT_2 * 10.003;
        let d = arc_distance_mm(Vec3::new(c, c, 0.004), &arc, &mut hint);
        assert!((d - 0.005).abs() < 1e-12, "{d}");
        // At −90° (outside the sweep), the nearer end is the start (10,0):
        // from (0,−10) that is √200.
        let d = arc_distance_mm(Vec3::new(0.0, -10.0, 0.0), &arc, &mut hint);
        assert!((d - 200f64.sqrt()).abs() < 1e-12, "{d}");
    }

    #[test]
    fn a_helix_turn_is_chosen_by_the_previous_sample() {
        // Two full turns of radius 10, rising 2 mm: at angle 0 the helix is
        // at z = 0, 1 and 2. A point at (10, 0, 1.001) is 1 µm above the
        // middle turn, which rises 1 mm per 20π mm: its distance to the helix
        // is 1 µm · cos(atan(1 / 20π)).
        let arc = Arc {
            start: Vec3::new(10.0, 0.0, 0.0),
            end: Vec3::new(10.0, 0.0, 2.0),
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: 2.0 * TAU,
        };
        let mut hint = 0.5;
        let d = arc_distance_mm(Vec3::new(10.0, 0.0, 1.001), &arc, &mut hint);
        let expected = 0.001 * (1.0 / (20.0 * std::f64::consts::PI)).atan().cos();
        assert!((d - expected).abs() < 1e-12, "{d} vs {expected}");
        assert!((hint - 0.5).abs() < 1e-6);
    }

    #[test]
    fn the_closest_point_of_a_steep_helix_is_found_off_its_angle() {
        // Radius 0.3 mm, a quarter turn rising 0.5 mm. A point 10 µm from
        // the helix along its normal in the plane of the axis direction and
        // the tangent (binormal): its angle about the axis differs from its
        // foot's, so the point at its angle is farther than 10 µm.
        let r = 0.3;
        let arc = Arc {
            start: Vec3::new(r, 0.0, 0.0),
            end: Vec3::new(0.0, r, 0.5),
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: TAU / 4.0,
        };
        let t = 0.5;
        let foot = arc.point_at(t);
        let a = TAU / 8.0;
        // Tangent (dθ/dt = π/2, dz/dt = 0.5) and the binormal-like normal
        // orthogonal to it and to the radial direction.
        let tangent = Vec3::new(-r * a.sin() * TAU / 4.0, r * a.cos() * TAU / 4.0, 0.5);
        let radial = Vec3::new(a.cos(), a.sin(), 0.0);
        let n = Vec3::new(
            radial.y * tangent.z - radial.z * tangent.y,
            radial.z * tangent.x - radial.x * tangent.z,
            radial.x * tangent.y - radial.y * tangent.x,
        );
        let p = foot + n * (0.01 / n.norm());
        let mut hint = 0.0;
        let d = arc_distance_mm(p, &arc, &mut hint);
        assert!((d - 0.01).abs() < 1e-6, "{d}");
    }

    #[test]
    fn a_cycle_is_followed_in_order() {
        // G85-like: rapid to the hole, feed down, feed back up.
        let m = |kind, a: [f64; 3], b: [f64; 3]| Motion {
            kind,
            source: MotionSource::Cycle,
            start: Vec3::new(a[0], a[1], a[2]),
            end: Vec3::new(b[0], b[1], b[2]),
            line: 7,
            column: 1,
            feed: 100.0,
            feed_mode: volcomp_gcode::FeedMode::PerMinute,
            path_mode: Default::default(),
            extra: Default::default(),
        };
        let motions = [
            m(MotionKind::Rapid, [0.0, 0.0, 5.0], [1.0, 1.0, 5.0]),
            m(MotionKind::Feed, [1.0, 1.0, 5.0], [1.0, 1.0, 0.0]),
            m(MotionKind::Feed, [1.0, 1.0, 0.0], [1.0, 1.0, 5.0]),
        ];
        let mut b = NominalBlock::new(7, &motions, true);
        let p = |z: f64| Vec3::new(1.0, 1.0, z);
        assert_eq!(b.pair(Vec3::new(0.0, 0.0, 5.0), p(5.0), false), Some(0));
        assert_eq!(b.pair(p(5.0), p(4.0), true), Some(1));
        // A take-up across the feed (Y only) stays with it.
        assert_eq!(b.pair(p(4.0), Vec3::new(1.0, 1.002, 4.0), true), Some(1));
        assert_eq!(b.pair(p(4.0), p(0.0), true), Some(1));
        // The take-up (2 µm up) and the return belong to the second feed.
        assert_eq!(b.pair(p(0.0), p(0.002), true), Some(2));
        assert_eq!(b.pair(p(0.002), p(5.0), true), Some(2));
        // Nothing is left for another rapid.
        assert_eq!(b.pair(p(5.0), p(6.0), false), None);
        assert_eq!(trace_tag(b"G1 Z0 (volcomp L7 cycle)"), Some(7));
    }

    /// A tool-centre path: a side to (10, 0), the corner arc about (10, 1)
    /// to (11, 1). The side's last command, compensated, ends 1 µm past
    /// the corner, (10.001, 0): 1 µm from the side's end but only
    /// √(1 + 10⁻⁶) − 1 ≈ 0.5 nm from the arc's circle, so by its end alone
    /// it would pair with the arc; its middle (7.5, 0) lies on the side and
    /// 2.5 mm from the arc, so by both it pairs with the side.
    #[test]
    fn a_command_ending_at_a_corner_pairs_with_the_move_it_runs_along() {
        let m = |kind, a: [f64; 2], b: [f64; 2]| Motion {
            kind,
            source: MotionSource::CutterComp,
            start: Vec3::new(a[0], a[1], 0.0),
            end: Vec3::new(b[0], b[1], 0.0),
            line: 7,
            column: 1,
            feed: 100.0,
            feed_mode: volcomp_gcode::FeedMode::PerMinute,
            path_mode: Default::default(),
            extra: Default::default(),
        };
        let corner = Arc {
            start: Vec3::new(10.0, 0.0, 0.0),
            end: Vec3::new(11.0, 1.0, 0.0),
            center: Vec3::new(10.0, 1.0, 0.0),
            plane: Plane::Xy,
            sweep_rad: TAU / 4.0,
        };
        let motions = [
            m(MotionKind::Feed, [0.0, 0.0], [10.0, 0.0]),
            m(MotionKind::Arc(corner), [10.0, 0.0], [11.0, 1.0]),
        ];
        let (from, to) = (Vec3::new(5.0, 0.0, 0.0), Vec3::new(10.001, 0.0, 0.0));
        let mid = (from + to) * 0.5;
        let mut b = NominalBlock::new(7, &motions, true);
        assert_eq!(b.pair(from, to, true), Some(1));
        let mut b = NominalBlock::new(7, &motions, true);
        assert_eq!(b.pair_via(from, Some(mid), to, true), Some(0));
        // The arc's own command then pairs with the arc.
        let arc_mid = corner.point_at(0.5);
        assert_eq!(
            b.pair_via(to, Some(arc_mid), Vec3::new(11.0, 1.0, 0.0), true),
            Some(1)
        );
    }
}
