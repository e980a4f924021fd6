//! The contact problem at velocity level, solved by projected Gauss–Seidel on the Delassus
//! operator `W = J M⁻¹ Jᵀ` (`docs/contact.md#solver`, `docs/design.md#contact`).
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
//! velocity, never a pulling normal force).

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

/// Projected Gauss–Seidel: `lambda` (the warm start on entry, the impulses on return) for the
/// `k × k` row-major `w`, free velocities `u_free` and targets `target` (tangent rows' targets
/// are unused). `u` is the workspace for the row velocities (`u_free + W λ` on return).
pub(crate) fn solve(
    w: &[f64],
    blocks: &[Block],
    u_free: &[f64],
    target: &[f64],
    lambda: &mut [f64],
    u: &mut [f64],
    stop: Stop,
) -> Solve {
    let Stop {
        max_iterations,
        tolerance,
    } = stop;
    let k = u_free.len();
    // u = u_free + W λ
    contact_velocities(u, u_free, w, lambda);
    // Adds W[:, i] δ to u (W is symmetric: its row i).
    let apply = |u: &mut [f64], i: usize, d: f64| {
        if d != 0.0 {
            for (x, wij) in u.iter_mut().zip(&w[i * k..(i + 1) * k]) {
                *x += wij * d;
            }
        }
    };
    // A unilateral row's exact update (its 1-D minimiser, clamped at 0): the velocity change.
    let unilateral = |lambda: &mut [f64], u: &mut [f64], i: usize| {
        let wii = w[i * k + i];
        if wii.is_nan() || wii <= 0.0 {
            // A row no impulse can move (its body's joints are all locked or welded).
            return 0.0;
        }
        let new = (lambda[i] - (u[i] - target[i]) / wii).max(0.0);
        let d = new - lambda[i];
        lambda[i] = new;
        apply(u, i, d);
        (d * wii).abs()
    };
    let mut out = Solve::default();
    for it in 0..max_iterations {
        let mut change = 0.0f64;
        for block in blocks {
            match *block {
                Block::Unilateral { row } => change = change.max(unilateral(lambda, u, row)),
                Block::Contact { row: n, mu } => {
                    change = change.max(unilateral(lambda, u, n));
                    // Tangents: the 2 × 2 solve for zero slip when it lies in the disc
                    // (sticking); else a projected gradient step of length 1/L (L the larger
                    // eigenvalue of the 2 × 2 block), whose fixed point on the rim opposes
                    // the slip (maximal dissipation) and which never raises the objective.
                    let (t1, t2) = (n + 1, n + 2);
                    let (a, b, c) = (w[t1 * k + t1], w[t1 * k + t2], w[t2 * k + t2]);
                    let det = a * c - b * b;
                    let bound = mu * lambda[n];
                    let (r1, r2) = (-u[t1], -u[t2]);
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
                    apply(u, t1, d1);
                    apply(u, t2, d2);
                    change = change.max((d1 * a).abs()).max((d2 * c).abs());
                }
            }
        }
        out = Solve {
            iterations: it + 1,
            change,
            converged: change <= tolerance || residual(blocks, target, lambda, u) <= tolerance,
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
    let head = |b: &Block| match *b {
        Block::Unilateral { row } | Block::Contact { row, .. } => row,
    };
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
        set.w.extend(
            set.rows
                .iter()
                .flat_map(|&i| set.rows.iter().map(move |&j| w[i * k + j])),
        );
        set.u_free.clear();
        set.u_free.extend(set.rows.iter().map(|&i| u_free[i]));
        set.target.clear();
        set.target.extend(set.rows.iter().map(|&i| target[i]));
        set.lambda.clear();
        set.lambda.extend(set.rows.iter().map(|&i| lambda[i]));
        set.u.clear();
        set.u.resize(a, 0.0);
        let s = solve(
            &set.w,
            &set.blocks,
            &set.u_free,
            &set.target,
            &mut set.lambda,
            &mut set.u,
            Stop {
                // (Blocks that joined after the last allowed sweep get one more: a contact
                // approaching with no impulse is never left out.)
                max_iterations: stop.max_iterations.saturating_sub(total.iterations).max(1),
                tolerance: stop.tolerance,
            },
        );
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
fn contact_velocities(u: &mut [f64], u_free: &[f64], w: &[f64], lambda: &[f64]) {
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
        let full = solve(
            &w,
            &blocks,
            &u_free,
            &target,
            &mut l_full,
            &mut u_full,
            stop,
        );
        let (mut l, mut u) = ([0.0; 12], [0.0; 12]);
        let mut set = ActiveSet::default();
        let act = solve_active(
            &w, &blocks, &u_free, &target, &mut l, &mut u, stop, &mut set,
        );
        assert!(full.converged && act.converged, "{full:?} {act:?}");
        assert!(residual(&blocks, &target, &l, &u) <= 1e-10);
        for i in 0..k {
            assert!((u[i] - u_full[i]).abs() < 1e-9, "u {u:?} vs {u_full:?}");
            let want = u_free[i] + (0..k).map(|j| w[i * k + j] * l[j]).sum::<f64>();
            assert!((u[i] - want).abs() < 1e-12);
        }
        assert!(l[0] > 0.0 && l[3] == 0.0, "{l:?}");
    }
}
