//! # articula-view
//!
//! View-dependent adaptive dynamics (DESIGN §7): a [`Camera`] and its frustum, per-body
//! bounding [`volumes`], [`visibility`] classes (visible, occluded, invisible) turned into joint
//! weights, and scenes of many articulated bodies.

pub mod camera;
pub mod render;
pub mod scene_file;
pub mod sim;
pub mod visibility;
pub mod volumes;

pub use camera::{Camera, CameraPath, Frustum, Keyframe, Plane};
pub use scene_file::{
    load_scene, parse_scene, CameraRig, LoadedScene, Placement, Push, SceneError, SceneSpec,
};
pub use sim::{global_selection, GlobalSelection, SceneSim, SceneSimError, SceneStep, SimBody};
pub use visibility::{
    body_poses, BodyView, Classifier, DepthBuffer, Placed, Visibility, VisibilitySettings,
};
pub use volumes::{body_volumes, inertia_box, symmetric_eigen, BodyVolumes, Volume};

/// Errors of the view layer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ViewError {
    /// An unusable camera.
    #[error("camera: {0}")]
    Camera(String),
}
