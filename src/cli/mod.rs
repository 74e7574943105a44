//! The command line over the library: [`args`] parses, one module per command family runs a
//! command over a library call ([`measure`], [`model`], [`ride`], [`simulate`]; `report` is a
//! single call), [`io`] writes. The exit code comes from what went wrong, in one place
//! ([`Exit`], [`exit_for`]); `src/main.rs` lists the codes.

mod args;
mod io;
mod measure;
mod model;
mod ride;
mod simulate;

use anyhow::Result;
use args::{Cli, Command};
use bikeproc::{fit, inertia, signal};
use clap::FromArgMatches as _;
use io::note;
use std::path::PathBuf;
use std::process::ExitCode;

/// A campaign none of whose rides gave an eigenvalue ([`Exit::Input`]).
#[derive(Debug, thiserror::Error)]
#[error("no ride of {} could be analysed (the reasons are listed above)", .0.display())]
struct NoRideAnalysed(PathBuf);

/// An option the input it was given with does not take (`--window` on a lab log, `--speed`
/// on a campaign): refused rather than ignored ([`Exit::Input`]).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub(crate) struct Refused(pub(crate) String);

/// A design whose target range was not reached ([`Exit::Unreached`]; the reason was printed).
#[derive(Debug, thiserror::Error)]
#[error("the target range was not reached (the reason is printed above)")]
struct Unreached;

/// The command's exit codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Exit {
    /// 0: done.
    Success = 0,
    /// 1: anything else: the machine (a file that cannot be read or written, standard output or
    /// error gone), the model, a figure.
    Failure = 1,
    /// 2: the command line or an input: a malformed or unknown option, a value refused, an
    /// input malformed or not analysable, an option the input does not take, an output that
    /// would overwrite an input.
    Input = 2,
    /// 3: `design` did not reach its target range (the closest design was printed).
    Unreached = 3,
}

impl From<Exit> for ExitCode {
    fn from(e: Exit) -> ExitCode {
        ExitCode::from(e as u8)
    }
}

/// The exit code of a command's error, from its kind: the one place where errors become codes.
fn exit_for(e: &anyhow::Error) -> Exit {
    if e.is::<Unreached>() {
        Exit::Unreached
    } else if is_input_error(e) {
        Exit::Input
    } else {
        Exit::Failure
    }
}

/// Parses the arguments, runs the command, prints an error with its causes and maps it to the
/// exit code.
pub fn main() -> ExitCode {
    if io::stdout_closed() {
        io::note_line(
            "error: standard output goes nowhere (closed with `>&-`, or /dev/null open \
             read-write as a closed descriptor or a daemon leaves it): what the command prints \
             would be lost; redirect it to a file, or discard it with `> /dev/null`",
        );
        return Exit::Failure.into();
    }
    let cli = match command()
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m))
    {
        Ok(cli) => cli,
        // `--help` and `--version` go to standard output, checked as every output is.
        Err(e) if !e.use_stderr() => {
            let written = io::out(&e.render().to_string());
            return if written.is_ok() {
                Exit::Success
            } else {
                Exit::Failure
            }
            .into();
        }
        Err(e) => {
            io::note_line(e.render().to_string().trim_end());
            return Exit::Input.into();
        }
    };
    let exit = match run(cli) {
        Ok(()) => Exit::Success,
        Err(e) => {
            io::note_line(&format!("error: {e:#}"));
            return exit_for(&e).into();
        }
    };
    // A warning or a "wrote …" line that standard error could not take: the user saw less than
    // the command said.
    if io::STDERR_FAILED.load(std::sync::atomic::Ordering::SeqCst) {
        return Exit::Failure.into();
    }
    exit.into()
}

/// The command line's grammar: [`Cli`]'s, every numeric option taking any value that starts
/// with a hyphen (`-0.5`, `-inf`, `-1:5:1` reach the option's check and are refused for their
/// value, instead of being taken for an unknown flag), every other option a negative number.
pub fn command() -> clap::Command {
    fn negatives(c: clap::Command) -> clap::Command {
        c.mut_args(|a| {
            if !a.get_action().takes_values() || a.is_positional() {
                a
            } else if is_numeric(&a) {
                a.allow_hyphen_values(true)
            } else {
                a.allow_negative_numbers(true)
            }
        })
        .mut_subcommands(negatives)
    }
    negatives(<Cli as clap::CommandFactory>::command())
}

/// Whether an option's value is a number or a range of numbers (by its parser's type).
fn is_numeric(a: &clap::Arg) -> bool {
    use std::any::TypeId;
    let id = a.get_value_parser().type_id();
    [
        TypeId::of::<f64>(),
        TypeId::of::<(f64, f64)>(),
        TypeId::of::<(f64, f64, f64)>(),
        TypeId::of::<u32>(),
        TypeId::of::<u64>(),
        TypeId::of::<usize>(),
    ]
    .iter()
    .any(|t| id == *t)
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Period(a) => measure::period(a),
        Command::CalibrateBar(a) => measure::calibrate_bar(a),
        Command::Inertia(a) => measure::inertia(a),
        Command::Measured(a) => measure::measured(a),
        Command::Stability(a) => model::stability(a),
        Command::Sensitivity(a) => model::sensitivity(a),
        Command::Compare(a) => model::compare(a),
        Command::Design(a) => model::design(a),
        Command::Dynamic(a) => ride::dynamic(a),
        Command::Gap(a) => ride::gap(a),
        Command::Simulate(s) => simulate::simulate(s),
        Command::Report(r) => {
            bikeproc::output::refuse_folder_over_inputs(&r.out, &[&r.data, &r.reference])?;
            if !r.data.join("rides.toml").is_file() {
                return Err(bikeproc::read::kind::WrongKind(format!(
                    "{}: no lab data here (its rides.toml is missing): run `bikeproc report` in \
                     the checkout's top folder, or name the folders with --data, --reference \
                     and --out",
                    r.data.display()
                ))
                .into());
            }
            let written =
                bikeproc::report::regenerate(&r.out, &r.data, &r.reference, &mut |m| note!("{m}"))?;
            note!("wrote {} files under {}", written.len(), r.out.display());
            Ok(())
        }
    }
}

/// Whether the error comes from an input that is malformed or cannot be analysed: one of its
/// chain is an input's kind ([`is_input_kind`]); a report's error is judged by the stage error
/// it wraps.
fn is_input_error(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        is_input_kind(c)
            || c.downcast_ref::<bikeproc::report::ReportError>()
                .and_then(|r| r.stage_error())
                .is_some_and(is_input_kind)
    })
}

/// The error kinds that mean an input (or the command line) is at fault: the list that makes
/// exit code 2.
fn is_input_kind(c: &(dyn std::error::Error + 'static)) -> bool {
    c.is::<bikeproc::read::log::LogError>()
        || c.is::<signal::SignalError>()
        || c.is::<fit::FitError>()
        || c.is::<fit::MeasureError>()
        || c.is::<inertia::InertiaError>()
        || c.is::<bikeproc::read::manifest::ManifestError>()
        || c.is::<inertia::measured::MeasuredError>()
        || c.is::<bikeproc::model::ParamError>()
        || c.is::<bikeproc::model::sensitivity::SensitivityError>()
        || c.is::<bikeproc::model::design::DesignError>()
        || c.is::<bikeproc::ride::RideError>()
        || c.is::<bikeproc::model::control::ControlError>()
        || c.is::<NoRideAnalysed>()
        || c.is::<Refused>()
        || c.is::<bikeproc::read::kind::WrongKind>()
        || matches!(
            c.downcast_ref::<bikeproc::output::OutputError>(),
            Some(bikeproc::output::OutputError::OverInput { .. })
        )
}

#[cfg(test)]
mod tests {
    use super::command;

    /// main.rs's doc lists every exit code, each once, and no other.
    #[test]
    fn main_rs_lists_every_exit_code() {
        use super::Exit;
        let doc = include_str!("../main.rs");
        let rows: Vec<u8> = doc
            .lines()
            .filter_map(|l| l.strip_prefix("//! | "))
            .filter_map(|l| l.split(' ').next()?.parse().ok())
            .collect();
        let codes = [Exit::Success, Exit::Failure, Exit::Input, Exit::Unreached].map(|e| e as u8);
        assert_eq!(rows, codes.to_vec(), "main.rs's table of exit codes");
    }
    use proptest::prelude::*;

    /// Every numeric option, with the path of subcommands that reaches it.
    fn value_options() -> Vec<(Vec<String>, String)> {
        fn walk(c: &clap::Command, path: Vec<String>, out: &mut Vec<(Vec<String>, String)>) {
            for a in c.get_arguments() {
                if let Some(long) = a.get_long() {
                    if a.get_action().takes_values() && super::is_numeric(a) {
                        out.push((path.clone(), format!("--{long}")));
                    }
                }
            }
            for s in c.get_subcommands() {
                let mut p = path.clone();
                p.push(s.get_name().to_string());
                walk(s, p, out);
            }
        }
        let mut out = Vec::new();
        walk(&command(), Vec::new(), &mut out);
        out
    }

    /// The values a careless user types where a number is wanted.
    const AWKWARD: [&str; 16] = [
        "-1",
        "-0.5",
        "0",
        "-0",
        "NaN",
        "nan",
        "inf",
        "-inf",
        "1e308",
        "-1e308",
        "1e400",
        "5:1",
        "1:1e308",
        "0:1e308:1e307",
        "-1:5:1",
        "nan:1",
    ];

    /// A refusal of `value` for `option`: names the option and echoes no number as hundreds of
    /// digits (1e308 was written out as a 309-digit integer).
    fn check_refusal(option: &str, value: &str, message: &str) {
        assert!(
            message.contains(option),
            "{option} {value}: the refusal does not name the option: {message}"
        );
        let longest_digits = message
            .split(|c: char| !c.is_ascii_digit())
            .map(str::len)
            .max()
            .unwrap_or(0);
        assert!(
            longest_digits < 25,
            "{option} {value}: a {longest_digits}-digit number in: {message}"
        );
    }

    fn parse(path: &[String], option: &str, value: &str) -> Result<(), clap::Error> {
        let mut argv = vec!["bikeproc".to_string()];
        argv.extend(path.iter().cloned());
        argv.push(option.to_string());
        argv.push(value.to_string());
        command().try_get_matches_from(argv).map(|_| ())
    }

    /// Every option of every command, given each awkward value: either taken (the command's
    /// own checks then run), or refused by its value's check with the option named; never a
    /// value mistaken for a flag (`--max-change -0.5` was "unexpected argument '-0'").
    #[test]
    fn every_option_refuses_awkward_numbers_by_name() {
        let options = value_options();
        assert!(
            options.len() > 40,
            "{} numeric options found",
            options.len()
        );
        for (path, option) in &options {
            for value in AWKWARD {
                let Err(e) = parse(path, option, value) else {
                    continue;
                };
                use clap::error::ErrorKind::*;
                match e.kind() {
                    // Taken: what is missing is another argument, not this one's value.
                    MissingRequiredArgument | MissingSubcommand | ArgumentConflict => {}
                    InvalidValue | ValueValidation => {
                        check_refusal(option, value, &e.render().to_string())
                    }
                    other => panic!(
                        "{} {option} {value}: {other:?}: {}",
                        path.join(" "),
                        e.render()
                    ),
                }
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        /// Any number at all, in plain or exponent form, for any option: the same rules.
        #[test]
        fn any_number_for_any_option(
            pick in 0usize..10_000,
            mantissa in -1e6f64..1e6,
            exponent in -320i32..320,
            range in any::<bool>(),
        ) {
            let options = value_options();
            let (path, option) = &options[pick % options.len()];
            let x = format!("{mantissa}e{exponent}");
            let value = if range { format!("{x}:{mantissa}") } else { x };
            if let Err(e) = parse(path, option, &value) {
                use clap::error::ErrorKind::*;
                if matches!(e.kind(), InvalidValue | ValueValidation) {
                    check_refusal(option, &value, &e.render().to_string());
                }
            }
        }
    }
}
