//! Lexing ahead: a program's lines lexed on a thread of their own while
//! the [`crate::Walker`] that reads them interprets the lines before.
//!
//! The thread reads its own copy of the program (a second reader of the
//! same file), splits it into lines where the walker's reader does (after
//! each `\n`, [`crate::ngc::source::Lines`]) and lexes each line's content
//! ([`lexer::content_len`], [`lexer::lex_block`]). It sends the tokens in
//! batches through a bounded channel, with the content they were lexed
//! from, so the memory held stays bounded whatever the program's length.
//!
//! The walker takes a line's tokens only where the content it read
//! itself is the same bytes ([`LexAhead::take`]): the lexer is a function
//! of the content alone, so the tokens are those it would make, to the
//! bit. Anything else — a line the thread has not reached, a line it could
//! not lex, a file that differs from what the walker reads, a line run
//! again by control flow — is lexed by the walker as before.

use crate::lexer::{self, Lexed};
use std::io::Read;
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TryRecvError};

/// Lines per batch, batches that may wait for the walker at once, and
/// batches made at most: those, the walker's and the thread's own (the
/// thread waits for one to come back rather than make more).
const BATCH_LINES: usize = 512;
const BATCHES_IN_FLIGHT: usize = 4;
const BATCHES_MADE: usize = BATCHES_IN_FLIGHT + 2;

/// Bytes read at a time, and the longest line the thread lexes: a longer
/// one ends the lexing ahead (the walker reads and refuses such lines
/// itself), so the memory held stays bounded.
const READ_BYTES: usize = 1 << 16;
const MAX_LINE_BYTES: usize = 1 << 12;

/// Consecutive lines, from `first` (0-based line of the program): the
/// content of each and what the lexer made of it. A batch the walker is
/// done with goes back to the thread, which lexes the next lines into the
/// same buffers (no allocation per line on either side).
#[derive(Debug, Default)]
struct Batch {
    first: usize,
    /// The lines' contents, one after the other; line `i` ends at
    /// `ends[i]` and starts where line `i − 1` ends.
    content: Vec<u8>,
    ends: Vec<usize>,
    /// The lexer's tokens of line `i`, when it accepted the line and the
    /// walker has not taken them yet (`ready[i]`).
    lexed: Vec<Lexed>,
    ready: Vec<bool>,
}

impl Batch {
    /// Empties the batch for the lines from `first` (its buffers kept).
    fn reset(&mut self, first: usize) {
        self.first = first;
        self.content.clear();
        self.ends.clear();
        self.ready.clear();
    }

    /// Lexes `content` as the batch's next line.
    fn push(&mut self, content: &[u8]) {
        let i = self.ends.len();
        if self.lexed.len() == i {
            self.lexed.push(Lexed::default());
        }
        let ok = lexer::lex_block(content, &mut self.lexed[i]).is_ok();
        self.content.extend_from_slice(content);
        self.ends.push(self.content.len());
        self.ready.push(ok);
    }

    fn len(&self) -> usize {
        self.ends.len()
    }

    fn end(&self) -> usize {
        self.first + self.len()
    }
}

/// The walker's end of the lexing ahead ([`crate::Walker::lex_ahead`]).
#[derive(Debug)]
pub struct LexAhead {
    rx: Option<Receiver<Batch>>,
    /// Batches the walker is done with, back to the thread.
    back: Option<SyncSender<Batch>>,
    batch: Batch,
    /// Lines whose tokens the walker took.
    pub(crate) taken: u64,
}

impl LexAhead {
    /// Starts lexing `program` on a thread of its own. The thread ends at
    /// the end of `program`, at a read error or a line longer than it
    /// lexes, or once this end is dropped.
    pub fn spawn(program: impl Read + Send + 'static) -> LexAhead {
        let (tx, rx) = sync_channel(BATCHES_IN_FLIGHT);
        // Room for every batch made and the walker's empty first one: a
        // batch given back is never dropped on the walker's thread.
        let (back, back_rx) = sync_channel(BATCHES_MADE + 1);
        let spawned = std::thread::Builder::new()
            .name("lex-ahead".into())
            .spawn(move || lex_lines(program, &tx, &back_rx));
        let ok = spawned.is_ok();
        LexAhead {
            // Without a thread nothing comes: the walker lexes every line.
            rx: ok.then_some(rx),
            back: ok.then_some(back),
            batch: Batch::default(),
            taken: 0,
        }
    }

    /// Puts the tokens of line `line` (0-based) into `out` when the thread
    /// lexed that line from the same `content` without an error (what
    /// [`lexer::lex_block`] of `content` would give) and they were not
    /// taken before; `false` otherwise, `out` then untouched. Lines must be
    /// asked in increasing order to be found: the batches before the one
    /// holding `line` are given back.
    #[inline]
    pub(crate) fn take(&mut self, line: usize, content: &[u8], out: &mut Lexed) -> bool {
        while line >= self.batch.end() {
            if !self.next_batch() {
                return false;
            }
        }
        let Some(i) = line.checked_sub(self.batch.first) else {
            return false;
        };
        if !self.batch.ready[i] {
            return false;
        }
        let start = match i {
            0 => 0,
            _ => self.batch.ends[i - 1],
        };
        if self.batch.content[start..self.batch.ends[i]] != *content {
            return false;
        }
        // The walker's own buffer goes to the batch in exchange (the
        // thread clears it before it lexes into it).
        std::mem::swap(out, &mut self.batch.lexed[i]);
        self.batch.ready[i] = false;
        self.taken += 1;
        true
    }

    /// The next batch, if the thread has sent it already (the walker never
    /// waits for it: a line not lexed yet is lexed by the walker). The
    /// batch before goes back to the thread.
    #[cold]
    fn next_batch(&mut self) -> bool {
        let Some(rx) = &self.rx else {
            return false;
        };
        match rx.try_recv() {
            Ok(b) => {
                let done = std::mem::replace(&mut self.batch, b);
                if let Some(back) = &self.back {
                    // The thread may have ended: the batch is dropped.
                    let _ = back.try_send(done);
                }
                true
            }
            Err(TryRecvError::Empty) => false,
            Err(TryRecvError::Disconnected) => {
                self.rx = None;
                false
            }
        }
    }
}

/// The thread: reads `program`, lexes its lines and sends them in
/// batches (reusing those that come back through `back`) until the input
/// ends or the walker's end is dropped.
fn lex_lines(mut program: impl Read, tx: &SyncSender<Batch>, back: &Receiver<Batch>) {
    let mut buf = vec![0u8; READ_BYTES + MAX_LINE_BYTES];
    let mut filled = 0;
    let mut made = 0;
    // A batch given back, a new one while fewer than `BATCHES_MADE` were
    // made, else the next given back (`None`: the walker is gone).
    let mut fresh = |first: usize| {
        let mut b = match back.try_recv() {
            Ok(b) => b,
            Err(_) if made < BATCHES_MADE => {
                made += 1;
                Batch::default()
            }
            Err(_) => back.recv().ok()?,
        };
        b.reset(first);
        Some(b)
    };
    let Some(mut batch) = fresh(0) else {
        return;
    };
    let mut eof = false;
    while !eof {
        match program.read(&mut buf[filled..]) {
            Ok(0) => eof = true,
            Ok(n) => filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(_) => break,
        }
        // Every whole line read (and at the end the last, without a
        // line feed).
        let mut start = 0;
        for k in memchr::memchr_iter(b'\n', &buf[..filled]) {
            let line = &buf[start..=k];
            batch.push(&line[..lexer::content_len(line)]);
            start = k + 1;
            if batch.len() == BATCH_LINES {
                let end = batch.end();
                if tx.send(batch).is_err() {
                    return;
                }
                let Some(next) = fresh(end) else {
                    return;
                };
                batch = next;
            }
        }
        if eof && start < filled {
            let line = &buf[start..filled];
            batch.push(&line[..lexer::content_len(line)]);
            start = filled;
        }
        buf.copy_within(start..filled, 0);
        filled -= start;
        if filled >= MAX_LINE_BYTES {
            // A line longer than lexed here: the walker takes it from here
            // (the buffer keeps room for a whole read after the rest).
            break;
        }
    }
    if batch.len() > 0 {
        let _ = tx.send(batch);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lexer::Token;

    /// Lines of every kind the lexer meets: words, comments, `;` comments,
    /// block delete, CR LF and CR CR LF endings, a BOM, expressions and
    /// o-words (refused or noted by the lexer), an unclosed comment, and a
    /// last line without a line feed.
    fn program(lines: usize) -> Vec<u8> {
        let mut p = b"\xEF\xBB\xBFG21 G90 (mm)\r\n".to_vec();
        for i in 0..lines {
            let line = match i % 9 {
                0 => format!("G1 X{}.{:03} Y-{}.5 F1200\n", i, i % 1000, i % 77),
                1 => format!("/g0 z{} ; rapid up\r\n", i % 5),
                2 => format!("N{i} G2 X1 Y2 I0.5 J0 (arc [#1])\n"),
                3 => "#1 = [2 * 3]\n".to_string(),
                4 => "o100 if [#1 GT 2]\n".to_string(),
                5 => "G1 X[#1] (unclosed\n".to_string(),
                6 => "(just a comment)\r\r\n".to_string(),
                7 => "\n".to_string(),
                _ => format!("X {} . 2 5 Y.{i}\n", i % 10),
            };
            p.extend_from_slice(line.as_bytes());
        }
        p.extend_from_slice(b"M2");
        p
    }

    /// The lines split as the walker's reader splits them (after each
    /// `\n`, the last without one), each line's content.
    fn contents(p: &[u8]) -> Vec<&[u8]> {
        let mut out = Vec::new();
        let mut s = 0;
        while s < p.len() {
            let e = memchr::memchr(b'\n', &p[s..]).map_or(p.len(), |k| s + k + 1);
            out.push(&p[s..e][..lexer::content_len(&p[s..e])]);
            s = e;
        }
        out
    }

    /// Waits until the thread has lexed everything (it runs on its own).
    fn ahead_of(p: Vec<u8>) -> LexAhead {
        let mut a = LexAhead::spawn(std::io::Cursor::new(p));
        let mut batches = Vec::new();
        let rx = a.rx.take().unwrap();
        let back = a.back.take().unwrap();
        // Every batch kept, a new one given back for each: the thread
        // makes no more than `BATCHES_MADE` itself.
        while let Ok(b) = rx.recv() {
            batches.push(b);
            // (Refused once the thread has ended.)
            let _ = back.send(Batch::default());
        }
        // Replay the batches through a channel of their own.
        let (tx, rx) = sync_channel(batches.len() + 1);
        for b in batches {
            tx.send(b).unwrap();
        }
        a.rx = Some(rx);
        a
    }

    #[test]
    fn every_line_lexed_ahead_is_the_lexers_tokens_of_its_content() {
        let p = program(5000);
        let lines = contents(&p);
        let mut a = ahead_of(p.clone());
        let (mut taken, mut refused) = (0, 0);
        for (i, c) in lines.iter().enumerate() {
            let mut own = Lexed::default();
            let r = lexer::lex_block(c, &mut own);
            // A stale token buffer, as the walker's is between lines.
            let mut got = Lexed::default();
            got.tokens.push(Token::BlockDelete(99));
            let took = a.take(i, c, &mut got);
            // Every line the lexer accepts is taken, no other.
            assert_eq!(
                took,
                r.is_ok(),
                "line {i}: {:?}",
                String::from_utf8_lossy(c)
            );
            if took {
                taken += 1;
                assert_eq!(got.tokens, own.tokens, "line {i}");
                assert_eq!(
                    (got.has_comment, got.ngc_in_comment, got.letters),
                    (own.has_comment, own.ngc_in_comment, own.letters),
                    "line {i}"
                );
            } else {
                refused += 1;
                assert_eq!(got.tokens, vec![Token::BlockDelete(99)]);
            }
        }
        // By hand: the BOM line, 5000 lines, `M2`. The lexer refuses the
        // parameter settings and o-words (kinds 3 and 4: 556 each, as
        // 5000 = 9 · 555 + 5) and the `X[#1]` lines (kind 5: 555); it
        // takes the rest.
        assert_eq!(lines.len(), 5002);
        assert_eq!(refused, 556 + 556 + 555, "{taken} taken");
        assert_eq!(taken, 5002 - refused);
    }

    #[test]
    fn a_line_read_other_than_lexed_ahead_is_not_taken() {
        let p = program(3000);
        let lines = contents(&p);
        let mut a = ahead_of(p.clone());
        let mut out = Lexed::default();
        // Line 1 (`G1 X0.000 Y-0.5 F1200`) read as other bytes.
        assert!(!a.take(1, b"G1 X0.000 Y-0.6 F1200", &mut out));
        assert!(out.tokens.is_empty());
        // The next line is taken, and the line before it too, in the same
        // batch (control flow going back); a line taken once is not taken
        // again (its tokens went to the walker).
        assert!(a.take(2, lines[2], &mut out));
        assert!(a.take(1, lines[1], &mut out));
        assert!(!a.take(2, lines[2], &mut out));
        // A line of the next batch drops this one: going back there, the
        // line is no longer found (the walker lexes it).
        assert!(a.take(BATCH_LINES + 1, lines[BATCH_LINES + 1], &mut out));
        assert!(!a.take(1, lines[1], &mut out));
        // Past the end of the program: nothing.
        assert!(!a.take(lines.len(), b"", &mut out));
    }

    /// Every event of `program` walked with its lines lexed ahead or not:
    /// number, bytes, tokens and motions; the error, if any, as text; and
    /// the lines taken from the thread.
    fn walk(program: &str, ahead: bool) -> (Vec<String>, u64) {
        let mut w = crate::Walker::new(
            std::io::Cursor::new(program.as_bytes().to_vec()),
            Some("p.ngc".into()),
            crate::Setup::default(),
            crate::InterpOptions::default(),
        );
        if ahead {
            w.lex_ahead(LexAhead::spawn(std::io::Cursor::new(
                program.as_bytes().to_vec(),
            )));
            // Let the thread run ahead (the walker would else lex the
            // first lines itself, correctly but not through the thread).
            std::thread::sleep(std::time::Duration::from_millis(200));
        }
        let mut out = Vec::new();
        loop {
            match w.next_line() {
                Ok(Some(ev)) => out.push(format!(
                    "{} {:?} {} {:?} {:?}",
                    ev.number,
                    String::from_utf8_lossy(ev.bytes),
                    ev.rendered,
                    ev.lexed.tokens,
                    ev.motions
                )),
                Ok(None) => break,
                Err(e) => {
                    out.push(e.to_string());
                    break;
                }
            }
        }
        (out, w.ahead.map_or(0, |a| a.taken))
    }

    #[test]
    fn a_program_walked_with_its_lines_lexed_ahead_is_the_same_program() {
        // A loop run three times (its lines read again: lexed by the
        // walker the second time), parameters, comments, CR LF, and more
        // lines than the batches in flight hold (the batches come back to
        // the thread and are lexed into again).
        let mut p = String::from("G21 G90 G17 (start)\r\n#1 = 0\n");
        p += "o100 while [#1 LT 3]\nG1 X[#1] Y1 F100\n#1 = [#1 + 1]\no100 endwhile\n";
        let n = 3 * BATCH_LINES * BATCHES_IN_FLIGHT;
        for i in 0..n {
            p += &format!("G1 X{}.{:03} Y{} (p{i})\n", i % 300, i % 1000, i % 7);
            if i % 5 == 0 {
                p += "/G0 Z1 ; up\r\n";
            }
        }
        let (plain, none) = walk(&format!("{p}M2\n"), false);
        let (ahead, taken) = walk(&format!("{p}M2\n"), true);
        assert_eq!(none, 0);
        assert_eq!(plain.len(), ahead.len());
        for (a, b) in plain.iter().zip(&ahead) {
            assert_eq!(a, b);
        }
        // Most lines came from the thread.
        assert!(taken > (n as u64) / 2, "{taken} of {}", plain.len());
        // A line the interpreter refuses is refused the same way.
        let bad = format!("{p}G1 X1 G2 Y1\nM2\n");
        let (plain, _) = walk(&bad, false);
        let (ahead, _) = walk(&bad, true);
        assert_eq!(plain.last(), ahead.last());
        assert!(plain.last().unwrap().contains("G1"), "{:?}", plain.last());
    }

    #[test]
    fn a_line_too_long_to_lex_ahead_ends_the_lexing_there() {
        let mut p = b"G1 X1\nG1 X2\n".to_vec();
        // Longer than a read and the room kept for a line: never whole.
        p.extend(std::iter::repeat_n(b'(', READ_BYTES + MAX_LINE_BYTES + 10));
        p.extend_from_slice(b")\nG1 X3\n");
        let mut a = ahead_of(p);
        let mut out = Lexed::default();
        assert!(a.take(0, b"G1 X1", &mut out));
        assert!(a.take(1, b"G1 X2", &mut out));
        assert!(!a.take(3, b"G1 X3", &mut out));
    }
}
