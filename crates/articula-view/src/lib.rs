//! # articula-view
//!
//! View-dependent adaptive dynamics (`docs/view.md`): a [`Camera`] and its frustum, per-body
//! bounding [`volumes`], [`visibility`] classes (visible, occluded, invisible) turned into joint
//! weights, and scenes of many articulated bodies under one joint budget — read from JSON
//! files ([`load_scene`], feature `serde`) or built in code ([`SceneBuilder`]), then stepped
//! by [`SceneSim`] and rendered to PNG frames ([`render`], feature `render`). Every invalid
//! scene is a [`SceneError`] naming its field, never a panic.
//!
//! ```
//! use articula_view::Camera;
//! use glam::DVec3;
//!
//! // A camera 10 m back along −x, looking at the origin, 60° vertical field of view.
//! let cam = Camera::look_at(DVec3::new(-10.0, 0.0, 1.0), DVec3::ZERO, DVec3::Z, 60.0, 16.0 / 9.0, 0.1, 100.0)
//!     .unwrap();
//! let frustum = cam.frustum();
//! assert!(frustum.sphere(DVec3::ZERO, 0.5)); // in front: visible
//! assert!(!frustum.sphere(DVec3::new(-20.0, 0.0, 0.0), 0.5)); // behind the camera
//! // A 1 m sphere twice as far covers about half the screen height.
//! let (near, far) = (cam.projected_size(DVec3::ZERO, 1.0), cam.projected_size(DVec3::new(10.0, 0.0, 1.0), 1.0));
//! assert!((near / far - 2.0).abs() < 0.1);
//! ```

pub mod camera;
pub mod render;
pub mod scene_file;
pub mod sim;
pub mod visibility;
pub mod volumes;

pub use camera::{Camera, CameraPath, Frustum, Keyframe, Plane};
#[cfg(feature = "serde")]
pub use scene_file::{load_scene, parse_scene};
pub use scene_file::{
    BodySpec, CameraRig, CameraSpec, CrowdSpec, ImageSpec, KeySpec, LoadedScene, Placement, Push,
    PushSpec, SceneBuilder, SceneError, SceneModel, SceneSpec, SpringSpec, Targets, VelocitySpec,
    VisibilitySpec,
};
pub use sim::{global_selection, GlobalSelection, SceneSim, SceneSimError, SceneStep, SimBody};
pub use visibility::{
    body_pose, body_poses, BodyView, Classifier, DepthBuffer, Placed, PosePlan, Visibility,
    VisibilitySettings,
};
pub use volumes::{body_volumes, inertia_box, symmetric_eigen, BodyVolumes, Volume};

/// Errors of the view layer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ViewError {
    /// An unusable camera.
    #[error("camera: {0}")]
    Camera(String),
}
