//! The command line over the library: [`args`] parses, one module per command family runs a
//! command over a library call ([`measure`], [`model`], [`ride`], [`simulate`]; `report` is a
//! single call), [`io`] writes. Exit code 0 on success, 2 when an input is malformed or cannot be
//! analysed, 1 otherwise.

mod args;
mod io;
mod measure;
mod model;
mod ride;
mod simulate;

use anyhow::Result;
use args::{Cli, Command};
use bikeproc::{fit, inertia, signal};
use clap::Parser;
use io::note;
use std::path::PathBuf;
use std::process::ExitCode;

/// A campaign none of whose rides gave an eigenvalue (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("no ride of {} could be analysed (the reasons are listed above)", .0.display())]
struct NoRideAnalysed(PathBuf);

/// A design whose target range was not reached (exit code 3; the reason was printed).
#[derive(Debug, thiserror::Error)]
#[error("the target range was not reached (the reason is printed above)")]
struct Unreached;

/// Parses the arguments, runs the command, prints an error with its causes and maps it to the
/// exit code.
pub fn main() -> ExitCode {
    if io::stdout_closed() {
        io::note_line(
            "error: standard output goes nowhere (closed with `>&-`, or /dev/null open \
             read-write as a closed descriptor or a daemon leaves it): what the command prints \
             would be lost; redirect it to a file, or discard it with `> /dev/null`",
        );
        return ExitCode::from(1);
    }
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        // `--help` and `--version` go to standard output, checked as every output is.
        Err(e) if !e.use_stderr() => {
            return match io::out(&e.render().to_string()) {
                Ok(()) => ExitCode::SUCCESS,
                Err(_) => ExitCode::from(1),
            };
        }
        Err(e) => {
            io::note_line(e.render().to_string().trim_end());
            return ExitCode::from(2);
        }
    };
    let code = match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            io::note_line(&format!("error: {e:#}"));
            if e.is::<Unreached>() {
                return ExitCode::from(3);
            }
            return ExitCode::from(if is_input_error(&e) { 2 } else { 1 });
        }
    };
    // A warning or a "wrote …" line that standard error could not take: the user saw less than
    // the command said.
    if io::STDERR_FAILED.load(std::sync::atomic::Ordering::SeqCst) {
        return ExitCode::from(1);
    }
    code
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
            if !r.data.join("rides.toml").is_file() {
                return Err(bikeproc::kind::WrongKind(format!(
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

/// Whether the error comes from an input that is malformed or cannot be analysed.
fn is_input_error(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.is::<bikeproc::log::LogError>()
            || c.is::<signal::SignalError>()
            || c.is::<fit::FitError>()
            || c.is::<fit::MeasureError>()
            || c.is::<inertia::InertiaError>()
            || c.is::<inertia::manifest::ManifestError>()
            || c.is::<inertia::measured::MeasuredError>()
            || c.is::<bikeproc::model::ParamError>()
            || c.is::<bikeproc::model::sensitivity::SensitivityError>()
            || c.is::<bikeproc::model::design::DesignError>()
            || c.is::<bikeproc::ride::RideError>()
            || c.is::<bikeproc::model::control::ControlError>()
            || c.is::<NoRideAnalysed>()
            || c.is::<bikeproc::kind::WrongKind>()
    })
}
