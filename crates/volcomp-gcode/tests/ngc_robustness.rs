//! Parameters, expressions and control flow on arbitrary input: every
//! program ends, with motions or with a located error, never a panic or a
//! hang (the executed-line limit is lowered so that endless loops end fast).

use proptest::prelude::*;
use std::io::Cursor;
use volcomp_gcode::{InterpOptions, Setup, Walker};

const PIECES: &[&str] = &[
    "G0 ",
    "G1 ",
    "G2 ",
    "X",
    "Y",
    "Z",
    "I",
    "J",
    "R",
    "F100 ",
    "#1",
    "#2",
    "#<a>",
    "#<_b>",
    "##1",
    "#[1+1]",
    "=",
    "[",
    "]",
    "+",
    "-",
    "*",
    "/",
    "**",
    " MOD ",
    " EQ ",
    " LT ",
    " AND ",
    "SIN[",
    "ATAN[1]/[",
    "EXISTS[#<a>]",
    "1",
    "2.5",
    "0",
    "-3",
    "o1 ",
    "o2 ",
    "o<s> ",
    "sub",
    "endsub",
    "call",
    "return",
    "while",
    "endwhile",
    "do",
    "repeat",
    "endrepeat",
    "if",
    "elseif",
    "else",
    "endif",
    "break",
    "continue",
    "M98 P1",
    "M99",
    "O1",
    "M2",
    "%",
    "(c)",
    ";c",
    " ",
    "\n",
    "\n",
    "\n",
];

fn run(text: &str) {
    let options = InterpOptions {
        max_executed_lines: 2_000,
        ..InterpOptions::default()
    };
    let mut w = Walker::new(
        Cursor::new(text.as_bytes().to_vec()),
        Some("p.ngc".into()),
        Setup::default(),
        options,
    );
    for _ in 0..10_000 {
        match w.next_line() {
            Ok(Some(_)) => {}
            Ok(None) => return,
            Err(e) => {
                let s = e.to_string();
                assert!(s.contains("p.ngc:"), "error without location: {s}");
                return;
            }
        }
    }
    panic!(
        "more than 10,000 events from a program of {} bytes",
        text.len()
    );
}

proptest! {
    #![proptest_config(crate::common::proptest_config(2000))]
    #[test]
    fn random_ngc_never_panics(picks in proptest::collection::vec(0..PIECES.len(), 0..60)) {
        let text: String = picks.iter().map(|&i| PIECES[i]).collect();
        run(&text);
    }
}

#[test]
fn structured_programs_end() {
    for p in [
        "o1 while [1]\no1 endwhile\nM2\n",
        "o1 do\no1 while [1]\nM2\n",
        "o1 sub\no1 call\no1 endsub\no1 call\nM2\n",
        "M98 P1\nM2\nO1\nM98 P1\nM99\n",
        "#1=1\no1 repeat [1e9]\n#1=[#1+1]\no1 endrepeat\nM2\n",
    ] {
        run(p);
    }
}
