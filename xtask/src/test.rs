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

const USAGE: &str = "cargo xtask test [--python-only | --rust-only] [--venv DIR] [PYTEST_ARGS...]";

/// The options of `cargo xtask test`.
struct Options {
    rust: bool,
    python: bool,
    venv: PathBuf,
    pytest: Vec<String>,
}

fn parse(root: &Path, args: &[String]) -> Result<Options, String> {
    let mut o = Options {
        rust: true,
        python: true,
        venv: root.join("target/py-venv"),
        pytest: Vec::new(),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--python-only" => o.rust = false,
            "--rust-only" => o.python = false,
            "--venv" => {
                o.venv = PathBuf::from(
                    it.next()
                        .ok_or(format!("--venv needs a directory\nusage: {USAGE}"))?,
                )
            }
            _ => o.pytest.push(a.clone()),
        }
    }
    if !o.rust && !o.python {
        return Err(format!(
            "--python-only and --rust-only exclude each other\nusage: {USAGE}"
        ));
    }
    Ok(o)
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
pub fn main(root: &Path, args: &[String]) -> Result<(), Box<dyn std::error::Error>> {
    let o = parse(root, args)?;
    if o.rust {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        run(Command::new(cargo)
            .args(["test", "--workspace"])
            .current_dir(root))?;
    }
    if o.python {
        let python = venv(root, &o.venv)?;
        let bin = python.parent().expect("bin directory").to_path_buf();
        let path = std::env::join_paths(std::iter::once(bin.clone()).chain(
            std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default()),
        ))?;
        run(Command::new(bin.join("maturin"))
            .args(["develop", "--release", "--quiet"])
            .current_dir(root.join("crates/articula-py"))
            .env("VIRTUAL_ENV", &o.venv)
            .env("PATH", &path))?;
        run(Command::new(&python)
            .args(["-m", "pytest", "crates/articula-py/tests", "-q", "-rs"])
            .args(&o.pytest)
            .current_dir(root))?;
    }
    eprintln!("==> cargo xtask test: all passed");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_pass_the_rest_to_pytest() {
        let args: Vec<String> = ["--python-only", "-k", "batch"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let o = parse(Path::new("/w"), &args).unwrap();
        assert!(!o.rust && o.python);
        assert_eq!(o.venv, Path::new("/w/target/py-venv"));
        assert_eq!(o.pytest, ["-k", "batch"]);
        let both: Vec<String> = ["--python-only", "--rust-only"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        assert!(parse(Path::new("/w"), &both).is_err());
    }
}
