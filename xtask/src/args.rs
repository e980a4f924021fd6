//! Positional arguments of the measuring subcommands, parsed with errors that name the argument
//! and show the usage line.

use std::str::FromStr;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// The remaining positional arguments of one subcommand.
pub struct Args<'a> {
    rest: std::slice::Iter<'a, String>,
    usage: &'static str,
}

impl<'a> Args<'a> {
    pub fn new(args: &'a [String], usage: &'static str) -> Args<'a> {
        Args {
            rest: args.iter(),
            usage,
        }
    }

    /// The next argument as a string, if any.
    pub fn next_str(&mut self) -> Option<&'a str> {
        self.rest.next().map(String::as_str)
    }

    /// The next argument parsed as `T`; `default` when there is none.
    pub fn next_or<T: FromStr>(&mut self, what: &str, default: T) -> Result<T>
    where
        T::Err: std::fmt::Display,
    {
        match self.rest.next() {
            None => Ok(default),
            Some(s) => self.parse(what, s),
        }
    }

    /// The next argument parsed as `T`; an error when there is none.
    pub fn next<T: FromStr>(&mut self, what: &str) -> Result<T>
    where
        T::Err: std::fmt::Display,
    {
        match self.rest.next() {
            None => Err(format!("missing {what}; usage: {}", self.usage).into()),
            Some(s) => self.parse(what, s),
        }
    }

    /// Every remaining argument parsed as `T`.
    pub fn rest<T: FromStr>(&mut self, what: &str) -> Result<Vec<T>>
    where
        T::Err: std::fmt::Display,
    {
        let rest: Vec<&String> = self.rest.by_ref().collect();
        rest.into_iter().map(|s| self.parse(what, s)).collect()
    }

    /// An error if arguments are left.
    pub fn finish(mut self) -> Result<()> {
        match self.rest.next() {
            None => Ok(()),
            Some(s) => Err(format!("unexpected argument `{s}`; usage: {}", self.usage).into()),
        }
    }

    fn parse<T: FromStr>(&self, what: &str, s: &str) -> Result<T>
    where
        T::Err: std::fmt::Display,
    {
        s.parse()
            .map_err(|e| format!("{what} `{s}`: {e}; usage: {}", self.usage).into())
    }
}

/// A model named on the command line: a chain length (`300`), a bundled model's file stem
/// (`humanoid`), or a bundled model's stem with `-floating` for its floating-base version.
pub fn model(name: &str) -> Result<articula_model::Model> {
    if let Ok(n) = name.parse::<usize>() {
        if n == 0 {
            return Err("a chain needs at least one link".into());
        }
        return Ok(articula_testkit::chain(n));
    }
    let (stem, floating) = match name.strip_suffix("-floating") {
        Some(stem) => (stem, true),
        None => (name, false),
    };
    if !articula_testkit::BUNDLED.contains(&stem) {
        return Err(format!(
            "model `{name}`: expected a chain length or one of {:?} (with `-floating` for a free base)",
            articula_testkit::BUNDLED
        )
        .into());
    }
    Ok(articula_testkit::bundled_with(stem, floating))
}

/// The loader's inertia policy as `--inertia` names it (`accept`, `strict`, `repair`).
pub fn inertia_policy(
    value: Option<&str>,
) -> std::result::Result<articula_model::InertiaPolicy, String> {
    use articula_model::InertiaPolicy;
    match value {
        Some("accept") => Ok(InertiaPolicy::Accept),
        Some("strict") => Ok(InertiaPolicy::Strict),
        Some("repair") => Ok(InertiaPolicy::Repair),
        Some(p) => Err(format!(
            "unknown inertia policy {p:?} (expected accept, strict or repair)"
        )),
        None => Err("--inertia needs a policy".into()),
    }
}

/// A repair bound's value (`--bound-mass`, `--bound-inertia`): finite and ≥ 0.
pub fn parse_bound(flag: &str, v: Option<&String>) -> std::result::Result<f64, String> {
    let v = v.ok_or_else(|| format!("{flag} needs a value"))?;
    match v.parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err(format!("{flag} must be a finite number ≥ 0, got {v:?}")),
    }
}
