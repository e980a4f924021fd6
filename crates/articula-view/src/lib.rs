//! # articula-view
//!
//! View-dependent adaptive dynamics (docs/design.md#view): a [`Camera`] and its frustum, per-body
//! bounding [`BodyVolumes`], [`Visibility`] classes (visible, occluded, invisible) turned into joint
//! weights, and scenes of many articulated bodies under one joint budget — read from JSON
//! files ([`load_scene`], [`SceneOptions`], feature `serde`) or built in code
//! ([`SceneBuilder`]), then stepped by [`SceneSim`] and rendered to PNG frames ([`render`], feature `render`). Every invalid
//! scene is a [`ViewError`] naming its field, never a panic.
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

mod camera;
mod error;
pub mod render;
mod scene_file;
mod sim;
mod visibility;
mod volumes;

pub use camera::{Camera, CameraPath, Frustum, Keyframe, Plane};
pub use error::ViewError;
#[cfg(feature = "serde")]
pub use scene_file::load_scene;
pub use scene_file::{
    body_memory_estimate, BodySpec, CameraRig, CameraSpec, CrowdSpec, GroundSpec, ImageSpec,
    KeySpec, LoadedScene, Placement, Push, PushSpec, SceneBuilder, SceneModel, SceneOptions,
    SceneSpec, SpringSpec, Targets, VelocitySpec, VisibilitySpec, DEFAULT_SCENE_MEMORY_LIMIT,
    MAX_SCENE_BYTES,
};
pub use sim::pose_springs;
pub use sim::{
    combine_state_hashes, combine_steps, merge_candidates, merge_depths, Candidate, Candidates,
    DepthMessage, SceneEnergy, SceneMethod, SceneShard, SceneSim, SceneStep, ShardRange, ShardStep,
    SimBody, ViewDeviation,
};
pub use visibility::{BodyView, PosePlan, Visibility, VisibilitySettings};
pub use volumes::{BodyVolumes, Volume};
