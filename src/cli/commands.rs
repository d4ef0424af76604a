//! The commands: each reads its options, loads the study, calls the library and returns its
//! report (printed by [`super::print`]).

use std::path::{Path, PathBuf};

use helixbif::Error;
use helixbif::analysis::dynamics::{BisectSettings, bisect as bisect_omega};
use helixbif::analysis::solve::{Solution, observable_errors, solve_at};
use helixbif::engine::periodic::branch::OrbitStop;
use helixbif::model::Model;
use helixbif::numerics::fit::power_law;
use helixbif::study::boundary::run_boundary;
use helixbif::study::branch::branch_report;
use helixbif::study::locate::{Resolution, locate_study};
use helixbif::study::orbits::{OrbitsOptions, branch_settings, run_orbits};
use helixbif::study::output::Table;
use helixbif::study::output::{Provenance, make_writable_dir};
use helixbif::study::plan::{
    check_accuracy, check_max_nodes, check_refinement_room, point_accuracy, with_carry_spacing,
};
use helixbif::study::run::run as run_study;
use helixbif::study::simulate::{
    OrbitOrigin, SimulateOptions, default_transient, run_simulate, simulation_provenance,
};
use helixbif::study::slurm::{SlurmJob, SlurmOptions, shard_from_env, submit, write_scripts};
use helixbif::study::sweep::{merge as merge_shards, run_sweep};
use helixbif::study::{Study, default_output, sweep_figures};

use super::args::{
    BisectArgs, BoundaryArgs, BranchArgs, FitArgs, LocateArgs, MergeArgs, OrbitsArgs, RunArgs,
    SimulateArgs, SlurmArgs, SolveArgs, StudyArgs, SweepArgs,
};
use super::report::{BisectReport, FitReport, MergeReport, Plain, Report, RunReport, Titled};

/// What a command returns: its report, and what it fell short of (a numerical failure reported
/// after the report is printed: the report holds everything computed).
pub struct Done {
    pub report: Box<dyn Report>,
    pub shortfall: Option<String>,
}

/// A report that reached what it was asked for.
fn done(report: impl Report + 'static) -> Done {
    Done {
        report: Box::new(report),
        shortfall: None,
    }
}

/// What a command returns: its outcome, or why it failed.
pub type Outcome = anyhow::Result<Done>;

fn load(args: &StudyArgs) -> Result<(Study, Model), Error> {
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let model = Model::new(&study.physical())?;
    Ok((study, model))
}

/// `--out`, made and checked writable (an unusable folder is bad input), or the study's default
/// folder (which depends on the `--set` overrides) with the command's own subfolder `sub`.
fn output_dir(
    args: &StudyArgs,
    study: &Study,
    out: Option<&Path>,
    sub: Option<&str>,
) -> Result<PathBuf, Error> {
    let Some(out) = out else {
        let dir = default_output(&study.name, &args.set);
        return Ok(sub.map_or_else(|| dir.clone(), |s| dir.join(s)));
    };
    let unusable = |e: std::io::Error| {
        Error::input(
            "--out",
            format!("cannot write results into {}: {e}", out.display()),
        )
    };
    make_writable_dir(out).map_err(unusable)?;
    Ok(out.to_path_buf())
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

/// A count given on the command line: a negative number (read, to be refused here) is refused
/// with the smallest count allowed, `min`; the rest of the range is checked where the count is
/// used.
fn count(field: &str, value: i64, min: usize) -> Result<usize, Error> {
    usize::try_from(value)
        .map_err(|_| Error::input(field, format!("must be >= {min}, got {value}")))
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

pub fn solve(args: &SolveArgs) -> Outcome {
    let (omega, shape) = (args.omega, args.shape.as_deref());
    finite("--omega", omega)?;
    let (study_file, model) = load(&args.study)?;
    let omegabar = model.scales.omega_to_bar(omega);
    let solution = solve_at(&model, omegabar, &study_file.newton)?;
    if let Some(path) = shape {
        write_shape(path, &model, &solution)?;
    }
    let errors = observable_errors(&study_file.physical(), &solution, &study_file.newton);
    let summary = solution.summary(&model, errors);
    Ok(done(titled(&study_file, summary)))
}

pub fn branch(args: &BranchArgs) -> Outcome {
    let (study, out) = (&args.study, args.out.as_deref());
    let (study_file, model) = load(study)?;
    let omega_max = args.omega_max.unwrap_or(study_file.branch.omega_max);
    if !(omega_max.is_finite() && omega_max != 0.0) {
        return Err(Error::input(
            "--omega-max",
            format!("must be a finite nonzero number (rad/s), got {omega_max}"),
        )
        .into());
    }
    let dir = output_dir(study, &study_file, out, Some("branch"))?;
    // A continuation that stalled prints its report (the points and events found) before the
    // failure.
    let report = branch_report(
        &study_file,
        &model,
        omega_max,
        &dir,
        &Provenance::of_process(),
    )?;
    let shortfall = report.stall_message();
    Ok(Done {
        report: Box::new(titled(&study_file, report)),
        shortfall,
    })
}

pub fn locate(args: &LocateArgs) -> Outcome {
    let study = &args.study;
    let how = if args.extrapolate {
        let nodes = args.nodes.iter().map(|&n| count("--nodes", n, 5));
        Resolution::Ladder(nodes.collect::<Result<_, _>>()?)
    } else if args.single {
        Resolution::Single
    } else {
        Resolution::Refine {
            accuracy: args.accuracy,
            max_nodes: count("--max-nodes", args.max_nodes, 5)?,
        }
    };
    let mut overrides = study.set.clone();
    if let Some(t) = args.tol {
        if !(t > 0.0 && t < 1e-2) {
            return Err(Error::input("--tol", format!("must lie in (0, 0.01), got {t}")).into());
        }
        overrides.push(format!("continuation.event_tol={t:e}"));
    }
    let study_file = Study::from_path(study.study.as_deref(), &overrides)?;
    if let Resolution::Refine {
        accuracy,
        max_nodes,
    } = how
    {
        check_accuracy("--accuracy", accuracy)?;
        check_max_nodes("--max-nodes", max_nodes)?;
        check_refinement_room("--max-nodes", max_nodes, &study_file.physical())?;
    }
    let result = locate_study(&study_file, &how)?;
    let shortfall = result.shortfall();
    Ok(Done {
        report: Box::new(titled(&study_file, result)),
        shortfall,
    })
}

pub fn boundary(b: &BoundaryArgs) -> Outcome {
    let (args, key, out) = (&b.study, b.vary.as_str(), b.out.as_deref());
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let dir = match out {
        Some(_) => output_dir(args, &study, out, None)?,
        None => {
            let mut dir = default_output(&study.name, &args.set).into_os_string();
            dir.push(format!(".boundary-{key}"));
            PathBuf::from(dir)
        }
    };
    let max_nodes = b
        .max_nodes
        .map(|m| count("--max-nodes", m, 5))
        .transpose()?;
    let accuracy = with_carry_spacing(
        point_accuracy(b.accuracy, max_nodes, ["--accuracy", "--max-nodes"])?,
        b.carry_spacing,
        (b.from, b.to),
        ["--accuracy", "--carry-spacing"],
    )?;
    if let Some(a) = accuracy {
        check_refinement_room("--max-nodes", a.max_nodes, &study.physical())?;
    }
    let provenance = Provenance::of_process();
    let (_, report) = run_boundary(&study, key, (b.from, b.to), accuracy, &dir, &provenance)?;
    let report = report?;
    let shortfall = report.shortfall();
    Ok(Done {
        report: Box::new(Plain(report)),
        shortfall,
    })
}

pub fn run(r: &RunArgs) -> Outcome {
    let (args, out, resume) = (&r.study, r.out.as_deref(), r.resume);
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let dir = output_dir(args, &study, out, None)?;
    let started = std::time::Instant::now();
    let result = run_study(&study, &dir, resume, &Provenance::of_process())?;
    Ok(done(RunReport {
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

pub fn sweep(s: &SweepArgs) -> Outcome {
    let (args, out) = (&s.study, s.out.as_deref());
    let shard = s
        .shard
        .as_deref()
        .map(|s| match s {
            "slurm" => shard_from_env(|name| std::env::var(name).ok()),
            _ => parse_shard(s),
        })
        .transpose()?;
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let dir = output_dir(args, &study, out, None)?;
    let summary = run_sweep(&study, &dir, shard)?;
    let figures = match shard {
        None => sweep_figures(&study, &dir).map(|_| ()),
        Some(_) => Ok(()),
    };
    // A shard that falls short of the accuracy has still done its points (a requeue would not
    // help, and the merge must run): the merge reports it.
    let shortfall = summary.shortfall().filter(|_| shard.is_none());
    if summary.failed > 0 {
        let what = points_failed(summary.failed);
        return Err(failed_points(&what, &summary.file, shortfall, figures).into());
    }
    figures?;
    Ok(Done {
        report: Box::new(titled(&study, summary)),
        shortfall,
    })
}

/// "K sweep point(s) failed".
fn points_failed(count: usize) -> String {
    match count {
        1 => "1 sweep point failed".into(),
        _ => format!("{count} sweep points failed"),
    }
}

/// The error of a sweep file `file` with failed points (`what` says which), once every row and
/// figure is written. Failed points come first; the shortfall of the accuracy and a figure the
/// failed points left without enough rows are said beside.
fn failed_points(
    what: &str,
    file: &str,
    shortfall: Option<String>,
    figures: Result<(), Error>,
) -> Error {
    let also = shortfall
        .into_iter()
        .chain(figures.err().map(|e| format!("the figures: {e}")))
        .map(|s| format!("; {s}"))
        .collect::<String>();
    Error::Numerical(format!("{what}; see the status column of {file}{also}"))
}

/// `helixbif slurm`: the scripts of a sweep as an array job and its merge, printed or submitted.
pub fn slurm(s: &SlurmArgs) -> Outcome {
    let (args, out, submit_jobs) = (&s.study, s.out.as_deref(), s.submit);
    let options = SlurmOptions {
        tasks: count("--tasks", s.tasks, 1)?,
        time: s.time.clone(),
        partition: s.partition.clone(),
    };
    let path = args.study.as_deref().ok_or_else(|| {
        Error::input(
            "STUDY",
            "`slurm` needs a sweep study file (the array tasks read it)",
        )
    })?;
    let study = Study::from_path(Some(path), &args.set)?;
    let absolute = |p: &Path| -> Result<PathBuf, Error> {
        std::path::absolute(p).map_err(helixbif::study::output::io_error(p))
    };
    let job = SlurmJob {
        binary: std::env::current_exe()?,
        study: std::fs::canonicalize(path).map_err(helixbif::study::output::io_error(path))?,
        set: args.set.clone(),
        out: absolute(&output_dir(args, &study, out, None)?)?,
        workdir: std::env::current_dir()?,
    };
    let scripts = write_scripts(&study, &job, &options)?;
    if submit_jobs {
        Ok(done(Plain(submit(scripts, &job.out)?)))
    } else {
        Ok(done(Plain(scripts)))
    }
}

pub fn merge(m: &MergeArgs) -> Outcome {
    let (args, out) = (&m.study, m.out.as_deref());
    let study = Study::from_path(args.study.as_deref(), &args.set)?;
    let dir = output_dir(args, &study, out, None)?;
    let merged = merge_shards(&study, &dir)?;
    let figures = sweep_figures(&study, &dir).map(|_| ());
    let file = dir.join("sweep.csv").display().to_string();
    let shortfall = merged.reach.as_ref().and_then(|r| r.shortfall(&file));
    // A shard run by hand (or requeued no more) can leave failed points: the merge keeps their
    // rows and fails for them, as the unsharded sweep does.
    if !merged.failed.is_empty() {
        let points: Vec<String> = merged.failed.iter().map(|(i, _)| i.to_string()).collect();
        let shards: std::collections::BTreeSet<usize> =
            merged.failed.iter().map(|&(_, k)| k).collect();
        let shards: Vec<String> = shards
            .iter()
            .map(|k| format!("--shard {k}/{}", merged.shards))
            .collect();
        let what = format!(
            "{} (point {}; run `helixbif sweep` again with {} to compute them)",
            points_failed(merged.failed.len()),
            points.join(", "),
            shards.join(", then ")
        );
        return Err(failed_points(&what, &file, shortfall, figures).into());
    }
    figures?;
    Ok(Done {
        report: Box::new(MergeReport {
            study: study.name.clone(),
            points: merged.points,
            shards: merged.shards,
            file,
            warned: merged.warned,
            reach: merged.reach,
        }),
        shortfall,
    })
}

pub fn fit(f: &FitArgs) -> Outcome {
    let (csv, x, y) = (f.csv.as_path(), f.x.as_str(), f.y.as_str());
    let table = Table::read(csv)?;
    let (xc, yc) = (table.index(x)?, table.index(y)?);
    let (kept, left_out) = table.usable(xc, yc, true);
    let (xs, ys): (Vec<f64>, Vec<f64>) = kept.iter().map(|&(_, x, y)| (x, y)).unzip();
    let fit = power_law(&xs, &ys)?;
    Ok(done(FitReport {
        csv: csv.display().to_string(),
        x: x.into(),
        y: y.into(),
        fit,
        left_out,
    }))
}

pub fn orbits(o: &OrbitsArgs) -> Outcome {
    let (args, out) = (&o.study, o.out.as_deref());
    let (study, model) = load(args)?;
    let opts = OrbitsOptions {
        settings: branch_settings(
            count("--max-orbits", o.max_orbits, 2)?,
            count("--steps", o.steps, 8)?,
            o.amplitude,
        ),
        omega_range: (
            o.omega_min.unwrap_or(0.0),
            o.omega_max.unwrap_or(study.branch.omega_max),
        ),
        resume: o.resume,
    };
    // On the command line the options' fields are flags.
    opts.validate_naming(|s| format!("--{}", s.replace('_', "-")))?;
    let dir = output_dir(args, &study, out, Some("orbits"))?;
    let report = run_orbits(&study, &model, &opts, &dir, &Provenance::of_process())?;
    if let OrbitStop::StepTooSmall(reason) = &report.stop {
        let reached = report.last.as_ref().map_or(f64::NAN, |r| r.omega);
        return Err(Error::Numerical(format!(
            "the orbit branch stalled at omega = {reached:.6e} rad/s after {} orbits ({reason}); \
             the orbits found are in {}",
            report.orbits, report.out
        ))
        .into());
    }
    Ok(done(titled(&study, report)))
}

/// `helixbif simulate`; `omega` and `from_orbit` as given on the command line (`opts` holds the
/// rest).
pub fn simulate(s: &SimulateArgs) -> Outcome {
    let (args, omega, from_orbit, out) =
        (&s.study, s.omega, s.from_orbit.as_deref(), s.out.as_deref());
    let mut opts = SimulateOptions {
        omega: omega.unwrap_or(f64::NAN),
        t_end: s.t_end,
        from_steady: s.from_steady,
        perturb: s.perturb,
        from_orbit: None,
        ramp_time: s.ramp_time,
        transient: s.transient.unwrap_or_else(|| {
            let from_rest = !s.from_steady && s.from_orbit.is_none();
            default_transient(s.t_end, s.ramp_time, from_rest)
        }),
        shape_every: count("--shape-every", s.shape_every, 0)?,
        newton: Default::default(),
        resume: s.resume,
        provenance: serde_json::Value::Null,
    };
    let (study, model) = load(args)?;
    if let Some(path) = from_orbit {
        let origin = OrbitOrigin::read(path)?;
        opts.omega = omega.unwrap_or(origin.start.omega);
        opts.from_orbit = Some(origin);
    }
    opts.newton = study.newton.clone();
    opts.provenance = simulation_provenance(&study);
    let dir = output_dir(args, &study, out, Some("simulate"))?;
    let bar = helixbif::study::progress::bar("simulate");
    let settings = study.integrator.settings(&model.scales);
    let report = run_simulate(
        &study,
        &model,
        &settings,
        &opts,
        &dir,
        &bar,
        &Provenance::of_process(),
    )?;
    Ok(done(titled(&study, report)))
}

pub fn bisect(o: &BisectArgs) -> Outcome {
    let args = &o.study;
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
    let result = bisect_omega(
        &model,
        s.omega_to_bar(o.lo),
        s.omega_to_bar(o.hi),
        &settings,
    )?;
    Ok(done(BisectReport::new(
        &study.name,
        model.nodes(),
        &result,
        |w| s.omega_from_bar(w),
        started.elapsed().as_secs_f64(),
    )))
}
