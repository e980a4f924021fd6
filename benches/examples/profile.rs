//! Runs one method in a loop for profiling: `cargo run --release -p articula-benches --example profile -- dca 300 2000`
use articula_dca::{forward_dynamics, Data, Method, State};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let method: Method = a.get(1).map(|s| s.parse().unwrap()).unwrap_or(Method::Dca);
    let n: usize = a.get(2).map(|s| s.parse().unwrap()).unwrap_or(300);
    let reps: usize = a.get(3).map(|s| s.parse().unwrap()).unwrap_or(1000);
    let model = articula_benches::chain(n);
    let s = State::random(&model, 42, 1.0);
    let mut data = Data::new(&model);
    let t = std::time::Instant::now();
    let mut acc = 0.0;
    for _ in 0..reps {
        acc += forward_dynamics(&model, &mut data, &s.q, &s.qd, &s.tau, &[], method).unwrap()[0];
    }
    println!(
        "{} us/call ({acc:e})",
        t.elapsed().as_secs_f64() * 1e6 / reps as f64
    );
}
