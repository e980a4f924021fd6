//! # articula-py
//!
//! The Python package `articula` (native module `articula._articula`): pyo3 bindings of the
//! articula facade crate with numpy arrays in and out. The Python side
//! (`python/articula/__init__.py`) re-exports these names, adds the exception classes,
//! `State` and `SceneBuilder`, and documents the package (`docs/python.md`).
//!
//! Conventions are the Rust library's (`docs/conventions.md`): a floating joint's `q` is
//! `[x, y, z, qw, qx, qy, qz]`, its velocity `[ω; v]` and force `[n; f]` in its body's frame;
//! spatial vectors and Jacobian rows are angular first.

mod adaptive;
mod dynamics;
mod errors;
mod input;
mod model;
mod scene;
mod shard;
mod stepping;

use pyo3::prelude::*;

/// The native module: every class and function the package re-exports.
#[pymodule]
fn _articula(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<model::PyModel>()?;
    m.add_class::<model::PyData>()?;
    m.add_class::<adaptive::PyAdaptive>()?;
    m.add_class::<scene::PyScene>()?;
    m.add_class::<shard::PyShard>()?;
    m.add_function(wrap_pyfunction!(shard::shard_merge_depths, m)?)?;
    m.add_function(wrap_pyfunction!(shard::shard_merge_candidates, m)?)?;
    m.add_function(wrap_pyfunction!(shard::shard_combine_steps, m)?)?;
    m.add_function(wrap_pyfunction!(shard::shard_combine_hashes, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::forward_dynamics, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::inverse_dynamics, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::mass_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::bias_forces, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::passive_forces, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::forward_kinematics, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::link_pose, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::jacobian, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::com, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::com_jacobian, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::kinetic_energy, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::potential_energy, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::momentum, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::centroidal_momentum, m)?)?;
    m.add_function(wrap_pyfunction!(dynamics::_time_forward_dynamics, m)?)?;
    m.add_function(wrap_pyfunction!(stepping::step_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(stepping::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(stepping::forward_dynamics_batch, m)?)?;
    m.add_function(wrap_pyfunction!(stepping::rollout, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
