use crate::output::CliError;

pub fn run(_a: crate::args::SimulateArgs) -> Result<(), CliError> {
    Err(CliError::Message("not yet".into()))
}
