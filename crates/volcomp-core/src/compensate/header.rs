//! The compensating half of a compensated program's provenance: the
//! header of a map compensation (what the options were) and the program
//! written with its header at the top (`io::provenance` has the header
//! itself, its dates and hashes).

use crate::compensate::solve::Method;
use crate::compensate::{
    compensate_program_seen, CompensateOptions, CompensateSummary, DirectionPolicy, PointRecord,
    ProgramStyle, Segmentation,
};
use crate::error::CompensationError;
use crate::io::provenance::{
    comment_text, num, wrapped_at_words, HeaderWriter, ProgramHeader, FIRST_LINE_PARTIAL,
};
use crate::model::ErrorModel;
use std::io::{self, BufRead, Seek, Write};
use volcomp_gcode::{Setup, Walker};

/// How much of a compensated program's body is kept in memory while its
/// header waits for the summary (bytes); the rest goes to a temporary file.
/// 1 MiB keeps compensate's peak memory flat (about 9.5 MiB on a
/// million-line program; 16 MiB here made it 24.5 MiB).
const BODY_IN_MEMORY: usize = 1 << 20;

impl ProgramHeader {
    /// The header of a map compensation (`compensate_program`): `maps` are
    /// (file name, SHA-256) of the map and every table it names.
    pub fn for_compensation(
        maps: Vec<(String, String)>,
        setup_file: Option<String>,
        setup: Setup,
        options: &CompensateOptions,
        date_utc: String,
    ) -> Self {
        let (method, options) = describe_options(options);
        Self {
            version: env!("CARGO_PKG_VERSION").to_string(),
            files: maps
                .into_iter()
                .map(|(n, h)| ("map".to_string(), n, h))
                .collect(),
            setup_file,
            work_offset_note: None,
            setup,
            method,
            options,
            date_utc,
        }
    }
}

/// The method and options in words.
pub fn describe_options(o: &CompensateOptions) -> (String, String) {
    let method = match o.method {
        Method::Exact => "exact".to_string(),
        Method::Direct => "direct".to_string(),
        Method::Pitch => "pitch".to_string(),
        Method::Ilc {
            gain,
            max_iterations,
        } => format!("ilc gain {}, max iterations {max_iterations}", num(gain)),
    };
    let split = match o.segmentation {
        Segmentation::Off => "no split".to_string(),
        Segmentation::Count(n) => format!("segments {n}"),
        Segmentation::MaxLength(l) => format!("segment length {} mm", num(l)),
        Segmentation::Adaptive {
            tolerance_mm,
            min_length_mm,
        } => match o.exact_contour_tolerance_mm {
            Some(exact) if exact < tolerance_mm => format!(
                "contour tolerance {} um ({} um under G61), min segment {} mm",
                num(tolerance_mm * 1e3),
                num(exact * 1e3),
                num(min_length_mm)
            ),
            _ => format!(
                "contour tolerance {} um, min segment {} mm",
                num(tolerance_mm * 1e3),
                num(min_length_mm)
            ),
        },
    };
    let mut parts = vec![
        split,
        format!("chord tolerance {} mm", num(o.chord_tolerance_mm)),
        format!("max correction {} mm", num(o.max_correction_mm)),
        match o.directions {
            DirectionPolicy::Commanded => "commanded directions".into(),
            DirectionPolicy::Nominal => "nominal directions".into(),
        },
        match (o.take_up, o.fold_take_ups) {
            (false, _) => "no take-up",
            (true, true) => "take-ups by path-control mode",
            (true, false) => "take-ups as separate blocks",
        }
        .into(),
    ];
    if let (true, true, Some(t)) = (o.take_up, o.fold_take_ups, o.take_up_tolerance_mm) {
        parts.push(format!("take-up tolerance {} um", num(t * 1e3)));
    }
    if let Some(d) = o.decimals {
        parts.push(format!("decimals {d}"));
    }
    (method, parts.join(", "))
}

/// A writer that also hands what passes through it to a second writer,
/// when one is given.
struct CopyTo<'a, W> {
    inner: W,
    copy: Option<&'a mut dyn Write>,
}

impl<W: Write> Write for CopyTo<'_, W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        if let Some(c) = self.copy.as_mut() {
            c.write_all(&buf[..n])?;
        }
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// [`super::compensate_program`] with the header inserted at the top of the
/// output; the program without its header (the header is comment lines
/// only) is also written to `body_copy`, when given, as it is made.
#[allow(clippy::too_many_arguments)]
pub fn compensate_program_with_header<R: BufRead>(
    walker: &mut Walker<R>,
    file: &str,
    model: &dyn ErrorModel,
    program_style: &ProgramStyle,
    options: &CompensateOptions,
    header: &ProgramHeader,
    out: &mut dyn Write,
    body_copy: Option<&mut dyn Write>,
    on_point: impl FnMut(&PointRecord),
    on_line: &mut dyn FnMut(&volcomp_gcode::LineEvent<'_>),
) -> Result<CompensateSummary, CompensationError> {
    let (summary, _) = compensate_program_with_header_counted(
        walker,
        file,
        model,
        program_style,
        options,
        header,
        out,
        body_copy,
        on_point,
        on_line,
    )?;
    Ok(summary)
}

/// [`compensate_program_with_header`], and the blocks of the header's
/// lines (none for a header of comment lines): added to the body's
/// (`blocks_out`, counted as it was written), the blocks of the whole
/// output.
#[allow(clippy::too_many_arguments)]
pub(super) fn compensate_program_with_header_counted<R: BufRead>(
    walker: &mut Walker<R>,
    file: &str,
    model: &dyn ErrorModel,
    program_style: &ProgramStyle,
    options: &CompensateOptions,
    header: &ProgramHeader,
    out: &mut dyn Write,
    body_copy: Option<&mut dyn Write>,
    on_point: impl FnMut(&PointRecord),
    on_line: &mut dyn FnMut(&volcomp_gcode::LineEvent<'_>),
) -> Result<(CompensateSummary, u64), CompensationError> {
    // The header says what was done at reversals, which is known once the
    // program has been written: the body waits in a spool (in memory up to
    // BODY_IN_MEMORY, then in an unnamed temporary file) until then.
    // Buffered: once the spool has rolled over to its file, every line
    // would otherwise be a write system call of its own. The copy goes on
    // meanwhile (a machining-time estimate of the program reads it while
    // the compensation runs, not after it).
    let mut spool = io::BufWriter::with_capacity(
        64 << 10,
        CopyTo {
            inner: tempfile::SpooledTempFile::new(BODY_IN_MEMORY),
            copy: body_copy,
        },
    );
    let summary = compensate_program_seen(
        walker,
        file,
        model,
        program_style,
        options,
        &mut spool,
        on_point,
        on_line,
    )?;
    let mut body = spool
        .into_inner()
        .map_err(|e| CompensationError::from(e.into_error()))?
        .inner;
    let mut lines = header.lines();
    let end = lines.len().saturating_sub(1);
    lines.insert(
        end,
        format!("({})", comment_text(&summary.reversals_text())),
    );
    if let Some(text) = summary.path_mode_text() {
        let end = lines.len().saturating_sub(1);
        for (k, l) in wrapped_at_words("path mode:", &text)
            .into_iter()
            .enumerate()
        {
            lines.insert(end + k, l);
        }
    }
    if let Some(text) = summary.uncompensated_text() {
        // Said first and last: the header never calls such a program
        // compensated.
        lines[0] = FIRST_LINE_PARTIAL.to_string();
        let end = lines.len().saturating_sub(1);
        for (k, l) in wrapped_at_words("WARNING", &text).into_iter().enumerate() {
            lines.insert(end + k, l);
        }
    }
    // Written whole, each on a line of its own between the body's lines.
    let header_blocks = super::size::blocks_of_lines(lines.iter().map(|l| l.as_bytes()));
    let mut w = HeaderWriter::new(out, lines);
    body.seek(io::SeekFrom::Start(0))
        .map_err(CompensationError::from)?;
    io::copy(&mut body, &mut w).map_err(CompensationError::from)?;
    let (_, place) = w.finish_placed().map_err(CompensationError::from)?;
    Ok((
        CompensateSummary {
            header: place,
            ..summary
        },
        header_blocks,
    ))
}
