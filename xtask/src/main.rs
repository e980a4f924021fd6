//! Project automation tasks, run via `cargo xtask <subcommand>`.

mod bench;
mod chart;
mod dd;
mod hp;
mod models;
mod pinocchio;
mod snapshots;
mod solver;
mod stability;
mod timing;

use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "\
usage: cargo xtask <subcommand>

subcommands:
    bench [--quick] [--peers] [--publish]
                            time DCA, ABA, CRBA (and with --peers Pinocchio and MuJoCo) on
                            chains of 10..10,000 links and the humanoid, measure their error
                            against a double-double reference, write
                            target/articula-bench/report.md and charts (SVG, PNG);
                            --quick samples in-process (minutes), otherwise criterion;
                            --publish also copies the charts into docs/img/ and the
                            report to docs/bench-report.md
    pinocchio               compare inverse dynamics, mass matrix, bias forces, centre of
                            mass, energies, momentum, link poses and Jacobians with
                            Pinocchio's on the humanoid (needs the peers' Python:
                            ARTICULA_PEERS_PYTHON or target/peers-venv)
    models                  regenerate the URDF test/benchmark models in models/
    stability               accuracy of DCA, ABA, CRBA against a double-double reference
                            (chain length, mass ratio) and integrators' energy drift;
                            writes docs/stability.md and charts in docs/img/
    snapshots [--accept]    run the snapshot tests of `articula info` (INSTA_UPDATE=no);
                            with --accept, rewrite the changed .snap files
                            (INSTA_UPDATE=always) and list them with git status
";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("models") => run(models::run(&workspace_root().join("models"))),
        Some("pinocchio") => run(pinocchio::run(&workspace_root())),
        Some("bench") => run(bench::run(&workspace_root(), &args[1..])),
        Some("stability") => run(stability::run(&workspace_root(), &args[1..])),
        Some("snapshots") => run(snapshots::run(&workspace_root(), &args[1..])),
        Some("-h" | "--help" | "help") => {
            print!("{USAGE}");
            ExitCode::SUCCESS
        }
        Some(other) => {
            eprintln!("error: unknown subcommand `{other}`\n");
            eprint!("{USAGE}");
            ExitCode::from(2)
        }
        None => {
            eprint!("{USAGE}");
            ExitCode::from(2)
        }
    }
}

/// Converts a task result into a process exit code, printing any error.
fn run(result: Result<(), Box<dyn std::error::Error>>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The workspace root (the parent of the `xtask` crate directory).
fn workspace_root() -> PathBuf {
    let manifest_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    manifest_dir
        .parent()
        .expect("xtask crate has a parent directory")
        .to_path_buf()
}
