//! The seeds' table ratio (issue 4: budget 50 ≥ 12×, budget 1 ≥ 300× faster than full DCA),
//! interleaved in one process so that a machine whose speed drifts times both alike:
//! `cargo run --release -p articula-adaptive --example seeds_ratio -- ROUNDS [BUDGET...]`
//! (defaults 8 rounds, budgets 1 and 50).
//!
//! The 300-link chain in the seeds' state with one external force
//! ([`articula_benches::seeded_state`]), semi-implicit Euler at dt = 1e-4, as the criterion
//! bench `adaptive_seeds_table/*/f1`: full DCA steps, and adaptive steps re-selecting every
//! 10 steps (selection included), runs restarted every 1,000 steps with the restart and the
//! whole-body re-selection after it untimed. Each round times a batch of DCA steps, then a
//! batch of each budget's steps; it prints every round's times and ratios, then the ratio of
//! the minima and the median round ratio per budget.

use articula_adaptive::{Adaptive, Settings};
use articula_benches::{chain, force_list, seeded_state};
use articula_dca::{step, Data, Integrator, Method};
use std::hint::black_box;
use std::time::{Duration, Instant};

const RUN: u64 = 1000;
const DT: f64 = 1e-4;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let rounds: usize = args.get(1).map(|a| a.parse()).transpose()?.unwrap_or(8);
    let mut budgets: Vec<usize> = args[2.min(args.len())..]
        .iter()
        .map(|a| a.parse())
        .collect::<Result<_, _>>()?;
    if budgets.is_empty() {
        budgets = vec![1, 50];
    }
    let model = chain(300);
    let s0 = seeded_state(&model, 1);
    let list = force_list(&s0.f_ext);
    let mut a0 = s0.clone();
    a0.f_ext.clear();

    // Full DCA: `n` steps, restarted every RUN (the restart untimed).
    let mut data = Data::new(&model);
    let mut s = s0.clone();
    let mut dca_calls = 0u64;
    let mut dca = |n: u64| -> Result<f64, Box<dyn std::error::Error>> {
        let mut total = Duration::ZERO;
        let mut t = Instant::now();
        for _ in 0..n {
            dca_calls += 1;
            if dca_calls.is_multiple_of(RUN) {
                total += t.elapsed();
                s.clone_from(&s0);
                t = Instant::now();
            }
            step(
                &model,
                &mut data,
                &mut s,
                Method::Dca,
                Integrator::SemiImplicitEuler,
                DT,
            )?;
            black_box(s.qd[0]);
        }
        Ok((total + t.elapsed()).as_secs_f64() * 1e6 / n as f64)
    };
    // Adaptive, per budget: its workspace, state and step count.
    let mut runs: Vec<(Adaptive, articula_dca::State, u64)> = budgets
        .iter()
        .map(|&b| {
            let settings = Settings {
                budget: Some(b),
                reselect_every: 10,
                ..Settings::default()
            };
            (Adaptive::new(&model, settings), a0.clone(), 0)
        })
        .collect();
    let mut adaptive = |k: usize, n: u64| -> Result<f64, Box<dyn std::error::Error>> {
        let (ad, s, calls) = &mut runs[k];
        let mut total = Duration::ZERO;
        let mut t = Instant::now();
        for _ in 0..n {
            *calls += 1;
            if calls.is_multiple_of(RUN) || *calls == 1 {
                // Restart: untimed, with the whole-body re-selection that follows it.
                total += t.elapsed();
                s.q.copy_from_slice(&a0.q);
                s.qd.copy_from_slice(&a0.qd);
                ad.invalidate();
                ad.step_with_forces(&model, s, DT, &list)?;
                t = Instant::now();
            }
            ad.step_with_forces(&model, s, DT, &list)?;
            black_box(s.qd[0]);
        }
        Ok((total + t.elapsed()).as_secs_f64() * 1e6 / n as f64)
    };
    // Warm-up.
    dca(200)?;
    for k in 0..budgets.len() {
        adaptive(k, 2000)?;
    }
    let mut best_dca = f64::MAX;
    let mut best = vec![f64::MAX; budgets.len()];
    let mut ratios = vec![Vec::new(); budgets.len()];
    for round in 0..rounds {
        let d = dca(300)?;
        best_dca = best_dca.min(d);
        print!("round {round}: dca {d:.2} us");
        for (k, &b) in budgets.iter().enumerate() {
            // About as long a batch as the DCA one (0.1-1 ms per step class).
            let n = if b <= 10 { 100_000 } else { 3_000 };
            let a = adaptive(k, n)?;
            best[k] = best[k].min(a);
            ratios[k].push(d / a);
            print!(", budget {b} {a:.3} us ({:.1}x)", d / a);
        }
        println!();
    }
    for (k, &b) in budgets.iter().enumerate() {
        let r = &mut ratios[k];
        r.sort_by(f64::total_cmp);
        println!(
            "budget {b} every 10: minima dca {best_dca:.2} us / adaptive {:.3} us = {:.1}x; median round ratio {:.1}x",
            best[k],
            best_dca / best[k],
            r[r.len() / 2]
        );
    }
    Ok(())
}
