//! `cargo xtask time METHOD MODEL [BATCHES] [CALLS] [--portable]`: the minimum and median time
//! per forward-dynamics call over `BATCHES` batches of `CALLS` calls (defaults 30 and 100), for
//! comparisons alternated with another program on a noisy machine — Pinocchio through
//! `peers/pin300.py`, or another build. `MODEL` is a chain length (`300`), a bundled model
//! (`humanoid`) or its floating-base version (`humanoid-floating`); the state is
//! `State::random(model, 42, 1.0)`, the benchmarks' state. `--portable` runs DCA's portable
//! compilation instead of the fused (AVX2 + FMA) one.

use crate::args;
use articula_dca::{forward_dynamics_slices, Data, Method, State};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// The arguments of `cargo xtask time`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// The forward-dynamics method.
    #[arg(value_parser = args::method())]
    pub method: Method,
    /// A chain length (`300`), a bundled model (`humanoid`) or its floating-base version
    /// (`humanoid-floating`).
    #[arg(value_parser = args::model_name)]
    pub model: String,
    /// Timed batches.
    #[arg(default_value_t = 30, value_parser = args::count, allow_negative_numbers = true)]
    pub batches: usize,
    /// Calls per batch.
    #[arg(default_value_t = 100, value_parser = args::count, allow_negative_numbers = true)]
    pub calls: usize,
    /// Run DCA's portable compilation instead of the fused (AVX2 + FMA) one.
    #[arg(long)]
    pub portable: bool,
}

pub fn run(o: &Options) -> Result<()> {
    let (method, name, batches, calls, portable) =
        (o.method, &o.model, o.batches, o.calls, o.portable);
    let model = args::model(name)?;
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
