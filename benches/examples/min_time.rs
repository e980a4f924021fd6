//! Minimum time per call over batches, for interleaved comparisons on a noisy machine:
//! `cargo run --release -p articula-benches --example min_time -- dca 300 30 100`
//! (method, chain length, batches, calls per batch). Prints the minimum and the median
//! wall-clock time per call over the batches. Instead of a chain length, a bundled model's
//! name (`humanoid`, or `humanoid-floating` for its floating-base version) times that model.
//! A fifth argument `portable` runs DCA's portable compilation instead of the fused one.
use articula_dca::{forward_dynamics_slices, Data, Method, State};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let method: Method = a.get(1).map(|s| s.parse().unwrap()).unwrap_or(Method::Dca);
    let name = a.get(2).map(String::as_str).unwrap_or("300");
    let batches: usize = a.get(3).map(|s| s.parse().unwrap()).unwrap_or(30);
    let calls: usize = a.get(4).map(|s| s.parse().unwrap()).unwrap_or(100);
    let model = match name.parse() {
        Ok(n) => articula_benches::chain(n),
        Err(_) => match name.strip_suffix("-floating") {
            Some(stem) => articula_benches::bundled_with(stem, true),
            None => articula_benches::bundled(name),
        },
    };
    let s = State::random(&model, 42, 1.0);
    let mut data = Data::new(&model);
    if a.get(5).map(String::as_str) == Some("portable") {
        data.set_fused_dca(false);
    }
    let mut acc = 0.0;
    let mut run = |data: &mut Data| {
        acc += forward_dynamics_slices(&model, data, &s.q, &s.qd, &s.tau, &[], method).unwrap()[0];
    };
    for _ in 0..calls {
        run(&mut data);
    }
    let mut t: Vec<f64> = (0..batches)
        .map(|_| {
            let start = std::time::Instant::now();
            for _ in 0..calls {
                run(&mut data);
            }
            start.elapsed().as_secs_f64() * 1e6 / calls as f64
        })
        .collect();
    t.sort_by(f64::total_cmp);
    println!(
        "{} {name}: min {:.2} us/call, median {:.2} ({acc:e})",
        method.name(),
        t[0],
        t[batches / 2]
    );
}
