//! `articula simulate --ground Z`: ground contact and joint limits in the step
//! (`docs/contact.md`), and the figures the summary adds.

use crate::CliError;
use articula_adaptive::{Adaptive, HybridContact, StepReport};
use articula_dca::{
    forward_kinematics, step_with_contact, ContactData, ContactForces, ContactSettings,
    ContactSolver, ContactStats, Data, Ground, Method, State,
};
use articula_model::Model;
use articula_spatial::SpatialForce;

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
}

/// `--contact-solver`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolverArg {
    /// Projected Gauss–Seidel (the default: the fastest on crowds).
    GaussSeidel,
    /// Gauss–Seidel with subspace minimisation: about half the iterations, each subspace
    /// step several sweeps' cost; converges where a light body carries a heavy one.
    Subspace,
}

/// The contact run: settings, workspace and the figures gathered over the steps.
pub struct GroundRun {
    settings: ContactSettings,
    contact: ContactData,
    /// `--method adaptive`: the hybrid body's contact workspace, and the exact reference
    /// run's (made at the first adaptive step).
    hybrid: Option<(HybridContact, ContactData)>,
    /// The external wrenches of an adaptive step, as a list.
    forces: Vec<(usize, SpatialForce)>,
    steps: u64,
    contacts: u64,
    rows: u64,
    solves: u64,
    not_converged: u64,
    max_penetration: f64,
}

impl GroundArgs {
    /// The contact run when `--ground` is given (after checking the values), else `None`.
    pub fn run(&self, model: &Model) -> Result<Option<GroundRun>, CliError> {
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
        let mut ground = Ground::horizontal(z);
        ground.friction = self.friction;
        ground.restitution = self.restitution;
        Ok(Some(GroundRun {
            settings: ContactSettings {
                ground: Some(ground),
                joint_limits: !self.no_joint_limits,
                solver: match self.contact_solver {
                    SolverArg::GaussSeidel => ContactSolver::GaussSeidel,
                    SolverArg::Subspace => ContactSolver::Subspace,
                },
                ..ContactSettings::default()
            },
            contact: ContactData::new(model),
            hybrid: None,
            forces: Vec::new(),
            steps: 0,
            contacts: 0,
            rows: 0,
            solves: 0,
            not_converged: 0,
            max_penetration: 0.0,
        }))
    }
}

impl GroundRun {
    /// `--drop H`: raises the floating base so that the lowest contact point is `h` above the
    /// ground.
    pub fn drop(
        &self,
        model: &Model,
        data: &mut Data,
        state: &mut State,
        h: f64,
    ) -> Result<(), CliError> {
        if !model.floating_base {
            return Err(CliError(
                "--drop needs a floating base (--floating-base)".into(),
            ));
        }
        if !h.is_finite() {
            return Err(CliError(format!("--drop must be finite, got {h}")));
        }
        let ground = self.settings.ground.expect("a ground");
        forward_kinematics(model, &state.q, &state.qd, data);
        let lowest = self.contact.lowest_point(data);
        if lowest.is_finite() {
            state.q[2] += ground.point.z + h - lowest;
        }
        Ok(())
    }

    /// One contact step.
    pub fn step(
        &mut self,
        model: &Model,
        data: &mut Data,
        state: &mut State,
        method: Method,
        dt: f64,
    ) -> Result<(), String> {
        step_with_contact(
            model,
            data,
            &mut self.contact,
            state,
            method,
            dt,
            &self.settings,
        )
        .map_err(|e| e.to_string())?;
        let s = self.contact.stats;
        self.record(&s);
        Ok(())
    }

    /// One contact step of the hybrid body `ad` (re-selection included when due).
    pub fn step_adaptive(
        &mut self,
        model: &Model,
        ad: &mut Adaptive,
        state: &mut State,
        dt: f64,
    ) -> Result<StepReport, String> {
        let (hybrid, _) = self
            .hybrid
            .get_or_insert_with(|| (HybridContact::new(model), ContactData::new(model)));
        // The hybrid step takes the external wrenches as a list (same convention as
        // `state.f_ext`: world coordinates, about the world origin).
        self.forces.clear();
        self.forces.extend(
            (state.f_ext.iter().enumerate())
                .filter(|(_, f)| **f != SpatialForce::ZERO)
                .map(|(i, f)| (i, *f)),
        );
        let f_ext = std::mem::take(&mut state.f_ext);
        let report = ad.step_with_contact(model, state, dt, &self.forces, hybrid, &self.settings);
        state.f_ext = f_ext;
        let report = report.map_err(|e| e.to_string())?;
        let s = hybrid.contact.stats;
        self.record(&s);
        Ok(report)
    }

    /// One exact DCA contact step of the reference run beside `--method adaptive` (its own
    /// workspace and warm starts; not counted in the figures).
    pub fn step_reference(
        &mut self,
        model: &Model,
        data: &mut Data,
        state: &mut State,
        dt: f64,
    ) -> Result<(), String> {
        let (_, reference) = self
            .hybrid
            .get_or_insert_with(|| (HybridContact::new(model), ContactData::new(model)));
        step_with_contact(
            model,
            data,
            reference,
            state,
            Method::Dca,
            dt,
            &self.settings,
        )
        .map_err(|e| e.to_string())
    }

    /// Adds one step's contact figures.
    fn record(&mut self, s: &ContactStats) {
        self.steps += 1;
        self.contacts += s.contacts as u64;
        self.rows += s.rows as u64;
        self.solves += s.response_solves as u64;
        self.not_converged += (!s.converged) as u64;
        self.max_penetration = self.max_penetration.max(s.max_penetration);
    }

    /// The summary lines: ground, penetration, contacts, kinetic energy at the end.
    /// The contact figures as keys of the `--json` summary.
    pub fn add_json(&self, j: &mut serde_json::Value) {
        let per = |x: u64| x as f64 / self.steps.max(1) as f64;
        j["max_penetration_m"] = serde_json::json!(self.max_penetration);
        j["contacts_mean"] = serde_json::json!(per(self.contacts));
        j["contact_rows_mean"] = serde_json::json!(per(self.rows));
        j["response_solves_mean"] = serde_json::json!(per(self.solves));
        j["steps_not_converged"] = serde_json::json!(self.not_converged);
        let f = self.last_forces().total().f;
        j["ground_force_end_n"] = serde_json::json!([f.x, f.y, f.z]);
    }

    /// The forces of the last contact step of the run (the hybrid body's with `--method
    /// adaptive`).
    fn last_forces(&self) -> &ContactForces {
        match &self.hybrid {
            Some((hybrid, _)) => hybrid.contact.forces(),
            None => self.contact.forces(),
        }
    }

    /// The contact figures as lines of the text summary.
    pub fn lines(&self, kinetic_end: f64) -> Vec<String> {
        let g = self.settings.ground.expect("a ground");
        let per = |x: u64| x as f64 / self.steps.max(1) as f64;
        vec![
            format!(
                "ground       z = {} m, friction {}, restitution {}, joint limits {} ({})",
                g.point.z,
                g.friction,
                g.restitution,
                if self.settings.joint_limits { "on" } else { "off" },
                self.contact.collision().summary()
            ),
            format!("max_penetration_m {:.3e}", self.max_penetration),
            format!(
                "contacts     {:.2} per step (mean), {:.2} rows, {:.2} response columns; {} step(s) not converged",
                per(self.contacts),
                per(self.rows),
                per(self.solves),
                self.not_converged
            ),
            format!("kinetic end  {kinetic_end:.6e} J"),
            {
                let f = self.last_forces().total().f;
                format!(
                    "ground force {:.6e} {:.6e} {:.6e} N (the last step's, world axes)",
                    f.x, f.y, f.z
                )
            },
        ]
    }
}
