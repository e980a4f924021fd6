//! `cargo xtask snapshots [--accept]`: the snapshot tests of `articula info`
//! (`crates/articula-cli/tests/snapshots.rs`, snapshots in `crates/articula-cli/tests/snapshots/`).
//!
//! Without `--accept` the tests run with `INSTA_UPDATE=no`: nothing is written and any
//! mismatch fails with its diff. With `--accept` they run with `INSTA_UPDATE=always`, which
//! rewrites the `.snap` files of mismatching or new snapshots in place (insta does this even
//! when `CI` is set, unlike its default `auto` mode); `git status` then lists what changed.
//! No `cargo-insta` is needed.

use std::ffi::OsString;
use std::path::Path;
use std::process::Command;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Where the snapshot files live, relative to the workspace root.
pub const SNAPSHOT_DIR: &str = "crates/articula-cli/tests/snapshots";

/// The arguments of `cargo xtask snapshots`.
#[derive(clap::Args, Debug)]
pub struct Options {
    /// Rewrite the changed .snap files (INSTA_UPDATE=always) and list them with git status.
    #[arg(long)]
    pub accept: bool,
}

/// Runs the task.
pub fn run(root: &Path, o: &Options) -> Result<()> {
    let accept = o.accept;
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| OsString::from("cargo"));
    let update = if accept { "always" } else { "no" };
    let mut cmd = Command::new(&cargo);
    cmd.current_dir(root)
        .args(["test", "-p", "articula-cli", "--test", "snapshots"])
        .env("INSTA_UPDATE", update)
        // A stray INSTA_FORCE_PASS would turn mismatches into passes.
        .env_remove("INSTA_FORCE_PASS");
    if accept {
        // Pending `.snap.new` files (left by a plain `cargo test` outside CI) are superseded
        // by the in-place rewrite.
        remove_pending(&root.join(SNAPSHOT_DIR))?;
    }
    println!("running: INSTA_UPDATE={update} cargo test -p articula-cli --test snapshots");
    let status = cmd
        .status()
        .map_err(|e| format!("cannot run {}: {e}", cargo.to_string_lossy()))?;
    if !status.success() {
        return Err(if accept {
            format!("snapshot tests failed even with --accept ({status}): see above").into()
        } else {
            format!(
                "snapshot tests failed ({status}); if the change is intended, run \
                 `cargo xtask snapshots --accept` and review the diff"
            )
            .into()
        });
    }
    if accept {
        println!("snapshots accepted; changes under {SNAPSHOT_DIR} (review before committing):");
        let git = Command::new("git")
            .current_dir(root)
            .args(["status", "--short", "--untracked-files=all", SNAPSHOT_DIR])
            .output();
        match git {
            Ok(out) if out.status.success() => {
                let text = String::from_utf8_lossy(&out.stdout);
                if text.trim().is_empty() {
                    println!("  (none)");
                } else {
                    print!("{text}");
                }
            }
            Ok(out) => eprintln!(
                "warning: git status failed: {}",
                String::from_utf8_lossy(&out.stderr).trim()
            ),
            Err(e) => eprintln!("warning: cannot run git: {e}"),
        }
    } else {
        println!("snapshots match");
    }
    Ok(())
}

/// Deletes `*.snap.new` files in `dir` (a missing directory is fine).
fn remove_pending(dir: &Path) -> Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    for entry in entries {
        let path = entry?.path();
        if path
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.ends_with(".snap.new"))
        {
            std::fs::remove_file(&path)
                .map_err(|e| format!("cannot remove {}: {e}", path.display()))?;
            println!("removed pending {}", path.display());
        }
    }
    Ok(())
}
