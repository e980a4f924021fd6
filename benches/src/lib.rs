//! Shared fixtures of the benchmarks: procedural models of any size.
//!
//! ```
//! let model = articula_benches::chain(1000);
//! assert_eq!((model.bodies.len(), model.nv), (1000, 1000));
//! assert_eq!(model.assembly.max_handles(), 2);
//! ```

use articula_model::{LoadOptions, Model};

pub mod growth;

/// A planar revolute pendulum chain of `n` links (0.1 m, 0.1 kg rods hanging along −z), the
/// same bodies as the bundled `models/chainN.urdf`, for sizes that are not bundled.
pub fn chain_urdf(n: usize) -> String {
    let mut s = String::from("<robot name=\"chain\"><link name=\"base\"><inertial><mass value=\"1\"/><inertia ixx=\"0.01\" iyy=\"0.01\" izz=\"0.01\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n");
    for i in 1..=n {
        let parent = if i == 1 {
            "base".to_string()
        } else {
            format!("link{}", i - 1)
        };
        let z = if i == 1 { -0.05 } else { -0.1 };
        s += &format!(
            "<link name=\"link{i}\"><inertial><origin xyz=\"0 0 -0.05\"/><mass value=\"0.1\"/><inertia ixx=\"8.5833e-5\" iyy=\"8.5833e-5\" izz=\"5e-6\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n<joint name=\"joint{i}\" type=\"revolute\"><parent link=\"{parent}\"/><child link=\"link{i}\"/><origin xyz=\"0 0 {z}\"/><axis xyz=\"0 1 0\"/><limit lower=\"-3.14\" upper=\"3.14\" effort=\"100\" velocity=\"10\"/></joint>\n"
        );
    }
    s + "</robot>"
}

/// Loads a bundled model by file stem (`humanoid`, `chain300`, ...).
pub fn bundled(name: &str) -> Model {
    bundled_with(name, false)
}

/// Loads a bundled model by file stem, its root welded to the world or (`floating_base`) free.
pub fn bundled_with(name: &str, floating_base: bool) -> Model {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../models/{name}.urdf"));
    Model::from_urdf_file(
        path,
        &LoadOptions::default().with_floating_base(floating_base),
    )
    .expect("bundled model loads")
}

/// A chain of `n` links.
pub fn chain(n: usize) -> Model {
    Model::from_urdf_str(&chain_urdf(n), &LoadOptions::default()).expect("chain loads")
}

/// The adaptive seeds' state (`cargo bench -p articula-adaptive --bench adaptive`): a random
/// configuration (seed 42) at rest with `forces` constant external forces on evenly spread
/// bodies, each a point force at its body's origin.
pub fn seeded_state(model: &Model, forces: usize) -> articula_dca::State {
    let mut s = articula_dca::State::random(model, 42, 0.0);
    s.qd.fill(0.0);
    let mut data = articula_dca::Data::new(model);
    articula_dca::forward_kinematics(model, &s.q, &s.qd, &mut data);
    let n = model.bodies.len();
    for k in 0..forces.min(n) {
        let body = (k * n) / forces.min(n);
        let dir = glam::DVec3::new(1.0, (k as f64).sin(), (k as f64).cos());
        s.f_ext[body] = data.point_force(body, glam::DVec3::ZERO, dir);
    }
    s
}

/// The non-zero wrenches of a dense external-force array as `(body, wrench)` pairs: how the
/// adaptive runs take their forces (`Adaptive::step_with_forces`: no O(n) scan of a dense
/// array per step).
pub fn force_list(
    f_ext: &[articula_spatial::SpatialForce],
) -> Vec<(usize, articula_spatial::SpatialForce)> {
    f_ext
        .iter()
        .enumerate()
        .filter(|(_, f)| **f != articula_spatial::SpatialForce::ZERO)
        .map(|(i, f)| (i, *f))
        .collect()
}
