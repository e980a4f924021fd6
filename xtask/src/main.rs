//! Project automation tasks, run via `cargo xtask <subcommand>`.

mod args;
mod bench;
mod chart;
mod contact_peers;
mod corpus;
mod crowd_chart;
mod docs;
mod drops;
mod growth;
mod hash;
mod mjcf_corpus;
mod models;
mod parallel;
mod pinocchio;
mod profile;
mod snapshots;
mod solver;
mod speedup;
mod stability;
mod stress;
mod test;
mod time;
mod timing;
mod trajectory;

use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "\
usage: cargo xtask <subcommand>

subcommands:
    bench [--quick] [--peers] [--publish] [--write-docs]
                            time DCA, ABA, CRBA (and with --peers Pinocchio and MuJoCo) on
                            chains of 10..10,000 links and the humanoid, measure their error
                            against a double-double reference, write
                            target/articula-bench/report.md and charts (SVG, PNG);
                            --quick samples in-process (minutes), otherwise criterion;
                            --publish also copies the charts into docs/img/ and the
                            report to docs/bench-report.md; --write-docs writes the
                            exact methods' one-step errors into docs/performance.md
    crowd-chart [SCENE.json] [--horizon S] [--budgets B,B,...] [--mujoco MS] [--publish]
                            cost per simulated second (one thread) against the view-weighted
                            error of crowd200 on its floor: adaptive budgets, the culling
                            baseline, exact DCA at 1x, 2x, 4x the step, MuJoCo's cost as a
                            line; writes target/articula-crowd/ (report.md, SVG, PNG);
                            --publish copies the chart into docs/img/
    mjcf-corpus [--quick] [--venv DIR]
                            loads every kinematic-tree MJCF model of dm-control and
                            gymnasium with articula and MuJoCo, compares M and qacc_smooth,
                            times DCA, ABA and mj_forward; writes
                            target/articula-mjcf-corpus/report.md
    corpus [--quick] [--inertia accept|strict|repair] [--bound-inertia KGM2]
           [--venv DIR] [--write-docs] [NAME...]
                            load every URDF of example-robot-data (fixed and floating
                            base), compare DCA and ABA with Pinocchio's aba, time the
                            three; writes target/articula-corpus/report.md (needs the
                            venv of peers/corpus.py; exits 2 without it)
    drops [--quick] [--inertia accept|strict|repair] [--bound-mass KG]
          [--bound-inertia KGM2] [--venv DIR] [--write-docs] [NAME...]
                            drop every URDF of example-robot-data (floating base, 0.3 m)
                            on a ground and run 3 s of DCA contact steps; writes
                            target/articula-drops/report.md (needs the venv's
                            example-robot-data)
    contact-peers [--rounds N] [--only CASES] [--venv DIR]
                            the humanoid drop, anymal standing and dropped and crowd200
                            in articula and MuJoCo, alternated, one thread: time per
                            step, penetration, contacts, energy (peers/contact_peers.py)
    pinocchio               compare inverse dynamics, mass matrix, bias forces, centre of
                            mass, energies, momentum, link poses and Jacobians with
                            Pinocchio's on the humanoid (needs the peers' Python:
                            ARTICULA_PEERS_PYTHON or target/peers-venv)
    test [--python-only | --rust-only] [--venv DIR] [PYTEST_ARGS...]
                            every test: cargo test --workspace, then the Python package's
                            (a venv in target/py-venv with maturin, numpy, pytest, pin,
                            example-robot-data, mujoco, matplotlib, ray installed from PyPI
                            when missing; the extension built with maturin develop --release;
                            pytest on crates/articula-py/tests, which runs examples/python)
    models                  regenerate the URDF test/benchmark models in models/
    models --chain N        print the URDF of an N-link chain (the bodies of chainN.urdf)
    models --tree BRANCHES LINKS
                            print the URDF of a head with BRANCHES chains of LINKS links
                            (articula_testkit::branches_urdf)
    stability               accuracy of DCA, ABA, CRBA against a double-double reference
                            (chain length, mass ratio) and integrators' energy drift;
                            writes docs/stability.md, charts in docs/img/ and the
                            longest chain's errors into docs/performance.md
    snapshots [--accept]    run the snapshot tests of `articula info` (INSTA_UPDATE=no);
                            with --accept, rewrite the changed .snap files
                            (INSTA_UPDATE=always) and list them with git status
    hash                    bit-level fingerprints: DCA's q̈ on the bundled models and
                            chains (qdd_hash), a crowd scene's state after 500 steps
    time METHOD MODEL [BATCHES] [CALLS] [--portable]
                            minimum and median time per forward-dynamics call (MODEL: a
                            chain length, a bundled model, or NAME-floating)
    growth [METHOD] [SHORT] [LONG] [ROUNDS]
                            time per call from a short to a long chain, the two interleaved
    parallel [THREADS] [ROUNDS] [LENGTH...]
                            one body's DCA split across threads against the serial DCA,
                            by chain length (the crossover, the long-chain speed-up)
    speedup seeds [ROUNDS] [BUDGET...] | speedup crowd SCENE.json [ROUNDS] [STEPS] [BUDGET...]
                            adaptive against exact DCA steps, interleaved in one process
    profile dynamics|adaptive|exact|scene ...
                            fixed workloads for callgrind and perf (see xtask/src/profile.rs)
";

/// The subcommands `main` dispatches, in its order (README.md's xtask list names each).
const SUBCOMMANDS: &[&str] = &[
    "corpus",
    "drops",
    "contact-peers",
    "test",
    "mjcf-corpus",
    "models",
    "hash",
    "time",
    "growth",
    "speedup",
    "parallel",
    "profile",
    "pinocchio",
    "bench",
    "crowd-chart",
    "stability",
    "snapshots",
];

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    // `cargo xtask SUBCOMMAND --help` prints the usage of every subcommand; an unknown
    // subcommand's is an error (exit 2), so that `--help` tells whether a subcommand exists
    // (xtask/tests/docs_commands.rs checks every one the docs name).
    if args.iter().skip(1).any(|a| a == "-h" || a == "--help") {
        let sub = args[0].as_str();
        if SUBCOMMANDS.contains(&sub) {
            print!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        eprintln!("error: unknown subcommand `{sub}`\n");
        eprint!("{USAGE}");
        return ExitCode::from(2);
    }
    match args.first().map(String::as_str) {
        Some("corpus") => corpus::main(&workspace_root(), &args[1..]),
        Some("drops") => drops::main(&workspace_root(), &args[1..]),
        Some("contact-peers") => contact_peers::main(&workspace_root(), &args[1..]),
        Some("test") => run(test::main(&workspace_root(), &args[1..])),
        Some("mjcf-corpus") => mjcf_corpus::main(&workspace_root(), &args[1..]),
        Some("models") if args.get(1).map(String::as_str) == Some("--chain") => {
            run(print_chain(&args[2..]))
        }
        Some("models") if args.get(1).map(String::as_str) == Some("--tree") => {
            run(print_tree(&args[2..]))
        }
        Some("models") => run(models::run(&workspace_root().join("models"))),
        Some("hash") => run(hash::run(&workspace_root(), &args[1..])),
        Some("time") => run(time::run(&args[1..])),
        Some("growth") => run(growth::run(&args[1..])),
        Some("speedup") => run(speedup::run(&args[1..])),
        Some("parallel") => run(parallel::run(&args[1..])),
        Some("profile") => run(profile::run(&args[1..])),
        Some("pinocchio") => run(pinocchio::run(&workspace_root())),
        Some("bench") => run(bench::run(&workspace_root(), &args[1..])),
        Some("crowd-chart") => run(crowd_chart::run(&workspace_root(), &args[1..])),
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

/// `cargo xtask models --chain N`: the URDF of an N-link chain on stdout (for the peers'
/// scripts, e.g. `peers/pin300.py`).
fn print_chain(args: &[String]) -> Result<(), Box<dyn std::error::Error>> {
    let mut a = args::Args::new(args, "cargo xtask models --chain N");
    let n: usize = a.next("link count")?;
    a.finish()?;
    print!("{}", articula_testkit::chain_urdf(n));
    Ok(())
}

/// `cargo xtask models --tree BRANCHES LINKS`: the URDF of a branched tree on stdout (a large
/// hybrid body whose passes split over subtrees, docs/scaling.md).
fn print_tree(args: &[String]) -> Result<(), Box<dyn std::error::Error>> {
    let mut a = args::Args::new(args, "cargo xtask models --tree BRANCHES LINKS");
    let branches: usize = a.next("branch count")?;
    let links: usize = a.next("links per branch")?;
    a.finish()?;
    print!(
        "{}",
        articula_testkit::branches_urdf(&vec![links; branches])
    );
    Ok(())
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
