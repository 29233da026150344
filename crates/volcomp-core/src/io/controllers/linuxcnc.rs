//! LinuxCNC through `volcomp map export --to linuxcnc`: the comp files of
//! [`crate::io::linuxcnc_comp`] (`x.comp`, `y.comp`, `z.comp`), with the
//! correction LinuxCNC applies from them.

use super::{
    axis_letter, ControllerCorrection, Export, ExportFile, Format, LimitError, Positioning,
    Rounding,
};
use crate::io::linuxcnc_comp::{self, CompFileType, MachineUnits, MAX_ENTRIES};

/// Writes one comp file per axis with a table (LinuxCNC keeps both
/// directions, so nothing is averaged). Values are written with ten
/// decimals of a machine unit: the rounding is reported all the same.
pub fn export(
    p: &[Option<Positioning>; 3],
    ty: CompFileType,
    units: MachineUnits,
) -> Result<Export, LimitError> {
    let mut files = Vec::new();
    let mut applied: [Option<Positioning>; 3] = [None, None, None];
    let mut rounding = Rounding {
        resolution_um: 1e-10 * units.mm_per_unit() * 1e3,
        max_um: 0.0,
    };
    let mut notes = vec![format!(
        "LinuxCNC INI (joints 0, 1, 2 = X, Y, Z with trivkins): COMP_FILE_TYPE = {}; remove BACKLASH, the comp files hold the reversal",
        ty.number()
    )];
    for (a, table) in p.iter().enumerate() {
        let Some(table) = table else { continue };
        let name = format!("{}.comp", axis_letter(a).to_ascii_lowercase());
        let text = linuxcnc_comp::write(table, ty, units).map_err(|e| LimitError {
            format: "linuxcnc",
            axis: axis_letter(a),
            message: e.to_string(),
            help: format!(
                "resample the table with a step of at least {} mm (linear interpolation)",
                crate::io::numfmt::fixed(
                    (table.positions_mm[table.positions_mm.len() - 1] - table.positions_mm[0])
                        / (MAX_ENTRIES - 1) as f64,
                    3
                )
            ),
        })?;
        let back = linuxcnc_comp::parse(&text, &name, ty, units).map_err(|e| LimitError {
            format: "linuxcnc",
            axis: axis_letter(a),
            message: e.to_string(),
            help: "the table cannot be written as a comp file".into(),
        })?;
        for (x, y) in back
            .forward_um
            .iter()
            .chain(&back.reverse_um)
            .zip(table.forward_um.iter().chain(&table.reverse_um))
        {
            rounding.max_um = rounding.max_um.max((x - y).abs());
        }
        notes.push(format!("[JOINT_{a}] COMP_FILE = {name}"));
        applied[a] = Some(back);
        files.push(ExportFile { name, text });
    }
    Ok(Export {
        files,
        applied: ControllerCorrection {
            format: Format::Linuxcnc,
            axes: applied,
            squareness_urad: None,
        },
        rounding,
        notes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_1_by_hand() {
        // e = +2 µm forward, +5 µm reverse at 100 mm → trims −0.002, −0.005 mm.
        let p = Positioning {
            positions_mm: vec![0.0, 100.0],
            forward_um: vec![0.0, 2.0],
            reverse_um: vec![3.0, 5.0],
        };
        let e = export(
            &[None, Some(p.clone()), None],
            CompFileType::Type1,
            MachineUnits::Mm,
        )
        .unwrap();
        assert_eq!(e.files.len(), 1);
        assert_eq!(e.files[0].name, "y.comp");
        assert_eq!(e.files[0].text, "0 0 -0.003\n100 -0.002 -0.005\n");
        assert_eq!(e.applied.axes[1].as_ref(), Some(&p));
        assert!(e.rounding.max_um < 1e-6);
        // LinuxCNC chooses the table by direction: reverse at 50 mm is 4 µm.
        assert!((e.applied.correction_um(1, 50.0, false) - 4.0).abs() < 1e-12);
    }
}
