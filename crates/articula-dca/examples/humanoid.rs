//! A URDF humanoid with a floating base: forward dynamics, inverse dynamics (τ comes back),
//! the mass matrix, the centre of mass, and a hand's pose and Jacobian.
//!
//! ```text
//! cargo run -p articula-dca --example humanoid [-- ROBOT.urdf [LINK]]
//! ```

use articula_dca::{
    forward_dynamics, forward_kinematics, inverse_dynamics, mass_matrix, Data, Method,
    ReferenceFrame, State,
};
use articula_model::{LoadOptions, Model};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .unwrap_or(concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/humanoid.urdf").into());
    let hand = args.next().unwrap_or("l_hand".into());
    let model = Model::from_urdf_file(&path, &LoadOptions::default().with_floating_base(true))?;
    let (nv, mass) = (model.nv, model.moving_mass());
    println!(
        "{}: {} bodies, nq = {}, nv = {nv}, {mass:.2} kg",
        model.name,
        model.bodies.len(),
        model.nq
    );

    // A random pose, velocities and joint torques (seeded), gravity along −z.
    let mut data = Data::new(&model);
    let state = State::random(&model, 1, 5.0);

    // Forward dynamics, then inverse dynamics of its accelerations: the torques come back.
    let qdd = forward_dynamics(&model, &mut data, &state, Method::Dca)?.to_vec();
    let tau = inverse_dynamics(&model, &mut data, &state.q, &state.qd, &qdd, &state.f_ext)?;
    let err = tau
        .iter()
        .zip(&state.tau)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    println!("q̈ of the base [ω̇; v̇]: {:.3?}", &qdd[..6]);
    println!("inverse dynamics of that q̈ gives τ back to {err:.1e} N·m");

    // The mass matrix: the base's linear rows carry the whole mass.
    let m = mass_matrix(&model, &mut data, &state.q)?;
    let diag: Vec<f64> = (0..6).map(|i| m[i * nv + i]).collect();
    println!("mass matrix {nv}×{nv}, base block diagonal: {diag:.3?} (total mass {mass:.3})");

    // Centre of mass, and a hand's pose, Jacobian and velocity.
    forward_kinematics(&model, &state.q, &state.qd, &mut data)?;
    println!("centre of mass (world): {:.4}", data.center_of_mass());
    let link = model.find_link(&hand).ok_or(format!("no link {hand}"))?;
    let (rotation, position) = data.link_pose(&link)?;
    println!("{hand} at {position:.4}, x axis {:.4}", rotation.x_axis);
    let j = data.link_jacobian(&model, &link, ReferenceFrame::LocalWorldAligned)?;
    let v: Vec<f64> = (0..6)
        .map(|r| (0..nv).map(|c| j[r * nv + c] * state.qd[c]).sum())
        .collect();
    let moving = (0..nv)
        .filter(|&c| (0..6).any(|r| j[r * nv + c] != 0.0))
        .count();
    println!("{hand} Jacobian: 6×{nv}, {moving} columns move it; [ω; v] = J q̇ = {v:.3?}");
    Ok(())
}
