//! File formats: the readers and writers of every file volcomp takes or
//! writes live here (the G-code program itself is read by `volcomp-gcode`).
//!
//! * [`load_model`]: every model file (axis tables, 21-component, straightness) behind one function.
//! * [`controllers`]: controller compensation tables (Siemens, LinuxCNC, Klipper, Marlin …), written and read.
//! * [`exchange`]: ISO 230-1 parameter files (ISG CSV, Etalon exchange format) read into the 21-component model.
//! * [`grid`]: the 3-D grid CSV of a model.
//! * [`table`]: the one located CSV reader every table file goes through.
//! * [`located`]: where a value of a TOML file is, for errors at it.
//! * [`model_file`]: model files (TOML + CSV tables of the 21-component model).
//! * [`linuxcnc_comp`]: LinuxCNC's screw-compensation files, read and written.
//! * [`provenance`]: the header volcomp writes at the top of a compensated program.
//! * [`numfmt`]: how computed numbers are written.
//! * [`probe_log`]: what a machine recorded while probing (LinuxCNC `(LOG,…)` files, CSV points).
//! * [`output`]: safe output (plans checked before work, atomic files).

pub mod controllers;
pub mod exchange;
pub mod grid;
pub mod linuxcnc_comp;
pub mod load;

pub mod model_file;
pub mod output;
pub mod probe_log;
pub mod provenance;
pub mod stream;

pub use crate::text::{located, numfmt, table};
pub use load::{load_model, LoadError, LoadOptions, LoadedModel, ModelKind};
pub use volcomp_geom::inputs;

/// A path's last component, for messages and headers.
pub fn file_name(p: &std::path::Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}

/// A name a user gave (a file name), as printed in messages: control
/// characters escaped (`\x1b`), so that it cannot drive the terminal.
pub fn shown_name(name: &str) -> String {
    volcomp_gcode::error::escape_name(name).into_owned()
}

/// A file of a table format could not be read: the system refused it, or
/// its content is malformed (located). The controller files' and the comp
/// files' readers both give it.
#[derive(Debug, thiserror::Error)]
pub enum FileReadError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The content is malformed (located).
    #[error(transparent)]
    Format(#[from] crate::error::MapFileError),
}

/// The file `path` read whole as UTF-8 text (a byte that is not UTF-8 is
/// refused at its line and column), recorded as read in its `role` ("the
/// controller file") for the output plan.
pub(crate) fn read_text(path: &std::path::Path, role: &str) -> Result<String, FileReadError> {
    let bytes = inputs::read(path, role).map_err(|source| FileReadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let file = path.display().to_string();
    Ok(table::utf8(&bytes, &file)?.to_string())
}

/// `text` read as a finite number (`None` for anything else, `inf` and
/// `NaN` too).
pub(crate) fn finite(text: &str) -> Option<f64> {
    text.parse().ok().filter(|v: &f64| v.is_finite())
}

/// A path as printed in messages ([`shown_name`]).
pub fn shown_path(path: &std::path::Path) -> String {
    shown_name(&path.display().to_string())
}
