//! An arc's pieces at a G64 corner split only past 0.4 µm (docs/compensation.md,
//! "Arcs: pieces at a blended corner split only past 0.4 µm").
//!
//! LinuxCNC 2.9 sizes the blend at a corner next to an arc by the arc
//! segment itself, not by the blend's need alone: a blend arc takes at most
//! a third of the next arc's angle and two thirds of the previous one's
//! (`phi2_max`, `phi1_max`), and where the arc bends away from the corner
//! (`convex`) only `sin(φ_max / 4)·r` of it, about a twelfth (a sixth) of
//! its length (src/emc/tp/blendmath.c, `blendInit3FromLineArc`,
//! `blendInit3FromArcArc`; the planner model: plan/blend.rs); a parabolic
//! blend runs into a segment at no more than `√(a_t·ℓ/2)` for a segment of
//! `ℓ` (tp.c, `tpComputeBlendVelocity`). A compensated arc is written as
//! pieces of itself; where the piece at a corner is a fraction of the
//! block, the corner's blend is that fraction as large and slower. Measured
//! on the planner model (set c's inch R arcs, nominal pieces, no map): the
//! same pieces inside the arc cost nothing, the pieces at the corners
//! everything: 0.13 mm corner pieces +19.5 %, 4 mm +6.9 %, 7.6 mm +2.4 %.
//!
//! So under G64 without P ([`super::TakeUpRule::Always`]: the tool may
//! leave the path by the reversal value at a reversal, the blend itself
//! leaves it by much more) an arc after a corner the planner blends with
//! an arc has zones at its ends: twelve times the blend distance the feed
//! needs (`Run::protect_mm` is twice it) from that corner, and six times it
//! from its end (the corner there is not known when the arc is compensated;
//! it is taken as the one at its start, as a line's end zone is,
//! `Run::split_end_mm`). A piece between quarter points (where an axis
//! reverses and its take-up is planned) that lies inside a zone is halved
//! only where it leaves the path by more than the run-through tolerance
//! (0.4 µm, what a G64 ramp may leave) instead of the contour tolerance
//! (super::arcs::arc_pieces_zoned). No zone after a parabolic blend (a
//! plunge into a circle ran faster with the contour tolerance's pieces:
//! set a g2_d40, ripple map, −9.5 % as main, −8.2 % with the whole circle
//! one zone), and no start zone where the arc starts planar after the
//! corner (its planar split needs the piece as the contour tolerance cut
//! it: set c g18_d20, example map, +10.4 → +21.6 % with it).

use super::points::Run;

/// How many blend distances from a corner before an arc no split is kept:
/// a convex blend takes about a twelfth of the piece after the corner
/// (`sin(φ₂/4)·r`, `φ₂` a third of its angle; blendmath.c).
pub(super) const START_ZONE_BLENDS: f64 = 12.0;

/// How many blend distances from an arc's end no split is kept: a convex
/// blend takes about a sixth of the piece before the corner (`φ₁` two
/// thirds of its angle; blendmath.c).
pub(super) const END_ZONE_BLENDS: f64 = 6.0;

/// The zones at the ends of an arc run as `run` under `rule`
/// ([`super::arcs::arc_pieces_zoned`]): their lengths from the start and
/// from the end (mm), and the tolerances (in the plane, along its normal;
/// mm) their pieces are halved past: the run-through tolerance
/// ([`super::points::RUN_THROUGH_TOLERANCE_MM`], 0.4 µm, what a G64 ramp
/// may leave) where the `tolerances_mm` are tighter. No zones but under
/// G64 without P at a feed per minute after a corner the planner blends.
pub(super) fn zones(
    rule: super::TakeUpRule,
    run: &Run,
    planar_before: bool,
    tolerances_mm: (f64, f64),
) -> ((f64, f64), (f64, f64)) {
    let loose = super::points::RUN_THROUGH_TOLERANCE_MM;
    let zone_tolerances_mm = (tolerances_mm.0.max(loose), tolerances_mm.1.max(loose));
    let none = ((0.0, 0.0), tolerances_mm);
    if rule != super::TakeUpRule::Always
        || run.feed_mm_min.is_none()
        || !run.corner_before
        || run.parabolic_before
        || run.protect_mm.is_nan()
        || run.protect_mm <= 0.0
    {
        return none;
    }
    let d_mm = 0.5 * run.protect_mm;
    // After a corner the motion before ended planar at, the arc's start is
    // split planar at the blend's reach (compensate/planar.rs), which needs
    // the piece as the contour tolerance cut it (its normal coordinate
    // between the piece's ends).
    let start_mm = if planar_before {
        0.0
    } else {
        START_ZONE_BLENDS * d_mm
    };
    ((start_mm, END_ZONE_BLENDS * d_mm), zone_tolerances_mm)
}

/// How far from a corner between two arcs of one plane the part of an arc
/// written planar there (compensate/planar.rs) reaches before it is
/// shortened to its tolerance (mm): the blend distance the feed needs
/// (`Run::protect_mm`'s half, `run` the motion after the corner); under G64
/// without P as far as the blend arc may take of the part at that distance:
/// [`START_ZONE_BLENDS`] of them after the corner, [`END_ZONE_BLENDS`]
/// before it (the blend arc takes at most a twelfth, a sixth of the part:
/// blendmath.c `phi2_max`, `phi1_max`). At most half the piece
/// (`planar_split`).
pub(super) fn planar_reach_mm(
    rule: super::TakeUpRule,
    run: &Run,
    side: super::planar::Side,
) -> f64 {
    let d_mm = 0.5 * run.protect_mm;
    if rule != super::TakeUpRule::Always {
        return d_mm;
    }
    match side {
        super::planar::Side::Start => START_ZONE_BLENDS * d_mm,
        super::planar::Side::End => END_ZONE_BLENDS * d_mm,
    }
}
