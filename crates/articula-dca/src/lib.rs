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
//! articula-adaptive writes its passes over the same arithmetic strategy to do likewise (the
//! `internals` feature). ABA (with its kinematics) is compiled for AVX2 too, with the portable
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
mod arith;
mod com;
mod crba;
mod data;
mod dca;
mod energy;
mod error;
mod finite;
mod integrate;
mod inverse;
mod jacobian;
mod kinematics;
mod link;
mod mass_matrix;
mod momentum;
mod refine;
mod small;
mod state;

pub use data::Data;
pub use error::DynamicsError;
pub use integrate::{integrate_floating, integrate_q, step, Integrator};
pub use inverse::{bias_forces, inverse_dynamics};
pub use jacobian::ReferenceFrame;
pub use kinematics::forward_kinematics;
pub use mass_matrix::mass_matrix;
pub use state::State;

use finite::all_finite;

/// Building blocks that the workspace's higher layers (articula-adaptive, articula-view,
/// `cargo xtask`) share with this crate, behind the `internals` cargo feature: the two
/// compilations of the DCA pass (portable, and AVX2 + FMA where [`fused_available`]) as the
/// [`Arith`] strategy, the small Cholesky kernels, per-body kinematics, the random-number
/// generator of [`State::random`](crate::State::random), and the workspace's switch between the
/// two compilations ([`Data::set_fused_dca`](crate::Data::set_fused_dca)). Not a stable API:
/// users need none of it.
///
/// [`fused_available`]: internals::fused_available
/// [`Arith`]: internals::Arith
#[cfg(feature = "internals")]
pub mod internals {
    #[cfg(target_arch = "x86_64")]
    pub use crate::arith::Fused;
    pub use crate::arith::{fused_available, Arith, Portable};
    pub use crate::finite::all_finite;
    pub use crate::kinematics::{body_kinematics, computation_origin};
    pub use crate::small::{cholesky, cholesky_into};
    pub use crate::state::SplitMix64;
}

use articula_model::Model;
use articula_spatial::SpatialForce;

/// A forward-dynamics algorithm.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Method {
    /// Featherstone's divide-and-conquer algorithm (the main solver).
    #[default]
    Dca,
    /// The articulated-body algorithm (reference).
    Aba,
    /// Composite-rigid-body algorithm + Cholesky (reference; allocates).
    Crba,
}

impl std::str::FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "dca" => Ok(Method::Dca),
            "aba" => Ok(Method::Aba),
            "crba" => Ok(Method::Crba),
            _ => Err(format!("unknown method '{s}' (expected dca, aba or crba)")),
        }
    }
}

impl Method {
    /// The lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            Method::Dca => "dca",
            Method::Aba => "aba",
            Method::Crba => "crba",
        }
    }
}

/// Forward dynamics of a [`State`]: `q̈ = FD(q, q̇, τ, f_ext)` by `method`, with gravity
/// (`Data::gravity`). Returns `q̈` (also left in `data.qdd`); `data` then holds the kinematics
/// of `(q, q̇)`. [`forward_dynamics_slices`] with the state's vectors.
pub fn forward_dynamics<'d>(
    model: &Model,
    data: &'d mut Data,
    state: &State,
    method: Method,
) -> Result<&'d [f64], DynamicsError> {
    forward_dynamics_slices(
        model,
        data,
        &state.q,
        &state.qd,
        &state.tau,
        &state.f_ext,
        method,
    )
}

/// Forward dynamics from slices: checks the inputs, runs forward kinematics and the chosen
/// algorithm, checks the result, and returns `q̈` (also left in `data.qdd`). `f_ext` may be
/// empty (no external forces) or hold one wrench per body, world coordinates about the world
/// origin. DCA and ABA allocate nothing.
pub fn forward_dynamics_slices<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    f_ext: &[SpatialForce],
    method: Method,
) -> Result<&'d [f64], DynamicsError> {
    check_inputs(model, q, qd, tau, f_ext)?;
    data.origin = kinematics::computation_origin(model, q);
    kinematics::forces_to_computation_frame(f_ext, data);
    let f_ext = std::mem::take(&mut data.f_ext_c);
    let result = match method {
        Method::Dca => dca::forward(model, q, qd, tau, &f_ext, data).and_then(|()| {
            // Regularised leaves always (see `refine`): their first solve is not exact.
            if data.refine.regularised || (data.refine_dca && data.refine_floating) {
                refine::refine_dca(model, tau, &f_ext, data)
            } else {
                Ok(())
            }
        }),
        Method::Aba => aba::forward(model, q, qd, tau, &f_ext, data).map(|()| {
            if model.floating_base && data.refine_floating {
                aba::refine(model, tau, &f_ext, data);
            }
        }),
        Method::Crba => {
            kinematics::kinematics(model, q, qd, data, |_, _| {});
            crba::crba(model, tau, &f_ext, data)
        }
    };
    data.f_ext_c = f_ext;
    result?;
    // A plain scan first; the per-joint search (for the name) only when something is wrong.
    let all_finite = all_finite(&data.qdd);
    for (_, part) in model.joint_parts().filter(|_| !all_finite) {
        if data.qdd[part.v_offset..part.v_offset + part.nv()]
            .iter()
            .any(|x| !x.is_finite())
        {
            return Err(DynamicsError::NonFinite {
                what: "qdd",
                name: part.name.clone(),
            });
        }
    }
    Ok(&data.qdd)
}

/// External wrench on body `i`: an empty slice means none.
#[inline]
pub(crate) fn f_ext_of(f_ext: &[SpatialForce], i: usize) -> SpatialForce {
    f_ext.get(i).copied().unwrap_or(SpatialForce::ZERO)
}

/// Checks the inputs of a dynamics call: lengths of `q`, `qd`, `tau` (and `f_ext` when not
/// empty), and that every number is finite — an error names the joint or body.
#[inline]
pub fn check_inputs(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    f_ext: &[SpatialForce],
) -> Result<(), DynamicsError> {
    check_values(model, q, qd, ("tau", tau), f_ext)
}

/// [`check_inputs`] with the third per-degree-of-freedom vector named (`tau`, `qdd`).
#[inline]
pub(crate) fn check_values(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    (third, tau): (&'static str, &[f64]),
    f_ext: &[SpatialForce],
) -> Result<(), DynamicsError> {
    for (what, len, expected) in [
        ("q", q.len(), model.nq),
        ("qd", qd.len(), model.nv),
        (third, tau.len(), model.nv),
    ] {
        if len != expected {
            return Err(DynamicsError::Dimension {
                what,
                expected,
                found: len,
            });
        }
    }
    if !f_ext.is_empty() && f_ext.len() != model.bodies.len() {
        return Err(DynamicsError::Dimension {
            what: "f_ext",
            expected: model.bodies.len(),
            found: f_ext.len(),
        });
    }
    let all_finite = all_finite(q) && all_finite(qd) && all_finite(tau);
    for (_, part) in model.joint_parts().filter(|_| !all_finite) {
        let (qo, vo) = (part.q_offset, part.v_offset);
        for (what, xs) in [
            ("q", &q[qo..qo + part.nq()]),
            ("qd", &qd[vo..vo + part.nv()]),
            (third, &tau[vo..vo + part.nv()]),
        ] {
            if xs.iter().any(|x| !x.is_finite()) {
                return Err(DynamicsError::NonFinite {
                    what,
                    name: part.name.clone(),
                });
            }
        }
    }
    for (i, f) in f_ext.iter().enumerate() {
        if !f.is_finite() {
            return Err(DynamicsError::NonFinite {
                what: "external force",
                name: model.bodies[i].name.clone(),
            });
        }
    }
    Ok(())
}

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
    (solve(false), solve(arith::fused_available()))
}
