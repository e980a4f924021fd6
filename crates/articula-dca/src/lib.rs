//! # articula-dca
//!
//! Exact forward dynamics of articulated bodies: Featherstone's divide-and-conquer algorithm
//! ([`Method::Dca`], the main solver), with the articulated-body algorithm ([`Method::Aba`]) and
//! CRBA + Cholesky ([`Method::Crba`]) as references, all with world axes (about the floating
//! base for a floating model; see `docs/conventions.md`) on the assembly tree of
//! [`articula_model`]. A [`Data`] workspace holds every buffer; DCA and ABA calls and
//! [`step`]s allocate nothing.
//!
//! Around forward dynamics: [`inverse_dynamics`] (RNEA), the [`mass_matrix`] (CRBA) and the
//! [`bias_forces`], the centre of mass ([`Data::center_of_mass`], [`Data::com_jacobian`]),
//! link poses ([`articula_model::Model::find_link`], [`Data::link_pose`]) and Jacobians
//! ([`Data::link_jacobian`] in a [`ReferenceFrame`], [`Data::point_jacobian`]), energies
//! ([`Data::kinetic_energy`], [`Data::potential_energy`]) and momentum ([`Data::momentum`],
//! [`Data::centroidal_momentum`]); `examples/humanoid.rs` runs them on a floating humanoid.
//!
//! The DCA pass is compiled twice: portably, and with fused multiply–adds for x86-64 CPUs with
//! AVX2 and FMA (detected at run time), which `Data::new` picks when it can. The two agree to
//! rounding (~1e-12 relative), so results may differ in their last bits between machines.
//! articula-adaptive writes its passes over the same arithmetic strategy to do likewise
//! (`articula_spatial::numerics`). ABA (with its kinematics) is compiled for AVX2 too, with the portable
//! arithmetic: the same bits.
//!
//! ```
//! use articula_dca::{forward_dynamics, Data, Method, State};
//! use articula_model::{LoadOptions, Model};
//!
//! let urdf = r#"<robot name="pendulum"><link name="base"/>
//!   <link name="bob"><inertial><origin xyz="0 0 -1"/><mass value="1"/>
//!     <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>
//!   <joint name="swing" type="continuous"><parent link="base"/><child link="bob"/>
//!     <axis xyz="0 1 0"/></joint></robot>"#;
//! let model = Model::from_urdf_str(urdf, &LoadOptions::default()).unwrap();
//! let mut data = Data::new(&model);
//! let mut state = State::neutral(&model);
//! state.q[0] = 0.5; // 0.5 rad from hanging straight down
//! let qdd = forward_dynamics(&model, &mut data, &state, Method::Dca).unwrap()[0];
//! // m l² q̈ = −m g l sin q, with the bob's own inertia I_yy = 1e-4 added.
//! let expected = -9.81 * 0.5f64.sin() / (1.0 + 1e-4);
//! assert!((qdd - expected).abs() < 1e-10 * expected.abs());
//! ```

// Index loops over joint columns and handles mirror the equations (S columns p, q; handles h, k).
#![allow(clippy::needless_range_loop)]

mod aba;
mod banked;
mod batch;
mod cluster;
mod com;
mod contact;
mod contact_dense;
mod contact_newton;
mod contact_solver;
mod crba;
mod data;
mod dca;
mod delassus;
mod energy;
mod error;
mod forward;
mod gather;
mod inputs;
mod integrate;
mod inverse;
mod jacobian;
mod kinematics;
mod krylov;
mod link;
mod mass_matrix;
mod mass_ratio;
mod momentum;
mod parallel_dca;
mod refine;
mod residual;
mod small;
mod state;
mod threads;

pub use batch::{Batch, BatchError};
pub use contact::{
    sphere_center, step_with_contact, step_with_dynamics, ContactData, ContactDynamics,
    ContactError, ContactForces, ContactScratch, ContactSettings, ContactSolver, ContactStats,
    Ground, MAX_ITERATIONS as CONTACT_MAX_ITERATIONS,
};
pub use data::Data;
pub use error::{human_bytes, DynamicsError, MAX_DENSE_MATRIX_BYTES};
pub use forward::{forward_dynamics, forward_dynamics_slices, Method};
pub use inputs::check_inputs;
pub use integrate::{integrate_floating, integrate_q, step, Integrator};
pub use inverse::{bias_forces, inverse_dynamics};
pub use jacobian::ReferenceFrame;
pub use kinematics::{body_kinematics, computation_origin, forward_kinematics};
pub use mass_matrix::mass_matrix;
pub use parallel_dca::{forward_dynamics_threads, PARALLEL_DCA_MIN_BODIES};
pub use state::{SplitMix64, State};
pub use threads::{Threads, ThreadsError};

/// What `cargo xtask` and this crate's own tests measure or drive that no program needs, behind
/// the `internals` cargo feature (nothing in the library turns it on): ABA's pass 2 at a
/// multi-DOF joint ([`articulate_multi`](internals::articulate_multi)), the split DCA solve at
/// any size, byte counts in words, and, re-exported from `articula_spatial::numerics` where
/// they live, the [`Arith`] strategy the two compilations of the DCA pass are written over
/// (portable, and AVX2 + FMA where [`fused_available`]; the workspace's switch between them is
/// [`Data::set_fused_dca`](crate::Data::set_fused_dca)) and the small Cholesky kernels.
///
/// [`fused_available`]: internals::fused_available
/// [`Arith`]: internals::Arith
#[cfg(feature = "internals")]
pub mod internals {
    pub use crate::aba::{articulate_multi, MultiArgs};
    pub use crate::error::human_bytes;
    /// [`crate::forward_dynamics_threads`]' split DCA solve whatever the model's size (for
    /// measuring the crossover: `cargo xtask parallel`).
    pub use crate::parallel_dca::forward_split as forward_dynamics_split;
    #[cfg(target_arch = "x86_64")]
    pub use articula_spatial::numerics::Fused;
    pub use articula_spatial::numerics::{
        cholesky, cholesky_into, fused_available, Arith, Portable,
    };
}

#[cfg(test)]
use articula_model::Model;

/// Every bundled model (`models/*.urdf` of the workspace), fixed and floating base, for the
/// crate's unit tests: `(name, floating_base, model)`.
#[cfg(test)]
pub(crate) fn bundled_models() -> impl Iterator<Item = (&'static str, bool, Model)> {
    ["chain10", "chain300", "humanoid", "plant", "rope"]
        .into_iter()
        .flat_map(|name| [false, true].map(|floating_base| (name, floating_base)))
        .map(|(name, floating_base)| {
            let model = articula_testkit::bundled_with(name, floating_base);
            (name, floating_base, model)
        })
}

/// `method`'s q̈ at seeded state `seed` of `model` (random external forces on odd seeds),
/// solved with the portable compilation and with the AVX2 + FMA one where the CPU has it:
/// `(portable, fused)`, for the crate's unit tests.
#[cfg(test)]
pub(crate) fn solve_portable_and_fused(
    model: &Model,
    data: &mut Data,
    seed: u64,
    method: Method,
) -> (Vec<f64>, Vec<f64>) {
    let mut s = State::random(model, seed, 1.0);
    if seed % 2 == 1 {
        s.randomize_forces(seed, 0.5);
    }
    let mut solve = |fused: bool| {
        data.dca.fused = fused;
        forward_dynamics(model, data, &s, method).unwrap().to_vec()
    };
    (
        solve(false),
        solve(articula_spatial::numerics::fused_available()),
    )
}
