//! Growth of the time per forward-dynamics call from a short chain to a long one, measured with
//! the two lengths interleaved in one process.
//!
//! On a shared machine the speed drifts in phases of a fraction of a second to minutes (other
//! tenants on the same cores, caches and memory), and the phases slow a call that streams
//! megabytes through the last-level cache more than one that lives in L2. Timing the two
//! lengths minutes apart (criterion's way) then measures the host as much as the code. Here each
//! round times a batch of short calls and one long call of about the same duration back to back,
//! each after an untimed call that warms its workspace, so both see the same phase. Two figures
//! come out:
//! - the **ratio of the minima** over the rounds: the cost on a quiet host (each length's
//!   fastest call), the figure `growth` has always reported;
//! - the **per-round ratios** (long / short in the same round): their median is what a typical
//!   minute of this host gives.
//!
//! `cargo xtask growth [METHOD] [SHORT] [LONG] [ROUNDS]` (defaults `dca 1000 10000 1000`) prints
//! both; `cargo xtask bench` reports them for DCA and ABA. Use runs of several seconds (1,000
//! rounds of DCA 1000/10000 take about 12 s): the host's slow phases last seconds, and a short
//! run's minima cannot escape them.

use articula_dca::{forward_dynamics_slices, Data, Method, State};
use std::time::Instant;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// The arguments of `cargo xtask growth`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// The forward-dynamics method.
    #[arg(value_name = "METHOD", default_value = "dca", value_parser = crate::args::method())]
    pub method: Method,
    /// The short chain's length (links).
    #[arg(value_name = "SHORT", default_value_t = 1000, value_parser = crate::args::count,
          allow_negative_numbers = true)]
    pub short: usize,
    /// The long chain's length (links).
    #[arg(value_name = "LONG", default_value_t = 10_000, value_parser = crate::args::count,
          allow_negative_numbers = true)]
    pub long: usize,
    /// Interleaved rounds.
    #[arg(value_name = "ROUNDS", default_value_t = 1000, value_parser = crate::args::count,
          allow_negative_numbers = true)]
    pub rounds: usize,
}

/// `cargo xtask growth [METHOD] [SHORT] [LONG] [ROUNDS]`.
pub fn run(o: &Options) -> Result<()> {
    let (method, short, long, rounds) = (o.method, o.short, o.long, o.rounds);
    let g = measure(method, short, long, rounds, |_| {});
    println!(
        "{} chain{} {:.2} us, chain{} {:.2} us (minima over {rounds} interleaved rounds): growth {:.2}x",
        g.method.name(),
        g.short,
        g.short_us,
        g.long,
        g.long_us,
        g.ratio()
    );
    println!(
        "per-round ratio: quartiles {:.2} {:.2} {:.2}, tenth percentile {:.2}",
        g.per_round_quantile(0.25),
        g.per_round_quantile(0.5),
        g.per_round_quantile(0.75),
        g.per_round_quantile(0.1)
    );
    Ok(())
}

/// One growth measurement (see the module documentation).
#[derive(Clone, Debug)]
pub struct Growth {
    pub method: Method,
    pub short: usize,
    pub long: usize,
    /// Minimum over the rounds of the time per call, µs.
    pub short_us: f64,
    pub long_us: f64,
    /// The per-round ratios `long / short`, sorted ascending.
    pub per_round: Vec<f64>,
}

impl Growth {
    /// The ratio of the minima (linear cost gives `long / short`).
    pub fn ratio(&self) -> f64 {
        self.long_us / self.short_us
    }

    /// The `f`-quantile (0 ≤ f ≤ 1) of the per-round ratios, nearest rank.
    pub fn per_round_quantile(&self, f: f64) -> f64 {
        quantile(&self.per_round, f)
    }
}

/// The `f`-quantile of an ascending, non-empty slice by nearest rank: the element at
/// `round((len − 1) f)`.
pub fn quantile(sorted: &[f64], f: f64) -> f64 {
    assert!(!sorted.is_empty(), "quantile of no values");
    let i = ((sorted.len() - 1) as f64 * f.clamp(0.0, 1.0)).round() as usize;
    sorted[i]
}

/// Measures the growth of `method` from `chain(short)` to `chain(long)` over `rounds` timed
/// rounds (after one untimed round that warms the caches and branch predictors), on
/// `State::random(model, 42, 1.0)`. `progress(r)` is called after each round.
pub fn measure(
    method: Method,
    short: usize,
    long: usize,
    rounds: usize,
    mut progress: impl FnMut(usize),
) -> Growth {
    let setup = |n: usize| {
        let model = articula_testkit::chain(n);
        let s = State::random(&model, 42, 1.0);
        let data = Data::new(&model);
        (model, s, data)
    };
    let (ms, ss, mut ds) = setup(short);
    let (ml, sl, mut dl) = setup(long);
    let mut sink = 0.0;
    let mut call = |m: &articula_model::Model, s: &State, d: &mut Data| {
        let qdd = forward_dynamics_slices(m, d, &s.q, &s.qd, &s.tau, &[], method)
            .expect("a random chain state is valid");
        sink += qdd[0];
    };
    // Batches of about the same length: `long / short` short calls per long call.
    let per = (long / short.max(1)).max(1);
    let (mut best_s, mut best_l) = (f64::INFINITY, f64::INFINITY);
    let mut per_round = Vec::with_capacity(rounds);
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
            per_round.push(tl / ts);
            progress(r);
        }
    }
    std::hint::black_box(sink);
    per_round.sort_by(f64::total_cmp);
    Growth {
        method,
        short,
        long,
        short_us: best_s * 1e6,
        long_us: best_l * 1e6,
        per_round,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_by_nearest_rank() {
        let v = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(quantile(&v, 0.0), 1.0);
        assert_eq!(quantile(&v, 0.5), 3.0);
        assert_eq!(quantile(&v, 0.25), 2.0);
        assert_eq!(quantile(&v, 1.0), 5.0);
        // Between ranks: round((4 − 1) · 0.5) = round(1.5) = 2.
        assert_eq!(quantile(&[10.0, 20.0, 30.0, 40.0], 0.5), 30.0);
    }

    #[test]
    fn growth_ratio_is_the_ratio_of_the_minima() {
        let g = Growth {
            method: Method::Dca,
            short: 1000,
            long: 10_000,
            short_us: 280.0,
            long_us: 3080.0,
            per_round: vec![10.5, 11.0, 12.0],
        };
        assert!((g.ratio() - 11.0).abs() < 1e-12);
        assert_eq!(g.per_round_quantile(0.5), 11.0);
    }
}
