//! `cargo xtask corpus`: every URDF of example-robot-data, fixed and floating base, loaded
//! by articula and checked against Pinocchio. Writes `target/articula-corpus/report.md` and
//! `report.json`.
//!
//! For each URDF and base: load it (library API, in-process) and record the refusal or the
//! warnings; on [`SEEDS`] seeded random states (`State::random(model, seed, 1.0)`) compare
//! `q̈` of DCA and ABA with Pinocchio's `pin.aba` (run by `peers/corpus.py` in the venv's
//! Python), joint by joint by URDF name; time DCA, ABA and `pin.aba` at the first state, in
//! [`PASSES`] passes that alternate which side runs first.
//!
//! **Error measure**: per state `max_j |q̈_j − q̈_pin,j| / max(1, max_j |q̈_pin,j|)` over every
//! velocity coordinate `j` (the floating base's six included); a robot's figure is the worst
//! over its states. A locked joint counts with `|q̈_j − 0|` (Pinocchio has no coordinate for
//! it). The check passes when every loaded robot is within [`TOLERANCE`].
//!
//! **Conventions mapped** (`docs/conventions.md`): articula's floating joint has
//! `q = [x, y, z, qw, qx, qy, qz]`, `q̇ = [ω; v]` and `τ = [n; f]` in the child (root) frame;
//! Pinocchio's free-flyer has `q = [x, y, z, qx, qy, qz, qw]`, `v = [v; ω]`, `τ = [f; n]`,
//! also in the child frame — the same quantities, reordered ([`pin_joint_state`],
//! [`ours_by_joint`]). A continuous joint's angle becomes Pinocchio's `(cos q, sin q)` in
//! `peers/corpus.py`. Mimic joints are independent on both sides (articula loads them so;
//! Pinocchio's `buildModelFromUrdf` does with its default `mimic=False`).

use crate::timing::{self, median};
use articula_dca::{forward_dynamics_slices, Data, Method, State};
use articula_model::{InertiaPolicy, JointKind, JointPart, LoadOptions, Model};
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

/// The largest error (see the module documentation) the check accepts.
pub const TOLERANCE: f64 = 1e-8;
/// Seeds of the compared states (`--quick`: the first two).
pub const SEEDS: [u64; 4] = [1, 2, 3, 4];
/// Timing passes over the corpus (`--quick`: one).
pub const PASSES: usize = 3;
/// Timing budget per robot, base and method, over all passes.
const BUDGET: Duration = Duration::from_millis(300);
const QUICK_BUDGET: Duration = Duration::from_millis(40);

pub(crate) const INSTALL: &str = "python3 -m venv target/peers-venv && \
target/peers-venv/bin/pip install pin mujoco example-robot-data";

pub const USAGE: &str = "\
usage: cargo xtask corpus [--quick] [--inertia accept|strict|repair] [--bound-inertia KGM2]
                          [--venv DIR] [NAME...]

Loads every URDF of example-robot-data (fixed and floating base), compares q̈ of DCA and ABA
with Pinocchio's aba on seeded random states, times the three, and writes
target/articula-corpus/report.md and report.json.

    --quick        two states per robot, one short timing pass (about a minute)
    --inertia P    the loader's inertia policy (default accept)
    --bound-inertia KGM2
                   with --inertia repair: every body's principal moments at least KGM2
                   (Pinocchio runs with the repaired inertias)
    --venv DIR     the Python venv with pin and example-robot-data (default target/peers-venv)
    NAME...        only the robots whose name or path contains one of these
";

/// The loader options for one run: the base, the inertia policy and its bound.
fn load_options(
    floating_base: bool,
    inertia: InertiaPolicy,
    bound_inertia: Option<f64>,
) -> LoadOptions {
    let o = LoadOptions::default()
        .with_floating_base(floating_base)
        .with_inertia(inertia);
    match bound_inertia {
        Some(b) => o.with_bound_inertia(b),
        None => o,
    }
}

/// The load warnings, one line each.
fn warnings(model: &Model) -> Vec<String> {
    model.warnings.iter().map(|w| w.to_string()).collect()
}

/// The joints the loader locked (q̈ = 0), whose coordinates follow the bodies' in `q` and `qd`.
fn locked_joints(model: &Model) -> Vec<JointPart> {
    model.locked.iter().map(|l| l.joint.clone()).collect()
}

/// Every joint with coordinates in a state: the bodies' parts, then the locked joints.
fn coordinate_parts<'a>(
    model: &'a Model,
    locked: &'a [JointPart],
) -> impl Iterator<Item = &'a JointPart> {
    model.joint_parts().map(|(_, p)| p).chain(locked)
}

#[derive(Debug)]
struct Options {
    quick: bool,
    inertia: InertiaPolicy,
    bound_inertia: Option<f64>,
    venv: PathBuf,
    names: Vec<String>,
}

fn parse(root: &Path, args: &[String]) -> Result<Options, String> {
    let mut o = Options {
        quick: false,
        inertia: InertiaPolicy::default(),
        bound_inertia: None,
        venv: root.join("target/peers-venv"),
        names: Vec::new(),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--quick" => o.quick = true,
            "--inertia" => o.inertia = crate::args::inertia_policy(it.next().map(String::as_str))?,
            "--bound-inertia" => o.bound_inertia = Some(crate::args::parse_bound(a, it.next())?),
            "--venv" => match it.next() {
                Some(d) => o.venv = PathBuf::from(d),
                None => return Err("--venv needs a directory".into()),
            },
            s if s.starts_with('-') => return Err(format!("unexpected argument {s:?}")),
            s => o.names.push(s.to_string()),
        }
    }
    if o.bound_inertia.is_some() && o.inertia != InertiaPolicy::Repair {
        return Err("--bound-inertia needs --inertia repair".into());
    }
    Ok(o)
}

/// Runs the subcommand: 0 when every loaded robot matches Pinocchio, 1 when one does not (or
/// something failed), 2 on bad arguments or a missing venv.
pub fn main(root: &Path, args: &[String]) -> ExitCode {
    let opts = match parse(root, args) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}\n");
            eprint!("{USAGE}");
            return ExitCode::from(2);
        }
    };
    let python = opts.venv.join("bin/python");
    if !python.exists() {
        eprintln!(
            "error: no Python at {} (the corpus check needs pin and example-robot-data); \
             create the venv from the workspace root with\n    {INSTALL}\nor pass --venv DIR",
            python.display()
        );
        return ExitCode::from(2);
    }
    let located = match locate(root, &python) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: {e}; install it with\n    {INSTALL}");
            return ExitCode::from(2);
        }
    };
    let robots = match select(&located.robots, &opts.names) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    match run(root, &opts, &python, &located, robots) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// example-robot-data's `robots/` directory and the versions, from `corpus.py --locate`.
pub(crate) struct Located {
    pub(crate) robots: PathBuf,
    pub(crate) versions: Vec<(String, String)>,
}

pub(crate) fn locate(root: &Path, python: &Path) -> Result<Located, String> {
    let out = Command::new(python)
        .arg(root.join("peers/corpus.py"))
        .arg("--locate")
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).trim().to_string());
    }
    let v: Value = serde_json::from_slice(&out.stdout)
        .map_err(|e| format!("peers/corpus.py --locate printed no JSON: {e}"))?;
    Ok(Located {
        robots: PathBuf::from(v["robots"].as_str().unwrap_or_default()),
        versions: versions_of(&v),
    })
}

fn versions_of(v: &Value) -> Vec<(String, String)> {
    v["versions"]
        .as_object()
        .into_iter()
        .flatten()
        .map(|(k, v)| (k.clone(), v.as_str().unwrap_or("?").to_string()))
        .collect()
}

/// One URDF of the corpus.
pub(crate) struct Robot {
    /// The file stem, or `package/stem` where two files share a stem.
    pub(crate) name: String,
    /// Path relative to example-robot-data's `robots/`.
    pub(crate) rel: String,
    pub(crate) path: PathBuf,
}

/// Every `*.urdf` under `dir`, sorted by name (case-insensitive).
fn discover(dir: &Path) -> Result<Vec<Robot>, String> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> Result<(), String> {
        let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for e in entries {
            let p = e.map_err(|e| format!("{}: {e}", dir.display()))?.path();
            if p.is_dir() {
                walk(&p, out)?;
            } else if p.extension().is_some_and(|x| x == "urdf") {
                out.push(p);
            }
        }
        Ok(())
    }
    let mut paths = Vec::new();
    walk(dir, &mut paths)?;
    paths.sort();
    let stem = |p: &Path| {
        p.file_stem()
            .unwrap_or_default()
            .to_string_lossy()
            .to_string()
    };
    let mut robots: Vec<Robot> = paths
        .iter()
        .map(|p| Robot {
            name: stem(p),
            rel: p
                .strip_prefix(dir)
                .unwrap_or(p)
                .to_string_lossy()
                .to_string(),
            path: p.clone(),
        })
        .collect();
    let names: Vec<String> = robots.iter().map(|r| r.name.clone()).collect();
    for r in &mut robots {
        if names.iter().filter(|n| **n == r.name).count() > 1 {
            let package = r.rel.split('/').next().unwrap_or_default();
            r.name = format!(
                "{}/{}",
                package.strip_suffix("_description").unwrap_or(package),
                r.name
            );
        }
    }
    robots.sort_by_key(|r| r.name.to_lowercase());
    Ok(robots)
}

/// A loaded robot on one base: the model, its states and our results.
struct Case {
    robot: usize,
    floating: bool,
    model: Model,
    data: Data,
    warnings: Vec<String>,
    /// The locked joints and their names.
    locked_parts: Vec<JointPart>,
    locked: Vec<String>,
    states: Vec<State>,
    /// q̈ by joint (Pinocchio's coordinates) per state, per method, or the dynamics error.
    ours: [Result<Vec<Joints>, String>; 2],
    /// Per-call times (µs) of the timed batches of DCA, ABA and `pin.aba`, over the passes.
    times: [Vec<f64>; 3],
    /// Pinocchio's q̈ per state, or why it has none.
    pin: Result<Vec<Joints>, String>,
}

/// Accelerations by URDF joint name, in Pinocchio's coordinates.
type Joints = BTreeMap<String, Vec<f64>>;

const METHODS: [Method; 2] = [Method::Dca, Method::Aba];

/// One row of the table: a robot on one base, loaded (a [`Case`]) or refused.
enum Outcome {
    Refused(String),
    Loaded(usize),
}

fn key(robot: &Robot, floating: bool) -> String {
    format!("{}/{}", robot.name, base_name(floating))
}

fn base_name(floating: bool) -> &'static str {
    if floating {
        "floating"
    } else {
        "fixed"
    }
}

/// The corpus's URDFs whose name or path contains one of `names` (all without names), and
/// how many there are in all.
pub(crate) fn select(dir: &Path, names: &[String]) -> Result<(Vec<Robot>, usize), String> {
    let all = discover(dir)?;
    let total = all.len();
    let robots: Vec<Robot> = all
        .into_iter()
        .filter(|r| {
            names.is_empty()
                || names
                    .iter()
                    .any(|n| r.name.contains(n.as_str()) || r.rel.contains(n.as_str()))
        })
        .collect();
    if robots.is_empty() {
        return Err(format!(
            "no URDF of the {total} in {} matches {names:?}",
            dir.display()
        ));
    }
    Ok((robots, total))
}

fn run(
    root: &Path,
    opts: &Options,
    python: &Path,
    located: &Located,
    (robots, total): (Vec<Robot>, usize),
) -> Result<bool, String> {
    let started = Instant::now();
    let out_dir = root.join("target/articula-corpus");
    std::fs::create_dir_all(&out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let seeds = if opts.quick { &SEEDS[..2] } else { &SEEDS[..] };
    let (passes, budget) = if opts.quick {
        (1, QUICK_BUDGET)
    } else {
        (PASSES, BUDGET)
    };
    println!(
        "corpus: {} of {total} URDFs in {}, fixed and floating base",
        robots.len(),
        located.robots.display()
    );

    // Load, and solve the compared states.
    let mut outcomes = Vec::new();
    let mut cases = Vec::new();
    for (ri, robot) in robots.iter().enumerate() {
        for floating in [false, true] {
            let options = load_options(floating, opts.inertia, opts.bound_inertia);
            match Model::from_urdf_file(&robot.path, &options) {
                Err(e) => outcomes.push((ri, floating, Outcome::Refused(e.to_string()))),
                Ok(model) => {
                    outcomes.push((ri, floating, Outcome::Loaded(cases.len())));
                    cases.push(solve(ri, floating, model, seeds));
                }
            }
        }
    }

    // Pinocchio's q̈ (first pass) and the timings, the side that starts alternating by pass.
    let pass_budget = budget / passes as u32;
    let min_batches = timing::MIN_BATCHES.div_ceil(passes);
    for pass in 0..passes {
        let compare = pass == 0;
        let pin_first = pass % 2 == 0;
        if pin_first {
            pinocchio(
                root,
                python,
                &out_dir,
                &robots,
                &mut cases,
                opts.inertia,
                compare,
                pass_budget,
                min_batches,
            )?;
        }
        for case in &mut cases {
            time_ours(case, pass_budget, min_batches);
        }
        if !pin_first {
            pinocchio(
                root,
                python,
                &out_dir,
                &robots,
                &mut cases,
                opts.inertia,
                compare,
                pass_budget,
                min_batches,
            )?;
        }
        eprintln!(
            "  pass {}/{passes} done ({:.0} s)",
            pass + 1,
            started.elapsed().as_secs_f64()
        );
    }

    let rows: Vec<Row> = outcomes
        .iter()
        .map(|(ri, floating, outcome)| row(&robots, &cases, *ri, *floating, outcome))
        .collect();
    let summary = summarize(&rows, robots.len());
    let command = command_line(opts);
    let table = table(&rows);
    print!("{table}");
    println!("\n{}", summary.line);
    let report = report_md(
        &command,
        &located.versions,
        opts,
        passes,
        budget,
        seeds.len(),
        &table,
        &summary,
        &rows,
    );
    let md = out_dir.join("report.md");
    std::fs::write(&md, report).map_err(|e| format!("{}: {e}", md.display()))?;
    let js = out_dir.join("report.json");
    let value = report_json(&command, &located.versions, opts, &summary, &rows);
    std::fs::write(
        &js,
        serde_json::to_string_pretty(&value).unwrap_or_default(),
    )
    .map_err(|e| format!("{}: {e}", js.display()))?;
    println!(
        "wrote {} and {} ({:.0} s)",
        md.display(),
        js.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(summary.failures.is_empty())
}

/// A loaded robot's states (the locked joints neutral, at rest, unforced) and DCA's and ABA's
/// q̈.
fn solve(robot: usize, floating: bool, model: Model, seeds: &[u64]) -> Case {
    let locked_parts = locked_joints(&model);
    let states: Vec<State> = seeds
        .iter()
        .map(|&seed| {
            let mut s = State::random(&model, seed, 1.0);
            for p in &locked_parts {
                s.q[p.q_offset..p.q_offset + p.nq()].copy_from_slice(p.neutral_q());
                s.qd[p.v_offset..p.v_offset + p.nv()].fill(0.0);
                s.tau[p.v_offset..p.v_offset + p.nv()].fill(0.0);
            }
            s
        })
        .collect();
    let mut data = Data::new(&model);
    let ours = METHODS.map(|method| {
        states
            .iter()
            .map(|s| {
                forward_dynamics_slices(&model, &mut data, &s.q, &s.qd, &s.tau, &s.f_ext, method)
                    .map(|qdd| ours_by_joint(&model, &locked_parts, qdd))
                    .map_err(|e| format!("{}: {e}", method.name().to_uppercase()))
            })
            .collect()
    });
    Case {
        robot,
        floating,
        warnings: warnings(&model),
        locked: locked_parts.iter().map(|p| p.name.clone()).collect(),
        locked_parts,
        model,
        data,
        states,
        ours,
        times: Default::default(),
        pin: Err("not run".into()),
    }
}

/// Our q̈ by URDF joint name, in Pinocchio's coordinates: a floating joint's `[α; a]` (angular
/// first, child frame) becomes `[a; α]`.
fn ours_by_joint(model: &Model, locked: &[JointPart], qdd: &[f64]) -> Joints {
    coordinate_parts(model, locked)
        .map(|p| {
            let a = &qdd[p.v_offset..p.v_offset + p.nv()];
            let a = if p.kind == JointKind::Floating {
                swap_halves(a)
            } else {
                a.to_vec()
            };
            (p.name.clone(), a)
        })
        .collect()
}

/// `[a; b]` → `[b; a]` for a six-vector (angular-first ↔ linear-first).
fn swap_halves(x: &[f64]) -> Vec<f64> {
    [&x[3..6], &x[0..3]].concat()
}

/// A joint's state for `peers/corpus.py`: `[q, q̇, τ]` for one coordinate; for a floating
/// joint Pinocchio's free-flyer coordinates `q = [x, y, z, qx, qy, qz, qw]`, `v = [v; ω]`,
/// `τ = [f; n]` from ours `[x, y, z, qw, qx, qy, qz]`, `[ω; v]`, `[n; f]` (child frame both).
fn pin_joint_state(
    model: &Model,
    locked: &[JointPart],
    s: &State,
) -> serde_json::Map<String, Value> {
    let mut joints = serde_json::Map::new();
    for p in coordinate_parts(model, locked) {
        let (q, v, t) = (
            &s.q[p.q_offset..p.q_offset + p.nq()],
            &s.qd[p.v_offset..p.v_offset + p.nv()],
            &s.tau[p.v_offset..p.v_offset + p.nv()],
        );
        let value = if p.kind == JointKind::Floating {
            json!({
                "q": [q[0], q[1], q[2], q[4], q[5], q[6], q[3]],
                "v": swap_halves(v),
                "tau": swap_halves(t),
            })
        } else {
            json!([q[0], v[0], t[0]])
        };
        joints.insert(p.name.clone(), value);
    }
    joints
}

/// The floating base's joint name in `model` (Pinocchio's root joint gets the same name).
fn root_joint(model: &Model) -> Option<String> {
    model
        .floating_base
        .then(|| model.bodies.first().and_then(|b| b.joint.first()))
        .flatten()
        .map(|p| p.name.clone())
}

/// Every body's inertia for Pinocchio, keyed by the last joint of its (composed) joint, whose
/// child frame is the body frame in both libraries: `[m, c (3), I_c (xx, xy, xz, yy, yz, zz)]`
/// with `c` the centre of mass and `I_c` the rotational inertia about it, in the body frame.
/// Under `--inertia repair` Pinocchio runs with these (the repaired numbers) instead of the
/// URDF's, so that the check compares the dynamics of one and the same model.
fn body_inertias(model: &Model) -> serde_json::Map<String, Value> {
    let mut out = serde_json::Map::new();
    for b in &model.bodies {
        let Some(last) = b.joint.last() else { continue };
        let (c, i) = (b.inertia.com(), b.inertia.inertia_about_com());
        out.insert(
            last.name.clone(),
            json!([
                b.inertia.mass,
                c.x,
                c.y,
                c.z,
                i.x_axis.x,
                i.y_axis.x,
                i.z_axis.x,
                i.y_axis.y,
                i.z_axis.y,
                i.z_axis.z
            ]),
        );
    }
    out
}

/// Runs `peers/corpus.py` on every case: Pinocchio's q̈ at the states (`compare`) and its
/// timing (the batches' times are added to the case's).
#[allow(clippy::too_many_arguments)]
fn pinocchio(
    root: &Path,
    python: &Path,
    out_dir: &Path,
    robots: &[Robot],
    cases: &mut [Case],
    inertia: InertiaPolicy,
    compare: bool,
    budget: Duration,
    min_batches: usize,
) -> Result<(), String> {
    if cases.is_empty() {
        return Ok(());
    }
    let specs: Vec<Value> = cases
        .iter()
        .map(|c| {
            json!({
                "key": key(&robots[c.robot], c.floating),
                "urdf": robots[c.robot].path,
                "root": root_joint(&c.model),
                "locked": c.locked,
                "inertias": (inertia == InertiaPolicy::Repair).then(|| body_inertias(&c.model)),
                "states": c.states.iter().map(|s| pin_joint_state(&c.model, &c.locked_parts, s)).collect::<Vec<_>>(),
            })
        })
        .collect();
    let config = json!({
        "budget_s": budget.as_secs_f64(),
        "min_batches": min_batches,
        "compare": compare,
        "robots": specs,
    });
    let cfg = out_dir.join("pinocchio-config.json");
    std::fs::write(&cfg, config.to_string()).map_err(|e| format!("{}: {e}", cfg.display()))?;
    let out = Command::new(python)
        .arg(root.join("peers/corpus.py"))
        .arg(&cfg)
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = stderr.lines().rev().take(5).collect();
        return Err(format!(
            "peers/corpus.py {} failed ({}): {}",
            cfg.display(),
            out.status,
            tail.into_iter().rev().collect::<Vec<_>>().join("\n")
        ));
    }
    let v: Value = serde_json::from_slice(&out.stdout)
        .map_err(|e| format!("peers/corpus.py printed no JSON: {e}"))?;
    let mut by_key: BTreeMap<String, &Value> = BTreeMap::new();
    for r in v["results"].as_array().into_iter().flatten() {
        by_key.insert(r["key"].as_str().unwrap_or_default().to_string(), r);
    }
    for c in cases.iter_mut() {
        let k = key(&robots[c.robot], c.floating);
        let Some(r) = by_key.get(&k) else {
            c.pin = Err("no result from peers/corpus.py".into());
            continue;
        };
        if let Some(e) = r["error"].as_str() {
            c.pin = Err(e.to_string());
            continue;
        }
        if compare {
            c.pin = Ok(r["qdd"]
                .as_array()
                .into_iter()
                .flatten()
                .map(|state| {
                    state
                        .as_object()
                        .into_iter()
                        .flatten()
                        .map(|(j, a)| {
                            let a = a.as_array().into_iter().flatten();
                            (
                                j.clone(),
                                a.map(|x| x.as_f64().unwrap_or(f64::NAN)).collect(),
                            )
                        })
                        .collect()
                })
                .collect());
        }
        c.times[2].extend(
            r["times"]
                .as_array()
                .into_iter()
                .flatten()
                .filter_map(Value::as_f64),
        );
    }
    Ok(())
}

/// Times DCA and ABA at the case's first state (no external forces, as Pinocchio's).
fn time_ours(case: &mut Case, budget: Duration, min_batches: usize) {
    let Case {
        model,
        data,
        states,
        ours,
        times,
        ..
    } = case;
    let s = &states[0];
    for (m, method) in METHODS.into_iter().enumerate() {
        if ours[m].is_err() {
            continue;
        }
        let sampled = timing::sample(budget, min_batches, || {
            forward_dynamics_slices(model, data, &s.q, &s.qd, &s.tau, &[], method).map(|qdd| {
                black_box(qdd);
            })
        });
        if let Ok(samples) = sampled {
            times[m].extend(samples.times_us);
        }
    }
}

/// The worst error over the states (see the module documentation) and the joint where it
/// is, or why there is none.
fn worst_error(
    ours: &[Joints],
    pin: &[Joints],
    locked: &[String],
) -> Result<(f64, String), String> {
    let mut worst = (0.0, String::new());
    for (o, p) in ours.iter().zip(pin) {
        let mut scale = 1.0f64;
        for (j, a) in p {
            if a.iter().any(|x| !x.is_finite()) {
                return Err(format!("Pinocchio's q̈ is not finite at joint {j}"));
            }
            scale = a.iter().fold(scale, |s, x| s.max(x.abs()));
        }
        let mut deltas = Vec::new();
        for (j, a) in o {
            match p.get(j) {
                Some(b) if b.len() == a.len() => {
                    deltas.extend(a.iter().zip(b).map(|(x, y)| ((x - y).abs(), j.clone())))
                }
                Some(b) => {
                    return Err(format!(
                        "joint {j}: {} coordinates here, {} in Pinocchio",
                        a.len(),
                        b.len()
                    ))
                }
                None if locked.contains(j) => deltas.extend(a.iter().map(|x| (x.abs(), j.clone()))),
                None => return Err(format!("joint {j} is not in Pinocchio's model")),
            }
        }
        if let Some(j) = p.keys().find(|j| !o.contains_key(*j)) {
            return Err(format!("Pinocchio's joint {j} is not in articula's model"));
        }
        for (d, j) in deltas {
            let e = d / scale;
            if e > worst.0 || e.is_nan() {
                worst = (e, j);
            }
        }
    }
    Ok(worst)
}

/// One row of the report.
struct Row {
    robot: String,
    rel: String,
    floating: bool,
    /// `Err(reason)` when refused.
    loaded: Result<LoadedRow, String>,
}

struct LoadedRow {
    bodies: usize,
    dof: usize,
    warnings: Vec<String>,
    locked: Vec<String>,
    /// DCA's and ABA's worst error and its joint, or why there is none.
    error: [Result<(f64, String), String>; 2],
    /// Median µs per call of DCA, ABA and `pin.aba`.
    us: [Option<f64>; 3],
}

impl LoadedRow {
    fn ratio(&self, m: usize) -> Option<f64> {
        Some(self.us[m]? / self.us[2]?)
    }
}

fn row(robots: &[Robot], cases: &[Case], ri: usize, floating: bool, outcome: &Outcome) -> Row {
    let loaded = match outcome {
        Outcome::Refused(why) => Err(why.clone()),
        Outcome::Loaded(ci) => {
            let c = &cases[*ci];
            let error = [0, 1].map(|m| match (&c.ours[m], &c.pin) {
                (Err(e), _) => Err(e.clone()),
                (_, Err(e)) => Err(format!("Pinocchio: {e}")),
                (Ok(o), Ok(p)) => worst_error(o, p, &c.locked),
            });
            let us = [0, 1, 2].map(|m| {
                let mut t = c.times[m].clone();
                (!t.is_empty()).then(|| median(&mut t))
            });
            Ok(LoadedRow {
                bodies: c.model.bodies.len(),
                dof: c.model.nv,
                warnings: c.warnings.clone(),
                locked: c.locked.clone(),
                error,
                us,
            })
        }
    };
    Row {
        robot: robots[ri].name.clone(),
        rel: robots[ri].rel.clone(),
        floating,
        loaded,
    }
}

struct Summary {
    line: String,
    /// Loaded rows that are not compared within the tolerance: `robot/base: why`.
    failures: Vec<String>,
}

fn summarize(rows: &[Row], robots: usize) -> Summary {
    let loaded = |floating: bool| {
        rows.iter()
            .filter(|r| r.floating == floating && r.loaded.is_ok())
            .count()
    };
    let mut failures = Vec::new();
    let mut worst = [(0.0f64, String::new()), (0.0, String::new())];
    for r in rows {
        let Ok(l) = &r.loaded else { continue };
        let at = format!("{}/{}", r.robot, base_name(r.floating));
        for (m, w) in worst.iter_mut().enumerate() {
            let method = METHODS[m].name().to_uppercase();
            match &l.error[m] {
                Ok((e, joint)) => {
                    if *e > TOLERANCE || e.is_nan() {
                        failures.push(format!("{at}: {method} error {e:.1e} (worst at {joint})"));
                    }
                    if *e >= w.0 || e.is_nan() {
                        *w = (*e, at.clone());
                    }
                }
                Err(why) => failures.push(format!("{at}: {method} not compared: {why}")),
            }
        }
    }
    let range = |m: usize, floating: bool| {
        let ratios: Vec<f64> = rows
            .iter()
            .filter(|r| r.floating == floating)
            .filter_map(|r| r.loaded.as_ref().ok())
            .filter(|l| l.dof > 0)
            .filter_map(|l| l.ratio(m))
            .collect();
        let lo = ratios.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = ratios.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if ratios.is_empty() {
            "-".to_string()
        } else {
            format!("{lo:.2}–{hi:.2}×")
        }
    };
    let verdict = if failures.is_empty() {
        format!("all within {TOLERANCE:.0e}")
    } else {
        format!("{} NOT within {TOLERANCE:.0e}", failures.len())
    };
    let line = format!(
        "{} of {robots} URDFs load with a fixed base, {} with a floating base; \
         worst error DCA {:.1e} ({}), ABA {:.1e} ({}): {verdict}; \
         time over pin.aba's (robots with a degree of freedom): DCA {} fixed, {} floating; ABA {} fixed, {} floating",
        loaded(false),
        loaded(true),
        worst[0].0,
        worst[0].1,
        worst[1].0,
        worst[1].1,
        range(0, false),
        range(0, true),
        range(1, false),
        range(1, true),
    );
    let timed: Vec<&LoadedRow> = rows
        .iter()
        .filter_map(|r| r.loaded.as_ref().ok())
        .filter(|l| l.dof > 0 && l.ratio(0).is_some())
        .collect();
    let slower = timed.iter().filter(|l| l.ratio(0) > Some(1.0)).count();
    let line = format!(
        "{line}; DCA slower than pin.aba on {slower} of {} robot-bases",
        timed.len()
    );
    Summary { line, failures }
}

/// A loader message's first line, for a table cell (the report lists the whole message).
fn headline(message: &str) -> &str {
    let first = message.lines().next().unwrap_or_default();
    first.strip_suffix(':').unwrap_or(first)
}

fn fmt_us(t: Option<f64>) -> String {
    match t {
        Some(t) if t >= 100.0 => format!("{t:.0}"),
        Some(t) if t >= 10.0 => format!("{t:.1}"),
        Some(t) => format!("{t:.2}"),
        None => "-".into(),
    }
}

fn fmt_error(e: &Result<(f64, String), String>) -> String {
    match e {
        Ok((x, _)) if *x > TOLERANCE || x.is_nan() => format!("**{x:.1e}**"),
        Ok((x, _)) if *x == 0.0 => "0".into(),
        Ok((x, _)) => format!("{x:.1e}"),
        Err(_) => "**n/a**".into(),
    }
}

/// The Markdown table, one row per robot and base.
fn table(rows: &[Row]) -> String {
    let mut t = String::from(
        "| robot | base | bodies/DOF | loaded | warnings | error DCA | error ABA | µs DCA | µs ABA | µs pin | DCA/pin | ABA/pin |\n\
         |---|---|--:|---|--:|--:|--:|--:|--:|--:|--:|--:|\n",
    );
    for r in rows {
        match &r.loaded {
            Err(why) => {
                let _ = writeln!(
                    t,
                    "| {} | {} | | refused: {} | | | | | | | | |",
                    r.robot,
                    base_name(r.floating),
                    headline(why).replace('|', "\\|")
                );
            }
            Ok(l) => {
                let mut status = "loaded".to_string();
                if !l.locked.is_empty() {
                    let _ = write!(status, " ({} locked)", l.locked.len());
                }
                if let Some(e) = l.error.iter().find_map(|e| e.as_ref().err()) {
                    let _ = write!(status, "; {}", e.replace('|', "\\|"));
                }
                let ratio = |m| l.ratio(m).map_or("-".into(), |x| format!("{x:.2}"));
                let _ = writeln!(
                    t,
                    "| {} | {} | {}/{} | {status} | {} | {} | {} | {} | {} | {} | {} | {} |",
                    r.robot,
                    base_name(r.floating),
                    l.bodies,
                    l.dof,
                    l.warnings.len(),
                    fmt_error(&l.error[0]),
                    fmt_error(&l.error[1]),
                    fmt_us(l.us[0]),
                    fmt_us(l.us[1]),
                    fmt_us(l.us[2]),
                    ratio(0),
                    ratio(1),
                );
            }
        }
    }
    t
}

fn command_line(opts: &Options) -> String {
    let mut c = String::from("cargo xtask corpus");
    if opts.quick {
        c.push_str(" --quick");
    }
    if opts.inertia != InertiaPolicy::default() {
        let _ = write!(c, " --inertia {}", opts.inertia.name());
    }
    if let Some(b) = opts.bound_inertia {
        let _ = write!(c, " --bound-inertia {b:e}");
    }
    for n in &opts.names {
        let _ = write!(c, " {n}");
    }
    c
}

#[allow(clippy::too_many_arguments)]
fn report_md(
    command: &str,
    versions: &[(String, String)],
    opts: &Options,
    passes: usize,
    budget: Duration,
    states: usize,
    table: &str,
    summary: &Summary,
    rows: &[Row],
) -> String {
    let mut s = String::new();
    let v: Vec<String> = versions.iter().map(|(k, v)| format!("{k} {v}")).collect();
    let _ = writeln!(s, "# Corpus: example-robot-data against Pinocchio\n");
    let _ = writeln!(
        s,
        "`{command}` ({}; inertia policy `{}`).\n",
        v.join(", "),
        opts.inertia.name()
    );
    let _ = writeln!(s, "{}\n", summary.line);
    // A call on a model without degrees of freedom is the bindings' own cost (and Pinocchio's
    // entry checks): an upper bound on what Python adds to every call.
    let overhead = rows
        .iter()
        .filter_map(|r| r.loaded.as_ref().ok())
        .filter(|l| l.dof == 0)
        .filter_map(|l| l.us[2])
        .fold(f64::INFINITY, f64::min);
    let overhead = if overhead.is_finite() {
        format!("a call on a robot without degrees of freedom takes {overhead:.2} µs, an upper bound on what the bindings add to each call")
    } else {
        "the bindings add a fraction of a microsecond to each call".into()
    };
    let _ = writeln!(
        s,
        "Error: per state `max_j |q̈_j − q̈_pin,j| / max(1, max_j |q̈_pin,j|)` over every \
         velocity coordinate (the floating base's six included), the worst of {states} seeded \
         random states (`State::random(model, seed, 1.0)`, seeds 1–{states}); bold above \
         {TOLERANCE:.0e}. Times: median µs per call at the first state, {:.0} ms per cell in \
         {passes} {} alternating which side runs first; `pin.aba` through its Python bindings \
         ({overhead}). Ratios: our time over Pinocchio's.\n",
        budget.as_secs_f64() * 1e3,
        if passes == 1 { "pass" } else { "passes" },
    );
    s.push_str(table);
    if !summary.failures.is_empty() {
        let _ = writeln!(s, "\n## Not within {TOLERANCE:.0e}\n");
        for f in &summary.failures {
            let _ = writeln!(s, "- {f}");
        }
    }
    // Each refusal once, with the robots it stopped (a base named when only one was refused).
    let mut refused: Vec<(&str, Vec<&Row>)> = Vec::new();
    for r in rows {
        if let Err(why) = &r.loaded {
            match refused.iter_mut().find(|(w, _)| w == why) {
                Some((_, those)) => those.push(r),
                None => refused.push((why, vec![r])),
            }
        }
    }
    if !refused.is_empty() {
        let _ = writeln!(s, "\n## Refused\n");
        for (why, those) in refused {
            let mut names: Vec<String> = Vec::new();
            for r in &those {
                let both = those.iter().filter(|o| o.robot == r.robot).count() == 2;
                if !both {
                    names.push(format!("{} ({} base)", r.robot, base_name(r.floating)));
                } else if !r.floating {
                    names.push(r.robot.clone());
                }
            }
            let mut lines = why.lines();
            let first = lines.next().unwrap_or_default();
            let _ = writeln!(s, "- {}: {first}", names.join(", "));
            for line in lines.map(str::trim).filter(|l| !l.is_empty()) {
                let _ = writeln!(s, "  - {}", line.trim_start_matches("- "));
            }
        }
    }
    let warned: Vec<&Row> = rows
        .iter()
        .filter(|r| !r.floating && r.loaded.as_ref().is_ok_and(|l| !l.warnings.is_empty()))
        .collect();
    if !warned.is_empty() {
        let _ = writeln!(s, "\n## Warnings (fixed base)\n");
        for r in warned {
            if let Ok(l) = &r.loaded {
                let _ = writeln!(s, "- {} ({}): {}", r.robot, l.warnings.len(), l.warnings[0]);
            }
        }
    }
    s
}

fn report_json(
    command: &str,
    versions: &[(String, String)],
    opts: &Options,
    summary: &Summary,
    rows: &[Row],
) -> Value {
    let err = |e: &Result<(f64, String), String>| match e {
        Ok((x, j)) => json!({"error": x, "joint": j}),
        Err(why) => json!({"not_compared": why}),
    };
    json!({
        "command": command,
        "versions": versions.iter().cloned().collect::<BTreeMap<_, _>>(),
        "inertia": opts.inertia.name(),
        "tolerance": TOLERANCE,
        "summary": summary.line,
        "failures": summary.failures,
        "rows": rows.iter().map(|r| {
            let mut o = json!({"robot": r.robot, "urdf": r.rel, "base": base_name(r.floating)});
            match &r.loaded {
                Err(why) => o["refused"] = json!(why),
                Ok(l) => {
                    o["bodies"] = json!(l.bodies);
                    o["dof"] = json!(l.dof);
                    o["warnings"] = json!(l.warnings);
                    o["locked"] = json!(l.locked);
                    o["dca"] = err(&l.error[0]);
                    o["aba"] = err(&l.error[1]);
                    o["us_per_call"] = json!({"dca": l.us[0], "aba": l.us[1], "pin_aba": l.us[2]});
                }
            }
            o
        }).collect::<Vec<_>>(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn joints(entries: &[(&str, &[f64])]) -> Joints {
        entries
            .iter()
            .map(|(j, a)| (j.to_string(), a.to_vec()))
            .collect()
    }

    #[test]
    fn error_is_relative_to_the_largest_acceleration_above_one() {
        // Powers of two: every difference below is exact.
        let d = 2f64.powi(-20);
        let pin = [joints(&[("a", &[100.0]), ("b", &[-3.0])])];
        let ours = [joints(&[("a", &[100.0]), ("b", &[-3.0 + d])])];
        assert_eq!(worst_error(&ours, &pin, &[]), Ok((d / 100.0, "b".into())));
        // Small accelerations: the denominator is 1.
        let pin = [joints(&[("a", &[2f64.powi(-10)])])];
        let ours = [joints(&[("a", &[2f64.powi(-10) + d])])];
        assert_eq!(worst_error(&ours, &pin, &[]), Ok((d, "a".into())));
    }

    #[test]
    fn error_takes_the_worst_state_and_checks_locked_joints_are_still() {
        let d = 2f64.powi(-30);
        let pin = [joints(&[("a", &[1.0])]), joints(&[("a", &[1.0])])];
        let ours = [
            joints(&[("a", &[1.0]), ("finger", &[0.0])]),
            joints(&[("a", &[1.0 + d]), ("finger", &[-4.0 * d])]),
        ];
        let locked = ["finger".to_string()];
        assert_eq!(
            worst_error(&ours, &pin, &locked),
            Ok((4.0 * d, "finger".into()))
        );
        // Not locked: a joint Pinocchio lacks is an error, as is one we lack.
        assert!(worst_error(&ours, &pin, &[]).is_err());
        assert!(worst_error(&[joints(&[])], &pin[..1], &[]).is_err());
    }

    #[test]
    fn error_refuses_non_finite_peers_and_mismatched_sizes() {
        let ours = [joints(&[("a", &[1.0])])];
        assert!(worst_error(&ours, &[joints(&[("a", &[f64::NAN])])], &[]).is_err());
        assert!(worst_error(&ours, &[joints(&[("a", &[1.0, 2.0])])], &[]).is_err());
    }

    /// The floating base's state and acceleration reach Pinocchio reordered: q's scalar last,
    /// velocity, force and acceleration linear part first.
    #[test]
    fn floating_base_maps_to_pinocchio_order() {
        let urdf = r#"<robot name="r"><link name="base"><inertial><mass value="2"/>
            <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
            <link name="arm"><inertial><mass value="1"/>
            <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
            <joint name="j" type="continuous"><parent link="base"/><child link="arm"/>
            <axis xyz="0 0 1"/></joint></robot>"#;
        let model =
            Model::from_urdf_str(urdf, &load_options(true, InertiaPolicy::Accept, None)).unwrap();
        let mut s = State::neutral(&model);
        s.q = vec![1.0, 2.0, 3.0, 0.5, 0.5, 0.5, 0.5, 0.7];
        s.qd = (1..=7).map(f64::from).collect();
        s.tau = (11..=17).map(f64::from).collect();
        let j = pin_joint_state(&model, &[], &s);
        assert_eq!(
            j["floating_base"],
            json!({"q": [1.0, 2.0, 3.0, 0.5, 0.5, 0.5, 0.5],
                   "v": [4.0, 5.0, 6.0, 1.0, 2.0, 3.0],
                   "tau": [14.0, 15.0, 16.0, 11.0, 12.0, 13.0]})
        );
        assert_eq!(j["j"], json!([0.7, 7.0, 17.0]));
        s.q[3..7].copy_from_slice(&[0.1, 0.2, 0.3, 0.4]);
        assert_eq!(
            pin_joint_state(&model, &[], &s)["floating_base"]["q"],
            json!([1.0, 2.0, 3.0, 0.2, 0.3, 0.4, 0.1])
        );
        let a = ours_by_joint(&model, &[], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
        assert_eq!(a["floating_base"], vec![4.0, 5.0, 6.0, 1.0, 2.0, 3.0]);
        assert_eq!(a["j"], vec![7.0]);
        assert_eq!(root_joint(&model).as_deref(), Some("floating_base"));
        // A locked joint's coordinates follow the bodies': it is sent and read like the others.
        let finger = JointPart {
            name: "finger".into(),
            kind: JointKind::Revolute,
            origin: articula_spatial::SpatialTransform::IDENTITY,
            axis: glam::DVec3::Z,
            q_offset: 8,
            v_offset: 7,
            limits: None,
        };
        s.q.push(0.0);
        s.qd.push(0.5);
        s.tau.push(-0.5);
        let locked = [finger];
        assert_eq!(
            pin_joint_state(&model, &locked, &s)["finger"],
            json!([0.0, 0.5, -0.5])
        );
        let a = ours_by_joint(&model, &locked, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 0.0]);
        assert_eq!(a["finger"], vec![0.0]);
        assert_eq!(a.len(), 3);
    }

    #[test]
    fn options_parse() {
        let root = Path::new("/w");
        let o = parse(
            root,
            &[
                "--quick".into(),
                "ur5".into(),
                "--inertia".into(),
                "repair".into(),
            ],
        )
        .unwrap();
        assert!(o.quick);
        assert_eq!(o.inertia, InertiaPolicy::Repair);
        assert_eq!(o.names, ["ur5"]);
        assert_eq!(o.venv, Path::new("/w/target/peers-venv"));
        assert!(parse(root, &["--inertia".into(), "lenient".into()]).is_err());
        assert!(parse(root, &["--inertia".into()]).is_err());
        assert!(parse(root, &["--bogus".into()]).is_err());
        let o = parse(root, &["--venv".into(), "/v".into()]).unwrap();
        assert_eq!(o.venv, Path::new("/v"));
    }
}
