//! The edges of the command line: bad numbers, unusable folders, runs that cannot fit in memory
//! or cannot reach their rate, and tables that stay empty.

use crate::common;

use common::{helixbif, temp_dir};

/// Every numeric option reads a negative number and refuses it with its range (exit 2, one
/// line naming the option), rather than failing in the argument parser.
#[test]
fn negative_numbers_are_read_and_refused_with_their_range() {
    for (args, field) in [
        (&["locate", "--accuracy", "-1"][..], "--accuracy"),
        (&["locate", "--tol", "-1"][..], "--tol"),
        (&["locate", "--max-nodes", "-3"][..], "--max-nodes"),
        // At or below the study's N = 60 the refinement has no finer rung.
        (&["locate", "--max-nodes", "60"][..], "--max-nodes"),
        (
            &["simulate", "--omega", "0.3", "--t-end", "-1"][..],
            "--t-end",
        ),
        (&["orbits", "--steps", "-1"][..], "--steps"),
        (&["orbits", "--amplitude", "-1"][..], "--amplitude"),
        (
            &["bisect", "--lo", "0.3", "--hi", "0.6", "--precision", "-1"][..],
            "--precision",
        ),
    ] {
        let (code, _, stderr) = helixbif(args);
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{args:?}: {stderr}");
        assert!(
            stderr.contains(&format!("invalid input: {field}: must")),
            "{args:?}: {stderr}"
        );
    }
}

/// An `--out` that cannot hold results (a file, a path under /proc) is bad input naming
/// `--out`.
#[test]
fn an_unusable_output_folder_is_bad_input() {
    let dir = temp_dir("edges-out");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("a-file");
    std::fs::write(&file, "x").unwrap();
    for out in [file.to_str().unwrap(), "/proc/helixbif/out"] {
        let (code, _, stderr) = helixbif(&[
            "branch",
            "--set",
            "fluid.model=lighthill",
            "--omega-max",
            "0.1",
            "--out",
            out,
        ]);
        assert_eq!(code, 2, "{out}: {stderr}");
        assert!(stderr.contains("invalid input: --out:"), "{stderr}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A node count whose dense matrices cannot fit in the memory the process may use (here an
/// address-space limit of 4 GB, as a cluster job's) is refused before any work, with the
/// estimate and the largest count that fits, not an allocation panic.
#[test]
fn a_run_that_cannot_fit_in_memory_is_refused_with_its_estimate() {
    let command = format!(
        "ulimit -v 4000000 && exec {} solve --omega 0.3 --set fluid.model=rpy --set \
         discretization.nodes=5000",
        env!("CARGO_BIN_EXE_helixbif")
    );
    let out = std::process::Command::new("sh")
        .args(["-c", &command])
        .output()
        .unwrap();
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("discretization.nodes: N = 5000 needs about 76.9 GB"),
        "{stderr}"
    );
    assert!(
        stderr.contains("ulimit -v") && stderr.contains("fits"),
        "{stderr}"
    );
}

/// The branch from rest of the default helix turns back at a fold near -0.247 rad/s: a steady
/// state beyond it is not on the branch, and `solve` says so with the fold's rate.
#[test]
fn solve_past_a_fold_names_the_fold() {
    let (code, _, stderr) = helixbif(&[
        "solve",
        "--set",
        "fluid.model=lighthill",
        "--omega",
        "-0.25",
    ]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("turns back at a fold at omega = -0.247"),
        "{stderr}"
    );
}

/// A branch without events still writes the header of `events.csv` (an empty table, not a
/// 0-byte file), and `meta.json` beside it.
#[test]
fn an_empty_event_table_keeps_its_header() {
    let dir = temp_dir("edges-events");
    let (code, _, stderr) = helixbif(&[
        "branch",
        "--set",
        "fluid.model=lighthill",
        "--omega-max",
        "0.1",
        "--set",
        "discretization.nodes=30",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let events = std::fs::read_to_string(dir.join("events.csv")).unwrap();
    assert!(events.starts_with("kind,omega,omegabar,re,im"), "{events}");
    assert_eq!(events.lines().count(), 1, "{events}");
    assert!(dir.join("meta.json").is_file());
    std::fs::remove_dir_all(&dir).ok();
}

/// A simulation past buckling on the Lighthill operator stops where parts of the collapsed rod
/// approach: the failure says when in seconds, how collapsed the rod was, why (the mobility and
/// the closest approach) and what to change, and keeps the time series.
#[test]
fn a_simulation_that_dies_says_when_why_and_what_to_change() {
    let dir = temp_dir("edges-simulate");
    let (code, _, stderr) = helixbif(&[
        "simulate",
        "--set",
        "fluid.model=lighthill",
        "--omega",
        "0.6",
        "--t-end",
        "300",
        "--shape-every",
        "0",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    for part in [
        "stopped at t = 222.",
        " s, the last state kept having hbar = 0.3",
        "closest approach of non-adjacent nodes",
        "--set fluid.model=rpy",
    ] {
        assert!(stderr.contains(part), "missing `{part}`: {stderr}");
    }
    let rows = std::fs::read_to_string(dir.join("timeseries.csv")).unwrap();
    assert!(
        rows.lines().count() > 1000,
        "{} rows kept",
        rows.lines().count()
    );
    std::fs::remove_dir_all(&dir).ok();
}
