//! Scene files (JSON): models, placements (single bodies and crowds), camera, budget, pushes.
//!
//! ```json
//! {
//!   "models": { "humanoid": "../humanoid.urdf" },
//!   "bodies": [ { "name": "hero", "model": "humanoid", "position": [4, 0, 1.2],
//!                 "rpy": [0, 0, 3.14], "velocity": { "linear": [0, 0, 0], "angular": [0, 0, 0] } } ],
//!   "crowds": [ { "name": "crowd", "model": "humanoid", "rows": 10, "columns": 20,
//!                 "origin": [6, -19, 1.2], "spacing": [2, 2], "jitter": 0.4, "seed": 7 } ],
//!   "camera": { "eye": [0, 0, 1.7], "target": [10, 0, 1.2], "fov_y_deg": 60 },
//!   "budget": 2000,
//!   "pushes": [ { "bodies": "all", "link": "chest", "point": [0, 0, 0.14],
//!                 "force": [400, 0, 0], "t0": 0, "t1": 0.2 } ]
//! }
//! ```
//! Paths of models are relative to the scene file. Every error names the file and the field
//! (`crowds[0].rows`, `pushes[2].link`, ...) and never panics. See `docs/view.md` for every
//! field.

use crate::camera::{Camera, CameraPath, Keyframe};
use crate::error::ViewError;
use crate::visibility::VisibilitySettings;
use crate::volumes::{body_volumes, BodyVolumes};
use articula_dca::SplitMix64;
use articula_dca::{ContactSettings, Ground};
use articula_model::{InertiaPolicy, LoadOptions, Model};
use glam::{DMat3, DQuat, DVec3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// `[x, y, z]`.
type V3 = [f64; 3];

/// The top level of a scene file.
#[derive(Clone, Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SceneSpec {
    /// Model name → URDF path (relative to the scene file).
    pub models: BTreeMap<String, String>,
    /// Single bodies.
    #[cfg_attr(feature = "serde", serde(default))]
    pub bodies: Vec<BodySpec>,
    /// Crowds: grids of bodies.
    #[cfg_attr(feature = "serde", serde(default))]
    pub crowds: Vec<CrowdSpec>,
    /// The camera.
    pub camera: CameraSpec,
    /// Scene-wide budget of active joints per step (none: unlimited).
    #[cfg_attr(feature = "serde", serde(default))]
    pub budget: Option<usize>,
    /// Scene-wide tolerance on the weighted acceleration metric left unsimulated.
    #[cfg_attr(feature = "serde", serde(default))]
    pub tolerance: Option<f64>,
    /// Time step (s).
    #[cfg_attr(feature = "serde", serde(default = "default_dt"))]
    pub dt: f64,
    /// Visibility and joint selection are redone every this many steps.
    #[cfg_attr(feature = "serde", serde(default = "one"))]
    pub reselect_every: usize,
    /// Gravity (m/s², world).
    #[cfg_attr(feature = "serde", serde(default = "default_gravity"))]
    pub gravity: V3,
    /// How visibility becomes weights.
    #[cfg_attr(feature = "serde", serde(default))]
    pub visibility: VisibilitySpec,
    /// Timed pushes.
    #[cfg_attr(feature = "serde", serde(default))]
    pub pushes: Vec<PushSpec>,
    /// Rendered image size (pixels).
    #[cfg_attr(feature = "serde", serde(default))]
    pub image: ImageSpec,
    /// Springs and dampers holding every internal joint near its neutral angle (none by
    /// default).
    #[cfg_attr(feature = "serde", serde(default))]
    pub joint_springs: Option<SpringSpec>,
    /// A horizontal floor the bodies stand on and fall to (none by default: no contact).
    #[cfg_attr(feature = "serde", serde(default))]
    pub ground: Option<GroundSpec>,
}

/// The floor `z = height` (`docs/contact.md`): hard, unilateral contact of every body's
/// contact spheres with Coulomb friction; the models' URDF joint limits are enforced with it.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct GroundSpec {
    /// Height of the floor (m, world z).
    #[cfg_attr(feature = "serde", serde(default))]
    pub height: f64,
    /// Coulomb friction coefficient μ ≥ 0 (default 1).
    #[cfg_attr(feature = "serde", serde(default = "unit"))]
    pub friction: f64,
    /// Restitution 0 ≤ e ≤ 1 (default 0: inelastic impacts).
    #[cfg_attr(feature = "serde", serde(default))]
    pub restitution: f64,
    /// Each contact solve stops once no row velocity changes by more than this, or every
    /// condition holds to it (m/s of residual approach or slip velocity, > 0; default
    /// [`GroundSpec::TOLERANCE`]).
    #[cfg_attr(feature = "serde", serde(default = "ground_tolerance"))]
    pub tolerance: f64,
    /// … or after this many Gauss–Seidel sweeps (≥ 1; default [`GroundSpec::MAX_ITERATIONS`]).
    #[cfg_attr(feature = "serde", serde(default = "ground_max_iterations"))]
    pub max_iterations: usize,
}

impl GroundSpec {
    /// The default solve tolerance of a scene's contact (m/s): a residual of a micrometre per
    /// second is far below the position slop, so characters stand without creeping (the
    /// library's default, 1e-9 m/s, is for known answers).
    pub const TOLERANCE: f64 = 1e-6;

    /// The default cap on a scene's contact sweeps (the library's: 200).
    pub const MAX_ITERATIONS: usize = 50;

    /// A floor at `height` with the defaults: friction 1, no restitution, the default
    /// tolerance and sweep cap.
    pub fn at(height: f64) -> GroundSpec {
        GroundSpec {
            height,
            friction: 1.0,
            restitution: 0.0,
            tolerance: Self::TOLERANCE,
            max_iterations: Self::MAX_ITERATIONS,
        }
    }

    /// The floor as articula-dca's [`Ground`].
    pub fn ground(&self) -> Ground {
        Ground {
            friction: self.friction,
            restitution: self.restitution,
            ..Ground::horizontal(self.height)
        }
    }

    /// The first field out of its range, and why.
    fn problem(&self) -> Option<(&'static str, &'static str)> {
        if !(self.height.is_finite() && self.height.abs() <= MAX_DISTANCE) {
            Some(("height", "must be finite, at most 1e6 m from 0"))
        } else if !(self.friction.is_finite() && self.friction >= 0.0) {
            Some(("friction", "must be a non-negative number"))
        } else if !(0.0..=1.0).contains(&self.restitution) {
            Some(("restitution", "must lie in [0, 1]"))
        } else if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            Some(("tolerance", "must be a positive number (m/s)"))
        } else if self.max_iterations == 0
            || self.max_iterations > articula_dca::CONTACT_MAX_ITERATIONS
        {
            Some(("max_iterations", "must lie in 1..=10000"))
        } else {
            None
        }
    }
}

fn unit() -> f64 {
    1.0
}

fn ground_tolerance() -> f64 {
    GroundSpec::TOLERANCE
}

fn ground_max_iterations() -> usize {
    GroundSpec::MAX_ITERATIONS
}

/// Pose springs: each internal degree of freedom `i` gets `τᵢ = −kᵢ qᵢ − cᵢ q̇ᵢ` with
/// `kᵢ = ω² Mᵢᵢ`, `cᵢ = 2 ζ ω Mᵢᵢ`, `ω = 2π frequency_hz`, `Mᵢᵢ` the joint-space inertia of the
/// degree of freedom in the neutral pose: every joint oscillates near the same frequency, so
/// light links are no stiffer for the integrator than heavy ones. Ragdolls without joint
/// limits otherwise swing their composed 3-axis joints through gimbal lock.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SpringSpec {
    /// Natural frequency (Hz).
    pub frequency_hz: f64,
    /// Damping ratio (1: critical).
    pub damping_ratio: f64,
}

fn default_dt() -> f64 {
    1.0 / 60.0
}
fn one() -> usize {
    1
}
fn default_gravity() -> V3 {
    [0.0, 0.0, -9.81]
}

/// A body's initial velocity (world frame): its root link origin's linear velocity and its
/// angular velocity.
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct VelocitySpec {
    /// m/s.
    #[cfg_attr(feature = "serde", serde(default))]
    pub linear: V3,
    /// rad/s.
    #[cfg_attr(feature = "serde", serde(default))]
    pub angular: V3,
}

/// One placed body ([`BodySpec::new`]).
#[derive(Clone, Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct BodySpec {
    /// Its name (default `bodyN`, N its index among `bodies`).
    #[cfg_attr(feature = "serde", serde(default))]
    pub name: Option<String>,
    /// A key of `models`.
    pub model: String,
    /// Root link position (world).
    pub position: V3,
    /// Root link orientation: roll, pitch, yaw (rad, URDF convention).
    #[cfg_attr(feature = "serde", serde(default))]
    pub rpy: V3,
    /// Initial velocity.
    #[cfg_attr(feature = "serde", serde(default))]
    pub velocity: VelocitySpec,
}

/// A grid of bodies: `rows` along the world x axis (away from a camera looking along +x),
/// `columns` along y, each position jittered uniformly in a square of ±`jitter` (seeded), each
/// yaw jittered by ±`yaw_jitter`. Bodies are named `NAME[r,c]`.
#[derive(Clone, Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct CrowdSpec {
    /// Name (default `crowdN`).
    #[cfg_attr(feature = "serde", serde(default))]
    pub name: Option<String>,
    /// A key of `models`.
    pub model: String,
    /// Rows (along x).
    pub rows: usize,
    /// Columns (along y).
    pub columns: usize,
    /// Position of body [0, 0].
    pub origin: V3,
    /// Spacing between rows (x) and between columns (y), metres.
    pub spacing: [f64; 2],
    /// Half width of the uniform position jitter (m).
    #[cfg_attr(feature = "serde", serde(default))]
    pub jitter: f64,
    /// Seed of the jitter.
    #[cfg_attr(feature = "serde", serde(default))]
    pub seed: u64,
    /// Yaw of every body (rad).
    #[cfg_attr(feature = "serde", serde(default))]
    pub yaw: f64,
    /// Half width of the uniform yaw jitter (rad).
    #[cfg_attr(feature = "serde", serde(default))]
    pub yaw_jitter: f64,
    /// Initial velocity of every body.
    #[cfg_attr(feature = "serde", serde(default))]
    pub velocity: VelocitySpec,
}

/// One keyframe of a camera path.
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct KeySpec {
    /// Time (s).
    pub t: f64,
    /// Eye.
    pub eye: V3,
    /// Target.
    pub target: V3,
}

/// The camera: fixed (`eye` and `target`) or moving (`path`).
#[derive(Clone, Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct CameraSpec {
    /// Fixed eye.
    #[cfg_attr(feature = "serde", serde(default))]
    pub eye: Option<V3>,
    /// Fixed target.
    #[cfg_attr(feature = "serde", serde(default))]
    pub target: Option<V3>,
    /// Keyframes of a moving camera.
    #[cfg_attr(feature = "serde", serde(default))]
    pub path: Option<Vec<KeySpec>>,
    /// Up vector.
    #[cfg_attr(feature = "serde", serde(default = "default_up"))]
    pub up: V3,
    /// Vertical field of view, degrees.
    #[cfg_attr(feature = "serde", serde(default = "default_fov"))]
    pub fov_y_deg: f64,
    /// Near plane (m).
    #[cfg_attr(feature = "serde", serde(default = "default_near"))]
    pub near: f64,
    /// Far plane (m).
    #[cfg_attr(feature = "serde", serde(default = "default_far"))]
    pub far: f64,
}

fn default_up() -> V3 {
    [0.0, 0.0, 1.0]
}
fn default_fov() -> f64 {
    60.0
}
fn default_near() -> f64 {
    0.1
}
fn default_far() -> f64 {
    500.0
}

/// Visibility weights.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct VisibilitySpec {
    /// Weight factor of occluded links.
    pub occluded_factor: f64,
    /// Projected size (fraction of the image height) from which a body gets full weight.
    pub full_detail_size: f64,
    /// Depth buffer cells `[width, height]`.
    pub depth_buffer: [usize; 2],
}

impl Default for VisibilitySpec {
    fn default() -> Self {
        let d = VisibilitySettings::default();
        VisibilitySpec {
            occluded_factor: d.occluded_factor,
            full_detail_size: d.full_detail_size,
            depth_buffer: [d.depth_width, d.depth_height],
        }
    }
}

/// Image size of rendered frames (its ratio is the camera's aspect ratio).
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct ImageSpec {
    /// Pixels.
    pub width: u32,
    /// Pixels.
    pub height: u32,
}

impl Default for ImageSpec {
    fn default() -> Self {
        ImageSpec {
            width: 640,
            height: 360,
        }
    }
}

/// Which bodies a push acts on.
#[derive(Clone, Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(untagged))]
pub enum Targets {
    /// `"all"`.
    All(String),
    /// Body names (a crowd's name stands for all its bodies).
    Names(Vec<String>),
}

/// A force at a point of a link over `[t0, t1]`.
#[derive(Clone, Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct PushSpec {
    /// `"all"` or a list of body or crowd names.
    pub bodies: Targets,
    /// URDF link name.
    pub link: String,
    /// Point of application in the link frame (m).
    #[cfg_attr(feature = "serde", serde(default))]
    pub point: V3,
    /// Force (N), world frame.
    pub force: V3,
    /// Start time (s).
    pub t0: f64,
    /// End time (s).
    pub t1: f64,
}

impl Default for SceneSpec {
    /// No model and no body yet, the default camera ([`CameraSpec::default`]), no budget, no
    /// tolerance, 60 steps per second, re-selection every step, standard gravity along −z.
    fn default() -> Self {
        SceneSpec {
            models: BTreeMap::new(),
            bodies: Vec::new(),
            crowds: Vec::new(),
            camera: CameraSpec::default(),
            budget: None,
            tolerance: None,
            dt: default_dt(),
            reselect_every: one(),
            gravity: default_gravity(),
            visibility: VisibilitySpec::default(),
            pushes: Vec::new(),
            image: ImageSpec::default(),
            joint_springs: None,
            ground: None,
        }
    }
}

impl Default for CameraSpec {
    /// A fixed camera at eye height (1.7 m) at the origin, looking along +x at a point 10 m
    /// ahead and 1.2 m up; 60° vertical field of view, near 0.1 m, far 500 m.
    fn default() -> Self {
        CameraSpec::look_at([0.0, 0.0, 1.7], [10.0, 0.0, 1.2])
    }
}

impl CameraSpec {
    /// A fixed camera at `eye` looking at `target` (world, metres), z up, with the default
    /// field of view and planes.
    pub fn look_at(eye: [f64; 3], target: [f64; 3]) -> Self {
        CameraSpec {
            eye: Some(eye),
            target: Some(target),
            path: None,
            up: default_up(),
            fov_y_deg: default_fov(),
            near: default_near(),
            far: default_far(),
        }
    }

    /// A camera moving through `keys` (times strictly increasing), z up, with the default
    /// field of view and planes.
    pub fn path(keys: Vec<KeySpec>) -> Self {
        CameraSpec {
            eye: None,
            target: None,
            path: Some(keys),
            ..CameraSpec::look_at([0.0; 3], [1.0, 0.0, 0.0])
        }
    }
}

impl BodySpec {
    /// One body of model `model` with its root link at `position`, upright, at rest.
    pub fn new(model: &str, position: [f64; 3]) -> Self {
        BodySpec {
            name: None,
            model: model.to_string(),
            position,
            rpy: [0.0; 3],
            velocity: VelocitySpec::default(),
        }
    }
}

impl CrowdSpec {
    /// A `rows × columns` grid of model `model` from the world origin, 2 m apart, upright,
    /// facing +x, at rest, without jitter; set the other fields with struct update syntax
    /// (`CrowdSpec { origin: [6.0, -19.0, 1.2], ..CrowdSpec::new("humanoid", 10, 20) }`).
    pub fn new(model: &str, rows: usize, columns: usize) -> Self {
        CrowdSpec {
            name: None,
            model: model.to_string(),
            rows,
            columns,
            origin: [0.0; 3],
            spacing: [2.0, 2.0],
            jitter: 0.0,
            seed: 0,
            yaw: 0.0,
            yaw_jitter: 0.0,
            velocity: VelocitySpec::default(),
        }
    }
}

impl PushSpec {
    /// Force `force` (N, world) on link `link` of every body, at the link's origin, over
    /// `[t0, t1]` (s).
    pub fn new(link: &str, force: [f64; 3], t0: f64, t1: f64) -> Self {
        PushSpec {
            bodies: Targets::All("all".into()),
            link: link.to_string(),
            point: [0.0; 3],
            force,
            t0,
            t1,
        }
    }
}

/// Builds a scene in code: models (already loaded, or URDF files), bodies, crowds, camera,
/// budget, pushes; [`SceneBuilder::build`] checks it all as a scene file is checked and
/// returns the scene ready for [`crate::SceneSim`], or a [`ViewError`] naming the field —
/// never a panic.
///
/// ```
/// use articula_model::{LoadOptions, Model};
/// use articula_view::{CameraSpec, CrowdSpec, SceneBuilder, SceneSim};
///
/// // A two-link body: a torso and an arm on a hinge.
/// let urdf = r#"<robot name="bot">
///   <link name="torso"><inertial><mass value="10"/>
///     <inertia ixx="0.3" iyy="0.3" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
///   <link name="arm"><inertial><origin xyz="0 0 -0.3"/><mass value="2"/>
///     <inertia ixx="0.02" iyy="0.02" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>
///   <joint name="shoulder" type="continuous"><parent link="torso"/><child link="arm"/>
///     <origin xyz="0 0.2 0.3"/><axis xyz="0 1 0"/></joint>
/// </robot>"#;
/// let model = Model::from_urdf_str(urdf, &LoadOptions::default().with_floating_base(true))?;
/// let scene = SceneBuilder::new()
///     .model("bot", model.clone())
///     .crowd(CrowdSpec { origin: [5.0, -3.0, 1.0], ..CrowdSpec::new("bot", 3, 4) })
///     .camera(CameraSpec::look_at([0.0, 0.0, 1.5], [10.0, 0.0, 1.0]))
///     .budget(4)
///     .build()?;
/// assert_eq!(scene.placements.len(), 12);
/// let mut sim = SceneSim::new(&scene)?;
/// let step = sim.step()?;
/// assert!(step.active_total <= 4);
///
/// // A crowd of a model nobody gave is an error, not a panic.
/// let ghosts = SceneBuilder::new().model("bot", model).crowd(CrowdSpec::new("ghost", 1, 1));
/// let err = ghosts.build().unwrap_err();
/// assert!(err.to_string().contains("crowds[0].model"), "{err}");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, Default)]
#[must_use]
pub struct SceneBuilder {
    spec: SceneSpec,
    models: Vec<(String, Model)>,
    base: PathBuf,
    memory_limit: Option<u64>,
}

impl SceneBuilder {
    /// An empty scene with the defaults of [`SceneSpec::default`].
    pub fn new() -> Self {
        SceneBuilder::default()
    }

    /// Starts from a spec (its model paths relative to the current directory, or to
    /// [`SceneBuilder::base`]).
    pub fn from_spec(spec: SceneSpec) -> Self {
        SceneBuilder {
            spec,
            ..SceneBuilder::default()
        }
    }

    /// Adds a loaded model under `name` (it needs a floating base:
    /// `LoadOptions::default().with_floating_base(true)`).
    pub fn model(mut self, name: &str, model: Model) -> Self {
        self.models.push((name.to_string(), model));
        self
    }

    /// Adds a model to load from a URDF file under `name` (loaded with a floating base by
    /// [`SceneBuilder::build`]; a relative path is relative to [`SceneBuilder::base`]).
    pub fn model_file(mut self, name: &str, path: impl AsRef<Path>) -> Self {
        let path = path.as_ref().display().to_string();
        self.spec.models.insert(name.to_string(), path);
        self
    }

    /// The folder relative model paths start from (default: the current directory).
    pub fn base(mut self, dir: impl AsRef<Path>) -> Self {
        self.base = dir.as_ref().to_path_buf();
        self
    }

    /// Adds one body.
    pub fn body(mut self, body: BodySpec) -> Self {
        self.spec.bodies.push(body);
        self
    }

    /// Adds a crowd (a grid of bodies).
    pub fn crowd(mut self, crowd: CrowdSpec) -> Self {
        self.spec.crowds.push(crowd);
        self
    }

    /// Sets the camera.
    pub fn camera(mut self, camera: CameraSpec) -> Self {
        self.spec.camera = camera;
        self
    }

    /// Sets the scene-wide budget of active internal degrees of freedom per step.
    pub fn budget(mut self, joints: usize) -> Self {
        self.spec.budget = Some(joints);
        self
    }

    /// Sets the scene-wide tolerance on the weighted acceleration metric left unsimulated.
    pub fn tolerance(mut self, tolerance: f64) -> Self {
        self.spec.tolerance = Some(tolerance);
        self
    }

    /// Sets the time step (s).
    pub fn dt(mut self, dt: f64) -> Self {
        self.spec.dt = dt;
        self
    }

    /// Re-selects visibility and joints every `steps` steps.
    pub fn reselect_every(mut self, steps: usize) -> Self {
        self.spec.reselect_every = steps;
        self
    }

    /// Sets gravity (m/s², world).
    pub fn gravity(mut self, gravity: [f64; 3]) -> Self {
        self.spec.gravity = gravity;
        self
    }

    /// Sets how visibility becomes weights.
    pub fn visibility(mut self, visibility: VisibilitySpec) -> Self {
        self.spec.visibility = visibility;
        self
    }

    /// Adds a timed push.
    pub fn push(mut self, push: PushSpec) -> Self {
        self.spec.pushes.push(push);
        self
    }

    /// Sets the rendered image size (pixels; its ratio is the camera's aspect ratio).
    pub fn image(mut self, width: u32, height: u32) -> Self {
        self.spec.image = ImageSpec { width, height };
        self
    }

    /// Holds every internal joint near its neutral angle with pose springs.
    pub fn joint_springs(mut self, springs: SpringSpec) -> Self {
        self.spec.joint_springs = Some(springs);
        self
    }

    /// Puts a floor under the bodies.
    pub fn ground(mut self, ground: GroundSpec) -> Self {
        self.spec.ground = Some(ground);
        self
    }

    /// The largest estimated memory of the running scene ([`body_memory_estimate`] summed
    /// over its bodies) that [`SceneBuilder::build`] accepts; default
    /// [`DEFAULT_SCENE_MEMORY_LIMIT`].
    pub fn memory_limit(mut self, bytes: u64) -> Self {
        self.memory_limit = Some(bytes);
        self
    }

    /// Checks everything and loads the model files: the scene, or the first problem.
    pub fn build(self) -> Result<LoadedScene, ViewError> {
        resolve_in(
            self.spec,
            Path::new(""),
            &self.base,
            self.models,
            LoadOptions::default(),
            self.memory_limit.unwrap_or(DEFAULT_SCENE_MEMORY_LIMIT),
        )
    }
}

/// The camera of a scene.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraRig {
    /// Fixed.
    Fixed(Camera),
    /// Moving along keyframes.
    Path(CameraPath),
}

impl CameraRig {
    /// The camera at time `t`.
    pub fn at(&self, t: f64) -> Camera {
        match self {
            CameraRig::Fixed(c) => *c,
            // Every keyframe was checked, and interpolated eyes and targets of valid keyframes
            // can only fail when they meet; then hold the previous keyframe's camera.
            CameraRig::Path(p) => p.at(t).unwrap_or_else(|_| {
                let i = p.keys.partition_point(|k| k.t <= t).saturating_sub(1);
                let k = p.keys[i];
                Camera::look_at(k.eye, k.target, p.up, p.fov_y_deg, p.aspect, p.near, p.far)
                    .expect("keyframes were checked")
            }),
        }
    }
}

/// One model of the scene.
#[derive(Clone, Debug)]
pub struct SceneModel {
    /// Its key in `models`.
    pub name: String,
    /// The URDF path as resolved (empty for a model given in code).
    pub path: PathBuf,
    /// The model (floating base).
    pub model: Model,
    /// Its bounding volumes.
    pub volumes: Vec<BodyVolumes>,
}

/// One placed body.
#[derive(Clone, Debug)]
pub struct Placement {
    /// Its name.
    pub name: String,
    /// Index into [`LoadedScene::models`].
    pub model: usize,
    /// Initial positions.
    pub q: Vec<f64>,
    /// Initial velocities.
    pub qd: Vec<f64>,
}

/// A resolved push.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Push {
    /// Placement index.
    pub body: usize,
    /// Model body the link belongs to.
    pub link_body: usize,
    /// Point of application in that body's frame.
    pub point: DVec3,
    /// Force, world.
    pub force: DVec3,
    /// Start time.
    pub t0: f64,
    /// End time.
    pub t1: f64,
}

/// A checked scene, ready to simulate.
#[derive(Clone, Debug)]
pub struct LoadedScene {
    /// The scene file.
    pub path: PathBuf,
    /// The models.
    pub models: Vec<SceneModel>,
    /// The bodies.
    pub placements: Vec<Placement>,
    /// The camera.
    pub camera: CameraRig,
    /// Pushes.
    pub pushes: Vec<Push>,
    /// Budget.
    pub budget: Option<usize>,
    /// Tolerance.
    pub tolerance: Option<f64>,
    /// Time step.
    pub dt: f64,
    /// Reselection period (steps).
    pub reselect_every: usize,
    /// Gravity.
    pub gravity: DVec3,
    /// Visibility settings.
    pub visibility: VisibilitySettings,
    /// Image size.
    pub image: ImageSpec,
    /// Pose springs.
    pub joint_springs: Option<SpringSpec>,
    /// The floor, if any.
    pub ground: Option<GroundSpec>,
}

/// The largest scene file read, in bytes.
pub const MAX_SCENE_BYTES: u64 = 16 << 20;

/// The largest estimated memory of a running scene accepted by default: 4 GiB
/// ([`body_memory_estimate`] summed over the bodies; [`SceneOptions::memory_limit`] and
/// [`SceneBuilder::memory_limit`] set another).
pub const DEFAULT_SCENE_MEMORY_LIMIT: u64 = 4 << 30;

/// An estimate of the heap one body of `model` takes in a running scene ([`crate::SceneSim`]):
/// its placement and state, its adaptive workspace (the exact DCA workspace inside it, whose
/// articulated-body blocks grow with the handles of every assembly-tree node, the hybrid
/// body's caches), its poses, metrics and share of the global queue:
/// `16 KiB + 4 KiB × bodies + 2,100 B × Σ handles²` over the assembly-tree nodes, fitted to
/// what the allocator reports (a humanoid body takes ~350 KB); a test keeps it between 1 and 3
/// times the measured heap on a humanoid, chains and a hub with many children.
pub fn body_memory_estimate(model: &Model) -> u64 {
    let blocks: u64 = model
        .assembly
        .nodes
        .iter()
        .map(|n| (n.handles.len() as u64).pow(2))
        .sum();
    MEM_BASE
        .saturating_add(MEM_BODY.saturating_mul(model.bodies.len() as u64))
        .saturating_add(MEM_BLOCK.saturating_mul(blocks))
}

/// Coefficients of [`body_memory_estimate`] (bytes): per body of the scene, per body of its
/// model, per pair of handles of an assembly-tree node (the articulated-body blocks of DCA and
/// of the hybrid body's caches).
const MEM_BASE: u64 = 16 << 10;
const MEM_BODY: u64 = 4 << 10;
const MEM_BLOCK: u64 = 2100;

/// How scene files are read: the load options of their models and the largest running scene
/// accepted. The one entry to scene files, in the manner of [`std::fs::OpenOptions`]:
/// `SceneOptions::default().with_memory_limit(1 << 30).load(path)`; [`load_scene`] is
/// `SceneOptions::default().load(path)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneOptions {
    /// How each body's model file is loaded (inertia policy and its repair bounds); the
    /// floating base is always on, whatever `floating_base` says.
    pub model: LoadOptions,
    /// The largest estimated memory of the running scene accepted (bytes;
    /// [`body_memory_estimate`] summed over the bodies, checked before any body is placed): a
    /// larger scene is [`ViewError::TooLarge`].
    pub memory_limit: u64,
}

impl Default for SceneOptions {
    fn default() -> Self {
        SceneOptions {
            model: LoadOptions::default(),
            memory_limit: DEFAULT_SCENE_MEMORY_LIMIT,
        }
    }
}

impl SceneOptions {
    /// With every load option of the models.
    pub fn with_model_options(self, model: LoadOptions) -> Self {
        SceneOptions { model, ..self }
    }

    /// With the inertia policy the models are loaded with.
    pub fn with_inertia(self, inertia: InertiaPolicy) -> Self {
        SceneOptions {
            model: self.model.with_inertia(inertia),
            ..self
        }
    }

    /// With the largest estimated memory of the running scene accepted (bytes).
    pub fn with_memory_limit(self, memory_limit: u64) -> Self {
        SceneOptions {
            memory_limit,
            ..self
        }
    }

    /// Reads and checks a scene file (at most [`MAX_SCENE_BYTES`]); model paths are relative
    /// to the file's folder.
    #[cfg(feature = "serde")]
    pub fn load(&self, path: impl AsRef<Path>) -> Result<LoadedScene, ViewError> {
        let path = path.as_ref();
        let io = |message: String| ViewError::Io {
            path: path.display().to_string(),
            message,
        };
        let bytes =
            articula_model::read_limited(path, MAX_SCENE_BYTES).map_err(|e| io(e.to_string()))?;
        let text = String::from_utf8(bytes).map_err(|e| io(e.to_string()))?;
        let base = path.parent().unwrap_or(Path::new("."));
        self.parse(&text, path, base)
    }

    /// Parses and checks scene text; `path` names the file in errors and `base` is the folder
    /// model paths are relative to.
    #[cfg(feature = "serde")]
    pub fn parse(&self, text: &str, path: &Path, base: &Path) -> Result<LoadedScene, ViewError> {
        let spec = parse_spec(text, path)?;
        resolve_in(spec, path, base, Vec::new(), self.model, self.memory_limit)
    }
}

/// Reads and checks a scene file with the default options: `SceneOptions::default().load(path)`
/// ([`SceneOptions`] sets others).
#[cfg(feature = "serde")]
pub fn load_scene(path: impl AsRef<Path>) -> Result<LoadedScene, ViewError> {
    SceneOptions::default().load(path)
}

/// The blocks of a scene file that must be JSON objects, as JSON paths (`[]`: every element
/// of an array). Serde reads a struct from an array too, by position (`"ground": [5.0, 0.3]`
/// as a floor at 5 m with μ 0.3): [`check_objects`] refuses that first.
#[cfg(feature = "serde")]
const OBJECT_BLOCKS: &[&str] = &[
    "",
    "models",
    "bodies[]",
    "bodies[].velocity",
    "crowds[]",
    "crowds[].velocity",
    "camera",
    "camera.path[]",
    "visibility",
    "pushes[]",
    "image",
    "joint_springs",
    "ground",
];

/// `Err((field, kind))` for the first block of [`OBJECT_BLOCKS`] present in `v` that is a JSON
/// array (other wrong types are serde's "invalid type" errors).
#[cfg(feature = "serde")]
fn check_objects(v: &serde_json::Value) -> Result<(), (String, &'static str)> {
    use serde_json::Value;
    fn kind(v: &Value) -> &'static str {
        match v {
            Value::Array(_) => "an array",
            Value::String(_) => "a string",
            Value::Number(_) => "a number",
            Value::Bool(_) => "a boolean",
            Value::Null => "null",
            Value::Object(_) => "an object",
        }
    }
    // Walks `rest` (path segments) from `v` at `at`, checking the block at the end.
    fn walk(v: &Value, at: String, rest: &[&str]) -> Result<(), (String, &'static str)> {
        let Some((first, rest)) = rest.split_first() else {
            // Only arrays: serde's own error for a number or a string in a block's place
            // already says "invalid type".
            return match v {
                Value::Array(_) => Err((if at.is_empty() { ".".into() } else { at }, kind(v))),
                _ => Ok(()),
            };
        };
        let (name, each) = match first.strip_suffix("[]") {
            Some(n) => (n, true),
            None => (*first, false),
        };
        let Some(child) = v.as_object().and_then(|o| o.get(name)) else {
            return Ok(());
        };
        let here = if at.is_empty() {
            name.to_string()
        } else {
            format!("{at}.{name}")
        };
        if !each {
            return walk(child, here, rest);
        }
        for (i, e) in child.as_array().into_iter().flatten().enumerate() {
            walk(e, format!("{here}[{i}]"), rest)?;
        }
        Ok(())
    }
    for block in OBJECT_BLOCKS {
        let segments: Vec<&str> = block.split('.').filter(|s| !s.is_empty()).collect();
        walk(v, String::new(), &segments)?;
    }
    Ok(())
}

/// The spec in scene text (`path` names the file in errors).
#[cfg(feature = "serde")]
fn parse_spec(text: &str, path: &Path) -> Result<SceneSpec, ViewError> {
    // Blocks given as arrays are refused by name before serde reads them by position. (Text
    // that is not JSON is left to the reader below, whose error has the line and column.)
    if let Ok(value) = serde_json::from_str::<serde_json::Value>(text) {
        check_objects(&value).map_err(|(field, kind)| ViewError::Json {
            path: path.display().to_string(),
            field,
            message: format!("must be a JSON object {{ ... }} (docs/view.md), not {kind}"),
        })?;
    }
    let de = &mut serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let field = match e.path().to_string() {
            f if f == "." => "top level".to_string(),
            f => f,
        };
        ViewError::Json {
            path: path.display().to_string(),
            field,
            message: e.inner().to_string(),
        }
    })
}

impl SceneSpec {
    /// Checks the spec and loads its models (URDF paths relative to `base`, each with a
    /// floating base): the scene ready to simulate, or the first problem as a
    /// [`ViewError`] naming its field (`crowds[0].rows`, ...), never a panic. Errors name the
    /// scene `<built in code>`; [`SceneBuilder`] adds models already in memory.
    pub fn resolve(self, base: impl AsRef<Path>) -> Result<LoadedScene, ViewError> {
        resolve_in(
            self,
            Path::new(""),
            base.as_ref(),
            Vec::new(),
            LoadOptions::default(),
            DEFAULT_SCENE_MEMORY_LIMIT,
        )
    }
}

/// How errors name a scene: its file, or `<built in code>` for an empty path.
fn scene_label(path: &Path) -> String {
    if path.as_os_str().is_empty() {
        "<built in code>".to_string()
    } else {
        path.display().to_string()
    }
}

fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// The largest distance a scene may place anything from the world origin (m): positions,
/// origins, spacings, jitters, camera points, the floor's height. Finite but absurd values
/// (1e308) are refused at load, naming their field, rather than failing at step 1.
pub const MAX_DISTANCE: f64 = 1e6;
/// The largest speed (m/s, rad/s) of an initial velocity and the largest gravity (m/s²).
pub const MAX_RATE: f64 = 1e4;
/// The largest push force (N).
pub const MAX_FORCE: f64 = 1e12;
/// The largest spring frequency (Hz) and damping ratio of `joint_springs`.
pub const MAX_SPRING: f64 = 1e4;

/// Every entry finite and at most `limit` in magnitude.
fn within(v: &[f64], limit: f64) -> bool {
    v.iter().all(|x| x.is_finite() && x.abs() <= limit)
}

/// Names the scene in its errors: every check of [`resolve_in`] reports through it.
struct Fields {
    file: String,
}

impl Fields {
    fn invalid(&self, field: impl Into<String>, message: impl Into<String>) -> ViewError {
        ViewError::Invalid {
            path: self.file.clone(),
            field: field.into(),
            message: message.into(),
        }
    }
}

/// Checks `spec`, loads its model files (relative to `base`) and adds `code_models`; `path`
/// names the scene in errors (empty: built in code).
fn resolve_in(
    spec: SceneSpec,
    path: &Path,
    base: &Path,
    code_models: Vec<(String, Model)>,
    options: LoadOptions,
    memory_limit: u64,
) -> Result<LoadedScene, ViewError> {
    let fields = Fields {
        file: scene_label(path),
    };
    check_scalars(&spec, &fields)?;
    let camera = camera_rig(&spec, &fields)?;
    let (models, model_index) = load_models(&spec, base, code_models, options, &fields)?;
    let find_model = |field: String, name: &str| {
        model_index.get(name).copied().ok_or_else(|| {
            fields.invalid(
                field,
                format!(
                    "no model named '{name}' (models: {})",
                    model_index.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            )
        })
    };
    check_memory(&spec, &models, &find_model, &fields, memory_limit)?;
    let (placements, groups) = place_bodies(&spec, &models, &find_model, &fields)?;
    let pushes = resolve_pushes(&spec, &models, &placements, &groups, &fields)?;
    let v = spec.visibility;
    let scene = LoadedScene {
        path: path.to_path_buf(),
        models,
        placements,
        camera,
        pushes,
        budget: spec.budget,
        tolerance: spec.tolerance,
        dt: spec.dt,
        reselect_every: spec.reselect_every,
        gravity: DVec3::from_array(spec.gravity),
        visibility: VisibilitySettings {
            occluded_factor: v.occluded_factor,
            full_detail_size: v.full_detail_size,
            depth_width: v.depth_buffer[0],
            depth_height: v.depth_buffer[1],
        },
        image: spec.image,
        joint_springs: spec.joint_springs,
        ground: spec.ground,
    };
    // What the spec's checks cannot see: placements that came out non-finite (a jitter or an
    // origin so large that a position overflows).
    scene.validate()?;
    Ok(scene)
}

/// The scene's scalar settings: step, re-selection, tolerance, gravity, visibility, image,
/// springs, ground.
fn check_scalars(spec: &SceneSpec, fields: &Fields) -> Result<(), ViewError> {
    if !(spec.dt.is_finite() && spec.dt > 0.0) {
        return Err(fields.invalid("dt", "must be a positive number"));
    }
    if spec.reselect_every == 0 {
        return Err(fields.invalid("reselect_every", "must be at least 1"));
    }
    if let Some(t) = spec.tolerance {
        if !(t.is_finite() && t >= 0.0) {
            return Err(fields.invalid("tolerance", "must be a non-negative number"));
        }
    }
    if !within(&spec.gravity, MAX_RATE) {
        return Err(fields.invalid("gravity", "must be finite, each component at most 1e4 m/s²"));
    }
    let v = spec.visibility;
    if !(v.occluded_factor.is_finite() && (0.0..=1.0).contains(&v.occluded_factor)) {
        return Err(fields.invalid("visibility.occluded_factor", "must lie in [0, 1]"));
    }
    if !(v.full_detail_size.is_finite() && v.full_detail_size > 0.0) {
        return Err(fields.invalid("visibility.full_detail_size", "must be a positive number"));
    }
    if !depth_cells_ok(v.depth_buffer[0], v.depth_buffer[1]) {
        return Err(fields.invalid(
            "visibility.depth_buffer",
            "needs 1 to 4,194,304 cells, both sides at least 1",
        ));
    }
    let img = spec.image;
    if img.width == 0 || img.height == 0 || img.width > 8192 || img.height > 8192 {
        return Err(fields.invalid("image", "width and height must lie in 1..=8192"));
    }
    if let Some(j) = spec.joint_springs {
        for (f, x) in [
            ("frequency_hz", j.frequency_hz),
            ("damping_ratio", j.damping_ratio),
        ] {
            if !(x.is_finite() && (0.0..=MAX_SPRING).contains(&x)) {
                return Err(
                    fields.invalid(format!("joint_springs.{f}"), "must be a number in [0, 1e4]")
                );
            }
        }
    }
    if let Some((f, why)) = spec.ground.as_ref().and_then(GroundSpec::problem) {
        return Err(fields.invalid(format!("ground.{f}"), why));
    }
    Ok(())
}

/// The camera: fixed (`eye` and `target`) or a keyframed path.
fn camera_rig(spec: &SceneSpec, fields: &Fields) -> Result<CameraRig, ViewError> {
    let c = &spec.camera;
    let aspect = spec.image.width as f64 / spec.image.height as f64;
    let cam_err = |e: ViewError| fields.invalid("camera", e.to_string());
    Ok(match (c.eye, c.target, &c.path) {
        (Some(eye), Some(target), None) => CameraRig::Fixed(
            Camera::look_at(
                DVec3::from_array(eye),
                DVec3::from_array(target),
                DVec3::from_array(c.up),
                c.fov_y_deg,
                aspect,
                c.near,
                c.far,
            )
            .map_err(cam_err)?,
        ),
        (None, None, Some(keys)) => CameraRig::Path(
            CameraPath::new(
                keys.iter()
                    .map(|k| Keyframe {
                        t: k.t,
                        eye: DVec3::from_array(k.eye),
                        target: DVec3::from_array(k.target),
                    })
                    .collect(),
                DVec3::from_array(c.up),
                c.fov_y_deg,
                aspect,
                c.near,
                c.far,
            )
            .map_err(|e| fields.invalid("camera.path", e.to_string()))?,
        ),
        _ => {
            return Err(fields.invalid(
                "camera",
                "give either both 'eye' and 'target' (a fixed camera) or 'path' (keyframes)",
            ))
        }
    })
}

/// The scene's models: its files (relative to `base`) then those built in code, with the
/// index of each name.
fn load_models(
    spec: &SceneSpec,
    base: &Path,
    code_models: Vec<(String, Model)>,
    options: LoadOptions,
    fields: &Fields,
) -> Result<(Vec<SceneModel>, BTreeMap<String, usize>), ViewError> {
    if spec.models.is_empty() && code_models.is_empty() {
        return Err(fields.invalid("models", "names no model"));
    }
    let mut models = Vec::new();
    let mut model_index = BTreeMap::new();
    for (name, rel) in &spec.models {
        let p = base.join(rel);
        let model = Model::from_file(&p, &options.with_floating_base(true)).map_err(|error| {
            ViewError::Model {
                path: fields.file.clone(),
                name: name.clone(),
                model_path: p.display().to_string(),
                error: Box::new(error),
            }
        })?;
        model_index.insert(name.clone(), models.len());
        models.push(SceneModel {
            name: name.clone(),
            path: p,
            volumes: body_volumes(&model),
            model,
        });
    }
    for (name, model) in code_models {
        let field = format!("models.{name}");
        if model_index.contains_key(&name) {
            return Err(fields.invalid(field, format!("duplicate model name '{name}'")));
        }
        if !model.floating_base {
            return Err(fields.invalid(
                field,
                "a scene's models need a floating base (load them with \
                 LoadOptions::default().with_floating_base(true))",
            ));
        }
        model_index.insert(name.clone(), models.len());
        models.push(SceneModel {
            name,
            path: PathBuf::new(),
            volumes: body_volumes(&model),
            model,
        });
    }
    Ok((models, model_index))
}

/// The memory of the running scene, before any body is placed: refused over `memory_limit`.
fn check_memory(
    spec: &SceneSpec,
    models: &[SceneModel],
    find_model: &impl Fn(String, &str) -> Result<usize, ViewError>,
    fields: &Fields,
    memory_limit: u64,
) -> Result<(), ViewError> {
    let mut bodies = spec.bodies.len() as u64;
    let mut estimate = 0u64;
    for (i, b) in spec.bodies.iter().enumerate() {
        let m = find_model(format!("bodies[{i}].model"), &b.model)?;
        estimate = estimate.saturating_add(body_memory_estimate(&models[m].model));
    }
    for (i, c) in spec.crowds.iter().enumerate() {
        let m = find_model(format!("crowds[{i}].model"), &c.model)?;
        let n = (c.rows as u64).saturating_mul(c.columns as u64);
        if n == 0 || n > 1_000_000 {
            // Refused when placed, naming its field.
            continue;
        }
        bodies = bodies.saturating_add(n);
        estimate =
            estimate.saturating_add(n.saturating_mul(body_memory_estimate(&models[m].model)));
    }
    if estimate > memory_limit {
        return Err(ViewError::TooLarge {
            path: fields.file.clone(),
            bodies,
            estimate,
            limit: memory_limit,
        });
    }
    Ok(())
}

/// A floating body's configuration and velocity at `pos`, turned by `rot`, moving with `vel`
/// (world frame; the floating base's velocity is stored in root coordinates).
fn place(model: &Model, pos: DVec3, rot: DMat3, vel: &VelocitySpec) -> (Vec<f64>, Vec<f64>) {
    let mut q = model.rest_q();
    let mut qd = vec![0.0; model.nv];
    let r = DQuat::from_mat3(&rot).normalize();
    q[..7].copy_from_slice(&[pos.x, pos.y, pos.z, r.w, r.x, r.y, r.z]);
    let w = rot.transpose() * DVec3::from_array(vel.angular);
    let v = rot.transpose() * DVec3::from_array(vel.linear);
    qd[..6].copy_from_slice(&[w.x, w.y, w.z, v.x, v.y, v.z]);
    (q, qd)
}

fn check_velocity(fields: &Fields, field: String, v: &VelocitySpec) -> Result<(), ViewError> {
    if within(&v.linear, MAX_RATE) && within(&v.angular, MAX_RATE) {
        Ok(())
    } else {
        Err(fields.invalid(
            field,
            "must be finite, each component at most 1e4 (m/s, rad/s)",
        ))
    }
}

/// Named groups of placements: a body's one, a crowd's members.
type Groups = BTreeMap<String, Vec<usize>>;

/// Every body and crowd member placed, with the groups pushes may name.
fn place_bodies(
    spec: &SceneSpec,
    models: &[SceneModel],
    find_model: &impl Fn(String, &str) -> Result<usize, ViewError>,
    fields: &Fields,
) -> Result<(Vec<Placement>, Groups), ViewError> {
    let mut placements = Vec::new();
    let mut groups = Groups::new();
    for (i, b) in spec.bodies.iter().enumerate() {
        let m = find_model(format!("bodies[{i}].model"), &b.model)?;
        if !within(&b.position, MAX_DISTANCE) {
            return Err(fields.invalid(
                format!("bodies[{i}].position"),
                "must be finite, each component at most 1e6 m",
            ));
        }
        if !finite(&b.rpy) {
            return Err(fields.invalid(format!("bodies[{i}].rpy"), "must be finite"));
        }
        check_velocity(fields, format!("bodies[{i}].velocity"), &b.velocity)?;
        let rot = articula_model::rpy_to_matrix(DVec3::from_array(b.rpy));
        let (q, qd) = place(
            &models[m].model,
            DVec3::from_array(b.position),
            rot,
            &b.velocity,
        );
        let name = b.name.clone().unwrap_or_else(|| format!("body{i}"));
        if groups.contains_key(&name) {
            return Err(fields.invalid(
                format!("bodies[{i}].name"),
                format!("duplicate name '{name}'"),
            ));
        }
        groups.insert(name.clone(), vec![placements.len()]);
        placements.push(Placement {
            name,
            model: m,
            q,
            qd,
        });
    }
    for (i, c) in spec.crowds.iter().enumerate() {
        let m = find_model(format!("crowds[{i}].model"), &c.model)?;
        check_crowd(i, c, fields)?;
        let name = c.name.clone().unwrap_or_else(|| format!("crowd{i}"));
        if groups.contains_key(&name) {
            return Err(fields.invalid(
                format!("crowds[{i}].name"),
                format!("duplicate name '{name}'"),
            ));
        }
        let members = place_crowd(c, &name, m, &models[m].model, &mut placements);
        groups.insert(name, members);
    }
    if placements.is_empty() {
        return Err(fields.invalid(
            "bodies",
            "the scene has no body (give 'bodies' or 'crowds')",
        ));
    }
    Ok((placements, groups))
}

/// The numbers of crowd `i`: its grid size, origin, spacing, far corner, jitters, yaw and
/// velocity.
fn check_crowd(i: usize, c: &CrowdSpec, fields: &Fields) -> Result<(), ViewError> {
    let field = |f: &str| format!("crowds[{i}].{f}");
    if c.rows == 0 || c.columns == 0 || c.rows.saturating_mul(c.columns) > 1_000_000 {
        return Err(fields.invalid(
            field("rows"),
            "rows and columns must be at least 1, with at most 1,000,000 bodies",
        ));
    }
    for (f, v) in [("origin", &c.origin[..]), ("spacing", &c.spacing[..])] {
        if !within(v, MAX_DISTANCE) {
            return Err(fields.invalid(field(f), "must be finite, each component at most 1e6 m"));
        }
    }
    // The grid's far corner too: rows × spacing stays within the distance limit.
    let extent = [
        c.origin[0] + c.rows as f64 * c.spacing[0],
        c.origin[1] + c.columns as f64 * c.spacing[1],
    ];
    if !within(&extent, MAX_DISTANCE) {
        return Err(fields.invalid(
            field("spacing"),
            "places the crowd's far corner more than 1e6 m from the origin",
        ));
    }
    for (f, x) in [("jitter", c.jitter), ("yaw_jitter", c.yaw_jitter)] {
        if !(x.is_finite() && (0.0..=MAX_DISTANCE).contains(&x)) {
            return Err(fields.invalid(field(f), "must be a number in [0, 1e6]"));
        }
    }
    if !c.yaw.is_finite() {
        return Err(fields.invalid(field("yaw"), "must be finite"));
    }
    check_velocity(fields, field("velocity"), &c.velocity)
}

/// Places the members of crowd `c` (named `name`, model index `m`) row by row, with the
/// crowd's seeded jitter; returns their placement indices.
fn place_crowd(
    c: &CrowdSpec,
    name: &str,
    m: usize,
    model: &Model,
    placements: &mut Vec<Placement>,
) -> Vec<usize> {
    let mut rng = SplitMix64(c.seed);
    let mut members = Vec::new();
    for r in 0..c.rows {
        for col in 0..c.columns {
            let jx = rng.uniform(-c.jitter, c.jitter);
            let jy = rng.uniform(-c.jitter, c.jitter);
            let yaw = c.yaw + rng.uniform(-c.yaw_jitter, c.yaw_jitter);
            let pos = DVec3::from_array(c.origin)
                + DVec3::new(
                    r as f64 * c.spacing[0] + jx,
                    col as f64 * c.spacing[1] + jy,
                    0.0,
                );
            let (q, qd) = place(model, pos, DMat3::from_rotation_z(yaw), &c.velocity);
            members.push(placements.len());
            placements.push(Placement {
                name: format!("{name}[{r},{col}]"),
                model: m,
                q,
                qd,
            });
        }
    }
    members
}

/// The pushes, each expanded to one per body it names (a body, a crowd or `"all"`).
fn resolve_pushes(
    spec: &SceneSpec,
    models: &[SceneModel],
    placements: &[Placement],
    groups: &Groups,
    fields: &Fields,
) -> Result<Vec<Push>, ViewError> {
    let mut pushes = Vec::new();
    for (i, p) in spec.pushes.iter().enumerate() {
        let field = |f: &str| format!("pushes[{i}].{f}");
        if !within(&p.point, MAX_DISTANCE) || !within(&p.force, MAX_FORCE) {
            return Err(fields.invalid(
                field("force"),
                "point (at most 1e6 m) and force (at most 1e12 N) must be finite",
            ));
        }
        if !(p.t0.is_finite() && p.t1.is_finite() && p.t0 <= p.t1) {
            return Err(fields.invalid(field("t0"), "needs finite t0 ≤ t1"));
        }
        for b in push_targets(i, &p.bodies, placements, groups, fields)? {
            let model = &models[placements[b].model].model;
            let found = model.bodies.iter().enumerate().find_map(|(bi, body)| {
                body.links
                    .iter()
                    .find(|(name, _)| name == &p.link)
                    .map(|(_, x)| (bi, *x))
            });
            let Some((link_body, x)) = found else {
                return Err(fields.invalid(
                    field("link"),
                    format!(
                        "model '{}' has no link '{}' that moves with a body (massless links inside composed joints cannot be pushed)",
                        models[placements[b].model].name, p.link
                    ),
                ));
            };
            pushes.push(Push {
                body: b,
                link_body,
                // Link frame → body frame.
                point: x.apply_point(DVec3::from_array(p.point)),
                force: DVec3::from_array(p.force),
                t0: p.t0,
                t1: p.t1,
            });
        }
    }
    Ok(pushes)
}

/// The placements push `i` acts on: every one for `"all"`, else those of each named group or
/// body.
fn push_targets(
    i: usize,
    targets: &Targets,
    placements: &[Placement],
    groups: &Groups,
    fields: &Fields,
) -> Result<Vec<usize>, ViewError> {
    match targets {
        Targets::All(s) if s == "all" => Ok((0..placements.len()).collect()),
        Targets::All(s) => Err(fields.invalid(
            format!("pushes[{i}].bodies"),
            format!("expected \"all\" or a list of names, found \"{s}\""),
        )),
        Targets::Names(names) => {
            let mut out = Vec::new();
            for (k, n) in names.iter().enumerate() {
                match groups.get(n) {
                    Some(g) => out.extend_from_slice(g),
                    None => match placements.iter().position(|pl| &pl.name == n) {
                        Some(b) => out.push(b),
                        None => {
                            return Err(fields.invalid(
                                format!("pushes[{i}].bodies[{k}]"),
                                format!("no body or crowd named '{n}'"),
                            ))
                        }
                    },
                }
            }
            Ok(out)
        }
    }
}

/// Whether a depth buffer of `w × h` cells is usable: both sides at least 1, at most 2²²
/// cells (no overflow on the way).
fn depth_cells_ok(w: usize, h: usize) -> bool {
    w >= 1 && h >= 1 && w.checked_mul(h).is_some_and(|n| n <= 1 << 22)
}

impl LoadedScene {
    /// The contact settings of every body's step: the `ground` (none: no contact) with the
    /// URDF joint limits, the solve stopping at the ground's `tolerance` (default 1e-6 m/s of
    /// residual approach or slip velocity) or after its `max_iterations` sweeps (default 50).
    pub fn contact_settings(&self) -> ContactSettings {
        let (tolerance, max_iterations) = self
            .ground
            .map_or((GroundSpec::TOLERANCE, GroundSpec::MAX_ITERATIONS), |g| {
                (g.tolerance, g.max_iterations)
            });
        ContactSettings {
            ground: self.ground.map(|g| g.ground()),
            tolerance,
            max_iterations,
            ..ContactSettings::default()
        }
    }

    /// Checks everything a [`crate::SceneSim`] relies on, for a scene whose public fields
    /// were set or changed by hand (a scene from [`load_scene`], [`SceneSpec::resolve`] or
    /// [`SceneBuilder::build`] passes): positive `dt`, a re-selection period of at least one
    /// step, valid tolerance, gravity, visibility, image, springs and camera; every model
    /// with a floating base and one bounding volume record per body; every placement naming a
    /// model, its `q` of `nq` and `q̇` of `nv` finite numbers; every push naming a placement
    /// and a body of its model, with finite point, force and `t0 ≤ t1`. Errors name the field
    /// (`placements[3].q`, ...).
    pub fn validate(&self) -> Result<(), ViewError> {
        let invalid = |field: String, message: String| {
            Err(ViewError::Invalid {
                path: scene_label(&self.path),
                field,
                message,
            })
        };
        let pos = |x: f64| x.is_finite() && x > 0.0;
        let non_neg = |x: f64| x.is_finite() && x >= 0.0;
        if !pos(self.dt) {
            return invalid("dt".into(), "must be a positive number".into());
        }
        if self.reselect_every == 0 {
            return invalid("reselect_every".into(), "must be at least 1".into());
        }
        if self.tolerance.is_some_and(|t| !non_neg(t)) {
            return invalid("tolerance".into(), "must be a non-negative number".into());
        }
        if !self.gravity.is_finite() {
            return invalid("gravity".into(), "must be finite".into());
        }
        let v = &self.visibility;
        if !(non_neg(v.occluded_factor) && v.occluded_factor <= 1.0) {
            return invalid(
                "visibility.occluded_factor".into(),
                "must lie in [0, 1]".into(),
            );
        }
        if !pos(v.full_detail_size) {
            return invalid(
                "visibility.full_detail_size".into(),
                "must be a positive number".into(),
            );
        }
        if !depth_cells_ok(v.depth_width, v.depth_height) {
            return invalid(
                "visibility.depth_width".into(),
                "the depth buffer needs 1 to 4,194,304 cells, both sides at least 1".into(),
            );
        }
        let img = self.image;
        if img.width == 0 || img.height == 0 || img.width > 8192 || img.height > 8192 {
            return invalid(
                "image".into(),
                "width and height must lie in 1..=8192".into(),
            );
        }
        if let Some(j) = self.joint_springs {
            if !(non_neg(j.frequency_hz) && non_neg(j.damping_ratio)) {
                return invalid(
                    "joint_springs".into(),
                    "frequency and damping ratio must be non-negative numbers".into(),
                );
            }
        }
        if let Some((f, why)) = self.ground.as_ref().and_then(GroundSpec::problem) {
            return invalid(format!("ground.{f}"), why.into());
        }
        match &self.camera {
            CameraRig::Fixed(c) => {
                let ok = c.position.is_finite()
                    && c.axes.is_finite()
                    && c.fov_y > 0.0
                    && c.fov_y < std::f64::consts::PI
                    && pos(c.aspect)
                    && pos(c.near)
                    && c.far.is_finite()
                    && c.far > c.near;
                if !ok {
                    return invalid(
                        "camera".into(),
                        "needs a finite pose, a field of view in (0, π), a positive aspect \
                         ratio and 0 < near < far"
                            .into(),
                    );
                }
            }
            CameraRig::Path(p) => {
                let checked =
                    CameraPath::new(p.keys.clone(), p.up, p.fov_y_deg, p.aspect, p.near, p.far);
                if let Err(e) = checked {
                    return invalid("camera.path".into(), e.to_string());
                }
            }
        }
        self.validate_bodies()
    }

    /// The models, placements and pushes of [`LoadedScene::validate`].
    fn validate_bodies(&self) -> Result<(), ViewError> {
        let invalid = |field: String, message: String| {
            Err(ViewError::Invalid {
                path: scene_label(&self.path),
                field,
                message,
            })
        };
        if self.models.is_empty() {
            return invalid("models".into(), "names no model".into());
        }
        for (i, m) in self.models.iter().enumerate() {
            if !m.model.floating_base {
                return invalid(
                    format!("models[{i}]"),
                    format!("model '{}' has no floating base", m.name),
                );
            }
            if m.volumes.len() != m.model.bodies.len() {
                return invalid(
                    format!("models[{i}].volumes"),
                    format!(
                        "{} bounding volume records for {} bodies",
                        m.volumes.len(),
                        m.model.bodies.len()
                    ),
                );
            }
        }
        if self.placements.is_empty() {
            return invalid("placements".into(), "the scene has no body".into());
        }
        for (i, p) in self.placements.iter().enumerate() {
            let Some(m) = self.models.get(p.model) else {
                return invalid(
                    format!("placements[{i}].model"),
                    format!("no model {} (the scene has {})", p.model, self.models.len()),
                );
            };
            let (nq, nv) = (m.model.nq, m.model.nv);
            for (what, xs, n) in [("q", &p.q, nq), ("qd", &p.qd, nv)] {
                if xs.len() != n {
                    return invalid(
                        format!("placements[{i}].{what}"),
                        format!(
                            "body '{}': {} numbers for model '{}', which needs {n}",
                            p.name,
                            xs.len(),
                            m.name
                        ),
                    );
                }
                if !finite(xs) {
                    return invalid(
                        format!("placements[{i}].{what}"),
                        format!("body '{}': not finite", p.name),
                    );
                }
            }
        }
        for (i, p) in self.pushes.iter().enumerate() {
            let field = |f: &str| format!("pushes[{i}].{f}");
            let Some(placement) = self.placements.get(p.body) else {
                return invalid(field("body"), format!("no placement {}", p.body));
            };
            let bodies = self.models[placement.model].model.bodies.len();
            if p.link_body >= bodies {
                return invalid(
                    field("link_body"),
                    format!("no body {} in a model of {bodies}", p.link_body),
                );
            }
            if !(p.point.is_finite() && p.force.is_finite()) {
                return invalid(field("force"), "point and force must be finite".into());
            }
            if !(p.t0.is_finite() && p.t1.is_finite() && p.t0 <= p.t1) {
                return invalid(field("t0"), "needs finite t0 ≤ t1".into());
            }
        }
        Ok(())
    }
}
