//! DCA vs ABA on an n-link chain: `cargo run --release -p articula-benches --example agree -- 20000`
//! prints the relative difference max|Δq̈| / max|q̈| on the straight chain (q = 0, moving) and at
//! seeded random states.
use articula_dca::{forward_dynamics_slices, Data, Method, State};
fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(1000);
    let model = articula_benches::chain(n);
    let mut data = Data::new(&model);
    // None: straight (q = 0) but moving (seeded random q̇ and τ); Some(k): seeded random state.
    for seed in [None, Some(1u64), Some(2)] {
        let s = match seed {
            None => {
                let mut s = State::random(&model, 7, 1.0);
                s.q.iter_mut().for_each(|x| *x = 0.0);
                s
            }
            Some(k) => State::random(&model, k, 1.0),
        };
        let run = |m, data: &mut Data| {
            forward_dynamics_slices(&model, data, &s.q, &s.qd, &s.tau, &[], m).map(|x| x.to_vec())
        };
        let aba = run(Method::Aba, &mut data).unwrap();
        match run(Method::Dca, &mut data) {
            Ok(dca) => {
                let scale = aba.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                let diff = aba
                    .iter()
                    .zip(&dca)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                println!("n={n} state={seed:?} rel diff {:.3e}", diff / scale);
            }
            Err(e) => println!("n={n} state={seed:?} DCA error: {e}"),
        }
    }
}
