//! `cargo xtask pinocchio`: articula's quantities around forward dynamics against Pinocchio's
//! on the humanoid (floating and fixed base) at seeded random states — inverse dynamics
//! (`rnea`), the mass matrix (`crba`), the bias forces (`nonLinearEffects`), the centre of mass
//! and its Jacobian, the energies, the centroidal momentum, and per link its world pose, its
//! Jacobians in the three reference frames (`getFrameJacobian`) and a point Jacobian.
//! Pinocchio runs in `peers/quantities.py` with the peers' Python (`$ARTICULA_PEERS_PYTHON`,
//! else `target/peers-venv`). Not part of CI: it needs that Python.

use articula_dca::{
    bias_forces, forward_kinematics, inverse_dynamics, mass_matrix, Data, ReferenceFrame, State,
};
use articula_model::{JointKind, LoadOptions, Model};
use glam::DVec3;
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

/// Links compared: a hand (a body's own link), a palm (welded to the hand by a fixed joint), a
/// foot at the end of a composed ankle, the head camera, and the root.
const LINKS: [&str; 5] = ["l_hand", "r_hand_palm", "l_foot", "head_camera", "pelvis"];
/// Largest difference allowed, relative to the largest entry of each quantity.
const TOLERANCE: f64 = 1e-10;

pub fn run(root: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let python = crate::bench::peers_python(root);
    if !python.exists() {
        return Err(format!(
            "no Python at {} (create it with `python3 -m venv target/peers-venv && \
             target/peers-venv/bin/pip install pin`, or set ARTICULA_PEERS_PYTHON)",
            python.display()
        )
        .into());
    }
    let urdf = root.join("models/humanoid.urdf");
    let mut worst = 0.0f64;
    for floating_base in [true, false] {
        let model = Model::from_urdf_file(
            &urdf,
            &LoadOptions::default().with_floating_base(floating_base),
        )?;
        let links: Vec<&str> = LINKS
            .into_iter()
            .filter(|l| model.find_link(l).is_some_and(|f| f.body.is_some()))
            .collect();
        let points: Vec<[f64; 3]> = (0..links.len())
            .map(|k| [0.05 * k as f64, -0.03, 0.02 + 0.01 * k as f64])
            .collect();
        let states: Vec<State> = (0..3)
            .map(|seed| State::random(&model, seed, 5.0))
            .collect();
        let qdds: Vec<Vec<f64>> = (0..states.len())
            .map(|k| {
                (0..model.nv)
                    .map(|j| ((j + 7 * k) as f64 * 0.61).sin() * 3.0)
                    .collect()
            })
            .collect();
        let request = json!({
            "urdf": urdf,
            "floating_base": floating_base,
            "nq": model.nq,
            "nv": model.nv,
            "joints": model.joint_parts().map(|(_, p)| json!({
                "name": p.name,
                "kind": if p.kind == JointKind::Floating { "floating" } else { "1dof" },
                "q_offset": p.q_offset,
                "v_offset": p.v_offset,
            })).collect::<Vec<_>>(),
            "links": links,
            "points": points,
            "states": states.iter().zip(&qdds).map(|(s, qdd)| json!({
                "q": s.q, "qd": s.qd, "qdd": qdd,
            })).collect::<Vec<_>>(),
        });
        let pin = run_python(&python, &root.join("peers/quantities.py"), &request)?;
        println!(
            "humanoid, {} base, Pinocchio {} (largest difference / largest entry):",
            if floating_base { "floating" } else { "fixed" },
            pin["pinocchio"].as_str().unwrap_or("?")
        );
        let mut data = Data::new(&model);
        let mut rows: Vec<(String, f64)> = Vec::new();
        let mut note = |what: &str, ours: &[f64], theirs: &Value| {
            let theirs = flatten(theirs);
            assert_eq!(ours.len(), theirs.len(), "{what}: sizes differ");
            let scale = ours.iter().fold(1e-300f64, |m, x| m.max(x.abs()));
            let diff = ours
                .iter()
                .zip(&theirs)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            match rows.iter_mut().find(|(w, _)| w == what) {
                Some((_, r)) => *r = r.max(diff / scale),
                None => rows.push((what.to_string(), diff / scale)),
            }
        };
        for ((s, qdd), theirs) in states
            .iter()
            .zip(&qdds)
            .zip(pin["states"].as_array().unwrap())
        {
            let tau = inverse_dynamics(&model, &mut data, &s.q, &s.qd, qdd, &[])?.to_vec();
            note("rnea", &tau, &theirs["tau"]);
            let b = bias_forces(&model, &mut data, &s.q, &s.qd)?.to_vec();
            note("nonLinearEffects", &b, &theirs["bias_forces"]);
            let m = mass_matrix(&model, &mut data, &s.q)?.to_vec();
            note("crba", &m, &theirs["mass_matrix"]);
            forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
            if floating_base {
                // With a fixed base the root link is welded to the world: articula leaves it
                // out of the centre of mass and the energies (`Model::ground_mass`), so these
                // are compared with a floating base only.
                note(
                    "centerOfMass",
                    &data.center_of_mass().to_array(),
                    &theirs["com"],
                );
                let jc = data.com_jacobian(&model)?.to_vec();
                note("jacobianCenterOfMass", &jc, &theirs["com_jacobian"]);
                note(
                    "computeKineticEnergy",
                    &[data.kinetic_energy()],
                    &theirs["kinetic_energy"],
                );
                note(
                    "computePotentialEnergy",
                    &[data.potential_energy()],
                    &theirs["potential_energy"],
                );
                let h = data.centroidal_momentum().to_array();
                note(
                    "computeCentroidalMomentum",
                    &h,
                    &theirs["centroidal_momentum"],
                );
            }
            for ((name, point), l) in links
                .iter()
                .zip(&points)
                .zip(theirs["links"].as_array().unwrap())
            {
                let link = model.find_link(name).unwrap();
                let (r, p) = data.link_pose(&link)?;
                let r: Vec<f64> = (0..3)
                    .flat_map(|i| (0..3).map(move |j| r.col(j)[i]))
                    .collect();
                note("oMf rotation", &r, &l["rotation"]);
                note("oMf translation", &p.to_array(), &l["translation"]);
                for (key, frame) in [
                    ("world", ReferenceFrame::World),
                    ("local", ReferenceFrame::Local),
                    ("local_world_aligned", ReferenceFrame::LocalWorldAligned),
                ] {
                    let j = data.link_jacobian(&model, &link, frame)?.to_vec();
                    note(
                        &format!("getFrameJacobian {}", key.to_uppercase()),
                        &j,
                        &l["jacobian"][key],
                    );
                }
                let jp = data
                    .point_jacobian(&model, &link, DVec3::from_array(*point))?
                    .to_vec();
                note("point Jacobian", &jp, &l["point_jacobian"]);
            }
        }
        for (what, rel) in &rows {
            println!("  {what:<38} {rel:.1e}");
            worst = worst.max(*rel);
        }
    }
    if worst > TOLERANCE {
        return Err(format!(
            "a quantity differs from Pinocchio's by {worst:.1e} (> {TOLERANCE:e})"
        )
        .into());
    }
    println!("all within {TOLERANCE:e} of Pinocchio's");
    Ok(())
}

/// Runs `script` with `request` on stdin and parses the JSON it prints.
fn run_python(
    python: &Path,
    script: &Path,
    request: &Value,
) -> Result<Value, Box<dyn std::error::Error>> {
    let mut child = Command::new(python)
        .arg(script)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()?;
    child
        .stdin
        .take()
        .ok_or("no stdin")?
        .write_all(request.to_string().as_bytes())?;
    let out = child.wait_with_output()?;
    if !out.status.success() {
        return Err(format!(
            "{} failed ({}): {}",
            script.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )
        .into());
    }
    Ok(serde_json::from_slice(&out.stdout)?)
}

/// The numbers of a JSON number or (nested) array, row by row.
fn flatten(v: &Value) -> Vec<f64> {
    match v {
        Value::Array(xs) => xs.iter().flat_map(flatten).collect(),
        x => vec![x.as_f64().unwrap_or(f64::NAN)],
    }
}
