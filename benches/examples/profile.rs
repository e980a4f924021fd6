//! Runs one method in a loop for profiling:
//! `cargo run --release -p articula-benches --example profile -- dca 300 2000`
//! (method, chain length, calls). Prints wall-clock and CPU time per call; on a loaded machine
//! the CPU time (from /proc, 10 ms resolution: use runs of a second or more) is the steadier.
use articula_dca::{forward_dynamics_slices, Data, Method, State};

/// User + system CPU time of this process in seconds (Linux; `None` elsewhere).
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let method: Method = a.get(1).map(|s| s.parse().unwrap()).unwrap_or(Method::Dca);
    let n: usize = a.get(2).map(|s| s.parse().unwrap()).unwrap_or(300);
    let reps: usize = a.get(3).map(|s| s.parse().unwrap()).unwrap_or(1000);
    let model = articula_benches::chain(n);
    let s = State::random(&model, 42, 1.0);
    let mut data = Data::new(&model);
    let c0 = cpu_seconds();
    let t = std::time::Instant::now();
    let mut acc = 0.0;
    for _ in 0..reps {
        acc += forward_dynamics_slices(&model, &mut data, &s.q, &s.qd, &s.tau, &[], method)
            .unwrap()[0];
    }
    let wall = t.elapsed().as_secs_f64() * 1e6 / reps as f64;
    let cpu = match (c0, cpu_seconds()) {
        (Some(a), Some(b)) => format!("{:.3}", (b - a) * 1e6 / reps as f64),
        _ => "?".to_string(),
    };
    println!("{wall:.3} us/call wall, {cpu} us/call cpu ({acc:e})");
}
