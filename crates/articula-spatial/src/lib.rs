//! # articula-spatial
//!
//! 6D spatial vector algebra (Featherstone, *Rigid Body Dynamics Algorithms*, ch. 2) on
//! glam `f64` types — the bottom layer of articula.
//!
//! - [`SpatialMotion`] `[w; v]` and [`SpatialForce`] `[n; f]` are distinct types (angular part
//!   first): adding a force to a motion does not compile, and their scalar product is power.
//! - [`SpatialTransform`] is a Plücker transform `rot(E) xlt(r)`; it maps motions, forces and
//!   inertias between frames.
//! - [`SpatialInertia`] is a rigid body's inertia (mass, first moment, rotational inertia).
//! - [`Mat6`] and [`SymMat6`] are the dense 6×6 blocks of the divide-and-conquer algorithm
//!   and of the articulated-body algorithm.
//!
//! ```
//! use articula_spatial::*;
//! use glam::{DMat3, DVec3};
//!
//! // A 2 kg body, centre of mass 0.5 m along x, spinning about z at 3 rad/s.
//! let inertia = SpatialInertia::new(2.0, DVec3::new(0.5, 0.0, 0.0), DMat3::IDENTITY * 0.1);
//! let v = SpatialMotion::new(DVec3::new(0.0, 0.0, 3.0), DVec3::ZERO);
//! let momentum: SpatialForce = inertia.mul_motion(v);
//! // Kinetic energy ½ vᵀ I v = ½ ω² (I_zz + m d²) = ½ · 9 · (0.1 + 0.5).
//! assert!((inertia.kinetic_energy(v) - 2.7).abs() < 1e-12);
//!
//! // Power is frame invariant: express both in a translated, rotated frame.
//! let x = SpatialTransform::from_pose(DMat3::from_rotation_x(0.3), DVec3::new(1.0, 2.0, 3.0));
//! let p0 = v.dot(momentum);
//! let p1 = x.apply_motion(v).dot(x.apply_force(momentum));
//! assert!((p0 - p1).abs() < 1e-12);
//! ```

mod arith;
mod cholesky;
mod finite;
mod inertia;
mod kernels;
mod matrix;
mod transform;
mod vector;

pub use glam::{DMat3, DQuat, DVec3};
pub use inertia::{skew, SpatialInertia};
pub use matrix::{Mat6, SymMat6};
pub use transform::SpatialTransform;
pub use vector::{SpatialForce, SpatialMotion};

/// The numeric kernels every layer above shares, each written once here
/// (docs/design.md#numerics): the arithmetic strategy [`Arith`](numerics::Arith) a pass is
/// written over, the [`fma_dispatch!`] macro that compiles such a pass for any CPU and for
/// AVX2 + FMA, and the raw-array kernels: the dot family (scalar products in named summation
/// orders), the finiteness check, and the small dense Cholesky / `L D Lᵀ` family (fixed 6×6,
/// leading `k × k`, run-time `n × n`, their solves and SPD inverses; one contract, see its
/// members' docs). Low-level: a program that only computes dynamics needs none of it.
pub mod numerics {
    #[cfg(target_arch = "x86_64")]
    pub use crate::arith::Fused;
    pub use crate::arith::{fused_available, Arith, Portable};
    pub use crate::cholesky::{
        cholesky, cholesky_into, cholesky_inv_diag, cholesky_rows, cholesky_rows_skip,
        cholesky_rows_solve, invert_factor_inv_diag, invert_joint_block, invert_spd_into,
        joint_block_regular, ldl5, psd_root, solve_llt_k, solve_lower, solve_lower_inv_diag,
        solve_lower_t, solve_lower_t_inv_diag, JOINT_PIVOT_REL,
    };
    pub use crate::finite::all_finite;
    pub use crate::kernels::{dot3, dot6, dot6_even_odd, dot6_pairs, dot_lanes, M6};
}
