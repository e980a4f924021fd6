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
use crate::visibility::VisibilitySettings;
use crate::volumes::{body_volumes, BodyVolumes};
use crate::ViewError;
use articula_dca::internals::SplitMix64;
use articula_model::{InertiaPolicy, LoadOptions, Model};
use glam::{DMat3, DQuat, DVec3};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// `[x, y, z]`.
type V3 = [f64; 3];

/// The top level of a scene file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Model name → URDF path (relative to the scene file).
    pub models: BTreeMap<String, String>,
    /// Single bodies.
    #[serde(default)]
    pub bodies: Vec<BodySpec>,
    /// Crowds: grids of bodies.
    #[serde(default)]
    pub crowds: Vec<CrowdSpec>,
    /// The camera.
    pub camera: CameraSpec,
    /// Scene-wide budget of active joints per step (none: unlimited).
    #[serde(default)]
    pub budget: Option<usize>,
    /// Scene-wide tolerance on the weighted acceleration metric left unsimulated.
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// Time step (s).
    #[serde(default = "default_dt")]
    pub dt: f64,
    /// Visibility and joint selection are redone every this many steps.
    #[serde(default = "one")]
    pub reselect_every: usize,
    /// Gravity (m/s², world).
    #[serde(default = "default_gravity")]
    pub gravity: V3,
    /// How visibility becomes weights.
    #[serde(default)]
    pub visibility: VisibilitySpec,
    /// Timed pushes.
    #[serde(default)]
    pub pushes: Vec<PushSpec>,
    /// Rendered image size (pixels).
    #[serde(default)]
    pub image: ImageSpec,
    /// Springs and dampers holding every internal joint near its neutral angle (none by
    /// default).
    #[serde(default)]
    pub joint_springs: Option<SpringSpec>,
}

/// Pose springs: each internal degree of freedom `i` gets `τᵢ = −kᵢ qᵢ − cᵢ q̇ᵢ` with
/// `kᵢ = ω² Mᵢᵢ`, `cᵢ = 2 ζ ω Mᵢᵢ`, `ω = 2π frequency_hz`, `Mᵢᵢ` the joint-space inertia of the
/// degree of freedom in the neutral pose: every joint oscillates near the same frequency, so
/// light links are no stiffer for the integrator than heavy ones. Ragdolls without joint
/// limits otherwise swing their composed 3-axis joints through gimbal lock.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
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
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VelocitySpec {
    /// m/s.
    #[serde(default)]
    pub linear: V3,
    /// rad/s.
    #[serde(default)]
    pub angular: V3,
}

/// One placed body.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Its name (default `bodyN`, N its index among `bodies`).
    #[serde(default)]
    pub name: Option<String>,
    /// A key of `models`.
    pub model: String,
    /// Root link position (world).
    pub position: V3,
    /// Root link orientation: roll, pitch, yaw (rad, URDF convention).
    #[serde(default)]
    pub rpy: V3,
    /// Initial velocity.
    #[serde(default)]
    pub velocity: VelocitySpec,
}

/// A grid of bodies: `rows` along the world x axis (away from a camera looking along +x),
/// `columns` along y, each position jittered uniformly in a square of ±`jitter` (seeded), each
/// yaw jittered by ±`yaw_jitter`. Bodies are named `NAME[r,c]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CrowdSpec {
    /// Name (default `crowdN`).
    #[serde(default)]
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
    #[serde(default)]
    pub jitter: f64,
    /// Seed of the jitter.
    #[serde(default)]
    pub seed: u64,
    /// Yaw of every body (rad).
    #[serde(default)]
    pub yaw: f64,
    /// Half width of the uniform yaw jitter (rad).
    #[serde(default)]
    pub yaw_jitter: f64,
    /// Initial velocity of every body.
    #[serde(default)]
    pub velocity: VelocitySpec,
}

/// One keyframe of a camera path.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeySpec {
    /// Time (s).
    pub t: f64,
    /// Eye.
    pub eye: V3,
    /// Target.
    pub target: V3,
}

/// The camera: fixed (`eye` and `target`) or moving (`path`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Fixed eye.
    #[serde(default)]
    pub eye: Option<V3>,
    /// Fixed target.
    #[serde(default)]
    pub target: Option<V3>,
    /// Keyframes of a moving camera.
    #[serde(default)]
    pub path: Option<Vec<KeySpec>>,
    /// Up vector.
    #[serde(default = "default_up")]
    pub up: V3,
    /// Vertical field of view, degrees.
    #[serde(default = "default_fov")]
    pub fov_y_deg: f64,
    /// Near plane (m).
    #[serde(default = "default_near")]
    pub near: f64,
    /// Far plane (m).
    #[serde(default = "default_far")]
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
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
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
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
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
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum Targets {
    /// `"all"`.
    All(String),
    /// Body names (a crowd's name stands for all its bodies).
    Names(Vec<String>),
}

/// A force at a point of a link over `[t0, t1]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PushSpec {
    /// `"all"` or a list of body or crowd names.
    pub bodies: Targets,
    /// URDF link name.
    pub link: String,
    /// Point of application in the link frame (m).
    #[serde(default)]
    pub point: V3,
    /// Force (N), world frame.
    pub force: V3,
    /// Start time (s).
    pub t0: f64,
    /// End time (s).
    pub t1: f64,
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
    /// The URDF path as resolved.
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
}

/// The largest scene file read, in bytes.
pub const MAX_SCENE_BYTES: u64 = 16 << 20;

/// Reads and checks a scene file.
pub fn load_scene(path: impl AsRef<Path>) -> Result<LoadedScene, ViewError> {
    load_scene_with(path, InertiaPolicy::default())
}

/// [`load_scene`] with the inertia policy its models are loaded with.
pub fn load_scene_with(
    path: impl AsRef<Path>,
    inertia: InertiaPolicy,
) -> Result<LoadedScene, ViewError> {
    let path = path.as_ref();
    let io = |message: String| ViewError::Io {
        path: path.display().to_string(),
        message,
    };
    let bytes =
        articula_model::read_limited(path, MAX_SCENE_BYTES).map_err(|e| io(e.to_string()))?;
    let text = String::from_utf8(bytes).map_err(|e| io(e.to_string()))?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse_scene_with(&text, path, base, inertia)
}

/// Parses and checks scene text; `path` names the file in errors and `base` is the folder model
/// paths are relative to.
pub fn parse_scene(text: &str, path: &Path, base: &Path) -> Result<LoadedScene, ViewError> {
    parse_scene_with(text, path, base, InertiaPolicy::default())
}

/// [`parse_scene`] with the inertia policy its models are loaded with.
pub fn parse_scene_with(
    text: &str,
    path: &Path,
    base: &Path,
    inertia: InertiaPolicy,
) -> Result<LoadedScene, ViewError> {
    let file = path.display().to_string();
    let de = &mut serde_json::Deserializer::from_str(text);
    let spec: SceneSpec = serde_path_to_error::deserialize(de).map_err(|e| {
        let field = match e.path().to_string() {
            f if f == "." => "top level".to_string(),
            f => f,
        };
        ViewError::Json {
            path: file.clone(),
            field,
            message: e.inner().to_string(),
        }
    })?;
    resolve(spec, path, base, inertia)
}

fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn resolve(
    spec: SceneSpec,
    path: &Path,
    base: &Path,
    inertia: InertiaPolicy,
) -> Result<LoadedScene, ViewError> {
    let file = path.display().to_string();
    let invalid = |field: String, message: String| ViewError::Invalid {
        path: file.clone(),
        field,
        message,
    };
    // Scalars.
    if !(spec.dt.is_finite() && spec.dt > 0.0) {
        return Err(invalid("dt".into(), "must be a positive number".into()));
    }
    if spec.reselect_every == 0 {
        return Err(invalid(
            "reselect_every".into(),
            "must be at least 1".into(),
        ));
    }
    if let Some(t) = spec.tolerance {
        if !(t.is_finite() && t >= 0.0) {
            return Err(invalid(
                "tolerance".into(),
                "must be a non-negative number".into(),
            ));
        }
    }
    if !finite(&spec.gravity) {
        return Err(invalid("gravity".into(), "must be finite".into()));
    }
    let v = spec.visibility;
    if !(v.occluded_factor.is_finite() && (0.0..=1.0).contains(&v.occluded_factor)) {
        return Err(invalid(
            "visibility.occluded_factor".into(),
            "must lie in [0, 1]".into(),
        ));
    }
    if !(v.full_detail_size.is_finite() && v.full_detail_size > 0.0) {
        return Err(invalid(
            "visibility.full_detail_size".into(),
            "must be a positive number".into(),
        ));
    }
    if v.depth_buffer[0] == 0
        || v.depth_buffer[1] == 0
        || v.depth_buffer[0] * v.depth_buffer[1] > 1 << 22
    {
        return Err(invalid(
            "visibility.depth_buffer".into(),
            "needs 1 to 4,194,304 cells, both sides at least 1".into(),
        ));
    }
    let img = spec.image;
    if img.width == 0 || img.height == 0 || img.width > 8192 || img.height > 8192 {
        return Err(invalid(
            "image".into(),
            "width and height must lie in 1..=8192".into(),
        ));
    }
    if let Some(j) = spec.joint_springs {
        for (f, x) in [
            ("frequency_hz", j.frequency_hz),
            ("damping_ratio", j.damping_ratio),
        ] {
            if !(x.is_finite() && x >= 0.0) {
                return Err(invalid(
                    format!("joint_springs.{f}"),
                    "must be a non-negative number".into(),
                ));
            }
        }
    }
    // Camera.
    let c = &spec.camera;
    let aspect = img.width as f64 / img.height as f64;
    let cam_err = |e: ViewError| invalid("camera".into(), e.to_string());
    let camera = match (c.eye, c.target, &c.path) {
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
            .map_err(|e| invalid("camera.path".into(), e.to_string()))?,
        ),
        _ => {
            return Err(invalid(
                "camera".into(),
                "give either both 'eye' and 'target' (a fixed camera) or 'path' (keyframes)".into(),
            ))
        }
    };
    // Models.
    if spec.models.is_empty() {
        return Err(invalid("models".into(), "names no model".into()));
    }
    let mut models = Vec::new();
    let mut model_index = BTreeMap::new();
    for (name, rel) in &spec.models {
        let p = base.join(rel);
        let model = Model::from_urdf_file(
            &p,
            &LoadOptions::default()
                .with_floating_base(true)
                .with_inertia(inertia),
        )
        .map_err(|error| ViewError::Model {
            path: file.clone(),
            name: name.clone(),
            model_path: p.display().to_string(),
            error: Box::new(error),
        })?;
        model_index.insert(name.clone(), models.len());
        models.push(SceneModel {
            name: name.clone(),
            path: p,
            volumes: body_volumes(&model),
            model,
        });
    }
    let find_model = |field: String, name: &str| {
        model_index.get(name).copied().ok_or_else(|| {
            invalid(
                field,
                format!(
                    "no model named '{name}' (models: {})",
                    spec.models.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            )
        })
    };
    // Placements.
    let mut placements = Vec::new();
    let mut groups: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    let place = |model: &Model, pos: DVec3, rot: DMat3, vel: &VelocitySpec| {
        let mut q = model.neutral_q();
        let mut qd = vec![0.0; model.nv];
        let r = DQuat::from_mat3(&rot).normalize();
        q[..7].copy_from_slice(&[pos.x, pos.y, pos.z, r.w, r.x, r.y, r.z]);
        // The floating base's velocity is in root coordinates.
        let w = rot.transpose() * DVec3::from_array(vel.angular);
        let v = rot.transpose() * DVec3::from_array(vel.linear);
        qd[..6].copy_from_slice(&[w.x, w.y, w.z, v.x, v.y, v.z]);
        (q, qd)
    };
    let check_vel = |field: String, v: &VelocitySpec| {
        if finite(&v.linear) && finite(&v.angular) {
            Ok(())
        } else {
            Err(invalid(field, "must be finite".into()))
        }
    };
    for (i, b) in spec.bodies.iter().enumerate() {
        let m = find_model(format!("bodies[{i}].model"), &b.model)?;
        if !finite(&b.position) || !finite(&b.rpy) {
            return Err(invalid(
                format!("bodies[{i}]"),
                "position and rpy must be finite".into(),
            ));
        }
        check_vel(format!("bodies[{i}].velocity"), &b.velocity)?;
        let rot = articula_model::rpy_to_matrix(DVec3::from_array(b.rpy));
        let (q, qd) = place(
            &models[m].model,
            DVec3::from_array(b.position),
            rot,
            &b.velocity,
        );
        let name = b.name.clone().unwrap_or_else(|| format!("body{i}"));
        if groups.contains_key(&name) {
            return Err(invalid(
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
        let field = |f: &str| format!("crowds[{i}].{f}");
        let m = find_model(field("model"), &c.model)?;
        if c.rows == 0 || c.columns == 0 || c.rows.saturating_mul(c.columns) > 1_000_000 {
            return Err(invalid(
                field("rows"),
                "rows and columns must be at least 1, with at most 1,000,000 bodies".into(),
            ));
        }
        if !finite(&c.origin) || !finite(&c.spacing) {
            return Err(invalid(
                field("origin"),
                "origin and spacing must be finite".into(),
            ));
        }
        for (f, x) in [("jitter", c.jitter), ("yaw_jitter", c.yaw_jitter)] {
            if !(x.is_finite() && x >= 0.0) {
                return Err(invalid(field(f), "must be a non-negative number".into()));
            }
        }
        if !c.yaw.is_finite() {
            return Err(invalid(field("yaw"), "must be finite".into()));
        }
        check_vel(field("velocity"), &c.velocity)?;
        let name = c.name.clone().unwrap_or_else(|| format!("crowd{i}"));
        if groups.contains_key(&name) {
            return Err(invalid(field("name"), format!("duplicate name '{name}'")));
        }
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
                let (q, qd) = place(
                    &models[m].model,
                    pos,
                    DMat3::from_rotation_z(yaw),
                    &c.velocity,
                );
                members.push(placements.len());
                placements.push(Placement {
                    name: format!("{name}[{r},{col}]"),
                    model: m,
                    q,
                    qd,
                });
            }
        }
        groups.insert(name, members);
    }
    if placements.is_empty() {
        return Err(invalid(
            "bodies".into(),
            "the scene has no body (give 'bodies' or 'crowds')".into(),
        ));
    }
    // Pushes.
    let mut pushes = Vec::new();
    for (i, p) in spec.pushes.iter().enumerate() {
        let field = |f: &str| format!("pushes[{i}].{f}");
        if !finite(&p.point) || !finite(&p.force) {
            return Err(invalid(
                field("force"),
                "point and force must be finite".into(),
            ));
        }
        if !(p.t0.is_finite() && p.t1.is_finite() && p.t0 <= p.t1) {
            return Err(invalid(field("t0"), "needs finite t0 ≤ t1".into()));
        }
        let targets: Vec<usize> = match &p.bodies {
            Targets::All(s) if s == "all" => (0..placements.len()).collect(),
            Targets::All(s) => {
                return Err(invalid(
                    field("bodies"),
                    format!("expected \"all\" or a list of names, found \"{s}\""),
                ))
            }
            Targets::Names(names) => {
                let mut out = Vec::new();
                for (k, n) in names.iter().enumerate() {
                    match groups.get(n) {
                        Some(g) => out.extend_from_slice(g),
                        None => match placements.iter().position(|pl| &pl.name == n) {
                            Some(b) => out.push(b),
                            None => {
                                return Err(invalid(
                                    format!("pushes[{i}].bodies[{k}]"),
                                    format!("no body or crowd named '{n}'"),
                                ))
                            }
                        },
                    }
                }
                out
            }
        };
        for b in targets {
            let model = &models[placements[b].model].model;
            let found = model.bodies.iter().enumerate().find_map(|(bi, body)| {
                body.links
                    .iter()
                    .find(|(name, _)| name == &p.link)
                    .map(|(_, x)| (bi, *x))
            });
            let Some((link_body, x)) = found else {
                return Err(invalid(
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
    Ok(LoadedScene {
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
        image: img,
        joint_springs: spec.joint_springs,
    })
}
