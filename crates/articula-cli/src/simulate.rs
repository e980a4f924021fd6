//! `articula simulate`: integrate the motion for a number of steps, report time per step and
//! energy drift, and optionally write the trajectory as CSV (`docs/state-format.md`).

use crate::watch::{parse_growth, EnergyWatch, GimbalWatch, DEFAULT_MAX_ENERGY_GROWTH};
use crate::{load_state, print_out, CliError, DynamicsArgs};
use articula_dca::{forward_kinematics, step, Data, Integrator, Method, State};
use articula_model::Model;
use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
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

/// Kinetic and gravitational potential energy of `state` (the potential is zero at the world
/// origin).
fn energy(model: &Model, data: &mut Data, state: &State) -> (f64, f64) {
    forward_kinematics(model, &state.q, &state.qd, data);
    (data.kinetic_energy(), data.potential_energy())
}

/// The CSV header: `t`, then one column per position coordinate (`joint`, or `joint[i]` for a
/// joint with several), then the same for velocities prefixed `qd:`.
pub fn csv_header(model: &Model) -> String {
    let mut cols = vec!["t".to_string()];
    for p in model.coordinate_parts() {
        push_columns(&mut cols, "", &p.name, p.nq());
    }
    for p in model.coordinate_parts() {
        push_columns(&mut cols, "qd:", &p.name, p.nv());
    }
    cols.iter()
        .map(|c| csv_field(c))
        .collect::<Vec<_>>()
        .join(",")
}

fn push_columns(cols: &mut Vec<String>, prefix: &str, name: &str, n: usize) {
    if n == 1 {
        cols.push(format!("{prefix}{name}"));
    } else {
        cols.extend((0..n).map(|i| format!("{prefix}{name}[{i}]")));
    }
}

/// Quotes a CSV field when it holds a comma, a quote or a line break (RFC 4180).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn write_row(w: &mut impl Write, t: f64, state: &State) -> std::io::Result<()> {
    write!(w, "{t:?}")?;
    for x in state.q.iter().chain(&state.qd) {
        write!(w, ",{x:?}")?;
    }
    writeln!(w)
}

struct Csv {
    path: PathBuf,
    w: BufWriter<File>,
}

impl Csv {
    fn create(path: &Path, model: &Model) -> Result<Csv, CliError> {
        // The folder is created if needed (the README writes into target/).
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)
                .map_err(|e| CliError(format!("cannot create {}: {e}", dir.display())))?;
        }
        let file = File::create(path)
            .map_err(|e| CliError(format!("cannot create {}: {e}", path.display())))?;
        let mut csv = Csv {
            path: path.to_path_buf(),
            w: BufWriter::new(file),
        };
        let header = csv_header(model);
        csv.io(|w| writeln!(w, "{header}"))?;
        Ok(csv)
    }

    fn io(
        &mut self,
        f: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
    ) -> Result<(), CliError> {
        f(&mut self.w).map_err(|e| CliError(format!("cannot write {}: {e}", self.path.display())))
    }

    fn row(&mut self, t: f64, state: &State) -> Result<(), CliError> {
        self.io(|w| write_row(w, t, state))
    }

    fn finish(mut self) -> Result<(), CliError> {
        self.io(|w| w.flush())
    }
}

/// Runs `articula simulate` on the pool of `--threads`.
pub fn run(args: &SimulateArgs) -> Result<(), CliError> {
    let threads = crate::threads(args.dynamics.threads)?;
    threads.install(|| run_here(args, &threads))
}

/// Runs `articula simulate` on the current thread (or pool); with `--method adaptive`, a
/// hybrid step of a large active region splits its per-joint sweeps over `threads`.
fn run_here(args: &SimulateArgs, threads: &articula_dca::Threads) -> Result<(), CliError> {
    let (model, mut data) = args.dynamics.load()?;
    let mut state = load_state(args.state.as_deref(), &model)?;
    let method = args.dynamics.method;
    let integrator = args.integrator.integrator();
    let (steps, dt) = (args.steps, args.dt);
    let mut ground = args.contact.run(&model)?;
    if let Some(g) = &ground {
        if integrator != Integrator::SemiImplicitEuler {
            return Err(CliError(
                "--ground needs --integrator euler (contact is solved in the semi-implicit Euler step)"
                    .into(),
            ));
        }
        // With the joint limits enforced and no state file, the run starts in the rest pose
        // (the neutral pose moved into the limits), not against a limit it violates.
        if !args.contact.no_joint_limits && args.state.is_none() {
            state.q.copy_from_slice(&model.rest_q());
        }
        if let Some(h) = args.contact.drop {
            g.drop(&model, &mut data, &mut state, h)?;
        }
    }
    // Adaptive: the hybrid body, and an exact DCA run beside it (from the same start) for the
    // trajectory error.
    let every = args.reselect_every.unwrap_or_else(|| {
        articula_adaptive::Settings::balanced_period(&model, args.dynamics.budget)
    });
    let mut adaptive = method.exact().is_none().then(|| {
        let mut ad = args.dynamics.adaptive(&model, every);
        ad.set_threads(threads.clone());
        (ad, state.clone())
    });
    let mut active = ActiveStats::default();

    let mut csv = match &args.out {
        Some(path) => Some(Csv::create(path, &model)?),
        None => None,
    };
    if let Some(csv) = &mut csv {
        csv.row(0.0, &state)?;
    }
    let (urdf, floor) = (&args.dynamics.model, args.contact.ground);
    let mut gltf = crate::gltf_out::SimGltf::start(&args.gltf, &model, urdf, floor, dt, &state.q)?;
    let (k0, p0) = energy(&model, &mut data, &state);
    let mut watch = EnergyWatch::new(k0, p0, args.max_energy_growth);
    let mut gimbal = GimbalWatch::default();
    gimbal.check(&model, &state.q, "", || "at t = 0".to_string());
    // The work of the constant joint forces, ∫ τ·q̇ dt (trapezoidal over each step).
    let torques = state.tau.iter().any(|&x| x != 0.0);
    let mut work = 0.0;
    let mut qd_before = state.qd.clone();

    // The bar appears only on a terminal, and only once the run has lasted long enough to be
    // worth watching.
    let bar = ProgressBar::with_draw_target(Some(steps), ProgressDrawTarget::hidden());
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} step {pos}/{len} [{bar:40}] {percent}% {elapsed_precise} (eta {eta})",
        )
        .expect("valid progress template")
        .progress_chars("=> "),
    );
    let show_bar = std::io::stderr().is_terminal() && steps >= 100;
    let mut bar_visible = false;
    let tick = (steps / 1000).max(1);

    let start = Instant::now();
    let mut in_steps = Duration::ZERO;
    let mut first_step = Duration::ZERO;
    let mut done = 0;
    let mut stop: Option<(u64, String)> = None;
    for k in 1..=steps {
        if torques {
            qd_before.copy_from_slice(&state.qd);
        }
        let t0 = Instant::now();
        let result = match (adaptive.as_mut(), ground.as_mut()) {
            (None, Some(g)) => g.step(
                &model,
                &mut data,
                &mut state,
                method.exact().unwrap_or_default(),
                dt,
            ),
            (None, None) => step(
                &model,
                &mut data,
                &mut state,
                method.exact().unwrap_or_default(),
                integrator,
                dt,
            )
            .map_err(|e| e.to_string()),
            (Some((ad, _)), Some(g)) => g
                .step_adaptive(&model, ad, &mut state, dt)
                .map(|r| active.add(k, r.active_dofs, steps)),
            (Some((ad, _)), None) => {
                articula_adaptive::step(&model, ad, &mut state, integrator, dt)
                    .map(|r| active.add(k, r.active_dofs, steps))
                    .map_err(|e| e.to_string())
            }
        };
        let took = t0.elapsed();
        in_steps += took;
        if k == 1 {
            first_step = took;
        }
        let result = result.and_then(|()| match adaptive.as_mut() {
            Some((_, exact)) => {
                let r = match ground.as_mut() {
                    Some(g) => g.step_reference(&model, &mut data, exact, dt),
                    None => step(&model, &mut data, exact, Method::Dca, integrator, dt)
                        .map_err(|e| e.to_string()),
                }
                .map_err(|e| format!("exact reference: {e}"));
                active.track(&state, exact);
                r
            }
            None => Ok(()),
        });
        let result = result.and_then(|()| {
            if !state.q.iter().chain(&state.qd).all(|x| x.is_finite()) {
                return Err("the state is not finite".to_string());
            }
            if torques {
                work += state
                    .tau
                    .iter()
                    .zip(qd_before.iter().zip(&state.qd))
                    .map(|(t, (a, b))| t * 0.5 * (a + b) * dt)
                    .sum::<f64>();
            }
            let (kk, pp) = energy(&model, &mut data, &state);
            watch.check(k, kk, pp, work)
        });
        let t = k as f64 * dt;
        if let Err(e) = result {
            stop = Some((k, e));
            break;
        }
        done = k;
        gimbal.check(&model, &state.q, "", || format!("step {k} (t = {t:?} s)"));
        if let Some(csv) = &mut csv {
            csv.row(t, &state)?;
        }
        if let Some(g) = &mut gltf {
            g.step(&model, k, t, &state.q)?;
        }
        if k % tick == 0 {
            if show_bar && !bar_visible && start.elapsed() > Duration::from_millis(500) {
                bar.set_draw_target(ProgressDrawTarget::stderr());
                bar_visible = true;
            }
            bar.set_position(k);
        }
    }
    bar.finish_and_clear();
    if let Some(csv) = csv {
        csv.finish()?;
    }
    if let Some(g) = gltf {
        g.finish(&model, (done, done as f64 * dt, &state.q), stop.is_none())?;
    }
    let (k1, p1) = if stop.is_some() {
        (f64::NAN, watch.last)
    } else {
        energy(&model, &mut data, &state)
    };
    let e1 = if stop.is_some() { watch.last } else { k1 + p1 };
    let per_step_us = in_steps.as_secs_f64() * 1e6 / done.max(1) as f64;
    let drift = e1 - watch.start - work;
    let stopped = stop.as_ref().map(|(k, e)| {
        format!(
            "step {k} of {steps} (from t = {:?} s): {e}",
            (k - 1) as f64 * dt
        )
    });

    // The first step apart (adaptive dynamics' whole-body selection), then the steady state.
    let steady_us =
        (in_steps - first_step).as_secs_f64() * 1e6 / done.saturating_sub(1).max(1) as f64;
    let out = if args.json {
        let mut j = serde_json::json!({
            "model": model.name,
            "dof": model.nv,
            "method": method.name(),
            "integrator": args.integrator.name(),
            "dt": dt,
            "steps": steps,
            "steps_done": done,
            "us_per_step": per_step_us,
            "first_step_ms": first_step.as_secs_f64() * 1e3,
            "steady_us_per_step": steady_us,
            "energy_start": watch.start,
            "energy_end": e1,
            "energy_drift": drift,
            "energy_drift_max": watch.max_drift,
            "energy_drift_max_step": watch.max_drift_step,
            "energy_drift_max_relative": watch.max_drift_relative(),
            "energy_scale": watch.scale,
            "work": work,
            "max_energy_growth": finite_or_null(args.max_energy_growth),
            "stop_reason": stopped,
        });
        if stop.is_none() {
            j["kinetic_end"] = serde_json::json!(k1);
        }
        if let Some(g) = &ground {
            g.add_json(&mut j);
        }
        if adaptive.is_some() {
            j["active_dofs_mean"] = serde_json::json!(active.sum as f64 / active.n.max(1) as f64);
            j["trajectory_error_max"] = serde_json::json!(active.err_max);
        }
        format!("{j}\n")
    } else {
        let base = if model.floating_base {
            "floating"
        } else {
            "fixed"
        };
        let e0 = watch.start;
        let mut lines = vec![
            format!(
                "model        {} ({} DOF, nq = {}, {base} base)",
                model.name, model.nv, model.nq
            ),
            format!("method       {}", method.name()),
            format!("integrator   {}", args.integrator.name()),
            match &stop {
                None => format!("steps        {steps}"),
                Some((k, _)) => format!("steps        {done} of {steps} (stopped at step {k})"),
            },
            format!("dt           {dt:?} s (t_end = {:?} s)", done as f64 * dt),
            format!(
                "wall time    {per_step_us:.3} µs per step ({:.3} ms in steps, {:.3} ms in all)",
                in_steps.as_secs_f64() * 1e3,
                start.elapsed().as_secs_f64() * 1e3
            ),
            if done > 1 {
                format!(
                    "first step   {:.3} ms, steady {steady_us:.3} µs per step (steps 2..{done})",
                    first_step.as_secs_f64() * 1e3,
                )
            } else {
                format!("first step   {:.3} ms", first_step.as_secs_f64() * 1e3)
            },
            format!("energy start {e0:.9e} J (kinetic {k0:.6e}, potential {p0:.6e})"),
            if stop.is_none() {
                format!("energy end   {e1:.9e} J (kinetic {k1:.6e}, potential {p1:.6e})")
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
            "energy drift {drift:.3e} J at the end (E - E0 - work), {}",
            rel(drift)
        ));
        lines.push(format!(
            "max drift    {:.3e} J at step {} ({:.3e} of the largest energy in play, {:.3e} J)",
            watch.max_drift,
            watch.max_drift_step,
            watch.max_drift_relative(),
            watch.scale
        ));
        if let Some(g) = &ground {
            lines.extend(g.lines(k1));
        }
        if adaptive.is_some() {
            lines.extend(active.lines(
                args.dynamics.budget,
                args.dynamics.tolerance,
                every,
                args.reselect_every.is_none(),
                args.dynamics.reselection,
            ));
        }
        if torques {
            lines.push(format!(
                "work         {work:.6e} J by the joint forces tau (held constant), not counted as drift"
            ));
        }
        if let Some(path) = &args.out {
            lines.push(format!(
                "trajectory   {} ({} rows after the header: t = 0 and one per step done)",
                path.display(),
                done + 1
            ));
        }
        if let Some(s) = &stopped {
            lines.push(format!("stopped      {s}"));
        }
        let mut out = lines.join("\n");
        out.push('\n');
        out
    };
    print_out(&out)?;
    match stopped {
        Some(s) => Err(CliError(s)),
        None => Ok(()),
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

/// Active joints over time and the distance to the exact run (`--method adaptive`).
#[derive(Default)]
struct ActiveStats {
    sum: u64,
    n: u64,
    min: Option<usize>,
    max: usize,
    /// (step, active DOFs) at ten evenly spaced steps.
    samples: Vec<(u64, usize)>,
    next_sample: u64,
    every: u64,
    err_max: f64,
    err_end: f64,
}

impl ActiveStats {
    fn add(&mut self, k: u64, active: usize, steps: u64) {
        self.every = (steps / 10).max(1);
        self.sum += active as u64;
        self.n += 1;
        self.min = Some(self.min.map_or(active, |m| m.min(active)));
        self.max = self.max.max(active);
        if k >= self.next_sample {
            self.samples.push((k, active));
            self.next_sample = k + self.every.max(1);
        }
    }

    /// Trajectory error: the largest coordinate difference `max |q − q_exact|`.
    fn track(&mut self, state: &State, exact: &State) {
        let e = state
            .q
            .iter()
            .zip(&exact.q)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        self.err_max = self.err_max.max(e);
        self.err_end = e;
    }

    fn lines(
        &self,
        budget: Option<usize>,
        tolerance: Option<f64>,
        every: u64,
        balanced: bool,
        how: crate::ReselectionArg,
    ) -> Vec<String> {
        let mean = self.sum as f64 / self.n.max(1) as f64;
        let limit = match (budget, tolerance) {
            (Some(b), Some(t)) => format!("budget {b} DOF, tolerance {t:e}"),
            (Some(b), None) => format!("budget {b} DOF"),
            (None, Some(t)) => format!("tolerance {t:e}"),
            (None, None) => "no limit (exact)".to_string(),
        };
        let samples: Vec<String> = self
            .samples
            .iter()
            .map(|(k, a)| format!("{k}:{a}"))
            .collect();
        vec![
            format!(
                "adaptive     {limit}, re-selection every {every} step(s){} by {}",
                if balanced { " (balanced default)" } else { "" },
                match how {
                    crate::ReselectionArg::Exact => "exact solve",
                    crate::ReselectionArg::Caches => "caches",
                }
            ),
            format!(
                "active DOFs  mean {mean:.2}, min {}, max {} (step:active {})",
                self.min.unwrap_or(0),
                self.max,
                samples.join(" ")
            ),
            format!(
                "traj error   max |q - q_exact| = {:.3e} over the run, {:.3e} at the end (exact: DCA, same integrator and dt)",
                self.err_max, self.err_end
            ),
        ]
    }
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

    #[test]
    fn csv_fields_are_quoted_when_needed() {
        assert_eq!(csv_field("joint1"), "joint1");
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("a\"b"), "\"a\"\"b\"");
    }
}
