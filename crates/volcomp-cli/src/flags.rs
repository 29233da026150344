//! The library's messages name options as `{name}`; the command line says
//! them with its flags (`--max-correction`). This is the one place that
//! turns a library error's text into the CLI's words.

use crate::options::{flags, Flags};
use volcomp_core::request::OptionError;
use volcomp_core::Error;

/// `e`'s text with the options it names said as the CLI's flags, when it
/// names any (`None`: the library's text stands).
pub fn reword(e: &(dyn std::error::Error + 'static)) -> Option<String> {
    let option = match e.downcast_ref::<Error>() {
        Some(Error::Option(o)) => Some(o),
        _ => e.downcast_ref::<OptionError>(),
    };
    if let Some(o) = option {
        return Some(o.render(&Flags));
    }
    let text = e.to_string();
    let said = flags(&text);
    (said != text).then_some(said)
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcomp_core::error::{help, CompensationError};

    #[test]
    fn a_located_help_is_said_with_the_flag() {
        let e = Error::from(CompensationError::AtLine {
            file: "p.ngc".into(),
            line: 4,
            message: "too far".into(),
            help: help::CORRECTION_LIMIT.into(),
        });
        assert_eq!(
            reword(&e).unwrap(),
            "p.ngc:4: too far\n  help: check that the map is in µm (not mm) and belongs to this machine; raise the largest accepted correction (--max-correction) only if the machine really is this far off"
        );
    }

    #[test]
    fn other_messages_stand() {
        let e = CompensationError::AtLine {
            file: "p.ngc".into(),
            line: 4,
            message: "m {x}".into(),
            help: "h".into(),
        };
        assert_eq!(reword(&e), None);
    }
}
