//! The `cargo xtask` subcommands that README.md and docs/ name exist, and the README's list of
//! them is complete: read from the help of the built xtask binary (clap's list of its
//! subcommands) and checked by running it with `SUBCOMMAND --help` (exit 0 for a known one, 2
//! otherwise).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The subcommands a help text lists (its `Commands:` section, clap's `help` aside), each with
/// its one-line description.
fn listed(help: &str) -> BTreeMap<String, String> {
    let section = &help[help.find("Commands:\n").expect("a list of subcommands") + 10..];
    section
        .lines()
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| {
            let (name, about) = l.trim().split_once(' ')?;
            Some((name.to_owned(), about.trim().to_owned()))
        })
        .filter(|(name, _)| name != "help")
        .collect()
}

/// The subcommands the xtask binary takes: those `cargo xtask --help` lists.
fn dispatched() -> BTreeSet<String> {
    let out = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .arg("--help")
        .output()
        .expect("run xtask");
    assert!(out.status.success(), "`cargo xtask --help` failed");
    listed(&String::from_utf8(out.stdout).unwrap())
        .into_keys()
        .collect()
}

/// `cargo xtask WORD` occurrences in README.md and docs/*.md (line breaks and backticks
/// within the phrase allowed), with the file that names each first.
fn named_in_docs() -> Vec<(String, String)> {
    let root = root();
    let mut files = vec![root.join("README.md")];
    for e in std::fs::read_dir(root.join("docs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            files.push(p);
        }
    }
    let mut seen = BTreeSet::new();
    let mut out = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        let words: Vec<&str> = text.split_whitespace().collect();
        for w in words.windows(3) {
            if w[0].trim_start_matches(['`', '(']) == "cargo" && w[1] == "xtask" {
                let sub: String = w[2]
                    .chars()
                    .take_while(|c| c.is_ascii_lowercase() || *c == '-')
                    .collect();
                if !sub.is_empty() && !sub.starts_with('-') && seen.insert(sub.clone()) {
                    out.push((sub, f.display().to_string()));
                }
            }
        }
    }
    out
}

fn help_status(sub: &str) -> Option<i32> {
    Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args([sub, "--help"])
        .output()
        .expect("run xtask")
        .status
        .code()
}

#[test]
fn every_subcommand_the_docs_name_exists() {
    let subs = dispatched();
    let named = named_in_docs();
    assert!(named.len() >= 10, "only {named:?} found");
    for (sub, file) in &named {
        assert!(
            subs.contains(sub),
            "{file} names `cargo xtask {sub}`, which `cargo xtask --help` does not list"
        );
        assert_eq!(
            help_status(sub),
            Some(0),
            "`cargo xtask {sub} --help` failed"
        );
    }
    assert_eq!(help_status("no-such-subcommand"), Some(2));
}

#[test]
fn the_readme_lists_every_subcommand() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    // The layout's entry: "xtask/   cargo xtask models | bench | ... |" over several lines,
    // up to the next directory entry.
    let start = readme
        .find("xtask/ ")
        .expect("README.md's layout has an xtask/ entry");
    let entry = &readme[start..];
    let end = entry.find("\npeers/").unwrap_or(entry.len());
    let listed: BTreeSet<String> = entry[..end]
        .replace("cargo xtask", "")
        .trim_start_matches("xtask/")
        .split(['|', '\n'])
        .map(|w| w.trim().to_owned())
        .filter(|w| !w.is_empty())
        .collect();
    assert_eq!(
        listed,
        dispatched(),
        "README.md's xtask list (left) against `cargo xtask --help` (right)"
    );
}

/// `cargo xtask` alone prints the same list as `--help` (on stderr, exit 2), each subcommand
/// with a description, and each subcommand has its own help.
#[test]
fn the_help_lists_every_subcommand_with_a_description() {
    let out = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .output()
        .expect("run xtask");
    assert_eq!(out.status.code(), Some(2));
    let list = listed(&String::from_utf8(out.stderr).unwrap());
    assert_eq!(list.keys().cloned().collect::<BTreeSet<_>>(), dispatched());
    assert!(list.len() >= 17, "{list:?}");
    for (sub, about) in &list {
        assert!(about.len() > 20, "`{sub}` has no description: {about:?}");
        assert_eq!(help_status(sub), Some(0), "`cargo xtask {sub} --help`");
    }
}

/// `xtask ARGS...`: its exit code and stdout.
fn run(args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("run xtask");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "`cargo xtask {}` failed: {stderr}",
        args.join(" ")
    );
    (out.status.code(), String::from_utf8(out.stdout).unwrap())
}

/// The documented subcommands that take seconds, run with small arguments (the docs' own runs
/// take minutes; the rest are covered by `--help` above): docs/scaling.md's `parallel` splits
/// one body on the two threads it is given, docs/performance.md's `models --chain` and
/// `models --tree` write models that load with the DOF the page quotes (the tree: `16 × 5000`
/// gives 112,003), and `time`, `growth` and `profile` print their figures.
#[test]
fn the_cheap_documented_subcommands_run() {
    let (_, out) = run(&["parallel", "2", "1", "300"]);
    assert!(out.starts_with("threads=2 rounds=1"), "{out}");
    assert!(
        out.contains("chain300: serial ") && out.contains(" split/2 "),
        "{out}"
    );

    let options = articula_model::LoadOptions::default();
    let (_, urdf) = run(&["models", "--chain", "50"]);
    let chain = articula_model::Model::from_urdf_str(&urdf, &options).unwrap();
    assert_eq!((chain.name.as_str(), chain.nv), ("chain", 50));
    let (_, urdf) = run(&["models", "--tree", "16", "50"]);
    let tree = articula_model::Model::from_urdf_str(&urdf, &options).unwrap();
    // A head and 16 branches; from 16 × 5000 links, 112,003 DOF: 7 × 16 × LINKS / 5 + 3.
    assert_eq!(tree.bodies.len(), 16 * 50 + 1);
    assert_eq!(tree.nv, 7 * 16 * 50 / 5 + 3);

    let (_, out) = run(&["time", "dca", "humanoid-floating", "2", "5"]);
    assert!(out.starts_with("dca humanoid-floating: min "), "{out}");
    let (_, out) = run(&["growth", "dca", "10", "100", "1"]);
    assert!(
        out.starts_with("dca chain10 ") && out.contains("growth"),
        "{out}"
    );
    let (_, out) = run(&["profile", "adaptive", "300", "50", "10", "30"]);
    assert!(out.contains("budget 50 re-select every 10"), "{out}");
}
