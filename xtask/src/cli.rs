//! The command line of `cargo xtask`, parsed by clap: one variant per subcommand, its arguments
//! in the subcommand's module.

use crate::{
    bench, contact_peers, corpus, crowd_chart, drops, growth, mjcf_corpus, models, parallel,
    profile, snapshots, speedup, stability, test, time,
};
use clap::error::ErrorKind;
use clap::{CommandFactory, Parser, Subcommand};
use std::ffi::OsString;

/// Project automation tasks.
#[derive(Parser, Debug)]
#[command(
    name = "xtask",
    bin_name = "cargo xtask",
    arg_required_else_help = true
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Every test: cargo test --workspace, then the Python package's tests.
    ///
    /// The Python tests run in a venv in target/py-venv with maturin, numpy, pytest, pin,
    /// example-robot-data, mujoco, matplotlib and ray installed from PyPI when missing; the
    /// extension is built with maturin develop --release; pytest runs crates/articula-py/tests,
    /// which runs examples/python.
    Test(test::Options),
    /// Regenerate the URDF test and benchmark models in models/, or print one model's URDF.
    Models(models::Options),
    /// Time DCA, ABA, CRBA (and peers) by model size, measure their errors; write a report.
    ///
    /// Times DCA, ABA, CRBA (and with --peers Pinocchio and MuJoCo) on chains of 10..10,000
    /// links and the humanoid, measures their error against a double-double reference, and
    /// writes target/articula-bench/report.md and charts (SVG, PNG).
    Bench(bench::Options),
    /// Cost per simulated second against the view-weighted error of a crowd scene.
    ///
    /// Crowd200 on its floor by default, one thread: adaptive budgets, the culling baseline,
    /// exact DCA at 1x, 2x, 4x the step, MuJoCo's cost as a line; writes target/articula-crowd/
    /// (report.md, SVG, PNG).
    CrowdChart(crowd_chart::Options),
    /// Accuracy of DCA, ABA, CRBA against a double-double reference and integrators' drift.
    ///
    /// By chain length and mass ratio, the integrators' energy drift, adaptive dynamics'
    /// deviation and the hard cases; writes docs/stability.md, charts in docs/img/ and the
    /// longest chain's errors into docs/performance.md.
    Stability(stability::Options),
    /// Run the snapshot tests of `articula info` (INSTA_UPDATE=no).
    Snapshots(snapshots::Options),
    /// Every URDF of example-robot-data against Pinocchio's aba, DCA and ABA timed.
    ///
    /// Loads every URDF of example-robot-data (fixed and floating base), compares q̈ of DCA and
    /// ABA with Pinocchio's aba on seeded random states, times the three, and writes
    /// target/articula-corpus/report.md and report.json (needs the venv of peers/corpus.py;
    /// exits 2 without it).
    Corpus(corpus::Options),
    /// Every kinematic-tree MJCF model of dm-control and gymnasium against MuJoCo.
    ///
    /// Loads every kinematic-tree MJCF model of the PyPI packages dm-control and gymnasium with
    /// articula and with MuJoCo (peers/mjcf_corpus.py), compares M and qacc_smooth on seeded
    /// random states (1e-9 relative; 1e-10 for models with ball joints), times DCA, ABA and
    /// MuJoCo's mj_forward, and writes target/articula-mjcf-corpus/report.md and report.json.
    MjcfCorpus(mjcf_corpus::Options),
    /// Drop every URDF of example-robot-data on a ground and run DCA contact steps.
    ///
    /// Floating base, 0.3 m above a ground at 0, 3 s of DCA contact steps of 1 ms; writes
    /// target/articula-drops/report.md and report.json (needs the venv's example-robot-data).
    Drops(drops::Options),
    /// Robots on the floor in articula and MuJoCo, alternated, one thread.
    ///
    /// The humanoid drop, anymal standing and dropped, and crowd200 (peers/contact_peers.py):
    /// time per step, penetration, contacts, energy; prints the table of docs/contact.md and
    /// writes target/contact-peers/report.json.
    ContactPeers(contact_peers::Options),
    /// Bit-level fingerprints: DCA's q̈ on models and chains, a crowd scene after 500 steps.
    Hash,
    /// Minimum and median time per forward-dynamics call of one method on one model.
    Time(time::Options),
    /// Time per call from a short to a long chain, the two interleaved.
    Growth(growth::Options),
    /// Adaptive against exact DCA steps, interleaved in one process.
    #[command(subcommand)]
    Speedup(speedup::Comparison),
    /// One body's DCA split across threads against the serial DCA, by chain length.
    Parallel(parallel::Options),
    /// Fixed workloads for callgrind and perf, each timed.
    ///
    /// The workload runs inside `xtask::profile::measured`, so that callgrind can collect only
    /// it: valgrind --tool=callgrind --toggle-collect='xtask::profile::measured*'
    /// target/release/xtask profile ...
    #[command(subcommand)]
    Profile(profile::Workload),
    /// Compare dynamics, kinematics and Jacobians with Pinocchio's on the humanoid.
    ///
    /// Inverse dynamics, mass matrix, bias forces, centre of mass, energies, momentum, link
    /// poses and Jacobians (needs the peers' Python: ARTICULA_PEERS_PYTHON or
    /// target/peers-venv).
    Pinocchio,
}

impl Command {
    /// The rules between arguments that clap does not check: the subcommand's name and the
    /// broken rule.
    fn check(&self) -> Result<(), (&'static str, String)> {
        match self {
            Command::Corpus(o) => o.check().map_err(|e| ("corpus", e)),
            Command::Drops(o) => o.check().map_err(|e| ("drops", e)),
            _ => Ok(()),
        }
    }
}

impl Cli {
    /// Parses a command line (the program's name first) and checks the rules between its
    /// arguments: clap's error (usage, exit code 2) when one is broken.
    pub fn parse_checked<I, T>(args: I) -> Result<Cli, clap::Error>
    where
        I: IntoIterator<Item = T>,
        T: Into<OsString> + Clone,
    {
        let cli = Cli::try_parse_from(args)?;
        if let Err((name, rule)) = cli.command.check() {
            let mut cmd = Cli::command();
            cmd.build();
            let sub = cmd
                .find_subcommand_mut(name)
                .expect("check names a subcommand");
            return Err(sub.error(ErrorKind::ArgumentConflict, rule));
        }
        Ok(cli)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `cargo xtask LINE` parsed and checked as `main` does.
    fn parse(line: &str) -> Result<Command, String> {
        let args = std::iter::once("xtask").chain(line.split_whitespace());
        Cli::parse_checked(args)
            .map(|cli| cli.command)
            .map_err(|e| e.to_string())
    }

    /// The parsed values of `cargo xtask LINE`, as `{:?}` prints them.
    fn values(line: &str) -> String {
        match parse(line) {
            Ok(c) => format!("{c:?}"),
            Err(e) => panic!("`cargo xtask {line}` does not parse: {e}"),
        }
    }

    /// The documented forms of the measuring subcommands (README.md, docs/, peers/) and what
    /// they parse into.
    #[test]
    fn documented_measurements_parse_into_their_values() {
        for (line, expected) in [
            (
                "time dca 300 200 100",
                r#"Time(Options { method: Dca, model: "300", batches: 200, calls: 100, portable: false })"#,
            ),
            (
                "time aba 300 200 100",
                r#"Time(Options { method: Aba, model: "300", batches: 200, calls: 100, portable: false })"#,
            ),
            (
                "time dca humanoid-floating",
                r#"Time(Options { method: Dca, model: "humanoid-floating", batches: 30, calls: 100, portable: false })"#,
            ),
            (
                "time crba 300 --portable 7",
                r#"Time(Options { method: Crba, model: "300", batches: 7, calls: 100, portable: true })"#,
            ),
            (
                "growth dca 1000 10000 1000",
                "Growth(Options { method: Dca, short: 1000, long: 10000, rounds: 1000 })",
            ),
            (
                "growth",
                "Growth(Options { method: Dca, short: 1000, long: 10000, rounds: 1000 })",
            ),
            (
                "parallel 2 9 1000 2000 5000 100000",
                "Parallel(Options { threads: 2, rounds: 9, lengths: [1000, 2000, 5000, 100000] })",
            ),
            (
                "parallel 2 7 100000",
                "Parallel(Options { threads: 2, rounds: 7, lengths: [100000] })",
            ),
            (
                "parallel",
                "Parallel(Options { threads: 2, rounds: 15, \
                 lengths: [250, 500, 1000, 2000, 5000, 20000, 100000] })",
            ),
            (
                "speedup seeds 8",
                "Speedup(Seeds { rounds: 8, budgets: [1, 50] })",
            ),
            (
                "speedup crowd models/scenes/crowd200.json 2 300 0 500 1000 2000 4000",
                r#"Speedup(Crowd { scene: "models/scenes/crowd200.json", rounds: 2, steps: 300, budgets: [0, 500, 1000, 2000, 4000] })"#,
            ),
            (
                "speedup crowd models/scenes/crowd200.json 3 300",
                r#"Speedup(Crowd { scene: "models/scenes/crowd200.json", rounds: 3, steps: 300, budgets: [] })"#,
            ),
            (
                "profile adaptive 100000 50 10 100",
                "Profile(Adaptive { links: 100000, budget: 50, period: 10, steps: 100, \
                 forces: 0, at_origin: false })",
            ),
            (
                "profile exact 300 30 5 --at-origin",
                "Profile(Exact { links: 300, steps: 30, forces: 5, at_origin: true })",
            ),
            (
                "profile dynamics aba humanoid 1000",
                r#"Profile(Dynamics { method: Aba, model: "humanoid", calls: 1000 })"#,
            ),
            (
                "profile scene models/scenes/crowd200.json 20 40",
                r#"Profile(Scene { scene: "models/scenes/crowd200.json", warmup: 20, steps: 40 })"#,
            ),
        ] {
            assert_eq!(values(line), expected, "`cargo xtask {line}`");
        }
    }

    /// The documented forms of the report and check subcommands and what they parse into.
    #[test]
    fn documented_reports_parse_into_their_values() {
        for (line, expected) in [
            (
                "bench --quick --peers --publish",
                "Bench(Options { quick: true, peers: true, publish: true, write_docs: false })",
            ),
            (
                "bench --quick --write-docs",
                "Bench(Options { quick: true, peers: false, publish: false, write_docs: true })",
            ),
            (
                "corpus icub --inertia repair --bound-inertia 1e-5",
                r#"Corpus(Options { quick: false, inertia: Repair, bound_inertia: Some(1e-5), venv: None, write_docs: false, names: ["icub"] })"#,
            ),
            (
                "corpus --quick --venv /v talos ur5",
                r#"Corpus(Options { quick: true, inertia: Accept, bound_inertia: None, venv: Some("/v"), write_docs: false, names: ["talos", "ur5"] })"#,
            ),
            (
                "drops --inertia repair --bound-inertia 1e-5",
                "Drops(Options { quick: false, seconds: None, inertia: Repair, bound_mass: None, \
                 bound_inertia: Some(1e-5), venv: None, write_docs: false, names: [] })",
            ),
            (
                "drops --seconds 10 hyq",
                r#"Drops(Options { quick: false, seconds: Some(10.0), inertia: Accept, bound_mass: None, bound_inertia: None, venv: None, write_docs: false, names: ["hyq"] })"#,
            ),
            (
                "contact-peers --only crowd --rounds 1",
                r#"ContactPeers(Options { rounds: 1, only: "crowd", venv: None })"#,
            ),
            (
                "contact-peers",
                r#"ContactPeers(Options { rounds: 3, only: "", venv: None })"#,
            ),
            (
                "crowd-chart --publish",
                "CrowdChart(Options { scene: None, horizon: 2.0, \
                 budgets: [0, 250, 500, 1000, 2000, 3000, 4000], mujoco: None, publish: true })",
            ),
            (
                "crowd-chart s.json --horizon 0.5 --budgets 0,1000 --mujoco 12.5",
                r#"CrowdChart(Options { scene: Some("s.json"), horizon: 0.5, budgets: [0, 1000], mujoco: Some(12.5), publish: false })"#,
            ),
            (
                "mjcf-corpus --quick",
                "MjcfCorpus(Options { quick: true, venv: None })",
            ),
            ("models", "Models(Options { chain: None, tree: None })"),
            (
                "models --chain 300",
                "Models(Options { chain: Some(300), tree: None })",
            ),
            (
                "models --tree 16 5000",
                "Models(Options { chain: None, tree: Some([16, 5000]) })",
            ),
            ("stability", "Stability(Options { only: None })"),
            (
                "stability cases --full",
                "Stability(Options { only: Some(Cases { full: true }) })",
            ),
            ("snapshots --accept", "Snapshots(Options { accept: true })"),
            ("hash", "Hash"),
            ("pinocchio", "Pinocchio"),
            (
                "test",
                "Test(Options { python_only: false, rust_only: false, venv: None, pytest: [] })",
            ),
            (
                "test --python-only -k batch",
                r#"Test(Options { python_only: true, rust_only: false, venv: None, pytest: ["-k", "batch"] })"#,
            ),
            // This command's flags come first: from the first pytest argument on, every
            // argument is pytest's.
            (
                "test -k batch --python-only",
                r#"Test(Options { python_only: false, rust_only: false, venv: None, pytest: ["-k", "batch", "--python-only"] })"#,
            ),
            (
                "test --venv /v -x --lf",
                r#"Test(Options { python_only: false, rust_only: false, venv: Some("/v"), pytest: ["-x", "--lf"] })"#,
            ),
        ] {
            assert_eq!(values(line), expected, "`cargo xtask {line}`");
        }
    }

    /// A bad value's error names the argument and the rule; so does a broken rule between
    /// arguments.
    #[test]
    fn errors_name_the_argument_and_the_rule() {
        for (line, argument, rule) in [
            ("time dca abc", "'<MODEL>'", "expected a chain length"),
            ("time dca 300 abc", "'[BATCHES]'", "whole number ≥ 1"),
            ("time dca 300 -5", "'[BATCHES]'", "got '-5'"),
            ("time dca 300 10 0", "'[CALLS]'", "whole number ≥ 1"),
            (
                "time fast 300",
                "'<METHOD>'",
                "possible values: dca, aba, crba",
            ),
            (
                "time dca",
                "<MODEL>",
                "required arguments were not provided",
            ),
            ("growth dca 0", "'[SHORT]'", "whole number ≥ 1"),
            ("parallel 2 0", "'[ROUNDS]'", "whole number ≥ 1"),
            ("parallel 2 1 300 x", "'[LENGTH]...'", "got 'x'"),
            (
                "crowd-chart --horizon -1",
                "'--horizon <S>'",
                "positive number of seconds",
            ),
            (
                "crowd-chart --budgets 0,x",
                "'--budgets <B,B,...>'",
                "whole number ≥ 0",
            ),
            (
                "drops --inertia repair --bound-mass -1",
                "'--bound-mass <KG>'",
                "finite number ≥ 0",
            ),
            (
                "corpus --inertia lenient",
                "'--inertia <P>'",
                "accept, strict, repair",
            ),
            (
                "corpus --bound-inertia 1e-5",
                "--bound-inertia",
                "needs --inertia repair",
            ),
            (
                "drops --bound-mass 1",
                "--bound-mass",
                "needs --inertia repair",
            ),
            (
                "corpus --write-docs ur5",
                "'--write-docs'",
                "cannot be used with",
            ),
            (
                "test --python-only --rust-only",
                "'--python-only'",
                "cannot be used with",
            ),
            (
                "models --tree 16",
                "'--tree <BRANCHES> <LINKS>'",
                "2 values required",
            ),
            (
                "profile adaptive 300 50 10 -3",
                "'<STEPS>'",
                "invalid digit",
            ),
            ("stability cases --fast", "'--fast'", "unexpected argument"),
            (
                "no-such-subcommand",
                "'no-such-subcommand'",
                "unrecognized subcommand",
            ),
        ] {
            let e = parse(line).expect_err(line);
            assert!(
                e.contains(argument) && e.contains(rule),
                "`cargo xtask {line}`: {e}"
            );
        }
    }

    /// clap's own consistency checks, and every subcommand's one-line description for the
    /// help list.
    #[test]
    fn every_subcommand_has_a_description() {
        let cmd = Cli::command();
        cmd.clone().debug_assert();
        let subs: Vec<_> = cmd.get_subcommands().collect();
        assert_eq!(subs.len(), 17);
        for sub in subs {
            let about = sub.get_about().map(|a| a.to_string()).unwrap_or_default();
            assert!(!about.is_empty(), "{} has no description", sub.get_name());
        }
    }
}
