//! The shared adaptive scratch against per-body buffers, and both against exact DCA, measured
//! in one process, interleaved: `cargo run --release -p articula-view --example scratch_ab --
//! SCENE.json ROUNDS [STEPS] [--crowd2000]`. Two simulations of the scene (shared scratch on,
//! off) run the same trajectory (bit-identical); each round times `STEPS` steps of each (order
//! alternating), then `STEPS` exact DCA steps (semi-implicit Euler, one `Data` for every body)
//! of every body from the round's states. Restarts from the initial states every 480 steps
//! (the crowd's stable span). Prints per-round times and the medians.
use articula_dca::{step, Data, Integrator, Method};
use articula_view::{load_scene, parse_scene, LoadedScene, SceneSim};
use std::path::Path;
use std::time::Instant;

fn median(mut x: Vec<f64>) -> f64 {
    x.sort_by(f64::total_cmp);
    x[x.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: scratch_ab SCENE.json ROUNDS [STEPS] [--crowd2000]");
        std::process::exit(2);
    }
    let rounds: usize = args[2].parse().unwrap();
    let steps: u64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(20);
    let scene: LoadedScene = if args.iter().any(|a| a == "--crowd2000") {
        // The criterion bench's crowd2000: the scene on a 40 × 50 grid, budget 4,000.
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&args[1]).unwrap()).unwrap();
        v["crowds"][0]["rows"] = 40.into();
        v["crowds"][0]["columns"] = 50.into();
        v["crowds"][0]["origin"] = serde_json::json!([4.0, -22.05, 1.0]);
        v["budget"] = 4000.into();
        let dir = Path::new(&args[1]).parent().unwrap();
        parse_scene(&v.to_string(), &dir.join("crowd2000.json"), dir).unwrap()
    } else {
        load_scene(&args[1]).unwrap()
    };
    let model = &scene.models[0].model;
    let mut data = Data::new(model);
    data.gravity = scene.gravity;
    let new_pair = || {
        let shared = SceneSim::new(&scene).unwrap();
        let mut own = SceneSim::new(&scene).unwrap();
        own.set_shared_scratch(false);
        (shared, own)
    };
    let (mut shared, mut own) = new_pair();
    let (mut ts, mut to, mut te) = (Vec::new(), Vec::new(), Vec::new());
    for r in 0..rounds {
        if shared.steps + steps > 480 {
            (shared, own) = new_pair();
        }
        let mut states: Vec<_> = shared.bodies.iter().map(|b| b.state.clone()).collect();
        let time = |sim: &mut SceneSim| {
            let t = Instant::now();
            for _ in 0..steps {
                sim.step().unwrap();
            }
            t.elapsed().as_secs_f64() * 1e3 / steps as f64
        };
        let (a, b) = if r % 2 == 0 {
            let a = time(&mut shared);
            (a, time(&mut own))
        } else {
            let b = time(&mut own);
            (time(&mut shared), b)
        };
        let t = Instant::now();
        for _ in 0..steps {
            for s in &mut states {
                step(
                    model,
                    &mut data,
                    s,
                    Method::Dca,
                    Integrator::SemiImplicitEuler,
                    scene.dt,
                )
                .unwrap();
            }
        }
        let e = t.elapsed().as_secs_f64() * 1e3 / steps as f64;
        println!(
            "round {r:3}: shared {a:.3} ms  own {b:.3} ms  exact DCA {e:.3} ms  shared/own {:.3}",
            a / b
        );
        ts.push(a);
        to.push(b);
        te.push(e);
    }
    let ratios: Vec<f64> = ts.iter().zip(&to).map(|(a, b)| a / b).collect();
    let (ms, mo, me) = (median(ts.clone()), median(to.clone()), median(te.clone()));
    println!(
        "medians: shared {ms:.3} ms ({:.0} steps/s), own {mo:.3} ms, exact DCA {me:.3} ms; \
         shared/own per round {:.3}; exact/shared {:.2}x, exact/own {:.2}x",
        1e3 / ms,
        median(ratios),
        me / ms,
        me / mo
    );
    let mins = |x: &[f64]| x.iter().copied().fold(f64::INFINITY, f64::min);
    println!(
        "minima: shared {:.3} ms, own {:.3} ms, exact DCA {:.3} ms",
        mins(&ts),
        mins(&to),
        mins(&te)
    );
}
