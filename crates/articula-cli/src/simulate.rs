//! `articula simulate`: integrate the motion for a number of steps, report time per step and
//! energy drift, and optionally write the trajectory as CSV (`docs/state-format.md`).

use crate::signals::Interrupt;
use crate::watch::{parse_growth, stop_message, warn_gimbal, DEFAULT_MAX_ENERGY_GROWTH};
use crate::{load_state, print_out, CliError, DynamicsArgs};
use articula_adaptive::simulation::{
    message_time, AdaptiveTally, CsvRecorder, Dynamics, Energy, GimbalWarning, Recorder,
    RunControl, Simulation, SimulationError, SimulationOptions, StepTiming, StopReason,
};
use articula_dca::Integrator;
use articula_model::Model;
use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Arguments of `articula simulate`.
#[derive(clap::Args, Debug)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub dynamics: DynamicsArgs,
    #[command(flatten)]
    pub contact: crate::ground::GroundArgs,
    /// Number of time steps (at least 1).
    #[arg(long, value_parser = parse_steps, allow_hyphen_values = true)]
    pub steps: u64,
    /// Time step in seconds (positive, finite).
    #[arg(long, value_parser = parse_dt, allow_hyphen_values = true)]
    pub dt: f64,
    /// Time integrator.
    #[arg(long, value_enum, default_value_t = IntegratorArg::Euler)]
    pub integrator: IntegratorArg,
    /// Initial state (docs/state-format.md); without it, the neutral configuration at rest.
    /// Its `tau` is held constant during the run.
    #[arg(long, value_name = "STATE.json")]
    pub state: Option<PathBuf>,
    /// Write the trajectory as CSV: a header, then the initial state (t = 0) and one row after
    /// every step (steps + 1 rows).
    #[arg(long, value_name = "traj.csv")]
    pub out: Option<PathBuf>,
    /// `--method adaptive`: re-select the hybrid body every this many steps. Default: the
    /// balanced period ⌈2 · internal DOFs / budget⌉, at most 50 (re-selection a fraction of the time;
    /// docs/adaptive.md#defaults).
    #[arg(long, value_name = "N", value_parser = parse_steps)]
    pub reselect_every: Option<u64>,
    /// Stop (exit 2) once the energy has grown, beyond the work of the joint forces, by more
    /// than this fraction of the largest energy in play (initial, kinetic, potential change,
    /// work): the integration diverges. `inf`: no bound. A non-finite state always stops.
    #[arg(long, value_name = "FRACTION", default_value_t = DEFAULT_MAX_ENERGY_GROWTH,
          value_parser = parse_growth)]
    pub max_energy_growth: f64,
    /// Print the summary as one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub gltf: crate::gltf_out::GltfArgs,
}

/// `--integrator`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum IntegratorArg {
    /// Semi-implicit (symplectic) Euler.
    Euler,
    /// Classic fourth-order Runge–Kutta.
    Rk4,
}

impl IntegratorArg {
    fn integrator(self) -> Integrator {
        match self {
            IntegratorArg::Euler => Integrator::SemiImplicitEuler,
            IntegratorArg::Rk4 => Integrator::Rk4,
        }
    }
    fn name(self) -> &'static str {
        match self {
            IntegratorArg::Euler => "euler (semi-implicit)",
            IntegratorArg::Rk4 => "rk4",
        }
    }
}

/// Parses a count that must be at least 1 (`--steps`, `--reps`).
pub fn parse_count(s: &str) -> Result<u64, String> {
    match s.trim().parse::<i128>() {
        Ok(n) if n >= 1 && n <= u64::MAX as i128 => Ok(n as u64),
        Ok(_) => Err(format!("must be at least 1, got {s}")),
        Err(_) => Err(format!("'{s}' is not a whole number")),
    }
}

fn parse_steps(s: &str) -> Result<u64, String> {
    parse_count(s).map_err(|e| format!("the number of steps {e}"))
}

fn parse_dt(s: &str) -> Result<f64, String> {
    let dt: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if !(dt.is_finite() && dt > 0.0) {
        return Err(format!(
            "the time step must be a positive finite number of seconds, got {s}"
        ));
    }
    Ok(dt)
}

/// Runs `articula simulate` on the pool of `--threads`.
pub fn run(args: &SimulateArgs) -> Result<(), CliError> {
    let threads = crate::threads(args.dynamics.threads)?;
    threads.install(|| run_here(args, &threads))
}

/// The library's options of these arguments.
fn options(
    args: &SimulateArgs,
    model: &Model,
    threads: &articula_dca::Threads,
) -> Result<(SimulationOptions, u64), CliError> {
    let integrator = args.integrator.integrator();
    let ground = args.contact.options(model, args.state.is_some())?;
    if ground.is_some() && integrator != Integrator::SemiImplicitEuler {
        return Err(CliError(
            "--ground needs --integrator euler (contact is solved in the semi-implicit Euler step)"
                .into(),
        ));
    }
    let every = args.reselect_every.unwrap_or_else(|| {
        articula_adaptive::Settings::balanced_period(model, args.dynamics.budget)
    });
    let dynamics = match args.dynamics.method.exact() {
        Some(method) => Dynamics::Exact(method),
        None => Dynamics::Adaptive {
            settings: args.dynamics.adaptive_settings(every),
            reselection: args.dynamics.reselection.into(),
        },
    };
    let options = SimulationOptions {
        dynamics,
        integrator,
        dt: args.dt,
        gravity: args.dynamics.gravity,
        ground,
        max_energy_growth: args.max_energy_growth,
        // Adaptive: an exact DCA run beside it (from the same start) for the trajectory error.
        exact_reference: true,
        threads: Some(threads.clone()),
    };
    Ok((options, every))
}

/// A simulation that cannot start, in the words of the command line.
fn start_error(e: SimulationError, floating_base: bool) -> CliError {
    let raise = if floating_base {
        "raise it with --drop H or a state above the floor"
    } else {
        "the model is fixed to the world: put the ground lower"
    };
    match e {
        SimulationError::StartsInsideFloor {
            link,
            lowest,
            ground,
            depth,
            limit,
        } => CliError(format!(
            "the body starts inside the floor: link {link}'s lowest contact point is at z = \
             {lowest:.4} m, {depth:.4} m below the ground (--ground {ground}; at most {limit} m \
             at the start): {raise}"
        )),
        other => CliError(other.to_string()),
    }
}

/// Runs `articula simulate` on the current thread (or pool); with `--method adaptive`, a
/// hybrid step of a large active region splits its per-joint sweeps over `threads`.
fn run_here(args: &SimulateArgs, threads: &articula_dca::Threads) -> Result<(), CliError> {
    let (model, _) = args.dynamics.load()?;
    let state = load_state(args.state.as_deref(), &model)?;
    let (options, every) = options(args, &model, threads)?;
    let floating_base = model.floating_base;
    let mut sim =
        Simulation::new(model, state, options).map_err(|e| start_error(e, floating_base))?;
    let mut csv = match &args.out {
        Some(path) => Some(
            CsvRecorder::create(path, sim.model())
                .map_err(|e| CliError(format!("cannot create {}: {e}", path.display())))?,
        ),
        None => None,
    };
    for (_, w) in sim.take_warnings() {
        warn_gimbal(sim.model(), &w, "", "at t = 0");
    }
    let floor = args.contact.ground;
    let mut gltf = crate::gltf_out::sim_recorder(&args.gltf, &sim, &args.dynamics.model, floor);
    let interrupt = Interrupt::install()?;
    let steps = args.steps;
    let bar = Bar::new(steps);
    let start = Instant::now();
    let stop = {
        let model = sim.model().clone();
        let mut gimbal = |k: u64, w: &GimbalWarning| {
            let t = k as f64 * args.dt;
            warn_gimbal(
                &model,
                w,
                "",
                &format!("step {k} (t = {:?} s)", message_time(t)),
            );
        };
        let mut progress = |k: u64, _: u64| bar.tick(k, start);
        let mut control = RunControl {
            stop: Some(interrupt.flag.clone()),
            progress: Some(&mut progress),
            gimbal: Some(&mut gimbal),
        };
        let mut recorders: Vec<&mut dyn Recorder> = Vec::new();
        if let Some(csv) = &mut csv {
            recorders.push(csv);
        }
        if let Some(g) = &mut gltf {
            recorders.push(g);
        }
        sim.run(steps, &mut recorders, &mut control)
    };
    bar.finish();
    crate::gltf_out::report(gltf.as_ref());
    let elapsed = start.elapsed();
    let stopped = match &stop.reason {
        StopReason::StepsDone => None,
        StopReason::Interrupted => {
            Some((stop.step, format!("interrupted by {}", interrupt.name())))
        }
        reason => Some((stop.step, stop_message(reason))),
    };
    let summary = Summary::new(&mut sim, steps, stopped, elapsed);
    let out = if args.json {
        summary.json(args, &sim)
    } else {
        summary.text(args, &sim, every)
    };
    print_out(&out)?;
    match (&summary.stopped, &stop.reason) {
        (Some(s), StopReason::Interrupted) => {
            eprintln!("error: {s}");
            std::process::exit(interrupt.exit_code().into())
        }
        (Some(s), _) => Err(CliError(s.clone())),
        (None, _) => Ok(()),
    }
}

/// The progress bar: it appears only on a terminal, and only once the run has lasted long
/// enough to be worth watching.
struct Bar {
    bar: ProgressBar,
    show: bool,
    visible: std::cell::Cell<bool>,
    tick: u64,
}

impl Bar {
    fn new(steps: u64) -> Bar {
        let bar = ProgressBar::with_draw_target(Some(steps), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} step {pos}/{len} [{bar:40}] {percent}% {elapsed_precise} (eta {eta})",
            )
            .expect("valid progress template")
            .progress_chars("=> "),
        );
        Bar {
            bar,
            show: std::io::stderr().is_terminal() && steps >= 100,
            visible: std::cell::Cell::new(false),
            tick: (steps / 1000).max(1),
        }
    }

    fn tick(&self, k: u64, start: Instant) {
        if k.is_multiple_of(self.tick) {
            if self.show && !self.visible.get() && start.elapsed() > Duration::from_millis(500) {
                self.bar.set_draw_target(ProgressDrawTarget::stderr());
                self.visible.set(true);
            }
            self.bar.set_position(k);
        }
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// The figures of the summary, text or JSON.
struct Summary {
    /// The steps asked for and done.
    steps: u64,
    done: u64,
    /// `Some((step, why))` when the run stopped before the last step.
    stopped_at: Option<(u64, String)>,
    /// The message of the stop: `step k of N (from t = ...): why`.
    stopped: Option<String>,
    timing: StepTiming,
    /// Wall time of the whole run.
    elapsed: Duration,
    /// Kinetic and potential energy at the end (not measured after a stop).
    end: Energy,
    /// The mechanical energy at the end (at the step that stopped the run, after a stop).
    e_end: f64,
    /// `E − E₀ − W` at the end.
    drift: f64,
}

impl Summary {
    fn new(
        sim: &mut Simulation,
        steps: u64,
        stopped_at: Option<(u64, String)>,
        elapsed: Duration,
    ) -> Self {
        let last = sim.energy_watch().last;
        let end = if stopped_at.is_some() {
            Energy {
                kinetic: f64::NAN,
                potential: last,
            }
        } else {
            sim.energy()
        };
        let e_end = if stopped_at.is_some() {
            last
        } else {
            end.kinetic + end.potential
        };
        let dt = sim.options().dt;
        let stopped = stopped_at.as_ref().map(|(k, e)| {
            format!(
                "step {k} of {steps} (from t = {:?} s): {e}",
                message_time((k - 1) as f64 * dt)
            )
        });
        Summary {
            steps,
            done: sim.steps_done(),
            stopped_at,
            stopped,
            timing: sim.timing(),
            elapsed,
            end,
            e_end,
            drift: e_end - sim.energy_watch().start - sim.work(),
        }
    }

    /// µs per step over the run, and over the steady state (the first step apart: adaptive
    /// dynamics' whole-body selection).
    fn per_step_us(&self) -> (f64, f64) {
        let t = &self.timing;
        let per_step = t.in_steps.as_secs_f64() * 1e6 / self.done.max(1) as f64;
        let steady = (t.in_steps - t.first_step).as_secs_f64() * 1e6
            / self.done.saturating_sub(1).max(1) as f64;
        (per_step, steady)
    }

    fn json(&self, args: &SimulateArgs, sim: &Simulation) -> String {
        let watch = sim.energy_watch();
        let (per_step_us, steady_us) = self.per_step_us();
        let mut j = serde_json::json!({
            "model": sim.model().name,
            "dof": sim.model().nv,
            "method": args.dynamics.method.name(),
            "integrator": args.integrator.name(),
            "dt": args.dt,
            "steps": self.steps,
            "steps_done": self.done,
            "us_per_step": per_step_us,
            "first_step_ms": self.timing.first_step.as_secs_f64() * 1e3,
            "steady_us_per_step": steady_us,
            "energy_start": watch.start,
            "energy_end": self.e_end,
            "energy_drift": self.drift,
            "energy_drift_max": watch.max_drift,
            "energy_drift_max_step": watch.max_drift_step,
            "energy_drift_max_relative": watch.max_drift_relative(),
            "energy_scale": watch.scale,
            "work": sim.work(),
            "max_energy_growth": finite_or_null(args.max_energy_growth),
            "stop_reason": self.stopped,
        });
        if self.stopped.is_none() {
            j["kinetic_end"] = serde_json::json!(self.end.kinetic);
        }
        crate::ground::add_json(sim, &mut j);
        if let Some(a) = sim.adaptive_tally() {
            j["active_dofs_mean"] = serde_json::json!(a.active_mean());
            j["trajectory_error_max"] = serde_json::json!(a.error_max);
        }
        format!("{j}\n")
    }

    fn text(&self, args: &SimulateArgs, sim: &Simulation, every: u64) -> String {
        let model = sim.model();
        let (watch, done, dt) = (sim.energy_watch(), self.done, args.dt);
        let (per_step_us, steady_us) = self.per_step_us();
        let first_ms = self.timing.first_step.as_secs_f64() * 1e3;
        let base = if model.floating_base {
            "floating"
        } else {
            "fixed"
        };
        let (e0, start) = (watch.start, sim.energy_start());
        let (e1, end) = (self.e_end, self.end);
        let mut lines = vec![
            format!(
                "model        {} ({} DOF, nq = {}, {base} base)",
                model.name, model.nv, model.nq
            ),
            format!("method       {}", args.dynamics.method.name()),
            format!("integrator   {}", args.integrator.name()),
            match &self.stopped_at {
                None => format!("steps        {}", self.steps),
                Some((k, _)) => format!(
                    "steps        {done} of {} (stopped at step {k})",
                    self.steps
                ),
            },
            format!("dt           {dt:?} s (t_end = {:?} s)", done as f64 * dt),
            format!(
                "wall time    {per_step_us:.3} µs per step ({:.3} ms in steps, {:.3} ms in all)",
                self.timing.in_steps.as_secs_f64() * 1e3,
                self.elapsed.as_secs_f64() * 1e3
            ),
            if done > 1 {
                format!(
                    "first step   {first_ms:.3} ms, steady {steady_us:.3} µs per step (steps 2..{done})"
                )
            } else {
                format!("first step   {first_ms:.3} ms")
            },
            format!(
                "energy start {e0:.9e} J (kinetic {:.6e}, potential {:.6e})",
                start.kinetic, start.potential
            ),
            if self.stopped.is_none() {
                format!(
                    "energy end   {e1:.9e} J (kinetic {:.6e}, potential {:.6e})",
                    end.kinetic, end.potential
                )
            } else {
                format!("energy end   {e1:.9e} J (at the step that stopped the run)")
            },
        ];
        let rel = |x: f64| {
            if e0 != 0.0 {
                format!("{:.3e} relative to |start|", x / e0.abs())
            } else {
                "n/a relative (start energy is 0)".to_string()
            }
        };
        lines.push(format!(
            "energy drift {:.3e} J at the end (E - E0 - work), {}",
            self.drift,
            rel(self.drift)
        ));
        lines.push(format!(
            "max drift    {:.3e} J at step {} ({:.3e} of the largest energy in play, {:.3e} J)",
            watch.max_drift,
            watch.max_drift_step,
            watch.max_drift_relative(),
            watch.scale
        ));
        lines.extend(crate::ground::lines(sim, end.kinetic));
        if let Some(a) = sim.adaptive_tally() {
            lines.extend(adaptive_lines(args, a, every));
        }
        if sim.has_torques() {
            lines.push(format!(
                "work         {:.6e} J by the joint forces tau (held constant), not counted as drift",
                sim.work()
            ));
        }
        if let Some(path) = &args.out {
            lines.push(format!(
                "trajectory   {} ({} rows after the header: t = 0 and one per step done)",
                path.display(),
                done + 1
            ));
        }
        if let Some(s) = &self.stopped {
            lines.push(format!("stopped      {s}"));
        }
        let mut out = lines.join("\n");
        out.push('\n');
        out
    }
}

/// `x` as JSON, `null` for an infinite bound.
fn finite_or_null(x: f64) -> serde_json::Value {
    if x.is_finite() {
        serde_json::json!(x)
    } else {
        serde_json::Value::Null
    }
}

/// The summary lines of `--method adaptive`: the limit, the active joints over time and the
/// distance to the exact run.
fn adaptive_lines(args: &SimulateArgs, a: &AdaptiveTally, every: u64) -> Vec<String> {
    let limit = match (args.dynamics.budget, args.dynamics.tolerance) {
        (Some(b), Some(t)) => format!("budget {b} DOF, tolerance {t:e}"),
        (Some(b), None) => format!("budget {b} DOF"),
        (None, Some(t)) => format!("tolerance {t:e}"),
        (None, None) => "no limit (exact)".to_string(),
    };
    let samples: Vec<String> = (a.samples.iter())
        .map(|(k, n)| format!("{k}:{n}"))
        .collect();
    vec![
        format!(
            "adaptive     {limit}, re-selection every {every} step(s){} by {}",
            if args.reselect_every.is_none() {
                " (balanced default)"
            } else {
                ""
            },
            match args.dynamics.reselection {
                crate::ReselectionArg::Exact => "exact solve",
                crate::ReselectionArg::Caches => "caches",
            }
        ),
        format!(
            "active DOFs  mean {:.2}, min {}, max {} (step:active {})",
            a.active_mean(),
            a.active_min.unwrap_or(0),
            a.active_max,
            samples.join(" ")
        ),
        format!(
            "traj error   max |q - q_exact| = {:.3e} over the run, {:.3e} at the end (exact: DCA, same integrator and dt)",
            a.error_max, a.error_end
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dt_must_be_positive_and_finite() {
        assert_eq!(parse_dt("1e-3"), Ok(1e-3));
        for bad in ["0", "-1e-3", "inf", "NaN", "x", ""] {
            assert!(parse_dt(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn counts_are_positive_whole_numbers() {
        assert_eq!(parse_count("1"), Ok(1));
        assert_eq!(parse_count("1000000"), Ok(1_000_000));
        for bad in ["0", "-3", "1.5", "x", "", "1e3"] {
            assert!(parse_count(bad).is_err(), "{bad}");
        }
    }
}
