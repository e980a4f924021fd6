//! `cargo xtask test`: every test of the project, the README's test command. Runs
//! `cargo test --workspace`, then the Python package's: makes (or reuses) a venv under
//! `target/py-venv`, installs what the tests need from PyPI when it is missing, builds the
//! extension into the venv (`maturin develop --release`, one release build; Ray too when PyPI
//! has it, for `articula.ray`) and runs pytest on
//! `crates/articula-py/tests` (Pinocchio comparisons, batches, errors, the fuzz loop, the
//! examples of `examples/python/` in their quick variants).

use std::path::{Path, PathBuf};
use std::process::Command;

/// What the Python tests need, as PyPI distribution names.
const PACKAGES: &[&str] = &[
    "maturin",
    "numpy",
    "pytest",
    "pin",
    "example-robot-data",
    "mujoco",
    "matplotlib",
];

/// The arguments of `cargo xtask test`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// Only the Python package's tests.
    #[arg(long, conflicts_with = "rust_only")]
    pub python_only: bool,
    /// Only `cargo test --workspace`.
    #[arg(long)]
    pub rust_only: bool,
    /// The venv of the Python tests [default: target/py-venv].
    #[arg(long, value_name = "DIR")]
    pub venv: Option<PathBuf>,
    /// Passed to pytest (`-k EXPR`, `-x`, ...), after this command's own flags.
    #[arg(value_name = "PYTEST_ARGS", allow_hyphen_values = true)]
    pub pytest: Vec<String>,
}

/// Runs `cmd`, echoing it; an error names it and its exit status.
fn run(cmd: &mut Command) -> Result<(), Box<dyn std::error::Error>> {
    eprintln!("==> {cmd:?}");
    let status = cmd
        .status()
        .map_err(|e| format!("cannot run {cmd:?}: {e}"))?;
    if !status.success() {
        return Err(format!("{cmd:?} failed ({status})").into());
    }
    Ok(())
}

/// Installed when missing if PyPI has it for this Python and platform; without it the tests
/// of `articula.ray` are skipped with the reason — except under CI, where a failed install
/// fails the run.
const OPTIONAL: &[&str] = &["ray"];

/// Whether this runs under CI (`CI` set to anything but `false` or empty, as `.ci/run` sets
/// it): then the optional packages are required.
fn under_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0")
}

/// The distributions of `packages` the venv's Python lacks.
fn missing(python: &Path, packages: &[&str]) -> Result<Vec<String>, Box<dyn std::error::Error>> {
    let script = format!(
        "import importlib.metadata as md\nfor d in {packages:?}:\n    try: md.version(d)\n    \
         except md.PackageNotFoundError: print(d)\n"
    );
    let out = Command::new(python).args(["-c", &script]).output()?;
    if !out.status.success() {
        return Err(format!("{} cannot list its packages", python.display()).into());
    }
    Ok(String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .map(String::from)
        .collect())
}

/// The venv's Python, made (and given the test packages) when needed.
fn venv(root: &Path, dir: &Path) -> Result<PathBuf, Box<dyn std::error::Error>> {
    let python = dir.join("bin/python");
    if !python.exists() {
        let system = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
        run(Command::new(&system)
            .args(["-m", "venv"])
            .arg(dir)
            .current_dir(root))?;
    }
    let pip = |need: &[String]| {
        let mut cmd = Command::new(&python);
        cmd.args(["-m", "pip", "install", "--disable-pip-version-check", "-q"])
            .args(need);
        cmd
    };
    let need = missing(&python, PACKAGES)?;
    if !need.is_empty() {
        run(&mut pip(&need))?;
    }
    let optional = missing(&python, OPTIONAL)?;
    if !optional.is_empty() {
        if let Err(e) = run(&mut pip(&optional)) {
            // Under CI (`.ci/run`) they are required: a skipped Ray suite must not pass.
            if under_ci() {
                return Err(
                    format!("{e}: CI needs {optional:?} for the tests of articula.ray").into(),
                );
            }
            eprintln!("warning: {e}: the tests that need {optional:?} will be skipped");
        }
    }
    Ok(python)
}

/// Runs `cargo xtask test`.
pub fn main(root: &Path, o: &Options) -> Result<(), Box<dyn std::error::Error>> {
    let dir = o
        .venv
        .clone()
        .unwrap_or_else(|| root.join("target/py-venv"));
    if !o.python_only {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        run(Command::new(cargo)
            .args(["test", "--workspace"])
            .current_dir(root))?;
    }
    if !o.rust_only {
        let python = venv(root, &dir)?;
        let bin = python.parent().expect("bin directory").to_path_buf();
        let path = std::env::join_paths(std::iter::once(bin.clone()).chain(
            std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default()),
        ))?;
        run(Command::new(bin.join("maturin"))
            .args(["develop", "--release", "--quiet"])
            .current_dir(root.join("crates/articula-py"))
            .env("VIRTUAL_ENV", &dir)
            .env("PATH", &path))?;
        run(Command::new(&python)
            .args(["-m", "pytest", "crates/articula-py/tests", "-q", "-rs"])
            .args(&o.pytest)
            .current_dir(root))?;
    }
    eprintln!("==> cargo xtask test: all passed");
    Ok(())
}
