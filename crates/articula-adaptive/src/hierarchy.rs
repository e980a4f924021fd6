//! Hierarchical state (DESIGN §6, adaptive updates): between re-selections a step touches the
//! hybrid body's active region and its rigid frontier only.
//!
//! A rigid subassembly keeps its mass properties in the frame of its top body (the body nearest
//! the root), and each rigid node keeps the pose of its top body in its parent's top-body frame
//! (`up`). Forward kinematics then runs over the active joints alone: the parent body of an
//! active joint sits at a constant pose in its rigid cluster (`prel`), and every body of a
//! cluster shares the cluster's spatial velocity.

use crate::hybrid::{Adaptive, Level, Rigid};
use articula_dca::DynamicsError;
use articula_model::{Model, NodeKind};
use articula_spatial::{SpatialForce, SpatialMotion, SpatialTransform};
use glam::DVec3;

/// Lists and frames of the current hybrid body.
#[derive(Clone, Debug, Default)]
pub(crate) struct Hierarchy {
    /// Built for the current hybrid body (cleared by a re-selection).
    pub valid: bool,
    /// Per node: `X_{top(parent)←top(n)}` (valid while the parent is rigid).
    pub up: Vec<SpatialTransform>,
    /// Per node: mass properties in its top body's frame (the computation frame if grounded).
    pub rig: Vec<Rigid>,
    /// Active join nodes, then frontier nodes, each ascending (post-order).
    pub hnodes: Vec<usize>,
    pub fnodes: Vec<usize>,
    /// Bodies whose joints are active, ascending (parents first).
    pub ajoints: Vec<usize>,
    /// Per body: its joint is active.
    pub abody: Vec<bool>,
    /// Per active body: the rigid cluster (frontier node) holding its parent body, or
    /// `usize::MAX` when the parent is an active body or the world; and the parent's pose in the
    /// cluster's top-body frame.
    pub pcl: Vec<usize>,
    pub prel: Vec<SpatialTransform>,
}

impl Adaptive {
    /// The frame of node `n`'s top body in the computation frame (the computation frame itself
    /// for a grounded node) — from the kinematics in `data`.
    fn top_frame(&self, n: usize) -> SpatialTransform {
        if self.grounded[n] {
            SpatialTransform::xlt(self.data.origin)
        } else {
            self.data.x[self.top[n]]
        }
    }

    /// Builds the hierarchical state for the current hybrid body from the full kinematics in
    /// `data` (right after a re-selection): mass properties of every rigid node in its top
    /// frame, `up` transforms, the node and joint lists, and the parents' cluster poses.
    pub(crate) fn build_hierarchy(&mut self, model: &Model) {
        let tree = &model.assembly;
        let nn = tree.nodes.len();
        let h = &mut self.hier;
        h.up.resize(nn, SpatialTransform::IDENTITY);
        h.rig.resize(nn, Rigid::default());
        h.abody.clear();
        h.abody.resize(model.bodies.len(), false);
        h.pcl.resize(model.bodies.len(), usize::MAX);
        h.prel
            .resize(model.bodies.len(), SpatialTransform::IDENTITY);
        h.hnodes.clear();
        h.fnodes.clear();
        h.ajoints.clear();
        for n in 0..nn {
            let node = &tree.nodes[n];
            let frame = self.top_frame(n);
            let rig = match node.kind {
                NodeKind::Ground => Rigid::default(),
                NodeKind::Body(i) => {
                    let bi = &model.bodies[i].inertia;
                    Rigid {
                        m: bi.mass,
                        c: bi.com(),
                        ic: bi.inertia_about_com(),
                    }
                }
                NodeKind::Join {
                    parent_side: a,
                    child_side: b,
                    ..
                } => {
                    // Children's mass properties carried into this node's top frame.
                    let into = |c: usize, me: &Adaptive| -> Rigid {
                        let x = frame.inverse() * me.top_frame(c);
                        let (r, p) = x.to_pose();
                        let rc = me.hier.rig[c];
                        Rigid {
                            m: rc.m,
                            c: r * rc.c + p,
                            ic: r * rc.ic * r.transpose(),
                        }
                    };
                    let (ra, rb) = (into(a, self), into(b, self));
                    ra.combine(&rb)
                }
            };
            self.hier.rig[n] = rig;
            if let Some(p) = node.parent {
                self.hier.up[n] = self.top_frame(p).inverse() * frame;
            }
            let is_join = matches!(node.kind, NodeKind::Join { .. });
            if is_join && self.active[n] {
                self.hier.hnodes.push(n);
                if let NodeKind::Join { joint, .. } = node.kind {
                    self.hier.abody[joint] = true;
                }
            } else if node.parent.is_none_or(|p| self.active[p]) {
                self.hier.fnodes.push(n);
            }
        }
        for j in 0..model.bodies.len() {
            if !self.hier.abody[j] {
                continue;
            }
            self.hier.ajoints.push(j);
            self.hier.pcl[j] = usize::MAX;
            if let Some(p) = model.bodies[j].parent {
                if !self.hier.abody[p] {
                    // Walk up from the parent's leaf to the frontier node holding it.
                    let mut n = tree.body_leaf[p];
                    let mut x = SpatialTransform::IDENTITY;
                    while let Some(par) = tree.nodes[n].parent.filter(|&q| !self.active[q]) {
                        x = self.hier.up[n] * x;
                        n = par;
                    }
                    self.hier.pcl[j] = n;
                    self.hier.prel[j] = x;
                }
            }
        }
        self.hier.valid = true;
    }

    /// Forward kinematics of the active joints only (parents first): poses, velocities,
    /// subspace columns and velocity products of the active bodies, and the handle points.
    fn active_kinematics(&mut self, model: &Model, q: &[f64], qd: &[f64]) {
        let x_cw = SpatialTransform::xlt(self.data.origin);
        for idx in 0..self.hier.ajoints.len() {
            let i = self.hier.ajoints[idx];
            let body = &model.bodies[i];
            let (x, v) = match body.parent {
                None => (x_cw, SpatialMotion::ZERO),
                Some(p) if self.hier.abody[p] => (self.data.x[p], self.data.v[p]),
                Some(_) => {
                    let f = self.hier.pcl[i];
                    if self.grounded[f] {
                        (x_cw * self.hier.prel[i], SpatialMotion::ZERO)
                    } else {
                        let t = self.top[f];
                        (self.data.x[t] * self.hier.prel[i], self.data.v[t])
                    }
                }
            };
            let (x, v, c) = articula_dca::body_kinematics(body, x, v, q, qd, &mut self.data.s);
            self.data.x[i] = x;
            self.data.v[i] = v;
            self.data.c[i] = c;
            self.point[i] = x.apply_point(DVec3::ZERO);
        }
    }

    /// One hybrid-body step between re-selections: kinematics of the active joints, the rigid
    /// frontier's composites from the hierarchical state, the main pass and back-substitution
    /// over the active region, with the external wrenches of `fsparse`. Writes `qdd` (zero
    /// outside the active region).
    pub(crate) fn hybrid_step(
        &mut self,
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
    ) -> Result<(), DynamicsError> {
        let tree = &model.assembly;
        self.data.origin = articula_dca::computation_origin(model, q);
        self.active_kinematics(model, q, qd);
        // Frontier composites in the computation frame; forces gathered per cluster.
        for idx in 0..self.hier.fnodes.len() {
            let f = self.hier.fnodes[idx];
            self.fsum[f] = SpatialForce::ZERO;
            if self.grounded[f] {
                continue;
            }
            let x = self.data.x[self.top[f]];
            let (r, _) = x.to_pose();
            let rl = self.hier.rig[f];
            self.comp[f] = Rigid {
                m: rl.m,
                c: x.apply_point(rl.c),
                ic: r * rl.ic * r.transpose(),
            };
        }
        // An external force on a rigid part goes to its cluster: a walk up the tree.
        if !self.fsparse.is_empty() {
            let x_cw = SpatialTransform::xlt(self.data.origin);
            for k in 0..self.fsparse.len() {
                let (i, fe) = self.fsparse[k];
                let mut n = tree.body_leaf[i];
                while let Some(p) = tree.nodes[n].parent.filter(|&p| !self.active[p]) {
                    n = p;
                }
                self.fsum[n] += x_cw.apply_force(fe);
            }
        }
        self.touched = 0;
        let (mut hi, mut fi) = (0, 0);
        // Merge the two ascending lists: post-order, children first.
        while hi < self.hier.hnodes.len() || fi < self.hier.fnodes.len() {
            let take_f = hi == self.hier.hnodes.len()
                || (fi < self.hier.fnodes.len() && self.hier.fnodes[fi] < self.hier.hnodes[hi]);
            self.touched += 1;
            if take_f {
                let f = self.hier.fnodes[fi];
                fi += 1;
                if self.grounded[f] {
                    self.ground_coefficients(f);
                } else {
                    let (r, v) = (self.comp[f], self.data.v[self.top[f]]);
                    self.rigid_coefficients(model, f, &r, v, self.fsum[f], Level::Acceleration)?;
                }
            } else {
                let n = self.hier.hnodes[hi];
                hi += 1;
                self.join(model, n, tau, Level::Acceleration)?;
            }
        }
        // q̈ outside the active region stays 0 from the re-selection step.
        let root = tree.root();
        let (ho, nh) = (self.lay.hoff[root], self.nh[root]);
        self.f[ho..ho + nh].fill(SpatialForce::ZERO);
        for idx in (0..self.hier.hnodes.len()).rev() {
            let n = self.hier.hnodes[idx];
            self.expand(model, n);
        }
        Ok(())
    }
}
