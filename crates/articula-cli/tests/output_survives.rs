//! Output that survives: a `simulate --out` run stopped by SIGTERM or SIGINT, or by a full
//! disk, leaves a CSV of complete rows (or none) and prints its summary with the reason.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

fn model_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../models")
        .join(name)
}

/// A scratch directory under the system temp dir, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(test: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!(
            "articula-output-survives-{}-{test}",
            std::process::id()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("cannot create a temp dir");
        Scratch(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A long `simulate --out` run of chain300 (rows of 601 numbers), started in the background.
fn spawn_long_run(csv: &Path, extra: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_articula"))
        .arg("simulate")
        .arg(model_path("chain300.urdf"))
        .args(["--steps", "100000000", "--dt", "1e-4", "--out"])
        .arg(csv)
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot run the articula binary")
}

/// Waits until the run has written at least `bytes` into its temporary file (the only file
/// in `dir`), then sends `signal`.
fn signal_once_writing(child: &mut Child, dir: &Path, bytes: u64, signal: &str) -> Output {
    let start = Instant::now();
    loop {
        let written: u64 = std::fs::read_dir(dir)
            .unwrap()
            .filter_map(|e| e.ok()?.metadata().ok())
            .map(|m| m.len())
            .sum();
        if written >= bytes {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the run wrote {written} bytes in 60 s"
        );
        assert!(child.try_wait().unwrap().is_none(), "the run ended early");
        std::thread::sleep(Duration::from_millis(20));
    }
    let status = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .expect("cannot run kill");
    assert!(status.success());
    let child = std::mem::replace(child, Command::new("true").spawn().unwrap());
    child.wait_with_output().unwrap()
}

/// Every row of the CSV has the header's column count and parses as numbers; returns the
/// number of rows after the header.
fn complete_rows(csv: &Path) -> usize {
    let text = std::fs::read_to_string(csv).expect("the CSV is under its final name");
    assert!(text.ends_with('\n'), "the last row is cut");
    let mut lines = text.lines();
    let columns = lines.next().unwrap().split(',').count();
    assert_eq!(columns, 1 + 300 + 300);
    let mut rows = 0;
    for (i, line) in lines.enumerate() {
        let fields: Vec<&str> = line.split(',').collect();
        assert_eq!(fields.len(), columns, "row {i} has {} fields", fields.len());
        for f in fields {
            f.parse::<f64>()
                .unwrap_or_else(|_| panic!("row {i}: '{f}' is not a number"));
        }
        rows += 1;
    }
    rows
}

/// The number after `key` in a summary line.
fn number_after(text: &str, key: &str) -> u64 {
    let at = text
        .find(key)
        .unwrap_or_else(|| panic!("no '{key}' in:\n{text}"));
    text[at + key.len()..]
        .split(|c: char| !c.is_ascii_digit())
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

/// SIGTERM during `simulate --out`: the run finishes its step, the CSV holds complete rows
/// (t = 0 and one per step done, as the summary says), the text summary names the signal as
/// the stop reason, and the exit code is 143; no temporary file is left.
#[test]
fn sigterm_leaves_complete_rows_and_a_summary() {
    let scratch = Scratch::new("sigterm");
    let csv = scratch.0.join("run.csv");
    let mut child = spawn_long_run(&csv, &[]);
    let out = signal_once_writing(&mut child, &scratch.0, 200_000, "-TERM");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(143), "{stdout}\n{stderr}");
    assert!(stdout.contains("interrupted by SIGTERM"), "{stdout}");
    assert!(stderr.contains("error: step"), "{stderr}");
    let done = number_after(&stdout, "steps        ");
    assert!(done >= 1, "{stdout}");
    let rows = complete_rows(&csv);
    assert_eq!(rows as u64, done + 1, "{stdout}");
    assert!(
        stdout.contains(&format!("({} rows after the header", done + 1)),
        "{stdout}"
    );
    let left: Vec<_> = std::fs::read_dir(&scratch.0).unwrap().collect();
    assert_eq!(left.len(), 1, "a temporary file is left: {left:?}");
}

/// SIGINT with `--json`: exit 130, the JSON summary's `stop_reason` names the signal and its
/// `steps_done` matches the rows written.
#[test]
fn sigint_prints_the_json_summary_with_its_stop_reason() {
    let scratch = Scratch::new("sigint");
    let csv = scratch.0.join("run.csv");
    let mut child = spawn_long_run(&csv, &["--json"]);
    let out = signal_once_writing(&mut child, &scratch.0, 200_000, "-INT");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(130), "{stdout}");
    let j: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    let reason = j["stop_reason"].as_str().unwrap();
    assert!(reason.ends_with("interrupted by SIGINT"), "{reason}");
    let done = j["steps_done"].as_u64().unwrap();
    assert!(j["energy_end"].as_f64().unwrap().is_finite(), "{stdout}");
    assert_eq!(complete_rows(&csv) as u64, done + 1);
    let left: Vec<_> = std::fs::read_dir(&scratch.0).unwrap().collect();
    assert_eq!(left.len(), 1, "a temporary file is left: {left:?}");
}

/// A tmpfs of `kib` KiB mounted on a scratch directory, unmounted on drop; `None` where this
/// process may not mount (not root).
struct TinyDisk(Scratch);

impl TinyDisk {
    fn mount(test: &str, kib: u32) -> Option<TinyDisk> {
        let scratch = Scratch::new(test);
        let ok = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={kib}k"), "tmpfs"])
            .arg(&scratch.0)
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        ok.then_some(TinyDisk(scratch))
    }
}

impl Drop for TinyDisk {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0 .0).status();
    }
}

/// A full disk during `simulate --out`: exit 2, the summary printed with the write error as
/// its stop reason, and no file under the final name (nor a temporary one) — never a cut CSV.
#[test]
fn a_full_disk_leaves_no_cut_csv() {
    let Some(disk) = TinyDisk::mount("full", 64) else {
        eprintln!("skipped: cannot mount a tmpfs here (needs root)");
        return;
    };
    let csv = disk.0 .0.join("run.csv");
    let out = Command::new(env!("CARGO_BIN_EXE_articula"))
        .arg("simulate")
        .arg(model_path("chain300.urdf"))
        .args(["--steps", "1000", "--dt", "1e-4", "--out"])
        .arg(&csv)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stdout}\n{stderr}");
    assert!(stdout.contains("stopped      step"), "{stdout}");
    assert!(stderr.contains("cannot write"), "{stderr}");
    assert!(stderr.contains("No space left on device"), "{stderr}");
    let left: Vec<_> = std::fs::read_dir(&disk.0 .0).unwrap().collect();
    assert!(left.is_empty(), "files left on the full disk: {left:?}");
}

/// Two humanoids in zero gravity, a 160×90 camera (the scene of `scene_cli.rs`).
fn two_bodies_scene(dir: &Path) -> PathBuf {
    let models = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models");
    let text = format!(
        r#"{{"models": {{"h": "{}/humanoid.urdf"}},
            "bodies": [{{"name": "front", "model": "h", "position": [5, 0, 1], "velocity": {{"angular": [0, 0, 1]}}}},
                       {{"name": "behind", "model": "h", "position": [-5, 0, 1]}}],
            "camera": {{"eye": [0, 0, 1], "target": [10, 0, 1]}},
            "budget": 12, "dt": 0.002, "gravity": [0, 0, 0],
            "image": {{"width": 160, "height": 90}}}}"#,
        models.display()
    );
    let path = dir.join("two.json");
    std::fs::write(&path, text).unwrap();
    path
}

/// Whether `bytes` is a whole PNG: the signature first, the IEND chunk last.
fn whole_png(bytes: &[u8]) -> bool {
    bytes.starts_with(b"\x89PNG\r\n\x1a\n") && bytes.ends_with(b"IEND\xaeB`\x82")
}

/// SIGTERM during `scene --out`: exit 143, the JSON summary with the signal as its
/// `stop_reason` and the frames counted, every PNG whole, no temporary file left.
#[test]
fn sigterm_during_scene_out_leaves_whole_frames_and_a_summary() {
    let scratch = Scratch::new("scene-sigterm");
    let scene = two_bodies_scene(&scratch.0);
    let frames = scratch.0.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_articula"))
        .arg("scene")
        .arg(&scene)
        .args(["--steps", "10000000", "--threads", "1", "--out"])
        .arg(&frames)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = signal_once_writing(&mut child, &frames, 20_000, "-TERM");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(143), "{stdout}");
    let j: serde_json::Value = serde_json::from_str(stdout.lines().last().unwrap()).unwrap();
    let reason = j["stop_reason"].as_str().unwrap();
    assert!(reason.ends_with("interrupted by SIGTERM"), "{reason}");
    let mut pngs = 0;
    for entry in std::fs::read_dir(&frames).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        assert!(!name.starts_with('.'), "a temporary file is left: {name}");
        assert!(whole_png(&std::fs::read(&path).unwrap()), "{name} is cut");
        pngs += 1;
    }
    // A frame and a map per frame written.
    assert_eq!(pngs, 2 * j["frames"].as_u64().unwrap(), "{stdout}");
}

/// A full disk during `scene --out`: exit 2 with the summary, the write error as its stop
/// reason, and only whole PNGs on the disk.
#[test]
fn a_full_disk_during_scene_out_leaves_only_whole_frames() {
    let Some(disk) = TinyDisk::mount("scene-full", 48) else {
        eprintln!("skipped: cannot mount a tmpfs here (needs root)");
        return;
    };
    let scratch = Scratch::new("scene-full-json");
    let scene = two_bodies_scene(&scratch.0);
    let out = Command::new(env!("CARGO_BIN_EXE_articula"))
        .arg("scene")
        .arg(&scene)
        .args(["--steps", "1000", "--threads", "1", "--out"])
        .arg(&disk.0 .0)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stdout}\n{stderr}");
    let j: serde_json::Value = serde_json::from_str(stdout.lines().last().unwrap()).unwrap();
    let reason = j["stop_reason"].as_str().unwrap();
    assert!(reason.contains("No space left on device"), "{reason}");
    let mut pngs = 0;
    for entry in std::fs::read_dir(&disk.0 .0).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        assert!(!name.starts_with('.'), "a temporary file is left: {name}");
        assert!(whole_png(&std::fs::read(&path).unwrap()), "{name} is cut");
        pngs += 1;
    }
    assert!(pngs >= 1, "no frame fitted on the disk: {stdout}");
}
