//! The command line's grammar: one clap `Args` struct per command, read by the command itself.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};
use helixbif::analysis::refine::{DEFAULT_ACCURACY, DEFAULT_MAX_NODES};

pub const AFTER_HELP: &str = "\
Every command that reads a study takes an optional study file (TOML, SI units); without one it
uses the built-in representative helix (docs/model.md section 7); sweep, merge and slurm need
one of kind \"sweep\". Relative paths inside a study resolve against the study file's folder.

--set KEY=VALUE overrides any study field by its dotted path, the value in TOML syntax:
  --set rod.E=2e6   --set discretization.nodes=80   --set shape.handedness=left
  --set fluid.model=lighthill   (Lighthill's operator as published; the default is \"rpy\")
A whole table is replaced by a TOML inline table:
  --set 'shape={kind=\"straight\", L=0.12, alpha_deg=15}'
With --set and no --out, results go to output/<name>.set-<overrides>/, never over the
study's own output/<name>/.

Exit codes: 0 success; 2 bad input (one line on stderr naming the field and the allowed
range); 1 numerical failure (one line saying where and why; results computed before it are
kept on disk).

Commands, options and output files: docs/commands.md; study keys: docs/studies.md.";

/// The end of the help of a command that writes an output folder.
pub const FOLDER_HELP: &str = "\
--set KEY=VALUE: a study key by its dotted path, the value in TOML syntax (`helixbif --help`);
with --set and no --out, results go to output/<name>.set-<overrides>/.
Exit codes: 0 success; 1 numerical failure (results computed before it kept on disk); 2 bad input.
Output files and their columns: docs/commands.md; study keys: docs/studies.md.";

/// The end of the help of a command that writes no output folder.
pub const REPORT_HELP: &str = "\
--set KEY=VALUE: a study key by its dotted path, the value in TOML syntax (`helixbif --help`).
Exit codes: 0 success; 1 numerical failure; 2 bad input.
Reports and options: docs/commands.md; study keys: docs/studies.md.";

/// Continuation and bifurcation analysis of elastic rods rotating in a viscous fluid
/// (Discrete Elastic Rods; the RPY-regularized line, or Lighthill's slender-body operator).
#[derive(Parser, Debug)]
#[command(name = "helixbif", version, about, after_help = AFTER_HELP)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// The study argument of the commands that need a sweep study (the built-in default is one
/// helix, not a sweep).
const SWEEP_STUDY: &str =
    "Study file (TOML) of kind \"sweep\", to be given: the built-in default is one helix";

/// Options shared by every command that reads a study.
#[derive(Args, Debug)]
pub struct StudyArgs {
    /// Study file (TOML); without one, the built-in representative helix.
    pub study: Option<PathBuf>,
    /// Override a study field: dotted key, TOML value (see the end of `helixbif --help`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Print one JSON object on stdout and nothing else there.
    #[arg(long)]
    pub json: bool,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// One rigidly rotating steady state at a rate: observables with their estimated errors, and
    /// Newton convergence.
    ///
    /// Reached from rest by a ramp in omega with the study's [newton] table; the same rate at
    /// N/2 + 1 nodes (and, on the RPY line, with another quadrature rule) gives each observable's
    /// estimated error. Writes no folder (--shape writes the node positions and twist angles).
    #[command(after_help = REPORT_HELP)]
    Solve(SolveArgs),
    /// Follow the steady branch from rest in omega, with its stability and events.
    ///
    /// Writes branch.csv, events.csv, hbar.svg, Fpbar.svg, eta.svg, max_re.svg and meta.json,
    /// rows as they are found; a branch that stalls exits 1 with its points kept.
    #[command(after_help = FOLDER_HELP)]
    Branch(BranchArgs),
    /// The buckling rate omega_b with its discretization error and criticality.
    ///
    /// The first loss of stability of the branch from rest: kind hopf, fold or branch_point;
    /// unstable_at_rest when the rest state is already unstable; none when the branch stays
    /// stable up to branch.omega_max. At a Hopf point, the first Lyapunov coefficient
    /// (supercritical, subcritical or undetermined; refined, also its error in N from the two
    /// rungs before the finest). By default N is refined until the estimated error is below
    /// --accuracy; --single locates at the study's N, --extrapolate over a ladder of node
    /// counts. Writes no files.
    #[command(after_help = REPORT_HELP)]
    Locate(LocateArgs),
    /// The stability boundary omega_b(q) as a curve in a second study field.
    ///
    /// Two-parameter continuation of the first loss of stability that `locate --single` finds
    /// at --from. Locates double Hopf points (the boundary switches mode), turning points (it
    /// jumps), zero-Hopf, Bogdanov-Takens and generalized Hopf points, and the first Lyapunov
    /// coefficient at every Hopf point. Writes boundary.csv and points.csv (rewritten after
    /// every point), boundary.svg, m_loc.svg and meta.json.
    #[command(after_help = FOLDER_HELP)]
    Boundary(BoundaryArgs),
    /// Do what the study's [study] table declares, writing output/<study name>/.
    ///
    /// Kinds: `locate` (omega_b refined in N to an accuracy, 1e-3 unless the table says, as
    /// `helixbif locate`: the default without a [study] table; or at the study's N with its
    /// estimated error; or over a ladder of node counts), `branch` (branches from rest,
    /// one per case, drawn together), `sweep` (omega_b over a parameter grid, fits),
    /// `boundary` (omega_b as curves in one field, one per case, the local exponent m_loc along
    /// them), `phase` (propulsive force over lambda/l and omegabar (R/lambda)^m with the
    /// stability boundary and natural flagella), `shapes` (steady shapes and the critical
    /// mode), `dynamics` (simulations from rest: time averages over the branch), `orbits`
    /// (periodic orbits from the Hopf point, as `helixbif orbits`).
    #[command(after_help = FOLDER_HELP)]
    Run(RunArgs),
    /// omega_b over the grid of a sweep study, in parallel, resumable and shardable.
    ///
    /// For a study of kind "sweep" (any other study is refused): each point a locate at its own
    /// N with its error from N/2 + 1 nodes (or, with the study's accuracy, refined to it),
    /// appended to sweep.csv as it finishes; a re-run skips the points already there.
    /// `--shard K/N` runs every N-th point (from the K-th) for array jobs.
    #[command(after_help = FOLDER_HELP, mut_arg("study", |a| a.help(SWEEP_STUDY)))]
    Sweep(SweepArgs),
    /// A sweep as a Slurm array job (one shard per task) and a merge job after it.
    ///
    /// Needs a study file of kind "sweep". Writes slurm-sweep.sbatch and slurm-merge.sbatch into
    /// the output folder and prints the two sbatch commands, or with --submit submits them (the
    /// merge after the array, afterok) and records both job ids in slurm.json.
    #[command(after_help = FOLDER_HELP, mut_arg("study", |a| a.help(SWEEP_STUDY)))]
    Slurm(SlurmArgs),
    /// Join the shard files of a sweep into sweep.csv.
    ///
    /// For a study of kind "sweep" (any other study is refused). Refuses shards of another study
    /// and missing or repeated points; draws the study's figures. With the study's accuracy,
    /// points that fell short of it make it exit 1 after everything is written.
    #[command(after_help = FOLDER_HELP, mut_arg("study", |a| a.help(SWEEP_STUDY)))]
    Merge(MergeArgs),
    /// The branch of periodic orbits born at the Hopf point, with their stability.
    ///
    /// From the Hopf point that `locate --single` finds: shooting on equal BDF2 steps, Floquet
    /// multipliers, secant continuation in omega past folds. Writes orbits.csv (a row as each
    /// orbit converges), states/, events.csv, branch/, amplitude.svg, hbar.svg, Fpbar.svg,
    /// checkpoint.json and meta.json.
    #[command(after_help = FOLDER_HELP)]
    Orbits(OrbitsArgs),
    /// Step the rod through time at a rate (BDF2, adaptive).
    ///
    /// From rest (the motor spun up over --ramp-time), from the steady state (--from-steady) or
    /// from a periodic orbit (--from-orbit). Writes timeseries.csv, shapes.csv, figures and
    /// meta.json; reports the mean and standard deviation of hbar, Fpbar and eta over
    /// t >= --transient. Uses the study's [integrator] table, and its [newton] table for the
    /// rest and steady states.
    #[command(after_help = FOLDER_HELP)]
    Simulate(SimulateArgs),
    /// omega_b by bisection on simulations from rest, as simulation studies find it.
    ///
    /// Each trial spins the motor up over --ramp-time and holds it for --hold-time; it is
    /// stable when the rod settles on the steady state. Uses the study's [newton] table.
    /// Writes no files.
    #[command(after_help = REPORT_HELP)]
    Bisect(BisectArgs),
    /// Fit a power law y = C x^p to two columns of a CSV file.
    ///
    /// Least squares in logarithms, ln y = ln C + p ln x (errors taken as relative), with 95%
    /// confidence intervals from the log-scale residuals (Student t); rows without positive
    /// numbers in both columns, or whose `status` is not ok, are left out and listed.
    #[command(after_help = "Exit codes: 0 success; 1 numerical failure; 2 bad input.")]
    Fit(FitArgs),
}

/// The options of `helixbif solve`.
#[derive(Args, Debug)]
pub struct SolveArgs {
    #[command(flatten)]
    pub study: StudyArgs,
    /// Rotation rate of the motor (rad/s; positive counter-clockwise seen from above).
    #[arg(long, allow_negative_numbers = true)]
    pub omega: f64,
    /// Write the node positions and twist angles (SI) to this CSV file.
    #[arg(long, value_name = "FILE.csv")]
    pub shape: Option<PathBuf>,
}

/// The options of `helixbif branch`.
#[derive(Args, Debug)]
pub struct BranchArgs {
    #[command(flatten)]
    pub study: StudyArgs,
    /// Rate to follow the branch to (rad/s; negative: towards clockwise rotation); default
    /// the study's `branch.omega_max`.
    #[arg(long, allow_negative_numbers = true)]
    pub omega_max: Option<f64>,
    /// Output folder; default `output/<study name>/branch/`.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The options of `helixbif locate`.
#[derive(Args, Debug)]
pub struct LocateArgs {
    #[command(flatten)]
    pub study: StudyArgs,
    /// Relative precision of omega_b, |d omega| <= TOL |omega| (default 1e-8; the study's
    /// continuation.event_tol).
    #[arg(long, allow_negative_numbers = true)]
    pub tol: Option<f64>,
    /// Relative accuracy of omega_b: N is refined from the study's (spacing halved each time)
    /// until the estimated error of the answer (in N and of the quadrature) is below it, or until --max-nodes (with
    /// Lighthill, its admissible range) stops it (docs/model.md section 10).
    #[arg(long, default_value_t = DEFAULT_ACCURACY, conflicts_with_all = ["single", "extrapolate"], allow_negative_numbers = true)]
    pub accuracy: f64,
    /// Largest node count of the refinement: above the study's N, where it starts.
    #[arg(long, default_value_t = DEFAULT_MAX_NODES as i64, conflicts_with_all = ["single", "extrapolate"], allow_negative_numbers = true)]
    pub max_nodes: i64,
    /// Locate at the study's N only, without an error estimate.
    #[arg(long, conflicts_with = "extrapolate")]
    pub single: bool,
    /// Run a ladder of node counts and extrapolate omega_b to infinite resolution.
    #[arg(long)]
    pub extrapolate: bool,
    /// Node counts of the ladder (comma separated); default N, 2N - 1, 4N - 3 from the study's
    /// N (with Lighthill, five inside its admissible range).
    #[arg(
        long,
        value_delimiter = ',',
        requires = "extrapolate",
        allow_negative_numbers = true
    )]
    pub nodes: Vec<i64>,
}

/// The options of `helixbif boundary`.
#[derive(Args, Debug)]
pub struct BoundaryArgs {
    #[command(flatten)]
    pub study: StudyArgs,
    /// The study field to vary: a dotted key of a number, or shape.R_over_lambda,
    /// shape.lambda_over_l.
    #[arg(long, value_name = "KEY")]
    pub vary: String,
    /// First value of the field (the curve starts from locate there).
    #[arg(long, allow_negative_numbers = true)]
    pub from: f64,
    /// Last value of the field.
    #[arg(long, allow_negative_numbers = true)]
    pub to: f64,
    /// Carry every Hopf point of the curve (followed at the study's N) to this relative accuracy
    /// of omega_b, as locate refines it: the column omega_b is then the point's answer,
    /// omega_b_error its estimated error, nodes its finest N (docs/model.md section 11).
    /// Without it, each point at the study's N with its discretization error from N/2 + 1.
    #[arg(long, allow_negative_numbers = true)]
    pub accuracy: Option<f64>,
    /// Largest node count a point is carried to (with --accuracy; default 500).
    #[arg(long, requires = "accuracy", allow_negative_numbers = true)]
    pub max_nodes: Option<i64>,
    /// With --accuracy: refine only points at least this far apart in ln of the varied value
    /// (0 to 1; default 0, every point), the first and last of each curve included, and give
    /// the points between the refined correction interpolated in ln q, with the interpolation's
    /// error added to theirs; where that error is above the accuracy, more points are refined
    /// (docs/model.md section 11).
    #[arg(long, allow_negative_numbers = true)]
    pub carry_spacing: Option<f64>,
    /// Output folder; default `output/<study name>.boundary-<KEY>/`.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The options of `helixbif run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    #[command(flatten)]
    pub study: StudyArgs,
    /// Output folder; default `output/<study name>/`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Kinds `dynamics` and `orbits`: continue from the checkpoints an interrupted run left
    /// in the output folder (finished simulations are read back, not run again); kind
    /// `boundary`: read back the curves a run of the same study finished, follow the rest.
    #[arg(long)]
    pub resume: bool,
}

/// The options of `helixbif sweep`.
#[derive(Args, Debug)]
pub struct SweepArgs {
    #[command(flatten)]
    pub study: StudyArgs,
    /// Run only the points with index = K-1 modulo N; `slurm`: K and N of the Slurm array
    /// task (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_MIN, SLURM_ARRAY_TASK_COUNT).
    #[arg(long, value_name = "K/N|slurm")]
    pub shard: Option<String>,
    /// Output folder; default `output/<study name>/`.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The options of `helixbif slurm`.
#[derive(Args, Debug)]
pub struct SlurmArgs {
    #[command(flatten)]
    pub study: StudyArgs,
    /// Number of array tasks (shards), 1 to the number of points.
    #[arg(long, allow_negative_numbers = true)]
    pub tasks: i64,
    /// Wall-time limit of each task and of the merge, HH:MM:SS or D-HH:MM:SS.
    #[arg(long, value_name = "HH:MM:SS")]
    pub time: Option<String>,
    /// Partition of the jobs (default: the cluster's).
    #[arg(long)]
    pub partition: Option<String>,
    /// Output folder; default `output/<study name>/`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Submit both jobs with sbatch instead of printing the commands.
    #[arg(long)]
    pub submit: bool,
}

/// The options of `helixbif merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    #[command(flatten)]
    pub study: StudyArgs,
    /// Folder holding the shards; default `output/<study name>/`.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The options of `helixbif orbits`.
#[derive(Args, Debug)]
pub struct OrbitsArgs {
    #[command(flatten)]
    pub study: StudyArgs,
    /// Largest number of orbits.
    #[arg(long, default_value_t = 40, allow_negative_numbers = true)]
    pub max_orbits: i64,
    /// Equal time steps per period (BDF2; the period error falls as steps^-2).
    #[arg(long, default_value_t = 100, allow_negative_numbers = true)]
    pub steps: i64,
    /// Normal-form radius of the first orbit, in reference lengths ell (the second has
    /// twice it).
    #[arg(long, default_value_t = 1e-3, allow_negative_numbers = true)]
    pub amplitude: f64,
    /// Lower end of the rates the branch may visit (rad/s); default 0.
    #[arg(long, allow_negative_numbers = true)]
    pub omega_min: Option<f64>,
    /// Upper end of the rates the branch may visit (rad/s); default the study's
    /// branch.omega_max.
    #[arg(long, allow_negative_numbers = true)]
    pub omega_max: Option<f64>,
    /// Output folder; default `output/<study name>/orbits/`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Take an interrupted branch up again from `checkpoint.json` in the output folder
    /// (written after every orbit): the orbits before it are kept, the next ones appended. One
    /// written for another rod, fluid, shape or discretization or with other options (but
    /// --max-orbits and the range) is refused.
    #[arg(long)]
    pub resume: bool,
}

/// The options of `helixbif simulate`.
#[derive(Args, Debug)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub study: StudyArgs,
    /// Rotation rate (rad/s; negative: clockwise seen from above); with --from-orbit, the
    /// orbit's by default.
    #[arg(
        long,
        allow_negative_numbers = true,
        required_unless_present = "from_orbit"
    )]
    pub omega: Option<f64>,
    /// Duration (s).
    #[arg(long, allow_negative_numbers = true)]
    pub t_end: f64,
    /// Start on the steady state at --omega (default: from rest, the motor spinning up).
    #[arg(long, conflicts_with = "from_orbit")]
    pub from_steady: bool,
    /// Start on a periodic orbit: a `states/orbit_<index>.json` written by `helixbif orbits`
    /// for the same study; the run is compared with the orbit period by period
    /// (`cycles.csv`: period averages, largest distance of `hbar` from the orbit's, the
    /// simulated period).
    #[arg(long, value_name = "FILE")]
    pub from_orbit: Option<PathBuf>,
    /// With --from-steady: displace along the least stable mode by this fraction of the
    /// reference length.
    #[arg(long, allow_negative_numbers = true, requires = "from_steady")]
    pub perturb: Option<f64>,
    /// Spin-up time (s) of a run from rest.
    #[arg(long, default_value_t = 20.0, allow_negative_numbers = true)]
    pub ramp_time: f64,
    /// Statistics over t >= this (s); default the second half of the run, and never the
    /// spin-up of a run from rest.
    #[arg(long, allow_negative_numbers = true)]
    pub transient: Option<f64>,
    /// Write the shape every this many time steps (0: never).
    #[arg(long, default_value_t = 50, allow_negative_numbers = true)]
    pub shape_every: i64,
    /// Output folder; default `output/<study name>/simulate/`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Continue from the checkpoint.json an interrupted run left in the output folder
    /// (saved every 25 steps; a larger --t-end extends a finished run).
    #[arg(long)]
    pub resume: bool,
}

/// The options of `helixbif bisect`.
#[derive(Args, Debug)]
pub struct BisectArgs {
    #[command(flatten)]
    pub study: StudyArgs,
    /// A stable rate (rad/s), nearer zero than --hi (both of one sign).
    #[arg(long, allow_negative_numbers = true)]
    pub lo: f64,
    /// An unstable rate (rad/s).
    #[arg(long, allow_negative_numbers = true)]
    pub hi: f64,
    /// Relative width of the final bracket.
    #[arg(long, default_value_t = 1e-2, allow_negative_numbers = true)]
    pub precision: f64,
    /// Spin-up time of each trial (s); default 0.2 time units mu ell^4/EI.
    #[arg(long, allow_negative_numbers = true)]
    pub ramp_time: Option<f64>,
    /// Time held at the trial rate after the spin-up (s); default 1.0 time unit
    /// mu ell^4/EI.
    #[arg(long, allow_negative_numbers = true)]
    pub hold_time: Option<f64>,
}

/// The options of `helixbif fit`.
#[derive(Args, Debug)]
pub struct FitArgs {
    /// CSV file with a header row.
    pub csv: PathBuf,
    /// Column of x.
    #[arg(long)]
    pub x: String,
    /// Column of y.
    #[arg(long)]
    pub y: String,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}
