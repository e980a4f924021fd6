//! # articula-gltf
//!
//! Animated **glTF 2.0** export (binary `.glb`, self-contained) of articulated-body motion, the
//! format Blender, three.js, game engines and online viewers read (`docs/gltf.md`).
//!
//! One node per body, placed at the body's world pose `(R, p)` sampled over time: the node's
//! `rotation` is the unit quaternion of `R` (body axes as columns in world coordinates) and its
//! `translation` is `p`, so a point `x` of the body frame is drawn at `R x + p`. Each body's
//! mesh is its links' `<visual>` geometry placed in the body frame (URDF primitives
//! tessellated, STL / COLLADA / OBJ files read by `mesh-loader`), shared by every character of
//! the same model. One animation, linear interpolation between samples.
//!
//! ```
//! use articula_gltf::{GltfRecorder, MeshOptions, ModelMeshes};
//! use articula_model::{LoadOptions, Model};
//! use glam::{DMat3, DVec3};
//!
//! let urdf = r#"<robot name="r"><link name="a"><inertial><mass value="1"/>
//!   <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
//!   <visual><geometry><box size="1 2 3"/></geometry></visual></link></robot>"#;
//! let model = Model::from_urdf_str(urdf, &LoadOptions::default().with_floating_base(true)).unwrap();
//! let mut rec = GltfRecorder::new();
//! let m = rec.add_model(&model, ModelMeshes::load(&model, None, &MeshOptions::default()));
//! rec.add_character("robot", m).unwrap();
//! for k in 0..3 {
//!     let pose = (DMat3::from_rotation_z(0.1 * k as f64), DVec3::new(0.0, 0.0, k as f64));
//!     rec.record(0.5 * k as f64, [&[pose][..]]).unwrap();
//! }
//! let (glb, summary) = rec.to_glb().unwrap();
//! assert_eq!(&glb[..4], b"glTF");
//! assert_eq!((summary.body_nodes, summary.samples, summary.triangles), (1, 3, 12));
//! ```

mod geometry;
mod recorder;
mod simulation;
mod visuals;

pub use geometry::{tessellate, TriMesh};
pub use recorder::{GltfRecorder, GltfSummary};
pub use simulation::GltfFile;
pub use visuals::{resolve, BodyMesh, MeshOptions, ModelMeshes, DEFAULT_RGBA};

use articula_model::Model;
use articula_view::{LoadedScene, PosePlan, SceneSim};
use glam::{DMat3, DVec3};
use std::path::Path;

/// What can go wrong while recording or writing.
#[derive(Debug, thiserror::Error)]
pub enum GltfError {
    /// The recorder was used out of order (a sample time not increasing, poses not matching
    /// the characters).
    #[error("glTF recorder: {0}")]
    Usage(String),
    /// The file could not be written.
    #[error("cannot write {path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// The system's message.
        message: String,
    },
    /// The file would exceed the 4 GiB a `.glb` can hold.
    #[error("the glTF file would be {bytes} bytes, over the 4 GiB a .glb can hold (record fewer samples)")]
    TooLarge {
        /// Its size.
        bytes: usize,
    },
}

/// Records one model's motion from its joint coordinates `q` (`articula simulate`).
#[derive(Clone, Debug)]
pub struct TrajectoryRecorder {
    recorder: GltfRecorder,
    plan: PosePlan,
    poses: Vec<(DMat3, DVec3)>,
    /// Warnings from reading the geometry (missing mesh files), for the caller to print.
    pub warnings: Vec<String>,
}

impl TrajectoryRecorder {
    /// A recorder of `model`, loaded from the URDF `urdf` when known (for its visuals).
    pub fn new(model: &Model, urdf: Option<&Path>, options: &MeshOptions) -> TrajectoryRecorder {
        let meshes = ModelMeshes::load(model, urdf, options);
        let warnings = meshes.warnings.clone();
        let mut recorder = GltfRecorder::new();
        let m = recorder.add_model(model, meshes);
        recorder
            .add_character(&model.name, m)
            .expect("a character added before any sample, of the model just added");
        TrajectoryRecorder {
            recorder,
            plan: PosePlan::new(model),
            poses: Vec::new(),
            warnings,
        }
    }

    /// Shows a floor at height `z`.
    pub fn set_floor(&mut self, z: Option<f64>) {
        self.recorder.set_floor(z);
    }

    /// Records the pose of every body at time `t` for coordinates `q` (of `model`, the one
    /// given to [`TrajectoryRecorder::new`]).
    pub fn record(&mut self, model: &Model, t: f64, q: &[f64]) -> Result<(), GltfError> {
        if q.len() != model.nq {
            return Err(GltfError::Usage(format!(
                "q has {} coordinates, the model {}",
                q.len(),
                model.nq
            )));
        }
        self.plan.poses(model, q, &mut self.poses);
        self.recorder.record(t, [&self.poses[..]])
    }

    /// The recorder (for [`GltfRecorder::to_glb`]).
    pub fn recorder(&self) -> &GltfRecorder {
        &self.recorder
    }

    /// Writes the file (through a temporary name).
    pub fn write(&self, path: &Path) -> Result<GltfSummary, GltfError> {
        self.recorder.write(path)
    }
}

/// Records every character of a scene (`articula scene`): each scene model's meshes once,
/// one node per body of every character.
#[derive(Clone, Debug)]
pub struct SceneRecorder {
    recorder: GltfRecorder,
    groups: Vec<Vec<usize>>,
    /// Warnings from reading the geometry (missing mesh files), each prefixed by its model.
    pub warnings: Vec<String>,
}

impl SceneRecorder {
    /// A recorder of `scene`'s characters, with a floor where the scene has one.
    pub fn new(scene: &LoadedScene, options: &MeshOptions) -> SceneRecorder {
        let mut recorder = GltfRecorder::new();
        let mut warnings = Vec::new();
        let mut ids = Vec::new();
        for m in &scene.models {
            let urdf = (!m.path.as_os_str().is_empty()).then_some(m.path.as_path());
            let meshes = ModelMeshes::load(&m.model, urdf, options);
            warnings.extend(meshes.warnings.iter().map(|w| format!("{}: {w}", m.name)));
            ids.push(recorder.add_model(&m.model, meshes));
        }
        for p in &scene.placements {
            recorder
                .add_character(&p.name, ids[p.model])
                .expect("characters added before any sample, of models just added");
        }
        recorder.set_floor(scene.ground.as_ref().map(|g| g.height));
        SceneRecorder {
            recorder,
            groups: Vec::new(),
            warnings,
        }
    }

    /// Records every character's body poses at the scene's current time.
    pub fn record(&mut self, sim: &mut SceneSim) -> Result<(), GltfError> {
        let t = sim.time();
        let frame = sim.frame(&mut self.groups);
        self.recorder.record(t, frame.iter().map(|b| b.poses))
    }

    /// The recorder (for [`GltfRecorder::to_glb`]).
    pub fn recorder(&self) -> &GltfRecorder {
        &self.recorder
    }

    /// Writes the file (through a temporary name).
    pub fn write(&self, path: &Path) -> Result<GltfSummary, GltfError> {
        self.recorder.write(path)
    }
}
