//! A line as LinuxCNC's reader sees it (`close_and_downcase`,
//! interp_read.cc): blanks removed and letters lower-cased outside comments,
//! comments kept as written. Each byte remembers its column in the original
//! line, so errors and edits point at the original.

/// A normalised line.
#[derive(Debug, Clone, Default)]
pub struct Norm {
    /// The normalised bytes.
    pub text: Vec<u8>,
    /// For each byte of `text`, its 0-based column in the original line.
    pub cols: Vec<usize>,
    /// Length of the original content (the column past its end).
    pub end: usize,
}

impl Norm {
    /// Normalises `content` (a line without its ending). An unclosed
    /// comment runs to the end of the line; the lexer reports it.
    pub fn of(content: &[u8]) -> Norm {
        let mut n = Norm {
            text: Vec::with_capacity(content.len()),
            cols: Vec::with_capacity(content.len()),
            end: content.len(),
        };
        let mut i = 0;
        while i < content.len() {
            let b = content[i];
            match b {
                b' ' | b'\t' | b'\r' => {}
                b'(' => {
                    while i < content.len() {
                        n.text.push(content[i]);
                        n.cols.push(i);
                        if content[i] == b')' {
                            break;
                        }
                        i += 1;
                    }
                }
                b';' => {
                    while i < content.len() {
                        n.text.push(content[i]);
                        n.cols.push(i);
                        i += 1;
                    }
                }
                _ => {
                    n.text.push(b.to_ascii_lowercase());
                    n.cols.push(i);
                }
            }
            i += 1;
        }
        n
    }

    /// The byte at `pos`, or 0 past the end.
    pub fn byte(&self, pos: usize) -> u8 {
        self.text.get(pos).copied().unwrap_or(0)
    }

    /// The original column of normalised position `pos` (the end of the
    /// line past the last byte).
    pub fn col(&self, pos: usize) -> usize {
        self.cols.get(pos).copied().unwrap_or(self.end)
    }

    /// The original byte range of normalised positions `start..end`.
    pub fn span(&self, start: usize, end: usize) -> std::ops::Range<usize> {
        let s = self.col(start);
        let e = if end > start {
            self.col(end - 1) + 1
        } else {
            s
        };
        s..e
    }
}
