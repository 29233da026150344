//! Lossless reading and writing, and robustness on arbitrary bytes.

use proptest::prelude::*;
use std::io::Cursor;
use std::path::PathBuf;
use volcomp_gcode::edit::{apply_edits, Edit};
use volcomp_gcode::lexer::{classify, content_len, lex_block, Lexed, LineKind};
use volcomp_gcode::{InterpOptions, Setup, Walker};

fn corpus() -> Vec<(String, Vec<u8>)> {
    // The bundled corpus (workspace root, see tests/corpus/SOURCES.md).
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/corpus");
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("corpus at {}: {e}", dir.display()))
        .filter_map(|e| e.ok())
        .filter(|e| !e.file_name().to_string_lossy().ends_with(".md"))
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    files.sort();
    assert!(files.len() >= 11, "expected the 11 bundled corpus programs");
    files
}

/// Splits like the reader does: every line keeps its ending.
fn lines(bytes: &[u8]) -> Vec<&[u8]> {
    bytes.split_inclusive(|b| *b == b'\n').collect()
}

#[test]
fn reading_and_writing_back_is_the_identity_on_the_corpus() {
    for (name, bytes) in corpus() {
        let mut out = Vec::with_capacity(bytes.len());
        let mut walker = Walker::new(
            Cursor::new(bytes.clone()),
            Some(name.clone()),
            Setup::default(),
            InterpOptions::default(),
        );
        loop {
            match walker.next_line() {
                Ok(Some(ev)) => apply_edits(ev.bytes, &mut [], &mut out).unwrap(),
                Ok(None) => break,
                // Interpretation may stop (missing tool lengths); the bytes
                // of every line read so far must still be exact.
                Err(_) => break,
            }
        }
        assert_eq!(&out[..], &bytes[..out.len()], "{name}");
    }
}

#[test]
fn one_word_edit_changes_exactly_that_word_on_every_corpus_line() {
    let mut lexed = Lexed::default();
    let mut edited = 0;
    for (name, bytes) in corpus() {
        for line in lines(&bytes) {
            let content = &line[..content_len(line)];
            if classify(content) != LineKind::Block || lex_block(content, &mut lexed).is_err() {
                continue;
            }
            for w in lexed
                .words()
                .filter(|w| matches!(w.letter, b'X' | b'Y' | b'Z' | b'F'))
            {
                let mut out = Vec::new();
                apply_edits(
                    line,
                    &mut [Edit::replace(w.value_span.clone(), "123.4560")],
                    &mut out,
                )
                .unwrap();
                let mut expected = line[..w.value_span.start].to_vec();
                expected.extend_from_slice(b"123.4560");
                expected.extend_from_slice(&line[w.value_span.end..]);
                assert_eq!(out, expected, "{name}");
                // And it lexes back to the new value, all else equal.
                let mut again = Lexed::default();
                lex_block(&out[..content_len(&out)], &mut again).unwrap();
                let before: Vec<(u8, f64)> = lexed.words().map(|x| (x.letter, x.value)).collect();
                let after: Vec<(u8, f64)> = again.words().map(|x| (x.letter, x.value)).collect();
                for (i, (b, a)) in before.iter().zip(&after).enumerate() {
                    if lexed.words().nth(i).unwrap().span == w.span {
                        assert_eq!(*a, (w.letter, 123.456));
                    } else {
                        assert_eq!(a, b, "{name}");
                    }
                }
                edited += 1;
            }
        }
    }
    assert!(edited > 100_000, "only {edited} words edited");
}

/// A number written in one of the styles real posts use.
fn styled(value_thousandths: i64, style: u8, spaces: bool) -> String {
    let v = value_thousandths as f64 / 1000.0;
    let mut s = match style % 4 {
        0 => format!("{v:.4}"),
        1 => format!("{v}"),
        2 => {
            // Leading zero dropped: `.25`, `-.25`.
            let t = format!("{v:.3}");
            if let Some(rest) = t.strip_prefix("0.") {
                format!(".{rest}")
            } else if let Some(rest) = t.strip_prefix("-0.") {
                format!("-.{rest}")
            } else {
                t
            }
        }
        _ => {
            if v.fract() == 0.0 {
                format!("{v:.0}.")
            } else {
                format!("{v}")
            }
        }
    };
    if spaces && s.len() > 2 {
        s.insert(1, ' ');
    }
    s
}

proptest! {
    #![proptest_config(crate::common::proptest_config(300))]

    #[test]
    fn numbers_in_any_style_lex_to_their_value(
        words in prop::collection::vec((prop::sample::select(vec!['X', 'Y', 'Z', 'F', 'x', 'y', 'z']), -9_999_999i64..9_999_999, 0u8..4, any::<bool>(), any::<bool>()), 1..8)
    ) {
        let mut line = String::new();
        let mut expected = Vec::new();
        for (letter, v, style, spaces, sep) in &words {
            if *sep { line.push(' '); }
            line.push(*letter);
            line.push_str(&styled(*v, *style, *spaces));
            expected.push((letter.to_ascii_uppercase() as u8, *v as f64 / 1000.0));
        }
        let mut lexed = Lexed::default();
        lex_block(line.as_bytes(), &mut lexed).unwrap();
        let got: Vec<(u8, f64)> = lexed.words().map(|w| (w.letter, w.value)).collect();
        prop_assert_eq!(got.len(), expected.len());
        for ((gl, gv), (el, ev)) in got.iter().zip(&expected) {
            prop_assert_eq!(gl, el);
            prop_assert!((gv - ev).abs() < 1e-9, "{} vs {} in {:?}", gv, ev, line);
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let mut walker = Walker::new(Cursor::new(bytes), None, Setup::default(), InterpOptions::default());
        while let Ok(Some(_)) = walker.next_line() {}
    }

    #[test]
    fn mutated_corpus_lines_never_panic(file in 0usize..11, start in 0usize..2000, flips in prop::collection::vec((0usize..200, any::<u8>()), 1..6)) {
        let corpus = corpus();
        let (_, bytes) = &corpus[file % corpus.len()];
        let all = lines(bytes);
        let from = start.min(all.len().saturating_sub(1));
        let mut chunk: Vec<u8> = all[from..(from + 20).min(all.len())].concat();
        for (pos, b) in flips {
            if !chunk.is_empty() {
                let i = pos % chunk.len();
                chunk[i] = b;
            }
        }
        let mut walker = Walker::new(Cursor::new(chunk), None, Setup::default(), InterpOptions::default());
        while let Ok(Some(_)) = walker.next_line() {}
    }
}
