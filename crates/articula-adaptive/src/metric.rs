//! Motion metrics (DESIGN §6): the acceleration metric `A(C) = Σ_{i∈C} q̈ᵢᵀ Aᵢ q̈ᵢ` as a
//! quadratic function of C's handle forces, `A(C) = Fᵀ Ψ F + Fᵀ p + η` (the theorem: known
//! before C's joint accelerations), the max-priority joint selection it drives, and the
//! velocity metric `V(C) = Σ_{i∈C} q̇ᵢᵀ Vᵢ q̇ᵢ`.

use crate::dense;
use crate::hybrid::{Adaptive, Entry, Selection};
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
        let tree = &model.assembly;
        for n in 0..tree.nodes.len() {
            let nc = 6 * self.nh[n];
            let (po, pv) = (self.poff[n], 6 * self.lay.hoff[n]);
            let NodeKind::Join {
                joint,
                parent_side: a,
                child_side: b,
            } = tree.nodes[n].kind
            else {
                self.psi[po..po + nc * nc].fill(0.0);
                self.pvec[pv..pv + nc].fill(0.0);
                self.eta[n] = 0.0;
                continue;
            };
            let body = &model.bodies[joint];
            let (vo, k) = (body.v_offset, body.nv);
            let (ko, wo) = (self.koff[n], self.woff[joint]);
            // Own joint: AK = A_C K (k × nc), Ψ = Kᵀ A K, p = 2 Kᵀ A k, η = kᵀ A k.
            let (s1, s2) = (&mut self.s1, &mut self.s2);
            let kmat = &self.kmat[ko..ko + k * nc];
            dense::a_b(&self.aw[wo..wo + k * k], kmat, k, k, nc, s1);
            let psi = &mut self.psi[po..po + nc * nc];
            dense::at_b(kmat, &s1[..k * nc], k, nc, nc, psi);
            let kv = &self.kvec[vo..vo + k];
            let mut ak = [0.0; 6];
            dense::a_x(&self.aw[wo..wo + k * k], kv, k, k, &mut ak);
            dense::at_x(kmat, &ak[..k], k, nc, &mut s2[..nc]);
            for (p, x) in self.pvec[pv..pv + nc].iter_mut().zip(&s2[..nc]) {
                *p = 2.0 * x;
            }
            let mut eta: f64 = kv.iter().zip(&ak).map(|(x, y)| x * y).sum();
            // Children.
            for (x, jx, sign) in [(a, self.lay.ja[n], -1.0), (b, self.lay.jb[n], 1.0)] {
                let nx = 6 * self.nh[x];
                let (pox, pvx) = (self.poff[x], 6 * self.lay.hoff[x]);
                // M_X (nx × nc) in s1, m_X (nx) in s3.
                let (mm, m) = (&mut self.s1, &mut self.s3);
                mm[..nx * nc].fill(0.0);
                m[..nx].fill(0.0);
                let hc = self.lay.hoff[n];
                for h in 0..self.nh[n] {
                    let (from_a, i) = self.lay.from[hc + h];
                    if from_a == (sign < 0.0) {
                        for r in 0..6 {
                            mm[(6 * i + r) * nc + 6 * h + r] = 1.0;
                        }
                    }
                }
                for r in 0..6 {
                    let row = &self.nmat[36 * hc + r * nc..36 * hc + r * nc + nc];
                    for (dst, &v) in mm[(6 * jx + r) * nc..(6 * jx + r) * nc + nc]
                        .iter_mut()
                        .zip(row)
                    {
                        *dst = sign * v;
                    }
                    m[6 * jx + r] = sign * self.nvec[n][r];
                }
                // T = Ψ_X M_X (nx × nc) in s2; u = 2 Ψ_X m_X + p_X in s3[nx..2nx].
                dense::a_b(
                    &self.psi[pox..pox + nx * nx],
                    &self.s1[..nx * nc],
                    nx,
                    nx,
                    nc,
                    &mut self.s2,
                );
                let (m, u) = self.s3.split_at_mut(nx);
                dense::a_x(&self.psi[pox..pox + nx * nx], m, nx, nx, u);
                let px = &self.pvec[pvx..pvx + nx];
                let mpm: f64 = m.iter().zip(u.iter()).map(|(x, y)| x * y).sum();
                let mp: f64 = m.iter().zip(px).map(|(x, y)| x * y).sum();
                eta += mpm + mp + self.eta[x];
                for (ui, pi) in u[..nx].iter_mut().zip(px) {
                    *ui = 2.0 * *ui + pi;
                }
                // Ψ_C += M_Xᵀ T, p_C += M_Xᵀ u.
                let (mm, t) = (&self.s1, &self.s2);
                let psi = &mut self.psi[po..po + nc * nc];
                for r in 0..nx {
                    let mrow = &mm[r * nc..r * nc + nc];
                    let trow = &t[r * nc..r * nc + nc];
                    for (i, &mi) in mrow.iter().enumerate() {
                        if mi == 0.0 {
                            continue;
                        }
                        for (dst, &tv) in psi[i * nc..i * nc + nc].iter_mut().zip(trow) {
                            *dst += mi * tv;
                        }
                    }
                    let ur = self.s3[nx + r];
                    if ur != 0.0 {
                        for (dst, &mi) in self.pvec[pv..pv + nc].iter_mut().zip(mrow) {
                            *dst += mi * ur;
                        }
                    }
                }
            }
            self.eta[n] = eta;
        }
    }

    /// `A(n)` at the handle forces currently in `f`.
    pub(crate) fn metric_at(&mut self, n: usize) -> f64 {
        let nc = 6 * self.nh[n];
        let hc = self.lay.hoff[n];
        for h in 0..self.nh[n] {
            self.fx[6 * h..6 * h + 6].copy_from_slice(&self.f[hc + h].to_array());
        }
        let (po, pv) = (self.poff[n], 6 * hc);
        let fx = &self.fx[..nc];
        dense::quad(&self.psi[po..po + nc * nc], fx, nc)
            + fx.iter()
                .zip(&self.pvec[pv..pv + nc])
                .map(|(x, y)| x * y)
                .sum::<f64>()
            + self.eta[n]
    }

    /// Adaptive joint selection (DESIGN §6) on the articulated coefficients and metric of the
    /// last passes: a max-priority queue keyed by `A(node)` from the root; pop the largest,
    /// compute its joint acceleration and its children's handle forces and metrics, push them;
    /// stop when the budget of internal degrees of freedom is spent or the metric mass left is
    /// at most the tolerance (tolerance 0 or no limit: until the queue is empty). A floating
    /// base's joint (the root) is always selected and free. Unselected joints get `q̈ = 0`.
    pub(crate) fn select(&mut self, model: &Model) -> Selection {
        let tree = &model.assembly;
        self.selected.fill(false);
        self.qdd.fill(0.0);
        self.heap.clear();
        let root = tree.root();
        let (ho, nh) = (self.lay.hoff[root], self.nh[root]);
        self.f[ho..ho + nh].fill(SpatialForce::ZERO);
        let total = self.metric_at(root);
        let mut sel = Selection {
            total_metric: total,
            ..Selection::default()
        };
        if !matches!(tree.nodes[root].kind, NodeKind::Join { .. }) {
            return sel;
        }
        self.heap.push(Entry {
            metric: total,
            node: root,
        });
        let mut remaining = total;
        let budget = self.settings.budget;
        let tol = self.settings.tolerance.filter(|t| *t > 0.0);
        let mut first = true;
        while let Some(&top) = self.heap.peek() {
            let NodeKind::Join { joint, .. } = tree.nodes[top.node].kind else {
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
            self.heap.pop();
            remaining -= top.metric;
            self.selected[top.node] = true;
            sel.active_dofs += cost;
            self.expand(model, top.node);
            let NodeKind::Join {
                parent_side: a,
                child_side: b,
                ..
            } = tree.nodes[top.node].kind
            else {
                unreachable!()
            };
            for c in [a, b] {
                if matches!(tree.nodes[c].kind, NodeKind::Join { .. }) {
                    let metric = self.metric_at(c);
                    remaining += metric;
                    self.heap.push(Entry { metric, node: c });
                }
            }
        }
        sel.predicted_error = self.heap.iter().map(|e| e.metric).sum::<f64>().max(0.0);
        sel
    }

    /// `V(C)` of every node from the velocities `qd`, bottom-up.
    pub(crate) fn velocity_metric(&mut self, model: &Model, qd: &[f64]) {
        let tree = &model.assembly;
        for (n, node) in tree.nodes.iter().enumerate() {
            self.vmetric[n] = match node.kind {
                NodeKind::Join {
                    joint,
                    parent_side: a,
                    child_side: b,
                } => {
                    let body = &model.bodies[joint];
                    let (vo, k, wo) = (body.v_offset, body.nv, self.woff[joint]);
                    let x = &qd[vo..vo + k];
                    dense::quad(&self.vw[wo..wo + k * k], x, k) + self.vmetric[a] + self.vmetric[b]
                }
                _ => 0.0,
            };
        }
    }
}
