//! A model's visual geometry as triangles, one mesh per body, its parts grouped by colour:
//! the URDF's `<visual>` elements (primitives tessellated, mesh files read), a stand-in
//! primitive with one warning for a mesh file that cannot be found or read, and each body's
//! inertia box where a body has nothing to show.

use crate::geometry::{from_scene, tessellate, TriMesh};
use articula_model::{inertia_box, Model, Shape, VisualShape, Visuals};
use articula_spatial::SpatialTransform;
use glam::DVec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A mesh file's sub-mesh and its colour in the file, if any.
type Part = (TriMesh, Option<[f64; 4]>);

/// The colour of a visual without a material (light grey).
pub const DEFAULT_RGBA: [f64; 4] = [0.7, 0.7, 0.72, 1.0];

/// Where mesh files are looked for.
#[derive(Clone, Debug, Default)]
pub struct MeshOptions {
    /// Extra directories: `package://PKG/rest` is tried as `DIR/PKG/rest` and `DIR/rest` in
    /// each; a relative file name as `DIR/name`.
    pub search_paths: Vec<PathBuf>,
}

/// One body's (or the world's) geometry: triangles grouped by colour.
#[derive(Clone, Debug, Default)]
pub struct BodyMesh {
    /// `(rgba, triangles in the body frame)`, one entry per distinct colour.
    pub parts: Vec<([f64; 4], TriMesh)>,
}

impl BodyMesh {
    fn add(&mut self, rgba: [f64; 4], mesh: &TriMesh, x: &SpatialTransform) {
        let key = rgba.map(|c| (c * 255.0).round() as u8);
        let slot = self
            .parts
            .iter()
            .position(|(c, _)| c.map(|c| (c * 255.0).round() as u8) == key);
        let slot = slot.unwrap_or_else(|| {
            self.parts.push((rgba, TriMesh::default()));
            self.parts.len() - 1
        });
        self.parts[slot].1.append(mesh, x);
    }

    /// Number of triangles.
    pub fn triangles(&self) -> usize {
        self.parts.iter().map(|(_, m)| m.triangles()).sum()
    }
}

/// The geometry of every body of a model (index = body), and of the links welded to the
/// world (`world`, in world coordinates).
#[derive(Clone, Debug, Default)]
pub struct ModelMeshes {
    /// Per body, in the body frame.
    pub bodies: Vec<BodyMesh>,
    /// Links welded to the world (a fixed base), in world coordinates.
    pub world: BodyMesh,
    /// Mesh files read.
    pub files_read: usize,
    /// Warnings (a mesh file missing or unreadable, replaced by a stand-in primitive).
    pub warnings: Vec<String>,
}

impl ModelMeshes {
    /// The geometry of `model`, whose URDF is `urdf` when known (its `<visual>` elements, mesh
    /// files resolved against the URDF's folder and `options`); without a URDF, the model's
    /// kept primitives ([`Visuals::from_body_geometry`]). A body with no visual at all shows
    /// its inertia box.
    pub fn load(model: &Model, urdf: Option<&Path>, options: &MeshOptions) -> ModelMeshes {
        let mut out = ModelMeshes {
            bodies: vec![BodyMesh::default(); model.bodies.len()],
            ..ModelMeshes::default()
        };
        let visuals = match urdf.map(|p| Visuals::from_urdf_file(p, model)) {
            Some(Ok(v)) => v,
            Some(Err(e)) => {
                out.warnings
                    .push(format!("visuals not read ({e}); showing collision shapes"));
                Visuals::from_body_geometry(model)
            }
            None => Visuals::from_body_geometry(model),
        };
        let base = urdf.and_then(Path::parent).unwrap_or(Path::new("."));
        let mut cache: HashMap<PathBuf, Option<Vec<Part>>> = HashMap::new();
        for v in &visuals.items {
            let rgba = v.rgba;
            let target = match v.body {
                Some(b) => &mut out.bodies[b],
                None => &mut out.world,
            };
            match &v.shape {
                VisualShape::Primitive(s) => {
                    if let Some(m) = tessellate(s) {
                        target.add(rgba.unwrap_or(DEFAULT_RGBA), &m, &v.origin);
                    }
                }
                VisualShape::Mesh { filename, scale } => {
                    let found = resolve(filename, base, &options.search_paths);
                    let loaded = found.as_ref().and_then(|path| {
                        cache
                            .entry(path.clone())
                            .or_insert_with(|| read_mesh(path, &mut out.warnings))
                            .clone()
                    });
                    match loaded {
                        Some(parts) => {
                            for (m, colour) in from_scene_scaled(parts, *scale) {
                                let c = rgba.or(colour).unwrap_or(DEFAULT_RGBA);
                                target.add(c, &m, &v.origin);
                            }
                        }
                        None => {
                            if found.is_none() {
                                out.warnings.push(format!(
                                    "link '{}': mesh '{filename}' not found (looked beside {} \
                                     and in the search paths); drawn as a 5 cm sphere",
                                    v.link,
                                    base.display()
                                ));
                            }
                            let stand_in = tessellate(&Shape::Sphere { radius: 0.05 })
                                .expect("a sphere tessellates");
                            target.add(rgba.unwrap_or(DEFAULT_RGBA), &stand_in, &v.origin);
                        }
                    }
                }
            }
        }
        out.files_read = cache.values().filter(|v| v.is_some()).count();
        for (b, mesh) in out.bodies.iter_mut().enumerate() {
            if mesh.parts.is_empty() {
                if let Some((pose, size)) = inertia_box(&model.bodies[b].inertia) {
                    let cube = tessellate(&Shape::Box { size }).expect("a box tessellates");
                    mesh.add(DEFAULT_RGBA, &cube, &pose);
                }
            }
        }
        out
    }
}

/// Meshes as read (unit scale) scaled by `scale` per axis: normals by the inverse scale, and
/// a mirroring scale reverses the triangles so that they stay counter-clockwise from outside.
fn from_scene_scaled(parts: Vec<Part>, scale: DVec3) -> Vec<Part> {
    if scale == DVec3::ONE {
        return parts;
    }
    let flip = scale.x * scale.y * scale.z < 0.0;
    let s = scale.as_vec3();
    parts
        .into_iter()
        .map(|(mut m, c)| {
            for p in &mut m.positions {
                *p = (glam::Vec3::from(*p) * s).to_array();
            }
            for n in &mut m.normals {
                let v = (glam::Vec3::from(*n) / s).normalize_or_zero();
                *n = if v.is_finite() && v != glam::Vec3::ZERO {
                    v.to_array()
                } else {
                    [0.0, 0.0, 1.0]
                };
            }
            if flip {
                for t in m.indices.chunks_exact_mut(3) {
                    t.swap(1, 2);
                }
            }
            (m, c)
        })
        .collect()
}

/// Reads a mesh file (STL, COLLADA, OBJ) at unit scale; a warning and `None` when it fails.
fn read_mesh(path: &Path, warnings: &mut Vec<String>) -> Option<Vec<(TriMesh, Option<[f64; 4]>)>> {
    let loader = mesh_loader::Loader::default();
    match loader.load(path) {
        Ok(scene) => {
            let parts = from_scene(&scene);
            if parts.is_empty() {
                warnings.push(format!(
                    "mesh {} has no triangles; drawn as a 5 cm sphere",
                    path.display()
                ));
                return None;
            }
            Some(parts)
        }
        Err(e) => {
            warnings.push(format!(
                "mesh {} not read ({e}); drawn as a 5 cm sphere",
                path.display()
            ));
            None
        }
    }
}

/// The file a URDF mesh `filename` names, if it exists: `package://PKG/rest` is looked for as
/// `ANCESTOR/rest` for the nearest ancestor folder of the URDF named `PKG`, then as
/// `DIR/PKG/rest` and `DIR/rest` for each search path `DIR` (and each entry of the
/// `ROS_PACKAGE_PATH` environment variable); `file://` paths and absolute paths are taken as
/// they are; other names are relative to the URDF's folder, then to each search path.
pub fn resolve(filename: &str, base: &Path, search: &[PathBuf]) -> Option<PathBuf> {
    let ros: Vec<PathBuf> = std::env::var_os("ROS_PACKAGE_PATH")
        .map(|v| std::env::split_paths(&v).collect())
        .unwrap_or_default();
    let dirs = search.iter().chain(&ros);
    let mut candidates: Vec<PathBuf> = Vec::new();
    if let Some(rest) = filename.strip_prefix("package://") {
        let (pkg, rel) = rest.split_once('/').unwrap_or((rest, ""));
        let abs = std::path::absolute(base).unwrap_or_else(|_| base.to_path_buf());
        if let Some(root) = abs
            .ancestors()
            .find(|a| a.file_name().is_some_and(|n| n == pkg))
        {
            candidates.push(root.join(rel));
        }
        for d in dirs {
            candidates.push(d.join(pkg).join(rel));
            candidates.push(d.join(rel));
        }
    } else if let Some(path) = filename.strip_prefix("file://") {
        candidates.push(PathBuf::from(path));
    } else if Path::new(filename).is_absolute() {
        candidates.push(PathBuf::from(filename));
    } else {
        candidates.push(base.join(filename));
        candidates.extend(dirs.map(|d| d.join(filename)));
    }
    candidates.into_iter().find(|c| c.is_file())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn package_paths_resolve_against_the_urdf_ancestors_and_search_paths() {
        let dir =
            std::env::temp_dir().join(format!("articula-gltf-resolve-{}", std::process::id()));
        let pkg = dir.join("share/my_robot");
        std::fs::create_dir_all(pkg.join("meshes")).unwrap();
        std::fs::create_dir_all(pkg.join("urdf")).unwrap();
        std::fs::write(pkg.join("meshes/a.stl"), b"solid\nendsolid\n").unwrap();
        let base = pkg.join("urdf");
        let want = Some(pkg.join("meshes/a.stl"));
        assert_eq!(resolve("package://my_robot/meshes/a.stl", &base, &[]), want);
        assert_eq!(
            resolve("../meshes/a.stl", &base, &[]),
            Some(base.join("../meshes/a.stl"))
        );
        // Another package name: found only through a search path.
        assert_eq!(resolve("package://other/meshes/a.stl", &base, &[]), None);
        assert_eq!(
            resolve(
                "package://other/meshes/a.stl",
                &base,
                std::slice::from_ref(&pkg)
            ),
            want
        );
        assert_eq!(
            resolve(
                "package://my_robot/meshes/a.stl",
                Path::new("/nowhere"),
                &[dir.join("share")]
            ),
            want
        );
        let abs = pkg.join("meshes/a.stl");
        let url = format!("file://{}", abs.display());
        assert_eq!(resolve(&url, Path::new("/nowhere"), &[]), Some(abs));
        assert_eq!(resolve("missing.stl", &base, &[]), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
