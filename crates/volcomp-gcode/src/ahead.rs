//! A program read and lexed on a thread of its own, ahead of the walker.
//!
//! Lexing is about two fifths of the walker's work on a CAM program (a
//! line of three words, ~500 of ~1,250 instructions). [`lex_ahead`] moves
//! it off the walker's thread: a thread reads the program in chunks, hands
//! each chunk on unchanged to the walker's reader ([`AheadReader`]), and
//! lexes every line the chunk completes with the walker's own lexer
//! ([`crate::lexer::lex_block`] of the line without its ending). The lines
//! go with the chunk that completes them, so when the walker holds a line,
//! its tokens are there too: the walker never waits for them.
//!
//! The walker takes a line's tokens instead of lexing it only where it
//! would lex the line itself as read (a line of the main program while no
//! control flow keeps lines) and only if the line read cleanly (no error,
//! nothing for the expression layer); every other line it lexes itself, as
//! without this. Lines are numbered as [`crate::ngc::source::Lines`]
//! numbers them (split after each `\n`; a last line without one counts),
//! and a line's content length is checked as well, so tokens always belong
//! to the line they are used for: the walker's events are the same with and
//! without lexing ahead (tested over the corpus).

use crate::lexer::{self, Lexed, Token};
use std::io::{BufRead, Read};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TryRecvError};
use std::sync::Arc;

/// Bytes read at a time (the lines they complete go with them). 16 KiB
/// keeps the lexed lines in flight small (a chunk of 20-byte CAM lines
/// carries ~800 token lists, ~0.2 MiB; with 32 KiB chunks `moves` peaked
/// at 14.4 MiB on 10 M lines, 2.7 MiB over the plain read-ahead).
const CHUNK_BYTES: usize = 1 << 14;
/// Chunks read ahead of the walker (with their lines' tokens), so memory
/// stays bounded.
const CHUNKS_AHEAD: usize = 4;
/// A line longer than this is not lexed ahead (LinuxCNC refuses lines of
/// more than 252 characters anyway; the walker says so).
const MAX_LEXED_LINE_BYTES: usize = 4096;

/// How one line was lexed ahead.
#[derive(Debug, Clone, Copy)]
struct LineLexed {
    /// Length of its content (without the line ending).
    content_len: usize,
    /// Whether the lexer read it cleanly (no error, nothing in a comment
    /// for the expression layer): only then are its tokens used.
    clean: bool,
    has_comment: bool,
    letters: u32,
}

/// The lines a chunk completed, from line `first` on: each line's tokens
/// in a list of their own, which the walker swaps for its own list (no
/// copy); the lists come back with the spent [`Lines`] to be filled again.
#[derive(Debug, Default)]
struct Lines {
    first: usize,
    tokens: Vec<Vec<Token>>,
    lines: Vec<LineLexed>,
}

/// What the reading thread hands over: a chunk of the program (empty at
/// its end) and the lines it completes, or the read's error.
type Chunk = std::io::Result<(Vec<u8>, Lines)>;

/// The walker's reader of a program read by [`lex_ahead`]: the program's
/// bytes as its source yields them, errors included, in order.
pub struct AheadReader {
    chunks: Receiver<Chunk>,
    spent: SyncSender<Vec<u8>>,
    lines: SyncSender<Lines>,
    /// Cleared when the walker takes no more lexed lines: the thread then
    /// only reads.
    lexing: Arc<AtomicBool>,
    chunk: Vec<u8>,
    at: usize,
    done: bool,
}

/// The lines [`lex_ahead`] lexed, for [`crate::Walker::with_lexed_ahead`].
pub struct LexedAhead {
    lines: Receiver<Lines>,
    spent: SyncSender<Lines>,
    current: Lines,
    /// Next entry of `current.lines`.
    at: usize,
    /// Lines whose tokens were taken (for the tests: the path is used).
    pub(crate) taken: usize,
}

/// Reads `source` on a thread of its own and lexes its lines there: the
/// reader to give the walker, and the lexed lines to give it with
/// [`crate::Walker::with_lexed_ahead`]. Dropping both stops the thread at
/// its next chunk.
pub fn lex_ahead<S: Read + Send + 'static>(source: S) -> (AheadReader, LexedAhead) {
    let (tx, chunks) = sync_channel(CHUNKS_AHEAD);
    let (spent, spent_rx) = sync_channel::<Vec<u8>>(CHUNKS_AHEAD + 2);
    let (lines_tx, lines_rx) = sync_channel(CHUNKS_AHEAD + 2);
    let (spent_lines, spent_lines_rx) = sync_channel::<Lines>(CHUNKS_AHEAD + 2);
    let lexing = Arc::new(AtomicBool::new(true));
    let still_lexing = Arc::clone(&lexing);
    std::thread::spawn(move || read_and_lex(source, tx, spent_rx, spent_lines_rx, &still_lexing));
    (
        AheadReader {
            chunks,
            spent,
            lines: lines_tx,
            lexing,
            chunk: Vec::new(),
            at: 0,
            done: false,
        },
        LexedAhead {
            lines: lines_rx,
            spent: spent_lines,
            current: Lines::default(),
            at: 0,
            taken: 0,
        },
    )
}

/// The reading thread: chunks of `source`, each with the lines it completes.
fn read_and_lex<S: Read>(
    mut source: S,
    tx: SyncSender<Chunk>,
    spent: Receiver<Vec<u8>>,
    spent_lines: Receiver<Lines>,
    lexing: &AtomicBool,
) {
    let mut lexed = Lexed::default();
    // Token lists to fill again (from spent `Lines`).
    let mut spare: Vec<Vec<Token>> = Vec::new();
    // The start of a line begun in an earlier chunk (at most
    // MAX_LEXED_LINE_BYTES of it: a longer line is not lexed).
    let mut pending: Vec<u8> = Vec::new();
    let mut pending_len = 0usize;
    let mut line_no = 0usize;
    loop {
        let mut buf = spent.try_recv().unwrap_or_default();
        buf.resize(CHUNK_BYTES, 0);
        let read = loop {
            match source.read(&mut buf) {
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                r => break r,
            }
        };
        let n = match read {
            Ok(n) => n,
            Err(e) => {
                let _ = tx.send(Err(e));
                return;
            }
        };
        buf.truncate(n);
        if !lexing.load(Ordering::Relaxed) {
            if tx.send(Ok((buf, Lines::default()))).is_err() || n == 0 {
                return;
            }
            continue;
        }
        let mut lines = match spent_lines.try_recv() {
            Ok(mut old) => {
                spare.append(&mut old.tokens);
                old.lines.clear();
                old
            }
            Err(_) => Lines::default(),
        };
        lines.first = line_no;
        let mut start = 0;
        for k in memchr::memchr_iter(b'\n', &buf) {
            let piece = &buf[start..=k];
            if pending_len == 0 {
                lex_line(piece, &mut lexed, &mut lines, &mut spare);
            } else {
                pending_len += piece.len();
                if pending_len <= MAX_LEXED_LINE_BYTES {
                    pending.extend_from_slice(piece);
                    lex_line(&pending, &mut lexed, &mut lines, &mut spare);
                } else {
                    unlexed_line(pending_len, &mut lines, &mut spare);
                }
                pending.clear();
                pending_len = 0;
            }
            start = k + 1;
        }
        let rest = &buf[start..];
        pending_len += rest.len();
        if pending_len <= MAX_LEXED_LINE_BYTES {
            pending.extend_from_slice(rest);
        }
        if n == 0 && pending_len > 0 {
            // The last line, without a line feed.
            if pending_len <= MAX_LEXED_LINE_BYTES {
                lex_line(&pending, &mut lexed, &mut lines, &mut spare);
            } else {
                unlexed_line(pending_len, &mut lines, &mut spare);
            }
        }
        line_no += lines.lines.len();
        if tx.send(Ok((buf, lines))).is_err() || n == 0 {
            return;
        }
    }
}

/// Lexes `line` (with its ending) into `lines`, as the walker would; its
/// tokens go in a list of `spare` (or a new one).
fn lex_line(line: &[u8], lexed: &mut Lexed, lines: &mut Lines, spare: &mut Vec<Vec<Token>>) {
    let content_len = lexer::content_len(line);
    let clean = lexer::lex_block(&line[..content_len], lexed).is_ok() && !lexed.ngc_in_comment;
    let mut list = spare.pop().unwrap_or_default();
    if clean {
        std::mem::swap(&mut lexed.tokens, &mut list);
    }
    lines.tokens.push(list);
    lines.lines.push(LineLexed {
        content_len,
        clean,
        has_comment: lexed.has_comment,
        letters: lexed.letters(),
    });
}

/// A line too long to lex ahead (`len` bytes with its ending).
fn unlexed_line(len: usize, lines: &mut Lines, spare: &mut Vec<Vec<Token>>) {
    lines.tokens.push(spare.pop().unwrap_or_default());
    lines.lines.push(LineLexed {
        content_len: len,
        clean: false,
        has_comment: false,
        letters: 0,
    });
}

impl BufRead for AheadReader {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.at == self.chunk.len() && !self.done {
            let used = std::mem::take(&mut self.chunk);
            if used.capacity() > 0 {
                let _ = self.spent.try_send(used);
            }
            self.at = 0;
            match self.chunks.recv() {
                Ok(Ok((chunk, lines))) => {
                    self.done = chunk.is_empty();
                    self.chunk = chunk;
                    // Lexed lines are dropped when the walker is not taking
                    // them (it then lexes those lines itself).
                    if let Err(std::sync::mpsc::TrySendError::Disconnected(_)) =
                        self.lines.try_send(lines)
                    {
                        self.lexing.store(false, Ordering::Relaxed);
                    }
                }
                Ok(Err(e)) => {
                    self.done = true;
                    return Err(e);
                }
                Err(_) => {
                    self.done = true;
                    return Err(std::io::Error::other("the thread reading ahead stopped"));
                }
            }
        }
        Ok(&self.chunk[self.at..])
    }

    fn consume(&mut self, n: usize) {
        self.at = (self.at + n).min(self.chunk.len());
    }
}

impl Read for AheadReader {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        let available = self.fill_buf()?;
        let n = available.len().min(out.len());
        out[..n].copy_from_slice(&available[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl LexedAhead {
    /// Puts the tokens of line `line` (0-based), whose content is
    /// `content_len` bytes long, into `out` if it was lexed cleanly ahead;
    /// `false` (and `out` as it was) if not. Lines must be asked for in
    /// increasing order; the ones skipped are dropped.
    #[inline]
    pub(crate) fn take(&mut self, line: usize, content_len: usize, out: &mut Lexed) -> bool {
        loop {
            let end = self.current.first + self.current.lines.len();
            if line < end {
                if line < self.current.first + self.at {
                    return false;
                }
                let k = line - self.current.first;
                self.at = k + 1;
                let l = self.current.lines[k];
                if !l.clean || l.content_len != content_len {
                    return false;
                }
                out.set_ahead(&mut self.current.tokens[k], l.has_comment, l.letters);
                self.taken += 1;
                return true;
            }
            // The chunk that completes the line came with the walker's bytes.
            match self.lines.try_recv() {
                Ok(next) => {
                    let spent = std::mem::replace(&mut self.current, next);
                    // Its token lists go back to be filled again.
                    let _ = self.spent.try_send(spent);
                    self.at = 0;
                }
                Err(TryRecvError::Empty | TryRecvError::Disconnected) => return false,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::lex_ahead;
    use crate::{InterpOptions, Setup, Walker};
    use std::io::{Cursor, Read};

    /// Hands out its bytes in pieces of the lengths given in turn (a pipe),
    /// so that lines span chunks.
    struct Pieces {
        bytes: Vec<u8>,
        at: usize,
        lengths: Vec<usize>,
        next: usize,
    }

    impl Read for Pieces {
        fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
            let want = self.lengths[self.next % self.lengths.len()];
            self.next += 1;
            let n = want.min(out.len()).min(self.bytes.len() - self.at);
            out[..n].copy_from_slice(&self.bytes[self.at..self.at + n]);
            self.at += n;
            Ok(n)
        }
    }

    /// `Pieces`, then an I/O error once its bytes are spent.
    struct ThenFails(Pieces);

    impl Read for ThenFails {
        fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
            if self.0.at == self.0.bytes.len() {
                return Err(std::io::Error::other("the disk went away"));
            }
            self.0.read(out)
        }
    }

    #[test]
    fn the_reader_yields_the_bytes_then_the_error_of_the_source() {
        // 700,000 bytes of lines (so chunks end inside lines), read back
        // through the reader in 40,000-byte reads: the same bytes, then the
        // source's own error, then nothing.
        let bytes: Vec<u8> = (0..700_000u32)
            .map(|i| {
                if i % 23 == 22 {
                    b'\n'
                } else {
                    b'0' + (i * 7 % 10) as u8
                }
            })
            .collect();
        for lengths in [vec![1 << 16], vec![1, 5000, 70_000], vec![1 << 20]] {
            for fails in [false, true] {
                let pieces = Pieces {
                    bytes: bytes.clone(),
                    at: 0,
                    lengths: lengths.clone(),
                    next: 0,
                };
                let (mut r, _lexed) = if fails {
                    lex_ahead(ThenFails(pieces))
                } else {
                    lex_ahead(pieces)
                };
                let mut got = Vec::new();
                let mut buf = vec![0; 40_000];
                let end = loop {
                    match r.read(&mut buf) {
                        Ok(0) => break None,
                        Ok(n) => got.extend_from_slice(&buf[..n]),
                        Err(e) => break Some(e.to_string()),
                    }
                };
                assert!(got == bytes, "reads {lengths:?}: {} bytes", got.len());
                assert_eq!(end.as_deref(), fails.then_some("the disk went away"));
                if fails {
                    assert_eq!(r.read(&mut buf).unwrap(), 0);
                }
            }
        }
        // Dropped before the end of an endless source: the thread stops at
        // its next chunk (it would otherwise keep a core busy).
        let (mut endless, lexed) = lex_ahead(std::io::repeat(b'x'));
        assert_eq!(std::io::BufRead::fill_buf(&mut endless).unwrap()[0], b'x');
        drop((endless, lexed));
    }

    /// Everything the walker says of `program`, line by line (the line's
    /// number, bytes, kind, tokens, motions, state flags), its warnings and
    /// how it ends.
    fn events<R: std::io::BufRead>(w: &mut Walker<R>) -> Vec<String> {
        let mut out = Vec::new();
        loop {
            match w.next_line() {
                Ok(Some(ev)) => out.push(format!(
                    "{} {:?} {:?} {} {:?} {:?} {} {:?} {}",
                    ev.number,
                    String::from_utf8_lossy(ev.bytes),
                    ev.kind,
                    ev.rendered,
                    ev.lexed.tokens,
                    ev.motions,
                    ev.after_end,
                    ev.file,
                    ev.lexed.has_polar(),
                )),
                Ok(None) => break,
                Err(e) => {
                    out.push(format!("error: {e}"));
                    break;
                }
            }
        }
        out.extend(w.warnings().iter().map(|w| format!("warning: {w}")));
        out
    }

    /// The walker's events with the lines lexed ahead (the program read in
    /// pieces of `lengths`) equal those of the walker lexing every line
    /// itself: the second method. How many lines' tokens were taken, and
    /// how many lines the walker gave.
    fn same_with_and_without(name: &str, program: &[u8], lengths: &[usize]) -> (usize, usize) {
        // Tools 1-99 of length 0 (the corpus' programs call tools) and G54.
        let mut table =
            String::from("units = \"mm\"\n[work_offsets]\nG54 = [150, 150, 100]\n[tools]\n");
        for i in 1..100 {
            table.push_str(&format!("{i} = 0\n"));
        }
        let setup = Setup::from_toml(&table).unwrap();
        let mut plain = Walker::new(
            Cursor::new(program.to_vec()),
            None,
            setup.clone(),
            InterpOptions::default(),
        );
        let (reader, lexed) = lex_ahead(Pieces {
            bytes: program.to_vec(),
            at: 0,
            lengths: lengths.to_vec(),
            next: 0,
        });
        let mut ahead =
            Walker::new(reader, None, setup, InterpOptions::default()).with_lexed_ahead(lexed);
        let (want, got) = (events(&mut plain), events(&mut ahead));
        assert_eq!(
            want.len(),
            got.len(),
            "{name}, reads of {lengths:?}: event count"
        );
        for (a, b) in want.iter().zip(&got) {
            assert_eq!(a, b, "{name}, reads of {lengths:?}");
        }
        (ahead.ahead.as_ref().map_or(0, |a| a.taken), want.len())
    }

    #[test]
    fn the_bundled_programs_walk_alike_lexed_ahead_or_not() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/corpus");
        let (mut n, mut taken, mut lines) = (0, 0, 0);
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "md") {
                continue;
            }
            let program = std::fs::read(&path).unwrap();
            let (t, l) = same_with_and_without(&path.display().to_string(), &program, &[1 << 16]);
            taken += t;
            lines += l;
            n += 1;
        }
        assert!(n >= 10, "the corpus is in {}", dir.display());
        // Most lines are taken as lexed ahead (not those of a program with
        // an O number, whose lines are kept for M98 calls, nor those after
        // a program stops with an error).
        assert!(taken * 2 > lines, "{taken} of {lines} lines taken");
    }

    #[test]
    fn edge_programs_walk_alike_lexed_ahead_or_not() {
        // Lines across reads, CR LF, a byte-order mark, comments the
        // expression layer reads, parameters, o-word loops (lines kept:
        // lexed here from then on), M98 calls, errors, `%` tapes, lines
        // after the end, a line too long, a last line without its feed.
        let long = format!("G1 X1 ({})\nG1 X2\nM2\n", "c".repeat(5000));
        let cases: Vec<String> = vec![
            "G21 G90\nG0 X1 Y2 Z3\nG1 X4 F100\nY5\r\nZ-1 (note)\nM2\n".into(),
            "\u{feff}G21\nG0 X1\nM2\n".into(),
            "G21\nG0 X1 (#1 in a comment)\nG1 X2 F10 ; [x]\nM2\n".into(),
            "G21\n#1 = 5\nG0 X#1\nG1 X[#1 + 1] F10\nM2\n".into(),
            "G21\nG0 X0\n#1 = 0\no100 while [#1 LT 3]\nG1 X[#1] F100\n#1 = [#1 + 1]\no100 endwhile\nG0 X9\nM2\n".into(),
            "G21\nG0 X1\nM98 P100 L2\nM2\nO100\nG1 X2 F50\nM99\n".into(),
            "G21\nG0 X1\nG1 X2 (open\nM2\n".into(),
            "G21\nG0 X1\nG1 Q1\nM2\n".into(),
            "%\nG21\nG0 X1\n%\nG0 X2\n".into(),
            "G21\nG0 X1\nM2\nG0 X5\n(after the end)\n".into(),
            long,
            "G21\nG0 X1\nG1 X2 F100".into(),
            "".into(),
            "\n\n\nG0 X1\n\n".into(),
            "G21 G0 X1\nO0001 (PROGRAM)\nG0 X2\nM2\n".into(),
        ];
        let mut taken = 0;
        for (i, case) in cases.iter().enumerate() {
            for lengths in [&[1 << 16][..], &[1], &[3, 1, 7], &[13, 50]] {
                taken += same_with_and_without(&format!("case {i}"), case.as_bytes(), lengths).0;
            }
        }
        assert!(taken > 100, "{taken} lines taken");
    }

    #[test]
    fn a_long_cam_program_walks_alike_lexed_ahead_or_not() {
        // Many chunks: the token lists go round (handed back and filled
        // again), lines span chunk ends.
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/corpus");
        let tiger = std::fs::read(dir.join("CauldronDevelopmentLLC__CAMotics__tiger.nc")).unwrap();
        for lengths in [&[1 << 16][..], &[4093, 10_000, 77]] {
            let (taken, lines) = same_with_and_without("tiger", &tiger, lengths);
            // All but the first lines (the thread's first chunk may come
            // after the walker's first lines) and the program end.
            assert!(taken + 2000 > lines, "{taken} of {lines} lines taken");
        }
    }
}
