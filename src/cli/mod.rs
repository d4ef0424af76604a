//! The command line of helixbif: parse, run the command, and print its one report (text, or
//! JSON with `--json`) in one place, with the exit code of the outcome (0 success, 2 bad input,
//! 1 numerical failure).

mod args;
mod commands;
mod numbers;
mod report;

use std::io::Write;
use std::process::ExitCode;

use clap::Parser;
use helixbif::Error;

use args::{Cli, Command};
use report::Report;

/// Prints a report on stdout. A closed pipe (`helixbif ... | head -1`) ends the output quietly.
fn print(report: &dyn Report, json: bool) -> std::io::Result<()> {
    let text = if json {
        report.to_json().to_string()
    } else {
        report.to_string()
    };
    let mut out = std::io::stdout().lock();
    writeln!(out, "{text}")?;
    out.flush()
}

/// Parses the command line, runs the command and prints its report; the exit code says how it
/// went.
pub fn main() -> ExitCode {
    helixbif::numerics::process::configure();
    let cli = Cli::parse();
    // A panic (a bug) ends the command with one line and exit code 1, like a numerical
    // failure; the panic hook has printed where it happened.
    // The copy of the RPY kernels and the interval of progress lines the environment asks
    // for, checked like options.
    let guarded = |run: &dyn Fn() -> commands::Outcome| -> commands::Outcome {
        helixbif::model::fluid::rpy::cap_from_environment()?;
        helixbif::study::progress::interval_from_environment()?;
        helixbif::error::caught(|| Ok(run()))?
    };
    let (result, json) = match &cli.command {
        Command::Solve(a) => (guarded(&|| commands::solve(a)), a.study.json),
        Command::Branch(a) => (guarded(&|| commands::branch(a)), a.study.json),
        Command::Locate(a) => (guarded(&|| commands::locate(a)), a.study.json),
        Command::Run(a) => (guarded(&|| commands::run(a)), a.study.json),
        Command::Boundary(a) => (guarded(&|| commands::boundary(a)), a.study.json),
        Command::Sweep(a) => (guarded(&|| commands::sweep(a)), a.study.json),
        Command::Slurm(a) => (guarded(&|| commands::slurm(a)), a.study.json),
        Command::Merge(a) => (guarded(&|| commands::merge(a)), a.study.json),
        Command::Fit(a) => (guarded(&|| commands::fit(a)), a.json),
        Command::Orbits(a) => (guarded(&|| commands::orbits(a)), a.study.json),
        Command::Simulate(a) => (guarded(&|| commands::simulate(a)), a.study.json),
        Command::Bisect(a) => (guarded(&|| commands::bisect(a)), a.study.json),
    };
    match result {
        Ok(done) => match print(done.report.as_ref(), json) {
            Ok(()) | Err(_) if done.shortfall.is_some() => {
                // The report (all that was computed) is out; what it fell short of is a failure.
                eprintln!(
                    "helixbif: error: numerical failure: {}",
                    done.shortfall.unwrap_or_default()
                );
                ExitCode::from(1)
            }
            Ok(()) => ExitCode::SUCCESS,
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("helixbif: error: writing the report: {e}");
                ExitCode::from(1)
            }
        },
        Err(e) => {
            let input = e.downcast_ref::<Error>().is_some_and(Error::is_input);
            eprintln!("helixbif: error: {e}");
            ExitCode::from(if input { 2 } else { 1 })
        }
    }
}
