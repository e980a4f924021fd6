//! The culling baseline ([`SceneMethod::Culling`], `docs/view.md#culling`): what a scene
//! costs and how far it drifts when the camera decides only *whether* a character is
//! simulated, not how much of it.
//!
//! At every re-selection (every `reselect_every` steps, the first included) the camera
//! classifies every character from its pose-only kinematics, with the same motion margins
//! and depth buffer as the adaptive scene. A character in view (visible or occluded) then gets
//! every joint free — its hybrid body is the whole body, whose step is exact dynamics (the
//! reduced-tree ABA of the adaptive step over every joint) — and a character out of view gets
//! none: its joints are locked by the same momentum-keeping impulses and it moves as one rigid
//! body (on a floor, the hybrid contact step of a body with no active joint), exactly as the
//! adaptive scene moves its invisible characters. No exact solve, no metric, no queue and no
//! budget: the classic view-dependent culling of animation systems, in the scene's own code.

use super::{
    first_error, free_exactly, placed, spring_torques, SceneMethod, SceneSim, SceneStep, SimBody,
    Worker,
};
use crate::error::ViewError;
use crate::scene_file::LoadedScene;
use crate::visibility::Visibility;

impl SceneSim<'_> {
    /// [`SceneSim::step`] by the culling baseline ([`SceneMethod::Culling`]).
    pub(super) fn step_culling(&mut self) -> Result<SceneStep, ViewError> {
        debug_assert_eq!(self.method, SceneMethod::Culling);
        let scene = self.scene;
        let t = self.time();
        let forced = std::mem::take(&mut self.reselect_next);
        let reselect = forced || self.steps.is_multiple_of(scene.reselect_every as u64);
        let (threads, shared) = (self.threads.clone(), self.shared);
        let chunk = self.chunk();
        if reselect {
            self.set_margins();
            let (springs, plans) = (&self.springs, &self.plans);
            threads.for_each_chunk(&mut self.bodies, &self.workers, chunk, |_, _, run| {
                for b in run.iter_mut() {
                    b.set_pushes(scene, &plans[b.model], t);
                    spring_torques(&springs[b.model], &mut b.state);
                    let model = &scene.models[b.model].model;
                    plans[b.model].poses(model, &b.state.q, &mut b.poses);
                }
            });
            self.add_push_work();
            {
                let cam = scene.camera.at(t);
                let n = self.bodies.len();
                let placed = placed(scene, &self.bodies, &self.parents, &self.margins);
                let (settings, views) = (&scene.visibility, &mut self.views);
                let classifier = &mut self.classifier;
                classifier.rasterize_with(&cam, &threads, chunk, n, &placed, views);
                classifier.occlude_with(&cam, settings, &threads, chunk, &placed, views);
            }
            let (mut classes, mut link_classes) = ([0; 3], [0; 3]);
            for view in &self.views {
                for c in &view.links {
                    link_classes[*c as usize] += 1;
                }
                classes[view.summary() as usize] += 1;
            }
            let (views, first_step) = (&self.views, self.steps == 0 || forced);
            threads.for_each_chunk(&mut self.bodies, &self.workers, chunk, |w, first, run| {
                for (j, b) in run.iter_mut().enumerate() {
                    let i = first + j;
                    let in_view = views[i].summary() != Visibility::Invisible;
                    if let Err(e) = cull(scene, shared, in_view, first_step, b, i, w) {
                        w.fail(i, e);
                    }
                }
            });
            first_error(&mut self.workers)?;
            self.last = SceneStep {
                reselected: true,
                classes,
                link_classes,
                ..SceneStep::default()
            };
        }
        self.step_bodies(reselect)
    }
}

/// Body `i` (`b`) in view (`in_view`: every joint free) or out of it (every joint locked):
/// its new hybrid body when its active joints are not already those (or at the first step).
fn cull(
    scene: &LoadedScene,
    shared: bool,
    in_view: bool,
    first_step: bool,
    b: &mut SimBody,
    i: usize,
    w: &mut Worker,
) -> Result<(), ViewError> {
    let model = &scene.models[b.model].model;
    let tree = &model.assembly;
    let internal = model
        .nv
        .saturating_sub(if model.floating_base { 6 } else { 0 });
    b.allocation = if in_view { internal } else { 0 };
    // Nothing is measured: no metric is computed, so no error is left unselected.
    b.error = 0.0;
    b.metrics.clear();
    b.unweighted = !in_view;
    // A floating base's root node is always free (`Adaptive::set_active`).
    let wanted = |j: usize| in_view || model.floating_base && tree.joint_node[j] == tree.root();
    let same = (0..model.bodies.len()).all(|j| b.adaptive.is_active(model, j) == wanted(j));
    b.changed = first_step || !same;
    if !b.changed {
        return Ok(());
    }
    let scratch = shared.then(|| &mut w.scratch[b.model]);
    free_exactly(scene, scratch, b, i, |_| in_view)
}

#[cfg(all(test, feature = "serde"))]
mod tests {
    use crate::{SceneMethod, SceneOptions, SceneSim};
    use std::path::{Path, PathBuf};

    /// Two pushed humanoids in view and one behind the camera, on their pose springs on the
    /// floor under gravity, with a budget of the two in view's joints.
    fn scene() -> crate::LoadedScene {
        let models = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models");
        let text = r#"{"models": {"h": "humanoid.urdf"},
            "bodies": [{"name": "a", "model": "h", "position": [5, -0.5, 1.021], "rpy": [0, 0, 3.14]},
                       {"name": "behind", "model": "h", "position": [-6, 0, 1.021]},
                       {"name": "b", "model": "h", "position": [6, 0.6, 1.021], "rpy": [0.1, 0, 3.0]}],
            "camera": {"eye": [0, 0, 1.5], "target": [10, 0, 1]},
            "budget": 68, "dt": 0.0016666666666666668, "reselect_every": 5,
            "gravity": [0, 0, -9.81],
            "joint_springs": {"frequency_hz": 2.0, "damping_ratio": 0.2},
            "pushes": [{"bodies": "all", "link": "chest", "point": [0.05, 0.1, 0.2],
                        "force": [-80, 40, 10], "t0": 0.0, "t1": 0.05}],
            "ground": {"height": 0, "friction": 1}}"#;
        SceneOptions::default()
            .parse(text, Path::new("test.json"), &models)
            .unwrap()
    }

    fn largest_difference(a: &SceneSim, b: &SceneSim, body: usize) -> f64 {
        let (x, y) = (&a.bodies[body].state, &b.bodies[body].state);
        x.q.iter()
            .chain(&x.qd)
            .zip(y.q.iter().chain(&y.qd))
            .fold(0.0f64, |m, (u, v)| m.max((u - v).abs()))
    }

    #[test]
    fn culling_is_exact_in_view_and_rigid_out_of_it() {
        let s = scene();
        let mut culling = SceneSim::new(&s).unwrap();
        culling.set_method(SceneMethod::Culling);
        let mut exact = SceneSim::new(&s).unwrap();
        exact.set_method(SceneMethod::Exact(articula_dca::Method::Dca));
        // The adaptive scene with a budget of the in-view joints: the same two exact
        // characters, the same rigid one behind the camera.
        let mut adaptive = SceneSim::new(&s).unwrap();
        for k in 0..150 {
            let c = culling.step().unwrap();
            exact.step().unwrap();
            adaptive.step().unwrap();
            assert_eq!(c.active_total, 68, "step {k}: {c:?}");
            assert_eq!(c.classes[2], 1, "step {k}: {c:?}");
            assert_eq!(c.total_error, 0.0);
        }
        // The characters in view against the exact reference (DCA, every joint): rounding.
        for body in [0, 2] {
            let d = largest_difference(&culling, &exact, body);
            assert!(d < 1e-8, "body {body}: {d:e}");
        }
        // Behind the camera: every internal joint locked at rest, as the adaptive scene
        // moves it, while the exact reference has it fall away from its pose.
        let behind = &culling.bodies[1].state;
        assert!(behind.qd[6..].iter().all(|v| *v == 0.0));
        let d = largest_difference(&culling, &adaptive, 1);
        assert!(d < 1e-9, "behind the camera: {d:e}");
        let d = largest_difference(&culling, &exact, 1);
        assert!(d > 1e-3, "the exact reference moves its joints: {d:e}");
    }

    #[test]
    fn switching_to_culling_reselects_at_the_next_step() {
        let s = scene();
        let mut sim = SceneSim::new(&s).unwrap();
        sim.set_method(SceneMethod::Exact(articula_dca::Method::Dca));
        for _ in 0..7 {
            sim.step().unwrap();
        }
        sim.set_method(SceneMethod::Culling);
        let step = sim.step().unwrap();
        assert!(step.reselected && step.active_total == 68, "{step:?}");
        assert_eq!(step.classes, [2, 0, 1]);
    }
}
