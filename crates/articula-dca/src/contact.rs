//! Ground contact and joint limits in the semi-implicit Euler step
//! ([`step_with_contact`], `docs/contact.md`, `docs/design.md#contact`).
//!
//! One step from `(q, q̇)`:
//!
//! 1. free motion `v_free = q̇ + dt M⁻¹(τ − C)` (forward dynamics by the step's [`Method`]);
//! 2. candidate rows at `q`: every contact sphere of [`CollisionModel`] whose gap to the
//!    ground `φ = n·(c − p₀) − r` is below `margin` plus the distance it can close in the step,
//!    with a normal row and two tangent rows; every limited joint within `margin` of a bound;
//! 3. `R = M⁻¹ Jᵀ` column by column: the response of the model at rest without gravity to the
//!    generalised force `J_iᵀ` is one forward-dynamics solve (`q̈ = M⁻¹ τ`); a body with 6 or
//!    more rows is solved once per unit wrench (6 solves) and its rows combine those;
//! 4. `W = J R` and `λ` by projected Gauss–Seidel (`contact_solver`), warm-started from the
//!    previous step's impulses at the same contact spheres and limits;
//! 5. `q̇⁺ = v_free + R λ`, `q⁺ = q ⊕ dt q̇⁺`;
//! 6. post-stabilisation: where a row penetrates deeper than `slop`, `q⁺ ← q⁺ ⊕ R μ` with
//!    `μ ≥ 0` the smallest push-out (`J R μ ≥ −φ − slop`, same solver, no friction) — a
//!    position change only, so it adds no kinetic energy.
//!
//! Targets: a row whose gap `φ > 0` may close it but not cross it (`u ≥ −φ/dt`, speculative
//! contact: no impact is missed); a contact whose gap closes within the step at its
//! start-of-step approach speed `u⁻`, faster than `restitution_velocity`, leaves at `−e u⁻`
//! (the bounce starts up to `|u⁻| dt` early: the ball turns a little above the floor).

use crate::contact_solver::{self, Block, Stop};
use crate::integrate::check_step_result;
use crate::{
    forward_dynamics, forward_dynamics_slices, integrate_q, Data, DynamicsError, Method, State,
};
use articula_model::{CollisionModel, Model};
use articula_spatial::SpatialForce;
use glam::DVec3;
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
    /// Gauss–Seidel sweeps at most (default 200).
    pub max_iterations: usize,
    /// Stop when no sweep changes a row velocity by more than this (default 1e-9, m/s or
    /// rad/s).
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
    /// Candidate contact spheres (3 rows each).
    pub candidates: usize,
    /// Contact spheres pushed by the ground (`λ_n > 0`).
    pub contacts: usize,
    /// Joint limits pushing (`λ > 0`).
    pub limits: usize,
    /// Rows of the contact problem (`k`).
    pub rows: usize,
    /// Forward-dynamics solves for `M⁻¹ Jᵀ` (each O(n)).
    pub response_solves: usize,
    /// Gauss–Seidel sweeps.
    pub iterations: usize,
    /// Whether the sweeps met `tolerance`.
    pub converged: bool,
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
/// allocates only when it meets more rows than any step before.
#[derive(Clone, Debug)]
pub struct ContactData {
    /// The model's contact spheres.
    pub collision: CollisionModel,
    /// Figures of the last step.
    pub stats: ContactStats,
    bounds: Vec<Bound>,
    /// Per block: its source and first row.
    sources: Vec<(Source, usize)>,
    blocks: Vec<Block>,
    /// Per row: the gap (normal and limit rows; 0 for tangents).
    phi: Vec<f64>,
    /// Per row: the wrench (contact rows, computation frame) whose power is the row velocity.
    wrench: Vec<SpatialForce>,
    jac: Vec<f64>,
    resp: Vec<f64>,
    w: Vec<f64>,
    u_free: Vec<f64>,
    target: Vec<f64>,
    lambda: Vec<f64>,
    u: Vec<f64>,
    /// Warm starts: per contact sphere `[λ_n, λ_t1, λ_t2]`, per bound `λ`.
    warm_spheres: Vec<[f64; 3]>,
    warm_bounds: Vec<f64>,
    qd_free: Vec<f64>,
    zero: Vec<f64>,
    tau: Vec<f64>,
    basis: Vec<f64>,
    delta: Vec<f64>,
    /// The coordinates some response moves, and `J`, `R` packed on them (`W = J R`).
    cols: Vec<usize>,
    packed: Vec<f64>,
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
        let nv = model.nv;
        ContactData {
            warm_spheres: vec![[0.0; 3]; collision.spheres.len()],
            warm_bounds: vec![0.0; bounds.len()],
            collision,
            stats: ContactStats::default(),
            bounds,
            sources: Vec::new(),
            blocks: Vec::new(),
            phi: Vec::new(),
            wrench: Vec::new(),
            jac: Vec::new(),
            resp: Vec::new(),
            w: Vec::new(),
            u_free: Vec::new(),
            target: Vec::new(),
            lambda: Vec::new(),
            u: Vec::new(),
            qd_free: vec![0.0; nv],
            zero: vec![0.0; nv],
            tau: vec![0.0; nv],
            basis: Vec::new(),
            delta: vec![0.0; nv],
            cols: Vec::with_capacity(nv),
            packed: Vec::new(),
        }
    }

    /// The number of joint bounds enforced when `joint_limits` is set (two per limited joint).
    pub fn joint_bounds(&self) -> usize {
        self.bounds.len()
    }
}

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

/// Two unit tangents completing the unit normal `n` to a right-handed frame.
fn tangents(n: DVec3) -> (DVec3, DVec3) {
    let helper = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let t1 = (helper - n * n.dot(helper)).normalize();
    (t1, n.cross(t1))
}

/// The dynamics under a contact step ([`step_with_dynamics`]): the free motion, the
/// kinematics the rows are read from, and the response `M⁻¹ τ` of the system at rest. Exact
/// dynamics ([`ExactDynamics`]: DCA, ABA or CRBA) and articula-adaptive's hybrid body (its
/// locked joints stay locked, a rigid cluster moves as one) implement it; detection, the
/// rows, the solve and the position correction are shared.
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

    /// Whether body `body`'s joint moves in this step (its columns of `J` are used; default
    /// every joint).
    fn moves(&self, _model: &Model, _body: usize) -> bool {
        true
    }

    /// The response to the generalised impulse `tau` of the system at rest without gravity,
    /// `out = M⁻¹ τ` (every entry written; 0 for a joint that does not move). Called after
    /// every row has read [`ContactDynamics::kinematics`] (it may overwrite them).
    fn response(
        &mut self,
        model: &Model,
        state: &State,
        tau: &[f64],
        out: &mut [f64],
    ) -> Result<(), DynamicsError>;

    /// `q ← q ⊕ h v` over the joints that move (default: all, [`integrate_q`]).
    fn integrate(&self, model: &Model, q: &mut [f64], v: &[f64], h: f64) {
        integrate_q(model, q, v, h);
    }
}

/// Exact forward dynamics under a contact step: `free_motion` and every response are one
/// forward-dynamics solve by `method` (O(n) with DCA or ABA), in the workspace `data`.
struct ExactDynamics<'a> {
    data: &'a mut Data,
    method: Method,
    /// `nv` zeros (the velocities of the system at rest).
    zero: &'a [f64],
}

impl ContactDynamics for ExactDynamics<'_> {
    fn free_motion(
        &mut self,
        model: &Model,
        state: &mut State,
        qdd: &mut [f64],
    ) -> Result<(), DynamicsError> {
        qdd.copy_from_slice(forward_dynamics(model, self.data, state, self.method)?);
        Ok(())
    }

    fn kinematics(&self) -> &Data {
        self.data
    }

    fn response(
        &mut self,
        model: &Model,
        state: &State,
        tau: &[f64],
        out: &mut [f64],
    ) -> Result<(), DynamicsError> {
        let gravity = std::mem::replace(&mut self.data.gravity, DVec3::ZERO);
        let r =
            forward_dynamics_slices(model, self.data, &state.q, self.zero, tau, &[], self.method)
                .map(|qdd| out.copy_from_slice(qdd));
        self.data.gravity = gravity;
        r
    }
}

/// The degrees of freedom between the root and body `b` whose joints move, visited leaf to
/// root.
fn path_dofs<D: ContactDynamics + ?Sized>(
    model: &Model,
    dynamics: &D,
    b: usize,
    mut f: impl FnMut(usize),
) {
    let mut body = Some(b);
    while let Some(i) = body {
        let bd = &model.bodies[i];
        if dynamics.moves(model, i) {
            (bd.v_offset..bd.v_offset + bd.nv).for_each(&mut f);
        }
        body = bd.parent;
    }
}

/// Advances `state` by `dt` with semi-implicit Euler, forward dynamics by `method`, and the
/// ground contact and joint limits of `settings` (module documentation). Without a ground and
/// with `joint_limits` off this is the plain semi-implicit Euler step (without the momentum
/// projection of [`crate::step`]: contact impulses are external). On return, `contact.stats`
/// holds the step's figures and `data` the kinematics of the last response solve (at the
/// start-of-step `q`).
///
/// Cost: one forward dynamics for the free motion, then one per column of `M⁻¹ Jᵀ` — per
/// contacting body `min(6, its rows)`, per active limit 1 — each O(n); `W` costs O(k² n) and a
/// Gauss–Seidel sweep O(k²) for `k` rows.
pub fn step_with_contact(
    model: &Model,
    data: &mut Data,
    contact: &mut ContactData,
    state: &mut State,
    method: Method,
    dt: f64,
    settings: &ContactSettings,
) -> Result<(), ContactError> {
    // (The zeros lent out and back: no allocation.)
    let zero = std::mem::take(&mut contact.zero);
    let mut dynamics = ExactDynamics {
        data,
        method,
        zero: &zero,
    };
    let r = step_with_dynamics(model, &mut dynamics, contact, state, dt, settings);
    contact.zero = zero;
    r
}

/// [`step_with_contact`] on any [`ContactDynamics`]: the free motion, the rows' kinematics,
/// the responses and the integration come from `dynamics`; detection, the rows, the
/// Gauss–Seidel solve and the position correction are the same for every dynamics.
pub fn step_with_dynamics<D: ContactDynamics + ?Sized>(
    model: &Model,
    dynamics: &mut D,
    contact: &mut ContactData,
    state: &mut State,
    dt: f64,
    settings: &ContactSettings,
) -> Result<(), ContactError> {
    let ground = check(settings, dt)?;
    let nv = model.nv;
    let cd = contact;
    cd.stats = ContactStats::default();
    // 1. Free motion.
    dynamics.free_motion(model, state, &mut cd.delta)?;
    for ((f, v), a) in cd.qd_free.iter_mut().zip(&state.qd).zip(&cd.delta) {
        *f = v + dt * a;
    }
    let data = dynamics.kinematics();
    // 2. Candidates, from the kinematics of the start of the step.
    cd.sources.clear();
    cd.blocks.clear();
    cd.phi.clear();
    cd.wrench.clear();
    cd.target.clear();
    if let Some((g, n)) = ground {
        let (t1, t2) = tangents(n);
        for (si, s) in cd.collision.spheres.iter().enumerate() {
            let c = data.x[s.body].apply_point(s.center);
            let phi = n.dot(c + data.origin - g.point) - s.radius;
            cd.stats.max_penetration = cd.stats.max_penetration.max(-phi);
            let r = c - n * s.radius;
            let v = data.v[s.body];
            let pre = n.dot(v.v + v.w.cross(r));
            if phi >= settings.margin + dt * (-pre).max(0.0) {
                continue;
            }
            let row = cd.phi.len();
            cd.sources.push((
                Source::Sphere {
                    sphere: si,
                    body: s.body,
                },
                row,
            ));
            cd.blocks.push(Block::Contact {
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
                cd.wrench.push(SpatialForce::new(r.cross(d), d));
                cd.phi.push(p);
                cd.target.push(t);
            }
        }
    }
    if settings.joint_limits {
        for (li, b) in cd.bounds.iter().enumerate() {
            // A joint that does not move in this step (locked in a hybrid body) has no row.
            if !dynamics.moves(model, b.body) {
                continue;
            }
            let phi = b.sign * (state.q[b.qi] - b.bound);
            let pre = b.sign * state.qd[b.vi];
            if phi >= settings.margin + dt * (-pre).max(0.0) {
                continue;
            }
            let row = cd.phi.len();
            cd.sources.push((Source::Limit { limit: li }, row));
            cd.blocks.push(Block::Unilateral { row });
            cd.wrench.push(SpatialForce::ZERO);
            cd.phi.push(phi);
            cd.target.push(if phi > settings.slop {
                -phi / dt
            } else {
                -phi.max(0.0) / dt
            });
        }
    }
    let k = cd.phi.len();
    cd.stats.rows = k;
    cd.stats.candidates = cd
        .sources
        .iter()
        .filter(|(s, _)| matches!(s, Source::Sphere { .. }))
        .count();
    if k == 0 {
        state.qd.copy_from_slice(&cd.qd_free);
        dynamics.integrate(model, &mut state.q, &state.qd, dt);
        cd.stats.converged = true;
        return finish(model, state);
    }
    // 3. Rows of J (dense, k × nv), before the response solves overwrite the kinematics.
    cd.jac.clear();
    cd.jac.resize(k * nv, 0.0);
    for &(src, row) in &cd.sources {
        match src {
            Source::Sphere { body, .. } => {
                for i in row..row + 3 {
                    let w = cd.wrench[i];
                    let jrow = &mut cd.jac[i * nv..(i + 1) * nv];
                    path_dofs(model, dynamics, body, |j| jrow[j] = data.s[j].dot(w));
                }
            }
            Source::Limit { limit } => {
                let b = cd.bounds[limit];
                cd.jac[row * nv + b.vi] = b.sign;
            }
        }
    }
    // 4. R = M⁻¹ Jᵀ, row i of `resp` the response to row i: forward dynamics at rest, without
    //    gravity, under the generalised force Jᵢᵀ.
    cd.resp.clear();
    cd.resp.resize(k * nv, 0.0);
    responses(model, dynamics, cd, state)?;
    // 5. W = J R (symmetric), u_free = J v_free, warm start.
    //    Only the coordinates some response moves enter the products (the active ones of a
    //    hybrid body, the contacting bodies' paths): the others add exact zeros, so the sums
    //    are the full ones to the bit.
    cd.cols.clear();
    cd.cols
        .extend((0..nv).filter(|&c| (0..k).any(|i| cd.resp[i * nv + c] != 0.0)));
    let m = cd.cols.len();
    cd.packed.clear();
    cd.packed.resize(2 * k * m, 0.0);
    let (pj, pr) = cd.packed.split_at_mut(k * m);
    for i in 0..k {
        for (x, &c) in cd.cols.iter().enumerate() {
            pj[i * m + x] = cd.jac[i * nv + c];
            pr[i * m + x] = cd.resp[i * nv + c];
        }
    }
    cd.w.clear();
    cd.w.resize(k * k, 0.0);
    for i in 0..k {
        let ji = &pj[i * m..(i + 1) * m];
        for j in i..k {
            let rj = &pr[j * m..(j + 1) * m];
            let x: f64 = ji.iter().zip(rj).map(|(a, b)| a * b).sum();
            cd.w[i * k + j] = x;
            cd.w[j * k + i] = x;
        }
    }
    cd.u_free.clear();
    cd.lambda.clear();
    for i in 0..k {
        let ji = &cd.jac[i * nv..(i + 1) * nv];
        cd.u_free
            .push(ji.iter().zip(&cd.qd_free).map(|(a, b)| a * b).sum());
    }
    for &(src, _) in &cd.sources {
        match src {
            Source::Sphere { sphere, .. } => cd.lambda.extend(cd.warm_spheres[sphere]),
            Source::Limit { limit } => cd.lambda.push(cd.warm_bounds[limit]),
        }
    }
    cd.u.clear();
    cd.u.resize(k, 0.0);
    let solve = contact_solver::solve(
        &cd.w,
        &cd.blocks,
        &cd.u_free,
        &cd.target,
        &mut cd.lambda,
        &mut cd.u,
        Stop {
            max_iterations: settings.max_iterations,
            tolerance: settings.tolerance,
        },
    );
    cd.stats.iterations = solve.iterations;
    cd.stats.converged = solve.change <= settings.tolerance;
    // Warm starts for the next step: these rows' impulses, zero elsewhere.
    cd.warm_spheres.iter_mut().for_each(|x| *x = [0.0; 3]);
    cd.warm_bounds.iter_mut().for_each(|x| *x = 0.0);
    for &(src, row) in &cd.sources {
        match src {
            Source::Sphere { sphere, .. } => {
                cd.warm_spheres[sphere] = [cd.lambda[row], cd.lambda[row + 1], cd.lambda[row + 2]];
                cd.stats.contacts += (cd.lambda[row] > 0.0) as usize;
            }
            Source::Limit { limit } => {
                cd.warm_bounds[limit] = cd.lambda[row];
                cd.stats.limits += (cd.lambda[row] > 0.0) as usize;
            }
        }
    }
    // 6. q̇⁺ = v_free + R λ, q⁺ = q ⊕ dt q̇⁺.
    state.qd.copy_from_slice(&cd.qd_free);
    add_responses(&mut state.qd, &cd.resp, &cd.lambda);
    dynamics.integrate(model, &mut state.q, &state.qd, dt);
    // 7. Post-stabilisation of what penetrates deeper than the slop.
    if cd.phi.iter().any(|&p| p < -settings.slop) {
        // Normal and limit rows only: friction is off (tangent rows' targets are ignored and
        // their impulses kept at 0 by μ = 0).
        for b in cd.blocks.iter_mut() {
            if let Block::Contact { mu, .. } = b {
                *mu = 0.0;
            }
        }
        for i in 0..k {
            cd.u_free[i] = 0.0;
            cd.target[i] = -cd.phi[i] - settings.slop;
            cd.lambda[i] = 0.0;
        }
        contact_solver::solve(
            &cd.w,
            &cd.blocks,
            &cd.u_free,
            &cd.target,
            &mut cd.lambda,
            &mut cd.u,
            Stop {
                max_iterations: settings.max_iterations,
                tolerance: settings.tolerance * dt,
            },
        );
        cd.delta.iter_mut().for_each(|x| *x = 0.0);
        add_responses(&mut cd.delta, &cd.resp, &cd.lambda);
        dynamics.integrate(model, &mut state.q, &cd.delta, 1.0);
    }
    finish(model, state)
}

/// Fills `contact.resp` (row i: `M⁻¹ Jᵢᵀ`) by forward-dynamics solves at rest (`data.gravity`
/// is zero here): per body with 6 or more rows, the 6 unit wrenches in the computation frame
/// (`τ_j = s_j[m]` along its path) combined by each row's wrench; one solve per row otherwise.
fn responses<D: ContactDynamics + ?Sized>(
    model: &Model,
    dynamics: &mut D,
    cd: &mut ContactData,
    state: &State,
) -> Result<(), DynamicsError> {
    let nv = model.nv;
    let mut b = 0;
    while b < cd.sources.len() {
        let (src, row) = cd.sources[b];
        let body = match src {
            Source::Sphere { body, .. } => Some(body),
            Source::Limit { .. } => None,
        };
        // This body's run of blocks (spheres are grouped by body).
        let mut end = b + 1;
        while end < cd.sources.len()
            && body.is_some()
            && matches!(cd.sources[end].0, Source::Sphere { body: o, .. } if Some(o) == body)
        {
            end += 1;
        }
        let rows = row..cd.sources.get(end).map_or(cd.phi.len(), |s| s.1);
        if let (Some(body), true) = (body, rows.len() >= 6) {
            cd.basis.clear();
            cd.basis.resize(6 * nv, 0.0);
            for m in 0..6 {
                cd.tau.iter_mut().for_each(|x| *x = 0.0);
                let s = &dynamics.kinematics().s;
                path_dofs(model, &*dynamics, body, |j| cd.tau[j] = s[j].to_array()[m]);
                let out = &mut cd.basis[m * nv..(m + 1) * nv];
                dynamics.response(model, state, &cd.tau, out)?;
                cd.stats.response_solves += 1;
            }
            for i in rows {
                let w = cd.wrench[i].to_array();
                let r = &mut cd.resp[i * nv..(i + 1) * nv];
                for (m, wm) in w.iter().enumerate() {
                    for (x, a) in r.iter_mut().zip(&cd.basis[m * nv..(m + 1) * nv]) {
                        *x += wm * a;
                    }
                }
            }
        } else {
            for i in rows {
                let tau = &cd.jac[i * nv..(i + 1) * nv];
                dynamics.response(model, state, tau, &mut cd.resp[i * nv..(i + 1) * nv])?;
                cd.stats.response_solves += 1;
            }
        }
        b = end;
    }
    Ok(())
}

/// `out += R λ`: the responses (rows of `resp`, each `out.len()` long) weighted by `lambda`.
fn add_responses(out: &mut [f64], resp: &[f64], lambda: &[f64]) {
    let nv = out.len();
    for (l, r) in lambda.iter().zip(resp.chunks_exact(nv)) {
        if *l != 0.0 {
            for (x, ri) in out.iter_mut().zip(r) {
                *x += ri * l;
            }
        }
    }
}

/// The end-of-step check: no NaN or infinity in `q` or `q̇`.
fn finish(model: &Model, state: &State) -> Result<(), ContactError> {
    Ok(check_step_result(model, state)?)
}
