//! MJCF `<mesh>` assets and the mass properties MuJoCo's compiler gives them.
//!
//! MuJoCo moves every mesh into its own principal frame: the vertices are scaled (`scale`,
//! after `refpos`/`refquat`), their centre of mass is found, the inertia about it is
//! diagonalised, and the mesh is re-expressed there. A mesh geom's frame is then its own
//! `pos`/`quat` composed with the mesh's (centre, principal axes), and its inertia is the
//! diagonal one scaled by `mass / volume`. This module does the same computation, in the same
//! order and with the same Jacobi iteration (`mjuu_eig3`), so the inertias (and the principal
//! frames) match MuJoCo's to rounding. The `inertia` attribute chooses how the volume is counted:
//!
//! - `legacy` (MuJoCo's default): each triangle's tetrahedron towards the surface centroid (for
//!   the centre of mass) and towards the centre of mass (for volume and inertia), with its
//!   volume taken positive — exact for convex meshes, larger than the true volume otherwise;
//! - `exact`: the same tetrahedra with signed volumes (the divergence theorem: exact for closed,
//!   consistently oriented meshes, which is checked);
//! - `shell`: mass spread on the surface, by area;
//! - `convex`: the convex hull's volume — not computed here (a clear error).

use super::mesh_file::{self, MeshFormat, TriangleMesh};
use super::xml::{Attrs, Compiler, Defaults, Doc, El, MAIN};
use crate::ModelError;
use glam::DVec3;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// MuJoCo's smallest denominator (`mjMINVAL`).
const MIN_VAL: f64 = 1e-15;
/// MuJoCo's `mjEPS`, below which a quaternion is not normalised.
const EPS: f64 = 1e-14;
/// MuJoCo 4's compiler diagonalises an inertia (`mjuu_eig3`) until the largest off-diagonal
/// entry is at most `max(tol, 4e-15)` times the largest entry, and does not reorder two moments
/// closer than `max(tol, 1e-12)` times it. Bodies' inertias (`fullinertia`, sums of geoms) are
/// diagonalised with `tol` = 4e-15, meshes' with 1e-7: a mesh keeps up to 1e-7 of off-diagonal
/// inertia that MuJoCo drops, so its principal moments are MuJoCo's only by the same rule.
/// (Read from MuJoCo 4.0.1's compiled library and checked bit for bit against it on random
/// matrices of every scale.)
pub(crate) const BODY_EIG_TOL: f64 = 4e-15;
/// The tolerance MuJoCo 4's `mjCMesh::Process` passes to `mjuu_eig3`.
pub(crate) const MESH_EIG_TOL: f64 = 1e-7;
/// The floor of the stopping tolerance.
const EIG_TOL_MIN: f64 = 4e-15;
/// The floor of the reordering tolerance.
const EIG_SORT_MIN: f64 = 1e-12;

/// How a mesh's volume and inertia are counted (the `<mesh inertia>` attribute).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum InertiaKind {
    Legacy,
    Exact,
    Shell,
    Convex,
}

/// A mesh's mass properties as MuJoCo compiles them, in the mesh file's frame.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MeshInertia {
    /// Volume (area for `shell`): mass = density × this.
    pub volume: f64,
    /// The centre of mass: the mesh frame's origin after MuJoCo re-centres it.
    pub pos: DVec3,
    /// The principal axes as MuJoCo's quaternion `[w, x, y, z]`.
    pub quat: [f64; 4],
    /// Half-sizes of the box with the same inertia per unit mass (MuJoCo's inertia box).
    pub boxsz: [f64; 3],
}

impl MeshInertia {
    /// Principal moments per unit mass (what MuJoCo's `mjCGeom::SetInertia` multiplies by
    /// the geom's mass).
    pub fn unit_moments(&self) -> DVec3 {
        let [a, b, c] = self.boxsz;
        DVec3::new(b * b + c * c, a * a + c * c, a * a + b * b) / 3.0
    }
}

/// The `<mesh>` assets of a model, read on first use and kept.
pub(crate) struct Meshes {
    /// Mesh name → its element.
    assets: HashMap<String, El>,
    /// The directory mesh files are resolved against (the model's directory and `meshdir`).
    dir: Option<PathBuf>,
    done: HashMap<String, MeshInertia>,
}

impl Meshes {
    /// Every `<asset><mesh>` of the document (names default to the file's stem, as MuJoCo's).
    pub fn read(doc: &Doc, compiler: &Compiler) -> Result<Meshes, ModelError> {
        let mut assets = HashMap::new();
        for asset in doc.root.each("asset") {
            for m in asset.each("mesh") {
                let name = match (m.attr("name"), m.attr("file")) {
                    (Some(n), _) => n.to_string(),
                    (None, Some(f)) => Path::new(f)
                        .file_stem()
                        .map(|s| s.to_string_lossy().into_owned())
                        .unwrap_or_default(),
                    (None, None) => {
                        return Err(doc.err(
                            m,
                            Some("name"),
                            "a <mesh> without a file needs a name",
                        ))
                    }
                };
                if assets.insert(name.clone(), m.clone()).is_some() {
                    return Err(doc.err(m, Some("name"), format!("repeated mesh name '{name}'")));
                }
            }
        }
        let dir = doc.dir.as_ref().map(|d| match &compiler.meshdir {
            Some(m) => d.join(m),
            None => d.clone(),
        });
        Ok(Meshes {
            assets,
            dir,
            done: HashMap::new(),
        })
    }

    /// The mass properties of mesh `name`, which geom `geom` (its attribute `mesh`) names.
    pub fn inertia(
        &mut self,
        doc: &Doc,
        defaults: &Defaults,
        name: &str,
        geom: &Attrs,
    ) -> Result<MeshInertia, ModelError> {
        if let Some(m) = self.done.get(name) {
            return Ok(*m);
        }
        let Some(el) = self.assets.get(name) else {
            return Err(geom.err(
                "mesh",
                format!("the mesh geom's mesh '{name}' is not an <asset><mesh>"),
            ));
        };
        let a = Attrs::new(doc, defaults, el, MAIN)?;
        let m = compile(&a, self.dir.as_deref())?;
        self.done.insert(name.to_string(), m);
        Ok(m)
    }
}

/// One `<mesh>` read (file or inline `vertex`/`face`) and processed.
fn compile(a: &Attrs, dir: Option<&Path>) -> Result<MeshInertia, ModelError> {
    if let Some(b) = a.get("builtin") {
        return Err(a.err("builtin", format!("built-in meshes ('{b}') are not read")));
    }
    let kind = match a.get("inertia").unwrap_or("legacy") {
        "legacy" => InertiaKind::Legacy,
        "exact" => InertiaKind::Exact,
        "shell" => InertiaKind::Shell,
        "convex" => InertiaKind::Convex,
        x => {
            return Err(a.err(
                "inertia",
                format!("expected convex, exact, legacy or shell, found '{x}'"),
            ))
        }
    };
    if kind == InertiaKind::Convex {
        return Err(a.err(
            "inertia",
            "inertia=\"convex\" takes the convex hull's volume, which articula does not \
             compute: use legacy (MuJoCo's default), exact or shell",
        ));
    }
    let (mesh, msh) = source(a, dir)?;
    let transform = Transform {
        scale: a.array::<3>("scale")?.unwrap_or([1.0; 3]),
        refpos: a.array::<3>("refpos")?.unwrap_or([0.0; 3]),
        refquat: a.array::<4>("refquat")?.unwrap_or([1.0, 0.0, 0.0, 0.0]),
    };
    let (attr, label) = match (a.get("file"), dir) {
        (Some(f), Some(d)) => ("file", d.join(f).display().to_string()),
        _ => ("vertex", "the vertex data".to_string()),
    };
    process(&mesh, msh, &transform, kind).map_err(|e| a.err(attr, format!("{label}: {e}")))
}

/// The mesh's triangles: from its `file` (against `dir`), else `vertex` and `face`; and
/// whether it came from a `.msh` file (whose faces MuJoCo reorders twice for mirroring scales).
fn source(a: &Attrs, dir: Option<&Path>) -> Result<(TriangleMesh, bool), ModelError> {
    if let Some(file) = a.get("file") {
        if a.get("vertex").is_some() {
            return Err(a.err("vertex", "give a mesh file or vertex data, not both"));
        }
        let Some(dir) = dir else {
            return Err(a.err(
                "file",
                "a mesh file needs the model's directory: load the model from its file",
            ));
        };
        let path = dir.join(file);
        let (mesh, format) = mesh_file::read(&path)
            .map_err(|e| a.err("file", format!("{}: {e}", path.display())))?;
        return Ok((mesh, format == MeshFormat::Msh));
    }
    let Some(vertex) = a.numbers("vertex", 0, usize::MAX)? else {
        return Err(a.err("file", "a <mesh> needs a file or vertex data"));
    };
    if vertex.len() % 3 != 0 {
        return Err(a.err("vertex", "vertex data must be a multiple of 3"));
    }
    let vertices: Vec<[f32; 3]> = vertex
        .chunks_exact(3)
        .map(|v| [v[0] as f32, v[1] as f32, v[2] as f32])
        .collect();
    let Some(face) = a.numbers("face", 0, usize::MAX)? else {
        return Err(a.err(
            "face",
            "a mesh without faces is its convex hull, which articula does not compute: give face",
        ));
    };
    if face.len() % 3 != 0 {
        return Err(a.err("face", "face data must be a multiple of 3"));
    }
    let mut faces = Vec::with_capacity(face.len() / 3);
    for f in face.chunks_exact(3) {
        let mut t = [0u32; 3];
        for (slot, &i) in t.iter_mut().zip(f) {
            if i.fract() != 0.0 || i < 0.0 || i as usize >= vertices.len() {
                return Err(a.err("face", format!("vertex index {i} does not exist")));
            }
            *slot = i as u32;
        }
        faces.push(t);
    }
    Ok((TriangleMesh { vertices, faces }, false))
}

/// The mesh's `refpos`, `refquat` and `scale`, applied in that order.
pub(crate) struct Transform {
    pub scale: [f64; 3],
    pub refpos: [f64; 3],
    pub refquat: [f64; 4],
}

/// MuJoCo's `mjCMesh::Process` for the mass properties: the transformed vertices' surface
/// centroid, centre of mass, inertia about it, and its principal axes.
pub(crate) fn process(
    mesh: &TriangleMesh,
    msh: bool,
    t: &Transform,
    kind: InertiaKind,
) -> Result<MeshInertia, String> {
    check_initial(mesh)?;
    let mut v: Vec<[f64; 3]> = mesh.vertices.iter().map(|p| p.map(f64::from)).collect();
    let mut faces = mesh.faces.clone();
    if kind == InertiaKind::Exact {
        check_orientation(&v, &faces)?;
    }
    // A mirroring scale turns the faces over; MuJoCo swaps a .msh's faces on reading and again
    // here, so only other files end up swapped.
    if t.scale[0] * t.scale[1] * t.scale[2] < 0.0 && !msh {
        for f in &mut faces {
            f.swap(1, 2);
        }
    }
    transform(&mut v, t);
    let facecen = face_centroid(&v, &faces)?;
    let com = match kind {
        InertiaKind::Shell => surface_com(&v, &faces, facecen)?,
        _ => volume_com(&v, &faces, facecen, kind)?,
    };
    let (inert, volume) = inertia(&v, &faces, com, kind);
    let full = [
        inert[0], inert[3], inert[4], inert[3], inert[1], inert[5], inert[4], inert[5], inert[2],
    ];
    let (eig, quat) = eig3(&full, MESH_EIG_TOL);
    if eig[2] <= 0.0 {
        return Err("an eigenvalue of the mesh's inertia is not positive".into());
    }
    let (atol, rtol) = (1e-9, 1e-6);
    if eig[0] + eig[1] < eig[2] * (1.0 - rtol) - atol
        || eig[0] + eig[2] < eig[1] * (1.0 - rtol) - atol
        || eig[1] + eig[2] < eig[0] * (1.0 - rtol) - atol
    {
        return Err("the mesh's principal moments violate A + B ≥ C".into());
    }
    let boxsz = [
        0.5 * (6.0 * (eig[1] + eig[2] - eig[0]) / volume).sqrt(),
        0.5 * (6.0 * (eig[0] + eig[2] - eig[1]) / volume).sqrt(),
        0.5 * (6.0 * (eig[0] + eig[1] - eig[2]) / volume).sqrt(),
    ];
    Ok(MeshInertia {
        volume,
        pos: DVec3::from_array(com),
        quat,
        boxsz,
    })
}

/// MuJoCo's checks before processing: at least four distinct vertices, faces in range.
fn check_initial(mesh: &TriangleMesh) -> Result<(), String> {
    let distinct: HashSet<[u32; 3]> = mesh
        .vertices
        .iter()
        .map(|v| v.map(|x| if x == 0.0 { 0 } else { x.to_bits() }))
        .collect();
    if distinct.len() < 4 {
        return Err(format!(
            "{} distinct vertices: a mesh needs at least 4",
            distinct.len()
        ));
    }
    let n = mesh.vertices.len() as u32;
    if let Some(f) = mesh.faces.iter().find(|f| f.iter().any(|&i| i >= n)) {
        return Err(format!("a face names a vertex that does not exist: {f:?}"));
    }
    Ok(())
}

/// `exact` needs consistently oriented faces: no directed edge twice.
fn check_orientation(v: &[[f64; 3]], faces: &[[u32; 3]]) -> Result<(), String> {
    let mut edges = HashSet::new();
    for f in faces {
        let [a, b, c] = f.map(|i| v[i as usize]);
        if triangle(a, b, c).area <= MIN_VAL.sqrt() {
            continue;
        }
        for (p, q) in [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])] {
            if !edges.insert((p, q)) {
                return Err(format!(
                    "faces have inconsistent orientation (the edge from vertex {} to {} \
                     appears twice): inertia=\"exact\" needs a closed, consistently oriented \
                     mesh",
                    p + 1,
                    q + 1
                ));
            }
        }
    }
    Ok(())
}

/// `refpos` subtracted, `refquat`'s inverse rotation, then `scale` (`ApplyTransformations`).
fn transform(v: &mut [[f64; 3]], t: &Transform) {
    if t.refpos != [0.0; 3] {
        for p in v.iter_mut() {
            for (x, r) in p.iter_mut().zip(t.refpos) {
                *x -= r;
            }
        }
    }
    if t.refquat != [1.0, 0.0, 0.0, 0.0] {
        let mut q = t.refquat;
        normalize(&mut q);
        let m = quat2mat(&q);
        for p in v.iter_mut() {
            *p = [
                m[0] * p[0] + m[3] * p[1] + m[6] * p[2],
                m[1] * p[0] + m[4] * p[1] + m[7] * p[2],
                m[2] * p[0] + m[5] * p[1] + m[8] * p[2],
            ];
        }
    }
    if t.scale != [1.0; 3] {
        for p in v.iter_mut() {
            for (x, s) in p.iter_mut().zip(t.scale) {
                *x *= s;
            }
        }
    }
}

/// A triangle's unit normal (unnormalised when tiny), centre and area (0 when tiny), as
/// MuJoCo's `triangle`.
struct Triangle {
    normal: [f64; 3],
    center: [f64; 3],
    area: f64,
}

fn triangle(v1: [f64; 3], v2: [f64; 3], v3: [f64; 3]) -> Triangle {
    let center = [
        (v1[0] + v2[0] + v3[0]) / 3.0,
        (v1[1] + v2[1] + v3[1]) / 3.0,
        (v1[2] + v2[2] + v3[2]) / 3.0,
    ];
    let b = [v2[0] - v1[0], v2[1] - v1[1], v2[2] - v1[2]];
    let c = [v3[0] - v1[0], v3[1] - v1[1], v3[2] - v1[2]];
    let mut normal = [
        b[1] * c[2] - b[2] * c[1],
        b[2] * c[0] - b[0] * c[2],
        b[0] * c[1] - b[1] * c[0],
    ];
    let len = dot(normal, normal).sqrt();
    if len < MIN_VAL {
        return Triangle {
            normal,
            center,
            area: 0.0,
        };
    }
    for x in &mut normal {
        *x /= len;
    }
    Triangle {
        normal,
        center,
        area: 0.5 * len,
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn corners(v: &[[f64; 3]], f: &[u32; 3]) -> Triangle {
    triangle(v[f[0] as usize], v[f[1] as usize], v[f[2] as usize])
}

/// The area-weighted centroid of the faces (`ComputeFaceCentroid`).
fn face_centroid(v: &[[f64; 3]], faces: &[[u32; 3]]) -> Result<[f64; 3], String> {
    let mut cen = [0.0; 3];
    let mut total = 0.0;
    for f in faces {
        let t = corners(v, f);
        for (c, x) in cen.iter_mut().zip(t.center) {
            *c += t.area * x;
        }
        total += t.area;
    }
    if total < MIN_VAL {
        return Err(format!(
            "the mesh's surface area {total:e} is too small (degenerate mesh)"
        ));
    }
    Ok(cen.map(|x| x / total))
}

/// Centre of mass of the tetrahedra from each face to `facecen` (`ComputeVolume`).
fn volume_com(
    v: &[[f64; 3]],
    faces: &[[u32; 3]],
    facecen: [f64; 3],
    kind: InertiaKind,
) -> Result<[f64; 3], String> {
    let mut com = [0.0; 3];
    let mut total = 0.0;
    for f in faces {
        let t = corners(v, f);
        let d = [
            t.center[0] - facecen[0],
            t.center[1] - facecen[1],
            t.center[2] - facecen[2],
        ];
        let mut vol = dot(d, t.normal) * t.area / 3.0;
        if kind == InertiaKind::Legacy {
            vol = vol.abs();
        }
        total += vol;
        for k in 0..3 {
            com[k] += vol * (t.center[k] * 3.0 / 4.0 + facecen[k] / 4.0);
        }
    }
    if total < MIN_VAL {
        return Err(if total < 0.0 {
            format!("the mesh's volume {total:e} is negative (misoriented triangles)")
        } else {
            format!(
                "the mesh's volume {total:e} is too small (a flat or open mesh): \
                 try inertia=\"shell\""
            )
        });
    }
    Ok(com.map(|x| x / total))
}

/// Centre of mass of the surface (`ComputeSurfaceArea`, with MuJoCo's weighting).
fn surface_com(v: &[[f64; 3]], faces: &[[u32; 3]], facecen: [f64; 3]) -> Result<[f64; 3], String> {
    let mut com = [0.0; 3];
    let mut total = 0.0;
    for f in faces {
        let t = corners(v, f);
        total += t.area;
        for k in 0..3 {
            com[k] += t.area * (t.center[k] * 3.0 / 4.0 + facecen[k] / 4.0);
        }
    }
    if total < MIN_VAL {
        return Err(format!("the mesh's surface area {total:e} is too small"));
    }
    Ok(com.map(|x| x / total))
}

/// Inertia about `com` (`[xx, yy, zz, xy, xz, yz]`, per unit density) and the volume (area
/// for `shell`) recounted with `com` as the apex (`ComputeInertia`).
fn inertia(
    v: &[[f64; 3]],
    faces: &[[u32; 3]],
    com: [f64; 3],
    kind: InertiaKind,
) -> ([f64; 6], f64) {
    let centered: Vec<[f64; 3]> = v
        .iter()
        .map(|p| [p[0] - com[0], p[1] - com[1], p[2] - com[2]])
        .collect();
    const K: [[usize; 2]; 6] = [[0, 0], [1, 1], [2, 2], [0, 1], [0, 2], [1, 2]];
    let c = if kind == InertiaKind::Shell {
        12.0
    } else {
        20.0
    };
    let mut p = [0.0; 6];
    let mut total = 0.0;
    for f in faces {
        let [d, e, g] = f.map(|i| centered[i as usize]);
        let t = triangle(d, e, g);
        let mut vol = if kind == InertiaKind::Shell {
            t.area
        } else {
            dot(t.center, t.normal) * t.area / 3.0
        };
        if kind == InertiaKind::Legacy {
            vol = vol.abs();
        }
        total += vol;
        for (j, &[a, b]) in K.iter().enumerate() {
            p[j] += vol / c
                * (2.0 * (d[a] * d[b] + e[a] * e[b] + g[a] * g[b])
                    + d[a] * e[b]
                    + d[b] * e[a]
                    + d[a] * g[b]
                    + d[b] * g[a]
                    + e[a] * g[b]
                    + e[b] * g[a]);
        }
    }
    (
        [p[1] + p[2], p[0] + p[2], p[0] + p[1], -p[3], -p[4], -p[5]],
        total,
    )
}

/// MuJoCo's `mjuu_normvec` for a quaternion.
fn normalize(q: &mut [f64; 4]) {
    let n2: f64 = q.iter().map(|x| x * x).sum();
    if n2 < EPS {
        return;
    }
    let n = n2.sqrt();
    if (n - 1.0).abs() > EPS {
        for x in q.iter_mut() {
            *x /= n;
        }
    }
}

/// MuJoCo's `mjuu_quat2mat` (row-major).
fn quat2mat(q: &[f64; 4]) -> [f64; 9] {
    if *q == [1.0, 0.0, 0.0, 0.0] {
        return [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    }
    let [w, x, y, z] = *q;
    let (q00, q01, q02, q03) = (w * w, w * x, w * y, w * z);
    let (q11, q12, q13) = (x * x, x * y, x * z);
    let (q22, q23, q33) = (y * y, y * z, z * z);
    [
        q00 + q11 - q22 - q33,
        2.0 * (q12 - q03),
        2.0 * (q13 + q02),
        2.0 * (q12 + q03),
        q00 - q11 + q22 - q33,
        2.0 * (q23 - q01),
        2.0 * (q13 - q02),
        2.0 * (q23 + q01),
        q00 - q11 - q22 + q33,
    ]
}

/// MuJoCo's `mjuu_mulquat` (normalised product).
pub(crate) fn mulquat(a: &[f64; 4], b: &[f64; 4]) -> [f64; 4] {
    let mut r = [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ];
    normalize(&mut r);
    r
}

fn mulmat(a: &[f64; 9], b: &[f64; 9]) -> [f64; 9] {
    std::array::from_fn(|k| {
        let (i, j) = (k / 3, k % 3);
        a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j]
    })
}

/// The principal moments and axes of a symmetric 3×3 matrix, as MuJoCo 4's compiler finds
/// them (`mjuu_eig3` with tolerance `tol`): Jacobi rotations accumulated in a quaternion until
/// the largest off-diagonal entry is at most `max(tol, 4e-15)` times the largest entry, then
/// the moments sorted decreasing by MuJoCo's three-step bubble (a 90° turn per swap, only
/// when they differ by more than `max(tol, 1e-12)` times the largest entry), so the axes are
/// MuJoCo's too. MuJoCo drops the residual off-diagonal, and so does this. The arithmetic is
/// MuJoCo's, operation for operation: the results are its bits.
pub(crate) fn eig3(mat: &[f64; 9], tol: f64) -> ([f64; 3], [f64; 4]) {
    let scale = mat.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let stop = EIG_TOL_MIN.max(tol) * scale;
    let mut quat = [1.0, 0.0, 0.0, 0.0];
    let mut eigval = [0.0; 3];
    for _ in 0..500 {
        let ev = quat2mat(&quat);
        let evt = [
            ev[0], ev[3], ev[6], ev[1], ev[4], ev[7], ev[2], ev[5], ev[8],
        ];
        let d = mulmat(&mulmat(&evt, mat), &ev);
        eigval = [d[0], d[4], d[8]];
        let (rk, ck, rotk) = if d[1].abs() > d[2].abs() && d[1].abs() > d[5].abs() {
            (0, 1, 2)
        } else if d[2].abs() > d[5].abs() {
            (0, 2, 1)
        } else {
            (1, 2, 0)
        };
        let off = d[3 * rk + ck];
        if off.abs() <= stop {
            break;
        }
        // The rotation zeroing entry (rk, ck): tan θ = t, as a quaternion by its half angle
        // (tan θ/2 = h) about axis rotk.
        let tau = (d[4 * ck] - d[4 * rk]) / (2.0 * off);
        let s = (1.0 + tau * tau).sqrt();
        let t = if tau >= 0.0 {
            1.0 / (tau + s)
        } else {
            -1.0 / (s - tau)
        };
        let h = t / (1.0 + (1.0 + t * t).sqrt());
        let c = 1.0 / (1.0 + h * h).sqrt();
        let mut r = [c, 0.0, 0.0, 0.0];
        r[rotk + 1] = if rotk == 1 { h } else { -h } * c;
        quat = mulquat(&quat, &r);
        normalize(&mut quat);
    }
    let keep = EIG_SORT_MIN.max(tol) * scale;
    for j in 0..3 {
        let j1 = j % 2;
        if eigval[j1] + keep < eigval[j1 + 1] {
            eigval.swap(j1, j1 + 1);
            // MuJoCo's literal for cos(π/4), 4 ulps above FRAC_1_SQRT_2: its bits matter.
            #[allow(clippy::approx_constant)]
            let mut r = [0.707106781186548, 0.0, 0.0, 0.0];
            r[(j1 + 2) % 3 + 1] = r[0];
            quat = mulquat(&quat, &r);
            normalize(&mut quat);
        }
    }
    (eigval, quat)
}

/// MuJoCo's `mjuu_rotVecQuat`: `v` rotated by `q`.
pub(crate) fn rot_vec_quat(v: DVec3, q: &[f64; 4]) -> DVec3 {
    let m = quat2mat(q);
    DVec3::new(
        m[0] * v.x + m[1] * v.y + m[2] * v.z,
        m[3] * v.x + m[4] * v.y + m[5] * v.z,
        m[6] * v.x + m[7] * v.y + m[8] * v.z,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed box, counter-clockwise faces seen from outside.
    fn box_mesh(h: [f32; 3]) -> TriangleMesh {
        let vertices = (0..8)
            .map(|i| {
                [
                    if i & 1 == 0 { -h[0] } else { h[0] },
                    if i & 2 == 0 { -h[1] } else { h[1] },
                    if i & 4 == 0 { -h[2] } else { h[2] },
                ]
            })
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let faces = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        TriangleMesh { vertices, faces }
    }

    const ID: Transform = Transform {
        scale: [1.0; 3],
        refpos: [0.0; 3],
        refquat: [1.0, 0.0, 0.0, 0.0],
    };

    #[test]
    fn box_volume_and_inertia_box() {
        for kind in [InertiaKind::Legacy, InertiaKind::Exact] {
            let m = process(&box_mesh([0.5, 1.0, 1.5]), false, &ID, kind).unwrap();
            assert!((m.volume - 6.0).abs() < 1e-12, "{}", m.volume);
            assert!(m.pos.length() < 1e-12);
            // The inertia box of a box is the box (sorted by decreasing moment: the
            // shortest side first).
            let mut b = m.boxsz;
            b.sort_by(f64::total_cmp);
            for (x, y) in b.iter().zip([0.5, 1.0, 1.5]) {
                assert!((x - y).abs() < 1e-12, "{:?}", m.boxsz);
            }
        }
    }

    #[test]
    fn eig3_diagonalises() {
        let mat = [2.0, 0.3, 0.1, 0.3, 1.5, -0.2, 0.1, -0.2, 1.0];
        // R diag(e) Rᵀ reproduces the matrix to the stopping rule: an off-diagonal entry of
        // at most max(tol, 4e-15) of the largest entry is left (and dropped), so the
        // reconstruction is that close, plus rounding; the moments are the eigenvalues
        // (their sum the trace, whatever the residual).
        for (tol, err) in [(BODY_EIG_TOL, 1e-14), (MESH_EIG_TOL, 4e-7)] {
            let (e, q) = eig3(&mat, tol);
            let r = quat2mat(&q);
            for i in 0..3 {
                for j in 0..3 {
                    let x: f64 = (0..3).map(|k| r[3 * i + k] * e[k] * r[3 * j + k]).sum();
                    assert!((x - mat[3 * i + j]).abs() < err, "{tol} {i}{j}: {x}");
                }
            }
            assert!((e.iter().sum::<f64>() - 4.5).abs() < 1e-14);
            assert!(e[0] >= e[1] && e[1] >= e[2]);
        }
    }
}
