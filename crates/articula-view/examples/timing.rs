//! Where a scene's time goes: `cargo run --release -p articula-view --example timing --
//! SCENE.json STEPS` prints the mean time of re-selection steps and of the steps between them,
//! the time of one classification and of `node_metrics` on every body, and of one exact DCA step
//! of every body on the final states.

use std::time::Instant;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene = articula_view::load_scene(&args[1]).unwrap();
    let steps: u64 = args[2].parse().unwrap();
    let mut sim = articula_view::SceneSim::new(&scene).unwrap();
    let (mut tr, mut nr, mut tn, mut nn) = (0.0, 0, 0.0, 0);
    for _ in 0..steps {
        let t = Instant::now();
        let s = sim.step().unwrap();
        let e = t.elapsed().as_secs_f64() * 1e3;
        if s.reselected {
            tr += e;
            nr += 1
        } else {
            tn += e;
            nn += 1
        }
    }
    println!(
        "reselect steps: {:.2} ms ({nr}); other steps: {:.3} ms ({nn})",
        tr / nr as f64,
        tn / nn.max(1) as f64
    );
    // Classification alone.
    let mut cl = articula_view::Classifier::new(&scene.visibility);
    let mut views = Vec::new();
    let parents: Vec<Option<usize>> = scene.models[0]
        .model
        .bodies
        .iter()
        .map(|b| b.parent)
        .collect();
    let placed: Vec<articula_view::Placed> = sim
        .bodies
        .iter()
        .map(|b| articula_view::Placed {
            volumes: &scene.models[0].volumes,
            poses: &b.poses,
            parents: &parents,
            margin: 0.1,
        })
        .collect();
    // Minimum and median over 60 calls: a loaded machine delays some calls, not all.
    let mut times: Vec<f64> = (0..60)
        .map(|_| {
            let t = Instant::now();
            cl.classify(
                &scene.camera.at(0.0),
                &scene.visibility,
                &placed,
                &mut views,
            );
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    println!(
        "classification: {:.3} ms (minimum over 60 calls; median {:.3} ms)",
        times[0], times[30]
    );
    // node_metrics alone for every body.
    let model = &scene.models[0].model;
    let mut m = vec![0.0; model.assembly.nodes.len()];
    let mut ad = articula_adaptive::Adaptive::new(model, Default::default());
    let t = Instant::now();
    for b in &sim.bodies {
        let s = &b.state;
        ad.node_metrics(model, &s.q, &s.qd, &s.tau, &s.f_ext, &mut m)
            .unwrap();
    }
    println!(
        "node_metrics all bodies: {:.3} ms",
        t.elapsed().as_secs_f64() * 1e3
    );
    // Exact DCA on every body for comparison.
    let model = &scene.models[0].model;
    let mut data = articula_dca::Data::new(model);
    let mut states: Vec<_> = sim.bodies.iter().map(|b| b.state.clone()).collect();
    let t = Instant::now();
    for _ in 0..20 {
        for s in &mut states {
            articula_dca::step(
                model,
                &mut data,
                s,
                articula_dca::Method::Dca,
                articula_dca::Integrator::SemiImplicitEuler,
                scene.dt,
            )
            .unwrap();
        }
    }
    println!(
        "exact DCA all bodies: {:.3} ms/step",
        t.elapsed().as_secs_f64() * 1e3 / 20.0
    );
}
