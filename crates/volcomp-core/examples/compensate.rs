//! Compensates a part program for a machine's measured errors and simulates
//! it before and after, through the library's front door.
//!
//! `cargo run -p volcomp-core --example compensate` (reads the bundled
//! `examples/data/`: the axis-table map, the set-up and the part program).

use std::path::Path;
use volcomp_core::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data");
    let model = load_model(&data.join("map.csv"), &LoadOptions::default())?.into_model();
    let machine = MachineSetup::from_setup_file(&data.join("machine.toml"))?;
    let program = std::fs::read(data.join("part.ngc"))?;

    let mut compensated = Vec::new();
    Compensator::new(model.as_ref())
        .setup(machine.clone())
        .run(program.as_slice(), &mut compensated)?;

    let before = Simulation::new(model.as_ref())
        .setup(machine.clone())
        .run(program.as_slice())?;
    let after = Simulation::new(model.as_ref())
        .setup(machine)
        .reference(program.as_slice())
        .run(compensated.as_slice())?;
    println!(
        "contour error max: {:.3} µm before, {:.3} µm after",
        before.contour_max_um, after.contour_max_um
    );
    assert!(after.contour_max_um < before.contour_max_um / 5.0);
    Ok(())
}

#[cfg(test)]
mod tests {
    /// `cargo test` runs the example, so the front door it shows keeps working.
    #[test]
    fn the_example_runs() {
        super::main().unwrap();
    }
}
