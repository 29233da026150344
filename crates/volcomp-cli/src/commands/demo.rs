use crate::output::CliError;

pub fn run(_a: crate::args::DemoArgs) -> Result<(), CliError> {
    Err(CliError::Message("not yet".into()))
}
