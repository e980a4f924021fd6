//! The recorder: characters (placed models) whose body poses are sampled over time, written as
//! one binary glTF 2.0 file with one node per body and one animation.

use crate::geometry::TriMesh;
use crate::visuals::{BodyMesh, ModelMeshes};
use crate::GltfError;
use glam::{DMat3, DQuat, DVec3};
use serde_json::{json, Value};
use std::path::Path;

/// A model added to a recorder: its body names and geometry.
#[derive(Clone, Debug)]
struct RecModel {
    bodies: Vec<String>,
    meshes: ModelMeshes,
}

/// One placed model: a node per body, each with its sampled poses.
#[derive(Clone, Debug)]
struct Character {
    name: String,
    model: usize,
    /// Index of its first body's track in [`GltfRecorder::tracks`].
    first: usize,
}

/// The sampled world poses of one body node (f32, as glTF stores them).
#[derive(Clone, Debug, Default)]
struct Track {
    translation: Vec<[f32; 3]>,
    /// Unit quaternions `[x, y, z, w]`, each sample's sign chosen nearest the previous one
    /// (so that viewers interpolate the short way).
    rotation: Vec<[f32; 4]>,
}

/// What a written file holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GltfSummary {
    /// File size (bytes).
    pub bytes: usize,
    /// Body nodes (animated).
    pub body_nodes: usize,
    /// Time samples.
    pub samples: usize,
    /// Meshes written (shared by the characters of one model).
    pub meshes: usize,
    /// Triangles over the meshes written (each counted once however often it is drawn).
    pub triangles: usize,
}

/// Records the body poses of one or more articulated models over time and writes them as an
/// animated binary glTF (`.glb`): one node per body (its world pose sampled at every
/// [`GltfRecorder::record`], linear interpolation between samples), the body's visual geometry
/// as a mesh shared by every character of the same model, materials from the model's colours,
/// and optionally a floor.
#[derive(Clone, Debug, Default)]
pub struct GltfRecorder {
    models: Vec<RecModel>,
    characters: Vec<Character>,
    tracks: Vec<Track>,
    times: Vec<f32>,
    floor: Option<f64>,
}

impl GltfRecorder {
    /// An empty recorder.
    pub fn new() -> GltfRecorder {
        GltfRecorder::default()
    }

    /// Adds a model (its geometry from [`ModelMeshes::load`]); returns its index for
    /// [`GltfRecorder::add_character`].
    pub fn add_model(&mut self, model: &articula_model::Model, meshes: ModelMeshes) -> usize {
        self.models.push(RecModel {
            bodies: model.bodies.iter().map(|b| b.name.clone()).collect(),
            meshes,
        });
        self.models.len() - 1
    }

    /// Adds a character: a placed copy of model `model` named `name` (node names are
    /// `name/body`). Characters must all be added before the first sample.
    pub fn add_character(&mut self, name: &str, model: usize) -> Result<usize, GltfError> {
        if !self.times.is_empty() {
            return Err(GltfError::Usage(format!(
                "character '{name}' added after the first sample"
            )));
        }
        let m = self
            .models
            .get(model)
            .ok_or_else(|| GltfError::Usage(format!("character '{name}': no model {model}")))?;
        let first = self.tracks.len();
        self.tracks
            .resize_with(first + m.bodies.len(), Track::default);
        self.characters.push(Character {
            name: name.to_string(),
            model,
            first,
        });
        Ok(self.characters.len() - 1)
    }

    /// Shows a floor (a square grey plane at height `z`, under everything recorded).
    pub fn set_floor(&mut self, z: Option<f64>) {
        self.floor = z.filter(|z| z.is_finite());
    }

    /// Number of samples recorded.
    pub fn samples(&self) -> usize {
        self.times.len()
    }

    /// Records one sample at time `t` (s, after the previous sample's): for every character in
    /// order, the world pose `(rotation, translation)` of each of its model's bodies (body
    /// axes as columns in world coordinates, body origin in world coordinates).
    pub fn record<'p>(
        &mut self,
        t: f64,
        poses: impl IntoIterator<Item = &'p [(DMat3, DVec3)]>,
    ) -> Result<(), GltfError> {
        let tf = t as f32;
        if !tf.is_finite() || self.times.last().is_some_and(|&last| tf <= last) {
            return Err(GltfError::Usage(format!(
                "sample time {t} s does not come after the previous sample's (glTF stores f32 \
                 times: {:?} s)",
                self.times.last()
            )));
        }
        let mut count = 0;
        for (c, body_poses) in poses.into_iter().enumerate() {
            let Some(ch) = self.characters.get(c) else {
                return Err(GltfError::Usage(format!(
                    "poses given for more than the {} characters",
                    self.characters.len()
                )));
            };
            let n = self.models[ch.model].bodies.len();
            if body_poses.len() != n {
                return Err(GltfError::Usage(format!(
                    "character '{}': {} poses for {n} bodies",
                    ch.name,
                    body_poses.len()
                )));
            }
            if body_poses
                .iter()
                .any(|(r, p)| !(r.is_finite() && p.is_finite()))
            {
                return Err(GltfError::Usage(format!(
                    "character '{}': a pose at t = {t} s is not finite",
                    ch.name
                )));
            }
            for (track, (r, p)) in self.tracks[ch.first..ch.first + n]
                .iter_mut()
                .zip(body_poses)
            {
                track.translation.push(p.as_vec3().to_array());
                let mut q = DQuat::from_mat3(r).normalize();
                if let Some(prev) = track.rotation.last() {
                    let prev = DQuat::from_xyzw(
                        prev[0].into(),
                        prev[1].into(),
                        prev[2].into(),
                        prev[3].into(),
                    );
                    if prev.dot(q) < 0.0 {
                        q = -q;
                    }
                }
                track.rotation.push(q.as_quat().normalize().to_array());
            }
            count += 1;
        }
        if count != self.characters.len() {
            return Err(GltfError::Usage(format!(
                "poses of {count} characters given, {} added",
                self.characters.len()
            )));
        }
        self.times.push(tf);
        Ok(())
    }

    /// Writes the file: to a temporary name beside `path`, renamed to `path` once complete.
    pub fn write(&self, path: &Path) -> Result<GltfSummary, GltfError> {
        let (bytes, mut summary) = self.to_glb()?;
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out.glb".into());
        let tmp = path.with_file_name(format!(".{name}.partial"));
        let io = |e: std::io::Error, p: &Path| GltfError::Io {
            path: p.display().to_string(),
            message: e.to_string(),
        };
        std::fs::write(&tmp, &bytes).map_err(|e| io(e, &tmp))?;
        std::fs::rename(&tmp, path).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            io(e, path)
        })?;
        summary.bytes = bytes.len();
        Ok(summary)
    }

    /// The binary glTF file and what it holds.
    pub fn to_glb(&self) -> Result<(Vec<u8>, GltfSummary), GltfError> {
        let mut w = Writer::default();
        let mut summary = GltfSummary {
            bytes: 0,
            body_nodes: self.tracks.len(),
            samples: self.times.len(),
            meshes: 0,
            triangles: 0,
        };
        // Meshes: per model, per body (and the world's), shared by the model's characters.
        let mut body_mesh: Vec<Vec<Option<usize>>> = Vec::new();
        let mut world_mesh: Vec<Option<usize>> = Vec::new();
        for m in &self.models {
            let ids = m
                .bodies
                .iter()
                .zip(&m.meshes.bodies)
                .map(|(name, mesh)| w.mesh(name, mesh, &mut summary))
                .collect();
            body_mesh.push(ids);
            world_mesh.push(w.mesh("world", &m.meshes.world, &mut summary));
        }
        // The root turns articula's z-up world into glTF's y-up one: −90° about x, so that
        // (x, y, z) is drawn at (x, z, −y). Below it, every pose is in articula's world.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let mut nodes: Vec<Value> =
            vec![json!({"name": "articula", "rotation": [-h, 0.0, 0.0, h], "children": []})];
        let mut roots = Vec::new();
        let mut channels = Vec::new();
        let mut samplers = Vec::new();
        let input = (!self.times.is_empty()).then(|| w.times(&self.times));
        for ch in &self.characters {
            let model = &self.models[ch.model];
            let mut children = Vec::new();
            for (b, name) in model.bodies.iter().enumerate() {
                let track = &self.tracks[ch.first + b];
                let mut node = json!({"name": format!("{}/{}", ch.name, name)});
                if let Some(mesh) = body_mesh[ch.model][b] {
                    node["mesh"] = mesh.into();
                }
                if let (Some(t), Some(r)) = (track.translation.first(), track.rotation.first()) {
                    node["translation"] = json!(t);
                    node["rotation"] = json!(r);
                }
                let id = nodes.len();
                nodes.push(node);
                children.push(id);
                if let Some(input) = input {
                    for (path, output) in [
                        ("translation", w.vec3s(&track.translation)),
                        ("rotation", w.vec4s(&track.rotation)),
                    ] {
                        channels.push(json!({
                            "sampler": samplers.len(),
                            "target": {"node": id, "path": path}
                        }));
                        samplers.push(json!({
                            "input": input, "output": output, "interpolation": "LINEAR"
                        }));
                    }
                }
            }
            if let Some(mesh) = world_mesh[ch.model] {
                children.push(nodes.len());
                nodes.push(json!({"name": format!("{}/world", ch.name), "mesh": mesh}));
            }
            roots.push(nodes.len());
            nodes.push(json!({"name": ch.name, "children": children}));
        }
        if let Some(z) = self.floor {
            let (centre, half) = self.extent();
            let mesh = w.floor(z, centre, half);
            roots.push(nodes.len());
            nodes.push(json!({"name": "floor", "mesh": mesh}));
        }
        nodes[0]["children"] = json!(roots);
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": "articula-gltf"},
            "scene": 0,
            "scenes": [{"name": "articula", "nodes": [0]}],
            "nodes": nodes,
        });
        if !channels.is_empty() {
            doc["animations"] = json!([{
                "name": "simulation", "channels": channels, "samplers": samplers
            }]);
        }
        Ok((w.finish(doc)?, summary))
    }

    /// The centre and half-size (in x and y) of the square that holds every recorded body
    /// origin, with a 2 m margin.
    fn extent(&self) -> (DVec3, f64) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in self.tracks.iter().flat_map(|t| &t.translation) {
            let p = glam::Vec3::from(*p).as_dvec3();
            lo = lo.min(p);
            hi = hi.max(p);
        }
        if !lo.is_finite() {
            return (DVec3::ZERO, 2.0);
        }
        let centre = 0.5 * (lo + hi);
        let half = 0.5 * (hi - lo).x.max((hi - lo).y) + 2.0;
        (centre, half)
    }
}

/// Accumulates the binary buffer and the JSON arrays that index it.
#[derive(Default)]
struct Writer {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    materials: Vec<Value>,
    /// Materials by colour (0..=255 per channel).
    material_keys: Vec<[u8; 4]>,
    /// The buffer view of all animation data (created at the first animation accessor).
    anim_view: Option<(usize, usize)>,
    anim: Vec<u8>,
}

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const FLOAT: u32 = 5126;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

impl Writer {
    /// A buffer view of `bytes` (4-byte aligned) with an optional target; returns its index.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = t.into();
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn accessor(&mut self, a: Value) -> usize {
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// A float accessor of `n`-vectors over its own vertex buffer view, with min and max.
    fn vertex_floats(&mut self, data: &[[f32; 3]], kind: &str, bounds: bool) -> usize {
        let flat: Vec<f32> = data.iter().flatten().copied().collect();
        let view = self.view(&f32_bytes(&flat), Some(ARRAY_BUFFER));
        let mut a = json!({
            "bufferView": view, "componentType": FLOAT, "count": data.len(), "type": kind
        });
        if bounds {
            let (lo, hi) = min_max(data);
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.accessor(a)
    }

    fn indices(&mut self, m: &TriMesh) -> usize {
        let (bytes, component): (Vec<u8>, u32) = if m.positions.len() <= u16::MAX as usize {
            let b = m.indices.iter().flat_map(|&i| (i as u16).to_le_bytes());
            (b.collect(), UNSIGNED_SHORT)
        } else {
            let b = m.indices.iter().flat_map(|&i| i.to_le_bytes());
            (b.collect(), UNSIGNED_INT)
        };
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessor(json!({
            "bufferView": view, "componentType": component, "count": m.indices.len(),
            "type": "SCALAR"
        }))
    }

    fn material(&mut self, rgba: [f64; 4]) -> usize {
        let key = rgba.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8);
        if let Some(i) = self.material_keys.iter().position(|k| *k == key) {
            return i;
        }
        let mut m = json!({
            "name": format!("rgba {} {} {} {}", key[0], key[1], key[2], key[3]),
            "pbrMetallicRoughness": {
                "baseColorFactor": key.map(|c| f64::from(c) / 255.0),
                "metallicFactor": 0.1,
                "roughnessFactor": 0.7
            }
        });
        if key[3] < 255 {
            m["alphaMode"] = "BLEND".into();
        }
        self.materials.push(m);
        self.material_keys.push(key);
        self.materials.len() - 1
    }

    /// A mesh of `body`'s parts (one primitive per colour); `None` when it has none.
    fn mesh(&mut self, name: &str, body: &BodyMesh, summary: &mut GltfSummary) -> Option<usize> {
        let mut primitives = Vec::new();
        for (rgba, m) in &body.parts {
            if m.indices.is_empty() {
                continue;
            }
            let position = self.vertex_floats(&m.positions, "VEC3", true);
            let normal = self.vertex_floats(&m.normals, "VEC3", false);
            let indices = self.indices(m);
            let material = self.material(*rgba);
            primitives.push(json!({
                "attributes": {"POSITION": position, "NORMAL": normal},
                "indices": indices, "material": material, "mode": 4
            }));
            summary.triangles += m.triangles();
        }
        if primitives.is_empty() {
            return None;
        }
        summary.meshes += 1;
        self.meshes
            .push(json!({"name": name, "primitives": primitives}));
        Some(self.meshes.len() - 1)
    }

    /// A square floor at height `z` centred under `centre`, of half-size `half`.
    fn floor(&mut self, z: f64, centre: DVec3, half: f64) -> usize {
        let c = DVec3::new(centre.x, centre.y, z);
        let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
        let floor = TriMesh {
            positions: corners
                .map(|(x, y)| {
                    (c + DVec3::new(x * half, y * half, 0.0))
                        .as_vec3()
                        .to_array()
                })
                .to_vec(),
            normals: vec![[0.0, 0.0, 1.0]; 4],
            indices: vec![0, 1, 2, 0, 2, 3],
        };
        let body = BodyMesh {
            parts: vec![([0.45, 0.47, 0.5, 1.0], floor)],
        };
        let mut ignore = GltfSummary {
            bytes: 0,
            body_nodes: 0,
            samples: 0,
            meshes: 0,
            triangles: 0,
        };
        self.mesh("floor", &body, &mut ignore)
            .expect("the floor has triangles")
    }

    /// Appends floats to the animation data; returns the byte offset in it.
    fn anim_floats(&mut self, v: &[f32]) -> usize {
        let at = self.anim.len();
        self.anim.extend(f32_bytes(v));
        at
    }

    fn anim_accessor(&mut self, offset: usize, count: usize, kind: &str) -> usize {
        // The view index is fixed at the end ([`Writer::finish`]); mark it now.
        self.anim_view.get_or_insert((usize::MAX, 0));
        self.accessor(json!({
            "bufferView": "animation", "byteOffset": offset, "componentType": FLOAT,
            "count": count, "type": kind
        }))
    }

    fn times(&mut self, times: &[f32]) -> usize {
        let at = self.anim_floats(times);
        let a = self.anim_accessor(at, times.len(), "SCALAR");
        self.accessors[a]["min"] = json!([times[0]]);
        self.accessors[a]["max"] = json!([times[times.len() - 1]]);
        a
    }

    fn vec3s(&mut self, v: &[[f32; 3]]) -> usize {
        let flat: Vec<f32> = v.iter().flatten().copied().collect();
        let at = self.anim_floats(&flat);
        self.anim_accessor(at, v.len(), "VEC3")
    }

    fn vec4s(&mut self, v: &[[f32; 4]]) -> usize {
        let flat: Vec<f32> = v.iter().flatten().copied().collect();
        let at = self.anim_floats(&flat);
        self.anim_accessor(at, v.len(), "VEC4")
    }

    /// The GLB: the JSON chunk, then the binary chunk.
    fn finish(mut self, mut doc: Value) -> Result<Vec<u8>, GltfError> {
        if self.anim_view.is_some() {
            let anim = std::mem::take(&mut self.anim);
            let view = self.view(&anim, None);
            for a in &mut self.accessors {
                if a["bufferView"] == "animation" {
                    a["bufferView"] = view.into();
                }
            }
        }
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        for (key, list) in [
            ("meshes", self.meshes),
            ("materials", self.materials),
            ("accessors", self.accessors),
            ("bufferViews", self.views),
        ] {
            if !list.is_empty() {
                doc[key] = Value::Array(list);
            }
        }
        if !self.bin.is_empty() {
            doc["buffers"] = json!([{"byteLength": self.bin.len()}]);
        }
        let mut text = serde_json::to_vec(&doc).expect("JSON of plain values");
        while !text.len().is_multiple_of(4) {
            text.push(b' ');
        }
        let bin_chunk = if self.bin.is_empty() {
            0
        } else {
            8 + self.bin.len()
        };
        let total = 12 + 8 + text.len() + bin_chunk;
        if total > u32::MAX as usize {
            return Err(GltfError::TooLarge { bytes: total });
        }
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(text.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&text);
        if !self.bin.is_empty() {
            out.extend_from_slice(&(self.bin.len() as u32).to_le_bytes());
            out.extend_from_slice(b"BIN\0");
            out.extend_from_slice(&self.bin);
        }
        Ok(out)
    }
}

fn min_max(data: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in data {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}
