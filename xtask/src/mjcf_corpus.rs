//! `cargo xtask mjcf-corpus`: every MJCF model of the PyPI packages dm-control and gymnasium,
//! loaded by articula and by MuJoCo (`peers/mjcf_corpus.py`); on seeded random states the
//! joint-space inertia `M` (`mj_fullM`) and the smooth acceleration `qacc_smooth` (passive
//! forces included) are compared, and DCA and ABA are timed against MuJoCo's `mj_forward`.
//! Writes `target/articula-mjcf-corpus/report.md` and `report.json`.

use articula_dca::{forward_dynamics_slices, mass_matrix, Data, Method, State};
use articula_model::{JointKind, LoadOptions, Model};
use glam::{DMat3, DQuat, DVec3};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

/// The arguments of `cargo xtask mjcf-corpus`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// Two states per model, short timings.
    #[arg(long)]
    pub quick: bool,
    /// The Python environment, with `pip install mujoco dm-control gymnasium`
    /// [default: target/peers-venv].
    #[arg(long, value_name = "DIR")]
    pub venv: Option<PathBuf>,
}

/// The agreement asked of every loaded model (relative to the largest entry).
const TOLERANCE: f64 = 1e-9;
/// The agreement asked of models with ball joints (whose coordinates are MuJoCo's, no map).
const BALL_TOLERANCE: f64 = 1e-10;

/// One model as MuJoCo lists it.
struct Listed {
    path: PathBuf,
    package: String,
    rel: String,
    tree: bool,
    reason: String,
    joints: Vec<(String, String, usize, usize)>,
    gravity: DVec3,
    unmodelled: Vec<String>,
}

/// Our side of one tree model: its coordinate map and the states.
struct Ours {
    model: Model,
    states: Vec<Mapped>,
    dca_us: f64,
    aba_us: f64,
}

/// A state in MuJoCo's coordinates and our M, q̈ (DCA, ABA) mapped to them.
struct Mapped {
    qpos: Vec<f64>,
    qvel: Vec<f64>,
    m: Vec<f64>,
    dca: Vec<f64>,
    aba: Vec<f64>,
}

/// 0 when every model agrees, 1 when one does not (or something failed), 2 on a missing venv
/// (clap exits 2 on bad arguments).
pub fn main(root: &Path, opts: &Options) -> ExitCode {
    let venv = crate::args::peers_venv(root, opts.venv.as_deref());
    let install = "python3 -m venv target/peers-venv && \
                   target/peers-venv/bin/pip install mujoco dm-control gymnasium";
    let needs = "the corpus needs mujoco, dm-control and gymnasium";
    let python = match crate::corpus::venv_python(&venv, needs, install) {
        Ok(p) => p,
        Err(code) => return code,
    };
    match run(root, &python, opts.quick) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("mjcf-corpus: {e}");
            ExitCode::FAILURE
        }
    }
}

fn python_json(python: &Path, script: &Path, arg: &str) -> Result<Value, String> {
    let out = Command::new(python)
        .arg(script)
        .arg(arg)
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).trim().to_string());
    }
    serde_json::from_slice(&out.stdout)
        .map_err(|e| format!("{} printed no JSON: {e}", script.display()))
}

fn listed(v: &Value) -> Vec<Listed> {
    let s = |x: &Value| x.as_str().unwrap_or_default().to_string();
    let f = |x: &Value| x.as_f64().unwrap_or(0.0);
    v["models"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|m| Listed {
            path: PathBuf::from(s(&m["path"])),
            package: s(&m["package"]),
            rel: s(&m["rel"]),
            tree: m["tree"].as_bool().unwrap_or(false),
            reason: s(&m["reason"]),
            joints: m["joints"]
                .as_array()
                .into_iter()
                .flatten()
                .map(|j| {
                    let u = |k: &str| j[k].as_u64().unwrap_or(0) as usize;
                    (s(&j["name"]), s(&j["type"]), u("qposadr"), u("dofadr"))
                })
                .collect(),
            gravity: DVec3::new(
                f(&m["gravity"][0]),
                f(&m["gravity"][1]),
                f(&m["gravity"][2]),
            ),
            unmodelled: m["unmodelled"]
                .as_array()
                .into_iter()
                .flatten()
                .map(s)
                .collect(),
        })
        .collect()
}

/// Our coordinates → MuJoCo's for one state: `qvel = P q̇` (a free joint's linear velocity
/// turned to the world, its angular one kept in the body frame, both swapped into MuJoCo's
/// order), and what a free joint adds to `qacc` (`R (ω × v)`). Ball joints have MuJoCo's
/// coordinates (quaternion; angular velocity in the body frame), hinges and slides too.
struct CoordMap {
    /// Per our joint part: (our q offset, our v offset, MuJoCo qposadr, dofadr, kind).
    parts: Vec<(usize, usize, usize, usize, JointKind)>,
}

impl CoordMap {
    fn new(model: &Model, mj: &Listed) -> Result<CoordMap, String> {
        let mut parts = Vec::new();
        for p in model.coordinate_parts() {
            let Some((_, ty, qa, da)) = mj.joints.iter().find(|j| j.0 == p.name) else {
                return Err(format!("joint '{}' is not MuJoCo's", p.name));
            };
            if p.kind.mjcf_type() != Some(ty.as_str()) {
                return Err(format!(
                    "joint '{}' is {ty} in MuJoCo, {:?} here",
                    p.name, p.kind
                ));
            }
            parts.push((p.q_offset, p.v_offset, *qa, *da, p.kind));
        }
        if parts.len() != mj.joints.len() {
            return Err(format!(
                "{} joints here, {} in MuJoCo",
                parts.len(),
                mj.joints.len()
            ));
        }
        Ok(CoordMap { parts })
    }

    fn rotation(q: &[f64], qo: usize) -> DMat3 {
        DMat3::from_quat(DQuat::from_xyzw(q[qo + 4], q[qo + 5], q[qo + 6], q[qo + 3]).normalize())
    }

    /// `P` (nv × nv, row-major) at `q`.
    fn p(&self, q: &[f64], nv: usize) -> Vec<f64> {
        let mut p = vec![0.0; nv * nv];
        for &(qo, vo, _, da, kind) in &self.parts {
            if kind != JointKind::Floating {
                for k in 0..kind.nv() {
                    p[(da + k) * nv + vo + k] = 1.0;
                }
                continue;
            }
            let r = Self::rotation(q, qo);
            for i in 0..3 {
                for j in 0..3 {
                    p[(da + i) * nv + vo + 3 + j] = r.col(j)[i];
                }
                p[(da + 3 + i) * nv + vo + i] = 1.0;
            }
        }
        p
    }

    fn qpos(&self, q: &[f64], nq: usize) -> Vec<f64> {
        let mut out = vec![0.0; nq];
        for &(qo, _, qa, _, kind) in &self.parts {
            let n = kind.nq();
            out[qa..qa + n].copy_from_slice(&q[qo..qo + n]);
        }
        out
    }

    /// `P x + δ` (δ: a free joint's `R (ω × v)` when `qd` is given).
    fn map(&self, p: &[f64], x: &[f64], q: &[f64], qd: Option<&[f64]>) -> Vec<f64> {
        let nv = x.len();
        let mut out: Vec<f64> = (0..nv)
            .map(|r| (0..nv).map(|c| p[r * nv + c] * x[c]).sum())
            .collect();
        if let Some(qd) = qd {
            for &(qo, vo, _, da, kind) in &self.parts {
                if kind == JointKind::Floating {
                    let w = DVec3::new(qd[vo], qd[vo + 1], qd[vo + 2]);
                    let v = DVec3::new(qd[vo + 3], qd[vo + 4], qd[vo + 5]);
                    let d = Self::rotation(q, qo) * w.cross(v);
                    for i in 0..3 {
                        out[da + i] += d[i];
                    }
                }
            }
        }
        out
    }
}

/// `P M Pᵀ`.
fn congruence(p: &[f64], m: &[f64], nv: usize) -> Vec<f64> {
    let mut pm = vec![0.0; nv * nv];
    for r in 0..nv {
        for k in 0..nv {
            let x = p[r * nv + k];
            if x != 0.0 {
                for c in 0..nv {
                    pm[r * nv + c] += x * m[k * nv + c];
                }
            }
        }
    }
    let mut out = vec![0.0; nv * nv];
    for r in 0..nv {
        for c in 0..nv {
            out[r * nv + c] = (0..nv).map(|k| pm[r * nv + k] * p[c * nv + k]).sum();
        }
    }
    out
}

fn time_us(budget: Duration, mut f: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    let end = Instant::now() + budget;
    while Instant::now() < end {
        let t = Instant::now();
        for _ in 0..20 {
            f();
        }
        best = best.min(t.elapsed().as_secs_f64() / 20.0);
    }
    best * 1e6
}

fn ours(mj: &Listed, n_states: u64, budget: Duration) -> Result<Ours, String> {
    let model =
        Model::from_mjcf_file(&mj.path, &LoadOptions::default()).map_err(|e| e.to_string())?;
    let map = CoordMap::new(&model, mj)?;
    let mut data = Data::new(&model);
    data.gravity = mj.gravity;
    let nv = model.nv;
    let nq: usize = mj
        .joints
        .iter()
        .map(|j| match j.1.as_str() {
            "free" => 7,
            "ball" => 4,
            _ => 1,
        })
        .sum();
    let mut states = Vec::new();
    let mut tau = vec![0.0; nv];
    for seed in 0..n_states {
        let s = State::random(&model, seed, 0.0);
        let p = map.p(&s.q, nv);
        let m = mass_matrix(&model, &mut data, &s.q)
            .map_err(|e| e.to_string())?
            .to_vec();
        model.passive_forces(&s.q, &s.qd, &mut tau);
        let mut qdd = |method| {
            forward_dynamics_slices(&model, &mut data, &s.q, &s.qd, &tau, &[], method)
                .map(|x| x.to_vec())
                .map_err(|e| format!("{}: {e}", method.name()))
        };
        let (dca, aba) = (qdd(Method::Dca)?, qdd(Method::Aba)?);
        states.push(Mapped {
            qpos: map.qpos(&s.q, nq),
            qvel: map.map(&p, &s.qd, &s.q, None),
            m: congruence(&p, &m, nv),
            dca: map.map(&p, &dca, &s.q, Some(&s.qd)),
            aba: map.map(&p, &aba, &s.q, Some(&s.qd)),
        });
    }
    let s = State::random(&model, 0, 0.0);
    model.passive_forces(&s.q, &s.qd, &mut tau);
    let mut time = |method| {
        time_us(budget, || {
            let _ = forward_dynamics_slices(&model, &mut data, &s.q, &s.qd, &tau, &[], method);
        })
    };
    let (dca_us, aba_us) = (time(Method::Dca), time(Method::Aba));
    Ok(Ours {
        model,
        states,
        dca_us,
        aba_us,
    })
}

/// `max |a − b| / max |b|`.
fn rel_err(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(f64::MIN_POSITIVE, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
        / scale
}

fn run(root: &Path, python: &Path, quick: bool) -> Result<bool, String> {
    let script = root.join("peers/mjcf_corpus.py");
    let list = python_json(python, &script, "--list")?;
    let models = listed(&list);
    let (n_states, budget) = if quick {
        (2, Duration::from_millis(20))
    } else {
        (10, Duration::from_millis(200))
    };
    let mut rows: Vec<(usize, Result<Ours, String>)> = Vec::new();
    for (i, mj) in models.iter().enumerate().filter(|(_, m)| m.tree) {
        rows.push((i, ours(mj, n_states, budget)));
    }
    // MuJoCo on the loaded models' states.
    let config = json!({
        "budget_s": budget.as_secs_f64(),
        "models": rows.iter().filter_map(|(i, r)| r.as_ref().ok().map(|o| json!({
            "path": models[*i].path,
            "states": o.states.iter().map(|s| json!({"qpos": s.qpos, "qvel": s.qvel})).collect::<Vec<_>>(),
        }))).collect::<Vec<_>>(),
    });
    let out_dir = root.join("target/articula-mjcf-corpus");
    std::fs::create_dir_all(&out_dir).map_err(|e| e.to_string())?;
    let cfg = out_dir.join("config.json");
    std::fs::write(&cfg, config.to_string()).map_err(|e| e.to_string())?;
    let theirs = python_json(python, &script, &cfg.display().to_string())?;
    let results = theirs["results"].as_array().cloned().unwrap_or_default();
    let report = Report::build(&models, &rows, &results);
    let md = report.markdown(&list["versions"], quick);
    std::fs::write(out_dir.join("report.md"), &md).map_err(|e| e.to_string())?;
    std::fs::write(
        out_dir.join("report.json"),
        serde_json::to_string_pretty(&report.json).unwrap_or_default(),
    )
    .map_err(|e| e.to_string())?;
    println!("{md}");
    println!("written: {}", out_dir.join("report.md").display());
    Ok(report.matched * 10 >= report.trees * 9)
}

/// The rows of the report.
struct Report {
    lines: Vec<String>,
    excluded: Vec<String>,
    json: Value,
    trees: usize,
    loaded: usize,
    matched: usize,
}

impl Report {
    fn build(
        models: &[Listed],
        rows: &[(usize, Result<Ours, String>)],
        results: &[Value],
    ) -> Report {
        let mut r = Report {
            lines: Vec::new(),
            excluded: Vec::new(),
            json: json!([]),
            trees: rows.len(),
            loaded: 0,
            matched: 0,
        };
        let mut js = Vec::new();
        for m in models.iter().filter(|m| !m.tree) {
            r.excluded.push(format!(
                "| {}/{} | {} |",
                m.package,
                m.rel,
                m.reason.replace('|', "\\|")
            ));
        }
        let mut at = 0;
        for (i, row) in rows {
            let mj = &models[*i];
            let name = format!("{}/{}", mj.package, mj.rel);
            let ours = match row {
                Err(e) => {
                    let e = e.replace(
                        &*mj.path
                            .parent()
                            .unwrap_or(Path::new(""))
                            .display()
                            .to_string(),
                        "…",
                    );
                    r.lines.push(format!(
                        "| {name} | – | refused | | | | | | | {} |",
                        e.replace('|', "\\|")
                    ));
                    js.push(json!({"model": name, "refused": e}));
                    continue;
                }
                Ok(o) => o,
            };
            r.loaded += 1;
            let res = &results[at];
            at += 1;
            let (mut em, mut ed, mut ea) = (0.0f64, 0.0f64, 0.0f64);
            for (s, t) in ours
                .states
                .iter()
                .zip(res["states"].as_array().into_iter().flatten())
            {
                let v = |k: &str| -> Vec<f64> {
                    t[k].as_array()
                        .into_iter()
                        .flatten()
                        .map(|x| x.as_f64().unwrap_or(f64::NAN))
                        .collect()
                };
                let (m, qacc) = (v("M"), v("qacc_smooth"));
                em = em.max(rel_err(&s.m, &m));
                ed = ed.max(rel_err(&s.dca, &qacc));
                ea = ea.max(rel_err(&s.aba, &qacc));
            }
            let has_ball = mj.joints.iter().any(|j| j.1 == "ball");
            let tol = if has_ball { BALL_TOLERANCE } else { TOLERANCE };
            let ok = em <= tol && ed <= tol && ea <= tol;
            r.matched += usize::from(ok);
            let mj_us = res["forward_us"].as_f64().unwrap_or(f64::NAN);
            let note = if mj.unmodelled.is_empty() {
                String::new()
            } else {
                format!("{} off in MuJoCo", mj.unmodelled.join(", "))
            };
            r.lines.push(format!(
                "| {name} | {} | {} | {em:.1e} | {ed:.1e} | {ea:.1e} | {:.2} | {:.2} | {mj_us:.2} | {note} |",
                ours.model.nv,
                if ok { "matches" } else { "**differs**" },
                ours.dca_us,
                ours.aba_us,
            ));
            js.push(
                json!({"model": name, "nv": ours.model.nv, "matches": ok, "m_err": em,
                "dca_err": ed, "aba_err": ea, "dca_us": ours.dca_us, "aba_us": ours.aba_us,
                "mujoco_forward_us": mj_us, "unmodelled": mj.unmodelled}),
            );
        }
        r.json = json!({"trees": r.trees, "loaded": r.loaded, "matched": r.matched, "models": js});
        r
    }

    fn markdown(&self, versions: &Value, quick: bool) -> String {
        let mut out = String::new();
        out.push_str(&format!(
            "MJCF corpus: {} kinematic-tree models, {} load, {} match MuJoCo to {TOLERANCE:e} \
             ({:.0}%); versions {versions}{}\n\n",
            self.trees,
            self.loaded,
            self.matched,
            100.0 * self.matched as f64 / self.trees.max(1) as f64,
            if quick { ", --quick" } else { "" },
        ));
        out.push_str(
            "| model | nv | result | M err | DCA q̈ err | ABA q̈ err | DCA µs | ABA µs | mj_forward µs | notes |\n\
             |---|---|---|---|---|---|---|---|---|---|\n",
        );
        for l in &self.lines {
            out.push_str(l);
            out.push('\n');
        }
        out.push_str("\nNot kinematic-tree models (not compared):\n\n| file | why |\n|---|---|\n");
        for l in &self.excluded {
            out.push_str(l);
            out.push('\n');
        }
        out
    }
}
