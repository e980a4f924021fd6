//! The contact problem of [`crate::contact_solver`] solved by a semismooth Newton method on
//! the Alart–Curnier equations (`docs/contact.md#solver`): hard contact, Coulomb's disc and
//! the joint limits together, to the conditions of [`residual`], in a few iterations.
//!
//! With `u = u_free + W λ` and per row a scale `ρᵢ = 1 / Wᵢᵢ` (an impulse per velocity), the
//! conditions are the zeros of
//!
//! - a unilateral row (a normal, a limit): `Φ = λ − max(0, σ)`, `σ = λ − ρ (u − b)`;
//! - a contact's tangents: `Φ_t = λ_t − proj_R(z)`, `z = λ_t − ρ_t u_t`, the projection onto
//!   the disc of radius `R = μ max(0, σ_n)`.
//!
//! A zero of `Φ` is exactly a solution: a row pushes (`σ > 0`) only on its target, else its
//! impulse is 0 and it does not approach below it; a contact inside its disc does not slip,
//! one on the rim slips against its force. Each Newton iteration reads the *status* of every
//! block at the iterate — separating (`σ ≤ 0`: its impulses are set to 0), pushing and
//! sticking (`u = b`, `u_t = 0`: rows of `W`), pushing and sliding (`λ_t = R ẑ` linearised in
//! `λ_n`, `λ_t` and `u`, which makes the system non-symmetric) — and solves one dense linear
//! system on the rows of the blocks that push: by Cholesky when every pushing contact sticks
//! (the system is then `W_FF`, symmetric), by LU with partial pivoting otherwise
//! ([`crate::contact_dense`]); a Cholesky factor is reused while the free rows repeat.
//! The redundant corners of a flat face make `W` singular: the system is factored with
//! `ε = REG · Wᵢᵢ` added to its diagonal (a proximal term) and the solution refined [`REFINE`]
//! times against the exact one, which removes most of the term's bias on the directions `W`
//! moves. A backtracking line search on
//! `Σ (Φᵢ / ρᵢ)²` (velocities squared) keeps the step from overshooting a change of status.
//!
//! The iterates of Alart–Curnier's method need not be feasible; what is tested and returned
//! is their projection (unilateral impulses clamped at 0, tangents onto their disc), so the
//! result is always feasible. Once the projection meets every condition to the tolerance
//! ([`residual`]), up to [`POLISH`] more iterations aim at [`POLISH_FACTOR`] of it (near the
//! solution a Newton step squares the error). After [`NEWTON_STEPS`] iterations, or when the
//! line search finds no decrease [`STALLS`] times, projected Gauss–Seidel ([`pgs`]) continues
//! from the best projection for what is left of the iteration cap.

use crate::contact_dense::{lu, lu_solve};
use crate::contact_solver::{
    contact_velocities, is_tangent, pgs, residual, sweep, Block, Solve, Stop,
};
use articula_spatial::numerics::{cholesky_rows, cholesky_rows_solve};

/// Newton iterations at most before the Gauss–Seidel fallback.
const NEWTON_STEPS: usize = 25;
/// Newton iterations at most after the tolerance is met.
const POLISH: usize = 2;
/// What those iterations aim at, relative to the tolerance.
const POLISH_FACTOR: f64 = 1e-3;
/// Stalls of the Newton step (no decrease) met with Gauss–Seidel sweeps before the fallback.
const STALLS: usize = 3;
/// Gauss–Seidel sweeps after a stall.
const SWEEPS_AFTER_STALL: usize = 3;
/// The proximal regularisation of the Newton systems, relative to each row's `Wᵢᵢ`.
const REG: f64 = 1e-3;
/// Refinement passes of each Newton system against the unregularised matrix.
const REFINE: usize = 2;
/// Re-solves of a Newton system after holding rows at 0, at most.
const HOLDS: usize = 4;
/// Halvings of the line search at most.
const HALVINGS: usize = 10;
/// A row with `Wᵢᵢ` below this times the largest diagonal entry moves with no impulse (its
/// body's joints are locked or welded): its impulse stays 0.
const IMMOVABLE: f64 = 1e-12;

/// The buffers of [`newton`] (grown, never shrunk).
#[derive(Clone, Debug, Default)]
pub(crate) struct Newton {
    /// Per row: `ρ = 1 / Wᵢᵢ` (a contact's tangents share `2 / (W₁₁ + W₂₂)`), 0 for a row no
    /// impulse moves.
    rho: Vec<f64>,
    /// The Alart–Curnier iterate: impulses and row velocities.
    lambda: Vec<f64>,
    u: Vec<f64>,
    /// The rows of the Newton system, and per row its place in it ([`usize::MAX`]: none).
    free: Vec<usize>,
    at: Vec<usize>,
    /// The system (`f × f`, row-major), then its LU factors, the same unregularised, the
    /// regularisation per row, and the row swaps.
    lu: Vec<f64>,
    jac: Vec<f64>,
    reg: Vec<f64>,
    piv: Vec<usize>,
    /// Right-hand side, the step on the free rows, a refinement's residual, `W_{·F} δ`.
    rhs: Vec<f64>,
    delta: Vec<f64>,
    corr: Vec<f64>,
    du: Vec<f64>,
    /// A trial point of the line search: impulses and velocities.
    trial_l: Vec<f64>,
    trial_u: Vec<f64>,
    /// Per row: held at 0 in this iteration's system (a block's first row marks it).
    held: Vec<bool>,
    /// Approach (m/s) below which a row with no impulse stays apart: half the tolerance.
    slack: f64,
    /// The system has a sliding contact (not symmetric: LU, else Cholesky).
    sliding: bool,
    /// The free rows whose Cholesky factor `lu` holds, when it does (this solve's `W`).
    factored: Vec<usize>,
    factored_valid: bool,
}

/// A block's status at an iterate (the branch of `Φ` it is on).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Status {
    /// `σ ≤ 0`: every impulse of the block 0.
    Separating,
    /// Pushing, on its target; a contact's tangents (if they move) not slipping.
    Sticking,
    /// A contact pushing and sliding: `ẑ` the unit direction of `z`, `κ = R / |z| < 1`.
    Sliding { zhat: (f64, f64), kappa: f64 },
}

/// The status of `block` at the iterate `(lambda, u)` and its `Φ / ρ` per row (velocities:
/// 0 for a row held at 0), into `phi` at the block's rows.
fn status(
    block: Block,
    target: &[f64],
    rho: &[f64],
    lambda: &[f64],
    u: &[f64],
    phi: &mut [f64; 3],
    slack: f64,
) -> Status {
    let (n, mu) = match block {
        Block::Unilateral { row } => (row, None),
        Block::Contact { row, mu } => (row, Some(mu)),
    };
    *phi = [0.0; 3];
    if rho[n] == 0.0 {
        return Status::Separating;
    }
    // (A row with no impulse approaching by less than `slack` stays apart: the kink of `Φ`
    // at λ = 0, u = b, where a Newton step cannot see the change of branch it causes.)
    let sigma = if lambda[n] <= 0.0 && u[n] - target[n] >= -slack {
        lambda[n]
    } else {
        lambda[n] - rho[n] * (u[n] - target[n])
    };
    let Some(mu) = mu else {
        if sigma > 0.0 {
            phi[0] = u[n] - target[n];
            return Status::Sticking;
        }
        phi[0] = lambda[n] / rho[n];
        return Status::Separating;
    };
    let rt = rho[n + 1];
    if sigma <= 0.0 {
        phi[0] = lambda[n] / rho[n];
        if rt > 0.0 {
            phi[1] = lambda[n + 1] / rt;
            phi[2] = lambda[n + 2] / rt;
        }
        return Status::Separating;
    }
    phi[0] = u[n] - target[n];
    if rt == 0.0 {
        return Status::Sticking;
    }
    let radius = mu * sigma;
    let (z1, z2) = (lambda[n + 1] - rt * u[n + 1], lambda[n + 2] - rt * u[n + 2]);
    let norm = (z1 * z1 + z2 * z2).sqrt();
    if norm <= radius {
        phi[1] = u[n + 1];
        phi[2] = u[n + 2];
        return Status::Sticking;
    }
    let zhat = (z1 / norm, z2 / norm);
    phi[1] = (lambda[n + 1] - radius * zhat.0) / rt;
    phi[2] = (lambda[n + 2] - radius * zhat.1) / rt;
    Status::Sliding {
        zhat,
        kappa: radius / norm,
    }
}

/// The rows of `block`: its first and how many.
fn rows(block: Block) -> (usize, usize) {
    match block {
        Block::Unilateral { row } => (row, 1),
        Block::Contact { row, .. } => (row, 3),
    }
}

/// `Σ (Φᵢ / ρᵢ)²` at `(lambda, u)`: 0 exactly at a solution.
fn merit(
    blocks: &[Block],
    target: &[f64],
    rho: &[f64],
    lambda: &[f64],
    u: &[f64],
    slack: f64,
) -> f64 {
    let mut phi = [0.0; 3];
    let mut sum = 0.0;
    for &b in blocks {
        status(b, target, rho, lambda, u, &mut phi, slack);
        sum += phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2];
    }
    sum
}

/// Projects `lambda` onto the constraints (unilateral impulses ≥ 0, tangents in the disc of
/// `μ λ_n`) and updates `u` by `W` times the change. O(k) plus O(k) per changed impulse.
fn project(w: &[f64], blocks: &[Block], lambda: &mut [f64], u: &mut [f64]) {
    let k = u.len();
    let mut moved = |lambda: &mut [f64], i: usize, new: f64| {
        let d = new - lambda[i];
        if d != 0.0 {
            lambda[i] = new;
            for (x, wi) in u.iter_mut().zip(&w[i * k..(i + 1) * k]) {
                *x += wi * d;
            }
        }
    };
    for &b in blocks {
        let (n, _) = rows(b);
        moved(lambda, n, lambda[n].max(0.0));
        if let Block::Contact { mu, .. } = b {
            let bound = mu * lambda[n];
            let (l1, l2) = (lambda[n + 1], lambda[n + 2]);
            let norm = (l1 * l1 + l2 * l2).sqrt();
            if norm > bound {
                let s = if norm > 0.0 { bound / norm } else { 0.0 };
                moved(lambda, n + 1, l1 * s);
                moved(lambda, n + 2, l2 * s);
            }
        }
    }
}

/// Semismooth Newton on the Alart–Curnier equations (module documentation): `lambda` the warm
/// start on entry, the impulses on return (feasible), `u` their row velocities, for the
/// row-major `k × k` `w`, free velocities `u_free` and targets `target`. Stops when the
/// [`residual`] is at most `stop.tolerance`; each Newton iteration and each Gauss–Seidel
/// sweep of the fallback counts one of `stop.max_iterations`. O(f³/3 + k f) per iteration
/// for `f` rows of pushing blocks.
#[allow(clippy::too_many_arguments)]
pub(crate) fn newton(
    w: &[f64],
    blocks: &[Block],
    u_free: &[f64],
    target: &[f64],
    lambda: &mut [f64],
    u: &mut [f64],
    stop: Stop,
    nw: &mut Newton,
) -> Solve {
    let k = u_free.len();
    scales(w, blocks, k, &mut nw.rho);
    nw.factored_valid = false;
    nw.slack = 0.5 * stop.tolerance;
    // Rows no impulse moves are held at 0; the warm start made feasible.
    for (l, &r) in lambda[..k].iter_mut().zip(&nw.rho) {
        if r == 0.0 {
            *l = 0.0;
        }
    }
    contact_velocities(u, u_free, w, lambda);
    project(w, blocks, &mut lambda[..k], &mut u[..k]);
    nw.lambda.clear();
    nw.lambda.extend_from_slice(&lambda[..k]);
    nw.u.clear();
    nw.u.extend_from_slice(&u[..k]);
    let mut best = residual(blocks, target, lambda, u);
    let mut out = Solve {
        iterations: 0,
        change: 0.0,
        converged: best <= stop.tolerance,
    };
    let steps = stop.max_iterations.min(NEWTON_STEPS);
    let mut stalls = 0;
    // Converged, the iterations go on while they are cheap and fast: up to [`POLISH`] more, to
    // [`POLISH_FACTOR`] of the tolerance (a Newton step near its solution squares the error).
    let mut polish = 0;
    while out.iterations < steps && best > POLISH_FACTOR * stop.tolerance && polish < POLISH {
        polish += out.converged as usize;
        let change = match newton_step(w, blocks, target, nw) {
            Some(change) => change,
            None if out.converged => break,
            None if stalls < STALLS => {
                // A few Gauss–Seidel sweeps move the iterate off the kink (a status on its
                // boundary) or shed the redundant impulses the Newton step could not.
                stalls += 1;
                project(w, blocks, &mut nw.lambda, &mut nw.u);
                let mut change = 0.0f64;
                for _ in 0..SWEEPS_AFTER_STALL {
                    change = change.max(sweep(w, blocks, target, &mut nw.lambda, &mut nw.u));
                }
                out.iterations += SWEEPS_AFTER_STALL - 1;
                change
            }
            None => break,
        };
        out.iterations += 1;
        out.change = change;
        // The projection of the new iterate, kept when it is the best so far.
        nw.trial_l.clear();
        nw.trial_l.extend_from_slice(&nw.lambda);
        nw.trial_u.clear();
        nw.trial_u.extend_from_slice(&nw.u);
        project(w, blocks, &mut nw.trial_l, &mut nw.trial_u);
        let r = residual(blocks, target, &nw.trial_l, &nw.trial_u);
        if r < best {
            best = r;
            lambda[..k].copy_from_slice(&nw.trial_l);
            u[..k].copy_from_slice(&nw.trial_u);
        }
        out.converged = best <= stop.tolerance;
    }
    if out.converged || out.iterations >= stop.max_iterations {
        return out;
    }
    // The fallback: Gauss–Seidel from the best projection, for the rest of the cap.
    let rest = Stop {
        max_iterations: stop.max_iterations - out.iterations,
        tolerance: stop.tolerance,
    };
    let s = pgs(w, blocks, u_free, target, lambda, u, rest);
    Solve {
        iterations: out.iterations + s.iterations,
        change: s.change,
        converged: s.converged,
    }
}

/// The rows' scales `ρ` ([`Newton::rho`]).
fn scales(w: &[f64], blocks: &[Block], k: usize, rho: &mut Vec<f64>) {
    let big = (0..k).fold(0.0f64, |m, i| m.max(w[i * k + i]));
    let movable = |i: usize| {
        let d = w[i * k + i];
        d > IMMOVABLE * big && d.is_finite()
    };
    rho.clear();
    rho.resize(k, 0.0);
    for &b in blocks {
        let (n, _) = rows(b);
        if movable(n) {
            rho[n] = 1.0 / w[n * k + n];
        }
        if matches!(b, Block::Contact { .. }) && movable(n + 1) && movable(n + 2) {
            let r = 2.0 / (w[(n + 1) * k + n + 1] + w[(n + 2) * k + n + 2]);
            rho[n + 1] = r;
            rho[n + 2] = r;
        }
    }
}

/// One Newton iteration on `nw.lambda`, `nw.u` (module documentation): the statuses, the
/// separating blocks' impulses set to 0, the system on the pushing blocks' rows solved, and
/// the step taken as far as the line search allows. Returns the largest row-velocity change,
/// `None` when no step lowers the merit (or the system is singular).
fn newton_step(w: &[f64], blocks: &[Block], target: &[f64], nw: &mut Newton) -> Option<f64> {
    let k = nw.u.len();
    // Separating blocks let go (their part of the Newton step, exactly).
    let mut phi = [0.0; 3];
    for &b in blocks {
        if status(b, target, &nw.rho, &nw.lambda, &nw.u, &mut phi, nw.slack) == Status::Separating {
            let (r, m) = rows(b);
            for i in r..r + m {
                let d = -nw.lambda[i];
                if d != 0.0 {
                    nw.lambda[i] = 0.0;
                    for (x, wi) in nw.u.iter_mut().zip(&w[i * k..(i + 1) * k]) {
                        *x += wi * d;
                    }
                }
            }
        }
    }
    let m0 = merit(blocks, target, &nw.rho, &nw.lambda, &nw.u, nw.slack);
    if m0 == 0.0 {
        return Some(0.0);
    }
    // The system on the pushing rows; a row with no impulse whose step would pull (δ < 0:
    // the kink at λ = 0, or redundant corners sharing a load) is held at 0 and the system
    // solved again without it, as an active-set method would.
    nw.held.clear();
    nw.held.resize(k, false);
    for _ in 0..=HOLDS {
        assemble(w, blocks, target, nw);
        if nw.free.is_empty() || !solve_system(nw) {
            return None;
        }
        let mut held = false;
        for &b in blocks {
            let (n, _) = rows(b);
            let x = nw.at[n];
            if x != usize::MAX && nw.lambda[n] <= 0.0 && nw.delta[x] < 0.0 {
                nw.held[n] = true;
                held = true;
            }
        }
        if !held {
            break;
        }
    }
    // du = W_{·F} δ.
    nw.du.clear();
    nw.du.resize(k, 0.0);
    for (&j, &d) in nw.free.iter().zip(&nw.delta) {
        if d != 0.0 {
            for (x, wj) in nw.du.iter_mut().zip(&w[j * k..(j + 1) * k]) {
                *x += wj * d;
            }
        }
    }
    // Backtracking on the merit (Armijo, with the Gauss–Newton slope −2 m₀): first the whole
    // step, then the step up to the first pushing impulse it takes to 0 (a change of status
    // the merit may not see coming), then halvings.
    let ratio = nw
        .free
        .iter()
        .zip(&nw.delta)
        .filter(|&(&j, &d)| d < 0.0 && nw.lambda[j] > 0.0 && !is_tangent(blocks, j))
        .map(|(&j, &d)| -nw.lambda[j] / d)
        .fold(1.0f64, f64::min);
    let mut alpha = 1.0;
    for h in 0..=HALVINGS + 1 {
        if h == 1 {
            if ratio >= 1.0 {
                continue;
            }
            alpha = ratio;
        } else if h > 1 {
            alpha = 0.5f64.powi(h as i32 - 1);
        }
        nw.trial_l.clear();
        nw.trial_l.extend_from_slice(&nw.lambda);
        nw.trial_u.clear();
        nw.trial_u
            .extend(nw.u.iter().zip(&nw.du).map(|(u, d)| u + alpha * d));
        for (&j, &d) in nw.free.iter().zip(&nw.delta) {
            nw.trial_l[j] += alpha * d;
        }
        let m = merit(blocks, target, &nw.rho, &nw.trial_l, &nw.trial_u, nw.slack);
        if m <= (1.0 - 2e-4 * alpha) * m0 {
            std::mem::swap(&mut nw.lambda, &mut nw.trial_l);
            std::mem::swap(&mut nw.u, &mut nw.trial_u);
            let change = nw.du.iter().fold(0.0f64, |c, d| c.max((alpha * d).abs()));
            return Some(change);
        }
    }
    None
}

/// `nw.delta` from the system `nw.jac` plus its regularisation, refined [`REFINE`] times
/// against it; `false` when it is singular or the step not finite.
fn solve_system(nw: &mut Newton) -> bool {
    let f = nw.free.len();
    let reuse = !nw.sliding && nw.factored_valid && nw.factored == nw.free;
    nw.delta.clear();
    nw.delta.extend_from_slice(&nw.rhs);
    if !reuse {
        nw.lu.clear();
        nw.lu.extend_from_slice(&nw.jac);
        for (x, e) in nw.reg.iter().enumerate() {
            nw.lu[x * f + x] += e;
        }
    }
    nw.factored_valid = false;
    if reuse {
        cholesky_rows_solve(&nw.lu, f, &mut nw.delta);
        nw.factored_valid = true;
    } else if nw.sliding {
        if !lu(&mut nw.lu, f, &mut nw.piv) {
            return false;
        }
        lu_solve(&nw.lu, f, &nw.piv, &mut nw.delta);
    } else {
        if !cholesky_rows(&mut nw.lu, f) {
            return false;
        }
        cholesky_rows_solve(&nw.lu, f, &mut nw.delta);
        nw.factored.clear();
        nw.factored.extend_from_slice(&nw.free);
        nw.factored_valid = true;
    }
    for _ in 0..REFINE {
        nw.corr.clear();
        for x in 0..f {
            let row = &nw.jac[x * f..(x + 1) * f];
            let ad: f64 = row.iter().zip(&nw.delta).map(|(a, d)| a * d).sum();
            nw.corr.push(nw.rhs[x] - ad);
        }
        if nw.sliding {
            lu_solve(&nw.lu, f, &nw.piv, &mut nw.corr);
        } else {
            cholesky_rows_solve(&nw.lu, f, &mut nw.corr);
        }
        for (d, c) in nw.delta.iter_mut().zip(&nw.corr) {
            *d += c;
        }
    }
    nw.delta.iter().all(|d| d.is_finite())
}

/// The Newton system at `nw`'s iterate (its separating blocks already at 0): the free rows
/// (every row of a pushing block that moves), the Jacobian `nw.jac` of `Φ / ρ` on them, its
/// regularisation `nw.reg` and the right-hand side `−Φ / ρ`.
fn assemble(w: &[f64], blocks: &[Block], target: &[f64], nw: &mut Newton) {
    let k = nw.u.len();
    nw.free.clear();
    nw.at.clear();
    nw.at.resize(k, usize::MAX);
    let mut phi = [0.0; 3];
    for &b in blocks {
        let (r, m) = rows(b);
        if nw.held[r]
            || status(b, target, &nw.rho, &nw.lambda, &nw.u, &mut phi, nw.slack)
                == Status::Separating
        {
            continue;
        }
        for i in r..r + m {
            if nw.rho[i] > 0.0 {
                nw.at[i] = nw.free.len();
                nw.free.push(i);
            }
        }
    }
    let f = nw.free.len();
    nw.jac.clear();
    nw.jac.resize(f * f, 0.0);
    nw.reg.clear();
    nw.rhs.clear();
    nw.sliding = false;
    // Every free row starts as its row of W (the equations u = b, u_t = 0).
    for (x, &i) in nw.free.iter().enumerate() {
        let wi = &w[i * k..(i + 1) * k];
        for (o, &j) in nw.jac[x * f..(x + 1) * f].iter_mut().zip(&nw.free) {
            *o = wi[j];
        }
        nw.reg.push(REG * wi[i]);
        nw.rhs.push(0.0);
    }
    for &b in blocks {
        let st = status(b, target, &nw.rho, &nw.lambda, &nw.u, &mut phi, nw.slack);
        let (r, m) = rows(b);
        if st == Status::Separating || nw.held[r] {
            continue;
        }
        for (i, p) in (r..r + m).zip(phi) {
            if nw.at[i] != usize::MAX {
                nw.rhs[nw.at[i]] = -p;
            }
        }
        if let (Status::Sliding { zhat, kappa, .. }, Block::Contact { row: n, mu }) = (st, b) {
            nw.sliding = true;
            slide_rows(w, nw, n, mu, zhat, kappa);
        }
    }
}

/// Replaces the tangent rows of the sliding contact at normal row `n` by the linearisation of
/// `(λ_t − R ẑ) / ρ_t`: `κ P W_t + μ ẑ (ρ_n / ρ_t) W_n + ((1 − κ P) e_t − μ ẑ e_n) / ρ_t`,
/// `P = 1 − ẑ ẑᵀ`.
fn slide_rows(w: &[f64], nw: &mut Newton, n: usize, mu: f64, zhat: (f64, f64), kappa: f64) {
    let k = nw.u.len();
    let f = nw.free.len();
    let z = [zhat.0, zhat.1];
    let p = [
        [1.0 - z[0] * z[0], -z[0] * z[1]],
        [-z[1] * z[0], 1.0 - z[1] * z[1]],
    ];
    let (rn, rt) = (nw.rho[n], nw.rho[n + 1]);
    let (wn, w1, w2) = (
        &w[n * k..(n + 1) * k],
        &w[(n + 1) * k..(n + 2) * k],
        &w[(n + 2) * k..(n + 3) * k],
    );
    for a in 0..2 {
        let x = nw.at[n + 1 + a];
        let (c1, c2, cn) = (kappa * p[a][0], kappa * p[a][1], mu * z[a] * rn / rt);
        let row = &mut nw.jac[x * f..(x + 1) * f];
        for (o, &j) in row.iter_mut().zip(&nw.free) {
            *o = c1 * w1[j] + c2 * w2[j] + cn * wn[j];
        }
        for b in 0..2 {
            let delta = if a == b { 1.0 } else { 0.0 };
            row[nw.at[n + 1 + b]] += (delta - kappa * p[a][b]) / rt;
        }
        row[nw.at[n]] -= mu * z[a] / rt;
        nw.reg[x] = REG / rt;
    }
}
