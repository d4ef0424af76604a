//! Command-line front end of helixbif: parse, load a study, call the library, print, write.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use helixbif::Error;
use helixbif::model::Model;
use helixbif::solve::{Solution, solve_at};
use helixbif::study::Study;

/// Continuation and bifurcation analysis of elastic rods rotating in a viscous fluid
/// (Discrete Elastic Rods + Lighthill slender-body theory).
#[derive(Parser, Debug)]
#[command(name = "helixbif", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Options shared by every command that reads a study.
#[derive(Args, Debug)]
struct StudyArgs {
    /// Study file (TOML); without one, the built-in representative helix.
    study: Option<PathBuf>,
    /// Override a study field, e.g. `--set rod.E=2e6 --set discretization.nodes=80`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Print one JSON object on stdout and nothing else there.
    #[arg(long)]
    json: bool,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// One rigidly rotating steady state: observables and Newton convergence.
    Solve {
        #[command(flatten)]
        study: StudyArgs,
        /// Rotation rate of the motor (rad/s, counter-clockwise seen from above).
        #[arg(long, allow_negative_numbers = true)]
        omega: f64,
        /// Write the node positions and twist angles (SI) to this CSV file.
        #[arg(long, value_name = "FILE.csv")]
        shape: Option<PathBuf>,
    },
}

fn load(args: &StudyArgs) -> Result<(Study, Model), Error> {
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let model = Model::new(&study.physical())?;
    Ok((study, model))
}

fn write_shape(path: &Path, model: &Model, solution: &Solution) -> anyhow::Result<()> {
    let mut w = csv::Writer::from_path(path)?;
    w.write_record(["i", "x", "y", "z", "theta"])?;
    let ell = model.scales.length;
    let config = &solution.state.config;
    for (i, p) in config.x.iter().enumerate() {
        let theta = config
            .theta
            .get(i)
            .map(|t| t.to_string())
            .unwrap_or_default();
        w.write_record([
            i.to_string(),
            (p.x * ell).to_string(),
            (p.y * ell).to_string(),
            (p.z * ell).to_string(),
            theta,
        ])?;
    }
    w.flush()?;
    Ok(())
}

fn solve(study: &StudyArgs, omega: f64, shape: Option<&Path>) -> anyhow::Result<()> {
    if !omega.is_finite() {
        return Err(
            Error::input("--omega", format!("must be a finite number, got {omega}")).into(),
        );
    }
    let (study_file, model) = load(study)?;
    let omegabar = model.scales.omega_to_bar(omega);
    let solution = solve_at(&model, omegabar, &study_file.newton)?;
    if let Some(path) = shape {
        write_shape(path, &model, &solution)?;
    }
    let s = solution.summary(&model);
    if study.json {
        println!("{}", serde_json::to_string(&s)?);
    } else {
        let o = &s.observables;
        println!(
            "steady state of `{}` at N = {} nodes",
            study_file.name, s.nodes
        );
        println!(
            "  omega    = {:.6e} rad/s   (omegabar = {:.6e})",
            o.omega, o.omegabar
        );
        println!(
            "  Fp       = {:.6e} N       (Fpbar = {:.6e}; rigid helix {:.6e})",
            o.fp, o.fpbar, s.fpbar_rigid
        );
        println!("  Tp       = {:.6e} N m", o.tp);
        match o.eta {
            Some(eta) => println!("  eta      = {eta:.6e}"),
            None => println!("  eta      = undefined at rest"),
        }
        println!(
            "  h        = {:.6e} m       (h0 = {:.6e} m, hbar = {:.6})",
            o.h, o.h0, o.hbar
        );
        println!(
            "  Newton   : {} iterations, residual {:.3e}; history {}",
            s.newton_iterations,
            s.residual_norm,
            s.residual_history
                .iter()
                .map(|r| format!("{r:.1e}"))
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // The dense matrices here are small (a few hundred rows): threading inside one factorization
    // costs more than it gains; parallelism is over independent solves instead.
    faer::set_global_parallelism(faer::Par::Seq);
    let result = match &cli.command {
        Command::Solve {
            study,
            omega,
            shape,
        } => solve(study, *omega, shape.as_deref()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let input = e.downcast_ref::<Error>().is_some_and(Error::is_input);
            eprintln!("helixbif: error: {e}");
            ExitCode::from(if input { 2 } else { 1 })
        }
    }
}
