//! `articula.Model` (a loaded URDF, immutable) and `articula.Data` (the workspace of one
//! model's dynamics calls).

use crate::errors::{dynamics_error, error, model_error, Kind};
use articula::dca::ContactData;
use articula::model::{InertiaPolicy, MasslessLeafPolicy};
use articula::prelude::{Data, LoadOptions, Model, State};
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// Every model gets an identity, so that a `Data` of another model is refused.
static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// An articulated model loaded from a URDF (immutable).
///
/// Build it with `Model.from_urdf(path_or_text, floating_base=False, inertia="accept", ...)`.
/// `nq` and `nv` are the sizes of `q` and of `v`, `tau`; a floating base adds 7 positions
/// `[x, y, z, qw, qx, qy, qz]` and 6 velocities `[wx, wy, wz, vx, vy, vz]` (angular first, in
/// the base's own frame) in front.
#[pyclass(name = "Model", module = "articula", frozen)]
pub struct PyModel {
    /// The model.
    pub model: Arc<Model>,
    /// Its identity (see [`PyData`]).
    pub id: u64,
}

impl PyModel {
    /// Wraps a model with a fresh identity.
    pub fn new(model: Model) -> PyModel {
        PyModel {
            model: Arc::new(model),
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
        }
    }
}

/// The loader's options from the keyword arguments of `Model.from_urdf`.
pub(crate) fn load_options(
    floating_base: bool,
    inertia: &str,
    massless_leaf: &str,
    bound_mass: Option<f64>,
    bound_inertia: Option<f64>,
) -> PyResult<LoadOptions> {
    let inertia = match inertia {
        "accept" => InertiaPolicy::Accept,
        "strict" => InertiaPolicy::Strict,
        "repair" => InertiaPolicy::Repair,
        other => {
            return Err(error(
                Kind::Model,
                format!("inertia must be 'accept', 'strict' or 'repair', not '{other}'"),
            ))
        }
    };
    let leaf = match massless_leaf {
        "lock" => MasslessLeafPolicy::Lock,
        "refuse" => MasslessLeafPolicy::Refuse,
        other => {
            return Err(error(
                Kind::Model,
                format!("massless_leaf must be 'lock' or 'refuse', not '{other}'"),
            ))
        }
    };
    let mut options = LoadOptions::default()
        .with_floating_base(floating_base)
        .with_inertia(inertia)
        .with_massless_leaf(leaf);
    if let Some(kg) = bound_mass {
        options = options.with_bound_mass(kg);
    }
    if let Some(kgm2) = bound_inertia {
        options = options.with_bound_inertia(kgm2);
    }
    Ok(options)
}

/// Whether `source` is a model's text rather than a path: its first non-blank character is `<`.
fn is_model_text(source: &str) -> bool {
    source.trim_start().starts_with('<')
}

/// The two model formats a source string may hold.
#[derive(Clone, Copy)]
enum Format {
    Urdf,
    Mjcf,
}

/// Loads `source` (a path, or the model's text when it starts with '<') as `format`.
fn load(
    py: Python<'_>,
    source: &Bound<'_, PyAny>,
    options: &LoadOptions,
    format: Format,
) -> PyResult<PyModel> {
    let name = match format {
        Format::Urdf => "URDF",
        Format::Mjcf => "MJCF",
    };
    let text: Option<String> = source.extract::<String>().ok();
    let model = match text {
        Some(t) if is_model_text(&t) => py.detach(|| match format {
            Format::Urdf => Model::from_urdf_str(&t, options),
            Format::Mjcf => Model::from_mjcf_str(&t, options),
        }),
        _ => {
            let path: std::path::PathBuf = source.extract().map_err(|_| {
                let ty = source
                    .get_type()
                    .name()
                    .map_or("?".into(), |n| n.to_string());
                error(
                    Kind::Model,
                    format!("source must be a path or {name} text, not {ty}"),
                )
            })?;
            py.detach(|| match format {
                Format::Urdf => Model::from_urdf_file(&path, options),
                Format::Mjcf => Model::from_mjcf_file(&path, options),
            })
        }
    }
    .map_err(model_error)?;
    Ok(PyModel::new(model))
}

#[pymethods]
impl PyModel {
    /// Loads a URDF from a file path (str or os.PathLike) or from URDF text (a string whose
    /// first non-blank character is '<').
    ///
    /// floating_base: give the root link 6 degrees of freedom (joint "floating_base").
    /// inertia: "accept" (load as written, warn), "strict" (refuse odd inertias) or "repair"
    /// (fix them as MuJoCo does); bound_mass / bound_inertia raise every body to at least
    /// these (repair only). massless_leaf: "lock" (weld massless moving leaves, their q̈ is 0)
    /// or "refuse". Raises articula.ModelError naming the file, link or joint.
    #[staticmethod]
    #[pyo3(signature = (source, floating_base=false, inertia="accept", massless_leaf="lock",
                        bound_mass=None, bound_inertia=None))]
    fn from_urdf(
        py: Python<'_>,
        source: &Bound<'_, PyAny>,
        floating_base: bool,
        inertia: &str,
        massless_leaf: &str,
        bound_mass: Option<f64>,
        bound_inertia: Option<f64>,
    ) -> PyResult<PyModel> {
        let options = load_options(
            floating_base,
            inertia,
            massless_leaf,
            bound_mass,
            bound_inertia,
        )?;
        load(py, source, &options, Format::Urdf)
    }

    /// Loads an MJCF (MuJoCo XML) model from a file path (its `<include>`s and mesh files
    /// resolved against its directory) or from MJCF text (a string whose first non-blank
    /// character is '<'; an `<include>` is then an error). The file decides the base: one
    /// free body alone under the world is a floating base. Ball joints are quaternions
    /// `[w, x, y, z]` in q, as MuJoCo's; `armature`, `damping` and springs are read
    /// (docs/mjcf.md lists what is read, warned about and refused). Options as in from_urdf.
    /// Raises articula.ModelError naming the file, body or joint.
    #[staticmethod]
    #[pyo3(signature = (source, inertia="accept", massless_leaf="lock", bound_mass=None,
                        bound_inertia=None))]
    fn from_mjcf(
        py: Python<'_>,
        source: &Bound<'_, PyAny>,
        inertia: &str,
        massless_leaf: &str,
        bound_mass: Option<f64>,
        bound_inertia: Option<f64>,
    ) -> PyResult<PyModel> {
        let options = load_options(false, inertia, massless_leaf, bound_mass, bound_inertia)?;
        load(py, source, &options, Format::Mjcf)
    }

    /// Loads a URDF or an MJCF file, by its content (an MJCF's root element is `<mujoco>`).
    /// floating_base applies to a URDF only (an MJCF file decides its base); the other
    /// options as in from_urdf.
    #[staticmethod]
    #[pyo3(signature = (path, floating_base=false, inertia="accept", massless_leaf="lock",
                        bound_mass=None, bound_inertia=None))]
    fn from_file(
        py: Python<'_>,
        path: std::path::PathBuf,
        floating_base: bool,
        inertia: &str,
        massless_leaf: &str,
        bound_mass: Option<f64>,
        bound_inertia: Option<f64>,
    ) -> PyResult<PyModel> {
        let options = load_options(
            floating_base,
            inertia,
            massless_leaf,
            bound_mass,
            bound_inertia,
        )?;
        let model = py
            .detach(|| Model::from_file(&path, &options))
            .map_err(model_error)?;
        Ok(PyModel::new(model))
    }

    /// The robot's name (URDF `<robot name>`).
    #[getter]
    fn name(&self) -> String {
        self.model.name.clone()
    }

    /// Number of position coordinates (length of q).
    #[getter]
    fn nq(&self) -> usize {
        self.model.nq
    }

    /// Number of velocity coordinates (length of v, tau, q̈).
    #[getter]
    fn nv(&self) -> usize {
        self.model.nv
    }

    /// Whether the root link floats (joint "floating_base" first in q and v).
    #[getter]
    fn floating_base(&self) -> bool {
        self.model.floating_base
    }

    /// Number of moving bodies (links merged by fixed joints count once); the rows of f_ext.
    #[getter]
    fn nbodies(&self) -> usize {
        self.model.bodies.len()
    }

    /// The bodies' names (their URDF links), in the order of f_ext's rows.
    #[getter]
    fn body_names(&self) -> Vec<String> {
        self.model.bodies.iter().map(|b| b.name.clone()).collect()
    }

    /// Every URDF link with a frame (the bodies' and those welded to them or to the world).
    #[getter]
    fn link_names(&self) -> Vec<String> {
        let ground = self.model.ground_links.iter().map(|(n, _)| n.clone());
        let bodies = self
            .model
            .bodies
            .iter()
            .flat_map(|b| b.links.iter().map(|(n, _)| n.clone()));
        ground.chain(bodies).collect()
    }

    /// The movable joints' URDF names in coordinate order (locked joints last).
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.model
            .coordinate_parts()
            .map(|p| p.name.clone())
            .collect()
    }

    /// The joints locked at load time (massless moving leaves): their q̈ is 0.
    #[getter]
    fn locked_joints(&self) -> Vec<String> {
        self.model
            .locked_joints()
            .into_iter()
            .map(String::from)
            .collect()
    }

    /// The loader's warnings, one string each.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.model.warnings.iter().map(|w| w.to_string()).collect()
    }

    /// Total mass of the moving bodies (kg).
    #[getter]
    fn mass(&self) -> f64 {
        self.model.moving_mass()
    }

    /// Index of joint `name`'s first position coordinate in q.
    fn idx_q(&self, name: &str) -> PyResult<usize> {
        self.part(name).map(|p| p.0)
    }

    /// Index of joint `name`'s first velocity coordinate in v.
    fn idx_v(&self, name: &str) -> PyResult<usize> {
        self.part(name).map(|p| p.1)
    }

    /// (nq, nv) of joint `name`: (1, 1) for revolute, continuous and prismatic joints, (7, 6)
    /// for a floating one.
    fn joint_size(&self, name: &str) -> PyResult<(usize, usize)> {
        self.part(name).map(|p| (p.2, p.3))
    }

    /// Lower position limits (length nq; -inf where a coordinate has none).
    #[getter]
    fn lower_limits<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.limits(0))
    }

    /// Upper position limits (length nq; +inf where a coordinate has none).
    #[getter]
    fn upper_limits<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.limits(1))
    }

    /// The neutral configuration: every angle 0, identity orientations (length nq).
    fn neutral<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.model.neutral_q())
    }

    /// The rest configuration: neutral, with every limited coordinate whose limits exclude 0
    /// moved to the nearer limit (length nq).
    fn rest<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.model.rest_q())
    }

    /// A reproducible random state (q, v, tau): angles in ±1.2 rad, displacements in ±0.2 m,
    /// rates in ±2, forces in ±tau_scale, a random floating-base pose. The states of
    /// `cargo xtask corpus` (seeds 1-4, tau_scale 1).
    #[pyo3(signature = (seed, tau_scale=1.0))]
    #[allow(clippy::type_complexity)]
    fn random_state<'py>(
        &self,
        py: Python<'py>,
        seed: u64,
        tau_scale: f64,
    ) -> (
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<f64>>,
    ) {
        let s = State::random(&self.model, seed, tau_scale);
        (
            PyArray1::from_vec(py, s.q),
            PyArray1::from_vec(py, s.qd),
            PyArray1::from_vec(py, s.tau),
        )
    }

    /// The body inertias as (mass, centre of mass (3), rotational inertia about the centre of
    /// mass (3×3)) in each body's frame, in body order.
    #[allow(clippy::type_complexity)]
    fn body_inertias<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Vec<(f64, Bound<'py, PyArray1<f64>>, Bound<'py, PyArray2<f64>>)>> {
        self.model
            .bodies
            .iter()
            .map(|b| {
                let i = &b.inertia;
                let c = if i.mass > 0.0 {
                    i.h / i.mass
                } else {
                    i.h * 0.0
                };
                // Parallel-axis theorem: I_c = Ī − m (|c|² 1 − c cᵀ).
                let ibar = i.ibar;
                let cc = c.dot(c);
                let mut rows = vec![vec![0.0; 3]; 3];
                for (r, row) in rows.iter_mut().enumerate() {
                    for (k, x) in row.iter_mut().enumerate() {
                        let delta = if r == k { cc } else { 0.0 };
                        *x = ibar.col(k)[r] - i.mass * (delta - c[r] * c[k]);
                    }
                }
                Ok((
                    i.mass,
                    PyArray1::from_slice(py, &c.to_array()),
                    PyArray2::from_vec2(py, &rows).map_err(|e| dynamics_error(e.to_string()))?,
                ))
            })
            .collect()
    }

    fn __repr__(&self) -> String {
        format!(
            "articula.Model('{}', nq={}, nv={}, bodies={}, floating_base={})",
            self.model.name,
            self.model.nq,
            self.model.nv,
            self.model.bodies.len(),
            if self.model.floating_base {
                "True"
            } else {
                "False"
            }
        )
    }
}

impl PyModel {
    /// (q offset, v offset, nq, nv) of a joint, or a ModelError naming it.
    fn part(&self, name: &str) -> PyResult<(usize, usize, usize, usize)> {
        self.model
            .coordinate_parts()
            .find(|p| p.name == name)
            .map(|p| (p.q_offset, p.v_offset, p.nq(), p.nv()))
            .ok_or_else(|| error(Kind::Model, format!("no movable joint named '{name}'")))
    }

    /// Bound `k` (0 lower, 1 upper) of every position coordinate.
    fn limits(&self, k: usize) -> Vec<f64> {
        let inf = if k == 0 {
            f64::NEG_INFINITY
        } else {
            f64::INFINITY
        };
        let mut out = vec![inf; self.model.nq];
        for p in self.model.coordinate_parts() {
            if let Some(l) = p.limits {
                out[p.q_offset] = l[k];
            }
        }
        out
    }
}

/// The workspace of one model's dynamics calls: `Data(model)`.
///
/// Every function that takes `(model, data, ...)` computes into it; the kinematics functions
/// (`link_pose`, `jacobian`, `com`, energies, momentum) read what the last call left.
/// `data.gravity` is the gravity vector (default (0, 0, -9.81) m/s²).
#[pyclass(name = "Data", module = "articula")]
pub struct PyData {
    /// The dynamics workspace.
    pub data: Data,
    /// The contact workspace, made at the first contact step.
    pub contact: Option<ContactData>,
    /// The identity of the model it was made for.
    pub model_id: u64,
    /// The nq of that model (for the error message).
    pub nq: usize,
    /// Whether `data` holds kinematics (a dynamics call or forward_kinematics ran).
    pub kinematics: bool,
}

#[pymethods]
impl PyData {
    #[new]
    fn new(model: &PyModel) -> PyData {
        PyData {
            data: Data::new(&model.model),
            contact: None,
            model_id: model.id,
            nq: model.model.nq,
            kinematics: false,
        }
    }

    /// Gravity in world coordinates (m/s²), default (0, 0, -9.81).
    #[getter]
    fn get_gravity<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.data.gravity.to_array())
    }

    #[setter]
    fn set_gravity(&mut self, g: [f64; 3]) -> PyResult<()> {
        if g.iter().any(|x| !x.is_finite()) {
            return Err(dynamics_error(format!("gravity must be finite, got {g:?}")));
        }
        self.data.gravity = g.into();
        Ok(())
    }

    fn __repr__(&self) -> String {
        format!("articula.Data(nq={})", self.nq)
    }
}

impl PyData {
    /// Refuses a workspace made for another model.
    pub fn check(&self, model: &PyModel) -> PyResult<()> {
        if self.model_id != model.id {
            return Err(dynamics_error(format!(
                "this Data was made for another model (nq={}); make one with articula.Data(model)",
                self.nq
            )));
        }
        Ok(())
    }

    /// Refuses to read kinematics before any call computed them.
    pub fn check_kinematics(&self) -> PyResult<()> {
        if !self.kinematics {
            return Err(dynamics_error(
                "no kinematics in this Data yet: call forward_kinematics(model, data, q, v) \
                 (or any dynamics function) first",
            ));
        }
        Ok(())
    }
}
