//! `cargo xtask hash`: bit-level fingerprints of the solvers' results, to show that a change
//! which should only move code leaves every bit alone.
//!
//! - **q̈ of DCA**: for each model (chains of 300 and 1,000 links, the bundled humanoid, plant
//!   and rope, fixed and floating base) and each compilation of the DCA pass (fused where the
//!   CPU has AVX2 + FMA, and portable), DCA at seeded random states (random external forces on
//!   odd seeds), an FNV-1a hash of the bits of every q̈ entry; the largest relative difference
//!   from ABA beside it as a sanity check; `qdd_hash` hashes the per-model hashes.
//! - **A scene's state**: `models/scenes/crowd200.json` stepped 500 times (adaptive dynamics on
//!   200 floating humanoids, one global budget), a rotate-xor hash of the bits of every body's
//!   `q` and `q̇`.
//!
//! Both depend on the CPU's compilation (fused or not): compare hashes from one machine.

use articula_dca::{forward_dynamics_slices, Data, Method, State};
use articula_model::Model;
use std::path::Path;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// The FNV-1a offset basis.
const FNV_START: u64 = 0xcbf29ce484222325;

/// Adds the bytes of `x`'s bits to the FNV-1a hash `h`.
fn fnv(h: &mut u64, x: f64) {
    for b in x.to_bits().to_le_bytes() {
        *h ^= b as u64;
        *h = h.wrapping_mul(0x100000001b3);
    }
}

pub fn run(root: &Path) -> Result<()> {
    println!("qdd_hash: {:016x}", qdd_hash(true)?);
    let scene = root.join("models/scenes/crowd200.json");
    let (steps, h) = (500, scene_hash(&scene, 500)?);
    println!("state hash: {h:016x} (crowd200, {steps} steps)");
    Ok(())
}

/// The q̈ fingerprint of DCA (see the module documentation); with `verbose`, one line per model
/// and compilation.
pub fn qdd_hash(verbose: bool) -> Result<u64> {
    let mut models: Vec<(String, Model)> = [300usize, 1000]
        .into_iter()
        .map(|n| (format!("chain{n}"), articula_testkit::chain(n)))
        .collect();
    for name in ["humanoid", "plant", "rope"] {
        for floating in [false, true] {
            let tag = if floating { " floating" } else { "" };
            models.push((
                format!("{name}{tag}"),
                articula_testkit::bundled_with(name, floating),
            ));
        }
    }
    let mut all = FNV_START;
    for (name, model) in &models {
        let mut data = Data::new(model);
        for fused in [true, false] {
            let used = data.set_fused_dca(fused);
            if fused && !used {
                continue;
            }
            let mut h = FNV_START;
            let mut worst = 0.0f64;
            for seed in 0..4u64 {
                let mut s = State::random(model, seed, 1.0);
                if seed % 2 == 1 {
                    s.randomize_forces(seed, 0.5);
                }
                let mut solve = |m| {
                    forward_dynamics_slices(model, &mut data, &s.q, &s.qd, &s.tau, &s.f_ext, m)
                        .map(<[f64]>::to_vec)
                        .map_err(|e| format!("{name}, seed {seed}, {}: {e}", m.name()))
                };
                let dca = solve(Method::Dca)?;
                let aba = solve(Method::Aba)?;
                dca.iter().for_each(|&x| fnv(&mut h, x));
                let scale = aba.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                let diff = aba
                    .iter()
                    .zip(&dca)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                worst = worst.max(diff / scale);
            }
            fnv(&mut all, f64::from_bits(h));
            if verbose {
                let comp = if used { "fused" } else { "portable" };
                println!("{name:>18} {comp:>8}: {h:016x}  (vs ABA {worst:.1e})");
            }
        }
    }
    Ok(all)
}

/// The state fingerprint of the scene `path` after `steps` steps.
pub fn scene_hash(path: &Path, steps: u64) -> Result<u64> {
    let scene = articula_view::load_scene(path)?;
    let mut sim = articula_view::SceneSim::new(&scene).map_err(|e| e.to_string())?;
    for _ in 0..steps {
        sim.step()?;
    }
    Ok(state_hash(&sim))
}

/// A rotate-xor hash of the bits of every body's `q` and `q̇` ([`SceneSim::state_hash`]).
///
/// [`SceneSim::state_hash`]: articula_view::SceneSim::state_hash
pub fn state_hash(sim: &articula_view::SceneSim) -> u64 {
    sim.state_hash()
}
