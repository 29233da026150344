//! The front door of compensation: a machine set-up ([`MachineSetup`]) and
//! a builder ([`Compensator`]) that reads a program, refuses one volcomp
//! compensated already, surveys its number style, interprets it and writes
//! it compensated, with the provenance header on top.
//!
//! ```
//! use volcomp_core::{AxisTableMap, CompensateOptions, Compensator, MachineSetup, Segmentation};
//! # fn main() -> Result<(), volcomp_core::Error> {
//! // A machine without error: the program comes back unchanged.
//! let map = AxisTableMap::from_csv(
//!     "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
//!      X,both,0,0,0,0\nX,both,100,0,0,0\nY,both,0,0,0,0\n\
//!      Y,both,100,0,0,0\nZ,both,0,0,0,0\nZ,both,100,0,0,0\n",
//!     "zero.csv",
//! )?;
//! let program = "G21 G90\nG0 X10 Y10 Z10\nG1 X20 F100\n";
//! let mut out = Vec::new();
//! let summary = Compensator::new(&map)
//!     .setup(MachineSetup::default())
//!     .options(CompensateOptions { segmentation: Segmentation::Off, ..Default::default() })
//!     .run(program.as_bytes(), &mut out)?;
//! assert_eq!(summary.lines_in, 3);
//! assert_eq!(String::from_utf8(out).unwrap(), program);
//! # Ok(())
//! # }
//! ```

use super::header::compensate_program_with_header_counted;
use super::{
    compensate_program_seen, survey_style, CompensateOptions, CompensateSummary, PointRecord,
};
use crate::error::{CompensatedEvidence, Error};
use crate::io::provenance::{find_compensation, Compensated};
use crate::io::provenance::{sha256_hex, ProgramHeader};
use crate::model::ErrorModel;
use std::io::{BufReader, Read, Write};
use std::path::Path;
use volcomp_gcode::{Setup, Warning};

/// How many bytes of a program are read first: for its number style and for
/// signs of an earlier compensation.
pub const HEAD_BYTES: u64 = 1 << 16;

pub use crate::model::setup::MachineSetup;

/// Refuses a program whose first bytes (`head`) show an earlier compensation
/// by volcomp: compensating it again would apply every correction twice.
pub fn refuse_if_compensated(head: &[u8], file: &str) -> Result<(), Error> {
    let (line, evidence) = match find_compensation(head) {
        Some(Compensated::Header(line)) => (line, CompensatedEvidence::Header),
        Some(Compensated::Trace(line)) => (line, CompensatedEvidence::Trace),
        None => return Ok(()),
    };
    Err(Error::AlreadyCompensated {
        file: file.to_string(),
        line,
        evidence,
    })
}

/// The header of a program compensated with the map file `map` (and the
/// tables it names, each hashed with SHA-256), the set-up file's name and
/// the set-up used, dated `date_utc` (ISO 8601).
pub fn header_for_map(
    map: &Path,
    setup_file: Option<&Path>,
    setup: &Setup,
    options: &CompensateOptions,
    date_utc: String,
) -> Result<ProgramHeader, Error> {
    let mut maps = Vec::new();
    for p in std::iter::once(map.to_path_buf()).chain(crate::io::output::referenced_files(map)) {
        let bytes = crate::io::inputs::read(&p, "the map").map_err(|e| Error::io(&p, e))?;
        maps.push((file_name(&p), sha256_hex(&bytes)));
    }
    Ok(ProgramHeader::for_compensation(
        maps,
        setup_file.map(file_name),
        setup.clone(),
        options,
        date_utc,
    ))
}

pub use crate::io::file_name;

/// A caller's function called on each item as it is produced.
type Callback<'a, T> = Box<dyn FnMut(&T) + 'a>;

/// Compensates a program for a machine's errors (see the [module
/// doc](self) for an example).
///
/// Defaults: [`MachineSetup::default`], [`CompensateOptions::default`], no
/// header, the program named `<program>` in messages, a program compensated
/// already is refused.
pub struct Compensator<'a> {
    model: &'a dyn ErrorModel,
    setup: MachineSetup,
    options: CompensateOptions,
    header: Option<ProgramHeader>,
    file: String,
    allow_recompensate: bool,
    on_point: Option<Callback<'a, PointRecord>>,
    on_warning: Option<Callback<'a, Warning>>,
    program_copy: Option<&'a mut dyn Write>,
    on_line: Option<&'a mut dyn FnMut(&volcomp_gcode::LineEvent<'_>)>,
}

impl<'a> Compensator<'a> {
    /// A compensation of programs for `model`'s errors.
    pub fn new(model: &'a dyn ErrorModel) -> Self {
        Self {
            model,
            setup: MachineSetup::default(),
            options: CompensateOptions::default(),
            header: None,
            file: "<program>".into(),
            allow_recompensate: false,
            on_point: None,
            on_warning: None,
            program_copy: None,
            on_line: None,
        }
    }

    /// The machine the program runs on.
    pub fn setup(mut self, setup: impl Into<MachineSetup>) -> Self {
        self.setup = setup.into();
        self
    }

    /// How to compensate.
    pub fn options(mut self, options: CompensateOptions) -> Self {
        self.options = options;
        self
    }

    /// The provenance header written at the top of the output.
    pub fn header(mut self, header: ProgramHeader) -> Self {
        self.header = Some(header);
        self
    }

    /// The program's name in messages (a file name, `<standard input>`).
    pub fn file_name(mut self, name: impl Into<String>) -> Self {
        self.file = name.into();
        self
    }

    /// Compensate even a program volcomp compensated already.
    pub fn allow_recompensate(mut self, allow: bool) -> Self {
        self.allow_recompensate = allow;
        self
    }

    /// Called with every compensated target point, in order.
    pub fn on_point(mut self, f: impl FnMut(&PointRecord) + 'a) -> Self {
        self.on_point = Some(Box::new(f));
        self
    }

    /// Called, once the run ends (also when it fails), with what the
    /// interpreter assumed (no units, no reference point, …).
    pub fn on_warning(mut self, f: impl FnMut(&Warning) + 'a) -> Self {
        self.on_warning = Some(Box::new(f));
        self
    }

    /// Also writes the compensated program to `copy` as it is made, without
    /// the provenance header (comment lines, written at the top of the
    /// output once the program is done: the body waits for it). What the
    /// copy gets times and runs as the output does: a machining-time
    /// estimate can read it while the compensation goes on.
    pub fn copy_program_to(mut self, copy: &'a mut dyn Write) -> Self {
        self.program_copy = Some(copy);
        self
    }

    /// Called with every line of the program as it is read (with its
    /// lexed words, its motions and the interpreter after it), before it
    /// is written: a machining-time estimate of the program can plan its
    /// moves without reading it again
    /// ([`crate::plan::compare_while_writing_fed`]).
    pub fn on_line(mut self, f: &'a mut dyn FnMut(&volcomp_gcode::LineEvent<'_>)) -> Self {
        self.on_line = Some(f);
        self
    }

    /// Reads `program`, writes it compensated to `out`, and says what it did.
    /// Nothing is written past an error; the caller discards a partial
    /// output (see [`crate::io::output`] for outputs written completely or
    /// not at all).
    pub fn run<R: Read, W: Write>(
        mut self,
        mut program: R,
        mut out: W,
    ) -> Result<CompensateSummary, Error> {
        let mut head = Vec::with_capacity(HEAD_BYTES as usize);
        (&mut program)
            .take(HEAD_BYTES)
            .read_to_end(&mut head)
            .map_err(|e| Error::io(&self.file, e))?;
        if !self.allow_recompensate {
            refuse_if_compensated(&head, &self.file)?;
        }
        let style = survey_style(&head);
        let reader = BufReader::with_capacity(
            HEAD_BYTES as usize,
            std::io::Cursor::new(head).chain(program),
        );
        // Computed values (`F[1/3]`) are written with the
        // decimals of the compensated words, not 17 digits.
        let decimals = |default: u8| {
            self.options
                .decimals
                .unwrap_or(default.max(style.survey.max_decimals()))
        };
        self.setup.interp.computed_decimals = Some([
            decimals(super::DEFAULT_DECIMALS_MM),
            decimals(super::DEFAULT_DECIMALS_INCH),
        ]);
        let mut walker = self.setup.walker(reader, &self.file);
        let mut no_op = |_: &PointRecord| {};
        let on_point: &mut dyn FnMut(&PointRecord) = match self.on_point.as_mut() {
            Some(f) => f.as_mut(),
            None => &mut no_op,
        };
        // The whole output's bytes are counted here, the header included.
        let mut out = super::size::Counted::new(&mut out);
        let mut no_line = |_: &volcomp_gcode::LineEvent<'_>| {};
        let on_line: &mut dyn FnMut(&volcomp_gcode::LineEvent<'_>) = match self.on_line.take() {
            Some(f) => f,
            None => &mut no_line,
        };
        let result = match (&self.header, self.program_copy.take()) {
            (Some(h), copy) => compensate_program_with_header_counted(
                &mut walker,
                &self.file,
                self.model,
                &style,
                &self.options,
                h,
                &mut out,
                copy,
                on_point,
                on_line,
            )
            .map(|(mut summary, header_blocks)| {
                summary.blocks_out += header_blocks;
                summary
            }),
            (None, copy) => {
                let mut out = crate::io::stream::Tee {
                    inner: &mut out,
                    copy: None,
                    stream: copy,
                };
                compensate_program_seen(
                    &mut walker,
                    &self.file,
                    self.model,
                    &style,
                    &self.options,
                    &mut out,
                    on_point,
                    on_line,
                )
            }
        };
        // The summary's blocks are the body's (counted as it was written)
        // and, with a header, the header's (added by the header's writer).
        let result = result.map(|mut summary| {
            summary.bytes_out = out.bytes();
            summary
        });
        if let Some(f) = self.on_warning.as_mut() {
            walker.warnings().iter().for_each(f);
        }
        Ok(result?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::axis_table::AxisTableMap;

    fn zero_map() -> AxisTableMap {
        let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
        for a in ["X", "Y", "Z"] {
            csv.push_str(&format!("{a},both,0,0,0,0\n{a},both,100,0,0,0\n"));
        }
        AxisTableMap::from_csv(&csv, "zero.csv").unwrap()
    }

    #[test]
    fn a_compensated_program_is_refused_unless_allowed() {
        let map = zero_map();
        let program = "G0 X1 Y1 Z1\nG1 X2 F100 (volcomp L2)\n";
        let e = Compensator::new(&map)
            .file_name("p.ngc")
            .run(program.as_bytes(), Vec::new())
            .unwrap_err();
        assert_eq!(e.kind(), crate::error::ErrorKind::RefusedProgram);
        assert!(e
            .to_string()
            .starts_with("p.ngc:2: this program was compensated"));
        let ok = Compensator::new(&map)
            .allow_recompensate(true)
            .run(program.as_bytes(), Vec::new());
        assert!(ok.is_ok(), "{ok:?}");
    }

    /// The summary's size is the whole output's, the header included: its
    /// bytes, and its blocks as a scan of the written text counts them
    /// ([`super::super::size::Blocks`] over all of it, the second method)
    /// and, for the simple programs, by hand (the header is comments only).
    /// Programs with and without a header, a `%` or a program number
    /// before it, comments, a `;` line, blank lines, a last line without
    /// its ending, CR LF endings.
    #[test]
    fn the_summary_counts_what_was_written() {
        let map = zero_map();
        let programs: [(&str, u64); 5] = [
            ("%\nG0 X1 Y1 Z1\n(c)\nG1 X2 F100\nM2\n%\n", 3),
            ("G0 X1 Y1 Z1\n\nG1 X2 F100 (a)\n; note\nM2", 3),
            ("O0001\n  \nG0 X1 ( a ) Y2 Z3\n(only)\nM30\n", 3),
            ("\r\n%\r\nG0 X1 Y0 Z0\r\n(b) G1 X3 F200\r\nM2\r\n%\r\n", 3),
            (
                "(just a comment)\nG0 X1 Y1 Z1\nG1 X5 Y2 F500\nG1 X0 Y0\nM2\n",
                4,
            ),
        ];
        for (program, by_hand) in programs {
            for with_header in [false, true] {
                let mut c = Compensator::new(&map);
                if with_header {
                    c = c.header(crate::io::provenance::ProgramHeader::for_compensation(
                        vec![("zero.csv".into(), sha256_hex(b"zero"))],
                        None,
                        Setup::default(),
                        &CompensateOptions::default(),
                        "2026-01-01T00:00:00Z".into(),
                    ));
                }
                let mut out = Vec::new();
                let summary = c.run(program.as_bytes(), &mut out).unwrap();
                let mut scanned = super::super::size::Blocks::default();
                scanned.scan(&out);
                let text = String::from_utf8_lossy(&out);
                assert_eq!(summary.bytes_out, out.len() as u64, "{text}");
                assert_eq!(summary.blocks_out, scanned.finish(), "{text}");
                assert_eq!(summary.blocks_out, by_hand, "{text}");
                assert_eq!(text.lines().count() > 12, with_header, "{text}");
            }
        }
    }

    #[test]
    fn the_program_copy_is_the_output_without_its_header_and_times_as_it() {
        // A map with slopes (every point corrected), a `%` program with
        // corners, arcs and path modes: the header goes after the `%`.
        let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
        for a in ["X", "Y", "Z"] {
            csv.push_str(&format!("{a},both,-100,0,0,0\n{a},both,200,9,-6,3\n"));
        }
        let map = AxisTableMap::from_csv(&csv, "slope.csv").unwrap();
        let mut program = String::from("%\n(a part)\nG21 G90 G17 G64\nG0 X0 Y0 Z1\nG1 Z0 F300\n");
        for i in 0..40 {
            let y = i as f64 * 0.5;
            program += &format!("G1 X{} Y{y} F{}\n", [0, 60][i % 2], [1200, 3000][i % 2]);
            program += &format!("G3 X{} Y{} R0.25\n", [0, 60][i % 2], y + 0.5);
        }
        program += "G61\nG1 X10 Y10\nG2 X20 Y10 I5 J0\nM2\n%\n";
        let header = crate::io::provenance::ProgramHeader::for_compensation(
            vec![("slope.csv".into(), sha256_hex(csv.as_bytes()))],
            None,
            Setup::default(),
            &CompensateOptions::default(),
            "2026-01-01T00:00:00Z".into(),
        );
        let mut copy = Vec::new();
        let mut out = Vec::new();
        let summary = Compensator::new(&map)
            .header(header)
            .copy_program_to(&mut copy)
            .run(program.as_bytes(), &mut out)
            .unwrap();
        let (out, copy) = (
            String::from_utf8(out).unwrap(),
            String::from_utf8(copy).unwrap(),
        );
        // The output's lines are the copy's with the header's comment
        // lines after the first (`%`).
        let (out_lines, copy_lines): (Vec<_>, Vec<_>) =
            (out.lines().collect(), copy.lines().collect());
        let header_len = out_lines.len() - copy_lines.len();
        assert!(header_len > 5, "{out}");
        assert_eq!(out_lines[0], "%");
        assert_eq!(copy_lines[0], "%");
        assert!(out_lines[1..=header_len]
            .iter()
            .all(|l| l.starts_with('(') && l.ends_with(')')));
        assert_eq!(out_lines[header_len + 1..], copy_lines[1..]);
        // The summary says where the header went: after the `%`, as long
        // as counted here; each line of the copy is at its written line.
        assert_eq!(
            summary.header,
            crate::io::provenance::HeaderPlace {
                body_lines_before: 1,
                lines: header_len as u64
            }
        );
        for (k, l) in copy_lines.iter().enumerate() {
            let at = summary.header.written_line(k as u64 + 1) as usize;
            assert_eq!(out_lines[at - 1], *l, "copy line {}", k + 1);
        }
        // Timed as the output itself.
        let setup = MachineSetup::default();
        let limits = crate::plan::Limits::default();
        let timed = |p: &str| {
            crate::plan::estimate_program(p.as_bytes(), "p.ngc", &setup, &limits).unwrap()
        };
        let (of_out, of_copy) = (timed(&out), timed(&copy));
        assert!(of_out.motion.periods > 1000, "{of_out:?}");
        assert_eq!(of_copy, of_out);
    }

    #[test]
    fn an_error_in_the_copy_is_located_at_its_line_in_the_written_file() {
        // The compensation reads the probing move (the set-up accepts it);
        // an estimate of the copy with the default set-up refuses it. The
        // written program has the header after its `%`: the error names the
        // line of the written file that holds the G38.2, counted here.
        let map = AxisTableMap::from_csv(
            "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
             X,both,0,0,0,0\nX,both,100,2,0,0\nY,both,0,0,0,0\n\
             Y,both,100,0,0,0\nZ,both,0,0,0,0\nZ,both,100,0,0,0\n",
            "x.csv",
        )
        .unwrap();
        let program = "%\nG21 G90\nG0 X10 Y10 Z10\nG1 X20 F100\nG38.2 Z5 F50\nM2\n%\n";
        let header = crate::io::provenance::ProgramHeader::for_compensation(
            vec![("x.csv".into(), sha256_hex(b"x"))],
            None,
            Setup::default(),
            &CompensateOptions::default(),
            "2026-01-01T00:00:00Z".into(),
        );
        let probing = MachineSetup {
            interp: volcomp_gcode::InterpOptions {
                accept_probing: true,
                ..Default::default()
            },
            ..MachineSetup::default()
        };
        let (mut copy, mut out) = (Vec::new(), Vec::new());
        let summary = Compensator::new(&map)
            .setup(probing)
            .header(header)
            .copy_program_to(&mut copy)
            .run(program.as_bytes(), &mut out)
            .unwrap();
        let out = String::from_utf8(out).unwrap();
        let probe_line = 1 + out.lines().position(|l| l.starts_with("G38.2")).unwrap() as u64;
        assert!(probe_line > 10, "{out}");
        let limits = crate::plan::Limits::default();
        let e =
            crate::plan::estimate_program(&copy[..], "o.ngc", &MachineSetup::default(), &limits)
                .unwrap_err();
        let Error::Gcode(g) = &e else { panic!("{e}") };
        // In the copy the G38.2 is line 5, as in the program.
        assert_eq!(g.diagnostic.line, 5, "{e}");
        let located = summary.header.locate_in_written(e);
        let Error::Gcode(g) = &located else {
            panic!("{located}")
        };
        assert_eq!(g.diagnostic.line, probe_line, "{located}\n{out}");
        assert!(
            located
                .to_string()
                .starts_with(&format!("o.ngc:{probe_line}:")),
            "{located}"
        );
    }

    #[test]
    fn points_and_warnings_reach_the_callbacks() {
        // Adaptive segmentation on a zero map (affine, no table point
        // crossed): the feed move is one target, plus the rapid's end.
        let map = zero_map();
        let (mut points, mut warnings) = (0, 0);
        let summary = Compensator::new(&map)
            .on_point(|_| points += 1)
            .on_warning(|_| warnings += 1)
            .run("G0 X1 Y1 Z1\nG1 X4 F100\n".as_bytes(), Vec::new())
            .unwrap();
        assert_eq!(points, 2);
        assert_eq!(summary.points, 2);
        // No G20/G21: the interpreter says it assumed mm.
        assert!(warnings >= 1);
    }
}
