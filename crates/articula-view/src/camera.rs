//! A pinhole camera, its view frustum, and projected sizes.
//!
//! Camera coordinates: `x` to the right of the image, `y` up, `z` the depth along the viewing
//! direction (positive in front of the camera). The frustum is `near ≤ z ≤ far`,
//! `|y| ≤ z tan(fov_y/2)`, `|x| ≤ z tan(fov_y/2) · aspect`.

use crate::error::ViewError;
use glam::{DMat3, DVec2, DVec3};

/// A pinhole camera: pose, vertical field of view, aspect ratio, near and far planes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Position of the eye (world).
    pub position: DVec3,
    /// Camera axes in world coordinates, as columns: right, up, forward (the viewing
    /// direction). Orthonormal, with the image convention x right, y up, z into the scene (a
    /// left-handed triple: `right × up = −forward`).
    pub axes: DMat3,
    /// Vertical field of view (radians), in `(0, π)`.
    pub fov_y: f64,
    /// Width / height of the image.
    pub aspect: f64,
    /// Near plane distance (> 0).
    pub near: f64,
    /// Far plane distance (> near).
    pub far: f64,
}

/// One of the six frustum planes: inside when `normal · p + offset ≥ 0` (world `p`), with a unit
/// `normal`, so the left side is the signed distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Unit normal, pointing into the frustum.
    pub normal: DVec3,
    /// Offset.
    pub offset: f64,
}

impl Plane {
    /// Signed distance of `p` (positive inside).
    #[inline]
    pub fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) + self.offset
    }
}

/// The view frustum as six inward planes (world coordinates): near, far, left, right, bottom,
/// top.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    /// The planes.
    pub planes: [Plane; 6],
}

impl Frustum {
    /// Whether the sphere may touch the frustum: `false` only when it lies entirely outside one
    /// plane (the usual conservative test: a sphere near a corner, outside two planes but not
    /// entirely outside either, counts as inside).
    pub fn sphere(&self, center: DVec3, radius: f64) -> bool {
        self.nearest_plane_distance(center) >= -radius
    }

    /// The least signed distance of `center` to the planes (positive inside), NaN if any is:
    /// `sphere(center, r)` is `nearest_plane_distance(center) >= -r`.
    pub fn nearest_plane_distance(&self, center: DVec3) -> f64 {
        let mut least = f64::INFINITY;
        for p in &self.planes {
            let d = p.distance(center);
            if d.is_nan() {
                return f64::NAN;
            }
            least = least.min(d);
        }
        least
    }

    /// Whether every point `p` within `radius (1 + 1e-12)` of `center` has a computed
    /// distance ([`Plane::distance`]) of at least 0 to every plane, so that
    /// `nearest_plane_distance(p) ≥ 0`, decided from the centre alone: its computed distance
    /// to each plane must exceed `radius + 1e-9 (radius + |center|₁ + |offset| + 1)`. NaN gives
    /// `false`.
    ///
    /// Why that margin suffices: with the plane's float coefficients, the exact distance
    /// `D(p) = n·p + o` changes by at most `|n| |p − center|` (`|n| ≤ 1 + 1e-12`: a normalised
    /// vector), and a computed distance (three products, three sums) is within
    /// `5e-16 (|n|∞ |p|₁ + |o|)` of `D` (`γ₄`), where `|p|₁ ≤ |center|₁ + 2 |p − center|`. So
    /// the computed distance at `p` is at least the centre's minus `radius (1 + 3e-12)` minus
    /// `4e-15 (radius + |center|₁ + |o|)`: positive under a margin that is far above both.
    pub fn holds_sphere(&self, center: DVec3, radius: f64) -> bool {
        let size = radius + center.abs().element_sum() + 1.0;
        self.planes.iter().all(|p| {
            let margin = radius + 1e-9 * (size + p.offset.abs());
            p.distance(center) >= margin
        })
    }

    /// Whether the capsule (segment `a`–`b` swept by a sphere of `radius`) may touch the
    /// frustum: the signed distance is affine along the segment, so the capsule is outside a
    /// plane exactly when both end spheres are.
    pub fn capsule(&self, a: DVec3, b: DVec3, radius: f64) -> bool {
        self.planes
            .iter()
            .all(|p| p.distance(a) >= -radius || p.distance(b) >= -radius)
    }

    /// Whether the oriented box (centre, axes as columns, half extents) may touch the frustum:
    /// outside a plane exactly when its support along the normal, `Σ eᵢ |n · axisᵢ|`, is
    /// smaller than the centre's distance behind it.
    pub fn oriented_box(&self, center: DVec3, axes: DMat3, half: DVec3) -> bool {
        self.planes.iter().all(|p| {
            let support = half.x * p.normal.dot(axes.x_axis).abs()
                + half.y * p.normal.dot(axes.y_axis).abs()
                + half.z * p.normal.dot(axes.z_axis).abs();
            p.distance(center) >= -support
        })
    }
}

impl Camera {
    /// A camera at `eye` looking at `target`, with `up` giving the image's vertical (it need not
    /// be orthogonal to the viewing direction, only not parallel to it). `fov_y_deg` in degrees.
    pub fn look_at(
        eye: DVec3,
        target: DVec3,
        up: DVec3,
        fov_y_deg: f64,
        aspect: f64,
        near: f64,
        far: f64,
    ) -> Result<Camera, ViewError> {
        let bad = |what: &str| Err(ViewError::Camera(what.to_string()));
        if !(eye.is_finite() && target.is_finite() && up.is_finite()) {
            return bad("eye, target and up must be finite");
        }
        if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) {
            return bad("the vertical field of view must lie strictly between 0 and 180 degrees");
        }
        if !(aspect.is_finite() && aspect > 0.0) {
            return bad("the aspect ratio must be a positive number");
        }
        if !(near.is_finite() && near > 0.0 && far.is_finite() && far > near) {
            return bad("near and far must satisfy 0 < near < far (finite)");
        }
        let d = target - eye;
        if d.length() < 1e-12 {
            return bad("the target coincides with the eye");
        }
        let forward = d.normalize();
        let right = forward.cross(up);
        if right.length() < 1e-9 * up.length().max(1e-300) || up.length() == 0.0 {
            return bad("the up vector is zero or parallel to the viewing direction");
        }
        let right = right.normalize();
        let true_up = right.cross(forward);
        Ok(Camera {
            position: eye,
            axes: DMat3::from_cols(right, true_up, forward),
            fov_y: fov_y_deg.to_radians(),
            aspect,
            near,
            far,
        })
    }

    /// The viewing direction (world).
    pub fn forward(&self) -> DVec3 {
        self.axes.z_axis
    }

    /// `tan(fov_y / 2)`.
    #[inline]
    pub fn tan_half_fov(&self) -> f64 {
        (0.5 * self.fov_y).tan()
    }

    /// World point → camera coordinates (x right, y up, z depth).
    #[inline]
    pub fn to_camera(&self, p: DVec3) -> DVec3 {
        self.axes.transpose() * (p - self.position)
    }

    /// World point → normalised image coordinates in `[-1, 1]²` when inside the field of view
    /// (x right, y up) and its depth; `None` behind the eye (depth ≤ 0).
    pub fn project(&self, p: DVec3) -> Option<(DVec2, f64)> {
        let c = self.to_camera(p);
        if c.z <= 0.0 {
            return None;
        }
        let t = self.tan_half_fov();
        Some((
            DVec2::new(c.x / (c.z * t * self.aspect), c.y / (c.z * t)),
            c.z,
        ))
    }

    /// The six frustum planes in world coordinates.
    pub fn frustum(&self) -> Frustum {
        let t = self.tan_half_fov();
        let ta = t * self.aspect;
        let (r, u, f) = (self.axes.x_axis, self.axes.y_axis, self.axes.z_axis);
        // In camera coordinates: z ≥ near, z ≤ far, z·ta ± x ≥ 0, z·t ± y ≥ 0.
        let plane = |n_cam: DVec3, off: f64| {
            let len = n_cam.length();
            let n = (r * n_cam.x + u * n_cam.y + f * n_cam.z) / len;
            Plane {
                normal: n,
                offset: off / len - n.dot(self.position),
            }
        };
        Frustum {
            planes: [
                plane(DVec3::new(0.0, 0.0, 1.0), -self.near),
                plane(DVec3::new(0.0, 0.0, -1.0), self.far),
                plane(DVec3::new(1.0, 0.0, ta), 0.0),
                plane(DVec3::new(-1.0, 0.0, ta), 0.0),
                plane(DVec3::new(0.0, 1.0, t), 0.0),
                plane(DVec3::new(0.0, -1.0, t), 0.0),
            ],
        }
    }

    /// Projected size of a sphere: its apparent diameter as a fraction of the image height.
    /// A sphere of radius `r` at distance `d > r` from the eye subtends the half angle
    /// `asin(r/d)`; on the image plane (focal length 1, half height `tan(fov/2)`) it measures
    /// `2 tan(asin(r/d)) = 2r / √(d² − r²)` when seen on the axis. Returns `∞` when the eye is
    /// inside the sphere.
    pub fn projected_size(&self, center: DVec3, radius: f64) -> f64 {
        let d2 = (center - self.position).length_squared();
        let r2 = radius * radius;
        if d2 <= r2 {
            return f64::INFINITY;
        }
        radius / ((d2 - r2).sqrt() * self.tan_half_fov())
    }
}

/// One keyframe of a camera path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    /// Time (s).
    pub t: f64,
    /// Eye position.
    pub eye: DVec3,
    /// Point looked at.
    pub target: DVec3,
}

/// A moving camera: keyframes of eye and target, interpolated linearly in time (held before
/// the first and after the last), with fixed up vector and lens.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPath {
    /// Keyframes, sorted by time (at least one).
    pub keys: Vec<Keyframe>,
    /// Up vector.
    pub up: DVec3,
    /// Vertical field of view (degrees).
    pub fov_y_deg: f64,
    /// Aspect ratio.
    pub aspect: f64,
    /// Near plane.
    pub near: f64,
    /// Far plane.
    pub far: f64,
}

impl CameraPath {
    /// Checks the path: keyframes sorted by strictly increasing time, each a valid camera.
    pub fn new(
        keys: Vec<Keyframe>,
        up: DVec3,
        fov_y_deg: f64,
        aspect: f64,
        near: f64,
        far: f64,
    ) -> Result<CameraPath, ViewError> {
        if keys.is_empty() {
            return Err(ViewError::Camera("a camera path needs a keyframe".into()));
        }
        for (i, k) in keys.iter().enumerate() {
            if !k.t.is_finite() {
                return Err(ViewError::Camera(format!(
                    "keyframe {i}: time is not finite"
                )));
            }
            if i > 0 && k.t <= keys[i - 1].t {
                return Err(ViewError::Camera(format!(
                    "keyframe {i}: times must increase strictly ({} after {})",
                    k.t,
                    keys[i - 1].t
                )));
            }
            Camera::look_at(k.eye, k.target, up, fov_y_deg, aspect, near, far)
                .map_err(|e| ViewError::Camera(format!("keyframe {i}: {e}")))?;
        }
        Ok(CameraPath {
            keys,
            up,
            fov_y_deg,
            aspect,
            near,
            far,
        })
    }

    /// The camera at time `t`.
    pub fn at(&self, t: f64) -> Result<Camera, ViewError> {
        let k = &self.keys;
        let (eye, target) = if t <= k[0].t {
            (k[0].eye, k[0].target)
        } else if t >= k[k.len() - 1].t {
            (k[k.len() - 1].eye, k[k.len() - 1].target)
        } else {
            let i = k.partition_point(|x| x.t <= t);
            let (a, b) = (&k[i - 1], &k[i]);
            let s = (t - a.t) / (b.t - a.t);
            (a.eye.lerp(b.eye, s), a.target.lerp(b.target, s))
        };
        Camera::look_at(
            eye,
            target,
            self.up,
            self.fov_y_deg,
            self.aspect,
            self.near,
            self.far,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::Camera;
    use glam::DVec3;

    #[test]
    fn a_held_sphere_is_inside_every_plane_to_its_rim() {
        // Random cameras at several scales; for centres inside the frustum, the largest radius
        // `holds_sphere` accepts, then points just beyond the rim towards each plane.
        let mut seed = 5u64;
        let mut rnd = |lo: f64, hi: f64| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
        };
        let mut held = 0;
        for k in 0..4000 {
            let scale = [1.0, 1e-3, 1e3, 1e6][k % 4];
            let v = |rnd: &mut dyn FnMut(f64, f64) -> f64| {
                DVec3::new(rnd(-1.0, 1.0), rnd(-1.0, 1.0), rnd(-1.0, 1.0)) * scale
            };
            let eye = v(&mut rnd);
            let target = eye + v(&mut rnd);
            let (fov, aspect) = (rnd(10.0, 120.0), rnd(0.5, 3.0));
            let Ok(c) = Camera::look_at(
                eye,
                target,
                DVec3::Z,
                fov,
                aspect,
                0.01 * scale,
                100.0 * scale,
            ) else {
                continue;
            };
            let f = c.frustum();
            let local = DVec3::new(rnd(-0.5, 0.5), rnd(-0.5, 0.5), rnd(0.1, 1.0));
            let center = c.position + c.axes * local * rnd(0.1, 50.0) * scale;
            let least = f.nearest_plane_distance(center);
            assert!(!f.holds_sphere(center, least), "{k}: no margin");
            let mut radius = least * (1.0 - 1e-8);
            while radius > least * 0.999 && !f.holds_sphere(center, radius) {
                radius *= 1.0 - 1e-10;
            }
            if !f.holds_sphere(center, radius) {
                continue;
            }
            held += 1;
            for p in &f.planes {
                let q = center - p.normal * radius * (1.0 + 1e-12);
                assert!(f.nearest_plane_distance(q) >= 0.0, "{k}: {q}");
            }
        }
        assert!(held > 1000, "{held}");
    }
}
