//! Ground contact and joint limits in the semi-implicit Euler step
//! ([`step_with_contact`], `docs/contact.md`, `docs/design.md#contact`).
//!
//! One step from `(q, q̇)`:
//!
//! 1. free motion `v_free = q̇ + dt M⁻¹(τ − C)` (forward dynamics by the step's [`Method`]);
//! 2. candidate rows at `q`: every contact sphere of [`CollisionModel`] whose gap to the
//!    ground `φ = n·(c − p₀) − r` is below `margin` plus the distance it can close in the step,
//!    with a normal row and two tangent rows (a body's spheres are skipped together when a
//!    ball holding them all cannot reach that far); every limited joint within `margin` of a
//!    bound;
//! 3. `W = J M⁻¹ Jᵀ` from the articulated tree of the system at rest ([`crate::delassus`]),
//!    built once per step: each column is the response to one row's wrench, propagated along
//!    its node's path (a node with many rows: its 6 unit wrenches read at the contact nodes,
//!    `Φ`, which its rows combine), one entry per pair of rows;
//! 4. `λ` by projected Gauss–Seidel, or with subspace minimisation ([`ContactSolver`],
//!    `contact_solver`), warm-started from the
//!    previous step's impulses at the same contact spheres and limits;
//! 5. `q̇⁺ = v_free + M⁻¹ Jᵀ λ` (one pass over the tree), `q⁺ = q ⊕ dt q̇⁺`;
//! 6. post-stabilisation: where a row penetrates deeper than `slop`, `q⁺ ← q⁺ ⊕ M⁻¹ Jᵀ μ`
//!    with `μ ≥ 0` the smallest push-out (`W μ ≥ −φ − slop`, same solver, no friction) — a
//!    position change only, so it adds no kinetic energy.
//!
//! Targets: a row whose gap `φ > 0` may close it but not cross it (`u ≥ −φ/dt`, speculative
//! contact: no impact is missed); a contact whose gap closes within the step at its
//! start-of-step approach speed `u⁻`, faster than `restitution_velocity`, leaves at `−e u⁻`
//! (the bounce starts up to `|u⁻| dt` early: the ball turns a little above the floor).

use crate::contact_solver::{self, ActiveSet, Block, Solve, Stop};
use crate::delassus::{Load, Tree, NONE};
use crate::integrate::check_step_result;
use crate::{integrate_q, Data, DynamicsError, Method, State};
use articula_model::{CollisionModel, Model};
use articula_spatial::{SpatialForce, SpatialInertia, SpatialMotion};
use glam::DVec3;
use std::sync::Arc;
use thiserror::Error;

/// A ground plane: the half-space `n·(x − point) ≥ 0` is free, below is solid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ground {
    /// A point of the plane (world frame, m).
    pub point: DVec3,
    /// Its normal, pointing out of the ground (any length > 0; a tilted normal is an incline).
    pub normal: DVec3,
    /// Coulomb friction coefficient `μ ≥ 0`.
    pub friction: f64,
    /// Restitution `0 ≤ e ≤ 1` (0: impacts are perfectly inelastic).
    pub restitution: f64,
}

impl Ground {
    /// The horizontal floor `z = height` with friction `μ = 1` and no restitution.
    pub fn horizontal(height: f64) -> Ground {
        Ground {
            point: DVec3::new(0.0, 0.0, height),
            normal: DVec3::Z,
            friction: 1.0,
            restitution: 0.0,
        }
    }

    /// The floor through the world origin tilted by `angle` (rad) about the world y axis
    /// (it rises towards −x), friction `friction`, no restitution.
    pub fn incline(angle: f64, friction: f64) -> Ground {
        Ground {
            point: DVec3::ZERO,
            normal: DVec3::new(angle.sin(), 0.0, angle.cos()),
            friction,
            restitution: 0.0,
        }
    }
}

/// What the contact step enforces, and its solver's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactSettings {
    /// The ground, if any.
    pub ground: Option<Ground>,
    /// Enforce the URDF limits of revolute and prismatic joints (default `true`).
    pub joint_limits: bool,
    /// Solver iterations at most (Gauss–Seidel sweeps, Newton iterations, subspace steps;
    /// default 200, at most [`MAX_ITERATIONS`]).
    pub max_iterations: usize,
    /// Stop when every condition holds to this residual velocity (default 1e-9, m/s or
    /// rad/s; Gauss–Seidel also stops when no sweep changes a row velocity by more).
    pub tolerance: f64,
    /// Penetration (m, or rad for a limit) left alone by the position correction (default
    /// 1e-4).
    pub slop: f64,
    /// Gap (m or rad) below which a contact or limit is a candidate, on top of what the
    /// current velocity closes in the step (default 2e-3).
    pub margin: f64,
    /// Approach speed (m/s or rad/s) below which restitution is not applied (default 0.05):
    /// a resting contact does not jitter.
    pub restitution_velocity: f64,
    /// The solver (default [`ContactSolver::GaussSeidel`]).
    pub solver: ContactSolver,
}

/// How the contact problem is solved (`docs/contact.md#solver`). Each stops at
/// `ContactSettings::tolerance` or after `max_iterations`, and each returns impulses inside
/// the friction discs and never a pulling normal force.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ContactSolver {
    /// Projected Gauss–Seidel: sweeps until no row velocity changes by more than the
    /// tolerance or every condition holds to it. The default.
    #[default]
    GaussSeidel,
    /// Projected Gauss–Seidel with subspace minimisation: a few sweeps fix which rows push
    /// and which contacts stick or slide, then the equations on those sets are solved
    /// exactly (a Cholesky factorisation of the pushing rows' `W`); stops when every
    /// condition holds to the tolerance. About half the iterations of Gauss–Seidel, each
    /// subspace step costing several sweeps.
    Subspace,
    /// Semismooth Newton on the Alart–Curnier equations: per iteration the status of every
    /// contact and limit (separating, sticking, sliding), one dense solve on the rows that
    /// push, and a line search; converges in a few iterations where Gauss–Seidel needs
    /// hundreds, and falls back to Gauss–Seidel sweeps when it stalls.
    Newton,
}

impl Default for ContactSettings {
    fn default() -> Self {
        ContactSettings {
            ground: None,
            joint_limits: true,
            max_iterations: 200,
            tolerance: 1e-9,
            slop: 1e-4,
            margin: 2e-3,
            restitution_velocity: 0.05,
            solver: ContactSolver::GaussSeidel,
        }
    }
}

/// A contact step's error: the dynamics', or settings it cannot use.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ContactError {
    /// Forward dynamics failed.
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
    /// A setting is out of its range.
    #[error("invalid contact setting {what}: {detail}")]
    Invalid {
        /// The setting.
        what: &'static str,
        /// Why.
        detail: String,
    },
}

/// Figures of the last [`step_with_contact`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactStats {
    /// Candidate contact spheres of the detection (3 rows each, but for those that other
    /// points of their node hold up, which get none).
    pub candidates: usize,
    /// Contact spheres pushed by the ground (`λ_n > 0`).
    pub contacts: usize,
    /// Joint limits pushing (`λ > 0`).
    pub limits: usize,
    /// Rows of the contact problem (`k`).
    pub rows: usize,
    /// Response columns of `W` (each a walk along one node's path of the articulated tree,
    /// not a forward-dynamics solve).
    pub response_solves: usize,
    /// Gauss–Seidel sweeps.
    pub iterations: usize,
    /// Whether the sweeps met `tolerance`.
    pub converged: bool,
    /// The solve's largest violation of its conditions at its end (m/s or rad/s: a pushing
    /// row off its target, a row approaching below it, a sticking contact's slip, a sliding
    /// one's slip not opposing its force); at most `tolerance` when `converged`, 0 without
    /// rows.
    pub residual: f64,
    /// The deepest penetration into the ground at the start of the step (m, ≥ 0).
    pub max_penetration: f64,
}

/// A candidate row's origin: a contact sphere or a joint bound.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Source {
    /// Contact sphere `sphere` of the collision model (its normal row; tangents follow).
    Sphere { sphere: usize, body: usize },
    /// Joint limit `limit` of [`ContactData`]'s list.
    Limit { limit: usize },
}

/// Consecutive contact spheres `first..end` of one body and a ball that holds them all
/// (`center` in the body frame, `reach` ≥ each sphere's `|c − center| + r`): the broad
/// phase skips the run when the ball is too far above the ground for any of them to be a
/// candidate.
#[derive(Clone, Copy, Debug, PartialEq)]
struct SphereRun {
    body: usize,
    first: usize,
    end: usize,
    center: DVec3,
    reach: f64,
}

impl SphereRun {
    /// The runs of `spheres`: each maximal sequence of one body's spheres, its ball centred
    /// on the middle of their bounding box.
    fn of(spheres: &[articula_model::ContactSphere]) -> Vec<SphereRun> {
        let mut runs = Vec::new();
        let mut first = 0;
        while first < spheres.len() {
            let body = spheres[first].body;
            let end = first
                + spheres[first..]
                    .iter()
                    .take_while(|s| s.body == body)
                    .count();
            let run = &spheres[first..end];
            let (lo, hi) = run.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), s| (lo.min(s.center), hi.max(s.center)),
            );
            let center = 0.5 * (lo + hi);
            let reach = run
                .iter()
                .map(|s| (s.center - center).length() + s.extent())
                .fold(0.0, f64::max);
            runs.push(SphereRun {
                body,
                first,
                end,
                center,
                reach,
            });
            first = end;
        }
        runs
    }
}

/// The buffers of [`drop_held_points`] (sized for every sphere and bound of the model).
#[derive(Clone, Debug, Default)]
struct Patches {
    /// `(node, source)` of the sphere candidates on moving nodes, sorted.
    members: Vec<(usize, usize)>,
    /// Per source: kept.
    keep: Vec<bool>,
    /// One node's touching points in the ground plane, and their convex hull.
    points: Vec<(f64, f64)>,
    hull: Vec<(f64, f64)>,
}

/// How a contact node's rows get their columns of `W` ([`delassus`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Basis {
    /// One response column per row.
    Rows,
    /// From the node's 6 unit-wrench columns `Φ_{·b}`, not computed yet.
    Pending,
    /// From `Φ_{·b}`, computed.
    Ready,
}

/// A joint bound: `sign (q[qi] − bound) ≥ 0` with velocity `sign q̇[vi]`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Bound {
    /// The body whose joint it bounds.
    body: usize,
    qi: usize,
    vi: usize,
    bound: f64,
    sign: f64,
}

/// The contact step's workspace, built once per model ([`ContactData::new`]); a step
/// allocates only when it meets more rows than any step before. Clones share the model's
/// contact spheres and joint bounds (each keeps its own warm starts and buffers): clone one
/// for each body of a crowd.
#[derive(Clone, Debug)]
pub struct ContactData {
    /// What the model gives: its contact spheres, their runs and its joint bounds (shared by
    /// clones: one copy read by every body of a crowd).
    shape: Arc<ContactShape>,
    /// Figures of the last step.
    pub stats: ContactStats,
    /// Response columns of the last step.
    columns: usize,
    /// Warm starts: per contact sphere `[λ_n, λ_t1, λ_t2]`, per bound `λ`.
    warm_spheres: Vec<[f64; 3]>,
    warm_bounds: Vec<f64>,
    /// The sources whose warm starts the last solve set.
    warm_set: Vec<Source>,
    /// The forces of the last step's solve.
    forces: ContactForces,
    /// The buffers one step uses and leaves ([`ContactScratch`]).
    s: ContactScratch,
    /// The model this workspace was built for (checked by every step).
    fingerprint: crate::data::Fingerprint,
}

/// The forces of a step's contact solve: its impulses over `dt`. Per body the ground pushes,
/// the wrench of its contact points (world axes, about the world origin, as external forces
/// are given); per bounded degree of freedom (`q̇` index) the limit's torque or force. The
/// position correction moves positions, not velocities, and adds nothing here.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContactForces {
    /// `(body, wrench)`, one entry per body the ground pushes.
    pub wrenches: Vec<(usize, SpatialForce)>,
    /// `(q̇ index, τ)`, one entry per pushing bound.
    pub torques: Vec<(usize, f64)>,
}

impl ContactForces {
    /// The ground's whole wrench on the model: the sum of [`ContactForces::wrenches`] (world
    /// axes, about the world origin). At rest its force is the model's weight.
    pub fn total(&self) -> SpatialForce {
        let mut t = SpatialForce::ZERO;
        for (_, w) in &self.wrenches {
            t += *w;
        }
        t
    }
}

/// A model's contact spheres ([`ContactData::collision`]), the spheres in runs of one body
/// each with a ball that holds them all, and its joint bounds.
#[derive(Debug)]
struct ContactShape {
    collision: CollisionModel,
    runs: Vec<SphereRun>,
    bounds: Vec<Bound>,
}

/// The buffers a contact step of one model uses within itself: the rows, the articulated tree,
/// `W`, the solver's, the free velocities and the impulses' response. Nothing in them carries
/// from one step to the next, so bodies of one model stepped in turn can share one
/// ([`ContactData::swap_scratch`]) that stays in the processor's caches instead of each
/// streaming its own from memory.
#[derive(Clone, Debug)]
pub struct ContactScratch {
    /// Per block: its source and first row.
    sources: Vec<(Source, usize)>,
    blocks: Vec<Block>,
    /// Per row: the gap (normal and limit rows; 0 for tangents).
    phi: Vec<f64>,
    /// Per row: the wrench (contact rows, computation frame) whose power is the row velocity.
    wrench: Vec<SpatialForce>,
    /// The articulated tree of the step, and per row its node and (joint-bound rows) bound.
    tree: Tree,
    row_node: Vec<usize>,
    row_bound: Vec<usize>,
    /// Per row: its direction in the contact frame (0 normal, 1 and 2 the tangents; [`NONE`]
    /// for a bound).
    row_dir: Vec<usize>,
    /// Per node: the impulses' wrench.
    node_wrench: Vec<[f64; 6]>,
    /// Per node: its contact rows (zero between steps) and its slot among the contact nodes
    /// ([`NONE`] between steps); the contact nodes; per row its node's slot ([`NONE`]: a
    /// bound, or a body welded to the world).
    node_rows: Vec<usize>,
    node_slot: Vec<usize>,
    contact_nodes: Vec<usize>,
    row_slot: Vec<usize>,
    /// Per contact node: how its rows' columns of `W` are made.
    slot_basis: Vec<Basis>,
    /// `Φ_{·b}` of the contact nodes taking 6 columns (36 m² accelerations), and one row's
    /// `Y_j = Φ_{·b} w_j` at the `m` contact nodes, both in the contact frame.
    phi_op: Vec<[f64; 6]>,
    y: Vec<[f64; 6]>,
    /// Per contact row: its wrench in the contact frame, 3 entries (index, value) of 6.
    local: Vec<([usize; 3], [f64; 3])>,
    /// The buffers of [`drop_held_points`].
    patches: Patches,
    /// The solver's active-set buffers.
    active: ActiveSet,
    w: Vec<f64>,
    u_free: Vec<f64>,
    target: Vec<f64>,
    lambda: Vec<f64>,
    u: Vec<f64>,
    /// The joint-space vectors of the step.
    joint: JointVectors,
}

/// The joint-space vectors of a contact step (`nv` each).
#[derive(Clone, Debug)]
struct JointVectors {
    /// The free-motion velocity `q̇ + dt M⁻¹(τ − C)`.
    qd_free: Vec<f64>,
    /// The joint-bound impulses gathered per coordinate.
    tau: Vec<f64>,
    /// A velocity change: the free motion's, then `M⁻¹ Jᵀ λ` (or the position correction).
    delta: Vec<f64>,
}

impl ContactScratch {
    /// The step buffers for `model` and its contact spheres ([`CollisionModel::new`]) and joint
    /// bounds, for [`ContactData::swap_scratch`].
    pub fn new(model: &Model) -> ContactScratch {
        let spheres = CollisionModel::new(model).spheres.len();
        let bounds = model
            .joint_parts()
            .filter(|(_, p)| p.limits.is_some())
            .count()
            * 2;
        Self::sized(model, spheres, bounds)
    }

    /// The step buffers for `model` with `spheres` contact spheres and `bounds` joint bounds.
    fn sized(model: &Model, spheres: usize, bounds: usize) -> ContactScratch {
        let (nb, nv) = (model.bodies.len(), model.nv);
        ContactScratch {
            sources: Vec::new(),
            blocks: Vec::new(),
            phi: Vec::new(),
            wrench: Vec::new(),
            tree: Tree::new(model),
            row_node: Vec::new(),
            row_bound: Vec::new(),
            row_dir: Vec::new(),
            node_wrench: Vec::with_capacity(nb),
            node_rows: Vec::with_capacity(nb),
            node_slot: Vec::with_capacity(nb),
            contact_nodes: Vec::with_capacity(nb),
            row_slot: Vec::new(),
            slot_basis: Vec::with_capacity(nb),
            phi_op: Vec::new(),
            y: Vec::with_capacity(nb),
            local: Vec::new(),
            // Sized for every sphere and bound at once: it never grows in a step.
            patches: Patches {
                members: Vec::with_capacity(spheres),
                keep: Vec::with_capacity(spheres + bounds),
                points: Vec::with_capacity(spheres),
                hull: Vec::with_capacity(spheres + 1),
            },
            active: ActiveSet::default(),
            w: Vec::new(),
            u_free: Vec::new(),
            target: Vec::new(),
            lambda: Vec::new(),
            u: Vec::new(),
            joint: JointVectors {
                qd_free: vec![0.0; nv],
                tau: vec![0.0; nv],
                delta: vec![0.0; nv],
            },
        }
    }
}

impl ContactData {
    /// The workspace for `model`: its [`CollisionModel`] and joint limits.
    pub fn new(model: &Model) -> ContactData {
        Self::with_collision(model, CollisionModel::new(model))
    }

    /// The workspace for `model` with the given contact spheres.
    pub fn with_collision(model: &Model, collision: CollisionModel) -> ContactData {
        let mut bounds = Vec::new();
        for (body, p) in model.joint_parts() {
            if let Some([lo, hi]) = p.limits {
                for (bound, sign) in [(lo, 1.0), (hi, -1.0)] {
                    bounds.push(Bound {
                        body,
                        qi: p.q_offset,
                        vi: p.v_offset,
                        bound,
                        sign,
                    });
                }
            }
        }
        ContactData {
            warm_spheres: vec![[0.0; 3]; collision.spheres.len()],
            warm_bounds: vec![0.0; bounds.len()],
            warm_set: Vec::with_capacity(collision.spheres.len() + bounds.len()),
            forces: ContactForces {
                wrenches: Vec::with_capacity(model.bodies.len()),
                torques: Vec::with_capacity(bounds.len()),
            },
            s: ContactScratch::sized(model, collision.spheres.len(), bounds.len()),
            shape: Arc::new(ContactShape {
                runs: SphereRun::of(&collision.spheres),
                collision,
                bounds,
            }),
            stats: ContactStats::default(),
            columns: 0,
            fingerprint: crate::data::Fingerprint::of(model),
        }
    }

    /// Exchanges this workspace's step buffers with `scratch` (O(1)): give it a scratch of the
    /// same model before a step and take it back after, and the bodies of one model stepped in
    /// turn share one scratch ([`ContactScratch`]). The warm starts and the last step's figures
    /// stay here.
    pub fn swap_scratch(&mut self, scratch: &mut ContactScratch) {
        std::mem::swap(&mut self.s, scratch);
    }

    /// The forces of the last step's contact solve (empty before the first step and after a
    /// step without contact).
    pub fn forces(&self) -> &ContactForces {
        &self.forces
    }

    /// The model's contact spheres.
    pub fn collision(&self) -> &CollisionModel {
        &self.shape.collision
    }

    /// The world height (`z`) of the lowest contact point in the kinematics `data`
    /// ([`crate::forward_kinematics`] of the model), `+∞` without contact spheres.
    pub fn lowest_point(&self, data: &Data) -> f64 {
        self.shape
            .collision
            .spheres
            .iter()
            .map(|s| (sphere_center(data, s, DVec3::Z) + data.origin).z - s.radius)
            .fold(f64::INFINITY, f64::min)
    }

    /// The number of joint bounds enforced when `joint_limits` is set (two per limited joint).
    pub fn joint_bounds(&self) -> usize {
        self.shape.bounds.len()
    }
}

/// The most Gauss–Seidel sweeps a step may be given (`ContactSettings::max_iterations`): a
/// bound on any step's work whatever the tolerance (the default is 200, 50 times less). A
/// tolerance below what rounding lets Gauss–Seidel reach would otherwise run to the count.
pub const MAX_ITERATIONS: usize = 10_000;

fn check(settings: &ContactSettings, dt: f64) -> Result<Option<(Ground, DVec3)>, ContactError> {
    let bad = |what, detail: String| Err(ContactError::Invalid { what, detail });
    if !(dt > 0.0 && dt.is_finite()) {
        return bad("dt", format!("{dt} is not a positive time step"));
    }
    for (what, x) in [
        ("tolerance", settings.tolerance),
        ("slop", settings.slop),
        ("margin", settings.margin),
        ("restitution_velocity", settings.restitution_velocity),
    ] {
        if !(x >= 0.0 && x.is_finite()) {
            return bad(what, format!("{x} must be finite and ≥ 0"));
        }
    }
    if settings.max_iterations > MAX_ITERATIONS {
        return bad(
            "max_iterations",
            format!(
                "{} is above the cap {MAX_ITERATIONS} (each sweep costs O(rows²); the solve \
                 ends at its tolerance or its cap, whichever comes first)",
                settings.max_iterations
            ),
        );
    }
    let Some(g) = settings.ground else {
        return Ok(None);
    };
    let len = g.normal.length();
    if !(len > 0.0 && len.is_finite() && g.point.is_finite()) {
        return bad("ground", format!("normal {} at {}", g.normal, g.point));
    }
    if !(g.friction >= 0.0 && g.friction.is_finite()) {
        return bad("friction", format!("{} must be finite and ≥ 0", g.friction));
    }
    if !(0.0..=1.0).contains(&g.restitution) {
        return bad(
            "restitution",
            format!("{} must be in [0, 1]", g.restitution),
        );
    }
    Ok(Some((g, g.normal / len)))
}

/// The contact frame `[n, t₁, t₂]` of the unit normal `n` (right-handed, the directions of a
/// contact's rows in order).
fn contact_frame(n: DVec3) -> [DVec3; 3] {
    let (t1, t2) = tangents(n);
    [n, t1, t2]
}

/// Two unit tangents completing the unit normal `n` to a right-handed frame.
fn tangents(n: DVec3) -> (DVec3, DVec3) {
    let helper = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let t1 = (helper - n * n.dot(helper)).normalize();
    (t1, n.cross(t1))
}

/// The dynamics under a contact step ([`step_with_dynamics`]): the free motion, the
/// kinematics the rows are read from, and the response `M⁻¹ τ` of the system at rest. Exact
/// dynamics (DCA, ABA or CRBA, as [`step_with_contact`] uses them) and articula-adaptive's
/// hybrid body (its locked joints stay locked, a rigid cluster moves as one) implement it;
/// detection, the rows, the solve and the position correction are shared.
pub trait ContactDynamics {
    /// The free-motion accelerations `q̈ = M⁻¹(τ − C)` of `state` into `qdd` (every entry
    /// written; 0 for a joint that does not move). May change `state.qd` first (a hybrid
    /// body's locking impulse); [`ContactDynamics::kinematics`] then holds the kinematics of
    /// the state as it is on return.
    fn free_motion(
        &mut self,
        model: &Model,
        state: &mut State,
        qdd: &mut [f64],
    ) -> Result<(), DynamicsError>;

    /// The kinematics of the step's start (after [`ContactDynamics::free_motion`]): `x`, `v`,
    /// `s` and `origin` of every body that carries a contact sphere and of its root path.
    fn kinematics(&self) -> &Data;

    /// Body `body`'s spatial inertia in the computation frame of
    /// [`ContactDynamics::kinematics`] (default: from its pose `x`).
    fn world_inertia(&self, model: &Model, body: usize) -> SpatialInertia {
        crate::kinematics::world_inertia(&self.kinematics().x[body], &model.bodies[body].inertia)
    }

    /// What the free motion added to the joint-space inertia's diagonal at degree of freedom
    /// `dof`: the armature, and `dt · damping` where damping is implicit over the step. The
    /// contact impulses' response sees the same inertia, so that an impulse `Jᵀλ` changes the
    /// velocity by `(M + diag(added))⁻¹ Jᵀλ`, as the free motion's forces do (default: none).
    fn added_inertia(&self, _model: &Model, _dof: usize) -> f64 {
        0.0
    }

    /// Whether body `body`'s joint moves in this step (its columns of `J` are used; default
    /// every joint).
    fn moves(&self, _model: &Model, _body: usize) -> bool {
        true
    }

    /// `q ← q ⊕ h v` over the joints that move (default: all, [`integrate_q`]).
    fn integrate(&self, model: &Model, q: &mut [f64], v: &[f64], h: f64) {
        integrate_q(model, q, v, h);
    }
}

/// Exact forward dynamics under a contact step: the free motion is one forward-dynamics
/// solve by `method` in the workspace `data`, every joint moves.
struct ExactDynamics<'a> {
    data: &'a mut Data,
    method: Method,
    /// The step, over which damping is implicit.
    dt: f64,
}

impl ContactDynamics for ExactDynamics<'_> {
    fn free_motion(
        &mut self,
        model: &Model,
        state: &mut State,
        qdd: &mut [f64],
    ) -> Result<(), DynamicsError> {
        // Passive forces applied, damping implicit over the step: the free motion's inertia
        // is M + dt·D ([`ContactDynamics::added_inertia`], which the impulses' response uses).
        let s = &*state;
        crate::integrate::with_passive_forces(
            model,
            self.data,
            (&s.q, &s.qd, &s.tau, &s.f_ext),
            self.method,
            self.dt,
        )?;
        qdd.copy_from_slice(&self.data.qdd);
        Ok(())
    }

    fn kinematics(&self) -> &Data {
        self.data
    }

    fn added_inertia(&self, model: &Model, dof: usize) -> f64 {
        let d = &model.dynamics;
        let armature = d.armature.get(dof).copied().unwrap_or(0.0);
        armature + self.dt * d.damping.get(dof).copied().unwrap_or(0.0)
    }
}

/// Advances `state` by `dt` with semi-implicit Euler, forward dynamics by `method`, and the
/// ground contact and joint limits of `settings` (module documentation). Without a ground and
/// with `joint_limits` off this is the plain semi-implicit Euler step (without the momentum
/// projection of [`crate::step`]: contact impulses are external). On return, `contact.stats`
/// holds the step's figures and `data` the kinematics of the start-of-step `q`.
///
/// Cost: one forward dynamics for the free motion, the articulated tree at rest O(n), per
/// contact node 6 response columns (its unit wrenches) or one per row, whichever is cheaper,
/// and one per active limit, each O(depth + the rows' paths), `W` from them (`k²/2` entries of
/// 3 products), O(k²) per Gauss–Seidel sweep for `k` rows, and O(n) to apply the impulses.
pub fn step_with_contact(
    model: &Model,
    data: &mut Data,
    contact: &mut ContactData,
    state: &mut State,
    method: Method,
    dt: f64,
    settings: &ContactSettings,
) -> Result<(), ContactError> {
    let mut dynamics = ExactDynamics { data, method, dt };
    step_with_dynamics(model, &mut dynamics, contact, state, dt, settings)
}

/// [`step_with_contact`] on any [`ContactDynamics`]: the free motion, the rows' kinematics,
/// the joints that move and the integration come from `dynamics`; detection, the rows, the
/// Gauss–Seidel solve and the position correction are the same for every dynamics.
pub fn step_with_dynamics<D: ContactDynamics + ?Sized>(
    model: &Model,
    dynamics: &mut D,
    contact: &mut ContactData,
    state: &mut State,
    dt: f64,
    settings: &ContactSettings,
) -> Result<(), ContactError> {
    let given = crate::data::Fingerprint::of(model);
    if contact.fingerprint != given {
        return Err(ContactError::Dynamics(DynamicsError::WrongModel {
            data: format!("ContactData of {}", contact.fingerprint.describe(&given)),
            model: given.describe(&contact.fingerprint),
        }));
    }
    let ground = check(settings, dt)?;
    let cd = contact;
    cd.stats = ContactStats::default();
    cd.forces.wrenches.clear();
    cd.forces.torques.clear();
    // 1. Free motion.
    dynamics.free_motion(model, state, &mut cd.s.joint.delta)?;
    for ((f, v), a) in
        cd.s.joint
            .qd_free
            .iter_mut()
            .zip(&state.qd)
            .zip(&cd.s.joint.delta)
    {
        *f = v + dt * a;
    }
    let data = dynamics.kinematics();
    let origin = data.origin;
    // 2. Candidates, from the kinematics of the start of the step.
    cd.s.sources.clear();
    cd.s.blocks.clear();
    cd.s.phi.clear();
    cd.s.wrench.clear();
    cd.s.target.clear();
    if let Some((g, n)) = ground {
        ground_candidates(cd, data, g, n, dt, settings);
    }
    if settings.joint_limits {
        limit_candidates(model, &*dynamics, cd, state, dt, settings);
    }
    cd.stats.candidates =
        cd.s.sources
            .iter()
            .filter(|(s, _)| matches!(s, Source::Sphere { .. }))
            .count();
    if cd.s.phi.is_empty() {
        state.qd.copy_from_slice(&cd.s.joint.qd_free);
        dynamics.integrate(model, &mut state.q, &state.qd, dt);
        cd.stats.converged = true;
        return finish(model, state);
    }
    // 3. The articulated tree of the system at rest (once), each row's node, and the rows'
    //    free velocities u_free = J v_free (a row reads its node's velocity).
    cd.s.tree.build(model, &*dynamics)?;
    if let Some((_, n)) = ground {
        drop_held_points(cd, n, settings.slop);
    }
    let k = cd.s.phi.len();
    cd.stats.rows = k;
    row_free_velocities(cd);
    // 4. W = J M⁻¹ Jᵀ by columns: per contact node, its 6 unit wrenches' responses at the
    //    contact nodes (each row's column a combination of those) or one response per row,
    //    whichever costs less.
    delassus(cd, ground.map(|(_, n)| contact_frame(n)));
    cd.stats.response_solves = cd.columns;
    cd.s.lambda.clear();
    for &(src, _) in &cd.s.sources {
        match src {
            Source::Sphere { sphere, .. } => {
                cd.s.lambda.extend_from_slice(&cd.warm_spheres[sphere]);
            }
            Source::Limit { limit } => cd.s.lambda.push(cd.warm_bounds[limit]),
        }
    }
    cd.s.u.clear();
    cd.s.u.resize(k, 0.0);
    let solve = solve_rows(&mut cd.s, settings, settings.tolerance);
    cd.stats.iterations = solve.iterations;
    cd.stats.converged = solve.converged;
    cd.stats.residual = contact_solver::residual(&cd.s.blocks, &cd.s.target, &cd.s.lambda, &cd.s.u);
    store_warm_starts(cd);
    record_forces(cd, origin, dt);
    // 5. q̇⁺ = v_free + M⁻¹ Jᵀ λ (one pass over the tree), q⁺ = q ⊕ dt q̇⁺.
    impulse_response(cd);
    state.qd.copy_from_slice(&cd.s.joint.qd_free);
    for (x, d) in state.qd.iter_mut().zip(&cd.s.joint.delta) {
        *x += d;
    }
    dynamics.integrate(model, &mut state.q, &state.qd, dt);
    // 6. Post-stabilisation of what penetrates deeper than the slop.
    post_stabilise(model, dynamics, cd, state, dt, settings);
    finish(model, state)
}

/// The world centre (relative to `data.origin`) of contact sphere `s` in the kinematics
/// `data`, against a plane of normal `n` (a rim point's place depends on it:
/// [`articula_model::ContactSphere::center_facing`]).
pub fn sphere_center(data: &Data, s: &articula_model::ContactSphere, n: DVec3) -> DVec3 {
    let x = &data.x[s.body];
    if s.rim.is_none() {
        return x.apply_point(s.center);
    }
    // The normal in the body frame: x maps body points affinely, p ↦ R p + t.
    let t = x.apply_point(DVec3::ZERO);
    x.apply_point(s.center_facing(x.inv_apply_point(t + n)))
}

/// Stage 2 of [`step_with_dynamics`] at the ground: the candidate contact spheres (those the
/// step may bring within the margin), three rows each, from the kinematics `data` of the
/// start of the step.
fn ground_candidates(
    cd: &mut ContactData,
    data: &Data,
    g: Ground,
    n: DVec3,
    dt: f64,
    settings: &ContactSettings,
) {
    let (t1, t2) = tangents(n);
    // Broad phase: a run of one body's spheres whose ball is above the ground by more
    // than the margin plus what its fastest point can close in the step has no
    // candidate (each sphere's gap is at least the ball's, its approach speed at most
    // the ball centre's plus |ω| times the reach; 1 nm covers the rounding).
    for run in &cd.shape.runs {
        let cw = data.x[run.body].apply_point(run.center);
        let v = data.v[run.body];
        let gap = n.dot(cw + data.origin - g.point) - run.reach;
        let pre = n.dot(v.v + v.w.cross(cw)) - v.w.length() * run.reach;
        if gap >= settings.margin + dt * (-pre).max(0.0) + 1e-9 {
            continue;
        }
        for si in run.first..run.end {
            let s = &cd.shape.collision.spheres[si];
            let c = sphere_center(data, s, n);
            let phi = n.dot(c + data.origin - g.point) - s.radius;
            cd.stats.max_penetration = cd.stats.max_penetration.max(-phi);
            let r = c - n * s.radius;
            let v = data.v[s.body];
            let pre = n.dot(v.v + v.w.cross(r));
            if phi >= settings.margin + dt * (-pre).max(0.0) {
                continue;
            }
            let row = cd.s.phi.len();
            cd.s.sources.push((
                Source::Sphere {
                    sphere: si,
                    body: s.body,
                },
                row,
            ));
            cd.s.blocks.push(Block::Contact {
                row,
                mu: g.friction,
            });
            // An impact in this step (the gap closes at the start-of-step speed) fast enough
            // to bounce leaves at e times that speed; otherwise the gap may close, not cross.
            let bounce = g.restitution > 0.0
                && pre < -settings.restitution_velocity
                && phi + dt * pre <= settings.slop;
            let target = if bounce {
                -g.restitution * pre
            } else {
                -phi.max(0.0) / dt
            };
            for (d, p, t) in [(n, phi, target), (t1, 0.0, 0.0), (t2, 0.0, 0.0)] {
                cd.s.wrench.push(SpatialForce::new(r.cross(d), d));
                cd.s.phi.push(p);
                cd.s.target.push(t);
            }
        }
    }
}

/// Stage 2 of [`step_with_dynamics`] at the joint limits: one unilateral row per bound the
/// step may reach, for the joints that move.
fn limit_candidates<D: ContactDynamics + ?Sized>(
    model: &Model,
    dynamics: &D,
    cd: &mut ContactData,
    state: &State,
    dt: f64,
    settings: &ContactSettings,
) {
    for (li, b) in cd.shape.bounds.iter().enumerate() {
        // A joint that does not move in this step (locked in a hybrid body) has no row.
        let phi = b.sign * (state.q[b.qi] - b.bound);
        let pre = b.sign * state.qd[b.vi];
        if phi >= settings.margin + dt * (-pre).max(0.0) || !dynamics.moves(model, b.body) {
            continue;
        }
        let row = cd.s.phi.len();
        cd.s.sources.push((Source::Limit { limit: li }, row));
        cd.s.blocks.push(Block::Unilateral { row });
        cd.s.wrench.push(SpatialForce::ZERO);
        cd.s.phi.push(phi);
        cd.s.target.push(if phi > settings.slop {
            -phi / dt
        } else {
            -phi.max(0.0) / dt
        });
    }
}

/// Stage 3 of [`step_with_dynamics`]: each row's node of the articulated tree, the nodes the
/// rows read, and the rows' free velocities `u_free = J v_free`.
fn row_free_velocities(cd: &mut ContactData) {
    let k = cd.s.phi.len();
    cd.s.row_node.clear();
    cd.s.row_bound.clear();
    cd.s.row_dir.clear();
    for &(src, _) in &cd.s.sources {
        match src {
            Source::Sphere { body, .. } => {
                let node = cd.s.tree.body_node[body];
                for d in 0..3 {
                    cd.s.row_node.push(node);
                    cd.s.row_bound.push(usize::MAX);
                    cd.s.row_dir.push(d);
                }
            }
            Source::Limit { limit } => {
                cd.s.row_node
                    .push(cd.s.tree.body_node[cd.shape.bounds[limit].body]);
                cd.s.row_bound.push(limit);
                cd.s.row_dir.push(NONE);
            }
        }
    }
    for i in 0..k {
        cd.s.tree.mark_read(cd.s.row_node[i]);
    }
    cd.s.tree.finish_marks();
    cd.s.tree.velocities(&cd.s.joint.qd_free);
    cd.s.u_free.clear();
    for i in 0..k {
        let v = cd.s.tree.velocity(cd.s.row_node[i]);
        let x = row_value(cd, i, |_| v, |dof| cd.s.joint.qd_free[dof]);
        cd.s.u_free.push(x);
    }
}

/// Warm starts for the next step: this step's impulses of its rows (spheres and bounds), and
/// the contacts and limits that push.
fn store_warm_starts(cd: &mut ContactData) {
    // last solve set are the only ones not zero).
    for &src in &cd.warm_set {
        match src {
            Source::Sphere { sphere, .. } => cd.warm_spheres[sphere] = [0.0; 3],
            Source::Limit { limit } => cd.warm_bounds[limit] = 0.0,
        }
    }
    cd.warm_set.clear();
    cd.warm_set.extend(cd.s.sources.iter().map(|s| s.0));
    for &(src, row) in &cd.s.sources {
        match src {
            Source::Sphere { sphere, .. } => {
                cd.warm_spheres[sphere] =
                    [cd.s.lambda[row], cd.s.lambda[row + 1], cd.s.lambda[row + 2]];
                cd.stats.contacts += (cd.s.lambda[row] > 0.0) as usize;
            }
            Source::Limit { limit } => {
                cd.warm_bounds[limit] = cd.s.lambda[row];
                cd.stats.limits += (cd.s.lambda[row] > 0.0) as usize;
            }
        }
    }
}

/// Stage 6 of [`step_with_dynamics`]: a position-only correction of what penetrates deeper
/// than the slop (normal and limit rows, friction off), integrated as a displacement.
fn post_stabilise<D: ContactDynamics + ?Sized>(
    model: &Model,
    dynamics: &mut D,
    cd: &mut ContactData,
    state: &mut State,
    dt: f64,
    settings: &ContactSettings,
) {
    let k = cd.s.phi.len();
    if !cd.s.phi.iter().any(|&p| p < -settings.slop) {
        return;
    }
    // Normal and limit rows only: friction is off (tangent rows' targets are ignored and
    // their impulses kept at 0 by μ = 0).
    for b in cd.s.blocks.iter_mut() {
        if let Block::Contact { mu, .. } = b {
            *mu = 0.0;
        }
    }
    for i in 0..k {
        cd.s.u_free[i] = 0.0;
        cd.s.target[i] = -cd.s.phi[i] - settings.slop;
        cd.s.lambda[i] = 0.0;
    }
    solve_rows(&mut cd.s, settings, settings.tolerance * dt);
    impulse_response(cd);
    dynamics.integrate(model, &mut state.q, &cd.s.joint.delta, 1.0);
}

/// The step's rows solved ([`contact_solver::solve_active`]) to `tolerance`, with the cap and
/// the solver of `settings`: the impulses into `lambda`, the row velocities into `u`.
fn solve_rows(s: &mut ContactScratch, settings: &ContactSettings, tolerance: f64) -> Solve {
    contact_solver::solve_active(
        &s.w,
        &s.blocks,
        &s.u_free,
        &s.target,
        &mut s.lambda,
        &mut s.u,
        Stop {
            max_iterations: settings.max_iterations,
            tolerance,
        },
        &mut s.active,
        match settings.solver {
            ContactSolver::GaussSeidel => contact_solver::Method::GaussSeidel,
            ContactSolver::Subspace => contact_solver::Method::Subspace,
            ContactSolver::Newton => contact_solver::Method::Newton,
        },
    )
}

/// The gap (m) up to which a contact point counts as touching in [`drop_held_points`]: a
/// dropped point may then end a step at most this much deeper than the whole problem allows
/// (the speculative targets of touching points are within `HELD_GAP / dt` of 0).
const HELD_GAP: f64 = 1e-6;

/// Drops the contact points that other points of the same node already hold up
/// (`docs/contact.md#candidates`): in a node (rigid: one moving joint and the bodies welded to
/// it) with five or more candidate spheres of one radius, a candidate whose contact point
/// projects onto the ground plane inside the convex hull of the projections of the node's
/// *touching* candidates (`φ ≤` [`HELD_GAP`]), and which is no deeper than `slop`, is removed
/// with its rows. Its normal velocity is the same convex combination `Σ αᵢ uᵢ` of the hull
/// points' (the normal row is affine in the point's projection: `n · (ω × δn) = 0` for a
/// height offset `δ`), whose targets are 0 (or within `HELD_GAP / dt` of it), so `uᵢ ≥ bᵢ`
/// gives `u ≥ b` at the dropped point to that margin: the smaller problem's impulses, with
/// zero at the dropped points, solve the whole one. The
/// four corners of a foot and its toes' in one cluster become the corners of their outline.
fn drop_held_points(cd: &mut ContactData, n: DVec3, slop: f64) {
    let (t1, t2) = tangents(n);
    let p = &mut cd.s.patches;
    // (node, source) of every sphere candidate on a moving node, by node.
    p.members.clear();
    for (i, &(src, _)) in cd.s.sources.iter().enumerate() {
        if let Source::Sphere { body, .. } = src {
            let node = cd.s.tree.body_node[body];
            if node != NONE {
                p.members.push((node, i));
            }
        }
    }
    if p.members.len() < 5 {
        return;
    }
    p.members.sort_unstable();
    p.keep.clear();
    p.keep.resize(cd.s.sources.len(), true);
    let mut dropped = false;
    let mut first = 0;
    while first < p.members.len() {
        let node = p.members[first].0;
        let end = first
            + p.members[first..]
                .iter()
                .take_while(|m| m.0 == node)
                .count();
        let group = first..end;
        first = end;
        if group.len() < 5 {
            continue;
        }
        let radius = |i: usize| match cd.s.sources[i].0 {
            Source::Sphere { sphere, .. } => cd.shape.collision.spheres[sphere].radius,
            Source::Limit { .. } => f64::NAN,
        };
        let r0 = radius(p.members[group.start].1);
        if p.members[group.clone()].iter().any(|m| radius(m.1) != r0) {
            continue;
        }
        // The contact points' projections: the normal row's torque is r × n, and
        // n × (r × n) is r's component in the plane.
        let point = |i: usize| {
            let row = cd.s.sources[i].1;
            let r = n.cross(cd.s.wrench[row].n);
            (t1.dot(r), t2.dot(r))
        };
        // The convex hull (counter-clockwise, no collinear vertices) of the touching points.
        p.points.clear();
        p.points.extend(
            p.members[group.clone()]
                .iter()
                .filter(|m| cd.s.phi[cd.s.sources[m.1].1] <= HELD_GAP)
                .map(|m| point(m.1)),
        );
        if p.points.len() < 3 {
            continue;
        }
        convex_hull(&mut p.points, &mut p.hull);
        if p.hull.len() < 3 {
            continue;
        }
        // Relative to the outline's size: points on its edges (collinear corners) count.
        let scale = p
            .hull
            .iter()
            .map(|&(x, y)| x.abs().max(y.abs()))
            .fold(0.0, f64::max);
        let eps = 1e-12 * scale * scale;
        for m in &p.members[group] {
            let (x, y) = point(m.1);
            if p.hull.contains(&(x, y)) || cd.s.phi[cd.s.sources[m.1].1] < -slop {
                continue;
            }
            let inside = (0..p.hull.len()).all(|e| {
                let (ax, ay) = p.hull[e];
                let (bx, by) = p.hull[(e + 1) % p.hull.len()];
                (bx - ax) * (y - ay) - (by - ay) * (x - ax) >= -eps
            });
            if inside {
                p.keep[m.1] = false;
                dropped = true;
            }
        }
    }
    if !dropped {
        return;
    }
    // Compact the rows of the kept blocks (blocks and sources are in the same order).
    let mut to = 0;
    for b in 0..cd.s.sources.len() {
        let (src, row) = cd.s.sources[b];
        let rows = match src {
            Source::Sphere { .. } => 3,
            Source::Limit { .. } => 1,
        };
        if !cd.s.patches.keep[b] {
            continue;
        }
        let new_row = to;
        for j in 0..rows {
            cd.s.phi[new_row + j] = cd.s.phi[row + j];
            cd.s.wrench[new_row + j] = cd.s.wrench[row + j];
            cd.s.target[new_row + j] = cd.s.target[row + j];
        }
        to += rows;
        cd.s.sources[b].1 = new_row;
        cd.s.blocks[b] = match cd.s.blocks[b] {
            Block::Unilateral { .. } => Block::Unilateral { row: new_row },
            Block::Contact { mu, .. } => Block::Contact { row: new_row, mu },
        };
    }
    cd.s.phi.truncate(to);
    cd.s.wrench.truncate(to);
    cd.s.target.truncate(to);
    let keep = &cd.s.patches.keep;
    let mut b = 0;
    cd.s.sources.retain(|_| {
        b += 1;
        keep[b - 1]
    });
    let mut b = 0;
    cd.s.blocks.retain(|_| {
        b += 1;
        keep[b - 1]
    });
}

/// The convex hull of `points` (Andrew's monotone chain) into `hull`, counter-clockwise,
/// without collinear vertices; `points` is sorted on return.
fn convex_hull(points: &mut [(f64, f64)], hull: &mut Vec<(f64, f64)>) {
    points.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    // The lower chain left to right, then the upper one right to left.
    let chain = |hull: &mut Vec<(f64, f64)>, q: (f64, f64), start: usize| {
        while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0
        {
            hull.pop();
        }
        hull.push(q);
    };
    hull.clear();
    for &q in points.iter() {
        chain(hull, q, 0);
    }
    hull.pop();
    let start = hull.len();
    for &q in points.iter().rev() {
        chain(hull, q, start);
    }
    hull.pop();
}

/// Row `i`'s value for a motion whose node velocities (or accelerations) `node` gives and
/// whose joint rates `joint` gives: `wᵢ · v` for a contact row, `±q̇_j` for a joint bound.
fn row_value(
    cd: &ContactData,
    i: usize,
    node: impl Fn(usize) -> SpatialMotion,
    joint: impl Fn(usize) -> f64,
) -> f64 {
    match cd.s.row_bound[i] {
        usize::MAX => cd.s.wrench[i].dot(node(cd.s.row_node[i])),
        li => {
            let b = cd.shape.bounds[li];
            b.sign * joint(b.vi)
        }
    }
}

/// Fills `cd.s.w` (`k × k`, row-major, exactly symmetric) with `W = J M⁻¹ Jᵀ`, one entry per
/// pair `i ≤ j` from the response to row `j`'s load (`docs/contact.md#cost`). The `m` nodes
/// carrying contact rows are the contact nodes; `Φ_ab` (6 × 6) is node `a`'s acceleration
/// for a unit wrench on node `b`, and a contact row `i` on node `a(i)` with wrench `wᵢ` has
/// `W_ij = wᵢᵀ Φ_{a(i) b(j)} w_j`. Per contact node `b`, whichever is cheaper by
/// [`Tree::column_cost`]: its 6 unit-wrench columns read at the contact nodes (`Φ_{·b}`), each
/// of its rows then `Y_j = Φ_{·b} w_j` and `W_ij = wᵢ · Y_j^{a(i)}`; or one column per row,
/// read at every row. A joint bound has its own column (bounds are the last rows, so a `Φ`
/// column only meets contact rows).
///
/// `Φ` and the wrenches are taken in the contact frame `frame` (`[n, t₁, t₂]`, world axes
/// rotated): there a row's wrench `(ρ × e_d, e_d)` (`ρ` its contact point, `d` its direction)
/// has 3 entries, so `Y_j` costs 18m and `W_ij` 3 products.
fn delassus(cd: &mut ContactData, frame: Option<[DVec3; 3]>) {
    let k = cd.s.phi.len();
    // Every entry is written below (no zeroing).
    if cd.s.w.len() < k * k {
        cd.s.w.resize(k * k, 0.0);
    }
    cd.s.w.truncate(k * k);
    cd.columns = 0;
    // The contact nodes, each row's slot among them, and per node its contact rows
    // (`node_rows`, `node_slot`: reset after use).
    let nodes = cd.s.tree.len();
    if cd.s.node_rows.len() < nodes {
        cd.s.node_rows.resize(nodes, 0);
        cd.s.node_slot.resize(nodes, NONE);
    }
    cd.s.contact_nodes.clear();
    cd.s.row_slot.clear();
    for i in 0..k {
        let node = cd.s.row_node[i];
        let slot = if cd.s.row_bound[i] == usize::MAX && node != NONE {
            if cd.s.node_slot[node] == NONE {
                cd.s.node_slot[node] = cd.s.contact_nodes.len();
                cd.s.contact_nodes.push(node);
            }
            cd.s.node_rows[node] += 1;
            cd.s.node_slot[node]
        } else {
            NONE
        };
        cd.s.row_slot.push(slot);
    }
    let m = cd.s.contact_nodes.len();
    // Per contact node: by its 6 unit wrenches (Φ) or a column per row, by cost. A column
    // costs `c`; `Φ_{·b}` costs 6 columns and 6m reads (18 each), then 18m per row.
    cd.s.slot_basis.clear();
    for s in 0..m {
        let node = cd.s.contact_nodes[s];
        let (r, c) = (cd.s.node_rows[node], cd.s.tree.column_cost(node));
        cd.s.slot_basis.push(if 6 * c + 18 * m * (r + 6) < r * c {
            Basis::Pending
        } else {
            Basis::Rows
        });
    }
    // The contact rows' wrenches in the contact frame: the moment's components off the
    // row's direction (on it, `ρ × e_d` has none) and the unit force.
    cd.s.local.clear();
    if let Some(fr) = frame {
        for i in 0..k {
            let d = cd.s.row_dir[i];
            cd.s.local.push(if d < 3 {
                let n = cd.s.wrench[i].n;
                let (a, b) = ((d + 1) % 3, (d + 2) % 3);
                ([a, b, 3 + d], [fr[a].dot(n), fr[b].dot(n), 1.0])
            } else {
                ([0; 3], [0.0; 3])
            });
        }
    }
    if cd.s.phi_op.len() < 36 * m * m {
        cd.s.phi_op.resize(36 * m * m, [0.0; 6]);
    }
    cd.s.y.resize(m, [0.0; 6]);
    for j in 0..k {
        let node = cd.s.row_node[j];
        let sb = cd.s.row_slot[j];
        if let (Some(fr), true) = (frame, sb != NONE && cd.s.slot_basis[sb] != Basis::Rows) {
            // Φ_{·b}[c][s] at cd.s.phi_op[(sb 6 + c) m + s]: slot s's acceleration for the unit
            // wrench c on this node (contact frame).
            let at = |c: usize, s: usize| (sb * 6 + c) * m + s;
            if cd.s.slot_basis[sb] == Basis::Pending {
                for c in 0..6 {
                    let (e, z) = (fr[c % 3], DVec3::ZERO);
                    let load = if c < 3 {
                        SpatialForce::new(e, z)
                    } else {
                        SpatialForce::new(z, e)
                    };
                    cd.s.tree.column(node, Load::Wrench(load));
                    cd.columns += 1;
                    for s in 0..m {
                        let a = cd.s.tree.accel(cd.s.contact_nodes[s]);
                        let (w, v) = (a.w, a.v);
                        cd.s.phi_op[at(c, s)] = [
                            fr[0].dot(w),
                            fr[1].dot(w),
                            fr[2].dot(w),
                            fr[0].dot(v),
                            fr[1].dot(v),
                            fr[2].dot(v),
                        ];
                    }
                }
                cd.s.slot_basis[sb] = Basis::Ready;
            }
            // Y_j = Φ_{·b} w_j at every contact node.
            let (cj, xj) = cd.s.local[j];
            for s in 0..m {
                let (p0, p1, p2) = (
                    &cd.s.phi_op[at(cj[0], s)],
                    &cd.s.phi_op[at(cj[1], s)],
                    &cd.s.phi_op[at(cj[2], s)],
                );
                cd.s.y[s] = std::array::from_fn(|r| xj[0] * p0[r] + xj[1] * p1[r] + xj[2] * p2[r]);
            }
            let (wj, wt) = cd.s.w.split_at_mut(j * k);
            for (i, ((&s, &(ci, xi)), x)) in cd.s.row_slot[..=j]
                .iter()
                .zip(&cd.s.local[..=j])
                .zip(&mut wt[..=j])
                .enumerate()
            {
                debug_assert_eq!(cd.s.row_bound[i], usize::MAX, "bounds are the last rows");
                *x = if s == NONE {
                    0.0
                } else {
                    let y = &cd.s.y[s];
                    xi[0] * y[ci[0]] + xi[1] * y[ci[1]] + xi[2] * y[ci[2]]
                };
                if i < j {
                    wj[i * k + j] = *x;
                }
            }
        } else {
            let load = match cd.s.row_bound[j] {
                usize::MAX => Load::Wrench(cd.s.wrench[j]),
                li => {
                    let bd = cd.shape.bounds[li];
                    Load::Tau {
                        dof: bd.vi - cd.s.tree.v_offset(node),
                        value: bd.sign,
                    }
                }
            };
            cd.s.tree.column(node, load);
            cd.columns += 1;
            for i in 0..=j {
                let x = column_value(cd, i);
                cd.s.w[j * k + i] = x;
                cd.s.w[i * k + j] = x;
            }
        }
    }
    for &node in &cd.s.contact_nodes {
        cd.s.node_rows[node] = 0;
        cd.s.node_slot[node] = NONE;
    }
}

/// Row `i`'s value of the tree's last response column.
fn column_value(cd: &ContactData, i: usize) -> f64 {
    let node = cd.s.row_node[i];
    row_value(
        cd,
        i,
        |n| cd.s.tree.accel(n),
        |dof| {
            if node == NONE {
                0.0
            } else {
                cd.s.tree.joint_accel(node, dof - cd.s.tree.v_offset(node))
            }
        },
    )
}

/// The solve's impulses over `dt` into `cd.forces`: per body its rows' `Σ λᵢ wᵢ / dt` (the
/// rows' wrenches are about the computation frame's `origin`; about the world origin the
/// moment gains `origin × f`), per pushing bound `λ sign / dt`.
fn record_forces(cd: &mut ContactData, origin: DVec3, dt: f64) {
    for &(src, row) in &cd.s.sources {
        match src {
            Source::Sphere { body, .. } => {
                let mut f = SpatialForce::ZERO;
                for r in row..row + 3 {
                    let w = cd.s.wrench[r];
                    f += SpatialForce::new(w.n * cd.s.lambda[r], w.f * cd.s.lambda[r]);
                }
                if f == SpatialForce::ZERO {
                    continue;
                }
                let f = SpatialForce::new((f.n + origin.cross(f.f)) / dt, f.f / dt);
                match cd.forces.wrenches.iter_mut().find(|(b, _)| *b == body) {
                    Some((_, w)) => *w += f,
                    None => cd.forces.wrenches.push((body, f)),
                }
            }
            Source::Limit { limit } => {
                let l = cd.s.lambda[row];
                if l > 0.0 {
                    let b = cd.shape.bounds[limit];
                    cd.forces.torques.push((b.vi, l * b.sign / dt));
                }
            }
        }
    }
}

/// `cd.s.joint.delta = M⁻¹ Jᵀ λ`: the rows' impulses gathered per node (wrenches) and per joint
/// (bounds), then one pass over the tree. `node_wrench` and `tau` are zero between calls:
/// only the rows' entries are set, and reset afterwards.
fn impulse_response(cd: &mut ContactData) {
    if cd.s.node_wrench.len() < cd.s.tree.len() {
        cd.s.node_wrench.resize(cd.s.tree.len(), [0.0; 6]);
    }
    for i in 0..cd.s.phi.len() {
        let (l, node) = (cd.s.lambda[i], cd.s.row_node[i]);
        if l == 0.0 || node == NONE {
            continue;
        }
        match cd.s.row_bound[i] {
            usize::MAX => {
                let w = cd.s.wrench[i].to_array();
                let f = &mut cd.s.node_wrench[node];
                for r in 0..6 {
                    f[r] += l * w[r];
                }
            }
            li => {
                let b = cd.shape.bounds[li];
                cd.s.joint.tau[b.vi] += l * b.sign;
            }
        }
    }
    cd.s.tree
        .solve(&cd.s.joint.tau, &cd.s.node_wrench, &mut cd.s.joint.delta);
    for i in 0..cd.s.phi.len() {
        let node = cd.s.row_node[i];
        match cd.s.row_bound[i] {
            _ if node == NONE => {}
            usize::MAX => cd.s.node_wrench[node] = [0.0; 6],
            li => cd.s.joint.tau[cd.shape.bounds[li].vi] = 0.0,
        }
    }
}

/// The end-of-step check: no NaN or infinity in `q` or `q̇`.
fn finish(model: &Model, state: &State) -> Result<(), ContactError> {
    Ok(check_step_result(model, state)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{forward_kinematics, mass_matrix};
    use glam::DQuat;

    /// `M x = b` by Cholesky (dense, row-major `n × n`; test reference only).
    fn spd_solve(m: &[f64], n: usize, b: &mut [f64]) {
        let mut l = m.to_vec();
        for j in 0..n {
            let d = (l[j * n + j] - (0..j).map(|k| l[j * n + k].powi(2)).sum::<f64>()).sqrt();
            l[j * n + j] = d;
            for i in j + 1..n {
                let s: f64 = (0..j).map(|k| l[i * n + k] * l[j * n + k]).sum();
                l[i * n + j] = (l[i * n + j] - s) / d;
            }
        }
        for i in 0..n {
            b[i] = (b[i] - (0..i).map(|k| l[i * n + k] * b[k]).sum::<f64>()) / l[i * n + i];
        }
        for i in (0..n).rev() {
            b[i] = (b[i] - (i + 1..n).map(|k| l[k * n + i] * b[k]).sum::<f64>()) / l[i * n + i];
        }
    }

    /// The broad phase keeps exactly the candidates of the per-sphere test: the floating
    /// humanoid tumbling at random poses and velocities (every joint moving, up to 20 rad/s and 20 m/s, 50 ms steps: the approach speed matters)
    /// with its lowest point from 5 cm below to 60 cm above the floor, candidates compared
    /// with every sphere's `φ < margin + dt max(−u⁻, 0)` from the same kinematics.
    #[test]
    fn broad_phase_keeps_every_candidate() {
        let model = articula_testkit::bundled_with("humanoid", true);
        let mut data = Data::new(&model);
        let mut cd = ContactData::new(&model);
        assert!(cd.shape.runs.len() >= 10 && cd.shape.runs.len() < cd.collision().spheres.len());
        let mut rng = crate::state::SplitMix64(26);
        let settings = ContactSettings {
            ground: Some(Ground::horizontal(0.0)),
            ..Default::default()
        };
        let dt = 0.05;
        let (mut skipped, mut kept) = (0, 0);
        for trial in 0..200 {
            let mut state = State::random(&model, 1000 + trial, 1.0);
            for v in state.qd.iter_mut() {
                *v = rng.uniform(-20.0, 20.0);
            }
            forward_kinematics(&model, &state.q, &state.qd, &mut data).unwrap();
            let lowest = cd.lowest_point(&data);
            state.q[2] += rng.uniform(-0.05, 0.6) - lowest;
            forward_kinematics(&model, &state.q, &state.qd, &mut data).unwrap();
            let expected: Vec<usize> = (cd.collision().spheres.iter().enumerate())
                .filter(|(_, s)| {
                    let c = sphere_center(&data, s, DVec3::Z);
                    let phi = (c + data.origin).z - s.radius;
                    let v = data.v[s.body];
                    let pre = (v.v + v.w.cross(c - DVec3::Z * s.radius)).z;
                    phi < settings.margin + dt * (-pre).max(0.0)
                })
                .map(|(i, _)| i)
                .collect();
            step_with_contact(
                &model,
                &mut data,
                &mut cd,
                &mut state,
                Method::Aba,
                dt,
                &settings,
            )
            .unwrap();
            let found: Vec<usize> =
                cd.s.sources
                    .iter()
                    .filter_map(|(s, _)| match *s {
                        Source::Sphere { sphere, .. } => Some(sphere),
                        Source::Limit { .. } => None,
                    })
                    .collect();
            // Every candidate is found (and some may then be dropped as held up by others:
            // `drop_held_points`).
            assert_eq!(cd.stats.candidates, expected.len(), "trial {trial}");
            assert!(found.iter().all(|i| expected.contains(i)), "trial {trial}");
            kept += expected.len();
            skipped += cd.collision().spheres.len() - expected.len();
        }
        // Both sides of the test are exercised.
        assert!(
            kept > 1000 && skipped > 3 * kept,
            "kept {kept}, skipped {skipped}"
        );
    }

    /// The floating humanoid lying on its side, falling onto the floor (horizontal, and
    /// tilted) with every joint moving and one joint hitting its bound: the tree's Delassus
    /// operator `W` equals the dense `J M⁻¹ Jᵀ` (CRBA's `M`, a Cholesky solve) and the step's
    /// velocity change is `M⁻¹ Jᵀ λ`, both to rounding. With armature `a` and damping `b` on
    /// the joints, `M` is the free motion's `M + diag(a + dt·b)` (damping implicit over the
    /// step) in both.
    #[test]
    fn tree_delassus_matches_the_dense_operator() {
        // On the floor and on a plane tilted about both horizontal axes (a contact frame
        // that is no permutation of the world axes).
        let tilted = Ground {
            normal: DVec3::new(0.2, -0.1, 1.0),
            ..Ground::horizontal(0.0)
        };
        // (A small margin: few rows per body, columns by row.)
        let (mut by_phi, mut by_row) = (false, false);
        let dt = 1e-3;
        for (ground, margin, passive) in [
            (Ground::horizontal(0.0), 0.3, false),
            (tilted, 0.3, false),
            (Ground::horizontal(0.0), 0.01, false),
            (Ground::horizontal(0.0), 0.3, true),
        ] {
            let mut model = articula_testkit::bundled_with("humanoid", true);
            let nv = model.nv;
            // The joints' (not the floating base's): armature 0.01–0.03 kg·m², damping 2–6
            // N·m·s/rad, as large on the light distal joints as M's own diagonal there.
            let (armature, damping): (Vec<f64>, Vec<f64>) = (0..nv)
                .map(|i| match (passive, i >= 6) {
                    (true, true) => (0.01 * (1 + i % 3) as f64, 2.0 * (1 + i % 3) as f64),
                    _ => (0.0, 0.0),
                })
                .unzip();
            if passive {
                model.dynamics.armature = armature;
                model.dynamics.damping = damping.clone();
            }
            let mut data = Data::new(&model);
            let mut cd = ContactData::new(&model);
            let mut state = State::neutral(&model);
            let r = DQuat::from_rotation_x(std::f64::consts::FRAC_PI_2);
            state.q[3..7].copy_from_slice(&[r.w, r.x, r.y, r.z]);
            for (i, v) in state.qd.iter_mut().enumerate() {
                *v = 0.3 * ((i as f64) * 1.7).sin();
            }
            state.qd[2] = -0.5;
            let b = cd.shape.bounds[0];
            // Inside its range by 1 mrad, closing at 2 rad/s (no penetration: no position
            // correction, so `lambda` holds the velocity impulses on return).
            state.q[b.qi] = b.bound + 1e-3 * b.sign;
            state.qd[b.vi] = -2.0 * b.sign;
            forward_kinematics(&model, &state.q, &state.qd, &mut data).unwrap();
            // The lowest sphere 0.5 mm above the plane.
            let nh = ground.normal.normalize();
            let gap = (cd.collision().spheres.iter())
                .map(|s| {
                    let c = sphere_center(&data, s, nh) + data.origin;
                    nh.dot(c - ground.point) - s.radius
                })
                .fold(f64::INFINITY, f64::min);
            state.q[2] += (5e-4 - gap) / nh.z;
            let q0 = state.q.clone();
            let settings = ContactSettings {
                ground: Some(ground),
                // Every sphere within 0.3 m a candidate: many bodies, many rows.
                margin,
                ..Default::default()
            };
            step_with_contact(
                &model,
                &mut data,
                &mut cd,
                &mut state,
                Method::Aba,
                dt,
                &settings,
            )
            .unwrap();
            let k = cd.stats.rows;
            // (The small margin meets the lying limbs' one rim point per cap: fewer rows.)
            let least = if margin > 0.1 { 20 } else { 10 };
            assert!(k >= least && cd.stats.limits >= 1, "{:?}", cd.stats);
            by_phi |= cd.s.slot_basis.contains(&Basis::Ready);
            by_row |= cd.s.slot_basis.contains(&Basis::Rows);
            // Dense J from the start-of-step kinematics (still in `data`).
            let mut jac = vec![0.0; k * nv];
            for i in 0..k {
                match cd.s.row_bound[i] {
                    usize::MAX => {
                        let body =
                            cd.s.sources
                                .iter()
                                .rev()
                                .find(|s| s.1 <= i)
                                .map(|s| match s.0 {
                                    Source::Sphere { body, .. } => body,
                                    Source::Limit { .. } => unreachable!(),
                                })
                                .unwrap();
                        let mut at = Some(body);
                        while let Some(bi) = at {
                            let bd = &model.bodies[bi];
                            for j in bd.v_offset..bd.v_offset + bd.nv {
                                jac[i * nv + j] = data.s[j].dot(cd.s.wrench[i]);
                            }
                            at = bd.parent;
                        }
                    }
                    li => jac[i * nv + cd.shape.bounds[li].vi] = cd.shape.bounds[li].sign,
                }
            }
            let mut md = Data::new(&model);
            let mut m = mass_matrix(&model, &mut md, &q0).unwrap().to_vec();
            for (i, b) in damping.iter().enumerate() {
                m[i * nv + i] += dt * b;
            }
            let mut worst = 0.0f64;
            let scale = cd.s.w.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            for j in 0..k {
                let mut x = jac[j * nv..(j + 1) * nv].to_vec();
                spd_solve(&m, nv, &mut x);
                for i in 0..k {
                    let want: f64 = (0..nv).map(|c| jac[i * nv + c] * x[c]).sum();
                    worst = worst.max((cd.s.w[i * k + j] - want).abs());
                }
            }
            assert!(
                worst <= 1e-10 * scale,
                "W off by {worst:e} (scale {scale:e})"
            );
            // q̇⁺ − v_free = M⁻¹ Jᵀ λ.
            let mut want: Vec<f64> = (0..nv)
                .map(|c| (0..k).map(|i| jac[i * nv + c] * cd.s.lambda[i]).sum())
                .collect();
            spd_solve(&m, nv, &mut want);
            let mut off = 0.0f64;
            for c in 0..nv {
                off = off.max((state.qd[c] - cd.s.joint.qd_free[c] - want[c]).abs());
            }
            let big = want.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            assert!(
                big > 1e-3 && off <= 1e-10 * big,
                "Δq̇ off by {off:e} of {big:e}"
            );
        }
        // Both ways of making W's columns are used.
        assert!(by_phi && by_row);
    }
}
