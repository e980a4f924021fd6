//! The cost of an adaptive step with re-selection through the caches, on a chain of `n` links:
//! `cargo run --release -p articula-adaptive --example reselect_cost -- N BUDGET PERIOD STEPS [dca]`
//! (defaults 300 50 1 2000; `dca`: exact DCA steps of the same run instead, for the ratio;
//! a sixth argument F puts F constant external forces on evenly spread bodies, as the
//! benches' seeds table does; a seventh, `seeded`, applies each at its body's origin as the
//! table's `seeded_state` does). The chain starts crumpled (random angles ±1.2 rad, seed 42) at
//! rest under gravity; the first step (whole-body re-selection building every cache) is not
//! timed. Prints the median over batches of 100 steps and the nodes the last step visited.
//! Also a fixed workload for callgrind (run it with two step counts and diff).

use articula_adaptive::{Adaptive, Settings};
use articula_dca::State;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let arg = |i: usize, d: u64| -> u64 {
        std::env::args()
            .nth(i)
            .and_then(|a| a.parse().ok())
            .unwrap_or(d)
    };
    let (n, budget, period, steps) = (arg(1, 300), arg(2, 50), arg(3, 1), arg(4, 2000));
    let model = articula_benches::chain(n as usize);
    let mut s = State::random(&model, 42, 0.0);
    s.qd.fill(0.0);
    s.f_ext.clear();
    let nf = arg(6, 0) as usize;
    // `seeded` (seventh argument): each force at its body's origin, as the benches'
    // `seeded_state` puts it; otherwise at the computation frame's origin.
    let seeded = std::env::args().nth(7).as_deref() == Some("seeded");
    let kin = {
        let mut d = articula_dca::Data::new(&model);
        articula_dca::forward_kinematics(&model, &s.q, &s.qd, &mut d);
        d
    };
    let forces: Vec<(usize, articula_spatial::SpatialForce)> = (0..nf.min(n as usize))
        .map(|k| {
            let body = k * n as usize / nf.min(n as usize);
            let dir = glam::DVec3::new(1.0, (k as f64).sin(), (k as f64).cos());
            let f = if seeded {
                kin.point_force(body, glam::DVec3::ZERO, dir)
            } else {
                articula_spatial::SpatialForce::new(glam::DVec3::ZERO, dir)
            };
            (body, f)
        })
        .collect();
    if std::env::args().nth(5).as_deref() == Some("dca") {
        let mut data = articula_dca::Data::new(&model);
        let mut us = Vec::new();
        let mut done = 0;
        while done < steps {
            let batch = 100.min(steps - done);
            let t = Instant::now();
            for _ in 0..batch {
                articula_dca::step(
                    &model,
                    &mut data,
                    &mut s,
                    articula_dca::Method::Dca,
                    articula_dca::Integrator::SemiImplicitEuler,
                    1e-4,
                )?;
            }
            us.push(t.elapsed().as_secs_f64() * 1e6 / batch as f64);
            done += batch;
        }
        us.sort_by(f64::total_cmp);
        println!(
            "chain{n} DCA: {:.3} µs per step (median of {} batches)",
            us[us.len() / 2],
            us.len()
        );
        return Ok(());
    }
    let mut ad = Adaptive::new(
        &model,
        Settings {
            budget: Some(budget as usize),
            reselect_every: period,
            ..Settings::default()
        },
    );
    let t = Instant::now();
    let first = ad.step(&model, &mut s, 1e-4)?;
    let first_ms = t.elapsed().as_secs_f64() * 1e3;
    let mut us = Vec::new();
    let mut touched = 0;
    let mut done = 0;
    while done < steps {
        let batch = 100.min(steps - done);
        let t = Instant::now();
        for _ in 0..batch {
            touched = ad
                .step_with_forces(&model, &mut s, 1e-4, &forces)?
                .nodes_touched;
        }
        us.push(t.elapsed().as_secs_f64() * 1e6 / batch as f64);
        done += batch;
    }
    us.sort_by(f64::total_cmp);
    println!(
        "chain{n} budget {budget} re-select every {period}: {:.3} µs per step (median of {} batches; \
         first step {first_ms:.1} ms, {} nodes; last step {touched} nodes, {} active DOFs)",
        us[us.len() / 2],
        us.len(),
        first.nodes_touched,
        first.active_dofs
    );
    Ok(())
}
