//! `articula scene`: simulate a scene file (docs/view.md) with one scene-wide joint budget
//! spent where the camera looks; progress on stderr, one JSON summary as the last line of
//! stdout, and with `--out` PNG frames from the camera and top-down maps.

use crate::simulate::parse_count;
use crate::{print_out, CliError};
use articula_view::render::{render_map, render_view, save_png};
use articula_view::{load_scene_with, SceneSim};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
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
    /// What to do with the scene's models' bodies whose inertia no rigid body has
    /// (docs/loading.md).
    #[arg(long, value_enum, default_value_t = crate::InertiaArg::Accept)]
    pub inertia: crate::InertiaArg,
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
pub fn run(args: &SceneArgs) -> Result<(), CliError> {
    let scene = load_scene_with(&args.scene, args.inertia.into())?;
    for m in &scene.models {
        for w in &m.model.warnings {
            eprintln!("warning: {}: {w}", m.name);
        }
    }
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir)
            .map_err(|e| CliError(format!("cannot create {}: {e}", dir.display())))?;
    }
    let mut sim = SceneSim::new(&scene)?;
    let steps = args.steps;
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
    let mut in_steps = Duration::ZERO;
    let mut active_sum = 0usize;
    let mut active_max = 0usize;
    let mut frames = 0u64;
    let (mut contacts_sum, mut max_penetration) = (0usize, 0.0f64);
    let mut last = None;
    for k in 0..steps {
        if let (Some(dir), true) = (&args.out, k % args.frame_every == 0) {
            let active = last
                .as_ref()
                .map_or(0, |s: &articula_view::SceneStep| s.active_total);
            write_frame(&mut sim, dir, k, active)?;
            frames += 1;
        }
        let t0 = Instant::now();
        let result = sim.step();
        in_steps += t0.elapsed();
        let s = match result {
            Ok(s) => s,
            Err(e) => {
                bar.finish_and_clear();
                return Err(CliError(format!(
                    "step {} of {steps} (t = {:?} s): {e}",
                    k + 1,
                    sim.time()
                )));
            }
        };
        active_sum += s.active_total;
        active_max = active_max.max(s.active_total);
        contacts_sum += s.contacts;
        max_penetration = max_penetration.max(s.max_penetration);
        bar.set_message(format!("{} active joints", s.active_total));
        bar.set_position(k + 1);
        last = Some(s);
    }
    bar.finish_and_clear();
    let last = last.expect("at least one step");
    if let Some(dir) = &args.out {
        write_frame(&mut sim, dir, steps, last.active_total)?;
        frames += 1;
    }
    let mut summary = serde_json::json!({
        "scene": args.scene.display().to_string(),
        "steps": steps,
        "dt": scene.dt,
        "bodies": sim.bodies.len(),
        "dof_total": sim.dof_total(),
        "budget": scene.budget,
        "tolerance": scene.tolerance,
        "reselect_every": scene.reselect_every,
        "active_joints_mean": active_sum as f64 / steps as f64,
        "active_joints_max": active_max,
        "active_joints_last": last.active_total,
        "ms_per_step": in_steps.as_secs_f64() * 1e3 / steps as f64,
        "visible": last.classes[0],
        "occluded": last.classes[1],
        "invisible": last.classes[2],
        "links": {
            "visible": last.link_classes[0],
            "occluded": last.link_classes[1],
            "invisible": last.link_classes[2],
        },
        "weighted_error": last.total_error,
        "frames": frames,
        "out": args.out.as_ref().map(|d| d.display().to_string()),
    });
    if scene.ground.is_some() {
        summary["max_penetration_m"] = max_penetration.into();
        summary["contacts_mean"] = (contacts_sum as f64 / steps as f64).into();
    }
    print_out(&format!("{summary}\n"))
}
