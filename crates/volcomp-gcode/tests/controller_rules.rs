//! What LinuxCNC refuses, volcomp refuses, with the reason; what it accepts
//! (polar `@`/`^` words, words that a code on the line uses), volcomp reads
//! as it does; what a program leaves unsaid is warned about.
//!
//! Every refused program is also given to LinuxCNC's `rs274` when it is
//! installed, and must be refused there with the quoted message: the rules
//! are LinuxCNC's (src/emc/rs274ngc/interp_check.cc, interp_find.cc,
//! interp_convert.cc), not ours.

use crate::common;
use std::io::Cursor;
use volcomp_gcode::{GcodeError, InterpOptions, Motion, Setup, Vec3, Warning};

fn run_with(program: &str, setup: Setup) -> (Result<Vec<Motion>, GcodeError>, Vec<Warning>) {
    run_with_options(program, setup, InterpOptions::default())
}

fn run_with_options(
    program: &str,
    setup: Setup,
    options: InterpOptions,
) -> (Result<Vec<Motion>, GcodeError>, Vec<Warning>) {
    common::motions_and_warnings(program, setup, options)
}

fn run(program: &str) -> Result<Vec<Motion>, GcodeError> {
    run_with(program, Setup::default()).0
}

/// rs274's verdict on a program: `Some(message)` when it refuses it.
fn rs274_error(program: &str) -> Option<Option<String>> {
    let text = common::rs274(format!("{program}M2\n").as_bytes())?.text();
    // rs274 prints canonical calls (numbered lines), "executing", and on a
    // refusal the message followed by the offending block.
    // A canonical call is `<number> N<digits or dots> CALL(…)`; o-word
    // errors start with the line number too (`5: duplicate O-word …`).
    let canonical = |l: &str| {
        l.split_once(' ').is_some_and(|(n, rest)| {
            n.bytes().all(|b| b.is_ascii_digit()) && rest.trim_start().starts_with('N')
        })
    };
    let error = text
        .lines()
        .map(str::trim)
        .find(|l| {
            !l.is_empty()
                && !canonical(l)
                && *l != "executing"
                && !program.lines().any(|p| p.trim() == *l)
        })
        .map(str::to_string);
    Some(error)
}

/// Refused by volcomp at `line:column` with `needle` in the message, and by
/// rs274 (when installed) with `linuxcnc` in its message.
fn refused(program: &str, line: u64, column: usize, needle: &str, linuxcnc: &str) {
    let e = run(program).expect_err(program);
    assert_eq!((e.line, e.column), (line, column), "{program}: {e}");
    assert!(e.message.contains(needle), "{program}: {e}");
    assert!(!e.help.is_empty(), "{program}: no advice in {e}");
    if let Some(verdict) = rs274_error(program) {
        let msg = verdict.unwrap_or_else(|| panic!("rs274 accepts {program:?}"));
        assert!(msg.contains(linuxcnc), "{program}: rs274 says {msg:?}");
    }
}

fn accepted_by_both(program: &str) -> Vec<Motion> {
    if let Some(verdict) = rs274_error(program) {
        assert_eq!(verdict, None, "rs274 refuses {program:?}");
    }
    run(program).unwrap_or_else(|e| panic!("{program}: {e}"))
}

fn close(a: Vec3, b: [f64; 3]) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() < 1e-9)
}

#[test]
fn feed_move_without_a_feed_rate_is_refused() {
    refused(
        "G1 Z-15\n",
        1,
        1,
        "no F word",
        "Cannot do g1 with zero feed rate",
    );
    refused(
        "G21\nG1\n",
        2,
        1,
        "zero feed rate",
        "Cannot do g1 with zero feed rate",
    );
    refused(
        "G0 X1\nG2 X2 I0.5\n",
        2,
        1,
        "zero feed rate",
        "Cannot make arc with zero feed rate",
    );
    refused(
        "G81 X1 R1 Z0\n",
        1,
        1,
        "zero feed rate",
        "Cannot feed with zero feed rate",
    );
    // F0 is no feed rate either, even on the move's own line.
    refused(
        "G1 F0 X1\n",
        1,
        4,
        "F0 is on this line",
        "Cannot do g1 with zero feed rate",
    );
    refused(
        "F100\nF0\nG1 X1\n",
        3,
        1,
        "no F word",
        "Cannot do g1 with zero feed rate",
    );
    // Under G93 every feed move needs its own F.
    refused(
        "G93 G1 X1 F10\nG1 X2\n",
        2,
        1,
        "inverse-time",
        "F word missing with inverse time",
    );
    // G95 needs a spindle speed as well.
    refused(
        "S1000\nG95 F0.1 G1 X1\nS0\nG1 X2\n",
        4,
        1,
        "zero spindle speed",
        "Cannot feed with zero spindle speed in feed per rev mode",
    );
    accepted_by_both("G95 F0.1 S100 G2 X1 I0.5\n");
    // Rapids need no feed rate.
    accepted_by_both("G0 X1 F0\n");
    accepted_by_both("F100\nG1 X1\nG0 X2\nG1 X3\n");
}

#[test]
fn scientific_notation_is_refused_with_the_reason() {
    // LinuxCNC reads `1e-05` as X1 and an E word and refuses the E word;
    // taking X1 would move the tool 1 mm instead of 10 nm.
    refused(
        "F100 G1 X1e-05\n",
        1,
        11,
        "scientific notation",
        "E word with no",
    );
    refused(
        "F100 G1 X.1E-2\n",
        1,
        12,
        "scientific notation",
        "E word with no",
    );
    refused("F100 G1 X1 E2\n", 1, 12, "E word with no", "E word with no");
}

#[test]
fn words_that_no_code_uses_are_refused() {
    for (line, letter, linuxcnc) in [
        ("F100 G1 X1 R2\n", 'R', "R word with no g code that uses it"),
        ("F100 G1 X1 I2\n", 'I', "I word with no"),
        ("F100 G1 X1 J2\n", 'J', "J word with no"),
        ("F100 G1 X1 K0\n", 'K', "K word with no"),
        ("F100 G1 X1 Q2\n", 'Q', "Q word with no"),
        ("F100 G1 X1 P2\n", 'P', "P word with no"),
        ("F100 G1 X1 L2\n", 'L', "L word with no"),
        ("F100 G1 X1 D2\n", 'D', "D word with no"),
        ("F100 G1 X1 H2\n", 'H', "H word with no"),
        ("G0 X1 R2\n", 'R', "R word with no g code that uses it"),
        ("G0 X1 P2\n", 'P', "P word with no"),
        ("F100 G2 X1 R1 L2\n", 'L', "L word with no"),
    ] {
        let column = line.find(letter).unwrap() + 1;
        refused(line, 1, column, &format!("{letter} word with no"), linuxcnc);
    }
}

#[test]
fn words_that_a_code_on_the_line_uses_are_accepted() {
    accepted_by_both("G0 X1 Y0\nG2 F100 X2 I0.5\n");
    accepted_by_both("G0 X1\nF100 G2 I1\n");
    accepted_by_both("G0 X1 Y0\nG2 F100 X2 Y1 R1\n");
    accepted_by_both("G4 P0.5\n");
    accepted_by_both("G64 P0.01 Q0.01\n");
    accepted_by_both("G10 L2 P1 X1\n");
    accepted_by_both("G0 Z5\nF100 G82 X1 R1 Z0 P0.5\n");
    accepted_by_both("G0 Z5\nF100 G81 X1 R1 Z0 L1\n");
    accepted_by_both("F100 G1 X1 M67 E0 Q1\n");
    accepted_by_both("F100 G1 X1 Q1 M61\n");
    accepted_by_both("F100 G1 X1 D2 G96 S100\n");
}

#[test]
fn polar_words_move_as_in_linuxcnc() {
    // End points printed by rs274 -g for the same programs.
    let m = accepted_by_both("F1 G1 @1 ^90\n");
    assert!(close(m[0].end, [0.0, 1.0, 0.0]), "{:?}", m[0].end);
    let m = accepted_by_both("G0 @1 ^30 Z1\n");
    assert!(close(m[0].end, [0.75f64.sqrt(), 0.5, 1.0]));
    // G90 `@` alone keeps the current angle, `^` alone the current radius.
    let m = accepted_by_both("G0 X1 Y1\nG1 F1 @2\n");
    assert!(close(m[1].end, [2f64.sqrt(), 2f64.sqrt(), 0.0]));
    let m = accepted_by_both("G0 X1\nG1 F1 ^45\n");
    assert!(close(m[1].end, [0.5f64.sqrt(), 0.5f64.sqrt(), 0.0]));
    let m = accepted_by_both("G0 X1\nG1 F1 @-1\n");
    assert!(close(m[1].end, [-1.0, 0.0, 0.0]));
    // G91: `@` adds to the radius, `^` to the angle.
    let m = accepted_by_both("G0 X1 Y1\nG91 G1 F1 @2\n");
    let r = 2f64.sqrt() + 2.0;
    assert!(close(m[1].end, [r * 0.5f64.sqrt(), r * 0.5f64.sqrt(), 0.0]));
    let m = accepted_by_both("G0 X1 Y1\nG91 G1 F1 ^90\n");
    assert!(close(m[1].end, [-1.0, 1.0, 0.0]));
    // About the origin of the current coordinate system (here G55 = 10, 20).
    let mut setup = Setup::default();
    setup.work_offsets_mm[1] = Vec3::new(10.0, 20.0, 0.0);
    setup.work_offsets_given[1] = true;
    let m = run_with("G55 G0 @2 ^90\n", setup).0.unwrap();
    assert!(close(m[0].end, [10.0, 22.0, 0.0]));
    // In inch, the radius is in inch.
    let m = run("G20 G0 @1 ^0\n").unwrap();
    assert!(close(m[0].end, [25.4, 0.0, 0.0]));
}

#[test]
fn polar_words_are_refused_where_linuxcnc_refuses_them() {
    refused(
        "F1 G1 X1 ^90\n",
        1,
        7,
        "both polar",
        "Cannot specify both polar coordinate and X word",
    );
    refused(
        "G0 X1\nG28 @1\n",
        2,
        5,
        "only be used for motion",
        "Polar coordinates can only be used for motion",
    );
    refused(
        "G91 G0 @1\n",
        1,
        8,
        "indeterminate at the origin",
        "indeterminate when at the origin",
    );
    refused(
        "G0 @1\n",
        1,
        4,
        "indeterminate at the origin",
        "Must specify angle in polar coordinate if at the origin",
    );
    // LinuxCNC checks the plane in effect before the block
    // (`Interp::enhance_block`): G18 on an earlier line refuses polar words,
    // G18 on the same line does not, and the move is still in X and Y.
    refused(
        "G18\nG0 @1 ^90\n",
        2,
        4,
        "XY plane",
        "Cannot use polar coordinate except in G17 plane",
    );
    let m = accepted_by_both("G18 G0 @1 ^90\nG17\n");
    assert!(close(m[0].end, [0.0, 1.0, 0.0]), "{:?}", m[0].end);
    // In a canned cycle, @ alone keeps the current angle (atan2 of the
    // current point: 0 here): the hole is at (1, 0).
    let m = accepted_by_both("G21 G0 X1\nF1 G81 @1 R1 Z0\n");
    let feed = m
        .iter()
        .find(|m| matches!(m.kind, volcomp_gcode::MotionKind::Feed))
        .unwrap();
    assert!(close(feed.end, [1.0, 0.0, 0.0]), "{:?}", feed.end);
    let e = run("G53 G0 @1 ^90\n").unwrap_err();
    assert!(e.message.contains("G53"), "{e}");
}

#[test]
fn missing_units_are_warned_about_once() {
    let (r, warnings) = run_with("G0 X1\nG0 X2\nG21\n", Setup::default());
    r.unwrap();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert_eq!((warnings[0].line, warnings[0].column), (1, 1));
    assert!(warnings[0].message.contains("G20 or G21"));
    assert!(warnings[0].to_string().starts_with("1:1: warning: "));
    for program in ["G21\nG0 X1\n", "G20 G0 X1\n", "(no motion)\n"] {
        let (_, w) = run_with(program, Setup::default());
        assert!(w.is_empty(), "{program}: {w:?}");
    }
}

#[test]
fn reference_points_missing_from_the_setup_are_warned_about() {
    let program = "G21\nG0 X1\nG28\nG28 Z0\nG30\n";
    let (r, warnings) = run_with(program, Setup::default());
    let m = r.unwrap();
    // G28 without a set-up point goes to machine zero, as LinuxCNC does.
    assert!(close(m[2].end, [0.0, 0.0, 0.0]));
    let lines: Vec<u64> = warnings.iter().map(|w| w.line).collect();
    assert_eq!(lines, vec![3, 5], "{warnings:?}");
    assert!(warnings[0].message.contains("G28") && warnings[0].message.contains("machine zero"));
    assert!(warnings[1].message.contains("G30"));
    let setup =
        Setup::from_toml("units = \"mm\"\n[reference]\nG28 = [0, 0, 100]\nG30 = [0, 0, 50]\n")
            .unwrap();
    let (r, warnings) = run_with(program, setup);
    r.unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    // G28.1 in the program sets the point: no warning either.
    let (_, warnings) = run_with("G21\nG0 X1\nG28.1\nG0 X2\nG28\n", Setup::default());
    assert!(warnings.is_empty(), "{warnings:?}");
}

#[test]
fn negative_spindle_speed_and_control_characters_are_refused() {
    refused(
        "S-100\n",
        1,
        1,
        "negative spindle speed",
        "Negative spindle speed used",
    );
    refused(
        "G0 X1\u{7}\n",
        1,
        6,
        "control character 0x07",
        "Bad character",
    );
}

#[test]
fn a_byte_order_mark_is_refused_as_linuxcnc_refuses_it() {
    refused(
        "\u{feff}G21\nG0 X1\n",
        1,
        1,
        "byte-order mark",
        "Bad character '\\357' used",
    );
}

#[test]
fn what_linuxcncs_reader_refuses_is_refused() {
    // fgets reads the NUL; the C string ends there, the comment is open.
    refused(
        "G21 (a\0b)\nG0 X1\n",
        1,
        7,
        "NUL byte in a comment",
        "Unclosed comment found",
    );
    // An N word is read only at the start of a block (`read_items`).
    refused(
        "G21\nG0 N5 X1\n",
        2,
        4,
        "does not start the line",
        "Bad character 'n' used",
    );
    refused(
        "(c) N5 G21\n",
        1,
        5,
        "does not start the line",
        "Bad character 'n' used",
    );
    accepted_by_both("N5 G21\n/N6 G0 X1\n");
    refused(
        "G21\nN-1 G0 X1\n",
        2,
        1,
        "negative line number",
        "Bad format unsigned integer",
    );
    // P-1 is LinuxCNC's "no P"; any other negative dwell passes.
    refused(
        "G21\nG4 P-1\n",
        2,
        4,
        "G4 P-1",
        "Dwell time missing with g4",
    );
    accepted_by_both("G21\nG4 P-2\n");
    // Q-1 likewise is "no Q": not refused where no code uses Q.
    accepted_by_both("G21\nG0 X1 Q-1\n");
}

#[test]
fn whole_number_words_are_read_as_linuxcnc_reads_them() {
    // `read_integer_value`: within 0.0001 of a whole number.
    accepted_by_both("G21\nT1.00001 M6\nM3.00005 S100\n");
    refused(
        "G21\nT1.5 M6\n",
        2,
        1,
        "not a whole number",
        "Non integer value for integer",
    );
    refused(
        "G21\nG0 X1\nG81 X1 R1 Z0 F10 L2.5\n",
        3,
        18,
        "not a whole number",
        "Non integer value for integer",
    );
    refused("G21\nT-1\n", 2, 1, "negative", "Negative tool id");
    // `read_g`: ten times the value within 0.001 of a whole number.
    let m = accepted_by_both("G21\nG1.0001 X1 F100\n");
    assert!(close(m[0].end, [1.0, 0.0, 0.0]));
    refused(
        "G21\nG1.002 X1 F100\n",
        2,
        1,
        "not a G code",
        "G-code out of range",
    );
}

#[test]
fn bytes_that_are_not_gcode_give_a_located_escaped_error() {
    let e = run("G21\nG1 X\u{e9}2\n").unwrap_err();
    assert_eq!((e.line, e.column), (2, 5));
    assert!(e.message.contains("not ASCII"), "{e}");
    let mut bytes = b"G21\nG0 X1 ".to_vec();
    bytes.extend_from_slice(b"\xe9\x1b[31m\x07\n");
    let e = common::first_error(Cursor::new(bytes), "t.ngc", "accepted");
    assert_eq!((e.line, e.column), (2, 7));
    let shown = e.to_string();
    assert!(shown.contains("G0 X1 \\xe9\\x1b[31m\\x07"), "{shown}");
    assert!(!shown.contains('\x1b') && !shown.contains('\x07'));
    let e = run("G\0 1\n").unwrap_err();
    assert!(e.message.contains("UTF-16"), "{e}");
}

#[test]
fn an_error_on_a_huge_line_shows_a_bounded_excerpt() {
    // 60 kB: under the reader's 1 MiB bound, far over LinuxCNC's 252.
    let mut program = String::from("G21\nG0");
    for _ in 0..20_000 {
        program.push_str(" X1");
    }
    program.push_str(" #1\n");
    let e = run(&program).unwrap_err();
    let shown = e.to_string();
    assert!(shown.len() < 1000, "{} bytes shown", shown.len());
    // LinuxCNC refuses the line for its length before reading a word of it.
    assert_eq!(e.line, 2, "{shown}");
    assert!(
        e.message
            .contains("LinuxCNC reads 252 characters at most before LF"),
        "{shown}"
    );
    assert!(
        e.source_line.starts_with('…') && e.source_line.ends_with('…'),
        "{shown}"
    );
}

#[test]
fn a_line_longer_than_linuxcnc_reads_is_refused_at_its_length() {
    // 252 characters are read; 253 are "Command too long" in rs274.
    let e = longest_line_read("\n", 252);
    assert_eq!(e.line, 2, "{e}");
    assert!(e.message.contains("Command too long"), "{e}");
}

/// A program whose second line is a comment of `longest` characters, lines
/// ending in `eol`, is read; one character more is refused (and so in
/// rs274, where it is installed): the refusal.
fn longest_line_read(eol: &str, longest: usize) -> GcodeError {
    let body = |n: usize| format!("G21{eol}({}){eol}", "c".repeat(n - 2));
    run(&format!("{}M2{eol}", body(longest))).expect("the longest line is read");
    let e = run(&format!("{}M2{eol}", body(longest + 1))).unwrap_err();
    if let Some(verdict) = rs274_error(&body(longest)) {
        assert_eq!(verdict, None, "rs274 reads {longest} characters");
        let refusal = rs274_error(&body(longest + 1)).unwrap();
        assert!(refusal.unwrap().contains("too long"));
    }
    e
}

/// The line ending counts: LinuxCNC reads 253 bytes of a line with its
/// ending, so a line ending in CR LF holds one character less — 251 are
/// read, 252 are "Command too long" in rs274 — and the message says so.
#[test]
fn a_crlf_line_holds_one_character_less() {
    let e = longest_line_read("\r\n", 251);
    assert_eq!((e.line, e.column), (2, 252), "{e}");
    assert!(
        e.message.contains("252 characters long and ends in CR LF")
            && e.message.contains("251 characters at most before CR LF"),
        "{e}"
    );
}

#[test]
fn a_line_of_gigabytes_is_refused_without_holding_it() {
    // 64 MiB of one line without a line feed: the reader stops at its
    // bound of 1 MiB instead of holding the line.
    struct Endless(u64);
    impl std::io::Read for Endless {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = (buf.len() as u64).min(self.0) as usize;
            buf[..n].fill(b'X');
            self.0 -= n as u64;
            Ok(n)
        }
    }
    let reader = std::io::BufReader::new(std::io::Read::chain(&b"G21\n"[..], Endless(64 << 20)));
    let e = common::first_error(reader, "t.ngc", "the endless line was read");
    assert_eq!(e.line, 2, "{e}");
    assert!(e.message.contains("longer than 1048576 bytes"), "{e}");
}

#[test]
fn spindle_synchronised_moves_are_refused_where_linuxcnc_refuses_them() {
    // interp_check.cc: K required, F refused; convert_straight: the
    // spindle must turn.
    refused(
        "S100 M3\nG33 Z-5\n",
        2,
        1,
        "K word missing with G33",
        "K word missing",
    );
    refused(
        "S100 M3\nG33 Z-5 K1 F100\n",
        2,
        12,
        "F word used with G33",
        "F word used",
    );
    refused(
        "G33 Z-5 K1\n",
        1,
        1,
        "Spindle not turning in G33",
        "Spindle not turning",
    );
    refused(
        "G33.1 Z-5 K1\n",
        1,
        1,
        "Spindle not turning in G33.1",
        "Spindle not turning",
    );
    // A G33.1 is in and back out: the tool ends where it started.
    let m = accepted_by_both("G21 G0 X1 Y2 Z3\nS100 M3\nG33.1 Z-5 K1\n");
    assert!(close(m[1].end, [1.0, 2.0, -5.0]) && close(m[2].end, [1.0, 2.0, 3.0]));
}

#[test]
fn reals_become_integers_as_linuxcnc_rounds_them() {
    // Repeat counts: `round_to_int`, half to even (2.5 → 2, 0.5 → 0, 3.5 → 4).
    for (count, passes) in [("5/2", 2), ("0.5", 0), ("3.5", 4), ("2.4999", 2)] {
        let p = format!("G21 G91\no1 repeat [{count}]\nG0 X1\no1 endrepeat\n");
        assert_eq!(accepted_by_both(&p).len(), passes, "repeat [{count}]");
    }
    // Arc turns: `round_to_int`, within 0.001.
    let m = accepted_by_both("G21 G0 X1\nG2 X1 I-1 P1.0005 F100\n");
    assert_eq!(m.len(), 2);
    refused(
        "G21 G0 X1\nG2 X1 I-1 P1.01 F100\n",
        2,
        11,
        "not a whole number of turns",
        "P value not an integer with M19 G2 or G3",
    );
    // G10 L2 P: `(int)(p + 0.0001)` after a check that lets P1.7 through:
    // LinuxCNC sets G54 (P1).
    let m = accepted_by_both("G21\nG10 L2 P1.7 X5 Y0 Z0\nG0 X0\n");
    assert!(close(m[0].end, [5.0, 0.0, 0.0]), "{:?}", m[0].end);
    refused(
        "G21\nG10 L2 P1.0003 X5 Y0 Z0\n",
        2,
        8,
        "not a whole number",
        "P value not an integer with G10",
    );
}

#[test]
fn a_work_offset_the_setup_does_not_give_is_refused_not_taken_as_zero() {
    let e = run("G21\nG55 G0 X1\n").unwrap_err();
    assert_eq!((e.line, e.column), (2, 1), "{e}");
    assert!(
        e.message.contains("G55") && e.help.contains("[work_offsets]"),
        "{e}"
    );
    let e = run("G21\nG0 X#5241\n").unwrap_err();
    assert!(e.message.contains("#5241 belongs to the G55 offset"), "{e}");
    let e = run("G21\nG0 X#5390\n").unwrap_err();
    assert!(e.message.contains("G59.3"), "{e}");
    // G54 (the program frame is the machine's when nothing is said), a
    // set-up table entry, a G10 L2 with X, Y and Z in the program: known.
    run("G21\nG54 G0 X#5221\n").unwrap();
    let setup = Setup::from_toml("units = \"mm\"\n[work_offsets]\nG56 = [1, 2, 3]\n").unwrap();
    let (m, _) = run_with("G21\nG56 G0 X#5261 Y0 Z0\n", setup);
    assert!(close(m.unwrap()[0].end, [2.0, 2.0, 3.0]));
    let m = run("G21\nG10 L2 P2 X1 Y2 Z3\nG55 G0 X0 Y0 Z0\n").unwrap();
    assert!(close(m[0].end, [1.0, 2.0, 3.0]));
    let e = run("G21\nG10 L2 P2 X1\n").unwrap_err();
    assert!(e.message.contains("sets only some axes of G55"), "{e}");
    // A var file gives every system (a missing line is 0, as in LinuxCNC).
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.var"), "5241 7\n5242 8\n5243 9\n").unwrap();
    let toml = dir.path().join("s.toml");
    std::fs::write(&toml, "units = \"mm\"\nvar_file = \"m.var\"\n").unwrap();
    let setup = Setup::from_toml_in(
        &std::fs::read_to_string(&toml).unwrap(),
        toml.to_str().unwrap(),
    )
    .unwrap();
    let (m, _) = run_with("G21\nG55 G0 X0 Y0 Z0\nG59.3 G0 X1 Y0 Z0\n", setup);
    let m = m.unwrap();
    assert!(close(m[0].end, [7.0, 8.0, 9.0]) && close(m[1].end, [1.0, 0.0, 0.0]));
}

#[test]
fn tool_parameters_are_the_spindle_tools_table_entry() {
    let mut setup = Setup {
        machine_units: volcomp_gcode::Units::Mm,
        ..Setup::default()
    };
    setup.tool_lengths_mm.insert(3, 40.0);
    setup.tool_diameters_mm.insert(3, 6.0);
    setup.tool_lengths_mm.insert(5, 50.0);
    // #5400 the tool, #5403 its table length (not the G43 offset, which is
    // off), #5410 its diameter; M61 does not refresh them (LinuxCNC's
    // `set_tool_parameters` runs before the tool reaches the table).
    let (m, _) = run_with(
        "G21\nG0 X#5400 Y#5403 Z#5410\nT3 M6\nG0 X#5400 Y#5403 Z#5410\nM61 Q5\nG0 X#5400 Y#5403\nG10 L1 P3 R4\nT3 M6\nG0 Z#5410\n",
        setup,
    );
    let m = m.unwrap();
    assert!(close(m[0].end, [0.0, 0.0, 0.0]));
    assert!(close(m[1].end, [3.0, 40.0, 6.0]));
    assert!(close(m[2].end, [3.0, 40.0, 6.0]));
    // G10 L1 R is the radius: the diameter becomes 8.
    assert!(close(m[3].end, [3.0, 40.0, 8.0]));
    // A tool whose length the set-up does not give is not read as 0.
    let e = run("G21\nT7 M6\nG0 Z#5403\n").unwrap_err();
    assert!(e.message.contains("length of tool 7"), "{e}");
}

#[test]
fn o_word_labels_given_as_expressions_and_named_programs_run() {
    // `read_o` reads a number label with `read_integer_value`: any value.
    let m = accepted_by_both(
        "G21\n#2 = 10\nO[#2 * 10] call\nG0 X2\nM30\nO100 sub\nG0 X1\nO100 endsub\n",
    );
    assert_eq!(m.len(), 2);
    assert!(close(m[0].end, [1.0, 0.0, 0.0]) && close(m[1].end, [2.0, 0.0, 0.0]));
    // A bare `O<name>` starts a Fanuc-style program: execution runs on.
    let m = accepted_by_both("G21\nO<MyProgram> (the body)\nG0 X3\n");
    assert!(close(m[0].end, [3.0, 0.0, 0.0]));
    refused(
        "G21\n#2 = 1.5\nO#2 call\n",
        3,
        2,
        "not a whole number",
        "Non integer value for integer",
    );
}

/// rs274's verdict on `program` as it is (no M2 added) and its motion count.
fn rs274_as_is(program: &str) -> Option<(Option<String>, usize)> {
    let run = common::rs274(program.as_bytes())?;
    let (out, canon) = (&run.output, &run.canon);
    let motions = canon
        .lines()
        .filter(|l| l.contains("STRAIGHT_") || l.contains("ARC_FEED"))
        .count();
    let text = String::from_utf8_lossy(&out.stderr).into_owned();
    let msg: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && *l != "executing")
        .collect();
    Some(((!out.status.success()).then(|| msg.join(" | ")), motions))
}

fn run_requiring_end(program: &str) -> (Result<Vec<Motion>, GcodeError>, Vec<Warning>) {
    let options = InterpOptions {
        require_program_end: true,
        ..InterpOptions::default()
    };
    run_with_options(program, Setup::default(), options)
}

#[test]
fn a_program_linuxcnc_runs_to_its_last_line_runs_with_a_warning() {
    // No M2 (grbl posts), a percent tape without its closing %, a stray %
    // as the last line: LinuxCNC makes every move, then complains.
    for (program, moves, linuxcnc) in [
        (
            "G21\nG0 X1\nG1 X2 F100\n",
            2,
            "File ended with no percent sign or program end",
        ),
        ("%\nG21\nG0 X1\n", 1, "File ended with no percent sign"),
        ("G21\nG0 X1\n%\n\n(end)\n", 1, "Bad character '%' used"),
    ] {
        let (m, warnings) = run_requiring_end(program);
        let m = m.unwrap_or_else(|e| panic!("{program:?}: {e}"));
        assert_eq!(m.len(), moves, "{program:?}");
        let w = warnings.last().expect("a warning");
        assert!(w.message.contains(linuxcnc), "{program:?}: {}", w.message);
        if let Some((verdict, n)) = rs274_as_is(program) {
            let msg = verdict.expect("rs274 complains");
            assert!(msg.contains(linuxcnc), "{program:?}: rs274 says {msg}");
            assert_eq!(n, moves, "{program:?}: rs274's moves");
        }
    }
    // Without LinuxCNC's rule (grbl and kin; a library reading a fragment):
    // no warning.
    assert!(run("G21\nG0 X1\n").is_ok());
    assert!(run_with("G21\nG0 X1\n", Setup::default()).1.is_empty());
}

#[test]
fn what_linuxcnc_refuses_before_it_moves_at_the_tape_stays_refused() {
    for (program, line, ours, linuxcnc) in [
        (
            "% hello\nG21\nG0 X1\nM2\n",
            1,
            "holds more than `%`",
            "Bad character '%' used",
        ),
        (
            "G21\nG0 X1\n%\nG0 X2\nM2\n",
            4,
            "line 3 is a `%` line",
            "Bad character '%' used",
        ),
        (
            "(c)\n%\nG21 G0 X1\n%\n",
            3,
            "line 2 is a `%` line",
            "Bad character '%' used",
        ),
    ] {
        let (r, _) = run_requiring_end(program);
        let e = r.expect_err(program);
        assert_eq!(e.line, line, "{program:?}: {e}");
        assert!(
            e.message.contains(ours) && e.message.contains(linuxcnc),
            "{e}"
        );
        if let Some((verdict, _)) = rs274_as_is(program) {
            let msg = verdict.expect("rs274 refuses");
            assert!(msg.contains(linuxcnc), "{program:?}: rs274 says {msg}");
        }
    }
}
