//! The import policy end to end (docs/loading.md): small URDFs of each defect kind through the
//! loader and the `articula` binary — placeholder links welded by fixed joints, round-off
//! inertias, triangle violations, indefinite bodies, massless leaves (locked joints against the
//! same model without them, by DCA, ABA and CRBA), deep nesting and oversize inputs.

use articula_dca::SplitMix64;
use articula_dca::{forward_dynamics_slices, Data, Method};
use articula_model::{
    InertiaDefectKind, InertiaPolicy, LoadOptions, LoadWarning, MasslessLeafPolicy, Model,
    ModelError,
};
use std::path::PathBuf;
use std::process::{Command, Output};

fn articula(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_articula"))
        .args(args)
        .output()
        .expect("cannot run the articula binary")
}

/// A file in a scratch directory of this test process.
fn scratch_file(name: &str, contents: &[u8]) -> PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("articula-loading-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("cannot create a temp dir");
    let path = dir.join(name);
    std::fs::write(&path, contents).expect("cannot write a temp file");
    path
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn link(name: &str, mass: f64, com: &str, i: [f64; 3]) -> String {
    format!(
        "<link name=\"{name}\"><inertial><origin xyz=\"{com}\"/><mass value=\"{mass}\"/>\
         <inertia ixx=\"{}\" ixy=\"0\" ixz=\"0\" iyy=\"{}\" iyz=\"0\" izz=\"{}\"/></inertial></link>\n",
        i[0], i[1], i[2]
    )
}

fn joint(name: &str, kind: &str, parent: &str, child: &str, xyz: &str, axis: &str) -> String {
    format!(
        "<joint name=\"{name}\" type=\"{kind}\"><origin xyz=\"{xyz}\" rpy=\"0.1 0.2 0.3\"/>\
         <parent link=\"{parent}\"/><child link=\"{child}\"/><axis xyz=\"{axis}\"/></joint>\n"
    )
}

fn robot(parts: &[String]) -> String {
    format!("<robot name=\"t\">\n{}</robot>\n", parts.concat())
}

/// A three-link arm; `fingers` adds a massless two-joint finger (one mimic joint) on the
/// middle link and a massless one-joint sensor mast on the base.
fn arm(fingers: bool) -> String {
    let mut parts = vec![
        link("base", 3.0, "0 0 0.05", [0.03, 0.04, 0.05]),
        link("upper", 1.5, "0 0 -0.2", [0.02, 0.025, 0.006]),
        link("fore", 1.0, "0.02 0 -0.15", [0.01, 0.012, 0.004]),
        link("hand", 0.4, "0 0.01 -0.05", [0.001, 0.0012, 0.0009]),
        joint(
            "shoulder",
            "revolute",
            "base",
            "upper",
            "0 0.1 0.2",
            "0 1 0",
        ),
        joint("elbow", "revolute", "upper", "fore", "0 0 -0.4", "1 0 0"),
        joint("wrist", "prismatic", "fore", "hand", "0 0 -0.3", "0 0 1"),
    ];
    if fingers {
        parts.extend([
            "<link name=\"knuckle\"/>\n".to_string(),
            "<link name=\"tip\"/>\n".to_string(),
            "<link name=\"pad\"/>\n".to_string(),
            "<link name=\"mast\"/>\n".to_string(),
            joint(
                "finger1",
                "revolute",
                "fore",
                "knuckle",
                "0.05 0 -0.1",
                "0 0 1",
            ),
            joint(
                "finger2",
                "continuous",
                "knuckle",
                "tip",
                "0.03 0 0",
                "0 0 1",
            )
            .replace("</joint>", "<mimic joint=\"finger1\"/></joint>"),
            joint("pad_weld", "fixed", "tip", "pad", "0.01 0 0", "1 0 0"),
            joint("mast", "prismatic", "base", "mast", "0 0 0.3", "0 0 1"),
        ]);
    }
    robot(&parts)
}

/// Random q, qd, τ for `model`, by joint name, drawn for `reference`'s joints first so that
/// both models get the same numbers on their common joints; joints only in `model` (locked)
/// get random values too (which must not matter).
fn states(reference: &Model, model: &Model, seed: u64) -> [(Vec<f64>, Vec<f64>, Vec<f64>); 2] {
    let mut rng = SplitMix64(seed);
    let mut out = [reference, model].map(|m| (m.neutral_q(), vec![0.0; m.nv], vec![0.0; m.nv]));
    let mut fill = |name: &str, nq: usize, nv: usize| {
        let q: Vec<f64> = (0..nq).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let v: Vec<f64> = (0..nv).map(|_| rng.uniform(-2.0, 2.0)).collect();
        let t: Vec<f64> = (0..nv).map(|_| rng.uniform(-3.0, 3.0)).collect();
        for (m, (qs, vs, ts)) in [reference, model].iter().zip(out.iter_mut()) {
            if let Some(p) = m.coordinate_parts().find(|p| p.name == name) {
                if p.nq() == 1 {
                    qs[p.q_offset] = q[0];
                }
                vs[p.v_offset..p.v_offset + nv].copy_from_slice(&v);
                ts[p.v_offset..p.v_offset + nv].copy_from_slice(&t);
            }
        }
    };
    for p in model.coordinate_parts() {
        fill(&p.name, p.nq(), p.nv());
    }
    out
}

#[test]
fn locked_joints_leave_the_rest_as_without_them() {
    for floating in [false, true] {
        let options = LoadOptions::default().with_floating_base(floating);
        let with = Model::from_urdf_str(&arm(true), &options).unwrap();
        let without = Model::from_urdf_str(&arm(false), &options).unwrap();
        assert_eq!(with.locked_joints(), vec!["finger1", "finger2", "mast"]);
        assert_eq!(with.nv, without.nv + 3);
        assert_eq!(with.bodies.len(), without.bodies.len());
        // Every locked joint is a warning; the mimic joint too.
        let locked_warnings = with
            .warnings
            .iter()
            .filter(|w| matches!(w, LoadWarning::LockedJoint { .. }))
            .count();
        assert_eq!(locked_warnings, 3);
        // The finger's links are welded to the forearm at the neutral position.
        let fore = with.bodies.iter().find(|b| b.name == "fore").unwrap();
        let welded: Vec<&str> = fore.links.iter().map(|l| l.0.as_str()).collect();
        assert_eq!(welded, vec!["fore", "knuckle", "tip", "pad"]);
        for seed in 1..=5 {
            let [(q0, v0, t0), (q1, v1, t1)] = states(&without, &with, seed);
            for method in [Method::Dca, Method::Aba, Method::Crba] {
                let mut d0 = Data::new(&without);
                let mut d1 = Data::new(&with);
                let a0 = forward_dynamics_slices(&without, &mut d0, &q0, &v0, &t0, &[], method)
                    .unwrap()
                    .to_vec();
                let a1 = forward_dynamics_slices(&with, &mut d1, &q1, &v1, &t1, &[], method)
                    .unwrap()
                    .to_vec();
                let scale = a0.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                for p in with.coordinate_parts() {
                    let got = &a1[p.v_offset..p.v_offset + p.nv()];
                    match without.coordinate_parts().find(|r| r.name == p.name) {
                        Some(r) => {
                            let want = &a0[r.v_offset..r.v_offset + r.nv()];
                            for (g, w) in got.iter().zip(want) {
                                assert!(
                                    (g - w).abs() <= 1e-12 * scale,
                                    "{method:?} floating={floating} {}: {g} vs {w}",
                                    p.name
                                );
                            }
                        }
                        // Locked: exactly zero, whatever its qd and τ.
                        None => assert!(got.iter().all(|&x| x == 0.0), "{}: {got:?}", p.name),
                    }
                }
            }
        }
    }
}

#[test]
fn massless_leaves_refused_on_request_all_named() {
    let e = Model::from_urdf_str(
        &arm(true),
        &LoadOptions::default().with_massless_leaf(MasslessLeafPolicy::Refuse),
    )
    .unwrap_err();
    assert_eq!(
        e,
        ModelError::SingularMassless {
            leaves: vec![
                ("knuckle".into(), "finger1".into()),
                ("mast".into(), "mast".into())
            ]
        }
    );
}

#[test]
fn a_welded_placeholder_is_no_defect() {
    // A 1e-6 kg placeholder whose own inertia breaks the triangle inequality (1e-5 > 2e-9),
    // welded to a body: the merged body is fine, so strict loads it without a warning.
    let text = robot(&[
        link("base", 2.0, "0 0 0", [0.02, 0.02, 0.02]),
        link("trunk", 5.0, "0 0 0.1", [0.1, 0.1, 0.05]),
        link("imu", 1e-6, "0 0 0", [1e-9, 1e-9, 1e-5]),
        joint("hip", "revolute", "base", "trunk", "0 0 0.2", "0 0 1"),
        joint("imu_weld", "fixed", "trunk", "imu", "0.1 0 0", "1 0 0"),
    ]);
    let strict = LoadOptions::default().with_inertia(InertiaPolicy::Strict);
    for floating in [false, true] {
        let m = Model::from_urdf_str(&text, &strict.with_floating_base(floating)).unwrap();
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    }
}

#[test]
fn round_off_never_refuses() {
    // icub's head: a zero inertia with ixz = 2.40741e-35, and a diagonal negative by 1e-12 of
    // the body's scale: both within tolerance. Accept loads both as written, with a warning,
    // and DCA (which inverts a regularised copy and refines) agrees with ABA on them.
    let text = robot(&[
        link("base", 2.0, "0 0 0", [0.02, 0.02, 0.02]),
        "<link name=\"head\"><inertial><origin xyz=\"0.0185 -0.1108 6.78454e-18\"/><mass value=\"1.33687\"/>\
         <inertia ixx=\"0\" ixy=\"0\" ixz=\"2.40741e-35\" iyy=\"0\" iyz=\"0\" izz=\"0\"/></inertial></link>\n"
            .to_string(),
        link("jaw", 0.5, "0.05 0 0", [-1e-14, 0.002, 0.002]),
        joint("neck", "revolute", "base", "head", "0 0 0.3", "0 0 1"),
        joint("chew", "revolute", "head", "jaw", "0.05 0 0", "0 1 0"),
    ]);
    let m = Model::from_urdf_str(&text, &LoadOptions::default()).unwrap();
    let odd: Vec<String> = m
        .warnings
        .iter()
        .filter_map(|w| match w {
            LoadWarning::OddInertia(d) => Some(d[0].body.clone()),
            LoadWarning::InertiaChanged(c) => panic!("changed: {c}"),
            _ => None,
        })
        .collect();
    assert_eq!(odd, vec!["head", "jaw"]);
    // Not raised (repair would set the moments to ~1e-11): zero up to the parallel-axis round-off.
    let ic = m.bodies[0].inertia.inertia_about_com().to_cols_array();
    assert!(ic.iter().all(|x| x.abs() < 1e-30), "{ic:?}");
    let mut data = Data::new(&m);
    let q = [0.3, -0.4];
    let v = [1.0, -2.0];
    let t = [0.1, 0.05];
    let dca = forward_dynamics_slices(&m, &mut data, &q, &v, &t, &[], Method::Dca)
        .unwrap()
        .to_vec();
    let aba = forward_dynamics_slices(&m, &mut data, &q, &v, &t, &[], Method::Aba)
        .unwrap()
        .to_vec();
    for (a, b) in dca.iter().zip(&aba) {
        assert!(
            (a - b).abs() <= 1e-10 * a.abs().max(1.0),
            "{dca:?} vs {aba:?}"
        );
    }
    // Strict names both, each with its numbers.
    let e = Model::from_urdf_str(
        &text,
        &LoadOptions::default().with_inertia(InertiaPolicy::Strict),
    )
    .unwrap_err();
    let ModelError::Inertia { defects, .. } = &e else {
        panic!("{e}")
    };
    let kinds: Vec<(&str, InertiaDefectKind)> =
        defects.iter().map(|d| (d.body.as_str(), d.kind)).collect();
    assert_eq!(
        kinds,
        vec![
            ("head", InertiaDefectKind::Singular),
            ("jaw", InertiaDefectKind::Singular)
        ]
    );
}

/// Two odd bodies: `upper` breaks the triangle inequality by 0.05 (0.08 > 0.01 + 0.02), `fore`
/// is indefinite (−0.001).
fn odd_arm() -> String {
    robot(&[
        link("base", 3.0, "0 0 0", [0.03, 0.03, 0.03]),
        link("upper", 1.5, "0 0 -0.2", [0.01, 0.02, 0.08]),
        link("fore", 1.0, "0 0 -0.15", [-0.001, 0.01, 0.01]),
        joint("shoulder", "revolute", "base", "upper", "0 0 0.2", "0 1 0"),
        joint("elbow", "revolute", "upper", "fore", "0 0 -0.4", "1 0 0"),
    ])
}

#[test]
fn policies_on_triangle_and_indefinite_bodies() {
    let text = odd_arm();
    // Accept refuses the indefinite body only, naming the repair policy.
    let e = Model::from_urdf_str(&text, &LoadOptions::default()).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("'fore'") && !msg.contains("'upper'"), "{msg}");
    assert!(msg.contains("--inertia repair"), "{msg}");
    // Strict lists both, with their numbers.
    let e = Model::from_urdf_str(
        &text,
        &LoadOptions::default().with_inertia(InertiaPolicy::Strict),
    )
    .unwrap_err();
    let msg = e.to_string();
    assert!(msg.starts_with("2 bodies"), "{msg}");
    assert!(
        msg.contains("'upper'") && msg.contains("by 5.000e-2"),
        "{msg}"
    );
    assert!(
        msg.contains("'fore'") && msg.contains("λ1 = -1.000000e-3"),
        "{msg}"
    );
    // Repair fixes both, reporting before and after; the results are rigid-body inertias.
    let m = Model::from_urdf_str(
        &text,
        &LoadOptions::default().with_inertia(InertiaPolicy::Repair),
    )
    .unwrap();
    let changes: Vec<_> = m
        .warnings
        .iter()
        .filter_map(|w| match w {
            LoadWarning::InertiaChanged(c) => Some(c.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(changes.len(), 2);
    let upper = &changes[0];
    assert_eq!(upper.fixes, vec!["balanceinertia"]);
    // Half the excess 0.05 onto each smaller moment: 0.035, 0.045, 0.08.
    for (got, want) in upper.moments.iter().zip([0.035, 0.045, 0.08]) {
        assert!((got - want).abs() < 1e-15, "{:?}", upper.moments);
    }
    assert!(m.warnings[0].to_string().contains("→"), "{}", m.warnings[0]);
    let fore = &changes[1];
    // λ1 raised from −0.001 to 1e-9 of the scale leaves λ3 = λ2 ≤ λ1 + λ2: no balancing.
    assert_eq!(fore.fixes, vec!["boundinertia"]);
    let [l1, l2, l3] = fore.moments;
    assert!(
        l1 > 0.0 && l3 <= (l1 + l2) * (1.0 + 1e-12),
        "{:?}",
        fore.moments
    );
}

#[test]
fn cli_inertia_flag_and_json_warnings() {
    let path = scratch_file("odd_arm.urdf", odd_arm().as_bytes());
    let p = path.to_str().unwrap();
    // Default: refused, exit 2, naming the flag.
    let out = articula(&["info", p]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("--inertia repair"),
        "{}",
        stderr(&out)
    );
    let out = articula(&["info", "--inertia", "strict", p]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("2 bodies"), "{}", stderr(&out));
    // Repair: loads; --json lists the two changes.
    let out = articula(&["info", "--json", "--inertia", "repair", p]);
    assert!(out.status.success(), "{}", stderr(&out));
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let warnings = info["warnings"].as_array().unwrap();
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(warnings[1].as_str().unwrap().contains("body 'fore'"));
    // fd, simulate and bench take the flag too; warnings go to stderr.
    for cmd in [
        vec!["fd", p, "--inertia", "repair"],
        vec![
            "simulate",
            p,
            "--inertia",
            "repair",
            "--steps",
            "2",
            "--dt",
            "0.001",
        ],
        vec!["bench", p, "--inertia", "repair", "--reps", "3"],
    ] {
        let out = articula(&cmd);
        assert!(out.status.success(), "{cmd:?}: {}", stderr(&out));
        assert!(stderr(&out).contains("warning: body 'upper'"), "{cmd:?}");
    }
}

/// `--bound-mass` and `--bound-inertia`: an error without `--inertia repair` (they would do
/// nothing), and with it a change of every body below them, reported by `info`.
#[test]
fn cli_repair_bounds() {
    // `fore` is a 1 kg point mass 2 mm from its joint; `base` (moments 0.03) is above the bound.
    let text = robot(&[
        link("base", 3.0, "0 0 0", [0.03, 0.03, 0.03]),
        link("fore", 1.0, "0.002 0 0", [0.0, 0.0, 0.0]),
        joint("elbow", "revolute", "base", "fore", "0 0 -0.4", "0 0 1"),
    ]);
    let path = scratch_file("point_fore.urdf", text.as_bytes());
    let p = path.to_str().unwrap();
    for (flag, cmd) in [
        (
            "--bound-inertia",
            vec!["info", p, "--bound-inertia", "1e-4"],
        ),
        ("--bound-mass", vec!["fd", p, "--bound-mass", "0.5"]),
        (
            "--bound-inertia",
            vec!["info", p, "--inertia", "strict", "--bound-inertia", "1e-4"],
        ),
    ] {
        let out = articula(&cmd);
        assert_eq!(out.status.code(), Some(2), "{cmd:?}");
        let err = stderr(&out);
        assert!(
            err.starts_with("error: ") && err.contains(flag) && err.contains("--inertia repair"),
            "{cmd:?}: {err}"
        );
    }
    // A bad value is refused by name.
    let out = articula(&["info", p, "--inertia", "repair", "--bound-mass", "-1"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("--bound-mass"), "{}", stderr(&out));
    // With repair: `fore`'s moments go from 0 to the bound, and only `fore` changes.
    let out = articula(&[
        "info",
        "--json",
        p,
        "--inertia",
        "repair",
        "--bound-inertia",
        "1e-4",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let warnings: Vec<&str> = info["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("body 'fore': boundinertia")
            && warnings[0].contains("→ [1.000000e-4, 1.000000e-4, 1.000000e-4]")
            && warnings[0].contains("below bound_inertia 1e-4"),
        "{}",
        warnings[0]
    );
    // fd then gives the elbow q̈ = τ / (b + m d²) about its axis (no gravity).
    let state = scratch_file("point_fore_state.json", br#"{"tau": {"elbow": [0.2]}}"#);
    let out = articula(&[
        "fd",
        p,
        "--inertia",
        "repair",
        "--bound-inertia",
        "1e-4",
        "--gravity",
        "0,0,0",
        "--state",
        state.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let fd: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let qdd = fd["qdd"]["elbow"][0].as_f64().unwrap();
    let want = 0.2 / (1e-4 + 1.0 * 0.002 * 0.002);
    assert!((qdd - want).abs() < 1e-10 * want, "{qdd} vs {want}");
}

#[test]
fn cli_lists_locked_joints() {
    let path = scratch_file("fingers.urdf", arm(true).as_bytes());
    let p = path.to_str().unwrap();
    let out = articula(&["info", "--json", p]);
    assert!(out.status.success(), "{}", stderr(&out));
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let locked: Vec<&str> = info["locked_joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["joint"].as_str().unwrap())
        .collect();
    assert_eq!(locked, vec!["finger1", "finger2", "mast"]);
    let out = articula(&["info", p]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("locked joints"), "{text}");
    // fd reports their q̈ as exactly 0, never NaN.
    let out = articula(&["fd", p]);
    assert!(out.status.success(), "{}", stderr(&out));
    let fd: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(fd["qdd"]["finger2"][0].as_f64(), Some(0.0));
    assert!(fd["qdd"]["elbow"][0].as_f64().unwrap().is_finite());
}

#[test]
fn deep_nesting_is_refused_not_a_stack_overflow() {
    // 30,000 nested elements in 210 KB: roxmltree recurses once per level.
    let n = 30_000;
    let text = format!(
        "<robot name=\"r\"><link name=\"a\"/>{}{}</robot>",
        "<x>".repeat(n),
        "</x>".repeat(n)
    );
    let e = Model::from_urdf_str(&text, &LoadOptions::default()).unwrap_err();
    assert_eq!(
        e,
        ModelError::TooDeep {
            line: 1,
            column: 33 + 3 * 255,
            limit: 256
        }
    );
    let path = scratch_file("deep.urdf", text.as_bytes());
    let out = articula(&["info", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("nested deeper than 256"),
        "{}",
        stderr(&out)
    );
    // Nesting hidden in comments, CDATA and attribute values does not count.
    let hidden = format!(
        "<robot name=\"r\"><!-- {} --><link name=\"a\" note=\"{}\"/><![CDATA[{}]]></robot>",
        "<x>".repeat(n),
        "&lt;x>".repeat(10),
        "<x>".repeat(n)
    );
    Model::from_urdf_str(&hidden, &LoadOptions::default()).unwrap();
}

#[test]
fn oversize_inputs_stop_at_the_limit() {
    // /dev/zero as a state file, a URDF and a scene: read up to the limit, exit 2.
    let urdf = scratch_file("pendulum.urdf", arm(false).as_bytes());
    let u = urdf.to_str().unwrap();
    let out = articula(&["fd", u, "--state", "/dev/zero"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("larger than the limit of 16777216 bytes"),
        "{}",
        stderr(&out)
    );
    let out = articula(&["info", "/dev/zero"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("larger than the limit of 67108864 bytes"),
        "{}",
        stderr(&out)
    );
    let out = articula(&["scene", "/dev/zero", "--steps", "1"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("larger than the limit of 16777216 bytes"),
        "{}",
        stderr(&out)
    );
}

/// icub's neck: a 1.3 kg point-mass head whose centre of mass is 0.4 mm from the neck axis,
/// behind a point-mass link between two joints. Accept loads both as written (a warning each);
/// ABA and CRBA never invert a body's inertia, DCA inverts a regularised copy and refines
/// against the exact Newton–Euler residual: all three agree to 1e-8 of the largest `q̈`, on
/// random states, fixed and floating base (CRBA + Cholesky is the independent reference).
/// `q̈` of the neck reaches ~1e6 here, and H is so ill-conditioned that ABA and CRBA
/// themselves differ by up to 5e-10 of it (DCA measured: 6e-10 fixed, 4e-9 floating).
#[test]
fn point_mass_head_near_a_joint_axis() {
    let point = |name: &str, mass: f64, com: &str| {
        format!(
            "<link name=\"{name}\"><inertial><origin xyz=\"{com}\"/><mass value=\"{mass}\"/>\
             <inertia ixx=\"0\" ixy=\"0\" ixz=\"0\" iyy=\"0\" iyz=\"0\" izz=\"0\"/></inertial></link>\n"
        )
    };
    let text = robot(&[
        link("torso", 4.0, "0 0 0.1", [0.05, 0.04, 0.03]),
        point("neck", 0.3, "0.01 0 0.03"),
        point("head", 1.3, "0.0004 0 0.08"),
        joint(
            "neck_pitch",
            "revolute",
            "torso",
            "neck",
            "0 0 0.3",
            "0 1 0",
        ),
        joint("neck_yaw", "revolute", "neck", "head", "0 0 0.05", "0 0 1"),
    ]);
    for floating in [false, true] {
        let m = Model::from_urdf_str(&text, &LoadOptions::default().with_floating_base(floating))
            .unwrap();
        let odd: Vec<&str> = m
            .warnings
            .iter()
            .filter_map(|w| match w {
                LoadWarning::OddInertia(d) => Some(d[0].body.as_str()),
                LoadWarning::InertiaChanged(c) => panic!("changed: {c}"),
                _ => None,
            })
            .collect();
        assert_eq!(odd, vec!["neck", "head"]);
        let neck = m.bodies.iter().find(|b| b.name == "neck").unwrap();
        assert_eq!(neck.inertia.inertia_about_com().to_cols_array(), [0.0; 9]);
        let mut data = Data::new(&m);
        let mut rng = SplitMix64(23);
        for _ in 0..20 {
            let mut q: Vec<f64> = (0..m.nq).map(|_| rng.uniform(-1.0, 1.0)).collect();
            if floating {
                let n = q[3..7].iter().map(|x| x * x).sum::<f64>().sqrt();
                q[3..7].iter_mut().for_each(|x| *x /= n);
            }
            let v: Vec<f64> = (0..m.nv).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let t: Vec<f64> = (0..m.nv).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let mut run = |method| {
                forward_dynamics_slices(&m, &mut data, &q, &v, &t, &[], method)
                    .unwrap()
                    .to_vec()
            };
            let (crba, aba, dca) = (run(Method::Crba), run(Method::Aba), run(Method::Dca));
            let scale = crba.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            for (name, got) in [("aba", &aba), ("dca", &dca)] {
                let err = got
                    .iter()
                    .zip(&crba)
                    .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
                assert!(
                    err <= 1e-8 * scale,
                    "floating {floating}: {name} {got:?} vs crba {crba:?}"
                );
            }
        }
        assert!(data.refinement_count() > 0);
    }
}
