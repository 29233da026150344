//! A map's export to a controller's compensation tables
//! (docs/controllers.md), as plain values: the format, where a 21-component
//! model's positioning is taken, the vendor's settings; checked here, then
//! the table written, how far it lies from the map as the controller
//! applies it (refused above the limit) and the sign-check files.

use super::option::OptionError;
use crate::io::controllers::table_error::{self, um, TableError};
use crate::io::controllers::{self, fanuc, siemens, Export, ExportFile, Positioning};
use crate::io::linuxcnc_comp::{CompFileType, MachineUnits};
use crate::model::axis_table::AxisTableMap;
use crate::model::kinematic::{Form, KinematicModel};
use crate::model::ErrorModel;
use crate::Error;
use volcomp_gcode::Vec3;
use volcomp_geom::Axis;

/// The controllers' formats: name, what, the files written.
const FORMATS: &[(&str, &str)] = &[
    (
        "linuxcnc",
        "LinuxCNC comp files x.comp, y.comp, z.comp (with --type, --units)",
    ),
    (
        "siemens-eec",
        "Siemens Sinumerik leadscrew error compensation %_N_AX_EEC_INI",
    ),
    (
        "siemens-cec",
        "Siemens Sinumerik sag/cross-axis compensation %_N_NC_CEC_INI (the straightness)",
    ),
    (
        "heidenhain",
        "Heidenhain TNC compensation value tables X.COM, Y.COM, Z.COM and VOLCOMP.CMA",
    ),
    (
        "isg-ssfk",
        "Beckhoff/ISG leadscrew error compensation lists achskw_x.lis … (kw.ssfk, 0.1 µm)",
    ),
    (
        "isg-csv",
        "Beckhoff/ISG volumetric compensation: volcomp.csv (ISG CSV, ISO 230-1 names) and volcomp.lis",
    ),
    (
        "fanuc",
        "Fanuc pitch error compensation: parameters 3620–3624 (3605#0, 3626, 3627 per direction) and the data, as a tape pitch.tap",
    ),
    (
        "klipper",
        "Klipper [skew_correction] profile from the model's squareness",
    ),
    ("marlin", "Marlin M852 I J K from the model's squareness"),
    (
        "rrf",
        "RepRapFirmware M556 S X Y Z from the model's squareness",
    ),
    (
        "grblhal",
        "grblHAL backlash settings $160–$162 (the mean reversal value)",
    ),
];

const RETURN: &[(&str, &str)] = &[
    (
        "positive",
        "Reference position return in the + direction (1006#5 = 0)",
    ),
    (
        "negative",
        "Reference position return in the − direction (1006#5 = 1)",
    ),
];

request! {
    /// The LinuxCNC side of a comp file, as plain values.
    #[allow(missing_docs)]
    pub struct CompRequest {}
    /// The LinuxCNC side of a comp file ([`CompRequest`]).
    pub const COMP_OPTIONS, unknown "comp_type";

    comp_type: Option<u64> = None, Count.flag("type").value("0|1"),
        "COMP_FILE_TYPE: 0 (nominal, actual forward, actual reverse) or 1 (nominal, trim forward, trim reverse; trim = nominal − actual).";

    units: Option<String> = None, Choice.value("UNITS").choices(&[("mm", ""), ("inch", "")]),
        "The machine's [TRAJ] LINEAR_UNITS, the unit of every number in the file.";
}

/// The units a comp file's numbers are in.
fn comp_choice(value: &str) -> Result<&'static str, OptionError> {
    let info = <CompRequest as super::Request>::info("units").expect("an option");
    info.choice(value).map_err(|p| OptionError::new("units", p))
}

impl CompRequest {
    /// The machine's units, if given.
    pub fn units(&self) -> Result<Option<MachineUnits>, OptionError> {
        self.units
            .as_deref()
            .map(|u| {
                Ok(match comp_choice(u)? {
                    "inch" => MachineUnits::Inch,
                    _ => MachineUnits::Mm,
                })
            })
            .transpose()
    }

    /// The comp file's type and units, both required.
    pub fn get(&self) -> Result<(CompFileType, MachineUnits), Error> {
        let ty = match self.comp_type {
            Some(n) => u8::try_from(n)
                .ok()
                .and_then(CompFileType::from_number)
                .ok_or_else(|| {
                    OptionError::new(
                        "comp_type",
                        format!("must be 0 or 1 (COMP_FILE_TYPE); got {n}"),
                    )
                })?,
            None => return Err(Error::Request("LinuxCNC comp files need {comp_type} 0 or {comp_type} 1: type 0 holds actual positions, type 1 the trims nominal − actual; check COMP_FILE_TYPE in the machine's INI file".into())),
        };
        let units = self.units()?.ok_or_else(|| {
            Error::Request("LinuxCNC comp files are in machine units: pass {units} mm or {units} inch as [TRAJ] LINEAR_UNITS says".into())
        })?;
        Ok((ty, units))
    }
}

request! {
    /// Where a 21-component model is evaluated as tables, as plain values.
    #[allow(missing_docs)]
    pub struct MapToolRequest {}
    /// Where a 21-component model is evaluated as tables (shared by the jobs
    /// that turn a model into tables).
    pub const MAP_TOOL_OPTIONS, unknown "tool_length_mm";

    tool_length_mm: Option<f64> = None, Number.flag("tool-length").value("MM"),
        "Tool length (mm) as G43 applies it: the tip lies this far below the spindle's gauge point. Default 0 (the gauge point).";

    tool_offset_mm: Option<[f64; 3]> = None, Triple.flag("tool-offset").value("X,Y,Z"),
        "Tool length offset vector (mm) as G43.1 applies it, for angle heads.";

    form: String = "htm".into(), Choice.value("FORM").default("htm").choices(&[
        ("htm", "Exact products of homogeneous transformation matrices"),
        ("first-order", "The small-angle (first-order) form"),
    ]),
        "Evaluation of the 21-component model.";
}

impl MapToolRequest {
    /// The tool's offset from the gauge point, if a tool was given.
    pub fn offset(&self) -> Result<Option<Vec3>, OptionError> {
        match (self.tool_length_mm, self.tool_offset_mm) {
            (Some(_), Some(_)) => Err(OptionError::new(
                "tool_length_mm",
                "cannot be given with {tool_offset_mm}: give the tool's length or its offset vector",
            )),
            (Some(l), None) => Ok(Some(Vec3::new(0.0, 0.0, l))),
            (None, Some([x, y, z])) => Ok(Some(Vec3::new(x, y, z))),
            (None, None) => Ok(None),
        }
    }

    /// The model's evaluation.
    pub fn form(&self) -> Result<Form, OptionError> {
        let info = <Self as super::Request>::info("form").expect("an option");
        match info
            .choice(&self.form)
            .map_err(|p| OptionError::new("form", p))?
        {
            "first-order" => Ok(Form::FirstOrder),
            _ => Ok(Form::Htm),
        }
    }
}

/// A map `volcomp map` works on: axis tables or a 21-component model.
#[derive(Debug, Clone, Copy)]
pub enum MapView<'a> {
    /// Forward and reverse tables per axis.
    Tables(&'a AxisTableMap),
    /// The 21-component model.
    Kinematic(&'a KinematicModel),
}

impl<'a> MapView<'a> {
    /// The map as an error model.
    pub fn model(self) -> &'a dyn ErrorModel {
        match self {
            MapView::Tables(m) => m,
            MapView::Kinematic(m) => m,
        }
    }
}

/// The positioning tables `E_aa` of a map: the axis tables' own, or a
/// 21-component model's as measured (or at `at` for the tool).
pub fn positioning_tables(
    map: MapView<'_>,
    at: Option<Vec3>,
    tool: Option<Vec3>,
    form: Form,
) -> Result<[Positioning; 3], Error> {
    Ok(match map {
        MapView::Tables(t) => Axis::ALL.map(|k| t.positioning(k)),
        MapView::Kinematic(m) => {
            if at.is_none() && tool.is_none() {
                // The positioning errors as measured, at the measuring line.
                Axis::ALL.map(|k| m.positioning_table(k))
            } else {
                let (shared_p, shared_t) = m.shared_measuring();
                let Some(reference) = at.or(shared_p) else {
                    return Err(Error::Request(
                        "pass {at} X,Y,Z: the model's axes were measured along different lines"
                            .into(),
                    ));
                };
                let Some(tool) = tool.or(shared_t) else {
                    return Err(Error::Request("pass {tool_length_mm} MM".into()));
                };
                let t = m.to_axis_tables(reference, tool, form)?;
                Axis::ALL.map(|k| t.positioning(k))
            }
        }
    })
}

/// The straightness tables of a map that are not zero: `(axis, direction, E_da)`.
pub fn straightness_tables(map: MapView<'_>) -> Vec<(usize, usize, Positioning)> {
    use crate::model::axis_table::Table;
    let pair = |f: &Table, r: &Table, d: usize| -> Positioning {
        let [lo, hi] = r.range();
        Positioning {
            positions_mm: f.positions_mm.clone(),
            forward_um: f.errors_um.iter().map(|e| e[d]).collect(),
            reverse_um: f
                .positions_mm
                .iter()
                .map(|&x| r.eval(x.clamp(lo, hi)).map_or(0.0, |e| e[d]))
                .collect(),
        }
    };
    let mut out = Vec::new();
    for a in 0..3 {
        for d in (0..3).filter(|&d| d != a) {
            let p = match map {
                MapView::Tables(t) => pair(&t.axes[a].forward, &t.axes[a].reverse, d),
                MapView::Kinematic(m) => pair(
                    &m.axes[a].forward.linear_um,
                    &m.axes[a].reverse.linear_um,
                    d,
                ),
            };
            if p.forward_um.iter().chain(&p.reverse_um).any(|v| *v != 0.0) {
                out.push((a, d, p));
            }
        }
    }
    out
}

request! {
    /// A map's export to a controller, as plain values.
    #[allow(missing_docs)]
    pub struct MapExportRequest {
        pub tool: MapToolRequest,
        pub comp: CompRequest,
    }
    /// The options of [`MapExportRequest`].
    pub const EXPORT_OPTIONS;
    options [EXPORT_OPTIONS, COMP_OPTIONS, MAP_TOOL_OPTIONS], unknown "tool_length_mm";

    to: Option<String> = None, Choice.value("TO").required().choices(FORMATS),
        "The controller's format.";

    step_mm: Option<f64> = None, Number.flag("step").value("MM"),
        "Spacing of the table's points (mm): required by equidistant tables (siemens-eec); resamples the others (linear interpolation).";

    at: Option<[f64; 3]> = None, Triple.value("X,Y,Z"),
        "Where the positioning error of a 21-component model is taken (axis position, mm; default: its measuring lines).";

    max_table_error_um: f64 = table_error::DEFAULT_MAX_TABLE_ERROR_UM,
        Number.value("UM").default("1"),
        "The largest deviation (µm) of the written table, as the controller applies it, from the map between and at its points: a larger one is refused with a finer step to choose.";

    backlash_only: bool = false, Switch,
        "linuxcnc: write each joint's BACKLASH (the mean reversal value) and no comp files.";

    axis_names: String = "X1,Y1,Z1".into(), Text.value("X,Y,Z").default("X1,Y1,Z1"),
        "siemens-eec: the machine axis names of X, Y, Z.";

    resolution_um: f64 = 1.0, Number.value("UM").default("1"),
        "siemens-eec: the NC's resolution of a compensation value (µm), 1/MD10200 mm.";

    max_points: Option<u64> = None, Count.value("N"),
        "The controller's largest number of points per table: siemens-eec MD38000 $MA_MM_ENC_COMP_MAX_POINTS (default 5000), isg-ssfk P-COMP-00059 (default 1500).";

    detection_unit_um: f64 = 1.0, Number.value("UM").default("1"),
        "fanuc: the detection unit (µm; 1 for IS-B).";

    fanuc_sign: String = "correction".into(),
        Choice.value("FANUC_SIGN").default("correction").choices(&[
            ("correction", "The values are the correction the control outputs, −e"),
            ("error", "The values are the error, +e"),
        ]),
        "fanuc: the sign of the values (not in the public documentation): correction = −e (default) or error = +e.";

    fanuc_data_offset: u64 = 10000, Count.value("N").default("10000"),
        "fanuc: the tape's data number of compensation point 0.";

    fanuc_bidirectional: String = "auto".into(),
        Choice.value("FANUC_BIDIRECTIONAL").default("auto").choices(&[
            ("auto", "Bidirectional where the reversal exceeds the detection unit"),
            ("on", "Always bidirectional"),
            ("off", "One table, the mean of both directions"),
        ]),
        "fanuc: one table per direction (3605#0, 3626, 3627): auto = where forward and reverse differ by more than the detection unit.";

    fanuc_reference_return: String = "positive".into(),
        Choice.value("FANUC_REFERENCE_RETURN").default("positive").choices(RETURN),
        "fanuc: the direction of the reference position return (1006#5), whose table is zero at the reference; 3627 holds the other's value.";

    reference_direction: String = "positive".into(),
        Choice.value("REFERENCE_DIRECTION").default("positive").choices(RETURN),
        "siemens-eec: the direction of the reference point approach (MD34010 $MA_REFP_CAM_DIR_IS_MINUS 0 = positive): MD32450's backlash acts on travel the other way.";

    cec_sign: String = "error".into(), Choice.value("CEC_SIGN").default("error").choices(&[
        ("error", "The values are the measured error, +e"),
        ("correction", "The values are the correction, −e"),
    ]),
        "siemens-cec: the sign of the values (the manual does not settle it): error = +e (default, as the leadscrew tables) or correction = −e.";

    homing_dir_mask: u64 = 0, Count.value("MASK").default("0"),
        "grblhal: the machine's $23 (homing direction invert mask): the side grblHAL adds the backlash to.";

    profile: String = "volcomp".into(), Text.value("NAME").default("volcomp"),
        "klipper: the profile's name (SKEW_PROFILE LOAD=NAME).";
}

/// What an export gives: the controller's files, the sign-check files,
/// and how far the table lies from the map as the controller applies it.
#[derive(Debug, Clone)]
pub struct Exported {
    /// The controller's files, rounding and notes.
    pub export: Export,
    /// The sign check on the machine (formats whose sign no vendor text
    /// settles), or none.
    pub checks: Vec<ExportFile>,
    /// The table's largest deviation from the map.
    pub error: TableError,
    /// The unit of the rounding: µm, or µrad for a skew.
    pub unit: &'static str,
    /// The limit the deviation was checked against.
    pub max_table_error_um: f64,
}

impl Exported {
    /// Every file to write: the controller's, then the sign check's.
    pub fn files(&self) -> impl Iterator<Item = &ExportFile> {
        self.export.files.iter().chain(&self.checks)
    }

    /// What was written and how close it is, for a person (standard
    /// error), after the files went to `dir`; options named as `{name}`.
    pub fn summary(&self, dir: &str) -> Vec<String> {
        let unit = self.unit;
        let e = &self.export;
        let mut lines = vec![format!(
            "volcomp: wrote {} to {dir}{}; rounded to the controller's resolution {} {unit}: largest change {} {unit}",
            crate::report::text::count((e.files.len() + self.checks.len()) as u64, "file", "files"),
            match self.checks.first() {
                None => String::new(),
                Some(c) => format!(
                    " (with {}: check the table's sign on the machine once, as it says)",
                    c.name
                ),
            },
            um(e.rounding.resolution_um),
            um(e.rounding.max_um)
        )];
        let err = &self.error;
        let (ax, x, forward) = err.at.unwrap_or((0, 0.0, true));
        lines.push(format!(
            "volcomp: the table as the controller applies it lies at most {} µm from the map (resampling and rounding; {} at {} mm, {}; exact: checked at every point of the map's and the controller's tables, where the largest difference of two linearly interpolated tables lies); {{max_table_error_um}} allows {}",
            um(err.max_um),
            ["X", "Y", "Z"][ax],
            crate::io::numfmt::fixed(x, 4),
            if forward { "forward" } else { "reverse" },
            um(self.max_table_error_um)
        ));
        if err.left_um > err.max_um {
            lines.push(format!(
                "volcomp: the controller leaves up to {} µm of the map uncorrected (what the format cannot hold); compensate it with {{controller}}",
                um(err.left_um)
            ));
        }
        lines
    }
}

/// The choice of option `name` that `value` names.
fn choice(name: &'static str, value: &str) -> Result<&'static str, OptionError> {
    let info = <MapExportRequest as super::Request>::info(name).expect("an option");
    info.choice(value).map_err(|p| OptionError::new(name, p))
}

fn direction(
    name: &'static str,
    value: &str,
) -> Result<controllers::ReferenceDirection, OptionError> {
    Ok(match choice(name, value)? {
        "negative" => controllers::ReferenceDirection::Negative,
        _ => controllers::ReferenceDirection::Positive,
    })
}

/// A positive option's value, or what to give.
fn positive(name: &'static str, v: f64) -> Result<f64, OptionError> {
    super::positive(name, v, "positive")
}

impl MapExportRequest {
    /// The format asked for.
    pub fn format(&self) -> Result<&'static str, OptionError> {
        let to = self
            .to
            .as_deref()
            .ok_or_else(|| OptionError::new("to", "is required"))?;
        choice("to", to)
    }

    /// The files an export in this format writes (the sign check's too),
    /// for the front end to check before any work.
    pub fn file_names(&self) -> Result<Vec<&'static str>, OptionError> {
        let to = self.format()?;
        let names: &[&str] = match to {
            "linuxcnc" => &["x.comp", "y.comp", "z.comp", "comp.ini"],
            "siemens-eec" => &["%_N_AX_EEC_INI"],
            "siemens-cec" => &["%_N_NC_CEC_INI"],
            "heidenhain" => &["X.COM", "Y.COM", "Z.COM", "VOLCOMP.CMA"],
            "isg-ssfk" => &["achskw_x.lis", "achskw_y.lis", "achskw_z.lis"],
            "isg-csv" => &["volcomp.csv", "volcomp.lis"],
            "fanuc" => &["pitch.tap"],
            "klipper" => &["skew_correction.cfg"],
            "marlin" => &["skew.gcode"],
            "rrf" => &["m556.g"],
            _ => &["backlash.txt"],
        };
        let mut all = names.to_vec();
        all.extend(sign_check_files(to));
        Ok(all)
    }

    /// The positioning tables of `map` where this request asks.
    fn positioning(&self, map: MapView<'_>) -> Result<[Positioning; 3], Error> {
        let tool = self.tool.offset()?;
        let at = self.at.map(|[x, y, z]| Vec3::new(x, y, z));
        positioning_tables(map, at, tool, self.tool.form()?)
    }

    /// The positioning tables resampled every `step` mm when a step is given.
    fn stepped(&self, map: MapView<'_>, step: Option<f64>) -> Result<[Positioning; 3], Error> {
        let tables = self.positioning(map)?;
        let Some(s) = step else {
            return Ok(tables);
        };
        // Checked before any table is built: a step of a nanometre over a
        // metre would be a billion points.
        let max = crate::limits::MAX_RESAMPLED_POINTS;
        for t in &tables {
            let n = t.resampled_points(s).unwrap_or(u64::MAX);
            if n > max {
                return Err(Error::Request(format!(
                    "{{step_mm}} {s} mm gives {n} table points over {:.3} … {:.3} mm, more than the {max} a table may have: choose a larger step",
                    t.positions_mm.first().copied().unwrap_or(0.0),
                    t.positions_mm.last().copied().unwrap_or(0.0),
                )));
            }
        }
        Ok(tables.map(|p| p.resample(s)))
    }

    /// The controller's tables of `map` (named `map_name` in messages),
    /// checked against the map, with the sign-check files.
    pub fn run(&self, map: MapView<'_>, map_name: &str) -> Result<Exported, Error> {
        let to = self.format()?;
        let step = match self.step_mm {
            Some(s) if !(s.is_finite() && s > 0.0) => {
                return Err(OptionError::new(
                    "step_mm",
                    format!("must be a positive length in mm; got {s}"),
                )
                .into())
            }
            other => other,
        };
        let skew = matches!(to, "klipper" | "marlin" | "rrf");
        let e = self.export(to, map, map_name, step)?;
        // How far the table, as the controller applies it, lies from the
        // map: checked before anything is written.
        let max_um = positive("max_table_error_um", self.max_table_error_um)?;
        let err = match (to, map) {
            (_, MapView::Kinematic(m)) if skew => {
                let s = &m.kinematics.squareness;
                table_error::squareness_error(
                    [s.xy_urad, s.yz_urad, s.zx_urad],
                    &e.applied,
                    m.range_mm(),
                )
            }
            _ if skew => TableError::default(),
            ("siemens-cec", _) => table_error::cross_error(&straightness_tables(map), &e.applied),
            _ => table_error::table_error(
                &self.positioning(map)?.map(Some),
                &e.applied,
                e.holds,
                e.zero_at,
            ),
        };
        // µrad over the map's arms: the error itself says it in µm.
        let rounding_um = if skew { 0.0 } else { e.rounding.max_um };
        table_error::check(e.applied.format.name(), &err, rounding_um, step, max_um)?;
        let checks = if sign_check_files(to).is_empty() {
            Vec::new()
        } else {
            let probes = controllers::signcheck::probes(
                &e,
                &self.positioning(map)?.map(Some),
                &straightness_tables(map),
            );
            controllers::signcheck::files(&e, &probes)
        };
        Ok(Exported {
            export: e,
            checks,
            error: err,
            unit: if skew { "µrad" } else { "µm" },
            max_table_error_um: max_um,
        })
    }

    /// The controller's files of format `to`.
    fn export(
        &self,
        to: &str,
        map: MapView<'_>,
        map_name: &str,
        step: Option<f64>,
    ) -> Result<Export, Error> {
        let whole = |name: &'static str, n: u64| {
            u32::try_from(n).map_err(|_| OptionError::new(name, format!("is too large: {n}")))
        };
        let max_points = |default: usize| {
            self.max_points.map_or(Ok(default), |n| {
                usize::try_from(n)
                    .map_err(|_| OptionError::new("max_points", format!("is too large: {n}")))
            })
        };
        Ok(match to {
            "grblhal" => controllers::grbl::export(
                &self.positioning(map)?.map(Some),
                whole("homing_dir_mask", self.homing_dir_mask)?,
            )?,
            "klipper" | "marlin" | "rrf" => {
                let MapView::Kinematic(m) = map else {
                    return Err(Error::Request(format!(
                        "{map_name}: axis tables hold no squareness; export the skew of a 21-component model (map convert --to model, then set [squareness_urad])"
                    )));
                };
                let s = &m.kinematics.squareness;
                let sq = [s.xy_urad, s.yz_urad, s.zx_urad];
                match to {
                    "klipper" => controllers::skew::klipper(sq, &self.profile)?,
                    "marlin" => controllers::skew::marlin(sq)?,
                    _ => controllers::skew::rrf(sq)?,
                }
            }
            "linuxcnc" => {
                use controllers::linuxcnc::LinuxcncExport;
                let (what, units) = if self.backlash_only {
                    let units = self.comp.units()?.ok_or_else(|| {
                        Error::Request("LinuxCNC's BACKLASH is in machine units: pass {units} mm or {units} inch as [TRAJ] LINEAR_UNITS says".into())
                    })?;
                    (LinuxcncExport::BacklashOnly, units)
                } else {
                    let (ty, units) = self.comp.get()?;
                    (LinuxcncExport::CompFiles(ty), units)
                };
                let t = self.stepped(map, step)?;
                controllers::linuxcnc::export(&t.map(Some), what, units)?
            }
            "fanuc" => {
                let Some(step) = step else {
                    return Err(Error::Request("Fanuc pitch error compensation is equidistant: pass {step_mm} MM, the interval of its points (parameter 3624)".into()));
                };
                let detection_unit_um = positive("detection_unit_um", self.detection_unit_um)?;
                let t = self.positioning(map)?;
                let o = fanuc::FanucOptions {
                    step_mm: step,
                    detection_unit_um,
                    sign: match choice("fanuc_sign", &self.fanuc_sign)? {
                        "error" => fanuc::FanucSign::Error,
                        _ => fanuc::FanucSign::Correction,
                    },
                    data_offset: whole("fanuc_data_offset", self.fanuc_data_offset)?,
                    bidirectional: match choice("fanuc_bidirectional", &self.fanuc_bidirectional)? {
                        "on" => fanuc::FanucBidirectional::On,
                        "off" => fanuc::FanucBidirectional::Off,
                        _ => fanuc::FanucBidirectional::Auto,
                    },
                    reference_return: match choice(
                        "fanuc_reference_return",
                        &self.fanuc_reference_return,
                    )? {
                        "negative" => fanuc::FanucReturn::Negative,
                        _ => fanuc::FanucReturn::Positive,
                    },
                    ..fanuc::FanucOptions::default()
                };
                fanuc::export(&t.map(Some), &o)?
            }
            "isg-ssfk" => controllers::isg::ssfk_export(
                &self.stepped(map, step)?.map(Some),
                max_points(controllers::isg::SSFK_MAX_POINTS)?,
            )?,
            "isg-csv" => match map {
                MapView::Kinematic(m) => controllers::isg::csv_export(m),
                MapView::Tables(t) => controllers::isg::csv_export(
                    &KinematicModel::from_axis_tables(t, crate::model::topology::Topology::SEED),
                ),
            },
            "heidenhain" => controllers::heidenhain::export(&self.stepped(map, step)?.map(Some))?,
            "siemens-cec" => {
                let Some(step) = step else {
                    return Err(Error::Request(
                        "a Siemens CEC table is equidistant: pass {step_mm} MM ($AN_CEC_STEP)"
                            .into(),
                    ));
                };
                let o = siemens::EecOptions {
                    axis_names: self.axis_names()?,
                    step_mm: step,
                    resolution_um: self.resolution_um,
                    max_points: max_points(5000)?,
                    reference: direction("reference_direction", &self.reference_direction)?,
                };
                let sign = match choice("cec_sign", &self.cec_sign)? {
                    "correction" => siemens::CecSign::Correction,
                    _ => siemens::CecSign::Error,
                };
                siemens::cec_export(&straightness_tables(map), &o, sign)?
            }
            _ => {
                let Some(step) = step else {
                    return Err(Error::Request("a Siemens EEC table is equidistant: pass {step_mm} MM, the spacing of its interpolation points ($AA_ENC_COMP_STEP)".into()));
                };
                let resolution_um = positive("resolution_um", self.resolution_um)?;
                let axis_names = self.axis_names()?;
                let t = self.positioning(map)?;
                let o = siemens::EecOptions {
                    axis_names,
                    step_mm: step,
                    resolution_um,
                    max_points: max_points(5000)?,
                    reference: direction("reference_direction", &self.reference_direction)?,
                };
                siemens::export(&t.map(Some), &o)?
            }
        })
    }

    /// The machine axis names of X, Y, Z.
    fn axis_names(&self) -> Result<[String; 3], OptionError> {
        let names: Vec<String> = self
            .axis_names
            .split(',')
            .map(|n| n.trim().to_string())
            .collect();
        <[String; 3]>::try_from(names).map_err(|_| {
            OptionError::new(
                "axis_names",
                format!(
                    "takes three machine axis names, e.g. X1,Y1,Z1; got `{}`",
                    self.axis_names
                ),
            )
        })
    }
}

/// The sign check's files of format `to` (none where a vendor's text
/// settles the sign; `controllers::signcheck`).
fn sign_check_files(to: &str) -> &'static [&'static str] {
    match to {
        "siemens-cec" => &["sign_check.txt", "SIGNCHECK.MPF"],
        "fanuc" | "isg-csv" => &["sign_check.txt", "signcheck.nc"],
        "heidenhain" => &["sign_check.txt", "SIGNCHECK.H"],
        _ => &[],
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Request, Value};
    use super::*;

    #[test]
    fn formats_and_their_files() {
        let mut r = MapExportRequest::default();
        assert_eq!(r.format().unwrap_err().to_string(), "to is required");
        r.set_named("to", Value::Text("Fanuc".into())).unwrap();
        assert_eq!(
            r.file_names().unwrap(),
            ["pitch.tap", "sign_check.txt", "signcheck.nc"]
        );
        r.set_named("to", Value::Text("fanuk".into())).unwrap();
        assert!(r
            .format()
            .unwrap_err()
            .to_string()
            .ends_with("got `fanuk` (did you mean `fanuc`?)"));
    }

    #[test]
    fn settings_are_checked_with_their_names() {
        let mut r = MapExportRequest {
            axis_names: "X1,Y1".into(),
            ..Default::default()
        };
        assert_eq!(
            r.axis_names().unwrap_err().to_string(),
            "axis_names takes three machine axis names, e.g. X1,Y1,Z1; got `X1,Y1`"
        );
        r.comp.comp_type = Some(2);
        assert_eq!(
            r.comp.get().unwrap_err().to_string(),
            "comp_type must be 0 or 1 (COMP_FILE_TYPE); got 2"
        );
        r.comp.comp_type = Some(1);
        r.comp.units = Some("Inch".into());
        assert_eq!(
            r.comp.get().unwrap(),
            (CompFileType::from_number(1).unwrap(), MachineUnits::Inch)
        );
        r.set_named("tool_length_mm", Value::Number(100.0)).unwrap();
        assert_eq!(r.tool.offset().unwrap(), Some(Vec3::new(0.0, 0.0, 100.0)));
        r.set_named("tool_offset_mm", Value::Triple([1.0, 0.0, 0.0]))
            .unwrap();
        assert!(r.tool.offset().is_err());
    }
}
