use std::time::Instant;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene = articula_view::load_scene(&args[1]).unwrap();
    let steps: u64 = args[2].parse().unwrap();
    let mut sim = articula_view::SceneSim::new(&scene);
    let (mut tr, mut nr, mut tn, mut nn) = (0.0, 0, 0.0, 0);
    for _ in 0..steps {
        let t = Instant::now();
        let s = sim.step().unwrap();
        let e = t.elapsed().as_secs_f64() * 1e3;
        if s.reselected {
            tr += e;
            nr += 1
        } else {
            tn += e;
            nn += 1
        }
    }
    println!(
        "reselect steps: {:.2} ms ({nr}); other steps: {:.3} ms ({nn})",
        tr / nr as f64,
        tn / nn.max(1) as f64
    );
    // Exact DCA on every body for comparison.
    let model = &scene.models[0].model;
    let mut data = articula_dca::Data::new(model);
    let mut states: Vec<_> = sim.bodies.iter().map(|b| b.state.clone()).collect();
    let t = Instant::now();
    for _ in 0..20 {
        for s in &mut states {
            articula_dca::step(
                model,
                &mut data,
                s,
                articula_dca::Method::Dca,
                articula_dca::Integrator::SemiImplicitEuler,
                scene.dt,
            )
            .unwrap();
        }
    }
    println!(
        "exact DCA all bodies: {:.3} ms/step",
        t.elapsed().as_secs_f64() * 1e3 / 20.0
    );
}
