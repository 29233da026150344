//! The peek at the next line an event carries (`LineEvent::next`) and what
//! it rules out (`LineEvent::next_may_start_arc`), checked against the
//! interpreter running that line.

use crate::common;

use std::io::Cursor;
use std::path::PathBuf;
use volcomp_gcode::{InterpOptions, MotionKind, Setup, Walker};

/// What one event says of the line after it, and what it is itself.
struct Seen {
    number: u64,
    bytes: Vec<u8>,
    next: Option<Vec<u8>>,
    may_start_arc: bool,
    arc: bool,
}

fn walk<R: std::io::BufRead>(mut walker: Walker<R>) -> Vec<Seen> {
    let mut seen = Vec::new();
    while let Ok(Some(ev)) = walker.next_line() {
        seen.push(Seen {
            number: ev.number,
            bytes: ev.bytes.to_vec(),
            next: ev.next.bytes().map(<[u8]>::to_vec),
            may_start_arc: ev.next_may_start_arc(),
            arc: ev
                .motions
                .iter()
                .any(|m| matches!(m.kind, MotionKind::Arc(_))),
        });
    }
    seen
}

/// Every event whose peek says the next line moves along no arc is followed
/// by the event of the next line, without an arc motion; where the peek has
/// the next line's text, it is that line of `program` (the original text: a
/// line with parameters is run rendered, a parameter setting alone yields
/// no event). Returns how many events ruled an arc out.
fn check_sound(name: &str, program: &[u8], seen: &[Seen]) -> usize {
    let lines: Vec<&[u8]> = program.split_inclusive(|b| *b == b'\n').collect();
    let mut ruled_out = 0;
    for (k, s) in seen.iter().enumerate() {
        if let Some(next) = &s.next {
            assert_eq!(
                Some(&next[..]),
                lines.get(s.number as usize).copied(),
                "{name}: the peek after line {} is not the next line",
                s.number
            );
        }
        if !s.may_start_arc {
            ruled_out += 1;
            let after = seen.get(k + 1);
            assert!(
                // No event after it: the walk stopped there (the end, or
                // an error the next line raised).
                after.is_none_or(|a| a.number == s.number + 1 && !a.arc),
                "{name}: line {} said no arc follows, the next event is {:?}",
                s.number,
                after.map(|a| (a.number, a.arc))
            );
        }
    }
    ruled_out
}

#[test]
fn the_peek_rules_out_an_arc_only_where_the_next_line_has_none() {
    // Each case: the line after a plain G1 line, and whether that G1 line's
    // peek may see an arc in it (by hand, from the text: LinuxCNC drops
    // spaces outside comments, `g 0 3` is G3).
    let cases: &[(&str, bool)] = &[
        ("G1 X2", false),
        ("X3 Y1", false),
        ("G2 X5 Y1 I1 J0", true),
        ("G1 X6", true), // after the G2 line: the modal motion is an arc
        ("G02 X8 Y1 I1 J0", true),
        ("G1 X9", true),
        ("g 0 3 X11 Y1 I1 J0", true),
        ("G1 X12", true),
        ("G3.0 X14 Y1 I1 J0", true),
        ("G1 X15", true),
        ("N10 G17 G2 X17 Y1 I1 J0", true),
        ("G1 X18", true),
        ("G1 X19 (G2 in a comment only, an o-word too)", false),
        ("G1 X20 ; G3 after a semicolon", false),
        ("", false),
        ("(a comment line)", false),
        ("G0 X21", false),
        ("G1 X22 F500", false),
        ("G4 P0.1", false),
        ("M3 S1000", false),
        ("G1 X[23]", true),
        ("G1 X24", false),
        ("#1 = 25", true),
        ("G1 X#1", true),
        ("G1 X26", false),
        ("/G1 X27", false),
        ("G1 X28", false),
    ];
    let mut program = String::from("G17 G21 G90 G64 P0.01 F600\nG0 X0 Y1 Z0\nG1 X1\n");
    for (line, _) in cases {
        program.push_str(line);
        program.push('\n');
    }
    program.push_str("M2\n");
    let seen = walk(common::walker(
        &program,
        Setup::default(),
        InterpOptions::default(),
    ));
    check_sound("cases", program.as_bytes(), &seen);
    // The event of line 3 (G1 X1) is followed by the cases: the line before
    // case k is line 3 + k. `#1 = 25` yields no event: its line is peeked
    // by the line before it only.
    for (k, (line, expected)) in cases.iter().enumerate() {
        let before = (3 + k) as u64;
        let Some(s) = seen.iter().find(|s| s.number == before) else {
            // Only a parameter setting alone yields no event.
            assert!(
                k > 0 && cases[k - 1].0.starts_with('#'),
                "no event for line {before}"
            );
            continue;
        };
        assert_eq!(
            s.may_start_arc,
            *expected,
            "line {before} ({:?}) before {line:?}",
            String::from_utf8_lossy(&s.bytes)
        );
        assert_eq!(
            s.next.as_deref(),
            Some(format!("{line}\n").as_bytes()),
            "the peek after line {before}"
        );
    }
    // The last line's peek: the program ends after it.
    assert!(seen
        .last()
        .is_some_and(|s| s.next.is_none() && s.may_start_arc));
}

#[test]
fn control_flow_and_the_program_end_leave_the_next_line_unknown() {
    // A loop's body runs again: after its last line the next line run is
    // the loop's start, not the line below it; the peek must not claim it.
    let program = "G17 G21 G90 F600\nG0 X0 Y0 Z0\n#1 = 0\no100 while [#1 LT 2]\nG1 X1\nG1 Y1\n#1 = [#1 + 1]\no100 endwhile\nG1 X2\nM2\nG2 X3 I1\n";
    let seen = walk(common::walker(
        program,
        Setup::default(),
        InterpOptions::default(),
    ));
    let ruled_out = check_sound("loop", program.as_bytes(), &seen);
    assert!(ruled_out >= 2, "G0 X0 Y0 Z0 and G1 X1 rule an arc out");
    // `G1 Y1` runs twice; the line after it is a parameter setting (`#`):
    // an arc is not ruled out.
    for s in seen.iter().filter(|s| s.number == 6) {
        assert!(s.may_start_arc);
    }
    // M2 ends the program: the lines after it are copied, not run; no
    // event after the end peeks.
    let m2 = seen.iter().position(|s| s.number == 10).unwrap();
    assert!(seen[m2..].iter().all(|s| s.next.is_none()));
}

#[test]
fn on_the_corpus_no_arc_follows_a_line_whose_peek_rules_one_out() {
    // The bundled real programs (workspace root, tests/corpus).
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/corpus");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| !p.to_string_lossy().ends_with(".md"))
        .collect();
    files.sort();
    let (mut ruled_out, mut arcs) = (0, 0);
    for path in &files {
        let bytes = std::fs::read(path).unwrap();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let seen = walk(Walker::new(
            Cursor::new(bytes.clone()),
            Some(name.clone()),
            Setup::default(),
            InterpOptions::default(),
        ));
        ruled_out += check_sound(&name, &bytes, &seen);
        arcs += seen.iter().filter(|s| s.arc).count();
    }
    // The check is not empty: the corpus has arcs, and most lines before
    // a line without one are ruled out.
    assert!(arcs > 100, "{arcs} arcs in the corpus");
    assert!(ruled_out > 1000, "{ruled_out} lines ruled an arc out");
}
