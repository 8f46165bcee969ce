//! Command-line options built from the settings registry ([`crate::settings`]): one clap
//! argument per entry (flag, value name, help, default, value parser), and the values given
//! read back into [`Values`]. A group of entries becomes an argument group with
//! [`SettingsArgs`].

use crate::settings::{Kind, Setting, Value, Values};
use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::parser::ValueSource;
use clap::{Arg, ArgAction, ArgMatches, Command};

/// The clap id of `setting`: its flag as a name (`--emccd-read-noise` -> `emccd_read_noise`),
/// as clap's derive names the field of an option.
pub fn id(setting: &Setting) -> String {
    setting.flag.trim_start_matches("--").replace('-', "_")
}

/// The clap argument of `setting`: its flag, value name (the id in capitals), help, default
/// and the registry's own check as value parser.
pub fn arg(setting: &'static Setting) -> Arg {
    let arg = Arg::new(id(setting))
        .long(setting.flag.trim_start_matches("--"))
        .value_name(id(setting).to_uppercase())
        .help(setting.help);
    let arg = match setting.default {
        Some(text) => arg.default_value(text),
        None => arg,
    };
    match setting.kind {
        // clap lists the words in --help and suggests the nearest for a typo.
        Kind::Choice(words) => arg.value_parser(
            PossibleValuesParser::new(words).map(|word| Value::Text(word.to_string())),
        ),
        Kind::Paths => arg
            .value_parser(parser(setting))
            .num_args(1..)
            .action(ArgAction::Append)
            .value_name("FILE"),
        Kind::Path => arg.value_parser(parser(setting)).value_name("FILE"),
        Kind::TextList => arg
            .value_parser(parser(setting))
            .action(ArgAction::Append)
            .allow_hyphen_values(true),
        Kind::Text => arg.value_parser(parser(setting)).allow_hyphen_values(true),
        Kind::Real(..) | Kind::Whole(..) => arg.value_parser(parser(setting)),
    }
}

/// The registry's parser of `setting` as a clap value parser.
fn parser(
    setting: &'static Setting,
) -> impl Fn(&str) -> std::result::Result<Value, String> + Clone + Send + Sync + 'static {
    move |text: &str| setting.parse(text)
}

/// The values of `settings` on the command line: those typed, and the defaults a command sets
/// for itself (`effective`'s grid); a value at the registry's default is left to the
/// registry, so that "given" means typed or the command's own.
pub fn values_of(matches: &ArgMatches, settings: &[&'static Setting]) -> Values {
    let mut values = Values::default();
    for &setting in settings {
        let id = id(setting);
        match matches.value_source(&id) {
            None => continue,
            Some(ValueSource::DefaultValue) if !command_default(matches, &id, setting) => continue,
            Some(_) => {}
        }
        let given = matches
            .get_many::<Value>(&id)
            .into_iter()
            .flatten()
            .cloned();
        values.set(setting, Value::gathered(setting.kind, given));
    }
    values
}

/// Whether the default clap took for `id` is a command's own, not the registry's.
fn command_default(matches: &ArgMatches, id: &str, setting: &Setting) -> bool {
    let raw: Vec<String> = matches
        .get_raw(id)
        .map(|v| v.map(|s| s.to_string_lossy().into_owned()).collect())
        .unwrap_or_default();
    raw != setting
        .default
        .iter()
        .map(|d| d.to_string())
        .collect::<Vec<_>>()
}

/// Clap arguments generated from a group of settings, and the values given for them.
pub trait SettingsArgs: Sized {
    /// The settings of the group, in the order of `--help`.
    const SETTINGS: &'static [&'static Setting];

    /// The group from the values given.
    fn from_values(values: Values) -> Self;

    /// `cmd` with one argument per setting of the group, then `finish` applied.
    fn add_to(cmd: Command, finish: fn(Command) -> Command) -> Command {
        finish(cmd.args(Self::SETTINGS.iter().map(|s| arg(s))))
    }
}

/// A struct of the values given for a group of settings, with clap's `Args` and
/// `FromArgMatches` generated from the group; `finish` (optional) adjusts the command after
/// the group's arguments are added (a long help, a guard option).
macro_rules! settings_group {
    (@finish) => { |cmd| cmd };
    (@finish $finish:expr) => { $finish };
    ($(#[$doc:meta])* $ty:ident = $settings:expr $(, finish = $finish:expr)?) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Default)]
        pub struct $ty {
            /// The values given (the others take the registry's defaults).
            pub values: $crate::settings::Values,
        }
        impl $crate::cli::settings::SettingsArgs for $ty {
            const SETTINGS: &'static [&'static $crate::settings::Setting] = $settings;
            fn from_values(values: $crate::settings::Values) -> Self {
                $ty { values }
            }
        }
        impl clap::FromArgMatches for $ty {
            fn from_arg_matches(m: &clap::ArgMatches) -> Result<Self, clap::Error> {
                use $crate::cli::settings::SettingsArgs;
                Ok(<$ty>::from_values($crate::cli::settings::values_of(m, <$ty>::SETTINGS)))
            }
            fn update_from_arg_matches(&mut self, m: &clap::ArgMatches) -> Result<(), clap::Error> {
                *self = <Self as clap::FromArgMatches>::from_arg_matches(m)?;
                Ok(())
            }
        }
        impl clap::Args for $ty {
            fn augment_args(cmd: clap::Command) -> clap::Command {
                let finish: fn(clap::Command) -> clap::Command =
                    $crate::cli::settings::settings_group!(@finish $($finish)?);
                <$ty as $crate::cli::settings::SettingsArgs>::add_to(cmd, finish)
            }
            fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
                <Self as clap::Args>::augment_args(cmd)
            }
        }
    };
}
pub(crate) use settings_group;

#[cfg(test)]
mod tests;
