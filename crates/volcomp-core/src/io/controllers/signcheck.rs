//! A sign check on the machine for the formats whose sign convention no
//! public vendor text settles (docs/controllers.md, "Sign checks"): Siemens
//! sag/cross-axis tables, Fanuc pitch error compensation (one table and
//! bidirectional), Heidenhain's `BACKLASH` column (and the axis column
//! beside it), the ISG volumetric compensation (whose configuration may
//! negate axes that carry the workpiece).
//!
//! The check is two positions of one axis, both approached in the
//! direction the table is for, where the table's correction differs most.
//! An indicator (a laser, a dial indicator against a straightedge for a
//! cross table) zeroed at the first reads at the second the error's change
//! `Δe = e(B) − e(A)` with the table off and `Δe − Δc` with it on (`Δc`
//! the correction's change: the controller commands `q − c`). A table with
//! the wrong sign reads `Δe + Δc`, about twice the error: five minutes
//! tell whether the table halves the error or doubles it.

use super::{
    axis_letter, interpolate_held, ControllerCorrection, Export, ExportFile, Format, Positioning,
};
use crate::io::numfmt::fixed;

/// One check: an axis moving from `a_mm` to `b_mm` (in the direction of
/// the table checked), the indicator along `measured`.
#[derive(Debug, Clone, PartialEq)]
pub struct Probe {
    /// The moving axis (0, 1, 2).
    pub axis: usize,
    /// The axis the indicator measures along.
    pub measured: usize,
    /// First position (mm, machine coordinates).
    pub a_mm: f64,
    /// Second position.
    pub b_mm: f64,
    /// The map's change of error between them (µm): the reading, table off.
    pub off_um: f64,
    /// The table's change of correction between them (µm).
    pub table_um: f64,
    /// Which table this is.
    pub what: String,
    /// The option that flips the sign, for the instructions.
    pub switch: &'static str,
}

impl Probe {
    fn forward(&self) -> bool {
        self.b_mm > self.a_mm
    }
    fn start_mm(&self, approach_mm: f64) -> f64 {
        if self.forward() {
            self.a_mm - approach_mm
        } else {
            self.a_mm + approach_mm
        }
    }
}

/// The approach run before the first position (mm): backlash taken up.
const APPROACH_MM: f64 = 5.0;
/// Feed of the check's moves (mm/min).
const FEED: f64 = 500.0;

/// The pair of positions of `c` (on the points of `x`, kept `margin` from
/// the ends so the approach stays in the measured range) where it changes
/// most, ordered for travel `forward`.
fn pair(x: &[f64], c: impl Fn(f64) -> f64, forward: bool) -> Option<(f64, f64)> {
    let (lo, hi) = (*x.first()?, *x.last()?);
    let inner: Vec<f64> = x
        .iter()
        .copied()
        .filter(|&p| p >= lo + APPROACH_MM && p <= hi - APPROACH_MM)
        .collect();
    let (mut min, mut max) = (*inner.first()?, *inner.first()?);
    for &p in &inner {
        if c(p) < c(min) {
            min = p;
        }
        if c(p) > c(max) {
            max = p;
        }
    }
    if min == max {
        return None;
    }
    let (a, b) = if min < max { (min, max) } else { (max, min) };
    Some(if forward { (a, b) } else { (b, a) })
}

/// The probe of axis `a`'s table for travel `forward`.
fn axis_probe(
    a: usize,
    map: &Positioning,
    applied: &ControllerCorrection,
    forward: bool,
    what: String,
    switch: &'static str,
) -> Option<Probe> {
    let t = applied.axes[a].as_ref()?;
    let c = |q: f64| applied.correction_um(a, q, forward);
    let (pa, pb) = pair(&t.positions_mm, c, forward)?;
    let e = |q: f64| {
        interpolate_held(
            &map.positions_mm,
            if forward {
                &map.forward_um
            } else {
                &map.reverse_um
            },
            q,
        )
    };
    Some(Probe {
        axis: a,
        measured: a,
        a_mm: pa,
        b_mm: pb,
        off_um: e(pb) - e(pa),
        table_um: c(pb) - c(pa),
        what,
        switch,
    })
}

/// The probes of an export whose sign no vendor text settles (none for the
/// others). `map`: the map's positioning tables the export was made from;
/// `cross`: its straightness tables (input, output, table) for Siemens CEC.
pub fn probes(
    e: &Export,
    map: &[Option<Positioning>; 3],
    cross: &[(usize, usize, Positioning)],
) -> Vec<Probe> {
    let applied = &e.applied;
    let mut out = Vec::new();
    let largest = |ps: Vec<Probe>| {
        ps.into_iter()
            .max_by(|x, y| x.table_um.abs().total_cmp(&y.table_um.abs()))
    };
    // The largest probe of one axis table over `axes`: its `forward` side,
    // described as `what(axis)`, flipped by `switch`.
    let largest_along = |axes: &mut dyn Iterator<Item = usize>,
                         forward: bool,
                         what: &dyn Fn(usize) -> String,
                         switch: &'static str| {
        largest(
            axes.filter_map(|a| axis_probe(a, map[a].as_ref()?, applied, forward, what(a), switch))
                .collect(),
        )
    };
    match applied.format {
        Format::SiemensCec => {
            let ps = applied
                .cross
                .iter()
                .filter_map(|(i, o, t)| {
                    let (_, _, m) = cross.iter().find(|(mi, mo, _)| mi == i && mo == o)?;
                    let c = |q: f64| interpolate_held(&t.positions_mm, &t.forward_um, q);
                    let (pa, pb) = pair(&t.positions_mm, c, true)?;
                    let e = |q: f64| {
                        0.5 * (interpolate_held(&m.positions_mm, &m.forward_um, q)
                            + interpolate_held(&m.positions_mm, &m.reverse_um, q))
                    };
                    Some(Probe {
                        axis: *i,
                        measured: *o,
                        a_mm: pa,
                        b_mm: pb,
                        off_um: e(pb) - e(pa),
                        table_um: c(pb) - c(pa),
                        what: format!(
                            "the cross-axis table E{}{} ({} as a function of {})",
                            axis_letter(*o),
                            axis_letter(*i),
                            axis_letter(*o),
                            axis_letter(*i)
                        ),
                        switch: "cec_sign = correction",
                    })
                })
                .collect();
            out.extend(largest(ps));
        }
        Format::Fanuc | Format::Heidenhain => {
            let (fw, rv, switch) = match applied.format {
                Format::Fanuc => (
                    "the pitch error table for + travel",
                    "the pitch error table for - travel (bidirectional)",
                    "fanuc_sign = error",
                ),
                _ => (
                    "the axis' column of its .COM table (+ travel)",
                    "the BACKLASH column of its .COM table (- travel)",
                    "the other sign: the values are negated in the .COM tables",
                ),
            };
            out.extend(largest_along(
                &mut (0..3),
                true,
                &|a| format!("{fw} of {}", axis_letter(a)),
                switch,
            ));
            let two_way = |a: usize| {
                applied.axes[a]
                    .as_ref()
                    .is_some_and(|t| t.forward_um != t.reverse_um)
            };
            let mut reversing =
                (0..3).filter(|&a| applied.format == Format::Heidenhain || two_way(a));
            out.extend(largest_along(
                &mut reversing,
                false,
                &|a| format!("{rv} of {}", axis_letter(a)),
                switch,
            ));
        }
        Format::IsgCsv => {
            out.extend(largest_along(
                &mut (0..3),
                true,
                &|a| format!("the volumetric compensation along {}", axis_letter(a)),
                "negate (P-VOLC-00009) of the axis in the configuration list",
            ));
        }
        _ => {}
    }
    out
}

/// One probe's five lines: the run-up, A, the stop to zero the indicator,
/// B, the stop to read it; `to` writes a move to a position.
fn stops(pr: &Probe, to: impl Fn(f64) -> String, zero: &str, read: &str) -> [String; 5] {
    [
        to(pr.start_mm(APPROACH_MM)),
        to(pr.a_mm),
        zero.to_string(),
        to(pr.b_mm),
        read.to_string(),
    ]
}

/// Each probe as a comment naming it and its stops (`M0` commented A and
/// B), for the dialects whose comments start with `;`.
fn commented(probes: &[Probe], to: impl Fn(&Probe, f64) -> String) -> Vec<String> {
    probes
        .iter()
        .flat_map(|pr| {
            let zero = "M0 ; A: zero the indicator";
            let read = "M0 ; B: read the indicator";
            std::iter::once(format!("; {}", pr.what)).chain(stops(pr, |v| to(pr, v), zero, read))
        })
        .collect()
}

/// The controller dialect of a check program.
fn program(format: Format, probes: &[Probe]) -> Option<ExportFile> {
    let l = |a: usize| axis_letter(a);
    let p = |v: f64| fixed(v, 3);
    let mut lines: Vec<String> = Vec::new();
    let name;
    match format {
        Format::SiemensCec => {
            name = "SIGNCHECK.MPF";
            lines.push("; volcomp sign check (sign_check.txt): machine coordinates, SUPA".into());
            lines.push("G90 G71 G94".into());
            lines.extend(commented(probes, |pr, v| {
                format!("G1 SUPA {}{} F{FEED}", l(pr.axis), p(v))
            }));
            lines.push("M30".into());
        }
        Format::Fanuc => {
            name = "signcheck.nc";
            lines.push("%".into());
            lines.push("O9001 (VOLCOMP SIGN CHECK, SEE SIGN_CHECK.TXT)".into());
            for pr in probes {
                lines.push("G90 G94".into());
                lines.extend(stops(
                    pr,
                    |v| format!("G53 {}{}", l(pr.axis), p(v)),
                    "M00 (A: ZERO THE INDICATOR)",
                    "M00 (B: READ THE INDICATOR)",
                ));
            }
            lines.push("M30".into());
            lines.push("%".into());
        }
        Format::Heidenhain => {
            name = "SIGNCHECK.H";
            let mut body =
                vec!["; volcomp sign check (sign_check.txt): M91 machine coordinates".to_string()];
            let s = |v: f64| format!("{}{}", if v < 0.0 { "" } else { "+" }, p(v));
            body.extend(commented(probes, |pr, v| {
                format!("L {}{} R0 F{FEED} M91", l(pr.axis), s(v))
            }));
            lines.push("0 BEGIN PGM SIGNCHECK MM".into());
            for (k, b) in body.iter().enumerate() {
                lines.push(format!("{} {b}", k + 1));
            }
            lines.push(format!("{} END PGM SIGNCHECK MM", body.len() + 1));
        }
        Format::IsgCsv => {
            name = "signcheck.nc";
            lines.push("; volcomp sign check (sign_check.txt): machine coordinates (G53), compensation off, then on".into());
            let mut body = Vec::new();
            for pr in probes {
                for (on, state) in [("OFF", "off"), ("ON", "on")] {
                    body.push(format!("#VOLCOMP {on} [ID0]"));
                    let zero = format!("M00 ; A, compensation {state}: zero the indicator");
                    let read = format!("M00 ; B, compensation {state}: read the indicator");
                    let mut moves =
                        stops(pr, |v| format!("G01 {}{}", l(pr.axis), p(v)), &zero, &read);
                    // The run-up in machine coordinates, at the check's feed.
                    moves[0] = format!("G53 G90 {} F{FEED}", moves[0]);
                    body.extend(moves);
                }
            }
            body.push("M30".into());
            lines.extend(
                body.iter()
                    .zip(1..)
                    .map(|(b, k)| format!("N{} {b}", 10 * k)),
            );
        }
        _ => return None,
    }
    Some(ExportFile {
        name: name.into(),
        text: lines.join("\n") + "\n",
    })
}

/// `sign_check.txt` and the check program for the probes of `e` (nothing
/// for a format whose sign its vendor's documents settle, or a table too
/// flat to tell).
pub fn files(e: &Export, probes: &[Probe]) -> Vec<ExportFile> {
    if probes.is_empty() {
        return Vec::new();
    }
    let Some(prog) = program(e.applied.format, probes) else {
        return Vec::new();
    };
    let um = super::table_error::um;
    let mut t = format!(
        "volcomp sign check for {}: no public vendor document settles the sign of these values, so check it once on the machine.\n\
         {} moves each axis below to two positions in machine coordinates, approaching both in the direction of the table checked\n\
         (inside the map's measured range; run it in single block with a low feed override).\n\
         Fix an indicator along the measured axis (a laser, or a dial indicator against a straightedge for a cross-axis table),\n\
         zero it at A and read it at B: once with the compensation off, once with it on. The readings are the actual change\n\
         minus the commanded one, in um (e = actual - commanded).\n",
        e.applied.format.name(),
        prog.name
    );
    for pr in probes {
        let on = pr.off_um - pr.table_um;
        let wrong = pr.off_um + pr.table_um;
        t.push_str(&format!(
            "\n{}: {} moves from A = {} mm to B = {} mm ({}), the indicator along {}.\n  compensation off: {} um (the map's change of error)\n  compensation on:  {} um (the table removes {} um)\n  a reading near {} um (the error doubled) means the sign is the wrong way round: export again with {}.\n",
            pr.what,
            axis_letter(pr.axis),
            fixed(pr.a_mm, 3),
            fixed(pr.b_mm, 3),
            if pr.forward() { "+ travel" } else { "- travel" },
            axis_letter(pr.measured),
            um(pr.off_um),
            um(on),
            um(pr.table_um),
            um(wrong),
            pr.switch
        ));
        if pr.table_um.abs() < 2.0 {
            t.push_str(&format!("  The table changes by only {} um here: close to a machine's repeatability, so repeat the readings a few times.\n", um(pr.table_um)));
        }
    }
    vec![
        ExportFile {
            name: "sign_check.txt".into(),
            text: t,
        },
        prog,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::controllers::{fanuc, heidenhain};

    fn map() -> Positioning {
        // Forward 0 → 10 µm over 0 … 100 mm, reverse 4 µm above.
        Positioning {
            positions_mm: (0..=10).map(|i| 10.0 * i as f64).collect(),
            forward_um: (0..=10).map(|i| i as f64).collect(),
            reverse_um: (0..=10).map(|i| i as f64 + 4.0).collect(),
        }
    }

    #[test]
    fn fanuc_checks_both_tables_by_hand() {
        let m = map();
        let e = fanuc::export(
            &[Some(m.clone()), None, None],
            &fanuc::FanucOptions::default(),
        )
        .unwrap();
        let p = probes(&e, &[Some(m), None, None], &[]);
        assert_eq!(p.len(), 2, "{p:?}");
        // + travel from 10 to 90 mm (the table's inner points): the map's
        // error grows by 8 µm; the table corrects it fully (1 µm steps).
        assert_eq!((p[0].a_mm, p[0].b_mm), (10.0, 90.0));
        assert!(
            (p[0].off_um - 8.0).abs() < 1e-9 && (p[0].table_um - 8.0).abs() < 1e-9,
            "{:?}",
            p[0]
        );
        // − travel: from 90 down to 10, −8 µm.
        assert_eq!((p[1].a_mm, p[1].b_mm), (90.0, 10.0));
        assert!((p[1].off_um + 8.0).abs() < 1e-9, "{:?}", p[1]);
        let f = files(&e, &p);
        let text = &f[0].text;
        assert!(text.contains("compensation off: 8 um"), "{text}");
        assert!(text.contains("compensation on:  0 um"), "{text}");
        assert!(text.contains("near 16 um"), "{text}");
        assert!(f[1].text.contains("G53 X5\nG53 X10\nM00"), "{}", f[1].text);
        assert!(f[1].text.contains("G53 X95\nG53 X90\nM00"), "{}", f[1].text);
    }

    #[test]
    fn isg_numbers_its_blocks_and_checks_with_the_compensation_off_then_on() {
        let pr = Probe {
            axis: 1,
            measured: 1,
            a_mm: 10.0,
            b_mm: 90.0,
            off_um: 8.0,
            table_um: 8.0,
            what: "the volumetric compensation along Y".into(),
            switch: "negate",
        };
        let f = program(Format::IsgCsv, &[pr]).unwrap();
        assert_eq!(f.name, "signcheck.nc");
        // The run-up 5 mm before A, in machine coordinates, at F500.
        assert_eq!(
            f.text,
            "; volcomp sign check (sign_check.txt): machine coordinates (G53), compensation off, then on\n\
             N10 #VOLCOMP OFF [ID0]\nN20 G53 G90 G01 Y5 F500\nN30 G01 Y10\n\
             N40 M00 ; A, compensation off: zero the indicator\nN50 G01 Y90\n\
             N60 M00 ; B, compensation off: read the indicator\n\
             N70 #VOLCOMP ON [ID0]\nN80 G53 G90 G01 Y5 F500\nN90 G01 Y10\n\
             N100 M00 ; A, compensation on: zero the indicator\nN110 G01 Y90\n\
             N120 M00 ; B, compensation on: read the indicator\nN130 M30\n"
        );
    }

    #[test]
    fn heidenhain_checks_the_backlash_column() {
        let m = map();
        let e = heidenhain::export(&[Some(m.clone()), None, None]).unwrap();
        let p = probes(&e, &[Some(m), None, None], &[]);
        assert_eq!(p.len(), 2);
        assert!(p[1].what.contains("BACKLASH"));
        let f = files(&e, &p);
        assert_eq!(f[1].name, "SIGNCHECK.H");
        assert!(
            f[1].text.starts_with("0 BEGIN PGM SIGNCHECK MM\n"),
            "{}",
            f[1].text
        );
        assert!(f[1].text.contains("L X+90 R0 F500 M91"), "{}", f[1].text);
        // A LinuxCNC export needs no check.
        let l = crate::io::controllers::linuxcnc::export(
            &[Some(map()), None, None],
            crate::io::controllers::linuxcnc::LinuxcncExport::CompFiles(
                crate::io::linuxcnc_comp::CompFileType::Type1,
            ),
            crate::io::linuxcnc_comp::MachineUnits::Mm,
        )
        .unwrap();
        assert!(probes(&l, &[Some(map()), None, None], &[]).is_empty());
    }
}
