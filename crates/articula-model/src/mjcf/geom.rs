//! MJCF frames (`pos` and the five ways to write an orientation) and geoms (their shapes as
//! contact geometry, and the mass and inertia MuJoCo gives them).

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
        let contype = a.number("contype", 1.0)?;
        let conaffinity = a.number("conaffinity", 1.0)?;
        Ok(Geom {
            kind,
            size,
            pose,
            collides: contype != 0.0 || conaffinity != 0.0,
            group: a.number("group", 0.0)? as i64,
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

    /// The geom's spatial inertia in its body's frame (`mass`, else `density` × volume).
    pub fn inertia(&self, a: &Attrs) -> Result<SpatialInertia, ModelError> {
        let Some((volume, unit)) = self.unit_inertia() else {
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
        let rot = DMat3::from_quat(self.pose.0);
        let ic = rot * DMat3::from_diagonal(unit * mass) * rot.transpose();
        Ok(SpatialInertia::new(mass, self.pose.1, ic))
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
