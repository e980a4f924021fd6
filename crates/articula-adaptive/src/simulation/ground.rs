//! Ground contact in a [`Simulation`](super::Simulation): the options ([`GroundOptions`]),
//! the drop onto the floor, the start-inside-the-floor check, the contact step of each
//! method and the figures gathered over the steps ([`ContactTally`]).

use super::stop::{SimulationError, StepError};
use crate::{Adaptive, HybridContact, StepReport};
use articula_dca::{
    forward_kinematics, step_with_contact, ContactData, ContactForces, ContactSettings,
    ContactStats, Data, Ground, Method, State,
};
use articula_model::Model;
use articula_spatial::SpatialForce;
use glam::DVec3;

/// Ground contact of a simulation.
#[derive(Clone, Debug)]
pub struct GroundOptions {
    /// The contact settings; `contact.ground` is the floor (`None`: joint limits only).
    pub contact: ContactSettings,
    /// Before the run, raise the floating base so that the lowest contact point is this many
    /// metres above the ground (`None`: start where the state is).
    pub drop: Option<f64>,
    /// Start from the rest pose ([`Model::rest_q`]: the neutral pose with every coordinate
    /// whose limits exclude 0 moved to the nearer bound) instead of the state's positions.
    pub rest_pose: bool,
    /// The deepest start below the ground allowed (m, default 0.05): deeper, the position
    /// correction would throw the body out with an energy no integration can follow, and the
    /// simulation refuses to start ([`SimulationError::StartsInsideFloor`]).
    pub max_start_penetration: f64,
}

impl GroundOptions {
    /// A horizontal floor at height `z` (friction 1, no restitution, joint limits on).
    pub fn floor(z: f64) -> GroundOptions {
        GroundOptions {
            contact: ContactSettings {
                ground: Some(Ground::horizontal(z)),
                ..ContactSettings::default()
            },
            drop: None,
            rest_pose: false,
            max_start_penetration: 0.05,
        }
    }
}

/// Contact figures summed over the steps of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactTally {
    /// Contact steps taken.
    pub steps: u64,
    /// Contact spheres pushed by the ground, summed over the steps.
    pub contacts: u64,
    /// Rows of the contact problems, summed.
    pub rows: u64,
    /// Response columns, summed.
    pub response_solves: u64,
    /// Steps whose solver did not meet its tolerance.
    pub not_converged: u64,
    /// The largest residual those steps' solves ended with (m/s; `ContactStats::residual`),
    /// 0 when every solve converged.
    pub worst_residual: f64,
    /// The deepest penetration seen at the start of a step (m).
    pub max_penetration: f64,
}

impl ContactTally {
    /// Adds one step's figures.
    fn add(&mut self, s: &ContactStats) {
        self.steps += 1;
        self.contacts += s.contacts as u64;
        self.rows += s.rows as u64;
        self.response_solves += s.response_solves as u64;
        self.not_converged += (!s.converged) as u64;
        if !s.converged {
            self.worst_residual = self.worst_residual.max(s.residual);
        }
        self.max_penetration = self.max_penetration.max(s.max_penetration);
    }

    /// `x` per contact step.
    pub fn per_step(&self, x: u64) -> f64 {
        x as f64 / self.steps.max(1) as f64
    }
}

/// The contact state of a run: settings, workspaces, figures.
#[derive(Clone, Debug)]
pub(super) struct ContactRun {
    /// The settings.
    pub settings: ContactSettings,
    /// The exact methods' contact workspace.
    pub exact: ContactData,
    /// Adaptive: the hybrid body's contact workspace and the exact reference run's (made at
    /// the first adaptive step).
    pub hybrid: Option<(HybridContact, ContactData)>,
    /// The external wrenches of an adaptive step, as a list.
    forces: Vec<(usize, SpatialForce)>,
    /// The figures so far.
    pub tally: ContactTally,
}

impl ContactRun {
    pub fn new(model: &Model, settings: ContactSettings) -> ContactRun {
        ContactRun {
            settings,
            exact: ContactData::new(model),
            hybrid: None,
            forces: Vec::new(),
            tally: ContactTally::default(),
        }
    }

    /// Raises the floating base so that the lowest contact point is `h` above the ground.
    pub fn drop(
        &self,
        model: &Model,
        data: &mut Data,
        state: &mut State,
        h: f64,
    ) -> Result<(), SimulationError> {
        if !model.floating_base {
            return Err(SimulationError::DropNeedsFloatingBase);
        }
        if !h.is_finite() {
            return Err(SimulationError::Invalid {
                what: "drop",
                detail: format!("must be finite, got {h}"),
            });
        }
        let Some(ground) = self.settings.ground else {
            return Ok(());
        };
        forward_kinematics(model, &state.q, &state.qd, data)?;
        let lowest = self.exact.lowest_point(data);
        if lowest.is_finite() {
            state.q[2] += ground.point.z + h - lowest;
        }
        Ok(())
    }

    /// Refuses a start deeper than `limit` below a horizontal ground (an inclined one is not
    /// checked).
    pub fn check_start(
        &self,
        model: &Model,
        data: &mut Data,
        state: &State,
        limit: f64,
    ) -> Result<(), SimulationError> {
        let Some(ground) = self.settings.ground else {
            return Ok(());
        };
        if ground.normal.x != 0.0 || ground.normal.y != 0.0 {
            return Ok(());
        }
        forward_kinematics(model, &state.q, &state.qd, data)?;
        let lowest = self
            .exact
            .collision()
            .spheres
            .iter()
            .map(|s| {
                let z = (articula_dca::sphere_center(data, s, DVec3::Z) + data.origin).z - s.radius;
                (z, s.body)
            })
            .fold(None, |low: Option<(f64, usize)>, (z, b)| match low {
                Some((lz, _)) if lz <= z => low,
                _ => Some((z, b)),
            });
        match lowest {
            Some((z, body)) if ground.point.z - z > limit => {
                Err(SimulationError::StartsInsideFloor {
                    link: model.bodies[body].name.clone(),
                    lowest: z,
                    ground: ground.point.z,
                    depth: ground.point.z - z,
                    limit,
                })
            }
            _ => Ok(()),
        }
    }

    /// One exact contact step.
    pub fn step(
        &mut self,
        model: &Model,
        data: &mut Data,
        state: &mut State,
        method: Method,
        dt: f64,
    ) -> Result<(), StepError> {
        step_with_contact(
            model,
            data,
            &mut self.exact,
            state,
            method,
            dt,
            &self.settings,
        )?;
        let s = self.exact.stats;
        self.tally.add(&s);
        Ok(())
    }

    /// One contact step of the hybrid body `ad` (re-selection included when due).
    pub fn step_adaptive(
        &mut self,
        model: &Model,
        ad: &mut Adaptive,
        state: &mut State,
        dt: f64,
    ) -> Result<StepReport, StepError> {
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
        let report = report?;
        let s = hybrid.contact.stats;
        self.tally.add(&s);
        Ok(report)
    }

    /// One exact DCA contact step of the reference run beside an adaptive one (its own
    /// workspace and warm starts; not counted in the figures).
    pub fn step_reference(
        &mut self,
        model: &Model,
        data: &mut Data,
        state: &mut State,
        dt: f64,
    ) -> Result<(), StepError> {
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
        )?;
        Ok(())
    }

    /// The forces of the last contact step (the hybrid body's for an adaptive run).
    pub fn last_forces(&self) -> &ContactForces {
        match &self.hybrid {
            Some((hybrid, _)) => hybrid.contact.forces(),
            None => self.exact.forces(),
        }
    }
}
