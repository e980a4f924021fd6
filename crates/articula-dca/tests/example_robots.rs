//! Every example-robot-data URDF articula loads, fixed and floating base: DCA, ABA and CRBA
//! against the double-double reference (`articula_testkit::ReferenceModel`), which carries ~32
//! digits and so is exact as far as any `f64` solver can tell.
//!
//! Skipped (with a message) when example-robot-data is not installed: `.ci/run` installs it in
//! `target/peers-venv`; `ROBOTS=/path/to/robots` points elsewhere.

use articula_dca::{forward_dynamics, Data, Method, State};
use articula_model::{LoadOptions, Model};
use articula_testkit::{example_robots_dir, rel_error, urdfs_under, Dd, ReferenceModel};

/// The bound on `max |q̈ − q̈_ref| / max |q̈_ref|`, for every method on every robot but one.
const TOL: f64 = 1e-10;

/// DCA's bound on icub, the hardest: its 1.3 kg point-mass head sits 0.4 mm from its neck
/// axis and 0.5 m from the floating base, and DCA's leaf clusters run about the base's origin
/// (`cluster.rs`): measured 6.8e-10 floating and 1.7e-10 fixed, where ABA, about each body's
/// own origin, is 4.7e-11 and 1.2e-11.
const TOL_DCA_ICUB: f64 = 1e-9;

#[test]
fn example_robots_match_the_reference() {
    let Some(dir) = example_robots_dir() else {
        eprintln!(
            "skipped: example-robot-data not in target/peers-venv (pip install example-robot-data)"
        );
        return;
    };
    let urdfs = urdfs_under(&dir);
    assert!(
        urdfs.len() >= 60,
        "{} URDFs under {}",
        urdfs.len(),
        dir.display()
    );
    let mut checked = 0;
    let mut failures = Vec::new();
    for path in &urdfs {
        for floating_base in [false, true] {
            let options = LoadOptions::default().with_floating_base(floating_base);
            let Ok(model) = Model::from_urdf_file(path, &options) else {
                continue;
            };
            if model.nv == 0 {
                continue;
            }
            let name = path.file_stem().unwrap().to_string_lossy();
            let worst = worst_error(&model);
            eprintln!("{name} floating={floating_base}: {worst:?}");
            checked += 1;
            for (method, e) in worst {
                let tol = if name == "icub" && method == Method::Dca {
                    TOL_DCA_ICUB
                } else {
                    TOL
                };
                if e.is_nan() || e > tol {
                    failures.push(format!(
                        "{name} floating={floating_base} {method:?}: {e:.1e}"
                    ));
                }
            }
        }
    }
    assert!(checked >= 120, "only {checked} robot-bases loaded");
    assert!(
        failures.is_empty(),
        "above {TOL:e} (icub DCA {TOL_DCA_ICUB:e}): {failures:#?}"
    );
}

/// The worst relative error of each method over three random states (external forces on one).
fn worst_error(model: &Model) -> [(Method, f64); 3] {
    let reference = ReferenceModel::new(model).expect("the reference takes every loaded joint");
    let mut data = Data::new(model);
    let mut worst = [(Method::Dca, 0.0), (Method::Aba, 0.0), (Method::Crba, 0.0)];
    for seed in 1..=3 {
        let mut s = State::random(model, seed, 1.0);
        if seed == 3 {
            s.randomize_forces(seed, 1.0);
        }
        let exact: Vec<f64> = reference
            .aba::<Dd>(&s.q, &s.qd, &s.tau, &s.f_ext)
            .into_iter()
            .map(Dd::to_f64)
            .collect();
        for (method, w) in worst.iter_mut() {
            let qdd = forward_dynamics(model, &mut data, &s, *method).unwrap();
            *w = f64::max(*w, rel_error(qdd, &exact));
        }
    }
    worst
}
