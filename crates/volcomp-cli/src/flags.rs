//! The library's messages speak of options ("the largest accepted
//! correction"); the command line says them with its flags
//! (`--max-correction`). This is the one place that maps the one to the
//! other.

use volcomp_core::error::{help, CompensationError};
use volcomp_core::request::OptionError;
use volcomp_core::surface::mirror::MirrorError;
use volcomp_core::Error;
use volcomp_gcode::interp::{K0_HELP, PROGRAM_END_HELP};

/// Each library help text that names an option, with the CLI's wording.
const HELP: [(&str, &str); 6] = [
    (
        help::SPLIT_UNDER_INVERSE_TIME,
        "pass --no-split for straight moves, or post the program in G94 (units per minute)",
    ),
    (
        help::TOO_MANY_POINTS,
        "split the move in the program, or pass a coarser --segment-length, --segments, --chord-tolerance or --min-segment-length",
    ),
    (
        help::CORRECTION_LIMIT,
        "check that the map is in µm (not mm) and belongs to this machine; raise --max-correction only if the machine really is this far off",
    ),
    (
        help::RESIDUAL_LIMIT,
        "with ILC raise the iteration limit or the gain; check that the map is smooth and in µm; the residual limit is an option (--max-residual-um)",
    ),
    (
        help::REFERENCE_PAIRING,
        "pass as --reference the original program this one was compensated from by volcomp (its `(volcomp Ln)` comments pair the two; a program written with --no-trace cannot be paired once lines were split or take-ups inserted)",
    ),
    (
        help::REFERENCE_LEFT,
        "pass as --reference the original program this one was compensated from, and simulate the whole compensated program",
    ),
];

/// The compensation error inside `e`, if any.
fn compensation<'e>(e: &'e (dyn std::error::Error + 'static)) -> Option<&'e CompensationError> {
    if let Some(c) = e.downcast_ref::<CompensationError>() {
        return Some(c);
    }
    match e.downcast_ref::<Error>() {
        Some(Error::Compensation(c)) => return Some(c),
        Some(Error::Mirror(MirrorError::Program(c))) => return Some(c),
        _ => {}
    }
    match e.downcast_ref::<MirrorError>() {
        Some(MirrorError::Program(c)) => Some(c),
        _ => None,
    }
}

/// `e`'s text with the options it names said as the CLI's flags, when it
/// names any (`None`: the library's text stands).
pub fn reword(e: &(dyn std::error::Error + 'static)) -> Option<String> {
    let option = match e.downcast_ref::<Error>() {
        Some(Error::Option(o)) => Some(o),
        _ => e.downcast_ref::<OptionError>(),
    };
    if let Some(o) = option {
        return Some(o.render(&crate::options::Flags));
    }
    let text = e.to_string();
    if text.ends_with(PROGRAM_END_HELP) {
        return Some(format!(
            "{text}, or pass --allow-no-program-end if the controller runs programs without one"
        ));
    }
    if text.ends_with(K0_HELP) {
        return Some(text.replacen(
            "or accept K0 on XY arcs in the options",
            "or pass --accept-k0",
            1,
        ));
    }
    if let Some(Error::AlreadyCompensated { .. }) = e.downcast_ref::<Error>() {
        return Some(e.to_string().replacen(
            "or allow recompensation if",
            "or pass --allow-recompensate if",
            1,
        ));
    }
    if let Some(CompensationError::AtLine { help, .. }) = compensation(e) {
        if let Some((lib, cli)) = HELP.iter().find(|(lib, _)| lib == help) {
            return Some(e.to_string().replacen(lib, cli, 1));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

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
            "p.ngc:4: too far\n  help: check that the map is in µm (not mm) and belongs to this machine; raise --max-correction only if the machine really is this far off"
        );
    }

    #[test]
    fn other_messages_stand() {
        let e = CompensationError::AtLine {
            file: "p.ngc".into(),
            line: 4,
            message: "m".into(),
            help: "h".into(),
        };
        assert_eq!(reword(&e), None);
    }
}
