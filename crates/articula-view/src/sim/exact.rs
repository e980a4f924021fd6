//! The scene's exact reference: every body stepped by exact forward dynamics
//! ([`SceneMethod::Exact`], `docs/view.md#exact-reference`).
//!
//! The same scene as the adaptive run — the same pose springs, pushes, gravity, floor, time
//! step and integrator (semi-implicit Euler) — with no camera and no budget: each body's step
//! is articula-dca's [`step`] (with a floor, its contact step [`step_with_contact`]) by the
//! chosen method, every joint moving. It is what the adaptive scene approximates, so its time
//! per step is the reference of the crowd's speed-up and its trajectory that of the crowd's
//! error.

use super::{first_error, spring_torques, take_sums, SceneSim, SceneStep, SimBody, Worker};
use crate::error::ViewError;
use crate::scene_file::LoadedScene;
use articula_adaptive::AdaptiveError;
use articula_dca::{step, step_with_contact, ContactError, ContactSettings, Integrator, Method};
use articula_spatial::SpatialForce;

/// How a scene steps its bodies ([`SceneSim::set_method`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SceneMethod {
    /// View-dependent adaptive dynamics: one scene-wide joint budget spent where the camera
    /// sees the largest weighted acceleration metric (the default).
    #[default]
    Adaptive,
    /// Exact forward dynamics by this method on every body, every joint moving: no camera, no
    /// selection. The reference the adaptive scene is measured against.
    Exact(Method),
    /// The culling baseline (`docs/view.md#culling`): at every re-selection the camera
    /// decides which characters are in view (visible or occluded); those step with every
    /// joint free (exact dynamics), the others with every joint locked (one rigid body, as
    /// the adaptive scene moves its invisible characters). No metric, no queue, no budget.
    Culling,
}

impl SceneSim<'_> {
    /// Sets how the bodies are stepped from the next step on (default
    /// [`SceneMethod::Adaptive`]). Switching to [`SceneMethod::Exact`] keeps every state as
    /// it is; switching to [`SceneMethod::Adaptive`] or [`SceneMethod::Culling`] re-selects
    /// at the next step.
    pub fn set_method(&mut self, method: SceneMethod) {
        if method != self.method && !matches!(method, SceneMethod::Exact(_)) {
            // The hybrid bodies no longer match the states: the next step re-selects them all.
            self.reselect_next = true;
        }
        self.method = method;
    }

    /// How the bodies are stepped.
    pub fn method(&self) -> SceneMethod {
        self.method
    }

    /// [`SceneSim::step`] by exact forward dynamics on every body.
    pub(super) fn step_exact(&mut self, method: Method) -> Result<SceneStep, ViewError> {
        let scene = self.scene;
        let t = self.time();
        let threads = self.threads.clone();
        let chunk = self.chunk();
        let settings = scene.contact_settings();
        let (springs, plans) = (&self.springs, &self.plans);
        threads.for_each_chunk(&mut self.bodies, &self.workers, chunk, |w, first, run| {
            for (j, b) in run.iter_mut().enumerate() {
                let i = first + j;
                b.set_pushes(scene, &plans[b.model], t);
                spring_torques(&springs[b.model], &mut b.state);
                if let Err(e) = exact_step(scene, method, &settings, b, i, w) {
                    w.fail(i, e);
                }
            }
        });
        let mut out = SceneStep::default();
        take_sums(&mut self.workers, &mut out);
        self.add_push_work();
        first_error(&mut self.workers)?;
        self.steps += 1;
        self.last_active = out.active_total;
        Ok(out)
    }
}

/// One exact step of body `i` (`b`, its springs' torques and this step's forces set) by
/// `method`, with the floor of `settings` when the scene has one; adds its degrees of freedom
/// and contact figures to worker `w`'s sums.
fn exact_step(
    scene: &LoadedScene,
    method: Method,
    settings: &ContactSettings,
    b: &mut SimBody,
    i: usize,
    w: &mut Worker,
) -> Result<(), ViewError> {
    let model = &scene.models[b.model].model;
    let state = &mut b.state;
    // The step takes the wrenches as a dense array in the state (empty: none); it is emptied
    // again after (the body's `f_ext` stays empty between steps, as documented).
    if !b.forces.is_empty() {
        state.f_ext.resize(model.bodies.len(), SpatialForce::ZERO);
        for &(k, f) in &b.forces {
            state.f_ext[k] = f;
        }
    }
    // The worker's workspace of the model (one copy per thread stays in the core's caches;
    // nothing in it carries over from one step to the next).
    let data = &mut w.exact[b.model];
    let r = match &mut b.contact {
        Some(hc) => {
            // The worker's step buffers of the model (the warm starts stay the body's).
            let scratch = w.contact[b.model].contact();
            hc.contact.swap_scratch(scratch);
            let r = step_with_contact(
                model,
                data,
                &mut hc.contact,
                state,
                method,
                scene.dt,
                settings,
            );
            hc.contact.swap_scratch(scratch);
            w.add_contact(&hc.contact.stats);
            r.map_err(|e| match e {
                ContactError::Dynamics(e) => AdaptiveError::Dynamics(e),
                e => AdaptiveError::Setting(e.to_string()),
            })
        }
        None => step(
            model,
            data,
            state,
            method,
            Integrator::SemiImplicitEuler,
            scene.dt,
        )
        .map_err(AdaptiveError::Dynamics),
    };
    state.f_ext.clear();
    b.active = model
        .nv
        .saturating_sub(if model.floating_base { 6 } else { 0 });
    b.rigid = None;
    w.active += b.active;
    r.map_err(|e| super::body_error(scene, i, e))
}
