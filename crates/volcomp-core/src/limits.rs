//! Limits that keep the work of one run bounded whatever the input.
//!
//! A program line can ask for an unbounded amount of work: a move of 100 m
//! split into 1 µm segments, a 10,000-turn helix linearised to 1 nm. Every
//! such request is measured *before* any point is generated, and refused with
//! a located error when it passes these limits; the output as a whole is
//! capped by [`LimitedWriter`]. `docs/errors.md` ("Limits") lists them.

use std::io::{self, Write};

/// Most target points one program block may be split into: one million,
/// i.e. 1 mm segments along 1 km of path, or a 10 mm-radius helix of about
/// 1,400 turns at the default 0.1 µm chord tolerance. A block's points are
/// held in memory while it is solved (about 130 bytes each with its written
/// line), so this bounds memory to some 130 MB per block.
pub const MAX_POINTS_PER_BLOCK: u64 = 1_000_000;

/// Default cap on the bytes one output may take: 256 MiB, about eight
/// million compensated lines, several times the largest programs of the
/// bundled real-world corpus after splitting at 1 mm. Larger outputs are
/// almost always a wrong segment length or unit; the CLI's
/// The caller may raise or remove the cap (`None`).
pub const DEFAULT_MAX_OUTPUT_BYTES: u64 = 256 * 1024 * 1024;

/// Longest line of a table file (CSV): 1 MiB. A table's line is a row of
/// numbers (a thermal file with a thousand sensors takes some 20 kB); a
/// longer line is not a table, and is refused before it is split into
/// fields.
pub const MAX_TABLE_LINE_BYTES: usize = 1 << 20;

/// Most data rows of one table file: 5 million (a map of a million points
/// per axis, forward and reverse, with room). Beyond it the table is
/// refused at the row that passes it; a finer table than this is finer
/// than any measurement (a point per 0.2 µm along a metre).
pub const MAX_TABLE_ROWS: usize = 5_000_000;

/// Largest position a table may give, in mm: the coordinate limit of
/// programs ([`volcomp_gcode::interp::MAX_COORDINATE_MM`], 100 m).
/// No program point reaches beyond it, so a table position beyond it is in
/// another unit (µm) and is refused at its row.
pub const MAX_POSITION_MM: f64 = volcomp_gcode::interp::MAX_COORDINATE_MM;

/// Largest error a map may give, in µm: 10 mm. The errors of machine tools
/// are micrometres to a few tenths of a millimetre; a value beyond this is
/// in another unit (nm) or in the wrong column, and is refused at its row
/// rather than at the first program line that meets it.
pub const MAX_ERROR_UM: f64 = 10_000.0;

/// Largest angular error a map may give, in µrad: 0.01 rad (0.57°).
/// Angular errors of machine tools are tens of microradians.
pub const MAX_ANGLE_URAD: f64 = 10_000.0;

/// Most ILC iterations per point: 1000. ILC with the default gain 0.5
/// halves the residual each step (a micrometre to a femtometre in 30
/// steps); a point that has not converged in 1000 steps will not, and the
/// work is points × iterations.
pub const MAX_ILC_ITERATIONS: u64 = 1000;

/// Most segments a feed move is split into by a fixed count: 10 000 (the
/// papers split into 10 to 30).
pub const MAX_SEGMENTS_PER_MOVE: u64 = 10_000;

/// Shortest segment a fixed or adaptive splitting may ask for: 1 µm
/// (0.001 mm), about the size of the corrections themselves; shorter
/// segments only multiply the work and the output.
pub const MIN_SEGMENT_LENGTH_MM: f64 = 1e-3;

/// Smallest chord tolerance for linearising arcs and splines: 1 nm
/// (1e-6 mm), a thousandth of the default.
pub const MIN_CHORD_TOLERANCE_MM: f64 = 1e-6;

/// Largest chord tolerance: 1 mm. Chords farther from the arc than this
/// change the part itself (a 10 mm circle within 1 mm is a hexagon), far
/// beyond any machine error being compensated.
pub const MAX_CHORD_TOLERANCE_MM: f64 = 1.0;

/// Most points a resampled controller table may have (`map export
/// --step`): a million, far beyond any controller's table (LinuxCNC reads
/// comp files of any length, but others hold hundreds), checked before the
/// table is built.
pub const MAX_RESAMPLED_POINTS: u64 = 1_000_000;

/// Smallest contour tolerance of adaptive splitting: 1 nm (0.001 µm).
pub const MIN_CONTOUR_TOLERANCE_UM: f64 = 1e-3;

/// Checks that `points` (which may be a float estimate, possibly infinite or
/// NaN) stays within [`MAX_POINTS_PER_BLOCK`]; the error says how many.
///
/// ```
/// use volcomp_core::limits::check_points;
/// assert!(check_points(1000.0).is_ok());
/// assert!(check_points(2.0e6).unwrap_err().contains("2000000"));
/// assert!(check_points(f64::NAN).is_err());
/// ```
pub fn check_points(points: f64) -> Result<(), String> {
    if points <= MAX_POINTS_PER_BLOCK as f64 {
        Ok(())
    } else {
        Err(format!(
            "this block would be split into {points:.0} points, more than the {MAX_POINTS_PER_BLOCK} volcomp handles in one block"
        ))
    }
}

/// A writer that refuses to pass more than `limit` bytes to `inner`.
///
/// The write that would cross the limit fails with an error of kind
/// [`io::ErrorKind::FileTooLarge`] and writes nothing of that call; the
/// caller discards the partial output (the CLI writes into a temporary file
/// that is only renamed into place on success).
#[derive(Debug)]
pub struct LimitedWriter<W> {
    inner: W,
    written: u64,
    limit: u64,
}

impl<W: Write> LimitedWriter<W> {
    /// Wraps `inner`; `limit: None` passes everything.
    pub fn new(inner: W, limit: Option<u64>) -> Self {
        Self {
            inner,
            written: 0,
            limit: limit.unwrap_or(u64::MAX),
        }
    }

    /// Bytes passed so far.
    pub fn written(&self) -> u64 {
        self.written
    }
}

impl<W: Write> Write for LimitedWriter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if self.written.saturating_add(buf.len() as u64) > self.limit {
            return Err(io::Error::new(
                io::ErrorKind::FileTooLarge,
                format!(
                    "the output would exceed its size limit of {} bytes; nothing was written",
                    self.limit
                ),
            ));
        }
        let n = self.inner.write(buf)?;
        self.written += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limited_writer_refuses_the_write_that_crosses_the_limit() {
        let mut w = LimitedWriter::new(Vec::new(), Some(10));
        w.write_all(b"0123456789").unwrap();
        let e = w.write_all(b"x").unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::FileTooLarge);
        assert_eq!(w.written(), 10);
        let mut unlimited = LimitedWriter::new(Vec::new(), None);
        unlimited.write_all(&[0u8; 100]).unwrap();
        assert_eq!(unlimited.written(), 100);
    }

    #[test]
    fn point_limit_is_inclusive() {
        assert!(check_points(MAX_POINTS_PER_BLOCK as f64).is_ok());
        assert!(check_points(MAX_POINTS_PER_BLOCK as f64 + 1.0).is_err());
        assert!(check_points(f64::INFINITY).is_err());
    }
}
