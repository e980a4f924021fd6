//! End-to-end tests of `articula fd`, `simulate` and `bench`: the real binary on bundled models,
//! state files written into a scratch directory.

use articula_model::{LoadOptions, Model};
use serde_json::Value;
use std::ffi::{OsStr, OsString};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn models_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

fn model_path(name: &str) -> PathBuf {
    models_dir().join(name)
}

fn articula<S: AsRef<OsStr>>(args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_articula"))
        .args(args)
        .output()
        .expect("cannot run the articula binary")
}

/// A scratch directory under the system temp dir, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(test: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!(
            "articula-dynamics-cli-{}-{test}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).expect("cannot create a temp dir");
        Scratch(dir)
    }

    fn file(&self, name: &str, contents: &str) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, contents).expect("cannot write a temp file");
        path
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn stdout(out: &Output) -> String {
    assert!(
        out.status.success(),
        "articula failed with {}:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout.clone()).expect("non-UTF-8 output")
}

/// The run failed as bad input: exit code 2 (not a panic's 101), `error:` on stderr.
fn assert_bad_input(out: &Output, what: &str) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(
        out.status.code(),
        Some(2),
        "{what}: expected exit code 2, got {}; stderr:\n{stderr}",
        out.status
    );
    assert!(
        stderr.contains("error:"),
        "{what}: no `error:` on stderr:\n{stderr}"
    );
    assert!(
        !stderr.contains("panicked"),
        "{what}: the binary panicked:\n{stderr}"
    );
    stderr
}

/// `articula fd MODEL [--state STATE] --method METHOD EXTRA...`: the parsed JSON and the joint
/// names in the order printed.
fn fd(model: &Path, state: Option<&Path>, method: &str, extra: &[&str]) -> (Value, Vec<String>) {
    let mut args: Vec<&OsStr> = vec!["fd".as_ref(), model.as_os_str()];
    if let Some(state) = state {
        args.extend([OsStr::new("--state"), state.as_os_str()]);
    }
    args.extend([OsStr::new("--method"), OsStr::new(method)]);
    args.extend(extra.iter().map(OsStr::new));
    let text = stdout(&articula(&args));
    let json: Value = serde_json::from_str(&text).expect("fd prints JSON");
    assert_eq!(json["method"], method);
    // Key order as printed (serde_json's Value sorts keys): one joint per line.
    let order = text
        .lines()
        .filter_map(|l| l.trim().strip_prefix('"'))
        .filter_map(|l| l.split_once("\": ["))
        .map(|(name, _)| name.to_string())
        .collect();
    (json, order)
}

/// `qdd` as (joint, values) in the order printed.
fn qdd(json: &Value, order: &[String]) -> Vec<(String, Vec<f64>)> {
    let map = json["qdd"].as_object().expect("qdd is an object");
    assert_eq!(map.len(), order.len(), "every qdd entry on its own line");
    order
        .iter()
        .map(|name| {
            let values = map[name]
                .as_array()
                .expect("an array per joint")
                .iter()
                .map(|x| x.as_f64().expect("a number"))
                .collect();
            (name.clone(), values)
        })
        .collect()
}

/// Movable joints of a URDF, read from its text (independently of the model loader).
fn urdf_movable_joints(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    text.split("<joint ")
        .skip(1)
        .filter(|j| !j.contains("type=\"fixed\""))
        .map(|j| {
            let start = j.find("name=\"").unwrap() + 6;
            j[start..start + j[start..].find('"').unwrap()].to_string()
        })
        .collect()
}

fn load(path: &Path, floating_base: bool) -> Model {
    Model::from_urdf_file(
        path,
        &LoadOptions::default().with_floating_base(floating_base),
    )
    .unwrap()
}

fn assert_close(a: &[(String, Vec<f64>)], b: &[(String, Vec<f64>)], tol: f64, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    for ((na, va), (nb, vb)) in a.iter().zip(b) {
        assert_eq!(na, nb, "{what}");
        assert_eq!(va.len(), vb.len(), "{what}: {na}");
        for (x, y) in va.iter().zip(vb) {
            assert!(
                (x - y).abs() <= tol * x.abs().max(1.0),
                "{what}: joint {na}: {x} vs {y}"
            );
        }
    }
}

const HUMANOID_STATE: &str = r#"{
  "q": {"l_hip_z": [0.1], "l_hip_x": [-0.2], "l_hip_y": [-0.6], "l_knee": [1.1],
        "r_hip_y": [0.3], "r_knee": [0.4], "l_ankle_y": [0.2], "lumbar_x": [0.15],
        "neck_z": [-0.3], "l_shoulder_x": [0.5], "l_elbow": [-0.8], "head_lidar_spin": [2.0]},
  "qd": {"l_knee": [1.5], "l_hip_y": [-0.7], "r_shoulder_z": [0.9], "lumbar_z": [0.3],
         "r_wrist_x": [-1.2]},
  "tau": {"l_knee": [5.0], "r_hip_x": [-3.0], "l_toe": [0.2]}
}"#;

#[test]
fn fd_humanoid_one_key_per_movable_joint_and_methods_agree() {
    let scratch = Scratch::new("humanoid");
    let state = scratch.file("state.json", HUMANOID_STATE);
    let path = model_path("humanoid.urdf");
    let model = load(&path, false);
    let model_order: Vec<String> = model.joint_parts().map(|(_, p)| p.name.clone()).collect();
    let mut urdf = urdf_movable_joints(&path);
    assert_eq!(urdf.len(), 34);

    let results: Vec<_> = ["dca", "aba", "crba"]
        .iter()
        .map(|m| {
            let (json, order) = fd(&path, Some(&state), m, &[]);
            assert_eq!(order, model_order, "{m}: joints in model coordinate order");
            let mut keys = order.clone();
            keys.sort();
            urdf.sort();
            assert_eq!(keys, urdf, "{m}: exactly the movable URDF joints");
            let q = qdd(&json, &order);
            assert!(q.iter().all(|(_, v)| v.len() == 1));
            q
        })
        .collect();
    assert_close(&results[0], &results[1], 1e-9, "dca vs aba");
    assert_close(&results[0], &results[2], 1e-9, "dca vs crba");
    // the state made a difference
    assert!(results[0].iter().any(|(_, v)| v[0].abs() > 1.0));
}

#[test]
fn fd_humanoid_floating_base() {
    let scratch = Scratch::new("floating");
    let state = scratch.file(
        "state.json",
        r#"{"q": {"floating_base": [0.1, -0.2, 1.0, 0.9, 0.1, -0.3, 0.2], "l_knee": [0.7]},
            "qd": {"floating_base": [0.1, 0.2, -0.3, 0.5, 0.0, -0.1]}}"#,
    );
    let path = model_path("humanoid.urdf");
    let (dca, order) = fd(&path, Some(&state), "dca", &["--floating-base"]);
    assert_eq!(order.len(), 35);
    assert_eq!(order[0], "floating_base");
    let dca = qdd(&dca, &order);
    assert_eq!(dca[0].1.len(), 6);
    let (aba, order) = fd(&path, Some(&state), "aba", &["--floating-base"]);
    assert_close(&dca, &qdd(&aba, &order), 1e-9, "floating dca vs aba");

    // At rest in the neutral pose, nothing holds the body: it falls freely.
    let (rest, order) = fd(&path, None, "dca", &["--floating-base"]);
    let rest = qdd(&rest, &order);
    let expected = [0.0, 0.0, 0.0, 0.0, 0.0, -9.81];
    for (x, e) in rest[0].1.iter().zip(expected) {
        assert!((x - e).abs() < 1e-9, "{:?}", rest[0]);
    }
    assert!(rest[1..].iter().all(|(_, v)| v[0].abs() < 1e-9), "{rest:?}");
}

#[test]
fn fd_chain10_hangs_at_rest_and_swings_back() {
    let scratch = Scratch::new("chain10");
    let path = model_path("chain10.urdf");
    let zero = scratch.file(
        "zero.json",
        r#"{"q": {"joint1": [0], "joint5": [0.0]}, "qd": {}, "tau": {}}"#,
    );
    for state in [None, Some(zero.as_path())] {
        for method in ["dca", "aba", "crba"] {
            let (json, order) = fd(&path, state, method, &[]);
            let q = qdd(&json, &order);
            assert_eq!(q.len(), 10);
            assert!(
                q.iter().all(|(_, v)| v.len() == 1 && v[0].abs() < 1e-12),
                "{method}: hanging straight down at rest does not move: {q:?}"
            );
        }
    }

    // Joint 1 (axis y) turned by +0.5 rad: gravity turns it back, q̈₁ < 0.
    let swung = scratch.file("swung.json", r#"{"q": {"joint1": [0.5]}}"#);
    let (dca, order) = fd(&path, Some(&swung), "dca", &[]);
    let dca = qdd(&dca, &order);
    let (aba, order) = fd(&path, Some(&swung), "aba", &[]);
    let aba = qdd(&aba, &order);
    assert_eq!(dca[0].0, "joint1");
    assert!(dca[0].1[0] < -1.0, "{dca:?}");
    assert!(aba[0].1[0] < -1.0, "{aba:?}");
    assert_close(&dca, &aba, 1e-8, "dca vs aba");

    // At rest q̈ is linear in gravity: upside down it falls the other way, without it nothing.
    let (up, order) = fd(&path, Some(&swung), "dca", &["--gravity", "0,0,9.81"]);
    let up = qdd(&up, &order);
    for ((_, a), (_, b)) in dca.iter().zip(&up) {
        assert!(
            (a[0] + b[0]).abs() <= 1e-9 * a[0].abs().max(1.0),
            "{a:?} {b:?}"
        );
    }
    let (none, order) = fd(&path, Some(&swung), "aba", &["--gravity", "0, 0, 0"]);
    assert!(qdd(&none, &order).iter().all(|(_, v)| v[0] == 0.0));
}

/// `fd chain10 --state FILE` with the given state text.
fn fd_with_state(scratch: &Scratch, text: &str) -> Output {
    let state = scratch.file("bad.json", text);
    articula(&[
        "fd".as_ref(),
        model_path("chain10.urdf").as_os_str(),
        "--state".as_ref(),
        state.as_os_str(),
    ])
}

#[test]
fn bad_state_files_are_bad_input() {
    let scratch = Scratch::new("bad-state");
    let cases: &[(&str, &[&str])] = &[
        (r#"{"q": {"elbow": [0.5]}}"#, &["unknown joint 'elbow'"]),
        (
            r#"{"tau": {"joint3": [1, 2]}}"#,
            &["joint3", "2 entries", "needs 1"],
        ),
        (r#"{"qd": {"joint2": []}}"#, &["joint2", "0 entries"]),
        (r#"{"q": {"joint1": [0.5]"#, &["bad.json"]),
        ("not json", &["bad.json"]),
        ("", &["bad.json"]),
        ("[]", &["expected a JSON object"]),
        (r#"{"q": {"joint1": [NaN]}}"#, &["bad.json"]),
        (
            r#"{"q": {"joint1": ["0.5"]}}"#,
            &["joint1", "expected a finite number"],
        ),
        (r#"{"q": {"joint1": [1e999]}}"#, &["joint1", "out of range"]),
        (r#"{"q": {"joint1": 0.5}}"#, &["joint1", "array of numbers"]),
        (r#"{"q": {}, "qdd": {}}"#, &["unknown field `qdd`"]),
        (
            r#"{"q": {"joint1": [1], "joint1": [2]}}"#,
            &["joint1", "twice"],
        ),
        (
            r#"{"q": {"floating_base": [0, 0, 0, 1, 0, 0, 0]}}"#,
            &["unknown joint 'floating_base'"],
        ),
    ];
    for (text, needles) in cases {
        let stderr = assert_bad_input(&fd_with_state(&scratch, text), text);
        for needle in *needles {
            assert!(
                stderr.contains(needle),
                "{text}: stderr should contain {needle:?}:\n{stderr}"
            );
        }
    }
    let missing = scratch.0.join("missing.json");
    let stderr = assert_bad_input(
        &articula(&[
            "fd".as_ref(),
            model_path("chain10.urdf").as_os_str(),
            "--state".as_ref(),
            missing.as_os_str(),
        ]),
        "missing state file",
    );
    assert!(stderr.contains("missing.json"), "{stderr}");
}

#[test]
fn floating_base_state_lengths_are_checked() {
    let scratch = Scratch::new("floating-lengths");
    let path = model_path("chain10.urdf");
    for (text, needle) in [
        (r#"{"q": {"floating_base": [0, 0, 0, 1, 0, 0]}}"#, "needs 7"),
        (
            r#"{"qd": {"floating_base": [0, 0, 0, 1, 0, 0, 0]}}"#,
            "needs 6",
        ),
        (r#"{"tau": {"floating_base": [0]}}"#, "needs 6"),
        (
            r#"{"q": {"floating_base": [0, 0, 0, 0, 0, 0, 0]}}"#,
            "quaternion",
        ),
    ] {
        let state = scratch.file("fb.json", text);
        let out = articula(&[
            "fd".as_ref(),
            path.as_os_str(),
            "--floating-base".as_ref(),
            "--state".as_ref(),
            state.as_os_str(),
        ]);
        let stderr = assert_bad_input(&out, text);
        assert!(stderr.contains("floating_base"), "{text}: {stderr}");
        assert!(stderr.contains(needle), "{text}: {stderr}");
    }
}

#[test]
fn bad_arguments_are_bad_input() {
    let chain = model_path("chain10.urdf");
    let chain = chain.to_str().unwrap();
    for args in [
        &["fd", chain, "--gravity", "0,0"][..],
        &["fd", chain, "--gravity", "0,0,x"],
        &["fd", chain, "--gravity", "0,0,inf"],
        &["fd", chain, "--method", "rnea"],
        &["simulate", chain, "--steps", "0", "--dt", "1e-3"],
        &["simulate", chain, "--steps", "-5", "--dt", "1e-3"],
        &["simulate", chain, "--steps", "10", "--dt", "0"],
        &["simulate", chain, "--steps", "10", "--dt", "-1e-3"],
        &["simulate", chain, "--steps", "10", "--dt", "NaN"],
        &["simulate", chain, "--steps", "10", "--dt", "inf"],
        &["simulate", chain, "--steps", "10"],
        &[
            "simulate",
            chain,
            "--steps",
            "10",
            "--dt",
            "1e-3",
            "--integrator",
            "verlet",
        ],
        &["bench", chain, "--reps", "0"],
    ] {
        assert_bad_input(&articula(args), &args.join(" "));
    }
}

#[test]
fn simulate_chain10_rk4_reports_drift_and_writes_csv() {
    let scratch = Scratch::new("simulate");
    let state = scratch.file(
        "state.json",
        r#"{"q": {"joint1": [0.5], "joint4": [-0.2]}}"#,
    );
    let csv = scratch.0.join("traj.csv");
    let out = articula(&[
        "simulate".as_ref(),
        model_path("chain10.urdf").as_os_str(),
        "--steps".as_ref(),
        "100".as_ref(),
        "--dt".as_ref(),
        "1e-3".as_ref(),
        "--integrator".as_ref(),
        "rk4".as_ref(),
        "--state".as_ref(),
        state.as_os_str(),
        "--out".as_ref(),
        csv.as_os_str(),
    ]);
    let summary = stdout(&out);
    for needle in [
        "chain10",
        "method       dca",
        "rk4",
        "steps        100",
        "µs per step",
        "energy start",
        "energy end",
    ] {
        assert!(summary.contains(needle), "{needle:?} missing:\n{summary}");
    }
    let drift_line = summary
        .lines()
        .find(|l| l.starts_with("energy drift"))
        .unwrap_or_else(|| panic!("no drift line:\n{summary}"));
    let drift: f64 = drift_line
        .split_whitespace()
        .nth(2)
        .unwrap()
        .parse()
        .unwrap();
    assert!(drift.abs() < 1e-4, "{drift_line}");

    // Header, then t = 0 and one row per step: 101 rows.
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 1 + 101);
    let header: Vec<&str> = lines[0].split(',').collect();
    assert_eq!(header.len(), 1 + 10 + 10);
    assert_eq!(header[0], "t");
    assert_eq!(header[1], "joint1");
    assert_eq!(header[11], "qd:joint1");
    let row = |i: usize| -> Vec<f64> {
        lines[i]
            .split(',')
            .map(|x| x.parse().expect("a number"))
            .collect()
    };
    let first = row(1);
    assert_eq!(first.len(), 21);
    assert_eq!(
        (first[0], first[1], first[4], first[11]),
        (0.0, 0.5, -0.2, 0.0)
    );
    let last = row(101);
    assert!((last[0] - 0.1).abs() < 1e-12);
    assert!(last[1] < 0.5, "joint1 swings back: {}", last[1]);
    assert!(last[11] < 0.0, "joint1 moves back: {}", last[11]);
}

#[test]
fn simulate_failure_names_the_step() {
    let scratch = Scratch::new("simulate-fail");
    let state = scratch.file("state.json", r#"{"tau": {"joint1": [1e300]}}"#);
    let out = articula(&[
        "simulate".as_ref(),
        model_path("chain10.urdf").as_os_str(),
        "--steps".as_ref(),
        "10".as_ref(),
        "--dt".as_ref(),
        "1e-3".as_ref(),
        "--state".as_ref(),
        state.as_os_str(),
    ]);
    let stderr = assert_bad_input(&out, "diverging simulation");
    assert!(
        stderr.contains("step ") && stderr.contains(" of 10"),
        "{stderr}"
    );
    assert!(stderr.contains("non-finite"), "{stderr}");
}

#[test]
fn bench_prints_time_per_call() {
    let chain = model_path("chain10.urdf");
    for method in ["dca", "aba"] {
        let out = stdout(&articula(&[
            "bench",
            chain.to_str().unwrap(),
            "--method",
            method,
            "--reps",
            "200",
        ]));
        assert!(out.contains(&format!("method={method}")), "{out}");
        assert!(out.contains("dof=10"), "{out}");
        assert!(out.contains("reps=200"), "{out}");
        let us: f64 = out
            .split_whitespace()
            .find_map(|w| w.strip_prefix("us_per_call="))
            .unwrap_or_else(|| panic!("no us_per_call= in {out}"))
            .parse()
            .unwrap();
        assert!(us > 0.0 && us.is_finite(), "{out}");
    }
}

#[test]
fn adaptive_fd_reports_its_selection_and_error() {
    let model = model_path("chain30.urdf");
    let scratch = Scratch::new("adaptive_fd");
    let state = scratch.file(
        "state.json",
        r#"{"q": {"joint1": [0.7], "joint12": [-0.4]}, "qd": {"joint20": [2.0]}, "tau": {"joint3": [1.5]}}"#,
    );
    let (exact, _) = fd(&model, Some(&state), "dca", &[]);
    let mut last = f64::INFINITY;
    for budget in ["0", "1", "5", "30"] {
        let (out, _) = fd(
            &model,
            Some(&state),
            "adaptive",
            &["--budget", budget, "--compare"],
        );
        let active = out["active_joints"].as_array().unwrap();
        assert_eq!(active.len(), budget.parse::<usize>().unwrap());
        let predicted = out["predicted_error"].as_f64().unwrap();
        let actual = out["actual_error"].as_f64().unwrap();
        assert!(
            (predicted - actual).abs() <= 1e-9 * (1.0 + actual),
            "{predicted} {actual}"
        );
        assert!(actual <= last * (1.0 + 1e-12));
        last = actual;
        // Active joints carry the exact accelerations, the others 0.
        for (name, v) in out["qdd"].as_object().unwrap() {
            let x = v[0].as_f64().unwrap();
            if active.iter().any(|a| a == name) {
                let e = exact["qdd"][name][0].as_f64().unwrap();
                assert!((x - e).abs() <= 1e-9 * (1.0 + e.abs()), "{name}");
            } else {
                assert_eq!(x, 0.0, "{name}");
            }
        }
    }
    assert!(last <= 1e-12);
}

#[test]
fn adaptive_settings_are_checked() {
    let model = model_path("chain10.urdf");
    for args in [
        vec!["fd", "--method", "adaptive", "--budget", "-1"],
        vec!["fd", "--method", "adaptive", "--tolerance", "-0.5"],
        vec!["fd", "--method", "adaptive", "--tolerance", "nan"],
        vec!["fd", "--method", "dca", "--budget", "3"],
        vec!["fd", "--method", "dca", "--compare"],
    ] {
        let mut all: Vec<OsString> = args.iter().map(OsString::from).collect();
        all.push(model.clone().into_os_string());
        let out = articula(&all);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
    }
}

/// `simulate --method adaptive` takes both integrators; with every joint active (no budget)
/// the RK4 run follows the exact RK4 run beside it.
#[test]
fn adaptive_simulation_steps_with_rk4() {
    let model = model_path("chain10.urdf");
    let mut all: Vec<OsString> = [
        "simulate",
        "--method",
        "adaptive",
        "--steps",
        "20",
        "--dt",
        "1e-3",
        "--integrator",
        "rk4",
    ]
    .iter()
    .map(OsString::from)
    .collect();
    all.push(model.into_os_string());
    let out = articula(&all);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("rk4"), "{stdout}");
    let err: f64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("traj error   max |q - q_exact| = "))
        .and_then(|l| l.split_whitespace().next())
        .expect("trajectory error line")
        .parse()
        .unwrap();
    assert!(err < 1e-10, "{stdout}");
}

/// The floating humanoid at `dt = 0.05` diverges: the run stops with exit 2 at the step where
/// its energy has grown beyond half of the largest energy in play, after the summary of the
/// steps done (which reports the drift at its maximum, at that step).
#[test]
fn simulate_stops_when_the_energy_grows_beyond_the_bound() {
    let humanoid = model_path("humanoid.urdf");
    let run = |extra: &[&str]| {
        let mut args: Vec<&OsStr> = vec![
            "simulate".as_ref(),
            humanoid.as_os_str(),
            "--floating-base".as_ref(),
            "--steps".as_ref(),
            "200".as_ref(),
            "--dt".as_ref(),
            "0.05".as_ref(),
        ];
        args.extend(extra.iter().map(OsStr::new));
        articula(&args)
    };
    let out = run(&[]);
    let stderr = assert_bad_input(&out, "diverging humanoid");
    assert!(stderr.contains(" of 200") && stderr.contains("--max-energy-growth 0.5"));
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(summary.contains("(stopped at step "), "{summary}");
    assert!(summary.contains("max drift"), "{summary}");
    // The same run as JSON: the stop, and the drift at its maximum where it stopped.
    let out = run(&["--json"]);
    assert_bad_input(&out, "diverging humanoid, JSON");
    let j: Value = serde_json::from_slice(&out.stdout).unwrap();
    let done = j["steps_done"].as_u64().unwrap();
    assert!((1..200).contains(&done), "{j}");
    assert_eq!(j["energy_drift_max_step"].as_u64(), Some(done + 1), "{j}");
    assert!(
        j["energy_drift_max_relative"].as_f64().unwrap() > 0.5,
        "{j}"
    );
    assert!(
        j["stop_reason"].as_str().unwrap().contains("energy grew"),
        "{j}"
    );
    // A looser bound lets it run longer: on to a non-finite state or the end.
    let out = run(&["--json", "--max-energy-growth", "inf"]);
    let j2: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(j2["steps_done"].as_u64().unwrap() > done, "{j2}");
}

/// `simulate --json` on a conservative run: the energy balance in numbers that agree with an
/// independent evaluation (the energy at the start from the library), time per step, steps
/// done, and no stop.
#[test]
fn simulate_json_reports_energy_and_time() {
    let chain = model_path("chain10.urdf");
    let scratch = Scratch::new("simulate-json");
    let state = scratch.file("state.json", r#"{"q": {"joint1": [0.5]}}"#);
    let out = articula(&[
        "simulate".as_ref(),
        chain.as_os_str(),
        "--steps".as_ref(),
        "200".as_ref(),
        "--dt".as_ref(),
        "1e-3".as_ref(),
        "--integrator".as_ref(),
        "rk4".as_ref(),
        "--state".as_ref(),
        state.as_os_str(),
        "--json".as_ref(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["steps_done"], 200);
    assert!(j["stop_reason"].is_null());
    assert!(j["us_per_step"].as_f64().unwrap() > 0.0);
    // E₀ = V₀ at rest: −Σ m g·c from the library's kinematics.
    let model = load(&chain, false);
    let mut data = articula_dca::Data::new(&model);
    let mut q = model.neutral_q();
    q[0] = 0.5;
    articula_dca::forward_kinematics(&model, &q, &vec![0.0; model.nv], &mut data).unwrap();
    let e0 = data.potential_energy();
    assert!((j["energy_start"].as_f64().unwrap() - e0).abs() <= 1e-12 * e0.abs());
    // RK4 at 1 ms conserves it to well below a microjoule on this chain; the largest drift
    // seen bounds the drift at the end.
    let (end, max) = (
        j["energy_drift"].as_f64().unwrap(),
        j["energy_drift_max"].as_f64().unwrap(),
    );
    assert!(end.abs() <= max && max < 1e-6, "{j}");
    assert!(j["kinetic_end"].as_f64().unwrap() > 0.0);
}

/// CRBA's dense joint-space inertia matrix of a 17,000-link chain would take 2.2 GB: refused
/// with exit 2 naming its size and the 2 GiB limit, before it is allocated.
#[test]
fn crba_beyond_the_dense_limit_is_refused() {
    let scratch = Scratch::new("crba-size");
    let chain = scratch.file("chain17k.urdf", &articula_testkit::chain_urdf(17_000));
    let out = articula(&[
        "fd".as_ref(),
        chain.as_os_str(),
        "--method".as_ref(),
        "crba".as_ref(),
    ]);
    let stderr = assert_bad_input(&out, "crba on 17,000 DOF");
    assert!(
        stderr.contains("17000 × 17000")
            && stderr.contains("2.2 GiB (2312000000 bytes)")
            && stderr.contains("limit of 2.0 GiB (2147483648 bytes)"),
        "{stderr}"
    );
}

/// `simulate --ground`: the floating humanoid dropped 5 cm lands; the summary has the contact
/// figures, the penetration below 5 mm.
#[test]
fn simulate_with_a_ground_reports_contact() {
    let humanoid = model_path("humanoid.urdf");
    let out = stdout(&articula(&[
        OsStr::new("simulate"),
        humanoid.as_os_str(),
        OsStr::new("--floating-base"),
        OsStr::new("--ground"),
        OsStr::new("0"),
        OsStr::new("--drop"),
        OsStr::new("0.05"),
        OsStr::new("--steps"),
        OsStr::new("200"),
        OsStr::new("--dt"),
        OsStr::new("1e-3"),
    ]));
    let field = |name: &str| -> f64 {
        let line = out
            .lines()
            .find(|l| l.starts_with(name))
            .unwrap_or_else(|| panic!("no {name} in:\n{out}"));
        line[name.len()..]
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let penetration = field("max_penetration_m");
    assert!((0.0..5e-3).contains(&penetration), "{out}");
    assert!(field("contacts") > 0.0, "{out}");
    assert!(field("kinetic end").is_finite(), "{out}");
    assert!(out.contains("joint limits on"), "{out}");
}

/// `simulate --method adaptive --ground`: at budget 0 the floating humanoid is one rigid body
/// (every internal joint locked); dropped 0.2 m, it falls 0.2 m (its lowest point from 0.2 m
/// to the floor, to 0.2 mm: twice the position slop), comes to rest, and keeps every joint
/// angle to the bit.
#[test]
fn simulate_adaptive_with_a_ground_lands_a_rigid_body() {
    let humanoid = model_path("humanoid.urdf");
    let scratch = Scratch::new("adaptive-ground");
    let csv = scratch.0.join("drop.csv");
    let out = stdout(&articula(&[
        "simulate",
        humanoid.to_str().unwrap(),
        "--floating-base",
        "--method",
        "adaptive",
        "--budget",
        "0",
        "--ground",
        "0",
        "--drop",
        "0.2",
        "--steps",
        "1000",
        "--dt",
        "1e-3",
        "--json",
        "--out",
        csv.to_str().unwrap(),
    ]));
    let j: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(j["steps_done"], 1000, "{out}");
    assert!(j["contacts_mean"].as_f64().unwrap() > 0.0, "{out}");
    assert!(j["kinetic_end"].as_f64().unwrap() < 1e-8, "{out}");
    assert!(j["max_penetration_m"].as_f64().unwrap() < 1e-3, "{out}");
    // At rest the floor carries the body's weight, m g straight up.
    let model =
        Model::from_urdf_file(&humanoid, &LoadOptions::default().with_floating_base(true)).unwrap();
    let weight = model.moving_mass() * 9.81;
    let force: Vec<f64> = j["ground_force_end_n"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(
        force[0].abs() < 1e-5 * weight && force[1].abs() < 1e-5 * weight,
        "{out}"
    );
    assert!(
        (force[2] - weight).abs() < 1e-5 * weight,
        "{force:?} against {weight} N"
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let nq = header.iter().filter(|c| !c.starts_with("qd:")).count() - 1;
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let (first, last) = (&rows[0], &rows[rows.len() - 1]);
    // Column 0 is t, then x, y, z of the base.
    let fall = first[3] - last[3];
    assert!((fall - 0.2).abs() < 2e-4, "fell {fall} m");
    assert_eq!(first[8..=nq], last[8..=nq], "a locked joint moved");
}

/// A floating box on one leg whose knee bends only within `[−2.6, −0.8]` rad (like go1's):
/// the neutral pose breaks the limit.
const BENT_KNEE: &str = r#"<robot name="leg">
  <link name="torso"><inertial><mass value="2"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.2 0.2 0.1"/></geometry></collision></link>
  <link name="thigh"><inertial><mass value="0.5"/><inertia ixx="2e-3" iyy="2e-3" izz="2e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="shank"><inertial><mass value="0.2"/><inertia ixx="7e-4" iyy="7e-4" izz="7e-4" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -0.2"/><geometry><sphere radius="0.02"/></geometry></collision></link>
  <joint name="hip" type="revolute"><parent link="torso"/><child link="thigh"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="10"/></joint>
  <joint name="knee" type="revolute"><parent link="thigh"/><child link="shank"/><origin xyz="0 0 -0.2"/>
    <axis xyz="0 1 0"/><limit lower="-2.6" upper="-0.8" effort="10" velocity="10"/></joint>
</robot>"#;

/// `simulate --ground` with the joint limits on starts in the rest pose (the knee at its
/// bound −0.8 rad, not at the neutral 0 it breaks); with `--no-joint-limits`, at neutral. And
/// with `--method adaptive` at a budget of every joint, its exact reference starts where the
/// adaptive run does (after `--drop`): the two trajectories agree to rounding.
#[test]
fn simulate_with_a_ground_starts_in_the_rest_pose() {
    let scratch = Scratch::new("rest-pose");
    let urdf = scratch.file("leg.urdf", BENT_KNEE);
    let csv = scratch.0.join("leg.csv");
    let first_knee = |extra: &[&str]| -> f64 {
        let mut args = vec![
            "simulate",
            urdf.to_str().unwrap(),
            "--floating-base",
            "--ground",
            "0",
            "--drop",
            "0.05",
            "--steps",
            "1",
            "--dt",
            "1e-3",
            "--out",
            csv.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        stdout(&articula(&args));
        let text = std::fs::read_to_string(&csv).unwrap();
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = header.iter().position(|c| *c == "knee").unwrap();
        lines
            .next()
            .unwrap()
            .split(',')
            .nth(col)
            .unwrap()
            .parse()
            .unwrap()
    };
    assert_eq!(first_knee(&[]), -0.8);
    assert_eq!(first_knee(&["--no-joint-limits"]), 0.0);
    let out = stdout(&articula(&[
        "simulate",
        urdf.to_str().unwrap(),
        "--floating-base",
        "--method",
        "adaptive",
        "--budget",
        "2",
        "--ground",
        "0",
        "--drop",
        "0.05",
        "--steps",
        "300",
        "--dt",
        "1e-3",
        "--json",
    ]));
    let j: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(j["steps_done"], 300, "{out}");
    assert!(j["contacts_mean"].as_f64().unwrap() > 0.0, "{out}");
    let err = j["trajectory_error_max"].as_f64().unwrap();
    assert!(
        err < 1e-9,
        "adaptive at full budget off its exact reference by {err}: {out}"
    );
}

/// `--contact-solver`: the humanoid dropped 5 cm lands with either solver (penetration under
/// 5 mm, contacts made), and the two solve it differently.
#[test]
fn simulate_with_either_contact_solver() {
    let humanoid = model_path("humanoid.urdf");
    let run = |solver: &str| -> serde_json::Value {
        let out = stdout(&articula(&[
            "simulate",
            humanoid.to_str().unwrap(),
            "--floating-base",
            "--ground",
            "0",
            "--drop",
            "0.05",
            "--steps",
            "300",
            "--dt",
            "1e-3",
            "--contact-solver",
            solver,
            "--json",
        ]));
        serde_json::from_str(out.trim()).unwrap()
    };
    let (gs, sub) = (run("gauss-seidel"), run("subspace"));
    for j in [&gs, &sub] {
        assert_eq!(j["steps_done"], 300, "{j}");
        assert!(j["max_penetration_m"].as_f64().unwrap() < 5e-3, "{j}");
        assert!(j["contacts_mean"].as_f64().unwrap() > 0.0, "{j}");
    }
    // The same run, solved differently: the states differ.
    assert_ne!(gs["energy_end"], sub["energy_end"]);
}

/// `--ground` refuses RK4 and bad values with exit code 2; contact options need `--ground`.
#[test]
fn simulate_ground_bad_input_exits_2() {
    let chain = model_path("chain10.urdf");
    let chain = chain.to_str().unwrap();
    for args in [
        &["--ground", "0", "--integrator", "rk4"][..],
        &["--ground", "0", "--restitution", "2"],
        &["--ground", "0", "--friction", "-1"],
        &["--ground", "0", "--drop", "1"],
        &["--friction", "0.5"],
        &["--no-joint-limits"],
        &["--contact-solver", "subspace"],
        &["--ground", "0", "--contact-solver", "newton"],
    ] {
        let mut all = vec!["simulate", chain, "--steps", "2", "--dt", "1e-3"];
        all.extend_from_slice(args);
        assert_bad_input(&articula(&all), &args.join(" "));
    }
}

/// `bench --states N --threads T` times the batch API on T threads and says so; a thread count
/// of 0, or `--states` with the adaptive method, is bad input.
#[test]
fn bench_reports_its_thread_count_and_batch() {
    let chain = model_path("chain10.urdf");
    let chain = chain.to_str().unwrap();
    for threads in ["1", "2"] {
        let out = stdout(&articula(&[
            "bench",
            chain,
            "--states",
            "8",
            "--threads",
            threads,
            "--reps",
            "20",
        ]));
        assert!(out.contains(&format!("threads={threads}")), "{out}");
        let field = |name: &str| -> f64 {
            out.split_whitespace()
                .find_map(|w| w.strip_prefix(name))
                .unwrap_or_else(|| panic!("no {name} in {out}"))
                .parse()
                .unwrap()
        };
        assert_eq!(field("states="), 8.0, "{out}");
        let per_state = field("us_per_state=");
        let per_call = field("us_per_call=");
        assert!(
            (per_state * 8.0 - per_call).abs() <= 1e-3 * 8.0 + 1e-9 * per_call,
            "{out}"
        );
    }
    assert_bad_input(
        &articula(&["bench", chain, "--threads", "0"]),
        "--threads 0",
    );
    assert_bad_input(
        &articula(&["bench", chain, "--method", "adaptive", "--states", "4"]),
        "--states with adaptive",
    );
}

/// `bench --method adaptive` times a continuing simulation; on a 1,000-link chain started with
/// the seeded velocities it went non-finite (`non-finite qdd at joint500`). From the seeded
/// pose at rest it runs, and its active region is the budget.
#[test]
fn adaptive_bench_runs_on_a_long_chain() {
    let chain = model_path("chain1000.urdf");
    let chain = chain.to_str().unwrap();
    // 1,500 steps: past the 1,000-step restart of the timed run.
    let out = stdout(&articula(&[
        "bench", chain, "--method", "adaptive", "--budget", "200", "--reps", "1500",
    ]));
    assert!(out.contains("active_dofs=200"), "{out}");
}
