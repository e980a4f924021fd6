//! The hard cases of `cargo xtask stability` (section 5): long chains hanging straight,
//! near-straight and tilted, large neighbour mass ratios, and links with many children, each
//! solved by DCA and ABA and compared with the double-double reference.

use articula_dca::{forward_dynamics, Data, Method, State};
use articula_model::{LoadOptions, Model};
use articula_testkit::{ratio_chain_urdf, rel_error};
use articula_testkit::{Dd, ReferenceModel};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// How a case's joint angles are set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pose {
    /// Every joint at 0: the chain hangs straight down.
    Straight,
    /// Every joint at ±0.01 rad (seeded uniform).
    NearStraight,
    /// The first joint at 0.5 rad, the others at 0: a straight chain tilted in the world.
    Tilted,
    /// The first joint at 0.3 rad.
    TiltedLess,
    /// The first joint at 0.2 rad: on 100,000 links joins lose pivots out of the chain's
    /// plane and DCA's fixed-point refinement diverges; GMRES refines it
    /// (docs/algorithms.md, "When the refinement diverges").
    TiltedLeast,
    /// `State::random` angles (±1.2 rad), rates (±2 rad/s) and torques (±1 N·m).
    Random,
}

impl Pose {
    pub fn label(self) -> &'static str {
        match self {
            Pose::Straight => "straight",
            Pose::NearStraight => "near-straight (±0.01 rad)",
            Pose::Tilted => "tilted (q₁ = 0.5 rad)",
            Pose::TiltedLess => "tilted (q₁ = 0.3 rad)",
            Pose::TiltedLeast => "tilted (q₁ = 0.2 rad)",
            Pose::Random => "random",
        }
    }
}

/// What the case's model is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// `articula_testkit::chain(n)`, with neighbour mass ratio `ratio` when it is not 1
    /// ([`ratio_chain_urdf`]).
    Chain { links: usize, ratio: f64 },
    /// `articula_testkit::star_urdf(k)` on a floating hub: one link with `k` children.
    Star { children: usize },
}

/// One hard case.
#[derive(Clone, Copy, Debug)]
pub struct Case {
    pub shape: Shape,
    pub pose: Pose,
    /// τ₁ = 1 N·m on the first joint (the others 0), instead of the pose's torques.
    pub tau1: bool,
}

impl Case {
    pub fn label(&self) -> String {
        let what = match self.shape {
            Shape::Chain { links, ratio: 1.0 } => format!("chain {links}"),
            Shape::Chain { links, ratio } => format!("chain {links}, mass ratio {ratio:e}"),
            Shape::Star { children } => format!("hub with {children} children"),
        };
        let tau = if self.tau1 { ", τ₁ = 1" } else { "" };
        format!("{what}, {}{tau}", self.pose.label())
    }

    /// The case's model as URDF (fixed base).
    pub fn urdf(&self) -> String {
        match self.shape {
            Shape::Chain { links, ratio: 1.0 } => articula_testkit::chain_urdf(links),
            Shape::Chain { links, ratio } => ratio_chain_urdf(links, ratio),
            Shape::Star { children } => articula_testkit::star_urdf(children),
        }
    }

    pub fn state(&self, model: &Model) -> State {
        let mut s = match self.pose {
            Pose::Random => State::random(model, 1, 1.0),
            _ => State::neutral(model),
        };
        match self.pose {
            Pose::NearStraight => {
                let r = State::random(model, 2, 0.0);
                for (q, x) in s.q.iter_mut().zip(&r.q) {
                    *q = x / 120.0;
                }
            }
            Pose::Tilted => s.q[0] = 0.5,
            Pose::TiltedLess => s.q[0] = 0.3,
            Pose::TiltedLeast => s.q[0] = 0.2,
            _ => {}
        }
        if self.tau1 {
            s.tau.iter_mut().for_each(|t| *t = 0.0);
            s.tau[0] = 1.0;
        }
        s
    }
}

/// A chain case; a straight chain gets τ₁ = 1 (hanging at rest with τ = 0, q̈ = 0 exactly and
/// a relative error means nothing).
const fn chain(links: usize, ratio: f64, pose: Pose) -> Case {
    Case {
        shape: Shape::Chain { links, ratio },
        pose,
        tau1: matches!(pose, Pose::Straight),
    }
}

/// The cases of issue 24 (items 1, 2, 7) and issue 39 (the chains tilted 0.2 and 0.3 rad):
/// `full` adds the 100,000-link ones.
pub fn cases(full: bool) -> Vec<Case> {
    let mut v = vec![
        chain(300, 1.0, Pose::Tilted),
        chain(500, 1.0, Pose::Tilted),
        chain(1_000, 1.0, Pose::Tilted),
        chain(8_000, 1.0, Pose::Tilted),
        chain(9_000, 1.0, Pose::Tilted),
        chain(20_000, 1.0, Pose::Tilted),
        chain(20_000, 1.0, Pose::TiltedLess),
        chain(20_000, 1.0, Pose::TiltedLeast),
        chain(20_000, 1.0, Pose::Straight),
        Case {
            shape: Shape::Chain {
                links: 10_000,
                ratio: 1e3,
            },
            pose: Pose::Straight,
            tau1: true,
        },
        chain(1_000, 1e6, Pose::NearStraight),
        chain(100, 1e9, Pose::Tilted),
        chain(300, 1e9, Pose::NearStraight),
        chain(500, 1e9, Pose::Random),
        Case {
            shape: Shape::Star { children: 2_000 },
            pose: Pose::Random,
            tau1: false,
        },
    ];
    if full {
        v.extend([
            chain(100_000, 1.0, Pose::Straight),
            chain(100_000, 1.0, Pose::NearStraight),
            chain(100_000, 1.0, Pose::Tilted),
            chain(100_000, 1.0, Pose::TiltedLess),
            chain(100_000, 1.0, Pose::TiltedLeast),
        ]);
    }
    v
}

/// A case's errors: DCA's and ABA's (`Err`: the message of a refusal), and Pinocchio's where
/// it ran (`None`: not run — larger than [`PIN_MAX_LINKS`] or no peers Python).
pub struct Outcome {
    pub case: Case,
    pub dca: std::result::Result<f64, String>,
    pub aba: std::result::Result<f64, String>,
    pub pin: Option<std::result::Result<f64, String>>,
}

/// The largest model Pinocchio is run on: its `Data` for a 300-link chain takes 1.8 GiB
/// (docs/performance.md), and 1,000 links fail under 4 GiB.
pub const PIN_MAX_LINKS: usize = 300;

/// Pinocchio's `pin.aba` on `urdf` at `state` (`peers/pin_qdd.py` with the peers' Python);
/// `None` without that Python.
fn pinocchio_qdd(urdf: &str, state: &State) -> Option<std::result::Result<Vec<f64>, String>> {
    let root = crate::workspace_root();
    let python = crate::bench::peers_python(&root);
    if !python.exists() {
        return None;
    }
    let run = || -> std::result::Result<Vec<f64>, String> {
        let dir = root.join("target/articula-stability");
        std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
        let path = dir.join("pin_case.urdf");
        std::fs::write(&path, urdf).map_err(|e| e.to_string())?;
        let mut child = std::process::Command::new(&python)
            .arg(root.join("peers/pin_qdd.py"))
            .arg(&path)
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .map_err(|e| e.to_string())?;
        let input = serde_json::json!({"q": state.q, "qd": state.qd, "tau": state.tau});
        {
            use std::io::Write;
            let mut stdin = child.stdin.take().ok_or("no stdin")?;
            stdin
                .write_all(input.to_string().as_bytes())
                .map_err(|e| e.to_string())?;
        }
        let out = child.wait_with_output().map_err(|e| e.to_string())?;
        if !out.status.success() {
            return Err(String::from_utf8_lossy(&out.stderr).into_owned());
        }
        serde_json::from_slice(&out.stdout).map_err(|e| e.to_string())
    };
    Some(run())
}

/// Runs `case`: DCA and ABA against the double-double reference.
pub fn run_case(case: Case) -> Result<Outcome> {
    let urdf = case.urdf();
    let model = Model::from_urdf_str(&urdf, &LoadOptions::default())?;
    let state = case.state(&model);
    let reference = ReferenceModel::new(&model)?;
    let exact: Vec<f64> = reference
        .aba::<Dd>(&state.q, &state.qd, &state.tau, &state.f_ext)
        .iter()
        .map(|x| x.to_f64())
        .collect();
    let mut data = Data::new(&model);
    let mut err = |m: Method| {
        forward_dynamics(&model, &mut data, &state, m)
            .map(|q| rel_error(q, &exact))
            .map_err(|e| e.to_string())
    };
    let dca = err(Method::Dca);
    let aba = err(Method::Aba);
    let pin = (model.bodies.len() <= PIN_MAX_LINKS)
        .then(|| pinocchio_qdd(&urdf, &state))
        .flatten()
        .map(|r| r.map(|q| rel_error(&q, &exact)));
    Ok(Outcome {
        case,
        dca,
        aba,
        pin,
    })
}

pub fn cell(r: &std::result::Result<f64, String>) -> String {
    match r {
        Ok(x) => format!("{x:.1e}"),
        Err(_) => "refused".into(),
    }
}

/// `cargo xtask stability cases [--full]`: prints the table only.
pub fn print(full: bool) -> Result<()> {
    for case in cases(full) {
        let t = std::time::Instant::now();
        let o = run_case(case)?;
        println!(
            "  {:<52} DCA {:>8}  ABA {:>8}  Pinocchio {:>8}  ({:.1} s){}",
            case.label(),
            cell(&o.dca),
            cell(&o.aba),
            o.pin.as_ref().map_or("—".into(), cell),
            t.elapsed().as_secs_f64(),
            match (&o.dca, &o.aba) {
                (Err(e), _) | (_, Err(e)) => format!("  [{e}]"),
                _ => String::new(),
            }
        );
    }
    Ok(())
}
