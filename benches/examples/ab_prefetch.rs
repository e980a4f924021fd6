//! The DCA back-substitution's software prefetches on and off, timed in one process with the
//! two interleaved call by call (so that the shared machine's phases hit both alike):
//! `cargo run --release -p articula-benches --example ab_prefetch -- 10000 300 back`
//! (chain length, rounds, `back` to toggle the prefetches or `same` for the tool's own bias:
//! both workspaces with the default setting). Each round times one call on each of two
//! workspaces, each after one untimed call, in alternating order; prints the minimum and
//! median of each and the median of the per-round ratios (on / off). On the shared 2-core
//! host of session 12 the `same` runs read 0.94–1.05 (ratios of minima and per-round medians
//! alike), so a setting's effect needs several runs alternated with `same` ones.
use articula_dca::{forward_dynamics_slices, Data, Method, State};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let n: usize = a.get(1).map(|s| s.parse().unwrap()).unwrap_or(10_000);
    let rounds: usize = a.get(2).map(|s| s.parse().unwrap()).unwrap_or(300);
    let which = a.get(3).map(String::as_str).unwrap_or("back");
    let model = articula_benches::chain(n);
    let s = State::random(&model, 42, 1.0);
    let mut on = Data::new(&model);
    let mut off = Data::new(&model);
    if which == "back" {
        on.set_dca_prefetch(true);
        off.set_dca_prefetch(false);
    }
    let mut acc = 0.0;
    let mut time = |d: &mut Data| {
        acc +=
            forward_dynamics_slices(&model, d, &s.q, &s.qd, &s.tau, &[], Method::Dca).unwrap()[0];
        let t = Instant::now();
        acc +=
            forward_dynamics_slices(&model, d, &s.q, &s.qd, &s.tau, &[], Method::Dca).unwrap()[0];
        t.elapsed().as_secs_f64() * 1e6
    };
    let (mut t_on, mut t_off, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
    // Round 0 warms the caches and the branch predictors.
    for r in 0..=rounds {
        let (x, y) = if r % 2 == 0 {
            let x = time(&mut on);
            (x, time(&mut off))
        } else {
            let y = time(&mut off);
            (time(&mut on), y)
        };
        if r > 0 {
            t_on.push(x);
            t_off.push(y);
            ratio.push(x / y);
        }
    }
    let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let (m_on, m_off) = (min(&t_on), min(&t_off));
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!(
        "chain{n} {which}: on min {m_on:.1} med {:.1} us, off min {m_off:.1} med {:.1} us; \
         on/off median per round {:.4}, of the minima {:.4} ({acc:e})",
        med(&mut t_on),
        med(&mut t_off),
        med(&mut ratio),
        m_on / m_off
    );
}
