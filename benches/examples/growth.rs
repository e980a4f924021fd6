//! Growth of the time per call from a short to a long chain, the two lengths interleaved in one
//! process (`articula_benches::growth`): `cargo run --release -p articula-benches --example
//! growth -- dca 1000 10000 1000` (method, short length, long length, rounds).
//!
//! Prints the minima of each length and their ratio (the cost on a quiet host; linear cost
//! gives `long / short`), and the quartiles of the per-round ratios (a typical minute of this
//! host). Use runs of several seconds (1,000 rounds of DCA 1000/10000 take about 12 s): the
//! host's slow phases last seconds, and a short run's minima cannot escape them.
use articula_benches::growth;
use articula_dca::Method;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let method: Method = a.get(1).map(|s| s.parse().unwrap()).unwrap_or(Method::Dca);
    let short: usize = a.get(2).map(|s| s.parse().unwrap()).unwrap_or(1000);
    let long: usize = a.get(3).map(|s| s.parse().unwrap()).unwrap_or(10_000);
    let rounds: usize = a.get(4).map(|s| s.parse().unwrap()).unwrap_or(1000);
    let g = growth::measure(method, short, long, rounds.max(1), |_| {});
    println!(
        "{method:?} chain{short} {:.2} us, chain{long} {:.2} us (minima over {rounds} interleaved rounds): growth {:.2}x",
        g.short_us,
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
}
