//! The command-line contract: verdicts that are never guesses (a branch unstable at rest, the
//! reason a branch stops), what `--set` does to the output folder, JSON from every command,
//! integer and negative values, a closed pipe, the help texts, and the study's `[newton]`
//! table honoured by every command.

use std::path::{Path, PathBuf};
use std::process::Stdio;

use crate::common;

use common::{helixbif, run_into, temp_dir};

/// The standing rod of Greenhill's problem, heavier than its critical weight
/// (`q L^3/EI = 28 > 7.84`): unstable before it turns.
const STANDING: [&str; 6] = [
    "--set",
    "shape={kind=\"straight\",L=0.12,alpha_deg=180}",
    "--set",
    "fluid.rho=0",
    "--set",
    "discretization.nodes=20",
];

#[test]
fn a_rest_state_that_is_already_unstable_is_reported_as_such() {
    let mut args = vec!["locate", "--set", "fluid.model=lighthill", "--json"];
    args.extend(STANDING);
    let (code, stdout, stderr) = helixbif(&args);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(v["kind"], "unstable_at_rest", "{v}");
    // Both bending planes of the round rod are unstable (Greenhill's double eigenvalue).
    assert_eq!(v["unstable_at_rest"], 2, "{v}");
    assert!(v["omega_b"].is_null());
    let mut args = vec!["locate"];
    args.extend(STANDING);
    let (_, text, _) = helixbif(&args);
    assert!(text.contains("already unstable"), "{text}");
}

#[test]
fn a_sweep_row_carries_the_unstable_rest_state_and_fit_lists_what_it_left_out() {
    let dir = temp_dir("cli-unstable-sweep");
    let study = dir.join("standing.toml");
    std::fs::write(
        &study,
        r#"name = "standing"
[rod]
E = 1255e3
r0 = 1.58e-3
rho = 1306.0
[fluid]
model = "lighthill"
mu = 1.32
rho = 0.0
[shape]
kind = "straight"
L = 0.12
alpha_deg = 15.0
[discretization]
nodes = 20
[branch]
omega_max = 3.5
[study]
kind = "sweep"
vary = [{ key = "shape.alpha_deg", values = [15.0, 180.0] }]
"#,
    )
    .unwrap();
    let out = dir.join("out");
    let (code, _, stderr) = helixbif(&[
        "sweep",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(
        code, 0,
        "an unstable rest state is a result, not a failure: {stderr}"
    );
    let table = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let rows: Vec<&str> = table.lines().skip(1).collect();
    assert!(rows[0].ends_with(",ok"), "{table}");
    assert!(
        rows[1].contains(",unstable_at_rest,") && rows[1].ends_with("at omega = 0)"),
        "{table}"
    );
    // A re-run keeps it (a finished point) instead of computing it again.
    let (_, stdout, _) = helixbif(&[
        "sweep",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(
        (v["already_done"].as_u64(), v["computed"].as_u64()),
        (Some(2), Some(0))
    );

    // fit leaves out the rows without a result, each with its reason.
    let csv = dir.join("points.csv");
    std::fs::write(
        &csv,
        "point,x,y,kind,status\n0,1,2,hopf,ok\n1,2,8,hopf,ok\n2,3,18,hopf,ok\n3,4,32,hopf,ok\n\
         4,5,,unstable_at_rest,unstable_at_rest (2 unstable eigenvalues at omega = 0)\n\
         5,6,,none,ok\n6,7,3,hopf,error: Newton failed\n",
    )
    .unwrap();
    let (code, stdout, stderr) = helixbif(&[
        "fit",
        csv.to_str().unwrap(),
        "--x",
        "x",
        "--y",
        "y",
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(v["n"], 4);
    assert!((v["p"].as_f64().unwrap() - 2.0).abs() < 1e-9, "{v}");
    let left: Vec<(String, String)> = v["left_out"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| {
            (
                l["point"].as_str().unwrap().to_string(),
                l["reason"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    assert_eq!(left.len(), 3, "{left:?}");
    assert_eq!(left[0].0, "4");
    assert!(left[0].1.contains("unstable_at_rest"), "{left:?}");
    assert!(
        left[1].1.contains("`y` is empty") && left[1].1.contains("none"),
        "{left:?}"
    );
    assert!(left[2].1.contains("error: Newton failed"), "{left:?}");
    let (_, text, _) = helixbif(&["fit", csv.to_str().unwrap(), "--x", "x", "--y", "y"]);
    assert!(text.contains("left out 3 rows"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_branch_that_approaches_itself_names_the_loss_of_positive_definiteness() {
    // The representative helix turned against its handedness: past an S of two folds its turns
    // close up until two come within about 3.5 delta of each other (near 0.29 rad/s).
    let dir = temp_dir("cli-helix-contact");
    let (code, _, stderr) = helixbif(&[
        "branch",
        "--set",
        "fluid.model=lighthill",
        "--set",
        "shape.handedness=\"left\"",
        "--set",
        "discretization.nodes=40",
        "--omega-max",
        "0.6",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("not positive definite")
            && stderr.contains("closest approach of non-adjacent nodes")
            && stderr.contains("smallest node spacing"),
        "{stderr}"
    );
    // What was found before is on disk.
    let rows = std::fs::read_to_string(dir.join("branch.csv")).unwrap();
    assert!(rows.lines().count() > 10);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_node_count_far_outside_the_range_is_refused_before_any_work() {
    let (code, _, stderr) = helixbif(&[
        "locate",
        "--set",
        "fluid.model=lighthill",
        "--set",
        "discretization.nodes=5000",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("admissible range 5..=87"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
}

/// A value of the wrong type is refused in one line naming the field and the values its type
/// takes, in words (not the Rust type it is read into).
#[test]
fn a_negative_or_non_numeric_node_count_is_refused_with_its_range_in_words() {
    for (value, shown) in [("-3", "integer `-3`"), ("abc", "string \"abc\"")] {
        let set = format!("discretization.nodes={value}");
        let (code, _, stderr) = helixbif(&["locate", "--single", "--set", &set]);
        assert_eq!(code, 2, "{stderr}");
        assert!(
            stderr.contains("discretization.nodes")
                && stderr.contains(shown)
                && stderr.contains("expected an integer >= 0")
                && !stderr.contains("usize"),
            "{stderr}"
        );
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
    }
}

#[test]
fn a_thin_tight_helix_buckling_at_a_high_rate_is_located_within_the_default_budget() {
    // R/lambda = 0.05 on the exponent study's rod: omegabar_b near 3.5e4, a hundred and fifty
    // times the representative helix's.
    let (code, stdout, stderr) = helixbif(&[
        "locate",
        "--single",
        "studies/exponent_m.toml",
        "--set",
        "shape.R_over_lambda=0.05",
        "--set",
        "branch.omega_max=10",
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(v["kind"], "hopf", "{v}");
    assert!(v["points"].as_u64().unwrap() < 100, "{v}");
    // The ratio was applied: R = 0.05 lambda.
    assert!(v["omegabar_b"].as_f64().unwrap() > 1e4, "{v}");
}

#[test]
fn set_overrides_write_to_their_own_folder_never_over_the_study_results() {
    let dir = temp_dir("cli-set-folder");
    let status = common::command()
        .current_dir(&dir)
        .args([
            "branch",
            "--set",
            "discretization.nodes=20",
            "--omega-max",
            "0.05",
        ])
        .output()
        .unwrap();
    assert!(status.status.success(), "{status:?}");
    // The branch command's own subfolder of the variant's folder.
    let own = dir.join("output/representative.set-discretization.nodes_20");
    assert!(
        own.join("branch/branch.csv").exists(),
        "{:?}",
        std::fs::read_dir(dir.join("output"))
    );
    assert!(!dir.join("output/representative").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// A small sweep study over the node count (an integer field) in `dir`.
fn node_sweep(dir: &Path) -> PathBuf {
    let study = dir.join("nodes.toml");
    let base = std::fs::read_to_string("studies/representative.toml")
        .unwrap()
        .replace("model = \"rpy\"", "model = \"lighthill\"");
    std::fs::write(
        &study,
        format!(
            "{}\n[study]\nkind = \"sweep\"\nvary = [{{ key = \"discretization.nodes\", values = [16, 20] }}]\n",
            base.replace("name = \"representative\"", "name = \"nodes\"")
        ),
    )
    .unwrap();
    study
}

#[test]
fn an_integer_field_is_swept_and_merge_prints_json() {
    let dir = temp_dir("cli-nodes");
    let study = node_sweep(&dir);
    let s = study.to_str().unwrap();
    let out = dir.join("out");
    let o = out.to_str().unwrap();
    for shard in ["1/2", "2/2"] {
        let (code, _, stderr) = helixbif(&["sweep", s, "--shard", shard, "--out", o]);
        assert_eq!(code, 0, "{stderr}");
    }
    let (code, stdout, stderr) = helixbif(&["merge", s, "--out", o, "--json"]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value =
        serde_json::from_str(stdout.trim()).expect("merge --json prints JSON");
    assert_eq!(
        (v["points"].as_u64(), v["shards"].as_u64()),
        (Some(2), Some(2)),
        "{v}"
    );
    let table = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let header: Vec<&str> = table.lines().next().unwrap().split(',').collect();
    let nodes = header.iter().position(|h| *h == "nodes").unwrap();
    let counts: Vec<&str> = table
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(nodes).unwrap())
        .collect();
    assert_eq!(counts, ["16", "20"], "{table}");
    // A fractional node count is refused, naming the field.
    let bad = std::fs::read_to_string(&study)
        .unwrap()
        .replace("[16, 20]", "[16.5]");
    std::fs::write(&study, bad).unwrap();
    let (code, _, stderr) = helixbif(&["sweep", s, "--out", dir.join("bad").to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("discretization.nodes") && stderr.contains("whole numbers"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn negative_rates_are_accepted_and_turn_the_motor_the_other_way() {
    let solve = |omega: &str| {
        let (code, stdout, stderr) = helixbif(&[
            "solve",
            "--set",
            "fluid.model=lighthill",
            "--omega",
            omega,
            "--set",
            "discretization.nodes=20",
            "--json",
        ]);
        assert_eq!(code, 0, "{stderr}");
        let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
        v["Fp_rigid"].as_f64().unwrap()
    };
    // The rigid thrust is odd in omega.
    let (forward, backward) = (solve("0.1"), solve("-0.1"));
    assert!(
        (forward + backward).abs() <= 1e-12 * forward.abs(),
        "{forward} {backward}"
    );
    let dir = temp_dir("cli-negative");
    let (code, stdout, stderr) = helixbif(&[
        "simulate",
        "--set",
        "fluid.model=lighthill",
        "--omega",
        "-0.1",
        "--t-end",
        "2",
        "--from-steady",
        "--shape-every",
        "0",
        "--set",
        "discretization.nodes=16",
        "--out",
        dir.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(v["omega"], -0.1);
    // A bracket of one sign is accepted by the parser and checked by the command.
    let (code, _, stderr) = helixbif(&[
        "bisect",
        "--set",
        "fluid.model=lighthill",
        "--lo",
        "-0.6",
        "--hi",
        "-0.3",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("--lo") && stderr.contains("|lo| < |hi|"),
        "{stderr}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_closed_pipe_ends_the_output_quietly() {
    let mut child = common::command()
        .args([
            "solve",
            "--omega",
            "0.05",
            "--set",
            "discretization.nodes=20",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The reader goes away before the report is written (`| head -0`).
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(out.status.success(), "{:?} {stderr}", out.status);
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn help_lists_the_study_kinds_the_exit_codes_and_the_set_syntax() {
    let (_, top, _) = helixbif(&["--help"]);
    assert!(
        top.contains("Exit codes") && top.contains("inline table"),
        "{top}"
    );
    let (_, run, _) = helixbif(&["run", "--help"]);
    for kind in ["locate", "branch", "sweep", "phase", "shapes", "dynamics"] {
        assert!(
            run.contains(&format!("`{kind}`")),
            "run --help lacks {kind}: {run}"
        );
    }
    for command in ["sweep", "merge", "slurm"] {
        let (_, text, _) = helixbif(&[command, "--help"]);
        assert!(
            text.contains("kind \"sweep\"") && text.contains("the built-in default is one helix"),
            "{command}: {text}"
        );
    }
    let (_, bisect, _) = helixbif(&["bisect", "--help"]);
    assert!(
        bisect.contains("--ramp-time") && bisect.contains("--hold-time"),
        "{bisect}"
    );
}

#[test]
fn simulate_and_bisect_read_the_study_newton_settings() {
    // The study's Newton table reaches the steady start of `simulate` (checked there: a value
    // out of range is refused, naming the field). A budget of one iteration no longer makes
    // that start fail: the ramp's tangent predictor, in small enough steps, leaves Newton one
    // step from convergence.
    let (code, _, stderr) = helixbif(&[
        "simulate",
        "--set",
        "fluid.model=lighthill",
        "--omega",
        "0.3",
        "--t-end",
        "1",
        "--from-steady",
        "--set",
        "discretization.nodes=16",
        "--set",
        "newton.max_iter=0",
        "--out",
        temp_dir("cli-newton-sim").to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("newton.max_iter"), "{stderr}");
    // The same for `bisect`, before any simulation.
    let (code, _, stderr) = helixbif(&[
        "bisect",
        "--set",
        "fluid.model=lighthill",
        "--lo",
        "0.3",
        "--hi",
        "0.7",
        "--set",
        "discretization.nodes=16",
        "--set",
        "newton.tol=2",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("newton.tol"), "{stderr}");
    let (code, _, stderr) = helixbif(&[
        "bisect",
        "--set",
        "fluid.model=lighthill",
        "--lo",
        "0.3",
        "--hi",
        "0.7",
        "--ramp-time",
        "0",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("--ramp-time"), "{stderr}");
}

#[test]
fn locate_refines_until_the_lighthill_range_ends_and_says_so() {
    // Default accuracy 1e-3: from N = 40 the spacing halves to 79, then the next rung is
    // capped at the admissible maximum 87, past which Lighthill's operator is indefinite.
    let (code, stdout, stderr) = helixbif(&[
        "locate",
        "--set",
        "fluid.model=lighthill",
        "--json",
        "--set",
        "discretization.nodes=40",
    ]);
    // The report is printed; the accuracy not reached is a numerical failure (exit 1).
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("accuracy 1e-3 not reached at N = 87"),
        "{stderr}"
    );
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    let rungs = rung_field(&v, "nodes");
    assert_eq!(rungs, [40.0, 79.0, 87.0], "{v}");
    assert_eq!(v["nodes"], 87);
    assert_eq!(v["reached"], false);
    let stopped = v["stopped"].as_str().unwrap();
    assert!(
        stopped.contains("N = 87") && stopped.contains("rpy"),
        "{stopped}"
    );
    // The estimate is the rungs' own: at least the last increment times h_f/(h_p - h_f) when
    // it falls back to first order, never below the second-order Richardson estimate.
    let w = rung_field(&v, "omega_b");
    let (hp, hf) = (1.0 / 78.0, 1.0 / 86.0);
    let second = (w[2] - w[1]).abs() * hf * hf / (hp * hp - hf * hf);
    let error = v["omega_b_error"].as_f64().unwrap();
    assert!(error >= second, "{error} vs {second}");
    assert!(
        (v["relative_error"].as_f64().unwrap() - error / w[2]).abs() < 1e-15,
        "{v}"
    );
    // Bad accuracies are refused, naming the flag.
    let (code, _, stderr) = helixbif(&[
        "locate",
        "--set",
        "fluid.model=lighthill",
        "--accuracy",
        "0.5",
    ]);
    assert_eq!(code, 2);
    assert!(
        stderr.contains("--accuracy") && stderr.contains("(0, 0.1)"),
        "{stderr}"
    );
    let (code, _, _) = helixbif(&[
        "locate",
        "--set",
        "fluid.model=lighthill",
        "--single",
        "--accuracy",
        "1e-2",
    ]);
    assert_eq!(code, 2);
}

#[test]
fn the_rpy_refinement_error_estimate_covers_the_error_against_a_finer_direct_computation() {
    // A thick rod (r0 = 6.32 mm, four times the representative's) on the RPY line: its
    // quadrature has a sixteenth of the points, so N = 161 is cheap. Rungs 21, 41, 81 (an
    // accuracy below what the quadrature leaves, 4.4e-5 relative, would stop at the second).
    let common = [
        "--set",
        "fluid.model=rpy",
        "--set",
        "rod.r0=6.32e-3",
        "--set",
        "branch.omega_max=300",
        "--json",
    ];
    let mut args = vec![
        "locate",
        "--accuracy",
        "1e-3",
        "--max-nodes",
        "81",
        "--set",
        "discretization.nodes=21",
    ];
    args.extend(common);
    let (code, stdout, stderr) = helixbif(&args);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("accuracy 1e-3 not reached"), "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    let w = rung_field(&v, "omega_b");
    assert_eq!(w.len(), 3, "{v}");
    assert!(v["stopped"].as_str().unwrap().contains("--max-nodes 81"));
    // The answer is the finest rung's value (the limit of 21, 41, 81 has the larger error in N)
    // less the quadrature's error measured at 41, with the change from 21 as its error.
    assert_eq!(v["answer"], "finest_rung");
    let correction = &v["quadrature_correction"];
    assert_eq!(correction["nodes"], serde_json::json!([21, 41]));
    let (e21, e41) = (
        v["quadrature"]["error"].as_f64().unwrap(),
        v["quadrature_finer"]["error"].as_f64().unwrap(),
    );
    assert_eq!(correction["subtracted"].as_f64().unwrap(), e41);
    assert!((correction["error"].as_f64().unwrap() - (e41 - e21).abs()).abs() < 1e-15);
    let answered = v["omega_b"].as_f64().unwrap();
    assert!((answered - (w[2] - e41)).abs() < 1e-12 * w[2], "{v}");
    // The observed order reported is the rungs', in the spacing h = 1/(N - 3/2) of the clamped
    // edge centred on the clamp (the default on this line): the p at which
    // (h1^p - h2^p)/(h2^p - h3^p) is the ratio of the increments, by bisection here.
    let p = v["estimate"]["observed_order"].as_f64().unwrap();
    let h = [21.0, 41.0, 81.0].map(|n: f64| 1.0 / (n - 1.5));
    let ratio = (w[1] - w[0]) / (w[2] - w[1]);
    let (mut lo, mut hi) = (0.05, 8.0);
    for _ in 0..100 {
        let mid: f64 = 0.5 * (lo + hi);
        let f = (h[0].powf(mid) - h[1].powf(mid)) / (h[1].powf(mid) - h[2].powf(mid));
        if f < ratio {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    assert!((p - 0.5 * (lo + hi)).abs() < 1e-6, "{p} {w:?}");
    let mut fine = vec!["locate", "--single", "--set", "discretization.nodes=161"];
    fine.extend(common);
    let (code, stdout, stderr) = helixbif(&fine);
    assert_eq!(code, 0, "{stderr}");
    let f: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(f["kind"], "hopf");
    // The true error of the N = 81 value is at least its distance to the finer value (both
    // converge from above); the estimate of the finest rung's own error (its discretization
    // error plus the size of the quadrature's) covers it, and by less than a factor of 20.
    let measured = w[2] - f["omega_b"].as_f64().unwrap();
    let error = v["finest_error"].as_f64().unwrap();
    assert!(measured > 0.0, "{measured}");
    assert!(
        error >= measured && error < 20.0 * measured,
        "{error} vs {measured}"
    );
}

#[test]
fn a_locate_study_with_an_accuracy_refines_and_writes_its_rungs() {
    let dir = temp_dir("cli-locate-accuracy");
    let study = dir.join("refine.toml");
    // The representative helix (its [discretization] table last) with 20 nodes and a study
    // table, on Lighthill's operator.
    let base = std::fs::read_to_string("studies/representative.toml")
        .unwrap()
        .replace("model = \"rpy\"", "model = \"lighthill\"")
        .replace("nodes = 60", "nodes = 20");
    let out = dir.join("out");
    // `run` on the study with `table` appended: its exit code, stderr and, where it wrote one,
    // its `locate.json`.
    let run = |table: &str| {
        std::fs::write(&study, format!("{base}{table}")).unwrap();
        let _ = std::fs::remove_file(out.join("locate.json"));
        let (code, _, stderr) = run_into(&study, &out);
        let json = std::fs::read_to_string(out.join("locate.json"))
            .ok()
            .map(|text| serde_json::from_str::<serde_json::Value>(&text).unwrap());
        (code, stderr, json)
    };
    let locate_table = |extra: &str| format!("\n[study]\nkind = \"locate\"\n{extra}");
    let (code, stderr, v) = run(&locate_table("accuracy = 1e-6\nmax_nodes = 39\n"));
    // The accuracy asked for is out of reach: a numerical failure, the rungs on disk.
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("accuracy 1e-6 not reached"), "{stderr}");
    let v = v.unwrap();
    assert_eq!(rung_field(&v, "nodes"), [20.0, 39.0], "{v}");
    assert_eq!(v["reached"], false);
    assert!(v["omega_b_error"].as_f64().unwrap() > 0.0);
    // Without a [study] table, `run` answers as `locate` does: refined to the default accuracy
    // (out of reach on Lighthill's operator, whose range ends at N = 87: exit 1 from both).
    let (code, stderr, ran) = run("");
    assert_eq!(code, 1, "{stderr}");
    let ran = ran.unwrap();
    let (code, located, stderr) = helixbif(&["locate", study.to_str().unwrap(), "--json"]);
    assert_eq!(code, 1, "{stderr}");
    let located: serde_json::Value = serde_json::from_str(located.trim()).unwrap();
    assert_eq!(ran["accuracy"], 1e-3);
    for key in ["omega_b", "omega_b_error", "reached", "stopped"] {
        assert_eq!(ran[key], located[key], "{key}");
    }
    assert_eq!(rung_field(&ran, "nodes"), rung_field(&located, "nodes"));
    assert_eq!(rung_field(&ran, "omega_b"), rung_field(&located, "omega_b"));
    // With `fixed_nodes`, at the study's N with its error from a coarser rung.
    let (code, stderr, fixed) = run(&locate_table("fixed_nodes = true\n"));
    assert_eq!(code, 0, "{stderr}");
    let fixed = fixed.unwrap();
    assert_eq!(rung_field(&fixed, "nodes"), [11.0, 20.0], "{fixed}");
    assert!(fixed["accuracy"].is_null() && fixed["omega_b_error"].as_f64().unwrap() > 0.0);
    // Out of range, or together with an extrapolation: refused, naming the field.
    for (extra, field) in [
        ("accuracy = 0.5\n", "study.accuracy"),
        ("accuracy = 1e-3\nextrapolate = true\n", "study.accuracy"),
        ("max_nodes = 3\n", "study.max_nodes"),
        (
            "max_nodes = 20\n",
            "study.max_nodes: must exceed discretization.nodes = 20",
        ),
        ("fixed_nodes = true\naccuracy = 1e-3\n", "study.fixed_nodes"),
        (
            "fixed_nodes = true\nnodes = [20, 39, 77]\n",
            "study.fixed_nodes",
        ),
    ] {
        let (code, stderr, _) = run(&locate_table(extra));
        assert_eq!(code, 2, "{extra}: {stderr}");
        assert!(stderr.contains(field), "{stderr}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The field `key` of every rung of a `locate` refinement's JSON.
fn rung_field(v: &serde_json::Value, key: &str) -> Vec<f64> {
    v["rungs"]
        .as_array()
        .expect("a refinement has rungs")
        .iter()
        .map(|r| r[key].as_f64().expect("a number"))
        .collect()
}

/// `simulate` killed mid-run (SIGKILL, no chance to tidy up) and started again with `--resume`
/// writes the same `timeseries.csv` and `shapes.csv`, byte for byte, as a run never
/// interrupted; a checkpoint of other options is refused with exit code 2, naming `--resume`
/// and the field that differs.
#[test]
fn simulate_killed_and_resumed_writes_the_uninterrupted_files() {
    let base = std::env::temp_dir().join(format!("helixbif-resume-{}", std::process::id()));
    let (whole, part) = (base.join("whole"), base.join("part"));
    let args = |out: &std::path::Path| -> Vec<String> {
        [
            "simulate",
            "--set",
            "fluid.model=lighthill",
            "--set",
            "discretization.nodes=16",
            "--set",
            "integrator.dt_max=0.02",
            "--omega",
            "1.0",
            "--t-end",
            "200",
            "--shape-every",
            "100",
            "--json",
            "--out",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([out.display().to_string()])
        .collect()
    };
    let status = common::command()
        .args(args(&whole))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    // The same run, killed once its checkpoint counts 2000 samples (of about 10000).
    let mut child = common::command()
        .args(args(&part))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let checkpoint = part.join("checkpoint.json");
    let samples = |text: &str| -> u64 {
        serde_json::from_str::<serde_json::Value>(text)
            .ok()
            .and_then(|v| v["samples"].as_u64())
            .unwrap_or(0)
    };
    loop {
        if child.try_wait().unwrap().is_some() {
            panic!("the run ended before it could be interrupted");
        }
        let text = std::fs::read_to_string(&checkpoint).unwrap_or_default();
        if samples(&text) >= 2000 {
            child.kill().unwrap();
            child.wait().unwrap();
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let saved = samples(&std::fs::read_to_string(&checkpoint).unwrap());
    let written = std::fs::read_to_string(part.join("timeseries.csv"))
        .unwrap()
        .lines()
        .count() as u64;
    assert!(saved < 9000, "interrupted at {saved} samples");
    assert!(
        written > saved,
        "rows after the checkpoint: {written} vs {saved}"
    );
    let mut resumed = args(&part);
    resumed.push("--resume".into());
    let out = common::command().args(&resumed).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for file in ["timeseries.csv", "shapes.csv"] {
        let a = std::fs::read(whole.join(file)).unwrap();
        let b = std::fs::read(part.join(file)).unwrap();
        assert!(a == b, "{file} differs after the resume");
    }
    // Another rate into the same folder: refused.
    let mut other = args(&part);
    let rate = other.iter().position(|a| a == "--omega").unwrap() + 1;
    other[rate] = "1.1".into();
    other.push("--resume".into());
    let out = common::command().args(&other).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--resume"), "{stderr}");
    assert!(stderr.contains("`omega` is 1.1 here"), "{stderr}");
    std::fs::remove_dir_all(&base).ok();
}

#[test]
fn integrator_and_quadrature_fields_out_of_range_are_named() {
    for (set, field) in [
        ("integrator.rtol=0.5", "integrator.rtol"),
        ("integrator.atol=-1", "integrator.atol"),
        ("integrator.dt_max=0", "integrator.dt_max"),
        ("integrator.jacobian=\"lu\"", "integrator.jacobian"),
        ("fluid.points_per_blob=4", "fluid.points_per_blob"),
    ] {
        let (code, _, stderr) = helixbif(&[
            "simulate",
            "--set",
            "fluid.model=lighthill",
            "--omega",
            "0.2",
            "--t-end",
            "1",
            "--set",
            set,
        ]);
        assert_eq!(code, 2, "{set}: {stderr}");
        assert!(stderr.contains(field), "{set}: {stderr}");
    }
    let (code, _, stderr) = helixbif(&[
        "solve",
        "--omega",
        "0.2",
        "--set",
        "fluid.model=\"rpy\"",
        "--set",
        "fluid.points_per_blob=1",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("fluid.points_per_blob") && stderr.contains("[2, 64]"),
        "{stderr}"
    );
}

/// `simulate --from-orbit` refuses, with exit code 2 and one line naming `--from-orbit`, a file
/// that is not there, one that is not an orbit's start, and an orbit of another model; without
/// `--omega` it runs at the orbit's rate.
#[test]
fn simulate_from_an_orbit_checks_the_file_and_takes_the_orbits_rate() {
    let dir = temp_dir("cli-from-orbit");
    let orbits = dir.join("orbits");
    let (code, _, stderr) = helixbif(&[
        "orbits",
        "--set",
        "fluid.model=lighthill",
        "--set",
        "discretization.nodes=20",
        "--max-orbits",
        "2",
        "--out",
        orbits.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let start = orbits.join("states").join("orbit_0001.json");
    let row: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&start).unwrap()).unwrap();
    let missing = dir.join("none.json");
    let not_an_orbit = orbits.join("meta.json");
    for (file, nodes, why) in [
        (&missing, "20", "none.json"),
        (&not_an_orbit, "20", "is not an orbit's start"),
        (&start, "22", "belongs to another model"),
    ] {
        let (code, _, stderr) = helixbif(&[
            "simulate",
            "--set",
            "fluid.model=lighthill",
            "--set",
            &format!("discretization.nodes={nodes}"),
            "--from-orbit",
            file.to_str().unwrap(),
            "--t-end",
            "1",
            "--out",
            dir.join("sim").to_str().unwrap(),
        ]);
        assert_eq!(code, 2, "{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(
            stderr.contains("--from-orbit") && stderr.contains(why),
            "{stderr}"
        );
    }
    let (code, stdout, stderr) = helixbif(&[
        "simulate",
        "--set",
        "fluid.model=lighthill",
        "--set",
        "discretization.nodes=20",
        "--from-orbit",
        start.to_str().unwrap(),
        "--t-end",
        "1",
        "--out",
        dir.join("sim").to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(v["omega"], row["omega"], "{v}");
    assert_eq!(v["orbit"]["index"], 1, "{v}");
    // Shorter than a period: no whole cycle to compare.
    assert_eq!(v["orbit"]["cycles"].as_array().unwrap().len(), 0, "{v}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `run` in text mode prints the report of the command its study's kind runs: for a branch
/// study, the same events, line for line, as `branch` on the same study (not a JSON dump). The
/// representative helix at `N = 20` on Lighthill's operator (a branch in a second, where the RPY
/// line's takes twenty).
#[test]
fn run_prints_the_text_report_of_the_command_it_runs() {
    let dir = temp_dir("cli-run-text");
    let study = dir.join("branch.toml");
    let base = std::fs::read_to_string("studies/representative.toml")
        .unwrap()
        .replace("nodes = 60", "nodes = 20")
        .replace("model = \"rpy\"", "model = \"lighthill\"");
    assert!(base.contains("model = \"lighthill\""));
    std::fs::write(
        &study,
        format!("{base}\n[branch]\nomega_max = 2.0\n\n[study]\nkind = \"branch\"\n"),
    )
    .unwrap();
    let run = |args: &[&str]| {
        let (code, stdout, stderr) = helixbif(args);
        assert_eq!(code, 0, "{args:?}: {stderr}");
        stdout
    };
    let (run_out, branch_out) = (dir.join("run"), dir.join("branch"));
    let ran = run(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        run_out.to_str().unwrap(),
    ]);
    let branched = run(&[
        "branch",
        study.to_str().unwrap(),
        "--out",
        branch_out.to_str().unwrap(),
    ]);
    assert!(!ran.contains('{'), "a JSON dump:\n{ran}");
    let events = |text: &str| -> Vec<String> {
        text.lines()
            .filter(|l| l.starts_with("  "))
            .map(str::to_owned)
            .collect()
    };
    assert!(
        !events(&branched).is_empty(),
        "the branch finds events:\n{branched}"
    );
    assert_eq!(
        events(&ran),
        events(&branched),
        "run:\n{ran}\nbranch:\n{branched}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A branch that stalls (turned clockwise, Lighthill's mobility of the rod stops being positive
/// definite near `omega = -0.238` rad/s) prints its report, with every event found on the way,
/// before it fails with exit code 1 and says where; the points stay on disk.
#[test]
fn a_stalled_branch_reports_its_events_before_it_fails() {
    let out = temp_dir("stalled-branch");
    let (code, stdout, stderr) = helixbif(&[
        "branch",
        "--set",
        "fluid.model=lighthill",
        "--omega-max",
        "-0.3",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{stderr}");
    let line = stderr.trim().lines().last().unwrap();
    assert!(
        line.starts_with("helixbif: error: numerical failure: continuation stalled at omega = "),
        "{stderr}"
    );
    let report: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(report["stalled"], true);
    let events = report["events"].as_array().unwrap();
    let rows = std::fs::read_to_string(out.join("events.csv")).unwrap();
    assert_eq!(events.len(), rows.lines().count() - 1);
    assert!(events.len() >= 2, "{report}");
    let points = std::fs::read_to_string(out.join("branch.csv")).unwrap();
    assert_eq!(
        report["points"].as_u64().unwrap() as usize,
        points.lines().count() - 1
    );
    std::fs::remove_dir_all(&out).ok();
}

/// `run` on the representative helix on Lighthill's operator at `N = 20` (its [discretization]
/// table last) with a boundary table of `R/lambda` from `from` to `to` and the lines `extra`,
/// written into `dir`: the exit code, stderr and the output folder.
fn run_boundary_study(dir: &Path, (from, to): (&str, &str), extra: &str) -> (i32, String, PathBuf) {
    std::fs::create_dir_all(dir).unwrap();
    let path = dir.join("boundary.toml");
    let base = std::fs::read_to_string("studies/representative.toml")
        .unwrap()
        .replace("model = \"rpy\"", "model = \"lighthill\"")
        .replace("nodes = 60", "nodes = 20");
    let table = format!(
        "\n[study]\nkind = \"boundary\"\nvary = \"shape.R_over_lambda\"\nfrom = {from}\n\
         to = {to}\n{extra}"
    );
    std::fs::write(&path, format!("{base}{table}")).unwrap();
    let out = dir.join("out");
    let (code, _, stderr) = run_into(&path, &out);
    (code, stderr, out)
}

/// A boundary study's refinement of its points (`accuracy`, `max_nodes`, `carry_spacing`): an
/// accuracy or a spacing out of range, or `max_nodes` or a spacing without an accuracy, is
/// refused before anything runs, in one line naming the field, with exit code 2.
#[test]
fn a_boundary_study_refuses_a_refinement_it_cannot_do() {
    let dir = std::env::temp_dir().join(format!("helixbif-boundary-plan-{}", std::process::id()));
    for (extra, message) in [
        ("accuracy = 0.2\n", "study.accuracy: must lie in (0, 0.1)"),
        (
            "max_nodes = 100\n",
            "study.max_nodes: bounds the refinement of the points, which needs study.accuracy",
        ),
        (
            "accuracy = 1e-3\nmax_nodes = 3\n",
            "study.max_nodes: must be >= 5",
        ),
        (
            "accuracy = 1e-3\nmax_nodes = 20\n",
            "study.max_nodes: must exceed discretization.nodes = 20",
        ),
        (
            "carry_spacing = 0.1\n",
            "study.carry_spacing: spaces the points refined to an accuracy, which needs \
             study.accuracy",
        ),
        (
            "accuracy = 1e-3\ncarry_spacing = -0.1\n",
            "study.carry_spacing: must be in [0, 1]",
        ),
    ] {
        let (code, stderr, _) = run_boundary_study(&dir, ("0.3", "0.31"), extra);
        assert_eq!(code, 2, "{extra}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(stderr.contains(message), "{extra}: {stderr}");
    }
    // A spacing in ln |q| needs the range on one side of 0.
    let (code, stderr, _) = run_boundary_study(
        &dir,
        ("-0.1", "0.31"),
        "accuracy = 1e-3\ncarry_spacing = 0.1\n",
    );
    assert_eq!(code, 2, "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains(
            "study.carry_spacing: spaces the points in ln |q|, which needs the range on one side \
             of 0, got -0.1 to 0.31"
        ),
        "{stderr}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A boundary study whose points cannot reach their accuracy (Lighthill's operator at `N = 20`,
/// at most 30 nodes, `1e-3` asked for) writes everything and then fails with exit code 1, one
/// line naming the case and the accuracy; `meta.json` holds every point's refinement (all
/// carried, none reached) and the curve's exponents with their errors.
#[test]
fn a_boundary_study_that_falls_short_of_its_accuracy_fails_after_writing_everything() {
    let dir = std::env::temp_dir().join(format!("helixbif-boundary-short-{}", std::process::id()));
    let extra = "accuracy = 1e-3\nmax_nodes = 30\n";
    let (code, stderr, out) = run_boundary_study(&dir, ("0.318", "0.317"), extra);
    assert_eq!(code, 1, "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("base: accuracy 1e-3 not reached at"),
        "{stderr}"
    );
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
    let curve = &meta["run"]["curves"][0];
    let report = &curve["report"];
    assert_eq!(report["carried"], report["points"]);
    assert_eq!(report["not_reached"], report["points"]);
    assert_eq!(report["nodes_max"], 30);
    for key in ["m_loc_smallest_error", "m_loc_limit_error"] {
        assert!(curve[key].as_f64().unwrap() > 0.0, "{key}: {curve}");
    }
    let table = std::fs::read_to_string(out.join("boundary.csv")).unwrap();
    assert_eq!(
        table.lines().count() as u64,
        report["points"].as_u64().unwrap() + 1
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A phase study's carry spacing for its boundary curve (`carry_spacing`) is refused without an
/// accuracy and out of `[0, 1]`, before anything runs, in one line naming the key, with exit
/// code 2.
#[test]
fn a_phase_study_refuses_a_carry_spacing_it_cannot_use() {
    let out = std::env::temp_dir().join(format!("helixbif-phase-spacing-{}", std::process::id()));
    for (extra, message) in [
        (
            vec!["study.carry_spacing=0.1"],
            "invalid input: study.carry_spacing: spaces the points refined to an accuracy, which \
             needs study.accuracy",
        ),
        (
            vec!["study.accuracy=1e-3", "study.carry_spacing=1.5"],
            "invalid input: study.carry_spacing: must be in [0, 1]",
        ),
    ] {
        let mut args = vec![
            "run",
            "studies/fig4d_phase.toml",
            "--out",
            out.to_str().unwrap(),
        ];
        for set in &extra {
            args.extend(["--set", set]);
        }
        let (code, _, stderr) = helixbif(&args);
        assert_eq!(code, 2, "{extra:?}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(stderr.contains(message), "{extra:?}: {stderr}");
        assert!(
            !out.exists(),
            "nothing is written before the study is checked"
        );
    }
}

/// `HELIXBIF_KERNELS` caps the copy of the RPY kernels: each copy gives the same report to the
/// last bit (the copies differ in speed only), and a value that names no copy is bad input,
/// named in one line with the values allowed.
#[test]
fn the_kernel_copy_is_chosen_by_the_environment_and_changes_no_bit() {
    let solve = |copy: &str| {
        let out = common::command()
            .args([
                "solve",
                "--omega",
                "0.3",
                "--set",
                "discretization.nodes=25",
                "--json",
            ])
            .env("HELIXBIF_KERNELS", copy)
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8(out.stdout).unwrap(),
            String::from_utf8(out.stderr).unwrap(),
        )
    };
    let (code, widest, stderr) = solve("avx512");
    assert_eq!(code, Some(0), "{stderr}");
    let v: serde_json::Value = serde_json::from_str(widest.trim()).unwrap();
    assert!(v["hbar"].as_f64().is_some_and(f64::is_finite), "{v}");
    for copy in ["avx2", "baseline", ""] {
        let (code, json, stderr) = solve(copy);
        assert_eq!(code, Some(0), "{copy}: {stderr}");
        assert_eq!(json, widest, "the {copy} copy");
    }
    let (code, stdout, stderr) = solve("avx3");
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stdout.is_empty(), "{stdout}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    for word in ["HELIXBIF_KERNELS", "avx3", "baseline, avx2 or avx512"] {
        assert!(stderr.contains(word), "{word}: {stderr}");
    }
}

/// Where stderr is not a terminal (a pipe here, a batch job's log on a cluster), a run's
/// progress bar is a plain line every `HELIXBIF_PROGRESS_SECONDS` (0: at every update): `locate`
/// writes its bar's lines, with no terminal control characters; by default (10 s) a run of a
/// second writes none; a value that is no number of seconds in range is bad input, named in one
/// line with the range.
#[test]
fn progress_in_a_log_is_a_plain_line_every_interval() {
    let locate = |seconds: Option<&str>| {
        let mut command = common::command();
        command.args([
            "locate",
            "--single",
            "--set",
            "fluid.model=lighthill",
            "--set",
            "discretization.nodes=20",
        ]);
        match seconds {
            Some(seconds) => command.env("HELIXBIF_PROGRESS_SECONDS", seconds),
            None => command.env_remove("HELIXBIF_PROGRESS_SECONDS"),
        };
        let out = command.output().unwrap();
        (out.status.code(), String::from_utf8(out.stderr).unwrap())
    };
    let (code, stderr) = locate(Some("0"));
    assert_eq!(code, Some(0), "{stderr}");
    let bar: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("locate N = 20 ["))
        .collect();
    assert!(bar.len() >= 3, "{stderr}");
    assert!(
        stderr.chars().all(|c| c == '\n' || !c.is_control()),
        "{stderr:?}"
    );
    let (code, stderr) = locate(None);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(!stderr.contains("locate N = 20 ["), "{stderr}");
    let (code, stderr) = locate(Some("-3"));
    assert_eq!(code, Some(2), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    for word in ["HELIXBIF_PROGRESS_SECONDS", "-3", "from 0 to 86400"] {
        assert!(stderr.contains(word), "{word}: {stderr}");
    }
}
