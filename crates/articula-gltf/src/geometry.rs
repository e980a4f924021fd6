//! Triangle meshes: URDF primitives tessellated, mesh files read through `mesh-loader`, and
//! the placement of either in its body's frame.

use articula_model::Shape;
use articula_spatial::SpatialTransform;
use glam::{DVec3, Vec3};
use std::f64::consts::{PI, TAU};

/// Segments around the axis of a cylinder, capsule or sphere.
const AROUND: usize = 24;
/// Rings from pole to pole of a sphere (a capsule's caps take half each).
const RINGS: usize = 12;

/// An indexed triangle mesh with one unit normal per vertex (metres, f32 as glTF stores it).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Unit vertex normals, one per position.
    pub normals: Vec<[f32; 3]>,
    /// Triangles, three vertex indices each, counter-clockwise seen from outside.
    pub indices: Vec<u32>,
}

impl TriMesh {
    /// Number of triangles.
    pub fn triangles(&self) -> usize {
        self.indices.len() / 3
    }

    /// Appends `other` moved by `x` (its frame → this mesh's frame).
    pub fn append(&mut self, other: &TriMesh, x: &SpatialTransform) {
        let base = self.positions.len() as u32;
        let rot = x.e;
        for (p, n) in other.positions.iter().zip(&other.normals) {
            let p = x.apply_point(DVec3::from(Vec3::from(*p)));
            self.positions.push(p.as_vec3().to_array());
            self.normals
                .push(unit(rot * DVec3::from(Vec3::from(*n))).to_array());
        }
        self.indices.extend(other.indices.iter().map(|i| i + base));
    }

    fn vertex(&mut self, p: DVec3, n: DVec3) -> u32 {
        self.positions.push(p.as_vec3().to_array());
        self.normals.push(unit(n).to_array());
        self.positions.len() as u32 - 1
    }

    /// A grid of `rows + 1` × `AROUND + 1` vertices from `f(row, column)` (position, normal),
    /// stitched into quads.
    fn grid(&mut self, rows: usize, f: impl Fn(usize, usize) -> (DVec3, DVec3)) {
        let base = self.positions.len() as u32;
        for i in 0..=rows {
            for j in 0..=AROUND {
                let (p, n) = f(i, j);
                self.vertex(p, n);
            }
        }
        let w = AROUND as u32 + 1;
        for i in 0..rows as u32 {
            for j in 0..AROUND as u32 {
                let (a, b) = (base + i * w + j, base + i * w + j + 1);
                let (c, d) = (a + w, b + w);
                self.indices.extend([a, b, d, a, d, c]);
            }
        }
    }

    /// A flat disc of radius `r` at height `z`, facing `+z` (`up`) or `−z`.
    fn disc(&mut self, r: f64, z: f64, up: bool) {
        let n = DVec3::new(0.0, 0.0, if up { 1.0 } else { -1.0 });
        let centre = self.vertex(DVec3::new(0.0, 0.0, z), n);
        for j in 0..=AROUND {
            let (s, c) = (TAU * j as f64 / AROUND as f64).sin_cos();
            self.vertex(DVec3::new(r * c, r * s, z), n);
        }
        for j in 0..AROUND as u32 {
            let (a, b) = (centre + 1 + j, centre + 2 + j);
            if up {
                self.indices.extend([centre, a, b]);
            } else {
                self.indices.extend([centre, b, a]);
            }
        }
    }
}

/// `v` normalised in f32 (glTF's validator checks unit length in f32); `+z` for a zero or
/// non-finite vector.
fn unit(v: DVec3) -> Vec3 {
    let n = v.normalize_or_zero();
    if n == DVec3::ZERO || !n.is_finite() {
        Vec3::Z
    } else {
        n.as_vec3().normalize()
    }
}

/// The triangles of a primitive in its own frame (as [`Shape`] describes it); `None` for
/// [`Shape::Mesh`].
pub fn tessellate(shape: &Shape) -> Option<TriMesh> {
    let mut m = TriMesh::default();
    match *shape {
        Shape::Box { size } => boxed(&mut m, 0.5 * size),
        Shape::Sphere { radius } => capsule(&mut m, radius, 0.0),
        Shape::Capsule { radius, length } => capsule(&mut m, radius, length),
        Shape::Cylinder { radius, length } => {
            let h = 0.5 * length;
            m.grid(1, |i, j| {
                let (s, c) = (TAU * j as f64 / AROUND as f64).sin_cos();
                let z = if i == 0 { -h } else { h };
                (DVec3::new(radius * c, radius * s, z), DVec3::new(c, s, 0.0))
            });
            m.disc(radius, h, true);
            m.disc(radius, -h, false);
        }
        Shape::Mesh => return None,
    }
    Some(m)
}

/// A box of half extents `h`: 6 faces of 4 vertices with the face's normal.
fn boxed(m: &mut TriMesh, h: DVec3) {
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            let mut n = DVec3::ZERO;
            n[axis] = sign;
            // Two axes spanning the face, ordered so that u × v = n.
            let (mut u, mut v) = (DVec3::ZERO, DVec3::ZERO);
            u[(axis + 1) % 3] = 1.0;
            v[(axis + 2) % 3] = sign;
            let c = n * h;
            let (u, v) = (u * h, v * h);
            let base = m.positions.len() as u32;
            for p in [c - u - v, c + u - v, c + u + v, c - u + v] {
                m.vertex(p, n);
            }
            m.indices
                .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
}

/// A capsule of radius `r` whose end spheres' centres are `±l/2` on z (a sphere for `l = 0`).
fn capsule(m: &mut TriMesh, r: f64, l: f64) {
    let half = 0.5 * l;
    // Rings 0..=RINGS from the south pole to the north; the upper half shifted up by l/2,
    // the lower half down (the equator is duplicated, joining the two by the cylinder band).
    let ring = |i: usize, j: usize, shift_up: bool| {
        let polar = PI * i as f64 / RINGS as f64 - 0.5 * PI;
        let (sp, cp) = polar.sin_cos();
        let (s, c) = (TAU * j as f64 / AROUND as f64).sin_cos();
        let n = DVec3::new(cp * c, cp * s, sp);
        let z = if shift_up { half } else { -half };
        (r * n + DVec3::new(0.0, 0.0, z), n)
    };
    let south = RINGS / 2;
    m.grid(south, |i, j| ring(i, j, false));
    if l > 0.0 {
        m.grid(1, |i, j| ring(south, j, i == 1));
    }
    m.grid(RINGS - south, |i, j| ring(south + i, j, true));
}

/// The meshes of a file read by `mesh-loader`, as one [`TriMesh`] per sub-mesh with its
/// diffuse colour when the file gives one. Normals are recomputed from the faces (area
/// weighted) where the file has none or not one per vertex; faces with an index out of range
/// are dropped, and a sub-mesh with a non-finite position is left out.
pub fn from_scene(scene: &mesh_loader::Scene) -> Vec<(TriMesh, Option<[f64; 4]>)> {
    let mut out = Vec::new();
    for (k, mesh) in scene.meshes.iter().enumerate() {
        let mut m = TriMesh {
            positions: mesh.vertices.clone(),
            ..TriMesh::default()
        };
        let count = m.positions.len() as u32;
        for f in &mesh.faces {
            if f.iter().any(|&i| i >= count) {
                continue;
            }
            m.indices.extend(*f);
        }
        if m.indices.is_empty() || m.positions.iter().flatten().any(|x| !x.is_finite()) {
            continue;
        }
        m.normals = if mesh.normals.len() == m.positions.len() {
            mesh.normals
                .iter()
                .map(|n| unit(Vec3::from(*n).as_dvec3()).to_array())
                .collect()
        } else {
            face_normals(&m)
        };
        let colour = scene
            .materials
            .get(k)
            .and_then(|mat| mat.color.diffuse)
            .map(|c| c.map(|x| f64::from(x).clamp(0.0, 1.0)));
        out.push((m, colour));
    }
    out
}

/// Area-weighted vertex normals of a mesh's triangles.
fn face_normals(m: &TriMesh) -> Vec<[f32; 3]> {
    let mut acc = vec![DVec3::ZERO; m.positions.len()];
    let p = |i: u32| Vec3::from(m.positions[i as usize]).as_dvec3();
    for t in m.indices.chunks_exact(3) {
        let n = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));
        for &i in t {
            acc[i as usize] += n;
        }
    }
    acc.into_iter().map(|n| unit(n).to_array()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Volume by the divergence theorem: positive for outward, counter-clockwise triangles.
    fn volume(m: &TriMesh) -> f64 {
        let p = |i: u32| Vec3::from(m.positions[i as usize]).as_dvec3();
        m.indices
            .chunks_exact(3)
            .map(|t| p(t[0]).dot(p(t[1]).cross(p(t[2]))) / 6.0)
            .sum()
    }

    #[test]
    fn primitives_enclose_their_volume_with_outward_triangles() {
        let cases = [
            (
                Shape::Box {
                    size: DVec3::new(1.0, 2.0, 3.0),
                },
                6.0,
                1e-6,
            ),
            // Inscribed polygons and polyhedra fall short by O(1/n²): 24 segments, ~1.1%.
            (
                Shape::Cylinder {
                    radius: 0.5,
                    length: 2.0,
                },
                PI * 0.25 * 2.0,
                0.012,
            ),
            (Shape::Sphere { radius: 1.0 }, 4.0 / 3.0 * PI, 0.04),
            (
                Shape::Capsule {
                    radius: 0.5,
                    length: 1.0,
                },
                PI * 0.25 + 4.0 / 3.0 * PI * 0.125,
                0.03,
            ),
        ];
        for (shape, exact, rel) in cases {
            let m = tessellate(&shape).unwrap();
            let v = volume(&m);
            assert!((v / exact - 1.0).abs() < rel, "{shape:?}: {v} vs {exact}");
            assert!(v <= exact * (1.0 + 1e-6), "{shape:?}: inscribed");
            assert_eq!(m.positions.len(), m.normals.len());
            for n in &m.normals {
                assert!((Vec3::from(*n).length() - 1.0).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn normals_point_away_from_the_centre() {
        for shape in [
            Shape::Box { size: DVec3::ONE },
            Shape::Sphere { radius: 0.3 },
            Shape::Capsule {
                radius: 0.2,
                length: 0.5,
            },
            Shape::Cylinder {
                radius: 0.2,
                length: 0.5,
            },
        ] {
            let m = tessellate(&shape).unwrap();
            for (p, n) in m.positions.iter().zip(&m.normals) {
                assert!(Vec3::from(*p).dot(Vec3::from(*n)) > 0.0, "{shape:?}");
            }
        }
    }

    #[test]
    fn append_moves_points_and_turns_normals() {
        let cube = tessellate(&Shape::Box { size: DVec3::ONE }).unwrap();
        let x = SpatialTransform::from_pose(
            glam::DMat3::from_rotation_z(0.5 * PI),
            DVec3::new(1.0, 2.0, 3.0),
        );
        let mut m = TriMesh::default();
        m.append(&cube, &x);
        m.append(&cube, &x);
        assert_eq!(m.indices.len(), 2 * cube.indices.len());
        assert_eq!(m.indices[cube.indices.len()], cube.indices[0] + 24);
        for (k, p) in cube.positions.iter().enumerate() {
            let want = x.apply_point(Vec3::from(*p).as_dvec3());
            assert!((Vec3::from(m.positions[k]).as_dvec3() - want).length() < 1e-6);
            let n = x.e * Vec3::from(cube.normals[k]).as_dvec3();
            assert!((Vec3::from(m.normals[k]).as_dvec3() - n).length() < 1e-6);
        }
        assert!((volume(&m) - 2.0).abs() < 1e-5);
    }
}
