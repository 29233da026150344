//! The context of the compensation walk: what every block writer takes.
//!
//! [`Walk`] holds the inputs that stay the same for the whole program (the
//! map, the options, the program's number style and word separator, its
//! name); [`Line`] is one line as every writer sees it, built by one
//! prologue ([`State::begin_line`]) for every kind of line: its event from
//! the interpreter, the model with the line's tool, the frame and number
//! style it is written in and the one in effect before it. The walk's own
//! state (the command sent so far, the direction state, the feed state, the
//! output buffer, the summary) is [`State`]; a writer is a method of it that
//! takes a `&Line`.

use super::frame::Frame;
use super::lines::line_ending;
use super::targets::mark_axes_set;
use super::{CompensateOptions, State};
use crate::model::{ErrorModel, WithTool};
use volcomp_gcode::lexer::Word;
use volcomp_gcode::number::{NumberStyle, StyleSurvey};
use volcomp_gcode::{FeedMode, LineEvent, MotionSource};

/// The walk's inputs, the same for every line.
pub(super) struct Walk<'w> {
    /// The map, without a tool ([`Line::model`] adds the line's).
    pub(super) model: &'w dyn ErrorModel,
    pub(super) options: &'w CompensateOptions,
    /// How the program writes numbers.
    pub(super) survey: &'w StyleSurvey,
    /// The separator written between words: a blank, or nothing for a
    /// program written without blanks.
    pub(super) sep: &'static str,
    /// The program's name, for messages.
    pub(super) file: &'w str,
}

/// One line of the program as every block writer takes it.
pub(super) struct Line<'a> {
    pub(super) ev: &'a LineEvent<'a>,
    /// The map with the tool active on this line: models with Abbe terms
    /// depend on it.
    pub(super) model: WithTool<'a>,
    /// Frame and number style of the line (its own modes and offsets).
    pub(super) frame: Frame,
    pub(super) style: NumberStyle,
    /// Frame and number style after the previous line (what a move written
    /// before the line's own words uses); `None` on the first line.
    pub(super) before: Option<(Frame, NumberStyle)>,
    /// The line's ending (`\n` where it has none).
    pub(super) ending: &'a [u8],
    /// Every axis has been set by the program so far.
    pub(super) all_known: bool,
}

impl<'a> Line<'a> {
    /// The line number.
    pub(super) fn number(&self) -> u64 {
        self.ev.number
    }

    /// The line's words.
    pub(super) fn words(&self) -> impl Iterator<Item = &'a Word> {
        self.ev.lexed.words()
    }

    /// The line's bytes without their ending and `;` comment.
    pub(super) fn content(&self) -> &'a [u8] {
        &self.ev.bytes[..volcomp_gcode::lexer::content_len(self.ev.bytes)]
    }

    /// The model as a trait object.
    pub(super) fn model(&self) -> &dyn ErrorModel {
        &self.model
    }

    /// Where the line's own moves are written: its frame, traced to it.
    pub(super) fn place(&self) -> Place<'_> {
        Place {
            frame: &self.frame,
            style: self.style,
            line: self.number(),
            ending: self.ending,
        }
    }

    /// Frame and number style before the line, or `own` on the first line.
    pub(super) fn before_or(&self, own: (Frame, NumberStyle)) -> (Frame, NumberStyle) {
        self.before.unwrap_or(own)
    }
}

/// Where an inserted line is written: the frame and number style of its
/// words, the original line its trace comment names, its line ending.
#[derive(Clone, Copy)]
pub(super) struct Place<'a> {
    pub(super) frame: &'a Frame,
    pub(super) style: NumberStyle,
    pub(super) line: u64,
    pub(super) ending: &'a [u8],
}

impl<'p> Place<'p> {
    /// The same place with another line ending.
    pub(super) fn with_ending(self, ending: &'p [u8]) -> Place<'p> {
        Place { ending, ..self }
    }
}

/// The axes whose position the program has set after the line `ev`, from
/// those set before it (`known`): the axes its motion words name, or all
/// three after a reference move (G28/G30).
pub(super) fn known_after(mut known: [bool; 3], ev: &LineEvent<'_>) -> [bool; 3] {
    // A line only ever adds axes: once all three are set (after the first
    // moves of almost every program) its words need no look.
    if known == [true; 3] {
        return known;
    }
    if !ev.motions.is_empty() {
        mark_axes_set(ev.lexed, &mut known);
    }
    if ev
        .motions
        .iter()
        .any(|m| m.source == MotionSource::Reference)
    {
        known = [true; 3];
    }
    known
}

impl<'w> State<'w> {
    /// The prologue of every line: counts it, clears the output buffer,
    /// follows the feed mode and the axes the program has set, and builds
    /// the [`Line`] the writers take.
    pub(super) fn begin_line<'a>(&mut self, ev: &'a LineEvent<'a>) -> Line<'a>
    where
        'w: 'a,
    {
        let g93_now = ev.interp.feed_mode() == FeedMode::InverseTime;
        self.g93_before = std::mem::replace(&mut self.g93_last, g93_now);
        self.summary.lines_in += 1;
        self.summary.bytes_in += ev.bytes.len() as u64;
        if !ev.rendered && ev.bytes.ends_with(b"\n") {
            // A line of the program as read: one line, its only `\n` its
            // last byte (the reader splits at every `\n`), so the
            // one-line count applies (a line that begins with a letter is
            // a block without a search for its end).
            self.blocks_in.scan_line(ev.bytes);
        } else {
            self.blocks_in.scan(ev.bytes);
        }
        self.buf.clear();
        self.known = known_after(self.known, ev);
        let (frame, style) = Frame::of(ev.interp, self.walk.options, self.walk.survey);
        Line {
            ev,
            model: WithTool {
                model: self.walk.model,
                tool_length_offset_mm: ev.interp.tool_length_offset_mm(),
            },
            frame,
            style,
            before: self.frame_before,
            ending: line_ending(ev.bytes),
            all_known: self.known.iter().all(|k| *k),
        }
    }
}
