//! End-to-end tests of the `articula` binary: exit codes on bad input and the figures that
//! matter on bundled models.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn models_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

fn articula(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_articula"))
        .args(args)
        .output()
        .expect("cannot run the articula binary")
}

fn info(path: &Path, extra: &[&str]) -> Output {
    let mut args: Vec<&std::ffi::OsStr> = vec!["info".as_ref(), path.as_os_str()];
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    articula(&args)
}

/// A scratch directory under the system temp dir, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(test: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!("articula-cli-{}-{test}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("cannot create a temp dir");
        Scratch(dir)
    }

    fn file(&self, name: &str, contents: &[u8]) -> PathBuf {
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

fn stdout(out: &Output) -> String {
    assert!(
        out.status.success(),
        "articula failed with {}:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout.clone()).expect("non-UTF-8 output")
}

#[test]
fn nonexistent_file_is_bad_input() {
    let scratch = Scratch::new("nonexistent");
    let missing = scratch.0.join("no-such-model.urdf");
    let stderr = assert_bad_input(&info(&missing, &[]), "nonexistent file");
    assert!(
        stderr.contains("no-such-model.urdf"),
        "the error should name the file:\n{stderr}"
    );
    assert_bad_input(&info(&missing, &["--json"]), "nonexistent file, --json");
}

#[test]
fn empty_file_is_bad_input() {
    let scratch = Scratch::new("empty");
    let empty = scratch.file("empty.urdf", b"");
    assert_bad_input(&info(&empty, &[]), "empty file");
    let blank = scratch.file("blank.urdf", b"  \n\t\n");
    assert_bad_input(&info(&blank, &["--json"]), "blank file");
}

#[test]
fn truncated_urdf_is_bad_input() {
    let scratch = Scratch::new("truncated");
    let full = std::fs::read(models_dir().join("humanoid.urdf")).expect("humanoid.urdf");
    for cut in [full.len() / 2, full.len() - 20, 40] {
        let path = scratch.file("truncated.urdf", &full[..cut]);
        assert_bad_input(&info(&path, &[]), &format!("URDF truncated at byte {cut}"));
    }
}

#[test]
fn binary_and_non_robot_files_are_bad_input() {
    let scratch = Scratch::new("garbage");
    let binary = scratch.file("binary.urdf", &[0x7f, b'E', b'L', b'F', 0, 0, 0xff, 0xfe]);
    assert_bad_input(&info(&binary, &[]), "binary file");
    let other = scratch.file("other.urdf", b"<sdf version=\"1.6\"><model/></sdf>");
    assert_bad_input(&info(&other, &[]), "not a <robot>");
}

#[test]
fn directory_is_bad_input() {
    assert_bad_input(&info(&models_dir(), &[]), "a directory");
}

#[test]
fn usage_errors_exit_2() {
    let out = articula(&["info".as_ref()]);
    assert_eq!(out.status.code(), Some(2), "missing model argument");
    let out = articula(&["no-such-subcommand".as_ref()]);
    assert_eq!(out.status.code(), Some(2), "unknown subcommand");
}

#[test]
fn humanoid_text_lists_composed_joints() {
    let text = stdout(&info(&models_dir().join("humanoid.urdf"), &[]));
    for composed in [
        "l_hip_z + l_hip_x + l_hip_y",
        "r_hip_z + r_hip_x + r_hip_y",
        "lumbar_z + lumbar_x + lumbar_y",
        "l_ankle_y + l_ankle_x",
    ] {
        assert!(
            text.lines().any(|l| l.contains(composed)),
            "no line lists the composed joint `{composed}`:\n{text}"
        );
    }
    assert!(text.contains("composed joints"), "{text}");
    assert!(
        !text.contains("assembly tree:"),
        "the tree is printed only with --tree"
    );
}

#[test]
fn chain300_assembly_is_balanced() {
    let text = stdout(&info(&models_dir().join("chain300.urdf"), &["--json"]));
    let json: serde_json::Value = serde_json::from_str(&text).expect("--json prints JSON");
    let depth = json["assembly"]["depth"].as_u64().expect("assembly.depth");
    let handles = json["assembly"]["max_handles"]
        .as_u64()
        .expect("assembly.max_handles");
    assert!(depth <= 10, "chain300: assembly depth {depth} > 10");
    assert!(handles <= 2, "chain300: {handles} handles > 2");
    assert_eq!(json["dof"], 300);
    assert_eq!(json["bodies"], 300);
}

#[test]
fn humanoid_floating_base_adds_six_dof() {
    let path = models_dir().join("humanoid.urdf");
    let fixed: serde_json::Value =
        serde_json::from_str(&stdout(&info(&path, &["--json"]))).expect("JSON");
    let floating: serde_json::Value =
        serde_json::from_str(&stdout(&info(&path, &["--json", "--floating-base"]))).expect("JSON");
    let dof = |v: &serde_json::Value, key: &str| v[key].as_u64().expect(key);
    assert_eq!(dof(&floating, "dof"), dof(&fixed, "dof") + 6);
    assert_eq!(dof(&floating, "nq"), dof(&fixed, "nq") + 7);
    assert_eq!(floating["floating_base"], true);
    assert_eq!(
        floating["ground_links"],
        serde_json::json!([]),
        "nothing is welded to the world with a floating base"
    );
}

#[test]
fn closed_stdout_is_not_a_panic() {
    use std::io::Read;
    // chain1000's tree (~120 kB) is larger than a pipe's buffer: the binary is still writing
    // when the reader goes away (`articula info ... --tree | head`).
    let mut child = Command::new(env!("CARGO_BIN_EXE_articula"))
        .arg("info")
        .arg(models_dir().join("chain1000.urdf"))
        .arg("--tree")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("cannot run the articula binary");
    let mut head = [0u8; 64];
    child
        .stdout
        .take()
        .expect("piped stdout")
        .read_exact(&mut head)
        .expect("some output");
    // The read end is dropped here.
    let out = child.wait_with_output().expect("articula runs to its end");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !stderr.contains("panicked"),
        "panic on a closed pipe:\n{stderr}"
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "a closed pipe is not an error; stderr:\n{stderr}"
    );
}

/// `info` names the format the file was read as: the bundled MJCF humanoid's ten ball joints
/// (3 DOF each) and its free root give 41 DOF; the URDF humanoid says URDF.
#[test]
fn info_names_the_file_format() {
    let text = stdout(&info(&models_dir().join("humanoid_ball.xml"), &[]));
    assert!(text.contains("\nMJCF "), "{text}");
    assert!(text.contains("41 DOF"), "{text}");
    assert!(text.contains("joints with MJCF limits"), "{text}");
    let text = stdout(&info(&models_dir().join("humanoid.urdf"), &[]));
    assert!(text.contains("\nURDF "), "{text}");
}
