//! How long a scene stays finite with other pose springs, push, time step and budget:
//! `cargo run --release -p articula-view --example stab -- SCENE.json FREQ_HZ DAMPING_RATIO
//! PUSH_N DT STEPS [BUDGET|none]` prints the first step that fails, or the largest internal
//! joint speed after STEPS steps (docs/view.md quotes its figures).

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&args[1]).unwrap()).unwrap();
    v["joint_springs"]["frequency_hz"] = args[2].parse::<f64>().unwrap().into();
    v["joint_springs"]["damping_ratio"] = args[3].parse::<f64>().unwrap().into();
    v["pushes"][0]["force"][0] = args[4].parse::<f64>().unwrap().into();
    v["dt"] = args[5].parse::<f64>().unwrap().into();
    let steps: usize = args[6].parse().unwrap();
    if args.len() > 7 {
        v["budget"] = if args[7] == "none" {
            serde_json::Value::Null
        } else {
            args[7].parse::<u64>().unwrap().into()
        };
    }
    let scene = articula_view::parse_scene(
        &v.to_string(),
        std::path::Path::new(&args[1]),
        std::path::Path::new("models/scenes"),
    )
    .unwrap();
    let mut sim = articula_view::SceneSim::new(&scene).unwrap();
    for k in 0..steps {
        if let Err(e) = sim.step() {
            println!("fail at {k}: {e}");
            return;
        }
    }
    let qmax = sim
        .bodies
        .iter()
        .flat_map(|b| b.state.qd[6..].iter())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    println!("ok {steps} steps, max internal qd {qmax:.2}");
}
