//! `articula.Scene`: a view-dependent crowd scene from a file or a spec (the builder of the
//! Python side writes the same JSON), stepped under one joint budget, with frames as the CLI
//! writes them.

use crate::errors::{error, scene_error, Kind};
use crate::model::load_options;
use articula::view::render::{render_map, render_view, save_png};
use articula::view::{LoadedScene, SceneOptions, SceneSim, SceneStep};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};

/// A running scene. The simulation borrows the loaded scene, which this struct owns on the heap.
#[pyclass(name = "Scene", module = "articula", unsendable)]
pub struct PyScene {
    // Field order matters: `sim` borrows `*scene` and is dropped first.
    sim: SceneSim<'static>,
    scene: Box<LoadedScene>,
    last: SceneStep,
    active_sum: u64,
}

impl PyScene {
    fn start(scene: LoadedScene) -> PyResult<PyScene> {
        let scene = Box::new(scene);
        // SAFETY: `scene` is boxed (its address does not move when `PyScene` moves) and never
        // mutated or dropped while `sim` lives: `sim` is declared first, so it is dropped
        // before `scene`, and no method hands out `&mut LoadedScene`.
        let borrowed: &'static LoadedScene = unsafe { &*(scene.as_ref() as *const LoadedScene) };
        let sim = SceneSim::new(borrowed).map_err(scene_error)?;
        Ok(PyScene {
            sim,
            scene,
            last: SceneStep::default(),
            active_sum: 0,
        })
    }
}

#[pymethods]
impl PyScene {
    /// Loads a scene file (JSON, docs/view.md); its models are found relative to the file.
    /// inertia: the models' inertia policy ("accept", "strict", "repair"). Raises
    /// articula.SceneError naming the file and field.
    #[staticmethod]
    #[pyo3(signature = (path, inertia="accept", threads=None))]
    fn from_file(
        py: Python<'_>,
        path: PathBuf,
        inertia: &str,
        threads: Option<usize>,
    ) -> PyResult<PyScene> {
        let options = SceneOptions::default()
            .with_model_options(load_options(false, inertia, "lock", None, None)?);
        let scene = py.detach(|| options.load(&path)).map_err(scene_error)?;
        let mut s = PyScene::start(scene)?;
        s.set_threads(threads)?;
        Ok(s)
    }

    /// A scene from its JSON text (what articula.SceneBuilder writes); model paths are relative
    /// to base (default: the current directory).
    #[staticmethod]
    #[pyo3(signature = (text, base=None, inertia="accept", threads=None))]
    fn from_json(
        text: &str,
        base: Option<PathBuf>,
        inertia: &str,
        threads: Option<usize>,
    ) -> PyResult<PyScene> {
        let policy = load_options(false, inertia, "lock", None, None)?.inertia;
        let base = base.unwrap_or_else(|| PathBuf::from("."));
        let scene = SceneOptions::default()
            .with_inertia(policy)
            .parse(text, Path::new("<scene spec>"), &base)
            .map_err(scene_error)?;
        let mut s = PyScene::start(scene)?;
        s.set_threads(threads)?;
        Ok(s)
    }

    /// Advances every body by the scene's dt and returns what the step did: {"reselected",
    /// "active_total", "visible", "occluded", "invisible", "weighted_error", "contacts",
    /// "max_penetration"}. Releases the GIL.
    fn step<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let sim = &mut self.sim;
        let s = py.detach(move || sim.step()).map_err(scene_error)?;
        self.active_sum += s.active_total as u64;
        self.last = s;
        step_dict(py, &self.last)
    }

    /// Steps done.
    #[getter]
    fn steps(&self) -> u64 {
        self.sim.steps
    }

    /// Simulated time (s).
    #[getter]
    fn time(&self) -> f64 {
        self.sim.time()
    }

    /// The scene's step (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.scene.dt
    }

    /// Number of bodies (characters).
    #[getter]
    fn nbodies(&self) -> usize {
        self.sim.bodies.len()
    }

    /// Body b's placement name.
    fn body_name(&self, b: usize) -> PyResult<String> {
        self.check(b)?;
        Ok(self.scene.placements[b].name.clone())
    }

    /// Body b's positions (a copy; its model's coordinates, floating base first).
    fn q<'py>(&self, py: Python<'py>, b: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.check(b)?;
        Ok(PyArray1::from_slice(py, &self.sim.bodies[b].state.q))
    }

    /// Body b's velocities (a copy).
    fn v<'py>(&self, py: Python<'py>, b: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.check(b)?;
        Ok(PyArray1::from_slice(py, &self.sim.bodies[b].state.qd))
    }

    /// The state hash `cargo xtask hash` prints: a rotate-xor of the bits of every body's q
    /// then v, in body order.
    fn state_hash(&self) -> u64 {
        self.sim.state_hash()
    }

    /// Per body: (its share of the budget, its weighted error) at the last re-selection.
    fn selection(&self) -> Vec<(usize, f64)> {
        let bodies = &self.sim.bodies;
        bodies.iter().map(|b| (b.allocation, b.error)).collect()
    }

    /// The summary so far, as `articula scene` prints it (the fields that do not depend on a
    /// run's wall-clock): steps, dt, bodies, dof_total, budget, active joints (mean, last),
    /// visibility classes, weighted error and energies.
    fn summary<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let last = &self.last;
        let steps = self.sim.steps;
        d.set_item("steps", steps)?;
        d.set_item("dt", self.scene.dt)?;
        d.set_item("bodies", self.sim.bodies.len())?;
        d.set_item("threads", self.sim.threads().count())?;
        d.set_item("dof_total", self.sim.dof_total())?;
        d.set_item("budget", self.scene.budget)?;
        d.set_item("tolerance", self.scene.tolerance)?;
        d.set_item("reselect_every", self.scene.reselect_every)?;
        d.set_item(
            "active_joints_mean",
            self.active_sum as f64 / steps.max(1) as f64,
        )?;
        d.set_item("active_joints_last", last.active_total)?;
        d.set_item("visible", last.classes[0])?;
        d.set_item("occluded", last.classes[1])?;
        d.set_item("invisible", last.classes[2])?;
        d.set_item("weighted_error", last.total_error)?;
        let e = self.sim.energy();
        d.set_item("energy_kinetic", e.kinetic)?;
        d.set_item("energy_gravity", e.gravity)?;
        d.set_item("energy_springs", e.springs)?;
        d.set_item("push_work", e.push_work)?;
        Ok(d)
    }

    /// Writes frame_NNNNN.png (the camera's view) and map_NNNNN.png (top-down map) into dir,
    /// as `articula scene --out` does; returns the two paths.
    fn save_frame(
        &mut self,
        py: Python<'_>,
        dir: PathBuf,
        index: u64,
    ) -> PyResult<(PathBuf, PathBuf)> {
        std::fs::create_dir_all(&dir)
            .map_err(|e| error(Kind::Scene, format!("cannot create {}: {e}", dir.display())))?;
        let active = self.last.active_total;
        let sim = &mut self.sim;
        let frame = dir.join(format!("frame_{index:05}.png"));
        let map = dir.join(format!("map_{index:05}.png"));
        let (f, m) = (frame.clone(), map.clone());
        py.detach(move || -> Result<(), String> {
            let cam = sim.scene.camera.at(sim.time());
            let (w, h) = (sim.scene.image.width, sim.scene.image.height);
            let mut groups = Vec::new();
            let bodies = sim.frame(&mut groups);
            save_png(&render_view(&cam, w, h, &bodies, active)?, &f)?;
            save_png(&render_map(&cam, h.max(400), &bodies)?, &m)
        })
        .map_err(|e| error(Kind::Scene, e))?;
        Ok((frame, map))
    }

    fn __repr__(&self) -> String {
        format!(
            "articula.Scene(bodies={}, dt={}, steps={})",
            self.sim.bodies.len(),
            self.scene.dt,
            self.sim.steps
        )
    }
}

impl PyScene {
    fn check(&self, b: usize) -> PyResult<()> {
        if b >= self.sim.bodies.len() {
            return Err(error(
                Kind::Scene,
                format!(
                    "body {b} out of range: the scene has {}",
                    self.sim.bodies.len()
                ),
            ));
        }
        Ok(())
    }

    fn set_threads(&mut self, threads: Option<usize>) -> PyResult<()> {
        let t = match threads {
            None => articula::dca::Threads::all(),
            Some(n) => articula::dca::Threads::new(n),
        }
        .map_err(|e| error(Kind::Scene, e.to_string()))?;
        self.sim.set_threads(t);
        Ok(())
    }
}

/// A scene step as a dict.
pub(crate) fn step_dict<'py>(py: Python<'py>, s: &SceneStep) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("reselected", s.reselected)?;
    d.set_item("active_total", s.active_total)?;
    d.set_item("visible", s.classes[0])?;
    d.set_item("occluded", s.classes[1])?;
    d.set_item("invisible", s.classes[2])?;
    d.set_item("weighted_error", s.total_error)?;
    d.set_item("contacts", s.contacts)?;
    d.set_item("max_penetration", s.max_penetration)?;
    Ok(d)
}
