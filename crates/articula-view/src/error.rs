//! The view layer's error: an unusable camera, a scene file that cannot be read or used, a
//! body whose dynamics failed while a scene stepped, a frame that could not be written.

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
    /// A scene whose running memory, estimated before any body is placed
    /// ([`crate::body_memory_estimate`] per body), exceeds the limit
    /// ([`crate::DEFAULT_SCENE_MEMORY_LIMIT`] unless set).
    #[error(
        "scene file {path}: {bodies} bodies would take about {} ({estimate} bytes), more than \
         the memory limit of {} ({limit} bytes)",
        articula_dca::human_bytes(*estimate),
        articula_dca::human_bytes(*limit)
    )]
    TooLarge {
        /// The scene file.
        path: String,
        /// Bodies in the scene.
        bodies: u64,
        /// The estimate (bytes).
        estimate: u64,
        /// The limit (bytes).
        limit: u64,
    },
    /// A frame that could not be rendered or written.
    #[error("frame: {0}")]
    Frame(String),
    /// A scene split over shards ([`crate::SceneShard`]) whose parts do not fit together: a
    /// shard count or range, a budget, tolerance or step that differs between the shards and
    /// the merge, a message that is not one, or a call out of the re-selection's order.
    #[error("sharded scene: {0}")]
    Shard(String),
}
