//! `cargo xtask time METHOD MODEL [BATCHES] [CALLS] [--portable]`: the minimum and median time
//! per forward-dynamics call over `BATCHES` batches of `CALLS` calls (defaults 30 and 100), for
//! comparisons alternated with another program on a noisy machine — Pinocchio through
//! `peers/pin300.py`, or another build. `MODEL` is a chain length (`300`), a bundled model
//! (`humanoid`) or its floating-base version (`humanoid-floating`); the state is
//! `State::random(model, 42, 1.0)`, the benchmarks' state. `--portable` runs DCA's portable
//! compilation instead of the fused (AVX2 + FMA) one.

use crate::args::{self, Args};
use articula_dca::{forward_dynamics_slices, Data, Method, State};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

const USAGE: &str = "cargo xtask time METHOD MODEL [BATCHES] [CALLS] [--portable]";

pub fn run(args: &[String]) -> Result<()> {
    let portable = args.iter().any(|a| a == "--portable");
    let args: Vec<String> = args
        .iter()
        .filter(|a| *a != "--portable")
        .cloned()
        .collect();
    let mut a = Args::new(&args, USAGE);
    let method: Method = a.next("method")?;
    let name: String = a.next("model")?;
    let batches: usize = a.next_or("batches", 30)?;
    let calls: usize = a.next_or("calls per batch", 100)?;
    a.finish()?;
    if batches == 0 || calls == 0 {
        return Err("batches and calls must be at least 1".into());
    }
    let model = args::model(&name)?;
    let s = State::random(&model, 42, 1.0);
    let mut data = Data::new(&model);
    if portable {
        data.set_fused_dca(false);
    }
    let mut acc = 0.0;
    let mut run = |data: &mut Data| -> Result<()> {
        acc += forward_dynamics_slices(&model, data, &s.q, &s.qd, &s.tau, &[], method)?[0];
        Ok(())
    };
    for _ in 0..calls {
        run(&mut data)?;
    }
    let mut t = Vec::with_capacity(batches);
    for _ in 0..batches {
        let start = std::time::Instant::now();
        for _ in 0..calls {
            run(&mut data)?;
        }
        t.push(start.elapsed().as_secs_f64() * 1e6 / calls as f64);
    }
    t.sort_by(f64::total_cmp);
    std::hint::black_box(acc);
    println!(
        "{} {name}{}: min {:.2} us/call, median {:.2} ({batches} batches of {calls})",
        method.name(),
        if portable { " portable" } else { "" },
        t[0],
        t[batches / 2]
    );
    Ok(())
}
