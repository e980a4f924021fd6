//! Adaptive scene steps against exact DCA on every body, interleaved in one process:
//! `cargo run --release -p articula-view --example crowd_ratio -- SCENE.json ROUNDS STEPS`.
//!
//! Each round times `STEPS` scene steps from a fresh [`SceneSim`] (as the criterion bench's
//! `adaptive_step`: re-selections, pushes and all), then `STEPS / 10` exact semi-implicit DCA
//! steps of every body from the states after 20 scene steps, with one shared workspace (as
//! `exact_dca_step`). Alternating the two within a round keeps them in the same phase of a
//! noisy machine; the ratio of each round and of the minima is printed.
use articula_dca::{step, Data, Integrator, Method};
use articula_view::SceneSim;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 {
        eprintln!("usage: crowd_ratio SCENE.json ROUNDS STEPS");
        std::process::exit(2);
    }
    let scene = articula_view::load_scene(&args[1]).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(2)
    });
    let (rounds, steps): (usize, u64) = (args[2].parse().unwrap(), args[3].parse().unwrap());
    let mut sim = SceneSim::new(&scene).unwrap();
    for _ in 0..20 {
        sim.step().unwrap();
    }
    let start: Vec<_> = sim.bodies.iter().map(|b| b.state.clone()).collect();
    let models: Vec<_> = sim.bodies.iter().map(|b| b.model).collect();
    let mut data: Vec<Data> = scene
        .models
        .iter()
        .map(|m| {
            let mut d = Data::new(&m.model);
            d.gravity = scene.gravity;
            d
        })
        .collect();
    let exact_steps = (steps / 10).max(1);
    let (mut best_a, mut best_e) = (f64::MAX, f64::MAX);
    let mut ratios = Vec::new();
    for round in 0..rounds {
        let mut sim = SceneSim::new(&scene).unwrap();
        let t = Instant::now();
        for _ in 0..steps {
            sim.step().unwrap();
        }
        let a = t.elapsed().as_secs_f64() * 1e3 / steps as f64;
        let mut states = start.clone();
        let t = Instant::now();
        for _ in 0..exact_steps {
            for (s, &m) in states.iter_mut().zip(&models) {
                let model = &scene.models[m].model;
                step(
                    model,
                    &mut data[m],
                    s,
                    Method::Dca,
                    Integrator::SemiImplicitEuler,
                    scene.dt,
                )
                .unwrap();
            }
        }
        let e = t.elapsed().as_secs_f64() * 1e3 / exact_steps as f64;
        best_a = best_a.min(a);
        best_e = best_e.min(e);
        ratios.push(e / a);
        println!(
            "round {round}: adaptive {a:.3} ms/step, exact DCA {e:.3} ms/step, ratio {:.2}",
            e / a
        );
    }
    ratios.sort_by(f64::total_cmp);
    println!(
        "minima: adaptive {best_a:.3} ms/step, exact DCA {best_e:.3} ms/step, ratio {:.2}; median round ratio {:.2}",
        best_e / best_a,
        ratios[ratios.len() / 2]
    );
}
