//! The library's request options as clap arguments: each option's flag,
//! placeholder, default and help come from its row in the library's table
//! (`volcomp_core::request`), its value is read by the library, and its
//! name is written as a flag wherever a library text names it ([`Flags`]).

use clap::builder::{PossibleValue, TypedValueParser};
use clap::error::{ContextKind, ContextValue, ErrorKind};
use clap::parser::ValueSource;
use clap::{Arg, ArgAction, ArgMatches, Args, Command, FromArgMatches};
use std::ffi::OsStr;
use volcomp_core::request::{self, did_you_mean, Kind, OptionInfo, Request, Spelling, Value};

/// Option names written as the command line's flags (`--chord-tolerance`).
pub struct Flags;

impl Spelling for Flags {
    fn option(&self, name: &str) -> String {
        match request::find(name) {
            Some(info) => format!("--{}", info.cli_flag()),
            None => format!("--{}", name.replace('_', "-")),
        }
    }
}

/// A library text with its options said as flags.
pub fn flags(text: &str) -> String {
    request::render(text, &Flags)
}

/// A request `R` read from the command line (flattened into a command's
/// clap arguments).
#[derive(Debug, Clone, Default)]
pub struct Options<R>(pub R);

impl<R> std::ops::Deref for Options<R> {
    type Target = R;
    fn deref(&self) -> &R {
        &self.0
    }
}

/// Reads an option's value with the library's parser; lists a choice's
/// values in help.
#[derive(Clone)]
struct LibraryValue(&'static OptionInfo);

impl TypedValueParser for LibraryValue {
    type Value = Value;

    fn parse_ref(
        &self,
        cmd: &Command,
        arg: Option<&Arg>,
        value: &OsStr,
    ) -> Result<Value, clap::Error> {
        let info = self.0;
        // A word outside a choice's list: the library's message, as the
        // Python package gives it ("--method must be one of …").
        if let (Kind::Choice, Some(text)) = (info.kind, value.to_str()) {
            return info.parse(text).map_err(|p| {
                let e = volcomp_core::request::OptionError::new(info.name, p);
                clap::Error::raw(ErrorKind::ValueValidation, e.render(&Flags) + "\n")
            });
        }
        let parse = move |text: &str| info.parse(text).map_err(|p| flags(&p));
        parse.parse_ref(cmd, arg, value)
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        (self.0.kind == Kind::Choice).then(|| {
            Box::new(self.0.choices.iter().map(|(value, help)| match *help {
                "" => PossibleValue::new(*value),
                help => PossibleValue::new(*value).help(help),
            })) as Box<dyn Iterator<Item = PossibleValue>>
        })
    }
}

/// The clap argument of an option.
fn arg(info: &'static OptionInfo) -> Arg {
    // One sentence ends without its period, as clap's own help does.
    let help = flags(info.help);
    let help = match help.strip_suffix('.') {
        Some(h) if !h.contains(". ") => h.to_string(),
        _ => help,
    };
    let arg = Arg::new(info.name)
        .long(info.cli_flag())
        .help(help)
        .hide(info.hidden);
    if info.kind == Kind::Switch {
        return arg.action(ArgAction::SetTrue);
    }
    let mut arg = arg
        .action(ArgAction::Set)
        .value_parser(LibraryValue(info))
        .value_name(if info.value_name.is_empty() {
            "VALUE"
        } else {
            info.value_name
        })
        .required(info.required);
    if let Some(d) = info.default {
        arg = arg.default_value(d);
    }
    // A value that starts with `-` is the option's value, refused for its
    // range with the option named (`--cycle -1`), never an unknown flag.
    match info.kind {
        // `-inf` too, which clap's negative-number test does not take.
        Kind::Number | Kind::Count | Kind::Size | Kind::Triple => arg.allow_hyphen_values(true),
        _ => arg,
    }
}

fn read<R: Request>(request: &mut R, m: &ArgMatches) -> Result<(), clap::Error> {
    for info in R::OPTIONS.iter().flat_map(|g| g.iter()) {
        if m.value_source(info.name) != Some(ValueSource::CommandLine) {
            continue;
        }
        let value = match info.kind {
            Kind::Switch => Value::Bool(!info.on_by_default()),
            _ => match m.get_one::<Value>(info.name) {
                Some(v) => v.clone(),
                None => continue,
            },
        };
        request
            .set(info.name, value)
            .map_err(|e| clap::Error::raw(ErrorKind::ValueValidation, e.render(&Flags)))?;
    }
    Ok(())
}

impl<R: Request> FromArgMatches for Options<R> {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        let mut r = R::default();
        read(&mut r, m)?;
        Ok(Options(r))
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        read(&mut self.0, m)
    }
}

impl<R: Request> Args for Options<R> {
    fn augment_args(cmd: Command) -> Command {
        cmd.args(R::OPTIONS.iter().flat_map(|g| g.iter()).map(arg))
    }

    fn augment_args_for_update(cmd: Command) -> Command {
        Self::augment_args(cmd)
    }
}

/// Adds "a similar argument exists" to an unknown flag that clap found no
/// match for (clap's own measure misses swapped letters: `--mpa`).
pub fn suggest_flag(mut e: clap::Error, root: &Command, argv: &[String]) -> clap::Error {
    if e.kind() != ErrorKind::UnknownArgument || e.get(ContextKind::SuggestedArg).is_some() {
        return e;
    }
    let Some(ContextValue::String(typed)) = e.get(ContextKind::InvalidArg) else {
        return e;
    };
    let Some(typed) = typed.strip_prefix("--") else {
        return e;
    };
    let typed = typed.split('=').next().unwrap_or(typed).to_string();
    // The subcommand the flag was given to: follow the words of argv.
    let mut cmd = root;
    for word in argv.iter().skip(1) {
        match cmd.find_subcommand(word) {
            Some(sub) => cmd = sub,
            None if word.starts_with('-') => continue,
            None => {}
        }
    }
    let longs: Vec<&str> = cmd
        .get_arguments()
        .filter(|a| !a.is_hide_set())
        .filter_map(|a| a.get_long())
        .collect();
    if let Some(found) = did_you_mean(&typed, longs) {
        e.insert(
            ContextKind::SuggestedArg,
            ContextValue::String(format!("--{found}")),
        );
    }
    e
}
