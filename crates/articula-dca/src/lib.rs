//! # articula-dca
//!
//! Exact forward dynamics of articulated bodies: Featherstone's divide-and-conquer algorithm
//! ([`Method::Dca`], the main solver), with the articulated-body algorithm ([`Method::Aba`]) and
//! CRBA + Cholesky ([`Method::Crba`]) as references, all with world axes (about the floating
//! base for a floating model; see `docs/conventions.md`) on the assembly tree of
//! [`articula_model`]. A [`Data`] workspace holds every buffer; DCA and ABA calls and
//! [`step`]s allocate nothing.
//!
//! The DCA pass is compiled twice: portably, and with fused multiply–adds for x86-64 CPUs with
//! AVX2 and FMA ([`fused_available`]), which `Data::new` picks when it can. The two agree to
//! rounding (~1e-12 relative), so results may differ in their last bits between machines.
//! Other crates write their passes over the same [`Arith`] type to do likewise. ABA (with its
//! kinematics) is compiled for AVX2 too, with the portable arithmetic: the same bits.
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
//! let qdd = forward_dynamics(&model, &mut data, &state.q, &state.qd, &state.tau, &state.f_ext, Method::Dca)
//!     .unwrap()[0];
//! // m l² q̈ = −m g l sin q, with the bob's own inertia I_yy = 1e-4 added.
//! let expected = -9.81 * 0.5f64.sin() / (1.0 + 1e-4);
//! assert!((qdd - expected).abs() < 1e-10 * expected.abs());
//! ```

// Index loops over joint columns and handles mirror the equations (S columns p, q; handles h, k).
#![allow(clippy::needless_range_loop)]

mod aba;
mod crba;
mod data;
mod dca;
mod error;
mod integrate;
mod kinematics;
mod refine;
mod small;
mod state;

pub use data::Data;
#[cfg(target_arch = "x86_64")]
pub use dca::Fused;
pub use dca::{fused_available, Arith, Portable};
pub use error::DynamicsError;
pub use integrate::{integrate_floating, integrate_q, step, Integrator};
pub use kinematics::{body_kinematics, computation_origin, forward_kinematics};
pub use small::{cholesky, cholesky_into};
pub use state::{SplitMix64, State};

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

/// Checks the inputs, runs forward kinematics and the chosen algorithm, checks the result, and
/// returns `q̈` (also left in `data.qdd`). `f_ext` may be empty (no external forces) or hold one
/// world-frame wrench per body.
pub fn forward_dynamics<'d>(
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

/// Whether every entry of `xs` is finite, without an early exit so that it vectorises: `x·0`
/// is ±0 for a finite `x` and NaN for an infinite or NaN one, summed in four lanes (a sum of
/// zeros is zero; one NaN makes it NaN). The input checks of the solvers here and of
/// articula-adaptive's steps use it.
#[inline]
pub fn all_finite(xs: &[f64]) -> bool {
    let mut acc = [0.0f64; 4];
    let mut chunks = xs.chunks_exact(4);
    for c in &mut chunks {
        for k in 0..4 {
            acc[k] += c[k] * 0.0;
        }
    }
    for &x in chunks.remainder() {
        acc[0] += x * 0.0;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) == 0.0
}

/// External wrench on body `i`: an empty slice means none.
#[inline]
pub(crate) fn f_ext_of(f_ext: &[SpatialForce], i: usize) -> SpatialForce {
    f_ext.get(i).copied().unwrap_or(SpatialForce::ZERO)
}

/// Checks the inputs of a dynamics call: lengths of `q`, `qd`, `tau` (and `f_ext` when not
/// empty), and that every number is finite — an error names the joint or body.
pub fn check_inputs(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    f_ext: &[SpatialForce],
) -> Result<(), DynamicsError> {
    for (what, len, expected) in [
        ("q", q.len(), model.nq),
        ("qd", qd.len(), model.nv),
        ("tau", tau.len(), model.nv),
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
            ("tau", &tau[vo..vo + part.nv()]),
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
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
    ["chain10", "chain300", "humanoid", "plant", "rope"]
        .into_iter()
        .flat_map(|name| [false, true].map(|floating_base| (name, floating_base)))
        .map(move |(name, floating_base)| {
            let options = articula_model::LoadOptions::default().with_floating_base(floating_base);
            let model = Model::from_urdf_file(dir.join(format!("{name}.urdf")), &options)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
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
        forward_dynamics(model, data, &s.q, &s.qd, &s.tau, &s.f_ext, method)
            .unwrap()
            .to_vec()
    };
    (solve(false), solve(dca::fused_available()))
}

#[cfg(test)]
mod finite_tests {
    /// `all_finite` against `is_finite` entry by entry: every length up to 13 (the four-lane
    /// chunks and every remainder), with one NaN, +∞ or −∞ at each position, and all finite
    /// (signed zeros, subnormals, the largest finite values included).
    #[test]
    fn all_finite_matches_is_finite() {
        let finite = [
            0.0,
            -0.0,
            1.5,
            -2.25e300,
            f64::MAX,
            f64::MIN,
            5e-324,
            -1e-310,
        ];
        for len in 0..=13 {
            let base: Vec<f64> = (0..len).map(|i| finite[i % finite.len()]).collect();
            assert!(super::all_finite(&base), "len {len}");
            for pos in 0..len {
                for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                    let mut xs = base.clone();
                    xs[pos] = bad;
                    let expected = xs.iter().all(|x| x.is_finite());
                    assert!(!expected);
                    assert_eq!(
                        super::all_finite(&xs),
                        expected,
                        "len {len} pos {pos} {bad}"
                    );
                }
            }
        }
    }
}
