//! Every model file behind one function, [`load_model`].
//!
//! A map is either a CSV file of axis tables (docs/design.md, "The axis-table
//! map") or a TOML file that says what model it holds in its first keys:
//!
//! ```toml
//! model = "kinematic-21"   # the kind: one of KNOWN_KINDS
//! format_version = 1       # optional; this volcomp reads version 1
//! ```
//!
//! Straightness models written before this scheme carry the same
//! information as `kind = "straightness"` and `format_version = 1`; both
//! keys are read. A TOML file whose kind is missing or unknown is refused
//! with its row and column and the list of known kinds.

use crate::error::MapFileError;
use crate::io::model_file;
use crate::model::axis_table::{AxisTableMap, Table};
use crate::model::kinematic::{ComponentTable, KinematicModel};
use crate::model::straightness::{self, StraightnessModel};
use crate::model::ErrorModel;
use std::path::Path;
use toml::Spanned;

/// What kind of model a file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ModelKind {
    /// Axis tables (CSV, docs/design.md).
    AxisTable,
    /// The 21-component kinematic model (TOML + CSV, docs/kinematic.md).
    Kinematic21,
    /// The planar straightness model (TOML, docs/straightness.md).
    Straightness,
}

impl ModelKind {
    /// The name a file uses for the kind (`model = "<name>"`).
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::AxisTable => "axis-table",
            ModelKind::Kinematic21 => model_file::MODEL_KIND,
            ModelKind::Straightness => straightness::KIND,
        }
    }

    /// The kind a TOML file names, if known.
    pub fn from_name(name: &str) -> Option<ModelKind> {
        TOML_KINDS.into_iter().find(|k| k.name() == name)
    }
}

/// The kinds a TOML model file may name.
pub const TOML_KINDS: [ModelKind; 2] = [ModelKind::Kinematic21, ModelKind::Straightness];

/// The format version of TOML model files this library reads.
pub const FORMAT_VERSION: i64 = model_file::FORMAT_VERSION;

/// How a model is loaded.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Hold a position outside a table's range at the table's end instead
    /// of refusing it (models with tables: axis tables, 21-component,
    /// straightness).
    pub clamp: bool,
}

/// A loaded model: the concrete model for queries, or a boxed
/// [`ErrorModel`] for compensation and simulation ([`LoadedModel::into_model`]).
#[derive(Debug, Clone)]
pub enum LoadedModel {
    /// Axis tables.
    AxisTables(Box<AxisTableMap>),
    /// The 21-component kinematic model.
    Kinematic(Box<KinematicModel>),
    /// The planar straightness model.
    Straightness(Box<StraightnessModel>),
}

impl LoadedModel {
    /// The model as an [`ErrorModel`].
    pub fn model(&self) -> &dyn ErrorModel {
        match self {
            LoadedModel::AxisTables(m) => m.as_ref(),
            LoadedModel::Kinematic(m) => m.as_ref(),
            LoadedModel::Straightness(m) => m.as_ref(),
        }
    }

    /// The model, boxed.
    pub fn into_model(self) -> Box<dyn ErrorModel> {
        match self {
            LoadedModel::AxisTables(m) => m,
            LoadedModel::Kinematic(m) => m,
            LoadedModel::Straightness(m) => m,
        }
    }

    /// What kind of model it is.
    pub fn kind(&self) -> ModelKind {
        match self {
            LoadedModel::AxisTables(_) => ModelKind::AxisTable,
            LoadedModel::Kinematic(_) => ModelKind::Kinematic21,
            LoadedModel::Straightness(_) => ModelKind::Straightness,
        }
    }

    /// One named ISO 230-1 component (`"EXX"`, `"EBY"`, …, as
    /// [`crate::model::arrays::component_name`] reads it) as position (mm),
    /// forward and reverse values (µm, or µrad for angular ones); axis
    /// tables have the linear ones only.
    pub fn component_columns(&self, name: &str) -> Result<[Vec<f64>; 3], String> {
        let (axis, dir, angular) = crate::model::arrays::component_name(name)?;
        let up = name.to_ascii_uppercase();
        let col = |t: &Table| -> Vec<f64> { t.errors_um.iter().map(|e| e[dir]).collect() };
        let pick = |c: &ComponentTable| {
            col(if angular {
                &c.angular_urad
            } else {
                &c.linear_um
            })
        };
        let (f, r) = match (self, angular) {
            (LoadedModel::AxisTables(m), false) => (&m.axes[axis].forward, &m.axes[axis].reverse),
            (LoadedModel::Kinematic(m), _) => {
                let t = &m.axes[axis];
                (&t.forward.linear_um, &t.reverse.linear_um)
            }
            _ => {
                return Err(format!(
                    "{up}: a {} model has no such component table; use components()",
                    self.kind().name()
                ))
            }
        };
        if f.positions_mm != r.positions_mm {
            return Err(format!("{up}: the forward and reverse tables of axis {} have different positions; read them from components()", ['X', 'Y', 'Z'][axis]));
        }
        Ok(match self {
            LoadedModel::Kinematic(m) => {
                let t = &m.axes[axis];
                [f.positions_mm.clone(), pick(&t.forward), pick(&t.reverse)]
            }
            _ => [f.positions_mm.clone(), col(f), col(r)],
        })
    }
}

pub use crate::error::domain::LoadError;

/// Loads the model in `path`.
///
/// * `.csv`: axis tables (docs/design.md, "The axis-table map").
/// * TOML (`.toml`, or any other name whose content names a kind): the kind
///   its `model` (or, in straightness files, `kind`) key names; the tables a
///   21-component model names are read relative to the file.
///
/// A straightness model is recognised by its content whatever its name.
///
/// ```
/// use volcomp_core::io::{load_model, LoadOptions, LoadedModel};
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("m.csv");
/// std::fs::write(&path, "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
///     X,both,0,0,0,0\nX,both,10,2,0,0\nY,both,0,0,0,0\nY,both,10,0,0,0\n\
///     Z,both,0,0,0,0\nZ,both,10,0,0,0\n").unwrap();
/// let m = load_model(&path, &LoadOptions { clamp: true }).unwrap();
/// assert!(matches!(m, LoadedModel::AxisTables(ref t) if t.clamp));
/// ```
pub fn load_model(path: &Path, options: &LoadOptions) -> Result<LoadedModel, LoadError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    // A file that cannot be read is reported as such, whatever its name.
    let bytes = crate::io::inputs::read(path, "the map").map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let file = path.display().to_string();
    let text = crate::io::table::utf8(&bytes, &file)?;
    // A straightness model is taken by its content, whatever the file's name.
    let discriminator = sniff(text);
    if ext.as_deref() != Some("csv") {
        if let Some(d) = &discriminator {
            if d.kind() == Some(ModelKind::Straightness) {
                let mut m = StraightnessModel::from_toml(text, &file)?;
                m.clamp = options.clamp;
                return Ok(LoadedModel::Straightness(Box::new(m)));
            }
        }
    }
    match ext.as_deref() {
        Some("csv") => load_axis_tables(text, &file, options),
        Some("toml") => load_toml(path, text, &file, discriminator.as_ref(), options),
        _ if discriminator.as_ref().is_some_and(|d| d.names_a_kind()) => {
            load_toml(path, text, &file, discriminator.as_ref(), options)
        }
        _ => Err(LoadError::UnknownFormat {
            path: path.to_path_buf(),
        }),
    }
}

fn load_axis_tables(
    text: &str,
    file: &str,
    options: &LoadOptions,
) -> Result<LoadedModel, LoadError> {
    let mut map = AxisTableMap::from_csv(text, file).map_err(|e| {
        let header = text
            .lines()
            .find(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        if header.is_some_and(|h| h.contains("ea_") || h.contains("eb_") || h.contains("ec_")) {
            LoadError::ComponentTable { source: e }
        } else {
            LoadError::File(e)
        }
    })?;
    map.clamp = options.clamp;
    Ok(LoadedModel::AxisTables(Box::new(map)))
}

fn load_toml(
    path: &Path,
    text: &str,
    file: &str,
    discriminator: Option<&Discriminator>,
    options: &LoadOptions,
) -> Result<LoadedModel, LoadError> {
    // A file that is not TOML at all: the 21-component reader reports the
    // syntax error where the parser found it.
    if let Some(d) = discriminator {
        d.check(text, file)?;
    }
    let mut m = model_file::model_from_text(path, text)?;
    m.clamp = options.clamp;
    Ok(LoadedModel::Kinematic(Box::new(m)))
}

/// The keys of a TOML file that say what it is.
#[derive(serde::Deserialize)]
struct Discriminator {
    model: Option<Spanned<String>>,
    kind: Option<Spanned<String>>,
}

impl Discriminator {
    /// The named kind, if it is known.
    fn kind(&self) -> Option<ModelKind> {
        self.model
            .as_ref()
            .or(self.kind.as_ref())
            .and_then(|k| ModelKind::from_name(k.get_ref()))
    }

    fn names_a_kind(&self) -> bool {
        self.model.is_some() || self.kind.is_some()
    }

    /// A located error unless the file names a known kind.
    fn check(&self, text: &str, file: &str) -> Result<(), MapFileError> {
        let known = TOML_KINDS
            .iter()
            .map(|k| format!("\"{}\"", k.name()))
            .collect::<Vec<_>>()
            .join(", ");
        match self.model.as_ref().or(self.kind.as_ref()) {
            None => Err(MapFileError::new(
                file,
                1,
                1,
                "the file does not say what model it is",
                format!(
                    "start the file with model = \"<kind>\"; the known kinds are {known} (docs/kinematic.md, docs/straightness.md)"
                ),
            )),
            Some(k) if ModelKind::from_name(k.get_ref()).is_none() => {
                let at = k.span().start.min(text.len());
                let (row, column) = model_file::row_col(text, at);
                let line_start = text[..at].rfind('\n').map_or(0, |i| i + 1);
                let line = text[line_start..].lines().next().unwrap_or("");
                Err(MapFileError::new(
                    file,
                    row,
                    column,
                    format!("`{}` is not a kind of model this volcomp knows", k.get_ref()),
                    format!("the known kinds are {known}"),
                )
                .with_source(line, at - line_start))
            }
            Some(_) => Ok(()),
        }
    }
}

/// The discriminating keys of `text`, or `None` when it is not TOML.
fn sniff(text: &str) -> Option<Discriminator> {
    toml::from_str::<Discriminator>(text).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::model_file::ModelFileError;
    use std::path::PathBuf;

    const TABLES: &str = "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
        X,both,0,0,0,0\nX,both,10,2,0,0\nY,both,0,0,0,0\nY,both,10,0,0,0\n\
        Z,both,0,0,0,0\nZ,both,10,0,0,0\n";

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn csv_is_axis_tables_and_carries_clamp() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "m.csv", TABLES);
        let m = load_model(&p, &LoadOptions { clamp: false }).unwrap();
        assert_eq!(m.kind(), ModelKind::AxisTable);
        // X table: 2 µm at 10 mm, so 1 µm half way.
        let e = m
            .model()
            .deviation_um(
                volcomp_gcode::Vec3::new(5.0, 0.0, 0.0),
                crate::model::ALL_FORWARD,
                crate::model::Components::All,
            )
            .unwrap();
        assert_eq!(e.x, 1.0);
        // Outside the range: refused without clamp, held with it.
        let far = volcomp_gcode::Vec3::new(20.0, 0.0, 0.0);
        let all = crate::model::Components::All;
        assert!(m
            .model()
            .deviation_um(far, crate::model::ALL_FORWARD, all)
            .is_err());
        let c = load_model(&p, &LoadOptions { clamp: true }).unwrap();
        assert_eq!(
            c.model()
                .deviation_um(far, crate::model::ALL_FORWARD, all)
                .unwrap()
                .x,
            2.0
        );
    }

    /// The located error of loading a model file `m.toml` holding `text`.
    fn refused(text: &str) -> crate::error::MapFileError {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "m.toml", text);
        match load_model(&p, &LoadOptions::default()).unwrap_err() {
            LoadError::File(f) => f,
            e => panic!("{e}"),
        }
    }

    #[test]
    fn missing_kind_is_located_and_lists_the_kinds() {
        let f = refused("chain = \"w X' Y' b Z t\"\n");
        assert_eq!((f.row, f.column), (1, 1));
        assert!(f.help.contains("\"kinematic-21\", \"straightness\""), "{f}");
    }

    #[test]
    fn unknown_kind_is_located_at_its_value() {
        let f = refused("# a model\nmodel = \"thermal-9\"\n");
        // Row 2, column 9: the opening quote of the value.
        assert_eq!((f.row, f.column), (2, 9));
        assert!(f.message.contains("thermal-9"));
        assert!(f.help.contains("\"kinematic-21\", \"straightness\""));
    }

    #[test]
    fn unsupported_format_version_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "m.toml",
            "model = \"kinematic-21\"\nformat_version = 2\n",
        );
        let e = load_model(&p, &LoadOptions::default()).unwrap_err();
        let LoadError::Kinematic(ModelFileError::Format(f)) = &e else {
            panic!("{e}")
        };
        assert_eq!((f.row, f.column), (2, 18));
        assert!(f.message.contains("format_version 2"));
    }

    #[test]
    fn kinematic_model_with_format_version_one_loads() {
        let dir = tempfile::tempdir().unwrap();
        let (toml, csv) = crate::example::kinematic::example_files("k.csv");
        write(dir.path(), "k.csv", &csv);
        let toml = toml.replacen(
            "model = \"kinematic-21\"\n",
            "model = \"kinematic-21\"\nformat_version = 1\n",
            1,
        );
        let p = write(dir.path(), "k.toml", &toml);
        let m = load_model(&p, &LoadOptions { clamp: true }).unwrap();
        let LoadedModel::Kinematic(k) = &m else {
            panic!("not kinematic")
        };
        assert!(k.clamp);
    }

    #[test]
    fn component_table_as_a_map_gets_a_note() {
        let dir = tempfile::tempdir().unwrap();
        let (_, csv) = crate::example::kinematic::example_files("k.csv");
        let p = write(dir.path(), "k.csv", &csv);
        let e = load_model(&p, &LoadOptions::default()).unwrap_err();
        assert!(matches!(e, LoadError::ComponentTable { .. }));
        assert!(e
            .to_string()
            .contains("note: this looks like the component table"));
    }

    #[test]
    fn other_extension_without_kind_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "m.txt", TABLES);
        let e = load_model(&p, &LoadOptions::default()).unwrap_err();
        assert!(matches!(e, LoadError::UnknownFormat { .. }));
        assert!(e.to_string().contains("choose the map format by extension"));
    }

    #[test]
    fn missing_file_names_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("none.csv");
        let e = load_model(&p, &LoadOptions::default()).unwrap_err();
        assert!(e.to_string().starts_with(&p.display().to_string()));
    }
}
