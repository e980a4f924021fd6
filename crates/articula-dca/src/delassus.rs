//! The contact step's articulated tree: `M⁻¹` applied to contact wrenches and joint impulses
//! without a forward-dynamics solve per column (`docs/contact.md#cost`,
//! `docs/design.md#contact`).
//!
//! The system at rest without gravity is articulated **once per step** (Featherstone's
//! articulated-body algorithm, RBDA Table 7.1, at `v = 0`, `a_g = 0`): leaves to root,
//! `U = Iᴬ S`, `D = Sᵀ U`, `Iᴬ_parent += Iᴬ − U D⁻¹ Uᵀ`. A node is a joint that moves in the
//! step; a body whose joint does not move (a locked joint of a hybrid body) is welded to its
//! parent's node, its inertia added to that node's, and a body welded to the world has no
//! node. So the same tree is exact dynamics' (every joint a node) and a hybrid body's reduced
//! system (the active joints, each with its rigid cluster).
//!
//! Then the response to one load (a unit wrench on a body, or a unit generalised force on a
//! joint) is, with `pᴬ = −f` at the loaded node, a walk **up its path** —
//! `u = τ − Sᵀ pᴬ`, `g = D⁻¹ u`, `pᴬ_parent = pᴬ + U g` — and **down** the nodes some row
//! reads — `a' = a_parent`, `q̈ = g − D⁻¹ Uᵀ a'` (`g = 0` off the path), `a = a' + S q̈` — in
//! O(depth + rows' paths) instead of O(n). The whole response `M⁻¹ τ` (the impulses applied
//! to the velocities) is the same two passes over every node, O(n).

use crate::{ContactDynamics, Data, DynamicsError};
use articula_model::Model;
use articula_spatial::numerics::{dot6, invert_spd_into, Portable};
use articula_spatial::{SpatialForce, SpatialInertia, SpatialMotion};

/// "No node": a body welded to the world, or the parent of a root node.
pub(crate) const NONE: usize = usize::MAX;

type V6 = [f64; 6];

/// One moving joint: its degrees of freedom and articulated-body quantities (computation
/// frame). `s`, `u` by columns, `dut = D⁻¹ Uᵀ` and `dinv` by rows; `k` of each used.
#[derive(Clone, Copy, Debug)]
struct Node {
    parent: usize,
    vo: usize,
    k: usize,
    s: [V6; 6],
    /// The rigid inertia of its bodies (the joint's and those welded to it).
    rigid: SpatialInertia,
    ia: [V6; 6],
    u: [V6; 6],
    dinv: [[f64; 6]; 6],
    dut: [V6; 6],
}

impl Default for Node {
    fn default() -> Self {
        Node {
            parent: NONE,
            vo: 0,
            k: 0,
            s: [[0.0; 6]; 6],
            rigid: SpatialInertia::default(),
            ia: [[0.0; 6]; 6],
            u: [[0.0; 6]; 6],
            dinv: [[0.0; 6]; 6],
            dut: [[0.0; 6]; 6],
        }
    }
}

/// A load of one response column.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Load {
    /// A wrench (computation frame) on the bodies of a node.
    Wrench(SpatialForce),
    /// A generalised force `value` on degree of freedom `dof` of a node (0-based in it).
    Tau { dof: usize, value: f64 },
}

/// The articulated tree of one step and its per-column workspace (grown, never shrunk: a
/// step allocates only when it meets a larger tree or more rows than any before).
#[derive(Clone, Debug)]
pub(crate) struct Tree {
    /// Per body: the node it moves with ([`NONE`]: welded to the world).
    pub body_node: Vec<usize>,
    nodes: Vec<Node>,
    /// This step's nodes (the first `len` of `nodes`).
    len: usize,
    /// Per node: a bias force, a `g = D⁻¹ u`, an acceleration (or velocity), its `q̈`.
    p: Vec<V6>,
    g: Vec<V6>,
    acc: Vec<V6>,
    qdd: Vec<V6>,
    /// Per node: the column that put it on its load's path (`g` valid), and the build whose
    /// rows read it (stamps: nothing is reset between columns or steps).
    stamp: Vec<usize>,
    read: Vec<usize>,
    /// The nodes some row reads and their root paths, ascending (parents first).
    needed: Vec<usize>,
    /// The down pass's cost over `needed` ([`Tree::column_cost`]'s units).
    down_cost: usize,
    /// Columns and builds so far (never reset: the stamps of `stamp` and `read`).
    column: usize,
    build: usize,
}

impl Tree {
    /// The workspace for `model`, sized for every joint moving (a step then allocates
    /// nothing here, whatever joints move).
    pub(crate) fn new(model: &Model) -> Tree {
        let n = model.bodies.iter().filter(|b| b.nv > 0).count();
        Tree {
            body_node: Vec::with_capacity(model.bodies.len()),
            nodes: Vec::with_capacity(n),
            len: 0,
            p: Vec::with_capacity(n),
            g: Vec::with_capacity(n),
            acc: Vec::with_capacity(n),
            qdd: Vec::with_capacity(n),
            stamp: Vec::with_capacity(n),
            read: Vec::with_capacity(n),
            needed: Vec::with_capacity(n),
            down_cost: 0,
            column: 0,
            build: 0,
        }
    }

    /// Builds and articulates the tree of `dynamics` at its kinematics (the start of the
    /// step): one node per moving joint, the other bodies' inertias welded to their parent's
    /// node. O(n).
    pub(crate) fn build<D: ContactDynamics + ?Sized>(
        &mut self,
        model: &Model,
        dynamics: &D,
    ) -> Result<(), DynamicsError> {
        let kin: &Data = dynamics.kinematics();
        let nb = model.bodies.len();
        self.body_node.clear();
        self.body_node.resize(nb, NONE);
        // Nodes are overwritten in place (only their first `k` columns and rows are read):
        // `len` counts this step's.
        let mut len = 0;
        for (b, body) in model.bodies.iter().enumerate() {
            let parent = body.parent.map_or(NONE, |p| {
                debug_assert!(p < b, "bodies are stored parents first");
                self.body_node[p]
            });
            let inertia = dynamics.world_inertia(model, b);
            if body.nv > 0 && dynamics.moves(model, b) {
                if len == self.nodes.len() {
                    self.nodes.push(Node::default());
                }
                let node = &mut self.nodes[len];
                node.parent = parent;
                node.vo = body.v_offset;
                node.k = body.nv;
                node.rigid = inertia;
                for d in 0..body.nv {
                    node.s[d] = kin.s[body.v_offset + d].to_array();
                }
                self.body_node[b] = len;
                len += 1;
            } else {
                self.body_node[b] = parent;
                if parent != NONE {
                    self.nodes[parent].rigid += inertia;
                }
            }
        }
        self.len = len;
        for node in &mut self.nodes[..len] {
            inertia_rows(&node.rigid, &mut node.ia);
        }
        // Leaves to root: U = Iᴬ S, D = Sᵀ U (plus the added inertia), D⁻¹, and the parent's Iᴬ += Iᴬ − U D⁻¹ Uᵀ.
        for i in (0..len).rev() {
            let (before, rest) = self.nodes.split_at_mut(i);
            let node = &mut rest[0];
            let k = node.k;
            for d in 0..k {
                node.u[d] = std::array::from_fn(|r| dot6::<Portable>(&node.ia[r], &node.s[d]));
            }
            let mut dm = [[0.0f64; 6]; 6];
            for a in 0..k {
                for b in 0..k {
                    dm[a][b] = dot6::<Portable>(&node.s[a], &node.u[b]);
                }
                dm[a][a] += dynamics.added_inertia(model, node.vo + a);
            }
            let spd = if k == 1 {
                // One dof: D⁻¹ = 1/d.
                node.dinv[0][0] = 1.0 / dm[0][0];
                dm[0][0] > 0.0
            } else {
                invert_spd_into(&dm, k, &mut node.dinv)
            };
            if !spd {
                let vo = node.vo;
                let body = (0..model.bodies.len())
                    .find(|&b| model.bodies[b].v_offset == vo && model.bodies[b].nv > 0)
                    .unwrap_or(0);
                return Err(DynamicsError::Singular {
                    joint: model.bodies[body].joint_name(),
                    detail: "Sᵀ Iᴬ S of the contact step's tree is not positive definite",
                });
            }
            for a in 0..k {
                node.dut[a] =
                    std::array::from_fn(|r| (0..k).map(|b| node.dinv[a][b] * node.u[b][r]).sum());
            }
            if node.parent != NONE {
                let pia = &mut before[node.parent].ia;
                for r in 0..6 {
                    for c in 0..6 {
                        let ud: f64 = (0..k).map(|d| node.u[d][r] * node.dut[d][c]).sum();
                        pia[r][c] += node.ia[r][c] - ud;
                    }
                }
            }
        }
        // Per-node buffers: every entry a pass reads it has written first (the stamps tell
        // the others). They are cleared all the same: the clearing brings them into cache
        // more cheaply than the passes' first scattered writes would.
        let n = len;
        for v in [&mut self.p, &mut self.g, &mut self.acc, &mut self.qdd] {
            v.clear();
            v.resize(n, [0.0; 6]);
        }
        if self.stamp.len() < n {
            self.stamp.resize(n, 0);
            self.read.resize(n, 0);
        }
        self.build += 1;
        self.needed.clear();
        self.down_cost = 0;
        Ok(())
    }

    /// The first degree of freedom of node `i`.
    pub(crate) fn v_offset(&self, i: usize) -> usize {
        self.nodes[i].vo
    }

    /// Marks node `i` (and its root path) as read by some row; call for every row's node
    /// before the columns.
    pub(crate) fn mark_read(&mut self, mut i: usize) {
        while i != NONE && self.read[i] != self.build {
            self.read[i] = self.build;
            i = self.nodes[i].parent;
        }
    }

    /// Orders the marked nodes (after every [`Tree::mark_read`]).
    pub(crate) fn finish_marks(&mut self) {
        self.needed.clear();
        self.down_cost = 0;
        for i in 0..self.len {
            if self.read[i] == self.build {
                self.needed.push(i);
                self.down_cost += 18 * self.nodes[i].k + 6;
            }
        }
    }

    /// An estimate of what one [`Tree::column`] loaded at node `at` costs, in multiply-adds:
    /// the walk up its path (`k² + 12k` per node of `k` dofs) and the down pass over the
    /// marked nodes (`18k + 6` each). O(depth of `at`).
    pub(crate) fn column_cost(&self, mut at: usize) -> usize {
        let mut cost = self.down_cost;
        while at != NONE {
            let k = self.nodes[at].k;
            cost += k * k + 12 * k + 6;
            at = self.nodes[at].parent;
        }
        cost
    }

    /// The response of the system at rest to `load` on node `at` ([`NONE`]: nothing moves):
    /// afterwards [`Tree::accel`] and [`Tree::joint_accel`] read it at the marked nodes.
    /// O(depth of `at` + marked nodes).
    pub(crate) fn column(&mut self, at: usize, load: Load) {
        self.column += 1;
        let col = self.column;
        if at == NONE {
            for &i in &self.needed {
                self.acc[i] = [0.0; 6];
                self.qdd[i] = [0.0; 6];
            }
            return;
        }
        // Up: pᴬ = −f (or 0), u = τ − Sᵀ pᴬ, g = D⁻¹ u, pᴬ_parent = pᴬ + U g.
        let mut p: V6 = match load {
            Load::Wrench(f) => {
                let f = f.to_array();
                std::array::from_fn(|r| -f[r])
            }
            Load::Tau { .. } => [0.0; 6],
        };
        let mut i = at;
        let mut first = true;
        while i != NONE {
            let node = &self.nodes[i];
            let k = node.k;
            let mut u = [0.0; 6];
            for (d, ud) in u.iter_mut().enumerate().take(k) {
                *ud = -dot6::<Portable>(&node.s[d], &p);
            }
            if let (true, Load::Tau { dof, value }) = (first, load) {
                u[dof] += value;
            }
            first = false;
            let g: V6 = std::array::from_fn(|a| {
                if a < k {
                    (0..k).map(|b| node.dinv[a][b] * u[b]).sum()
                } else {
                    0.0
                }
            });
            if node.parent != NONE {
                for d in 0..k {
                    for (r, pr) in p.iter_mut().enumerate() {
                        *pr += node.u[d][r] * g[d];
                    }
                }
            }
            self.g[i] = g;
            self.stamp[i] = col;
            i = node.parent;
        }
        // Down the marked nodes: q̈ = g − D⁻¹ Uᵀ a', a = a' + S q̈.
        for &i in &self.needed {
            let node = &self.nodes[i];
            let root = node.parent == NONE;
            let ap = if root {
                [0.0; 6]
            } else {
                self.acc[node.parent]
            };
            let on = self.stamp[i] == col;
            let mut a = ap;
            let mut qdd = [0.0; 6];
            for d in 0..node.k {
                let gd = if on { self.g[i][d] } else { 0.0 };
                // (A root's a' is 0: q̈ = g.)
                let x = if root {
                    gd
                } else {
                    gd - dot6::<Portable>(&node.dut[d], &ap)
                };
                qdd[d] = x;
                for (r, ar) in a.iter_mut().enumerate() {
                    *ar += node.s[d][r] * x;
                }
            }
            self.acc[i] = a;
            self.qdd[i] = qdd;
        }
    }

    /// The last column's acceleration of node `i` (marked; [`NONE`]: zero).
    pub(crate) fn accel(&self, i: usize) -> SpatialMotion {
        if i == NONE {
            SpatialMotion::ZERO
        } else {
            SpatialMotion::from_array(self.acc[i])
        }
    }

    /// The last column's `q̈` of degree of freedom `dof` of node `i` (marked).
    pub(crate) fn joint_accel(&self, i: usize, dof: usize) -> f64 {
        self.qdd[i][dof]
    }

    /// `out = M⁻¹ τ` of the system at rest for the generalised force `tau` plus the wrenches
    /// `wrenches` (per node, computation frame); 0 for a joint that does not move. O(n).
    pub(crate) fn solve(&mut self, tau: &[f64], wrenches: &[V6], out: &mut [f64]) {
        out.fill(0.0);
        let n = self.len;
        for i in 0..n {
            let f = wrenches[i];
            self.p[i] = std::array::from_fn(|r| -f[r]);
        }
        for i in (0..n).rev() {
            let node = &self.nodes[i];
            let k = node.k;
            let p = self.p[i];
            let u: V6 = std::array::from_fn(|d| {
                if d < k {
                    tau[node.vo + d] - dot6::<Portable>(&node.s[d], &p)
                } else {
                    0.0
                }
            });
            let g: V6 = std::array::from_fn(|a| {
                if a < k {
                    (0..k).map(|b| node.dinv[a][b] * u[b]).sum()
                } else {
                    0.0
                }
            });
            self.g[i] = g;
            if node.parent != NONE {
                let mut pp = p;
                for d in 0..k {
                    for (r, x) in pp.iter_mut().enumerate() {
                        *x += node.u[d][r] * g[d];
                    }
                }
                let parent = &mut self.p[node.parent];
                for r in 0..6 {
                    parent[r] += pp[r];
                }
            }
        }
        for i in 0..n {
            let node = &self.nodes[i];
            let ap = if node.parent == NONE {
                [0.0; 6]
            } else {
                self.acc[node.parent]
            };
            let mut a = ap;
            for d in 0..node.k {
                let x = self.g[i][d] - dot6::<Portable>(&node.dut[d], &ap);
                out[node.vo + d] = x;
                for (r, ar) in a.iter_mut().enumerate() {
                    *ar += node.s[d][r] * x;
                }
            }
            self.acc[i] = a;
        }
    }

    /// The spatial velocity (computation frame) of every node for joint velocities `qd`,
    /// read back by [`Tree::velocity`]. O(n).
    pub(crate) fn velocities(&mut self, qd: &[f64]) {
        for i in 0..self.len {
            let node = &self.nodes[i];
            let mut v = if node.parent == NONE {
                [0.0; 6]
            } else {
                self.acc[node.parent]
            };
            for d in 0..node.k {
                for (r, x) in v.iter_mut().enumerate() {
                    *x += node.s[d][r] * qd[node.vo + d];
                }
            }
            self.acc[i] = v;
        }
    }

    /// Node `i`'s velocity from the last [`Tree::velocities`] ([`NONE`]: zero).
    pub(crate) fn velocity(&self, i: usize) -> SpatialMotion {
        self.accel(i)
    }

    /// The number of nodes.
    pub(crate) fn len(&self) -> usize {
        self.len
    }
}

/// `out` = the 6 × 6 matrix `[Ī h×; h×ᵀ m1]` of `i` by rows, `Ī` made exactly symmetric (the
/// entries of `SpatialInertia::to_mat6`, without its 6 × 6 averaging pass).
fn inertia_rows(i: &SpatialInertia, out: &mut [V6; 6]) {
    let ib = i.ibar.to_cols_array_2d();
    let (m, h) = (i.mass, i.h);
    let ibar = |r: usize, c: usize| {
        if r == c {
            ib[c][r]
        } else {
            0.5 * (ib[c][r] + ib[r][c])
        }
    };
    // h× by rows: [[0, −h_z, h_y], [h_z, 0, −h_x], [−h_y, h_x, 0]].
    let hx = [[0.0, -h.z, h.y], [h.z, 0.0, -h.x], [-h.y, h.x, 0.0]];
    for (r, row) in out.iter_mut().enumerate() {
        for (c, x) in row.iter_mut().enumerate() {
            *x = match (r < 3, c < 3) {
                (true, true) => ibar(r, c),
                (true, false) => hx[r][c - 3],
                (false, true) => hx[c][r - 3],
                (false, false) if r == c => m,
                (false, false) => 0.0,
            };
        }
    }
}
