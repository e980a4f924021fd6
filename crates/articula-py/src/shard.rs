//! `articula.SceneShard` and the driver's merges: one shard of a crowd scene split by body
//! over processes, stepped through a re-selection's three exchanges with bytes in and out
//! (`articula.ray.ShardedScene` drives them over Ray; docs/scaling.md).

use crate::errors::{error, scene_error, Kind};
use crate::model::load_options;
use articula::view::{
    body_memory_estimate, combine_state_hashes, combine_steps, merge_candidates, merge_depths,
    Candidates, DepthMessage, LoadedScene, SceneOptions, SceneShard, ShardStep,
    DEFAULT_SCENE_MEMORY_LIMIT,
};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::PathBuf;

/// One shard of a scene. The shard borrows its part of the scene, which this struct owns on
/// the heap.
#[pyclass(name = "SceneShard", module = "articula", unsendable)]
pub struct PyShard {
    // Field order matters: `shard` borrows `*part` and is dropped first.
    shard: SceneShard<'static>,
    part: Box<LoadedScene>,
}

/// The shard's part of `scene`, checked against the memory limit on its own.
fn part(scene: &LoadedScene, index: usize, count: usize) -> PyResult<PyShard> {
    let (part, range) = scene.shard(index, count).map_err(scene_error)?;
    let estimate: u64 = part
        .placements
        .iter()
        .map(|p| body_memory_estimate(&part.models[p.model].model))
        .sum();
    if estimate > DEFAULT_SCENE_MEMORY_LIMIT {
        return Err(error(
            Kind::Scene,
            format!(
                "{}: shard {index} of {count} ({} bodies) would take about {estimate} bytes, \
                 more than the limit of {DEFAULT_SCENE_MEMORY_LIMIT}: use more shards",
                part.path.display(),
                range.bodies
            ),
        ));
    }
    let part = Box::new(part);
    // SAFETY: `part` is boxed (its address does not move when `PyShard` moves) and never
    // mutated or dropped while `shard` lives: `shard` is declared first, so it is dropped
    // before `part`, and no method hands out `&mut LoadedScene`.
    let borrowed: &'static LoadedScene = unsafe { &*(part.as_ref() as *const LoadedScene) };
    let shard = SceneShard::new(borrowed, range).map_err(scene_error)?;
    Ok(PyShard { shard, part })
}

#[pymethods]
impl PyShard {
    /// Shard `index` of `count` of a scene file: bodies ⌊index·N/count⌋ up to the next
    /// shard's first. The whole file is read (every worker needs it at the same path), then
    /// only this shard's bodies are set up. threads: its bodies' threads (default all).
    #[staticmethod]
    #[pyo3(signature = (path, index, count, inertia="accept", threads=None))]
    fn from_file(
        py: Python<'_>,
        path: PathBuf,
        index: usize,
        count: usize,
        inertia: &str,
        threads: Option<usize>,
    ) -> PyResult<PyShard> {
        // The limit applies to each shard's part (below), not to the whole scene.
        let options = SceneOptions::default()
            .with_model_options(load_options(false, inertia, "lock", None, None)?)
            .with_memory_limit(u64::MAX);
        let scene = py.detach(|| options.load(&path)).map_err(scene_error)?;
        let mut s = part(&scene, index, count)?;
        let t = match threads {
            None => articula::dca::Threads::all(),
            Some(n) => articula::dca::Threads::new(n),
        }
        .map_err(|e| error(Kind::Scene, e.to_string()))?;
        s.shard.set_threads(t);
        Ok(s)
    }

    /// (index, count, first, bodies, total): its place in the scene.
    #[getter]
    fn range(&self) -> (usize, usize, usize, usize, usize) {
        let r = self.shard.range();
        (r.index, r.count, r.first, r.bodies, r.total)
    }

    /// The scene's re-selection period (steps).
    #[getter]
    fn reselect_every(&self) -> usize {
        self.part.reselect_every
    }

    /// Steps done.
    #[getter]
    fn steps(&self) -> u64 {
        self.shard.sim().steps
    }

    /// Whether the next step re-selects (begin() starts it).
    fn reselects_next(&self) -> bool {
        self.shard.reselects_next()
    }

    /// A re-selection's first exchange: exact solves, frustum classes, the depth buffer of
    /// this shard's occluders (bytes for merge_depths). Releases the GIL.
    fn begin<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let shard = &mut self.shard;
        let b = py.detach(move || shard.begin().map(|d| d.to_bytes()));
        Ok(PyBytes::new(py, &b.map_err(scene_error)?))
    }

    /// The second exchange, with the merged depth buffer (merge_depths' bytes): weights,
    /// metrics and this shard's candidates (bytes for merge_candidates).
    fn weigh<'py>(&mut self, py: Python<'py>, merged: &[u8]) -> PyResult<Bound<'py, PyBytes>> {
        let merged = DepthMessage::from_bytes(merged).map_err(scene_error)?;
        let shard = &mut self.shard;
        let b = py.detach(move || shard.weigh(&merged).map(|c| c.to_bytes()));
        Ok(PyBytes::new(py, &b.map_err(scene_error)?))
    }

    /// The last exchange: the global queue took this shard's first `taken` pops; its bodies
    /// get their shares and step, then up to `then` steps more before the next re-selection.
    /// Returns each step's bytes (for combine_steps).
    #[pyo3(signature = (taken, then=0))]
    fn apply<'py>(
        &mut self,
        py: Python<'py>,
        taken: usize,
        then: usize,
    ) -> PyResult<Vec<Bound<'py, PyBytes>>> {
        let shard = &mut self.shard;
        let steps = py.detach(move || {
            let mut out = vec![shard.apply(taken)?];
            out.extend(shard.advance(then)?);
            Ok(out)
        });
        Ok(bytes_list(py, steps.map_err(scene_error)?))
    }

    /// Up to `max` steps before the next re-selection; each step's bytes.
    fn advance<'py>(&mut self, py: Python<'py>, max: usize) -> PyResult<Vec<Bound<'py, PyBytes>>> {
        let shard = &mut self.shard;
        let steps = py.detach(move || shard.advance(max));
        Ok(bytes_list(py, steps.map_err(scene_error)?))
    }

    /// (hash, numbers): the state hash of this shard's bodies, for combine_state_hashes.
    fn state_hash(&self) -> (u64, u64) {
        self.shard.state_hash()
    }

    /// Its bodies' positions and velocities: two lists of arrays, in body order.
    #[allow(clippy::type_complexity)]
    fn states<'py>(
        &self,
        py: Python<'py>,
    ) -> (
        Vec<Bound<'py, PyArray1<f64>>>,
        Vec<Bound<'py, PyArray1<f64>>>,
    ) {
        let bodies = &self.shard.sim().bodies;
        (
            bodies
                .iter()
                .map(|b| PyArray1::from_slice(py, &b.state.q))
                .collect(),
            bodies
                .iter()
                .map(|b| PyArray1::from_slice(py, &b.state.qd))
                .collect(),
        )
    }

    /// Per body: (its share of the budget, its weighted error) at the last re-selection.
    fn selection(&self) -> Vec<(usize, f64)> {
        let bodies = &self.shard.sim().bodies;
        bodies.iter().map(|b| (b.allocation, b.error)).collect()
    }
}

fn bytes_list(py: Python<'_>, steps: Vec<ShardStep>) -> Vec<Bound<'_, PyBytes>> {
    steps
        .iter()
        .map(|s| PyBytes::new(py, &s.to_bytes()))
        .collect()
}

/// The scene's depth buffer from its shards' (SceneShard.begin bytes): the nearest depth per
/// cell.
#[pyfunction]
pub fn shard_merge_depths<'py>(
    py: Python<'py>,
    parts: Vec<Vec<u8>>,
) -> PyResult<Bound<'py, PyBytes>> {
    let parts = parts
        .iter()
        .map(|b| DepthMessage::from_bytes(b))
        .collect::<Result<Vec<_>, _>>()
        .map_err(scene_error)?;
    Ok(PyBytes::new(
        py,
        &merge_depths(&parts).map_err(scene_error)?.to_bytes(),
    ))
}

/// The global queue over the shards' candidates (SceneShard.weigh bytes, in shard order):
/// how many pops of each shard it takes.
#[pyfunction]
pub fn shard_merge_candidates(parts: Vec<Vec<u8>>) -> PyResult<Vec<usize>> {
    let parts = parts
        .iter()
        .map(|b| Candidates::from_bytes(b))
        .collect::<Result<Vec<_>, _>>()
        .map_err(scene_error)?;
    merge_candidates(&parts).map_err(scene_error)
}

/// The scene's step from its shards' (one step's bytes per shard, in shard order), as
/// Scene.step returns it; `last_error` is the error of the last re-selection.
#[pyfunction]
pub fn shard_combine_steps<'py>(
    py: Python<'py>,
    parts: Vec<Vec<u8>>,
    total: usize,
    last_error: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let parts = parts
        .iter()
        .map(|b| ShardStep::from_bytes(b))
        .collect::<Result<Vec<_>, _>>()
        .map_err(scene_error)?;
    crate::scene::step_dict(py, &combine_steps(&parts, total, last_error))
}

/// The whole scene's state hash from its shards' (hash, numbers), in shard order.
#[pyfunction]
pub fn shard_combine_hashes(parts: Vec<(u64, u64)>) -> u64 {
    combine_state_hashes(&parts)
}
