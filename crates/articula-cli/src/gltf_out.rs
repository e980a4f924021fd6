//! `--gltf out.glb` of `articula simulate` and `articula scene`: the run recorded as an
//! animated binary glTF (docs/gltf.md) by articula-gltf: `simulate` adds a recorder to its
//! run, `scene` calls three hooks (start, after each step, finish).

use crate::CliError;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The glTF options shared by `simulate` and `scene`.
#[derive(clap::Args, Debug, Clone)]
pub struct GltfArgs {
    /// Write the motion as an animated glTF 2.0 binary file (`.glb`: one node per body, the
    /// URDF's visual meshes, one animation; docs/gltf.md). Written through a temporary name.
    #[arg(long, value_name = "out.glb")]
    pub gltf: Option<PathBuf>,
    /// With `--gltf`: sample the poses every this many steps (the first and the last state are
    /// always sampled). Default: the steps closest to 1/50 s.
    #[arg(long, value_name = "N", requires = "gltf", value_parser = parse_every, allow_hyphen_values = true)]
    pub gltf_every: Option<u64>,
    /// With `--gltf`: another folder to look for mesh files in (`package://PKG/...` is tried
    /// as `DIR/PKG/...` and `DIR/...`); repeatable. The URDF's own folder and its ancestors
    /// are always searched, and `ROS_PACKAGE_PATH`.
    #[arg(long, value_name = "DIR", requires = "gltf")]
    pub mesh_path: Vec<PathBuf>,
}

fn parse_every(s: &str) -> Result<u64, String> {
    crate::simulate::parse_count(s).map_err(|e| format!("the glTF sample period {e}"))
}

impl GltfArgs {
    fn every(&self, dt: f64) -> u64 {
        self.gltf_every
            .unwrap_or_else(|| ((0.02 / dt).round() as u64).max(1))
    }

    fn options(&self) -> articula_gltf::MeshOptions {
        articula_gltf::MeshOptions {
            search_paths: self.mesh_path.clone(),
        }
    }
}

fn failed(e: articula_gltf::GltfError) -> CliError {
    CliError(format!("--gltf: {e}"))
}

fn report_summary(path: &Path, s: &articula_gltf::GltfSummary, spent: Duration) {
    eprintln!(
        "wrote {} ({:.1} MB: {} body nodes, {} samples, {} meshes, {} triangles; {:.0} ms \
         reading meshes, recording and writing)",
        path.display(),
        s.bytes as f64 / 1e6,
        s.body_nodes,
        s.samples,
        s.meshes,
        s.triangles,
        spent.as_secs_f64() * 1e3
    );
}

/// The glTF recorder of an `articula simulate` run when `--gltf` is given (its mesh warnings
/// printed); the run calls it with its other recorders.
pub fn sim_recorder(
    args: &GltfArgs,
    sim: &articula_adaptive::simulation::Simulation,
    urdf: &Path,
    floor: Option<f64>,
) -> Option<articula_gltf::GltfFile> {
    let path = args.gltf.as_ref()?;
    let every = args.every(sim.options().dt);
    let file = articula_gltf::GltfFile::new(sim, Some(urdf), &args.options(), path, every, floor);
    for w in file.warnings() {
        eprintln!("warning: {w}");
    }
    Some(file)
}

/// The line on stderr once the file of a run is written.
pub fn report(file: Option<&articula_gltf::GltfFile>) {
    if let Some((f, s)) = file.and_then(|f| Some((f, f.written.as_ref()?))) {
        report_summary(f.path(), s, f.spent);
    }
}

/// The recording of one `articula scene` run.
pub struct SceneGltf {
    rec: articula_gltf::SceneRecorder,
    path: PathBuf,
    every: u64,
    last: u64,
    /// Time spent in the recorder (meshes, samples, file).
    spent: Duration,
}

impl SceneGltf {
    /// Starts recording (the scene at t = 0) when `--gltf` is given.
    pub fn start(
        args: &GltfArgs,
        sim: &mut articula_view::SceneSim,
    ) -> Result<Option<SceneGltf>, CliError> {
        let Some(path) = &args.gltf else {
            return Ok(None);
        };
        let t0 = Instant::now();
        let mut rec = articula_gltf::SceneRecorder::new(sim.scene, &args.options());
        for w in &rec.warnings {
            eprintln!("warning: {w}");
        }
        rec.record(sim).map_err(failed)?;
        Ok(Some(SceneGltf {
            rec,
            path: path.clone(),
            every: args.every(sim.scene.dt),
            last: 0,
            spent: t0.elapsed(),
        }))
    }

    /// After step `k`: records the scene every N steps.
    pub fn step(&mut self, sim: &mut articula_view::SceneSim, k: u64) -> Result<(), CliError> {
        if k.is_multiple_of(self.every) {
            let t0 = Instant::now();
            self.rec.record(sim).map_err(failed)?;
            self.last = k;
            self.spent += t0.elapsed();
        }
        Ok(())
    }

    /// Records the last state (after step `k`) if not yet, and writes the file (after a run
    /// that stopped, `complete` false, only the samples so far).
    pub fn finish(
        mut self,
        sim: &mut articula_view::SceneSim,
        k: u64,
        complete: bool,
    ) -> Result<(), CliError> {
        let t0 = Instant::now();
        if complete && k != self.last {
            self.rec.record(sim).map_err(failed)?;
        }
        let s = self.rec.write(&self.path).map_err(failed)?;
        report_summary(&self.path, &s, self.spent + t0.elapsed());
        Ok(())
    }
}
