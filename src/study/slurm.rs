//! Sweeps on a Slurm cluster: the shard of an array task read from its environment, and the
//! `sbatch` scripts behind `helixbif slurm` (an array over the shards, a merge that waits for it).
//!
//! A sweep point is an independent `locate` of seconds to minutes, so on a cluster the unit of
//! work is one shard per array task (`helixbif sweep STUDY --shard slurm`), each writing its own
//! resumable file (see [`super::sweep`]); the merge job joins the shards once every task has
//! succeeded (`--dependency=afterok`) and refuses missing or repeated points. A task that is
//! killed, preempted or cancelled and run again in the same array (`scontrol requeue JOB_K`) sees
//! the same environment, so it takes the same shard and skips the points already in its file.
//! Resubmitting one element as a new array (`sbatch --array=K`) would not: that array has one
//! task, so `--shard slurm` would read shard 1 of 1.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde::Serialize;

use super::Study;
use super::sweep::{cases, grid, shard_files, sweep_plan};
use crate::study::output::{create_dir, io_error, write_atomically};
use crate::{Error, Result};

/// The variables of an array task that `--shard slurm` needs (Slurm sets them in every task of
/// an array job; `SLURM_ARRAY_TASK_STEP` and `SLURM_ARRAY_TASK_MAX`, when present, are only
/// checked against them).
pub const ARRAY_VARIABLES: [&str; 3] = [
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_COUNT",
];

/// The shard `(K, N)` of the current array task: `K = (SLURM_ARRAY_TASK_ID -
/// SLURM_ARRAY_TASK_MIN) / SLURM_ARRAY_TASK_STEP + 1` and `N = SLURM_ARRAY_TASK_COUNT`, so an
/// array `--array=1-N` (or `0-(N-1)`) runs shards `1/N .. N/N`. `var` looks a variable up
/// (`std::env::var` in the binary, a table in tests). Missing or inconsistent variables (outside
/// an array task, or an array that is not a range with a constant step) are an input error
/// naming them.
pub fn shard_from_env(var: impl Fn(&str) -> Option<String>) -> Result<(usize, usize)> {
    let field = "--shard slurm";
    let names = ARRAY_VARIABLES.join(", ");
    let read = |name: &str| -> Result<Option<usize>> {
        match var(name) {
            None => Ok(None),
            Some(text) => text.trim().parse().map(Some).map_err(|_| {
                Error::input(
                    field,
                    format!("{name} = `{text}` is not a non-negative integer (needs {names})"),
                )
            }),
        }
    };
    let require = |name: &str| -> Result<usize> {
        read(name)?.ok_or_else(|| {
            Error::input(
                field,
                format!(
                    "{name} is not set: needs {names}, which Slurm sets in the tasks of an array job (sbatch --array)"
                ),
            )
        })
    };
    let (id, min, count) = (
        require(ARRAY_VARIABLES[0])?,
        require(ARRAY_VARIABLES[1])?,
        require(ARRAY_VARIABLES[2])?,
    );
    let step = read("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1);
    let max = read("SLURM_ARRAY_TASK_MAX")?;
    let inconsistent = || {
        Error::input(
            field,
            format!(
                "SLURM_ARRAY_TASK_ID = {id}, SLURM_ARRAY_TASK_MIN = {min}, SLURM_ARRAY_TASK_COUNT = {count}, SLURM_ARRAY_TASK_STEP = {step}{}: not a task of an array MIN-MAX:STEP (use --shard K/N for other layouts)",
                max.map(|m| format!(", SLURM_ARRAY_TASK_MAX = {m}"))
                    .unwrap_or_default()
            ),
        )
    };
    if count == 0 || step == 0 || id < min || (id - min) % step != 0 {
        return Err(inconsistent());
    }
    let k = (id - min) / step + 1;
    let last = (count - 1)
        .checked_mul(step)
        .and_then(|span| span.checked_add(min));
    if k > count || max.is_some_and(|m| Some(m) != last) {
        return Err(inconsistent());
    }
    Ok((k, count))
}

/// What the scripts run and where: every path absolute, because an array task starts on another
/// machine, possibly in another folder.
#[derive(Clone, Debug)]
pub struct SlurmJob {
    /// The `helixbif` binary the tasks run (the one that wrote the scripts).
    pub binary: PathBuf,
    /// The study file.
    pub study: PathBuf,
    /// The `--set` overrides, passed on to every task and to the merge (they change the
    /// study's fingerprint, so the merge must see the same ones).
    pub set: Vec<String>,
    /// The output folder of the sweep (shards, logs, scripts, `slurm.json`).
    pub out: PathBuf,
    /// The folder the tasks start in (relative paths inside the study resolve from there).
    pub workdir: PathBuf,
}

/// Resources of the array tasks and the merge job.
#[derive(Clone, Debug)]
pub struct SlurmOptions {
    /// Number of array tasks (shards).
    pub tasks: usize,
    /// Wall-time limit of each task and of the merge job, `[D-]HH:MM:SS` (else the partition's).
    pub time: Option<String>,
    /// Partition (else the cluster's default).
    pub partition: Option<String>,
}

/// The scripts written for a sweep and the two `sbatch` commands that submit them.
#[derive(Clone, Debug, Serialize)]
pub struct SlurmScripts {
    /// Name of the study.
    pub study: String,
    /// Points of the sweep.
    pub points: usize,
    /// Array tasks (shards).
    pub tasks: usize,
    /// `slurm-sweep.sbatch`, the array.
    pub array_script: PathBuf,
    /// `slurm-merge.sbatch`, the merge.
    pub merge_script: PathBuf,
    /// Shell commands: the first submits the array, the second the merge depending on it.
    pub commands: [String; 2],
}

/// What `--submit` recorded in `slurm.json`.
#[derive(Clone, Debug, Serialize)]
pub struct SlurmSubmission {
    #[serde(flatten)]
    pub scripts: SlurmScripts,
    /// Job id of the array (its tasks are `ARRAY_1 .. ARRAY_N`).
    pub array_job: u64,
    /// Job id of the merge.
    pub merge_job: u64,
    /// The merge's dependency, `afterok:ARRAY`.
    pub dependency: String,
}

/// Checks a wall-time limit `HH:MM:SS` or `D-HH:MM:SS` (minutes and seconds `00..59`, not zero).
pub fn check_time(text: &str) -> Result<()> {
    let bad = || {
        Error::input(
            "--time",
            format!(
                "expected HH:MM:SS or D-HH:MM:SS (minutes and seconds 00..59, more than zero), got `{text}`"
            ),
        )
    };
    let (days, clock) = match text.split_once('-') {
        Some((d, rest)) => (Some(d), rest),
        None => (None, text),
    };
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let fields: Vec<&str> = clock.split(':').collect();
    let [h, m, s] = fields[..] else {
        return Err(bad());
    };
    if !(days.is_none_or(digits) && digits(h) && m.len() == 2 && s.len() == 2) {
        return Err(bad());
    }
    let number = |x: &str| x.parse::<u64>().map_err(|_| bad());
    let (d, h, m, s) = (
        days.map_or(Ok(0), number)?,
        number(h)?,
        number(m)?,
        number(s)?,
    );
    if m > 59 || s > 59 || d + h + m + s == 0 {
        return Err(bad());
    }
    Ok(())
}

/// Checks a partition name (or a comma-separated list): letters, digits, `_ . -`.
fn check_partition(text: &str) -> Result<()> {
    let ok = text.split(',').all(|p| {
        !p.is_empty()
            && p.bytes()
                .all(|b| b.is_ascii_alphanumeric() || b"_.-".contains(&b))
    });
    if ok {
        Ok(())
    } else {
        Err(Error::input(
            "--partition",
            format!(
                "expected a partition name (letters, digits, _ . -; several separated by commas), got `{text}`"
            ),
        ))
    }
}

/// A word for the shell, in single quotes.
fn quote(text: &str) -> String {
    format!("'{}'", text.replace('\'', r"'\''"))
}

/// A path as text for a script (quoted there), refusing what is not UTF-8.
fn utf8<'a>(field: &str, path: &'a Path) -> Result<&'a str> {
    path.to_str()
        .ok_or_else(|| Error::input(field, format!("{} is not valid UTF-8", path.display())))
}

/// A path as text for a `#SBATCH` line, which takes no quotes: refuses whitespace, quotes,
/// backslashes and `%` (a file-name pattern there).
fn sbatch_path<'a>(field: &str, path: &'a Path) -> Result<&'a str> {
    let text = utf8(field, path)?;
    if text
        .chars()
        .any(|c| c.is_whitespace() || c.is_control() || "%'\"\\".contains(c))
    {
        return Err(Error::input(
            field,
            format!(
                "{text}: a folder for Slurm's #SBATCH lines may not contain whitespace, quotes, backslashes or %"
            ),
        ));
    }
    Ok(text)
}

/// The job name: `helixbif-<study name>` in characters every Slurm tool shows as they are.
fn job_name(study: &str) -> String {
    let name: String = study
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "_.-".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("helixbif-{name}")
}

/// The `#SBATCH` lines for the time limit and the partition, if given.
fn resource_lines(options: &SlurmOptions) -> String {
    let mut lines = String::new();
    if let Some(t) = &options.time {
        lines.push_str(&format!("#SBATCH --time={t}\n"));
    }
    if let Some(p) = &options.partition {
        lines.push_str(&format!("#SBATCH --partition={p}\n"));
    }
    lines
}

/// The helixbif command line of a script: binary, subcommand, study, the extra arguments, the
/// overrides, each quoted for the shell.
fn command_line(job: &SlurmJob, subcommand: &str, extra: &[&str]) -> Result<String> {
    let mut words = vec![
        quote(utf8("helixbif", &job.binary)?),
        subcommand.to_string(),
        quote(utf8("STUDY", &job.study)?),
    ];
    words.extend(extra.iter().map(|w| w.to_string()));
    words.extend(["--out".to_string(), quote(utf8("--out", &job.out)?)]);
    for s in &job.set {
        words.extend(["--set".to_string(), quote(s)]);
    }
    Ok(words.join(" "))
}

/// The array script: `--array=1-N`, one `helixbif sweep --shard slurm` per task, requeueable,
/// logs appended (a requeued task adds to its log) in the output folder.
pub fn array_script(
    job: &SlurmJob,
    options: &SlurmOptions,
    study: &str,
    points: usize,
) -> Result<String> {
    let out = sbatch_path("--out", &job.out)?;
    let workdir = sbatch_path("working directory", &job.workdir)?;
    let name = job_name(study);
    let n = options.tasks;
    Ok(format!(
        "#!/bin/bash
# The sweep of study `{study}` ({points} points) as a Slurm array of {n} tasks, one shard each,
# written by `helixbif slurm` (helixbif {version}). Submit it with
#   sbatch --parsable {out}/slurm-sweep.sbatch
# A killed or cancelled task runs again as the same shard, skipping its finished points, with
#   scontrol requeue ARRAY_JOB_K
# (a new `sbatch --array=K` would be an array of one task, i.e. shard 1 of 1).
#SBATCH --job-name={name}
#SBATCH --array=1-{n}
#SBATCH --ntasks=1
{resources}#SBATCH --chdir={workdir}
#SBATCH --output={out}/slurm-sweep-%A_%a.log
#SBATCH --open-mode=append
#SBATCH --requeue
set -eu
# One thread per allocated CPU (sbatch --cpus-per-task=C for more).
export RAYON_NUM_THREADS=\"${{SLURM_CPUS_PER_TASK:-1}}\"
exec {command}
",
        version = env!("CARGO_PKG_VERSION"),
        resources = resource_lines(options),
        command = command_line(job, "sweep", &["--shard", "slurm"])?,
    ))
}

/// The merge script: `helixbif merge` of the output folder, submitted with
/// `--dependency=afterok:ARRAY_JOB` so that it starts once every task has succeeded.
pub fn merge_script(job: &SlurmJob, options: &SlurmOptions, study: &str) -> Result<String> {
    let out = sbatch_path("--out", &job.out)?;
    let workdir = sbatch_path("working directory", &job.workdir)?;
    let name = job_name(study);
    Ok(format!(
        "#!/bin/bash
# Joins the shards of the sweep of study `{study}` into {out}/sweep.csv, written by
# `helixbif slurm` (helixbif {version}). Submit it after the array job ARRAY_JOB with
#   sbatch --parsable --dependency=afterok:ARRAY_JOB {out}/slurm-merge.sbatch
# `helixbif merge` refuses shards of another study and missing or repeated points.
#SBATCH --job-name={name}-merge
#SBATCH --ntasks=1
{resources}#SBATCH --chdir={workdir}
#SBATCH --output={out}/slurm-merge-%j.log
#SBATCH --open-mode=append
set -eu
exec {command}
",
        version = env!("CARGO_PKG_VERSION"),
        resources = resource_lines(options),
        command = command_line(job, "merge", &[])?,
    ))
}

/// Validates the options against the study, writes `slurm-sweep.sbatch` and `slurm-merge.sbatch`
/// into the output folder, and returns them with the two `sbatch` commands.
pub fn write_scripts(
    study: &Study,
    job: &SlurmJob,
    options: &SlurmOptions,
) -> Result<SlurmScripts> {
    let (plan_cases, vary, _) = sweep_plan(study, "slurm")?;
    let points = grid(cases(plan_cases).len(), vary).len();
    if options.tasks == 0 || options.tasks > points {
        return Err(Error::input(
            "--tasks",
            format!(
                "must lie in 1..={points} (the sweep has {points} points), got {}",
                options.tasks
            ),
        ));
    }
    if let Some(t) = &options.time {
        check_time(t)?;
    }
    if let Some(p) = &options.partition {
        check_partition(p)?;
    }
    let array = array_script(job, options, &study.name, points)?;
    let merge = merge_script(job, options, &study.name)?;
    create_dir(&job.out)?;
    // Shards of another split in the same folder would make the merge fail at the very end.
    if let Some((_, n, path)) = shard_files(&job.out)?
        .into_iter()
        .find(|(_, n, _)| *n != options.tasks)
    {
        return Err(Error::input(
            "--tasks",
            format!(
                "{} holds shards of a split into {n} ({}); use --tasks {n}, or another --out",
                job.out.display(),
                path.display()
            ),
        ));
    }
    let array_script = job.out.join("slurm-sweep.sbatch");
    let merge_script = job.out.join("slurm-merge.sbatch");
    write_atomically(&array_script, array.as_bytes())?;
    write_atomically(&merge_script, merge.as_bytes())?;
    let commands = [
        format!(
            "array=$(sbatch --parsable {})",
            quote(utf8("--out", &array_script)?)
        ),
        format!(
            "sbatch --parsable --dependency=afterok:${{array%%;*}} {}",
            quote(utf8("--out", &merge_script)?)
        ),
    ];
    Ok(SlurmScripts {
        study: study.name.clone(),
        points,
        tasks: options.tasks,
        array_script,
        merge_script,
        commands,
    })
}

/// Runs `sbatch --parsable ARGS SCRIPT` and returns the job id it prints (`ID` or
/// `ID;CLUSTER`).
fn sbatch(args: &[&str], script: &Path) -> Result<u64> {
    let output = Command::new("sbatch")
        .arg("--parsable")
        .args(args)
        .arg(script)
        .output()
        .map_err(|e| Error::Io {
            path: "sbatch".into(),
            source: std::io::Error::new(e.kind(), format!("cannot run sbatch: {e}")),
        })?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    let first = stdout.lines().next().unwrap_or("").trim();
    let id = first.split(';').next().and_then(|s| s.parse::<u64>().ok());
    match id {
        Some(id) if output.status.success() => Ok(id),
        _ => Err(Error::Io {
            path: format!("sbatch {}", script.display()),
            source: std::io::Error::other(format!(
                "{} (stdout `{}`, stderr `{}`)",
                output.status,
                stdout.trim(),
                stderr.trim().replace('\n', "; ")
            )),
        }),
    }
}

/// Submits the array, then the merge with `--dependency=afterok:ARRAY_JOB`, and records both
/// job ids in `slurm.json` in the output folder. If the merge cannot be submitted, the array's id
/// is recorded all the same (its tasks run), and the error names it.
pub fn submit(scripts: SlurmScripts, out: &Path) -> Result<SlurmSubmission> {
    let record = out.join("slurm.json");
    let array_job = sbatch(&[], &scripts.array_script)?;
    let dependency = format!("afterok:{array_job}");
    let merge = sbatch(
        &[&format!("--dependency={dependency}")],
        &scripts.merge_script,
    );
    let write = |value: &serde_json::Value| -> Result<()> {
        let text = serde_json::to_string_pretty(value).map_err(io_json(&record))?;
        write_atomically(&record, format!("{text}\n").as_bytes())
    };
    match merge {
        Ok(merge_job) => {
            let submission = SlurmSubmission {
                scripts,
                array_job,
                merge_job,
                dependency,
            };
            write(&serde_json::to_value(&submission).map_err(io_json(&record))?)?;
            Ok(submission)
        }
        Err(e) => {
            let mut value = serde_json::to_value(&scripts).map_err(io_json(&record))?;
            value["array_job"] = array_job.into();
            write(&value)?;
            Err(Error::Io {
                path: record.display().to_string(),
                source: std::io::Error::other(format!(
                    "array job {array_job} submitted, but not its merge job: {e}"
                )),
            })
        }
    }
}

/// A JSON error while writing `path`, as an I/O error on it.
fn io_json(path: &Path) -> impl FnOnce(serde_json::Error) -> Error + '_ {
    move |e| io_error(path)(std::io::Error::other(e.to_string()))
}
