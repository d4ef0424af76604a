//! The command line: JSON output, exit codes and one-line errors naming the field.

use crate::common;

use common::helixbif;

#[test]
fn solve_json_has_the_documented_keys() {
    let (code, stdout, _) = helixbif(&[
        "solve",
        "--omega",
        "0.05",
        "--json",
        "--set",
        "discretization.nodes=30",
    ]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    for key in [
        "omega",
        "omegabar",
        "Fp",
        "Fpbar",
        "Tp",
        "eta",
        "h",
        "hbar",
        "h0",
        "newton_iterations",
        "residual_norm",
        "nodes",
    ] {
        assert!(v.get(key).is_some(), "missing key {key}");
    }
    assert_eq!(v["nodes"], 30);
    assert!(v["residual_norm"].as_f64().unwrap() < 1e-9);
    assert!((v["omega"].as_f64().unwrap() - 0.05).abs() < 1e-15);
    assert!(v["errors"]["Fp"].as_f64().unwrap() > 0.0);
    assert!(v["errors_missing"].is_null());
}

/// `solve` states an error beside every observable (first order from `N/2 + 1` nodes, plus the
/// quadrature's on the RPY line): on a case of its own (the thick rod on the RPY line at 20 rad/s,
/// about 0.6 of its `omega_b`), each stated error at `N = 31` covers the difference to a direct
/// solve at `N = 241`, eight times finer, and is at most ten times it. A model too coarse for a
/// coarser rung says why it has no errors.
#[test]
fn the_errors_solve_states_cover_a_finer_direct_computation() {
    let solve = |nodes: &str| {
        let set = format!("discretization.nodes={nodes}");
        let (code, stdout, stderr) = helixbif(&[
            "solve",
            "--omega",
            "20",
            "--json",
            "--set",
            "fluid.model=rpy",
            "--set",
            "rod.r0=6.32e-3",
            "--set",
            &set,
        ]);
        assert_eq!(code, 0, "{stderr}");
        serde_json::from_str::<serde_json::Value>(stdout.trim()).unwrap()
    };
    let (coarse, fine) = (solve("31"), solve("241"));
    assert_eq!(coarse["errors"]["quadrature_compared_with"], 4.0);
    for key in ["Fp", "Fpbar", "Tp", "eta", "h", "h0", "hbar", "Fpbar_rigid"] {
        let error = coarse["errors"][key].as_f64().unwrap();
        let difference = (coarse[key].as_f64().unwrap() - fine[key].as_f64().unwrap()).abs();
        assert!(
            difference <= error && error <= 10.0 * difference,
            "{key}: stated {error:e}, against N = 241 {difference:e}"
        );
    }
    let (code, stdout, _) = helixbif(&[
        "solve",
        "--omega",
        "0.05",
        "--json",
        "--set",
        "discretization.nodes=7",
    ]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert!(v["errors"].is_null());
    assert!(
        v["errors_missing"]
            .as_str()
            .unwrap()
            .contains("no coarser rung of at least 5 nodes"),
        "{v}"
    );
}

#[test]
fn study_file_equals_the_built_in_default() {
    let study = concat!(env!("CARGO_MANIFEST_DIR"), "/studies/representative.toml");
    let a = helixbif(&[
        "solve",
        study,
        "--omega",
        "0.05",
        "--json",
        "--set",
        "discretization.nodes=20",
    ]);
    let b = helixbif(&[
        "solve",
        "--omega",
        "0.05",
        "--json",
        "--set",
        "discretization.nodes=20",
    ]);
    assert_eq!(a.0, 0);
    assert_eq!(a.1, b.1);
}

#[test]
fn shape_file_has_one_row_per_node_in_si() {
    let path = std::env::temp_dir().join(format!("helixbif-shape-{}.csv", std::process::id()));
    let p = path.to_str().unwrap();
    let (code, _, _) = helixbif(&[
        "solve",
        "--omega",
        "0.0",
        "--set",
        "discretization.nodes=12",
        "--shape",
        p,
    ]);
    assert_eq!(code, 0);
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::remove_file(&path).ok();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "i,x,y,z,theta");
    assert_eq!(lines.len(), 13);
    // On the default RPY line the clamped edge is centred on the clamp point (R, 0, 0) m of the
    // representative helix (docs/model.md section 2): the first two nodes lie on the helix half
    // an edge to either side of it, mirror images in the plane y = 0 through the clamp point
    // and the axis.
    let row = |k: usize| -> Vec<f64> {
        lines[k]
            .split(',')
            .skip(1)
            .take(3)
            .map(|v| v.parse().unwrap())
            .collect()
    };
    let (a, b) = (row(1), row(2));
    for (u, v) in [(a[0], b[0]), (a[1], -b[1]), (a[2], -b[2])] {
        assert!((u - v).abs() < 1e-15, "{a:?} {b:?}");
    }
    assert!((a[0].hypot(a[1]) - 0.0159).abs() < 1e-15, "{a:?}");
    assert!(a[0] > 0.0 && a[0] < 0.0159 && a[2] > 0.0, "{a:?}");
    // On Lighthill's operator the clamp node itself sits there.
    let (code, _, _) = helixbif(&[
        "solve",
        "--omega",
        "0.0",
        "--set",
        "fluid.model=lighthill",
        "--set",
        "discretization.nodes=12",
        "--shape",
        p,
    ]);
    assert_eq!(code, 0);
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::remove_file(&path).ok();
    let first: Vec<f64> = text
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .take(4)
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(first, vec![0.0, 0.0159, 0.0, 0.0]);
}

#[test]
fn bad_input_exits_2_with_one_line_naming_the_field() {
    let cases: &[(&str, &str)] = &[
        ("rod.E=0", "rod.E"),
        ("rod.E=-1", "rod.E"),
        ("rod.r0=0", "rod.r0"),
        ("fluid.mu=0", "fluid.mu"),
        ("shape.l=0", "shape.l"),
        ("shape.lambda=-0.05", "shape.lambda"),
        ("shape.R=0", "shape.R"),
        ("discretization.nodes=4", "discretization.nodes"),
        ("discretization.nodes=-3", "discretization.nodes"),
        ("rod.r0=0.02", "rod.r0"),
        ("shape.lambda=0.003", "shape.lambda"),
        ("rod.E=nan", "rod.E"),
        ("fluid.mu=inf", "fluid.mu"),
        ("rod.Ee=1", "rod.Ee"),
        ("shape.foo=1", "foo"),
        ("discretization.nodes=120", "discretization.nodes"),
        ("newton.tol=0", "newton.tol"),
        // The centred clamp is RPY's; Lighthill's line (the default here) allows "first" only.
        (
            "discretization.clamp_edge=centred",
            "discretization.clamp_edge",
        ),
        ("discretization.clamp_edge=middle", "clamp_edge"),
    ];
    for (set, field) in cases {
        let (code, stdout, stderr) = helixbif(&[
            "solve",
            "--set",
            "fluid.model=lighthill",
            "--omega",
            "0.1",
            "--set",
            set,
        ]);
        assert_eq!(code, 2, "--set {set}: {stderr}");
        assert!(stdout.is_empty());
        assert_eq!(
            stderr.trim_end().lines().count(),
            1,
            "--set {set}: {stderr}"
        );
        assert!(stderr.contains(field), "--set {set}: {stderr}");
        assert!(!stderr.contains("panicked"));
    }
    let (code, _, stderr) =
        helixbif(&["solve", "--set", "fluid.model=lighthill", "--omega", "nan"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("--omega"));
    let (code, _, stderr) = helixbif(&[
        "solve",
        "--set",
        "fluid.model=lighthill",
        "/nonexistent/study.toml",
        "--omega",
        "0.1",
    ]);
    assert_eq!(code, 2);
    assert!(stderr.contains("study file"));
}

#[test]
fn node_count_outside_the_admissible_range_is_refused_with_the_reason() {
    let (code, _, stderr) = helixbif(&[
        "solve",
        "--set",
        "fluid.model=lighthill",
        "--omega",
        "0.1",
        "--set",
        "discretization.nodes=95",
    ]);
    assert_eq!(code, 2);
    assert!(stderr.contains("admissible range 5..=87"), "{stderr}");
    assert!(stderr.contains("positive definite"));
}

#[test]
fn locate_json_has_the_documented_keys() {
    let (code, stdout, stderr) = helixbif(&[
        "locate",
        "--set",
        "fluid.model=lighthill",
        "--single",
        "--json",
        "--set",
        "discretization.nodes=30",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    for key in [
        "omega_b",
        "omegabar_b",
        "kind",
        "im",
        "Fp",
        "Fpbar",
        "hbar",
        "nodes",
    ] {
        assert!(v.get(key).is_some(), "missing key {key}");
    }
    assert_eq!(v["kind"], "hopf");
    assert_eq!(v["nodes"], 30);
    // Below omega_b nothing happens: kind none, exit 0.
    let (code, stdout, _) = helixbif(&[
        "locate",
        "--set",
        "fluid.model=lighthill",
        "--single",
        "--json",
        "--set",
        "discretization.nodes=20",
        "--set",
        "branch.omega_max=0.2",
    ]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(v["kind"], "none");
    assert!(v["omega_b"].is_null());
}

#[test]
fn locate_extrapolate_reports_the_limit_and_its_error() {
    // A ladder in the asymptotic range (the known-order model of docs/model.md section 10 does
    // not hold on rungs as coarse as N = 30).
    let (code, stdout, stderr) = helixbif(&[
        "locate",
        "--set",
        "fluid.model=lighthill",
        "--json",
        "--extrapolate",
        "--nodes",
        "50,60,70",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    let raw: Vec<f64> = v["omega_b"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(raw.len(), 3);
    let limit = v["omega_b_extrapolated"].as_f64().unwrap();
    let error = v["omega_b_error"].as_f64().unwrap();
    // omega_b decreases with N here; the limit lies beyond the finest value, and the bar covers
    // at least the distance to the first-order limit through the two finest rungs.
    assert!(raw[0] > raw[1] && raw[1] > raw[2], "{raw:?}");
    assert!(limit < raw[2], "{limit} vs {raw:?}");
    let (h1, h2) = (1.0 / 59.0, 1.0 / 69.0);
    let first_order = raw[2] - (raw[2] - raw[1]) / (h2 - h1) * h2;
    assert!(
        error >= (limit - first_order).abs() * (1.0 - 1e-9),
        "{error}"
    );
    assert_eq!(v["coefficients"].as_array().unwrap().len(), 2);
    assert!(v["model"].as_str().unwrap().contains("c0 + c1 h + c2 h^2"));
}

#[test]
fn branch_writes_csv_files_and_meta() {
    let dir = std::env::temp_dir().join(format!("helixbif-branch-{}", std::process::id()));
    let d = dir.to_str().unwrap();
    let (code, _, stderr) = helixbif(&[
        "branch",
        "--set",
        "fluid.model=lighthill",
        "--set",
        "discretization.nodes=24",
        "--omega-max",
        "1.0",
        "--out",
        d,
    ]);
    assert_eq!(code, 0, "{stderr}");
    let branch = std::fs::read_to_string(dir.join("branch.csv")).unwrap();
    let header = branch.lines().next().unwrap();
    assert_eq!(
        header,
        "s,omega,omegabar,Fp,Fpbar,Fpbar_rigid,Tp,eta,h,hbar,max_re,n_unstable,stable,probe"
    );
    assert!(branch.lines().count() > 5);
    let events = std::fs::read_to_string(dir.join("events.csv")).unwrap();
    assert!(
        events.lines().nth(1).unwrap().starts_with("hopf,"),
        "{events}"
    );
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("meta.json")).unwrap()).unwrap();
    assert_eq!(meta["nodes"], 24);
    assert!(meta["crate_version"].is_string() && meta["command_line"].is_array());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn simulate_writes_a_time_series_whose_late_statistics_are_the_steady_state() {
    // From the steady state at a stable rate, displaced along its least stable mode by 1e-3 of
    // the reference length: the motion decays back, so the late mean of hbar is the steady
    // hbar from Newton's method (an independent route), to about the displacement, and the
    // spread is of that order too.
    let dir = std::env::temp_dir().join(format!("helixbif-simulate-{}", std::process::id()));
    let d = dir.to_str().unwrap();
    let (code, stdout, stderr) = helixbif(&[
        "simulate",
        "--set",
        "fluid.model=lighthill",
        "--set",
        "discretization.nodes=16",
        "--omega",
        "0.2",
        "--t-end",
        "30",
        "--from-steady",
        "--perturb",
        "1e-3",
        "--transient",
        "20",
        "--shape-every",
        "10",
        "--out",
        d,
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert!(v["steps"].as_u64().unwrap() > 10);
    let series = std::fs::read_to_string(dir.join("timeseries.csv")).unwrap();
    assert_eq!(
        series.lines().next().unwrap(),
        "t,omega,hbar,Fp,Fpbar,Tp,eta"
    );
    let last: Vec<f64> = series
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|x| x.parse().unwrap())
        .collect();
    assert!((last[0] - 30.0).abs() < 1e-6 && (last[1] - 0.2).abs() < 1e-12);
    let (code, steady, stderr) = helixbif(&[
        "solve",
        "--set",
        "fluid.model=lighthill",
        "--set",
        "discretization.nodes=16",
        "--omega",
        "0.2",
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let steady: serde_json::Value = serde_json::from_str(steady.trim()).unwrap();
    let (mean, std) = (
        v["hbar_mean"].as_f64().unwrap(),
        v["hbar_std"].as_f64().unwrap(),
    );
    let hbar = steady["hbar"].as_f64().unwrap();
    assert!(
        (mean - hbar).abs() < 1e-3,
        "late mean {mean} against the steady {hbar}"
    );
    assert!(std < 1e-3, "late spread {std}");
    let fpbar = steady["Fpbar"].as_f64().unwrap();
    let fp_mean = v["Fpbar_mean"].as_f64().unwrap();
    assert!(
        (fp_mean / fpbar - 1.0).abs() < 1e-2,
        "{fp_mean} against {fpbar}"
    );
    assert!(dir.join("shapes.csv").exists() && dir.join("timeseries_hbar.svg").exists());
    std::fs::remove_dir_all(&dir).ok();
    // Bad input.
    let (code, _, stderr) = helixbif(&[
        "simulate",
        "--set",
        "fluid.model=lighthill",
        "--omega",
        "0.2",
        "--t-end",
        "-1",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("--t-end"));
    let (code, _, stderr) = helixbif(&[
        "bisect",
        "--set",
        "fluid.model=lighthill",
        "--lo",
        "0.5",
        "--hi",
        "0.4",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("--lo"));
}

#[test]
fn orbits_follows_the_unstable_orbits_below_a_subcritical_hopf_point() {
    // N = 20: the representative helix's Hopf point is subcritical (l1 > 0), so the orbits born
    // there are unstable and exist below omega_b, their period that of the critical mode to
    // O(r^2), their amplitude growing along the branch.
    let dir = std::env::temp_dir().join(format!("helixbif-orbits-{}", std::process::id()));
    let d = dir.to_str().unwrap();
    let (code, stdout, stderr) = helixbif(&[
        "orbits",
        "--set",
        "fluid.model=lighthill",
        "--set",
        "discretization.nodes=20",
        "--max-orbits",
        "4",
        "--out",
        d,
        "--json",
    ]);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(v["criticality"], "subcritical");
    assert_eq!(v["orbits"], 4);
    let omega_hopf = v["omega_hopf"].as_f64().unwrap();
    let period_hopf = 2.0 * std::f64::consts::PI / v["frequency"].as_f64().unwrap();
    let mut reader = csv::Reader::from_path(dir.join("orbits.csv")).unwrap();
    let header = reader.headers().unwrap().clone();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let rows: Vec<csv::StringRecord> = reader.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), 4);
    let num = |r: &csv::StringRecord, name: &str| r[col(name)].parse::<f64>().unwrap();
    for pair in rows.windows(2) {
        assert!(num(&pair[1], "amplitude") > num(&pair[0], "amplitude"));
        assert!(num(&pair[1], "omega") < num(&pair[0], "omega"));
    }
    for r in &rows {
        assert_eq!(&r[col("stable")], "false");
        assert!(num(r, "max_multiplier") > 1.0);
        // The discrete Hopf point lies a little above the exact one (BDF2's damping), and
        // BDF2's period is long by about (2 pi / 100)^2 / 3 = 1.3e-3 at 100 steps: every orbit
        // is within 1e-3 of the Hopf rate and 2e-3 of its period.
        assert!((num(r, "omega") / omega_hopf - 1.0).abs() < 1e-3);
        assert!((num(r, "period") / period_hopf - 1.0).abs() < 2e-3);
    }
    for svg in ["amplitude.svg", "hbar.svg", "Fpbar.svg"] {
        let text = std::fs::read_to_string(dir.join(svg)).unwrap();
        roxmltree::Document::parse(&text).unwrap();
    }
    assert!(dir.join("events.csv").exists() && dir.join("meta.json").exists());
    std::fs::remove_dir_all(&dir).ok();
    // Bad input names the flag.
    let (code, _, stderr) = helixbif(&["orbits", "--set", "fluid.model=lighthill", "--steps", "3"]);
    assert_eq!(code, 2);
    assert!(
        stderr.contains("--steps") && stderr.contains("[8, 100000]"),
        "{stderr}"
    );
}

#[test]
fn orbits_resumed_from_its_checkpoint_gives_the_uninterrupted_branch() {
    let base = std::env::temp_dir().join(format!("helixbif-orbits-resume-{}", std::process::id()));
    let (whole, part) = (base.join("whole"), base.join("part"));
    // The branch of the 16-node rod on Lighthill's operator, `orbits` of them, into `dir`.
    let arguments = |dir: &std::path::Path, orbits: &'static str| -> Vec<String> {
        let dir = dir.to_str().unwrap().to_string();
        [
            "orbits",
            "--set",
            "fluid.model=lighthill",
            "--set",
            "discretization.nodes=16",
            "--max-orbits",
            orbits,
            "--out",
        ]
        .iter()
        .map(|a| a.to_string())
        .chain([dir])
        .collect()
    };
    let run = |dir: &std::path::Path, orbits: &'static str, resume: bool| {
        let mut args = arguments(dir, orbits);
        args.push("--json".into());
        if resume {
            args.push("--resume".into());
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (code, stdout, stderr) = helixbif(&args);
        assert_eq!(code, 0, "{stderr}");
        serde_json::from_str::<serde_json::Value>(stdout.trim()).unwrap()
    };
    run(&whole, "5", false);
    run(&part, "3", false);
    let resumed = run(&part, "5", true);
    assert_eq!(resumed["resumed_at"], 3);
    assert_eq!(resumed["orbits"], 5);
    // A checkpoint of another rod (or of other steps per period) is refused, naming --resume
    // and the field that differs, and leaves the branch as it was; more orbits may be asked of
    // the same one (above).
    let table = std::fs::read_to_string(part.join("orbits.csv")).unwrap();
    for (other, field) in [
        (
            ["--set", "rod.E=1.3e6"],
            "`physical.rod.E` is 1300000.0 here and 1255000.0",
        ),
        (
            ["--steps", "60"],
            "`settings.shooting.flow.steps` is 60 here and 100",
        ),
    ] {
        let mut args = arguments(&part, "7");
        args.extend(["--resume", other[0], other[1]].map(String::from));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (code, _, stderr) = helixbif(&args);
        assert_eq!(code, 2, "{stderr}");
        assert!(
            stderr.contains("--resume") && stderr.contains("other options"),
            "{stderr}"
        );
        assert!(stderr.contains(field), "{stderr}");
        assert_eq!(
            std::fs::read_to_string(part.join("orbits.csv")).unwrap(),
            table
        );
    }
    let omegas = |dir: &std::path::Path| -> Vec<(usize, f64)> {
        let mut reader = csv::Reader::from_path(dir.join("orbits.csv")).unwrap();
        reader
            .records()
            .map(|r| {
                let r = r.unwrap();
                (r[0].parse().unwrap(), r[1].parse().unwrap())
            })
            .collect()
    };
    let (a, b) = (omegas(&whole), omegas(&part));
    assert_eq!(a.len(), 5);
    assert_eq!(
        a.iter().map(|r| r.0).collect::<Vec<_>>(),
        vec![0, 1, 2, 3, 4]
    );
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.0, y.0);
        assert!((x.1 - y.1).abs() <= 1e-12 * x.1, "{x:?} {y:?}");
    }
    std::fs::remove_dir_all(&base).ok();
}
