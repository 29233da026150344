//! Byte-range edits spliced into a line: the only way volcomp changes a program.
//!
//! An [`Edit`] replaces a byte range of the original line with new text (an
//! empty range inserts). Everything outside the edited ranges is copied
//! verbatim, so reading a program and applying no edits reproduces it byte
//! for byte, and a one-word edit changes exactly that word.

use std::ops::Range;

/// Replace `range` of a line with `content` (insert when the range is empty).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Edit {
    /// Byte range in the original line.
    pub range: Range<usize>,
    /// Replacement text.
    pub content: String,
}

impl Edit {
    /// Replaces a range.
    pub fn replace(range: Range<usize>, content: impl Into<String>) -> Self {
        Self {
            range,
            content: content.into(),
        }
    }

    /// Inserts text before byte `at`.
    pub fn insert(at: usize, content: impl Into<String>) -> Self {
        Self::replace(at..at, content)
    }

    /// Deletes a range.
    pub fn delete(range: Range<usize>) -> Self {
        Self::replace(range, String::new())
    }
}

/// Why edits could not be applied.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EditError {
    /// Two edits touch the same bytes.
    #[error("edits overlap at byte {0}")]
    Overlap(usize),
    /// An edit reaches past the end of the line.
    #[error("edit range ends at byte {end} past the line length {len}")]
    OutOfRange {
        /// End of the offending range.
        end: usize,
        /// Length of the line.
        len: usize,
    },
}

/// Appends `line` with `edits` applied to `out`. Edits may come in any order;
/// insertions at the same position keep their given order.
pub fn apply_edits(line: &[u8], edits: &mut [Edit], out: &mut Vec<u8>) -> Result<(), EditError> {
    edits.sort_by_key(|e| (e.range.start, e.range.end));
    let mut cursor = 0;
    for e in edits.iter() {
        if e.range.end > line.len() || e.range.start > e.range.end {
            return Err(EditError::OutOfRange {
                end: e.range.end,
                len: line.len(),
            });
        }
        if e.range.start < cursor {
            return Err(EditError::Overlap(e.range.start));
        }
        out.extend_from_slice(&line[cursor..e.range.start]);
        out.extend_from_slice(e.content.as_bytes());
        cursor = e.range.end;
    }
    out.extend_from_slice(&line[cursor..]);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_edits_is_identity() {
        let mut out = Vec::new();
        apply_edits(b"G1 X10 (c)\r\n", &mut [], &mut out).unwrap();
        assert_eq!(out, b"G1 X10 (c)\r\n");
    }

    #[test]
    fn replace_and_insert() {
        let line = b"G1X10Y5\n";
        let mut edits = vec![Edit::insert(7, "Z1"), Edit::replace(3..5, "10.0012")];
        let mut out = Vec::new();
        apply_edits(line, &mut edits, &mut out).unwrap();
        assert_eq!(out, b"G1X10.0012Y5Z1\n");
    }

    #[test]
    fn overlap_is_an_error() {
        let mut edits = vec![Edit::replace(0..3, "a"), Edit::replace(2..4, "b")];
        let mut out = Vec::new();
        assert_eq!(
            apply_edits(b"abcdef", &mut edits, &mut out),
            Err(EditError::Overlap(2))
        );
    }
}
