//! Snapshot tests of `articula info` on every bundled model (`models/*.urdf`).
//!
//! For each model two snapshots live in `tests/snapshots/`:
//! - `<model>_info.snap`: the JSON of `articula info MODEL --json`, parsed and re-serialised;
//! - `<model>_tree.snap`: the text of `articula info MODEL --tree` (summary, composed joints,
//!   merged bodies and the assembly tree outline).
//!
//! The humanoid is also snapshotted with `--floating-base` (`humanoid_floating_*`).
//!
//! Check with `cargo xtask snapshots`; after an intended change, rewrite with
//! `cargo xtask snapshots --accept` and review the diff of the `.snap` files.

use articula_model::{LoadOptions, Model};
use std::collections::BTreeSet;
use std::path::PathBuf;
use std::process::Command;

fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn model_path(model: &str) -> PathBuf {
    workspace_root()
        .join("models")
        .join(format!("{model}.urdf"))
}

/// Runs the real binary: `articula info models/<model>.urdf <args>`, and returns its stdout.
fn info(model: &str, args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_articula"))
        .arg("info")
        .arg(model_path(model))
        .args(args)
        .output()
        .expect("cannot run the articula binary");
    assert!(
        out.status.success(),
        "articula info {model} {args:?} failed with {}:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("articula printed non-UTF-8 output")
}

/// Takes both snapshots of one model, named `<name>_info` and `<name>_tree`.
fn snapshot_model(model: &str, name: &str, extra: &[&str]) {
    let mut settings = insta::Settings::clone_current();
    settings.set_prepend_module_to_snapshot(false);
    settings.set_omit_expression(true);

    let json_args: Vec<&str> = extra.iter().copied().chain(["--json"]).collect();
    let text = info(model, &json_args);
    let json: serde_json::Value = serde_json::from_str(&text)
        .unwrap_or_else(|e| panic!("articula info {model} --json is not JSON ({e}):\n{text}"));
    settings.set_description(format!(
        "articula info models/{model}.urdf {}",
        json_args.join(" ")
    ));
    settings.bind(|| insta::assert_json_snapshot!(format!("{name}_info"), json));

    let tree_args: Vec<&str> = extra.iter().copied().chain(["--tree"]).collect();
    let text = info(model, &tree_args);
    // The outline printed by the CLI is the library's outline of the same model.
    let loaded = Model::from_urdf_file(
        model_path(model),
        &LoadOptions::default().with_floating_base(extra.contains(&"--floating-base")),
    )
    .expect("bundled model loads");
    let outline = loaded.assembly.outline(&loaded);
    assert!(
        text.ends_with(&format!("assembly tree:\n{outline}")),
        "`articula info {model} --tree` does not end with the assembly tree outline"
    );
    settings.set_description(format!(
        "articula info models/{model}.urdf {}",
        tree_args.join(" ")
    ));
    settings.bind(|| insta::assert_snapshot!(format!("{name}_tree"), text));
}

/// One test per bundled model; `MODELS` lists them for the completeness checks below.
macro_rules! model_snapshots {
    ($($test:ident => $model:literal),* $(,)?) => {
        const MODELS: &[&str] = &[$($model),*];
        $(
            #[test]
            fn $test() {
                snapshot_model($model, $model, &[]);
            }
        )*
    };
}

model_snapshots! {
    chain10 => "chain10",
    chain30 => "chain30",
    chain100 => "chain100",
    chain300 => "chain300",
    chain1000 => "chain1000",
    humanoid => "humanoid",
    plant => "plant",
    rope => "rope",
}

#[test]
fn humanoid_floating_base() {
    snapshot_model("humanoid", "humanoid_floating", &["--floating-base"]);
}

/// Names of every snapshot the tests above take.
fn expected_snapshots() -> BTreeSet<String> {
    MODELS
        .iter()
        .copied()
        .chain(["humanoid_floating"])
        .flat_map(|m| [format!("{m}_info.snap"), format!("{m}_tree.snap")])
        .collect()
}

#[test]
fn every_bundled_model_is_snapshotted() {
    let bundled: BTreeSet<String> = std::fs::read_dir(workspace_root().join("models"))
        .expect("models/ exists")
        .filter_map(|e| {
            let name = e.ok()?.file_name().into_string().ok()?;
            name.strip_suffix(".urdf").map(str::to_string)
        })
        .collect();
    let tested: BTreeSet<String> = MODELS.iter().map(|m| m.to_string()).collect();
    assert_eq!(
        bundled, tested,
        "models/*.urdf and the models of tests/snapshots.rs differ: add the new model to \
         `model_snapshots!` and run `cargo xtask snapshots --accept`"
    );
}

#[test]
fn no_stale_snapshot_files() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/snapshots");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return; // first run: nothing written yet
    };
    let expected = expected_snapshots();
    let stale: Vec<String> = entries
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|name| name.ends_with(".snap") && !expected.contains(name))
        .collect();
    assert!(
        stale.is_empty(),
        "snapshot files no test takes (delete them): {stale:?} in {}",
        dir.display()
    );
}
