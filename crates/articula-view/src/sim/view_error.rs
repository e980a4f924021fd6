//! The view-weighted error of a scene against its reference (`docs/view.md#view-error`):
//! how far, on the screen and in the world, the links the camera sees are from where the
//! reference run puts them.
//!
//! The camera at the common time classifies the **reference's** links (its poses, no motion
//! margin: what the camera sees now) with the scene's depth buffer. Each link weighs what the
//! scene's visibility weights make of it — 1 visible, `occluded_factor` occluded, 0 invisible —
//! and its position is the centre of its bounding sphere. The error is the weighted mean over
//! the links of every character of
//! - the **screen distance** (pixels at the scene's image size) between the link's projection
//!   in the two runs (a point at or behind the near plane is projected as if on it), and
//! - the **world distance** (m) between the two positions.
//!
//! Distance on the screen is what a viewer sees: a character far from the camera may drift by
//! centimetres and move a fraction of a pixel, one close to it by as much in many pixels.

use super::SceneSim;
use crate::camera::Camera;
use crate::error::ViewError;
use crate::visibility::{BodyView, Placed, Visibility};
use glam::{DMat3, DVec2, DVec3};

/// How far one scene's visible links are from another's ([`SceneSim::view_deviation`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ViewDeviation {
    /// Simulated time of the comparison (s).
    pub time: f64,
    /// Weighted mean screen distance (pixels at the scene's image size).
    pub pixels: f64,
    /// Weighted mean world distance (m).
    pub metres: f64,
    /// Largest screen distance of a link of non-zero weight (pixels).
    pub max_pixels: f64,
    /// Links of the reference the camera sees.
    pub visible_links: usize,
    /// Links of the reference in the view but hidden behind others.
    pub occluded_links: usize,
    /// The weights' sum (`visible_links + occluded_factor · occluded_links`); 0 when the
    /// camera sees no link (then both means are 0).
    pub weight: f64,
}

impl SceneSim<'_> {
    /// The view-weighted error of `other` against `self` as the reference, both at the same
    /// simulated time (they may step at different time steps): see the module's text. Both
    /// must run the same scene's characters (the same models in the same order); `other` is
    /// read only, and `self` keeps its states (the classification uses scratch of its own).
    pub fn view_deviation(&mut self, other: &SceneSim) -> Result<ViewDeviation, ViewError> {
        let time = self.time();
        if (other.time() - time).abs() > 1e-9 * time.abs().max(1.0) {
            return Err(ViewError::Camera(format!(
                "view error: the two runs are at different times ({time} s and {} s)",
                other.time()
            )));
        }
        let scene = self.scene;
        let n = self.bodies.len();
        if other.bodies.len() != n {
            return Err(ViewError::Camera(format!(
                "view error: the reference has {n} characters, the run {}",
                other.bodies.len()
            )));
        }
        let mut poses = (Vec::with_capacity(n), Vec::with_capacity(n));
        for (i, (r, o)) in self.bodies.iter().zip(&other.bodies).enumerate() {
            let (mr, mo) = (self.model(i), other.model(i));
            if r.model != o.model || mr.nq != mo.nq || mr.bodies.len() != mo.bodies.len() {
                return Err(ViewError::BodyState {
                    name: scene.placements[i].name.clone(),
                    message: format!(
                        "view error: model {} ({} links) in the reference, model {} ({} links) \
                         in the run",
                        r.model,
                        mr.bodies.len(),
                        o.model,
                        mo.bodies.len()
                    ),
                });
            }
            for (state, out) in [(&r.state, &mut poses.0), (&o.state, &mut poses.1)] {
                if state.q.len() != mr.nq {
                    return Err(ViewError::BodyState {
                        name: scene.placements[i].name.clone(),
                        message: format!("q has {} numbers, the model {}", state.q.len(), mr.nq),
                    });
                }
                let mut p = Vec::new();
                self.plans[r.model].poses(mr, &state.q, &mut p);
                out.push(p);
            }
        }
        let cam = scene.camera.at(time);
        let mut views: Vec<BodyView> = Vec::new();
        let (bodies, parents, reference) = (&self.bodies, &self.parents, &poses.0);
        let chunk = self.chunk();
        let body = |i: usize| Placed {
            volumes: &scene.models[bodies[i].model].volumes,
            poses: &reference[i],
            parents: &parents[bodies[i].model],
            margin: 0.0,
        };
        let threads = self.threads.clone();
        let classifier = &mut self.classifier;
        classifier.rasterize_with(&cam, &threads, chunk, n, &body, &mut views);
        classifier.occlude_with(&cam, &scene.visibility, &threads, chunk, &body, &mut views);
        let image = DVec2::new(scene.image.width as f64, scene.image.height as f64);
        let mut d = ViewDeviation {
            time,
            ..ViewDeviation::default()
        };
        let (mut px, mut m) = (0.0, 0.0);
        for (i, view) in views.iter().enumerate() {
            let volumes = &scene.models[bodies[i].model].volumes;
            for (k, class) in view.links.iter().enumerate() {
                let w = match class {
                    Visibility::Visible => 1.0,
                    Visibility::Occluded => scene.visibility.occluded_factor,
                    Visibility::Invisible => 0.0,
                };
                match class {
                    Visibility::Visible => d.visible_links += 1,
                    Visibility::Occluded => d.occluded_links += 1,
                    Visibility::Invisible => {}
                }
                if w == 0.0 {
                    continue;
                }
                let at = |(r, p): (DMat3, DVec3)| r * volumes[k].bound.0 + p;
                let (a, b) = (at(poses.0[i][k]), at(poses.1[i][k]));
                let s = (pixel(&cam, image, a) - pixel(&cam, image, b)).length();
                d.max_pixels = d.max_pixels.max(s);
                px += w * s;
                m += w * (a - b).length();
                d.weight += w;
            }
        }
        if d.weight > 0.0 {
            d.pixels = px / d.weight;
            d.metres = m / d.weight;
        }
        Ok(d)
    }
}

/// World point → pixel (x right, y down, origin top left) on an image of `size` pixels; a
/// point at or behind the near plane is projected as if on it.
fn pixel(cam: &Camera, size: DVec2, p: DVec3) -> DVec2 {
    let c = cam.to_camera(p);
    let z = c.z.max(cam.near);
    let t = cam.tan_half_fov();
    let ndc = DVec2::new(c.x / (z * t * cam.aspect), c.y / (z * t));
    DVec2::new(0.5 * (ndc.x + 1.0) * size.x, 0.5 * (1.0 - ndc.y) * size.y)
}

#[cfg(all(test, feature = "serde"))]
mod tests {
    use super::*;
    use crate::{SceneMethod, SceneOptions};
    use std::path::{Path, PathBuf};

    fn scene(bodies: &str) -> crate::LoadedScene {
        let models = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models");
        let text = format!(
            r#"{{"models": {{"h": "humanoid.urdf"}}, "bodies": [{bodies}],
                "camera": {{"eye": [0, 0, 1.5], "target": [10, 0, 1.5]}},
                "image": {{"width": 640, "height": 360}},
                "dt": 0.0016666666666666668, "gravity": [0, 0, 0]}}"#
        );
        SceneOptions::default()
            .parse(&text, Path::new("test.json"), &models)
            .unwrap()
    }

    #[test]
    fn a_pixel_is_where_the_camera_projects_it() {
        let s = scene(r#"{"name": "a", "model": "h", "position": [5, 0, 1.021]}"#);
        let cam = s.camera.at(0.0);
        let size = DVec2::new(640.0, 360.0);
        // On the axis: the image centre.
        let c = pixel(&cam, size, DVec3::new(7.0, 0.0, 1.5));
        assert!((c - DVec2::new(320.0, 180.0)).length() < 1e-9, "{c}");
        // `Camera::project` agrees inside the view (normalised coordinates to pixels).
        let p = DVec3::new(6.0, 0.7, 1.1);
        let (ndc, _) = cam.project(p).unwrap();
        let expect = DVec2::new((ndc.x + 1.0) * 320.0, (1.0 - ndc.y) * 180.0);
        assert!((pixel(&cam, size, p) - expect).length() < 1e-9);
    }

    #[test]
    fn a_shifted_character_deviates_by_its_shift() {
        // Two runs of one character 5 m in front of the camera; the second character of the
        // reference is behind the camera (invisible: weight 0, whatever its drift).
        let s = scene(
            r#"{"name": "a", "model": "h", "position": [5, 0, 1.021]},
               {"name": "b", "model": "h", "position": [-5, 0, 1.021]}"#,
        );
        let mut reference = SceneSim::new(&s).unwrap();
        let mut run = SceneSim::new(&s).unwrap();
        let same = reference.view_deviation(&run).unwrap();
        assert_eq!((same.pixels, same.metres, same.max_pixels), (0.0, 0.0, 0.0));
        assert!(same.visible_links > 10 && same.weight > 10.0, "{same:?}");
        // Move the whole of `a` by 1 cm sideways (−y: to the right on the screen) and `b`
        // by a metre: every link of `a` moves 1 cm, and on the screen by
        // 0.01 m · f / depth pixels, f = (H / 2) / tan(fov / 2).
        run.bodies[0].state.q[1] -= 0.01;
        run.bodies[1].state.q[1] -= 1.0;
        let d = reference.view_deviation(&run).unwrap();
        assert!((d.metres - 0.01).abs() < 1e-12, "{d:?}");
        let cam = s.camera.at(0.0);
        let f = 180.0 / cam.tan_half_fov();
        // Depths of `a`'s links: within its extent about 5 m.
        let (lo, hi) = (0.01 * f / 5.4, 0.01 * f / 4.6);
        assert!(
            d.pixels > lo && d.pixels < hi,
            "{} not in {lo}..{hi}",
            d.pixels
        );
        assert_eq!(
            d.visible_links + d.occluded_links,
            same.visible_links + same.occluded_links
        );
    }

    #[test]
    fn runs_at_different_times_or_of_different_scenes_are_errors() {
        let s = scene(r#"{"name": "a", "model": "h", "position": [5, 0, 1.021]}"#);
        let two = scene(
            r#"{"name": "a", "model": "h", "position": [5, 0, 1.021]},
               {"name": "b", "model": "h", "position": [6, 0, 1.021]}"#,
        );
        let mut reference = SceneSim::new(&s).unwrap();
        let mut run = SceneSim::new(&s).unwrap();
        run.set_method(SceneMethod::Exact(articula_dca::Method::Dca));
        run.step().unwrap();
        let e = reference.view_deviation(&run).unwrap_err();
        assert!(e.to_string().contains("different times"), "{e}");
        let other = SceneSim::new(&two).unwrap();
        let e = reference.view_deviation(&other).unwrap_err();
        assert!(e.to_string().contains("1 characters, the run 2"), "{e}");
    }
}
