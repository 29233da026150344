//! `volcomp map export --to FORMAT`: the library's controller writers
//! (`volcomp_core::io::controllers`), their notes and rounding printed.

use super::{
    load_map, positioning_tables, positive_step, write_text, ExportArgs, ExportFormat, Map,
};
use super::{CecSignArg, FanucBidirectionalArg, FanucReturnArg, FanucSignArg};
use crate::output::{check, CliError, OutputPlan};
use std::io::Write;
use volcomp_core::io::controllers::{self, siemens, Export, Positioning};

/// The machine axis names of `--axis-names`.
fn axis_names(text: &str) -> Result<[String; 3], CliError> {
    let names: Vec<String> = text.split(',').map(|n| n.trim().to_string()).collect();
    match names.as_slice() {
        [x, y, z] => Ok([x.clone(), y.clone(), z.clone()]),
        _ => Err(CliError::Message(format!(
            "--axis-names takes three machine axis names, e.g. X1,Y1,Z1; got `{text}`"
        ))),
    }
}

/// The straightness tables of a map that are not zero: `(axis, direction, E_da)`.
fn straightness_tables(map: &Map) -> Vec<(usize, usize, Positioning)> {
    use volcomp_core::model::axis_table::Table;
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
                Map::Tables(t) => pair(&t.axes[a].forward, &t.axes[a].reverse, d),
                Map::Kinematic(m) => pair(
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

/// The tables resampled every `step` mm when a step is given.
fn stepped(tables: [Positioning; 3], step: Option<f64>) -> Result<[Positioning; 3], CliError> {
    let Some(s) = step else {
        return Ok(tables);
    };
    // Checked before any table is built: a step of a nanometre over a
    // metre would be a billion points.
    let max = volcomp_core::limits::MAX_RESAMPLED_POINTS;
    for t in &tables {
        let n = t.resampled_points(s).unwrap_or(u64::MAX);
        if n > max {
            return Err(CliError::Message(format!(
                "--step {s} mm gives {n} table points over {:.3} … {:.3} mm, more than the {max} a table may have: choose a larger step",
                t.positions_mm.first().copied().unwrap_or(0.0),
                t.positions_mm.last().copied().unwrap_or(0.0),
            )));
        }
    }
    Ok(tables.map(|p| p.resample(s)))
}

pub fn export(a: ExportArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.map_input("MAP", &a.map);
    let names: &[&str] = match a.to {
        ExportFormat::Linuxcnc => &["x.comp", "y.comp", "z.comp", "comp.ini"],
        ExportFormat::SiemensEec => &["%_N_AX_EEC_INI"],
        ExportFormat::SiemensCec => &["%_N_NC_CEC_INI"],
        ExportFormat::Heidenhain => &["X.COM", "Y.COM", "Z.COM", "VOLCOMP.CMA"],
        ExportFormat::IsgSsfk => &["achskw_x.lis", "achskw_y.lis", "achskw_z.lis"],
        ExportFormat::IsgCsv => &["volcomp.csv", "volcomp.lis"],
        ExportFormat::Fanuc => &["pitch.tap"],
        ExportFormat::Klipper => &["skew_correction.cfg"],
        ExportFormat::Marlin => &["skew.gcode"],
        ExportFormat::Rrf => &["m556.g"],
        ExportFormat::Grblhal => &["backlash.txt"],
    };
    // The sign check on the machine, for the formats whose sign no vendor
    // text settles (controllers::signcheck).
    let checks: &[&str] = match a.to {
        ExportFormat::SiemensCec => &["sign_check.txt", "SIGNCHECK.MPF"],
        ExportFormat::Fanuc | ExportFormat::IsgCsv => &["sign_check.txt", "signcheck.nc"],
        ExportFormat::Heidenhain => &["sign_check.txt", "SIGNCHECK.H"],
        _ => &[],
    };
    for n in names.iter().chain(checks) {
        plan.output(format!("-o (its {n})"), a.output.join(n));
    }
    check(&plan)?;
    let map = load_map(&a.map, false)?;
    let step = positive_step(a.step)?;
    let form = a.form.into();
    let e: Export = match a.to {
        ExportFormat::Grblhal => {
            let t = positioning_tables(&map, a.at.as_deref(), &a.tool, form)?;
            controllers::grbl::export(&t.map(Some), a.homing_dir_mask)?
        }
        ExportFormat::Klipper | ExportFormat::Marlin | ExportFormat::Rrf => {
            let Map::Kinematic(m) = &map else {
                return Err(CliError::Message(format!(
                    "{}: axis tables hold no squareness; export the skew of a 21-component model (map convert --to model, then set [squareness_urad])",
                    a.map.display()
                )));
            };
            let s = &m.kinematics.squareness;
            let sq = [s.xy_urad, s.yz_urad, s.zx_urad];
            match a.to {
                ExportFormat::Klipper => controllers::skew::klipper(sq, &a.profile)?,
                ExportFormat::Marlin => controllers::skew::marlin(sq)?,
                _ => controllers::skew::rrf(sq)?,
            }
        }
        ExportFormat::Linuxcnc => {
            use controllers::linuxcnc::LinuxcncExport;
            let (what, units) = if a.backlash_only {
                let units = a.comp.units.ok_or_else(|| {
                    CliError::Message("LinuxCNC's BACKLASH is in machine units: pass --units mm or --units inch as [TRAJ] LINEAR_UNITS says".into())
                })?;
                (LinuxcncExport::BacklashOnly, units.into())
            } else {
                let (ty, units) = a.comp.get()?;
                (LinuxcncExport::CompFiles(ty), units)
            };
            let t = stepped(
                positioning_tables(&map, a.at.as_deref(), &a.tool, form)?,
                step,
            )?;
            controllers::linuxcnc::export(&t.map(Some), what, units)?
        }
        ExportFormat::Fanuc => {
            let Some(step) = step else {
                return Err(CliError::Message("Fanuc pitch error compensation is equidistant: pass --step MM, the interval of its points (parameter 3624)".into()));
            };
            if !(a.detection_unit_um.is_finite() && a.detection_unit_um > 0.0) {
                return Err(CliError::Message(format!(
                    "--detection-unit-um must be positive; got {}",
                    a.detection_unit_um
                )));
            }
            let t = positioning_tables(&map, a.at.as_deref(), &a.tool, form)?;
            let o = controllers::fanuc::FanucOptions {
                step_mm: step,
                detection_unit_um: a.detection_unit_um,
                sign: match a.fanuc_sign {
                    FanucSignArg::Correction => controllers::fanuc::FanucSign::Correction,
                    FanucSignArg::Error => controllers::fanuc::FanucSign::Error,
                },
                data_offset: a.fanuc_data_offset,
                bidirectional: match a.fanuc_bidirectional {
                    FanucBidirectionalArg::Auto => controllers::fanuc::FanucBidirectional::Auto,
                    FanucBidirectionalArg::On => controllers::fanuc::FanucBidirectional::On,
                    FanucBidirectionalArg::Off => controllers::fanuc::FanucBidirectional::Off,
                },
                reference_return: match a.fanuc_reference_return {
                    FanucReturnArg::Positive => controllers::fanuc::FanucReturn::Positive,
                    FanucReturnArg::Negative => controllers::fanuc::FanucReturn::Negative,
                },
                ..controllers::fanuc::FanucOptions::default()
            };
            controllers::fanuc::export(&t.map(Some), &o)?
        }
        ExportFormat::IsgSsfk => {
            let t = stepped(
                positioning_tables(&map, a.at.as_deref(), &a.tool, form)?,
                step,
            )?;
            controllers::isg::ssfk_export(
                &t.map(Some),
                a.max_points.unwrap_or(controllers::isg::SSFK_MAX_POINTS),
            )?
        }
        ExportFormat::IsgCsv => {
            let model = match &map {
                Map::Kinematic(m) => (**m).clone(),
                Map::Tables(t) => volcomp_core::model::kinematic::KinematicModel::from_axis_tables(
                    t,
                    volcomp_core::model::topology::Topology::SEED,
                ),
            };
            controllers::isg::csv_export(&model)
        }
        ExportFormat::Heidenhain => {
            let t = stepped(
                positioning_tables(&map, a.at.as_deref(), &a.tool, form)?,
                step,
            )?;
            controllers::heidenhain::export(&t.map(Some))?
        }
        ExportFormat::SiemensCec => {
            let Some(step) = step else {
                return Err(CliError::Message(
                    "a Siemens CEC table is equidistant: pass --step MM ($AN_CEC_STEP)".into(),
                ));
            };
            let names = axis_names(&a.axis_names)?;
            let o = siemens::EecOptions {
                axis_names: names,
                step_mm: step,
                resolution_um: a.resolution_um,
                max_points: a.max_points.unwrap_or(5000),
                reference: match a.reference_direction {
                    FanucReturnArg::Positive => controllers::ReferenceDirection::Positive,
                    FanucReturnArg::Negative => controllers::ReferenceDirection::Negative,
                },
            };
            let sign = match a.cec_sign {
                CecSignArg::Error => siemens::CecSign::Error,
                CecSignArg::Correction => siemens::CecSign::Correction,
            };
            siemens::cec_export(&straightness_tables(&map), &o, sign)?
        }
        ExportFormat::SiemensEec => {
            let Some(step) = step else {
                return Err(CliError::Message("a Siemens EEC table is equidistant: pass --step MM, the spacing of its interpolation points ($AA_ENC_COMP_STEP)".into()));
            };
            if !(a.resolution_um.is_finite() && a.resolution_um > 0.0) {
                return Err(CliError::Message(format!(
                    "--resolution-um must be positive; got {}",
                    a.resolution_um
                )));
            }
            let names: Vec<String> = a
                .axis_names
                .split(',')
                .map(|n| n.trim().to_string())
                .collect();
            let [x, y, z] = names.as_slice() else {
                return Err(CliError::Message(format!(
                    "--axis-names takes three machine axis names, e.g. X1,Y1,Z1; got `{}`",
                    a.axis_names
                )));
            };
            let t = positioning_tables(&map, a.at.as_deref(), &a.tool, form)?;
            let o = siemens::EecOptions {
                axis_names: [x.clone(), y.clone(), z.clone()],
                step_mm: step,
                resolution_um: a.resolution_um,
                max_points: a.max_points.unwrap_or(5000),
                reference: match a.reference_direction {
                    FanucReturnArg::Positive => controllers::ReferenceDirection::Positive,
                    FanucReturnArg::Negative => controllers::ReferenceDirection::Negative,
                },
            };
            siemens::export(&t.map(Some), &o)?
        }
    };
    // How far the table, as the controller applies it, lies from the map:
    // checked before anything is written.
    use controllers::table_error::{self, um};
    if !(a.max_table_error_um.is_finite() && a.max_table_error_um > 0.0) {
        return Err(CliError::Message(format!(
            "--max-table-error-um must be positive; got {}",
            a.max_table_error_um
        )));
    }
    let err = match a.to {
        ExportFormat::Klipper | ExportFormat::Marlin | ExportFormat::Rrf => {
            use volcomp_core::model::ErrorModel;
            match &map {
                Map::Kinematic(m) => {
                    let s = &m.kinematics.squareness;
                    table_error::squareness_error(
                        [s.xy_urad, s.yz_urad, s.zx_urad],
                        &e.applied,
                        m.range_mm(),
                    )
                }
                Map::Tables(_) => table_error::TableError::default(),
            }
        }
        ExportFormat::SiemensCec => {
            table_error::cross_error(&straightness_tables(&map), &e.applied)
        }
        _ => table_error::table_error(
            &positioning_tables(&map, a.at.as_deref(), &a.tool, form)?.map(Some),
            &e.applied,
            e.holds,
            e.zero_at,
        ),
    };
    let rounding_um = match a.to {
        // µrad over the map's arms: the error itself says it in µm.
        ExportFormat::Klipper | ExportFormat::Marlin | ExportFormat::Rrf => 0.0,
        _ => e.rounding.max_um,
    };
    table_error::check(
        e.applied.format.name(),
        &err,
        rounding_um,
        step,
        a.max_table_error_um,
    )?;
    let checks = if checks.is_empty() {
        Vec::new()
    } else {
        let probes = controllers::signcheck::probes(
            &e,
            &positioning_tables(&map, a.at.as_deref(), &a.tool, form)?.map(Some),
            &straightness_tables(&map),
        );
        controllers::signcheck::files(&e, &probes)
    };
    std::fs::create_dir_all(&a.output).map_err(|err| CliError::Io(a.output.clone(), err))?;
    for f in e.files.iter().chain(&checks) {
        write_text(&a.output.join(&f.name), &[&a.map], &f.text)?;
    }
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    for n in &e.notes {
        writeln!(out, "# {n}").map_err(CliError::Stdout)?;
    }
    let unit = match a.to {
        ExportFormat::Klipper | ExportFormat::Marlin | ExportFormat::Rrf => "µrad",
        _ => "µm",
    };
    crate::note!(
        "volcomp: wrote {} file(s) to {}{}; rounded to the controller's resolution {} {unit}: largest change {} {unit}",
        e.files.len() + checks.len(),
        a.output.display(),
        if checks.is_empty() {
            String::new()
        } else {
            format!(
                " (with {}: check the table's sign on the machine once, as it says)",
                checks[0].name
            )
        },
        um(e.rounding.resolution_um),
        um(e.rounding.max_um)
    );
    let (ax, x, forward) = err.at.unwrap_or((0, 0.0, true));
    crate::note!(
        "volcomp: the table as the controller applies it lies at most {} µm from the map (resampling and rounding; {} at {} mm, {}; exact: checked at every point of the map's and the controller's tables, where the largest difference of two linearly interpolated tables lies); --max-table-error-um allows {}",
        um(err.max_um),
        ["X", "Y", "Z"][ax],
        volcomp_core::io::numfmt::fixed(x, 4),
        if forward { "forward" } else { "reverse" },
        um(a.max_table_error_um)
    );
    if err.left_um > err.max_um {
        crate::note!(
            "volcomp: the controller leaves up to {} µm of the map uncorrected (what the format cannot hold); compensate it with --controller",
            um(err.left_um)
        );
    }
    Ok(())
}
