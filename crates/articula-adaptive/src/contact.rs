//! Ground contact and joint limits for the hybrid body ([`Adaptive::step_with_contact`],
//! `docs/contact.md#adaptive-dynamics`).
//!
//! The hybrid body is fixed for the step (its re-selection, when due, comes first): its
//! generalised coordinates are the active joints', a locked joint keeps `q̇ = 0` and a rigid
//! cluster moves as one. A contact row's Jacobian is the exact one restricted to the active
//! columns (a point on a locked body moves with the active joints above it), the hybrid mass
//! matrix `M_h` is `M` restricted to them, and `M_h⁻¹` is applied by articula-dca's contact
//! step ([`step_with_dynamics`]) on the reduced tree it articulates from [`ContactDynamics::moves`]:
//! one node per active joint, each locked body's inertia welded to its parent's node (the
//! rigid cluster), a body welded to the world in none — so a response column walks only the
//! active joints on a contact body's path. That step also does detection on the whole body's
//! kinematics (a rigidified part still collides), the rows, the Gauss–Seidel solve and the
//! position correction. With every joint active this is articula-dca's exact contact step to
//! rounding.

use crate::{integrate_part, Adaptive, AdaptiveError, StepReport};
use articula_dca::{
    forward_kinematics, step_with_dynamics, ContactData, ContactDynamics, ContactError,
    ContactSettings, Data, DynamicsError, State,
};
use articula_model::Model;
use articula_spatial::{SpatialForce, SpatialInertia};

/// The workspace of [`Adaptive::step_with_contact`]: articula-dca's contact workspace
/// (contact spheres, joint bounds, warm starts, the last step's figures in `contact.stats`)
/// and the whole body's kinematics the rows are read from.
#[derive(Clone, Debug)]
pub struct HybridContact {
    /// The contact step's workspace and figures.
    pub contact: ContactData,
    /// Whole-body kinematics of the step's start (locked parts included).
    kin: Data,
    /// The free-motion accelerations of the step.
    qdd: Vec<f64>,
}

impl HybridContact {
    /// The workspace for `model` ([`ContactData::new`]: its contact spheres and joint limits).
    pub fn new(model: &Model) -> HybridContact {
        HybridContact {
            contact: ContactData::new(model),
            kin: Data::new(model),
            qdd: vec![0.0; model.nv],
        }
    }
}

/// The hybrid body under articula-dca's contact step.
struct Hybrid<'a> {
    ad: &'a Adaptive,
    kin: &'a Data,
    qdd: &'a [f64],
}

impl ContactDynamics for Hybrid<'_> {
    fn free_motion(
        &mut self,
        _model: &Model,
        _state: &mut State,
        qdd: &mut [f64],
    ) -> Result<(), DynamicsError> {
        // Computed before the contact step (with the re-selection's errors).
        qdd.copy_from_slice(self.qdd);
        Ok(())
    }

    fn kinematics(&self) -> &Data {
        self.kin
    }

    fn world_inertia(&self, _model: &Model, body: usize) -> SpatialInertia {
        // Set by the whole-body kinematics (the default's computation, done there).
        self.kin.inertia[body]
    }

    fn moves(&self, model: &Model, body: usize) -> bool {
        self.ad.is_active(model, body)
    }

    fn integrate(&self, model: &Model, q: &mut [f64], v: &[f64], h: f64) {
        // The active joints only: a locked joint keeps its coordinates to the bit.
        for &j in &self.ad.hier.ajoints {
            for part in &model.bodies[j].joint {
                integrate_part(part, q, v, h);
            }
        }
    }
}

impl Adaptive {
    /// One semi-implicit Euler step of the hybrid body with the ground contact and joint
    /// limits of `settings` (`docs/contact.md`): the re-selection when due (as
    /// [`Adaptive::step_with_forces`], the external wrenches `forces` as a list), the hybrid
    /// body's free motion, then articula-dca's contact step with the hybrid body's responses
    /// (module documentation). A body with no active joint (budget 0) moves as one rigid body
    /// and still lands. `contact.contact.stats` holds the step's contact figures.
    ///
    /// Cost: the hybrid step, whole-body kinematics O(n) for the contact spheres and the
    /// reduced tree's inertias, per response column a walk along the active joints of one
    /// contact body's path and the rows' paths, O(k²) for `W` and per Gauss–Seidel sweep
    /// (`k` rows).
    pub fn step_with_contact(
        &mut self,
        model: &Model,
        state: &mut State,
        dt: f64,
        forces: &[(usize, SpatialForce)],
        contact: &mut HybridContact,
        settings: &ContactSettings,
    ) -> Result<StepReport, AdaptiveError> {
        self.set_forces(model, state, forces)?;
        let mut report = self.step_dynamics(model, state)?;
        // The free motion: the active joints' q̈ (0 elsewhere).
        contact.qdd.fill(0.0);
        for &j in &self.hier.ajoints {
            let b = &model.bodies[j];
            let r = b.v_offset..b.v_offset + b.nv;
            contact.qdd[r.clone()].copy_from_slice(&self.body.qdd[r]);
        }
        forward_kinematics(model, &state.q, &state.qd, &mut contact.kin);
        let mut hybrid = Hybrid {
            ad: self,
            kin: &contact.kin,
            qdd: &contact.qdd,
        };
        let r = step_with_dynamics(
            model,
            &mut hybrid,
            &mut contact.contact,
            state,
            dt,
            settings,
        );
        // The free motion's accelerations stay the workspace's (`Adaptive::qdd`).
        self.body.qdd.copy_from_slice(&contact.qdd);
        r.map_err(|e| match e {
            ContactError::Dynamics(e) => AdaptiveError::Dynamics(e),
            e => AdaptiveError::Setting(e.to_string()),
        })?;
        self.steps += 1;
        report.active_dofs = self.hier.dofs;
        report.predicted_error = self.last.predicted_error;
        report.nodes_touched = self.touched;
        Ok(report)
    }
}
