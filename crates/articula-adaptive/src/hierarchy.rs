//! Hierarchical state (DESIGN §6, adaptive updates): between re-selections a step touches the
//! hybrid body's active region and its rigid frontier only.
//!
//! A rigid subassembly keeps its mass properties in the frame of its top body (the body nearest
//! the root), and each rigid node keeps the pose of its top body in its parent's top-body frame
//! (`up`). Forward kinematics then runs over the active joints alone: the parent body of an
//! active joint sits at a constant pose in its rigid cluster (`prel`), and every body of a
//! cluster shares the cluster's spatial velocity.

use crate::dense;
use crate::hybrid::{Adaptive, Level, Rigid};
use articula_dca::DynamicsError;
use articula_model::{Model, NodeKind};
use articula_spatial::{SpatialForce, SpatialInertia, SpatialMotion, SpatialTransform};
use glam::DVec3;

/// Lists and frames of the current hybrid body.
#[derive(Clone, Debug, Default)]
pub(crate) struct Hierarchy {
    /// Built for the current hybrid body (cleared by a re-selection).
    pub valid: bool,
    /// Per frontier node (rigid cluster): mass properties in its top body's frame.
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
    /// Per active body: its rigid cluster (the frontier node whose top body it is), and the
    /// active body topping the cluster that holds its parent (`usize::MAX`: the world or a
    /// cluster welded to the ground).
    pub cl: Vec<usize>,
    pub par: Vec<usize>,
    /// Articulated-body workspace of the reduced tree (one rigid cluster per active body):
    /// per active body `Iᴬ`, `pᴬ`, `D⁻¹` (one DOF) or the Cholesky factor of `D` (several)
    /// and the cluster's acceleration; per degree of
    /// freedom `U = Iᴬ s` and `u = τ − sᵀ pᴬ`.
    pub ia: Vec<[[f64; 6]; 6]>,
    pub pa: Vec<SpatialForce>,
    pub dinv: Vec<[[f64; 6]; 6]>,
    pub acc: Vec<SpatialMotion>,
    pub u: Vec<[f64; 6]>,
    pub uu: Vec<f64>,
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

    /// Builds the hierarchical state for the current hybrid body (the `active` flags) from the
    /// poses in `data` and the composites of [`Adaptive::composites`]: the node and joint lists,
    /// the mass properties of every rigid cluster (frontier node) in its top body's frame, and
    /// the pose of each active joint's parent body in its cluster's frame. Positions only:
    /// velocities are not read.
    pub(crate) fn build_hierarchy(&mut self, model: &Model) {
        let tree = &model.assembly;
        let nn = tree.nodes.len();
        let nb = model.bodies.len();
        let h = &mut self.hier;
        h.rig.resize(nn, Rigid::default());
        h.abody.clear();
        h.abody.resize(nb, false);
        h.pcl.resize(nb, usize::MAX);
        h.prel.resize(nb, SpatialTransform::IDENTITY);
        h.cl.resize(nb, usize::MAX);
        h.par.resize(nb, usize::MAX);
        h.ia.resize(nb, [[0.0; 6]; 6]);
        h.pa.resize(nb, SpatialForce::ZERO);
        h.dinv.resize(nb, [[0.0; 6]; 6]);
        h.acc.resize(nb, SpatialMotion::ZERO);
        h.u.resize(model.nv, [0.0; 6]);
        h.uu.resize(model.nv, 0.0);
        h.hnodes.clear();
        h.fnodes.clear();
        h.ajoints.clear();
        for n in 0..nn {
            let node = &tree.nodes[n];
            if let NodeKind::Join { joint, .. } = node.kind {
                if self.active[n] {
                    self.hier.hnodes.push(n);
                    self.hier.abody[joint] = true;
                    continue;
                }
            }
            if node.parent.is_none_or(|p| self.active[p]) {
                self.hier.fnodes.push(n);
                if !self.grounded[n] {
                    // The composite (computation frame) carried into the top body's frame.
                    let x = self.data.x[self.top[n]];
                    let (r, _) = x.to_pose();
                    let c = self.comp[n];
                    self.hier.rig[n] = Rigid {
                        m: c.m,
                        c: x.inverse().apply_point(c.c),
                        ic: r.transpose() * c.ic * r,
                    };
                }
            }
        }
        for j in 0..nb {
            if !self.hier.abody[j] {
                continue;
            }
            self.hier.ajoints.push(j);
            self.hier.pcl[j] = usize::MAX;
            self.hier.par[j] = usize::MAX;
            if let Some(p) = model.bodies[j].parent {
                if !self.hier.abody[p] {
                    // Walk up from the parent's leaf to the frontier node holding it.
                    let mut n = tree.body_leaf[p];
                    while let Some(par) = tree.nodes[n].parent.filter(|&q| !self.active[q]) {
                        n = par;
                    }
                    self.hier.pcl[j] = n;
                    self.hier.prel[j] = self.top_frame(n).inverse() * self.data.x[p];
                    if !self.grounded[n] {
                        // The cluster's top body: its joint is one of the cluster's handles,
                        // all of which are active.
                        self.hier.par[j] = self.top[n];
                    }
                } else {
                    self.hier.par[j] = p;
                }
            }
            // The cluster j tops: the frontier node above j's leaf.
            let mut n = tree.body_leaf[j];
            while let Some(par) = tree.nodes[n].parent.filter(|&q| !self.active[q]) {
                n = par;
            }
            self.hier.cl[j] = n;
        }
        self.hier.valid = true;
    }

    /// Forward kinematics of the active joints only (parents first): poses, velocities,
    /// subspace columns and velocity products of the active bodies, and the handle points.
    pub(crate) fn active_kinematics(&mut self, model: &Model, q: &[f64], qd: &[f64]) {
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
            let (x, v, c) = revolute_kinematics(body, x, v, q, qd, &mut self.data.s)
                .unwrap_or_else(|| {
                    articula_dca::body_kinematics(body, x, v, q, qd, &mut self.data.s)
                });
            self.data.x[i] = x;
            self.data.v[i] = v;
            self.data.c[i] = c;
        }
    }

    /// One hybrid-body step between re-selections: kinematics of the active joints, then the
    /// hybrid body's forward dynamics over its reduced tree — one rigid cluster (frontier node)
    /// per active joint, with the cluster's composite inertia from the hierarchical state — by
    /// the articulated-body algorithm (Featherstone, RBDA Table 7.1) in the computation frame,
    /// with the external wrenches of `fsparse` gathered per cluster. The hybrid body is the
    /// same mechanical system the DCA main pass and back-substitution solve
    /// ([`Adaptive::set_full_passes`] runs those; tested equal to 1e-10), at a fraction of the
    /// cost per joint: the clusters' handle blocks are never formed. Writes `qdd` (zero outside
    /// the active region).
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
        for idx in 0..self.hier.fnodes.len() {
            let f = self.hier.fnodes[idx];
            self.fsum[f] = SpatialForce::ZERO;
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
        self.fresh = false;
        self.reduced_aba(model, tau, Level::Acceleration)
    }

    /// The forward dynamics of the hybrid body over its reduced tree (one rigid cluster per
    /// active joint, the clusters' mass properties from the hierarchical state) by the
    /// articulated-body algorithm in the computation frame, from the kinematics of the active
    /// bodies in `data`: `q̈` of the active joints into `qdd` (other entries untouched). At
    /// [`Level::Impulse`] there are no bias terms (no velocity products, gravity or external
    /// forces) and `tau` holds generalized momenta: the result is the velocity after the
    /// locking impulse.
    pub(crate) fn reduced_aba(
        &mut self,
        model: &Model,
        tau: &[f64],
        level: Level,
    ) -> Result<(), DynamicsError> {
        let accel = level == Level::Acceleration;
        // The nodes this stands for: the active joins and the rigid frontier.
        self.touched = self.hier.hnodes.len() + self.hier.fnodes.len();
        let h = &mut self.hier;
        // Pass 1: each cluster's spatial inertia about the computation origin (from its
        // top-body frame), `I = [Ī, h×; h×ᵀ, m 1]`, and bias force `pᴬ = v ×* I v − f_ext`
        // (gravity enters as the world's acceleration −a_g).
        for &j in &h.ajoints {
            let f = h.cl[j];
            let x = &self.data.x[j];
            let rl = &h.rig[f];
            let inertia =
                SpatialInertia::new(rl.m, x.apply_point(rl.c), x.e * rl.ic * x.e.transpose());
            let (ib, hv, m) = (inertia.ibar, inertia.h, inertia.mass);
            let ia = &mut h.ia[j];
            let ibc = [ib.x_axis, ib.y_axis, ib.z_axis];
            for r in 0..3 {
                for c in 0..3 {
                    ia[r][c] = ibc[c][r];
                    ia[r + 3][c + 3] = if r == c { m } else { 0.0 };
                }
            }
            // h× and its transpose.
            let hx = [[0.0, -hv.z, hv.y], [hv.z, 0.0, -hv.x], [-hv.y, hv.x, 0.0]];
            for r in 0..3 {
                for c in 0..3 {
                    ia[r][c + 3] = hx[r][c];
                    ia[c + 3][r] = hx[r][c];
                }
            }
            h.pa[j] = if accel {
                let v = self.data.v[j];
                v.cross_force(inertia.mul_motion(v)) - self.fsum[f]
            } else {
                SpatialForce::ZERO
            };
        }
        // Pass 2, leaves to root: U = Iᴬ S, D = Sᵀ U, u = τ − Sᵀ pᴬ; the parent cluster gets
        // Iᵃ = Iᴬ − U D⁻¹ Uᵀ and pᵃ = pᴬ + Iᵃ c + U D⁻¹ u.
        for idx in (0..h.ajoints.len()).rev() {
            let j = h.ajoints[idx];
            let body = &model.bodies[j];
            let (vo, k) = (body.v_offset, body.nv);
            let pa = h.pa[j];
            let parent = h.par[j];
            let c = if accel {
                self.data.c[j].to_array()
            } else {
                [0.0; 6]
            };
            if k == 1 {
                let ia = &h.ia[j];
                let s = self.data.s[vo].to_array();
                let u = mul6(ia, &s);
                let d = dot6(&s, &u);
                if d.is_nan() || d <= 0.0 {
                    return Err(singular(model, j));
                }
                let dinv = 1.0 / d;
                let uu = tau[vo] - self.data.s[vo].dot(pa);
                h.u[vo] = u;
                h.uu[vo] = uu;
                h.dinv[j][0][0] = dinv;
                if parent == usize::MAX {
                    continue;
                }
                let ic = mul6(ia, &c);
                let g = dinv * (uu - dot6(&c, &u));
                let add = SpatialForce::from_array(std::array::from_fn(|r| ic[r] + u[r] * g));
                h.pa[parent] += pa + add;
                let (lo, hi) = h.ia.split_at_mut(j);
                add_sub_outer(&mut lo[parent], &hi[0], &u, dinv);
                continue;
            }
            let mut d = [[0.0; 6]; 6];
            for p in 0..k {
                let u = mul6(&h.ia[j], &self.data.s[vo + p].to_array());
                h.u[vo + p] = u;
                for qq in 0..=p {
                    let x = dot6(&self.data.s[vo + qq].to_array(), &u);
                    d[p][qq] = x;
                    d[qq][p] = x;
                }
                h.uu[vo + p] = tau[vo + p] - self.data.s[vo + p].dot(pa);
            }
            // D = L Lᵀ. With Y = U L⁻ᵀ (columns y_p) and z = L⁻¹ u: U D⁻¹ Uᵀ = Y Yᵀ and
            // U D⁻¹ u = Y z.
            if k > 0 {
                h.dinv[j] = dense::cholesky_k(&d, k).ok_or_else(|| singular(model, j))?;
            }
            if parent == usize::MAX {
                continue;
            }
            let l = &h.dinv[j];
            let mut y = [[0.0; 6]; 6];
            let mut z = [0.0; 6];
            for p in 0..k {
                let mut yp = h.u[vo + p];
                let mut zp = h.uu[vo + p];
                for qq in 0..p {
                    let lpq = l[p][qq];
                    zp -= lpq * z[qq];
                    for r in 0..6 {
                        yp[r] -= lpq * y[qq][r];
                    }
                }
                let inv = 1.0 / l[p][p];
                z[p] = zp * inv;
                for r in 0..6 {
                    yp[r] *= inv;
                }
                y[p] = yp;
            }
            // Iᵃ = Iᴬ − Y Yᵀ, pᵃ = pᴬ + Iᵃ c + Y z (Iᵃ c = Iᴬ c − Y (Yᵀ c)).
            let (lo, hi) = h.ia.split_at_mut(j);
            let (target, ia) = (&mut lo[parent], &hi[0]);
            let mut add = mul6(ia, &c);
            for p in 0..k {
                let g = z[p] - dot6(&y[p], &c);
                for r in 0..6 {
                    add[r] += y[p][r] * g;
                }
            }
            h.pa[parent] += pa + SpatialForce::from_array(add);
            for r in 0..6 {
                for cc in r..6 {
                    let mut x = target[r][cc] + ia[r][cc];
                    for p in 0..k {
                        x -= y[p][r] * y[p][cc];
                    }
                    target[r][cc] = x;
                    target[cc][r] = x;
                }
            }
        }
        // Pass 3, root to leaves: a' = a_parent + c, q̈ = D⁻¹ (u − Uᵀ a'), a = a' + S q̈.
        let a0 = if accel {
            SpatialMotion::new(DVec3::ZERO, -self.data.gravity)
        } else {
            SpatialMotion::ZERO
        };
        for idx in 0..h.ajoints.len() {
            let j = h.ajoints[idx];
            let body = &model.bodies[j];
            let (vo, k) = (body.v_offset, body.nv);
            let parent = h.par[j];
            let mut ap = if parent == usize::MAX {
                a0
            } else {
                h.acc[parent]
            };
            if accel {
                ap += self.data.c[j];
            }
            let apa = ap.to_array();
            if k == 1 {
                let x = h.dinv[j][0][0] * (h.uu[vo] - dot6(&apa, &h.u[vo]));
                self.qdd[vo] = x;
                h.acc[j] = ap + self.data.s[vo] * x;
                continue;
            }
            // q̈ = L⁻ᵀ L⁻¹ r.
            let l = &h.dinv[j];
            let mut x = [0.0; 6];
            for p in 0..k {
                let mut v = h.uu[vo + p] - dot6(&apa, &h.u[vo + p]);
                for qq in 0..p {
                    v -= l[p][qq] * x[qq];
                }
                x[p] = v / l[p][p];
            }
            for p in (0..k).rev() {
                let mut v = x[p];
                for qq in p + 1..k {
                    v -= l[qq][p] * x[qq];
                }
                x[p] = v / l[p][p];
            }
            let mut a = ap;
            for p in 0..k {
                self.qdd[vo + p] = x[p];
                a += self.data.s[vo + p] * x[p];
            }
            h.acc[j] = a;
        }
        Ok(())
    }
}

/// [`articula_dca::body_kinematics`] for a joint made of revolute parts about coordinate axes
/// (`±x`, `±y`, `±z`, the usual URDF case): the rotation by `q` touches two columns of the
/// pose and an identity part origin (the massless links of a composed joint) costs nothing.
/// `None` for any other joint.
#[inline]
fn revolute_kinematics(
    body: &articula_model::Body,
    x0: SpatialTransform,
    v0: SpatialMotion,
    q: &[f64],
    qd: &[f64],
    s: &mut [SpatialMotion],
) -> Option<(SpatialTransform, SpatialMotion, SpatialMotion)> {
    let mut axes = [(0usize, 0.0f64); 6];
    for (k, part) in body.joint.iter().enumerate() {
        if k >= 6
            || !matches!(
                part.kind,
                articula_model::JointKind::Revolute | articula_model::JointKind::Continuous
            )
        {
            return None;
        }
        let a = part.axis.to_array();
        let i = (0..3).find(|&i| a[i] == 1.0 || a[i] == -1.0)?;
        if a[(i + 1) % 3] != 0.0 || a[(i + 2) % 3] != 0.0 {
            return None;
        }
        axes[k] = (i, a[i]);
    }
    let (mut x, mut v) = (x0, v0);
    let mut c = SpatialMotion::ZERO;
    for (k, part) in body.joint.iter().enumerate() {
        if part.origin.e != glam::DMat3::IDENTITY || part.origin.r != DVec3::ZERO {
            x = x * part.origin;
        }
        let (i, sign) = axes[k];
        let (sn, cs) = (sign * q[part.q_offset]).sin_cos();
        // E ← E R(q), r ← R(q)ᵀ r for the rotation about coordinate axis i: columns / components
        // (i+1, i+2) turn by the angle.
        let (a, b) = ((i + 1) % 3, (i + 2) % 3);
        let (ea, eb) = (x.e.col(a), x.e.col(b));
        *x.e.col_mut(a) = ea * cs + eb * sn;
        *x.e.col_mut(b) = eb * cs - ea * sn;
        let (ra, rb) = (x.r[a], x.r[b]);
        x.r[a] = cs * ra + sn * rb;
        x.r[b] = cs * rb - sn * ra;
        let sk = x.apply_motion(part.subspace_column(0));
        s[part.v_offset] = sk;
        let vj = sk * qd[part.v_offset];
        c += v.cross_motion(vj);
        v += vj;
    }
    Some((x, v, c))
}

/// `a x` for a 6 × 6 matrix.
#[inline(always)]
fn mul6(a: &[[f64; 6]; 6], x: &[f64; 6]) -> [f64; 6] {
    std::array::from_fn(|r| dot6(&a[r], x))
}

/// `s += a − α u uᵀ` on symmetric 6 × 6 matrices (upper triangle computed, mirrored).
#[inline(always)]
fn add_sub_outer(s: &mut [[f64; 6]; 6], a: &[[f64; 6]; 6], u: &[f64; 6], alpha: f64) {
    for i in 0..6 {
        let aui = alpha * u[i];
        for j in i..6 {
            let x = s[i][j] + a[i][j] - aui * u[j];
            s[i][j] = x;
            s[j][i] = x;
        }
    }
}

#[inline(always)]
fn dot6(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]
}

/// The error of a joint whose `Sᵀ Iᴬ S` is not positive definite.
fn singular(model: &Model, j: usize) -> DynamicsError {
    DynamicsError::Singular {
        joint: model.bodies[j].joint_name(),
        detail: "Sᵀ Iᴬ S of the hybrid body is not positive definite",
    }
}
