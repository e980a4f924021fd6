//! The per-body calls of a view-dependent scene (`articula-view`'s crowd) on the floating
//! humanoid, for callgrind: `cargo run --release -p articula-adaptive --example humanoid_cost --
//! MODE ROUNDS` with MODE one of `metrics` (`node_metrics` on the state), `active`
//! (`set_active` alternating between two hybrid bodies, so every call locks joints) or `step`
//! (a hybrid step with half the joints active). Each round also advances the state by one
//! hybrid step, as the scene does; run with two round counts and diff the totals. Prints the
//! median time per call over batches of 100.

use articula_adaptive::{Adaptive, Settings};
use articula_dca::State;
use articula_model::{LoadOptions, Model};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mode = std::env::args().nth(1).unwrap_or_else(|| "step".into());
    let rounds: usize = std::env::args()
        .nth(2)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1000);
    let path = format!("{}/../../models/humanoid.urdf", env!("CARGO_MANIFEST_DIR"));
    let model = Model::from_urdf_file(&path, &LoadOptions::default().with_floating_base(true))?;
    let mut s = State::random(&model, 7, 0.0);
    s.f_ext.clear();
    let mut ad = Adaptive::new(
        &model,
        Settings {
            reselect_every: u64::MAX,
            ..Settings::default()
        },
    );
    let mut out = vec![0.0; model.assembly.nodes.len()];
    let nb = model.bodies.len();
    ad.set_active(&model, &mut s, |j| j % 2 == 0)?;
    ad.step(&model, &mut s, 1e-4)?;
    let mut us = Vec::new();
    let mut done = 0;
    while done < rounds {
        let batch = 100.min(rounds - done);
        let mut t = 0.0;
        for r in 0..batch {
            let t0 = Instant::now();
            match mode.as_str() {
                "metrics" => ad.node_metrics(&model, &s.q, &s.qd, &s.tau, &s.f_ext, &mut out)?,
                "active" => {
                    let odd = (done + r) % 2 == 1;
                    ad.set_active(&model, &mut s, |j| (j % 2 == 0) != (odd && j * 3 < nb))?;
                }
                _ => {
                    ad.step(&model, &mut s, 1e-4)?;
                }
            }
            t += t0.elapsed().as_secs_f64();
            if mode != "step" {
                ad.step(&model, &mut s, 1e-4)?;
            }
        }
        us.push(t * 1e6 / batch as f64);
        done += batch;
    }
    us.sort_by(f64::total_cmp);
    println!(
        "humanoid {mode}: {:.3} µs per call (median of {} batches; {} active DOFs)",
        us[us.len() / 2],
        us.len(),
        ad.active_dofs(&model)
    );
    Ok(())
}
