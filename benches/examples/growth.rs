//! Growth of the time per call from a short to a long chain, measured in one process with the
//! two lengths interleaved (so that the machine's speed, which drifts within minutes on a
//! shared VM, is the same for both): `cargo run --release -p articula-benches --example growth
//! -- dca 1000 10000 40` (method, short length, long length, rounds). Each round times a batch
//! of the short chain and a batch of the long one with about the same total time, each after
//! one untimed call that warms its workspace; the minimum
//! over the rounds of each is the figure, and the ratio of the minima is the growth (linear
//! cost gives `long / short`).
use articula_dca::{forward_dynamics, Data, Method, State};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let method: Method = a.get(1).map(|s| s.parse().unwrap()).unwrap_or(Method::Dca);
    let short: usize = a.get(2).map(|s| s.parse().unwrap()).unwrap_or(1000);
    let long: usize = a.get(3).map(|s| s.parse().unwrap()).unwrap_or(10_000);
    let rounds: usize = a.get(4).map(|s| s.parse().unwrap()).unwrap_or(40);
    let setup = |n: usize| {
        let model = articula_benches::chain(n);
        let s = State::random(&model, 42, 1.0);
        let data = Data::new(&model);
        (model, s, data)
    };
    let (ms, ss, mut ds) = setup(short);
    let (ml, sl, mut dl) = setup(long);
    let mut acc = 0.0;
    let mut call = |m: &articula_model::Model, s: &State, d: &mut Data| {
        acc += forward_dynamics(m, d, &s.q, &s.qd, &s.tau, &[], method).unwrap()[0];
    };
    // Batches of about the same length: `long / short` short calls per long call.
    let per = (long / short).max(1);
    let (mut best_s, mut best_l) = (f64::INFINITY, f64::INFINITY);
    for r in 0..=rounds {
        // One untimed call before each timed batch: the other length's call evicted this
        // one's workspace from the caches, and a warm workspace is what repeated calls see.
        call(&ms, &ss, &mut ds);
        let t = Instant::now();
        for _ in 0..per {
            call(&ms, &ss, &mut ds);
        }
        let ts = t.elapsed().as_secs_f64() / per as f64;
        call(&ml, &sl, &mut dl);
        let t = Instant::now();
        call(&ml, &sl, &mut dl);
        let tl = t.elapsed().as_secs_f64();
        // Round 0 warms the caches and the branch predictors.
        if r > 0 {
            best_s = best_s.min(ts);
            best_l = best_l.min(tl);
        }
    }
    println!(
        "{method:?} chain{short} {:.2} us, chain{long} {:.2} us (minima over {rounds} interleaved rounds): growth {:.2}x ({acc:e})",
        best_s * 1e6,
        best_l * 1e6,
        best_l / best_s
    );
}
