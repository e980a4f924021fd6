//! `cargo xtask crowd-chart [SCENE.json] [--horizon S] [--budgets B,B,...] [--mujoco MS]
//! [--publish]`: cost per simulated second against the view-weighted error for a crowd scene
//! (default crowd200 on its floor), written to `target/articula-crowd/` (report.md, the chart
//! as SVG and PNG); `--publish` copies the chart into `docs/img/`.
//!
//! Every run starts from the scene's start, on one thread, for `--horizon` simulated seconds
//! (default 2):
//! - the **exact reference**: DCA on every character at the scene's time step
//!   ([`SceneMethod::Exact`]); its states at [`CHECKPOINTS`] are kept;
//! - **adaptive dynamics** at each budget (default 0 … 4,000 joints);
//! - the **culling baseline** ([`SceneMethod::Culling`]: characters in view exact, the others
//!   rigid);
//! - **exact DCA at 2× and 4× the time step** (a run whose state goes non-finite or whose
//!   energy grows past half the largest energy in play is reported as diverged, not plotted).
//!
//! Cost is the CPU time of the run's steps on its thread (`/proc/thread-self/schedstat`: a
//! shared host slices the wall time, not this) divided by its simulated time (ms per
//! simulated second); error is [`SceneSim::view_deviation`] against the reference's state at each
//! checkpoint (pixels at the scene's image size, and metres). The chart plots the error at
//! [`CHART_AT`] s. MuJoCo's cost for a comparable crowd (`peers/mujoco_crowd.py`) is a
//! vertical line when given (`--mujoco MS`, ms per simulated second) or measured by the
//! script through the peers' Python.

use crate::chart::{self, LogLogPlot, Series};
use articula_dca::{Method, State, Threads};
use articula_view::{LoadedScene, SceneMethod, SceneSim, ViewDeviation};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Simulated times (s) at which the runs are compared with the reference.
pub const CHECKPOINTS: [f64; 3] = [0.1, 0.5, 2.0];
/// The checkpoint the chart plots.
pub const CHART_AT: f64 = 0.5;
/// Default budgets of the adaptive runs (internal joints over the whole crowd).
pub const BUDGETS: [usize; 7] = [0, 250, 500, 1000, 2000, 3000, 4000];
/// Time-step multiples of the coarser exact runs.
pub const COARSE: [u32; 2] = [2, 4];
/// A run is called diverged when its energy grows, beyond the pushes' work, by more than this
/// fraction of the largest energy in play (`articula scene`'s default bound).
const MAX_ENERGY_GROWTH: f64 = 0.5;

const CHART: &str = "crowd_cost_vs_view_error";
/// The default scene, relative to the workspace root.
const CROWD: &str = "models/scenes/crowd200.json";

/// The arguments of `cargo xtask crowd-chart`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// The crowd scene [default: models/scenes/crowd200.json].
    #[arg(value_name = "SCENE.json")]
    pub scene: Option<PathBuf>,
    /// Simulated seconds of every run.
    #[arg(long, value_name = "S", default_value_t = 2.0, value_parser = crate::args::seconds,
          allow_negative_numbers = true)]
    pub horizon: f64,
    /// The adaptive runs' budgets (internal joints over the whole crowd).
    #[arg(long, value_name = "B,B,...", value_delimiter = ',', default_values_t = BUDGETS,
          value_parser = crate::args::whole)]
    pub budgets: Vec<usize>,
    /// MuJoCo's cost for a comparable crowd (ms per simulated second), instead of measuring it
    /// with peers/mujoco_crowd.py.
    #[arg(long, value_name = "MS_PER_SIM_S", value_parser = crate::args::cost,
          allow_negative_numbers = true)]
    pub mujoco: Option<f64>,
    /// Also copy the chart into docs/img/.
    #[arg(long)]
    pub publish: bool,
}

impl Options {
    /// The scene file: the one given, else the workspace's crowd200.
    fn scene(&self, root: &Path) -> PathBuf {
        self.scene.clone().unwrap_or_else(|| root.join(CROWD))
    }
}

/// One run of the chart.
pub struct CrowdRun {
    /// `adaptive b=2000`, `culling`, `exact DCA dt×2`, …
    pub label: String,
    /// Its time step (s).
    pub dt: f64,
    /// Wall time of its steps per simulated second (ms), one thread.
    pub cost_ms: f64,
    /// Mean internal joints simulated per step.
    pub active_mean: f64,
    /// The view-weighted error at each checkpoint reached.
    pub errors: Vec<ViewDeviation>,
    /// Why it stopped before the horizon, if it did.
    pub diverged: Option<String>,
}

/// The reference's states at each checkpoint (time, states in body order).
type Snapshots = Vec<(u64, Vec<State>)>;

/// Steps of `dt` in `t` seconds.
fn steps_in(t: f64, dt: f64) -> u64 {
    (t / dt).round() as u64
}

/// Runs `scene` by `method` for `horizon` s on one thread; at each checkpoint calls `check`
/// (the run and the checkpoint's index). Returns the cost, the mean active joints, and why it
/// diverged.
fn run_scene(
    scene: &LoadedScene,
    method: SceneMethod,
    horizon: f64,
    mut check: impl FnMut(&SceneSim, usize) -> Result<()>,
) -> Result<(f64, f64, Option<String>)> {
    let mut sim = SceneSim::new(scene)?;
    sim.set_threads(Threads::serial());
    sim.set_method(method);
    let steps = steps_in(horizon, scene.dt);
    let marks: Vec<u64> = CHECKPOINTS.iter().map(|t| steps_in(*t, scene.dt)).collect();
    let e0 = sim.energy();
    let scale =
        |e: &articula_view::SceneEnergy| e.kinetic.abs() + e.gravity.abs() + e.springs.abs();
    let (start, mut largest) = (e0.total(), scale(&e0));
    let (mut wall, mut active) = (Duration::ZERO, 0usize);
    let mut diverged = None;
    for k in 1..=steps {
        let (t, c) = (Instant::now(), thread_cpu());
        let r = sim.step();
        wall += match (c, thread_cpu()) {
            (Some(a), Some(b)) => b.saturating_sub(a),
            _ => t.elapsed(),
        };
        match r {
            Ok(s) => active += s.active_total,
            Err(e) => {
                diverged = Some(format!("step {k} (t = {:.3} s): {e}", k as f64 * scene.dt));
                break;
            }
        }
        if let Some(i) = marks.iter().position(|m| *m == k) {
            // The energy balance at the checkpoints (its cost stays out of the time).
            let e = sim.energy();
            largest = largest.max(scale(&e));
            let growth = e.total() - e.push_work - start;
            if growth.is_nan() || growth > MAX_ENERGY_GROWTH * largest {
                diverged = Some(format!(
                    "energy grew by {growth:.3e} J by t = {:.3} s",
                    k as f64 * scene.dt
                ));
                break;
            }
            check(&sim, i)?;
        }
    }
    let done = sim.steps.max(1);
    let cost = wall.as_secs_f64() * 1e3 / (done as f64 * scene.dt);
    Ok((cost, active as f64 / done as f64, diverged))
}

/// CPU time this thread has run (`/proc/thread-self/schedstat`, Linux): what a step costs
/// whatever else shares the cores (a loaded host slices the wall time, not this). `None`
/// elsewhere (then the wall time is used).
fn thread_cpu() -> Option<Duration> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: u64 = s.split_whitespace().next()?.parse().ok()?;
    Some(Duration::from_nanos(ns))
}

/// The exact reference's run: its cost and its states at the checkpoints.
fn reference(scene: &LoadedScene, horizon: f64) -> Result<(CrowdRun, Snapshots)> {
    let mut snaps = Vec::new();
    let (cost_ms, active_mean, diverged) =
        run_scene(scene, SceneMethod::Exact(Method::Dca), horizon, |sim, _| {
            snaps.push((
                sim.steps,
                sim.bodies.iter().map(|b| b.state.clone()).collect(),
            ));
            Ok(())
        })?;
    if let Some(d) = diverged {
        return Err(format!("the exact reference diverged: {d}").into());
    }
    let run = CrowdRun {
        label: "exact DCA (the reference)".into(),
        dt: scene.dt,
        cost_ms,
        active_mean,
        errors: Vec::new(),
        diverged: None,
    };
    Ok((run, snaps))
}

/// One run against the reference's snapshots.
fn measured(
    scene: &LoadedScene,
    base: &LoadedScene,
    label: String,
    method: SceneMethod,
    horizon: f64,
    snaps: &Snapshots,
) -> Result<CrowdRun> {
    let mut probe = SceneSim::new(base)?;
    probe.set_threads(Threads::serial());
    let mut errors = Vec::new();
    let (cost_ms, active_mean, diverged) = run_scene(scene, method, horizon, |sim, i| {
        let (steps, states) = &snaps[i];
        probe.steps = *steps;
        for (b, s) in probe.bodies.iter_mut().zip(states) {
            b.state.clone_from(s);
        }
        errors.push(probe.view_deviation(sim)?);
        Ok(())
    })?;
    let run = CrowdRun {
        label,
        dt: scene.dt,
        cost_ms,
        active_mean,
        errors,
        diverged,
    };
    println!(
        "  {}: {:.0} ms per simulated s, {:.0} joints a step, view error {}{}",
        run.label,
        run.cost_ms,
        run.active_mean,
        run.errors
            .iter()
            .map(|e| format!("{:.2} px / {:.2e} m at {} s", e.pixels, e.metres, e.time))
            .collect::<Vec<_>>()
            .join(", "),
        run.diverged
            .as_deref()
            .map_or(String::new(), |d| format!("; diverged: {d}"))
    );
    Ok(run)
}

pub fn run(root: &Path, o: &Options) -> Result<()> {
    let started = Instant::now();
    let scene = o.scene(root);
    let base = articula_view::load_scene(&scene)?;
    let horizon = o.horizon;
    println!("crowd chart: {} ({horizon} s, one thread)", scene.display());
    let (reference, snaps) = reference(&base, horizon)?;
    println!(
        "  {}: {:.0} ms per simulated s",
        reference.label, reference.cost_ms
    );
    let mut runs = Vec::new();
    for &b in &o.budgets {
        let mut s = base.clone();
        s.budget = Some(b);
        let label = format!("adaptive b={b}");
        runs.push(measured(
            &s,
            &base,
            label,
            SceneMethod::Adaptive,
            horizon,
            &snaps,
        )?);
    }
    runs.push(measured(
        &base,
        &base,
        "culling".into(),
        SceneMethod::Culling,
        horizon,
        &snaps,
    )?);
    for m in COARSE {
        let mut s = base.clone();
        s.dt = base.dt * m as f64;
        let exact = SceneMethod::Exact(Method::Dca);
        let label = format!("exact DCA dt×{m}");
        runs.push(measured(&s, &base, label, exact, horizon, &snaps)?);
    }
    let mujoco = match o.mujoco {
        Some(ms) => Some((ms, "given with --mujoco".to_string())),
        None => mujoco_figure(root, &scene, horizon),
    };
    let out = root.join("target/articula-crowd");
    let files = write_chart(&out, &base, &reference, &runs, mujoco.as_ref().map(|m| m.0))?;
    let text = report(
        o,
        root,
        &base,
        &reference,
        &runs,
        mujoco.as_ref(),
        started.elapsed(),
    );
    std::fs::write(out.join("report.md"), &text)?;
    println!("wrote {}", out.join("report.md").display());
    for f in &files {
        println!("wrote {}", f.display());
        if o.publish {
            let to = root
                .join("docs/img")
                .join(f.file_name().ok_or("chart without a name")?);
            std::fs::copy(f, &to)?;
            println!("copied to {}", to.display());
        }
    }
    println!("crowd chart took {:.0} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// MuJoCo's ms per simulated second for the same crowd (`peers/mujoco_crowd.py` through the
/// peers' Python), with how it ran; `None` (said on stdout) when it cannot run.
fn mujoco_figure(root: &Path, scene: &Path, horizon: f64) -> Option<(f64, String)> {
    let python = crate::bench::peers_python(root);
    let script = root.join("peers/mujoco_crowd.py");
    let out = std::process::Command::new(&python)
        .arg(&script)
        .arg(scene)
        .arg(format!("{horizon}"))
        .output();
    match out {
        Ok(o) if o.status.success() => {
            let text = String::from_utf8_lossy(&o.stdout);
            let last = text.lines().last().unwrap_or_default().to_string();
            let v: serde_json::Value = serde_json::from_str(&last).ok()?;
            let ms = v["ms_per_sim_s"].as_f64()?;
            let note = v["note"].as_str().unwrap_or_default().to_string();
            println!("  MuJoCo: {ms:.0} ms per simulated s ({note})");
            Some((ms, note))
        }
        Ok(o) => {
            println!(
                "  MuJoCo: {} failed: {}",
                script.display(),
                String::from_utf8_lossy(&o.stderr)
                    .lines()
                    .last()
                    .unwrap_or_default()
            );
            None
        }
        Err(e) => {
            println!("  MuJoCo: cannot run {}: {e}", python.display());
            None
        }
    }
}

fn error_at(run: &CrowdRun, t: f64) -> Option<&ViewDeviation> {
    run.errors.iter().find(|e| (e.time - t).abs() < 1e-6)
}

fn write_chart(
    out: &Path,
    scene: &LoadedScene,
    reference: &CrowdRun,
    runs: &[CrowdRun],
    mujoco: Option<f64>,
) -> Result<Vec<PathBuf>> {
    let mut series: Vec<Series> = Vec::new();
    let mut add = |name: &str, x: f64, y: f64, label: String| {
        if let Some(s) = series.iter_mut().find(|s| s.name == name) {
            s.points.push((x, y));
            s.labels.push(label);
        } else {
            series.push(Series {
                name: name.into(),
                points: vec![(x, y)],
                labels: vec![label],
            });
        }
    };
    for r in runs.iter().filter(|r| r.diverged.is_none()) {
        // A zero error (nothing drifted on screen) is drawn at the chart's floor.
        let Some(e) = error_at(r, CHART_AT) else {
            continue;
        };
        let y = e.pixels.max(1e-4);
        match r.label.strip_prefix("adaptive ") {
            Some(b) => add("adaptive (view-dependent)", r.cost_ms, y, b.to_string()),
            None if r.label == "culling" => add("culling baseline", r.cost_ms, y, String::new()),
            None => add(
                "exact DCA, coarser step",
                r.cost_ms,
                y,
                r.label.trim_start_matches("exact DCA ").to_string(),
            ),
        }
    }
    let mut vlines = vec![(reference.cost_ms, "exact DCA (reference)".to_string())];
    if let Some(ms) = mujoco {
        vlines.push((ms, "MuJoCo".to_string()));
    }
    chart::write_loglog(
        out,
        CHART,
        &LogLogPlot {
            title: format!(
                "{} characters on the floor: cost against view-weighted error at {CHART_AT} s",
                scene.placements.len()
            ),
            x_desc: "CPU ms per simulated second (one thread)".into(),
            y_desc: format!(
                "mean screen distance of visible links from the exact run (px, {}×{})",
                scene.image.width, scene.image.height
            ),
            series,
            lines: true,
            vlines,
        },
    )
}

fn report(
    o: &Options,
    root: &Path,
    scene: &LoadedScene,
    reference: &CrowdRun,
    runs: &[CrowdRun],
    mujoco: Option<&(f64, String)>,
    took: Duration,
) -> String {
    let file = o.scene(root);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Crowd: cost per simulated second against view-weighted error\n\n\
         `cargo xtask crowd-chart {}` ({} s simulated per run, one thread, took {:.0} s; \
         machine load average {} when written). Scene: {} characters, {} internal joints, \
         dt = {:.3} ms, image {}×{}.\n",
        file.strip_prefix(root).unwrap_or(&file).display(),
        o.horizon,
        took.as_secs_f64(),
        std::fs::read_to_string("/proc/loadavg")
            .ok()
            .and_then(|l| l.split_whitespace().next().map(str::to_string))
            .unwrap_or_default(),
        scene.placements.len(),
        scene
            .placements
            .iter()
            .map(|p| scene.models[p.model].model.nv.saturating_sub(6))
            .sum::<usize>(),
        scene.dt * 1e3,
        scene.image.width,
        scene.image.height,
    );
    let _ = writeln!(
        s,
        "The exact reference (DCA on every character, dt = {:.3} ms) costs **{:.0} ms per \
         simulated second**.{}\n",
        reference.dt * 1e3,
        reference.cost_ms,
        mujoco.map_or(String::new(), |(ms, note)| format!(
            " MuJoCo: **{ms:.0} ms per simulated second** ({note})."
        ))
    );
    let head: String = CHECKPOINTS
        .iter()
        .filter(|t| **t <= o.horizon + 1e-9)
        .map(|t| format!(" px at {t} s | m at {t} s |"))
        .collect();
    let _ = writeln!(
        s,
        "| run | dt (ms) | ms per simulated s | joints a step |{head}"
    );
    let _ = writeln!(
        s,
        "|---|---:|---:|---:|{}",
        "---:|".repeat(
            2 * CHECKPOINTS
                .iter()
                .filter(|t| **t <= o.horizon + 1e-9)
                .count()
        )
    );
    for r in runs {
        let cells: String = CHECKPOINTS
            .iter()
            .filter(|t| **t <= o.horizon + 1e-9)
            .map(|t| match error_at(r, *t) {
                Some(e) => format!(" {:.3} | {:.2e} |", e.pixels, e.metres),
                None => " — | — |".into(),
            })
            .collect();
        let _ = writeln!(
            s,
            "| {}{} | {:.3} | {:.0} | {:.0} |{cells}",
            r.label,
            r.diverged
                .as_deref()
                .map_or(String::new(), |d| format!(" (diverged: {d})")),
            r.dt * 1e3,
            r.cost_ms,
            r.active_mean
        );
    }
    let _ = writeln!(s, "\n![crowd chart]({CHART}.png)\n");
    let _ = writeln!(s, "{}", verdict(runs));
    s
}

/// Whether adaptive dynamics beats culling at equal cost, in words from the figures.
pub fn verdict(runs: &[CrowdRun]) -> String {
    let at = |r: &CrowdRun| error_at(r, CHART_AT).map(|e| e.pixels);
    let Some(cull) = runs.iter().find(|r| r.label == "culling") else {
        return String::new();
    };
    let Some(ce) = at(cull) else {
        return format!("The culling baseline stopped early: {:?}.", cull.diverged);
    };
    let adaptive: Vec<&CrowdRun> = runs
        .iter()
        .filter(|r| r.label.starts_with("adaptive") && at(r).is_some())
        .collect();
    let cheaper: Vec<String> = adaptive
        .iter()
        .filter(|r| r.cost_ms <= cull.cost_ms)
        .map(|r| {
            format!(
                "{} ({:.0} ms/s, {:.3} px)",
                r.label,
                r.cost_ms,
                at(r).unwrap_or(0.0)
            )
        })
        .collect();
    let better: Vec<String> = adaptive
        .iter()
        .filter(|r| r.cost_ms <= cull.cost_ms && at(r).unwrap_or(f64::MAX) <= ce)
        .map(|r| r.label.clone())
        .collect();
    format!(
        "Culling costs {:.0} ms per simulated second with {:.3} px of view-weighted error at \
         {CHART_AT} s. Adaptive runs at most as costly: {}. Of those, at most as far from the \
         reference on screen as culling: {}.",
        cull.cost_ms,
        ce,
        if cheaper.is_empty() {
            "none".into()
        } else {
            cheaper.join(", ")
        },
        if better.is_empty() {
            "none".into()
        } else {
            better.join(", ")
        }
    )
}
