//! The simulation driver against hand-written stepping loops (the same calls, so the same
//! bits), and its checks: the energy guard, the stop flag, a failing recorder, the floor drop
//! and the start inside the floor.

use articula_adaptive::simulation::{
    Dynamics, EnergyStop, GroundOptions, Recorder, RunControl, Simulation, SimulationError,
    SimulationOptions, StopReason,
};
use articula_adaptive::{Adaptive, Reselection, Settings};
use articula_dca::{
    forward_kinematics, step, step_with_contact, ContactData, Data, Integrator, Method, State,
};
use articula_model::{LoadOptions, Model};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

fn model(name: &str, floating: bool) -> Model {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../models")
        .join(name);
    Model::from_urdf_file(&path, &LoadOptions::default().with_floating_base(floating)).unwrap()
}

fn swinging(model: &Model) -> State {
    let mut state = State::neutral(model);
    state.q[0] = 0.7;
    state.qd[1] = -0.3;
    state.tau[2] = 0.05;
    state
}

/// An exact run (RK4, ABA) is `articula_dca::step` repeated: the same state to the bit, the
/// work of the constant torque accumulated, and the energy balance near zero.
#[test]
fn an_exact_run_is_the_hand_written_loop() {
    let model = model("chain10.urdf", false);
    let options = SimulationOptions {
        dynamics: Dynamics::Exact(Method::Aba),
        integrator: Integrator::Rk4,
        dt: 1e-3,
        ..SimulationOptions::default()
    };
    let mut sim = Simulation::new(model.clone(), swinging(&model), options).unwrap();
    let stop = sim.run(300, &mut [], &mut RunControl::default());
    assert_eq!(stop.reason, StopReason::StepsDone);
    assert_eq!((stop.step, sim.steps_done()), (300, 300));
    let (mut data, mut state) = (Data::new(&model), swinging(&model));
    for _ in 0..300 {
        step(
            &model,
            &mut data,
            &mut state,
            Method::Aba,
            Integrator::Rk4,
            1e-3,
        )
        .unwrap();
    }
    assert_eq!(sim.state().q, state.q);
    assert_eq!(sim.state().qd, state.qd);
    assert!(sim.has_torques() && sim.work() != 0.0);
    let watch = sim.energy_watch();
    assert!(watch.max_drift_relative() < 1e-6, "{watch:?}");
    assert!((sim.time() - 0.3).abs() < 1e-15);
}

/// An adaptive run with its exact reference is `articula_adaptive::step` beside
/// `articula_dca::step`: same bits, and the reported error is the distance between them.
#[test]
fn an_adaptive_run_with_its_reference_is_the_hand_written_loop() {
    let model = model("chain30.urdf", false);
    let settings = Settings {
        budget: Some(6),
        reselect_every: 5,
        ..Settings::default()
    };
    let options = SimulationOptions {
        dynamics: Dynamics::Adaptive {
            settings: settings.clone(),
            reselection: Reselection::ExactSolve,
        },
        exact_reference: true,
        ..SimulationOptions::default()
    };
    let mut sim = Simulation::new(model.clone(), swinging(&model), options).unwrap();
    let stop = sim.run(200, &mut [], &mut RunControl::default());
    assert!(stop.reason.is_complete(), "{stop:?}");
    let mut ad = Adaptive::new(&model, settings);
    ad.set_reselection(Reselection::ExactSolve);
    let (mut data, mut state, mut exact) = (Data::new(&model), swinging(&model), swinging(&model));
    let mut err_max = 0.0f64;
    for _ in 0..200 {
        let r = articula_adaptive::step(
            &model,
            &mut ad,
            &mut state,
            Integrator::SemiImplicitEuler,
            1e-3,
        )
        .unwrap();
        assert!(r.active_dofs <= 6);
        step(
            &model,
            &mut data,
            &mut exact,
            Method::Dca,
            Integrator::SemiImplicitEuler,
            1e-3,
        )
        .unwrap();
        let e = state
            .q
            .iter()
            .zip(&exact.q)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        err_max = err_max.max(e);
    }
    assert_eq!(sim.state().q, state.q);
    let tally = sim.adaptive_tally().unwrap();
    assert_eq!(tally.error_max, err_max);
    assert!(err_max > 0.0, "a budget of 6 of 30 joints leaves an error");
    assert_eq!(tally.steps, 200);
    assert!(
        tally.active_max <= 6 && tally.samples.len() == 10,
        "{tally:?}"
    );
}

/// A floating humanoid at dt = 0.05 s diverges: the run stops on the energy guard (or on a
/// non-finite state), not after every step, and `step` keeps returning the same stop.
#[test]
fn the_energy_guard_stops_a_diverging_run() {
    let model = model("humanoid.urdf", true);
    let mut state = State::neutral(&model);
    for (i, qd) in state.qd.iter_mut().enumerate() {
        *qd = 0.5 * ((i % 5) as f64 - 2.0);
    }
    let options = SimulationOptions {
        dt: 0.05,
        gravity: Some(glam::DVec3::ZERO),
        ..SimulationOptions::default()
    };
    let mut sim = Simulation::new(model, state, options).unwrap();
    let stop = sim.run(400, &mut [], &mut RunControl::default());
    assert!(stop.step < 400, "{stop:?}");
    assert!(
        matches!(
            stop.reason,
            StopReason::Energy(EnergyStop::Diverged { .. })
                | StopReason::Energy(EnergyStop::NotFinite { .. })
                | StopReason::NonFiniteState
                | StopReason::StepFailed(_)
        ),
        "{stop:?}"
    );
    if let StopReason::Energy(EnergyStop::Diverged {
        growth,
        bound,
        scale,
    }) = stop.reason
    {
        assert!(growth > bound * scale);
    }
    assert_eq!(sim.steps_done(), stop.step - 1);
    assert_eq!(sim.step().unwrap_err(), stop);
}

/// A recorder that counts its calls and fails at a given row.
struct Counting {
    rows: u64,
    fail_at: u64,
    finished: bool,
}

impl Recorder for Counting {
    fn record(&mut self, _: &Simulation) -> std::io::Result<()> {
        self.rows += 1;
        if self.rows == self.fail_at {
            return Err(std::io::Error::other("disk full"));
        }
        Ok(())
    }
    fn finish(
        &mut self,
        _: &Simulation,
        _: &articula_adaptive::simulation::Stop,
    ) -> std::io::Result<()> {
        self.finished = true;
        Ok(())
    }
}

/// The stop flag ends a run at a step boundary (the state is the hand loop's after the steps
/// done, and the run can go on); a recorder that fails stops the run with its error; the
/// progress callback sees every step done.
#[test]
fn the_stop_flag_and_a_failing_recorder_end_a_run_between_steps() {
    let model = model("chain10.urdf", false);
    let mut sim = Simulation::new(
        model.clone(),
        swinging(&model),
        SimulationOptions::default(),
    )
    .unwrap();
    let flag = Arc::new(AtomicBool::new(false));
    let mut seen = 0;
    let stop = {
        let flag2 = flag.clone();
        let mut progress = |k: u64, _| {
            seen = k;
            if k == 37 {
                flag2.store(true, Ordering::Relaxed);
            }
        };
        let mut control = RunControl {
            stop: Some(flag.clone()),
            progress: Some(&mut progress),
            gimbal: None,
        };
        sim.run(100, &mut [], &mut control)
    };
    assert_eq!(seen, 37);
    assert_eq!(
        (stop.step, stop.reason.clone()),
        (38, StopReason::Interrupted)
    );
    let (mut data, mut state) = (Data::new(&model), swinging(&model));
    for _ in 0..37 {
        step(
            &model,
            &mut data,
            &mut state,
            Method::Dca,
            Integrator::SemiImplicitEuler,
            1e-3,
        )
        .unwrap();
    }
    assert_eq!(sim.state().q, state.q);
    // Not over: the run goes on; the recorder's failure at its 5th row (t = 0 and 4 steps)
    // stops it after step 41.
    let mut rec = Counting {
        rows: 0,
        fail_at: 5,
        finished: false,
    };
    let stop = sim.run(100, &mut [&mut rec], &mut RunControl::default());
    assert_eq!(stop.step, 41);
    assert_eq!(stop.reason, StopReason::RecorderFailed("disk full".into()));
    assert!(rec.finished);
}

/// The drop puts the lowest contact point `h` above the floor (against the contact
/// workspace's own measure), an exact contact run is `step_with_contact` repeated, and a start
/// 1 m inside the floor is refused naming the link.
#[test]
fn the_floor_drop_and_a_start_inside_the_floor() {
    let model = model("humanoid.urdf", true);
    let mut ground = GroundOptions::floor(0.2);
    ground.drop = Some(0.05);
    let options = SimulationOptions {
        ground: Some(ground.clone()),
        ..SimulationOptions::default()
    };
    let mut sim = Simulation::new(model.clone(), State::neutral(&model), options).unwrap();
    let mut contact = ContactData::new(&model);
    let mut data = Data::new(&model);
    let mut state = sim.state().clone();
    forward_kinematics(&model, &state.q, &state.qd, &mut data).unwrap();
    assert!((contact.lowest_point(&data) - 0.25).abs() < 1e-12);
    let stop = sim.run(150, &mut [], &mut RunControl::default());
    assert!(stop.reason.is_complete(), "{stop:?}");
    for _ in 0..150 {
        step_with_contact(
            &model,
            &mut data,
            &mut contact,
            &mut state,
            Method::Dca,
            1e-3,
            &ground.contact,
        )
        .unwrap();
    }
    assert_eq!(sim.state().q, state.q);
    let tally = sim.contact_tally().unwrap();
    assert!(tally.contacts > 0 && tally.steps == 150, "{tally:?}");

    ground.drop = Some(-1.0);
    let options = SimulationOptions {
        ground: Some(ground),
        ..SimulationOptions::default()
    };
    match Simulation::new(model.clone(), State::neutral(&model), options) {
        Err(SimulationError::StartsInsideFloor { depth, link, .. }) => {
            assert!((depth - 1.0).abs() < 1e-9, "{depth}");
            assert!(model.bodies.iter().any(|b| b.name == link));
        }
        other => panic!("expected a refusal, got {:?}", other.err()),
    }
    let rk4 = SimulationOptions {
        integrator: Integrator::Rk4,
        ground: Some(GroundOptions::floor(0.0)),
        ..SimulationOptions::default()
    };
    assert_eq!(
        Simulation::new(model.clone(), State::neutral(&model), rk4).err(),
        Some(SimulationError::ContactNeedsEuler)
    );
}
