//! Slurm: the shard of an array task from its environment, shard files that resume after a kill
//! without repeating or losing a point, and the sbatch scripts of `helixbif slurm` (run here as
//! plain bash with the array variables Slurm would set, and submitted through a stand-in sbatch).
//! The real cluster is `scripts/slurm-e2e`.

use std::collections::HashMap;
use std::os::unix::fs::PermissionsExt;
use std::path::Path;
use std::process::Command;

use crate::common;

use common::{helixbif, small_sweep, temp_dir};
use helixbif::study::slurm::{ARRAY_VARIABLES, check_time, shard_from_env};

/// The rows of a sweep CSV without the timing column, in file order.
fn rows(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let seconds = header.iter().position(|h| *h == "seconds").unwrap();
    lines
        .map(|l| {
            l.split(',')
                .enumerate()
                .filter(|(i, _)| *i != seconds)
                .map(|(_, v)| v)
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect()
}

/// The point indices of rows.
fn points(rows: &[String]) -> Vec<usize> {
    rows.iter()
        .map(|r| r.split(',').next().unwrap().parse().unwrap())
        .collect()
}

fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
    let map: HashMap<String, String> = pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    move |name| map.get(name).cloned()
}

/// The message of an input error.
fn input_error(result: helixbif::Result<(usize, usize)>) -> String {
    match result {
        Err(e) if e.is_input() => e.to_string(),
        other => panic!("expected an input error, got {other:?}"),
    }
}

#[test]
fn the_shard_of_an_array_task_comes_from_its_environment() {
    let task = |id: &str, min: &str, count: &str, more: &[(&str, &str)]| {
        let mut pairs = vec![
            ("SLURM_ARRAY_TASK_ID", id),
            ("SLURM_ARRAY_TASK_MIN", min),
            ("SLURM_ARRAY_TASK_COUNT", count),
        ];
        pairs.extend_from_slice(more);
        shard_from_env(env(&pairs))
    };
    // --array=1-4 and --array=0-3: the same four shards.
    for k in 1..=4 {
        assert_eq!(task(&k.to_string(), "1", "4", &[]).unwrap(), (k, 4));
        let max = [("SLURM_ARRAY_TASK_MAX", "3")];
        assert_eq!(task(&(k - 1).to_string(), "0", "4", &max).unwrap(), (k, 4));
    }
    // --array=10-16:2 is four tasks.
    let stepped = [
        ("SLURM_ARRAY_TASK_STEP", "2"),
        ("SLURM_ARRAY_TASK_MAX", "16"),
    ];
    assert_eq!(task("14", "10", "4", &stepped).unwrap(), (3, 4));
    assert!(task("13", "10", "4", &stepped).is_err());
    // Outside an array task: every missing variable named.
    for missing in ARRAY_VARIABLES {
        let pairs: Vec<(&str, &str)> = ARRAY_VARIABLES
            .iter()
            .filter(|v| **v != missing)
            .map(|v| (*v, "1"))
            .collect();
        let message = input_error(shard_from_env(env(&pairs)));
        assert!(
            message.contains(&format!("{missing} is not set")),
            "{message}"
        );
        for v in ARRAY_VARIABLES {
            assert!(message.contains(v), "{message}");
        }
    }
    // Inconsistent values: past the count, below the minimum, a list that is no range, no
    // tasks, not a number.
    for (id, min, count, more) in [
        ("5", "1", "4", &[][..]),
        ("0", "1", "4", &[][..]),
        ("3", "1", "3", &[("SLURM_ARRAY_TASK_MAX", "7")][..]),
        ("1", "1", "0", &[][..]),
        ("x", "1", "4", &[][..]),
        ("-1", "0", "4", &[][..]),
    ] {
        let message = input_error(task(id, min, count, more));
        assert!(message.contains("--shard slurm"), "{message}");
        assert!(message.contains("SLURM_ARRAY_TASK_"), "{message}");
    }
}

#[test]
fn time_limits_are_checked() {
    for good in ["00:10:00", "1:00:00", "72:00:00", "2-12:00:00", "0:00:01"] {
        assert!(check_time(good).is_ok(), "{good}");
    }
    for bad in [
        "10:00", "1:60:00", "1:00:60", "00:00:00", "1-2", "a:00:00", "1:0:00", "", "-1:00:00",
    ] {
        let e = check_time(bad).unwrap_err();
        assert!(
            e.is_input() && e.to_string().contains("--time"),
            "{bad}: {e}"
        );
    }
}

/// The binary, with the Slurm array variables removed (and `set` added).
fn helixbif_env(args: &[&str], set: &[(&str, &str)]) -> (i32, String, String) {
    let mut command = common::command();
    command.args(args);
    for v in ARRAY_VARIABLES
        .iter()
        .chain(&["SLURM_ARRAY_TASK_STEP", "SLURM_ARRAY_TASK_MAX"])
    {
        command.env_remove(v);
    }
    command.envs(set.iter().copied());
    let out = command.output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

#[test]
fn sweep_shard_slurm_runs_the_array_tasks_shard_or_says_what_is_missing() {
    let dir = temp_dir("slurm-env");
    let study = small_sweep(&dir);
    let s = study.to_str().unwrap();
    let out = dir.join("out");
    let o = out.to_str().unwrap();
    let (code, stdout, err) = helixbif_env(&["sweep", s, "--shard", "slurm", "--out", o], &[]);
    assert_eq!(code, 2, "{stdout}{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    for v in ARRAY_VARIABLES {
        assert!(err.contains(v), "{err}");
    }
    assert!(!out.join("sweep.shard-1-of-1.csv").exists());
    // Task 2 of --array=1-4: points 1 and 5, the same rows as --shard 2/4.
    let task = [
        ("SLURM_ARRAY_TASK_ID", "2"),
        ("SLURM_ARRAY_TASK_MIN", "1"),
        ("SLURM_ARRAY_TASK_COUNT", "4"),
        ("SLURM_ARRAY_TASK_MAX", "4"),
    ];
    let (code, _, err) = helixbif_env(&["sweep", s, "--shard", "slurm", "--out", o], &task);
    assert_eq!(code, 0, "{err}");
    let from_env = rows(&out.join("sweep.shard-2-of-4.csv"));
    assert_eq!(points(&from_env), vec![1, 5]);
    let explicit = dir.join("explicit");
    let (code, _, err) = helixbif(&[
        "sweep",
        s,
        "--shard",
        "2/4",
        "--out",
        explicit.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(rows(&explicit.join("sweep.shard-2-of-4.csv")), from_env);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_shard_cut_short_by_a_kill_resumes_without_repeating_or_losing_a_point() {
    let dir = temp_dir("slurm-resume");
    let study = small_sweep(&dir);
    let s = study.to_str().unwrap();
    let whole = dir.join("whole");
    let (code, _, err) = helixbif(&[
        "sweep",
        s,
        "--shard",
        "1/2",
        "--out",
        whole.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let name = "sweep.shard-1-of-2.csv";
    let plan = "sweep.shard-1-of-2.plan.json";
    let reference = rows(&whole.join(name));
    assert_eq!(points(&reference), vec![0, 2, 4, 6]);
    let complete = std::fs::read_to_string(whole.join(name)).unwrap();
    let last_row_start = complete.trim_end().rfind('\n').unwrap() + 1;
    // What a kill can leave: the last row cut in its middle, cut inside its status (`o` of
    // `ok`), cut before its line end; a row written twice (two writers, or a copy).
    let repeated_row = &complete[last_row_start..];
    let cases: Vec<(&str, String, usize)> = vec![
        (
            "cut mid-row",
            complete[..last_row_start + repeated_row.len() / 2].to_string(),
            3,
        ),
        (
            "cut in the status",
            complete[..complete.trim_end().len() - 1].to_string(),
            3,
        ),
        ("no line end", complete.trim_end().to_string(), 4),
        (
            "header only",
            complete[..complete.find('\n').unwrap() + 1].to_string(),
            0,
        ),
        ("row twice", format!("{complete}{repeated_row}"), 4),
    ];
    for (label, text, kept) in cases {
        let resumed = dir.join(label.replace(' ', "-"));
        std::fs::create_dir_all(&resumed).unwrap();
        std::fs::write(resumed.join(name), &text).unwrap();
        std::fs::copy(whole.join(plan), resumed.join(plan)).unwrap();
        let (code, out, err) = helixbif(&[
            "sweep",
            s,
            "--shard",
            "1/2",
            "--out",
            resumed.to_str().unwrap(),
            "--json",
        ]);
        assert_eq!(code, 0, "{label}: {err}");
        let summary: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
        assert_eq!(summary["already_done"], kept, "{label}: {summary}");
        assert_eq!(summary["computed"], 4 - kept, "{label}: {summary}");
        // Each point once, in order, with the numbers of the uninterrupted run.
        assert_eq!(rows(&resumed.join(name)), reference, "{label}");
        // The two shards merge (the other one run fresh) to every point exactly once.
        let (code, _, err) = helixbif(&[
            "sweep",
            s,
            "--shard",
            "2/2",
            "--out",
            resumed.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{label}: {err}");
        let (code, _, err) = helixbif(&["merge", s, "--out", resumed.to_str().unwrap()]);
        assert_eq!(code, 0, "{label}: {err}");
        let merged = rows(&resumed.join("sweep.csv"));
        assert_eq!(points(&merged), (0..8).collect::<Vec<_>>(), "{label}");
        assert!(
            !std::fs::read_dir(&resumed).unwrap().any(|e| e
                .unwrap()
                .file_name()
                .to_string_lossy()
                .ends_with(".tmp")),
            "{label}: a temporary file was left"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_merge_of_shards_with_a_failed_point_keeps_every_row_and_exits_1() {
    let dir = temp_dir("slurm-failed");
    let study = small_sweep(&dir);
    let s = study.to_str().unwrap();
    let o = dir.join("out");
    let o = o.to_str().unwrap();
    for shard in ["1/2", "2/2"] {
        let (code, _, err) = helixbif(&["sweep", s, "--shard", shard, "--out", o]);
        assert_eq!(code, 0, "{err}");
    }
    let (code, _, err) = helixbif(&["merge", s, "--out", o]);
    assert_eq!(code, 0, "{err}");
    let reference = rows(&Path::new(o).join("sweep.csv"));
    // What a shard run by hand leaves when a point fails and no one runs it again: its row with
    // an error status (point 2, the second row of shard 1).
    let shard = Path::new(o).join("sweep.shard-1-of-2.csv");
    let text = std::fs::read_to_string(&shard).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let status = lines[2].rfind(',').unwrap() + 1;
    assert_eq!(&lines[2][status..], "ok", "{text}");
    lines[2].replace_range(status.., "error: Newton diverged at omega = 0.3 rad/s");
    std::fs::write(&shard, lines.join("\n") + "\n").unwrap();
    for written in ["sweep.csv", "sweep_0.svg"] {
        std::fs::remove_file(Path::new(o).join(written)).unwrap();
    }
    let (code, _, err) = helixbif(&["merge", s, "--out", o]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(
            "1 sweep point failed (point 2; run `helixbif sweep` again with --shard 1/2 to \
             compute them); see the status column of"
        ) && err.contains("sweep.csv"),
        "{err}"
    );
    // The figure is drawn before the merge fails.
    assert!(Path::new(o).join("sweep_0.svg").exists());
    // Every row is merged, the failed one as it is.
    let merged = rows(&Path::new(o).join("sweep.csv"));
    assert_eq!(points(&merged), (0..8).collect::<Vec<_>>());
    assert!(merged[2].ends_with(",error: Newton diverged at omega = 0.3 rad/s"));
    // The shard run again computes the failed point alone, and the merge is whole.
    let (code, out, err) = helixbif(&["sweep", s, "--shard", "1/2", "--out", o, "--json"]);
    assert_eq!(code, 0, "{err}");
    let summary: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(
        (
            summary["already_done"].as_u64(),
            summary["computed"].as_u64()
        ),
        (Some(3), Some(1))
    );
    let (code, _, err) = helixbif(&["merge", s, "--out", o]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(rows(&Path::new(o).join("sweep.csv")), reference);
    std::fs::remove_dir_all(&dir).ok();
}

/// The line of `script` that starts with `prefix`.
fn line<'a>(script: &'a str, prefix: &str) -> &'a str {
    script
        .lines()
        .find(|l| l.starts_with(prefix))
        .unwrap_or_else(|| panic!("no line `{prefix}` in\n{script}"))
}

#[test]
fn slurm_writes_an_array_and_a_merge_that_run_the_sweep() {
    let dir = temp_dir("slurm-scripts");
    let study = small_sweep(&dir);
    let s = study.to_str().unwrap();
    let out = dir.join("cluster");
    let o = out.to_str().unwrap();
    let (code, stdout, err) = helixbif_env(
        &[
            "slurm",
            s,
            "--tasks",
            "3",
            "--time",
            "01:30:00",
            "--partition",
            "short",
            "--out",
            o,
            "--set",
            "rod.E=1.3e6",
        ],
        &[],
    );
    assert_eq!(code, 0, "{err}");
    let array = std::fs::read_to_string(out.join("slurm-sweep.sbatch")).unwrap();
    let merge = std::fs::read_to_string(out.join("slurm-merge.sbatch")).unwrap();
    assert_eq!(line(&array, "#SBATCH --array="), "#SBATCH --array=1-3");
    assert_eq!(line(&array, "#SBATCH --time="), "#SBATCH --time=01:30:00");
    assert_eq!(line(&merge, "#SBATCH --time="), "#SBATCH --time=01:30:00");
    assert_eq!(
        line(&array, "#SBATCH --partition="),
        "#SBATCH --partition=short"
    );
    assert_eq!(
        line(&array, "#SBATCH --output="),
        format!("#SBATCH --output={o}/slurm-sweep-%A_%a.log")
    );
    assert!(!merge.contains("--array"), "{merge}");
    let binary = std::fs::canonicalize(env!("CARGO_BIN_EXE_helixbif")).unwrap();
    let study_abs = std::fs::canonicalize(&study).unwrap();
    assert_eq!(
        line(&array, "exec "),
        format!(
            "exec '{}' sweep '{}' --shard slurm --out '{o}' --set 'rod.E=1.3e6'",
            binary.display(),
            study_abs.display()
        )
    );
    assert_eq!(
        line(&merge, "exec "),
        format!(
            "exec '{}' merge '{}' --out '{o}' --set 'rod.E=1.3e6'",
            binary.display(),
            study_abs.display()
        )
    );
    // The printed commands: the array, then the merge after it.
    let commands: Vec<&str> = stdout.lines().skip(1).map(str::trim).collect();
    assert_eq!(
        commands,
        [
            format!("array=$(sbatch --parsable '{o}/slurm-sweep.sbatch')"),
            format!(
                "sbatch --parsable --dependency=afterok:${{array%%;*}} '{o}/slurm-merge.sbatch'"
            ),
        ]
    );
    assert!(!out.join("slurm.json").exists());
    // The scripts are bash: each task as Slurm would start it, then the merge.
    for k in 1..=3 {
        let status = Command::new("bash")
            .arg(out.join("slurm-sweep.sbatch"))
            .env("SLURM_ARRAY_TASK_ID", k.to_string())
            .env("SLURM_ARRAY_TASK_MIN", "1")
            .env("SLURM_ARRAY_TASK_COUNT", "3")
            .env("SLURM_ARRAY_TASK_MAX", "3")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .unwrap();
        assert!(status.success(), "task {k}");
    }
    let status = Command::new("bash")
        .arg(out.join("slurm-merge.sbatch"))
        .stdout(std::process::Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    let reference = dir.join("reference");
    let (code, _, err) = helixbif(&[
        "sweep",
        s,
        "--set",
        "rod.E=1.3e6",
        "--out",
        reference.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(
        rows(&out.join("sweep.csv")),
        rows(&reference.join("sweep.csv"))
    );
    // Bad input: one line naming the flag and what is allowed.
    for (args, flag) in [
        (vec!["--tasks", "0"], "--tasks"),
        (vec!["--tasks", "9"], "--tasks"),
        (vec!["--tasks", "2", "--time", "90:00"], "--time"),
        (vec!["--tasks", "2", "--time", "1:75:00"], "--time"),
        (vec!["--tasks", "2", "--partition", "a b"], "--partition"),
    ] {
        let other = dir.join("other");
        let mut all = vec!["slurm", s, "--out", other.to_str().unwrap()];
        all.extend(args.iter().copied());
        let (code, _, err) = helixbif(&all);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(flag), "{args:?}: {err}");
    }
    let (_, _, err) = helixbif(&["slurm", s, "--out", o, "--tasks", "9"]);
    assert!(err.contains("1..=8"), "{err}");
    // The folder holds shards of a split into 3: another count would never merge.
    let (code, _, err) = helixbif(&[
        "slurm",
        s,
        "--set",
        "rod.E=1.3e6",
        "--out",
        o,
        "--tasks",
        "2",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--tasks 3"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn submit_runs_sbatch_twice_with_the_dependency_and_records_the_job_ids() {
    let dir = temp_dir("slurm-submit");
    let study = small_sweep(&dir);
    let s = study.to_str().unwrap();
    // A stand-in sbatch: logs its arguments, prints job ids the way `sbatch --parsable` does.
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let calls = dir.join("calls.txt");
    let fake = bin.join("sbatch");
    std::fs::write(
        &fake,
        format!(
            "#!/bin/bash\necho \"$*\" >> '{}'\nn=$(wc -l < '{}')\nif [ \"$FAIL_AT\" = \"$n\" ]; then echo 'sbatch: error: Batch job submission failed' >&2; exit 1; fi\nif [ \"$n\" = 1 ]; then echo '4242;cluster'; else echo 4243; fi\n",
            calls.display(),
            calls.display()
        ),
    )
    .unwrap();
    std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap());
    let out = dir.join("cluster");
    let o = out.to_str().unwrap();
    let submit = |fail_at: &str| {
        std::fs::remove_file(&calls).ok();
        helixbif_env(
            &["slurm", s, "--tasks", "4", "--out", o, "--submit"],
            &[("PATH", path.as_str()), ("FAIL_AT", fail_at)],
        )
    };
    let (code, stdout, err) = submit("");
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("array job 4242"), "{stdout}");
    let logged: Vec<String> = std::fs::read_to_string(&calls)
        .unwrap()
        .lines()
        .map(String::from)
        .collect();
    assert_eq!(
        logged,
        [
            format!("--parsable {o}/slurm-sweep.sbatch"),
            format!("--parsable --dependency=afterok:4242 {o}/slurm-merge.sbatch"),
        ]
    );
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("slurm.json")).unwrap()).unwrap();
    assert_eq!(record["array_job"], 4242);
    assert_eq!(record["merge_job"], 4243);
    assert_eq!(record["dependency"], "afterok:4242");
    assert_eq!(record["tasks"], 4);
    assert_eq!(record["points"], 8);
    // The merge refused: exit 1 naming the array job, whose id is still recorded.
    let (code, _, err) = submit("2");
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("array job 4242 submitted"), "{err}");
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("slurm.json")).unwrap()).unwrap();
    assert_eq!(record["array_job"], 4242);
    assert!(record.get("merge_job").is_none(), "{record}");
    // No sbatch at all: exit 1, one line.
    let (code, _, err) = helixbif_env(
        &["slurm", s, "--tasks", "4", "--out", o, "--submit"],
        &[("PATH", "/nonexistent")],
    );
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("sbatch"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The array tasks of a cluster run start together in one output folder, and each checks that it
/// can write there. Sixteen threads released at once, each checking the folder a hundred times:
/// every check passes and leaves nothing behind (a probe with one fixed name fails here, one
/// check removing the probe of another under it).
#[test]
fn array_tasks_starting_together_all_pass_the_write_check_of_their_shared_folder() {
    use helixbif::study::output::make_writable_dir;
    use std::sync::{Arc, Barrier};
    let dir = temp_dir("slurm-write-check").join("out");
    let start = Arc::new(Barrier::new(16));
    let failures: usize = (0..16)
        .map(|_| {
            let (dir, start) = (dir.clone(), Arc::clone(&start));
            std::thread::spawn(move || {
                start.wait();
                (0..100)
                    .filter(|_| make_writable_dir(&dir).is_err())
                    .count()
            })
        })
        .collect::<Vec<_>>()
        .into_iter()
        .map(|t| t.join().unwrap())
        .sum();
    assert_eq!(failures, 0, "{failures} of 1600 write checks failed");
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(left.is_empty(), "probes left behind: {left:?}");
}
