//! Study files: every study of `studies/` parses and a reduced version of it runs; sweeps are
//! resumable and shardable with the same numbers; `fit` recovers a known power law.

use std::path::{Path, PathBuf};

use crate::common;

use common::{helixbif, run_into, small_sweep, temp_dir};
use helixbif::study::Study;
use helixbif::study::output::Provenance;
use helixbif::study::plan::Plan;
use helixbif::study::run::{StudyResult, run};

/// A reduced version of a study: few nodes, the first two values of every list, a short range.
fn reduced(mut study: Study) -> Study {
    study.discretization.per_turn = None;
    study.discretization.nodes = 16;
    study.branch.omega_max = study.branch.omega_max.min(0.8);
    match &mut study.study {
        Some(Plan::Sweep { vary, cases, .. }) => {
            for v in vary.iter_mut() {
                v.values = v.points().into_iter().take(2).collect();
                v.range = None;
            }
            cases.truncate(2);
        }
        Some(Plan::Phase {
            lambda_over_l,
            m,
            rows,
            ..
        }) => {
            lambda_over_l.truncate(2);
            m.get_or_insert(1.0);
            *rows = 8;
        }
        Some(Plan::Shapes { omegas }) => omegas.truncate(2),
        Some(Plan::Dynamics {
            omegas,
            t_end,
            transient,
            ramp_time,
            ..
        }) => {
            omegas.truncate(1);
            *t_end = 10.0;
            *transient = 5.0;
            *ramp_time = 2.0;
        }
        Some(Plan::Branch { cases }) => cases.truncate(2),
        Some(Plan::Orbits(orbits)) => {
            // At N = 16 the Hopf point lies near 1.33 rad/s.
            orbits.max_orbits = 3;
            study.branch.omega_max = 2.0;
            orbits.omega_max = None;
        }
        Some(Plan::Boundary {
            from, to, cases, ..
        }) => {
            cases.truncate(2);
            *to = *from + 0.1 * (*to - *from);
        }
        _ => {}
    }
    study
}

/// Counts the `<text>` elements equal to `label` in an SVG file, after checking it parses.
fn svg_texts(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let doc =
        roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    doc.descendants()
        .filter(|n| n.has_tag_name("text"))
        .filter_map(|n| n.text().map(|t| t.trim().to_string()))
        .collect()
}

#[test]
fn every_study_parses_and_a_reduced_version_runs() {
    let studies = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies");
    let mut names: Vec<PathBuf> = std::fs::read_dir(&studies)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    assert!(names.len() >= 8, "{names:?}");
    for path in names {
        let study = Study::from_path(Some(&path), &[])
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let small = reduced(study);
        let dir = temp_dir(&format!("study-{}", small.name));
        let report = run(&small, &dir, false, &Provenance::default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(dir.join("meta.json").exists(), "{}", path.display());
        // Every SVG written is valid XML with labelled axes.
        let svgs: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "svg"))
            .collect();
        if small.study.as_ref().is_some_and(|p| p.kind() != "locate") {
            assert!(
                !svgs.is_empty(),
                "{}: no figure ({})",
                path.display(),
                serde_json::to_string(&report).unwrap()
            );
        }
        for svg in &svgs {
            let texts = svg_texts(svg);
            assert!(
                texts.iter().any(|t| t.contains('(') && t.contains(')')),
                "{}: no axis label with a unit",
                svg.display()
            );
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}

#[test]
fn study_paths_resolve_against_the_study_file_and_the_exponent_is_read_beside_the_output() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // From any working directory the phase study finds the data of the repository.
    let study = Study::from_path(Some(&root.join("studies/fig4d_phase.toml")), &[]).unwrap();
    let Some(Plan::Phase {
        bacteria,
        exponent_study,
        ..
    }) = &study.study
    else {
        panic!("fig4d_phase is a phase study")
    };
    let bacteria = PathBuf::from(bacteria.as_ref().unwrap());
    assert!(bacteria.is_file(), "{}", bacteria.display());
    assert_eq!(
        std::fs::read_to_string(&bacteria).unwrap(),
        std::fs::read_to_string(root.join("data/bacteria.csv")).unwrap()
    );
    assert!(Path::new(exponent_study).is_file(), "{exponent_study}");
    // A reduced phase study without m reads it from `<out>/../exponent_m/fit.json`.
    let dir = temp_dir("phase-exponent");
    std::fs::create_dir_all(dir.join("exponent_m")).unwrap();
    std::fs::write(dir.join("exponent_m/fit.json"), "{\"m\": 2.5}").unwrap();
    let mut small = reduced(study);
    if let Some(Plan::Phase { m, .. }) = &mut small.study {
        *m = None;
    }
    let report = run(&small, &dir.join("phase"), false, &Provenance::default()).unwrap();
    let StudyResult::Phase(phase) = report else {
        panic!("a phase study reports a phase result")
    };
    assert_eq!(phase.m, 2.5);
    std::fs::remove_dir_all(&dir).ok();
}

/// A boundary study resumed after an interruption reads back the curves the interrupted run
/// finished (their folders keep that run's record) and follows the rest again: the same
/// curves, local exponents and shared power law as the run that was not interrupted, to the
/// last bit. A study of one curve resumes the same way. A resume with other settings than the
/// folder's (the rod, or the range of the curves) is refused before any curve is followed,
/// naming `--resume`.
#[test]
fn a_resumed_boundary_study_reads_back_its_finished_curves_and_follows_the_rest() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("studies/exponent_m.toml");
    let study = reduced(Study::from_path(Some(&path), &[]).unwrap());
    let dir = temp_dir("boundary-resume");
    let by = |name: &str| Provenance {
        command_line: vec![name.to_string()],
    };
    let StudyResult::Boundary(whole) = run(&study, &dir, false, &by("whole")).unwrap() else {
        panic!("a boundary study reports a boundary result")
    };
    assert_eq!(whole.curves.len(), 2);
    let (first, second) = (dir.join("lambda_l_0_125"), dir.join("lambda_l_0_1875"));
    let table = |folder: &Path| std::fs::read_to_string(folder.join("boundary.csv")).unwrap();
    let followed_by = |folder: &Path| {
        let record: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(folder.join("curve.json")).unwrap())
                .unwrap();
        record["command_line"][0].as_str().unwrap().to_string()
    };
    let (first_table, second_table) = (table(&first), table(&second));
    // The second curve killed after three points, as a kill leaves its folder: the points so
    // far, and no record of a finished curve.
    let kept: Vec<&str> = second_table.lines().take(4).collect();
    assert!(second_table.lines().count() > 6, "{second_table}");
    std::fs::write(second.join("boundary.csv"), kept.join("\n") + "\n").unwrap();
    std::fs::remove_file(second.join("curve.json")).unwrap();
    std::fs::remove_file(dir.join("m_loc.svg")).unwrap();

    let StudyResult::Boundary(resumed) = run(&study, &dir, true, &by("resumed")).unwrap() else {
        panic!("a boundary study reports a boundary result")
    };
    // The finished curve was read back, the interrupted one followed again.
    assert_eq!(followed_by(&first), "whole");
    assert_eq!(followed_by(&second), "resumed");
    assert_eq!(table(&first), first_table);
    assert_eq!(table(&second), second_table);
    assert!(dir.join("m_loc.svg").exists());
    let read_back: Vec<bool> = resumed.curves.iter().map(|c| c.resumed).collect();
    assert_eq!(read_back, [true, false]);
    assert!(whole.curves.iter().all(|c| !c.resumed));
    for (a, b) in whole.curves.iter().zip(&resumed.curves) {
        assert_eq!(a.label, b.label);
        assert_eq!(a.m_loc_smallest, b.m_loc_smallest);
        assert_eq!(a.m_loc_limit, b.m_loc_limit);
        assert_eq!(a.m_loc_limit_error, b.m_loc_limit_error);
        let (ra, rb) = (a.report.as_ref().unwrap(), b.report.as_ref().unwrap());
        assert_eq!((ra.points, ra.segments), (rb.points, rb.segments));
        assert_eq!(ra.relative_error_max, rb.relative_error_max);
    }
    let (ca, cb) = (whole.common_fit.unwrap(), resumed.common_fit.unwrap());
    assert_eq!((ca.p, ca.p_ci, ca.n), (cb.p, cb.p_ci, cb.n));

    // Followed for other settings (the rod, or the range): refused, nothing followed.
    for (set, field) in [
        (
            "rod.E=1.3e6",
            "`study.rod.E` is 1300000.0 here and 1255000.0",
        ),
        ("study.from=0.39", "`range.0` is 0.39 here and 0.4"),
    ] {
        let other = reduced(Study::from_path(Some(&path), &[set.to_string()]).unwrap());
        let Err(refused) = run(&other, &dir, true, &by("other")) else {
            panic!("a resume with {set} runs")
        };
        assert!(refused.is_input(), "{refused}");
        assert!(refused.to_string().contains("--resume"), "{refused}");
        assert!(refused.to_string().contains(field), "{refused}");
        assert_eq!(followed_by(&first), "whole");
        assert_eq!(followed_by(&second), "resumed");
    }

    // A study of one curve, in the study's own folder.
    let mut one = study.clone();
    if let Some(Plan::Boundary { cases, .. }) = &mut one.study {
        cases.truncate(1);
    }
    let lone = temp_dir("boundary-resume-one");
    run(&one, &lone, false, &by("whole")).unwrap();
    let lone_table = table(&lone);
    run(&one, &lone, true, &by("resumed")).unwrap();
    assert_eq!(followed_by(&lone), "whole");
    assert_eq!(table(&lone), lone_table);
    std::fs::remove_dir_all(&dir).ok();
    std::fs::remove_dir_all(&lone).ok();
}

/// The rows of a sweep CSV without the timing column, sorted by point.
fn rows(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let seconds = header.iter().position(|h| *h == "seconds").unwrap();
    let mut rows: Vec<String> = lines
        .map(|l| {
            l.split(',')
                .enumerate()
                .filter(|(i, _)| *i != seconds)
                .map(|(_, v)| v)
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect();
    rows.sort_by_key(|r| r.split(',').next().unwrap().parse::<usize>().unwrap());
    rows
}

#[test]
fn a_killed_sweep_resumes_and_shards_merge_to_the_same_numbers() {
    let dir = temp_dir("sweep");
    let study = small_sweep(&dir);
    let s = study.to_str().unwrap();
    // Uninterrupted reference.
    let whole = dir.join("whole");
    let (code, _, err) = helixbif(&["sweep", s, "--out", whole.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let reference = rows(&whole.join("sweep.csv"));
    assert_eq!(reference.len(), 8);
    // Killed midway: wait until some points are on disk, kill, re-run.
    let killed = dir.join("killed");
    let mut child = common::command()
        .args(["sweep", s, "--out", killed.to_str().unwrap()])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let csv = killed.join("sweep.csv");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    loop {
        let done = std::fs::read_to_string(&csv)
            .map(|t| t.lines().count().saturating_sub(1))
            .unwrap_or(0);
        if done >= 2 || std::time::Instant::now() > deadline {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let partial = std::fs::read_to_string(&csv).unwrap().lines().count() - 1;
    let (code, out, err) = helixbif(&["sweep", s, "--out", killed.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let summary: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(
        summary["already_done"].as_u64().unwrap() as usize
            + summary["computed"].as_u64().unwrap() as usize,
        8
    );
    assert!(
        summary["already_done"].as_u64().unwrap() as usize >= partial.min(8) - 1,
        "{summary} vs {partial}"
    );
    assert_eq!(
        rows(&csv),
        reference,
        "resumed sweep differs from the uninterrupted one"
    );
    // A complete sweep re-run computes nothing.
    let (_, out, _) = helixbif(&["sweep", s, "--out", killed.to_str().unwrap(), "--json"]);
    let summary: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(summary["computed"], 0);
    // Two shards merged equal the whole.
    let sharded = dir.join("sharded");
    for k in ["1/2", "2/2"] {
        let (code, _, err) =
            helixbif(&["sweep", s, "--shard", k, "--out", sharded.to_str().unwrap()]);
        assert_eq!(code, 0, "{err}");
    }
    let (code, _, err) = helixbif(&["merge", s, "--out", sharded.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(rows(&sharded.join("sweep.csv")), reference);
    // Merging shards of another study is refused.
    let (code, _, err) = helixbif(&[
        "merge",
        s,
        "--set",
        "rod.E=2e6",
        "--out",
        sharded.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("different study"), "{err}");
    // The figure holds one marker per point and its axis labels.
    let texts = svg_texts(&whole.join("sweep_0.svg"));
    assert!(texts.iter().any(|t| t == "ω_b (rad/s)"), "{texts:?}");
    let svg = std::fs::read_to_string(whole.join("sweep_0.svg")).unwrap();
    assert_eq!(svg.matches("<circle").count(), 8);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn fit_recovers_a_power_law_from_a_csv() {
    let dir = temp_dir("fit");
    let path = dir.join("data.csv");
    let mut text = String::from("x,y\n");
    let mut state = 2024u64;
    for i in 0..20 {
        let x = 0.5 + 0.25 * i as f64;
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let noise = 1.0 + 0.02 * ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5);
        text.push_str(&format!("{x},{}\n", 4.0 * x.powf(-0.6) * noise));
    }
    std::fs::write(&path, text).unwrap();
    let (code, out, err) = helixbif(&[
        "fit",
        path.to_str().unwrap(),
        "--x",
        "x",
        "--y",
        "y",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    let p_ci: Vec<f64> = v["p_ci"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(p_ci[0] < -0.6 && -0.6 < p_ci[1], "{v}");
    assert!((v["p"].as_f64().unwrap() + 0.6).abs() < 0.02);
    for key in ["C", "C_ci", "n", "r2"] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    let (code, _, err) = helixbif(&["fit", path.to_str().unwrap(), "--x", "nope", "--y", "y"]);
    assert_eq!(code, 2);
    assert!(err.contains("nope"));
    std::fs::remove_dir_all(&dir).ok();
}

/// Every point of a sweep states the estimated discretization error of its `omega_b`
/// (`omega_b_error`), the same as `locate` refining from `N/2 + 1` to the point's `N` states.
#[test]
fn every_point_of_a_sweep_states_the_discretization_error_of_its_omega_b() {
    let dir = temp_dir("sweep-errors");
    let study = small_sweep(&dir);
    let study = study.to_str().unwrap();
    let out = dir.join("out");
    let (code, _, stderr) = helixbif(&[
        "sweep",
        study,
        "--set",
        "discretization.nodes=30",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    let mut table = csv::Reader::from_path(out.join("sweep.csv")).unwrap();
    let header = table.headers().unwrap().clone();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let rows: Vec<csv::StringRecord> = table.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), 8);
    for row in rows.iter().step_by(3) {
        let lambda_over_l = &row[col("lambda_over_l")];
        let error: f64 = row[col("omega_b_error")].parse().unwrap();
        let (code, stdout, stderr) = helixbif(&[
            "locate",
            study,
            "--set",
            &format!("shape.lambda_over_l={lambda_over_l}"),
            "--set",
            "discretization.nodes=16",
            "--max-nodes",
            "30",
            "--accuracy",
            "1e-9",
            "--json",
        ]);
        assert!(code <= 1, "{stderr}");
        let refined: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        let expected = refined["omega_b_error"].as_f64().unwrap();
        let omega_b: f64 = row[col("omega_b")].parse().unwrap();
        assert!(
            (refined["omega_b"].as_f64().unwrap() - omega_b).abs() <= 1e-7 * omega_b,
            "{lambda_over_l}: {stdout}"
        );
        assert!(
            (error - expected).abs() <= 1e-6 * expected && error > 0.0,
            "lambda/l = {lambda_over_l}: sweep {error}, locate {expected}"
        );
    }
}

/// A sweep carried to an accuracy (`accuracy`, `max_nodes` in its [study] table): every point
/// is `locate`'s refinement from the point's `N`, the same answer, error, finest `N` and verdict
/// `reached` as `helixbif locate --accuracy` at that point (the thick rod on the RPY line, which
/// reaches `1e-2` from `N = 31`). A sweep whose points fall short of their accuracy (Lighthill's
/// operator capped at 30 nodes) writes every row and figure, then fails with exit code 1 in one
/// line; a re-run keeps the rows and says the same.
#[test]
fn a_sweep_carried_to_an_accuracy_answers_as_locate_does_at_every_point() {
    let dir = temp_dir("sweep-accuracy");
    std::fs::create_dir_all(&dir).unwrap();
    let base = std::fs::read_to_string("studies/representative.toml").unwrap();
    let sweep = |model: &str, nodes: &str, extra: &str| {
        let text = base
            .replace("model = \"rpy\"", &format!("model = \"{model}\""))
            .replace("nodes = 60", &format!("nodes = {nodes}"));
        format!(
            "{text}\n[study]\nkind = \"sweep\"\nvary = [{{ key = \"shape.R_over_lambda\", values \
             = [0.3, 0.31] }}]\nfigures = [{{ x = \"R_over_lambda\", y = \"omega_b\" }}]\n{extra}"
        )
    };
    let thick = ["--set", "rod.r0=6.32e-3", "--set", "branch.omega_max=300"];
    let path = dir.join("thick.toml");
    std::fs::write(&path, sweep("rpy", "31", "accuracy = 1e-2\n")).unwrap();
    let out = dir.join("thick");
    let mut args = vec!["sweep", path.to_str().unwrap()];
    args.extend(thick);
    args.extend(["--out", out.to_str().unwrap()]);
    let (code, stdout, stderr) = helixbif(&args);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("reached at 2 of the 2 points located"),
        "{stdout}"
    );
    let mut table = csv::Reader::from_path(out.join("sweep.csv")).unwrap();
    let header = table.headers().unwrap().clone();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let rows: Vec<csv::StringRecord> = table.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), 2);
    for row in &rows {
        let q = &row[col("shape.R_over_lambda")];
        let mut args = vec!["locate", path.to_str().unwrap(), "--accuracy", "1e-2"];
        args.extend(thick);
        let set = format!("shape.R_over_lambda={q}");
        args.extend(["--set", &set, "--json"]);
        let (code, stdout, stderr) = helixbif(&args);
        assert_eq!(code, 0, "{stderr}");
        let located: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        let number = |c: &str| row[col(c)].parse::<f64>().unwrap();
        for (column, key) in [("omega_b", "omega_b"), ("omega_b_error", "omega_b_error")] {
            let expected = located[key].as_f64().unwrap();
            assert!(
                (number(column) - expected).abs() <= 1e-12 * expected,
                "{column} at {q}: sweep {}, locate {expected}",
                number(column)
            );
        }
        assert_eq!(number("nodes"), located["nodes"].as_f64().unwrap());
        assert!(number("nodes") > 31.0, "refined past the point's N");
        assert_eq!(&row[col("reached")], "true");
        assert_eq!(located["reached"], true);
    }
    // Out of reach: every row and the figure written, then exit 1 (also when re-run). The third
    // point (`R/lambda = 0.1`) is stable up to `branch.omega_max`: a result without an omega_b,
    // neither reached nor missed.
    let path = dir.join("short.toml");
    let short = "accuracy = 1e-3\nmax_nodes = 30\n";
    let text = sweep("lighthill", "20", short).replace("[0.3, 0.31]", "[0.3, 0.31, 0.1]");
    std::fs::write(&path, text).unwrap();
    let reached = |out: &Path| {
        let mut table = csv::Reader::from_path(out.join("sweep.csv")).unwrap();
        let at = table.headers().unwrap().iter().position(|h| h == "reached");
        table
            .records()
            .map(|r| r.unwrap()[at.unwrap()].to_string())
            .collect::<Vec<String>>()
    };
    let missed = "accuracy 1e-3 not reached at 2 of 2 sweep points located";
    let out = dir.join("short");
    for _ in 0..2 {
        let (code, _, stderr) = run_into(&path, &out);
        assert_eq!(code, 1, "{stderr}");
        // The figure's note of the row it leaves out (no omega_b), then the one error line.
        let lines: Vec<&str> = stderr.trim().lines().collect();
        assert_eq!(lines.len(), 2, "{stderr}");
        assert!(lines[0].contains("leaves out row 3 (point 2)"), "{stderr}");
        assert!(lines[1].contains(missed), "{stderr}");
        assert_eq!(reached(&out), ["false", "false", ""]);
        assert!(out.join("sweep_0.svg").exists());
    }
    // In shards: each shard finishes (exit 0, so that an `afterok` merge runs); the merge
    // writes everything, then fails.
    let sharded = dir.join("sharded");
    for shard in ["1/2", "2/2"] {
        let (code, _, stderr) = helixbif(&[
            "sweep",
            path.to_str().unwrap(),
            "--shard",
            shard,
            "--out",
            sharded.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{shard}: {stderr}");
    }
    let merge = [
        "merge",
        path.to_str().unwrap(),
        "--out",
        sharded.to_str().unwrap(),
    ];
    let (code, _, stderr) = helixbif(&merge);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains(missed), "{stderr}");
    assert_eq!(reached(&sharded), ["false", "false", ""]);
    assert!(sharded.join("sweep_0.svg").exists());
    // A point whose own N leaves its refinement no room is refused before anything runs.
    let path = dir.join("room.toml");
    let text = sweep("lighthill", "20", short).replace(
        "key = \"shape.R_over_lambda\", values = [0.3, 0.31]",
        "key = \"discretization.nodes\", values = [20, 40]",
    );
    std::fs::write(&path, text).unwrap();
    let out = dir.join("room");
    let (code, _, stderr) = run_into(&path, &out);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("study.max_nodes: must exceed discretization.nodes = 40"),
        "{stderr}"
    );
    assert!(!out.join("sweep.csv").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// A phase map carried to an accuracy (`accuracy`, `max_nodes` in its [study] table): each
/// column's first loss of stability is `locate`'s refinement at its `lambda/l` (the same
/// `omegabar_b` and error as `helixbif locate --accuracy --max-nodes` there), the boundary curve's
/// points are carried as a boundary study's (its first point the first column's value), and a
/// map out of reach (Lighthill's operator from `N = 16`, capped at 30 nodes) writes everything,
/// then fails with exit code 1 in one line naming the columns and the curve.
#[test]
fn a_phase_map_carried_to_an_accuracy_refines_its_columns_and_its_curve() {
    let dir = temp_dir("phase-accuracy");
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string("studies/fig4d_phase.toml")
        .unwrap()
        .replace("per_turn = 12.0", "")
        .replace("nodes = 60", "nodes = 16")
        .replace("omega_max = 0.15", "omega_max = 0.8")
        .replace(
            "lambda_over_l = [0.125, 0.1875, 0.25, 0.3125, 0.375]",
            "lambda_over_l = [0.125, 0.1875]",
        )
        .replace("exponent_study = \"exponent_m.toml\"", "m = 2.5")
        .replace("bacteria = \"../data/bacteria.csv\"", "");
    let path = dir.join("phase.toml");
    std::fs::write(&path, format!("{text}accuracy = 1e-3\nmax_nodes = 30\n")).unwrap();
    let out = dir.join("out");
    let (code, _, stderr) = run_into(&path, &out);
    assert_eq!(code, 1, "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    for part in [
        "accuracy 1e-3 not reached at the first loss of stability of the column(s) lambda/l = \
         0.125, 0.1875",
        "boundary curve: accuracy 1e-3 not reached at",
    ] {
        assert!(stderr.contains(part), "{stderr}");
    }
    let read = |file: &Path| {
        let mut table = csv::Reader::from_path(file).unwrap();
        let header: Vec<String> = table.headers().unwrap().iter().map(String::from).collect();
        let rows: Vec<Vec<String>> = table
            .records()
            .map(|r| r.unwrap().iter().map(String::from).collect())
            .collect();
        (header, rows)
    };
    let (header, columns) = read(&out.join("boundary.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert_eq!(columns.len(), 2);
    for row in &columns {
        assert_eq!(
            (row[col("nodes")].as_str(), row[col("reached")].as_str()),
            ("30", "false")
        );
    }
    let first = &columns[0];
    let (code, stdout, stderr) = helixbif(&[
        "locate",
        path.to_str().unwrap(),
        "--set",
        "shape.lambda_over_l=0.125",
        "--set",
        "shape.R_over_lambda=0.318",
        "--accuracy",
        "1e-3",
        "--max-nodes",
        "30",
        "--json",
    ]);
    assert_eq!(code, 1, "{stderr}");
    let located: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let (omegabar_b, omega_b) = (
        located["omegabar_b"].as_f64().unwrap(),
        located["omega_b"].as_f64().unwrap(),
    );
    let column = |name: &str| first[col(name)].parse::<f64>().unwrap();
    assert!((column("omegabar_b") - omegabar_b).abs() <= 1e-9 * omegabar_b);
    let error = located["omega_b_error"].as_f64().unwrap() * omegabar_b / omega_b;
    assert!((column("omegabar_b_error") - error).abs() <= 1e-9 * error);
    let (header, curve) = read(&out.join("boundary_curve/boundary.csv"));
    let at = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert!(curve.len() > 2);
    let start: f64 = curve[0][at("omegabar_b")].parse().unwrap();
    assert!((start - omegabar_b).abs() <= 1e-9 * omegabar_b, "{start}");
    for row in &curve {
        assert_eq!(
            [
                &row[at("reached")],
                &row[at("nodes")],
                &row[at("curve_nodes")]
            ],
            ["false", "30", "16"]
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
