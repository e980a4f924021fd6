//! Motion metrics (docs/design.md#adaptive): acceleration metric `A(C) = Σ_{i∈C} q̈ᵢᵀ Aᵢ q̈ᵢ` as a
//! quadratic function of C's handle forces, `A(C) = Fᵀ Ψ F + Fᵀ p + η` (the theorem: known
//! before C's joint accelerations), the max-priority joint selection it drives, and the
//! velocity metric `V(C) = Σ_{i∈C} q̇ᵢᵀ Vᵢ q̇ᵢ`, and the exact solve of a metric query.
//!
//! Neither metric stands for `q̈ᵀ H q̈` or `q̇ᵀ H q̇`: `Aᵢ` and `Vᵢ` are the caller's weights
//! (identity by default), not the joint-space inertia, so armature does not enter them as a
//! weight. It enters through the accelerations: `K`, `k` of the joins (and the exact solve)
//! are those of `(M + A) q̈ = τ − b`, so Ψ, p, η and the exact node metrics are the metric of
//! the dynamics with armature (and, in a step, with its passive forces and `A + h B`).

use crate::adaptive::Adaptive;
use crate::dense;
use crate::parts::selection_queue::{Entry, Selection};
use articula_dca::DynamicsError;
use articula_model::{Model, NodeKind};
use articula_spatial::SpatialForce;

impl Adaptive {
    /// Ψ, p, η of every node, bottom-up, from the articulated coefficients of the last main
    /// pass. With `q̈_C = K F + k` and the children's handle forces affine in C's,
    /// `F_A = M_A F + m_A`, `F_B = M_B F + m_B`:
    /// `Ψ_C = Kᵀ A_C K + M_Aᵀ Ψ_A M_A + M_Bᵀ Ψ_B M_B`,
    /// `p_C = 2 Kᵀ A_C k + M_Aᵀ (2 Ψ_A m_A + p_A) + M_Bᵀ (2 Ψ_B m_B + p_B)`,
    /// `η_C = kᵀ A_C k + m_Aᵀ Ψ_A m_A + m_Aᵀ p_A + η_A + (same for B)`. Leaves: 0.
    pub(crate) fn metric_pass(&mut self, model: &Model) {
        for n in 0..model.assembly.nodes.len() {
            self.metric_node(model, n);
        }
    }

    /// Ψ, p, η of node `n` from its children's (see [`Adaptive::metric_pass`]).
    pub(crate) fn metric_node(&mut self, model: &Model, n: usize) {
        let tree = &model.assembly;
        {
            let nc = 6 * self.coef.handles[n];
            let (po, pv) = (self.metric.quad_at[n], 6 * self.coef.layout.hoff[n]);
            let NodeKind::Join {
                joint,
                parent_side: a,
                child_side: b,
            } = tree.nodes[n].kind
            else {
                self.metric.quad[po..po + nc * nc].fill(0.0);
                self.metric.linear[pv..pv + nc].fill(0.0);
                self.metric.constant[n] = 0.0;
                return;
            };
            let body = &model.bodies[joint];
            let (vo, k) = (body.v_offset, body.nv);
            let (ko, wo) = (self.maps.qdd_gain_at[n], self.metric.weight_at[joint]);
            // Own joint: AK = A_C K (k × nc), Ψ = Kᵀ A K, p = 2 Kᵀ A k, η = kᵀ A k.
            let (s1, s2) = (&mut self.scratch.metric_ak, &mut self.scratch.metric_g);
            let kmat = &self.maps.qdd_gain[ko..ko + k * nc];
            dense::a_b(
                &self.metric.accel_weights[wo..wo + k * k],
                kmat,
                k,
                k,
                nc,
                s1,
            );
            let psi = &mut self.metric.quad[po..po + nc * nc];
            dense::at_b(kmat, &s1[..k * nc], k, nc, nc, psi);
            let kv = &self.maps.qdd_bias[vo..vo + k];
            let mut ak = [0.0; 6];
            dense::a_x(
                &self.metric.accel_weights[wo..wo + k * k],
                kv,
                k,
                k,
                &mut ak,
            );
            dense::at_x(kmat, &ak[..k], k, nc, &mut s2[..nc]);
            for (p, x) in self.metric.linear[pv..pv + nc].iter_mut().zip(&s2[..nc]) {
                *p = 2.0 * x;
            }
            let mut eta: f64 = kv.iter().zip(&ak).map(|(x, y)| x * y).sum();
            // Children. M_X copies C's handle forces onto X's shared handles and puts
            // s·(N F + n) on X's principal-joint handle jx (s = −1 for A, +1 for B), so with
            // Ψ_X in handle blocks: Ψ_C gets Ψ_X[i,l] at (h_i, h_l), s·Ψ_X[i,jx] N on rows
            // h_i (and its transpose), and Nᵀ Ψ_X[jx,jx] N.
            for (x, jx, sign) in [
                (a, self.coef.layout.ja[n], -1.0),
                (b, self.coef.layout.jb[n], 1.0),
            ] {
                eta += self.metric_child(n, x, jx, sign);
            }
            self.metric.constant[n] = eta;
        }
    }

    /// Child `x` of join `n` (its principal-joint handle `jx`, `sign` −1 for A, +1 for B)
    /// into n's Ψ and p (see [`Adaptive::metric_node`]); returns its share of η.
    fn metric_child(&mut self, n: usize, x: usize, jx: usize, sign: f64) -> f64 {
        let nc = 6 * self.coef.handles[n];
        let (po, pv) = (self.metric.quad_at[n], 6 * self.coef.layout.hoff[n]);
        let hc = self.coef.layout.hoff[n];
        let nhc = self.coef.handles[n];
        let nx = 6 * self.coef.handles[x];
        let (pox, pvx) = (self.metric.quad_at[x], 6 * self.coef.layout.hoff[x]);
        // X handle i → C handle (usize::MAX for jx).
        let map = &mut self.scratch.handle_map;
        map.fill(usize::MAX);
        for h in 0..nhc {
            let (from_a, i) = self.coef.layout.from[hc + h];
            if from_a == (sign < 0.0) {
                map[i] = h;
            }
        }
        // Children precede their parent in post-order: X's blocks lie below C's.
        let (psi_lo, psi_hi) = self.metric.quad.split_at_mut(po);
        let psix = &psi_lo[pox..pox + nx * nx];
        let psic = &mut psi_hi[..nc * nc];
        let (p_lo, p_hi) = self.metric.linear.split_at_mut(pv);
        let px = &p_lo[pvx..pvx + nx];
        let pc = &mut p_hi[..nc];
        let nm = &self.maps.force_gain[36 * hc..36 * hc + 6 * nc];
        let nvec = self.maps.force_bias[n];
        // G = Ψ_X[jx,jx] N (6 × nc) in s2.
        let g = &mut self.scratch.metric_g[..6 * nc];
        g.fill(0.0);
        for r in 0..6 {
            for t in 0..6 {
                let w = psix[(6 * jx + r) * nx + 6 * jx + t];
                if w != 0.0 {
                    for (gv, &nv) in g[r * nc..r * nc + nc]
                        .iter_mut()
                        .zip(&nm[t * nc..t * nc + nc])
                    {
                        *gv += w * nv;
                    }
                }
            }
        }
        // Nᵀ G
        for t in 0..6 {
            let grow = &g[t * nc..t * nc + nc];
            for (i, &ni) in nm[t * nc..t * nc + nc].iter().enumerate() {
                if ni != 0.0 {
                    for (dst, &gv) in psic[i * nc..i * nc + nc].iter_mut().zip(grow) {
                        *dst += ni * gv;
                    }
                }
            }
        }
        // u_jx = 2 Ψ_X[jx,jx] m + p_X,jx with m = s n; η terms.
        let mut ujx = [0.0; 6];
        let mut eta_x = self.metric.constant[x];
        for r in 0..6 {
            let mut psim = 0.0;
            for t in 0..6 {
                psim += psix[(6 * jx + r) * nx + 6 * jx + t] * sign * nvec[t];
            }
            eta_x += sign * nvec[r] * (psim + px[6 * jx + r]);
            ujx[r] = 2.0 * psim + px[6 * jx + r];
        }
        // p_C += Nᵀ (s u_jx)
        for t in 0..6 {
            let w = sign * ujx[t];
            for (dst, &nv) in pc.iter_mut().zip(&nm[t * nc..t * nc + nc]) {
                *dst += w * nv;
            }
        }
        for i in 0..self.coef.handles[x] {
            let hi = map[i];
            if hi == usize::MAX {
                continue;
            }
            // Ψ_X[i,l] blocks for shared handles l.
            for l in 0..self.coef.handles[x] {
                let hl = map[l];
                if hl == usize::MAX {
                    continue;
                }
                for r in 0..6 {
                    let src = &psix[(6 * i + r) * nx + 6 * l..(6 * i + r) * nx + 6 * l + 6];
                    let dst = &mut psic[(6 * hi + r) * nc + 6 * hl..(6 * hi + r) * nc + 6 * hl + 6];
                    for (d, v) in dst.iter_mut().zip(src) {
                        *d += v;
                    }
                }
            }
            // C = s Ψ_X[i,jx] N (6 × nc): rows 6 hi.., and columns 6 hi.. (transpose).
            for r in 0..6 {
                let row = 6 * hi + r;
                let crow = &mut self.scratch.metric_row[..nc];
                crow.fill(0.0);
                for t in 0..6 {
                    let w = sign * psix[(6 * i + r) * nx + 6 * jx + t];
                    if w != 0.0 {
                        for (cv, &nv) in crow.iter_mut().zip(&nm[t * nc..t * nc + nc]) {
                            *cv += w * nv;
                        }
                    }
                }
                for c in 0..nc {
                    psic[row * nc + c] += crow[c];
                    psic[c * nc + row] += crow[c];
                }
                // u_i = 2 s Ψ_X[i,jx] n + p_X,i
                let mut ui = px[6 * i + r];
                for t in 0..6 {
                    ui += 2.0 * sign * psix[(6 * i + r) * nx + 6 * jx + t] * nvec[t];
                }
                pc[row] += ui;
            }
        }

        eta_x
    }

    /// `A(n)` at the handle forces currently in `f`.
    pub(crate) fn metric_at(&mut self, n: usize) -> f64 {
        let nc = 6 * self.coef.handles[n];
        let hc = self.coef.layout.hoff[n];
        for h in 0..self.coef.handles[n] {
            self.scratch.handle_forces[6 * h..6 * h + 6]
                .copy_from_slice(&self.coef.force[hc + h].to_array());
        }
        let (po, pv) = (self.metric.quad_at[n], 6 * hc);
        let fx = &self.scratch.handle_forces[..nc];
        dense::quad(&self.metric.quad[po..po + nc * nc], fx, nc)
            + fx.iter()
                .zip(&self.metric.linear[pv..pv + nc])
                .map(|(x, y)| x * y)
                .sum::<f64>()
            + self.metric.constant[n]
    }

    /// Joint selection (docs/design.md#adaptive) on the articulated coefficients and metric of the
    /// last passes: a max-priority queue keyed by `A(node)` from the root; pop the largest,
    /// compute its joint acceleration and its children's handle forces and metrics, push them;
    /// stop when the budget of internal degrees of freedom is spent or the metric mass left is
    /// at most the tolerance (tolerance 0 or no limit: until the queue is empty). A floating
    /// base's joint (the root) is always selected and free. Unselected joints get `q̈ = 0`.
    pub(crate) fn select(&mut self, model: &Model) -> Selection {
        self.queue.selected.fill(false);
        self.body.qdd.fill(0.0);
        let total = self.metric_at(model.assembly.root());
        self.run_queue(
            model,
            total,
            |_, _| false,
            |ad, _, c| {
                matches!(model.assembly.nodes[c].kind, NodeKind::Join { .. })
                    .then(|| ad.metric_at(c))
            },
        )
    }

    /// The priority queue of the selection, from the root (metric `total`) with zero handle
    /// forces: pops the largest metric while the budget and the tolerance allow, marks it
    /// selected, lets `on_pop` prepare the node, back-substitutes it ([`Adaptive::expand`];
    /// not when `on_pop` says this pass's handle forces and `q̈` of the node are there already) and
    /// pushes each child for which `child(self, node, child)` gives a metric (the joins).
    /// Shared by the whole-body selection ([`Adaptive::select`]) and the cached one
    /// (`update.rs`), which differ only in where a node's coefficients and metric come from.
    pub(crate) fn run_queue(
        &mut self,
        model: &Model,
        total: f64,
        mut on_pop: impl FnMut(&mut Self, usize) -> bool,
        mut child: impl FnMut(&mut Self, usize, usize) -> Option<f64>,
    ) -> Selection {
        let tree = &model.assembly;
        self.queue.heap.clear();
        let root = tree.root();
        let (ho, nh) = (self.coef.layout.hoff[root], self.coef.handles[root]);
        self.coef.force[ho..ho + nh].fill(SpatialForce::ZERO);
        let mut sel = Selection {
            total_metric: total,
            ..Selection::default()
        };
        if !matches!(tree.nodes[root].kind, NodeKind::Join { .. }) {
            return sel;
        }
        self.queue.heap.push(Entry {
            metric: total,
            node: root,
        });
        let mut remaining = total;
        let budget = self.settings.budget;
        let tol = self.settings.tolerance.filter(|t| *t > 0.0);
        let mut first = true;
        while let Some(&top) = self.queue.heap.peek() {
            let NodeKind::Join {
                joint,
                parent_side: a,
                child_side: b,
            } = tree.nodes[top.node].kind
            else {
                unreachable!("only joins are queued")
            };
            let cost = model.bodies[joint].nv;
            let free = first && model.floating_base;
            first = false;
            if !free {
                if tol.is_some_and(|t| remaining <= t) {
                    break;
                }
                if budget.is_some_and(|b| sel.budget_used + cost > b) {
                    break;
                }
                sel.budget_used += cost;
            }
            self.queue.heap.pop();
            remaining -= top.metric;
            let n = top.node;
            self.queue.selected[n] = true;
            sel.active_dofs += cost;
            if !on_pop(self, n) {
                self.expand(model, n);
            }
            for c in [a, b] {
                if let Some(metric) = child(self, n, c) {
                    remaining += metric;
                    self.queue.heap.push(Entry { metric, node: c });
                }
            }
        }
        sel.predicted_error = self
            .queue
            .heap
            .iter()
            .map(|e| e.metric)
            .sum::<f64>()
            .max(0.0);
        sel
    }

    /// `A(C)` of every node at the joint accelerations in `body.qdd` (an exact solve's).
    pub(crate) fn exact_node_metrics(&self, model: &Model, out: &mut [f64]) {
        subtree_quadratic(
            model,
            &self.metric.accel_weights,
            &self.metric.weight_at,
            &self.body.qdd,
            out,
        );
    }

    /// `V(C)` of every node from the velocities `qd`, bottom-up.
    pub(crate) fn velocity_metric(&mut self, model: &Model, qd: &[f64]) {
        subtree_quadratic(
            model,
            &self.metric.velocity_weights,
            &self.metric.weight_at,
            qd,
            &mut self.queue.velocity_metric,
        );
    }
}

/// `Σ_{i∈C} xᵢᵀ Wᵢ xᵢ` of every node `C` of the assembly tree, bottom-up (post-order: a child
/// before its parent), with joint i's k×k weight at `w[woff[i]..]`: the velocity metric from
/// `q̇` and `V`, or the acceleration metric from exact `q̈` and `A`.
pub(crate) fn subtree_quadratic(
    model: &Model,
    w: &[f64],
    woff: &[usize],
    x: &[f64],
    out: &mut [f64],
) {
    subtree_sums(model, out, |joint, body| {
        let (vo, k, wo) = (body.v_offset, body.nv, woff[joint]);
        dense::quad(&w[wo..wo + k * k], &x[vo..vo + k], k)
    });
}

/// `out[n]` = the join's own term `term(joint, body)` plus its two sides' sums, bottom-up over
/// the assembly tree (0 at leaves).
#[inline(always)]
fn subtree_sums(
    model: &Model,
    out: &mut [f64],
    term: impl Fn(usize, &articula_model::Body) -> f64,
) {
    for (n, node) in model.assembly.nodes.iter().enumerate() {
        out[n] = match node.kind {
            NodeKind::Join {
                joint,
                parent_side: a,
                child_side: b,
            } => term(joint, &model.bodies[joint]) + out[a] + out[b],
            _ => 0.0,
        };
    }
}

/// [`subtree_quadratic`] with every weight a scaled identity `Aᵢ = wᵢ 1` given by its scale
/// (one per model body): per joint `Σₖ xₖ (wᵢ xₖ)` over its non-zero components, in order —
/// the same operations [`crate::dense::quad`] does on the scaled identity (its row sums add
/// exact zeros to `wᵢ xₖ`), so the same numbers to the bit.
pub(crate) fn subtree_scaled_quadratic(model: &Model, w: &[f64], x: &[f64], out: &mut [f64]) {
    subtree_sums(model, out, |joint, body| {
        let (vo, k, wi) = (body.v_offset, body.nv, w[joint]);
        let mut s = 0.0;
        for &xk in &x[vo..vo + k] {
            if xk != 0.0 {
                s += xk * (wi * xk);
            }
        }
        s
    });
}

/// The exact solve of [`Adaptive::exact_solve`] on `data`'s buffers (the workspace's own or
/// a scratch's): `q̈` into `qdd`.
pub(crate) fn solve_exact(
    model: &Model,
    data: &mut articula_dca::Data,
    qdd: &mut [f64],
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    f_ext: &[SpatialForce],
) -> Result<(), DynamicsError> {
    // A metric steers the selection: ~1e-9 relative is plenty, so the floating-base
    // refinement of the exact solve (for long floating chains) is skipped here.
    let refine = std::mem::replace(&mut data.refine_floating, false);
    let solved = articula_dca::forward_dynamics_slices(
        model,
        data,
        q,
        qd,
        tau,
        f_ext,
        articula_dca::Method::Aba,
    )
    .map(|x| qdd.copy_from_slice(x));
    data.refine_floating = refine;
    solved
}
