//! `articula simulate --ground Z`: ground contact and joint limits in the step
//! (`docs/contact.md`) as the library's `GroundOptions`, and the figures the summary adds.

use crate::CliError;
use articula_adaptive::simulation::{GroundOptions, Simulation};
use articula_dca::ContactSolver;
use articula_model::Model;

/// The contact options of `articula simulate`.
#[derive(clap::Args, Debug, Clone)]
pub struct GroundArgs {
    /// A horizontal ground plane at height Z (m): hard contact with Coulomb friction, and the
    /// URDF joint limits enforced (docs/contact.md). Semi-implicit Euler; exact methods and
    /// `--method adaptive` (its rigid parts still collide).
    #[arg(long, value_name = "Z", allow_hyphen_values = true)]
    pub ground: Option<f64>,
    /// `--ground`: Coulomb friction coefficient μ ≥ 0.
    #[arg(long, value_name = "MU", default_value_t = 1.0, requires = "ground",
          value_parser = crate::parse_nonnegative)]
    pub friction: f64,
    /// `--ground`: restitution 0 ≤ e ≤ 1.
    #[arg(long, value_name = "E", default_value_t = 0.0, requires = "ground")]
    pub restitution: f64,
    /// `--ground`: do not enforce the URDF joint limits.
    #[arg(long, requires = "ground")]
    pub no_joint_limits: bool,
    /// `--ground`: before the run, raise a floating base so that the lowest contact point is H
    /// metres above the ground.
    #[arg(long, value_name = "H", requires = "ground", value_parser = crate::parse_nonnegative)]
    pub drop: Option<f64>,
    /// `--ground`: how the contact problem is solved (docs/contact.md#solver).
    #[arg(long, value_enum, default_value_t = SolverArg::GaussSeidel, requires = "ground")]
    pub contact_solver: SolverArg,
    /// `--ground`: stop each contact solve once every condition holds to this residual
    /// velocity (m/s or rad/s; default the library's, docs/contact.md#solver).
    #[arg(long, value_name = "V", requires = "ground", value_parser = crate::parse_nonnegative)]
    pub contact_tolerance: Option<f64>,
    /// `--ground`: at most this many solver iterations per contact solve (1..=10000; default
    /// the library's).
    #[arg(long, value_name = "N", requires = "ground")]
    pub contact_iterations: Option<usize>,
}

/// `--contact-solver`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolverArg {
    /// Projected Gauss–Seidel (the default): no factorisation, but hundreds of sweeps where
    /// contacts are redundant or a light body carries a heavy one.
    GaussSeidel,
    /// Gauss–Seidel with subspace minimisation: about half the iterations, each subspace
    /// step several sweeps' cost; converges where a light body carries a heavy one.
    Subspace,
    /// Semismooth Newton on the contact and limit rows together: a few iterations, each one
    /// dense solve on the rows that push; with `--contact-tolerance 1e-6` almost every solve
    /// converges.
    Newton,
}

impl GroundArgs {
    /// The ground options of these flags when `--ground` is given (after checking the values
    /// and the model), else `None`. Without a state file (`state_given` false) and with the
    /// joint limits on, the run starts in the rest pose.
    pub fn options(
        &self,
        model: &Model,
        state_given: bool,
    ) -> Result<Option<GroundOptions>, CliError> {
        let Some(z) = self.ground else {
            return Ok(None);
        };
        if !z.is_finite() {
            return Err(CliError(format!("--ground must be finite, got {z}")));
        }
        if !(self.friction >= 0.0 && self.friction.is_finite()) {
            return Err(CliError(format!(
                "--friction must be a finite number ≥ 0, got {}",
                self.friction
            )));
        }
        if !(0.0..=1.0).contains(&self.restitution) {
            return Err(CliError(format!(
                "--restitution must be in [0, 1], got {}",
                self.restitution
            )));
        }
        if let Some(h) = self.drop {
            if !model.floating_base {
                return Err(CliError(
                    "--drop needs a floating base (--floating-base)".into(),
                ));
            }
            if !h.is_finite() {
                return Err(CliError(format!("--drop must be finite, got {h}")));
            }
        }
        let mut options = GroundOptions::floor(z);
        let contact = &mut options.contact;
        if let Some(ground) = &mut contact.ground {
            ground.friction = self.friction;
            ground.restitution = self.restitution;
        }
        contact.joint_limits = !self.no_joint_limits;
        contact.solver = match self.contact_solver {
            SolverArg::GaussSeidel => ContactSolver::GaussSeidel,
            SolverArg::Subspace => ContactSolver::Subspace,
            SolverArg::Newton => ContactSolver::Newton,
        };
        if let Some(t) = self.contact_tolerance {
            if !(t > 0.0 && t.is_finite()) {
                return Err(CliError(format!(
                    "--contact-tolerance must be a positive number (m/s), got {t}"
                )));
            }
            contact.tolerance = t;
        }
        if let Some(n) = self.contact_iterations {
            if n == 0 || n > articula_dca::CONTACT_MAX_ITERATIONS {
                return Err(CliError(format!(
                    "--contact-iterations must lie in 1..={}, got {n}",
                    articula_dca::CONTACT_MAX_ITERATIONS
                )));
            }
            contact.max_iterations = n;
        }
        options.drop = self.drop;
        // With the joint limits enforced and no state file, the run starts in the rest pose
        // (the neutral pose moved into the limits), not against a limit it violates.
        options.rest_pose = !self.no_joint_limits && !state_given;
        Ok(Some(options))
    }
}

/// The contact figures of `sim` as keys of the `--json` summary.
pub fn add_json(sim: &Simulation, j: &mut serde_json::Value) {
    let (Some(tally), Some(forces)) = (sim.contact_tally(), sim.contact_forces()) else {
        return;
    };
    j["max_penetration_m"] = serde_json::json!(tally.max_penetration);
    j["contacts_mean"] = serde_json::json!(tally.per_step(tally.contacts));
    j["contact_rows_mean"] = serde_json::json!(tally.per_step(tally.rows));
    j["response_solves_mean"] = serde_json::json!(tally.per_step(tally.response_solves));
    j["steps_not_converged"] = serde_json::json!(tally.not_converged);
    j["worst_residual_m_per_s"] = serde_json::json!(tally.worst_residual);
    let f = forces.total().f;
    j["ground_force_end_n"] = serde_json::json!([f.x, f.y, f.z]);
}

/// The contact figures of `sim` as lines of the text summary: ground, penetration, contacts,
/// kinetic energy at the end, the last step's ground force.
pub fn lines(sim: &Simulation, kinetic_end: f64) -> Vec<String> {
    let (Some(g), Some(tally), Some(contact), Some(forces)) = (
        sim.options().ground.as_ref(),
        sim.contact_tally(),
        sim.contact_data(),
        sim.contact_forces(),
    ) else {
        return Vec::new();
    };
    let settings = &g.contact;
    let ground = settings.ground.expect("--ground sets a floor");
    let f = forces.total().f;
    vec![
        format!(
            "ground       z = {} m, friction {}, restitution {}, joint limits {} ({})",
            ground.point.z,
            ground.friction,
            ground.restitution,
            if settings.joint_limits { "on" } else { "off" },
            contact.collision().summary()
        ),
        format!("max_penetration_m {:.3e}", tally.max_penetration),
        format!(
            "contacts     {:.2} per step (mean), {:.2} rows, {:.2} response columns; {} step(s) not converged{}",
            tally.per_step(tally.contacts),
            tally.per_step(tally.rows),
            tally.per_step(tally.response_solves),
            tally.not_converged,
            if tally.not_converged > 0 {
                format!(" (largest residual {:.1e} m/s)", tally.worst_residual)
            } else {
                String::new()
            }
        ),
        format!("kinetic end  {kinetic_end:.6e} J"),
        format!(
            "ground force {:.6e} {:.6e} {:.6e} N (the last step's, world axes)",
            f.x, f.y, f.z
        ),
    ]
}
