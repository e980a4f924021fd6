//! The documented commands are tests: every ```` ```console ```` block of README.md and
//! docs/*.md runs here (trycmd), from the workspace root, with the debug-profile `articula`
//! that this test builds, and its output (stdout and stderr together) and exit code are
//! compared with the text.
//!
//! A block is a sequence of `$ articula ...` lines, each followed by its expected output;
//! `? 2` after a command expects that exit code (0 otherwise). In the expected output `[..]`
//! matches the rest of a line's variable part (a timing, a path) and a line `...` any number of
//! lines. Blocks tagged otherwise (```` ```sh ````, ```` ```text ````, a bare fence) are shown,
//! not run: long runs, timings, and commands other than `articula`.
//!
//! `cargo test -p articula-cli --test docs` runs them alone; a mismatch shows the diff and
//! the document's line. The cases are copies under the test's temporary directory, so
//! `TRYCMD=overwrite` does not rewrite the documents: edit the block from the diff shown.

use std::path::{Path, PathBuf};

/// The workspace root (two levels above this crate).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The Markdown files whose console blocks run: README.md and every docs/*.md.
fn documents() -> Vec<PathBuf> {
    let root = root();
    let mut files = vec![root.join("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .expect("docs/ is readable")
        .map(|e| e.expect("docs/ entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    docs.sort();
    files.extend(docs);
    files
}

/// `text` with every line outside a ```` ```console ```` block blanked, so that trycmd (which
/// reads every fenced block of a Markdown file, a bare fence included) sees only the console
/// blocks, and the number of blocks.
///
/// trycmd takes the newline before a command or the closing fence as formatting, not output;
/// the commands' outputs end with a newline, so one empty line is put after each output (and
/// one blank line after the block dropped for it), which keeps every block's first command at
/// its line in the document: a failure names it (a later command of the same block reads a
/// line or two further down).
fn console_blocks_only(text: &str) -> (String, usize) {
    let mut out = String::with_capacity(text.len());
    let (mut fence, mut inside, mut blocks) = (None::<String>, false, 0);
    // Lines added inside blocks and not yet taken back from the blank lines outside.
    let (mut debt, mut after_output) = (0usize, false);
    for line in text.lines() {
        let trimmed = line.trim_start();
        let closes = |f: &str| trimmed.starts_with(f) && trimmed.trim_matches('`').is_empty();
        match fence.clone() {
            Some(f) if closes(&f) => {
                if inside {
                    if after_output {
                        out.push('\n');
                        debt += 1;
                    }
                    out.push_str(line);
                    out.push('\n');
                } else {
                    blank(&mut out, &mut debt);
                }
                (fence, inside, after_output) = (None, false, false);
            }
            Some(_) if inside => {
                let command = line.starts_with("$ ");
                if command && after_output {
                    out.push('\n');
                    debt += 1;
                }
                after_output = !(command || line.starts_with("> ") || line.starts_with("? "));
                out.push_str(line);
                out.push('\n');
            }
            Some(_) => blank(&mut out, &mut debt),
            None if trimmed.starts_with("```") => {
                let ticks = trimmed.len() - trimmed.trim_start_matches('`').len();
                fence = Some("`".repeat(ticks));
                inside = trimmed[ticks..].trim() == "console";
                if inside {
                    blocks += 1;
                    out.push_str(line);
                    out.push('\n');
                } else {
                    blank(&mut out, &mut debt);
                }
            }
            None => blank(&mut out, &mut debt),
        }
    }
    (out, blocks)
}

/// One blank line for a line outside the console blocks, unless a line added inside a block
/// takes its place.
fn blank(out: &mut String, debt: &mut usize) {
    if *debt > 0 {
        *debt -= 1;
    } else {
        out.push('\n');
    }
}

#[test]
fn documented_commands_print_what_the_docs_say() {
    let root = root().canonicalize().expect("workspace root");
    let cases = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("docs-console");
    std::fs::create_dir_all(&cases).unwrap();
    let mut total = 0;
    let mut files = Vec::new();
    for doc in documents() {
        let text = std::fs::read_to_string(&doc).unwrap();
        let (only, blocks) = console_blocks_only(&text);
        if blocks == 0 {
            continue;
        }
        total += blocks;
        let rel = doc.strip_prefix(self::root()).unwrap_or(&doc);
        let name = rel.to_string_lossy().replace(['/', '\\'], "__");
        let case = cases.join(name);
        std::fs::write(&case, only).unwrap();
        files.push(case);
    }
    assert!(
        total >= 5,
        "only {total} console blocks found in README.md and docs/"
    );
    // The documents' commands name paths relative to the workspace root; trycmd runs each
    // command in this process's directory (no other test here depends on it).
    std::env::set_current_dir(&root).unwrap();
    let t = trycmd::TestCases::new();
    t.register_bin("articula", trycmd::cargo::cargo_bin!("articula"));
    for f in &files {
        t.case(f);
    }
    t.run();
}

/// The subcommands of `articula`.
const SUBCOMMANDS: [&str; 5] = ["info", "fd", "simulate", "bench", "scene"];

/// Every `articula SUB ...` command written in `text` that no console block runs: an inline
/// `code` span (which may break across lines) or a line of any other fenced block (joined with
/// the next when it ends in `\`; a `#` comment dropped), as (line, subcommand, its `--flags`).
fn shown_commands(text: &str) -> Vec<(usize, String, Vec<String>)> {
    let mut out = Vec::new();
    let mut take = |line: usize, command: &str| {
        let words: Vec<&str> = command.split_whitespace().collect();
        for (i, w) in words.iter().enumerate() {
            let program = w.rsplit('/').next().unwrap_or(w);
            let Some(sub) = words.get(i + 1) else {
                continue;
            };
            if program != "articula" || !SUBCOMMANDS.contains(sub) {
                continue;
            }
            let flags = words[i + 2..]
                .iter()
                .map(|w| w.trim_start_matches(['[', '(']))
                .filter(|w| w.starts_with("--") && w.len() > 2)
                .map(|w| {
                    w.chars()
                        .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
                        .collect::<String>()
                })
                .collect();
            out.push((line, (*sub).to_owned(), flags));
        }
    };
    let (mut fence, mut console, mut pending) = (None::<String>, false, String::new());
    let mut start = 0;
    let mut prose = String::new();
    for (n, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        if let Some(f) = &fence {
            if trimmed.starts_with(f.as_str()) && trimmed.trim_matches('`').is_empty() {
                fence = None;
            } else if !console {
                let code = line.split(" #").next().unwrap_or(line);
                if pending.is_empty() {
                    start = n + 1;
                }
                pending.push_str(code.trim_end_matches('\\'));
                pending.push(' ');
                if !code.trim_end().ends_with('\\') {
                    take(start, &pending);
                    pending.clear();
                }
            }
            prose.push('\n');
            continue;
        }
        if trimmed.starts_with("```") {
            let ticks = trimmed.len() - trimmed.trim_start_matches('`').len();
            fence = Some("`".repeat(ticks));
            console = trimmed[ticks..].trim() == "console";
            prose.push('\n');
            continue;
        }
        prose.push_str(line);
        prose.push('\n');
    }
    // Inline spans: the odd pieces between backticks, each at the line it starts on.
    let mut at = 0;
    for (k, piece) in prose.split('`').enumerate() {
        if k % 2 == 1 {
            let line = prose[..at].matches('\n').count() + 1;
            take(line, &piece.replace('\n', " "));
        }
        at += piece.len() + 1;
    }
    out
}

#[test]
fn every_flag_the_docs_show_is_one_the_cli_takes() {
    let bin = trycmd::cargo::cargo_bin!("articula");
    let mut help = std::collections::BTreeMap::new();
    for sub in SUBCOMMANDS {
        let out = std::process::Command::new(bin)
            .args([sub, "--help"])
            .output()
            .expect("run articula SUB --help");
        assert!(out.status.success(), "articula {sub} --help failed");
        // The options' own lines (`      --steps <STEPS>`, `  -h, --help`), not their text.
        let options: Vec<String> = String::from_utf8(out.stdout)
            .unwrap()
            .lines()
            .map(str::trim_start)
            .filter(|l| l.starts_with('-'))
            .flat_map(|l| l.split([' ', ',']).filter(|w| w.starts_with("--")))
            .map(str::to_owned)
            .collect();
        help.insert(sub, options);
    }
    let (mut checked, mut wrong) = (0, Vec::new());
    for doc in documents() {
        let text = std::fs::read_to_string(&doc).unwrap();
        let rel = doc
            .strip_prefix(root())
            .unwrap_or(&doc)
            .display()
            .to_string();
        for (line, sub, flags) in shown_commands(&text) {
            for flag in flags {
                checked += 1;
                let known = help[sub.as_str()].contains(&flag);
                if !known {
                    wrong.push(format!("{rel}:{line}: articula {sub} {flag}"));
                }
            }
        }
    }
    assert!(checked >= 50, "only {checked} flags found in the docs");
    assert!(
        wrong.is_empty(),
        "flags the docs show that `articula SUB --help` does not list:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn shown_commands_are_read_from_spans_and_blocks() {
    let text = "Run `articula simulate m.urdf\n--steps 10 [--json]` or\n```sh\n\
                target/release/articula scene s.json --threads 1 \\\n    --ground 0  # --no\n```\n\
                ```console\n$ articula info m --tree\n```\n`articula-cli` `articula bench M --reps`\n";
    let got = shown_commands(text);
    assert_eq!(
        got,
        vec![
            (
                4,
                "scene".to_owned(),
                vec!["--threads".to_owned(), "--ground".to_owned()]
            ),
            (
                1,
                "simulate".to_owned(),
                vec!["--steps".to_owned(), "--json".to_owned()]
            ),
            (10, "bench".to_owned(), vec!["--reps".to_owned()]),
        ]
    );
}

#[test]
fn console_blocks_are_found_and_other_blocks_blanked() {
    let text = "a\n```sh\n$ cargo x\n```\n```console\n$ articula info m\nout\n$ articula y\n? 2\nerr\n```\nb\nc\n```\nplain\n```\n";
    let (only, n) = console_blocks_only(text);
    assert_eq!(n, 1);
    // An empty line after each output, taken back from the blank lines after the block.
    assert_eq!(
        only,
        "\n\n\n\n```console\n$ articula info m\nout\n\n$ articula y\n? 2\nerr\n\n```\n\n\n\n"
    );
    assert_eq!(only.lines().count(), text.lines().count());
}
