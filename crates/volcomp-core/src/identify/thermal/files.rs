//! Input and output files of the thermal workflow (formats in
//! `docs/thermal.md`). Every bad value is reported with file, row and column.
//!
//! * artifact: `sphere,distance_mm` — calibrated distance from sphere 1;
//! * measurements: `cycle,time_h,placement,sphere,x_mm,y_mm,z_mm` — measured
//!   sphere centres in machine coordinates, every placement of a cycle with
//!   every sphere;
//! * temperatures: `cycle,time_h,<sensor>…` — one row per cycle, one column
//!   per sensor (°C; name them `<name>_C`);
//! * the thermal model: TOML, [`ThermalModelFile`].

use super::artifact::{BallArray, PlacementMeasurement};
use super::identify::{identify, Identification};
use super::poly::PolyModel;
use super::regression::{features, Regression};
use super::ThermalError;
use crate::error::MapFileError;
use crate::io::table::{CsvTable, Header, UnknownColumns};
use crate::model::kinematic::Kinematics;
use crate::model::topology::Topology;
use std::collections::BTreeMap;
use volcomp_gcode::Vec3;

/// The `model` value of a thermal model file.
pub const THERMAL_KIND: &str = "volcomp-thermal-1";

fn err(file: &str, row: usize, column: usize, message: String, help: &str) -> MapFileError {
    MapFileError::new(file, row, column, message, help)
}

/// Reads a thermal CSV whose header must name `required` (any order);
/// returns the table and the required columns' indices. With `others`
/// false, any other column is refused.
fn parse_csv<'a>(
    text: &'a str,
    file: &str,
    required: &[&str],
    others: bool,
) -> Result<(CsvTable<'a>, Vec<usize>), MapFileError> {
    let layout = required.join(",");
    let t = CsvTable::parse(
        text,
        file,
        &Header {
            known: required,
            unknown: if others {
                UnknownColumns::Keep
            } else {
                UnknownColumns::Refuse
            },
            layout: &layout,
        },
    )?;
    let cols = required
        .iter()
        .map(|r| t.require(r))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((t, cols))
}

/// Reads the artifact definition.
pub fn parse_artifact(text: &str, file: &str) -> Result<BallArray, MapFileError> {
    let (csv, c) = parse_csv(text, file, &["sphere", "distance_mm"], false)?;
    let mut d = Vec::new();
    for r in csv.records()? {
        let sphere = csv.index(r, c[0])?;
        if sphere != d.len() + 1 {
            return Err(csv.error(
                r,
                c[0],
                format!("sphere {sphere} where sphere {} was expected", d.len() + 1),
                "number the spheres 1, 2, 3 … in order",
            ));
        }
        let v = csv.number(r, c[1])?;
        let ok = if d.is_empty() {
            v == 0.0
        } else {
            v > d[d.len() - 1]
        };
        if !ok {
            return Err(csv.error(
                r,
                c[1],
                format!("distance {v} mm is not valid here"),
                "sphere 1 has distance 0; the others strictly increasing distances from sphere 1",
            ));
        }
        d.push(v);
    }
    if d.len() < 3 {
        return Err(err(
            file,
            csv.last_line(),
            1,
            format!("{} spheres", d.len()),
            "a ball array needs at least 3 spheres",
        ));
    }
    Ok(BallArray { distances_mm: d })
}

/// One measurement cycle: its number, time and the measured placements
/// (in order of placement label).
#[derive(Debug, Clone, PartialEq)]
pub struct Cycle {
    /// Cycle number as in the file.
    pub cycle: usize,
    /// Time (h).
    pub time_h: f64,
    /// Placements, ordered by label.
    pub placements: Vec<PlacementMeasurement>,
}

/// Reads measured sphere centres grouped by cycle (ordered by cycle number).
pub fn parse_measurements(
    text: &str,
    file: &str,
    array: &BallArray,
) -> Result<Vec<Cycle>, MapFileError> {
    let (csv, c) = parse_csv(
        text,
        file,
        &[
            "cycle",
            "time_h",
            "placement",
            "sphere",
            "x_mm",
            "y_mm",
            "z_mm",
        ],
        false,
    )?;
    type Spheres = BTreeMap<usize, (usize, Vec3)>;
    let mut cycles: BTreeMap<usize, (f64, usize, BTreeMap<String, Spheres>)> = BTreeMap::new();
    for r in csv.records()? {
        let row = &r.line;
        let cycle = csv.index(r, c[0])?;
        let time = csv.number(r, c[1])?;
        let sphere = csv.index(r, c[3])?;
        if sphere == 0 || sphere > array.len() {
            return Err(csv.error(
                r,
                c[3],
                format!(
                    "sphere {sphere} does not exist: the artifact has {}",
                    array.len()
                ),
                "number spheres from 1 as in the artifact file",
            ));
        }
        let mut p = Vec3::ZERO;
        for k in 0..3 {
            p[k] = csv.number(r, c[4 + k])?;
        }
        let entry = cycles.entry(cycle).or_insert((time, *row, BTreeMap::new()));
        if entry.0 != time {
            return Err(csv.error(
                r,
                c[1],
                format!(
                    "cycle {cycle} has time {time} h here but {} h on line {}",
                    entry.0, entry.1
                ),
                "give every row of a cycle the same time_h",
            ));
        }
        let label = csv.text(r, c[2]).to_string();
        let spheres = entry.2.entry(label.clone()).or_default();
        if let Some((first, _)) = spheres.insert(sphere, (*row, p)) {
            return Err(csv.error(
                r,
                c[3],
                format!("sphere {sphere} of placement {label} in cycle {cycle} again (first on line {first})"),
                "give each sphere once per placement and cycle",
            ));
        }
    }
    let mut out = Vec::new();
    for (cycle, (time_h, row, placements)) in cycles {
        let mut list = Vec::new();
        for (label, spheres) in placements {
            if spheres.len() != array.len() {
                let missing = (1..=array.len())
                    .find(|s| !spheres.contains_key(s))
                    .unwrap_or(0);
                return Err(err(
                    file,
                    row,
                    4,
                    format!("cycle {cycle}, placement {label}: sphere {missing} is missing"),
                    "measure every sphere of the artifact in every placement",
                ));
            }
            list.push(PlacementMeasurement {
                centres_mm: spheres.values().map(|(_, p)| *p).collect(),
            });
        }
        out.push(Cycle {
            cycle,
            time_h,
            placements: list,
        });
    }
    if out.is_empty() {
        return Err(err(
            file,
            1,
            1,
            "no measurements".into(),
            "add rows below the header",
        ));
    }
    Ok(out)
}

/// Temperatures per cycle.
#[derive(Debug, Clone, PartialEq)]
pub struct Temperatures {
    /// Sensor names (header).
    pub sensors: Vec<String>,
    /// Cycle numbers.
    pub cycles: Vec<usize>,
    /// Times (h).
    pub time_h: Vec<f64>,
    /// `values[t][s]` in °C.
    pub values: Vec<Vec<f64>>,
}

impl Temperatures {
    /// The row of `cycle` in the file named `file`, or the last row without
    /// a cycle (the latest moment).
    pub fn row_of(&self, cycle: Option<usize>, file: &str) -> Result<usize, ThermalError> {
        match cycle {
            None => Ok(self.values.len().saturating_sub(1)),
            Some(c) => {
                self.cycles
                    .iter()
                    .position(|&k| k == c)
                    .ok_or_else(|| ThermalError::NoSuchCycle {
                        file: file.to_string(),
                        cycle: c,
                        first: self.cycles.first().copied().unwrap_or(0),
                        last: self.cycles.last().copied().unwrap_or(0),
                    })
            }
        }
    }
}

/// The temperatures a sensor of a machine tool can read, °C: from a cold
/// hall in winter to a spindle motor's winding at its limit (insulation
/// class H: 180 °C), with room. A value outside is a sensor fault, a wrong
/// unit or a wrong column, and is refused at its row and column.
pub const TEMPERATURE_RANGE_C: [f64; 2] = [-50.0, 200.0];

/// Reads a temperature file (rows in time order; every value within
/// [`TEMPERATURE_RANGE_C`]).
pub fn parse_temperatures(text: &str, file: &str) -> Result<Temperatures, MapFileError> {
    let (csv, c) = parse_csv(text, file, &["cycle", "time_h"], true)?;
    let sensor_cols: Vec<usize> = (0..csv.header.len()).filter(|k| !c.contains(k)).collect();
    if sensor_cols.is_empty() {
        return Err(err(
            file,
            csv.header_line,
            csv.header.len() + 1,
            "no sensor columns".into(),
            "add one column per sensor after cycle,time_h, e.g. spindle_C",
        ));
    }
    for &k in &sensor_cols {
        sensor_unit(&csv, k)?;
    }
    let mut t = Temperatures {
        sensors: sensor_cols.iter().map(|&k| csv.header[k].clone()).collect(),
        cycles: Vec::new(),
        time_h: Vec::new(),
        values: Vec::new(),
    };
    for r in csv.records()? {
        let cycle = csv.index(r, c[0])?;
        let time = csv.number(r, c[1])?;
        if t.time_h.last().is_some_and(|&last| time <= last) {
            return Err(csv.error(
                r,
                c[1],
                format!("time {time} h does not increase"),
                "sort the rows by time, one row per cycle",
            ));
        }
        let mut v = Vec::new();
        for &k in &sensor_cols {
            let value = csv.number(r, k)?;
            if !(TEMPERATURE_RANGE_C[0]..=TEMPERATURE_RANGE_C[1]).contains(&value) {
                return Err(csv.error(
                    r,
                    k,
                    format!(
                        "{value} °C is not a temperature of a machine tool ({} … {} °C)",
                        TEMPERATURE_RANGE_C[0], TEMPERATURE_RANGE_C[1]
                    ),
                    "check the sensor (a fault reads far off), the unit (kelvin are 273 more than °C) and the column",
                ));
            }
            v.push(value);
        }
        t.cycles.push(cycle);
        t.time_h.push(time);
        t.values.push(v);
    }
    if t.values.is_empty() {
        return Err(err(
            file,
            csv.header_line,
            1,
            "no temperatures".into(),
            "add one row per cycle",
        ));
    }
    Ok(t)
}

/// Checks that sensor column `k` says its unit: `<name>_C` (°C). Other
/// units are refused rather than converted or guessed.
fn sensor_unit(csv: &CsvTable, k: usize) -> Result<(), MapFileError> {
    let name = &csv.header[k];
    let at = |message: String, help: &str| csv.error_at(csv.header_line, k, message, help);
    match name.rsplit_once('_').map(|(_, u)| u) {
        Some("c") => Ok(()),
        Some("k" | "f" | "degf") => Err(at(
            format!("sensor column `{name}` is not in °C"),
            "convert the temperatures to degrees Celsius and name the column <name>_C",
        )),
        _ => Err(at(
            format!("sensor column `{name}` does not say its unit"),
            "name every sensor column with its unit, e.g. spindle_C for °C: volcomp never guesses a unit",
        )),
    }
}

/// One parameter in a thermal model file. Values are in `unit` (`um` for
/// linear components, `urad` for angles and squareness).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ParamFit {
    /// Parameter name, e.g. `EXX.P1`.
    pub name: String,
    /// `um` or `urad`.
    pub unit: String,
    /// Regression intercept (unit).
    pub intercept: f64,
    /// Slopes (unit per kelvin) per sensor, lag 0 first, then lag 1 …
    pub per_kelvin: Vec<f64>,
    /// RMS of the regression residuals (unit).
    pub residual_rms: f64,
    /// Identified value per cycle (unit).
    pub identified: Vec<f64>,
    /// Standard uncertainty of the identified value per cycle (unit).
    pub sigma: Vec<f64>,
}

/// The thermal model file (TOML).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ThermalModelFile {
    /// Always [`THERMAL_KIND`].
    pub model: String,
    /// Kinematic chain, e.g. `w X' Y' b Z t`.
    pub chain: String,
    /// Axis ranges `[lo, hi]` (mm) the polynomials are defined on.
    pub ranges_mm: [[f64; 2]; 3],
    /// Maximum Legendre order.
    pub order: usize,
    /// Tool length offset of the probe (mm), also the measuring tool length
    /// of the written 21-component models.
    pub probe_length_mm: f64,
    /// Temperature sensor names, in regressor order.
    pub sensors: Vec<String>,
    /// Number of lagged cycles in the regression.
    pub lags: usize,
    /// Points per component table in predicted models.
    pub table_samples: usize,
    /// Cycle times (h) of the training data.
    pub time_h: Vec<f64>,
    /// Training temperatures per cycle (°C), `temperatures_c[t][s]`.
    pub temperatures_c: Vec<Vec<f64>>,
    /// Estimated probing noise per cycle (µm).
    pub sigma0_um: Vec<f64>,
    /// Parameters the artifact placements cannot identify: no values, zero
    /// in predicted models.
    pub unidentifiable: Vec<String>,
    /// The identifiable parameters.
    pub params: Vec<ParamFit>,
}

/// Options of [`fit`].
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Kinematic chain text, e.g. `w X' Y' b Z t`.
    pub chain: String,
    /// Axis ranges (mm).
    pub ranges_mm: [[f64; 2]; 3],
    /// Maximum Legendre order.
    pub order: usize,
    /// Probe tool length offset (mm).
    pub probe_length_mm: f64,
    /// Lagged cycles in the regression.
    pub lags: usize,
    /// Relative singular-value threshold.
    pub relative_threshold: f64,
    /// Points per table in predicted models.
    pub table_samples: usize,
}

/// Most Legendre order of a thermal model's components (the work and the
/// observations it needs grow with it; measured drifts are smooth: the
/// published study uses order 2).
pub const MAX_ORDER: usize = 10;

/// Most lagged cycles of a regression.
pub const MAX_LAGS: usize = 100;

/// Points per component table of a predicted model: 2 to 10 000.
pub const TABLE_SAMPLES: [usize; 2] = [2, 10_000];

impl FitOptions {
    /// Checks the options before any file is read or any work done: the
    /// order (≤ [`MAX_ORDER`]), the lags (≤ [`MAX_LAGS`]), the points per
    /// table ([`TABLE_SAMPLES`]), the threshold (0 … 1), the ranges
    /// (finite, increasing) and the probe length (finite). The message
    /// starts with the option's name.
    pub fn check(&self) -> Result<(), ThermalError> {
        self.problem()
            .map_err(|(name, problem)| ThermalError::Invalid(format!("{name} {problem}")))
    }

    /// The first option that cannot be used: its name and what is wrong
    /// (words that follow the name: `must be …`).
    pub fn problem(&self) -> Result<(), (&'static str, String)> {
        self.size_problem()?;
        if !(self.relative_threshold > 0.0 && self.relative_threshold < 1.0) {
            return Err((
                "threshold",
                format!(
                    "must be a relative threshold between 0 and 1 (default {}); got {}",
                    super::identify::DEFAULT_RELATIVE_THRESHOLD,
                    self.relative_threshold
                ),
            ));
        }
        if self.ranges_mm.iter().flatten().any(|v| !v.is_finite())
            || self.ranges_mm.iter().any(|[lo, hi]| lo >= hi)
        {
            return Err((
                "ranges_mm",
                format!(
                    "must be three increasing ranges of finite numbers (x0 < x1); got {:?}",
                    self.ranges_mm
                ),
            ));
        }
        if !self.probe_length_mm.is_finite() {
            return Err((
                "probe_length_mm",
                "must be a finite length in mm".to_string(),
            ));
        }
        Ok(())
    }

    /// The bounds on the sizes of the work (order, lags, table points).
    fn size_problem(&self) -> Result<(), (&'static str, String)> {
        if self.order > MAX_ORDER {
            return Err((
                "order",
                format!(
                    "must be at most {MAX_ORDER}, the highest Legendre order volcomp fits; got {}: measured thermal drifts are smooth, order 2 (the default) to 4 describes them",
                    self.order
                ),
            ));
        }
        if self.lags > MAX_LAGS {
            return Err((
                "lags",
                format!(
                    "must be at most {MAX_LAGS}; got {}: a regression with more lagged cycles has more unknowns than a measurement campaign has cycles",
                    self.lags
                ),
            ));
        }
        let [lo, hi] = TABLE_SAMPLES;
        if !(lo..=hi).contains(&self.table_samples) {
            return Err((
                "table_samples",
                format!(
                    "must be {lo} to {hi} (points per component table of a predicted model; the default is 61); got {}",
                    self.table_samples
                ),
            ));
        }
        Ok(())
    }
}

/// The polynomial model of a chain, ranges, order and probe length.
pub fn poly_model(
    chain: &str,
    ranges_mm: [[f64; 2]; 3],
    order: usize,
    probe_length_mm: f64,
) -> Result<PolyModel, ThermalError> {
    let topology: Topology = chain.parse().map_err(ThermalError::Chain)?;
    for (a, r) in ranges_mm.iter().enumerate() {
        if !(r[0].is_finite() && r[1].is_finite() && r[1] > r[0]) {
            return Err(ThermalError::Invalid(format!(
                "the range of axis {} is {}…{} mm: give lo < hi",
                ['X', 'Y', 'Z'][a],
                r[0],
                r[1]
            )));
        }
    }
    if !(1..=8).contains(&order) {
        return Err(ThermalError::Invalid(format!(
            "Legendre order {order}: use 1 … 8 (2 is the default)"
        )));
    }
    if !probe_length_mm.is_finite() {
        return Err(ThermalError::Invalid(
            "the probe length is not finite".into(),
        ));
    }
    let mut k = Kinematics::new(topology);
    for m in &mut k.measuring {
        m.tool_offset_mm = Vec3::new(0.0, 0.0, probe_length_mm);
    }
    Ok(PolyModel::new(k, ranges_mm, order))
}

/// Identifies every cycle and fits the regression: the thermal model file
/// and the per-cycle identifications (in cycle order).
pub fn fit(
    array: &BallArray,
    cycles: &[Cycle],
    temps: &Temperatures,
    temps_file: &str,
    o: &FitOptions,
) -> Result<(ThermalModelFile, Vec<Identification>), ThermalError> {
    o.check()?;
    let model = poly_model(&o.chain, o.ranges_mm, o.order, o.probe_length_mm)?;
    let probe = Vec3::new(0.0, 0.0, o.probe_length_mm);
    let mut idents = Vec::new();
    let mut t_rows = Vec::new();
    for c in cycles {
        for (p, pm) in c.placements.iter().enumerate() {
            for (j, q) in pm.centres_mm.iter().enumerate() {
                for a in 0..3 {
                    let [lo, hi] = o.ranges_mm[a];
                    if q[a] < lo - 1.0 || q[a] > hi + 1.0 {
                        return Err(ThermalError::OutsideRange(super::OutsideRange {
                            cycle: c.cycle,
                            placement: p + 1,
                            sphere: j + 1,
                            axis: ['X', 'Y', 'Z'][a],
                            value_mm: q[a],
                            range_mm: [lo, hi],
                        }));
                    }
                }
            }
        }
        let row = temps
            .cycles
            .iter()
            .position(|&k| k == c.cycle)
            .ok_or_else(|| {
                ThermalError::Invalid(format!(
                    "{temps_file}: no temperatures for measurement cycle {} — add a row `{},{},…`",
                    c.cycle, c.cycle, c.time_h
                ))
            })?;
        let id =
            identify(&model, array, &c.placements, probe, o.relative_threshold).map_err(|e| {
                ThermalError::Cycle {
                    cycle: c.cycle,
                    source: Box::new(e),
                }
            })?;
        idents.push(id);
        t_rows.push(temps.values[row].clone());
    }
    let ident: Vec<usize> = (0..model.len())
        .filter(|&i| idents.iter().all(|id| id.theta[i].is_some()))
        .collect();
    let outputs: Vec<Vec<f64>> = idents
        .iter()
        .map(|id| ident.iter().map(|&i| id.theta[i].unwrap_or(0.0)).collect())
        .collect();
    let reg = Regression::fit(&t_rows, &outputs, o.lags)?;
    let params = ident
        .iter()
        .enumerate()
        .map(|(k, &i)| ParamFit {
            name: model.params[i].name(),
            unit: model.params[i].unit().into(),
            intercept: reg.coefficients[k][0],
            per_kelvin: reg.coefficients[k][1..].to_vec(),
            residual_rms: reg.residual_rms[k],
            identified: outputs.iter().map(|o| o[k]).collect(),
            sigma: idents
                .iter()
                .map(|id| id.sigma[i].unwrap_or(f64::NAN))
                .collect(),
        })
        .collect();
    let file = ThermalModelFile {
        model: THERMAL_KIND.into(),
        chain: o.chain.clone(),
        ranges_mm: o.ranges_mm,
        order: o.order,
        probe_length_mm: o.probe_length_mm,
        sensors: temps.sensors.clone(),
        lags: o.lags,
        table_samples: o.table_samples,
        time_h: cycles.iter().map(|c| c.time_h).collect(),
        temperatures_c: t_rows,
        sigma0_um: idents
            .iter()
            .map(|id| id.sigma0_um.unwrap_or(f64::NAN))
            .collect(),
        unidentifiable: (0..model.len())
            .filter(|i| !ident.contains(i))
            .map(|i| model.params[i].name())
            .collect(),
        params,
    };
    Ok((file, idents))
}

impl ThermalModelFile {
    /// Reads the TOML text.
    pub fn from_toml(text: &str, file: &str) -> Result<Self, ThermalError> {
        let m: ThermalModelFile = toml::from_str(text).map_err(|e| {
            let (row, column) = e.span().map_or((1, 1), |s| {
                let before = &text[..s.start.min(text.len())];
                let row = before.matches('\n').count() + 1;
                let col = before.len() - before.rfind('\n').map_or(0, |p| p + 1) + 1;
                (row, col)
            });
            ThermalError::File(err(
                file,
                row,
                column,
                e.message().to_string(),
                "write the file with `volcomp thermal fit`",
            ))
        })?;
        if m.model != THERMAL_KIND {
            return Err(ThermalError::File(err(
                file,
                1,
                1,
                format!("model = \"{}\" is not a thermal model", m.model),
                &format!("a thermal model file has model = \"{THERMAL_KIND}\""),
            )));
        }
        m.check_values(text, file)?;
        Ok(m)
    }

    /// Refuses a value the model cannot be used with, at its row and
    /// column: a number that is not finite where every prediction uses it
    /// (the ranges, the probe length, a parameter's intercept or slopes,
    /// the training temperatures and times: `nan` would be written into
    /// every table), and a size beyond the bounds of [`FitOptions::check`].
    /// The uncertainties may be `nan` (a parameter unidentified in a cycle).
    fn check_values(&self, text: &str, file: &str) -> Result<(), ThermalError> {
        use crate::io::located::{key_error, Scope};
        let bad = |scope: Scope<'_>, key: &str, what: String, help: &str| {
            ThermalError::File(key_error(file, text, scope, key, what, help))
        };
        let finite = "write a finite number (the file as `volcomp thermal fit` wrote it has one)";
        if self.ranges_mm.iter().flatten().any(|v| !v.is_finite())
            || self.ranges_mm.iter().any(|[lo, hi]| lo >= hi)
        {
            return Err(bad(
                Scope::Top,
                "ranges_mm",
                format!(
                    "ranges_mm {:?} are not three increasing ranges of finite numbers",
                    self.ranges_mm
                ),
                "give [[x0, x1], [y0, y1], [z0, z1]] in mm, each with x0 < x1",
            ));
        }
        if !self.probe_length_mm.is_finite() {
            return Err(bad(
                Scope::Top,
                "probe_length_mm",
                format!(
                    "probe_length_mm = {} is not a finite number",
                    self.probe_length_mm
                ),
                finite,
            ));
        }
        if self.time_h.iter().any(|v| !v.is_finite()) {
            return Err(bad(
                Scope::Top,
                "time_h",
                "time_h holds a value that is not a finite number".into(),
                finite,
            ));
        }
        if self.temperatures_c.iter().flatten().any(|v| !v.is_finite()) {
            return Err(bad(
                Scope::Top,
                "temperatures_c",
                "temperatures_c holds a value that is not a finite number".into(),
                finite,
            ));
        }
        for (k, p) in self.params.iter().enumerate() {
            if !p.intercept.is_finite() {
                return Err(bad(
                    Scope::Entry("params", k),
                    "intercept",
                    format!(
                        "parameter {}: intercept = {} is not a finite number",
                        p.name, p.intercept
                    ),
                    finite,
                ));
            }
            if p.per_kelvin.iter().any(|v| !v.is_finite()) {
                return Err(bad(
                    Scope::Entry("params", k),
                    "per_kelvin",
                    format!(
                        "parameter {}: per_kelvin holds a value that is not a finite number",
                        p.name
                    ),
                    finite,
                ));
            }
        }
        let sizes = FitOptions {
            chain: self.chain.clone(),
            ranges_mm: self.ranges_mm,
            order: self.order,
            probe_length_mm: self.probe_length_mm,
            lags: self.lags,
            relative_threshold: 0.5,
            table_samples: self.table_samples,
        };
        if let Err((key, problem)) = sizes.size_problem() {
            return Err(bad(
                Scope::Top,
                key,
                format!(
                    "{key} = {} {problem}",
                    match key {
                        "order" => self.order,
                        "lags" => self.lags,
                        _ => self.table_samples,
                    }
                ),
                "write the file again with `volcomp thermal fit`",
            ));
        }
        Ok(())
    }

    /// Writes the TOML text.
    pub fn to_toml(&self) -> String {
        let body = toml::to_string(self).unwrap_or_else(|e| format!("# cannot serialise: {e}\n"));
        format!(
            "# volcomp thermal model (docs/thermal.md): parameters of the 21-component model with\n\
             # Legendre-polynomial components, regressed on temperatures. Per parameter: intercept\n\
             # (its unit), per_kelvin (unit/K per sensor, lag 0 first), identified values and sigma\n\
             # per training cycle. unit is um for linear components, urad for angles/squareness.\n{body}"
        )
    }

    /// The polynomial model the file describes.
    pub fn poly_model(&self) -> Result<PolyModel, ThermalError> {
        poly_model(
            &self.chain,
            self.ranges_mm,
            self.order,
            self.probe_length_mm,
        )
    }

    /// Predicted parameters (full vector, `None` for the unidentifiable) at
    /// row `row` of `temps` (its sensors must match the model's by name).
    /// Temperatures outside the training range are refused
    /// ([`super::checks::check_training_range`]).
    pub fn predict(
        &self,
        temps: &Temperatures,
        temps_file: &str,
        row: usize,
    ) -> Result<Vec<Option<f64>>, ThermalError> {
        if temps.sensors == self.sensors {
            super::checks::check_training_range(self, temps, temps_file, row)?;
        }
        self.predict_extrapolating(temps, temps_file, row)
    }

    /// As [`Self::predict`], but without refusing temperatures outside the
    /// training range (the caller has asked to extrapolate).
    pub fn predict_extrapolating(
        &self,
        temps: &Temperatures,
        temps_file: &str,
        row: usize,
    ) -> Result<Vec<Option<f64>>, ThermalError> {
        if temps.sensors != self.sensors {
            return Err(ThermalError::Invalid(format!(
                "{temps_file}: sensors {:?}, the model was fitted on {:?} — give the same columns in the same order",
                temps.sensors, self.sensors
            )));
        }
        if row < self.lags {
            return Err(ThermalError::Invalid(format!(
                "{temps_file}: the model uses {} lagged cycles; give at least {} rows up to the moment",
                self.lags,
                self.lags + 1
            )));
        }
        let model = self.poly_model()?;
        let mut theta = vec![None; model.len()];
        let f = features(&temps.values, row, self.lags).unwrap_or_default();
        for p in &self.params {
            let i = model.index(&p.name).ok_or_else(|| {
                ThermalError::Invalid(format!("unknown parameter `{}` in the model", p.name))
            })?;
            if p.per_kelvin.len() + 1 != f.len() {
                return Err(ThermalError::Invalid(format!(
                    "parameter `{}` has {} slopes, expected {}",
                    p.name,
                    p.per_kelvin.len(),
                    f.len() - 1
                )));
            }
            theta[i] = Some(
                p.intercept
                    + p.per_kelvin
                        .iter()
                        .zip(&f[1..])
                        .map(|(b, t)| b * t)
                        .sum::<f64>(),
            );
        }
        Ok(theta)
    }

    /// The 21-component model files `(toml, csv)` for parameters `theta`,
    /// the TOML naming `tables` as its CSV.
    pub fn model_files(
        &self,
        theta: &[Option<f64>],
        tables: &str,
        description: &str,
    ) -> Result<(String, String), ThermalError> {
        let model = self.poly_model()?;
        let km = model.to_kinematic_model(theta, self.table_samples.max(2));
        Ok((
            crate::io::model_file::model_to_toml(&km, tables, Some(description)),
            crate::io::model_file::components_to_csv(&km.axes),
        ))
    }
}
