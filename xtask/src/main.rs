//! Project automation tasks, run via `cargo xtask <subcommand>`.

mod args;
mod bench;
mod chart;
mod cli;
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

use cli::{Cli, Command};
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = Cli::parse_checked(std::env::args_os()).unwrap_or_else(|e| e.exit());
    let root = workspace_root();
    match &cli.command {
        Command::Test(o) => run(test::main(&root, o)),
        Command::Models(o) => run(models::main(&root, o)),
        Command::Bench(o) => run(bench::run(&root, o)),
        Command::CrowdChart(o) => run(crowd_chart::run(&root, o)),
        Command::Stability(o) => run(stability::run(&root, o)),
        Command::Snapshots(o) => run(snapshots::run(&root, o)),
        Command::Corpus(o) => corpus::main(&root, o),
        Command::MjcfCorpus(o) => mjcf_corpus::main(&root, o),
        Command::Drops(o) => drops::main(&root, o),
        Command::ContactPeers(o) => contact_peers::main(&root, o),
        Command::Hash => run(hash::run(&root)),
        Command::Time(o) => run(time::run(o)),
        Command::Growth(o) => run(growth::run(o)),
        Command::Speedup(c) => run(speedup::run(c)),
        Command::Parallel(o) => run(parallel::run(o)),
        Command::Profile(w) => run(profile::run(w)),
        Command::Pinocchio => run(pinocchio::run(&root)),
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
