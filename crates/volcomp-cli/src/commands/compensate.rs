use crate::output::CliError;

pub fn run(_a: crate::args::CompensateArgs) -> Result<(), CliError> {
    Err(CliError::Message("not yet".into()))
}
