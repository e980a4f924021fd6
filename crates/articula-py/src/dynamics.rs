//! The free functions of one state: forward and inverse dynamics, the mass matrix, bias
//! forces, kinematics, poses, Jacobians, centre of mass, energies and momentum. Each takes
//! `(model, data, ...)` as Pinocchio's do; a single call is microseconds, so it keeps the GIL.

use crate::errors::{dynamics_error, error, from_dynamics, Kind};
use crate::input::{check_quaternions, triple, vector, wrenches};
use crate::model::{PyData, PyModel};
use articula::glam::{DMat3, DVec3};
use articula::model::LinkFrame;
use articula::prelude::{Method, Model, ReferenceFrame, SpatialForce};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;

/// A method name to the library's.
pub(crate) fn method(name: &str) -> PyResult<Method> {
    name.parse::<Method>().map_err(dynamics_error)
}

/// A row-major `rows × cols` numpy array from a flat slice.
pub(crate) fn matrix<'py>(
    py: Python<'py>,
    flat: &[f64],
    rows: usize,
    cols: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    PyArray1::from_slice(py, flat).reshape([rows, cols])
}

/// A 3×3 rotation as a numpy array (row-major).
fn rotation<'py>(py: Python<'py>, r: DMat3) -> PyResult<Bound<'py, PyArray2<f64>>> {
    matrix(py, &r.transpose().to_cols_array(), 3, 3)
}

/// A spatial force `[n; f]` as a numpy array of 6.
fn force<'py>(py: Python<'py>, f: SpatialForce) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, &f.to_array())
}

/// Forward dynamics: the joint accelerations q̈ (length nv) of state (q, v, tau) with gravity
/// and the external wrenches f_ext (None, or an array (nbodies, 6) of [n; f] rows in world
/// coordinates about the world origin), by method "dca" (divide and conquer, the default),
/// "aba" (articulated-body algorithm) or "crba" (mass matrix + Cholesky). data then holds the
/// kinematics of (q, v). Pinocchio: pin.aba(model, data, q, v, tau) (mind the floating-base
/// order, docs/python.md).
#[pyfunction]
#[pyo3(signature = (model, data, q, v, tau, f_ext=None, method="dca"))]
#[allow(clippy::too_many_arguments)]
pub fn forward_dynamics<'py>(
    py: Python<'py>,
    model: &PyModel,
    data: &mut PyData,
    q: &Bound<'py, PyAny>,
    v: &Bound<'py, PyAny>,
    tau: &Bound<'py, PyAny>,
    f_ext: Option<&Bound<'py, PyAny>>,
    method: &str,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    data.check(model)?;
    let m = self::method(method)?;
    let x = triple(&model.model, q, v, ("tau", tau))?;
    let f = wrenches(&model.model, f_ext)?;
    let qdd = articula::dca::forward_dynamics_slices(
        &model.model,
        &mut data.data,
        x.q.slice(),
        x.v.slice(),
        x.third.slice(),
        &f,
        m,
    );
    data.kinematics = true;
    Ok(PyArray1::from_slice(py, qdd.map_err(from_dynamics)?))
}

/// Inverse dynamics (recursive Newton–Euler): the joint forces tau (length nv) that give the
/// accelerations a at (q, v) with gravity and f_ext (as for forward_dynamics), so that
/// inverse_dynamics(..., forward_dynamics(..., tau)) == tau. Pinocchio: pin.rnea.
#[pyfunction]
#[pyo3(signature = (model, data, q, v, a, f_ext=None))]
pub fn inverse_dynamics<'py>(
    py: Python<'py>,
    model: &PyModel,
    data: &mut PyData,
    q: &Bound<'py, PyAny>,
    v: &Bound<'py, PyAny>,
    a: &Bound<'py, PyAny>,
    f_ext: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    data.check(model)?;
    let x = triple(&model.model, q, v, ("a", a))?;
    let f = wrenches(&model.model, f_ext)?;
    let tau = articula::dca::inverse_dynamics(
        &model.model,
        &mut data.data,
        x.q.slice(),
        x.v.slice(),
        x.third.slice(),
        &f,
    );
    data.kinematics = true;
    Ok(PyArray1::from_slice(py, tau.map_err(from_dynamics)?))
}

/// The joint-space inertia matrix M(q) (nv × nv, symmetric) by the composite-rigid-body
/// algorithm. Pinocchio: pin.crba (which fills only the upper triangle).
#[pyfunction]
pub fn mass_matrix<'py>(
    py: Python<'py>,
    model: &PyModel,
    data: &mut PyData,
    q: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    data.check(model)?;
    let nv = model.model.nv;
    let q = vector(q, "q", model.model.nq)?;
    check_quaternions(&model.model, q.slice(), "q")?;
    let m = articula::dca::mass_matrix(&model.model, &mut data.data, q.slice());
    data.kinematics = true;
    matrix(py, m.map_err(from_dynamics)?, nv, nv)
}

/// The bias forces b(q, v) = inverse_dynamics(q, v, 0) without external forces: Coriolis,
/// centrifugal and gravity terms, so that M q̈ + b = tau. Pinocchio: pin.nonLinearEffects.
#[pyfunction]
pub fn bias_forces<'py>(
    py: Python<'py>,
    model: &PyModel,
    data: &mut PyData,
    q: &Bound<'py, PyAny>,
    v: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    data.check(model)?;
    let q = vector(q, "q", model.model.nq)?;
    let v = vector(v, "v", model.model.nv)?;
    check_quaternions(&model.model, q.slice(), "q")?;
    let b = articula::dca::bias_forces(&model.model, &mut data.data, q.slice(), v.slice());
    data.kinematics = true;
    Ok(PyArray1::from_slice(py, b.map_err(from_dynamics)?))
}

/// The passive joint forces at (q, v): per degree of freedom -damping v - stiffness (q -
/// springref), from URDF <dynamics damping> and MJCF damping, stiffness and springdamper.
/// MuJoCo: data.qfrc_passive. Stepping applies them (damping implicitly); forward_dynamics
/// with an explicit tau does not, so forward_dynamics(model, data, q, v, tau +
/// passive_forces(model, q, v)) is MuJoCo's qacc_smooth.
#[pyfunction]
pub fn passive_forces<'py>(
    py: Python<'py>,
    model: &PyModel,
    q: &Bound<'py, PyAny>,
    v: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let q = vector(q, "q", model.model.nq)?;
    let v = vector(v, "v", model.model.nv)?;
    check_quaternions(&model.model, q.slice(), "q")?;
    let mut out = vec![0.0; model.model.nv];
    model.model.passive_forces(q.slice(), v.slice(), &mut out);
    Ok(PyArray1::from_vec(py, out))
}

/// Positions and velocities of every body at (q, v) (v defaults to zero) into data, for
/// link_pose, jacobian, com, com_jacobian, the energies and momentum.
/// Pinocchio: pin.forwardKinematics + pin.updateFramePlacements.
#[pyfunction]
#[pyo3(signature = (model, data, q, v=None))]
pub fn forward_kinematics(
    model: &PyModel,
    data: &mut PyData,
    q: &Bound<'_, PyAny>,
    v: Option<&Bound<'_, PyAny>>,
) -> PyResult<()> {
    data.check(model)?;
    let m = &model.model;
    let q = vector(q, "q", m.nq)?;
    check_quaternions(m, q.slice(), "q")?;
    let zero = vec![0.0; m.nv];
    let v = match v.filter(|v| !v.is_none()) {
        Some(v) => Some(vector(v, "v", m.nv)?),
        None => None,
    };
    let vs = v.as_ref().map_or(&zero[..], |v| v.slice());
    articula::dca::check_inputs(m, q.slice(), vs, &zero, &[]).map_err(from_dynamics)?;
    articula::dca::forward_kinematics(m, q.slice(), vs, &mut data.data).map_err(from_dynamics)?;
    data.kinematics = true;
    Ok(())
}

/// A URDF link's frame, or a ModelError naming it.
pub(crate) fn find_link(model: &Model, link: &str) -> PyResult<LinkFrame> {
    model.find_link(link).ok_or_else(|| {
        error(
            Kind::Model,
            format!(
                "no link named '{link}' with a frame of its own (massless links folded into a \
                 composed joint have none; see model.link_names)"
            ),
        )
    })
}

/// The pose of a URDF link in the world from data's kinematics: (R, p), R its axes (3×3,
/// columns in world coordinates), p its origin. Pinocchio: data.oMf[frame_id] (rotation,
/// translation).
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn link_pose<'py>(
    py: Python<'py>,
    model: &PyModel,
    data: &PyData,
    link: &str,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<f64>>)> {
    data.check(model)?;
    data.check_kinematics()?;
    let frame = find_link(&model.model, link)?;
    let (r, p) = data.data.link_pose(&frame).map_err(from_dynamics)?;
    Ok((rotation(py, r)?, PyArray1::from_slice(py, &p.to_array())))
}

/// The spatial Jacobian of a URDF link (6 × nv), rows [ω; v] (angular first; Pinocchio puts
/// v first), from data's kinematics. frame: "local_world_aligned" (world axes about the link's
/// origin, the default), "local" (the link's axes) or "world" (world axes about the world
/// origin). Pinocchio: pin.getFrameJacobian(model, data, id, pin.LOCAL_WORLD_ALIGNED) with its
/// two 3-row blocks swapped.
#[pyfunction]
#[pyo3(signature = (model, data, link, frame="local_world_aligned"))]
pub fn jacobian<'py>(
    py: Python<'py>,
    model: &PyModel,
    data: &mut PyData,
    link: &str,
    frame: &str,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    data.check(model)?;
    data.check_kinematics()?;
    let f = match frame {
        "world" => ReferenceFrame::World,
        "local" => ReferenceFrame::Local,
        "local_world_aligned" => ReferenceFrame::LocalWorldAligned,
        other => {
            return Err(dynamics_error(format!(
                "frame must be 'world', 'local' or 'local_world_aligned', not '{other}'"
            )))
        }
    };
    let lf = find_link(&model.model, link)?;
    let nv = model.model.nv;
    let j = data
        .data
        .link_jacobian(&model.model, &lf, f)
        .map_err(from_dynamics)?;
    matrix(py, j, 6, nv)
}

/// The centre of mass of the moving bodies in world coordinates (3), from data's kinematics.
/// Pinocchio: pin.centerOfMass.
#[pyfunction]
pub fn com<'py>(
    py: Python<'py>,
    model: &PyModel,
    data: &PyData,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    data.check(model)?;
    data.check_kinematics()?;
    let c: DVec3 = data.data.center_of_mass();
    Ok(PyArray1::from_slice(py, &c.to_array()))
}

/// The centre-of-mass Jacobian (3 × nv, world coordinates): ċ = J_c v. Pinocchio:
/// pin.jacobianCenterOfMass.
#[pyfunction]
pub fn com_jacobian<'py>(
    py: Python<'py>,
    model: &PyModel,
    data: &mut PyData,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    data.check(model)?;
    data.check_kinematics()?;
    let nv = model.model.nv;
    let j = data
        .data
        .com_jacobian(&model.model)
        .map_err(from_dynamics)?;
    matrix(py, j, 3, nv)
}

/// Kinetic energy (J) of data's kinematics. Pinocchio: pin.computeKineticEnergy.
#[pyfunction]
pub fn kinetic_energy(model: &PyModel, data: &PyData) -> PyResult<f64> {
    data.check(model)?;
    data.check_kinematics()?;
    Ok(data.data.kinetic_energy())
}

/// Gravitational potential energy (J, zero at the world origin) of data's kinematics.
/// Pinocchio: pin.computePotentialEnergy.
#[pyfunction]
pub fn potential_energy(model: &PyModel, data: &PyData) -> PyResult<f64> {
    data.check(model)?;
    data.check_kinematics()?;
    Ok(data.data.potential_energy())
}

/// The total spatial momentum [angular; linear] (6) about the world origin, world axes.
#[pyfunction]
pub fn momentum<'py>(
    py: Python<'py>,
    model: &PyModel,
    data: &PyData,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    data.check(model)?;
    data.check_kinematics()?;
    Ok(force(py, data.data.momentum()))
}

/// The centroidal momentum [angular; linear] (6) about the centre of mass, world axes.
/// Pinocchio: pin.computeCentroidalMomentum (which puts linear first).
#[pyfunction]
pub fn centroidal_momentum<'py>(
    py: Python<'py>,
    model: &PyModel,
    data: &PyData,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    data.check(model)?;
    data.check_kinematics()?;
    Ok(force(py, data.data.centroidal_momentum()))
}

/// The per-call time (s) of `calls` forward-dynamics calls inside Rust, on inputs read once:
/// what `peers/python_speed.py` subtracts from a call from Python to find the bindings' cost.
/// Not part of the public API.
#[pyfunction]
#[pyo3(signature = (model, data, q, v, tau, calls, method="dca"))]
#[allow(clippy::too_many_arguments)]
pub fn _time_forward_dynamics(
    model: &PyModel,
    data: &mut PyData,
    q: &Bound<'_, PyAny>,
    v: &Bound<'_, PyAny>,
    tau: &Bound<'_, PyAny>,
    calls: usize,
    method: &str,
) -> PyResult<f64> {
    data.check(model)?;
    let m = self::method(method)?;
    let x = triple(&model.model, q, v, ("tau", tau))?;
    let (q, v, tau) = (x.q.slice(), x.v.slice(), x.third.slice());
    let t0 = std::time::Instant::now();
    for _ in 0..calls {
        articula::dca::forward_dynamics_slices(&model.model, &mut data.data, q, v, tau, &[], m)
            .map_err(from_dynamics)?;
    }
    data.kinematics = true;
    Ok(t0.elapsed().as_secs_f64() / calls.max(1) as f64)
}
