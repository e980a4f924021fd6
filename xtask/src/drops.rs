//! `cargo xtask drops`: every URDF of example-robot-data dropped on the floor. Writes
//! `target/articula-drops/report.md` and `report.json` (`docs/contact.md#robots-on-the-floor`).
//!
//! For each URDF (found as `cargo xtask corpus` finds them): load it with a floating base
//! under the inertia policy asked for (library API, in-process), raise it so that its lowest
//! contact point is [`DROP`] above a horizontal ground at height 0 (friction 1, no
//! restitution, the URDF joint limits enforced: `articula simulate`'s defaults), and run
//! [`SECONDS`] (`--quick`: [`QUICK_SECONDS`]) of semi-implicit Euler steps of [`DT`] with DCA
//! from the rest pose at rest ([`Model::rest_q`]: the neutral pose moved into the joint limits,
//! as `articula simulate --ground` starts).
//!
//! **Divergence**: a run stops at the first step whose state is not finite, whose contact step
//! fails, or whose energy has grown by more than [`MAX_ENERGY_GROWTH`] of the largest energy in
//! play: `E − E₀ > 0.5 · max(|E₀|, max T, max |V − V₀|)` (`E = T + V`, kinetic plus
//! gravitational; no joint forces act) — the check of `articula simulate`
//! (`--max-energy-growth`, default 0.5).
//!
//! **Verdicts** of a loaded robot: *at rest* when it ran to the end with a kinetic energy per
//! kilogram of total mass below [`REST`] (a mass-weighted RMS speed `√(2T/M)` under 4.5 cm/s),
//! *moving* when it ran to the end above it, *stopped* when the divergence check stopped it.

use crate::corpus::{self, Robot};
use articula_dca::{
    forward_kinematics, step_with_contact, ContactData, ContactSettings, Data, Ground, Method,
    State,
};
use articula_model::{InertiaPolicy, LoadOptions, Model};
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Height of the drop (m): the lowest contact point's height above the ground at the start.
pub const DROP: f64 = 0.3;
/// Time step (s).
pub const DT: f64 = 1e-3;
/// Simulated time (s), and with `--quick`.
pub const SECONDS: f64 = 3.0;
pub const QUICK_SECONDS: f64 = 1.0;
/// The divergence bound on the energy growth (a fraction of the largest energy in play).
pub const MAX_ENERGY_GROWTH: f64 = 0.5;
/// At rest: kinetic energy per kilogram at the end below this (J/kg).
pub const REST: f64 = 1e-3;

pub const USAGE: &str = "\
usage: cargo xtask drops [--quick] [--inertia accept|strict|repair] [--bound-mass KG]
                         [--bound-inertia KGM2] [--venv DIR] [NAME...]

Drops every URDF of example-robot-data (floating base, 0.3 m above a ground at 0) and runs
3 s of DCA contact steps of 1 ms; writes target/articula-drops/report.md and report.json.

    --quick              1 s instead of 3 s
    --inertia P          the loader's inertia policy (default accept)
    --bound-mass KG      with --inertia repair: every body's mass at least KG
    --bound-inertia KGM2 with --inertia repair: every body's principal moments at least KGM2
    --venv DIR           the Python venv with example-robot-data (default target/peers-venv)
    NAME...              only the robots whose name or path contains one of these
";

#[derive(Debug)]
struct Options {
    quick: bool,
    inertia: InertiaPolicy,
    bound_mass: Option<f64>,
    bound_inertia: Option<f64>,
    venv: PathBuf,
    names: Vec<String>,
}

impl Options {
    fn load_options(&self) -> LoadOptions {
        let mut o = LoadOptions::default()
            .with_floating_base(true)
            .with_inertia(self.inertia);
        if let Some(kg) = self.bound_mass {
            o = o.with_bound_mass(kg);
        }
        if let Some(b) = self.bound_inertia {
            o = o.with_bound_inertia(b);
        }
        o
    }

    /// The command line that reproduces the run.
    fn command(&self) -> String {
        let mut c = "cargo xtask drops".to_string();
        if self.quick {
            c += " --quick";
        }
        if self.inertia != InertiaPolicy::Accept {
            let _ = write!(c, " --inertia {}", self.inertia.name());
        }
        if let Some(kg) = self.bound_mass {
            let _ = write!(c, " --bound-mass {kg:e}");
        }
        if let Some(b) = self.bound_inertia {
            let _ = write!(c, " --bound-inertia {b:e}");
        }
        for n in &self.names {
            let _ = write!(c, " {n}");
        }
        c
    }

    fn seconds(&self) -> f64 {
        if self.quick {
            QUICK_SECONDS
        } else {
            SECONDS
        }
    }
}

fn parse(root: &Path, args: &[String]) -> Result<Options, String> {
    let mut o = Options {
        quick: false,
        inertia: InertiaPolicy::Accept,
        bound_mass: None,
        bound_inertia: None,
        venv: root.join("target/peers-venv"),
        names: Vec::new(),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--quick" => o.quick = true,
            "--inertia" => o.inertia = crate::args::inertia_policy(it.next().map(String::as_str))?,
            "--bound-mass" => o.bound_mass = Some(crate::args::parse_bound(a, it.next())?),
            "--bound-inertia" => o.bound_inertia = Some(crate::args::parse_bound(a, it.next())?),
            "--venv" => match it.next() {
                Some(d) => o.venv = PathBuf::from(d),
                None => return Err("--venv needs a directory".into()),
            },
            s if s.starts_with('-') => return Err(format!("unexpected argument {s:?}")),
            s => o.names.push(s.to_string()),
        }
    }
    for (flag, b) in [
        ("--bound-mass", o.bound_mass),
        ("--bound-inertia", o.bound_inertia),
    ] {
        if b.is_some() && o.inertia != InertiaPolicy::Repair {
            return Err(format!("{flag} needs --inertia repair"));
        }
    }
    Ok(o)
}

/// Runs the subcommand: 0 when the report is written, 2 on bad arguments or a missing venv,
/// 1 when the report cannot be written.
pub fn main(root: &Path, args: &[String]) -> ExitCode {
    let opts = match parse(root, args) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}\n");
            eprint!("{USAGE}");
            return ExitCode::from(2);
        }
    };
    let python = opts.venv.join("bin/python");
    if !python.exists() {
        eprintln!(
            "error: no Python at {} (the robots come from example-robot-data); create the \
             venv from the workspace root with\n    {}\nor pass --venv DIR",
            python.display(),
            corpus::INSTALL
        );
        return ExitCode::from(2);
    }
    let located = match corpus::locate(root, &python) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: {e}; install it with\n    {}", corpus::INSTALL);
            return ExitCode::from(2);
        }
    };
    let (robots, _) = match corpus::select(&located.robots, &opts.names) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let started = Instant::now();
    let drops: Vec<Fall> = robots
        .iter()
        .map(|r| {
            let d = drop_robot(r, &opts);
            eprintln!("{:<28} {}", r.name, d.brief());
            d
        })
        .collect();
    let summary = Summary::of(&drops);
    let out_dir = root.join("target/articula-drops");
    let written = std::fs::create_dir_all(&out_dir)
        .and_then(|()| {
            std::fs::write(
                out_dir.join("report.md"),
                report_md(&opts, &located.versions, &drops, &summary),
            )
        })
        .and_then(|()| {
            let j = report_json(&opts, &located.versions, &drops, &summary);
            std::fs::write(
                out_dir.join("report.json"),
                serde_json::to_string_pretty(&j).expect("JSON") + "\n",
            )
        });
    if let Err(e) = written {
        eprintln!("error: cannot write {}: {e}", out_dir.display());
        return ExitCode::FAILURE;
    }
    println!("{}", summary.line());
    if let Some((worst, name)) = Summary::statics(&drops) {
        println!("at rest the floor carries M g to within {worst:.1e} (largest: {name})");
    }
    println!(
        "report: {} ({:.1} s)",
        out_dir.join("report.md").display(),
        started.elapsed().as_secs_f64()
    );
    ExitCode::SUCCESS
}

/// What became of one robot.
enum Outcome {
    /// Not loaded: the first line of the loader's reason.
    Refused(String),
    Loaded(Run),
}

/// A loaded robot's run.
struct Run {
    bodies: usize,
    nv: usize,
    mass: f64,
    /// Load warnings (odd or changed inertias, locked joints...).
    warnings: usize,
    steps: u64,
    planned: u64,
    /// The step that stopped the run and why.
    stop: Option<(u64, String)>,
    max_penetration: f64,
    /// Kinetic energy at the end (J; at the last finite step of a stopped run).
    kinetic_end: f64,
    /// `E − E₀` at the end (J; negative: dissipated by the contacts).
    drift: f64,
    /// The largest `E − E₀` over the run, as a fraction of the largest energy in play.
    max_growth: f64,
    /// Steps whose contact solve did not meet its tolerance.
    not_converged: u64,
    contacts_mean: f64,
    us_per_step: f64,
    /// The ground's vertical force at the last step over the weight `M g` (1 at rest: the
    /// floor carries the robot; `ContactData::forces`).
    floor_load: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Verdict {
    Rest,
    Moving,
    Stopped,
    Refused,
}

impl Verdict {
    fn name(self) -> &'static str {
        match self {
            Verdict::Rest => "at rest",
            Verdict::Moving => "moving",
            Verdict::Stopped => "stopped",
            Verdict::Refused => "refused",
        }
    }
}

struct Fall {
    name: String,
    rel: String,
    outcome: Outcome,
}

impl Fall {
    fn verdict(&self) -> Verdict {
        match &self.outcome {
            Outcome::Refused(_) => Verdict::Refused,
            Outcome::Loaded(r) if r.stop.is_some() => Verdict::Stopped,
            Outcome::Loaded(r) if r.kinetic_end / r.mass < REST => Verdict::Rest,
            Outcome::Loaded(_) => Verdict::Moving,
        }
    }

    /// One progress line.
    fn brief(&self) -> String {
        match &self.outcome {
            Outcome::Refused(why) => format!("refused: {why}"),
            Outcome::Loaded(r) => format!(
                "{}: {} steps, KE end {:.2e} J/kg, max penetration {:.2} mm, {:.0} µs/step{}",
                self.verdict().name(),
                r.steps,
                r.kinetic_end / r.mass,
                r.max_penetration * 1e3,
                r.us_per_step,
                r.stop
                    .as_ref()
                    .map(|(k, e)| format!(" (step {k}: {e})"))
                    .unwrap_or_default()
            ),
        }
    }
}

/// Kinetic and potential energy of `state` (sets the kinematics of `data`).
fn energy(model: &Model, data: &mut Data, state: &State) -> (f64, f64) {
    forward_kinematics(model, &state.q, &state.qd, data);
    (data.kinetic_energy(), data.potential_energy())
}

fn drop_robot(robot: &Robot, opts: &Options) -> Fall {
    let outcome = match Model::from_urdf_file(&robot.path, &opts.load_options()) {
        Err(e) => Outcome::Refused(reason(&e.to_string())),
        Ok(model) => Outcome::Loaded(simulate(&model, opts.seconds())),
    };
    Fall {
        name: robot.name.clone(),
        rel: robot.rel.clone(),
        outcome,
    }
}

/// The first line of a loader's message, with the first item of a list it announces
/// (`3 bodies with an inertia no rigid body has:` and the first body).
fn reason(message: &str) -> String {
    let mut lines = message.lines();
    let first = lines.next().unwrap_or("").trim_end();
    match (first.ends_with(':'), lines.next()) {
        (true, Some(item)) => format!("{first} {} ...", item.trim().trim_start_matches("- ")),
        _ => first.to_string(),
    }
}

/// The drop of one loaded model: `seconds` of contact steps (see the module documentation).
fn simulate(model: &Model, seconds: f64) -> Run {
    let settings = ContactSettings {
        ground: Some(Ground::horizontal(0.0)),
        joint_limits: true,
        ..ContactSettings::default()
    };
    let mut contact = ContactData::new(model);
    let mut data = Data::new(model);
    let mut state = State::neutral(model);
    state.q.copy_from_slice(&model.rest_q());
    forward_kinematics(model, &state.q, &state.qd, &mut data);
    let lowest = contact.lowest_point(&data);
    if lowest.is_finite() {
        state.q[2] += DROP - lowest;
    }
    let (t0, v0) = energy(model, &mut data, &state);
    let e0 = t0 + v0;
    let mut scale = e0.abs().max(t0);
    let (mut kinetic_end, mut e_end, mut max_growth) = (t0, e0, 0.0f64);
    let planned = (seconds / DT).round() as u64;
    let (mut steps, mut stop) = (0, None);
    let (mut max_penetration, mut not_converged, mut contacts) = (0.0f64, 0, 0);
    let mut in_steps = Duration::ZERO;
    for k in 1..=planned {
        let t = Instant::now();
        let r = step_with_contact(
            model,
            &mut data,
            &mut contact,
            &mut state,
            Method::Dca,
            DT,
            &settings,
        );
        in_steps += t.elapsed();
        if let Err(e) = r {
            stop = Some((k, e.to_string()));
            break;
        }
        let s = contact.stats;
        max_penetration = max_penetration.max(s.max_penetration);
        not_converged += u64::from(!s.converged);
        contacts += s.contacts;
        if !state.q.iter().chain(&state.qd).all(|x| x.is_finite()) {
            stop = Some((k, "the state is not finite".to_string()));
            break;
        }
        let (t, v) = energy(model, &mut data, &state);
        let e = t + v;
        scale = scale.max(t).max((v - v0).abs());
        if !e.is_finite() {
            stop = Some((k, format!("non-finite energy ({e} J)")));
            break;
        }
        max_growth = max_growth.max((e - e0) / scale);
        if e - e0 > MAX_ENERGY_GROWTH * scale {
            stop = Some((
                k,
                format!(
                    "the energy grew by {:.3e} J, more than {MAX_ENERGY_GROWTH} × {scale:.3e} J",
                    e - e0
                ),
            ));
            break;
        }
        (kinetic_end, e_end, steps) = (t, e, k);
    }
    let mass: f64 = model.bodies.iter().map(|b| b.inertia.mass).sum();
    let floor_load = contact.forces().total().f.z / (mass * -data.gravity.z);
    let us_per_step =
        in_steps.as_secs_f64() * 1e6 / (steps + u64::from(stop.is_some())).max(1) as f64;
    Run {
        bodies: model.bodies.len(),
        nv: model.nv,
        mass,
        warnings: model.warnings.len(),
        steps,
        planned,
        stop,
        max_penetration,
        kinetic_end,
        drift: e_end - e0,
        max_growth,
        not_converged,
        contacts_mean: contacts as f64 / steps.max(1) as f64,
        us_per_step,
        floor_load,
    }
}

struct Summary {
    rest: usize,
    moving: usize,
    stopped: usize,
    refused: usize,
}

impl Summary {
    fn of(drops: &[Fall]) -> Summary {
        let count = |v| drops.iter().filter(|d| d.verdict() == v).count();
        Summary {
            rest: count(Verdict::Rest),
            moving: count(Verdict::Moving),
            stopped: count(Verdict::Stopped),
            refused: count(Verdict::Refused),
        }
    }

    /// Over the robots at rest: the largest `|floor load − 1|` and whose it is.
    fn statics(drops: &[Fall]) -> Option<(f64, &str)> {
        drops
            .iter()
            .filter(|d| d.verdict() == Verdict::Rest)
            .filter_map(|d| match &d.outcome {
                Outcome::Loaded(r) => Some(((r.floor_load - 1.0).abs(), d.name.as_str())),
                Outcome::Refused(_) => None,
            })
            .max_by(|a, b| a.0.total_cmp(&b.0))
    }

    fn line(&self) -> String {
        format!(
            "{} landed and came to rest (KE < {REST:e} J/kg), {} finite but moving, \
             {} stopped (diverged), {} refused",
            self.rest, self.moving, self.stopped, self.refused
        )
    }
}

fn report_md(
    opts: &Options,
    versions: &[(String, String)],
    drops: &[Fall],
    summary: &Summary,
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Robots dropped on the floor\n");
    let _ = writeln!(s, "`{}`\n", opts.command());
    let _ = writeln!(
        s,
        "Floating base, the lowest contact point {DROP} m above a ground at z = 0 (friction 1, \
         no restitution, joint limits on), {} s of DCA contact steps of {DT} s from the \
         rest pose at rest; inertia policy `{}`{}{}. At rest: kinetic energy \
         below {REST:e} J per kg at the end. Stopped: the state or the energy diverged \
         (E − E₀ above {MAX_ENERGY_GROWTH} of the largest energy in play).\n",
        opts.seconds(),
        opts.inertia.name(),
        opts.bound_mass
            .map(|x| format!(", bound_mass {x:e} kg"))
            .unwrap_or_default(),
        opts.bound_inertia
            .map(|x| format!(", bound_inertia {x:e} kg·m²"))
            .unwrap_or_default(),
    );
    let versions: Vec<String> = versions.iter().map(|(k, v)| format!("{k} {v}")).collect();
    if !versions.is_empty() {
        let _ = writeln!(s, "Robots from {}.\n", versions.join(", "));
    }
    let _ = writeln!(s, "**{}**\n", summary.line());
    if let Some((worst, name)) = Summary::statics(drops) {
        let _ = writeln!(
            s,
            "At rest the floor carries each robot's weight: its vertical force at the last step \
             is `M g` to within {worst:.1e} (largest: {name}; column *floor load*, in weights).\n"
        );
    }
    let _ = writeln!(
        s,
        "| robot | verdict | bodies | nv | mass (kg) | steps | max penetration (mm) | \
         KE end (J/kg) | E − E₀ (J) | max growth | contacts | not converged | µs/step | \
         floor load |"
    );
    let _ = writeln!(
        s,
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    );
    for d in drops {
        match &d.outcome {
            Outcome::Refused(_) => {
                let _ = writeln!(s, "| {} | refused | | | | | | | | | | | | |", d.name);
            }
            Outcome::Loaded(r) => {
                // A stopped run's last energies are those of a diverging state.
                let (kinetic, drift) = if r.stop.is_some() {
                    ("—".to_string(), "—".to_string())
                } else {
                    (
                        format!("{:.2e}", r.kinetic_end / r.mass),
                        format!("{:.3e}", r.drift),
                    )
                };
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {:.2} | {}/{} | {:.2} | {kinetic} | {drift} | {:.1e} | \
                     {:.1} | {} | {:.0} | {:.6} |",
                    d.name,
                    d.verdict().name(),
                    r.bodies,
                    r.nv,
                    r.mass,
                    r.steps,
                    r.planned,
                    r.max_penetration * 1e3,
                    r.max_growth,
                    r.contacts_mean,
                    r.not_converged,
                    r.us_per_step,
                    r.floor_load
                );
            }
        }
    }
    let notes: Vec<String> = drops
        .iter()
        .filter_map(|d| match &d.outcome {
            Outcome::Refused(why) => Some(format!("- **{}** refused: {why}", d.name)),
            Outcome::Loaded(Run {
                stop: Some((k, why)),
                ..
            }) => Some(format!("- **{}** stopped at step {k}: {why}", d.name)),
            Outcome::Loaded(r) if d.verdict() == Verdict::Moving => Some(format!(
                "- **{}** still moving at the end: {:.2e} J/kg",
                d.name,
                r.kinetic_end / r.mass
            )),
            _ => None,
        })
        .collect();
    if !notes.is_empty() {
        let _ = writeln!(s, "\n## Exceptions\n\n{}", notes.join("\n"));
    }
    s
}

fn report_json(
    opts: &Options,
    versions: &[(String, String)],
    drops: &[Fall],
    summary: &Summary,
) -> Value {
    let robots: Vec<Value> = drops
        .iter()
        .map(|d| {
            let mut j = json!({
                "name": d.name,
                "path": d.rel,
                "verdict": d.verdict().name(),
            });
            match &d.outcome {
                Outcome::Refused(why) => j["refused"] = json!(why),
                Outcome::Loaded(r) => {
                    let finite = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
                    j["bodies"] = json!(r.bodies);
                    j["nv"] = json!(r.nv);
                    j["mass_kg"] = json!(r.mass);
                    j["load_warnings"] = json!(r.warnings);
                    j["steps"] = json!(r.steps);
                    j["steps_planned"] = json!(r.planned);
                    j["stopped_at"] = json!(r.stop.as_ref().map(|s| s.0));
                    j["stop_reason"] = json!(r.stop.as_ref().map(|s| &s.1));
                    j["max_penetration_m"] = json!(r.max_penetration);
                    j["kinetic_end_j"] = finite(r.kinetic_end);
                    j["kinetic_end_j_per_kg"] = finite(r.kinetic_end / r.mass);
                    j["energy_drift_j"] = finite(r.drift);
                    j["energy_growth_max_relative"] = finite(r.max_growth);
                    j["contacts_mean"] = json!(r.contacts_mean);
                    j["steps_not_converged"] = json!(r.not_converged);
                    j["us_per_step"] = json!(r.us_per_step);
                    j["floor_load"] = finite(r.floor_load);
                }
            }
            j
        })
        .collect();
    json!({
        "command": opts.command(),
        "inertia": opts.inertia.name(),
        "bound_mass_kg": opts.bound_mass,
        "bound_inertia_kgm2": opts.bound_inertia,
        "seconds": opts.seconds(),
        "dt": DT,
        "drop_m": DROP,
        "rest_j_per_kg": REST,
        "max_energy_growth": MAX_ENERGY_GROWTH,
        "versions": versions.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
        "summary": {
            "at_rest": summary.rest,
            "moving": summary.moving,
            "stopped": summary.stopped,
            "refused": summary.refused,
            "line": summary.line(),
        },
        "robots": robots,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusal_reasons_keep_the_first_item() {
        assert_eq!(
            reason(
                "3 bodies with an inertia no rigid body has:\n  - body 'a' (mass 1 kg): x\n  - b"
            ),
            "3 bodies with an inertia no rigid body has: body 'a' (mass 1 kg): x ..."
        );
        assert_eq!(reason("the robot has no links"), "the robot has no links");
    }

    #[test]
    fn bounds_need_repair_and_finite_values() {
        let root = Path::new("/w");
        let args = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let e = parse(root, &args(&["--bound-inertia", "1e-4"])).unwrap_err();
        assert!(e.contains("--inertia repair"), "{e}");
        let e = parse(
            root,
            &args(&["--inertia", "repair", "--bound-inertia", "-1"]),
        )
        .unwrap_err();
        assert!(e.contains("--bound-inertia"), "{e}");
        let o = parse(
            root,
            &args(&["--inertia", "repair", "--bound-inertia", "1e-4", "icub"]),
        )
        .unwrap();
        assert_eq!(o.load_options().bound_inertia, Some(1e-4));
        assert_eq!(
            o.command(),
            "cargo xtask drops --inertia repair --bound-inertia 1e-4 icub"
        );
    }
}
