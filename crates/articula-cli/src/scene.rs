//! `articula scene`: simulate a scene file (docs/view.md) with one scene-wide joint budget
//! spent where the camera looks; progress on stderr, one JSON summary as the last line of
//! stdout, and with `--out` PNG frames from the camera and top-down maps.

use crate::signals::Interrupt;
use crate::simulate::parse_count;
use crate::watch::{energy_stop_message, parse_growth, warn_gimbal, DEFAULT_MAX_ENERGY_GROWTH};
use crate::{print_out, CliError};
use articula_adaptive::simulation::{message_time, EnergyWatch, GimbalWatch};
use articula_view::render::{render_map, render_view, save_png};
use articula_view::{SceneMethod, SceneOptions, SceneSim};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Arguments of `articula scene`.
#[derive(clap::Args, Debug)]
pub struct SceneArgs {
    /// The scene file (JSON; model paths are relative to it).
    pub scene: PathBuf,
    /// Number of time steps (at least 1).
    #[arg(long, value_parser = parse_steps, allow_hyphen_values = true)]
    pub steps: u64,
    /// Write `frame_NNNNN.png` (the camera's view) and `map_NNNNN.png` (top-down map) into this
    /// folder (created if needed).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// With `--out`: write a frame every this many steps (the first and the last are always
    /// written).
    #[arg(long, default_value_t = 1, value_parser = parse_every, allow_hyphen_values = true)]
    pub frame_every: u64,
    /// How the scene's models' inertias are loaded (docs/loading.md).
    #[command(flatten)]
    pub inertia: crate::InertiaArgs,
    /// Stop (exit 2, after the summary of the steps done) once the scene's energy (kinetic,
    /// gravity, pose springs) has grown, beyond the work of the pushes, by more than this
    /// fraction of the largest energy in play; checked after every step. `inf`: no bound.
    #[arg(long, value_name = "FRACTION", default_value_t = DEFAULT_MAX_ENERGY_GROWTH,
          value_parser = parse_growth)]
    pub max_energy_growth: f64,
    /// Refuse (exit 2) a scene whose estimated memory exceeds this (bytes, or with a unit:
    /// `512MiB`, `8GiB`, `2GB`); the estimate is made before any body is placed.
    #[arg(long, value_name = "SIZE", default_value = "4GiB", value_parser = parse_size)]
    pub memory_limit: u64,
    /// Threads the bodies' steps are spread over (default: one per core); the global joint
    /// budget stays one choice. The scene's state is the same bits for any count.
    #[arg(long, value_name = "N", value_parser = crate::parse_threads, allow_hyphen_values = true)]
    pub threads: Option<usize>,
    /// Put a floor at height Z (m) under every character (friction 1, no restitution),
    /// replacing the scene's `ground` block (docs/contact.md#scenes).
    #[arg(long, value_name = "Z", allow_hyphen_values = true, value_parser = parse_finite)]
    pub ground: Option<f64>,
    /// Replace the scene's gravity by (0, 0, GZ) m/s² (with `--ground`: `--gravity -9.81`
    /// stands a zero-gravity crowd on the floor).
    #[arg(long, value_name = "GZ", allow_hyphen_values = true, value_parser = parse_finite)]
    pub gravity: Option<f64>,
    /// Replace the scene's joint budget: the internal degrees of freedom simulated per step,
    /// over every character (0: every character one rigid body).
    #[arg(long, value_name = "N", value_parser = crate::parse_budget)]
    pub budget: Option<usize>,
    /// How every character is stepped: `adaptive` (the scene's joint budget spent where the
    /// camera looks), or the exact reference by `dca`, `aba` or `crba` on every character
    /// (every joint moving; no camera, no budget) for comparison (docs/view.md#exact-reference).
    #[arg(long, value_enum, default_value_t = crate::MethodArg::Adaptive)]
    pub method: crate::MethodArg,
    /// The culling baseline instead of adaptive dynamics: characters in view (visible or
    /// occluded) with every joint free, the others rigid; no budget (docs/view.md#culling).
    #[arg(long)]
    pub culling: bool,
    /// Run the exact reference by this method beside the scene (same start, same springs,
    /// pushes and floor) and report the view-weighted error against it after 0.1, 0.5 and
    /// 2 s and at the last step (docs/view.md#view-error). Doubles the work, more or less.
    #[arg(long, value_name = "METHOD", value_parser = parse_reference)]
    pub reference: Option<articula_dca::Method>,
    #[command(flatten)]
    pub gltf: crate::gltf_out::GltfArgs,
}

/// An exact method by `--method`'s names.
fn parse_reference(s: &str) -> Result<articula_dca::Method, String> {
    use clap::ValueEnum;
    crate::MethodArg::from_str(s, false)
        .ok()
        .and_then(crate::MethodArg::exact)
        .ok_or_else(|| format!("unknown reference '{s}' (dca, aba or crba)"))
}

fn parse_finite(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("{s} is not a finite number")),
    }
}

/// Parses a memory size: a whole number of bytes, or a number with a unit (`KiB`, `MiB`, `GiB`,
/// `TiB` powers of 1,024; `KB`, `MB`, `GB`, `TB` powers of 1,000).
pub fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let split = t.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(t.len());
    let (num, unit) = (t[..split].trim(), t[split..].trim());
    let scale: f64 = match unit.to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "kib" => 1024.0,
        "mib" => 1024f64.powi(2),
        "gib" => 1024f64.powi(3),
        "tib" => 1024f64.powi(4),
        "kb" => 1e3,
        "mb" => 1e6,
        "gb" => 1e9,
        "tb" => 1e12,
        _ => {
            return Err(format!(
                "unknown unit '{unit}' in '{s}' (KiB, MiB, GiB, TiB, KB, MB, GB, TB)"
            ))
        }
    };
    let x: f64 = num
        .parse()
        .map_err(|_| format!("'{s}' is not a size (a number of bytes, or 512MiB, 8GiB, ...)"))?;
    let bytes = x * scale;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!(
            "the memory limit must be at least 1 byte, got '{s}'"
        ));
    }
    Ok(bytes as u64)
}

fn parse_steps(s: &str) -> Result<u64, String> {
    parse_count(s).map_err(|e| format!("the number of steps {e}"))
}

fn parse_every(s: &str) -> Result<u64, String> {
    parse_count(s).map_err(|e| format!("the frame period {e}"))
}

fn write_frame(
    sim: &mut SceneSim,
    dir: &std::path::Path,
    index: u64,
    active_total: usize,
) -> Result<(), CliError> {
    let cam = sim.scene.camera.at(sim.time());
    let (w, h) = (sim.scene.image.width, sim.scene.image.height);
    let mut groups = Vec::new();
    let bodies = sim.frame(&mut groups);
    let view = render_view(&cam, w, h, &bodies, active_total)?;
    save_png(&view, &dir.join(format!("frame_{index:05}.png")))?;
    let map = render_map(&cam, h.max(400), &bodies)?;
    save_png(&map, &dir.join(format!("map_{index:05}.png")))?;
    Ok(())
}

/// Runs `articula scene`.
/// The checked flags' scene: the file with the command line's overrides (its models'
/// warnings printed, `--out` created), and the exact method `--method` asks for, if any.
fn load(
    args: &SceneArgs,
) -> Result<(articula_view::LoadedScene, Option<articula_dca::Method>), CliError> {
    let exact = args.method.exact();
    if exact.is_some() && args.budget.is_some() {
        return Err(CliError("--budget needs --method adaptive".to_string()));
    }
    if args.culling && (exact.is_some() || args.budget.is_some()) {
        return Err(CliError(
            "--culling replaces adaptive dynamics: it takes neither --method nor --budget"
                .to_string(),
        ));
    }
    let mut scene = SceneOptions::default()
        .with_model_options(args.inertia.options()?)
        .with_memory_limit(args.memory_limit)
        .load(&args.scene)?;
    if let Some(height) = args.ground {
        scene.ground = Some(articula_view::GroundSpec::at(height));
    }
    if let Some(gz) = args.gravity {
        scene.gravity = articula_spatial::DVec3::new(0.0, 0.0, gz);
    }
    if let Some(budget) = args.budget {
        scene.budget = Some(budget);
    }
    for m in &scene.models {
        for w in &m.model.warnings {
            eprintln!("warning: {}: {w}", m.name);
        }
    }
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir)
            .map_err(|e| CliError(format!("cannot create {}: {e}", dir.display())))?;
    }
    Ok((scene, exact))
}

pub fn run(args: &SceneArgs) -> Result<(), CliError> {
    let (scene, exact) = load(args)?;
    let mut sim = SceneSim::new(&scene)?;
    sim.set_threads(crate::threads(args.threads)?);
    if let Some(m) = exact {
        sim.set_method(SceneMethod::Exact(m));
    } else if args.culling {
        sim.set_method(SceneMethod::Culling);
    }
    let mut reference = ViewReference::start(&scene, args.reference, sim.threads())?;
    let steps = args.steps;
    let bar = progress_bar(steps);
    let mut gltf = crate::gltf_out::SceneGltf::start(&args.gltf, &mut sim)?;
    let e0 = sim.energy();
    let mut watch = EnergyWatch::new(e0.kinetic, e0.gravity + e0.springs, args.max_energy_growth);
    let mut gimbal = vec![GimbalWatch::default(); scene.models.len()];
    let check_every = scene.reselect_every as u64;
    let mut tally = Tally::default();
    let mut last = None;
    let mut done = 0u64;
    let mut stop: Option<String> = None;
    let interrupt = Interrupt::install()?;
    for k in 0..steps {
        let at = |e: &str| {
            format!(
                "step {} of {steps} (t = {:?} s): {e}",
                k + 1,
                message_time((k + 1) as f64 * scene.dt)
            )
        };
        if interrupt.flag.load(Ordering::Relaxed) {
            stop = Some(at(&format!("interrupted by {}", interrupt.name())));
            break;
        }
        if let (Some(dir), true) = (&args.out, k % args.frame_every == 0) {
            let active = last
                .as_ref()
                .map_or(0, |s: &articula_view::SceneStep| s.active_total);
            if let Err(CliError(e)) = write_frame(&mut sim, dir, k, active) {
                stop = Some(at(&e));
                break;
            }
            tally.frames += 1;
        }
        let t0 = Instant::now();
        let result = sim.step();
        tally.in_steps += t0.elapsed();
        let checked = match result {
            Ok(s) => {
                tally.add(&s);
                bar.set_message(format!("{} active joints", s.active_total));
                bar.set_position(k + 1);
                last = Some(s);
                // The energy every step (a divergence is caught within one step); the
                // composed joints at re-selections.
                let gimbal_too = (k + 1) % check_every == 0 || k + 1 == steps;
                check_scene(&mut sim, &mut watch, &mut gimbal, k + 1, gimbal_too)
            }
            Err(e) => Err(e.to_string()),
        };
        if let Err(e) = checked {
            stop = Some(at(&e));
            break;
        }
        done = k + 1;
        if let Err(CliError(e)) = reference.step(&mut sim, done == steps) {
            stop = Some(at(&e));
            break;
        }
        if let Some(g) = &mut gltf {
            g.step(&mut sim, done)?;
        }
    }
    bar.finish_and_clear();
    if let Some(g) = gltf {
        g.finish(&mut sim, done, stop.is_none())?;
    }
    if let (Some(dir), None) = (&args.out, &stop) {
        let active = last.as_ref().map_or(0, |s| s.active_total);
        match write_frame(&mut sim, dir, steps, active) {
            Ok(()) => tally.frames += 1,
            Err(CliError(e)) => stop = Some(format!("the last frame: {e}")),
        }
    }
    let last = last.unwrap_or_default();
    let run = RunEnd {
        done,
        stop: &stop,
        exact: exact.is_some(),
    };
    let summary = summary(args, &scene, &sim, &tally, &last, &watch, &reference, run);
    print_out(&format!("{summary}\n"))?;
    match stop {
        Some(s) if interrupt.flag.load(Ordering::Relaxed) => {
            eprintln!("error: {s}");
            std::process::exit(interrupt.exit_code().into())
        }
        Some(s) => Err(CliError(s)),
        None => Ok(()),
    }
}

/// The counters of a scene run, summed over its steps.
#[derive(Default)]
struct Tally {
    /// Wall time inside `SceneSim::step`.
    in_steps: Duration,
    active_sum: usize,
    active_max: usize,
    /// Frames written to `--out`.
    frames: u64,
    contacts_sum: usize,
    max_penetration: f64,
    solves_sum: usize,
    capped_sum: usize,
    rows_sum: usize,
    sweeps_sum: usize,
}

impl Tally {
    fn add(&mut self, s: &articula_view::SceneStep) {
        self.active_sum += s.active_total;
        self.active_max = self.active_max.max(s.active_total);
        self.contacts_sum += s.contacts;
        self.max_penetration = self.max_penetration.max(s.max_penetration);
        self.solves_sum += s.contact_solves;
        self.capped_sum += s.contact_capped;
        self.rows_sum += s.contact_rows;
        self.sweeps_sum += s.contact_sweeps;
    }
}

/// How a scene run ended: the steps done, why it stopped early (if it did), whether it
/// ran an exact method.
#[derive(Clone, Copy)]
struct RunEnd<'a> {
    done: u64,
    stop: &'a Option<String>,
    exact: bool,
}

/// The progress bar of a run of `steps` steps, drawn only on a terminal.
fn progress_bar(steps: u64) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(steps), ProgressDrawTarget::hidden());
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} step {pos}/{len} [{bar:40}] {percent}% {elapsed_precise} (eta {eta}) {msg}",
        )
        .expect("valid progress template")
        .progress_chars("=> "),
    );
    if std::io::stderr().is_terminal() {
        bar.set_draw_target(ProgressDrawTarget::stderr());
    }
    bar
}

/// The JSON summary `articula scene` prints at the end of a run.
#[allow(clippy::too_many_arguments)]
fn summary(
    args: &SceneArgs,
    scene: &articula_view::LoadedScene,
    sim: &SceneSim,
    tally: &Tally,
    last: &articula_view::SceneStep,
    watch: &EnergyWatch,
    reference: &ViewReference,
    run: RunEnd,
) -> serde_json::Value {
    let e_end = watch.last;
    let mut summary = serde_json::json!({
        "scene": args.scene.display().to_string(),
        "steps": run.done,
        "steps_requested": args.steps,
        "dt": scene.dt,
        "method": if args.culling { "culling" } else { args.method.name() },
        "bodies": sim.bodies.len(),
        "threads": sim.threads().count(),
        "dof_total": sim.dof_total(),
        "budget": scene.budget,
        "tolerance": scene.tolerance,
        "reselect_every": scene.reselect_every,
        "active_joints_mean": tally.active_sum as f64 / run.done.max(1) as f64,
        "active_joints_max": tally.active_max,
        "active_joints_last": last.active_total,
        "ms_per_step": tally.in_steps.as_secs_f64() * 1e3 / run.done.max(1) as f64,
        "visible": last.classes[0],
        "occluded": last.classes[1],
        "invisible": last.classes[2],
        "links": {
            "visible": last.link_classes[0],
            "occluded": last.link_classes[1],
            "invisible": last.link_classes[2],
        },
        "weighted_error": last.total_error,
        "energy_start": watch.start,
        "energy_end": e_end,
        "energy_drift_max": watch.max_drift,
        "energy_drift_max_step": watch.max_drift_step,
        "energy_drift_max_relative": watch.max_drift_relative(),
        "frames": tally.frames,
        "out": args.out.as_ref().map(|d| d.display().to_string()),
        "stop_reason": run.stop,
    });
    if run.exact {
        // No camera, no selection: every joint moves, nothing is left unselected.
        for key in [
            "budget",
            "tolerance",
            "reselect_every",
            "visible",
            "occluded",
            "invisible",
            "links",
        ] {
            summary[key] = serde_json::Value::Null;
        }
    }
    if let Some(r) = &reference.method {
        summary["reference"] = r.name().into();
        summary["view_error"] = reference.json();
    }
    if scene.ground.is_some() {
        summary["max_penetration_m"] = tally.max_penetration.into();
        summary["contacts_mean"] = (tally.contacts_sum as f64 / run.done.max(1) as f64).into();
        summary["contact_capped_fraction"] =
            (tally.capped_sum as f64 / tally.solves_sum.max(1) as f64).into();
        summary["contact_rows_mean"] =
            (tally.rows_sum as f64 / tally.solves_sum.max(1) as f64).into();
        summary["contact_sweeps_mean"] =
            (tally.sweeps_sum as f64 / tally.solves_sum.max(1) as f64).into();
    }
    summary
}

/// The exact reference run beside the scene (`--reference`) and the view-weighted errors
/// measured against it.
struct ViewReference<'s> {
    method: Option<articula_dca::Method>,
    sim: Option<SceneSim<'s>>,
    /// `(t, error)` at each of [`VIEW_ERROR_TIMES`] reached and at the last step.
    errors: Vec<articula_view::ViewDeviation>,
}

/// Simulated times (s) at which `--reference` measures the view-weighted error.
const VIEW_ERROR_TIMES: [f64; 3] = [0.1, 0.5, 2.0];

impl<'s> ViewReference<'s> {
    fn start(
        scene: &'s articula_view::LoadedScene,
        method: Option<articula_dca::Method>,
        threads: &articula_dca::Threads,
    ) -> Result<Self, CliError> {
        let sim = match method {
            Some(m) => {
                let mut sim = SceneSim::new(scene)?;
                sim.set_threads(threads.clone());
                sim.set_method(SceneMethod::Exact(m));
                Some(sim)
            }
            None => None,
        };
        Ok(ViewReference {
            method,
            sim,
            errors: Vec::new(),
        })
    }

    /// One step of the reference (after the scene's); the error at the checkpoints and at
    /// the `last` step.
    fn step(&mut self, run: &mut SceneSim, last: bool) -> Result<(), CliError> {
        let Some(r) = &mut self.sim else {
            return Ok(());
        };
        r.step()
            .map_err(|e| CliError(format!("the exact reference: {e}")))?;
        let dt = r.scene.dt;
        let at_mark = VIEW_ERROR_TIMES
            .iter()
            .any(|t| (t / dt).round() as u64 == r.steps);
        if at_mark || last {
            let d = r.view_deviation(run)?;
            if self.errors.last().is_none_or(|e| e.time != d.time) {
                self.errors.push(d);
            }
        }
        Ok(())
    }

    fn json(&self) -> serde_json::Value {
        self.errors
            .iter()
            .map(|e| {
                serde_json::json!({
                    "t": e.time,
                    "pixels": e.pixels,
                    "metres": e.metres,
                    "max_pixels": e.max_pixels,
                    "visible_links": e.visible_links,
                    "occluded_links": e.occluded_links,
                })
            })
            .collect()
    }
}

/// The checks after a step: the energy balance (every step), and with `gimbal_too` (at
/// re-selections) every character's composed joints against gimbal lock (one warning per joint
/// of each model, naming the first character that neared it).
fn check_scene(
    sim: &mut SceneSim,
    watch: &mut EnergyWatch,
    gimbal: &mut [GimbalWatch],
    k: u64,
    gimbal_too: bool,
) -> Result<(), String> {
    let e = sim.energy();
    let t = sim.time();
    for (b, placement) in sim.bodies.iter().zip(&sim.scene.placements) {
        if !gimbal_too {
            break;
        }
        let model = &sim.scene.models[b.model].model;
        let who = format!("body '{}': ", placement.name);
        gimbal[b.model].check(model, &b.state.q, |w| {
            warn_gimbal(
                model,
                &w,
                &who,
                &format!("step {k} (t = {:?} s)", message_time(t)),
            )
        });
    }
    (watch.check(k, e.kinetic, e.gravity + e.springs, e.push_work))
        .map_err(|e| energy_stop_message(&e))
}

#[cfg(test)]
mod tests {
    use super::parse_size;
    use articula_view::DEFAULT_SCENE_MEMORY_LIMIT;

    #[test]
    fn sizes_take_binary_and_decimal_units() {
        // The default of --memory-limit is the library's.
        assert_eq!(parse_size("4GiB"), Ok(DEFAULT_SCENE_MEMORY_LIMIT));
        assert_eq!(parse_size("512 MiB"), Ok(512 << 20));
        assert_eq!(parse_size("2GB"), Ok(2_000_000_000));
        assert_eq!(parse_size("1000"), Ok(1000));
        assert_eq!(parse_size("1.5KiB"), Ok(1536));
        for bad in ["", "0", "-1GiB", "4 parsecs", "GiB", "inf"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }
}
