//! How the controller's trajectory planner joins the pieces a compensation
//! writes: LinuxCNC 2.9's rules ([LinuxCNC tp] in docs/references.md), so
//! the pieces are ones it runs at the programmed feed and joins without a
//! stop where the original had none (docs/compensation.md, "Pieces the
//! planner runs at full speed").
//!
//! * **Tangency** (`tpSetupTangent`, src/emc/tp/tp.c): two segments join
//!   without a stop or a blend when, with `v` the slower one's target
//!   velocity (its feed, capped by its length per servo period `T`),
//!   `a_inst = v/T + a` and `Δt` the change of the unit tangent,
//!   `max_i a_inst·|Δt_i| / A_i` stays below `ARC_BLEND_KINK_RATIO` (0.1 by
//!   default), the ratio doubled where an arc takes part
//!   (`BLEND_ACC_RATIO_TANGENTIAL` 0.5, blendmath.h). Otherwise G61 stops
//!   there (TC_TERM_COND_EXACT: `tpChooseBestBlend` makes no blend) and G64
//!   blends; G61.1 stops at every block end.
//! * **Length clamp** (`tcClampVelocityByLength`, src/emc/tp/tc.c): a
//!   segment runs no faster than its length per servo period.
//! * **Blend distance** (`blendComputeParameters`, src/emc/tp/blendmath.c;
//!   `tcFindBlendTolerance`, tc.c): under G64 a corner of deflection `φ`
//!   (half-angle `θ = (π − φ)/2` between the segments) is rounded by an arc
//!   of radius `R = tan θ · d` that leaves the segments `d` before and after
//!   the corner, `d` at most half of each neighbour; its speed is
//!   `√(a_n R)`, `a_n = A·√(1 − 0.5²)` (`BLEND_ACC_RATIO_NORMAL`). A piece
//!   next to a corner shorter than twice the `d` the feed needs slows the
//!   corner down.

use volcomp_gcode::lexer::Word;
use volcomp_gcode::{PathMode, Vec3};

/// `ARC_BLEND_KINK_RATIO`'s default ([TRAJ] in the INI, initraj.cc).
const KINK_RATIO: f64 = 0.1;

/// Half the angle within which two tangents are anti-parallel for the
/// planner, which stops there instead of blending (`tpSetupTangent`, tp.c:
/// `|u₁ + u₂| < 2°`).
pub(super) const REVERSAL_HALF_ANGLE_RAD: f64 = std::f64::consts::PI / 180.0;

/// `BLEND_ACC_RATIO_TANGENTIAL` (blendmath.h): the share of the
/// acceleration an arc may use along its path; the tangency ratio is
/// divided by it where an arc takes part.
const ARC_TANGENTIAL_RATIO: f64 = 0.5;

/// The machine's limits that the planner's joins depend on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannerLimits {
    /// Largest acceleration of X, Y, Z (mm/s²; LinuxCNC's `[AXIS_*]
    /// MAX_ACCELERATION`).
    pub max_acceleration_mm_s2: [f64; 3],
    /// The servo period (s; LinuxCNC's `[EMCMOT] SERVO_PERIOD`, 1 ms by
    /// default).
    pub servo_period_s: f64,
}

impl Default for PlannerLimits {
    /// 1,000 mm/s² per axis (the cycle-time benchmark's machine,
    /// bench/cycle_time/config) and LinuxCNC's default 1 ms servo period.
    fn default() -> Self {
        Self {
            max_acceleration_mm_s2: [1000.0; 3],
            servo_period_s: 0.001,
        }
    }
}

/// The deflection `φ` (rad) of a corner from unit tangent `t1` to `t2`:
/// the angle between them, which the blend distances turn on.
pub fn deflection_rad(t1: Vec3, t2: Vec3) -> f64 {
    t1.dot(t2).clamp(-1.0, 1.0).acos()
}

impl PlannerLimits {
    /// The target velocity (mm/s) of a segment of `length_mm` at
    /// `feed_mm_min`: the feed, capped by the length per servo period.
    pub fn segment_velocity_mm_s(&self, feed_mm_min: f64, length_mm: f64) -> f64 {
        (feed_mm_min / 60.0).min(length_mm / self.servo_period_s)
    }

    /// The shortest segment (mm) the planner runs at `feed_mm_min`: its
    /// length per servo period.
    pub fn shortest_at_feed_mm(&self, feed_mm_min: f64) -> f64 {
        feed_mm_min / 60.0 * self.servo_period_s
    }

    /// How far the unit tangent may turn along axis `i` at a join run at
    /// `v_mm_s` for the planner to take it as tangent (see the module
    /// documentation); halved where an arc takes part.
    pub fn tangent_tolerance(&self, v_mm_s: f64, arc: bool) -> [f64; 3] {
        let a = self
            .max_acceleration_mm_s2
            .iter()
            .fold(0.0f64, |m, x| m.max(*x));
        let a_inst = v_mm_s / self.servo_period_s + a;
        let k = if arc {
            KINK_RATIO * ARC_TANGENTIAL_RATIO
        } else {
            KINK_RATIO
        };
        self.max_acceleration_mm_s2.map(|ai| k * ai / a_inst)
    }

    /// How much of the tangency tolerance the turn from unit tangent `t1`
    /// to `t2` uses at `v_mm_s` (below 1: tangent).
    pub fn kink_ratio(&self, t1: Vec3, t2: Vec3, v_mm_s: f64, arc: bool) -> f64 {
        let tol = self.tangent_tolerance(v_mm_s, arc);
        (0..3).fold(0.0f64, |m, i| m.max((t2[i] - t1[i]).abs() / tol[i]))
    }

    /// The normal acceleration of a blend (mm/s²): the smallest axis limit
    /// times `BLEND_ACC_RATIO_NORMAL` (a blend's plane may lie along any
    /// two axes).
    pub(super) fn blend_normal_acceleration(&self) -> f64 {
        let a = self
            .max_acceleration_mm_s2
            .iter()
            .fold(f64::INFINITY, |m, x| m.min(*x));
        a * (1.0 - ARC_TANGENTIAL_RATIO * ARC_TANGENTIAL_RATIO).sqrt()
    }

    /// The distance (mm) before and after a G64 corner from unit tangent
    /// `t1` to `t2` that a blend at `v_mm_s` needs: `d = R / tan θ` with
    /// `R = v²/a_n` (module documentation); 0 where the segments are
    /// collinear.
    pub fn blend_distance_mm(&self, t1: Vec3, t2: Vec3, v_mm_s: f64) -> f64 {
        self.blend_distance_at_mm(deflection_rad(t1, t2), v_mm_s)
    }

    /// [`Self::blend_distance_mm`] at a corner of deflection `phi`
    /// ([`deflection_rad`]).
    pub fn blend_distance_at_mm(&self, phi: f64, v_mm_s: f64) -> f64 {
        if phi <= 1e-12 {
            return 0.0;
        }
        let theta = 0.5 * (std::f64::consts::PI - phi);
        let radius = v_mm_s * v_mm_s / self.blend_normal_acceleration();
        radius / theta.tan()
    }

    /// How far from the corner between the unit tangents `t1` and `t2` a
    /// blend whose arc keeps within `tolerance_mm` of the corner (G64 P)
    /// may reach (mm): an arc of radius `R` tangent to both lines at `d`
    /// from the corner passes `R/sin θ − R` from it (`θ` half the angle
    /// between the lines, `d = R/tan θ`), so `d = tol · cos θ / (1 − sin θ)`
    /// (tp.c, `tpCreateLineLineBlend`: the blend's deviation is limited by
    /// the segment's tolerance). Infinite where the lines are collinear.
    pub fn blend_distance_within_mm(&self, t1: Vec3, t2: Vec3, tolerance_mm: f64) -> f64 {
        self.blend_distance_within_at_mm(deflection_rad(t1, t2), tolerance_mm)
    }

    /// [`Self::blend_distance_within_mm`] at a corner of deflection `phi`
    /// ([`deflection_rad`]).
    pub fn blend_distance_within_at_mm(&self, phi: f64, tolerance_mm: f64) -> f64 {
        if phi <= 1e-12 {
            return f64::INFINITY;
        }
        let theta = 0.5 * (std::f64::consts::PI - phi);
        tolerance_mm * theta.cos() / (1.0 - theta.sin())
    }

    /// The farthest from a corner of unknown angle the planner's blend can
    /// reach into a line of `length_mm` run at `v_mm_s` (mm): the largest,
    /// over the half-angle `θ` between the segments, of
    /// `min(L/2, R/tan θ, T·tan(π/4 + θ/2))` (`blendComputeParameters`,
    /// blendmath.c: `d` is at most half a neighbour, at most
    /// `d_tol = T cos θ/(1 − sin θ) = T tan(π/4 + θ/2)` for the blend
    /// tolerance `T`, and at full speed `R = v²/a_n`). `T` is the G64 P
    /// tolerance `tolerance_mm` (at most a quarter of the line), or under
    /// G64 without P a quarter of the line (`tcFindBlendTolerance`, tc.c;
    /// a shorter neighbour only makes it smaller). The speed term falls
    /// and the tolerance term rises with `θ`, so the largest is where they
    /// meet: with `t = tan(θ/2)`, `R(1 − t)² = 2Tt`, so
    /// `t = (R + T − √(T² + 2RT))/R` and `d = T(1 + t)/(1 − t)`.
    ///
    /// A corner whose tangents are anti-parallel within 2° is a reversal,
    /// which stops (`tpSetupTangent`), so `θ ≥ 1°`.
    ///
    /// A split nearer than twice this to the end of a line whose next
    /// move is not known yet may cut that corner's blend short (a blend
    /// takes at most half of the piece next to it).
    pub fn blend_reach_any_corner_mm(
        &self,
        v_mm_s: f64,
        length_mm: f64,
        tolerance_mm: Option<f64>,
    ) -> f64 {
        let half = 0.5 * length_mm;
        let quarter = 0.25 * length_mm;
        let t_mm = tolerance_mm.map_or(quarter, |p| p.min(quarter));
        let r_mm = v_mm_s * v_mm_s / self.blend_normal_acceleration();
        if !(t_mm > 0.0 && r_mm > 0.0) {
            return 0.0;
        }
        let t = (r_mm + t_mm - (t_mm * t_mm + 2.0 * r_mm * t_mm).sqrt()) / r_mm;
        let reach = if 2.0 * t.atan() >= REVERSAL_HALF_ANGLE_RAD {
            t_mm * (1.0 + t) / (1.0 - t)
        } else {
            // Where they meet the corner is a reversal, which stops: the
            // sharpest corner blended has the largest reach.
            r_mm / REVERSAL_HALF_ANGLE_RAD.tan()
        };
        reach.min(half)
    }
}

/// The path-control words that keep the arc pieces of one block arcs
/// under `G64 P p Q q` (Q is P where the program gives none): before the
/// pieces `G64 P p Q0`, after them the program's `G64 P p Q q` again, in the
/// program's units (`mm_per_unit`: before the block's line, and on it).
///
/// LinuxCNC 2.9's canonical layer writes an arc whose chord deviation is
/// below the naive-CAM tolerance q as two lines through its middle
/// (emccanon.cc `ARC_FEED`) and merges consecutive lines that lie within q
/// of one line (`linkable`): the short arc pieces of a compensated arc,
/// whose deviation is micrometres, would reach the planner as corners. The
/// original arc, longer, is one arc; its pieces stay arcs under Q0, and
/// what follows the block runs under the program's own Q again.
///
/// `None` where the mode is not G64 with both P and a naive-CAM tolerance,
/// where the block's line carries Q, a path-control word, or a P that is
/// not an arc's turn count (a line is left as the program wrote it), or
/// where p or q rounds to nothing in the program's units. `arc`: the block
/// is an arc, whose P is its turn count (rs274ngc reads P on a G2/G3 line
/// as the number of turns; the written pieces drop it, and the words here
/// stand on lines of their own): an arc of more than one turn is wrapped
/// as any other.
pub(super) fn naive_cam_words<'a>(
    mode: PathMode,
    mut words: impl Iterator<Item = &'a Word>,
    mm_per_unit: (f64, f64),
    arc: bool,
    sep: &str,
) -> Option<(String, String)> {
    let PathMode::Blend {
        tolerance_mm,
        naive_cam_mm,
    } = mode
    else {
        return None;
    };
    if !(tolerance_mm > 0.0 && naive_cam_mm > 0.0) {
        return None;
    }
    if words.any(|w| {
        (w.letter == b'P' && !arc)
            || w.letter == b'Q'
            || (w.letter == b'G'
                && [61.0, 61.1, 64.0]
                    .iter()
                    .any(|g| (w.value - g).abs() < 1e-9))
    }) {
        return None;
    }
    let text = |mm: f64, per: f64| -> Option<String> {
        let t = format!("{:.8}", mm / per);
        let t = t.trim_end_matches('0').trim_end_matches('.');
        (t != "0" && !t.is_empty()).then(|| t.to_string())
    };
    let before = format!("G64{sep}P{}{sep}Q0", text(tolerance_mm, mm_per_unit.0)?);
    let after = format!(
        "G64{sep}P{}{sep}Q{}",
        text(tolerance_mm, mm_per_unit.1)?,
        text(naive_cam_mm, mm_per_unit.1)?
    );
    Some((before, after))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The words read back as LinuxCNC reads them: P and Q in the units in
    /// effect, Q0 turning naive-CAM off for the pieces only.
    #[test]
    fn arc_pieces_under_g64_p_run_without_naive_cam_and_the_program_s_q_comes_back() {
        let mode = PathMode::Blend {
            tolerance_mm: 0.005,
            naive_cam_mm: 0.005,
        };
        let none: [Word; 0] = [];
        let (before, after) = naive_cam_words(mode, none.iter(), (1.0, 1.0), true, " ").unwrap();
        assert_eq!(before, "G64 P0.005 Q0");
        assert_eq!(after, "G64 P0.005 Q0.005");
        // Inch: P0.0002 in = 0.00508 mm, Q0.001 in; written back in inch.
        let mode = PathMode::Blend {
            tolerance_mm: 0.0002 * 25.4,
            naive_cam_mm: 0.001 * 25.4,
        };
        let (before, after) = naive_cam_words(mode, none.iter(), (25.4, 25.4), true, "").unwrap();
        assert_eq!(before, "G64P0.0002Q0");
        assert_eq!(after, "G64P0.0002Q0.001");
        // No naive-CAM (Q0, or G64 without P), or another mode: nothing.
        for mode in [
            PathMode::Blend {
                tolerance_mm: 0.005,
                naive_cam_mm: 0.0,
            },
            PathMode::Blend {
                tolerance_mm: 0.0,
                naive_cam_mm: 0.0,
            },
            PathMode::ExactPath,
        ] {
            assert_eq!(
                naive_cam_words(mode, none.iter(), (1.0, 1.0), true, " "),
                None
            );
        }
    }

    /// An arc's turn count (P on a G2/G3 line, rs274ngc) does not keep its
    /// pieces from being wrapped; a P on a line that is not an arc, a Q or
    /// a path-control word of the line's own does.
    #[test]
    fn an_arc_of_two_turns_is_wrapped_and_a_line_s_own_p_or_q_is_left_alone() {
        let mode = PathMode::Blend {
            tolerance_mm: 0.005,
            naive_cam_mm: 0.005,
        };
        let words = |s: &str| {
            let mut l = volcomp_gcode::lexer::Lexed::default();
            volcomp_gcode::lexer::lex_block(s.as_bytes(), &mut l).unwrap();
            l.words().cloned().collect::<Vec<Word>>()
        };
        let turns = words("G3 X15 Y0 I-15 J0 P2");
        let (before, after) = naive_cam_words(mode, turns.iter(), (1.0, 1.0), true, " ").unwrap();
        assert_eq!(
            (before.as_str(), after.as_str()),
            ("G64 P0.005 Q0", "G64 P0.005 Q0.005")
        );
        assert_eq!(
            naive_cam_words(mode, turns.iter(), (1.0, 1.0), false, " "),
            None
        );
        for own in ["G3 X15 Y0 I-15 J0 Q0.01", "G64 P0.01 G3 X15 Y0 I-15 J0"] {
            let w = words(own);
            assert_eq!(
                naive_cam_words(mode, w.iter(), (1.0, 1.0), true, " "),
                None,
                "{own}"
            );
        }
    }

    #[test]
    fn the_tangency_tolerance_is_the_kink_ratio_of_the_instant_acceleration() {
        // F6000 (100 mm/s), 1 ms, 1000 mm/s²: a_inst = 100 000 + 1000;
        // 0.1 · 1000 / 101 000 = 0.990 mrad for lines, half with an arc.
        let p = PlannerLimits::default();
        let t = p.tangent_tolerance(100.0, false);
        assert!((t[0] - 0.1 * 1000.0 / 101_000.0).abs() < 1e-15, "{t:?}");
        let t = p.tangent_tolerance(100.0, true);
        assert!((t[2] - 0.05 * 1000.0 / 101_000.0).abs() < 1e-15, "{t:?}");
        // A turn of 0.8 mrad about Z between two lines along X: tangent at
        // F6000, not with an arc.
        let a = 0.8e-3f64;
        let (t1, t2) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(a.cos(), a.sin(), 0.0));
        assert!(p.kink_ratio(t1, t2, 100.0, false) < 1.0);
        assert!(p.kink_ratio(t1, t2, 100.0, true) > 1.0);
    }

    #[test]
    fn a_right_angle_blend_at_full_speed_needs_its_radius() {
        // 90°: θ = 45°, d = R = v² / (1000·√0.75) = 10 000 / 866.03 = 11.547 mm.
        let p = PlannerLimits::default();
        let d = p.blend_distance_mm(Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), 100.0);
        assert!(
            (d - 10_000.0 / (1000.0 * 0.75f64.sqrt())).abs() < 1e-9,
            "{d}"
        );
        // Collinear: nothing to blend.
        let x = Vec3::new(1.0, 0.0, 0.0);
        assert_eq!(p.blend_distance_mm(x, x, 100.0), 0.0);
    }

    /// Under G64 P0.005 at F6000 (R = 11.547 mm) the reach of a blend at
    /// any corner is about `√(2RT)` = √(2 · 11.547 · 0.005) = 0.3398 mm
    /// (`θ` near π/2: `R/tan θ ≈ R ε`, `T tan(π/4 + θ/2) ≈ 2T/ε`); it is
    /// the largest over a fine sweep of `θ` (a second method); under G64
    /// without P a hexagon's 15 mm edge can be blended up to its middle
    /// (7.5 mm), and at F3000 a 30 mm line to 9.98 mm of its end.
    #[test]
    fn the_reach_of_a_blend_at_a_corner_not_known_yet() {
        let p = PlannerLimits::default();
        let d = p.blend_reach_any_corner_mm(100.0, 15.0, Some(0.005));
        assert!(
            (d - (2.0f64 * 11.547005 * 0.005).sqrt()).abs() < 1e-4,
            "{d}"
        );
        let sweep = |v: f64, l: f64, t: f64| {
            let r = v * v / (1000.0 * 0.75f64.sqrt());
            (1..20_000).fold(0.0f64, |m, k| {
                let th = f64::from(k) / 20_000.0 * std::f64::consts::FRAC_PI_2;
                let tol = t * (std::f64::consts::FRAC_PI_4 + th / 2.0).tan();
                m.max((r / th.tan()).min(tol).min(l / 2.0))
            })
        };
        for (v, l, t) in [(100.0, 15.0, 0.005), (50.0, 30.0, 7.5), (100.0, 60.0, 15.0)] {
            let tol = (t < 0.25 * l - 1e-12).then_some(t);
            let d = p.blend_reach_any_corner_mm(v, l, tol);
            assert!(
                (d - sweep(v, l, t)).abs() < 2e-3 * d.max(1.0),
                "{v} {l} {t}: {d}"
            );
        }
        assert!((p.blend_reach_any_corner_mm(100.0, 15.0, None) - 7.5).abs() < 1e-12);
        let d = p.blend_reach_any_corner_mm(50.0, 30.0, None);
        assert!((d - 9.978).abs() < 1e-3, "{d}");
        // F500 on a 200 mm line: R = 8.333²/866.03 = 0.0802 mm; the terms
        // would meet below 1°, at a reversal: the reach is R / tan 1° =
        // 4.594 mm.
        let v = 500.0 / 60.0;
        let d = p.blend_reach_any_corner_mm(v, 200.0, None);
        let r = v * v / (1000.0 * 0.75f64.sqrt());
        assert!((d - r / 1f64.to_radians().tan()).abs() < 1e-9, "{d}");
        assert!((d - 4.594).abs() < 1e-3, "{d}");
    }

    #[test]
    fn a_segment_shorter_than_its_feed_per_period_is_slowed() {
        let p = PlannerLimits::default();
        assert!((p.shortest_at_feed_mm(6000.0) - 0.1).abs() < 1e-12);
        assert!((p.segment_velocity_mm_s(6000.0, 0.05) - 50.0).abs() < 1e-9);
        assert!((p.segment_velocity_mm_s(6000.0, 1.0) - 100.0).abs() < 1e-9);
    }
}
