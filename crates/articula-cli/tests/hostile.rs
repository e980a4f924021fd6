//! Hostile and careless inputs end within seconds with an error naming the cause (issue 39):
//! thread counts, FIFOs, negative numbers, absurd values, malformed files, scene blocks given
//! as arrays, a singular configuration.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn models() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

fn model(name: &str) -> String {
    models().join(name).display().to_string()
}

/// Runs `articula args`, killed after 30 s (a hang fails the test instead of stalling it).
fn articula(args: &[&str]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_articula"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot run the articula binary");
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(30) {
            child.kill().unwrap();
            panic!("articula {args:?} did not finish within 30 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn scratch(name: &str, contents: &[u8]) -> PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("articula-hostile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap();
    path
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Exit code 2 and every one of `needles` in stderr.
fn refused(out: &Output, needles: &[&str]) {
    let e = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{e}");
    for n in needles {
        assert!(e.contains(n), "expected '{n}' in: {e}");
    }
}

#[test]
fn thread_counts_are_capped() {
    let chain = model("chain10.urdf");
    let cap = articula_dca::Threads::max_count().to_string();
    for cmd in [
        vec!["fd", chain.as_str()],
        vec!["simulate", chain.as_str(), "--steps", "2"],
        vec!["bench", chain.as_str()],
    ] {
        let mut args = cmd.clone();
        args.extend(["--threads", "100000"]);
        refused(&articula(&args), &["--threads", &cap]);
        let mut args = cmd;
        args.extend(["--threads", "-3"]);
        refused(&articula(&args), &["--threads"]);
    }
    let scene = model("scenes/crowd200.json");
    refused(
        &articula(&["scene", &scene, "--steps", "1", "--threads", "100000"]),
        &["--threads", &cap],
    );
}

#[test]
fn negative_numbers_reach_the_validators() {
    let chain = model("chain10.urdf");
    let humanoid = model("humanoid.urdf");
    let scene = model("scenes/crowd200.json");
    for (args, flag) in [
        (
            vec![
                "simulate",
                humanoid.as_str(),
                "--floating-base",
                "--ground",
                "0",
                "--friction",
                "-1",
            ],
            "--friction",
        ),
        (
            vec![
                "simulate",
                humanoid.as_str(),
                "--floating-base",
                "--ground",
                "0",
                "--drop",
                "-1",
            ],
            "--drop",
        ),
        (
            vec!["simulate", chain.as_str(), "--max-energy-growth", "-1"],
            "--max-energy-growth",
        ),
        (
            vec![
                "fd",
                chain.as_str(),
                "--method",
                "adaptive",
                "--budget",
                "-1",
            ],
            "--budget",
        ),
        (vec!["scene", scene.as_str(), "--budget", "-1"], "--budget"),
        (
            vec!["scene", scene.as_str(), "--memory-limit", "-1"],
            "--memory-limit",
        ),
        (
            vec!["scene", scene.as_str(), "--max-energy-growth", "-1"],
            "--max-energy-growth",
        ),
    ] {
        let out = articula(&args);
        let e = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {e}");
        assert!(
            e.contains(flag) && !e.contains("unexpected argument"),
            "{args:?}: {e}"
        );
    }
}

#[cfg(unix)]
#[test]
fn fifos_are_refused_without_blocking() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("articula-hostile-fifo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let fifo = dir.join("pipe");
    let _ = std::fs::remove_file(&fifo);
    if !Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success())
    {
        eprintln!("no mkfifo here: skipped");
        return;
    }
    let f = fifo.display().to_string();
    let chain = model("chain10.urdf");
    refused(&articula(&["fd", &chain, "--state", &f]), &["FIFO", &f]);
    refused(&articula(&["fd", &f]), &["FIFO"]);
    refused(&articula(&["info", &f]), &["FIFO"]);
    refused(&articula(&["scene", &f, "--steps", "1"]), &["FIFO"]);
    std::fs::remove_file(&fifo).unwrap();
}

#[test]
fn malformed_urdf_names_the_file() {
    let p = scratch(
        "broken.urdf",
        b"<robot name=\"r\"><link name=\"a\"></robot>",
    );
    let path = p.display().to_string();
    refused(
        &articula(&["info", &path]),
        &[&path, "malformed XML", "line 1"],
    );
    refused(&articula(&["fd", &path]), &[&path, "malformed XML"]);
}

#[test]
fn absurd_mass_is_refused_with_a_readable_number() {
    let text = std::fs::read_to_string(models().join("chain10.urdf"))
        .unwrap()
        .replacen("<mass value=\"1.000000\"/>", "<mass value=\"1e308\"/>", 1);
    assert!(text.contains("1e308"));
    let p = scratch("heavy.urdf", text.as_bytes());
    let out = articula(&["info", p.to_str().unwrap(), "--json"]);
    refused(&out, &["mass", "1e308", "1e12"]);
    assert!(stderr(&out).len() < 300, "{}", stderr(&out));
}

#[test]
fn gimbal_lock_is_singular_for_every_method() {
    let state = scratch(
        "gimbal.json",
        br#"{"q": {"l_hip_x": [1.5707963267948966]}}"#,
    );
    let humanoid = model("humanoid.urdf");
    for method in ["dca", "aba", "crba"] {
        for floating in [false, true] {
            let mut args = vec!["fd", humanoid.as_str(), "--method", method, "--state"];
            args.push(state.to_str().unwrap());
            if floating {
                args.push("--floating-base");
            }
            refused(&articula(&args), &["singular", "l_hip_x", "gimbal lock"]);
        }
    }
}

#[test]
fn scene_blocks_given_as_arrays_are_refused() {
    let m = model("humanoid.urdf");
    for (block, field) in [
        (r#""ground": [5.0, 0.3]"#, "ground"),
        (r#""ground": []"#, "ground"),
    ] {
        let text = format!(
            r#"{{"models": {{"h": "{m}"}}, "camera": {{"eye": [0, 0, 1.5], "target": [10, 0, 1]}},
               "bodies": [{{"model": "h", "position": [0, 0, 1.2]}}], {block}}}"#
        );
        let p = scratch("arrays.json", text.as_bytes());
        refused(
            &articula(&["scene", p.to_str().unwrap(), "--steps", "1"]),
            &[field, "must be a JSON object"],
        );
    }
    let text = format!(
        r#"{{"models": {{"h": "{m}"}}, "camera": [[0, 0, 1.5], [10, 0, 1]],
           "bodies": [{{"model": "h", "position": [0, 0, 1.2]}}]}}"#
    );
    let p = scratch("camera.json", text.as_bytes());
    refused(
        &articula(&["scene", p.to_str().unwrap(), "--steps", "1"]),
        &["camera", "must be a JSON object"],
    );
    let _ = Path::new("");
}
