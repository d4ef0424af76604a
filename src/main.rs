//! Command-line front end of helixbif: parse, load a study, call the library, print, write.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use helixbif::Error;
use helixbif::dynamics::{BisectSettings, DynamicsSettings, bisect};
use helixbif::fit::power_law;
use helixbif::model::Model;
use helixbif::output::Table;
use helixbif::params::ShapeParams;
use helixbif::solve::{Solution, solve_at};
use helixbif::study::run::run;
use helixbif::study::runs::{default_ladder, run_branch, run_ladder, run_locate};
use helixbif::study::simulate::{SimulateOptions, run_simulate};
use helixbif::study::sweep::{merge, run_sweep};
use helixbif::study::{Study, figures, sweep_figures};

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
    /// Follow the steady branch from rest in omega: branch.csv, events.csv, meta.json, figures.
    Branch {
        #[command(flatten)]
        study: StudyArgs,
        /// Largest rotation rate (rad/s); default the study's `branch.omega_max`.
        #[arg(long)]
        omega_max: Option<f64>,
        /// Output folder; default `output/<study name>/`.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// The critical buckling rate omega_b: first loss of stability of the branch from rest.
    Locate {
        #[command(flatten)]
        study: StudyArgs,
        /// Relative precision of omega_b (default 1e-8).
        #[arg(long)]
        tol: Option<f64>,
        /// Run a ladder of node counts and extrapolate omega_b to infinite resolution.
        #[arg(long)]
        extrapolate: bool,
        /// Node counts of the ladder (comma separated); default five inside the admissible range.
        #[arg(long, value_delimiter = ',', requires = "extrapolate")]
        nodes: Vec<usize>,
    },
    /// Do what the study's [study] table declares (branch, locate, sweep, phase, shapes) and
    /// write `output/<study name>/`.
    Run {
        #[command(flatten)]
        study: StudyArgs,
        /// Output folder; default `output/<study name>/`.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// omega_b over the study's parameter grid, in parallel, resumable; `--shard K/N` runs every
    /// N-th point (from the K-th) for array jobs.
    Sweep {
        #[command(flatten)]
        study: StudyArgs,
        /// Run only the points with index = K-1 modulo N.
        #[arg(long, value_name = "K/N")]
        shard: Option<String>,
        /// Output folder; default `output/<study name>/`.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Join the shard files of a sweep into sweep.csv.
    Merge {
        #[command(flatten)]
        study: StudyArgs,
        /// Folder holding the shards; default `output/<study name>/`.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Step the rod through time at a rate (BDF2, adaptive): time series of hbar, Fp, Tp, eta,
    /// shapes, figures, and late-time mean and standard deviation.
    Simulate {
        #[command(flatten)]
        study: StudyArgs,
        /// Rotation rate (rad/s).
        #[arg(long)]
        omega: f64,
        /// Duration (s).
        #[arg(long)]
        t_end: f64,
        /// Start on the steady state at --omega (default: from rest, the motor spinning up).
        #[arg(long)]
        from_steady: bool,
        /// With --from-steady: displace along the least stable mode by this fraction of the
        /// reference length.
        #[arg(long)]
        perturb: Option<f64>,
        /// Spin-up time (s) of a run from rest.
        #[arg(long, default_value_t = 20.0)]
        ramp_time: f64,
        /// Statistics over t >= this (s).
        #[arg(long, default_value_t = 0.0)]
        transient: f64,
        /// Write the shape every this many time steps (0: never).
        #[arg(long, default_value_t = 50)]
        shape_every: usize,
        /// Output folder; default `output/<study name>/simulate/`.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// omega_b the way simulation studies found it: bisection on runs from rest, each judged by
    /// whether the rod settles on the steady state.
    Bisect {
        #[command(flatten)]
        study: StudyArgs,
        /// A stable rate (rad/s).
        #[arg(long)]
        lo: f64,
        /// An unstable rate (rad/s).
        #[arg(long)]
        hi: f64,
        /// Relative width of the final bracket.
        #[arg(long, default_value_t = 1e-2)]
        precision: f64,
    },
    /// Least-squares power law y = C x^p with 95% confidence intervals.
    Fit {
        /// CSV file with a header row.
        csv: PathBuf,
        /// Column of x.
        #[arg(long)]
        x: String,
        /// Column of y.
        #[arg(long)]
        y: String,
        /// Print one JSON object on stdout.
        #[arg(long)]
        json: bool,
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

fn branch(study: &StudyArgs, omega_max: Option<f64>, out: Option<&Path>) -> anyhow::Result<()> {
    let (study_file, model) = load(study)?;
    let omega_max = omega_max.unwrap_or(study_file.branch.omega_max);
    if !(omega_max.is_finite() && omega_max > 0.0) {
        return Err(Error::input(
            "--omega-max",
            format!("must be a finite number > 0, got {omega_max}"),
        )
        .into());
    }
    let dir = out.map_or_else(
        || Path::new("output").join(&study_file.name),
        Path::to_path_buf,
    );
    let (report, tables) = run_branch(&study_file, &model, omega_max, &dir)?;
    let case = figures::Case {
        label: &study_file.name,
        tables: &tables,
        rigid: matches!(study_file.shape, ShapeParams::Helix { .. }),
    };
    figures::branch_figures(&dir, &study_file.name, &[case])?;
    if report.stalled {
        return Err(Error::Numerical(format!(
            "continuation stalled at omega = {:.6e} rad/s ({}); the {} points found are in {}",
            tables.points.last().map_or(0.0, |r| r.omega),
            report.stop,
            report.points,
            report.out
        ))
        .into());
    }
    if study.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!(
            "branch of `{}` at N = {}: {} points up to omega = {:.4} rad/s ({}), {} events, {:.2} s; written to {}",
            study_file.name,
            model.nodes(),
            report.points,
            tables.points.last().map_or(0.0, |r| r.omega),
            report.stop,
            report.events,
            report.seconds,
            report.out
        );
        for e in &tables.events {
            println!(
                "  {:<12} omega = {:.8} rad/s (omegabar = {:.6e}), eigenvalue {:+.3e} {:+.4e} i /s",
                e.kind, e.omega, e.omegabar, e.re, e.im
            );
        }
    }
    Ok(())
}

fn locate_command(
    study: &StudyArgs,
    tol: Option<f64>,
    extrapolate: bool,
    nodes: &[usize],
) -> anyhow::Result<()> {
    let mut overrides = study.set.clone();
    if let Some(t) = tol {
        overrides.push(format!("continuation.event_tol={t:e}"));
    }
    let study_file = Study::from_path(study.study.as_deref(), &overrides)?;
    if extrapolate {
        let ladder = if nodes.is_empty() {
            default_ladder(&study_file)
        } else {
            nodes.to_vec()
        };
        let result = run_ladder(&study_file, &ladder)?;
        if study.json {
            println!("{}", serde_json::to_string(&result)?);
        } else {
            println!(
                "omega_b of `{}` over a ladder of node counts:",
                study_file.name
            );
            for ((n, w), k) in result.nodes.iter().zip(&result.omega_b).zip(&result.kinds) {
                println!("  N = {n:3}: omega_b = {w:.8} rad/s ({k})");
            }
            let range = match result.nodes_max {
                Some(max) => format!("admissible N <= {max}"),
                None => "no admissible-N limit".to_owned(),
            };
            println!(
                "  extrapolated: omega_b = {:.6} +- {:.6} rad/s (convergence order {:.2}; {range})",
                result.omega_b_extrapolated, result.omega_b_error, result.order
            );
        }
        return Ok(());
    }
    let model = Model::new(&study_file.physical())?;
    let located = run_locate(&study_file, &model)?;
    if study.json {
        println!("{}", serde_json::to_string(&located)?);
    } else if let (Some(w), Some(wb)) = (located.omega_b, located.omegabar_b) {
        println!(
            "critical rate of `{}` at N = {}: {}",
            study_file.name, located.nodes, located.kind
        );
        println!(
            "  omega_b    = {w:.10} rad/s   (omegabar_b = {wb:.8e}, relative precision {:.1e})",
            located.precision.unwrap_or(f64::NAN)
        );
        if let Some(im) = located.im {
            println!(
                "  frequency  = {im:.8} rad/s     (Im(s) of the critical mode, co-rotating frame)"
            );
        }
        println!(
            "  Fp         = {:.6e} N     (Fpbar = {:.6})",
            located.fp.unwrap_or(f64::NAN),
            located.fpbar.unwrap_or(f64::NAN)
        );
        println!("  hbar       = {:.6}", located.hbar.unwrap_or(f64::NAN));
        println!(
            "  ({} continuation points, {} corrector iterations)",
            located.points, located.corrector_iterations
        );
    } else {
        println!(
            "the branch of `{}` stays stable up to omega_max = {} rad/s (kind: none)",
            study_file.name, located.omega_max
        );
    }
    Ok(())
}

fn output_dir(study: &Study, out: Option<&Path>) -> PathBuf {
    out.map_or_else(|| Path::new("output").join(&study.name), Path::to_path_buf)
}

fn run_command(args: &StudyArgs, out: Option<&Path>) -> anyhow::Result<()> {
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let dir = output_dir(&study, out);
    let started = std::time::Instant::now();
    let report = run(&study, &dir)?;
    if args.json {
        println!("{report}");
    } else {
        println!(
            "study `{}` ({}) done in {:.1} s; results in {}",
            study.name,
            study.study.as_ref().map_or("locate", |p| p.kind()),
            started.elapsed().as_secs_f64(),
            dir.display()
        );
        println!("{report:#}");
    }
    Ok(())
}

fn parse_shard(text: &str) -> Result<(usize, usize), Error> {
    let bad = || {
        Error::input(
            "--shard",
            format!("expected K/N with 1 <= K <= N, got `{text}`"),
        )
    };
    let (k, n) = text.split_once('/').ok_or_else(bad)?;
    let (k, n): (usize, usize) = (
        k.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if k == 0 || n == 0 || k > n {
        return Err(bad());
    }
    Ok((k, n))
}

fn sweep_command(args: &StudyArgs, shard: Option<&str>, out: Option<&Path>) -> anyhow::Result<()> {
    let shard = shard.map(parse_shard).transpose()?;
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let dir = output_dir(&study, out);
    let summary = run_sweep(&study, &dir, shard)?;
    if args.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        println!(
            "sweep `{}`: {} points ({} already done, {} computed, {} failed) in {:.1} s -> {}",
            study.name,
            summary.points,
            summary.already_done,
            summary.computed,
            summary.failed,
            summary.seconds,
            summary.file
        );
    }
    if summary.failed > 0 {
        return Err(Error::Numerical(format!(
            "{} sweep points failed; see the status column of {}",
            summary.failed, summary.file
        ))
        .into());
    }
    if shard.is_none() {
        sweep_figures(&study, &dir)?;
    }
    Ok(())
}

fn merge_command(args: &StudyArgs, out: Option<&Path>) -> anyhow::Result<()> {
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let dir = output_dir(&study, out);
    let rows = merge(&study, &dir)?;
    sweep_figures(&study, &dir)?;
    println!(
        "merged {rows} points into {}",
        dir.join("sweep.csv").display()
    );
    Ok(())
}

fn fit_command(csv: &Path, x: &str, y: &str, json: bool) -> anyhow::Result<()> {
    let table = Table::read(csv)?;
    let (xc, yc) = (table.index(x)?, table.index(y)?);
    let (xs, ys): (Vec<f64>, Vec<f64>) = (0..table.rows.len())
        .filter_map(|r| Some((table.number(r, xc)?, table.number(r, yc)?)))
        .unzip();
    let fit = power_law(&xs, &ys)?;
    if json {
        println!("{}", serde_json::to_string(&fit)?);
    } else {
        println!("{y} = C {x}^p over {} rows of {}:", fit.n, csv.display());
        println!(
            "  p = {:.6}   95% CI [{:.6}, {:.6}]",
            fit.p, fit.p_ci[0], fit.p_ci[1]
        );
        println!(
            "  C = {:.6e}   95% CI [{:.6e}, {:.6e}]",
            fit.c, fit.c_ci[0], fit.c_ci[1]
        );
        println!("  r2 = {:.6}", fit.r2);
    }
    Ok(())
}

fn simulate_command(
    args: &StudyArgs,
    opts: SimulateOptions,
    out: Option<&Path>,
) -> anyhow::Result<()> {
    let (study, model) = load(args)?;
    let dir = out.map_or_else(
        || Path::new("output").join(&study.name).join("simulate"),
        Path::to_path_buf,
    );
    let report = run_simulate(&model, &DynamicsSettings::default(), &opts, &dir)?;
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!(
            "simulated `{}` at omega = {} rad/s for {} s: {} steps ({} rejected), {:.1} s; written to {}",
            study.name,
            report.omega,
            report.t_end,
            report.steps,
            report.rejected,
            report.seconds,
            dir.display()
        );
        if let (Some(h), Some(hs), Some(f), Some(fs)) = (
            report.hbar_mean,
            report.hbar_std,
            report.fpbar_mean,
            report.fpbar_std,
        ) {
            println!(
                "  after t = {} s: hbar = {h:.6} +- {hs:.2e}, Fpbar = {f:.6} +- {fs:.2e}",
                opts.transient
            );
        }
    }
    Ok(())
}

fn bisect_command(args: &StudyArgs, lo: f64, hi: f64, precision: f64) -> anyhow::Result<()> {
    let (study, model) = load(args)?;
    if !(lo.is_finite() && hi.is_finite() && 0.0 < lo && lo < hi) {
        return Err(Error::input(
            "--lo",
            format!("need 0 < lo < hi, got lo = {lo}, hi = {hi}"),
        )
        .into());
    }
    if !(precision > 0.0 && precision < 1.0) {
        return Err(Error::input(
            "--precision",
            format!("must lie in (0, 1), got {precision}"),
        )
        .into());
    }
    model.check_resolution()?;
    let settings = BisectSettings {
        precision,
        ..BisectSettings::default()
    };
    let started = std::time::Instant::now();
    let s = model.scales;
    let result = bisect(&model, s.omega_to_bar(lo), s.omega_to_bar(hi), &settings)?;
    let seconds = started.elapsed().as_secs_f64();
    let (a, b) = (
        s.omega_from_bar(result.bracket.0),
        s.omega_from_bar(result.bracket.1),
    );
    if args.json {
        println!(
            "{}",
            serde_json::json!({ "omega_b": s.omega_from_bar(result.estimate), "bracket": [a, b], "trials": result.trials.len(), "steps": result.steps, "seconds": seconds, "nodes": model.nodes() })
        );
    } else {
        println!(
            "bisection of `{}` at N = {}: omega_b in [{a:.6}, {b:.6}] rad/s ({} trials, {} time steps, {seconds:.1} s)",
            study.name,
            model.nodes(),
            result.trials.len(),
            result.steps
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
        Command::Branch {
            study,
            omega_max,
            out,
        } => branch(study, *omega_max, out.as_deref()),
        Command::Locate {
            study,
            tol,
            extrapolate,
            nodes,
        } => locate_command(study, *tol, *extrapolate, nodes),
        Command::Run { study, out } => run_command(study, out.as_deref()),
        Command::Sweep { study, shard, out } => {
            sweep_command(study, shard.as_deref(), out.as_deref())
        }
        Command::Merge { study, out } => merge_command(study, out.as_deref()),
        Command::Fit { csv, x, y, json } => fit_command(csv, x, y, *json),
        Command::Simulate {
            study,
            omega,
            t_end,
            from_steady,
            perturb,
            ramp_time,
            transient,
            shape_every,
            out,
        } => simulate_command(
            study,
            SimulateOptions {
                omega: *omega,
                t_end: *t_end,
                from_steady: *from_steady,
                perturb: *perturb,
                ramp_time: *ramp_time,
                transient: *transient,
                shape_every: *shape_every,
            },
            out.as_deref(),
        ),
        Command::Bisect {
            study,
            lo,
            hi,
            precision,
        } => bisect_command(study, *lo, *hi, *precision),
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
