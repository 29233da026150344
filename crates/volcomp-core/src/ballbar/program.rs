//! The LinuxCNC program that runs a circular test: for each run, a rapid
//! to the start of the feed-in arc, the feed-in arc, the whole circle (one
//! G2/G3 whose end is its start: a full turn, LinuxCNC 2.9
//! `src/emc/rs274ngc/interp_arc.cc`), the feed-out arc; the runs follow
//! each other without a stop, the same path [`super::predict`] simulates.
//! Positions are written in the axis frame under G53-free G54 with a zero
//! offset assumed: run it with the work offset that makes program and
//! machine coordinates the same, or shift the centre by it.

use super::predict::TestCircle;
use super::{BallbarError, Plane, Sense};
use std::fmt::Write;

/// A number in mm with at most six decimals, trailing zeros dropped.
fn mm(v: f64) -> String {
    crate::io::numfmt::mm(v)
}

/// The axis words of point `p` in the plane (`X… Y…` for XY).
fn words(plane: Plane, p: volcomp_gcode::Vec3) -> String {
    let (u, v) = plane.axes();
    let (nu, nv) = plane.axis_names();
    format!("{nu}{} {nv}{}", mm(p[u]), mm(p[v]))
}

/// The arc-centre words (`I`, `J`, `K` for X, Y, Z) from `from` to `centre`.
fn centre_words(plane: Plane, from: volcomp_gcode::Vec3, centre: volcomp_gcode::Vec3) -> String {
    let (u, v) = plane.axes();
    let letter = |a: usize| ['I', 'J', 'K'][a];
    let (a, b) = if u < v { (u, v) } else { (v, u) };
    format!(
        "{}{} {}{}",
        letter(a),
        mm(centre[a] - from[a]),
        letter(b),
        mm(centre[b] - from[b])
    )
}

/// The program of `test` (LinuxCNC dialect, mm).
pub fn program(test: &TestCircle) -> Result<String, BallbarError> {
    test.check()?;
    let c = test.centre_mm;
    let r = test.radius_mm;
    let at = |deg: f64| test.plane.point(c, r, deg.to_radians());
    let (nu, nv) = test.plane.axis_names();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "(volcomp ballbar test, ISO 230-4: plane {}, radius {} mm, centre X{} Y{} Z{}, F{} mm/min)",
        test.plane.name(),
        mm(r),
        mm(c.x),
        mm(c.y),
        mm(c.z),
        mm(test.feed_mm_per_min)
    );
    let _ = writeln!(
        s,
        "(data arc from {} deg, from {nu} toward {nv}; feed-in and feed-out arcs {} deg)",
        mm(test.start_deg),
        mm(test.overshoot_deg)
    );
    let _ = writeln!(s, "G21 G90 G94 G40 G49 G54 {} G61", test.plane.gcode());
    let (u, v) = test.plane.axes();
    let w = 3 - u - v;
    let nw = b"XYZ"[w] as char;
    let first = test.start_deg - test.senses[0].sign() * test.overshoot_deg;
    let _ = writeln!(s, "G0 {nw}{}", mm(c[w]));
    let _ = writeln!(s, "G0 {}", words(test.plane, at(first)));
    let _ = writeln!(s, "F{}", mm(test.feed_mm_per_min));
    for sense in &test.senses {
        let g = match sense {
            Sense::Ccw => "G3",
            Sense::Cw => "G2",
        };
        let sg = sense.sign();
        let from = test.start_deg - sg * test.overshoot_deg;
        let _ = writeln!(s, "({} run)", sense.name());
        // An arc of 360° is a full turn: written as one G2/G3 back to its start.
        let arc = |s: &mut String, a0: f64, a1: f64| {
            let _ = writeln!(
                s,
                "{g} {} {}",
                words(test.plane, at(a1)),
                centre_words(test.plane, at(a0), c)
            );
        };
        arc(&mut s, from, test.start_deg);
        arc(&mut s, test.start_deg, test.start_deg + sg * 360.0);
        arc(
            &mut s,
            test.start_deg,
            test.start_deg + sg * test.overshoot_deg,
        );
    }
    let _ = writeln!(s, "M2");
    Ok(s)
}
