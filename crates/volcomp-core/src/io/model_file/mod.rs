//! Files of the 21-component model: a TOML description and CSV component
//! tables (format documented in `docs/kinematic.md`).
//!
//! ```toml
//! model = "kinematic-21"             # required: what this file is
//! chain = "w X' Y' b Z t"            # required: workpiece → tool
//! tables = "machine.csv"             # required: one file or a list, relative to this one
//! angles = "relative"                # or "moving-part" (default relative)
//! measuring_point_mm = [0, 0, 0]     # axis positions of the measuring lines
//! measuring_tool_length_mm = 0       # tool length offset of the reflector
//! [squareness_urad]                  # required, all three
//! xy = 0.0                           # Y moves along (S_xy, 1, 0)
//! yz = 0.0                           # Z moves along (S_zx, S_yz, 1)
//! zx = 0.0
//! [measuring.X]                      # optional: where X alone was measured
//! point_mm = [0, 150, 200]
//! tool_length_mm = 100
//! ```
//!
//! The CSV extends the axis-table layout of docs/design.md by three angle columns:
//!
//! ```text
//! axis,direction,position_mm,ex_um,ey_um,ez_um,ea_urad,eb_urad,ec_urad
//! X,forward,0,0.00,0.00,0.00,0.0,0.0,0.0
//! ```
//!
//! For the rows of axis X, `ex_um` is EXX, `ey_um` EYX, `ez_um` EZX, `ea_urad`
//! EAX, `eb_urad` EBX, `ec_urad` ECX; likewise for Y and Z. Angles may be
//! given in arc seconds instead (`ea_arcsec` …). Every bad value is reported
//! with file, row and column.

use crate::error::MapFileError;
use crate::io::numfmt;
use crate::model::axis_table::Table;
use crate::model::kinematic::{
    AngleConvention, AxisComponents, ComponentTable, KinematicModel, Kinematics, MeasuringLine,
    Squareness,
};
use crate::model::positioning::Positioning;
use crate::model::topology::Topology;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use toml::Spanned;
use volcomp_gcode::Vec3;
use volcomp_geom::Axis;

/// The `model` value that identifies a 21-component model file.
pub use crate::error::domain::MODEL_KIND;

/// The `format_version` of model files this library reads (optional in the file).
pub const FORMAT_VERSION: i64 = 1;

/// Micro-radians per arc second.
pub const URAD_PER_ARCSEC: f64 = std::f64::consts::PI / (180.0 * 3600.0) * 1e6;

const AXES: [char; 3] = ['X', 'Y', 'Z'];

pub use crate::error::domain::ModelFileError;

fn map_err(file: &str, row: usize, column: usize, message: String, help: &str) -> MapFileError {
    MapFileError::new(file, row, column, message, help)
}

mod tables;
pub use tables::{components_from_csv, components_to_csv, TableRows, CSV_HEADER};

// ---------------------------------------------------------------------------
// TOML description

#[derive(serde::Deserialize)]
#[serde(untagged)]
enum RawTables {
    One(String),
    Many(Vec<String>),
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSquareness {
    xy: Option<Spanned<f64>>,
    yz: Option<Spanned<f64>>,
    zx: Option<Spanned<f64>>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLine {
    point_mm: Option<Spanned<Vec<f64>>>,
    tool_length_mm: Option<Spanned<f64>>,
    tool_offset_mm: Option<Spanned<Vec<f64>>>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawModel {
    model: Option<Spanned<String>>,
    format_version: Option<Spanned<i64>>,
    description: Option<String>,
    chain: Option<Spanned<String>>,
    tables: Option<Spanned<RawTables>>,
    angles: Option<Spanned<String>>,
    measuring_point_mm: Option<Spanned<Vec<f64>>>,
    measuring_tool_length_mm: Option<Spanned<f64>>,
    measuring_tool_offset_mm: Option<Spanned<Vec<f64>>>,
    squareness_urad: Option<Spanned<RawSquareness>>,
    measuring: Option<BTreeMap<Spanned<String>, Spanned<RawLine>>>,
}

/// 1-based (row, column) of byte `offset` in `text`.
pub(crate) fn row_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let row = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map(|i| i + 1).unwrap_or(0);
    (row, before[line_start..].chars().count() + 1)
}

/// What a TOML model file says, before its tables are read.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelHeader {
    /// Free text.
    pub description: Option<String>,
    /// Kinematics (chain, measuring lines, squareness, angle convention).
    pub kinematics: Kinematics,
    /// Table files as written, with the (row, column) where each is named.
    pub tables: Vec<(String, usize, usize)>,
}

/// Parses the TOML description; `file` names it in errors.
pub fn parse_header(text: &str, file: &str) -> Result<ModelHeader, MapFileError> {
    let at = |offset: usize, message: String, help: &str| {
        let (row, column) = row_col(text, offset);
        map_err(file, row, column, message, help)
    };
    let raw: RawModel = toml::from_str(text).map_err(|e| {
        let offset = e.span().map(|s| s.start).unwrap_or(0);
        let message = e.message().trim().to_string();
        let help = if message.contains("unknown field") {
            "keys carry their unit (measuring_point_mm, squareness_urad …); see docs/kinematic.md for the keys of a model file"
        } else {
            "see docs/kinematic.md for the format of a model file"
        };
        at(offset, message, help)
    })?;
    match &raw.model {
        Some(m) if m.get_ref() == MODEL_KIND => {}
        Some(m) => {
            return Err(at(
                m.span().start,
                format!("`model = \"{}\"` is not a 21-component model", m.get_ref()),
                &format!("a 21-component model file says model = \"{MODEL_KIND}\""),
            ))
        }
        None => {
            return Err(at(
                0,
                "the file does not say what model it is".into(),
                &format!("start the file with model = \"{MODEL_KIND}\""),
            ))
        }
    }
    if let Some(v) = &raw.format_version {
        if *v.get_ref() != FORMAT_VERSION {
            return Err(at(
                v.span().start,
                format!(
                    "format_version {} is not supported (this volcomp reads {FORMAT_VERSION})",
                    v.get_ref()
                ),
                "write the file again with this volcomp, or leave format_version out",
            ));
        }
    }
    let Some(chain) = &raw.chain else {
        return Err(at(0, "the model has no `chain`".into(), "name the kinematic chain from workpiece to tool, e.g. chain = \"w X' Y' b Z t\" (table on X, X on Y, spindle on Z)"));
    };
    let topology = Topology::parse(chain.get_ref()).map_err(|e| {
        // Point at the character inside the string (after the opening quote).
        let start = chain.span().start + 1;
        let offset = text[start..]
            .char_indices()
            .nth(e.column.saturating_sub(1))
            .map(|(i, _)| start + i)
            .unwrap_or(start);
        at(offset, format!("chain: {}", e.message), &e.help)
    })?;
    let angles = match raw.angles.as_ref().map(|a| (a.get_ref().as_str(), a.span().start)) {
        None | Some(("relative", _)) => AngleConvention::Relative,
        Some(("moving-part", _)) => AngleConvention::MovingPart,
        Some((other, offset)) => {
            return Err(at(
                offset,
                format!("unknown angle convention `{other}`"),
                "write angles = \"relative\" (tool relative to workpiece) or \"moving-part\" (as measured on the moving carriage)",
            ))
        }
    };
    let sq_help = "give all three squareness errors in µrad: [squareness_urad] xy = …, yz = …, zx = … (Y moves along (xy, 1, 0), Z along (zx, yz, 1)); write 0 for a square machine";
    let Some(sq) = &raw.squareness_urad else {
        return Err(at(
            text.len(),
            "the model has no squareness errors (`[squareness_urad]` is missing)".into(),
            sq_help,
        ));
    };
    let sq_start = sq.span().start;
    let sq = sq.get_ref();
    let get = |v: &Option<Spanned<f64>>, name: &str| -> Result<f64, MapFileError> {
        match v {
            Some(x) if x.get_ref().is_finite() => Ok(*x.get_ref()),
            Some(x) => Err(at(
                x.span().start,
                format!("squareness {name} is not a finite number"),
                sq_help,
            )),
            None => Err(at(
                sq_start,
                format!("squareness `{name}` is missing"),
                sq_help,
            )),
        }
    };
    let squareness = Squareness {
        xy_urad: get(&sq.xy, "xy")?,
        yz_urad: get(&sq.yz, "yz")?,
        zx_urad: get(&sq.zx, "zx")?,
    };
    let finite3 = |v: &Spanned<Vec<f64>>, what: &str| -> Result<Vec3, MapFileError> {
        let values = v.get_ref();
        if values.len() != 3 {
            Err(at(
                v.span().start,
                format!("{what} has {} values", values.len()),
                "write three numbers in mm: [x, y, z]",
            ))
        } else if values.iter().all(|x| x.is_finite()) {
            Ok(Vec3::new(values[0], values[1], values[2]))
        } else {
            Err(at(
                v.span().start,
                format!("{what} has a value that is not a finite number"),
                "write three numbers in mm",
            ))
        }
    };
    let tool = |length: &Option<Spanned<f64>>,
                offset: &Option<Spanned<Vec<f64>>>,
                what: &str|
     -> Result<Option<Vec3>, MapFileError> {
        match (length, offset) {
            (Some(l), Some(_)) => Err(at(
                l.span().start,
                format!("{what}: give a tool length or a tool offset vector, not both"),
                "tool_length_mm = L is the offset (0, 0, L)",
            )),
            (Some(l), None) if l.get_ref().is_finite() => {
                Ok(Some(Vec3::new(0.0, 0.0, *l.get_ref())))
            }
            (Some(l), None) => Err(at(
                l.span().start,
                format!("{what}: the tool length is not a finite number"),
                "write the length in mm",
            )),
            (None, Some(o)) => finite3(o, what).map(Some),
            (None, None) => Ok(None),
        }
    };
    let point = match &raw.measuring_point_mm {
        Some(p) => finite3(p, "measuring_point_mm")?,
        None => Vec3::ZERO,
    };
    let tool_offset = tool(
        &raw.measuring_tool_length_mm,
        &raw.measuring_tool_offset_mm,
        "measuring tool",
    )?
    .unwrap_or(Vec3::ZERO);
    let mut measuring = [MeasuringLine {
        point_mm: point,
        tool_offset_mm: tool_offset,
    }; 3];
    for (name, line) in raw.measuring.iter().flatten() {
        let a = match name.get_ref().to_ascii_uppercase().as_str() {
            "X" => 0,
            "Y" => 1,
            "Z" => 2,
            other => {
                return Err(at(
                    name.span().start,
                    format!("`[measuring.{other}]` is not an axis"),
                    "per-axis measuring lines are [measuring.X], [measuring.Y], [measuring.Z]",
                ))
            }
        };
        let l = line.get_ref();
        if let Some(p) = &l.point_mm {
            measuring[a].point_mm = finite3(p, "point_mm")?;
        }
        if let Some(t) = tool(
            &l.tool_length_mm,
            &l.tool_offset_mm,
            &format!("measuring.{}", AXES[a]),
        )? {
            measuring[a].tool_offset_mm = t;
        }
    }
    let Some(tables) = &raw.tables else {
        return Err(at(
            text.len(),
            "the model names no component tables (`tables` is missing)".into(),
            "write tables = \"components.csv\" (relative to this file) or a list of files",
        ));
    };
    let (row, column) = row_col(text, tables.span().start);
    let names = match tables.get_ref() {
        RawTables::One(s) => vec![s.clone()],
        RawTables::Many(v) => v.clone(),
    };
    if names.is_empty() {
        return Err(map_err(
            file,
            row,
            column,
            "`tables` is empty".into(),
            "name at least one CSV file",
        ));
    }
    Ok(ModelHeader {
        description: raw.description,
        kinematics: Kinematics {
            topology,
            measuring,
            squareness,
            angles,
        },
        tables: names.into_iter().map(|n| (n, row, column)).collect(),
    })
}

/// Reads a table file named in a model file: `(display name, text)`, or why not.
pub type TableReader<'a> = dyn FnMut(&str) -> Result<(String, String), std::io::Error> + 'a;

/// Parses a model from its TOML text; `read_table(name)` returns the text
/// of a table file named in it (or why it cannot), and its display name.
pub fn parse_model(
    text: &str,
    file: &str,
    read_table: &mut TableReader<'_>,
) -> Result<KinematicModel, MapFileError> {
    let header = parse_header(text, file)?;
    let mut rows = TableRows::default();
    for (name, row, column) in &header.tables {
        let (shown, csv) = read_table(name).map_err(|why| {
            map_err(
                file,
                *row,
                *column,
                format!("cannot read the table `{name}`: {why}"),
                "table paths are relative to the model file",
            )
        })?;
        rows.add_csv(&csv, &shown)?;
    }
    let axes = rows.assemble()?;
    Ok(KinematicModel::new(axes, header.kinematics))
}

/// Reads a model file and the tables it names (relative to its directory).
pub fn read_model(path: &Path) -> Result<KinematicModel, ModelFileError> {
    let text =
        crate::io::inputs::read_to_string(path, "the model").map_err(|e| ModelFileError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
    model_from_text(path, &text)
}

/// Parses the model file `path` whose text is `text`, reading the tables it
/// names relative to its directory.
pub fn model_from_text(path: &Path, text: &str) -> Result<KinematicModel, ModelFileError> {
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let role = format!(
        "a table named in {}",
        crate::io::shown_name(&crate::io::file_name(path))
    );
    let mut read = |name: &str| -> Result<(String, String), std::io::Error> {
        let p: PathBuf = dir.join(name);
        crate::io::inputs::read_to_string(&p, &role).map(|t| (p.display().to_string(), t))
    };
    Ok(parse_model(text, &path.display().to_string(), &mut read)?)
}

fn toml_string(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

/// A point as a TOML array of three lengths (mm).
fn triple(v: Vec3) -> String {
    format!("[{}]", [v.x, v.y, v.z].map(numfmt::mm).join(", "))
}

/// Writes the TOML description of `model`, naming `tables` as its table file.
pub fn model_to_toml(model: &KinematicModel, tables: &str, description: Option<&str>) -> String {
    let k = &model.kinematics;
    let mut s = String::from(
        "# volcomp 21-component kinematic error model (ISO 230-1); see docs/kinematic.md\n",
    );
    s.push_str(&format!("model = \"{MODEL_KIND}\"\n"));
    if let Some(d) = description {
        s.push_str(&format!("description = {}\n", toml_string(d)));
    }
    s.push_str(&format!("chain = \"{}\"\n", k.topology));
    s.push_str(&format!("tables = {}\n", toml_string(tables)));
    s.push_str(&format!(
        "angles = \"{}\"\n",
        match k.angles {
            AngleConvention::Relative => "relative",
            AngleConvention::MovingPart => "moving-part",
        }
    ));
    let first = k.measuring[0];
    let same = k.measuring.iter().all(|m| *m == first);
    let line = if same {
        first
    } else {
        MeasuringLine::default()
    };
    s.push_str(&format!("measuring_point_mm = {}\n", triple(line.point_mm)));
    let t = line.tool_offset_mm;
    if t.x == 0.0 && t.y == 0.0 {
        s.push_str(&format!("measuring_tool_length_mm = {}\n", numfmt::mm(t.z)));
    } else {
        s.push_str(&format!("measuring_tool_offset_mm = {}\n", triple(t)));
    }
    s.push_str("\n[squareness_urad]  # Y moves along (xy, 1, 0), Z along (zx, yz, 1)\n");
    s.push_str(&format!(
        "xy = {}\nyz = {}\nzx = {}\n",
        k.squareness.xy_urad, k.squareness.yz_urad, k.squareness.zx_urad
    ));
    if !same {
        for (a, m) in k.measuring.iter().enumerate() {
            s.push_str(&format!(
                "\n[measuring.{}]\npoint_mm = {}\n",
                AXES[a],
                triple(m.point_mm)
            ));
            let t = m.tool_offset_mm;
            if t.x == 0.0 && t.y == 0.0 {
                s.push_str(&format!("tool_length_mm = {}\n", numfmt::mm(t.z)));
            } else {
                s.push_str(&format!("tool_offset_mm = {}\n", triple(t)));
            }
        }
    }
    s
}

/// The two files of a model to be written as `toml_path`.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelFiles {
    /// The TOML description (`toml_path` itself).
    pub toml: String,
    /// Where the component tables go: beside it, same stem, `.csv`.
    pub csv_path: PathBuf,
    /// The component tables.
    pub csv: String,
}

/// The TOML description and CSV tables of `model` written as `toml_path`
/// (which must end in `.toml`); the description names the CSV by its file
/// name, so the pair can be moved together.
pub fn model_files(
    model: &KinematicModel,
    toml_path: &Path,
    description: Option<&str>,
) -> Result<ModelFiles, ModelFileError> {
    let is_toml = toml_path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    if !is_toml {
        return Err(ModelFileError::NotToml {
            path: toml_path.display().to_string(),
        });
    }
    let csv_path = toml_path.with_extension("csv");
    let csv_name = csv_path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    Ok(ModelFiles {
        toml: model_to_toml(model, &csv_name, description),
        csv: components_to_csv(&model.axes),
        csv_path,
    })
}

/// Rows of the component table (header [`CSV_HEADER`] included) that hold
/// only the positioning error `p` of axis `axis` (0 = X), both directions,
/// under the comment line `# {comment}`.
pub fn positioning_rows_csv(p: &Positioning, axis: Axis, comment: &str) -> String {
    let axis = axis.index();
    let mut s = format!("# {comment}\n{CSV_HEADER}\n");
    for (dir, v) in [("forward", &p.forward_um), ("reverse", &p.reverse_um)] {
        for (x, e) in p.positions_mm.iter().zip(v.iter()) {
            let mut lin = [0.0; 3];
            lin[axis] = *e;
            s.push_str(&format!(
                "{},{dir},{},{},{},{},0,0,0\n",
                AXES[axis],
                numfmt::mm(*x),
                numfmt::um(lin[0]),
                numfmt::um(lin[1]),
                numfmt::um(lin[2])
            ));
        }
    }
    s
}

/// A positioning-only model (straightness, angles and squareness zero) from
/// positioning tables `E_aa` per axis: what a LinuxCNC comp file or an
/// ISO 230-2 test gives.
pub fn positioning_model(
    tables: [(Table, Table); 3],
    topology: Topology,
) -> Option<KinematicModel> {
    let mut axes = Vec::with_capacity(3);
    for (a, (fwd, rev)) in tables.into_iter().enumerate() {
        let build = |t: Table| {
            let n = t.positions_mm.len();
            let linear = t
                .errors_um
                .iter()
                .map(|e| {
                    let mut v = Vec3::ZERO;
                    v[a] = e[a];
                    v
                })
                .collect();
            ComponentTable::new(t.positions_mm, linear, vec![Vec3::ZERO; n])
        };
        let f = build(fwd)?;
        let r = build(rev)?;
        axes.push(AxisComponents {
            forward: f,
            reverse: r,
        });
    }
    let mut it = axes.into_iter();
    let axes = [it.next()?, it.next()?, it.next()?];
    Some(KinematicModel::new(axes, Kinematics::new(topology)))
}

#[cfg(test)]
mod tests {
    use super::*;

    const CSV: &str = "axis,direction,position_mm,ex_um,ey_um,ez_um,ea_urad,eb_urad,ec_urad\n\
        X,forward,0,0,0,0,0,0,0\nX,forward,100,1,0.5,0,2,0,4\n\
        X,reverse,0,2,0,0,0,0,0\nX,reverse,100,3,0.5,0,2,0,4\n\
        Y,both,0,0,0,0,0,0,0\nY,both,100,0,2,0,0,0,0\n\
        Z,both,0,0,0,0,0,0,0\nZ,both,100,0,0,3,0,1,0\n";

    const TOML: &str = "model = \"kinematic-21\"\nchain = \"w X' Y' b Z t\"\ntables = \"t.csv\"\n\
        measuring_point_mm = [0, 50, 60]\nmeasuring_tool_length_mm = 100\n\
        [squareness_urad]\nxy = 10\nyz = -5\nzx = 2.5\n\
        [measuring.Z]\npoint_mm = [10, 20, 0]\ntool_length_mm = 50\n";

    fn load(toml: &str, csv: &str) -> Result<KinematicModel, MapFileError> {
        let csv = csv.to_string();
        parse_model(toml, "m.toml", &mut |name| {
            if name == "t.csv" {
                Ok(("t.csv".into(), csv.clone()))
            } else {
                Err(std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    "No such file or directory (os error 2)",
                ))
            }
        })
    }

    #[test]
    fn reads_a_model() {
        let m = load(TOML, CSV).unwrap();
        let k = &m.kinematics;
        assert_eq!(k.topology, Topology::SEED);
        assert_eq!(k.squareness.zx_urad, 2.5);
        assert_eq!(k.measuring[0].point_mm, Vec3::new(0.0, 50.0, 60.0));
        assert_eq!(k.measuring[0].tool_offset_mm, Vec3::new(0.0, 0.0, 100.0));
        assert_eq!(k.measuring[2].point_mm, Vec3::new(10.0, 20.0, 0.0));
        assert_eq!(k.measuring[2].tool_offset_mm, Vec3::new(0.0, 0.0, 50.0));
        assert_eq!(
            m.axes[0].reverse.linear_um.errors_um[1],
            Vec3::new(3.0, 0.5, 0.0)
        );
        assert_eq!(
            m.axes[2].forward.angular_urad.errors_um[1],
            Vec3::new(0.0, 1.0, 0.0)
        );
        // Written out and read back: the same model.
        let toml = model_to_toml(&m, "t.csv", Some("test \"machine\""));
        let again = load(&toml, &components_to_csv(&m.axes)).unwrap();
        assert_eq!(again, m);
    }

    #[test]
    fn arc_seconds_are_converted() {
        let csv = CSV.replace("ec_urad", "ec_arcsec");
        let m = load(TOML, &csv).unwrap();
        let v = m.axes[0].forward.angular_urad.errors_um[1].z;
        // 4″ = 4 · π/648000 rad = 19.392547 µrad
        assert!((v - 19.392_547).abs() < 1e-6, "{v}");
    }

    fn err(toml: &str, csv: &str) -> MapFileError {
        load(toml, csv).unwrap_err()
    }

    #[test]
    fn bad_tables_name_file_row_and_column() {
        // NaN in EZX of X reverse at 100 mm: row 5, column 6.
        let e = err(
            TOML,
            &CSV.replace(
                "X,reverse,100,3,0.5,0,2,0,4",
                "X,reverse,100,3,0.5,NaN,2,0,4",
            ),
        );
        assert_eq!((e.file.as_str(), e.row, e.column), ("t.csv", 5, 6), "{e}");
        // Non-increasing position.
        let e = err(TOML, &CSV.replace("Y,both,100", "Y,both,0"));
        assert_eq!((e.row, e.column), (7, 3), "{e}");
        assert!(e.message.contains("does not increase"), "{e}");
        // A unit missing in the header.
        let e = err(TOML, &CSV.replace("eb_urad", "eb"));
        assert_eq!((e.row, e.column), (1, 8), "{e}");
        assert!(e.message.contains("no unit"), "{e}");
        // A component missing from the header.
        let e = err(TOML, &CSV.replace(",ec_urad", ""));
        assert_eq!(e.row, 1, "{e}");
        assert!(e.message.contains("ec_urad"), "{e}");
        // An axis missing.
        let no_z: String = CSV
            .lines()
            .filter(|l| !l.starts_with('Z'))
            .map(|l| format!("{l}\n"))
            .collect();
        let e = err(TOML, &no_z);
        assert!(e.message.contains("EZZ"), "{e}");
        assert_eq!(e.file, "t.csv");
        // Wrong field count.
        let e = err(
            TOML,
            &CSV.replace("Y,both,0,0,0,0,0,0,0", "Y,both,0,0,0,0,0,0"),
        );
        assert_eq!((e.row, e.column), (6, 9), "{e}");
    }

    #[test]
    fn bad_descriptions_name_row_and_column() {
        // The model file with `from` replaced by `to`: refused.
        let edited = |from: &str, to: &str| err(&TOML.replace(from, to), CSV);
        let e = edited("zx = 2.5\n", "");
        assert!(e.message.contains("`zx` is missing"), "{e}");
        assert_eq!(e.row, 6, "{e}");
        let e = edited("w X' Y' b Z t", "w X' Y' b X t");
        assert_eq!((e.row, e.column), (2, 20), "{e}");
        assert!(e.message.contains("twice"), "{e}");
        let e = edited("measuring_point_mm", "measuring_point");
        assert_eq!(e.row, 4, "{e}");
        assert!(e.message.contains("unknown field"), "{e}");
        assert!(e.help.contains("unit"), "{e}");
        let e = edited("t.csv", "missing.csv");
        assert_eq!((e.file.as_str(), e.row, e.column), ("m.toml", 3, 10), "{e}");
        let e = edited("kinematic-21", "thermal");
        assert_eq!((e.row, e.column), (1, 9), "{e}");
        let e = edited("model = \"kinematic-21\"\n", "");
        assert!(e.message.contains("what model"), "{e}");
        let e = edited("[squareness_urad]\nxy = 10\nyz = -5\nzx = 2.5\n", "");
        assert!(e.message.contains("squareness"), "{e}");
        let e = edited(
            "measuring_point_mm = [0, 50, 60]",
            "measuring_point_mm = [0, nan, 60]",
        );
        assert_eq!(e.row, 4, "{e}");
        // Four values where a point has three: refused at the array.
        let e = edited(
            "measuring_point_mm = [0, 50, 60]",
            "measuring_point_mm = [0, 50, 60, 70]",
        );
        assert_eq!((e.row, e.column), (4, 22), "{e}");
        assert!(e.message.contains("has 4 values"), "{e}");
        let e = edited(
            "tables = \"t.csv\"\n",
            "tables = \"t.csv\"\nangles = \"absolute\"\n",
        );
        assert!(e.message.contains("angle convention"), "{e}");
        assert_eq!((e.row, e.column), (4, 10), "{e}");
    }

    #[test]
    fn model_files_need_a_toml_name_and_put_the_csv_beside_it() {
        let m = crate::example::kinematic::example_model();
        let f = model_files(&m, Path::new("out/m.TOML"), Some("d")).unwrap();
        assert_eq!(f.csv_path, Path::new("out/m.csv"));
        assert!(f.toml.contains("tables = \"m.csv\"\n"));
        assert!(f.toml.contains("description = \"d\"\n"));
        assert!(f.csv.lines().any(|l| l == CSV_HEADER));
        let e = model_files(&m, Path::new("m.csv"), None).unwrap_err();
        assert!(matches!(e, ModelFileError::NotToml { .. }));
    }

    #[test]
    fn positioning_rows_hold_the_axis_own_column() {
        let p = Positioning::new(&[0.0, 50.0], &[1.0, 2.5], &[-1.0, 0.0]);
        let s = positioning_rows_csv(&p, Axis::Y, "test");
        assert_eq!(
            s,
            format!(
                "# test\n{CSV_HEADER}\nY,forward,0,0,1,0,0,0,0\nY,forward,50,0,2.5,0,0,0,0\nY,reverse,0,0,-1,0,0,0,0\nY,reverse,50,0,0,0,0,0,0\n"
            )
        );
    }
}
