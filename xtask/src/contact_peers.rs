//! `cargo xtask contact-peers`: robots on the floor in articula and in MuJoCo, side by side
//! (`docs/contact.md#against-mujoco`).
//!
//! Builds `target/release/articula`, writes the bundled crowd's start states, springs and
//! pushes as the scene itself computes them (`target/contact-peers/crowd200.json`), then runs
//! `peers/contact_peers.py` in the peers' venv, which alternates articula's command line and
//! MuJoCo's `mj_step` on each case, one thread, and prints the table.

use articula_view::{load_scene, pose_springs, SceneSim};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

/// The scene the crowd case runs.
const CROWD: &str = "models/scenes/crowd200.json";

/// The arguments of `cargo xtask contact-peers`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// Rounds of every case.
    #[arg(long, value_name = "N", default_value_t = 3, value_parser = crate::args::count,
          allow_negative_numbers = true)]
    pub rounds: usize,
    /// Only the cases whose name contains one of these (humanoid, anymal, crowd).
    #[arg(long, value_name = "CASES", default_value = "")]
    pub only: String,
    /// The Python venv with mujoco and example-robot-data [default: target/peers-venv].
    #[arg(long, value_name = "DIR")]
    pub venv: Option<PathBuf>,
}

/// The crowd's start states (root position and quaternion), springs per joint (name,
/// stiffness, damping) and pushes, from the scene's own loading.
fn crowd_spec(root: &Path) -> Result<Value, String> {
    let scene = load_scene(root.join(CROWD)).map_err(|e| format!("{CROWD}: {e}"))?;
    let sim = SceneSim::new(&scene).map_err(|e| format!("{CROWD}: {e}"))?;
    let model = &scene.models[0].model;
    let sp = scene
        .joint_springs
        .ok_or(format!("{CROWD} has no joint_springs"))?;
    let names: Vec<(usize, &str)> = model
        .joint_parts()
        .map(|(_, p)| (p.v_offset, p.name.as_str()))
        .collect();
    let springs: Vec<Value> = pose_springs(
        model,
        sp.frequency_hz,
        sp.damping_ratio,
        scene.dt,
        scene.ground.is_some(),
    )
    .into_iter()
    .map(|(_, v, k, c)| {
        let name = names.iter().find(|n| n.0 == v).map_or("?", |n| n.1);
        json!([name, k, c])
    })
    .collect();
    let bodies: Vec<Value> = sim
        .bodies
        .iter()
        .map(|b| json!({"position": &b.state.q[0..3], "quaternion_wxyz": &b.state.q[3..7]}))
        .collect();
    let chest = model.find_link("chest").and_then(|l| l.body);
    let pushes: Vec<Value> = scene
        .pushes
        .iter()
        .map(|p| {
            if Some(p.link_body) != chest {
                return Err(format!("{CROWD}: a push not on the chest"));
            }
            Ok(json!({"bodies": [p.body], "point": p.point.to_array(),
                      "force": p.force.to_array(), "t0": p.t0, "t1": p.t1}))
        })
        .collect::<Result<_, _>>()?;
    Ok(json!({"dt": scene.dt, "bodies": bodies, "springs": springs, "pushes": pushes}))
}

/// 0 when every case ran, 1 when one failed, 2 on a missing venv (clap exits 2 on bad
/// arguments).
pub fn main(root: &Path, opts: &Options) -> ExitCode {
    let venv = crate::args::peers_venv(root, opts.venv.as_deref());
    let needs = "the harness needs mujoco and example-robot-data";
    let python = match crate::corpus::venv_python(&venv, needs, crate::corpus::INSTALL) {
        Ok(p) => p,
        Err(code) => return code,
    };
    match run(root, opts, &python) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(root: &Path, opts: &Options, python: &Path) -> Result<(), String> {
    let status = Command::new(env!("CARGO"))
        .args(["build", "--release", "-p", "articula-cli"])
        .current_dir(root)
        .status()
        .map_err(|e| format!("cargo build: {e}"))?;
    if !status.success() {
        return Err("cargo build --release -p articula-cli failed".into());
    }
    let out = root.join("target/contact-peers");
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let crowd = out.join("crowd200.json");
    let spec = crowd_spec(root)?;
    std::fs::write(&crowd, spec.to_string()).map_err(|e| format!("{}: {e}", crowd.display()))?;
    let status = Command::new(python)
        .arg(root.join("peers/contact_peers.py"))
        .arg("--articula")
        .arg(root.join("target/release/articula"))
        .arg("--crowd")
        .arg(&crowd)
        .args(["--rounds", &opts.rounds.to_string(), "--only", &opts.only])
        .arg("--json")
        .arg(out.join("report.json"))
        .current_dir(root)
        .status()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if !status.success() {
        return Err("peers/contact_peers.py failed".into());
    }
    Ok(())
}
