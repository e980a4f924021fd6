//! Bit-level fingerprint of DCA's q̈, to show that a change to the pass leaves every bit of its
//! result alone: `cargo run --release -p articula-benches --example qdd_hash`. For each model
//! (procedural chains, the bundled humanoid, plant and rope, fixed and floating base) and each
//! compilation (fused where the CPU has AVX2 + FMA, and portable), solves DCA at seeded random
//! states (external forces on odd seeds) and prints an FNV-1a hash of the bits of every q̈
//! entry, with the largest relative difference from ABA as a sanity check.
use articula_dca::{forward_dynamics_slices, Data, Method, State};
use articula_model::Model;

fn fnv(h: &mut u64, x: f64) {
    for b in x.to_bits().to_le_bytes() {
        *h ^= b as u64;
        *h = h.wrapping_mul(0x100000001b3);
    }
}

fn main() {
    let mut models: Vec<(String, Model)> = [300usize, 1000]
        .into_iter()
        .map(|n| (format!("chain{n}"), articula_benches::chain(n)))
        .collect();
    for name in ["humanoid", "plant", "rope"] {
        for floating in [false, true] {
            let tag = if floating { " floating" } else { "" };
            models.push((
                format!("{name}{tag}"),
                articula_benches::bundled_with(name, floating),
            ));
        }
    }
    let mut all = 0xcbf29ce484222325u64;
    for (name, model) in &models {
        let mut data = Data::new(model);
        for fused in [true, false] {
            let used = data.set_fused_dca(fused);
            if fused && !used {
                continue;
            }
            let mut h = 0xcbf29ce484222325u64;
            let mut worst = 0.0f64;
            for seed in 0..4u64 {
                let mut s = State::random(model, seed, 1.0);
                if seed % 2 == 1 {
                    s.randomize_forces(seed, 0.5);
                }
                let solve = |m, data: &mut Data| {
                    forward_dynamics_slices(model, data, &s.q, &s.qd, &s.tau, &s.f_ext, m)
                        .unwrap()
                        .to_vec()
                };
                let dca = solve(Method::Dca, &mut data);
                let aba = solve(Method::Aba, &mut data);
                dca.iter().for_each(|&x| fnv(&mut h, x));
                let scale = aba.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                let diff = aba
                    .iter()
                    .zip(&dca)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                worst = worst.max(diff / scale);
            }
            fnv(&mut all, f64::from_bits(h));
            let comp = if used { "fused" } else { "portable" };
            println!("{name:>18} {comp:>8}: {h:016x}  (vs ABA {worst:.1e})");
        }
    }
    println!("all: {all:016x}");
}
