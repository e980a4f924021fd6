//! `articula scene`: exit code 2 on bad scenes, the JSON summary, PNG frames.

use std::path::PathBuf;
use std::process::{Command, Output};

fn models_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

fn articula(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_articula"))
        .args(args)
        .output()
        .expect("cannot run the articula binary")
}

struct Scratch(PathBuf);

impl Scratch {
    fn new(test: &str) -> Scratch {
        let dir =
            std::env::temp_dir().join(format!("articula-scene-{}-{test}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
    fn file(&self, name: &str, text: &str) -> String {
        let p = self.0.join(name);
        std::fs::write(&p, text).unwrap();
        p.display().to_string()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The JSON summary (the last line of stdout) of a run that must have succeeded.
fn succeeded(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(stdout.lines().last().expect("a summary")).unwrap()
}

fn bad(out: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{needles:?}: stderr: {stderr}");
    assert!(stderr.contains("error:"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "stderr lacks {n}: {stderr}");
    }
}

fn two_bodies(models: &str) -> String {
    format!(
        r#"{{"models": {{"h": "{models}/humanoid.urdf"}},
            "bodies": [{{"name": "front", "model": "h", "position": [5, 0, 1], "velocity": {{"angular": [0, 0, 1]}}}},
                       {{"name": "behind", "model": "h", "position": [-5, 0, 1]}}],
            "camera": {{"eye": [0, 0, 1], "target": [10, 0, 1]}},
            "budget": 12, "dt": 0.002, "gravity": [0, 0, 0],
            "image": {{"width": 160, "height": 90}}}}"#
    )
}

#[test]
fn bad_scenes_exit_2_with_a_clear_message() {
    let s = Scratch::new("bad");
    bad(
        &articula(&["scene", "/nonexistent/x.json", "--steps", "1"]),
        &["/nonexistent/x.json"],
    );
    let f = s.file("broken.json", "{\"models\": ");
    bad(
        &articula(&["scene", &f, "--steps", "1"]),
        &["broken.json", "EOF"],
    );
    let f = s.file("nomodel.json", &two_bodies("/nowhere"));
    bad(
        &articula(&["scene", &f, "--steps", "1"]),
        &["models.h", "/nowhere/humanoid.urdf"],
    );
    let f = s.file(
        "typo.json",
        &two_bodies(&models_dir().display().to_string()).replace("\"budget\"", "\"budgte\""),
    );
    bad(
        &articula(&["scene", &f, "--steps", "1"]),
        &["unknown field `budgte`"],
    );
    let f = s.file("ok.json", &two_bodies(&models_dir().display().to_string()));
    bad(&articula(&["scene", &f, "--steps", "0"]), &["steps"]);
    bad(&articula(&["scene", &f, "--steps", "-3"]), &["steps"]);
    bad(
        &articula(&["scene", &f, "--steps", "1", "--frame-every", "0"]),
        &["frame"],
    );
}

#[test]
fn summary_and_frames() {
    let s = Scratch::new("ok");
    let f = s.file("ok.json", &two_bodies(&models_dir().display().to_string()));
    let out_dir = s.0.join("frames");
    let out = articula(&[
        "scene",
        &f,
        "--steps",
        "4",
        "--out",
        out_dir.to_str().unwrap(),
        "--frame-every",
        "2",
    ]);
    let v = succeeded(&out);
    assert_eq!(v["steps"], 4);
    assert_eq!(v["bodies"], 2);
    assert_eq!(v["dof_total"], 68);
    assert_eq!(v["visible"], 1);
    assert_eq!(v["invisible"], 1);
    assert_eq!(v["occluded"], 0);
    let mean = v["active_joints_mean"].as_f64().unwrap();
    assert!(mean > 0.0 && mean <= 12.0, "{mean}");
    assert!(v["ms_per_step"].as_f64().unwrap() > 0.0);
    // Frames at steps 0, 2 and the last (4): each a PNG of the scene's size, with a map.
    assert_eq!(v["frames"], 3);
    for k in [0, 2, 4] {
        let png = std::fs::read(out_dir.join(format!("frame_{k:05}.png"))).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        let w = u32::from_be_bytes(png[16..20].try_into().unwrap());
        let h = u32::from_be_bytes(png[20..24].try_into().unwrap());
        assert_eq!((w, h), (160, 90));
        assert!(out_dir.join(format!("map_{k:05}.png")).exists());
    }
}

/// `--ground`, `--gravity` and `--budget` on a zero-gravity scene: at budget 0 both humanoids
/// are rigid (no active joint), stand on the floor put under their feet, and the summary has
/// the contact figures, consistent with each other.
#[test]
fn ground_gravity_and_budget_flags() {
    let s = Scratch::new("floor");
    let f = s.file(
        "floor.json",
        &two_bodies(&models_dir().display().to_string()),
    );
    let out = articula(&[
        "scene",
        &f,
        "--steps",
        "100",
        "--ground",
        "-0.021",
        "--gravity",
        "-9.81",
        "--budget",
        "0",
    ]);
    let v = succeeded(&out);
    assert_eq!(v["budget"], 0);
    assert_eq!(v["active_joints_max"], 0);
    assert!(v["contacts_mean"].as_f64().unwrap() >= 6.0, "{v}");
    assert!(v["max_penetration_m"].as_f64().unwrap() < 1e-3, "{v}");
    let capped = v["contact_capped_fraction"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&capped), "{v}");
    // Every pushed contact has 3 rows, and at most 2 bodies solve per step: rows per solve
    // ≥ 3 · contacts per step / 2. A solve at the cap made its 50 sweeps.
    let rows = v["contact_rows_mean"].as_f64().unwrap();
    assert!(rows >= 1.5 * v["contacts_mean"].as_f64().unwrap(), "{v}");
    let sweeps = v["contact_sweeps_mean"].as_f64().unwrap();
    assert!(sweeps >= 1.0 && sweeps >= 50.0 * capped, "{v}");
}

/// A crowd of a million humanoids is refused before any body is placed: the estimate and the
/// limit are named. A small scene under a smaller `--memory-limit` is refused too.
#[test]
fn a_scene_beyond_the_memory_limit_is_refused() {
    let scratch = Scratch::new("memory");
    let models = models_dir().display().to_string();
    let huge = scratch.file(
        "huge.json",
        &format!(
            r#"{{"models": {{"h": "{models}/humanoid.urdf"}},
                "crowds": [{{"model": "h", "rows": 1000, "columns": 1000, "origin": [5, 0, 1], "spacing": [1, 1]}}],
                "camera": {{"eye": [0, 0, 1], "target": [10, 0, 1]}}}}"#
        ),
    );
    let out = articula(&["scene", &huge, "--steps", "1"]);
    bad(
        &out,
        &[
            "1000000 bodies would take about",
            "GiB",
            "memory limit of 4.0 GiB",
        ],
    );
    let small = scratch.file("small.json", &two_bodies(&models));
    let out = articula(&["scene", &small, "--steps", "1", "--memory-limit", "100KiB"]);
    bad(
        &out,
        &["2 bodies", "memory limit of 100.0 KiB (102400 bytes)"],
    );
    let out = articula(&[
        "scene",
        &small,
        "--steps",
        "1",
        "--memory-limit",
        "4 parsecs",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown unit"));
}

/// A diverging scene (a humanoid tumbling at 10 rad/s, stepped at dt = 0.02 s: semi-implicit
/// Euler on the free-floating humanoid diverges; pose springs no longer can, being bounded
/// by the time step) stops with exit 2 at the re-selection where its energy has grown beyond
/// the bound, after printing the summary of the steps done; `--max-energy-growth inf` lets it
/// run on until the state is not finite, which stops it too, with its summary.
#[test]
fn a_diverging_scene_stops_with_its_summary() {
    let scratch = Scratch::new("diverge");
    let models = models_dir().display().to_string();
    let text = two_bodies(&models)
        .replace(r#""dt": 0.002,"#, r#""dt": 0.02, "reselect_every": 2,"#)
        .replace(r#""angular": [0, 0, 1]"#, r#""angular": [10, 3, 1]"#);
    let path = scratch.file("diverge.json", &text);
    let summary = |out: &Output| -> serde_json::Value {
        let stdout = String::from_utf8_lossy(&out.stdout);
        serde_json::from_str(stdout.lines().last().expect("a summary")).unwrap()
    };
    let out = articula(&["scene", &path, "--steps", "400"]);
    bad(&out, &["step ", " of 400", "--max-energy-growth 0.5"]);
    let s = summary(&out);
    let done = s["steps"].as_u64().unwrap();
    assert!(done < 400, "{s}");
    assert_eq!(s["steps_requested"], 400);
    assert!(
        s["stop_reason"].as_str().unwrap().contains("energy grew"),
        "{s}"
    );
    assert!(
        s["energy_drift_max_relative"].as_f64().unwrap() > 0.5,
        "{s}"
    );
    // Without the bound: on until the dynamics fails on a non-finite state.
    let out = articula(&[
        "scene",
        &path,
        "--steps",
        "400",
        "--max-energy-growth",
        "inf",
    ]);
    bad(&out, &["step ", "non-finite"]);
    let s = summary(&out);
    assert!(s["steps"].as_u64().unwrap() >= done, "{s}");
    assert!(
        s["stop_reason"].as_str().unwrap().contains("non-finite"),
        "{s}"
    );
}

/// `--method dca` steps every character exactly (every joint moving, no camera figures), on the
/// floor too; `--budget` with an exact method is refused.
#[test]
fn the_exact_reference_method() {
    let s = Scratch::new("exact");
    let f = s.file(
        "exact.json",
        &two_bodies(&models_dir().display().to_string()),
    );
    let out = articula(&[
        "scene",
        &f,
        "--steps",
        "60",
        "--method",
        "dca",
        "--ground",
        "-0.021",
        "--gravity",
        "-9.81",
    ]);
    let v = succeeded(&out);
    assert_eq!(v["method"], "dca");
    // Two humanoids of 34 internal degrees of freedom each, all of them moving at every step.
    assert_eq!(v["dof_total"], 68);
    assert_eq!(v["active_joints_mean"], 68.0);
    assert_eq!(v["active_joints_max"], 68);
    assert!(v["budget"].is_null() && v["visible"].is_null(), "{v}");
    assert!(v["contacts_mean"].as_f64().unwrap() >= 6.0, "{v}");
    assert!(v["max_penetration_m"].as_f64().unwrap() < 1e-3, "{v}");
    bad(
        &articula(&[
            "scene", &f, "--steps", "1", "--method", "aba", "--budget", "3",
        ]),
        &["--budget needs --method adaptive"],
    );
}

#[test]
fn a_reference_beside_the_scene_reports_the_view_error() {
    let s = Scratch::new("reference");
    let f = s.file(
        "reference.json",
        &two_bodies(&models_dir().display().to_string()),
    );
    let floor = ["--ground", "-0.021", "--gravity", "-9.81"];
    let run = |extra: &[&str]| {
        let mut args = vec!["scene", &f, "--steps", "50", "--reference", "dca"];
        args.extend_from_slice(&floor);
        args.extend_from_slice(extra);
        succeeded(&articula(&args))
    };
    // 50 steps of 2 ms: the checkpoint at 0.1 s is the last step (one entry).
    let v = run(&["--budget", "12"]);
    assert_eq!(v["reference"], "dca");
    let e = v["view_error"].as_array().unwrap();
    assert_eq!(e.len(), 1, "{v}");
    assert!((e[0]["t"].as_f64().unwrap() - 0.1).abs() < 1e-12, "{v}");
    // The front character is in view, the other behind the camera.
    assert!(e[0]["visible_links"].as_u64().unwrap() > 10, "{v}");
    let budget12 = e[0]["pixels"].as_f64().unwrap();
    assert!(
        budget12 > 1e-6,
        "12 of 68 joints drift from the reference: {v}"
    );
    // The culling baseline runs the character in view exactly: no drift on screen but
    // rounding; the one out of view (weight 0) is rigid.
    let v = run(&["--culling"]);
    assert_eq!(v["method"], "culling");
    assert_eq!(v["active_joints_max"], 34, "{v}");
    let culled = v["view_error"][0]["pixels"].as_f64().unwrap();
    assert!(culled < 1e-6, "{culled} px: {v}");
    // Without --reference: no view error in the summary.
    let v = succeeded(&articula(&["scene", &f, "--steps", "2"]));
    assert!(v.get("view_error").is_none(), "{v}");
    bad(
        &articula(&["scene", &f, "--steps", "1", "--culling", "--budget", "3"]),
        &["--culling replaces adaptive dynamics"],
    );
    bad(
        &articula(&["scene", &f, "--steps", "1", "--reference", "rk4"]),
        &["unknown reference 'rk4'"],
    );
}
