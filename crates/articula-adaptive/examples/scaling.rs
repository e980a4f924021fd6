//! Step time at a fixed budget against chain length, between re-selections (the hierarchical
//! state) and for the re-selection itself:
//! `cargo run --release -p articula-adaptive --example scaling -- 1000 100000`.

use articula_adaptive::{Adaptive, Settings};
use articula_dca::State;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let sizes: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse())
        .collect::<Result<_, _>>()?;
    let sizes = if sizes.is_empty() {
        vec![1000, 10_000, 100_000]
    } else {
        sizes
    };
    let budget = 50;
    println!("budget {budget}, dt 1e-4, crumpled chain at rest (random angles ±1.2 rad)");
    for n in sizes {
        let model = articula_benches::chain(n);
        let mut s0 = State::random(&model, 42, 0.0);
        s0.qd.fill(0.0);
        s0.f_ext.clear();
        let mut ad = Adaptive::new(
            &model,
            Settings {
                budget: Some(budget),
                reselect_every: u64::MAX,
                ..Settings::default()
            },
        );
        let mut s = s0.clone();
        let t = Instant::now();
        let first = ad.step(&model, &mut s, 1e-4)?;
        let reselect_ms = t.elapsed().as_secs_f64() * 1e3;
        // Median of 21 batches of 100 hybrid steps.
        let mut us = Vec::new();
        let mut touched = 0;
        for _ in 0..21 {
            let t = Instant::now();
            for _ in 0..100 {
                touched = ad.step(&model, &mut s, 1e-4)?.nodes_touched;
            }
            us.push(t.elapsed().as_secs_f64() * 1e6 / 100.0);
        }
        us.sort_by(f64::total_cmp);
        println!(
            "chain{n:<7} re-selection {reselect_ms:9.1} ms ({} nodes)   step between re-selections {:8.2} µs ({touched} nodes, {} active DOFs)",
            first.nodes_touched, us[10], first.active_dofs
        );
    }
    Ok(())
}
