//! What a user sees when a program is refused: `file:line:column: message`,
//! the line with a caret under the column, and `help: …`, pinned as insta
//! snapshots (`tests/snapshots/`) for a handful of representative bad
//! programs.
//!
//! The snapshots were reviewed by hand: the caret sits under the offending
//! word, the line and column are the ones LinuxCNC's `rs274` names (it prints
//! the refused block after its message), and the message quotes rs274's
//! where volcomp follows its rule. When `rs274` is installed,
//! [`rs274_refuses_the_same_programs_on_the_same_line`] checks that again
//! against it; without it that test says so and checks nothing.

use crate::common;
use std::io::Cursor;
use volcomp_gcode::GcodeError;

/// A bad program, the line volcomp and rs274 refuse, and the words rs274's
/// message contains (`None` where its message is of another kind).
struct Case {
    name: &'static str,
    program: Vec<u8>,
    line: u64,
    rs274_says: Option<&'static str>,
}

fn cases() -> Vec<Case> {
    // A line of 196 bytes whose bad word is at its end: rs274 reads lines
    // of up to 255 characters, so it still judges the word.
    let long = [
        b"G0 X0 Y0 (".as_slice(),
        &b"a long comment ".repeat(12),
        b") Q1\n",
    ]
    .concat();
    vec![
        Case {
            name: "unknown_g_code",
            program: b"G21 G90\nG0 X0 Y0\nG1 X10 F100 G12\n".to_vec(),
            line: 3,
            rs274_says: Some("Unknown g code used"),
        },
        Case {
            name: "word_no_code_uses",
            program: b"G21 G90\nG0 X0 Y0\nG1 X10 F100 Q5\n".to_vec(),
            line: 3,
            rs274_says: Some("Q word with no"),
        },
        Case {
            name: "scientific_notation",
            program: b"G21 G90\nG1 X1e-05 F100\n".to_vec(),
            line: 2,
            rs274_says: Some("E word with no G70, G76, M66, M67 or M68 to use it"),
        },
        Case {
            name: "feed_move_without_f",
            program: b"G21 G90\nG0 X0 Y0\nG1 X10\n".to_vec(),
            line: 3,
            rs274_says: Some("Cannot do g1 with zero feed rate"),
        },
        Case {
            name: "arc_radius_mismatch",
            program: b"G21 G90 G17\nG0 X0 Y0\nG2 X10 Y0 I3 J0 F100\n".to_vec(),
            line: 3,
            rs274_says: Some("Radius to end of arc differs from radius to start"),
        },
        Case {
            name: "long_line_column_far_right",
            program: [b"G21 G90\n".as_slice(), &long].concat(),
            line: 2,
            rs274_says: Some("Q word with no"),
        },
        Case {
            name: "byte_not_utf8",
            program: b"G21 G90\nG0 X\xe91\n".to_vec(),
            line: 2,
            // rs274 fails to read the number ("bad number format").
            rs274_says: None,
        },
    ]
}

fn error_of(program: &[u8]) -> GcodeError {
    let accepted = format!("volcomp accepted {:?}", String::from_utf8_lossy(program));
    common::first_error(Cursor::new(program.to_vec()), "part.ngc", &accepted)
}

#[test]
fn rendered_errors_point_at_the_word_and_say_what_to_do() {
    for case in cases() {
        let e = error_of(&case.program);
        assert_eq!(e.line, case.line, "{}: {e}", case.name);
        insta::assert_snapshot!(case.name, e.to_string());
    }
}

#[test]
fn the_excerpt_of_a_long_line_is_cut_before_the_caret() {
    let case = cases()
        .into_iter()
        .find(|c| c.name == "long_line_column_far_right")
        .unwrap();
    let e = error_of(&case.program);
    // `Q1` begins at byte 10 + 12·15 + 2 + 1 = 193 of the line: far beyond
    // the 60 bytes shown on each side of the caret, so the excerpt starts
    // with `…` and the caret is 60 characters after it.
    assert_eq!(e.column, 193);
    assert!(e.source_line.starts_with('…'), "{e}");
    assert!(e.source_line.ends_with(") Q1"), "{e}");
    let caret = usize::from(e.caret);
    assert_eq!(e.source_line.chars().nth(caret), Some('Q'), "{e}");
    assert_eq!(caret, 1 + 60);
}

/// What rs274 prints when it refuses `program`: its message and the block
/// it names. `None` when rs274 is not installed.
fn rs274_refusal(program: &[u8]) -> Option<(String, String)> {
    let text = common::rs274(&[program, b"M2\n"].concat())?.text();
    // Canonical calls are numbered; "executing" is chatter; a refusal is the
    // message, then the refused block.
    let mut rest = text.lines().map(str::trim).filter(|l| {
        !l.is_empty() && !l.starts_with(|c: char| c.is_ascii_digit()) && *l != "executing"
    });
    let message = rest.next().unwrap_or_default().to_string();
    let block = rest.next().unwrap_or_default().to_string();
    Some((message, block))
}

#[test]
fn rs274_refuses_the_same_programs_on_the_same_line() {
    for case in cases() {
        let Some((message, block)) = rs274_refusal(&case.program) else {
            // CI installs rs274 (.ci/run): there its absence is a failure.
            assert!(
                std::env::var_os("CI").is_none(),
                "rs274 (Debian package linuxcnc-uspace) is not installed, and CI is set: CI must install it"
            );
            eprintln!(
                "!! SKIPPED: rs274 is not installed: the refusals were NOT compared with LinuxCNC"
            );
            return;
        };
        assert!(!message.is_empty(), "{}: rs274 accepts it", case.name);
        let ours = error_of(&case.program);
        if let Some(words) = case.rs274_says {
            assert!(
                message.contains(words),
                "{}: rs274 says {message}",
                case.name
            );
            // rs274 prints the block it refuses: the line volcomp names.
            let line = String::from_utf8_lossy(
                case.program
                    .split(|&b| b == b'\n')
                    .nth(ours.line as usize - 1)
                    .unwrap(),
            )
            .into_owned();
            assert_eq!(
                block,
                line.trim(),
                "{}: rs274 refuses another line",
                case.name
            );
        }
    }
}
