//! How a URDF becomes a model: the import policies of [`LoadOptions`] (see `docs/loading.md`).

/// What to do with a body (after fixed-joint merging) whose rotational inertia no rigid body
/// has: principal moments below zero, breaking the triangle inequality, or a point or rod mass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InertiaPolicy {
    /// Load the numbers as written and warn once per odd body: dynamics stays exact for the
    /// numbers given (results equal Pinocchio's). Two exceptions: a body whose inertia is
    /// really indefinite (a principal moment below zero beyond the tolerance), or massless with
    /// a rotational inertia, is refused (no dynamics is defined for it: load with
    /// [`InertiaPolicy::Repair`]); a point or rod mass — singular within round-off, which the
    /// divide-and-conquer algorithm cannot invert — gets the smallest rotational inertia that
    /// makes it invertible, reported as a warning.
    #[default]
    Accept,
    /// Refuse every odd body, each listed with its numbers.
    Strict,
    /// Fix every odd body the way MuJoCo's `boundmass`, `boundinertia` and `balanceinertia`
    /// do, each change reported with the numbers before and after; with
    /// [`LoadOptions::bound_mass`] or [`LoadOptions::bound_inertia`], also raise every body
    /// below those absolute bounds.
    Repair,
}

impl InertiaPolicy {
    /// The lowercase name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            InertiaPolicy::Accept => "accept",
            InertiaPolicy::Strict => "strict",
            InertiaPolicy::Repair => "repair",
        }
    }
}

/// What to do with a moving joint whose child subtree has no mass at all (romeo's finger
/// joints): its acceleration is undetermined (`0 · q̈ = τ`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MasslessLeafPolicy {
    /// Lock the joint: its massless links are welded to its parent at the joint's neutral
    /// position, its coordinates stay in `q` and `qd` (so states keep their shape) and its
    /// `q̈` is exactly 0 from every algorithm. Reported as a warning and by
    /// [`crate::Model::locked_joints`].
    #[default]
    Lock,
    /// Refuse the model, listing every such joint.
    Refuse,
}

/// How to turn a URDF into a model. Build it from [`LoadOptions::default`] and the `with_*`
/// methods (the struct may grow):
///
/// ```
/// use articula_model::{InertiaPolicy, LoadOptions};
/// let options = LoadOptions::default()
///     .with_floating_base(true)
///     .with_inertia(InertiaPolicy::Repair);
/// assert!(options.floating_base);
/// ```
///
/// A robot whose point masses sit close to joint axes (icub) loads under
/// [`InertiaPolicy::Repair`] with an absolute floor on the principal moments that keeps its
/// joints soft enough for a millisecond step (`docs/loading.md#absolute-bounds`):
///
/// ```
/// use articula_model::{InertiaPolicy, LoadOptions};
/// let options = LoadOptions::default()
///     .with_inertia(InertiaPolicy::Repair)
///     .with_bound_inertia(1e-5);
/// assert_eq!(options.bound_inertia, Some(1e-5));
/// ```
#[non_exhaustive]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoadOptions {
    /// Give the root link six degrees of freedom (joint [`crate::FLOATING_BASE_JOINT`])
    /// instead of welding it to the world.
    pub floating_base: bool,
    /// What to do with bodies whose inertia no rigid body has.
    pub inertia: InertiaPolicy,
    /// What to do with moving joints that carry no mass.
    pub massless_leaf: MasslessLeafPolicy,
    /// [`InertiaPolicy::Repair`] only: every body's mass is raised to at least this (kg), like
    /// MuJoCo's `boundmass`. Links with neither mass nor inertia are not bodies of the
    /// dynamics (they fold into composed joints or are locked) and stay massless. Finite and
    /// ≥ 0, else the load fails with [`crate::ModelError::BadOption`].
    pub bound_mass: Option<f64>,
    /// [`InertiaPolicy::Repair`] only: every body's principal moments about its centre of mass
    /// are raised to at least this (kg·m²), like MuJoCo's `boundinertia` (axes and centre of
    /// mass kept). Finite and ≥ 0, else the load fails with [`crate::ModelError::BadOption`].
    pub bound_inertia: Option<f64>,
}

impl LoadOptions {
    /// With or without a floating base.
    pub fn with_floating_base(self, on: bool) -> Self {
        Self {
            floating_base: on,
            ..self
        }
    }

    /// With the given inertia policy.
    pub fn with_inertia(self, p: InertiaPolicy) -> Self {
        Self { inertia: p, ..self }
    }

    /// With an absolute lower bound on every body's mass (kg; needs [`InertiaPolicy::Repair`]).
    pub fn with_bound_mass(self, kg: f64) -> Self {
        Self {
            bound_mass: Some(kg),
            ..self
        }
    }

    /// With an absolute lower bound on every body's principal moments (kg·m²; needs
    /// [`InertiaPolicy::Repair`]).
    pub fn with_bound_inertia(self, kgm2: f64) -> Self {
        Self {
            bound_inertia: Some(kgm2),
            ..self
        }
    }

    /// The repair bounds checked against the policy: `Ok((bound_mass, bound_inertia))`, each
    /// 0 when not given, or the reason they cannot be used.
    pub(crate) fn bounds(&self) -> Result<(f64, f64), crate::ModelError> {
        let check = |option: &'static str, x: Option<f64>| match x {
            None => Ok(0.0),
            Some(x) if !(x.is_finite() && x >= 0.0) => Err(crate::ModelError::BadOption {
                option,
                message: format!("must be a finite number ≥ 0, got {x}"),
            }),
            Some(_) if self.inertia != InertiaPolicy::Repair => Err(crate::ModelError::BadOption {
                option,
                message: format!(
                    "applies only under the repair inertia policy, not {}",
                    self.inertia.name()
                ),
            }),
            Some(x) => Ok(x),
        };
        Ok((
            check("bound_mass", self.bound_mass)?,
            check("bound_inertia", self.bound_inertia)?,
        ))
    }

    /// With the given massless-leaf policy.
    pub fn with_massless_leaf(self, p: MasslessLeafPolicy) -> Self {
        Self {
            massless_leaf: p,
            ..self
        }
    }
}
