//! Value parsers shared by the subcommands' arguments (`crate::cli`), each error naming the
//! rule it breaks (clap names the argument), and the models named on the command line.

use articula_dca::Method;
use articula_model::InertiaPolicy;
use clap::builder::{PossibleValuesParser, TypedValueParser};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// A model named on the command line: a chain length (`300`), a bundled model's file stem
/// (`humanoid`), or a bundled model's stem with `-floating` for its floating-base version.
pub fn model(name: &str) -> Result<articula_model::Model> {
    model_name(name)?;
    if let Ok(n) = name.parse::<usize>() {
        return Ok(articula_testkit::chain(n));
    }
    let (stem, floating) = split_floating(name);
    Ok(articula_testkit::bundled_with(stem, floating))
}

/// Checks a model name as [`model`] reads it, without building the model (the value parser
/// of `MODEL` arguments).
pub fn model_name(name: &str) -> std::result::Result<String, String> {
    if let Ok(n) = name.parse::<usize>() {
        if n == 0 {
            return Err("a chain needs at least one link".into());
        }
        return Ok(name.to_string());
    }
    let (stem, _) = split_floating(name);
    if !articula_testkit::BUNDLED.contains(&stem) {
        return Err(format!(
            "expected a chain length or one of {:?} (with `-floating` for a free base)",
            articula_testkit::BUNDLED
        ));
    }
    Ok(name.to_string())
}

/// A bundled model's stem and whether `-floating` asked for its floating base.
fn split_floating(name: &str) -> (&str, bool) {
    match name.strip_suffix("-floating") {
        Some(stem) => (stem, true),
        None => (name, false),
    }
}

/// `METHOD` arguments: `dca`, `aba` or `crba` (listed in `--help`).
pub fn method() -> impl TypedValueParser<Value = Method> {
    PossibleValuesParser::new(["dca", "aba", "crba"]).try_map(|s| s.parse::<Method>())
}

/// A count that must be at least 1 (rounds, batches, chain lengths, threads).
pub fn count(s: &str) -> std::result::Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!("expected a whole number ≥ 1, got '{s}'")),
    }
}

/// A whole number ≥ 0 with the spaces around it ignored (`--budgets 0, 250`).
pub fn whole(s: &str) -> std::result::Result<usize, String> {
    s.trim()
        .parse::<usize>()
        .map_err(|_| format!("expected a whole number ≥ 0, got '{s}'"))
}

/// A repair bound's value (`--bound-mass`, `--bound-inertia`): finite and ≥ 0.
pub fn bound(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err(format!("expected a finite number ≥ 0, got '{s}'")),
    }
}

/// A duration in seconds: finite and > 0 (`--horizon`).
pub fn seconds(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(format!("expected a positive number of seconds, got '{s}'")),
    }
}

/// A cost: finite and ≥ 0 (`--mujoco`, ms per simulated second).
pub fn cost(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err(format!("expected a finite number ≥ 0, got '{s}'")),
    }
}

/// `--inertia P`: the loader's inertia policy, `accept`, `strict` or `repair` (listed in
/// `--help`).
pub fn inertia() -> impl TypedValueParser<Value = InertiaPolicy> {
    PossibleValuesParser::new(["accept", "strict", "repair"]).try_map(|s| match s.as_str() {
        "accept" => Ok(InertiaPolicy::Accept),
        "strict" => Ok(InertiaPolicy::Strict),
        "repair" => Ok(InertiaPolicy::Repair),
        _ => Err(format!("unknown inertia policy '{s}'")),
    })
}

/// Checks that the repair bounds given (flag, value) come with `--inertia repair`.
pub fn bounds_need_repair(
    inertia: InertiaPolicy,
    bounds: &[(&str, Option<f64>)],
) -> std::result::Result<(), String> {
    for (flag, b) in bounds {
        if b.is_some() && inertia != InertiaPolicy::Repair {
            return Err(format!("{flag} needs --inertia repair"));
        }
    }
    Ok(())
}

/// `--venv DIR` when given, else the workspace's peers' venv `target/peers-venv`.
pub fn peers_venv(root: &std::path::Path, venv: Option<&std::path::Path>) -> std::path::PathBuf {
    venv.map_or_else(
        || root.join("target/peers-venv"),
        std::path::Path::to_path_buf,
    )
}
