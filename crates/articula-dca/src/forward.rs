//! Forward dynamics: the [`Method`] that solves it, and the entry points that check the
//! inputs, run it and check its result.

use crate::inputs::check_inputs;
use crate::{aba, crba, dca, kinematics, refine};
use crate::{Data, DynamicsError, State};
use articula_model::Model;
use articula_spatial::numerics::all_finite;
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
    crate::inputs::check_data(model, data)?;
    check_inputs(model, q, qd, tau, f_ext)?;
    if method == Method::Crba {
        crate::error::check_dense("joint-space inertia matrix", model.nv, model.nv)?;
    }
    data.origin = kinematics::computation_origin(model, q);
    kinematics::forces_to_computation_frame(f_ext, data);
    let f_ext = std::mem::take(&mut data.f_ext_c);
    let result = match method {
        Method::Dca => dca_or_fall_back(model, q, qd, tau, &f_ext, data, |data| {
            dca::forward(model, q, qd, tau, &f_ext, data)
        }),
        Method::Aba => aba_refined(model, q, qd, tau, &f_ext, data),
        Method::Crba => {
            kinematics::kinematics(model, q, qd, data, |_, _| {});
            crba::crba(model, tau, &f_ext, data)
        }
    };
    data.f_ext_c = f_ext;
    result?;
    check_qdd(model, data)?;
    Ok(&data.qdd)
}

/// ABA with its floating-base refinement.
fn aba_refined(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
) -> Result<(), DynamicsError> {
    aba::forward(model, q, qd, tau, f_ext, data)?;
    if model.floating_base && data.refine_floating {
        aba::refine(model, tau, f_ext, data);
    }
    Ok(())
}

/// DCA's solve `solve` (serial or split; `f_ext` in the computation frame) with its
/// refinement rule, answered by ABA when DCA cannot certify its own answer: the refinement
/// did not converge, or a join was singular where ABA's articulated inertias are not (a
/// rounding artefact of DCA's compliances on very long bodies). Each fallback is counted
/// (`Data::fallback_count`, reported as a warning by callers). A joint found singular by the
/// test every method shares (`joint_block_regular`) is an error without a fallback.
pub(crate) fn dca_or_fall_back(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
    solve: impl FnOnce(&mut Data) -> Result<(), DynamicsError>,
) -> Result<(), DynamicsError> {
    let certified = solve(data).and_then(|()| {
        // Regularised leaves always (see `refine`): their first solve is not exact.
        // ... and solves whose join factorisation lost a pivot to rounding, and models
        // whose neighbouring bodies differ greatly in mass (`refine`).
        if data.refine.regularised
            || data.refine.mass_ratio
            || data.dca.clamped > 0
            || (data.refine_dca && data.refine_floating)
        {
            refine::refine_dca(model, tau, f_ext, data)
        } else {
            Ok(true)
        }
    });
    match certified {
        Ok(true) => Ok(()),
        Ok(false) => {
            data.refine.fallbacks += 1;
            aba_refined(model, q, qd, tau, f_ext, data)
        }
        Err(DynamicsError::Singular { detail, .. })
            if detail != crate::error::JOINT_BLOCK_SINGULAR =>
        {
            aba_refined(model, q, qd, tau, f_ext, data)?;
            data.refine.fallbacks += 1;
            Ok(())
        }
        Err(e) => Err(e),
    }
}

/// `Ok` when every `q̈` in `data.qdd` is finite, else the error naming the first joint with
/// one that is not.
pub(crate) fn check_qdd(model: &Model, data: &Data) -> Result<(), DynamicsError> {
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
    Ok(())
}
