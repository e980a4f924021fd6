//! A simulation driver: steps a model with any method — exact DCA, ABA, CRBA or adaptive —
//! with or without ground contact, and holds what a run needs around the step: the energy
//! guard, the gimbal-lock watch, the drop onto the floor, an exact reference beside an
//! adaptive run, recorders (CSV, or any [`Recorder`]), a stop flag and a progress callback.
//!
//! ```
//! use articula_adaptive::simulation::{GroundOptions, Simulation, SimulationOptions, StopReason};
//! use articula_dca::State;
//! use articula_model::{LoadOptions, Model};
//!
//! // A 1 kg ball on a floating base, dropped 0.1 m onto a floor at z = 0.
//! let urdf = r#"<robot name="ball"><link name="ball"><inertial><mass value="1"/>
//!   <inertia ixx="0.004" iyy="0.004" izz="0.004" ixy="0" ixz="0" iyz="0"/></inertial>
//!   <collision><geometry><sphere radius="0.1"/></geometry></collision></link></robot>"#;
//! let model = Model::from_urdf_str(urdf, &LoadOptions::default().with_floating_base(true))?;
//! let state = State::neutral(&model);
//! let mut ground = GroundOptions::floor(0.0);
//! ground.drop = Some(0.1);
//! let options = SimulationOptions { dt: 1e-3, ground: Some(ground), ..SimulationOptions::default() };
//! let mut sim = Simulation::new(model, state, options)?;
//! let stop = sim.run(500, &mut [], &mut Default::default());
//! assert_eq!(stop.reason, StopReason::StepsDone);
//! // At rest on the floor: the ball's centre one radius above it.
//! assert!((sim.state().q[2] - 0.1).abs() < 1e-3);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod ground;
mod guard;
mod record;
mod stop;

pub use ground::{ContactTally, GroundOptions};
pub use guard::{
    EnergyStop, EnergyWatch, GimbalWarning, GimbalWatch, DEFAULT_MAX_ENERGY_GROWTH, GIMBAL_WARNING,
};
pub use record::{csv_header, CsvRecorder, Recorder};
pub use stop::{message_time, SimulationError, StepError, Stop, StopReason};

use crate::{Adaptive, Reselection, Settings, StepReport, Threads};
use articula_dca::{forward_kinematics, step, ContactForces, Data, Integrator, Method, State};
use articula_model::Model;
use articula_spatial::DVec3;
use ground::ContactRun;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Which dynamics steps the model.
#[derive(Clone, Debug, PartialEq)]
pub enum Dynamics {
    /// An exact method (DCA, ABA, CRBA).
    Exact(Method),
    /// Adaptive dynamics under a budget or tolerance.
    Adaptive {
        /// Budget, tolerance, re-selection period.
        settings: Settings,
        /// How a re-selection finds the new hybrid body.
        reselection: Reselection,
    },
}

/// The options of a [`Simulation`].
#[derive(Clone, Debug)]
pub struct SimulationOptions {
    /// The method (default exact DCA).
    pub dynamics: Dynamics,
    /// The integrator (default semi-implicit Euler; contact needs it).
    pub integrator: Integrator,
    /// The time step (s, positive and finite; default 1e-3).
    pub dt: f64,
    /// Gravity in world coordinates (m/s²); `None` (the default) takes the model's
    /// ([`Model::gravity`]: an MJCF file's `<option gravity>`, `(0, 0, −9.81)` for a URDF).
    pub gravity: Option<DVec3>,
    /// Ground contact and joint limits (default none).
    pub ground: Option<GroundOptions>,
    /// Stop once the energy has grown, beyond the work of the joint forces, by more than this
    /// fraction of the largest energy in play ([`EnergyWatch`]; default
    /// [`DEFAULT_MAX_ENERGY_GROWTH`], `∞`: no bound). A non-finite state always stops.
    pub max_energy_growth: f64,
    /// Adaptive: also step an exact DCA run from the same start and track the largest
    /// coordinate difference ([`AdaptiveTally::error_max`]); default off.
    pub exact_reference: bool,
    /// Adaptive: the pool a large active region's per-joint sweeps run on (default: the
    /// calling thread).
    pub threads: Option<Threads>,
}

impl Default for SimulationOptions {
    fn default() -> Self {
        SimulationOptions {
            dynamics: Dynamics::Exact(Method::Dca),
            integrator: Integrator::SemiImplicitEuler,
            dt: 1e-3,
            gravity: None,
            ground: None,
            max_energy_growth: DEFAULT_MAX_ENERGY_GROWTH,
            exact_reference: false,
            threads: None,
        }
    }
}

/// Active joints over an adaptive run, and the distance to its exact reference.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AdaptiveTally {
    /// Active DOFs summed over the steps.
    pub active_sum: u64,
    /// Adaptive steps taken.
    pub steps: u64,
    /// The fewest and the most active DOFs of a step.
    pub active_min: Option<usize>,
    /// The most active DOFs of a step.
    pub active_max: usize,
    /// (step, active DOFs) at ten evenly spaced steps of [`Simulation::run`].
    pub samples: Vec<(u64, usize)>,
    /// The next step sampled.
    next_sample: u64,
    /// Sample every this many steps (0: no samples).
    sample_every: u64,
    /// With the exact reference: the largest `max |q − q_exact|` over the run.
    pub error_max: f64,
    /// With the exact reference: `max |q − q_exact|` after the last step.
    pub error_end: f64,
}

impl AdaptiveTally {
    fn add(&mut self, k: u64, report: &StepReport) {
        let active = report.active_dofs;
        self.active_sum += active as u64;
        self.steps += 1;
        self.active_min = Some(self.active_min.map_or(active, |m| m.min(active)));
        self.active_max = self.active_max.max(active);
        if self.sample_every > 0 && k >= self.next_sample {
            self.samples.push((k, active));
            self.next_sample = k + self.sample_every;
        }
    }

    fn track(&mut self, state: &State, exact: &State) {
        let e = (state.q.iter().zip(&exact.q)).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        self.error_max = self.error_max.max(e);
        self.error_end = e;
    }

    /// The mean active DOFs per step.
    pub fn active_mean(&self) -> f64 {
        self.active_sum as f64 / self.steps.max(1) as f64
    }
}

/// The adaptive method's workspace and figures.
#[derive(Clone, Debug)]
struct AdaptiveRun {
    adaptive: Adaptive,
    /// The exact DCA reference run's state, when asked for.
    reference: Option<State>,
    tally: AdaptiveTally,
}

/// Kinetic and potential energy (J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy {
    /// Kinetic energy `T`.
    pub kinetic: f64,
    /// Gravitational potential energy `V` (zero at the world origin).
    pub potential: f64,
}

/// Wall time spent in the steps (the dynamics and contact step only, not the checks).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepTiming {
    /// All steps together.
    pub in_steps: Duration,
    /// The first step (adaptive dynamics' whole-body selection).
    pub first_step: Duration,
}

/// A callback for a joint newly near gimbal lock: (step, warning).
pub type GimbalCallback<'a> = &'a mut dyn FnMut(u64, &GimbalWarning);

/// A progress callback: (steps done in this run, steps asked for).
pub type ProgressCallback<'a> = &'a mut dyn FnMut(u64, u64);

/// What a caller adds to [`Simulation::run`]: a stop flag, a progress callback, a warning
/// callback.
#[derive(Default)]
pub struct RunControl<'a> {
    /// Raised (by a signal handler, another thread), it ends the run at the next step
    /// boundary with [`StopReason::Interrupted`].
    pub stop: Option<Arc<AtomicBool>>,
    /// Called after every step done with (steps done in this run, steps asked for).
    pub progress: Option<ProgressCallback<'a>>,
    /// Called for every joint newly near gimbal lock, with the step (0: the start).
    pub gimbal: Option<GimbalCallback<'a>>,
}

/// A model in motion: the state, the method's workspaces and the run's checks and figures.
#[derive(Clone, Debug)]
pub struct Simulation {
    model: Model,
    options: SimulationOptions,
    data: Data,
    state: State,
    adaptive: Option<Box<AdaptiveRun>>,
    contact: Option<ContactRun>,
    energy: EnergyWatch,
    energy_start: Energy,
    gimbal: GimbalWatch,
    /// Joints newly near gimbal lock, with their step, not yet handed to a caller.
    warnings: Vec<(u64, GimbalWarning)>,
    /// The work of the constant joint forces so far, `∫ τ·q̇ dt` (trapezoidal per step).
    work: f64,
    /// Whether `state.tau` has a non-zero entry (the work is then tracked).
    torques: bool,
    /// `q̇` before the step (for the work).
    qd_before: Vec<f64>,
    steps_done: u64,
    stopped: Option<Stop>,
    timing: StepTiming,
}

impl Simulation {
    /// Prepares a run of `model` from `state`: checks the options, applies the ground options
    /// (rest pose, drop, the start-inside-the-floor check), builds the method's workspaces,
    /// and measures the starting energy and the gimbal watch's first look (hand its warnings
    /// on with [`Simulation::take_warnings`] or [`RunControl::gimbal`]).
    pub fn new(
        model: Model,
        mut state: State,
        options: SimulationOptions,
    ) -> Result<Simulation, SimulationError> {
        check_options(&model, &state, &options)?;
        let mut data = Data::new(&model);
        let gravity = options.gravity.unwrap_or(model.gravity);
        data.gravity = gravity;
        let contact = match &options.ground {
            Some(g) => {
                let run = ContactRun::new(&model, g.contact);
                if g.rest_pose {
                    state.q.copy_from_slice(&model.rest_q());
                }
                if let Some(h) = g.drop {
                    run.drop(&model, &mut data, &mut state, h)?;
                }
                run.check_start(&model, &mut data, &state, g.max_start_penetration)?;
                Some(run)
            }
            None => None,
        };
        let adaptive = match &options.dynamics {
            Dynamics::Exact(_) => None,
            Dynamics::Adaptive {
                settings,
                reselection,
            } => {
                let mut adaptive = Adaptive::new(&model, settings.clone());
                adaptive.data.gravity = gravity;
                adaptive.set_reselection(*reselection);
                if let Some(threads) = &options.threads {
                    adaptive.set_threads(threads.clone());
                }
                let reference = options.exact_reference.then(|| state.clone());
                Some(Box::new(AdaptiveRun {
                    adaptive,
                    reference,
                    tally: AdaptiveTally::default(),
                }))
            }
        };
        forward_kinematics(&model, &state.q, &state.qd, &mut data)?;
        let energy_start = Energy {
            kinetic: data.kinetic_energy(),
            potential: data.potential_energy(),
        };
        let energy = EnergyWatch::new(
            energy_start.kinetic,
            energy_start.potential,
            options.max_energy_growth,
        );
        let mut sim = Simulation {
            torques: state.tau.iter().any(|&x| x != 0.0),
            qd_before: state.qd.clone(),
            model,
            options,
            data,
            state,
            adaptive,
            contact,
            energy,
            energy_start,
            gimbal: GimbalWatch::default(),
            warnings: Vec::new(),
            work: 0.0,
            steps_done: 0,
            stopped: None,
            timing: StepTiming::default(),
        };
        sim.watch_gimbal();
        Ok(sim)
    }

    /// One step with its checks. After a stop other than an interruption the simulation is
    /// over: every later call returns the same stop.
    pub fn step(&mut self) -> Result<(), Stop> {
        if let Some(stop) = &self.stopped {
            return Err(stop.clone());
        }
        let k = self.steps_done + 1;
        match self.step_checked(k) {
            Ok(()) => {
                self.steps_done = k;
                self.watch_gimbal();
                Ok(())
            }
            Err(reason) => {
                let stop = Stop { step: k, reason };
                self.stopped = Some(stop.clone());
                Err(stop)
            }
        }
    }

    /// Runs up to `steps` steps: the recorders see the start, every step done and the end;
    /// the run ends early at a stop (a step that fails, the energy guard, a non-finite state, a
    /// recorder that cannot write) or when `control.stop` is raised. Returns where and why it
    /// ended. Can be called again to continue (unless the run stopped on an error).
    pub fn run(
        &mut self,
        steps: u64,
        recorders: &mut [&mut dyn Recorder],
        control: &mut RunControl,
    ) -> Stop {
        if let Some(a) = &mut self.adaptive {
            a.tally.sample_every = (steps / 10).max(1);
        }
        self.hand_warnings(control);
        let mut stop = self.record_all(recorders, |r, sim| r.begin(sim)).err();
        let mut done = 0;
        while stop.is_none() && done < steps {
            if control
                .stop
                .as_ref()
                .is_some_and(|f| f.load(Ordering::Relaxed))
            {
                stop = Some(Stop {
                    step: self.steps_done + 1,
                    reason: StopReason::Interrupted,
                });
                break;
            }
            if let Err(s) = self.step() {
                stop = Some(s);
                break;
            }
            done += 1;
            self.hand_warnings(control);
            stop = self.record_all(recorders, |r, sim| r.record(sim)).err();
            if let Some(progress) = &mut control.progress {
                progress(done, steps);
            }
        }
        let mut stop = stop.unwrap_or(Stop {
            step: self.steps_done,
            reason: StopReason::StepsDone,
        });
        for r in recorders.iter_mut() {
            if let Err(e) = r.finish(self, &stop) {
                if matches!(stop.reason, StopReason::StepsDone | StopReason::Interrupted) {
                    stop.reason = StopReason::RecorderFailed(e.to_string());
                }
            }
        }
        stop
    }

    /// Calls `f` on every recorder; the first error is a stop at the current step.
    fn record_all(
        &self,
        recorders: &mut [&mut dyn Recorder],
        f: impl Fn(&mut dyn Recorder, &Simulation) -> std::io::Result<()>,
    ) -> Result<(), Stop> {
        for r in recorders.iter_mut() {
            f(&mut **r, self).map_err(|e| Stop {
                step: self.steps_done,
                reason: StopReason::RecorderFailed(e.to_string()),
            })?;
        }
        Ok(())
    }

    /// Step `k`: the method's step, the exact reference, then the checks.
    fn step_checked(&mut self, k: u64) -> Result<(), StopReason> {
        if self.torques {
            self.qd_before.copy_from_slice(&self.state.qd);
        }
        let t0 = Instant::now();
        let result = self.advance(k);
        let took = t0.elapsed();
        self.timing.in_steps += took;
        if k == 1 {
            self.timing.first_step = took;
        }
        result.map_err(StopReason::StepFailed)?;
        self.step_reference().map_err(StopReason::ReferenceFailed)?;
        if !self
            .state
            .q
            .iter()
            .chain(&self.state.qd)
            .all(|x| x.is_finite())
        {
            return Err(StopReason::NonFiniteState);
        }
        let dt = self.options.dt;
        if self.torques {
            self.work += (self.state.tau.iter())
                .zip(self.qd_before.iter().zip(&self.state.qd))
                .map(|(t, (a, b))| t * 0.5 * (a + b) * dt)
                .sum::<f64>();
        }
        let e = self.energy();
        (self.energy.check(k, e.kinetic, e.potential, self.work)).map_err(StopReason::Energy)
    }

    /// The method's step (exact or adaptive, with or without contact).
    fn advance(&mut self, k: u64) -> Result<(), StepError> {
        let (model, state, dt) = (&self.model, &mut self.state, self.options.dt);
        let integrator = self.options.integrator;
        let method = match self.options.dynamics {
            Dynamics::Exact(m) => m,
            Dynamics::Adaptive { .. } => Method::Dca,
        };
        match (self.adaptive.as_deref_mut(), self.contact.as_mut()) {
            (None, Some(c)) => c.step(model, &mut self.data, state, method, dt),
            (None, None) => Ok(step(model, &mut self.data, state, method, integrator, dt)?),
            (Some(a), Some(c)) => {
                let report = c.step_adaptive(model, &mut a.adaptive, state, dt)?;
                a.tally.add(k, &report);
                Ok(())
            }
            (Some(a), None) => {
                let report = crate::step(model, &mut a.adaptive, state, integrator, dt)?;
                a.tally.add(k, &report);
                Ok(())
            }
        }
    }

    /// The exact DCA reference's step beside an adaptive run, and the distance to it.
    fn step_reference(&mut self) -> Result<(), StepError> {
        let Some(a) = self.adaptive.as_deref_mut() else {
            return Ok(());
        };
        let Some(exact) = &mut a.reference else {
            return Ok(());
        };
        let (model, dt) = (&self.model, self.options.dt);
        let r = match self.contact.as_mut() {
            Some(c) => c.step_reference(model, &mut self.data, exact, dt),
            None => step(
                model,
                &mut self.data,
                exact,
                Method::Dca,
                self.options.integrator,
                dt,
            )
            .map_err(StepError::from),
        };
        a.tally.track(&self.state, exact);
        r
    }

    /// Looks for joints newly near gimbal lock at the current state.
    fn watch_gimbal(&mut self) {
        let (k, warnings) = (self.steps_done, &mut self.warnings);
        (self.gimbal).check(&self.model, &self.state.q, |w| warnings.push((k, w)));
    }

    fn hand_warnings(&mut self, control: &mut RunControl) {
        if let Some(f) = &mut control.gimbal {
            for (k, w) in self.warnings.drain(..) {
                f(k, &w);
            }
        }
    }

    /// The joints newly near gimbal lock since the last call, each with its step (0: the
    /// start).
    pub fn take_warnings(&mut self) -> Vec<(u64, GimbalWarning)> {
        std::mem::take(&mut self.warnings)
    }

    /// Kinetic and potential energy of the current state (runs the kinematics into
    /// [`Simulation::data`]); NaN for a state that is not finite.
    pub fn energy(&mut self) -> Energy {
        let (q, qd) = (&self.state.q, &self.state.qd);
        if forward_kinematics(&self.model, q, qd, &mut self.data).is_err() {
            return Energy {
                kinetic: f64::NAN,
                potential: f64::NAN,
            };
        }
        Energy {
            kinetic: self.data.kinetic_energy(),
            potential: self.data.potential_energy(),
        }
    }

    /// The model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The options.
    pub fn options(&self) -> &SimulationOptions {
        &self.options
    }

    /// The current state (after the drop and the rest pose, then after each step).
    pub fn state(&self) -> &State {
        &self.state
    }

    /// The current state, to change the joint forces or external wrenches between steps
    /// (the work is tracked only when `tau` was non-zero at the start).
    pub fn state_mut(&mut self) -> &mut State {
        &mut self.state
    }

    /// The exact workspace; after a step done it holds the kinematics of the current state.
    pub fn data(&self) -> &Data {
        &self.data
    }

    /// Steps done.
    pub fn steps_done(&self) -> u64 {
        self.steps_done
    }

    /// The time of the current state, `steps_done · dt` (s).
    pub fn time(&self) -> f64 {
        self.steps_done as f64 * self.options.dt
    }

    /// The energy at the start.
    pub fn energy_start(&self) -> Energy {
        self.energy_start
    }

    /// The energy balance: start, largest drift, scale, last energy seen.
    pub fn energy_watch(&self) -> &EnergyWatch {
        &self.energy
    }

    /// The work of the joint forces so far (J).
    pub fn work(&self) -> f64 {
        self.work
    }

    /// Whether the joint forces do work (a non-zero `tau` at the start).
    pub fn has_torques(&self) -> bool {
        self.torques
    }

    /// Wall time spent in the steps.
    pub fn timing(&self) -> StepTiming {
        self.timing
    }

    /// The stop that ended the simulation, if a step failed or a check stopped it.
    pub fn stopped(&self) -> Option<&Stop> {
        self.stopped.as_ref()
    }

    /// The adaptive workspace of an adaptive run.
    pub fn adaptive(&self) -> Option<&Adaptive> {
        self.adaptive.as_ref().map(|a| &a.adaptive)
    }

    /// The active joints and reference error of an adaptive run.
    pub fn adaptive_tally(&self) -> Option<&AdaptiveTally> {
        self.adaptive.as_ref().map(|a| &a.tally)
    }

    /// The contact figures of a run with ground contact.
    pub fn contact_tally(&self) -> Option<&ContactTally> {
        self.contact.as_ref().map(|c| &c.tally)
    }

    /// The contact workspace of the exact methods (its collision model, its last forces).
    pub fn contact_data(&self) -> Option<&articula_dca::ContactData> {
        self.contact.as_ref().map(|c| &c.exact)
    }

    /// The forces of the last contact step (the hybrid body's for an adaptive run).
    pub fn contact_forces(&self) -> Option<&ContactForces> {
        self.contact.as_ref().map(|c| c.last_forces())
    }
}

/// The options' and the state's checks before a run.
fn check_options(
    model: &Model,
    state: &State,
    options: &SimulationOptions,
) -> Result<(), SimulationError> {
    let invalid = |what, detail: String| Err(SimulationError::Invalid { what, detail });
    if !(options.dt.is_finite() && options.dt > 0.0) {
        return invalid(
            "dt",
            format!("must be a positive finite time step, got {}", options.dt),
        );
    }
    if let Some(g) = options.gravity.filter(|g| !g.is_finite()) {
        return invalid("gravity", format!("must be finite, got {g}"));
    }
    if options.max_energy_growth.is_nan() || options.max_energy_growth <= 0.0 {
        return invalid(
            "max_energy_growth",
            format!(
                "must be a positive fraction (∞: no bound), got {}",
                options.max_energy_growth
            ),
        );
    }
    for (what, expected, found) in [
        ("q", model.nq, state.q.len()),
        ("qd", model.nv, state.qd.len()),
        ("tau", model.nv, state.tau.len()),
        ("f_ext", model.bodies.len(), state.f_ext.len()),
    ] {
        if expected != found {
            return Err(SimulationError::StateSize {
                what,
                expected,
                found,
            });
        }
    }
    if let Some(g) = &options.ground {
        if options.integrator != Integrator::SemiImplicitEuler {
            return Err(SimulationError::ContactNeedsEuler);
        }
        if let Some(ground) = &g.contact.ground {
            let (mu, e) = (ground.friction, ground.restitution);
            if !(ground.point.is_finite() && ground.normal.is_finite()) {
                return invalid("ground", format!("must be finite, got {}", ground.point));
            }
            if !(mu >= 0.0 && mu.is_finite()) {
                return invalid(
                    "ground.friction",
                    format!("must be a finite number ≥ 0, got {mu}"),
                );
            }
            if !(0.0..=1.0).contains(&e) {
                return invalid("ground.restitution", format!("must be in [0, 1], got {e}"));
            }
        }
        if g.max_start_penetration.is_nan() || g.max_start_penetration < 0.0 {
            return invalid(
                "max_start_penetration",
                format!("must be ≥ 0, got {}", g.max_start_penetration),
            );
        }
    }
    Ok(())
}
