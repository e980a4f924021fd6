//! `articula`: the command-line front end.
//!
//! Exit codes: 0 success, 2 bad input (a model, state or argument that cannot be used; the
//! error is printed on stderr), never a panic's 101.

mod info;

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "articula",
    version,
    about = "Forward dynamics of articulated bodies"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Describe a URDF model: bodies after merging, degrees of freedom, composed joints, mass,
    /// assembly tree.
    Info {
        /// The URDF file.
        model: PathBuf,
        /// Give the root link six degrees of freedom instead of welding it to the world.
        #[arg(long)]
        floating_base: bool,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
        /// Also print the assembly tree as an indented outline (text mode).
        #[arg(long)]
        tree: bool,
    },
}

/// An error for the user: printed on stderr, exit code 2.
pub struct CliError(pub String);

impl<E: std::fmt::Display> From<E> for CliError {
    fn from(e: E) -> Self {
        CliError(e.to_string())
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Info {
            model,
            floating_base,
            json,
            tree,
        } => info::run(&model, floating_base, json, tree),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(CliError(msg)) => {
            eprintln!("error: {msg}");
            ExitCode::from(2)
        }
    }
}
