//! The glTF file of a [`Simulation`] run: a [`Recorder`] the run calls at its start, after
//! every step and at its end.

use crate::{GltfSummary, MeshOptions, TrajectoryRecorder};
use articula_adaptive::simulation::{Recorder, Simulation, Stop, StopReason};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Records a [`Simulation`] run into a `.glb` file: the state at the start, every `every`
/// steps, and the last state (of a run that did every step or was interrupted at a step
/// boundary; a run stopped by a failed step keeps the samples before it). The file is written
/// at the end, through a temporary name.
#[derive(Clone, Debug)]
pub struct GltfFile {
    recorder: TrajectoryRecorder,
    path: PathBuf,
    every: u64,
    last: Option<u64>,
    /// Time spent reading meshes, recording and writing.
    pub spent: Duration,
    /// What the file holds, once written.
    pub written: Option<GltfSummary>,
}

impl GltfFile {
    /// A recorder of `sim`'s model (its visuals read from `urdf`), writing `path` and
    /// sampling every `every` steps (at least 1), with a floor at `floor` if given.
    pub fn new(
        sim: &Simulation,
        urdf: Option<&Path>,
        options: &MeshOptions,
        path: &Path,
        every: u64,
        floor: Option<f64>,
    ) -> GltfFile {
        let t0 = Instant::now();
        let mut recorder = TrajectoryRecorder::new(sim.model(), urdf, options);
        recorder.set_floor(floor);
        GltfFile {
            recorder,
            path: path.to_path_buf(),
            every: every.max(1),
            last: None,
            spent: t0.elapsed(),
            written: None,
        }
    }

    /// Warnings from reading the geometry (missing mesh files).
    pub fn warnings(&self) -> &[String] {
        &self.recorder.warnings
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn sample(&mut self, sim: &Simulation) -> std::io::Result<()> {
        let t0 = Instant::now();
        let k = sim.steps_done();
        let result = self
            .recorder
            .record(sim.model(), sim.time(), &sim.state().q);
        self.last = Some(k);
        self.spent += t0.elapsed();
        result.map_err(std::io::Error::other)
    }
}

impl Recorder for GltfFile {
    fn begin(&mut self, sim: &Simulation) -> std::io::Result<()> {
        self.sample(sim)
    }

    fn record(&mut self, sim: &Simulation) -> std::io::Result<()> {
        if sim.steps_done().is_multiple_of(self.every) {
            self.sample(sim)?;
        }
        Ok(())
    }

    fn finish(&mut self, sim: &Simulation, stop: &Stop) -> std::io::Result<()> {
        let whole = matches!(stop.reason, StopReason::StepsDone | StopReason::Interrupted);
        if whole && self.last != Some(sim.steps_done()) {
            self.sample(sim)?;
        }
        let t0 = Instant::now();
        let written = self.recorder.write(&self.path);
        self.spent += t0.elapsed();
        self.written = Some(written.map_err(std::io::Error::other)?);
        Ok(())
    }
}
