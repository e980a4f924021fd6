//! Steps a scene for profiling: `cargo run --release -p articula-view --example profile_steps --
//! SCENE.json WARMUP STEPS`. The `WARMUP` steps run first (outside [`measured`]); then
//! `measured` runs `STEPS` more, so that a profiler can collect only those, e.g.
//! `valgrind --tool=callgrind --toggle-collect='profile_steps::measured' ...`.
use articula_view::SceneSim;

#[inline(never)]
fn measured(sim: &mut SceneSim, steps: u64) -> usize {
    let mut active = 0;
    for _ in 0..steps {
        active += sim.step().unwrap().active_total;
    }
    active
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 {
        eprintln!("usage: profile_steps SCENE.json WARMUP STEPS");
        std::process::exit(2);
    }
    let scene = articula_view::load_scene(&args[1]).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(2)
    });
    let (warmup, steps): (u64, u64) = (args[2].parse().unwrap(), args[3].parse().unwrap());
    let mut sim = SceneSim::new(&scene).unwrap();
    for _ in 0..warmup {
        sim.step().unwrap();
    }
    let t = std::time::Instant::now();
    let active = measured(&mut sim, steps);
    println!(
        "{:.3} ms/step over {steps} steps after {warmup}; mean active joints {:.1}",
        t.elapsed().as_secs_f64() * 1e3 / steps as f64,
        active as f64 / steps as f64
    );
    let mut h = 0u64;
    for b in &sim.bodies {
        for x in b.state.q.iter().chain(&b.state.qd) {
            h = h.rotate_left(5) ^ x.to_bits();
        }
    }
    println!("state hash {h:016x}");
}
