//! # articula-view
//!
//! View-dependent adaptive dynamics (docs/design.md#view): a [`Camera`] and its frustum, per-body
//! bounding [`BodyVolumes`], [`Visibility`] classes (visible, occluded, invisible) turned into joint
//! weights, and scenes of many articulated bodies under one joint budget — read from JSON
//! files ([`load_scene`], feature `serde`) or built in code ([`SceneBuilder`]), then stepped
//! by [`SceneSim`] and rendered to PNG frames ([`render`], feature `render`). Every invalid
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
pub mod render;
mod scene_file;
mod sim;
mod visibility;
mod volumes;

pub use camera::{Camera, CameraPath, Frustum, Keyframe, Plane};
#[cfg(feature = "serde")]
pub use scene_file::{load_scene, load_scene_with, parse_scene, parse_scene_with};
pub use scene_file::{
    BodySpec, CameraRig, CameraSpec, CrowdSpec, ImageSpec, KeySpec, LoadedScene, Placement, Push,
    PushSpec, SceneBuilder, SceneModel, SceneSpec, SpringSpec, Targets, VelocitySpec,
    VisibilitySpec,
};
pub use sim::{SceneSim, SceneStep, SimBody};
pub use visibility::{BodyView, Visibility, VisibilitySettings};
pub use volumes::{BodyVolumes, Volume};

/// Everything that can go wrong in the view layer: an unusable camera, a scene file that
/// cannot be read or used, a body whose dynamics failed while a scene stepped.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// An unusable camera or camera path.
    #[error("camera: {0}")]
    Camera(String),
    /// The scene file could not be read.
    #[error("cannot read scene file {path}: {message}")]
    Io {
        /// The path.
        path: String,
        /// The system's message.
        message: String,
    },
    /// Not JSON, or JSON of the wrong shape.
    #[error("scene file {path}: {field}: {message}")]
    Json {
        /// The scene file.
        path: String,
        /// The JSON path of the offending value (`.` for the top level).
        field: String,
        /// What is wrong (with line and column).
        message: String,
    },
    /// A value of the right type that cannot be used.
    #[error("scene file {path}: {field}: {message}")]
    Invalid {
        /// The scene file.
        path: String,
        /// The field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A model that cannot be loaded.
    #[error("scene file {path}: models.{name}: {model_path}: {error}")]
    Model {
        /// The scene file.
        path: String,
        /// The model's key in `models`.
        name: String,
        /// The resolved URDF path.
        model_path: String,
        /// The loader's error.
        error: Box<articula_model::ModelError>,
    },
    /// A body's dynamics failed while the scene stepped (`what` is `body`, or `model` for a
    /// failure in a model's shared workspace).
    #[error("{what} '{name}': {error}")]
    Dynamics {
        /// `"body"` or `"model"`.
        what: &'static str,
        /// The body's placement name or the model's key.
        name: String,
        /// The adaptive solver's error.
        error: articula_adaptive::AdaptiveError,
    },
    /// A body whose state no longer fits its model (a `q`, `q̇` or `τ` of the wrong length, or
    /// a model index out of range) when the scene steps.
    #[error("body '{name}': {message}")]
    BodyState {
        /// The body's placement name.
        name: String,
        /// What does not fit.
        message: String,
    },
    /// A frame that could not be rendered or written.
    #[error("frame: {0}")]
    Frame(String),
}
