//! `cargo xtask bench [--quick] [--peers]`: speed against model size, error against time per
//! step, the seeds' table, peers beside us. Writes `target/articula-bench/report.md` and its
//! charts (SVG and PNG).
//!
//! - Time per forward-dynamics call of DCA, ABA and CRBA on chains of 10 … 10,000 links
//!   (`articula_testkit::chain`) and the humanoid, on `State::random(model, 42, 1.0)` — the
//!   criterion benches' state. Quick mode times in-process ([`crate::timing`], in [`PASSES`]
//!   passes over the table); full mode runs `cargo bench -p articula-benches --bench dynamics`
//!   and reads criterion's medians.
//! - Growth from 1,000 to 10,000 links of DCA and ABA, the two lengths interleaved in one
//!   process ([`crate::growth`]: ratio of the minima and per-round ratios).
//! - Error against time per step on the 300-link chain: (a) the acceleration-metric error
//!   `Σ (q̈ − q̈_exact)²` of one step, `q̈_exact` from the double-double reference
//!   ([`articula_testkit::reference`]); (b) the deviation `‖q(1 s) − q_ref(1 s)‖` from an RK4 reference with a
//!   ten times smaller step.
//! - The seeds' table (adaptive budgets × external forces on the 300-link chain).
//! - `--peers`: Pinocchio's ABA and MuJoCo's `mj_forward` through `peers/peers.py`.

use crate::chart::{self, HeatMap, LogLogPlot, Series};
use crate::solver::{Runner, Solver, ADAPTIVE_BUDGETS};
use crate::timing;
use crate::trajectory::{self, metric_error, Study};
use articula_dca::SplitMix64;
use articula_dca::{Integrator, State};
use articula_model::{LoadOptions, Model};
use articula_testkit::Dd;
use articula_testkit::ReferenceModel;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Chain sizes of the scaling chart (the criterion benches' sizes).
pub const CHAIN_SIZES: [usize; 7] = [10, 30, 100, 300, 1000, 3000, 10_000];
/// Columns of the seeds' table (Redon, Galoppo, Lin 2005): numbers of external forces on the
/// 300-link chain; its rows are the adaptive budgets [`ADAPTIVE_BUDGETS`] and full DCA.
pub const SEED_FORCES: [usize; 6] = [1, 5, 10, 20, 50, 250];
/// Passes over the speed table (each cell gets `1 / PASSES` of its budget in each).
pub const PASSES: usize = 4;
/// The seed of the benchmarked state (as in the criterion benches and `articula bench`).
pub const SEED: u64 = 42;
/// Why the adaptive rows are empty.
pub const ADAPTIVE_PENDING: &str = "Adaptive dynamics (`articula-adaptive`, issue 4) does not \
exist yet: its rows, points and cells are **pending** — nothing is shown for them until the \
crate lands and is added as a `Solver` variant in `xtask/src/solver.rs`.";

/// The arguments of `cargo xtask bench`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// Sample in-process (minutes) instead of running criterion.
    #[arg(long)]
    pub quick: bool,
    /// Also time Pinocchio and MuJoCo (peers/peers.py, through the peers' Python).
    #[arg(long)]
    pub peers: bool,
    /// Also copy the charts into docs/img/ and the report to docs/bench-report.md (for
    /// docs/performance.md and the README).
    #[arg(long)]
    pub publish: bool,
    /// Also write the exact methods' one-step errors into docs/performance.md between its
    /// markers (they do not depend on the machine).
    #[arg(long)]
    pub write_docs: bool,
}

/// One row of the speed table: a model and the time per call of each method (µs).
struct SpeedRow {
    model: String,
    links: usize,
    times: BTreeMap<String, f64>,
}

/// A peer's µs per call, its q̈ by joint name (when comparable) and a note on how it ran.
type PeerResult = (f64, Option<BTreeMap<String, f64>>, String);

/// Result of the peers' script.
#[derive(Default)]
struct Peers {
    /// Why they did not run, when they did not.
    skipped: Option<String>,
    versions: Vec<(String, String)>,
    /// (model, peer) → (µs per call, q̈ by joint name, note)
    results: BTreeMap<(String, String), PeerResult>,
    /// (model, peer) → peak resident memory of the process that ran it (MiB).
    rss: BTreeMap<(String, String), f64>,
    errors: Vec<String>,
}

pub fn run(root: &Path, opts: &Options) -> Result<()> {
    let started = Instant::now();
    let out = root.join("target/articula-bench");
    std::fs::create_dir_all(out.join("urdf"))?;
    let budget = if opts.quick {
        Duration::from_millis(250)
    } else {
        Duration::from_secs(1)
    };

    // Models: the chains (written out as URDF for the peers) and the humanoid.
    let mut models: Vec<(String, PathBuf, Model)> = Vec::new();
    for n in CHAIN_SIZES {
        let path = out.join("urdf").join(format!("chain{n}.urdf"));
        std::fs::write(&path, articula_testkit::chain_urdf(n))?;
        models.push((format!("chain{n}"), path, articula_testkit::chain(n)));
    }
    let hpath = root.join("models/humanoid.urdf");
    let humanoid = Model::from_urdf_file(&hpath, &LoadOptions::default())?;
    models.push(("humanoid".into(), hpath, humanoid));

    let mut rows = speed_rows(root, opts, &models, budget)?;

    let growths = growth_pairs(opts);

    // 2. Accuracy on the 300-link chain.
    let chain300 = articula_testkit::chain(300);
    let acc_state = State::random(&chain300, SEED, 1.0);
    let reference = ReferenceModel::new(&chain300)?;
    let exact: Vec<f64> = reference
        .aba::<Dd>(
            &acc_state.q,
            &acc_state.qd,
            &acc_state.tau,
            &acc_state.f_ext,
        )
        .iter()
        .map(|x| x.to_f64())
        .collect();
    // label, µs, Σ(Δq̈)²; adaptive dynamics twice: its first step (the whole-body selection
    // of a one-state call) and its steady step re-selecting at every step.
    let mut accel: Vec<(String, f64, f64)> = Vec::new();
    for solver in Solver::all() {
        let mut r = Runner::new(&chain300, solver);
        let qdd = r.forward(&acc_state)?.to_vec();
        let t = speed_of(&rows, "chain300", &solver.label());
        let e = metric_error(&qdd, &exact);
        match solver {
            Solver::Adaptive { .. } => {
                let start = trajectory::crumpled_start(&chain300, solver);
                let (_, steady) = trajectory::steady_time(
                    &chain300,
                    solver,
                    Integrator::SemiImplicitEuler,
                    1e-3,
                    &start,
                    100,
                    3,
                )?;
                accel.push((format!("{} first step", solver.label()), t, e));
                accel.push((format!("{} steady step", solver.label()), steady, e));
            }
            Solver::Exact(_) => accel.push((solver.label(), t, e)),
        }
    }
    println!("  one-step errors: {accel:?}");
    if opts.write_docs {
        let mut table = String::from(
            "| method | one-step error `Σ (q̈ − q̈_exact)²`, 300-link chain |\n| --- | ---: |\n",
        );
        for solver in Solver::EXACT {
            if let Some((_, _, e)) = accel.iter().find(|(l, _, _)| *l == solver.label()) {
                table.push_str(&format!("| {} | {e:.1e} |\n", solver.label()));
            }
        }
        crate::docs::write_between_markers(&root.join("docs/performance.md"), "bench", &table)?;
    }
    let traj = trajectory::study(&chain300)?;
    println!(
        "  trajectory reference check {:.3e} rad",
        traj.reference_check
    );

    let seeds = seeds_table(&chain300, budget)?;

    // 4. Peers.
    let peers = if opts.peers {
        run_peers(root, &out, &models, &acc_state, &chain300, budget)
    } else {
        Peers {
            skipped: Some("not requested (run `cargo xtask bench --peers`)".into()),
            ..Peers::default()
        }
    };
    for ((model, peer), (t, _, _)) in &peers.results {
        println!("  {model:<10} {peer:<18} {t:>12.2} µs");
        if let Some(row) = rows.iter_mut().find(|r| &r.model == model) {
            row.times.insert(peer.clone(), *t);
        }
    }
    for (model, peer) in peers.results.keys() {
        if model == "chain300" {
            if let Some((t, Some(qdd), _)) = peers.results.get(&(model.clone(), peer.clone())) {
                let v: Vec<f64> = (1..=300)
                    .map(|i| qdd.get(&format!("joint{i}")).copied().unwrap_or(f64::NAN))
                    .collect();
                accel.push((peer.clone(), *t, metric_error(&v, &exact)));
            }
        }
    }

    // Charts and report.
    let mut files = Vec::new();
    files.extend(chart_speed(&out, &rows)?);
    files.extend(chart_accel(&out, &accel)?);
    let pin_traj = if opts.peers {
        pinocchio_trajectories(root, &out, &chain300, &traj)
    } else {
        Vec::new()
    };
    files.extend(chart_traj(&out, &traj, &pin_traj)?);
    files.extend(chart_seeds(&out, &seeds)?);
    let report = report(
        opts,
        &rows,
        &growths,
        &accel,
        (&traj, &pin_traj),
        &seeds,
        &peers,
        &files,
        started.elapsed(),
    );
    let path = out.join("report.md");
    std::fs::write(&path, report)?;
    println!("wrote {}", path.display());
    for f in &files {
        println!("wrote {}", f.display());
    }
    if opts.publish {
        let img = root.join("docs/img");
        std::fs::create_dir_all(&img)?;
        for f in &files {
            let to = img.join(f.file_name().ok_or("chart without a file name")?);
            std::fs::copy(f, &to)?;
            println!("copied to {}", to.display());
        }
    }
    if opts.publish {
        // The report beside the charts, for docs/performance.md to link.
        let mut text = std::fs::read_to_string(&path)?;
        for f in &files {
            let name = f.file_name().and_then(|n| n.to_str()).unwrap_or_default();
            text = text.replace(&format!("]({name})"), &format!("](img/{name})"));
        }
        let to = root.join("docs/bench-report.md");
        std::fs::write(&to, text)?;
        println!("copied the report to {}", to.display());
    }
    println!("bench took {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// Part 1 of the bench: the time per call of every solver on every model, from criterion
/// (full mode's exact methods) or sampled in-process in PASSES passes over the table.
fn speed_rows(
    root: &Path,
    opts: &Options,
    models: &[(String, PathBuf, Model)],
    budget: Duration,
) -> Result<Vec<SpeedRow>> {
    let mut rows: Vec<SpeedRow> = Vec::new();
    let criterion = if opts.quick {
        None
    } else {
        Some(run_criterion(root)?)
    };
    // The cells timed in-process (all of them in quick mode, the adaptive ones in full mode)
    // are timed in PASSES passes over the whole table, each with a share of the budget, and
    // each cell's time is the median over the batches of all passes: a shared host's slow
    // phases last seconds, and timing a cell in one window would let a phase set it alone
    // (the 10,000-link chain's cells, ~60 calls, fit in a quarter of a second).
    let mut times: Vec<BTreeMap<String, f64>> = vec![BTreeMap::new(); models.len()];
    // (model index, solver, per-call times of all passes' batches)
    let mut pending: Vec<(usize, Solver, Vec<f64>)> = Vec::new();
    for (mi, (name, _, model)) in models.iter().enumerate() {
        for solver in Solver::all() {
            if !solver.runs_at(model.nv) {
                continue;
            }
            let from_criterion = criterion
                .as_ref()
                .filter(|_| matches!(solver, Solver::Exact(_)));
            match from_criterion {
                Some(c) => {
                    let t = c
                        .get(&(name.clone(), solver.label()))
                        .copied()
                        .ok_or_else(|| {
                            format!("criterion has no estimate for {} on {name}", solver.label())
                        })?;
                    times[mi].insert(solver.label(), t);
                }
                None => pending.push((mi, solver, Vec::new())),
            }
        }
    }
    for pass in 0..PASSES {
        println!("  speed: pass {}/{PASSES}", pass + 1);
        for (mi, solver, samples) in &mut pending {
            let model = &models[*mi].2;
            let state = State::random(model, SEED, 1.0);
            let mut r = Runner::new(model, *solver);
            let per_pass = timing::MIN_BATCHES.div_ceil(PASSES);
            let s = timing::sample(budget / PASSES as u32, per_pass, || {
                r.forward(black_box(&state)).map(|q| {
                    black_box(q[0]);
                })
            })?;
            samples.extend(s.times_us);
        }
    }
    for (mi, solver, mut samples) in pending {
        let t = timing::median(&mut samples);
        println!(
            "  {:<10} {:<5} {:>12.2} µs  (median of {} batches over {PASSES} passes)",
            models[mi].0,
            solver.label(),
            t,
            samples.len()
        );
        times[mi].insert(solver.label(), t);
    }
    for ((name, _, model), times) in models.iter().zip(times) {
        rows.push(SpeedRow {
            model: name.clone(),
            links: model.bodies.len(),
            times,
        });
    }

    Ok(rows)
}

/// Part 1b of the bench: growth from 1,000 to 10,000 links, the two lengths interleaved in
/// one process (the table's medians time each size apart, minutes apart in full mode, and a
/// shared host's phases move them by more than the cache effects being measured).
fn growth_pairs(opts: &Options) -> Vec<crate::growth::Growth> {
    let rounds = if opts.quick { 400 } else { 1000 };
    let mut growths = Vec::new();
    for method in [articula_dca::Method::Dca, articula_dca::Method::Aba] {
        let t0 = Instant::now();
        let g = crate::growth::measure(method, 1000, 10_000, rounds, |r| {
            if (1..4).any(|k| r == rounds * k / 4) {
                println!("  growth {method:?} 1000 -> 10000: round {r}/{rounds}");
            }
        });
        println!(
            "  growth {method:?} 1000 -> 10000: minima {:.1} / {:.1} µs, {:.2}× (per-round median {:.2}×), {:.1} s",
            g.short_us,
            g.long_us,
            g.ratio(),
            g.per_round_quantile(0.5),
            t0.elapsed().as_secs_f64()
        );
        growths.push(g);
    }

    growths
}

/// Part 3 of the bench, the seeds' table: a row per adaptive budget (pending while the
/// solver does not exist), then full DCA.
fn seeds_table(chain300: &Model, budget: Duration) -> Result<SeedsTable> {
    let mut seeds: SeedsTable = Vec::new();
    let rows_solvers = ADAPTIVE_BUDGETS
        .iter()
        .map(|&b| (format!("adaptive {b}"), Solver::adaptive(b)))
        .chain(ADAPTIVE_BUDGETS.iter().map(|&b| {
            (
                format!("adaptive {b} caches"),
                Some(Solver::Adaptive {
                    budget: b,
                    every: 1,
                    caches: true,
                }),
            )
        }))
        .chain(std::iter::once((
            "full DCA (300)".to_string(),
            Some(Solver::Exact(articula_dca::Method::Dca)),
        )));
    for (label, solver) in rows_solvers {
        let mut cells = Vec::new();
        for &k in &SEED_FORCES {
            cells.push(match solver {
                Some(solver) => {
                    let t = time_seeds_cell(chain300, solver, k, budget / 2)?;
                    println!("  seeds' table: {label} with {k} forces {t:.1} µs");
                    Some(t)
                }
                None => None,
            });
        }
        seeds.push((label, cells));
    }

    Ok(seeds)
}

fn speed_of(rows: &[SpeedRow], model: &str, label: &str) -> f64 {
    rows.iter()
        .find(|r| r.model == model)
        .and_then(|r| r.times.get(label).copied())
        .unwrap_or(f64::NAN)
}

/// The seeds' table: per row (label), per number of forces, µs per step (`None`: pending).
type SeedsTable = Vec<(String, Vec<Option<f64>>)>;

/// Steps of each timed run of a seeds' table cell (the first, a whole-body selection, apart).
const SEEDS_RUN: usize = 100;

/// A seeds' table cell: steady time per semi-implicit Euler step (µs; dt = 1 ms) of `solver`
/// with `k` external forces (1 N, random directions, at the origins of `k` bodies spread along
/// the chain, as world wrenches from the start's poses) on the crumpled chain falling from
/// rest ([`trajectory::crumpled_start`]): runs of [`SEEDS_RUN`] continuing steps re-selecting
/// at every step (adaptive), the first step of each run (the whole-body selection) left out,
/// the minimum over the runs that fit in `budget` (see [`trajectory::steady_time`]).
fn time_seeds_cell(model: &Model, solver: Solver, k: usize, budget: Duration) -> Result<f64> {
    let mut state = trajectory::crumpled_start(model, Solver::Exact(articula_dca::Method::Dca));
    let n = model.bodies.len();
    let mut rng = SplitMix64(7);
    let mut data = articula_dca::Data::new(model);
    articula_dca::forward_kinematics(model, &state.q, &state.qd, &mut data).unwrap();
    for j in 0..k {
        let body = ((j * n) / k + n / (2 * k)).min(n - 1);
        let d = glam::DVec3::new(
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
        )
        .normalize();
        state.f_ext[body] = data.point_force(body, glam::DVec3::ZERO, d);
    }
    let t0 = Instant::now();
    let mut runs = Vec::new();
    while runs.len() < 3 || (t0.elapsed() < budget && runs.len() < 51) {
        let (_, steady) = trajectory::steady_time(
            model,
            solver,
            Integrator::SemiImplicitEuler,
            1e-3,
            &state,
            SEEDS_RUN,
            1,
        )?;
        runs.push(steady);
    }
    Ok(runs.into_iter().fold(f64::INFINITY, f64::min))
}

/// Runs criterion and reads the median of each benchmark: group `chain` (ids
/// `<method>/<links>`) and `humanoid` (`<method>/34dof`).
fn run_criterion(root: &Path) -> Result<BTreeMap<(String, String), f64>> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    println!("running: cargo bench -p articula-benches --bench dynamics");
    let status = Command::new(cargo)
        .current_dir(root)
        .args(["bench", "-p", "articula-benches", "--bench", "dynamics"])
        .status()?;
    if !status.success() {
        return Err(format!("cargo bench failed ({status})").into());
    }
    read_criterion(&root.join("target/criterion"))
}

/// Reads criterion's median estimates (ns) under `dir` as µs, keyed by (model, METHOD).
fn read_criterion(dir: &Path) -> Result<BTreeMap<(String, String), f64>> {
    let mut out = BTreeMap::new();
    for (group, label) in CHAIN_SIZES
        .iter()
        .map(|n| ("chain", n.to_string()))
        .chain(std::iter::once(("humanoid", "34dof".to_string())))
    {
        for m in ["dca", "aba", "crba"] {
            let f = dir
                .join(group)
                .join(m)
                .join(&label)
                .join("new/estimates.json");
            let Ok(text) = std::fs::read_to_string(&f) else {
                continue;
            };
            let v: serde_json::Value = serde_json::from_str(&text)?;
            let ns = v["median"]["point_estimate"]
                .as_f64()
                .ok_or_else(|| format!("{}: no median", f.display()))?;
            let model = if group == "chain" {
                format!("chain{label}")
            } else {
                "humanoid".into()
            };
            out.insert((model, m.to_uppercase()), ns / 1000.0);
        }
    }
    Ok(out)
}

/// MuJoCo's `mj_forward` factorises the dense mass matrix of a chain: 87 ms at 1000 links on
/// this machine class and about n³ beyond, so larger chains are not run.
const MUJOCO_MAX_DOF: usize = 1000;

/// The Python that has the peers: `$ARTICULA_PEERS_PYTHON`, else `target/peers-venv`.
pub(crate) fn peers_python(root: &Path) -> PathBuf {
    if let Some(p) = std::env::var_os("ARTICULA_PEERS_PYTHON") {
        return PathBuf::from(p);
    }
    root.join("target/peers-venv/bin/python")
}

fn run_peers(
    root: &Path,
    out: &Path,
    models: &[(String, PathBuf, Model)],
    acc_state: &State,
    chain300: &Model,
    budget: Duration,
) -> Peers {
    let python = peers_python(root);
    if !python.exists() {
        return Peers {
            skipped: Some(format!(
                "no Python at {} (create it with `python3 -m venv target/peers-venv && \
                 target/peers-venv/bin/pip install pin mujoco`, or set ARTICULA_PEERS_PYTHON)",
                python.display()
            )),
            ..Peers::default()
        };
    }
    // Each model at the benchmarked state; the 300-link chain at the accuracy state (the same
    // seed, so the same numbers).
    let mut specs = Vec::new();
    for (name, path, model) in models {
        let s = if name == "chain300" {
            debug_assert_eq!(model.nv, chain300.nv);
            acc_state.clone()
        } else {
            State::random(model, SEED, 1.0)
        };
        let mut joints = serde_json::Map::new();
        for (_, part) in model.joint_parts() {
            joints.insert(
                part.name.clone(),
                serde_json::json!([
                    s.q[part.q_offset],
                    s.qd[part.v_offset],
                    s.tau[part.v_offset]
                ]),
            );
        }
        let skip: Vec<&str> = if model.nv > MUJOCO_MAX_DOF {
            vec!["mujoco"]
        } else {
            vec![]
        };
        specs.push(serde_json::json!({"name": name, "urdf": path, "joints": joints, "skip": skip}));
    }
    let config =
        serde_json::json!({"budget_s": budget.as_secs_f64(), "passes": PASSES, "models": specs});
    let cfg = out.join("peers-config.json");
    if let Err(e) = std::fs::write(&cfg, config.to_string()) {
        return Peers {
            skipped: Some(format!("cannot write {}: {e}", cfg.display())),
            ..Peers::default()
        };
    }
    println!("running peers with {}", python.display());
    let output = Command::new(&python)
        .arg(root.join("peers/peers.py"))
        .arg(&cfg)
        .output();
    let output = match output {
        Ok(o) if o.status.success() => o,
        Ok(o) => {
            return Peers {
                skipped: Some(format!(
                    "peers/peers.py failed ({}): {}",
                    o.status,
                    String::from_utf8_lossy(&o.stderr).trim()
                )),
                ..Peers::default()
            }
        }
        Err(e) => {
            return Peers {
                skipped: Some(format!("cannot run {}: {e}", python.display())),
                ..Peers::default()
            }
        }
    };
    let v: serde_json::Value = match serde_json::from_slice(&output.stdout) {
        Ok(v) => v,
        Err(e) => {
            return Peers {
                skipped: Some(format!("peers/peers.py printed no JSON: {e}")),
                ..Peers::default()
            }
        }
    };
    let mut p = Peers::default();
    if let Some(vs) = v["versions"].as_object() {
        p.versions = vs
            .iter()
            .map(|(k, v)| (k.clone(), v.as_str().unwrap_or("?").to_string()))
            .collect();
    }
    for r in v["results"].as_array().into_iter().flatten() {
        let model = r["model"].as_str().unwrap_or("?").to_string();
        let peer = r["peer"].as_str().unwrap_or("?").to_string();
        let t = r["us_per_call"].as_f64().unwrap_or(f64::NAN);
        let qdd = r["qdd"].as_object().map(|m| {
            m.iter()
                .map(|(k, v)| (k.clone(), v.as_f64().unwrap_or(f64::NAN)))
                .collect()
        });
        let note = r["note"].as_str().unwrap_or("").to_string();
        if let Some(m) = r["peak_rss_mib"].as_f64() {
            p.rss.insert((model.clone(), peer.clone()), m);
        }
        p.results.insert((model, peer), (t, qdd, note));
    }
    p.errors = v["errors"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|e| e.as_str().unwrap_or("?").to_string())
        .collect();
    if p.results.is_empty() {
        p.skipped = Some(format!("no peer ran: {}", p.errors.join("; ")));
    }
    p
}

/// Pinocchio's `aba` with a plain integrator in Python (`peers/pin_trajectory.py`) over the
/// trajectory study's runs: one series per integrator, `(ms per simulated s, deviation from
/// the study's reference)` labelled by the time step. Empty (said on stdout) when the peers'
/// Python cannot run it.
fn pinocchio_trajectories(root: &Path, out: &Path, chain300: &Model, traj: &Study) -> Vec<Series> {
    let start = trajectory::crumpled_start(chain300, Solver::Exact(articula_dca::Method::Dca));
    let runs: Vec<(&str, f64)> = trajectory::EXACT_DTS
        .iter()
        .map(|dt| ("euler", *dt))
        .chain(trajectory::RK4_DTS.iter().map(|dt| ("rk4", *dt)))
        .collect();
    let spec = serde_json::json!({"q0": start.q, "horizon": trajectory::HORIZON, "runs": runs});
    let spec_path = out.join("pin_trajectory.json");
    let run = || -> Result<String> {
        std::fs::write(&spec_path, spec.to_string())?;
        let o = Command::new(peers_python(root))
            .arg(root.join("peers/pin_trajectory.py"))
            .arg(out.join("urdf/chain300.urdf"))
            .arg(&spec_path)
            .output()?;
        if !o.status.success() {
            return Err(String::from_utf8_lossy(&o.stderr).into_owned().into());
        }
        Ok(String::from_utf8_lossy(&o.stdout).into_owned())
    };
    let text = match run() {
        Ok(t) => t,
        Err(e) => {
            println!("  Pinocchio trajectories did not run: {e}");
            return Vec::new();
        }
    };
    let mut series: Vec<Series> = Vec::new();
    for line in text.lines() {
        let Ok(v) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        let (Some(dt), Some(us)) = (v["dt"].as_f64(), v["us_per_step"].as_f64()) else {
            continue;
        };
        let q: Vec<f64> = v["q"]
            .as_array()
            .map(|a| a.iter().filter_map(|x| x.as_f64()).collect())
            .unwrap_or_default();
        let deviation = if q.len() == traj.q_ref.len() {
            trajectory::norm_diff(&q, &traj.q_ref)
        } else {
            f64::NAN
        };
        let name = match v["integrator"].as_str() {
            Some("rk4") => "Pinocchio aba + RK4 (Python)",
            _ => "Pinocchio aba + semi-implicit Euler (Python)",
        };
        println!("  {name} dt {dt:.2e}: {us:.1} µs/step, deviation {deviation:.3e} rad");
        let (x, label) = (us * 1e-3 / dt, format!("{} ms", dt * 1e3));
        match series.iter_mut().find(|s| s.name == name) {
            Some(s) => {
                s.points.push((x, deviation));
                s.labels.push(label);
            }
            None => series.push(Series {
                name: name.into(),
                points: vec![(x, deviation)],
                labels: vec![label],
            }),
        }
    }
    series
}

// ---------------------------------------------------------------------------------------------
// Charts

const SPEED_CHART: &str = "time_vs_links";
const ACCEL_CHART: &str = "error_accel_vs_time";
const TRAJ_CHART: &str = "error_trajectory_vs_time";
const ACCUM_CHART: &str = "error_accumulated_vs_time";
const SEEDS_CHART: &str = "seeds_table";

fn chart_speed(out: &Path, rows: &[SpeedRow]) -> Result<Vec<PathBuf>> {
    let mut labels: Vec<String> = Vec::new();
    for r in rows {
        for k in r.times.keys() {
            if !labels.contains(k) {
                labels.push(k.clone());
            }
        }
    }
    labels.sort_by_key(|l| order(l));
    let series = labels
        .iter()
        .map(|l| Series {
            name: l.clone(),
            points: rows
                .iter()
                .filter(|r| r.model.starts_with("chain"))
                .filter_map(|r| r.times.get(l).map(|t| (r.links as f64, *t)))
                .collect(),
            labels: vec![],
        })
        .collect();
    chart::write_loglog(
        out,
        SPEED_CHART,
        &LogLogPlot {
            title: "Forward dynamics of an n-link pendulum chain: time per step".into(),
            x_desc: "links n".into(),
            y_desc: "time per forward-dynamics call (µs)".into(),
            series,
            lines: true,
            vlines: vec![],
        },
    )
}

/// Table and legend order: ours first, then the peers.
fn order(label: &str) -> usize {
    [
        "DCA",
        "ABA",
        "CRBA",
        "Pinocchio ABA",
        "Pinocchio ABA (WORLD)",
        "MuJoCo mj_forward",
    ]
    .iter()
    .position(|l| *l == label)
    // Adaptive budgets after the exact methods and peers, in budget order.
    .or_else(|| {
        label
            .strip_prefix("adaptive b=")
            .and_then(|b| b.parse::<usize>().ok())
            .map(|b| 100 + b)
    })
    .unwrap_or(usize::MAX)
}

fn chart_accel(out: &Path, accel: &[(String, f64, f64)]) -> Result<Vec<PathBuf>> {
    // Adaptive dynamics as two lines over the budgets (first step, steady step), the others
    // as single points.
    let mut series: Vec<Series> = Vec::new();
    for (l, t, e) in accel {
        let grouped = ["first step", "steady step"].into_iter().find_map(|kind| {
            l.strip_suffix(&format!(" {kind}"))
                .and_then(|m| m.strip_prefix("adaptive "))
                .map(|b| (format!("adaptive, {kind}"), b.to_string()))
        });
        match grouped {
            Some((name, budget)) => {
                if let Some(sr) = series.iter_mut().find(|sr| sr.name == name) {
                    sr.points.push((*t, *e));
                    sr.labels.push(budget);
                } else {
                    series.push(Series {
                        name,
                        points: vec![(*t, *e)],
                        labels: vec![budget],
                    });
                }
            }
            None => series.push(Series {
                name: l.clone(),
                points: vec![(*t, *e)],
                labels: vec![format!("{e:.1e}")],
            }),
        }
    }
    chart::write_loglog(
        out,
        ACCEL_CHART,
        &LogLogPlot {
            title: "300-link chain, one step (dt = 1 ms): acceleration-metric error vs time".into(),
            x_desc: "time per call or step (µs); adaptive: first step and steady step apart".into(),
            y_desc: "Σ (qdd − qdd_exact)²  ((rad/s²)²)".into(),
            series,
            lines: false,
            vlines: vec![],
        },
    )
}

/// The study's runs as chart series: one line per exact method and integrator over the time
/// steps, one per adaptive re-selection policy and integrator over the budgets (the runs
/// re-selecting through the caches stay in the table only); `y` picks the error. x is the
/// cost per simulated second (ms).
fn study_series(traj: &Study, y: impl Fn(&trajectory::Run) -> Option<f64>) -> Vec<Series> {
    let mut series: Vec<Series> = Vec::new();
    for r in &traj.runs {
        let Some(e) = y(r) else { continue };
        let integ = trajectory::integrator_name(r.integrator);
        let (name, label) = match &r.policy {
            Some(p) if p.contains("caches") => continue,
            Some(p) => (
                if p.starts_with("balanced") {
                    format!("adaptive + {integ}, balanced")
                } else {
                    format!("adaptive + {integ}, {p}")
                },
                format!("b={}", r.method.trim_start_matches("adaptive b=")),
            ),
            None => (
                format!("{} + {integ}", r.method),
                format!("{} ms", r.dt * 1e3),
            ),
        };
        let x = r.ms_per_sim_s();
        if let Some(sr) = series.iter_mut().find(|sr| sr.name == name) {
            sr.points.push((x, e));
            sr.labels.push(label);
        } else {
            series.push(Series {
                name,
                points: vec![(x, e)],
                labels: vec![label],
            });
        }
    }
    series
}

fn chart_traj(out: &Path, traj: &Study, peers: &[Series]) -> Result<Vec<PathBuf>> {
    let mut series = study_series(traj, |r| Some(r.deviation));
    series.extend(peers.iter().cloned());
    let mut files = chart::write_loglog(
        out,
        TRAJ_CHART,
        &LogLogPlot {
            title: format!(
                "300-link chain crumpled (±{} rad) falling {} s: deviation from RK4 reference",
                trajectory::CRUMPLE,
                trajectory::HORIZON
            ),
            x_desc: "cost per simulated second (CPU ms, one thread)".into(),
            y_desc: format!("‖q({0} s) − q_ref({0} s)‖ (rad)", trajectory::HORIZON),
            series,
            lines: true,
            vlines: vec![],
        },
    )?;
    files.extend(chart::write_loglog(
        out,
        ACCUM_CHART,
        &LogLogPlot {
            title: format!(
                "Adaptive dynamics, {} s of the falling chain: accumulated acceleration-metric error",
                trajectory::HORIZON
            ),
            x_desc: "cost per simulated second (CPU ms, one thread)".into(),
            y_desc: "∫ Σ (qdd − qdd_exact)² dt  ((rad/s²)² s)".into(),
            series: study_series(traj, |r| r.accel_error.filter(|e| *e > 0.0)),
            lines: true,
            vlines: vec![],
        },
    )?);
    Ok(files)
}

fn chart_seeds(out: &Path, seeds: &SeedsTable) -> Result<Vec<PathBuf>> {
    chart::write_heat_map(
        out,
        SEEDS_CHART,
        &HeatMap {
            title: "Seeds' table, 300-link chain: time per step (ms; colour log 0.01…10 ms)".into(),
            x_desc: "external forces".into(),
            y_desc: "active joints".into(),
            cols: SEED_FORCES.iter().map(|f| f.to_string()).collect(),
            rows: seeds.iter().map(|(l, _)| l.clone()).collect(),
            values: seeds
                .iter()
                .map(|(_, c)| c.iter().map(|t| t.map(|t| t / 1000.0)).collect())
                .collect(),
            unit: "ms".into(),
            // The seeds' figures span 0.02 … 5.89 ms.
            range: Some((0.01, 10.0)),
        },
    )
}

/// The seeds' table as published (Redon, Galoppo and Lin 2005, ms per iteration on a
/// 300-link pendulum): per number of external forces ([`SEED_FORCES`]), the times at 1, 50,
/// 100, 150, 200 and 250 active joints, then full DCA.
const REDON_2005: [[f64; 7]; 6] = [
    [0.02, 0.51, 1.71, 2.97, 4.04, 5.40, 5.89],
    [0.07, 0.49, 1.54, 3.21, 4.34, 5.19, 5.89],
    [0.16, 0.73, 1.47, 3.03, 4.22, 5.16, 5.88],
    [0.40, 0.90, 1.60, 3.00, 4.72, 5.56, 5.90],
    [0.98, 1.40, 2.16, 3.58, 4.99, 5.59, 5.92],
    [1.83, 2.30, 2.97, 4.28, 5.43, 6.31, 6.04],
];

/// For each point, whether no other point is at least as fast and at least as accurate and
/// better in one of the two (the Pareto front of time against error).
fn on_front(points: &[(f64, f64)]) -> Vec<bool> {
    points
        .iter()
        .map(|&(t, e)| {
            !points
                .iter()
                .any(|&(t2, e2)| t2 <= t && e2 <= e && (t2 < t || e2 < e))
        })
        .collect()
}

/// Which adaptive points of the one-step chart are on its front, in words.
fn accel_words(accel: &[(String, f64, f64)]) -> String {
    let pts: Vec<(f64, f64)> = accel.iter().map(|(_, t, e)| (*t, *e)).collect();
    let front = on_front(&pts);
    let (on, off): (Vec<_>, Vec<_>) = accel
        .iter()
        .zip(&front)
        .filter(|((l, ..), _)| l.starts_with("adaptive"))
        .partition(|(_, f)| **f);
    let names = |v: &[(&(String, f64, f64), &bool)]| {
        v.iter()
            .map(|((l, ..), _)| l.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    format!(
        "**Where adaptive dynamics is on the front (one step).** On the speed-against-error \
         front of this chart: {}. Not on it (another method is both faster and more accurate): \
         {}. A selection is exact only when it covers every joint; below that its one-step \
         error at this fast-moving state is of the order of the whole acceleration metric, \
         so adaptive dynamics is on this front only where it is faster than every exact solver.",
        if on.is_empty() {
            "none".into()
        } else {
            names(&on)
        },
        if off.is_empty() {
            "none".into()
        } else {
            names(&off)
        }
    )
}

/// The Pareto front of the trajectory study (cost per simulated second against deviation,
/// the peers' points included), in words, cheapest first; then the adaptive runs off it.
fn study_words(traj: &Study, peers: &[Series]) -> String {
    let name = |r: &trajectory::Run| {
        let integ = trajectory::integrator_name(r.integrator);
        match &r.policy {
            Some(p) => format!("{} + {integ} ({p})", r.method),
            None => format!("{} + {integ} at {} ms", r.method, r.dt * 1e3),
        }
    };
    let mut points: Vec<(String, f64, f64, bool)> = traj
        .runs
        .iter()
        .map(|r| (name(r), r.ms_per_sim_s(), r.deviation, r.policy.is_some()))
        .collect();
    for sr in peers {
        for (p, l) in sr.points.iter().zip(&sr.labels) {
            points.push((format!("{} at {l}", sr.name), p.0, p.1, false));
        }
    }
    let front = on_front(&points.iter().map(|p| (p.1, p.2)).collect::<Vec<_>>());
    let mut on: Vec<&(String, f64, f64, bool)> = points
        .iter()
        .zip(&front)
        .filter(|(_, f)| **f)
        .map(|(p, _)| p)
        .collect();
    on.sort_by(|a, b| a.1.total_cmp(&b.1));
    let words: Vec<String> = on
        .iter()
        .map(|(n, c, e, _)| format!("{n} ({c:.1} ms/s, {e:.1e} rad)"))
        .collect();
    let off: Vec<&str> = points
        .iter()
        .zip(&front)
        .filter(|(p, f)| p.3 && !**f)
        .map(|(p, _)| p.0.as_str())
        .collect();
    format!(
        "**The Pareto front (trajectories).** The runs no other run beats in both cost per \
         simulated second and deviation, from the cheapest to the most accurate: {}. Adaptive \
         runs off the front (another run is both cheaper and closer to the reference): {}.",
        words.join("; "),
        if off.is_empty() {
            "none".to_string()
        } else {
            off.join(", ")
        }
    )
}

// ---------------------------------------------------------------------------------------------
// Report

fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

/// The 1-minute load average (other work on the machine while the benchmarks ran).
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "unknown".into())
}

fn fmt_us(t: Option<&f64>) -> String {
    match t {
        Some(t) if t.is_finite() => {
            if *t >= 100.0 {
                format!("{t:.0}")
            } else {
                format!("{t:.2}")
            }
        }
        _ => "—".into(),
    }
}

/// The report's paragraph on the interleaved growth measurements.
fn growth_paragraph(growths: &[crate::growth::Growth]) -> String {
    let Some(first) = growths.first() else {
        return String::new();
    };
    let mut s = format!(
        "The same growth with the two lengths interleaved in one process \
         (`crate::growth`, {} rounds; each round times 10 calls on 1,000 links and \
         one on 10,000 back to back, so both see the same phase of a shared host):\n\n\
         | method | 1,000 links (µs, minimum) | 10,000 links (µs, minimum) | ratio of the minima | \
         per-round ratio: median (quartiles) |\n|---|---:|---:|---:|---:|\n",
        first.per_round.len()
    );
    for g in growths {
        let _ = writeln!(
            s,
            "| {:?} | {:.1} | {:.1} | **{:.2}×** | {:.2}× ({:.2}–{:.2}) |",
            g.method,
            g.short_us,
            g.long_us,
            g.ratio(),
            g.per_round_quantile(0.5),
            g.per_round_quantile(0.25),
            g.per_round_quantile(0.75)
        );
    }
    s += "\nThe ratio of the minima is the cost on a quiet host; the per-round median is what a \
          typical minute of this machine gives (a slow phase costs the 10,000-link call, which \
          streams megabytes through the last-level cache, more than the 1,000-link one, which \
          largely stays in L2).\n";
    s
}

#[allow(clippy::too_many_arguments)]
fn report(
    opts: &Options,
    rows: &[SpeedRow],
    growths: &[crate::growth::Growth],
    accel: &[(String, f64, f64)],
    (traj, pin_traj): (&Study, &[Series]),
    seeds: &SeedsTable,
    peers: &Peers,
    files: &[PathBuf],
    took: Duration,
) -> String {
    let mut s = String::new();
    report_header(&mut s, opts, took);
    report_speed(&mut s, rows, growths, peers);
    report_accuracy(&mut s, accel, traj, pin_traj);
    report_seeds(&mut s, seeds);
    report_peers(&mut s, peers, files);
    s
}

/// The report's title, how it was made, and the machine.
fn report_header(s: &mut String, opts: &Options, took: Duration) {
    let mode = if opts.quick {
        format!(
            "quick (in-process sampling: median over batches of calls after a warm-up, \
             gathered in {PASSES} passes over the table)"
        )
    } else {
        format!(
            "full (criterion: `cargo bench -p articula-benches --bench dynamics`, median \
             estimates; the adaptive cells in-process, in {PASSES} passes over the table)"
        )
    };
    let _ = writeln!(s, "# articula benchmark report\n");
    let _ = writeln!(
        s,
        "Generated by `cargo xtask bench{}{}{}`, mode: {mode}; took {:.0} s.\n\
         Machine: {}, {} logical CPUs; 1-minute load average {} when the report was written \
         (above the CPU count, other work shared the machine: compare figures of one run with \
         each other, and treat differences under ~20% as noise).\n",
        if opts.quick { " --quick" } else { "" },
        if opts.peers { " --peers" } else { "" },
        if opts.publish { " --publish" } else { "" },
        took.as_secs_f64(),
        cpu_name(),
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1),
        load_average(),
    );
    if !Solver::adaptive_available() {
        let _ = writeln!(s, "> {ADAPTIVE_PENDING}\n");
    }
}

/// The time per call table, growth, and the comparison with Pinocchio on chain300.
fn report_speed(
    s: &mut String,
    rows: &[SpeedRow],
    growths: &[crate::growth::Growth],
    peers: &Peers,
) {
    // Speed table.
    let mut labels: Vec<String> = Vec::new();
    for r in rows {
        for k in r.times.keys() {
            if !labels.contains(k) {
                labels.push(k.clone());
            }
        }
    }
    labels.sort_by_key(|l| order(l));
    let _ = writeln!(s, "## Time per forward-dynamics call (µs)\n");
    let _ = writeln!(
        s,
        "State `State::random(model, {SEED}, 1.0)` (angles ±1.2 rad, rates ±2 rad/s, torques ±1), \
         no external force; chains from `articula_testkit::chain(n)` (0.1 m, 0.1 kg rods), the \
         humanoid from `models/humanoid.urdf` (fixed base, 34 DOF). CRBA (dense O(n³)) stops \
         at 1000 links.\n"
    );
    let _ = writeln!(s, "| model | links | {} | DCA / ABA |", labels.join(" | "));
    let _ = writeln!(s, "|---|---:|{}---:|", "---:|".repeat(labels.len()));
    for r in rows {
        let cells: Vec<String> = labels.iter().map(|l| fmt_us(r.times.get(l))).collect();
        let ratio = r
            .times
            .get("DCA")
            .zip(r.times.get("ABA"))
            .map(|(d, a)| d / a);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            r.model,
            r.links,
            cells.join(" | "),
            ratio.map_or("—".into(), |x| format!("{x:.2}"))
        );
    }
    let growth = |l: &str| speed_of(rows, "chain10000", l) / speed_of(rows, "chain1000", l);
    let _ = writeln!(
        s,
        "\nGrowth from 1,000 to 10,000 links (10× the links; linear cost gives 10), from the \
         table (medians, each size timed apart from the other): DCA {:.1}×, ABA {:.1}×.\n",
        growth("DCA"),
        growth("ABA")
    );
    let _ = writeln!(s, "{}", growth_paragraph(growths));
    for (peer, call) in [
        ("Pinocchio ABA", "the default convention"),
        (
            "Pinocchio ABA (WORLD)",
            "`pin.Convention.WORLD`, its faster variant on chains",
        ),
    ] {
        let key = ("chain300".to_string(), peer.to_string());
        if let Some(p) = peers.results.get(&key).map(|r| r.0) {
            let _ = writeln!(
                s,
                "300-link chain against {peer} ({p:.1} µs, {call}): our ABA {:.2}×, our DCA {:.2}× its time.\n",
                speed_of(rows, "chain300", "ABA") / p,
                speed_of(rows, "chain300", "DCA") / p
            );
        }
    }
    let _ = writeln!(s, "![time per step against links]({SPEED_CHART}.png)\n");
}

/// Error against time: one step (a) and trajectories (b).
fn report_accuracy(
    s: &mut String,
    accel: &[(String, f64, f64)],
    traj: &Study,
    pin_traj: &[Series],
) {
    // Accuracy.
    let _ = writeln!(s, "## Error against time per step (300-link chain)\n");
    let _ = writeln!(
        s,
        "**(a) One step.** Acceleration-metric error `Σᵢ (q̈ᵢ − q̈ᵢ,exact)²` (identity weights) at \
         the benchmarked state, against `q̈_exact` from the double-double ABA of \
         `crates/articula-testkit/src/reference.rs` (~32 digits, independent of the library's f64 code). \
         Adaptive dynamics has two times per budget: its **first step**, the one-state call \
         (`Adaptive::forward_dynamics`: a whole-body selection, what the first step of a run \
         costs), and its **steady step**, the mean step after the first of a {} s run of the \
         crumpled chain below re-selecting at **every** step (selection, locking impulses and \
         the hybrid body's dynamics). Its error is the selection's at the benchmarked state; \
         the other methods' time is one forward-dynamics call.\n",
        trajectory::HORIZON
    );
    let _ = writeln!(
        s,
        "| method | µs per call or step | Σ (q̈ − q̈_exact)² | RMS error (rad/s²) |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|");
    for (l, t, e) in accel {
        let _ = writeln!(
            s,
            "| {l} | {} | {e:.3e} | {:.3e} |",
            fmt_us(Some(t)),
            (e / 300.0).sqrt()
        );
    }
    let _ = writeln!(s, "\n![one-step error against time]({ACCEL_CHART}.png)\n");
    let _ = writeln!(s, "{}\n", accel_words(accel));
    let _ = writeln!(
        s,
        "**(b) Trajectories.** The 300-link chain crumpled at rest (every angle uniform in \
         ±{} rad, τ = 0) falling under gravity for {} s, the way `articula simulate` runs it \
         ([adaptive.md](adaptive.md#defaults)). Deviation `‖q(T) − q_ref(T)‖` at T = {} s from \
         an RK4 run with ABA at dt = {} ms (the same run at twice its step differs from it by \
         {:.2e} rad; RK4's own error is about 1/16 of that). The crumpled chain is chaotic: over \
         a second every approximate method ends far from the reference, over a tenth of a second \
         the deviation still ranks them. For adaptive dynamics also the acceleration-metric \
         error accumulated over the run, `∫ Σᵢ (q̈ᵢ − q̈ᵢ,exact)² dt`, `q̈_exact` the exact \
         DCA solve at the state each step used (after its locking impulse); the exact methods' \
         is zero by construction. Time per step is the steady state (the mean step after the \
         first; the first step apart), the minimum over 5 runs; an RK4 step is four dynamics \
         calls. **Cost per simulated second** is that time over the step (CPU ms on one thread \
         per second of simulated motion): what a user choosing a method and a step pays for \
         the same simulated time. Adaptive dynamics runs at dt = {} ms with semi-implicit Euler \
         (re-selecting at every step, through the caches, or at the library's default \
         balanced period) and with RK4 (balanced period). The charts leave out the runs \
         through the caches (in the table).\n",
        trajectory::CRUMPLE,
        trajectory::HORIZON,
        trajectory::HORIZON,
        traj.reference_dt * 1e3,
        traj.reference_check,
        trajectory::ADAPTIVE_DT * 1e3,
    );
    let _ = writeln!(
        s,
        "| method | re-selection | integrator | dt (ms) | first step (µs) | steady µs per step | ms per simulated s | deviation at {} s (rad) | accumulated Σ (q̈ − q̈_exact)² dt |",
        trajectory::HORIZON
    );
    let _ = writeln!(s, "|---|---|---|---:|---:|---:|---:|---:|---:|");
    for r in &traj.runs {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {:.3e} | {} |",
            r.method,
            r.policy.as_deref().unwrap_or("—"),
            trajectory::integrator_name(r.integrator),
            r.dt * 1e3,
            fmt_us(Some(&r.first_us)),
            fmt_us(Some(&r.steady_us)),
            fmt_us(Some(&r.ms_per_sim_s())),
            r.deviation,
            match (r.accel_error, &r.policy) {
                (Some(e), _) => format!("{e:.3e}"),
                (None, None) => "0 (exact)".into(),
                (None, Some(_)) => "— (RK4 stages)".into(),
            }
        );
    }
    for sr in pin_traj {
        for (p, l) in sr.points.iter().zip(&sr.labels) {
            let _ = writeln!(
                s,
                "| {} | — | — | {} | — | {} | {} | {:.3e} | 0 (exact) |",
                sr.name,
                l.trim_end_matches(" ms"),
                fmt_us(Some(
                    &(p.0 * l.trim_end_matches(" ms").parse::<f64>().unwrap_or(f64::NAN))
                )),
                fmt_us(Some(&p.0)),
                p.1
            );
        }
    }
    if !traj.diverged.is_empty() {
        let _ = writeln!(
            s,
            "\nRuns that diverged (a non-finite state before {} s): {}.",
            trajectory::HORIZON,
            traj.diverged.join("; ")
        );
    }
    if pin_traj.is_empty() {
        let _ = writeln!(
            s,
            "\nPinocchio's points (`pin.aba` with the same integrators in Python, \
             `peers/pin_trajectory.py`) are drawn with `--peers`."
        );
    } else {
        let _ = writeln!(
            s,
            "\nPinocchio: `pin.aba` with the same integrators written in Python \
             (`peers/pin_trajectory.py`, the interpreter's loop included in its time; the \
             minimum over 3 runs), from the same start; its deviation is the same reference's."
        );
    }
    let _ = writeln!(s, "\n![trajectory error against time]({TRAJ_CHART}.png)\n");
    let _ = writeln!(
        s,
        "![accumulated acceleration-metric error against time]({ACCUM_CHART}.png)\n"
    );
    let _ = writeln!(s, "{}\n", study_words(traj, pin_traj));
}

/// The seeds' table beside Redon et al. 2005's.
fn report_seeds(s: &mut String, seeds: &SeedsTable) {
    // Seeds' table.
    let _ = writeln!(
        s,
        "## The seeds' table (300-link chain, time per step in ms)\n"
    );
    let _ = writeln!(
        s,
        "Steady time per semi-implicit Euler step (dt = 1 ms) with k external forces (1 N at the \
         origins of k bodies spread along the chain) on the crumpled chain falling from rest: \
         runs of {SEEDS_RUN} continuing steps, adaptive dynamics **re-selecting at every step** \
         (the first step of each run, its whole-body selection, left out), the minimum over the \
         runs. Rows `adaptive N` re-select by the default exact solve, rows `adaptive N caches` \
         through the caches of the rigid subassemblies ([adaptive.md](adaptive.md#defaults)).\n"
    );
    let head = SEED_FORCES
        .iter()
        .map(|f| format!("{f} forces"))
        .collect::<Vec<_>>()
        .join(" | ");
    let _ = writeln!(s, "| active joints | {head} |");
    let _ = writeln!(s, "|---|{}", "---:|".repeat(SEED_FORCES.len()));
    for (label, cells) in seeds {
        let cells: Vec<String> = cells
            .iter()
            .map(|t| t.map_or("pending".into(), |t| format!("{:.3}", t / 1000.0)))
            .collect();
        let _ = writeln!(s, "| {label} | {} |", cells.join(" | "));
    }
    let _ = writeln!(s, "\n![seeds' table]({SEEDS_CHART}.png)\n");
    let _ = writeln!(
        s,
        "The same table from Redon et al. 2005 (300-link pendulum, ms per iteration, on the \
         hardware of 2005), and both as fractions of full DCA's time in the same column (the \
         machines differ by two decades; the fractions compare):\n"
    );
    let _ = writeln!(s, "| active joints | {head} |");
    let _ = writeln!(s, "|---|{}", "---:|".repeat(SEED_FORCES.len()));
    for (r, label) in [
        "adaptive 1",
        "adaptive 50",
        "adaptive 100",
        "adaptive 150",
        "adaptive 200",
        "adaptive 250",
        "full DCA (300)",
    ]
    .iter()
    .enumerate()
    {
        let cells: Vec<String> = REDON_2005
            .iter()
            .map(|row| format!("{:.2}", row[r]))
            .collect();
        let _ = writeln!(s, "| {label} (2005) | {} |", cells.join(" | "));
    }
    let _ = writeln!(s, "\n| active joints: time / full DCA's | {head} |");
    let _ = writeln!(s, "|---|{}", "---:|".repeat(SEED_FORCES.len()));
    let dca_row = seeds.last().map(|(_, c)| c.clone()).unwrap_or_default();
    for (r, (label, cells)) in seeds.iter().take(seeds.len().saturating_sub(1)).enumerate() {
        let cells: Vec<String> = cells
            .iter()
            .zip(&dca_row)
            .enumerate()
            .map(|(c, (t, d))| {
                let ours = match (t, d) {
                    (Some(t), Some(d)) => format!("{:.3}", t / d),
                    _ => "pending".into(),
                };
                // The 2005 table's column of the same budget (it has none at 300).
                let k = r % ADAPTIVE_BUDGETS.len();
                let theirs = REDON_2005
                    .get(c)
                    .filter(|_| k < 6)
                    .map(|row| row[k] / row[6])
                    .map_or("—".into(), |x| format!("{x:.3}"));
                format!("{ours} ({theirs})")
            })
            .collect();
        let _ = writeln!(s, "| {label}: ours (2005) | {} |", cells.join(" | "));
    }
    let _ = writeln!(s);
}

/// The peers' notes and memory, how to install them, the files written.
fn report_peers(s: &mut String, peers: &Peers, files: &[PathBuf]) {
    let root_target = |p: &PathBuf| {
        p.file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default()
    };
    // Peers.
    let _ = writeln!(s, "## Peers\n");
    match &peers.skipped {
        Some(why) => {
            let _ = writeln!(s, "Pinocchio and MuJoCo were **skipped**: {why}.\n");
        }
        None => {
            let v: Vec<String> = peers
                .versions
                .iter()
                .map(|(k, v)| format!("{k} {v}"))
                .collect();
            let _ = writeln!(
                s,
                "Timed through their Python bindings by `peers/peers.py` ({}), with the same \
                 harness (median over batches after a warm-up, gathered in {PASSES} passes over \
                 the models, each (model, peer) in a child process of its own), on the same \
                 URDF files and states (set by joint name). The bindings add roughly a \
                 microsecond per call, which matters only for the smallest models. Notes:\n",
                v.join(", ")
            );
            let mut notes: BTreeMap<String, String> = BTreeMap::new();
            for ((model, peer), (_, _, note)) in &peers.results {
                notes
                    .entry(format!("{peer}: {note}"))
                    .and_modify(|m| {
                        m.push_str(", ");
                        m.push_str(model)
                    })
                    .or_insert_with(|| model.clone());
            }
            for (note, models) in notes {
                let _ = writeln!(s, "- {note} ({models})");
            }
            let _ = writeln!(
                s,
                "- MuJoCo mj_forward: not run above {MUJOCO_MAX_DOF} links (its dense \
                 mass-matrix factorisation makes one call take seconds there)."
            );
            for e in &peers.errors {
                let _ = writeln!(s, "- failed: {e}");
            }
            let _ = writeln!(
                s,
                "\nPeak resident memory of the Python process that ran each peer (MiB; \
                 includes the interpreter and the library, ~100 MiB):\n"
            );
            let _ = writeln!(s, "| model | peer | peak RSS (MiB) |\n|---|---|---:|");
            for ((model, peer), m) in &peers.rss {
                let _ = writeln!(s, "| {model} | {peer} | {m:.0} |");
            }
            let _ = writeln!(s);
        }
    }
    let _ = writeln!(
        s,
        "Install them with `python3 -m venv target/peers-venv && target/peers-venv/bin/pip \
         install pin mujoco`, then run `cargo xtask bench --peers` (or set \
         `ARTICULA_PEERS_PYTHON` to a Python that has both).\n"
    );
    let _ = writeln!(s, "## Files\n");
    for f in files {
        let _ = writeln!(s, "- `{}`", root_target(f));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn criterion_medians_are_read_as_microseconds() {
        let dir = std::env::temp_dir().join(format!("xtask-criterion-{}", std::process::id()));
        for (group, m, label, ns) in [
            ("chain", "dca", "300", 450_000.0),
            ("humanoid", "aba", "34dof", 5_500.0),
        ] {
            let d = dir.join(group).join(m).join(label).join("new");
            std::fs::create_dir_all(&d).unwrap();
            let json = format!(
                r#"{{"mean":{{"point_estimate":1.0}},"median":{{"point_estimate":{ns}}}}}"#
            );
            std::fs::write(d.join("estimates.json"), json).unwrap();
        }
        let got = read_criterion(&dir).unwrap();
        assert_eq!(got.len(), 2);
        assert_eq!(got[&("chain300".to_string(), "DCA".to_string())], 450.0);
        assert_eq!(got[&("humanoid".to_string(), "ABA".to_string())], 5.5);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn growth_paragraph_reports_minima_and_per_round_ratios() {
        let g = crate::growth::Growth {
            method: articula_dca::Method::Dca,
            short: 1000,
            long: 10_000,
            short_us: 280.0,
            long_us: 2940.0,
            per_round: vec![10.0, 10.5, 11.0, 11.5, 12.0],
        };
        let p = growth_paragraph(&[g]);
        assert!(p.contains("5 rounds"), "{p}");
        assert!(
            p.contains("| Dca | 280.0 | 2940.0 | **10.50×** | 11.00× (10.50–11.50) |"),
            "{p}"
        );
        assert!(growth_paragraph(&[]).is_empty());
    }

    #[test]
    fn metric_error_is_the_sum_of_squares() {
        assert_eq!(metric_error(&[1.0, 2.0], &[0.0, 4.0]), 5.0);
    }

    #[test]
    fn seeds_table_marks_adaptive_rows_pending() {
        let dir = std::env::temp_dir().join(format!("xtask-seeds-{}", std::process::id()));
        let mut seeds: SeedsTable = ADAPTIVE_BUDGETS
            .iter()
            .map(|b| (format!("adaptive {b}"), vec![None; SEED_FORCES.len()]))
            .collect();
        seeds.push(("full DCA".into(), vec![Some(400.0); SEED_FORCES.len()]));
        let files = chart_seeds(&dir, &seeds).unwrap();
        let svg = std::fs::read_to_string(&files[0]).unwrap();
        assert_eq!(
            svg.matches("pending").count(),
            ADAPTIVE_BUDGETS.len() * SEED_FORCES.len()
        );
        assert_eq!(svg.matches("0.400 ms").count(), SEED_FORCES.len());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
