//! The `urdf-rs` interop (feature `urdf-rs`): `Model::from_urdf_robot` on a robot read by the
//! urdf-rs crate gives the same model as the built-in reader, on every bundled model, with a
//! fixed and a floating base, and under every inertia policy.

#![cfg(feature = "urdf-rs")]

mod common;

use articula_model::{urdf_rs, InertiaPolicy, LoadOptions, Model};

fn assert_same(a: &Model, b: &Model, what: &str) {
    assert_eq!(a.name, b.name, "{what}: name");
    assert_eq!(a.bodies, b.bodies, "{what}: bodies");
    assert_eq!(a.ground_links, b.ground_links, "{what}: ground links");
    assert_eq!(a.ground_mass, b.ground_mass, "{what}: ground mass");
    assert_eq!((a.nq, a.nv), (b.nq, b.nv), "{what}: coordinates");
    assert_eq!(a.assembly, b.assembly, "{what}: assembly tree");
    assert_eq!(a.warnings, b.warnings, "{what}: warnings");
    assert_eq!(a.locked, b.locked, "{what}: locked joints");
    assert_eq!(
        (a.urdf_links, a.urdf_joints),
        (b.urdf_links, b.urdf_joints),
        "{what}: URDF counts"
    );
}

#[test]
fn every_bundled_model_is_the_same_through_urdf_rs() {
    let paths = common::bundled_models();
    assert!(paths.len() >= 8, "{paths:?}");
    for path in paths {
        let robot = urdf_rs::read_file(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
        for floating_base in [false, true] {
            for policy in [InertiaPolicy::Accept, InertiaPolicy::Strict] {
                let options = LoadOptions::default()
                    .with_floating_base(floating_base)
                    .with_inertia(policy);
                let builtin = Model::from_urdf_file(&path, &options).unwrap();
                let via = Model::from_urdf_robot(&robot, &options).unwrap();
                assert_same(
                    &builtin,
                    &via,
                    &format!("{} floating={floating_base} {policy:?}", path.display()),
                );
            }
        }
    }
}

#[test]
fn policies_apply_to_urdf_rs_robots() {
    // A body breaking the triangle inequality and a massless finger: the same warnings,
    // refusals and locked joints either way.
    let text = common::robot(
        &[
            common::link("base", 1.0),
            common::link_raw("arm", "1", "0.01", "0.01", "0.05"),
            common::bare_link("finger"),
            common::joint("shoulder", "revolute", "base", "arm"),
            common::joint("f", "revolute", "arm", "finger"),
        ]
        .concat(),
    );
    let robot = urdf_rs::read_from_string(&text).unwrap();
    for policy in [
        InertiaPolicy::Accept,
        InertiaPolicy::Strict,
        InertiaPolicy::Repair,
    ] {
        let options = LoadOptions::default().with_inertia(policy);
        let builtin = Model::from_urdf_str(&text, &options);
        let via = Model::from_urdf_robot(&robot, &options);
        match (builtin, via) {
            (Ok(a), Ok(b)) => {
                assert_same(&a, &b, &format!("{policy:?}"));
                assert_eq!(a.locked_joints(), vec!["f"]);
            }
            (Err(a), Err(b)) => assert_eq!(a, b),
            (a, b) => panic!("{policy:?}: {:?} vs {:?}", a.err(), b.err()),
        }
    }
}
