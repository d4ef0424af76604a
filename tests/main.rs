//! The integration tests: one test crate whose modules are the files of this folder (Cargo's
//! `autotests` is off and this file is the one `[[test]]` target), so that the library's generic
//! code is compiled and linked once for all of them and the test threads share the long tests
//! of every file. A test is named by its file: `cargo test --release --test integration
//! boundary::` runs the tests of `tests/boundary.rs`.

mod common;
mod svg;

mod bifurcation;
mod boundary;
mod cantilever;
mod cli;
mod cli_contract;
mod continuation_engine;
mod criticality;
mod dynamics;
mod edges;
mod event_logic;
mod fluid;
mod krylov_stability;
mod mobility_form;
mod newton;
mod periodic_orbits;
mod plot;
mod refine;
mod rod_derivatives;
mod rod_orbits;
mod rpy;
mod slurm;
mod steady_jacobian;
mod steady_physics;
mod studies;
mod two_parameter;

/// Every `.rs` file of this folder is a module of this crate: with `autotests` off, a file left
/// out of the list above would never run.
#[test]
fn every_file_of_the_tests_folder_is_a_module_of_this_crate() {
    let folder = concat!(env!("CARGO_MANIFEST_DIR"), "/tests");
    let this = std::fs::read_to_string(format!("{folder}/main.rs")).unwrap();
    let declared: Vec<&str> = this
        .lines()
        .filter_map(|l| l.strip_prefix("mod ")?.strip_suffix(';'))
        .collect();
    let mut files = 0;
    for entry in std::fs::read_dir(folder).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        if let Some(module) = name.strip_suffix(".rs").filter(|&m| m != "main") {
            files += 1;
            assert!(
                declared.contains(&module),
                "tests/{name} is not a module of tests/main.rs"
            );
        }
    }
    assert_eq!(files + 2, declared.len(), "{declared:?}");
}
