//! One body's DCA across threads against the serial DCA, by chain length: where the split
//! (`articula_dca::forward_dynamics_threads`) starts to pay, and what it gives on long chains.
//!
//! `cargo xtask parallel [THREADS] [ROUNDS] [LENGTH...]` (defaults `2 15 250 500 1000 2000
//! 5000 20000 100000`). Each round times, back to back, a batch of each of three calls of
//! about 50 ms in all, after an untimed call of each: the serial DCA (`forward_dynamics`),
//! the split solve on one thread and the split solve on `THREADS` threads (the split forced
//! whatever the length: `internals::forward_dynamics_split`). The medians over the rounds
//! come out, with the per-round ratio serial / split on `THREADS` threads (its median and
//! range): the crossover is the shortest chain whose ratio stays above 1.

use crate::timing::median;
use articula_dca::internals::forward_dynamics_split;
use articula_dca::{forward_dynamics_slices, Data, Method, State, Threads};
use std::time::Instant;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// The chain lengths measured when none are given.
pub const LENGTHS: [usize; 7] = [250, 500, 1000, 2000, 5000, 20_000, 100_000];

/// The arguments of `cargo xtask parallel`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// Threads of the split solve.
    #[arg(value_name = "THREADS", default_value_t = 2, value_parser = crate::args::count,
          allow_negative_numbers = true)]
    pub threads: usize,
    /// Rounds per chain length.
    #[arg(value_name = "ROUNDS", default_value_t = 15, value_parser = crate::args::count,
          allow_negative_numbers = true)]
    pub rounds: usize,
    /// Chain lengths (links).
    #[arg(value_name = "LENGTH", default_values_t = LENGTHS, value_parser = crate::args::count,
          allow_negative_numbers = true)]
    pub lengths: Vec<usize>,
}

/// `cargo xtask parallel [THREADS] [ROUNDS] [LENGTH...]`.
pub fn run(o: &Options) -> Result<()> {
    let rounds = o.rounds;
    let pool = Threads::new(o.threads)?;
    let serial = Threads::serial();
    println!(
        "threads={} rounds={rounds} (medians over rounds, us per call)",
        pool.count()
    );
    for &n in &o.lengths {
        let model = articula_testkit::chain(n);
        let s = State::random(&model, 42, 1.0);
        let mut data = [Data::new(&model), Data::new(&model), Data::new(&model)];
        let mut sink = 0.0;
        let mut call = |k: usize, data: &mut Data| {
            let qdd = match k {
                0 => forward_dynamics_slices(&model, data, &s.q, &s.qd, &s.tau, &[], Method::Dca),
                1 => forward_dynamics_split(&model, data, &s.q, &s.qd, &s.tau, &[], &serial),
                _ => forward_dynamics_split(&model, data, &s.q, &s.qd, &s.tau, &[], &pool),
            }
            .expect("a random chain state is valid");
            sink += qdd[0];
        };
        // Calls per batch: about 50 ms a round for the three.
        let t0 = Instant::now();
        call(0, &mut data[0]);
        let per = ((0.016 / t0.elapsed().as_secs_f64()) as usize).clamp(1, 10_000);
        let mut us = [Vec::new(), Vec::new(), Vec::new()];
        let mut ratio = Vec::new();
        for _ in 0..rounds {
            for (k, d) in data.iter_mut().enumerate() {
                call(k, d);
                let t = Instant::now();
                for _ in 0..per {
                    call(k, d);
                }
                us[k].push(t.elapsed().as_secs_f64() * 1e6 / per as f64);
            }
            ratio.push(us[0].last().unwrap() / us[2].last().unwrap());
        }
        std::hint::black_box(sink);
        let [a, b, c] = us.map(|mut v| median(&mut v));
        let lo = ratio.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = ratio.iter().copied().fold(0.0, f64::max);
        println!(
            "chain{n}: serial {a:.1}  split/1 {b:.1}  split/{} {c:.1}  serial/split: median {:.2} (rounds {lo:.2}..{hi:.2})",
            pool.count(),
            median(&mut ratio),
        );
    }
    Ok(())
}
