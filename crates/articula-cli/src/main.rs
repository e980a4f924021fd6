//! `articula`: the command-line front end.
//!
//! Exit codes: 0 success, 2 bad input (a model, state or argument that cannot be used; the
//! error is printed on stderr), never a panic's 101.

mod bench;
mod fd;
mod gltf_out;
mod ground;
mod info;
mod scene;
mod signals;
mod simulate;
mod state_json;
mod watch;

use articula_dca::{Data, Method, State, Threads};
use articula_model::{InertiaPolicy, LoadOptions, Model};
use articula_spatial::DVec3;
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};
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
        #[command(flatten)]
        inertia: InertiaArgs,
    },
    /// Forward dynamics of one state: the joint accelerations, as JSON keyed by URDF joint name.
    // Negative numbers reach the flags' validators, which name the flag and its rule.
    #[command(allow_negative_numbers = true)]
    Fd(fd::FdArgs),
    /// Integrate the motion from a state for a number of steps; print a summary (time per step,
    /// energy drift) and optionally write the trajectory as CSV.
    // Negative numbers reach the flags' validators, which name the flag and its rule.
    #[command(allow_negative_numbers = true)]
    Simulate(simulate::SimulateArgs),
    /// Time forward-dynamics calls on a seeded random state.
    // Negative numbers reach the flags' validators, which name the flag and its rule.
    #[command(allow_negative_numbers = true)]
    Bench(bench::BenchArgs),
    /// Simulate a scene of many bodies with view-dependent adaptive dynamics (one scene-wide
    /// joint budget); optionally write PNG frames and top-down maps.
    // Negative numbers reach the flags' validators, which name the flag and its rule.
    #[command(allow_negative_numbers = true)]
    Scene(scene::SceneArgs),
}

/// Options shared by the dynamics commands.
#[derive(Args, Clone, Debug)]
pub struct DynamicsArgs {
    /// The URDF file.
    pub model: PathBuf,
    /// Forward-dynamics algorithm.
    #[arg(long, value_enum, default_value_t = MethodArg::Dca)]
    pub method: MethodArg,
    /// Gravity acceleration in world coordinates (m/s²), as `gx,gy,gz` [default: the model's:
    /// an MJCF file's `<option gravity>`, else 0,0,-9.81].
    #[arg(long, value_name = "GX,GY,GZ", value_parser = parse_gravity, allow_hyphen_values = true)]
    pub gravity: Option<DVec3>,
    /// Give the root link six degrees of freedom (joint `floating_base`) instead of welding it
    /// to the world.
    #[arg(long)]
    pub floating_base: bool,
    #[command(flatten)]
    pub inertia: InertiaArgs,
    /// `--method adaptive`: the most internal degrees of freedom simulated (0 = one rigid body).
    #[arg(long, value_name = "K", value_parser = parse_budget, allow_hyphen_values = true)]
    pub budget: Option<usize>,
    /// `--method adaptive`: how a re-selection finds the new hybrid body.
    #[arg(long, value_enum, default_value_t = ReselectionArg::Exact)]
    pub reselection: ReselectionArg,
    /// `--method adaptive`: stop selecting joints once the acceleration-metric error left is at
    /// most E (0 = exact).
    #[arg(long, value_name = "E", value_parser = parse_tolerance, allow_hyphen_values = true)]
    pub tolerance: Option<f64>,
    /// Threads (default: one per core) for work across states (`bench --states`), for one
    /// body's DCA solve from 5,000 bodies (`fd`, `bench`; below, it runs on one thread) and for
    /// a hybrid step's per-joint sweeps from 10,000 active joints (`simulate`, `bench` with
    /// `--method adaptive`). Results are the same bits for any count.
    #[arg(long, value_name = "N", value_parser = parse_threads, allow_hyphen_values = true)]
    pub threads: Option<usize>,
}

/// `--threads N`: at least 1, at most `Threads::max_count()` (8 per core, at least 64).
pub fn parse_threads(s: &str) -> Result<usize, String> {
    let cap = Threads::max_count();
    match s.parse::<usize>() {
        Ok(n) if n > cap => Err(format!(
            "{n} is more than the cap of {cap} threads (8 per core on this machine, at least 64)"
        )),
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!(
            "the thread count must be a whole number from 1 to {cap}, got '{s}'"
        )),
    }
}

/// The pool of `--threads` (default: one thread per core).
pub fn threads(count: Option<usize>) -> Result<Threads, CliError> {
    Ok(match count {
        Some(n) => Threads::new(n)?,
        None => Threads::all()?,
    })
}

/// `--inertia` and its repair bounds, on every command that loads URDFs.
#[derive(Args, Clone, Debug)]
pub struct InertiaArgs {
    /// What to do with bodies whose inertia no rigid body has (docs/loading.md).
    #[arg(long, value_enum, default_value_t = InertiaArg::Accept)]
    pub inertia: InertiaArg,
    /// With `--inertia repair`: raise every body's mass to at least KG (MuJoCo's `boundmass`).
    #[arg(long, value_name = "KG", value_parser = parse_bound, allow_hyphen_values = true)]
    pub bound_mass: Option<f64>,
    /// With `--inertia repair`: raise every body's principal moments to at least KGM2 (kg·m²,
    /// MuJoCo's `boundinertia`), e.g. 1e-5 for icub's point masses (docs/loading.md).
    #[arg(long, value_name = "KGM2", value_parser = parse_bound,
          allow_hyphen_values = true)]
    pub bound_inertia: Option<f64>,
}

impl InertiaArgs {
    /// The load options of these flags (fixed base), or why they cannot be used together.
    pub fn options(&self) -> Result<LoadOptions, CliError> {
        let mut options = LoadOptions::default().with_inertia(self.inertia.into());
        for (flag, bound) in [
            ("--bound-mass", self.bound_mass),
            ("--bound-inertia", self.bound_inertia),
        ] {
            if bound.is_some() && self.inertia != InertiaArg::Repair {
                return Err(CliError(format!(
                    "{flag} needs --inertia repair (the bounds change bodies only when \
                     repairing; the policy is {})",
                    InertiaPolicy::from(self.inertia).name()
                )));
            }
        }
        if let Some(kg) = self.bound_mass {
            options = options.with_bound_mass(kg);
        }
        if let Some(kgm2) = self.bound_inertia {
            options = options.with_bound_inertia(kgm2);
        }
        Ok(options)
    }
}

/// Parses `--bound-mass` and `--bound-inertia`: a finite number ≥ 0.
fn parse_bound(s: &str) -> Result<f64, String> {
    let x: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if !(x.is_finite() && x >= 0.0) {
        return Err(format!("the bound must be a finite number ≥ 0, got '{s}'"));
    }
    Ok(x)
}

/// `--inertia`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum InertiaArg {
    /// Load the numbers as written, one warning per odd body; an indefinite inertia is refused.
    Accept,
    /// Refuse every odd body, each listed with its numbers.
    Strict,
    /// Fix odd bodies (MuJoCo-like bound mass, bound inertia, balance inertia), each change
    /// reported.
    Repair,
}

impl From<InertiaArg> for InertiaPolicy {
    fn from(a: InertiaArg) -> Self {
        match a {
            InertiaArg::Accept => InertiaPolicy::Accept,
            InertiaArg::Strict => InertiaPolicy::Strict,
            InertiaArg::Repair => InertiaPolicy::Repair,
        }
    }
}

/// `--method`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Featherstone's divide-and-conquer algorithm (the main solver).
    Dca,
    /// The articulated-body algorithm (reference).
    Aba,
    /// Composite-rigid-body algorithm + Cholesky (reference).
    Crba,
    /// Adaptive dynamics (articula-adaptive): the joints chosen by the acceleration metric
    /// within `--budget` / `--tolerance`.
    Adaptive,
}

impl MethodArg {
    /// The exact algorithm, `None` for adaptive.
    pub fn exact(self) -> Option<Method> {
        match self {
            MethodArg::Dca => Some(Method::Dca),
            MethodArg::Aba => Some(Method::Aba),
            MethodArg::Crba => Some(Method::Crba),
            MethodArg::Adaptive => None,
        }
    }

    /// The lowercase name.
    pub fn name(self) -> &'static str {
        self.exact().map_or("adaptive", Method::name)
    }
}

/// `--reselection`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ReselectionArg {
    /// One exact solve of the whole body, every node's metric, the queue, the locking
    /// impulses: O(n) at the cost of an ABA pass, nothing cached (the fastest when the
    /// selection changes, as on a falling or swinging body).
    Exact,
    /// Through the caches of the rigid subassemblies: O(active region) plus a cache rebuild
    /// per node leaving it; the first step builds every cache.
    Caches,
}

impl From<ReselectionArg> for articula_adaptive::Reselection {
    fn from(r: ReselectionArg) -> Self {
        match r {
            ReselectionArg::Exact => articula_adaptive::Reselection::ExactSolve,
            ReselectionArg::Caches => articula_adaptive::Reselection::Caches,
        }
    }
}

/// Parses a finite number ≥ 0 (`--friction`, `--drop`).
pub(crate) fn parse_nonnegative(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err(format!("must be a finite number ≥ 0, got '{s}'")),
    }
}

/// Parses `--budget`: a whole number ≥ 0.
pub(crate) fn parse_budget(s: &str) -> Result<usize, String> {
    s.trim()
        .parse()
        .map_err(|_| format!("the budget must be a whole number ≥ 0, got '{s}'"))
}

/// Parses `--tolerance`: a finite number ≥ 0.
fn parse_tolerance(s: &str) -> Result<f64, String> {
    let x: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if !(x.is_finite() && x >= 0.0) {
        return Err(format!(
            "the tolerance must be a finite number ≥ 0, got '{s}'"
        ));
    }
    Ok(x)
}

/// Parses `gx,gy,gz`: three finite numbers.
fn parse_gravity(s: &str) -> Result<DVec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!(
            "expected three numbers gx,gy,gz separated by commas, got {}",
            parts.len()
        ));
    }
    let mut g = [0.0; 3];
    for (x, p) in g.iter_mut().zip(&parts) {
        *x = p
            .parse::<f64>()
            .map_err(|_| format!("'{p}' is not a number"))?;
        if !x.is_finite() {
            return Err(format!("'{p}' is not a finite number"));
        }
    }
    Ok(DVec3::from_array(g))
}

impl DynamicsArgs {
    /// The settings of `--method adaptive` (budget, tolerance) with the period `reselect_every`.
    pub fn adaptive_settings(&self, reselect_every: u64) -> articula_adaptive::Settings {
        articula_adaptive::Settings {
            budget: self.budget,
            tolerance: self.tolerance,
            reselect_every,
            velocity_tolerance: None,
        }
    }

    /// The adaptive workspace of `--method adaptive` (budget, tolerance, gravity).
    pub fn adaptive(&self, model: &Model, reselect_every: u64) -> articula_adaptive::Adaptive {
        let settings = self.adaptive_settings(reselect_every);
        let mut ad = articula_adaptive::Adaptive::new(model, settings);
        if let Some(g) = self.gravity {
            ad.data.gravity = g;
        }
        ad.set_reselection(self.reselection.into());
        ad
    }

    /// Loads the model (printing its warnings on stderr) and a workspace with the gravity set.
    pub fn load(&self) -> Result<(Model, Data), CliError> {
        let model = Model::from_file(
            &self.model,
            &self
                .inertia
                .options()?
                .with_floating_base(self.floating_base),
        )?;
        for w in &model.warnings {
            eprintln!("warning: {w}");
        }
        if self.method != MethodArg::Adaptive && (self.budget.is_some() || self.tolerance.is_some())
        {
            return Err(CliError(
                "--budget and --tolerance need --method adaptive".to_string(),
            ));
        }
        let mut data = Data::new(&model);
        if let Some(g) = self.gravity {
            data.gravity = g;
        }
        Ok((model, data))
    }
}

/// Prints `text` on stdout as is. A closed pipe (`articula ... | head`) is not an error: the
/// reader has what it wanted.
pub fn print_out(text: &str) -> Result<(), CliError> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(CliError(format!("cannot write to stdout: {e}"))),
    }
}

/// The largest state file read, in bytes.
pub const MAX_STATE_BYTES: u64 = 16 << 20;

/// The state in a STATE.json file, or the neutral state at rest without one.
pub fn load_state(path: Option<&Path>, model: &Model) -> Result<State, CliError> {
    let Some(path) = path else {
        return Ok(State::neutral(model));
    };
    let bytes = articula_model::read_limited(path, MAX_STATE_BYTES)
        .map_err(|e| CliError(format!("cannot read state file {}: {e}", path.display())))?;
    let text = String::from_utf8(bytes)
        .map_err(|e| CliError(format!("cannot read state file {}: {e}", path.display())))?;
    state_json::parse_state(&text, model)
        .map_err(|e| CliError(format!("state file {}: {e}", path.display())))
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
            inertia,
        } => inertia.options().and_then(|options| {
            info::run(
                &model,
                &options.with_floating_base(floating_base),
                json,
                tree,
            )
        }),
        Command::Fd(args) => fd::run(&args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Scene(args) => scene::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(CliError(msg)) => {
            eprintln!("error: {msg}");
            ExitCode::from(2)
        }
    }
}
