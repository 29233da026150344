//! Arbitrary bytes through the whole reader: lexer, interpreter, arcs.
//! Errors are fine; panics, hangs and unbounded memory are not.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::io::Cursor;
use volcomp_gcode::edit::apply_edits;
use volcomp_gcode::{InterpOptions, MotionKind, Setup, Walker};

fuzz_target!(|data: &[u8]| {
    let mut walker = Walker::new(
        Cursor::new(data.to_vec()),
        None,
        Setup::default(),
        InterpOptions::default(),
    );
    let mut echo = Vec::with_capacity(data.len());
    while let Ok(Some(ev)) = walker.next_line() {
        // Writing back without edits must reproduce the line.
        let before = echo.len();
        apply_edits(ev.bytes, &mut [], &mut echo).expect("no edits cannot fail");
        assert_eq!(&echo[before..], ev.bytes);
        for m in ev.motions {
            if let MotionKind::Arc(arc) = m.kind {
                // Linearisation must terminate for any arc the reader accepts.
                if arc.chord_count(1e-4) < 100_000 {
                    arc.for_each_chord_end(1e-4, |_| {});
                }
            }
        }
    }
});
