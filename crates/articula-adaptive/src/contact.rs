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
//! kinematics (a rigidified part still collides; each locked body's pose composed from its
//! cluster's, [`HybridContact`]), the rows, the Gauss–Seidel solve and the position
//! correction. With every joint active this is articula-dca's exact contact step to
//! rounding.

use crate::{integrate_part, Adaptive, AdaptiveError, StepReport};
use articula_dca::{
    forward_kinematics, step_with_dynamics, ContactData, ContactDynamics, ContactError,
    ContactScratch, ContactSettings, Data, DynamicsError, State,
};
use articula_model::Model;
use articula_spatial::{SpatialForce, SpatialInertia, SpatialMotion, SpatialTransform};

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
    /// The rigid clusters of the hybrid body of build `gen` ([`Clusters`]).
    clusters: Clusters,
}

/// The buffers of a hybrid body's contact step that nothing carries from one step to the
/// next: articula-dca's ([`ContactScratch`]) and the whole-body kinematics. Bodies of one
/// model stepped in turn share one ([`HybridContact::swap_scratch`]), which then stays in the
/// processor's caches.
#[derive(Clone, Debug)]
pub struct HybridScratch {
    contact: ContactScratch,
    kin: Data,
}

impl HybridScratch {
    /// The buffers for `model`.
    pub fn new(model: &Model) -> HybridScratch {
        HybridScratch {
            contact: ContactScratch::new(model),
            kin: Data::new(model),
        }
    }

    /// articula-dca's part, for an exact contact step's [`ContactData::swap_scratch`].
    pub fn contact(&mut self) -> &mut ContactScratch {
        &mut self.contact
    }
}

/// The hybrid body's rigid clusters, for its whole-body kinematics without a forward
/// kinematics pass: a locked body keeps its pose in the frame of the active body whose cluster
/// it belongs to, and shares that body's spatial velocity.
#[derive(Clone, Debug)]
struct Clusters {
    /// The build of the hybrid body's records (`Hierarchy::gen`) these are for.
    gen: Option<u64>,
    /// Per body: the active body whose cluster it belongs to (itself when its joint is active),
    /// [`WORLD`] when no active joint lies above it (welded to the world: fixed pose).
    anchor: Vec<usize>,
    /// Per body: its pose in its anchor's frame, `X_{a←b}` (its computation-frame pose for a
    /// body welded to the world; the identity for an active body).
    rel: Vec<SpatialTransform>,
    /// Per active body: its cluster's composite spatial inertia in its own frame.
    composite: Vec<SpatialInertia>,
    /// Per body, this step: its cluster's composite in the computation frame for an active
    /// body, zero for the others (the contact tree sums each cluster into its node).
    inertia: Vec<SpatialInertia>,
}

/// [`Clusters::anchor`] of a body with no active joint above it.
const WORLD: usize = usize::MAX;

impl HybridContact {
    /// The workspace for `model` ([`ContactData::new`]: its contact spheres and joint limits).
    pub fn new(model: &Model) -> HybridContact {
        let n = model.bodies.len();
        HybridContact {
            contact: ContactData::new(model),
            kin: Data::new(model),
            qdd: vec![0.0; model.nv],
            clusters: Clusters {
                gen: None,
                anchor: vec![WORLD; n],
                rel: vec![SpatialTransform::IDENTITY; n],
                composite: vec![SpatialInertia::ZERO; n],
                inertia: vec![SpatialInertia::ZERO; n],
            },
        }
    }

    /// Exchanges this workspace's step buffers with `scratch` (O(1)): give it a scratch of the
    /// same model before [`Adaptive::step_with_contact`] and take it back after, and the
    /// bodies of one model stepped in turn share one. The warm starts, the rigid clusters and
    /// the last step's figures stay here.
    pub fn swap_scratch(&mut self, scratch: &mut HybridScratch) {
        self.contact.swap_scratch(&mut scratch.contact);
        std::mem::swap(&mut self.kin, &mut scratch.kin);
    }

    /// The whole body's kinematics at the step's start into `kin`: after a new hybrid body,
    /// one forward kinematics pass, from which each locked body's pose in its cluster and each
    /// cluster's composite inertia are kept; at the other steps, each active body's pose,
    /// velocity and subspace columns from the hybrid step's own kinematics (`ad.data`), and
    /// each locked body's pose composed from its cluster's (`x_b = x_a X_{a←b}`) with its
    /// velocity — O(n) compositions, no sines or cosines. Then the clusters' inertias in the
    /// computation frame.
    fn whole_kinematics(
        &mut self,
        model: &Model,
        ad: &Adaptive,
        q: &[f64],
        qd: &[f64],
    ) -> Result<(), DynamicsError> {
        let (kin, cl) = (&mut self.kin, &mut self.clusters);
        if cl.gen != Some(ad.hier.gen) || !ad.hier.valid {
            forward_kinematics(model, q, qd, kin)?;
            for (b, body) in model.bodies.iter().enumerate() {
                let active = body.nv > 0 && ad.is_active(model, b);
                let anchor = match body.parent {
                    _ if active => b,
                    Some(p) => cl.anchor[p],
                    None => WORLD,
                };
                cl.anchor[b] = anchor;
                cl.rel[b] = match anchor {
                    WORLD => kin.x[b],
                    a if a == b => SpatialTransform::IDENTITY,
                    a => kin.x[a].inverse() * kin.x[b],
                };
                cl.composite[b] = SpatialInertia::ZERO;
                if anchor != WORLD {
                    let i = cl.rel[b].apply_inertia(&body.inertia);
                    cl.composite[anchor] += i;
                }
            }
            cl.gen = ad.hier.valid.then_some(ad.hier.gen);
        } else {
            kin.origin = ad.data.origin;
            for (b, body) in model.bodies.iter().enumerate() {
                match cl.anchor[b] {
                    WORLD => {
                        kin.x[b] = cl.rel[b];
                        kin.v[b] = SpatialMotion::ZERO;
                    }
                    a if a == b => {
                        kin.x[b] = ad.data.x[b];
                        kin.v[b] = ad.data.v[b];
                        let r = body.v_offset..body.v_offset + body.nv;
                        kin.s[r.clone()].copy_from_slice(&ad.data.s[r]);
                    }
                    a => {
                        kin.x[b] = kin.x[a] * cl.rel[b];
                        kin.v[b] = kin.v[a];
                    }
                }
            }
        }
        for (b, x) in kin.x.iter().enumerate() {
            cl.inertia[b] = if cl.anchor[b] == b {
                x.apply_inertia(&cl.composite[b])
            } else {
                SpatialInertia::ZERO
            };
        }
        Ok(())
    }
}

/// The hybrid body under articula-dca's contact step.
struct Hybrid<'a> {
    ad: &'a Adaptive,
    kin: &'a Data,
    /// Per body: its cluster's composite inertia (active bodies), zero elsewhere.
    inertia: &'a [SpatialInertia],
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
        // Each cluster's composite on its active body (the contact tree sums a node's bodies).
        self.inertia[body]
    }

    fn added_inertia(&self, _model: &Model, dof: usize) -> f64 {
        // The free motion's armature: the model's plus `h b` of the implicit damping
        // (`passive.rs`), for the impulses' response to see the same inertia.
        self.ad.data.armature().get(dof).copied().unwrap_or(0.0)
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
    /// Cost: the hybrid step, whole-body kinematics for the contact spheres (O(n) pose
    /// compositions from the rigid clusters; a forward kinematics pass after a new hybrid
    /// body), one inertia per cluster, per response column a walk along the active joints of one
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
        // Damping implicit over the step, as in the contact step's inertia (`M + A + h B`).
        self.set_damping_step(model, dt);
        let mut report = self.step_dynamics(model, state)?;
        // The free motion: the active joints' q̈ (0 elsewhere).
        contact.qdd.fill(0.0);
        for &j in &self.hier.ajoints {
            let b = &model.bodies[j];
            let r = b.v_offset..b.v_offset + b.nv;
            contact.qdd[r.clone()].copy_from_slice(&self.body.qdd[r]);
        }
        contact.whole_kinematics(model, self, &state.q, &state.qd)?;
        let mut hybrid = Hybrid {
            ad: self,
            kin: &contact.kin,
            inertia: &contact.clusters.inertia,
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

#[cfg(test)]
mod tests {
    use super::HybridContact;
    use crate::{Adaptive, Settings};
    use articula_dca::{forward_kinematics, ContactSettings, Data, State};
    use articula_spatial::SpatialInertia;

    /// The largest entry of `a − b` over two 6×6 inertias' matrices.
    fn inertia_gap(a: &SpatialInertia, b: &SpatialInertia) -> f64 {
        let (a, b) = (a.to_mat6(), b.to_mat6());
        (0..36).fold(0.0, |m, k| {
            m.max((a.get(k / 6, k % 6) - b.get(k / 6, k % 6)).abs())
        })
    }

    /// The largest entry of `a − b`.
    fn mat_gap(a: glam::DMat3, b: glam::DMat3) -> f64 {
        (a - b)
            .to_cols_array()
            .iter()
            .fold(0.0, |m, x| m.max(x.abs()))
    }

    /// The whole-body kinematics a contact step reads, composed from the hybrid step's own and
    /// each locked body's pose in its cluster, equal a forward kinematics pass of the same state
    /// to rounding — poses, velocities, the active joints' subspace columns — and each cluster's
    /// inertia the sum of its bodies': on the humanoid, fixed and floating, with a third of its
    /// joints active, over steps after the one that built the clusters.
    #[test]
    fn cluster_kinematics_equal_forward_kinematics() {
        // No floor and no limits: the plain semi-implicit step.
        let settings = ContactSettings {
            joint_limits: false,
            ..ContactSettings::default()
        };
        for floating in [false, true] {
            let model = articula_testkit::bundled_with("humanoid", floating);
            let mut full = Data::new(&model);
            for seed in 0..4u64 {
                let mut state = State::random(&model, seed, 0.5);
                // The forces go as a list (none here).
                state.f_ext.clear();
                let settings_ad = Settings {
                    reselect_every: u64::MAX,
                    ..Settings::default()
                };
                let mut ad = Adaptive::new(&model, settings_ad);
                ad.set_active(&model, &mut state, |j| (j as u64 + seed).is_multiple_of(3))
                    .unwrap();
                let mut hc = HybridContact::new(&model);
                let mut worst = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
                for _ in 0..4 {
                    let (q, qd) = (state.q.clone(), state.qd.clone());
                    ad.step_with_contact(&model, &mut state, 1e-3, &[], &mut hc, &settings)
                        .unwrap();
                    forward_kinematics(&model, &q, &qd, &mut full).unwrap();
                    let kin = &hc.kin;
                    assert_eq!(kin.origin, full.origin);
                    for b in 0..model.bodies.len() {
                        let (x, y) = (kin.x[b], full.x[b]);
                        worst.0 = worst.0.max(mat_gap(x.e, y.e));
                        worst.0 = worst.0.max((x.r - y.r).abs().max_element());
                        let (v, w) = (kin.v[b], full.v[b]);
                        worst.1 = worst.1.max((v.w - w.w).abs().max_element());
                        worst.1 = worst.1.max((v.v - w.v).abs().max_element());
                        let body = &model.bodies[b];
                        if body.nv > 0 && ad.is_active(&model, b) {
                            for k in body.v_offset..body.v_offset + body.nv {
                                let (s, t) = (kin.s[k], full.s[k]);
                                worst.2 = worst.2.max((s.w - t.w).abs().max_element());
                                worst.2 = worst.2.max((s.v - t.v).abs().max_element());
                            }
                            // The cluster: this body and the locked ones anchored to it.
                            let sum = (0..model.bodies.len())
                                .filter(|&c| hc.clusters.anchor[c] == b)
                                .fold(SpatialInertia::ZERO, |acc, c| acc + full.inertia[c]);
                            let gap = inertia_gap(&hc.clusters.inertia[b], &sum);
                            worst.3 = worst.3.max(gap / sum.mass.max(1.0));
                        } else {
                            assert_eq!(hc.clusters.inertia[b].mass, 0.0);
                        }
                    }
                }
                // The clusters of the first step served the next three.
                assert_eq!(hc.clusters.gen, Some(ad.hier.gen));
                eprintln!("floating {floating}, seed {seed}: gaps {worst:?}");
                assert!(
                    worst.0 < 1e-13 && worst.1 < 1e-12 && worst.2 < 1e-13 && worst.3 < 1e-12,
                    "floating {floating}, seed {seed}: pose, velocity, subspace, inertia gaps {worst:?}"
                );
            }
        }
    }
}
