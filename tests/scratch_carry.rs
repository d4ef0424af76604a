use helixbif::analysis::solve::solve_at;
use helixbif::engine::newton::NewtonSettings;
use helixbif::model::Model;
use helixbif::model::rod::frame::rechart;
use helixbif::model::steady::Steady;
use helixbif::problem::carry::carry_config;
use helixbif::problem::steady;
use helixbif::study::Study;
use std::path::Path;

#[test]
#[ignore]
fn scratch() {
    let study_path = std::env::var("STUDY").unwrap_or("studies/fig4d_phase.toml".into());
    let w: f64 = std::env::var("W")
        .unwrap_or("423.8".into())
        .parse()
        .unwrap();
    let sets: Vec<String> = vec![
        "fluid.model=rpy".into(),
        "discretization.per_turn=15".into(),
    ];
    let study = Study::from_path(Some(Path::new(&study_path)), &sets).unwrap();
    let mut p = study.physical();
    let coarse = Model::new(&p).unwrap();
    p.discretization.nodes = 2 * coarse.nodes() - 1;
    p.discretization.per_turn = None;
    let fine = Model::new(&p).unwrap();
    println!("N = {} -> {}", coarse.nodes(), fine.nodes());
    let s = solve_at(&coarse, w, &NewtonSettings::default()).unwrap();
    let cfg = rechart(&s.state.config, &s.state.chart, &coarse.chart);
    let u = carry_config(&coarse, &cfg, &fine);
    let direct = solve_at(&fine, w, &NewtonSettings::default()).unwrap();
    let dcfg = rechart(&direct.state.config, &direct.state.chart, &fine.chart);
    let ud = Steady::new(&fine, 0.0).free_vector(&dcfg);
    let st = Steady::new(&fine, w);
    let n0 = |v: Vec<f64>| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let r = st.residual(&u).unwrap();
    let fp = 3 * (fine.nodes() - 2);
    let blocks: Vec<String> = r[..fp]
        .chunks(3)
        .enumerate()
        .step_by(10)
        .map(|(i, c)| {
            format!(
                "{}:{:.1e}",
                i + 2,
                (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
            )
        })
        .collect();
    println!("position rows: {}", blocks.join(" "));
    let tw: Vec<String> = r[fp..]
        .iter()
        .enumerate()
        .step_by(10)
        .map(|(i, v)| format!("{}:{:.1e}", i + 1, v.abs()))
        .collect();
    println!("twist rows: {}", tw.join(" "));
    let cc = Steady::new(&fine, 0.0).config(&u);
    println!("carried residual {:.3e}", n0(st.residual(&u).unwrap()));
    let r = steady::solve(
        &fine,
        w,
        fine.weight,
        &cc,
        &fine.chart,
        &NewtonSettings::default(),
    );
    println!(
        "fully carried newton: {:?}",
        r.map(|s| s.report.history)
            .map_err(|e| e.to_string().chars().take(60).collect::<String>())
    );
    let us = helixbif::problem::twist::slave_twist_in(&fine, &fine.chart, &u).unwrap();
    println!("slaved residual {:.3e}", n0(st.residual(&us).unwrap()));
    let r = steady::solve(
        &fine,
        w,
        fine.weight,
        &Steady::new(&fine, 0.0).config(&us),
        &fine.chart,
        &NewtonSettings::default(),
    );
    println!(
        "slaved newton: {:?}",
        r.map(|s| s.report.history)
            .map_err(|e| e.to_string().chars().take(60).collect::<String>())
    );
    let mut mixed = u.clone();
    mixed[..fp].copy_from_slice(&ud[..fp]);
    let n = |v: Vec<f64>| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    println!(
        "direct x, carried theta: residual {:.3e}",
        n(st.residual(&mixed).unwrap())
    );
    let mc = Steady::new(&fine, 0.0).config(&mixed);
    let r = steady::solve(
        &fine,
        w,
        fine.weight,
        &mc,
        &fine.chart,
        &NewtonSettings::default(),
    );
    println!(
        "  newton: {:?}",
        r.map(|s| s.report.history.len()).map_err(|e| e
            .to_string()
            .chars()
            .take(60)
            .collect::<String>())
    );
    let mut mixed = ud.clone();
    mixed[..fp].copy_from_slice(&u[..fp]);
    let mc = Steady::new(&fine, 0.0).config(&mixed);
    let r = steady::solve(
        &fine,
        w,
        fine.weight,
        &mc,
        &fine.chart,
        &NewtonSettings::default(),
    );
    println!(
        "carried x, direct theta newton: {:?}",
        r.map(|s| s.report.history.len()).map_err(|e| e
            .to_string()
            .chars()
            .take(60)
            .collect::<String>())
    );
}
