//! How a program writes its numbers and separates its words, surveyed from
//! its first bytes so that rewritten words look like the program's own.

use volcomp_gcode::lexer::LineKind;
use volcomp_gcode::number::StyleSurvey;

/// How a program writes its numbers and separates its words.
#[derive(Debug, Clone, Default)]
pub struct ProgramStyle {
    /// Evidence of the number style.
    pub survey: StyleSurvey,
    /// Words are separated by blanks (`G1 X1`), not written together (`G1X1`).
    pub spaced: bool,
}

/// Infers the program's number style and word spacing from its first bytes.
pub fn survey_style(head: &[u8]) -> ProgramStyle {
    let mut survey = StyleSurvey::default();
    let mut lexed = volcomp_gcode::lexer::Lexed::default();
    let (mut spaced, mut compact) = (0u32, 0u32);
    for line in head.split(|b| *b == b'\n') {
        let content = &line[..volcomp_gcode::lexer::content_len(line)];
        if volcomp_gcode::lexer::classify(content) != LineKind::Block
            || volcomp_gcode::lexer::lex_block(content, &mut lexed).is_err()
        {
            continue;
        }
        let mut prev_end = None;
        for w in lexed.words() {
            if matches!(w.letter, b'X' | b'Y' | b'Z' | b'I' | b'J' | b'K' | b'R') {
                survey.record(&content[w.value_span.clone()]);
            }
            if let Some(e) = prev_end {
                if e == w.span.start {
                    compact += 1;
                } else {
                    spaced += 1;
                }
            }
            prev_end = Some(w.span.end);
        }
    }
    ProgramStyle {
        survey,
        spaced: spaced >= compact,
    }
}
