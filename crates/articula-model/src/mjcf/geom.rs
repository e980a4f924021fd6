//! MJCF frames (`pos` and the five ways to write an orientation) and geoms (their shapes as
//! contact geometry, and the mass and inertia MuJoCo gives them).

use super::mesh::{self, MeshInertia};
use super::xml::{Attrs, Compiler};
use crate::urdf::{Geometry, GeometryRole, Shape};
use crate::ModelError;
use articula_spatial::{SpatialInertia, SpatialTransform};
use glam::{DMat3, DQuat, DVec3};
use std::f64::consts::PI;

/// The rotation that takes `z` onto `v` by the shortest arc (MuJoCo's `mju_quatZ2Vec`).
pub(crate) fn z_to(v: DVec3) -> DQuat {
    let v = v.normalize();
    let axis = DVec3::Z.cross(v);
    let s = axis.length();
    if s < 1e-10 {
        return if v.z < 0.0 {
            DQuat::from_xyzw(1.0, 0.0, 0.0, 0.0)
        } else {
            DQuat::IDENTITY
        };
    }
    DQuat::from_axis_angle(axis / s, s.atan2(v.z))
}

/// The orientation an element writes with `quat`, `axisangle`, `euler`, `xyaxes` or `zaxis`
/// (at most one of them), identity when none.
pub(crate) fn orientation(a: &Attrs, c: &Compiler) -> Result<DQuat, ModelError> {
    let given: Vec<&str> = ["quat", "axisangle", "euler", "xyaxes", "zaxis"]
        .into_iter()
        .filter(|k| a.get(k).is_some())
        .collect();
    if given.len() > 1 {
        return Err(a.err(
            given[1],
            format!("orientation given twice ({})", given.join(", ")),
        ));
    }
    let bad = |k: &str| a.err(k, "degenerate orientation (a zero vector)");
    if let Some([w, x, y, z]) = a.array::<4>("quat")? {
        let q = DQuat::from_xyzw(x, y, z, w);
        if q.length() < 1e-12 {
            return Err(bad("quat"));
        }
        return Ok(q.normalize());
    }
    if let Some([x, y, z, t]) = a.array::<4>("axisangle")? {
        let axis = DVec3::new(x, y, z);
        if axis.length() < 1e-12 {
            return Err(bad("axisangle"));
        }
        return Ok(DQuat::from_axis_angle(axis.normalize(), c.angle(t)));
    }
    if let Some(e) = a.array::<3>("euler")? {
        let mut q = DQuat::IDENTITY;
        for (i, &ch) in c.eulerseq.iter().enumerate() {
            let axis = match ch.to_ascii_lowercase() {
                b'x' => DVec3::X,
                b'y' => DVec3::Y,
                _ => DVec3::Z,
            };
            let r = DQuat::from_axis_angle(axis, c.angle(e[i]));
            // Lower case: about the rotated axes (intrinsic); upper case: the fixed ones.
            q = if ch.is_ascii_lowercase() {
                q * r
            } else {
                r * q
            };
        }
        return Ok(q.normalize());
    }
    if let Some(v) = a.array::<6>("xyaxes")? {
        let x = DVec3::new(v[0], v[1], v[2]);
        let y = DVec3::new(v[3], v[4], v[5]);
        if x.length() < 1e-12 {
            return Err(bad("xyaxes"));
        }
        let x = x.normalize();
        let y = y - x * x.dot(y);
        if y.length() < 1e-12 {
            return Err(bad("xyaxes"));
        }
        let y = y.normalize();
        return Ok(DQuat::from_mat3(&DMat3::from_cols(x, y, x.cross(y))).normalize());
    }
    if let Some(z) = a.array::<3>("zaxis")? {
        let z = DVec3::from_array(z);
        if z.length() < 1e-12 {
            return Err(bad("zaxis"));
        }
        return Ok(z_to(z));
    }
    Ok(DQuat::IDENTITY)
}

/// The element's frame → its parent's frame, from `pos` and its orientation.
pub(crate) fn frame(a: &Attrs, c: &Compiler) -> Result<SpatialTransform, ModelError> {
    let pos = DVec3::from_array(a.array::<3>("pos")?.unwrap_or([0.0; 3]));
    let rot = orientation(a, c)?;
    Ok(SpatialTransform::from_pose(DMat3::from_quat(rot), pos))
}

/// A geom as MuJoCo compiles it: its kind, `size` (half-lengths; `fromto` applied), frame,
/// and whether it collides.
pub(crate) struct Geom {
    pub kind: String,
    pub size: [f64; 3],
    pub pose: (DQuat, DVec3),
    pub collides: bool,
    pub group: i64,
    /// The `<mesh>` asset a mesh geom shows (its `mesh` attribute).
    pub mesh: Option<String>,
}

impl Geom {
    pub fn read(a: &Attrs, c: &Compiler) -> Result<Geom, ModelError> {
        let kind = a.get("type").unwrap_or("sphere").to_string();
        let sizes = a.numbers("size", 1, 3)?.unwrap_or_default();
        let mut size = [0.0; 3];
        size[..sizes.len()].copy_from_slice(&sizes);
        let mut pose = (
            orientation(a, c)?,
            DVec3::from_array(a.array::<3>("pos")?.unwrap_or([0.0; 3])),
        );
        if let Some(ft) = a.array::<6>("fromto")? {
            let (from, to) = (
                DVec3::new(ft[0], ft[1], ft[2]),
                DVec3::new(ft[3], ft[4], ft[5]),
            );
            let d = to - from;
            if !matches!(kind.as_str(), "capsule" | "cylinder" | "box" | "ellipsoid") {
                return Err(a.err("fromto", format!("a {kind} geom takes no fromto")));
            }
            if d.length() < 1e-12 {
                return Err(a.err("fromto", "the two points coincide"));
            }
            pose = (z_to(d), (from + to) / 2.0);
            let half = d.length() / 2.0;
            match kind.as_str() {
                "capsule" | "cylinder" => size[1] = half,
                _ => {
                    if sizes.len() < 2 {
                        size[1] = size[0];
                    }
                    size[2] = half;
                }
            }
        }
        if size.iter().any(|&x| x < 0.0) {
            return Err(a.err("size", "a size is negative"));
        }
        let mesh = a.get("mesh").map(str::to_string);
        let contype = a.number("contype", 1.0)?;
        let conaffinity = a.number("conaffinity", 1.0)?;
        Ok(Geom {
            kind,
            size,
            pose,
            collides: contype != 0.0 || conaffinity != 0.0,
            group: a.number("group", 0.0)? as i64,
            mesh,
        })
    }

    /// Volume and principal moments per unit mass about the centre (geom axes), for the
    /// primitive shapes; `None` for others (meshes, planes, height fields).
    fn unit_inertia(&self) -> Option<(f64, DVec3)> {
        let [a, b, c] = self.size;
        Some(match self.kind.as_str() {
            "sphere" => (4.0 / 3.0 * PI * a.powi(3), DVec3::splat(0.4 * a * a)),
            "ellipsoid" => (
                4.0 / 3.0 * PI * a * b * c,
                DVec3::new(b * b + c * c, a * a + c * c, a * a + b * b) / 5.0,
            ),
            "box" => (
                8.0 * a * b * c,
                DVec3::new(b * b + c * c, a * a + c * c, a * a + b * b) / 3.0,
            ),
            "cylinder" => {
                let h = 2.0 * b;
                let t = (3.0 * a * a + h * h) / 12.0;
                (PI * a * a * h, DVec3::new(t, t, a * a / 2.0))
            }
            "capsule" => {
                // A cylinder and two hemispheres, as MuJoCo's compiler does.
                let (r, h) = (a, 2.0 * b);
                let sphere = 4.0 * r / (4.0 * r + 3.0 * h);
                let cyl = 1.0 - sphere;
                let t = cyl * (3.0 * r * r + h * h) / 12.0
                    + sphere * (0.4 * r * r + h * (3.0 * r + 2.0 * h) / 8.0);
                let z = cyl * r * r / 2.0 + sphere * 0.4 * r * r;
                (PI * r * r * (h + 4.0 / 3.0 * r), DVec3::new(t, t, z))
            }
            _ => return None,
        })
    }

    /// The geom's mass, centre and principal moments and axes, as MuJoCo's compiler keeps
    /// them (`mass`, else `density` × volume).
    pub fn mass_properties(
        &self,
        a: &Attrs,
        mesh: Option<&MeshInertia>,
    ) -> Result<GeomMass, ModelError> {
        let kind = self.kind.as_str();
        match (kind, &self.mesh) {
            ("mesh", None) => return Err(a.err("mesh", "a mesh geom needs a mesh")),
            ("mesh", Some(_)) | (_, None) => {}
            (_, Some(_)) => {
                return Err(a.err(
                    "mesh",
                    format!("a {kind} geom fitted to a mesh is not read: give its size"),
                ))
            }
        }
        if a.flag("shellinertia", Some(false))? == Some(true) {
            return Err(a.err(
                "shellinertia",
                if kind == "mesh" {
                    "for mesh geoms, inertia should be specified in the mesh asset \
                     (<mesh inertia=\"shell\">), as MuJoCo says"
                } else {
                    "shell inertia of primitive geoms is not computed: give the body an <inertial>"
                },
            ));
        }
        let mut pose = self.pose;
        let found = match mesh {
            Some(m) => {
                // MuJoCo's geom frame absorbs the mesh's: pos += R(quat) · mesh pos,
                // quat ← quat · mesh quat (mjuu_frameaccum).
                let q = self.pose.0;
                let q = [q.w, q.x, q.y, q.z];
                let qm = mesh::mulquat(&q, &m.quat);
                pose = (
                    DQuat::from_xyzw(qm[1], qm[2], qm[3], qm[0]),
                    self.pose.1 + mesh::rot_vec_quat(m.pos, &q),
                );
                Some((m.volume, m.unit_moments()))
            }
            None => self.unit_inertia(),
        };
        let Some((volume, unit)) = found else {
            return Err(a.err(
                "type",
                format!(
                    "the body's inertia would come from a {} geom, whose volume articula does \
                     not compute: give the body an <inertial>",
                    self.kind
                ),
            ));
        };
        let mass = match a.get("mass") {
            Some(_) => a.number("mass", 0.0)?,
            None => a.number("density", 1000.0)? * volume,
        };
        if mass < 0.0 {
            return Err(a.err("mass", format!("negative mass {mass}")));
        }
        Ok(GeomMass {
            mass,
            pos: pose.1,
            quat: pose.0,
            moments: unit * mass,
        })
    }

    /// The contact shape, when articula has one for it.
    pub fn geometry(&self) -> Option<Geometry> {
        let [a, b, c] = self.size;
        let shape = match self.kind.as_str() {
            "sphere" => Shape::Sphere { radius: a },
            "capsule" => Shape::Capsule {
                radius: a,
                length: 2.0 * b,
            },
            "cylinder" => Shape::Cylinder {
                radius: a,
                length: 2.0 * b,
            },
            "box" => Shape::Box {
                size: 2.0 * DVec3::new(a, b, c),
            },
            "mesh" => Shape::Mesh,
            _ => return None,
        };
        Some(Geometry {
            shape,
            origin: SpatialTransform::from_pose(DMat3::from_quat(self.pose.0), self.pose.1),
            role: if self.collides {
                GeometryRole::Collision
            } else {
                GeometryRole::Visual
            },
        })
    }
}

/// A geom's (or a body's) mass properties as MuJoCo stores them: mass, centre, principal
/// axes and moments.
#[derive(Clone, Copy, Debug)]
pub(crate) struct GeomMass {
    pub mass: f64,
    /// Centre of mass in the body frame.
    pub pos: DVec3,
    /// Principal axes in the body frame.
    pub quat: DQuat,
    /// Principal moments about the centre.
    pub moments: DVec3,
}

impl GeomMass {
    /// As a spatial inertia in the body frame.
    pub fn spatial(&self) -> SpatialInertia {
        let rot = DMat3::from_quat(self.quat);
        let ic = rot * DMat3::from_diagonal(self.moments) * rot.transpose();
        SpatialInertia::new(self.mass, self.pos, ic)
    }

    /// A body's mass properties from its geoms', as MuJoCo's `mjCBody::InertiaFromGeom`:
    /// geoms of mass ≤ 1e-14 are left out, one geom is copied, several are summed about
    /// their common centre and re-diagonalised by [`mesh::eig3`] with MuJoCo's body
    /// tolerance (its dropped residual, up to 4e-15 of the largest entry, is MuJoCo's too).
    pub fn principal_sum(parts: &[GeomMass]) -> SpatialInertia {
        let sel: Vec<&GeomMass> = parts.iter().filter(|g| g.mass > 1e-14).collect();
        match sel.as_slice() {
            [] => SpatialInertia::ZERO,
            [one] => one.spatial(),
            _ => {
                let mass: f64 = sel.iter().map(|g| g.mass).sum();
                let com = sel.iter().fold(DVec3::ZERO, |c, g| c + g.pos * g.mass) / mass;
                let mut total = DMat3::ZERO;
                for g in &sel {
                    let rot = DMat3::from_quat(g.quat);
                    let d = g.pos - com;
                    let shift = DMat3::from_diagonal(DVec3::splat(d.length_squared()))
                        - DMat3::from_cols(d * d.x, d * d.y, d * d.z);
                    total +=
                        rot * DMat3::from_diagonal(g.moments) * rot.transpose() + shift * g.mass;
                }
                let full = [
                    total.x_axis.x,
                    total.y_axis.x,
                    total.z_axis.x,
                    total.x_axis.y,
                    total.y_axis.y,
                    total.z_axis.y,
                    total.x_axis.z,
                    total.y_axis.z,
                    total.z_axis.z,
                ];
                let (eig, q) = mesh::eig3(&full, mesh::BODY_EIG_TOL);
                GeomMass {
                    mass,
                    pos: com,
                    quat: DQuat::from_xyzw(q[1], q[2], q[3], q[0]),
                    moments: DVec3::from_array(eig),
                }
                .spatial()
            }
        }
    }
}
