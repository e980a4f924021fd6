//! A 1,000-link rope (20 m) swinging under adaptive dynamics: 100 of its 1,000 joints
//! simulated, chosen again every 10 steps where the accelerations matter most; the rest move
//! rigidly. The predicted error is the acceleration metric left out, `Σ q̈²` of the skipped
//! joints, against exact dynamics.
//! `cargo run --release --example rope`
use articula::prelude::*;
use std::time::Instant;

/// `n` segments of 2 cm and 2 g hanging from a fixed anchor, hinges alternating about x and y.
fn rope(n: usize) -> String {
    let mut urdf = String::from(r#"<robot name="rope"><link name="s0"/>"#);
    for i in 1..=n {
        let (parent, axis) = (i - 1, if i % 2 == 0 { "1 0 0" } else { "0 1 0" });
        urdf += &format!(
            r#"<link name="s{i}"><inertial><origin xyz="0 0 -0.01"/><mass value="0.002"/>
            <inertia ixx="7e-8" iyy="7e-8" izz="1e-9" ixy="0" ixz="0" iyz="0"/></inertial></link>
            <joint name="j{i}" type="continuous"><parent link="s{parent}"/><child link="s{i}"/>
            <origin xyz="0 0 {}"/><axis xyz="{axis}"/></joint>"#,
            if i == 1 { 0.0 } else { -0.02 }
        );
    }
    urdf + "</robot>"
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let model = Model::from_urdf_str(&rope(1000), &LoadOptions::default())?;
    let mut state = State::neutral(&model);
    state.q[0] = 0.3; // released straight, 0.3 rad from hanging
    let dt = 2e-4;
    // Exact DCA for reference: the time of one step.
    let (mut data, mut exact, t) = (Data::new(&model), state.clone(), Instant::now());
    for _ in 0..50 {
        step(
            &model,
            &mut data,
            &mut exact,
            Method::Dca,
            Integrator::SemiImplicitEuler,
            dt,
        )?;
    }
    println!(
        "exact DCA: {:.1} µs/step over all 1000 joints",
        t.elapsed().as_secs_f64() * 1e6 / 50.0
    );
    let settings = Settings {
        budget: Some(100),
        reselect_every: 10,
        ..Settings::default()
    };
    let mut adaptive = Adaptive::new(&model, settings);
    let mut t = Instant::now();
    for k in 1..=2500 {
        let report = adaptive.step(&model, &mut state, dt)?;
        if k % 250 == 0 {
            let (us, total) = (
                t.elapsed().as_secs_f64() * 4e3,
                adaptive.selection().total_metric,
            );
            println!("t = {:.2} s: {} active joints, predicted error {:.2e} ({:.1}% of the metric), {us:.1} µs/step",
                k as f64 * dt, report.active_dofs, report.predicted_error, 100.0 * report.predicted_error / total);
            t = Instant::now();
        }
    }
    Ok(())
}
