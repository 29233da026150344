//! From a program's moves to planner segments, as LinuxCNC's canonical
//! layer sends them (src/emc/task/emccanon.cc: `STRAIGHT_TRAVERSE`,
//! `STRAIGHT_FEED`, `ARC_FEED`, `SET_MOTION_CONTROL_MODE`, `see_segment`,
//! `linkable`, `flush_segments`, `chord_deviation`; [LinuxCNC tp]).
//!
//! Under `G64 P p Q q` with `q > 0` (Q defaults to P), consecutive feed
//! moves whose intermediate points all lie within `q` of the straight line
//! from the first start to the last end are sent as that one line (at most
//! 101 points), and an XY arc whose chord departs from it by less than `q`
//! is sent as two lines through its middle. A change of feed rate or of
//! path mode, a rapid or an arc ends such a chain.

use super::geometry::Circle;
use super::segment::{arc_limits, line_limits, Canon, Seg, Shape, Term};
use super::{Limits, Move, MoveKind, PathMode};
use volcomp_gcode::{Plane, Vec3};

/// The canonical layer's state.
#[derive(Debug, Clone)]
pub(crate) struct CanonState {
    end_point: Option<Vec3>,
    feed_mm_s: f64,
    mode: PathMode,
    /// Points of feed moves waiting to be sent as one line (naive CAM).
    chain: Vec<(Vec3, u64)>,
}

impl CanonState {
    pub fn new() -> Self {
        CanonState {
            end_point: None,
            feed_mm_s: 0.0,
            mode: PathMode::default(),
            chain: Vec::new(),
        }
    }

    fn term(&self) -> (Term, f64) {
        match self.mode {
            PathMode::ExactStop => (Term::Stop, 0.0),
            PathMode::ExactPath => (Term::Exact, 0.0),
            PathMode::Blend { tolerance_mm, .. } => (Term::Parabolic, tolerance_mm),
        }
    }

    fn naivecam_mm(&self) -> f64 {
        match self.mode {
            PathMode::Blend { naive_cam_mm, .. } => naive_cam_mm,
            _ => 0.0,
        }
    }

    /// A straight segment from the end point to `end`, appended to `out`
    /// (built in place, not copied through an `Option`; none below the
    /// resolution).
    fn line(&self, end: Vec3, canon: Canon, line: u64, limits: &Limits, out: &mut Vec<Seg>) {
        let Some(start) = self.end_point else {
            return;
        };
        let Some((v_max, acc)) = line_limits(end - start, limits) else {
            return;
        };
        let l = super::geometry::Line::new(start, end);
        if l.length_mm < 1e-12 {
            return;
        }
        let vel = match canon {
            Canon::Traverse => v_max,
            _ => self.feed_mm_s.min(v_max),
        };
        if vel <= 0.0 || acc <= 0.0 {
            return;
        }
        let (term, tol) = self.term();
        out.push(Seg::new(
            Shape::Line(l),
            canon,
            line,
            l.length_mm,
            vel,
            v_max,
            acc,
            term,
            tol,
            limits.servo_period_s,
        ));
    }

    /// Sends the chained feed moves as one line (`flush_segments`).
    fn flush(&mut self, limits: &Limits, out: &mut Vec<Seg>) {
        let Some(&(end, line)) = self.chain.last() else {
            return;
        };
        self.line(end, Canon::Feed, line, limits, out);
        self.end_point = Some(end);
        self.chain.clear();
    }

    /// Whether `p` may join the chain (`linkable`).
    fn linkable(&self, p: Vec3) -> bool {
        let tol = self.naivecam_mm();
        let Some(b) = self.end_point else {
            return false;
        };
        if tol == 0.0 || self.chain.len() > 100 || p == b {
            return false;
        }
        let m = p - b;
        self.chain.iter().all(|(q, _)| {
            let t0 = (m.dot(*q - b) / m.dot(m)).clamp(0.0, 1.0);
            (*q - (b + m * t0)).norm() <= tol
        })
    }

    /// A feed move's end point (`see_segment`).
    fn see(&mut self, p: Vec3, line: u64, limits: &Limits, out: &mut Vec<Seg>) {
        if !self.chain.is_empty() && !self.linkable(p) {
            self.flush(limits, out);
        }
        self.chain.push((p, line));
        if !matches!(self.mode, PathMode::Blend { .. }) || self.naivecam_mm() == 0.0 {
            // Without naive CAM a chain never grows: send it at once.
            self.flush(limits, out);
        }
    }

    /// Everything waiting is sent (before a wait, at the end).
    pub fn finish(&mut self, limits: &Limits, out: &mut Vec<Seg>) {
        self.flush(limits, out);
    }

    /// The segments `m` makes, appended to `out`.
    pub fn push(&mut self, m: &Move, limits: &Limits, out: &mut Vec<Seg>) {
        if self.end_point.is_none() {
            self.end_point = Some(m.start);
        }
        if m.mode != self.mode {
            self.flush(limits, out);
            self.mode = m.mode;
        }
        match m.kind {
            MoveKind::Rapid => {
                self.flush(limits, out);
                self.line(m.end, Canon::Traverse, m.line, limits, out);
                self.end_point = Some(m.end);
            }
            MoveKind::Feed => {
                self.set_feed(m.feed_mm_s, limits, out);
                self.see(m.end, m.line, limits, out);
            }
            MoveKind::Arc {
                center,
                plane,
                sweep_rad,
            } => {
                self.set_feed(m.feed_mm_s, limits, out);
                self.arc(m, center, plane, sweep_rad, limits, out);
            }
        }
    }

    /// `SET_FEED_RATE`: a new rate ends a naive-CAM chain.
    fn set_feed(&mut self, feed_mm_s: f64, limits: &Limits, out: &mut Vec<Seg>) {
        if feed_mm_s != self.feed_mm_s {
            self.flush(limits, out);
            self.feed_mm_s = feed_mm_s;
        }
    }

    fn arc(
        &mut self,
        m: &Move,
        center: Vec3,
        plane: Plane,
        sweep_rad: f64,
        limits: &Limits,
        out: &mut Vec<Seg>,
    ) {
        let (u, v, w) = plane.axes();
        let start = self.chain.last().map_or(m.start, |(p, _)| *p);
        let tol = self.naivecam_mm();
        if plane == Plane::Xy && matches!(self.mode, PathMode::Blend { .. }) && tol > 0.0 {
            let (dev, (mx, my)) = chord_deviation(
                (start.x, start.y),
                (m.end.x, m.end.y),
                (center.x, center.y),
                sweep_rad < 0.0,
            );
            if dev < tol {
                let mp = Vec3::new(mx, my, (start.z + m.end.z) / 2.0);
                self.see(mp, m.line, limits, out);
                self.see(m.end, m.line, limits, out);
                return;
            }
        }
        self.flush(limits, out);
        let start = self.end_point.unwrap_or(m.start);
        let mut e_u = Vec3::ZERO;
        e_u[u] = 1.0;
        let mut e_v = Vec3::ZERO;
        e_v[v] = 1.0;
        let n = e_u.cross(e_v);
        let normal = if sweep_rad < 0.0 { -n } else { n };
        let angle = sweep_rad.abs();
        let r0 = (start[u] - center[u]).hypot(start[v] - center[v]);
        let r1 = (m.end[u] - center[u]).hypot(m.end[v] - center[v]);
        let axis_len = m.end[w] - start[w];
        self.end_point = Some(m.end);
        if angle <= 0.0 {
            return;
        }
        let lim = arc_limits((u, v), m.end - start, r0, r1, angle, axis_len, limits);
        let circle = Circle::new(start, m.end, center, normal, angle);
        let length = circle.length_mm();
        let vel = self.feed_mm_s.min(lim.v_max);
        if length < 1e-12 || !(vel > 0.0 && lim.a_max > 0.0) {
            return;
        }
        let (term, tol) = self.term();
        out.push(Seg::new(
            Shape::Circle(circle),
            Canon::Arc,
            m.line,
            length,
            vel,
            lim.v_max,
            lim.a_max,
            term,
            tol,
            limits.servo_period_s,
        ));
    }
}

/// LinuxCNC's `chord_deviation` (src/emc/task/emccanon.cc): the sagitta of
/// the arc from `start` to `end` about `center` in the XY plane (mm) and
/// its middle point. The included angle is taken from the two end angles
/// alone, within one turn: the arc's full turns (`P`) do not count, so a
/// whole circle has the sagitta of its diameter, and an arc of more than a
/// turn that of its principal part. The 1e-5 rad margins and the second
/// correction (atan2's ±π edge) are LinuxCNC's.
pub(crate) fn chord_deviation(
    start: (f64, f64),
    end: (f64, f64),
    center: (f64, f64),
    clockwise: bool,
) -> (f64, (f64, f64)) {
    let th1 = (start.1 - center.1).atan2(start.0 - center.0);
    let mut th2 = (end.1 - center.1).atan2(end.0 - center.0);
    let r = (start.1 - center.1).hypot(start.0 - center.0);
    for _ in 0..2 {
        let dth = th2 - th1;
        if clockwise && dth >= -1e-5 {
            th2 -= 2.0 * std::f64::consts::PI;
        } else if !clockwise && dth <= 1e-5 {
            th2 += 2.0 * std::f64::consts::PI;
        }
    }
    let included = (th2 - th1).abs();
    let mid = (th2 + th1) / 2.0;
    let dev = r * (1.0 - (included / 2.0).cos());
    (dev, (center.0 + r * mid.cos(), center.1 + r * mid.sin()))
}
