//! Time stepping: one step of a state, a whole trajectory (`simulate`, with the energy guard),
//! and the batch calls `forward_dynamics_batch` and `rollout` across cores. Long calls release
//! the GIL.

use crate::dynamics::method;
use crate::errors::{dynamics_error, error, Kind};
use crate::input::{check_quaternions, expect_shape, read, vector, wrenches, Input};
use crate::model::{PyData, PyModel};
use articula::adaptive::simulation::{
    message_time, Dynamics, GroundOptions, Simulation, SimulationOptions, StopReason,
};
use articula::dca::Threads;
use articula::dca::{step_with_contact, ContactData, ContactSettings, Ground};
use articula::prelude::{Data, Integrator, Method, Model, State};
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Mutex;

/// How each step is taken.
#[derive(Clone, Copy)]
pub(crate) struct StepOptions {
    /// The forward-dynamics method.
    pub method: Method,
    /// The integrator (semi-implicit Euler with contact).
    pub integrator: Integrator,
    /// Contact and limits, when there is a ground or joint limits are enforced.
    pub contact: Option<ContactSettings>,
    /// The step (s).
    pub dt: f64,
}

/// Reads `ground`: None, a height (the horizontal floor z = height, μ = 1), or an object with
/// `point`, `normal`, `friction`, `restitution` (`articula.Ground`).
fn ground(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Ground>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    if let Ok(h) = obj.extract::<f64>() {
        return Ok(Some(Ground::horizontal(h)));
    }
    let bad = |e: PyErr| {
        dynamics_error(format!(
            "ground must be None, a height or an articula.Ground: {e}"
        ))
    };
    let point: [f64; 3] = obj
        .getattr("point")
        .and_then(|x| x.extract())
        .map_err(bad)?;
    let normal: [f64; 3] = obj
        .getattr("normal")
        .and_then(|x| x.extract())
        .map_err(bad)?;
    let friction: f64 = obj
        .getattr("friction")
        .and_then(|x| x.extract())
        .map_err(bad)?;
    let restitution: f64 = obj
        .getattr("restitution")
        .and_then(|x| x.extract())
        .map_err(bad)?;
    Ok(Some(Ground {
        point: point.into(),
        normal: normal.into(),
        friction,
        restitution,
    }))
}

/// The step options from the keyword arguments shared by `step`, `simulate` and `rollout`.
pub(crate) fn options(
    dt: f64,
    integrator: Option<&str>,
    method_name: &str,
    ground_obj: Option<&Bound<'_, PyAny>>,
    joint_limits: bool,
) -> PyResult<StepOptions> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(dynamics_error(format!(
            "dt must be a finite number > 0, got {dt}"
        )));
    }
    let g = ground(ground_obj)?;
    let contact = (g.is_some() || joint_limits).then(|| ContactSettings {
        ground: g,
        joint_limits,
        ..ContactSettings::default()
    });
    let integrator = match (integrator, contact.is_some()) {
        (None, false) | (Some("rk4"), false) => Integrator::Rk4,
        (None, true) | (Some("euler"), _) => Integrator::SemiImplicitEuler,
        (Some("rk4"), true) => {
            return Err(dynamics_error(
                "steps with a ground or joint limits are semi-implicit Euler: pass \
                 integrator='euler' (or leave it out)",
            ))
        }
        (Some(other), _) => {
            return Err(dynamics_error(format!(
                "integrator must be 'rk4' or 'euler', not '{other}'"
            )))
        }
    };
    Ok(StepOptions {
        method: method(method_name)?,
        integrator,
        contact,
        dt,
    })
}

/// One step of `state` (contact workspace made on first use).
pub(crate) fn step_once(
    model: &Model,
    data: &mut Data,
    contact: &mut Option<ContactData>,
    state: &mut State,
    o: &StepOptions,
) -> Result<(), String> {
    match &o.contact {
        None => articula::dca::step(model, data, state, o.method, o.integrator, o.dt)
            .map_err(|e| e.to_string()),
        Some(settings) => {
            let cd = contact.get_or_insert_with(|| ContactData::new(model));
            step_with_contact(model, data, cd, state, o.method, o.dt, settings)
                .map_err(|e| e.to_string())
        }
    }
}

/// One step of (q, v) under constant tau and f_ext; returns the new (q, v). The Python
/// `articula.step` calls this and writes the result into its `State`.
#[pyfunction]
#[pyo3(signature = (model, data, q, v, tau, f_ext, dt, integrator=None, method="dca",
                    ground=None, joint_limits=false))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn step_arrays<'py>(
    py: Python<'py>,
    model: &PyModel,
    data: &mut PyData,
    q: &Bound<'py, PyAny>,
    v: &Bound<'py, PyAny>,
    tau: &Bound<'py, PyAny>,
    f_ext: Option<&Bound<'py, PyAny>>,
    dt: f64,
    integrator: Option<&str>,
    method: &str,
    ground: Option<&Bound<'py, PyAny>>,
    joint_limits: bool,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>)> {
    data.check(model)?;
    let m = &model.model;
    let o = options(dt, integrator, method, ground, joint_limits)?;
    let q = vector(q, "q", m.nq)?;
    check_quaternions(m, q.slice(), "q")?;
    let mut state = State {
        q: q.slice().to_vec(),
        qd: vector(v, "v", m.nv)?.slice().to_vec(),
        tau: vector(tau, "tau", m.nv)?.slice().to_vec(),
        f_ext: wrenches(m, f_ext)?,
    };
    if state.f_ext.is_empty() {
        state.f_ext = State::neutral(m).f_ext;
    }
    let PyData {
        data: d,
        contact,
        kinematics,
        ..
    } = data;
    *kinematics = true;
    step_once(m, d, contact, &mut state, &o).map_err(dynamics_error)?;
    Ok((
        PyArray1::from_vec(py, state.q),
        PyArray1::from_vec(py, state.qd),
    ))
}

/// Joint forces over a run: one vector for every step, or one per step.
#[derive(Clone, Copy)]
enum Torques<'a> {
    Constant(&'a [f64]),
    PerStep(&'a [f64]),
}

impl Torques<'_> {
    fn at(&self, k: usize, nv: usize) -> &[f64] {
        match self {
            Torques::Constant(t) => t,
            Torques::PerStep(t) => &t[k * nv..(k + 1) * nv],
        }
    }
}

/// What stopped a rollout: a step's error.
struct Stop {
    step: usize,
    message: String,
}

/// One trajectory from (q0, v0) with a fresh workspace, each step's (q, v) into `out_q`,
/// `out_v` (`steps` rows): the steps `simulate`'s driver takes (the same library calls), without
/// its energy bookkeeping.
fn run(
    model: &Model,
    (q0, v0): (&[f64], &[f64]),
    tau: Torques,
    o: &StepOptions,
    out_q: &mut [f64],
    out_v: &mut [f64],
) -> Result<(), Stop> {
    let (nq, nv) = (model.nq, model.nv);
    let mut data = Data::new(model);
    let mut contact = None;
    let mut state = State::neutral(model);
    state.q.copy_from_slice(q0);
    state.qd.copy_from_slice(v0);
    for k in 0..out_q.len() / nq.max(1) {
        state.tau.copy_from_slice(tau.at(k, nv));
        step_once(model, &mut data, &mut contact, &mut state, o).map_err(|message| Stop {
            step: k + 1,
            message,
        })?;
        let finite = state.q.iter().chain(&state.qd).all(|x| x.is_finite());
        if !finite {
            let message = "the state after the step is not finite".to_string();
            return Err(Stop {
                step: k + 1,
                message,
            });
        }
        out_q[k * nq..(k + 1) * nq].copy_from_slice(&state.q);
        out_v[k * nv..(k + 1) * nv].copy_from_slice(&state.qd);
    }
    Ok(())
}

/// Reads tau for `steps` steps: None (zero), a vector (nv) or one per step (steps, nv); with a
/// leading batch dimension `batch` when given.
fn torques<'py>(
    obj: Option<&Bound<'py, PyAny>>,
    name: &str,
    batch: Option<usize>,
    steps: usize,
    nv: usize,
) -> PyResult<(Option<Input<'py>>, bool)> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok((None, false));
    };
    let input = read(obj, name)?;
    let lead: Vec<usize> = batch.into_iter().collect();
    let constant: Vec<usize> = lead.iter().copied().chain([nv]).collect();
    let per_step: Vec<usize> = lead.iter().copied().chain([steps, nv]).collect();
    let shape = input.shape();
    if shape == constant {
        Ok((Some(input), false))
    } else if shape == per_step {
        Ok((Some(input), true))
    } else {
        expect_shape(&input, name, &constant).map(|_| (None, false))
    }
}

/// A numpy array of `shape` from a flat vector.
fn array<'py>(
    py: Python<'py>,
    flat: Vec<f64>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    PyArray1::from_vec(py, flat).reshape(shape.to_vec())
}

/// Simulates one model from (q0, v0) for `steps` steps of `dt` under joint forces tau (None,
/// a vector of nv, or one per step: (steps, nv)), on the library's simulation driver
/// (`articula::adaptive::simulation`, what `articula simulate` runs). Returns a dict of arrays:
/// "t" (steps + 1), "q" (steps + 1, nq), "v" (steps + 1, nv), "energy" (steps + 1; kinetic +
/// potential), the first row the initial state. integrator "rk4" (default without contact) or
/// "euler" (semi-implicit; the only one with a ground or joint limits); ground None, a height
/// or an articula.Ground; joint_limits enforces the URDF limits. The energy guard raises
/// articula.DivergenceError when E − E0 − W (W the work of the joint forces, counted when the
/// first step's are not all zero) grows beyond max_energy_growth times the largest energy in
/// play (None: no guard); a failed step or a non-finite state raises DynamicsError. Releases
/// the GIL.
#[pyfunction]
#[pyo3(signature = (model, q0, v0, tau=None, steps=1000, dt=1e-3, integrator=None,
                    method="dca", ground=None, joint_limits=false, max_energy_growth=Some(0.5)))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    model: &PyModel,
    q0: &Bound<'py, PyAny>,
    v0: &Bound<'py, PyAny>,
    tau: Option<&Bound<'py, PyAny>>,
    steps: usize,
    dt: f64,
    integrator: Option<&str>,
    method: &str,
    ground: Option<&Bound<'py, PyAny>>,
    joint_limits: bool,
    max_energy_growth: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let m = &*model.model;
    let (nq, nv) = (m.nq, m.nv);
    let o = options(dt, integrator, method, ground, joint_limits)?;
    let q0 = vector(q0, "q0", nq)?;
    let v0 = vector(v0, "v0", nv)?;
    check_quaternions(m, q0.slice(), "q0")?;
    let (tau_in, per_step) = torques(tau, "tau", None, steps, nv)?;
    let tau_vec = tau_in.as_ref().map_or_else(|| vec![0.0; nv], Input::to_vec);
    let torques = if per_step {
        Torques::PerStep(&tau_vec)
    } else {
        Torques::Constant(&tau_vec)
    };
    let mut state = State::neutral(m);
    state.q.copy_from_slice(q0.slice());
    state.qd.copy_from_slice(v0.slice());
    state.tau.copy_from_slice(torques.at(0, nv));
    let sim_options = SimulationOptions {
        dynamics: Dynamics::Exact(o.method),
        integrator: o.integrator,
        dt,
        ground: o.contact.map(|contact| GroundOptions {
            contact,
            ..GroundOptions::floor(0.0)
        }),
        max_energy_growth: max_energy_growth.unwrap_or(f64::INFINITY),
        ..SimulationOptions::default()
    };
    let mut q = Vec::with_capacity((steps + 1) * nq);
    let mut v = Vec::with_capacity((steps + 1) * nv);
    let mut energy = Vec::with_capacity(steps + 1);
    // The driver's refusal to start (its message), or where and why the run stopped.
    let result = py.detach(|| -> Result<(), (u64, Option<StopReason>, String)> {
        let mut sim =
            Simulation::new(m.clone(), state, sim_options).map_err(|e| (0, None, e.to_string()))?;
        let mut record = |sim: &mut Simulation| {
            q.extend_from_slice(&sim.state().q);
            v.extend_from_slice(&sim.state().qd);
            let e = sim.energy();
            energy.push(e.kinetic + e.potential);
        };
        record(&mut sim);
        for k in 0..steps {
            sim.state_mut().tau.copy_from_slice(torques.at(k, nv));
            sim.step()
                .map_err(|s| (s.step, Some(s.reason.clone()), s.reason.to_string()))?;
            record(&mut sim);
        }
        Ok(())
    });
    if let Err((step, reason, message)) = result {
        let kind = match reason {
            Some(StopReason::Energy(_)) => Kind::Divergence,
            _ => Kind::Dynamics,
        };
        if reason.is_none() {
            return Err(error(kind, message));
        }
        return Err(error(
            kind,
            format!(
                "step {step} of {steps} (t = {} s): {message}",
                message_time(step as f64 * dt)
            ),
        ));
    }
    let out = PyDict::new(py);
    let t: Vec<f64> = (0..=steps).map(|k| k as f64 * dt).collect();
    out.set_item("t", PyArray1::from_vec(py, t))?;
    out.set_item("q", array(py, q, &[steps + 1, nq])?)?;
    out.set_item("v", array(py, v, &[steps + 1, nv])?)?;
    out.set_item("energy", PyArray1::from_vec(py, energy))?;
    Ok(out)
}

/// The worker threads: `None` for every core, else that many (pools are kept for reuse).
fn threads(count: Option<usize>) -> PyResult<Threads> {
    static POOLS: Mutex<Vec<Threads>> = Mutex::new(Vec::new());
    let Some(n) = count else {
        return Threads::all().map_err(dynamics_error);
    };
    let mut pools = POOLS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(t) = pools.iter().find(|t| t.count() == n) {
        return Ok(t.clone());
    }
    let t = Threads::new(n).map_err(dynamics_error)?;
    pools.push(t.clone());
    Ok(t)
}

/// Reads a batch (n, width) named `name`; `n` is taken from the first batch read.
fn batch<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    n: Option<usize>,
    width: usize,
) -> PyResult<Input<'py>> {
    let input = read(obj, name)?;
    let shape = input.shape();
    let rows = n.unwrap_or(if shape.len() == 2 { shape[0] } else { 0 });
    expect_shape(&input, name, &[rows, width])?;
    Ok(input)
}

/// Checks every row's quaternions.
fn check_rows(model: &Model, q: &[f64], name: &str) -> PyResult<()> {
    for (i, row) in q.chunks_exact(model.nq.max(1)).enumerate() {
        check_quaternions(model, row, &format!("{name}[{i}]"))?;
    }
    Ok(())
}

/// Forward dynamics of many states across cores: Q (n, nq), V (n, nv), TAU (n, nv) →
/// q̈ (n, nv), each row equal bit for bit to forward_dynamics of that row. threads: None for
/// every core. Raises DynamicsError naming the lowest failing row. Releases the GIL.
/// Pinocchio: pin.abaInParallel.
#[pyfunction]
#[pyo3(signature = (model, Q, V, TAU, method="dca", threads=None))]
#[allow(non_snake_case)]
pub fn forward_dynamics_batch<'py>(
    py: Python<'py>,
    model: &PyModel,
    Q: &Bound<'py, PyAny>,
    V: &Bound<'py, PyAny>,
    TAU: &Bound<'py, PyAny>,
    method: &str,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let m = &*model.model;
    let method = self::method(method)?;
    let q = batch(Q, "Q", None, m.nq)?;
    let n = q.shape()[0];
    let v = batch(V, "V", Some(n), m.nv)?;
    let tau = batch(TAU, "TAU", Some(n), m.nv)?;
    check_rows(m, q.slice(), "Q")?;
    let pool = self::threads(threads)?;
    let (qs, vs, ts) = (&q.to_vec()[..], &v.to_vec()[..], &tau.to_vec()[..]);
    let mut qdd = vec![0.0; n * m.nv];
    let result = py.detach(|| {
        let f_ext = State::neutral(m).f_ext;
        let states: Vec<State> = (0..n)
            .map(|i| State {
                q: qs[i * m.nq..(i + 1) * m.nq].to_vec(),
                qd: vs[i * m.nv..(i + 1) * m.nv].to_vec(),
                tau: ts[i * m.nv..(i + 1) * m.nv].to_vec(),
                f_ext: f_ext.clone(),
            })
            .collect();
        let mut b = articula::dca::Batch::new(m, pool);
        b.forward_dynamics(m, &states, method, &mut qdd)
    });
    result.map_err(|e| dynamics_error(format!("row {e}")))?;
    array(py, qdd, &[n, m.nv])
}

/// One trajectory's outputs and error.
struct Slot<'a> {
    q: &'a mut [f64],
    v: &'a mut [f64],
    stop: Option<Stop>,
}

/// Rolls out many trajectories across cores: Q0 (n, nq), V0 (n, nv), TAU (n, nv) constant or
/// (n, steps, nv) per step → (Q, V) of shapes (n, steps, nq) and (n, steps, nv), the state
/// after each step (as mujoco.rollout). Trajectory i equals simulate(model, Q0[i], V0[i],
/// TAU[i], ...)["q"][1:] bit for bit, whatever the thread count. Same step options as
/// simulate, without the energy guard. Raises DynamicsError naming the lowest failing
/// trajectory. Releases the GIL.
#[pyfunction]
#[pyo3(signature = (model, Q0, V0, TAU=None, steps=100, dt=1e-3, integrator=None, method="dca",
                    ground=None, joint_limits=false, threads=None))]
#[allow(non_snake_case, clippy::too_many_arguments, clippy::type_complexity)]
pub fn rollout<'py>(
    py: Python<'py>,
    model: &PyModel,
    Q0: &Bound<'py, PyAny>,
    V0: &Bound<'py, PyAny>,
    TAU: Option<&Bound<'py, PyAny>>,
    steps: usize,
    dt: f64,
    integrator: Option<&str>,
    method: &str,
    ground: Option<&Bound<'py, PyAny>>,
    joint_limits: bool,
    threads: Option<usize>,
) -> PyResult<(Bound<'py, PyArrayDyn<f64>>, Bound<'py, PyArrayDyn<f64>>)> {
    let m = &*model.model;
    let (nq, nv) = (m.nq, m.nv);
    let o = options(dt, integrator, method, ground, joint_limits)?;
    let q0 = batch(Q0, "Q0", None, nq)?;
    let n = q0.shape()[0];
    let v0 = batch(V0, "V0", Some(n), nv)?;
    check_rows(m, q0.slice(), "Q0")?;
    let (tau_in, per_step) = torques(TAU, "TAU", Some(n), steps, nv)?;
    let zero = vec![0.0; nv];
    let pool = self::threads(threads)?;
    let mut q = vec![0.0; n * steps * nq];
    let mut v = vec![0.0; n * steps * nv];
    let (q0s, v0s) = (&q0.to_vec()[..], &v0.to_vec()[..]);
    let tau_vec = tau_in.as_ref().map(Input::to_vec);
    let tau_all = tau_vec.as_deref();
    let stop = py.detach(|| {
        let mut slots: Vec<Slot> = q
            .chunks_mut((steps * nq).max(1))
            .zip(v.chunks_mut((steps * nv).max(1)))
            .map(|(q, v)| Slot { q, v, stop: None })
            .collect();
        slots.truncate(n);
        pool.for_each_mut(&mut slots, |i, slot| {
            let tau = match tau_all {
                None => Torques::Constant(&zero),
                Some(t) if per_step => Torques::PerStep(&t[i * steps * nv..(i + 1) * steps * nv]),
                Some(t) => Torques::Constant(&t[i * nv..(i + 1) * nv]),
            };
            let (q0, v0) = (&q0s[i * nq..(i + 1) * nq], &v0s[i * nv..(i + 1) * nv]);
            slot.stop = run(m, (q0, v0), tau, &o, slot.q, slot.v).err();
        });
        slots
            .into_iter()
            .enumerate()
            .find_map(|(i, s)| s.stop.map(|s| (i, s)))
    });
    if let Some((i, s)) = stop {
        return Err(dynamics_error(format!(
            "trajectory {i}, step {} (t = {} s): {}",
            s.step,
            message_time(s.step as f64 * dt),
            s.message
        )));
    }
    Ok((
        array(py, q, &[n, steps, nq])?,
        array(py, v, &[n, steps, nv])?,
    ))
}
