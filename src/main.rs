//! Command-line front end of helixbif: parse, load a study, call the library, and print the one
//! report of the command (text, or JSON with `--json`) in one place.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use helixbif::Error;
use helixbif::analysis::dynamics::{BisectSettings, bisect};
use helixbif::analysis::solve::{Solution, solve_at};
use helixbif::boundary::run_boundary;
use helixbif::engine::periodic::branch::OrbitStop;
use helixbif::model::Model;
use helixbif::model::params::ShapeParams;
use helixbif::numerics::fit::power_law;
use helixbif::output::Table;
use helixbif::report::{BisectReport, FitReport, MergeReport, Report, RunReport, Titled};
use helixbif::study::orbits::{OrbitsOptions, branch_settings, run_orbits};
use helixbif::study::plan::{check_accuracy, check_max_nodes};
use helixbif::study::run::run;
use helixbif::study::runs::{
    DEFAULT_MAX_NODES, default_ladder, run_branch, run_ladder, run_locate, run_refinement,
};
use helixbif::study::simulate::{
    OrbitOrigin, SimulateOptions, run_simulate, simulation_provenance,
};
use helixbif::study::slurm::{SlurmJob, SlurmOptions, shard_from_env, submit, write_scripts};
use helixbif::study::sweep::{merge, run_sweep};
use helixbif::study::{Study, default_output, figures, sweep_figures};

const AFTER_HELP: &str = "\
Every command that reads a study takes an optional study file (TOML, SI units); without one it
uses the built-in representative helix (docs/model.md section 7). Relative paths inside a study
resolve against the study file's folder.

--set KEY=VALUE overrides any study field by its dotted path, the value in TOML syntax:
  --set rod.E=2e6   --set discretization.nodes=80   --set shape.handedness=left
  --set 'fluid.model=\"rpy\"'   (the RPY-regularized fluid, docs/model.md section 9)
A whole table is replaced by a TOML inline table:
  --set 'shape={kind=\"straight\", L=0.12, alpha_deg=15}'
With --set and no --out, results go to output/<name>.set-<overrides>/, never over the
study's own output/<name>/.

Exit codes: 0 success; 2 bad input (one line on stderr naming the field and the allowed
range); 1 numerical failure (one line saying where and why; results computed before it are
kept on disk).";

/// Continuation and bifurcation analysis of elastic rods rotating in a viscous fluid
/// (Discrete Elastic Rods + Lighthill slender-body theory).
#[derive(Parser, Debug)]
#[command(name = "helixbif", version, about, after_help = AFTER_HELP)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Options shared by every command that reads a study.
#[derive(Args, Debug)]
struct StudyArgs {
    /// Study file (TOML); without one, the built-in representative helix.
    study: Option<PathBuf>,
    /// Override a study field: dotted key, TOML value (see the end of `helixbif --help`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Print one JSON object on stdout and nothing else there.
    #[arg(long)]
    json: bool,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// One rigidly rotating steady state: observables and Newton convergence.
    #[command(after_help = AFTER_HELP)]
    Solve {
        #[command(flatten)]
        study: StudyArgs,
        /// Rotation rate of the motor (rad/s; positive counter-clockwise seen from above).
        #[arg(long, allow_negative_numbers = true)]
        omega: f64,
        /// Write the node positions and twist angles (SI) to this CSV file.
        #[arg(long, value_name = "FILE.csv")]
        shape: Option<PathBuf>,
    },
    /// Follow the steady branch from rest in omega: branch.csv, events.csv, meta.json, figures.
    #[command(after_help = AFTER_HELP)]
    Branch {
        #[command(flatten)]
        study: StudyArgs,
        /// Rate to follow the branch to (rad/s; negative: towards clockwise rotation); default
        /// the study's `branch.omega_max`.
        #[arg(long, allow_negative_numbers = true)]
        omega_max: Option<f64>,
        /// Output folder; default `output/<study name>/`.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// The critical buckling rate omega_b: first loss of stability of the branch from rest
    /// (kind hopf, fold or branch_point; unstable_at_rest when the rest state is already
    /// unstable; none when the branch stays stable up to branch.omega_max); at a Hopf point its
    /// first Lyapunov coefficient: supercritical or subcritical.
    #[command(after_help = AFTER_HELP)]
    Locate {
        #[command(flatten)]
        study: StudyArgs,
        /// Relative precision of omega_b, |d omega| <= TOL |omega| (default 1e-8; the study's
        /// continuation.event_tol).
        #[arg(long)]
        tol: Option<f64>,
        /// Relative accuracy EPS of omega_b: N is refined from the study's (spacing halved
        /// each time) until the estimated discretization error is below EPS or the model can
        /// go no further (Lighthill's admissible range, --max-nodes), and the error, the N used
        /// and how the error was estimated are reported (docs/model.md section 10).
        #[arg(long, default_value_t = 1e-3, conflicts_with_all = ["single", "extrapolate"])]
        accuracy: f64,
        /// Largest node count of the refinement.
        #[arg(long, default_value_t = DEFAULT_MAX_NODES, conflicts_with_all = ["single", "extrapolate"])]
        max_nodes: usize,
        /// Locate at the study's N only, without an error estimate.
        #[arg(long, conflicts_with = "extrapolate")]
        single: bool,
        /// Run a ladder of node counts and extrapolate omega_b to infinite resolution.
        #[arg(long)]
        extrapolate: bool,
        /// Node counts of the ladder (comma separated); default five inside the admissible range.
        #[arg(long, value_delimiter = ',', requires = "extrapolate")]
        nodes: Vec<usize>,
    },
    /// The stability boundary omega_b against a second study field (e.g. shape.R_over_lambda)
    /// as a curve, by two-parameter continuation of the first loss of stability that `locate`
    /// finds at --from (a Hopf point; a fold or branch point); double Hopf points (where the
    /// boundary switches mode), turning points (where it jumps), zero-Hopf, Bogdanov-Takens and
    /// generalized Hopf points located, the first Lyapunov coefficient (super- or subcritical)
    /// at every Hopf point: boundary.csv, points.csv, boundary.svg, m_loc.svg.
    #[command(after_help = AFTER_HELP)]
    Boundary {
        #[command(flatten)]
        study: StudyArgs,
        /// The study field to vary: a dotted key of a number, or shape.R_over_lambda,
        /// shape.lambda_over_l.
        #[arg(long, value_name = "KEY")]
        vary: String,
        /// First value of the field (the curve starts from locate there).
        #[arg(long, allow_negative_numbers = true)]
        from: f64,
        /// Last value of the field.
        #[arg(long, allow_negative_numbers = true)]
        to: f64,
        /// Output folder; default `output/<study name>.boundary-<KEY>/`.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Do what the study's [study] table declares and write `output/<study name>/`. Kinds:
    /// `locate` (the default without a [study] table: omega_b, or a ladder of node counts),
    /// `branch` (branches from rest, one per case, drawn together), `sweep` (omega_b over a
    /// parameter grid, fits), `boundary` (omega_b as curves in one field, one per case, the
    /// local exponent m_loc along them), `phase` (propulsive force over lambda/l and omegabar
    /// (R/lambda)^m with the stability boundary and natural flagella), `shapes` (steady
    /// shapes and the critical mode), `dynamics` (simulations from rest: time averages over
    /// the branch), `orbits` (periodic orbits from the Hopf point, as `helixbif orbits`).
    #[command(after_help = AFTER_HELP)]
    Run {
        #[command(flatten)]
        study: StudyArgs,
        /// Output folder; default `output/<study name>/`.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Kinds `dynamics` and `orbits`: continue from the checkpoints an interrupted run left
        /// in the output folder (finished simulations are read back, not run again).
        #[arg(long)]
        resume: bool,
    },
    /// omega_b over the parameter grid of a study of kind "sweep" (any other study is refused),
    /// in parallel and resumable; `--shard K/N` runs every N-th point (from the K-th) for
    /// array jobs.
    #[command(after_help = AFTER_HELP)]
    Sweep {
        #[command(flatten)]
        study: StudyArgs,
        /// Run only the points with index = K-1 modulo N; `slurm`: K and N of the Slurm array
        /// task (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_MIN, SLURM_ARRAY_TASK_COUNT).
        #[arg(long, value_name = "K/N|slurm")]
        shard: Option<String>,
        /// Output folder; default `output/<study name>/`.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// A sweep as a Slurm array job (one shard per task) and a merge job after it (afterok):
    /// writes the two sbatch scripts into the output folder and prints the sbatch commands, or
    /// submits them and records both job ids in slurm.json.
    #[command(after_help = AFTER_HELP)]
    Slurm {
        #[command(flatten)]
        study: StudyArgs,
        /// Number of array tasks (shards), 1 to the number of points.
        #[arg(long)]
        tasks: usize,
        /// Wall-time limit of each task and of the merge, HH:MM:SS or D-HH:MM:SS.
        #[arg(long, value_name = "HH:MM:SS")]
        time: Option<String>,
        /// Partition of the jobs (default: the cluster's).
        #[arg(long)]
        partition: Option<String>,
        /// Output folder; default `output/<study name>/`.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Submit both jobs with sbatch instead of printing the commands.
        #[arg(long)]
        submit: bool,
    },
    /// Join the shard files of a study of kind "sweep" (any other study is refused) into
    /// sweep.csv.
    #[command(after_help = AFTER_HELP)]
    Merge {
        #[command(flatten)]
        study: StudyArgs,
        /// Folder holding the shards; default `output/<study name>/`.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Periodic orbits born at the Hopf point that `locate` finds (first Lyapunov coefficient,
    /// shooting on equal BDF2 steps, Floquet multipliers, secant continuation in omega past
    /// folds): orbits.csv (period, amplitude, time averages of hbar, Fpbar, Tp over a period,
    /// multipliers, stability), events.csv (folds, stability changes), amplitude.svg, hbar.svg,
    /// Fpbar.svg, meta.json. Rows are written as each orbit converges.
    #[command(after_help = AFTER_HELP)]
    Orbits {
        #[command(flatten)]
        study: StudyArgs,
        /// Largest number of orbits.
        #[arg(long, default_value_t = 40)]
        max_orbits: usize,
        /// Equal time steps per period (BDF2; the period error falls as steps^-2).
        #[arg(long, default_value_t = 100)]
        steps: usize,
        /// Normal-form radius of the first orbit, in reference lengths ell (the second has
        /// twice it).
        #[arg(long, default_value_t = 1e-3)]
        amplitude: f64,
        /// The branch ends when omega leaves [omega_min, omega_max] (rad/s); default
        /// [0, branch.omega_max].
        #[arg(long, allow_negative_numbers = true)]
        omega_min: Option<f64>,
        #[arg(long, allow_negative_numbers = true)]
        omega_max: Option<f64>,
        /// Output folder; default `output/<study name>/orbits/`.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Take an interrupted branch up again from `checkpoint.json` in the output folder
        /// (written after every orbit): the orbits before it are kept, the next ones appended.
        #[arg(long)]
        resume: bool,
    },
    /// Step the rod through time at a rate (BDF2, adaptive): time series of hbar, Fp, Tp, eta,
    /// shapes, figures, and late-time mean and standard deviation. Uses the study's [newton]
    /// table for the rest and steady states.
    #[command(after_help = AFTER_HELP)]
    Simulate {
        #[command(flatten)]
        study: StudyArgs,
        /// Rotation rate (rad/s; negative: clockwise seen from above); with --from-orbit, the
        /// orbit's by default.
        #[arg(
            long,
            allow_negative_numbers = true,
            required_unless_present = "from_orbit"
        )]
        omega: Option<f64>,
        /// Duration (s).
        #[arg(long)]
        t_end: f64,
        /// Start on the steady state at --omega (default: from rest, the motor spinning up).
        #[arg(long, conflicts_with = "from_orbit")]
        from_steady: bool,
        /// Start on a periodic orbit: a `states/orbit_<index>.json` written by `helixbif orbits`
        /// for the same study; the run is compared with the orbit period by period
        /// (`cycles.csv`: period averages, largest distance of `hbar` from the orbit's, the
        /// simulated period).
        #[arg(long, value_name = "FILE")]
        from_orbit: Option<PathBuf>,
        /// With --from-steady: displace along the least stable mode by this fraction of the
        /// reference length.
        #[arg(long, allow_negative_numbers = true, requires = "from_steady")]
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
        /// Continue from the checkpoint.json an interrupted run left in the output folder
        /// (saved every 25 steps; a larger --t-end extends a finished run).
        #[arg(long)]
        resume: bool,
    },
    /// omega_b the way simulation studies found it: bisection on runs from rest, each judged by
    /// whether the rod settles on the steady state. Uses the study's [newton] table.
    #[command(after_help = AFTER_HELP)]
    Bisect {
        #[command(flatten)]
        study: StudyArgs,
        /// A stable rate (rad/s), nearer zero than --hi (both of one sign).
        #[arg(long, allow_negative_numbers = true)]
        lo: f64,
        /// An unstable rate (rad/s).
        #[arg(long, allow_negative_numbers = true)]
        hi: f64,
        /// Relative width of the final bracket.
        #[arg(long, default_value_t = 1e-2)]
        precision: f64,
        /// Spin-up time of each trial (s); default 0.2 time units mu ell^4/EI.
        #[arg(long)]
        ramp_time: Option<f64>,
        /// Time held at the trial rate after the spin-up (s); default 1.0 time unit
        /// mu ell^4/EI.
        #[arg(long)]
        hold_time: Option<f64>,
    },
    /// Least-squares power law y = C x^p with 95% confidence intervals; rows without
    /// positive numbers in both columns (or whose `status` is not ok) are left out and listed.
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

/// What a command returns: its report, and whether it asks for JSON.
type Outcome = anyhow::Result<Box<dyn Report>>;

fn load(args: &StudyArgs) -> Result<(Study, Model), Error> {
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let model = Model::new(&study.physical())?;
    Ok((study, model))
}

/// `--out`, or the study's default folder (which depends on the `--set` overrides).
fn output_dir(args: &StudyArgs, study: &Study, out: Option<&Path>) -> PathBuf {
    out.map_or_else(|| default_output(&study.name, &args.set), Path::to_path_buf)
}

fn titled<T>(study: &Study, result: T) -> Titled<T> {
    Titled {
        study: study.name.clone(),
        result,
    }
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

fn finite(field: &str, value: f64) -> Result<(), Error> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(Error::input(
            field,
            format!("must be a finite number, got {value}"),
        ))
    }
}

fn solve(study: &StudyArgs, omega: f64, shape: Option<&Path>) -> Outcome {
    finite("--omega", omega)?;
    let (study_file, model) = load(study)?;
    let omegabar = model.scales.omega_to_bar(omega);
    let solution = solve_at(&model, omegabar, &study_file.newton)?;
    if let Some(path) = shape {
        write_shape(path, &model, &solution)?;
    }
    Ok(Box::new(titled(&study_file, solution.summary(&model))))
}

fn branch(study: &StudyArgs, omega_max: Option<f64>, out: Option<&Path>) -> Outcome {
    let (study_file, model) = load(study)?;
    let omega_max = omega_max.unwrap_or(study_file.branch.omega_max);
    if !(omega_max.is_finite() && omega_max != 0.0) {
        return Err(Error::input(
            "--omega-max",
            format!("must be a finite nonzero number (rad/s), got {omega_max}"),
        )
        .into());
    }
    let dir = output_dir(study, &study_file, out);
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
            report.omega_reached, report.stop, report.points, report.out
        ))
        .into());
    }
    Ok(Box::new(titled(&study_file, report)))
}

/// How `locate` treats the node count.
enum Resolution<'a> {
    /// The study's `N` only.
    Single,
    /// Refined until the estimated error is below `accuracy` (relative).
    Refine { accuracy: f64, max_nodes: usize },
    /// Over a ladder (empty: the default one), extrapolated.
    Ladder(&'a [usize]),
}

fn locate_command(study: &StudyArgs, tol: Option<f64>, how: Resolution<'_>) -> Outcome {
    let mut overrides = study.set.clone();
    if let Some(t) = tol {
        if !(t > 0.0 && t < 1e-2) {
            return Err(Error::input("--tol", format!("must lie in (0, 0.01), got {t}")).into());
        }
        overrides.push(format!("continuation.event_tol={t:e}"));
    }
    let study_file = Study::from_path(study.study.as_deref(), &overrides)?;
    match how {
        Resolution::Ladder(nodes) => {
            let ladder = if nodes.is_empty() {
                default_ladder(&study_file)
            } else {
                nodes.to_vec()
            };
            let result = run_ladder(&study_file, &ladder)?;
            Ok(Box::new(titled(&study_file, result)))
        }
        Resolution::Refine {
            accuracy,
            max_nodes,
        } => {
            check_accuracy("--accuracy", accuracy)?;
            check_max_nodes("--max-nodes", max_nodes)?;
            let result = run_refinement(&study_file, accuracy, max_nodes)?;
            Ok(Box::new(titled(&study_file, result)))
        }
        Resolution::Single => {
            let model = Model::new(&study_file.physical())?;
            let located = run_locate(&study_file, &model)?;
            Ok(Box::new(titled(&study_file, located)))
        }
    }
}

fn boundary_command(
    args: &StudyArgs,
    key: &str,
    from: f64,
    to: f64,
    out: Option<&Path>,
) -> Outcome {
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let dir = out.map_or_else(
        || {
            let mut dir = default_output(&study.name, &args.set).into_os_string();
            dir.push(format!(".boundary-{key}"));
            PathBuf::from(dir)
        },
        Path::to_path_buf,
    );
    let report = run_boundary(&study, key, from, to, &dir)?;
    Ok(Box::new(report))
}

fn run_command(args: &StudyArgs, out: Option<&Path>, resume: bool) -> Outcome {
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let dir = output_dir(args, &study, out);
    let started = std::time::Instant::now();
    let result = run(&study, &dir, resume)?;
    Ok(Box::new(RunReport {
        study: study.name.clone(),
        kind: study.study.as_ref().map_or("locate", |p| p.kind()).into(),
        seconds: started.elapsed().as_secs_f64(),
        out: dir.display().to_string(),
        result,
    }))
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

fn sweep_command(args: &StudyArgs, shard: Option<&str>, out: Option<&Path>) -> Outcome {
    let shard = shard
        .map(|s| match s {
            "slurm" => shard_from_env(|name| std::env::var(name).ok()),
            _ => parse_shard(s),
        })
        .transpose()?;
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let dir = output_dir(args, &study, out);
    let summary = run_sweep(&study, &dir, shard)?;
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
    Ok(Box::new(titled(&study, summary)))
}

/// `helixbif slurm`: the scripts of a sweep as an array job and its merge, printed or submitted.
fn slurm_command(
    args: &StudyArgs,
    options: SlurmOptions,
    out: Option<&Path>,
    submit_jobs: bool,
) -> Outcome {
    let path = args.study.as_deref().ok_or_else(|| {
        Error::input(
            "STUDY",
            "`slurm` needs a sweep study file (the array tasks read it)",
        )
    })?;
    let study = Study::from_path(Some(path), &args.set)?;
    let absolute = |p: &Path| -> Result<PathBuf, Error> {
        std::path::absolute(p).map_err(helixbif::output::io_error(p))
    };
    let job = SlurmJob {
        binary: std::env::current_exe()?,
        study: std::fs::canonicalize(path).map_err(helixbif::output::io_error(path))?,
        set: args.set.clone(),
        out: absolute(&output_dir(args, &study, out))?,
        workdir: std::env::current_dir()?,
    };
    let scripts = write_scripts(&study, &job, &options)?;
    if submit_jobs {
        Ok(Box::new(submit(scripts, &job.out)?))
    } else {
        Ok(Box::new(scripts))
    }
}

fn merge_command(args: &StudyArgs, out: Option<&Path>) -> Outcome {
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let dir = output_dir(args, &study, out);
    let (points, shards) = merge(&study, &dir)?;
    sweep_figures(&study, &dir)?;
    Ok(Box::new(MergeReport {
        study: study.name.clone(),
        points,
        shards,
        file: dir.join("sweep.csv").display().to_string(),
    }))
}

fn fit_command(csv: &Path, x: &str, y: &str) -> Outcome {
    let table = Table::read(csv)?;
    let (xc, yc) = (table.index(x)?, table.index(y)?);
    let (kept, left_out) = table.usable(xc, yc, true);
    let (xs, ys): (Vec<f64>, Vec<f64>) = kept.iter().map(|&(_, x, y)| (x, y)).unzip();
    let fit = power_law(&xs, &ys)?;
    Ok(Box::new(FitReport {
        csv: csv.display().to_string(),
        x: x.into(),
        y: y.into(),
        fit,
        left_out,
    }))
}

/// The options of `helixbif orbits`.
struct OrbitsArgs {
    resume: bool,
    max_orbits: usize,
    steps: usize,
    amplitude: f64,
    omega_min: Option<f64>,
    omega_max: Option<f64>,
}

fn orbits_command(args: &StudyArgs, o: &OrbitsArgs, out: Option<&Path>) -> Outcome {
    let (study, model) = load(args)?;
    let opts = OrbitsOptions {
        settings: branch_settings(o.max_orbits, o.steps, o.amplitude),
        omega_range: (
            o.omega_min.unwrap_or(0.0),
            o.omega_max.unwrap_or(study.branch.omega_max),
        ),
        resume: o.resume,
    };
    // The options name their fields as in a study; on the command line they are flags.
    opts.validate().map_err(|e| match e {
        Error::Input { field, message } => Error::Input {
            field: format!(
                "--{}",
                field.trim_start_matches("orbits.").replace('_', "-")
            ),
            message,
        },
        other => other,
    })?;
    let dir = out.map_or_else(
        || default_output(&study.name, &args.set).join("orbits"),
        Path::to_path_buf,
    );
    let report = run_orbits(&study, &model, &opts, &dir)?;
    if let OrbitStop::StepTooSmall(reason) = &report.stop {
        let reached = report.last.as_ref().map_or(f64::NAN, |r| r.omega);
        return Err(Error::Numerical(format!(
            "the orbit branch stalled at omega = {reached:.6e} rad/s after {} orbits ({reason}); \
             the orbits found are in {}",
            report.orbits, report.out
        ))
        .into());
    }
    Ok(Box::new(titled(&study, report)))
}

/// `helixbif simulate`; `omega` and `from_orbit` as given on the command line (`opts` holds the
/// rest).
fn simulate_command(
    args: &StudyArgs,
    omega: Option<f64>,
    from_orbit: Option<&Path>,
    mut opts: SimulateOptions,
    out: Option<&Path>,
) -> Outcome {
    let (study, model) = load(args)?;
    if let Some(path) = from_orbit {
        let origin = OrbitOrigin::read(path)?;
        opts.omega = omega.unwrap_or(origin.start.omega);
        opts.from_orbit = Some(origin);
    }
    opts.newton = study.newton.clone();
    opts.provenance = simulation_provenance(&study);
    let dir = out.map_or_else(
        || default_output(&study.name, &args.set).join("simulate"),
        Path::to_path_buf,
    );
    let bar = indicatif::ProgressBar::new(1000).with_style(
        indicatif::ProgressStyle::with_template("simulate [{elapsed_precise}] {bar:30} {msg}")
            .expect("a valid template"),
    );
    let settings = study.integrator.settings(&model.scales);
    let report = run_simulate(&model, &settings, &opts, &dir, &bar)?;
    Ok(Box::new(titled(&study, report)))
}

/// The bisection's options from the command line (durations in seconds).
struct BisectOptions {
    lo: f64,
    hi: f64,
    precision: f64,
    ramp_time: Option<f64>,
    hold_time: Option<f64>,
}

fn bisect_command(args: &StudyArgs, o: &BisectOptions) -> Outcome {
    let (study, model) = load(args)?;
    for (field, v) in [("--lo", o.lo), ("--hi", o.hi)] {
        finite(field, v)?;
    }
    if !(o.precision > 0.0 && o.precision < 1.0) {
        return Err(Error::input(
            "--precision",
            format!("must lie in (0, 1), got {}", o.precision),
        )
        .into());
    }
    model.check_resolution()?;
    let s = model.scales;
    let mut settings = BisectSettings {
        precision: o.precision,
        newton: study.newton.clone(),
        ..BisectSettings::default()
    };
    for (field, seconds, target) in [
        ("--ramp-time", o.ramp_time, &mut settings.ramp_time),
        ("--hold-time", o.hold_time, &mut settings.hold_time),
    ] {
        if let Some(t) = seconds {
            if !(t.is_finite() && t > 0.0) {
                return Err(Error::input(
                    field,
                    format!("must be a finite number > 0 (s), got {t}"),
                )
                .into());
            }
            *target = t / s.time;
        }
    }
    let started = std::time::Instant::now();
    let result = bisect(
        &model,
        s.omega_to_bar(o.lo),
        s.omega_to_bar(o.hi),
        &settings,
    )?;
    Ok(Box::new(BisectReport::new(
        &study.name,
        model.nodes(),
        &result,
        |w| s.omega_from_bar(w),
        started.elapsed().as_secs_f64(),
    )))
}

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

fn main() -> ExitCode {
    helixbif::numerics::allocator::keep_freed_pages();
    let cli = Cli::parse();
    // The dense matrices here are small (a few hundred rows): threading inside one factorization
    // costs more than it gains; parallelism is over independent solves instead.
    faer::set_global_parallelism(faer::Par::Seq);
    let (result, json) = match &cli.command {
        Command::Solve {
            study,
            omega,
            shape,
        } => (solve(study, *omega, shape.as_deref()), study.json),
        Command::Branch {
            study,
            omega_max,
            out,
        } => (branch(study, *omega_max, out.as_deref()), study.json),
        Command::Locate {
            study,
            tol,
            accuracy,
            max_nodes,
            single,
            extrapolate,
            nodes,
        } => {
            let how = if *extrapolate {
                Resolution::Ladder(nodes)
            } else if *single {
                Resolution::Single
            } else {
                Resolution::Refine {
                    accuracy: *accuracy,
                    max_nodes: *max_nodes,
                }
            };
            (locate_command(study, *tol, how), study.json)
        }
        Command::Run { study, out, resume } => {
            (run_command(study, out.as_deref(), *resume), study.json)
        }
        Command::Boundary {
            study,
            vary,
            from,
            to,
            out,
        } => (
            boundary_command(study, vary, *from, *to, out.as_deref()),
            study.json,
        ),
        Command::Sweep { study, shard, out } => (
            sweep_command(study, shard.as_deref(), out.as_deref()),
            study.json,
        ),
        Command::Slurm {
            study,
            tasks,
            time,
            partition,
            out,
            submit,
        } => (
            slurm_command(
                study,
                SlurmOptions {
                    tasks: *tasks,
                    time: time.clone(),
                    partition: partition.clone(),
                },
                out.as_deref(),
                *submit,
            ),
            study.json,
        ),
        Command::Merge { study, out } => (merge_command(study, out.as_deref()), study.json),
        Command::Fit { csv, x, y, json } => (fit_command(csv, x, y), *json),
        Command::Orbits {
            study,
            max_orbits,
            steps,
            amplitude,
            omega_min,
            omega_max,
            out,
            resume,
        } => (
            orbits_command(
                study,
                &OrbitsArgs {
                    resume: *resume,
                    max_orbits: *max_orbits,
                    steps: *steps,
                    amplitude: *amplitude,
                    omega_min: *omega_min,
                    omega_max: *omega_max,
                },
                out.as_deref(),
            ),
            study.json,
        ),
        Command::Simulate {
            study,
            omega,
            t_end,
            from_steady,
            from_orbit,
            perturb,
            ramp_time,
            transient,
            shape_every,
            out,
            resume,
        } => (
            simulate_command(
                study,
                omega.as_ref().copied(),
                from_orbit.as_deref(),
                SimulateOptions {
                    omega: omega.unwrap_or(f64::NAN),
                    t_end: *t_end,
                    from_steady: *from_steady,
                    perturb: *perturb,
                    from_orbit: None,
                    ramp_time: *ramp_time,
                    transient: *transient,
                    shape_every: *shape_every,
                    newton: Default::default(),
                    resume: *resume,
                    provenance: serde_json::Value::Null,
                },
                out.as_deref(),
            ),
            study.json,
        ),
        Command::Bisect {
            study,
            lo,
            hi,
            precision,
            ramp_time,
            hold_time,
        } => (
            bisect_command(
                study,
                &BisectOptions {
                    lo: *lo,
                    hi: *hi,
                    precision: *precision,
                    ramp_time: *ramp_time,
                    hold_time: *hold_time,
                },
            ),
            study.json,
        ),
    };
    match result {
        Ok(report) => match print(report.as_ref(), json) {
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
