//! The contact problem at velocity level, solved by projected Gauss–Seidel ([`pgs`]) or by
//! projected Gauss–Seidel with subspace minimisation ([`solve`]) on the Delassus operator
//! `W = J M⁻¹ Jᵀ` (`docs/contact.md#solver`, `docs/design.md#contact`).
//!
//! Rows `u = J v⁺` (contact normals and tangents, joint-limit rows) with
//! `u = u_free + W λ`; the impulses `λ` satisfy, per block,
//!
//! - a **unilateral row** (a contact normal, a joint limit): `λ ≥ 0`, `u ≥ b`, `λ (u − b) = 0`
//!   (`b` the row's target velocity: `−φ/dt` for a gap `φ > 0` not yet closed, else 0, or the
//!   restitution velocity);
//! - a **friction pair** (the two tangents of a contact): `|λ_t| ≤ μ λ_n` (the Coulomb disc),
//!   and where it slides, `λ_t` opposes the tangential velocity.
//!
//! Gauss–Seidel sweeps the blocks in order: a unilateral row takes its exact 1-D minimiser
//! clamped at 0; a friction pair its 2 × 2 solve for zero slip when that lies in the disc,
//! else a projected-gradient step onto the disc (whose fixed point opposes the slip: maximal
//! dissipation). Every update lowers `½ λᵀWλ + λᵀ(u_free − b)` for the current bounds.
//! Each update changes `u` by a column of `W`, so a sweep costs O(k²) for `k` rows. The
//! sweeps stop when no impulse changes the velocity of its row by more than `tolerance` (m/s),
//! or when the iterate meets every condition above to `tolerance` in velocity ([`residual`]:
//! redundant contacts, such as the four corners of a flat face, make `W` singular and the
//! split of their impulses creep on long after the velocities are right), or after
//! `max_iterations`; the last iterate is used either way (it is always inside the
//! cone and non-negative: a non-converged solve leaves some residual slip or approach
//! velocity, never a pulling normal force). [`solve`] adds exact solves of the equations the
//! sweeps' index sets give, and stops on the residual alone.

use crate::contact_newton::{newton, Newton};
use articula_spatial::numerics::{cholesky_rows_skip, cholesky_rows_solve};

/// One block of rows of the contact problem.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Block {
    /// A unilateral row (`λ ≥ 0`, `u ≥ b`) at `row`.
    Unilateral {
        /// Its row.
        row: usize,
    },
    /// A contact: its normal at `row`, its two tangents at `row + 1`, `row + 2`, friction `mu`.
    Contact {
        /// The normal's row.
        row: usize,
        /// Coulomb friction coefficient.
        mu: f64,
    },
}

/// When [`solve`] stops: after `max_iterations` sweeps, or after a sweep that changed no row
/// velocity by more than `tolerance`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Stop {
    /// Sweeps at most.
    pub max_iterations: usize,
    /// Largest row-velocity change of a final sweep (m/s or rad/s).
    pub tolerance: f64,
}

/// Outcome of [`solve`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Solve {
    /// Sweeps made.
    pub iterations: usize,
    /// The largest velocity change of the last sweep (m/s or rad/s).
    pub change: f64,
    /// Stopped by `tolerance` (the change or the [`residual`]), not by `max_iterations`.
    pub converged: bool,
}

/// Gauss–Seidel sweeps between two rounds of subspace steps.
const SWEEPS: usize = 3;
/// Subspace steps in a round at most (each from the last one's projected iterate, while that
/// changes the index sets or halves the residual).
const SUBSPACE_STEPS: usize = 4;
/// The subspace systems' regularisation, relative to their largest diagonal entry.
const SHIFT: f64 = 1e-10;
/// Passes of a subspace solve (the first is the plain Cholesky solve, the others refine it
/// and carry the sliding contacts' coupling).
const PASSES: usize = 3;

/// The buffers of [`solve`]'s subspace steps (grown, never shrunk).
#[derive(Clone, Debug, Default)]
pub(crate) struct Subspace {
    /// The free rows (indices into the problem, increasing).
    free: Vec<usize>,
    /// Per free row: `μ d` for the normal of a sliding contact (its tangent impulse follows
    /// the normal's along `d`), else 0.
    slide: Vec<(f64, f64)>,
    /// `W_FF + C` (the sliding contacts' coupling, below; row-major `f × f`).
    a: Vec<f64>,
    /// `W_FF + ε·1`, then its Cholesky factor (row-major `f × f`).
    m: Vec<f64>,
    /// The velocity error `b_F − u_F` of the iterate the step starts from.
    err: Vec<f64>,
    /// A refinement's residual, then its correction.
    rhs: Vec<f64>,
    /// The impulse change on the free rows.
    delta: Vec<f64>,
    /// The candidate iterate: impulses and row velocities.
    lambda: Vec<f64>,
    u: Vec<f64>,
    /// The impulses a step starts from (its sliding contacts turned against their slip).
    start: Vec<f64>,
    /// The iterate a chained step starts from.
    from_lambda: Vec<f64>,
    from_u: Vec<f64>,
}

/// Projected Gauss–Seidel with subspace minimisation (PGS-SM, after Silcowitz, Niebe and
/// Erleben 2010): `lambda` (the warm start on entry, the impulses on return) for the `k × k`
/// row-major `w`, free velocities `u_free` and targets `target` (tangent rows' targets are
/// unused). `u` is the workspace for the row velocities (`u_free + W λ` on return).
///
/// [`SWEEPS`] Gauss–Seidel sweeps ([`sweep`]) settle the index sets — which unilateral rows
/// push, which contacts stick and which slide (and in which direction) — then a round of
/// subspace steps ([`subspace_step`]) solves the equality problem on those sets exactly:
/// pushing rows on their target, sticking contacts not slipping, the others' impulses held.
/// Each step's projection onto the constraints may change the index sets; the next step
/// starts from it while it does (or halves the residual), up to [`SUBSPACE_STEPS`]. The best
/// iterate by [`residual`] is kept, and the sweeps resume. Stops when the [`residual`] is at
/// most `tolerance` or after `max_iterations` sweeps and subspace steps (each counts one); the
/// iterate is always non-negative on unilateral rows and inside the friction discs.
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve(
    w: &[f64],
    blocks: &[Block],
    u_free: &[f64],
    target: &[f64],
    lambda: &mut [f64],
    u: &mut [f64],
    stop: Stop,
    sub: &mut Subspace,
) -> Solve {
    let Stop {
        max_iterations,
        tolerance,
    } = stop;
    let k = u_free.len();
    contact_velocities(u, u_free, w, lambda);
    let mut out = Solve::default();
    let mut it = 0;
    // Sweeps before the next round of subspace steps: doubled after a round that improved
    // nothing (the index sets the sweeps reach are not yet the solution's).
    let mut sweeps = SWEEPS;
    while it < max_iterations {
        for _ in 0..sweeps {
            if it == max_iterations {
                return out;
            }
            let change = sweep(w, blocks, target, lambda, u);
            it += 1;
            out = Solve {
                iterations: it,
                change,
                converged: residual(blocks, target, lambda, u) <= tolerance,
            };
            if out.converged {
                return out;
            }
        }
        let mut best = residual(blocks, target, lambda, u);
        let start = best;
        let mut from = best;
        sub.from_lambda.clear();
        sub.from_lambda.extend_from_slice(&lambda[..k]);
        sub.from_u.clear();
        sub.from_u.extend_from_slice(&u[..k]);
        for _ in 0..SUBSPACE_STEPS {
            if it == max_iterations {
                return out;
            }
            it += 1;
            out.iterations = it;
            let (from_lambda, from_u) = (
                std::mem::take(&mut sub.from_lambda),
                std::mem::take(&mut sub.from_u),
            );
            let step = subspace_step(w, blocks, u_free, target, &from_lambda, &from_u, sub);
            sub.from_lambda = from_lambda;
            sub.from_u = from_u;
            let Some((r, projected)) = step else {
                break;
            };
            if r < best {
                best = r;
                // (The change is that of the velocities, as a sweep's.)
                out.change = u[..k]
                    .iter()
                    .zip(&sub.u[..k])
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                lambda.copy_from_slice(&sub.lambda[..k]);
                u[..k].copy_from_slice(&sub.u[..k]);
                out.converged = r <= tolerance;
                if out.converged {
                    return out;
                }
            }
            if !(projected || r < 0.5 * from) {
                break;
            }
            from = r;
            std::mem::swap(&mut sub.from_lambda, &mut sub.lambda);
            std::mem::swap(&mut sub.from_u, &mut sub.u);
        }
        if best > 0.5 * start {
            sweeps = usize::MAX;
        }
    }
    out
}

/// One subspace step from the iterate `lambda` (row velocities `u`): the candidate into
/// `sub.lambda` and `sub.u`; returns its [`residual`] and whether the index sets changed (an
/// impulse reached 0 or the rim of its disc, or a row held at 0 now approaches), `None` when
/// there is nothing to solve.
///
/// The free rows `F` are the unilateral rows that push or approach (`λ > 0` or `u < b`) and
/// both tangents of each sticking contact (`|λ_t| < μ λ_n`); a sliding contact (on its rim,
/// in the direction `d = λ_t / |λ_t|`) keeps its tangent impulse on the rim, `Δλ_t = μ d Δλ_n`;
/// the other impulses are held. The equations `u_F = b_F` (tangent targets 0) in the changes
/// `δ` of the free impulses read `(W_FF + C) δ = b_F − u_F`, `C` the sliding contacts'
/// coupling (`μ (d₁ W_{F,t₁} + d₂ W_{F,t₂})` in the column of their normal). They are solved
/// by the Cholesky factor of `W_FF + ε·1` (`ε` = [`SHIFT`] times its largest diagonal entry:
/// the corners of a flat face make `W_FF` singular) and [`PASSES`] passes of `δ += (W_FF +
/// ε)⁻¹ (e − (W_FF + C) δ)` (iterative refinement, which also carries `C`). The step then
/// goes as far as the first pushing impulse it takes to 0 (a ratio test; along a singular
/// direction, where `δ` is large, that is the impulse the redundant contacts shed), and the
/// projection clamps what remains outside: entering rows at 0, sticking tangents into the
/// disc of the new `μ λ_n`. Rows no impulse moves (`W_ii` at rounding level) are never free.
/// O(f³/6 + k²) for `f` free rows.
#[allow(clippy::too_many_arguments)]
fn subspace_step(
    w: &[f64],
    blocks: &[Block],
    u_free: &[f64],
    target: &[f64],
    lambda: &[f64],
    u: &[f64],
    sub: &mut Subspace,
) -> Option<(f64, bool)> {
    let k = u_free.len();
    let scale = (0..k).fold(0.0f64, |m, i| m.max(w[i * k + i]));
    if scale.is_nan() || scale <= 0.0 {
        return None;
    }
    let movable = |i: usize| w[i * k + i] > 1e-12 * scale;
    turn_sliding_friction((w, k), blocks, lambda, u, sub);
    sub.start.clear();
    sub.start.extend_from_slice(&sub.lambda);
    free_set(blocks, target, movable, sub);
    let lambda = &sub.start;
    let f = sub.free.len();
    if f == 0 {
        return None;
    }
    let free = &sub.free;
    // a = W_FF + C (row-major f × f), m its symmetric part W_FF + ε·1, factored.
    sub.a.clear();
    let sliding = sub.slide.iter().any(|&s| s != (0.0, 0.0));
    if sliding {
        sub.a.resize(f * f, 0.0);
    }
    for (x, &i) in free.iter().enumerate().filter(|_| sliding) {
        let row = &w[i * k..(i + 1) * k];
        let out = &mut sub.a[x * f..(x + 1) * f];
        for (o, &j) in out.iter_mut().zip(free) {
            *o = row[j];
        }
        for ((o, &j), &(s1, s2)) in out.iter_mut().zip(free).zip(&sub.slide) {
            if s1 != 0.0 || s2 != 0.0 {
                *o += s1 * row[j + 1] + s2 * row[j + 2];
            }
        }
    }
    let shift = SHIFT * free.iter().fold(0.0f64, |m, &i| m.max(w[i * k + i]));
    sub.m.clear();
    sub.m.resize(f * f, 0.0);
    for (x, &i) in free.iter().enumerate() {
        let row = &w[i * k..(i + 1) * k];
        // (The lower triangle is all the factorisation reads.)
        for (o, &j) in sub.m[x * f..x * f + x + 1].iter_mut().zip(free) {
            *o = row[j];
        }
        sub.m[x * f + x] += shift;
    }
    cholesky_rows_skip(&mut sub.m, f, 0.0)?;
    // δ = (W_FF + ε)⁻¹ e, then with a sliding contact δ += (W_FF + ε)⁻¹ (e − a δ).
    sub.delta.clear();
    sub.delta.extend_from_slice(&sub.err);
    cholesky_rows_solve(&sub.m, f, &mut sub.delta);
    for _ in 1..if sliding { PASSES } else { 1 } {
        sub.rhs.clear();
        sub.rhs.resize(f, 0.0);
        for (x, r) in sub.rhs.iter_mut().enumerate() {
            let row = &sub.a[x * f..(x + 1) * f];
            *r = sub.err[x] - row.iter().zip(&sub.delta).map(|(a, d)| a * d).sum::<f64>();
        }
        cholesky_rows_solve(&sub.m, f, &mut sub.rhs);
        for (d, r) in sub.delta.iter_mut().zip(&sub.rhs) {
            *d += r;
        }
    }
    if sub.delta.iter().any(|d| !d.is_finite()) {
        return None;
    }
    // The step, up to the first pushing impulse it takes to 0 (which leaves the free set;
    // rows entering the set, at 0, are clamped by the projection below instead).
    let mut step = 1.0f64;
    let mut blocking = None;
    for (&i, &d) in free.iter().zip(&sub.delta) {
        if d < 0.0 && lambda[i] > 0.0 && lambda[i] + step * d < 0.0 && !is_tangent(blocks, i) {
            step = -lambda[i] / d;
            blocking = Some(i);
        }
    }
    for ((&i, d), &(s1, s2)) in free.iter().zip(&sub.delta).zip(&sub.slide) {
        sub.lambda[i] += step * d;
        if s1 != 0.0 || s2 != 0.0 {
            sub.lambda[i + 1] += s1 * step * d;
            sub.lambda[i + 2] += s2 * step * d;
        }
    }
    let changed = project_onto_constraints(blocks, blocking, &mut sub.lambda);
    // u' = u + W (λ' − λ), over the impulses that changed.
    for j in 0..k {
        let d = sub.lambda[j] - sub.start[j];
        if d != 0.0 {
            for (x, wj) in sub.u.iter_mut().zip(&w[j * k..(j + 1) * k]) {
                *x += wj * d;
            }
        }
    }
    // A row held at 0 that now approaches joins the free set in the next step.
    let changed = changed
        || blocks.iter().any(|b| {
            let r = head(b);
            sub.lambda[r] == 0.0 && sub.u[r] < target[r] && free.binary_search(&r).is_err()
        });
    Some((residual(blocks, target, &sub.lambda, &sub.u[..k]), changed))
}

/// The start of a subspace step, into `sub.lambda`, `sub.u`: the iterate with each sliding
/// contact's friction turned against its current slip (`λ_t = −μ λ_n u_t / |u_t|`, the
/// direction maximal dissipation gives it).
fn turn_sliding_friction(
    (w, k): (&[f64], usize),
    blocks: &[Block],
    lambda: &[f64],
    u: &[f64],
    sub: &mut Subspace,
) {
    sub.lambda.clear();
    sub.lambda.extend_from_slice(&lambda[..k]);
    sub.u.clear();
    sub.u.extend_from_slice(&u[..k]);
    for block in blocks {
        if let Block::Contact { row: n, mu } = *block {
            let bound = mu * lambda[n];
            let (l1, l2) = (lambda[n + 1], lambda[n + 2]);
            let (s1, s2) = (u[n + 1], u[n + 2]);
            let slip = (s1 * s1 + s2 * s2).sqrt();
            if bound > 0.0 && l1 * l1 + l2 * l2 >= (bound * (1.0 - 1e-9)).powi(2) && slip > 0.0 {
                let (n1, n2) = (-bound * s1 / slip, -bound * s2 / slip);
                for (t, d) in [(n + 1, n1 - l1), (n + 2, n2 - l2)] {
                    sub.lambda[t] += d;
                    for (x, wt) in sub.u.iter_mut().zip(&w[t * k..(t + 1) * k]) {
                        *x += wt * d;
                    }
                }
            }
        }
    }
}

/// The free rows of a subspace step from its start `sub.start`, `sub.u` (module
/// documentation of [`solve`]): `sub.free`, `sub.slide` and the velocity errors `sub.err`.
fn free_set(blocks: &[Block], target: &[f64], movable: impl Fn(usize) -> bool, sub: &mut Subspace) {
    let (lambda, u) = (&sub.start, &sub.u);
    sub.free.clear();
    sub.slide.clear();
    // (e = b − u per free row: the targets of tangent rows are 0.)
    sub.err.clear();
    for block in blocks {
        match *block {
            Block::Unilateral { row } => {
                if (lambda[row] > 0.0 || u[row] < target[row]) && movable(row) {
                    sub.free.push(row);
                    sub.slide.push((0.0, 0.0));
                    sub.err.push(target[row] - u[row]);
                }
            }
            Block::Contact { row: n, mu } => {
                if !((lambda[n] > 0.0 || u[n] < target[n]) && movable(n)) {
                    continue;
                }
                let bound = mu * lambda[n];
                let (l1, l2) = (lambda[n + 1], lambda[n + 2]);
                let norm = (l1 * l1 + l2 * l2).sqrt();
                sub.free.push(n);
                sub.err.push(target[n] - u[n]);
                if norm < bound * (1.0 - 1e-9) && movable(n + 1) && movable(n + 2) {
                    sub.slide.push((0.0, 0.0));
                    sub.free.extend([n + 1, n + 2]);
                    sub.slide.extend([(0.0, 0.0); 2]);
                    sub.err.extend([-u[n + 1], -u[n + 2]]);
                } else if norm > 0.0 && lambda[n] > 0.0 {
                    sub.slide.push((mu * l1 / norm, mu * l2 / norm));
                } else {
                    sub.slide.push((0.0, 0.0));
                }
            }
        }
    }
}

/// A subspace step's impulses `lambda` projected onto the constraints (the `blocking` row at
/// 0, unilateral impulses ≥ 0, tangents into their disc); `true` when that changed an index
/// set.
fn project_onto_constraints(blocks: &[Block], blocking: Option<usize>, lambda: &mut [f64]) -> bool {
    let mut changed = blocking.is_some();
    if let Some(i) = blocking {
        lambda[i] = 0.0;
    }
    for block in blocks {
        match *block {
            Block::Unilateral { row } => {
                if lambda[row] < 0.0 {
                    lambda[row] = 0.0;
                    changed = true;
                }
            }
            Block::Contact { row: n, mu } => {
                if lambda[n] < 0.0 {
                    lambda[n] = 0.0;
                    changed = true;
                }
                let bound = mu * lambda[n];
                let (l1, l2) = (lambda[n + 1], lambda[n + 2]);
                let norm = (l1 * l1 + l2 * l2).sqrt();
                if norm > bound {
                    // Onto the rim: a sticking contact starts to slide (a sliding one only
                    // meets it to rounding, or lost its normal impulse).
                    changed |= norm > bound * (1.0 + 1e-9) || bound == 0.0;
                    let s = if norm > 0.0 { bound / norm } else { 0.0 };
                    lambda[n + 1] = l1 * s;
                    lambda[n + 2] = l2 * s;
                }
            }
        }
    }
    changed
}

/// Row `i` is a friction row (the first or second tangent of a contact).
pub(crate) fn is_tangent(blocks: &[Block], i: usize) -> bool {
    // Blocks are in row order: the last block starting at or before `i`.
    let at = blocks.partition_point(|b| head(b) <= i);
    matches!(blocks[at - 1], Block::Contact { row, .. } if row != i)
}

/// A block's first row.
fn head(b: &Block) -> usize {
    match *b {
        Block::Unilateral { row } | Block::Contact { row, .. } => row,
    }
}

/// One projected Gauss–Seidel sweep over `blocks`: a unilateral row takes its exact 1-D
/// minimiser clamped at 0; a friction pair its 2 × 2 solve for zero slip when that lies in the
/// disc, else a projected-gradient step onto the disc. Updates `u` with each change; returns
/// the largest row-velocity change. O(k²).
///
/// A contact's three updates go through `u` in one pass: the tangents read only their own two
/// velocities after the normal's change, so those two are updated first and the whole of `u`
/// after, each entry adding the three columns in the order the updates were made (the same
/// sums, in the same order, as three passes).
pub(crate) fn sweep(
    w: &[f64],
    blocks: &[Block],
    target: &[f64],
    lambda: &mut [f64],
    u: &mut [f64],
) -> f64 {
    let k = target.len();
    let row = |i: usize| &w[i * k..(i + 1) * k];
    // A unilateral row's exact update (its 1-D minimiser, clamped at 0): the impulse change.
    let unilateral = |lambda: &mut [f64], u: &[f64], i: usize| {
        let wii = w[i * k + i];
        if wii.is_nan() || wii <= 0.0 {
            // A row no impulse can move (its body's joints are all locked or welded).
            return 0.0;
        }
        let new = (lambda[i] - (u[i] - target[i]) / wii).max(0.0);
        let d = new - lambda[i];
        lambda[i] = new;
        d
    };
    let mut change = 0.0f64;
    for block in blocks {
        match *block {
            Block::Unilateral { row: i } => {
                let d = unilateral(lambda, u, i);
                if d != 0.0 {
                    for (x, wij) in u.iter_mut().zip(row(i)) {
                        *x += wij * d;
                    }
                }
                change = change.max((d * w[i * k + i]).abs());
            }
            Block::Contact { row: n, mu } => {
                let dn = unilateral(lambda, u, n);
                change = change.max((dn * w[n * k + n]).abs());
                // Tangents: the 2 × 2 solve for zero slip when it lies in the disc
                // (sticking); else a projected gradient step of length 1/L (L the larger
                // eigenvalue of the 2 × 2 block), whose fixed point on the rim opposes
                // the slip (maximal dissipation) and which never raises the objective.
                let (t1, t2) = (n + 1, n + 2);
                let (mut u1, mut u2) = (u[t1], u[t2]);
                if dn != 0.0 {
                    u1 += w[n * k + t1] * dn;
                    u2 += w[n * k + t2] * dn;
                }
                let (a, b, c) = (w[t1 * k + t1], w[t1 * k + t2], w[t2 * k + t2]);
                let det = a * c - b * b;
                let bound = mu * lambda[n];
                let (r1, r2) = (-u1, -u2);
                let stick = (det > 1e-12 * a * c)
                    .then(|| {
                        let (d1, d2) = ((c * r1 - b * r2) / det, (a * r2 - b * r1) / det);
                        (lambda[t1] + d1, lambda[t2] + d2)
                    })
                    .filter(|&(l1, l2)| l1 * l1 + l2 * l2 <= bound * bound);
                let (l1, l2) = stick.unwrap_or_else(|| {
                    let l = 0.5 * (a + c) + (0.25 * (a - c) * (a - c) + b * b).sqrt();
                    if l.is_nan() || l <= 0.0 {
                        // Tangents no impulse can move.
                        return (lambda[t1], lambda[t2]);
                    }
                    let (l1, l2) = (lambda[t1] + r1 / l, lambda[t2] + r2 / l);
                    // (√(l1² + l2²): `hypot`'s overflow guard costs more than the
                    // rest of the sweep, and impulses are far from overflowing.)
                    let norm = (l1 * l1 + l2 * l2).sqrt();
                    if norm > bound {
                        let s = if norm > 0.0 { bound / norm } else { 0.0 };
                        (l1 * s, l2 * s)
                    } else {
                        (l1, l2)
                    }
                });
                let (d1, d2) = (l1 - lambda[t1], l2 - lambda[t2]);
                lambda[t1] = l1;
                lambda[t2] = l2;
                add_columns(u, [(row(n), dn), (row(t1), d1), (row(t2), d2)]);
                change = change.max((d1 * a).abs()).max((d2 * c).abs());
            }
        }
    }
    change
}

/// `u += Σ cᵢ dᵢ` over the columns `cᵢ` whose `dᵢ` is not 0, in one pass, each entry adding
/// them in order (a zero `dᵢ` adds nothing: a column of a row no impulse moves may hold NaN).
fn add_columns(u: &mut [f64], cols: [(&[f64], f64); 3]) {
    let [(c0, d0), (c1, d1), (c2, d2)] = cols;
    match (d0 != 0.0, d1 != 0.0, d2 != 0.0) {
        (true, true, true) => {
            for (((x, a), b), c) in u.iter_mut().zip(c0).zip(c1).zip(c2) {
                *x = *x + a * d0 + b * d1 + c * d2;
            }
        }
        (false, true, true) => {
            for ((x, b), c) in u.iter_mut().zip(c1).zip(c2) {
                *x = *x + b * d1 + c * d2;
            }
        }
        (true, false, false) => {
            for (x, a) in u.iter_mut().zip(c0) {
                *x += a * d0;
            }
        }
        (false, false, false) => {}
        _ => {
            for (c, d) in [(c0, d0), (c1, d1), (c2, d2)] {
                if d != 0.0 {
                    for (x, w) in u.iter_mut().zip(c) {
                        *x += w * d;
                    }
                }
            }
        }
    }
}

/// Projected Gauss–Seidel: [`sweep`]s until one changes no row velocity by more than
/// `tolerance`, or the [`residual`] is at most `tolerance`, or after `max_iterations` sweeps;
/// `lambda` is the warm start on entry, the impulses on return, `u` the row velocities.
pub(crate) fn pgs(
    w: &[f64],
    blocks: &[Block],
    u_free: &[f64],
    target: &[f64],
    lambda: &mut [f64],
    u: &mut [f64],
    stop: Stop,
) -> Solve {
    contact_velocities(u, u_free, w, lambda);
    let mut out = Solve::default();
    for it in 0..stop.max_iterations {
        let change = sweep(w, blocks, target, lambda, u);
        out = Solve {
            iterations: it + 1,
            change,
            converged: change <= stop.tolerance
                || residual(blocks, target, lambda, u) <= stop.tolerance,
        };
        if out.converged {
            break;
        }
    }
    out
}

/// The buffers of [`solve_active`] (grown, never shrunk).
#[derive(Clone, Debug, Default)]
pub(crate) struct ActiveSet {
    /// Per block: in the active set.
    on: Vec<bool>,
    /// The active rows (indices into the full problem), the compacted problem's blocks, `W`,
    /// free velocities, targets, impulses and velocities.
    rows: Vec<usize>,
    blocks: Vec<Block>,
    w: Vec<f64>,
    u_free: Vec<f64>,
    target: Vec<f64>,
    lambda: Vec<f64>,
    u: Vec<f64>,
    /// The subspace steps' buffers.
    sub: Subspace,
    /// The Newton solver's buffers.
    newton: Newton,
}

/// The method of [`solve_active`]'s compacted solves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Method {
    /// Projected Gauss–Seidel ([`pgs`]).
    GaussSeidel,
    /// Gauss–Seidel with subspace minimisation ([`solve`]).
    Subspace,
    /// Semismooth Newton ([`newton`]).
    Newton,
}

/// [`solve`] on the blocks that can push, the others' impulses held at 0: a resting crowd's
/// candidate contacts are about half separating (a gap within the margin, or lifting off), and
/// each sweep then costs O(a²) for `a` active rows instead of O(k²). The active set starts
/// with the blocks the warm start pushes or whose velocity at the warm start (`u_free + W λ`)
/// falls short of their target; after each solve the inactive blocks' velocities are
/// computed (O(k a)) and any that falls short by more than `tolerance` joins the set and the
/// solve resumes from the current impulses. On return every block meets the conditions of
/// [`solve`]'s stop (the active ones by the compacted solve, the inactive ones with `λ = 0`
/// and `u ≥ b − tolerance`) unless `max_iterations` sweeps (over all rounds) ran out; blocks
/// that join after the last of those get one more sweep. `u` holds `u_free + W λ` for every
/// row.
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve_active(
    w: &[f64],
    blocks: &[Block],
    u_free: &[f64],
    target: &[f64],
    lambda: &mut [f64],
    u: &mut [f64],
    stop: Stop,
    set: &mut ActiveSet,
    method: Method,
) -> Solve {
    let k = u_free.len();
    // Sized for every block active: the buffers grow only with `k`.
    set.w.reserve((k * k).saturating_sub(set.w.len()));
    for v in [
        &mut set.u_free,
        &mut set.target,
        &mut set.lambda,
        &mut set.u,
    ] {
        v.reserve(k.saturating_sub(v.len()));
    }
    set.rows.reserve(k.saturating_sub(set.rows.len()));
    set.blocks
        .reserve(blocks.len().saturating_sub(set.blocks.len()));
    set.on.reserve(blocks.len().saturating_sub(set.on.len()));
    // u at the warm start.
    contact_velocities(u, u_free, w, lambda);
    set.on.clear();
    set.on.extend(blocks.iter().map(|b| {
        let r = head(b);
        lambda[r] > 0.0 || u[r] - target[r] <= stop.tolerance
    }));
    // An inactive block pushes nothing.
    for (b, &on) in blocks.iter().zip(&set.on) {
        if !on {
            let r = head(b);
            let n = if matches!(b, Block::Contact { .. }) {
                3
            } else {
                1
            };
            lambda[r..r + n].iter_mut().for_each(|l| *l = 0.0);
        }
    }
    let mut total = Solve::default();
    loop {
        // The compacted problem of the active blocks.
        set.rows.clear();
        set.blocks.clear();
        for (b, &on) in blocks.iter().zip(&set.on) {
            if !on {
                continue;
            }
            let at = set.rows.len();
            match *b {
                Block::Unilateral { row } => {
                    set.rows.push(row);
                    set.blocks.push(Block::Unilateral { row: at });
                }
                Block::Contact { row, mu } => {
                    set.rows.extend([row, row + 1, row + 2]);
                    set.blocks.push(Block::Contact { row: at, mu });
                }
            }
        }
        let a = set.rows.len();
        set.w.clear();
        for &i in &set.rows {
            let wi = &w[i * k..(i + 1) * k];
            set.w.extend(set.rows.iter().map(|&j| wi[j]));
        }
        set.u_free.clear();
        set.u_free.extend(set.rows.iter().map(|&i| u_free[i]));
        set.target.clear();
        set.target.extend(set.rows.iter().map(|&i| target[i]));
        set.lambda.clear();
        set.lambda.extend(set.rows.iter().map(|&i| lambda[i]));
        set.u.clear();
        set.u.resize(a, 0.0);
        let round = Stop {
            // (Blocks that joined after the last allowed sweep get one more: a contact
            // approaching with no impulse is never left out.)
            max_iterations: stop.max_iterations.saturating_sub(total.iterations).max(1),
            tolerance: stop.tolerance,
        };
        let (cw, cb, cu, ct) = (&set.w, &set.blocks, &set.u_free, &set.target);
        let (lambda_a, u_a) = (&mut set.lambda, &mut set.u);
        let s = match method {
            Method::Subspace => solve(cw, cb, cu, ct, lambda_a, u_a, round, &mut set.sub),
            Method::Newton => newton(cw, cb, cu, ct, lambda_a, u_a, round, &mut set.newton),
            Method::GaussSeidel => pgs(cw, cb, cu, ct, lambda_a, u_a, round),
        };
        total.iterations += s.iterations;
        total.change = s.change;
        total.converged = s.converged;
        for (x, &i) in set.rows.iter().enumerate() {
            lambda[i] = set.lambda[x];
        }
        // Every row's velocity; inactive blocks that fall short join.
        let mut joined = false;
        for i in 0..k {
            let row = &w[i * k..(i + 1) * k];
            u[i] = u_free[i] + set.rows.iter().map(|&j| row[j] * lambda[j]).sum::<f64>();
        }
        for (b, on) in blocks.iter().zip(set.on.iter_mut()) {
            let r = head(b);
            if !*on && u[r] - target[r] < -stop.tolerance {
                *on = true;
                joined = true;
            }
        }
        if !joined {
            return total;
        }
        total.converged = false;
        if total.iterations > stop.max_iterations {
            return total;
        }
    }
}

/// The largest violation (m/s or rad/s) of the contact conditions by `lambda` with row
/// velocities `u`: a unilateral row pushing (`λ > 0`) off its target (`|u − b|`) or approaching
/// below it (`b − u`); a friction pair inside the disc slipping (`|u_t|`), or on its rim
/// slipping other than against its force (the slip's part across `λ_t` and along it). Every
/// condition is met when it is 0. O(k).
pub(crate) fn residual(blocks: &[Block], target: &[f64], lambda: &[f64], u: &[f64]) -> f64 {
    let unilateral = |i: usize| {
        let v = u[i] - target[i];
        if lambda[i] > 0.0 {
            v.abs()
        } else {
            (-v).max(0.0)
        }
    };
    let mut worst = 0.0f64;
    for block in blocks {
        match *block {
            Block::Unilateral { row } => worst = worst.max(unilateral(row)),
            Block::Contact { row: n, mu } => {
                worst = worst.max(unilateral(n));
                let bound = mu * lambda[n];
                if bound <= 0.0 {
                    // No friction to apply: any slip is allowed.
                    continue;
                }
                let (l1, l2, u1, u2) = (lambda[n + 1], lambda[n + 2], u[n + 1], u[n + 2]);
                let norm = (l1 * l1 + l2 * l2).sqrt();
                let r = if norm < bound * (1.0 - 1e-9) {
                    (u1 * u1 + u2 * u2).sqrt()
                } else {
                    let (d1, d2) = (l1 / norm, l2 / norm);
                    let along = u1 * d1 + u2 * d2;
                    let (p1, p2) = (u1 - along * d1, u2 - along * d2);
                    (p1 * p1 + p2 * p2).sqrt().max(along)
                };
                worst = worst.max(r);
            }
        }
    }
    worst
}

/// The contact-space velocities `u = u_free + W λ` (`W` the row-major `k × k` Delassus
/// operator, `k = u_free.len()`), into `u[..k]`.
pub(crate) fn contact_velocities(u: &mut [f64], u_free: &[f64], w: &[f64], lambda: &[f64]) {
    let k = u_free.len();
    for (i, ui) in u[..k].iter_mut().enumerate() {
        let row = &w[i * k..(i + 1) * k];
        *ui = u_free[i]
            + row
                .iter()
                .zip(lambda.iter())
                .map(|(a, b)| a * b)
                .sum::<f64>();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One contact on a unit point mass (W = identity): the normal impulse cancels the
    /// approach, friction is capped by μ λ_n and opposes the slip; against the closed form.
    #[test]
    fn point_mass_contact_matches_the_closed_form() {
        let w = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let blocks = [Block::Contact { row: 0, mu: 0.5 }];
        // Approaching at 2 m/s, sliding at (3, 4) m/s: λ_n = 2, |λ_t| = 1 against (3, 4)/5.
        let (mut l, mut u) = ([0.0; 3], [0.0; 3]);
        let s = solve(
            &w,
            &blocks,
            &[-2.0, 3.0, 4.0],
            &[0.0; 3],
            &mut l,
            &mut u,
            Stop {
                max_iterations: 50,
                tolerance: 1e-12,
            },
            &mut Subspace::default(),
        );
        assert!(s.iterations <= 3, "{s:?}");
        for (got, want) in l.iter().zip([2.0, -0.6, -0.8]) {
            assert!((got - want).abs() < 1e-14, "{l:?}");
        }
        // Slow slip (0.3, 0.4) inside the cone: stuck, u_t = 0.
        let (mut l, mut u) = ([0.0; 3], [0.0; 3]);
        solve(
            &w,
            &blocks,
            &[-2.0, 0.3, 0.4],
            &[0.0; 3],
            &mut l,
            &mut u,
            Stop {
                max_iterations: 50,
                tolerance: 1e-12,
            },
            &mut Subspace::default(),
        );
        assert!(
            u[1].abs() < 1e-14 && u[2].abs() < 1e-14 && u[0].abs() < 1e-14,
            "{u:?}"
        );
        // Separating: no impulse at all.
        let (mut l, mut u) = ([0.0; 3], [0.0; 3]);
        solve(
            &w,
            &blocks,
            &[1.0, 3.0, 4.0],
            &[0.0; 3],
            &mut l,
            &mut u,
            Stop {
                max_iterations: 50,
                tolerance: 1e-12,
            },
            &mut Subspace::default(),
        );
        assert_eq!(l, [0.0; 3]);
    }

    /// Two coupled unilateral rows against the exact LCP solution (found by enumeration).
    #[test]
    fn coupled_rows_solve_the_lcp() {
        let w = [2.0, 1.0, 1.0, 2.0];
        let blocks = [Block::Unilateral { row: 0 }, Block::Unilateral { row: 1 }];
        // u = u_free + W λ ≥ 0, λ ≥ 0: u_free = (−3, 1) → λ = (1.5, 0), u = (0, 2.5).
        let (mut l, mut u) = ([0.0; 2], [0.0; 2]);
        solve(
            &w,
            &blocks,
            &[-3.0, 1.0],
            &[0.0; 2],
            &mut l,
            &mut u,
            Stop {
                max_iterations: 100,
                tolerance: 1e-14,
            },
            &mut Subspace::default(),
        );
        assert!((l[0] - 1.5).abs() < 1e-13 && l[1] == 0.0, "{l:?}");
        assert!(u[0].abs() < 1e-13 && (u[1] - 2.5).abs() < 1e-13, "{u:?}");
        // Both active: u_free = (−3, −3) → λ = (1, 1).
        let (mut l, mut u) = ([0.0; 2], [0.0; 2]);
        solve(
            &w,
            &blocks,
            &[-3.0, -3.0],
            &[0.0; 2],
            &mut l,
            &mut u,
            Stop {
                max_iterations: 100,
                tolerance: 1e-14,
            },
            &mut Subspace::default(),
        );
        assert!(
            (l[0] - 1.0).abs() < 1e-12 && (l[1] - 1.0).abs() < 1e-12,
            "{l:?}"
        );
    }

    /// The active-set solve reaches the full solve's solution on a coupled problem where
    /// some contacts separate, one separating at the warm start is pulled in, and every
    /// condition holds on return.
    #[test]
    fn active_set_matches_the_full_solve() {
        // W = A Aᵀ + 0.5 I (12 × 12: four contacts), A fixed pseudo-random.
        let k = 12;
        let a: Vec<f64> = (0..k * k)
            .map(|i| ((i * 7919 % 23) as f64 - 11.0) / 11.0)
            .collect();
        let mut w = vec![0.0; k * k];
        for i in 0..k {
            for j in 0..k {
                w[i * k + j] = (0..k).map(|m| a[i * k + m] * a[j * k + m]).sum::<f64>()
                    + if i == j { 0.5 } else { 0.0 };
            }
        }
        let blocks: Vec<Block> = (0..4)
            .map(|c| Block::Contact {
                row: 3 * c,
                mu: 0.6,
            })
            .collect();
        // Contacts 0 and 2 approach, 1 separates fast, 3 separates slowly (coupling may
        // pull it in).
        let u_free = [
            -1.0, 0.3, -0.2, 2.0, 0.1, 0.0, -0.7, -0.4, 0.5, 0.05, 0.2, 0.1,
        ];
        let target = [0.0; 12];
        let stop = Stop {
            max_iterations: 5000,
            tolerance: 1e-12,
        };
        let (mut l_full, mut u_full) = ([0.0; 12], [0.0; 12]);
        let full = pgs(
            &w,
            &blocks,
            &u_free,
            &target,
            &mut l_full,
            &mut u_full,
            stop,
        );
        assert!(residual(&blocks, &target, &l_full, &u_full) <= 1e-10);
        // Gauss–Seidel and the subspace solver on the active set.
        for method in [Method::GaussSeidel, Method::Subspace, Method::Newton] {
            let (mut l, mut u) = ([0.0; 12], [0.0; 12]);
            let mut set = ActiveSet::default();
            let act = solve_active(
                &w, &blocks, &u_free, &target, &mut l, &mut u, stop, &mut set, method,
            );
            assert!(full.converged && act.converged, "{full:?} {act:?}");
            assert!(residual(&blocks, &target, &l, &u) <= 1e-10, "{method:?}");
            for i in 0..k {
                assert!((u[i] - u_full[i]).abs() < 1e-9, "u {u:?} vs {u_full:?}");
                let want = u_free[i] + (0..k).map(|j| w[i * k + j] * l[j]).sum::<f64>();
                assert!((u[i] - want).abs() < 1e-12);
            }
            assert!(l[0] > 0.0 && l[3] == 0.0, "{l:?}");
        }
    }

    /// A rigid body or a chain of them with contact points: the generalized mass matrix `M`
    /// (`n × n`), the contact rows `J` (normal `z`, tangents `x`, `y` at each point) and the
    /// free velocity; `W = J M⁻¹ Jᵀ` and `u_free = J v_free` built densely here.
    struct Rig {
        n: usize,
        m: Vec<f64>,
        j: Vec<f64>,
        v_free: Vec<f64>,
    }

    fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }

    impl Rig {
        /// Rows `[d, p × d, 0…]` for the corner `p` (relative to the first body's centre of
        /// mass; the first six coordinates are that body's linear and angular velocity).
        fn corner_rows(n: usize, corners: &[[f64; 3]]) -> Vec<f64> {
            let mut j = vec![0.0; 3 * corners.len() * n];
            for (c, &p) in corners.iter().enumerate() {
                for (r, d) in [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
                    .into_iter()
                    .enumerate()
                {
                    let row = &mut j[(3 * c + r) * n..(3 * c + r + 1) * n];
                    row[..3].copy_from_slice(&d);
                    row[3..6].copy_from_slice(&cross(p, d));
                }
            }
            j
        }

        /// `M⁻¹ x`.
        fn m_inv(&self, x: &mut [f64]) {
            let mut l = self.m.clone();
            assert_eq!(cholesky_rows_skip(&mut l, self.n, 0.0), Some(0));
            cholesky_rows_solve(&l, self.n, x);
        }

        /// `(W, u_free)`.
        fn problem(&self) -> (Vec<f64>, Vec<f64>) {
            let n = self.n;
            let k = self.j.len() / n;
            let mut w = vec![0.0; k * k];
            for c in 0..k {
                let mut x = self.j[c * n..(c + 1) * n].to_vec();
                self.m_inv(&mut x);
                for r in 0..k {
                    w[r * k + c] = (0..n).map(|i| self.j[r * n + i] * x[i]).sum();
                }
            }
            // Exactly symmetric, as the step's W.
            for r in 0..k {
                for c in 0..r {
                    let x = 0.5 * (w[r * k + c] + w[c * k + r]);
                    w[r * k + c] = x;
                    w[c * k + r] = x;
                }
            }
            let u_free = (0..k)
                .map(|r| (0..n).map(|i| self.j[r * n + i] * self.v_free[i]).sum())
                .collect();
            (w, u_free)
        }

        /// The velocity after the impulses, `v_free + M⁻¹ Jᵀ λ`.
        fn v_after(&self, lambda: &[f64]) -> Vec<f64> {
            let n = self.n;
            let mut x: Vec<f64> = (0..n)
                .map(|i| {
                    (0..lambda.len())
                        .map(|r| self.j[r * n + i] * lambda[r])
                        .sum()
                })
                .collect();
            self.m_inv(&mut x);
            x.iter().zip(&self.v_free).map(|(a, b)| a + b).collect()
        }
    }

    const G_DT: f64 = 9.81e-3;

    /// A box resting flat on the floor on its four bottom corners (12 rows on 6 degrees of
    /// freedom: `W` has rank 6), falling at `g dt` and drifting slowly sideways: from a cold
    /// start the solve reaches the exact answer — the box at rest, total normal impulse
    /// `m g dt`, total friction impulse cancelling the drift's momentum — in a few steps.
    #[test]
    fn four_corner_box_comes_to_rest_exactly() {
        let (m, a, b, c) = (2.0, 0.3, 0.2, 0.1);
        let inertia = [
            m / 3.0 * (b * b + c * c),
            m / 3.0 * (a * a + c * c),
            m / 3.0 * (a * a + b * b),
        ];
        let mut mm = vec![0.0; 36];
        for i in 0..3 {
            mm[i * 7] = m;
            mm[(i + 3) * 7] = inertia[i];
        }
        let corners = [[a, b, -c], [-a, b, -c], [-a, -b, -c], [a, -b, -c]];
        let rig = Rig {
            n: 6,
            m: mm,
            j: Rig::corner_rows(6, &corners),
            v_free: vec![1e-3, -2e-3, -G_DT, 0.0, 0.0, 0.0],
        };
        let (w, u_free) = rig.problem();
        let blocks: Vec<Block> = (0..4)
            .map(|i| Block::Contact {
                row: 3 * i,
                mu: 0.8,
            })
            .collect();
        let stop = Stop {
            max_iterations: 200,
            tolerance: 1e-12,
        };
        let (mut l, mut u) = ([0.0; 12], [0.0; 12]);
        let s = solve(
            &w,
            &blocks,
            &u_free,
            &[0.0; 12],
            &mut l,
            &mut u,
            stop,
            &mut Subspace::default(),
        );
        assert!(s.converged && s.iterations <= 8, "{s:?}");
        let v = rig.v_after(&l);
        assert!(v.iter().all(|x| x.abs() < 1e-12), "v⁺ = {v:?}");
        let total = |r: usize| (0..4).map(|i| l[3 * i + r]).sum::<f64>();
        // (Velocities within 1e-12 m/s: impulses within a few times m · 1e-12.)
        assert!((total(0) - m * G_DT).abs() < 1e-11, "{l:?}");
        assert!((total(1) + m * 1e-3).abs() < 1e-11 && (total(2) - m * 2e-3).abs() < 1e-11);
        assert!(
            (0..4).all(|i| l[3 * i] >= 0.0 && l[3 * i + 1].hypot(l[3 * i + 2]) <= 0.8 * l[3 * i])
        );
        println!("four-corner box: {s:?}");
    }

    /// A light foot (1 kg, 4 corners on the floor) under a heavy body (100 kg, 0.5 m above a
    /// ball-joint ankle at the back of the foot), the whole falling at `g dt`: `W` is singular
    /// (rank 6 of 12) and badly conditioned, and plain Gauss–Seidel is still far from
    /// converged after 200 sweeps; the subspace solve converges in a handful of steps to the
    /// exact answer — everything at rest (9 coordinates), total normal impulse `101 kg · g dt`,
    /// no net friction — which a long plain Gauss–Seidel run approaches too.
    #[test]
    fn light_foot_under_a_heavy_body_converges_in_a_few_steps() {
        let (mf, mh) = (1.0, 100.0);
        let (fa, fb, fc) = (0.1, 0.05, 0.025);
        let ankle = [-0.05, 0.0, fc];
        let r = [0.0, 0.0, 0.5]; // heavy centre of mass − ankle
        let foot_i = [
            mf / 3.0 * (fb * fb + fc * fc),
            mf / 3.0 * (fa * fa + fc * fc),
            mf / 3.0 * (fa * fa + fb * fb),
        ];
        let heavy_i = [
            mh / 12.0 * (0.2f64.powi(2) + 1.0),
            mh / 12.0 * (0.3f64.powi(2) + 1.0),
            mh / 12.0 * (0.3f64.powi(2) + 0.2f64.powi(2)),
        ];
        // Coordinates: foot linear and angular velocity (at its centre of mass), the ankle's
        // relative angular velocity. Heavy body: ω_h = ω_f + ω_j,
        // v_h = v_f + ω_f × ankle + ω_h × r.
        let n = 9;
        let skew = |x: [f64; 3]| [[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]];
        let mut jh = vec![0.0; 6 * n];
        let (sa, sr) = (skew(ankle), skew(r));
        for i in 0..3 {
            jh[i * n + i] = 1.0;
            for c in 0..3 {
                // ω × x = −[x] ω
                jh[i * n + 3 + c] = -sa[i][c] - sr[i][c];
                jh[i * n + 6 + c] = -sr[i][c];
            }
            jh[(3 + i) * n + 3 + i] = 1.0;
            jh[(3 + i) * n + 6 + i] = 1.0;
        }
        let mut mm = vec![0.0; n * n];
        for i in 0..3 {
            mm[i * n + i] += mf;
            mm[(3 + i) * n + 3 + i] += foot_i[i];
        }
        let diag_h = [mh, mh, mh, heavy_i[0], heavy_i[1], heavy_i[2]];
        for a in 0..n {
            for b in 0..n {
                mm[a * n + b] += (0..6)
                    .map(|i| jh[i * n + a] * diag_h[i] * jh[i * n + b])
                    .sum::<f64>();
            }
        }
        let corners = [
            [fa, fb, -fc],
            [-fa, fb, -fc],
            [-fa, -fb, -fc],
            [fa, -fb, -fc],
        ];
        let mut v_free = vec![0.0; n];
        v_free[2] = -G_DT;
        let rig = Rig {
            n,
            m: mm,
            j: Rig::corner_rows(n, &corners),
            v_free,
        };
        let (w, u_free) = rig.problem();
        let blocks: Vec<Block> = (0..4)
            .map(|i| Block::Contact {
                row: 3 * i,
                mu: 1.0,
            })
            .collect();
        let target = [0.0; 12];
        let stop = Stop {
            max_iterations: 200,
            tolerance: 1e-9,
        };
        let (mut lp, mut up) = ([0.0; 12], [0.0; 12]);
        let plain = pgs(&w, &blocks, &u_free, &target, &mut lp, &mut up, stop);
        let (mut l, mut u) = ([0.0; 12], [0.0; 12]);
        let s = solve(
            &w,
            &blocks,
            &u_free,
            &target,
            &mut l,
            &mut u,
            stop,
            &mut Subspace::default(),
        );
        println!(
            "light foot: plain {plain:?} (residual {:e}), subspace {s:?}",
            residual(&blocks, &target, &lp, &up)
        );
        assert!(!plain.converged, "{plain:?}");
        assert!(s.converged && s.iterations <= 12, "{s:?}");
        let v = rig.v_after(&l);
        assert!(v.iter().all(|x| x.abs() < 1e-9), "v⁺ = {v:?}");
        let total = |l: &[f64], r: usize| (0..4).map(|i| l[3 * i + r]).sum::<f64>();
        // (Velocities within 1e-9 m/s: impulses within the system's mass times that.)
        let near = 4e-9 * (mf + mh);
        assert!((total(&l, 0) - (mf + mh) * G_DT).abs() < near, "{l:?}");
        assert!(
            total(&l, 1).abs() < near && total(&l, 2).abs() < near,
            "{l:?}"
        );
        // A long plain run approaches the same velocities.
        let long = pgs(
            &w,
            &blocks,
            &u_free,
            &target,
            &mut lp,
            &mut up,
            Stop {
                max_iterations: 200_000,
                tolerance: 1e-12,
            },
        );
        assert!(residual(&blocks, &target, &lp, &up) <= 1e-9, "{long:?}");
        for (a, b) in u.iter().zip(&up) {
            assert!((a - b).abs() < 1e-8, "{u:?} vs {up:?}");
        }
        assert!((total(&lp, 0) - total(&l, 0)).abs() < near, "{long:?}");
    }
}
