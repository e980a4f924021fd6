//! The bundled humanoid dropped 0.5 m onto a floor, stepped by the library's simulation
//! driver: the drop onto the floor, ground contact with joint limits, the energy guard that
//! stops a diverging run, the gimbal-lock watch and the trajectory as CSV all come from
//! `articula::adaptive::simulation`; the program only sets options and prints. Then the same
//! body started 1 m inside the floor, which the driver refuses with its own error.
//! `cargo run --release --example drop [-- OUT.csv]`
use articula::prelude::*;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/humanoid.urdf");
    let model = Model::from_urdf_file(path, &LoadOptions::default().with_floating_base(true))?;
    let mut ground = GroundOptions::floor(0.0);
    ground.drop = Some(0.5);
    ground.rest_pose = true;
    let options = SimulationOptions {
        dt: 1e-3,
        ground: Some(ground),
        // Stop once the energy has grown by a tenth of the largest energy in play.
        max_energy_growth: 0.1,
        ..SimulationOptions::default()
    };
    let mut sim = Simulation::new(model.clone(), State::neutral(&model), options.clone())?;
    let csv = std::env::args()
        .nth(1)
        .map_or_else(|| PathBuf::from("target/drop.csv"), PathBuf::from);
    let mut recorder = CsvRecorder::create(&csv, sim.model())?;
    let mut warn = |k: u64, w: &GimbalWarning| {
        println!(
            "step {k}: {} near gimbal lock",
            model.bodies[w.body].joint_name()
        );
    };
    let mut control = RunControl {
        gimbal: Some(&mut warn),
        ..RunControl::default()
    };
    let stop = sim.run(1500, &mut [&mut recorder], &mut control);
    let (watch, tally) = (sim.energy_watch(), sim.contact_tally().unwrap());
    println!(
        "{} after {} steps ({:.2} s): base at z = {:.3} m, {:.1} contacts per step, \
         deepest penetration {:.2e} m",
        stop.reason.name(),
        sim.steps_done(),
        sim.time(),
        sim.state().q[2],
        tally.per_step(tally.contacts),
        tally.max_penetration
    );
    println!(
        "energy {:.3} J -> {:.3} J (the landing is inelastic: the guard stops growth, not \
         loss), largest |E - E0| {:.2} of the energy in play; trajectory in {}",
        watch.start,
        watch.last,
        watch.max_drift_relative(),
        csv.display()
    );

    // The same body 1 m inside the floor: refused before the first step.
    let mut inside = options;
    let ground = inside.ground.as_mut().unwrap();
    ground.drop = Some(-1.0);
    match Simulation::new(model.clone(), State::neutral(&model), inside) {
        Err(e @ SimulationError::StartsInsideFloor { .. }) => println!("refused: {e}"),
        other => return Err(format!("expected a refusal, got {:?}", other.err()).into()),
    }
    Ok(())
}
