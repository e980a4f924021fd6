//! The joint kinds, each defined in one place: coordinates (`nq`, `nv`), motion, motion
//! subspace, configuration integration and difference, neutral and random configurations,
//! limits, and how a state file names its coordinates (`docs/design.md#joint-kinds`).
//!
//! Conventions (`docs/conventions.md`): a joint moves its *moving frame* relative to its *joint
//! frame*. Velocities are in the moving frame.
//!
//! | kind | `q` | `q̇` | subspace columns (moving frame) |
//! |---|---|---|---|
//! | revolute, continuous | angle (rad) | rate | `[axis; 0]` |
//! | prismatic | displacement (m) | rate | `[0; axis]` |
//! | ball | unit quaternion `[qw, qx, qy, qz]` | angular velocity `ω` (moving frame) | `[eₖ; 0]` |
//! | floating | `[x, y, z, qw, qx, qy, qz]` | body twist `[ω; v]` (moving frame) | unit vectors |
//! | fixed | — | — | — |
//!
//! The ball joint's `q̇` is the angular velocity of the moving frame in its own coordinates,
//! as MuJoCo's `qvel` of a ball joint; the quaternion is the moving frame's orientation in the
//! joint frame, and integration is `q ← q exp(h ω)`.

use articula_spatial::{SpatialMotion, SpatialTransform};
use glam::{DMat3, DQuat, DVec3};

/// The motion a joint allows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize),
    serde(rename_all = "snake_case")
)]
#[non_exhaustive]
pub enum JointKind {
    /// Rotation about the axis, with limits in the URDF ([`crate::JointPart::limits`]).
    Revolute,
    /// Rotation about the axis without limits.
    Continuous,
    /// Translation along the axis.
    Prismatic,
    /// Welded: the child is merged into the parent.
    Fixed,
    /// Six degrees of freedom.
    Floating,
    /// Spherical: three rotational degrees of freedom about the joint's origin, a unit
    /// quaternion in `q` (MJCF `type="ball"`).
    Ball,
}

/// Every kind, for tests and tables.
pub const JOINT_KINDS: [JointKind; 6] = [
    JointKind::Revolute,
    JointKind::Continuous,
    JointKind::Prismatic,
    JointKind::Fixed,
    JointKind::Floating,
    JointKind::Ball,
];

impl JointKind {
    /// Number of position coordinates.
    pub fn nq(self) -> usize {
        match self {
            JointKind::Fixed => 0,
            JointKind::Revolute | JointKind::Continuous | JointKind::Prismatic => 1,
            JointKind::Ball => 4,
            JointKind::Floating => 7,
        }
    }

    /// Number of velocity coordinates (degrees of freedom).
    pub fn nv(self) -> usize {
        match self {
            JointKind::Fixed => 0,
            JointKind::Revolute | JointKind::Continuous | JointKind::Prismatic => 1,
            JointKind::Ball => 3,
            JointKind::Floating => 6,
        }
    }

    /// The lower-case name used in files and messages (`"revolute"`, `"ball"`, …).
    pub fn name(self) -> &'static str {
        match self {
            JointKind::Revolute => "revolute",
            JointKind::Continuous => "continuous",
            JointKind::Prismatic => "prismatic",
            JointKind::Fixed => "fixed",
            JointKind::Floating => "floating",
            JointKind::Ball => "ball",
        }
    }

    /// The MJCF joint `type` of this kind (`None` for fixed: MJCF welds by having no joint).
    pub fn mjcf_type(self) -> Option<&'static str> {
        match self {
            JointKind::Revolute | JointKind::Continuous => Some("hinge"),
            JointKind::Prismatic => Some("slide"),
            JointKind::Ball => Some("ball"),
            JointKind::Floating => Some("free"),
            JointKind::Fixed => None,
        }
    }

    /// One rotation about the axis (revolute, continuous).
    pub fn is_hinge(self) -> bool {
        match self {
            JointKind::Revolute | JointKind::Continuous => true,
            JointKind::Prismatic | JointKind::Fixed | JointKind::Floating | JointKind::Ball => {
                false
            }
        }
    }

    /// One coordinate along or about an axis (revolute, continuous, prismatic): `q = q̇`
    /// dimensionally, integration by addition, scalar limits.
    pub fn is_scalar(self) -> bool {
        self.is_hinge() || self == JointKind::Prismatic
    }

    /// Whether the joint only rotates its moving frame about the joint frame's origin (or does
    /// not move): every point keeps its distance from that origin.
    pub fn keeps_origin(self) -> bool {
        match self {
            JointKind::Revolute | JointKind::Continuous | JointKind::Ball | JointKind::Fixed => {
                true
            }
            JointKind::Prismatic | JointKind::Floating => false,
        }
    }

    /// Whether the kind takes `[lower, upper]` limits on its coordinate (revolute, prismatic).
    pub fn takes_limits(self) -> bool {
        matches!(self, JointKind::Revolute | JointKind::Prismatic)
    }

    /// Offset in the joint's `q` of its unit quaternion `[qw, qx, qy, qz]`, if it has one.
    pub fn quaternion_offset(self) -> Option<usize> {
        match self {
            JointKind::Ball => Some(0),
            JointKind::Floating => Some(3),
            JointKind::Revolute
            | JointKind::Continuous
            | JointKind::Prismatic
            | JointKind::Fixed => None,
        }
    }

    /// Whether `q ⊕ v` is a Lie-group exponential whose fourth-order Runge–Kutta slope needs
    /// the `dexp⁻¹` correction ([`JointKind::rkmk_slope`]).
    pub fn on_a_lie_group(self) -> bool {
        self.quaternion_offset().is_some()
    }

    /// The neutral coordinates (zero angle and displacement; identity orientation).
    pub fn neutral_q(self) -> &'static [f64] {
        match self {
            JointKind::Floating => &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            JointKind::Ball => &[1.0, 0.0, 0.0, 0.0],
            JointKind::Fixed => &[],
            JointKind::Revolute | JointKind::Continuous | JointKind::Prismatic => &[0.0],
        }
    }

    /// Writes random coordinates into `q` (length [`JointKind::nq`]), drawing from
    /// `uniform(lo, hi)`: angles in [-1.2, 1.2] rad (clear of the gimbal lock of composed 3-axis
    /// joints), displacements in [-0.2, 0.2] m, orientations by a random axis and an angle in
    /// [-3, 3] rad, floating positions in [-1, 1]³ m.
    pub fn random_q(self, q: &mut [f64], uniform: &mut dyn FnMut(f64, f64) -> f64) {
        let rotation = |uniform: &mut dyn FnMut(f64, f64) -> f64| {
            let axis = DVec3::new(uniform(-1.0, 1.0), uniform(-1.0, 1.0), uniform(-1.0, 1.0));
            DQuat::from_axis_angle(axis.normalize_or(DVec3::X), uniform(-3.0, 3.0))
        };
        match self {
            JointKind::Revolute | JointKind::Continuous => q[0] = uniform(-1.2, 1.2),
            JointKind::Prismatic => q[0] = uniform(-0.2, 0.2),
            JointKind::Floating => {
                let rot = rotation(uniform);
                q.copy_from_slice(&[
                    uniform(-1.0, 1.0),
                    uniform(-1.0, 1.0),
                    uniform(-1.0, 1.0),
                    rot.w,
                    rot.x,
                    rot.y,
                    rot.z,
                ]);
            }
            JointKind::Ball => {
                let rot = rotation(uniform);
                q.copy_from_slice(&[rot.w, rot.x, rot.y, rot.z]);
            }
            JointKind::Fixed => {}
        }
    }

    /// The joint's own motion: the map from the moving frame to the joint frame for the
    /// coordinates `q` (length [`JointKind::nq`]); `axis` is the joint's unit axis (scalar
    /// kinds). Quaternions are normalised first.
    pub fn motion_transform(self, axis: DVec3, q: &[f64]) -> SpatialTransform {
        match self {
            JointKind::Revolute | JointKind::Continuous => {
                SpatialTransform::from_pose(DMat3::from_axis_angle(axis, q[0]), DVec3::ZERO)
            }
            JointKind::Prismatic => SpatialTransform::from_pose(DMat3::IDENTITY, axis * q[0]),
            JointKind::Floating => {
                let rot = DQuat::from_xyzw(q[4], q[5], q[6], q[3]).normalize();
                SpatialTransform::from_pose(DMat3::from_quat(rot), DVec3::new(q[0], q[1], q[2]))
            }
            JointKind::Ball => {
                let rot = DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize();
                SpatialTransform::from_pose(DMat3::from_quat(rot), DVec3::ZERO)
            }
            JointKind::Fixed => SpatialTransform::IDENTITY,
        }
    }

    /// Column `k` of the motion subspace in the moving frame (table in the module docs).
    pub fn subspace_column(self, axis: DVec3, k: usize) -> SpatialMotion {
        match self {
            JointKind::Revolute | JointKind::Continuous => SpatialMotion::new(axis, DVec3::ZERO),
            JointKind::Prismatic => SpatialMotion::new(DVec3::ZERO, axis),
            JointKind::Floating | JointKind::Ball => {
                let mut a = [0.0; 6];
                a[k] = 1.0;
                SpatialMotion::from_array(a)
            }
            JointKind::Fixed => SpatialMotion::ZERO,
        }
    }

    /// `q ← q ⊕ h v`: scalar coordinates add; a ball joint turns by `exp(h ω)` in its moving
    /// frame; a floating joint moves by the SE(3) exponential of its body twist
    /// ([`integrate_floating`]).
    pub fn integrate(self, q: &mut [f64], v: &[f64], h: f64) {
        match self {
            JointKind::Revolute | JointKind::Continuous | JointKind::Prismatic => q[0] += v[0] * h,
            JointKind::Floating => integrate_floating(q, v, h),
            JointKind::Ball => {
                let rot = DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize();
                let r = (rot * exp_rotation(DVec3::new(v[0], v[1], v[2]), h)).normalize();
                q[..4].copy_from_slice(&[r.w, r.x, r.y, r.z]);
            }
            JointKind::Fixed => {}
        }
    }

    /// The velocity `v` (length [`JointKind::nv`]) that moves `q0` to `q1` in unit time:
    /// `q0 ⊕ v = q1` ([`JointKind::integrate`] with `h = 1`). Rotations take the shorter way
    /// (angle ≤ π).
    pub fn difference(self, q0: &[f64], q1: &[f64], v: &mut [f64]) {
        match self {
            JointKind::Revolute | JointKind::Continuous | JointKind::Prismatic => {
                v[0] = q1[0] - q0[0]
            }
            JointKind::Ball => {
                let r0 = DQuat::from_xyzw(q0[1], q0[2], q0[3], q0[0]).normalize();
                let r1 = DQuat::from_xyzw(q1[1], q1[2], q1[3], q1[0]).normalize();
                v[..3].copy_from_slice(&log_rotation(r0.inverse() * r1).to_array());
            }
            JointKind::Floating => {
                let r0 = DQuat::from_xyzw(q0[4], q0[5], q0[6], q0[3]).normalize();
                let r1 = DQuat::from_xyzw(q1[4], q1[5], q1[6], q1[3]).normalize();
                let phi = log_rotation(r0.inverse() * r1);
                let dp = r0.inverse()
                    * (DVec3::new(q1[0], q1[1], q1[2]) - DVec3::new(q0[0], q0[1], q0[2]));
                // Solve J(φ) u = dp for u (J of `integrate_floating`).
                let u = j_inverse(phi, dp);
                v[..3].copy_from_slice(&phi.to_array());
                v[3..6].copy_from_slice(&u.to_array());
            }
            JointKind::Fixed => {}
        }
    }

    /// The Runge–Kutta–Munthe-Kaas position slope `dexp⁻¹_{−Θ}(ξ)` of a joint on a Lie group
    /// (ball: SO(3), floating: SE(3)), written over `xi` (length [`JointKind::nv`]); `theta`
    /// is the stage's increment. Scalar kinds keep `ξ`.
    pub fn rkmk_slope(self, theta: &[f64], xi: &mut [f64]) {
        let n = self.nv();
        if !self.on_a_lie_group() {
            return;
        }
        let mut t = [0.0; 6];
        let mut x = [0.0; 6];
        t[..n].copy_from_slice(&theta[..n]);
        x[..n].copy_from_slice(&xi[..n]);
        let t = SpatialMotion::from_array(t);
        if t == SpatialMotion::ZERO {
            return;
        }
        let slope = t.dexp_inv_slope(SpatialMotion::from_array(x)).to_array();
        xi[..n].copy_from_slice(&slope[..n]);
    }

    /// What each coordinate of a state vector means, for messages and state files: `what` is
    /// `"q"`, `"qd"` or anything else for forces.
    pub fn coordinates(self, what: &str) -> &'static str {
        match (what, self) {
            ("q", JointKind::Floating) => "[x, y, z, qw, qx, qy, qz]",
            ("qd", JointKind::Floating) => "[wx, wy, wz, vx, vy, vz] in the moving frame",
            (_, JointKind::Floating) => "[nx, ny, nz, fx, fy, fz] in the moving frame",
            ("q", JointKind::Ball) => "[qw, qx, qy, qz]",
            ("qd", JointKind::Ball) => "[wx, wy, wz] in the moving frame",
            (_, JointKind::Ball) => "[nx, ny, nz] in the moving frame",
            ("q", JointKind::Prismatic) => "[displacement in m]",
            ("qd", JointKind::Prismatic) => "[velocity in m/s]",
            (_, JointKind::Prismatic) => "[force in N]",
            ("q", JointKind::Revolute | JointKind::Continuous) => "[angle in rad]",
            ("qd", JointKind::Revolute | JointKind::Continuous) => "[angular velocity in rad/s]",
            (_, JointKind::Revolute | JointKind::Continuous) => "[torque in N m]",
            (_, JointKind::Fixed) => "[]",
        }
    }
}

/// The rotation `exp(h ω)` (a negative `h` turns backwards).
fn exp_rotation(w: DVec3, h: f64) -> DQuat {
    let angle = w.length() * h;
    if angle != 0.0 {
        DQuat::from_axis_angle(w.normalize(), angle)
    } else {
        DQuat::IDENTITY
    }
}

/// The rotation vector `φ` with `exp(φ) = r`, angle in [0, π].
fn log_rotation(r: DQuat) -> DVec3 {
    let r = if r.w < 0.0 { -r } else { r };
    let s = DVec3::new(r.x, r.y, r.z);
    let sn = s.length();
    if sn < 1e-8 {
        // 2 atan2(|s|, w) / |s| → 2/w (1 − |s|²/(3w²)).
        return s * (2.0 / r.w) * (1.0 - sn * sn / (3.0 * r.w * r.w));
    }
    s * (2.0 * sn.atan2(r.w) / sn)
}

/// `u` with `J(φ) u = p`, `J(φ) = 1 + a [φ]× + b [φ]×²` of [`integrate_floating`].
fn j_inverse(phi: DVec3, p: DVec3) -> DVec3 {
    let th = phi.length();
    // J⁻¹ = 1 − ½ [φ]× + c [φ]×², c = (1 − θ sin θ / (2 (1 − cos θ))) / θ².
    let c = if th < 1e-2 {
        let t2 = th * th;
        1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0
    } else {
        (1.0 - th * th.sin() / (2.0 * (1.0 - th.cos()))) / (th * th)
    };
    let pp = phi.cross(p);
    p - 0.5 * pp + c * phi.cross(pp)
}

/// `q ← q ⊕ h·v` for one floating joint: `q = [x, y, z, qw, qx, qy, qz]`, `v = [ω; v]` its
/// body twist. The exact motion at constant body velocity: orientation `R exp(ω h)`
/// (renormalised), position `p + R J(ω h) v h` with `J(φ) = ∫₀¹ exp(s [φ]×) ds =
/// 1 + a [φ]× + b [φ]×²`, `a = (1 − cos θ)/θ²`, `b = (θ − sin θ)/θ³`, `θ = |φ|`. (`p + R v h`
/// alone is only first order in `h` and makes RK4 first order on a floating base.)
pub fn integrate_floating(q: &mut [f64], v: &[f64], h: f64) {
    let rot = DQuat::from_xyzw(q[4], q[5], q[6], q[3]).normalize();
    let w = DVec3::new(v[0], v[1], v[2]);
    let v = DVec3::new(v[3], v[4], v[5]);
    let phi = w * h;
    let th = phi.length();
    let (a, b) = if th < 1e-2 {
        // Taylor series (the closed forms cancel); the next terms are < 1e-16.
        let t2 = th * th;
        (
            0.5 - t2 / 24.0 + t2 * t2 / 720.0,
            1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0,
        )
    } else {
        let s = (0.5 * th).sin();
        (2.0 * s * s / (th * th), (th - th.sin()) / (th * th * th))
    };
    let pv = phi.cross(v);
    let p = DVec3::new(q[0], q[1], q[2]) + rot * ((v + a * pv + b * phi.cross(pv)) * h);
    let r = (rot * exp_rotation(w, h)).normalize();
    q[..7].copy_from_slice(&[p.x, p.y, p.z, r.w, r.x, r.y, r.z]);
}

#[cfg(test)]
mod tests {
    use super::{JointKind, JOINT_KINDS};
    use glam::DVec3;

    fn lcg(seed: &mut u64) -> impl FnMut(f64, f64) -> f64 + '_ {
        move |lo, hi| {
            *seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((*seed >> 11) as f64 / (1u64 << 53) as f64)
        }
    }

    /// `q0 ⊕ (q1 ⊖ q0) = q1` for every kind, on random pairs (quaternions up to sign), and the
    /// motion of `q0 ⊕ h v` for small `h` is `h v` along the subspace: the difference of the
    /// motion transforms over `h` tends to `Σ S_k v_k`.
    #[test]
    fn difference_inverts_integration_and_velocity_matches_subspace() {
        let axis = DVec3::new(0.3, -0.5, 0.8).normalize();
        let mut seed = 7;
        for kind in JOINT_KINDS {
            for _ in 0..50 {
                let mut u = lcg(&mut seed);
                let (mut q0, mut q1) = (vec![0.0; kind.nq()], vec![0.0; kind.nq()]);
                kind.random_q(&mut q0, &mut u);
                kind.random_q(&mut q1, &mut u);
                let mut v = vec![0.0; kind.nv()];
                kind.difference(&q0, &q1, &mut v);
                let mut q = q0.clone();
                kind.integrate(&mut q, &v, 1.0);
                let sign = match kind.quaternion_offset() {
                    Some(o) if q[o] * q1[o] < 0.0 => -1.0,
                    _ => 1.0,
                };
                for i in 0..kind.nq() {
                    let s = if kind.quaternion_offset().is_some_and(|o| i >= o) {
                        sign
                    } else {
                        1.0
                    };
                    assert!((q[i] - s * q1[i]).abs() < 1e-12, "{kind:?} {q:?} {q1:?}");
                }
                // Velocity: X(q0)⁻¹ X(q0 ⊕ h v) ≈ 1 + h [S v]×.
                let w: Vec<f64> = (0..kind.nv()).map(|_| u(-1.0, 1.0)).collect();
                let h = 1e-6;
                let mut qh = q0.clone();
                kind.integrate(&mut qh, &w, h);
                let x0 = kind.motion_transform(axis, &q0);
                let xh = kind.motion_transform(axis, &qh);
                let rel = x0.inverse() * xh;
                let (e, r) = rel.to_pose();
                let mut expect = articula_spatial::SpatialMotion::ZERO;
                for (k, wk) in w.iter().enumerate() {
                    expect += kind.subspace_column(axis, k) * *wk;
                }
                let dw = DVec3::new(
                    e.y_axis.z - e.z_axis.y,
                    e.z_axis.x - e.x_axis.z,
                    e.x_axis.y - e.y_axis.x,
                ) * (0.5 / h);
                assert!(
                    (dw - expect.w).length() < 1e-5,
                    "{kind:?} {dw} {}",
                    expect.w
                );
                assert!(
                    (r / h - expect.v).length() < 1e-5,
                    "{kind:?} {} {}",
                    r / h,
                    expect.v
                );
            }
        }
    }

    /// The ball joint's sizes, neutral pose and names.
    #[test]
    fn ball_joint_definition() {
        let b = JointKind::Ball;
        assert_eq!((b.nq(), b.nv(), b.name()), (4, 3, "ball"));
        assert_eq!(b.neutral_q(), &[1.0, 0.0, 0.0, 0.0]);
        assert_eq!(b.quaternion_offset(), Some(0));
        assert!(!b.takes_limits() && !b.is_scalar());
        for kind in JOINT_KINDS {
            assert_eq!(kind.neutral_q().len(), kind.nq(), "{kind:?}");
        }
    }
}
