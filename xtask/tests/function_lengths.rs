//! Functions stay short enough to hold at once: none over 150 lines in `crates/`, none over 200
//! anywhere in the workspace's Rust (crates/, xtask/, benches/, examples/).
//!
//! A function's length is counted from the line of its `fn` keyword to the line of its closing
//! brace, doc comments and attributes aside; a nested function counts both inside its parent
//! and on its own. The scanner blanks comments, strings and character literals first, so braces
//! inside them do not count.

use std::path::{Path, PathBuf};

/// Longest function allowed in `crates/` (library, CLI, tests).
const CRATES_LIMIT: usize = 150;
/// Longest function allowed anywhere else.
const ANYWHERE_LIMIT: usize = 200;

/// Functions still over the limit, each with the length it may not exceed: (file, function,
/// lines). An entry that has come under the limit must be removed (the test says so), so
/// the list only shrinks.
const NOT_YET_SPLIT: &[(&str, &str, usize)] = &[];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// One function: where it starts and how many lines it spans.
#[derive(Debug, Clone, PartialEq)]
struct Function {
    name: String,
    /// 1-based line of the `fn` keyword.
    line: usize,
    lines: usize,
}

/// `text` with the contents of comments, string, byte-string, raw-string and character
/// literals replaced by spaces (newlines kept, so line numbers hold).
fn blank_literals(text: &str) -> Vec<u8> {
    let b = text.as_bytes();
    let mut out = b.to_vec();
    let mut i = 0;
    let blank = |out: &mut Vec<u8>, from: usize, to: usize| {
        for c in &mut out[from..to] {
            if *c != b'\n' {
                *c = b' ';
            }
        }
    };
    while i < b.len() {
        let ident_before = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        match b[i] {
            b'/' if b.get(i + 1) == Some(&b'/') => {
                let end = b[i..]
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(b.len(), |p| i + p);
                blank(&mut out, i, end);
                i = end;
            }
            b'/' if b.get(i + 1) == Some(&b'*') => {
                let (mut depth, mut j) = (1, i + 2);
                while j < b.len() && depth > 0 {
                    if b[j] == b'/' && b.get(j + 1) == Some(&b'*') {
                        depth += 1;
                        j += 2;
                    } else if b[j] == b'*' && b.get(j + 1) == Some(&b'/') {
                        depth -= 1;
                        j += 2;
                    } else {
                        j += 1;
                    }
                }
                blank(&mut out, i, j);
                i = j;
            }
            b'r' if !ident_before && matches!(b.get(i + 1), Some(b'"' | b'#')) => {
                let hashes = b[i + 1..].iter().take_while(|&&c| c == b'#').count();
                if b.get(i + 1 + hashes) != Some(&b'"') {
                    i += 1;
                    continue;
                }
                let close: Vec<u8> = std::iter::once(b'"')
                    .chain(std::iter::repeat_n(b'#', hashes))
                    .collect();
                let start = i + 2 + hashes;
                let end = b[start..]
                    .windows(close.len())
                    .position(|w| w == close.as_slice())
                    .map_or(b.len(), |p| start + p + close.len());
                blank(&mut out, i, end);
                i = end;
            }
            b'"' => {
                let mut j = i + 1;
                while j < b.len() && b[j] != b'"' {
                    j += if b[j] == b'\\' { 2 } else { 1 };
                }
                blank(&mut out, i, (j + 1).min(b.len()));
                i = j + 1;
            }
            b'\'' => {
                // A character literal ('x', '\n', '\u{..}') or a lifetime ('a).
                let end = if b.get(i + 1) == Some(&b'\\') {
                    b[i + 2..]
                        .iter()
                        .position(|&c| c == b'\'')
                        .map(|p| i + 3 + p)
                } else {
                    let ch = text[i + 1..].chars().next().map_or(1, char::len_utf8);
                    (b.get(i + 1 + ch) == Some(&b'\'')).then_some(i + 2 + ch)
                };
                match end {
                    Some(end) => {
                        blank(&mut out, i, end);
                        i = end;
                    }
                    None => i += 1,
                }
            }
            _ => i += 1,
        }
    }
    out
}

/// Every function with a body in `text`.
fn functions(text: &str) -> Vec<Function> {
    let code = blank_literals(text);
    let line_of = |pos: usize| code[..pos].iter().filter(|&&c| c == b'\n').count() + 1;
    let is_ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let mut found = Vec::new();
    let mut i = 0;
    while let Some(p) = code[i..].windows(3).position(|w| w == b"fn ") {
        let at = i + p;
        i = at + 3;
        if at > 0 && is_ident(code[at - 1]) {
            continue;
        }
        let name_start = at + 3 + code[at + 3..].iter().take_while(|c| **c == b' ').count();
        let name_len = code[name_start..]
            .iter()
            .take_while(|c| is_ident(**c))
            .count();
        if name_len == 0 {
            continue;
        }
        // The body opens at the first `{` outside parentheses and angle brackets; a `;` first
        // means a declaration without body (a trait method).
        let (mut paren, mut j) = (0i32, name_start + name_len);
        let open = loop {
            match code.get(j) {
                None => break None,
                Some(b'(' | b'[') => paren += 1,
                Some(b')' | b']') => paren -= 1,
                Some(b';') if paren == 0 => break None,
                Some(b'{') if paren == 0 => break Some(j),
                _ => {}
            }
            j += 1;
        };
        let Some(open) = open else { continue };
        let (mut depth, mut k) = (0usize, open);
        while k < code.len() {
            match code[k] {
                b'{' => depth += 1,
                b'}' => {
                    depth -= 1;
                    if depth == 0 {
                        break;
                    }
                }
                _ => {}
            }
            k += 1;
        }
        let line = line_of(at);
        found.push(Function {
            name: String::from_utf8_lossy(&code[name_start..name_start + name_len]).into_owned(),
            line,
            lines: line_of(k.min(code.len() - 1)) - line + 1,
        });
    }
    found
}

/// Every `.rs` file under `dir`, `target/` directories aside.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            if p.file_name()
                .is_some_and(|n| n != "target" && n != "node_modules")
            {
                rust_files(&p, out);
            }
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn the_scanner_measures_known_shapes() {
    let text = "fn a() {\n    let s = \"}\";\n    let c = '}';\n    // }\n}\n\
                trait T { fn d(&self); fn e<'a>(&'a self) -> &'a str { r#\"{\"# } }\n\
                fn f(x: [u8; 2]) -> impl Fn(u8) -> u8 {\n    move |y| {\n        y\n    }\n}\n";
    let got = functions(text);
    let summary: Vec<(&str, usize, usize)> = got
        .iter()
        .map(|f| (f.name.as_str(), f.line, f.lines))
        .collect();
    assert_eq!(summary, [("a", 1, 5), ("e", 6, 1), ("f", 7, 5)]);
}

#[test]
fn no_function_is_over_the_length_limits() {
    let root = root();
    let mut over = Vec::new();
    let mut stale = Vec::new();
    let mut counted = 0;
    for (dir, limit) in [
        ("crates", CRATES_LIMIT),
        ("xtask", ANYWHERE_LIMIT),
        ("benches", ANYWHERE_LIMIT),
        ("examples", ANYWHERE_LIMIT),
    ] {
        let mut files = Vec::new();
        rust_files(&root.join(dir), &mut files);
        for f in files {
            let text = std::fs::read_to_string(&f).unwrap();
            for func in functions(&text) {
                counted += 1;
                let rel = f.strip_prefix(&root).unwrap_or(&f).display().to_string();
                let known = NOT_YET_SPLIT
                    .iter()
                    .find(|(file, name, _)| *file == rel && *name == func.name);
                let allowed = known.map_or(limit, |k| k.2);
                if func.lines > allowed {
                    over.push((func.lines, allowed, rel, func));
                } else if known.is_some() && func.lines <= limit {
                    stale.push(format!("{rel} {}", func.name));
                }
            }
        }
    }
    assert!(counted > 1000, "the scanner found only {counted} functions");
    over.sort_by_key(|b| std::cmp::Reverse(b.0));
    let list: Vec<String> = over
        .iter()
        .map(|(n, limit, file, f)| format!("{n:4} > {limit}  {file}:{} {}", f.line, f.name))
        .collect();
    assert!(
        over.is_empty(),
        "functions over the limit:\n{}",
        list.join("\n")
    );
    assert!(
        stale.is_empty(),
        "now within the limit, remove from NOT_YET_SPLIT: {stale:?}"
    );
}
