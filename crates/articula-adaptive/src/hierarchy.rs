//! Hierarchical state (docs/design.md#adaptive): between re-selections a step touches the
//! hybrid body's active region and its rigid frontier only.
//!
//! A rigid subassembly keeps its mass properties in the frame of its top body (the body nearest
//! the root), and each rigid node keeps the pose of its top body in its parent's top-body frame
//! (`up`). Forward kinematics then runs over the active joints alone: the parent body of an
//! active joint sits at a constant pose in its rigid cluster (`prel`), and every body of a
//! cluster shares the cluster's spatial velocity.

use crate::adaptive::Adaptive;
use crate::hybrid::Level;
use crate::parts::composites::Rigid;
use crate::parts::hierarchy::{
    coordinate_axis, revolute_parts, ActiveJoint, Hierarchy, Parent, ReducedAba, RevoluteParts,
    AX_PARTS, NO_PARENT,
};
use crate::parts::subtrees::{Base, Chain, PARALLEL_HYBRID_MIN_JOINTS};
#[cfg(feature = "parallel")]
use crate::parts::subtrees::{Subtree, Subtrees};
#[cfg(feature = "parallel")]
use articula_dca::Threads;
use articula_dca::{Data, DynamicsError};
use articula_model::{Model, NodeKind};
use articula_spatial::numerics::{cholesky_into, dot6_pairs, joint_block_regular, Arith, Portable};
use articula_spatial::{Mat6, SpatialForce, SpatialMotion, SpatialTransform};
use glam::DVec3;

impl Adaptive {
    /// The frame of node `n`'s top body in the computation frame (the computation frame itself
    /// for a grounded node) — from the kinematics in `data`.
    fn top_frame(&self, n: usize) -> SpatialTransform {
        if self.composites.grounded[n] {
            SpatialTransform::xlt(self.data.origin)
        } else {
            self.data.x[self.composites.top_body[n]]
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
        h.cluster_mass.resize(nn, Rigid::default());
        h.abody.clear();
        h.abody.resize(nb, false);
        h.parent_cluster.resize(nb, usize::MAX);
        h.prel.resize(nb, SpatialTransform::IDENTITY);
        h.own_cluster.resize(nb, usize::MAX);
        h.parent_top.resize(nb, usize::MAX);
        if h.axis.len() != nb {
            h.axis = model.bodies.iter().map(coordinate_axis).collect();
            h.parts = model.bodies.iter().map(revolute_parts).collect();
        }
        // At their largest from the first build on (every node, every body), so that a later
        // hybrid body with more joints grows nothing.
        h.hnodes.clear();
        h.hnodes.reserve(nn);
        h.fnodes.clear();
        h.fnodes.reserve(nn);
        h.ajoints.clear();
        h.ajoints.reserve(nb);
        for n in 0..nn {
            let node = &tree.nodes[n];
            if let NodeKind::Join { joint, .. } = node.kind {
                if self.body.active[n] {
                    self.hier.hnodes.push(n);
                    self.hier.abody[joint] = true;
                    continue;
                }
            }
            if node.parent.is_none_or(|p| self.body.active[p]) {
                self.hier.fnodes.push(n);
                if !self.composites.grounded[n] {
                    // The composite (computation frame) carried into the top body's frame.
                    let x = self.data.x[self.composites.top_body[n]];
                    let (r, _) = x.to_pose();
                    let c = self.composites.rigid[n];
                    self.hier.cluster_mass[n] = Rigid {
                        mass: c.mass,
                        com: x.inverse().apply_point(c.com),
                        inertia: r.transpose() * c.inertia * r,
                    };
                }
            }
        }
        for j in 0..nb {
            if !self.hier.abody[j] {
                continue;
            }
            self.hier.ajoints.push(j);
            self.hier.parent_cluster[j] = usize::MAX;
            self.hier.parent_top[j] = usize::MAX;
            if let Some(p) = model.bodies[j].parent {
                if !self.hier.abody[p] {
                    // Walk up from the parent's leaf to the frontier node holding it.
                    let mut n = tree.body_leaf[p];
                    while let Some(par) = tree.nodes[n].parent.filter(|&q| !self.body.active[q]) {
                        n = par;
                    }
                    self.hier.parent_cluster[j] = n;
                    self.hier.prel[j] = self.top_frame(n).inverse() * self.data.x[p];
                    if !self.composites.grounded[n] {
                        // The cluster's top body: its joint is one of the cluster's handles,
                        // all of which are active.
                        self.hier.parent_top[j] = self.composites.top_body[n];
                    }
                } else {
                    self.hier.parent_top[j] = p;
                }
            }
            // The cluster j tops: the frontier node above j's leaf.
            let mut n = tree.body_leaf[j];
            while let Some(par) = tree.nodes[n].parent.filter(|&q| !self.body.active[q]) {
                n = par;
            }
            self.hier.own_cluster[j] = n;
        }
        self.build_records(model);
        self.hier.valid = true;
        self.hier.from_cache = false;
        self.hier.kin_fresh = false;
    }

    /// The records of the reduced tree (`records`) from the lists and frames of
    /// [`Adaptive::build_hierarchy`], and the articulated-body workspace sized to them.
    pub(crate) fn build_records(&mut self, model: &Model) {
        let h = &mut self.hier;
        h.records.clear();
        h.gen += 1;
        if h.force_cluster.len() != model.bodies.len() {
            h.force_cluster = vec![(0, 0); model.bodies.len()];
        }
        // Room for every body at the first build: later hybrid bodies allocate nothing.
        let nb = model.bodies.len();
        if h.records.capacity() < nb {
            h.records.reserve(nb);
            h.reduced_aba
                .ia
                .reserve(nb.saturating_sub(h.reduced_aba.ia.len()));
            h.reduced_aba
                .cholesky
                .reserve(nb.saturating_sub(h.reduced_aba.cholesky.len()));
            for v in [&mut h.reduced_aba.pa, &mut h.reduced_aba.acceleration] {
                v.reserve(nb.saturating_sub(v.len()));
            }
            h.reduced_aba
                .dinv
                .reserve(nb.saturating_sub(h.reduced_aba.dinv.len()));
            h.sin_cos.reserve(model.nv.saturating_sub(h.sin_cos.len()));
            h.angles.reserve(model.nv.saturating_sub(h.angles.len()));
            h.reduced_aba
                .u
                .reserve(model.nv.saturating_sub(h.reduced_aba.u.len()));
            h.reduced_aba
                .uu
                .reserve(model.nv.saturating_sub(h.reduced_aba.uu.len()));
        }
        if h.ridx.len() != nb {
            h.ridx.resize(nb, usize::MAX);
        }
        let mut dof = 0;
        h.angles.clear();
        for idx in 0..h.ajoints.len() {
            let j = h.ajoints[idx];
            let body = &model.bodies[j];
            let axis = h.axis[j];
            let narrow = |i: usize| u32::try_from(i).expect("fewer than 2³² bodies, coordinates");
            let parent = match body.parent {
                None => Parent::World,
                Some(p) if h.abody[p] => Parent::Active(narrow(p)),
                Some(_) if self.composites.grounded[h.parent_cluster[j]] => Parent::Ground,
                Some(_) => Parent::Cluster(narrow(self.composites.top_body[h.parent_cluster[j]])),
            };
            let mut x0 = match parent {
                Parent::World | Parent::Active(_) => SpatialTransform::IDENTITY,
                Parent::Cluster(_) | Parent::Ground => h.prel[j],
            };
            let mut mulx = !matches!(parent, Parent::World | Parent::Active(_));
            if axis.is_some() {
                let o = body.joint[0].origin;
                if o.e != glam::DMat3::IDENTITY || o.r != DVec3::ZERO {
                    x0 = if mulx { x0 * o } else { o };
                    mulx = true;
                }
            }
            // The parent record: the active body topping the parent's cluster (`parent_top`) comes
            // earlier in `ajoints`.
            let pidx = if h.parent_top[j] == usize::MAX {
                u32::MAX
            } else {
                narrow(h.ridx[h.parent_top[j]])
            };
            let revs = match h.parts[j] {
                Some(_)
                    if body.joint.iter().enumerate().all(|(p, part)| {
                        part.q_offset == body.q_offset + p && part.v_offset == body.v_offset + p
                    }) && body.nq == body.joint.len()
                        && body.nv == body.joint.len() =>
                {
                    body.joint.len() as u8
                }
                _ => 0,
            };
            if let Some((_, sign)) = axis {
                h.angles.push((narrow(body.q_offset), sign as f32));
            } else if let Some(parts) = &h.parts[j] {
                for (k, part) in body.joint.iter().enumerate() {
                    h.angles
                        .push((narrow(part.q_offset), parts.axis(k).1 as f32));
                }
            }
            h.ridx[j] = h.records.len();
            h.records.push(ActiveJoint {
                body: narrow(j),
                q_offset: narrow(body.q_offset),
                v_offset: narrow(body.v_offset),
                dof_count: narrow(body.nv),
                first_dof: narrow(dof),
                pidx,
                cluster: narrow(h.own_cluster[j]),
                parent,
                mulx,
                shift: mulx && x0.e == glam::DMat3::IDENTITY,
                revs,
                axis_code: match (axis, &h.parts[j]) {
                    (Some((i, _)), _) => i as u8,
                    (None, Some(_)) => AX_PARTS,
                    (None, None) => u8::MAX,
                },
                sign: axis.map_or(0.0, |(_, sign)| sign),
                rev_parts: h.parts[j].unwrap_or_default(),
                fixed_pose: x0,
                cluster_mass: h.cluster_mass[h.own_cluster[j]],
            });
            dof += body.nv;
        }
        h.dofs = dof;
        let na = h.records.len();
        h.reduced_aba.ia.resize(na, Mat6::ZERO);
        h.reduced_aba.pa.resize(na, [0.0; 6]);
        h.reduced_aba.acceleration.resize(na, [0.0; 6]);
        h.reduced_aba.dinv.resize(na, 0.0);
        h.sin_cos.resize(h.angles.len(), (0.0, 1.0));
        h.reduced_aba.cholesky.resize(na, [[0.0; 6]; 6]);
        h.reduced_aba.u.resize(dof, [0.0; 6]);
        h.reduced_aba.uu.resize(dof, 0.0);
        // (Nothing to split without the `parallel` feature.)
        #[cfg(feature = "parallel")]
        h.split.find(model, &h.records);
    }

    /// Forward kinematics of the active joints only (parents first): poses, velocities,
    /// subspace columns and velocity products of the active bodies. A joint of one revolute
    /// part about a coordinate axis takes its parent frame composed with its constant pose
    /// (`fixed_pose`: the parent body's pose in its cluster and the joint origin) and turns two
    /// columns of it; its axis is a column of the pose, `s = [ω; p × ω]` with `p` the body's
    /// origin.
    #[inline]
    pub(crate) fn active_kinematics(&mut self, model: &Model, q: &[f64], qd: &[f64]) {
        // Also compiled for AVX2 + FMA (the same bits, wider vectors), run when `fused`.
        articula_spatial::fma_dispatch! {
            fn run(this: &mut Adaptive, model: &Model, q: &[f64], qd: &[f64]);
            avx2_fma: this.switches.fused, Portable;
            |A| this.active_kinematics_with(model, q, qd)
        }
        run(self, model, q, qd)
    }

    #[inline(always)]
    fn active_kinematics_with(&mut self, model: &Model, q: &[f64], qd: &[f64]) {
        let wide = self.switches.fused;
        let x_cw = SpatialTransform::xlt(self.data.origin);
        // The angles' sines and cosines first (the loop below then makes no call), four
        // records at a time in AVX2 lanes when `wide` (the same bits).
        let h = &mut self.hier;
        let (ang, scs) = (&h.angles[..], &mut h.sin_cos[..h.angles.len()]);
        // (One thread without the `parallel` feature.)
        if h.records.len() >= PARALLEL_HYBRID_MIN_JOINTS && self.threads.count() > 1 {
            // Runs of `RECORD_GRAIN` angles (a multiple of four: the same lanes of four as
            // one sweep) on the threads; each angle's sine and cosine are its own.
            #[cfg(feature = "parallel")]
            {
                use rayon::prelude::*;
                self.threads.install(|| {
                    ang.par_chunks(RECORD_GRAIN)
                        .zip(scs.par_chunks_mut(RECORD_GRAIN))
                        .for_each(|(ang, scs)| sin_cos_angles(wide, ang, scs, q))
                });
            }
        } else {
            sin_cos_angles(wide, ang, scs, q);
        }
        let h = &mut self.hier;
        let d = &mut self.data;
        // The records' sines and cosines in turn (one per closed-form joint, one per part).
        let scs = &h.sin_cos[..h.angles.len()];
        let mut out = Kin {
            x: &mut d.x[..],
            v: &mut d.v[..],
            c: &mut d.c[..],
            s: &mut d.s[..],
        };
        let (rec, none) = (&h.records[..], (x_cw, SpatialMotion::ZERO));
        // (One thread without the `parallel` feature.)
        #[cfg(feature = "parallel")]
        if rec.len() >= PARALLEL_HYBRID_MIN_JOINTS
            && self.threads.count() > 1
            && !h.split.tasks.is_empty()
        {
            let (tasks, at) = (&mut h.split.tasks[..], (x_cw, q, qd));
            split_kinematics(wide, model, &self.threads, rec, tasks, at, scs, out);
            return;
        }
        kinematics_run(
            wide,
            model,
            rec,
            Base::ZERO,
            none,
            (x_cw, q, qd),
            scs,
            &mut out,
        );
    }

    /// One hybrid-body step between re-selections: kinematics of the active joints, then the
    /// hybrid body's forward dynamics over its reduced tree — one rigid cluster (frontier node)
    /// per active joint, with the cluster's composite inertia from the hierarchical state — by
    /// the articulated-body algorithm (Featherstone, RBDA Table 7.1) in the computation frame,
    /// with the external wrenches of `forces.sparse` gathered per cluster. The hybrid body is the
    /// same mechanical system the DCA main pass and back-substitution solve
    /// ([`Adaptive::set_full_passes`] runs those; tested equal to 1e-10), at a fraction of the
    /// cost per joint: the clusters' handle blocks are never formed. Writes `qdd` (zero outside
    /// the active region). `kinematics_fresh`: the active bodies' kinematics in `data` are
    /// already those of `(q, q̇)` (a cached re-selection that kept the hybrid body).
    pub(crate) fn hybrid_step(
        &mut self,
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        kinematics_fresh: bool,
    ) -> Result<(), DynamicsError> {
        let tree = &model.assembly;
        if !kinematics_fresh {
            self.data.origin = articula_dca::computation_origin(model, q);
            self.active_kinematics(model, q, qd);
        }
        // (Through disjoint borrows, so that the vectors' pointers stay in registers.)
        let (fnodes, fsum) = (&self.hier.fnodes, &mut self.forces.node_sums);
        for &f in fnodes {
            fsum[f] = SpatialForce::ZERO;
        }
        // An external force on a rigid part goes to its cluster: a walk up the tree, once per
        // body and hybrid body.
        if !self.forces.sparse.is_empty() {
            let x_cw = SpatialTransform::xlt(self.data.origin);
            let gen = self.hier.gen;
            for k in 0..self.forces.sparse.len() {
                let (i, fe) = self.forces.sparse[k];
                let n = match self.hier.force_cluster[i] {
                    (g, n) if g == gen => n,
                    _ => {
                        let mut n = tree.body_leaf[i];
                        while let Some(p) = tree.nodes[n].parent.filter(|&p| !self.body.active[p]) {
                            n = p;
                        }
                        self.hier.force_cluster[i] = (gen, n);
                        n
                    }
                };
                self.forces.node_sums[n] += x_cw.apply_force(fe);
            }
        }
        self.fresh.valid = false;
        if model.dynamics.has_passive() {
            // The active joints' τ + passive(q, q̇) (`passive.rs`).
            let mut total = std::mem::take(&mut self.passive.tau);
            self.active_passive_tau(model, (q, qd, tau), &mut total);
            let r = self.reduced_aba(model, &total, Level::Acceleration);
            self.passive.tau = total;
            return r;
        }
        self.reduced_aba(model, tau, Level::Acceleration)
    }

    /// The forward dynamics of the hybrid body over its reduced tree (one rigid cluster per
    /// active joint, the clusters' mass properties from the hierarchical state) by the
    /// articulated-body algorithm in the computation frame, from the kinematics of the active
    /// bodies in `data`: `q̈` of the active joints into `qdd` (other entries untouched). At
    /// [`Level::Impulse`] there are no bias terms (no velocity products, gravity or external
    /// forces) and `tau` holds generalized momenta: the result is the velocity after the
    /// locking impulse.
    ///
    /// Compiled twice over [`Arith`], as articula-dca's DCA pass: with fused multiply–adds
    /// ([`Fused`], on a CPU with AVX2 and FMA: `Adaptive::fused`) or portably.
    pub(crate) fn reduced_aba(
        &mut self,
        model: &Model,
        tau: &[f64],
        level: Level,
    ) -> Result<(), DynamicsError> {
        if let [r] = &self.hier.records[..] {
            if r.dof_count() == 1 && r.pidx() == NO_PARENT {
                return self.one_joint(model, tau, level);
            }
        }
        // Also compiled for AVX2 + FMA with fused multiply–adds, run when `fused`.
        articula_spatial::fma_dispatch! {
            fn run(this: &mut Adaptive, model: &Model, tau: &[f64], level: Level) -> Result<(), DynamicsError>;
            avx2_fma: this.switches.fused, Fused;
            |A| this.reduced_aba_with::<A>(model, tau, level)
        }
        run(self, model, tau, level)
    }

    /// [`Adaptive::reduced_aba`] for a reduced tree of one single-DOF joint on the world or
    /// on a cluster welded to the ground (budget 1 on a fixed base): the articulated-body
    /// algorithm with nothing to articulate, `q̈ = (τ − sᵀ pᴬ − sᵀ I a') / sᵀ I s` with
    /// `a' = a₀ + c` (RBDA Table 7.1: `U = I s`, `D = sᵀ U`, `u = τ − sᵀ pᴬ`,
    /// `q̈ = D⁻¹ (u − Uᵀ a')`). The two products by the cluster's spatial inertia
    /// (`I s`, and `I v` in `pᴬ = v ×* I v − f_ext`) come from its parts ([`Parts`]) instead
    /// of forming the 6 × 6 matrix and sweeping it. The same solution; the rounding differs
    /// from the general passes' (tests compare both with exact DCA).
    fn one_joint(&mut self, model: &Model, tau: &[f64], level: Level) -> Result<(), DynamicsError> {
        // Also compiled for AVX2 + FMA (the same bits, wider vectors), run when `fused`.
        articula_spatial::fma_dispatch! {
            fn run(this: &mut Adaptive, model: &Model, tau: &[f64], level: Level) -> Result<(), DynamicsError>;
            avx2_fma: this.switches.fused, Portable;
            |A| this.one_joint_with(model, tau, level)
        }
        run(self, model, tau, level)
    }

    #[inline(always)]
    fn one_joint_with(
        &mut self,
        model: &Model,
        tau: &[f64],
        level: Level,
    ) -> Result<(), DynamicsError> {
        let accel = level == Level::Acceleration;
        self.touched = self.hier.hnodes.len() + self.hier.fnodes.len();
        let d = &self.data;
        let r = &self.hier.records[0];
        let x = &d.x[r.body()];
        let rl = &r.cluster_mass;
        // The cluster's centre of mass from the joint's body (computation axes), h = m c.
        let cw = x.e * (rl.com - x.r);
        let body = Parts {
            e: x.e,
            et: x.e.transpose(),
            ic: rl.inertia,
            m: rl.mass,
            cw,
            cc: cw.dot(cw),
            hv: cw * rl.mass,
        };
        let s = d.s[r.v_offset()];
        let u = body.inertia(s);
        let mut dd = s.dot(u);
        // The step's armature, or the model's at impulse level (as `reduced_aba_with`).
        let armature = if accel {
            d.armature()
        } else {
            &model.dynamics.armature
        };
        if let Some(a) = armature.get(r.v_offset()) {
            dd += a;
        }
        if dd.is_nan() || dd <= 0.0 {
            return Err(singular(model, r.body()));
        }
        let (pa, ap) = if accel {
            let v = d.v[r.body()];
            (
                v.cross_force(body.inertia(v)) - self.forces.node_sums[r.cluster()],
                SpatialMotion::new(DVec3::ZERO, -d.gravity) + d.c[r.body()],
            )
        } else {
            (SpatialForce::ZERO, SpatialMotion::ZERO)
        };
        let uu = tau[r.v_offset()] - s.dot(pa);
        self.body.qdd[r.v_offset()] = (1.0 / dd) * (uu - ap.dot(u));
        Ok(())
    }

    #[inline(always)]
    fn reduced_aba_with<A: Arith>(
        &mut self,
        model: &Model,
        tau: &[f64],
        level: Level,
    ) -> Result<(), DynamicsError> {
        let accel = level == Level::Acceleration;
        let wide = self.switches.fused;
        // The nodes this stands for: the active joins and the rigid frontier.
        self.touched = self.hier.hnodes.len() + self.hier.fnodes.len();
        let h = &mut self.hier;
        let d = &self.data;
        // Pass 1: each cluster's spatial inertia about the computation origin (from its
        // top-body frame), `I = [Ī, h×; h×ᵀ, m 1]` with `Ī = E I_c Eᵀ + m (|c|² 1 − c cᵀ)`,
        // `h = m c`, and bias force `pᴬ = v ×* I v − f_ext` (gravity enters as the world's
        // acceleration −a_g).
        let n = h.records.len();
        let node_sums = &self.forces.node_sums[..];
        // (One thread without the `parallel` feature.)
        if n >= PARALLEL_HYBRID_MIN_JOINTS && self.threads.count() > 1 {
            #[cfg(feature = "parallel")]
            {
                use rayon::prelude::*;
                let (rec, ia, pa) = (
                    &h.records[..],
                    &mut h.reduced_aba.ia[..n],
                    &mut h.reduced_aba.pa[..n],
                );
                self.threads.install(|| {
                    rec.par_chunks(RECORD_GRAIN)
                        .zip(ia.par_chunks_mut(RECORD_GRAIN))
                        .zip(pa.par_chunks_mut(RECORD_GRAIN))
                        .for_each(|((r, ia), pa)| {
                            clusters_run(wide, r, ia, pa, d, node_sums, accel)
                        })
                });
            }
        } else {
            for ((r, ia), pa) in h
                .records
                .iter()
                .zip(h.reduced_aba.ia.iter_mut())
                .zip(h.reduced_aba.pa.iter_mut())
            {
                cluster(r, d, node_sums, accel, ia, pa);
            }
        }
        // Pass 2, leaves to root: U = Iᴬ S, D = Sᵀ U, u = τ − Sᵀ pᴬ; the parent cluster gets
        // Iᵃ = Iᴬ − U D⁻¹ Uᵀ and pᵃ = pᴬ + Iᵃ c + U D⁻¹ u ([`articulate_record`]).
        // The workspace as local slices (their pointers and lengths stay in registers, and
        // the per-record arrays need no bounds checks).
        let Hierarchy {
            records: rec,
            reduced_aba:
                ReducedAba {
                    ia,
                    pa: pas,
                    acceleration: acc,
                    dinv,
                    u: us,
                    uu: uus,
                    cholesky: chol,
                },
            split,
            ..
        } = h;
        let n = rec.len();
        let rec = &rec[..];
        let mut w = Art {
            ia: &mut ia[..n],
            pa: &mut pas[..n],
            u: &mut us[..],
            uu: &mut uus[..],
            chol: &mut chol[..n],
        };
        let dinvs = &mut dinv[..n];
        // The armature of the solve: at impulse level the model's own (momentum is
        // `(M + A) q̇`), at acceleration level the step's (`a + h b`, `passive.rs`).
        let armature = if accel {
            d.armature()
        } else {
            &model.dynamics.armature[..]
        };
        let run = Run {
            wide,
            accel,
            rec,
            d,
            tau,
            armature,
        };
        // Pass 3's acceleration of the world: −a_g (gravity enters as the world's acceleration).
        let a0 = if accel {
            SpatialMotion::new(DVec3::ZERO, -d.gravity).to_array()
        } else {
            [0.0; 6]
        };
        let acc = &mut acc[..n];
        // (One thread without the `parallel` feature.)
        #[cfg(feature = "parallel")]
        if n >= PARALLEL_HYBRID_MIN_JOINTS && self.threads.count() > 1 && !split.tasks.is_empty() {
            let qdd = &mut self.body.qdd[..];
            let tasks = &mut split.tasks[..];
            return split_passes::<A>(&run, &self.threads, tasks, w, dinvs, acc, qdd, a0)
                .map_err(|idx| singular(model, rec[idx].body()));
        }
        #[cfg(not(feature = "parallel"))]
        let _ = split;
        for idx in (0..n).rev() {
            if !articulate_record::<A>(&run, &rec[idx], idx, Base::ZERO, &mut w, dinvs) {
                return Err(singular(model, rec[idx].body()));
            }
        }
        // Pass 3, root to leaves: a' = a_parent + c, q̈ = D⁻¹ (u − Uᵀ a'), a = a' + S q̈
        // ([`accelerate_run`]).
        let mut io = Accel {
            chol: &*w.chol,
            u: &*w.u,
            uu: &*w.uu,
            s: &d.s[..],
            qdd: &mut self.body.qdd[..],
        };
        let none = Chain::NONE;
        accelerate_run::<A>(&run, 0..n, Base::ZERO, none, a0, a0, &mut io, acc, dinvs);
        Ok(())
    }
}

/// Where the active bodies' kinematics go: per body its pose, velocity and velocity product,
/// per velocity coordinate its subspace column — a workspace that starts at a [`Base`] (its
/// `body` and `vo`).
struct Kin<'a> {
    x: &'a mut [SpatialTransform],
    v: &'a mut [SpatialMotion],
    c: &'a mut [SpatialMotion],
    s: &'a mut [SpatialMotion],
}

#[cfg(feature = "parallel")]
impl<'a> Kin<'a> {
    /// The same workspace, borrowed.
    fn reborrow(&mut self) -> Kin<'_> {
        Kin {
            x: self.x,
            v: self.v,
            c: self.c,
            s: self.s,
        }
    }

    /// The workspace (which starts at `from`) before `at` and from `at` on.
    fn split(self, from: Base, at: Base) -> (Kin<'a>, Kin<'a>) {
        let (b, k) = (at.body - from.body, at.v_offset - from.v_offset);
        let (x, x1) = self.x.split_at_mut(b);
        let (v, v1) = self.v.split_at_mut(b);
        let (c, c1) = self.c.split_at_mut(b);
        let (s, s1) = self.s.split_at_mut(k);
        (
            Kin { x, v, c, s },
            Kin {
                x: x1,
                v: v1,
                c: c1,
                s: s1,
            },
        )
    }
}

/// The kinematics of the records `records` (parents first) into the workspace `out` that starts
/// at `at`, with `scs` the sines and cosines of their angles in turn and `(x_cw, q, q̇)`.
/// A parent body before `at.body` (the root of a subtree run on its own) has pose and
/// velocity `root`. A joint of the general path (not closed-form, [`RevoluteParts`] or
/// floating) needs `at.vo` zero (its columns go where `body_kinematics` puts them).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn kinematics_run(
    wide: bool,
    model: &Model,
    rec: &[ActiveJoint],
    at: Base,
    root: (SpatialTransform, SpatialMotion),
    (x_cw, q, qd): (SpatialTransform, &[f64], &[f64]),
    mut scs: &[(f64, f64)],
    d: &mut Kin,
) {
    for r in rec {
        let (base, v) = match r.parent {
            Parent::World | Parent::Ground => (x_cw, SpatialMotion::ZERO),
            Parent::Active(p) | Parent::Cluster(p) => match p as usize {
                p if p < at.body => root,
                p => (d.x[p - at.body], d.v[p - at.body]),
            },
        };
        let b = r.body() - at.body;
        // The parent frame composed with the record's constant pose (in each branch: the
        // general path passes it in memory, the closed form keeps it in registers).
        let compose = |base: SpatialTransform| {
            if r.shift {
                SpatialTransform {
                    e: base.e,
                    r: r.fixed_pose.r + base.r,
                }
            } else if r.mulx {
                base * r.fixed_pose
            } else {
                base
            }
        };
        let Some((i, sign)) = r.axis() else {
            let x = compose(base);
            let body = &model.bodies[r.body()];
            match r.parts() {
                Some(parts) => {
                    let sc;
                    (sc, scs) = scs.split_at(body.joint.len());
                    let out = (&mut d.x[b], &mut d.v[b], &mut d.c[b]);
                    let s = (&mut *d.s, at.v_offset);
                    revolute(wide, body, parts, &x, &v, sc, qd, s, out);
                }
                None => match body.joint.as_slice() {
                    [part] if part.kind == articula_model::JointKind::Floating => {
                        let out = (&mut d.x[b], &mut d.v[b], &mut d.c[b]);
                        floating(wide, part, &x, &v, q, qd, (&mut *d.s, at.v_offset), out);
                    }
                    _ => {
                        debug_assert_eq!(
                            at.v_offset, 0,
                            "the general path at the start of the columns"
                        );
                        let (x, v, c) = articula_dca::body_kinematics(body, x, v, q, qd, d.s);
                        d.x[b] = x;
                        d.v[b] = v;
                        d.c[b] = c;
                    }
                },
            }
            continue;
        };
        let Some((&(sn, cs), rest)) = scs.split_first() else {
            unreachable!("one angle per closed-form joint")
        };
        scs = rest;
        let mut x = compose(base);
        let w = turn(&mut x, i, sn, cs) * sign;
        let p = -(x.e * x.r);
        let s = SpatialMotion::new(w, p.cross(w));
        d.s[r.v_offset() - at.v_offset] = s;
        let vj = s * qd[r.v_offset()];
        let c = v.cross_motion(vj);
        let v = v + vj;
        d.x[b] = x;
        d.v[b] = v;
        d.c[b] = c;
    }
}

/// The kinematics of the active joints over the subtrees `tasks` on `threads`
/// ([`Subtrees`](crate::parts::subtrees::Subtrees)): the top records (and the subtrees with a joint of the general path)
/// serially, then each other subtree on a task from its root's parent's pose and velocity.
/// Each body's arithmetic is the serial loop's.
#[cfg(feature = "parallel")]
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn split_kinematics(
    wide: bool,
    model: &Model,
    threads: &Threads,
    rec: &[ActiveJoint],
    tasks: &mut [Subtree],
    at: (SpatialTransform, &[f64], &[f64]),
    scs: &[(f64, f64)],
    mut out: Kin,
) {
    let none = (at.0, SpatialMotion::ZERO);
    let (mut start, mut ang) = (0, 0);
    for t in tasks.iter() {
        let top = &rec[start..t.start];
        kinematics_run(
            wide,
            model,
            top,
            Base::ZERO,
            none,
            at,
            &scs[ang..],
            &mut out,
        );
        if !t.kin_on_task {
            let sub = &rec[t.start..t.stop];
            kinematics_run(
                wide,
                model,
                sub,
                Base::ZERO,
                none,
                at,
                &scs[t.angle_start..],
                &mut out,
            );
        }
        (start, ang) = (t.stop, t.angle_stop);
    }
    kinematics_run(
        wide,
        model,
        &rec[start..],
        Base::ZERO,
        none,
        at,
        &scs[ang..],
        &mut out,
    );
    for t in tasks.iter_mut() {
        t.kin_root = match rec[t.start].parent {
            Parent::World | Parent::Ground => none,
            Parent::Active(p) | Parent::Cluster(p) => (out.x[p as usize], out.v[p as usize]),
        };
    }
    let (tasks, first) = (&*tasks, tasks[0].base);
    let (_, from) = out.reborrow().split(Base::ZERO, first);
    threads.install(|| kinematics_tasks(wide, model, rec, tasks, at, scs, from));
}

/// The kinematics of the subtrees `tasks` of the general-path-free kind, halves of the list
/// on two tasks, into the workspace `out` from the first's start.
#[cfg(feature = "parallel")]
#[allow(clippy::too_many_arguments)]
fn kinematics_tasks(
    wide: bool,
    model: &Model,
    rec: &[ActiveJoint],
    tasks: &[Subtree],
    at: (SpatialTransform, &[f64], &[f64]),
    scs: &[(f64, f64)],
    out: Kin,
) {
    match tasks {
        [] => {}
        [t] if t.kin_on_task => kinematics_subtree(wide, model, rec, t, at, scs, out),
        [_] => {}
        _ => {
            let mid = tasks.len() / 2;
            let (lo, hi) = out.split(tasks[0].base, tasks[mid].base);
            rayon::join(
                || kinematics_tasks(wide, model, rec, &tasks[..mid], at, scs, lo),
                || kinematics_tasks(wide, model, rec, &tasks[mid..], at, scs, hi),
            );
        }
    }
}

#[cfg(feature = "parallel")]
articula_spatial::fma_dispatch! {
    /// The kinematics of one subtree from its root's parent's pose and velocity, compiled for
    /// AVX2 + FMA too when `wide` (the same bits, wider vectors).
    fn kinematics_subtree(wide: bool, model: &Model, rec: &[ActiveJoint], t: &Subtree, at: (SpatialTransform, &[f64], &[f64]), scs: &[(f64, f64)], out: Kin<'_>);
    avx2_fma: wide, Portable;
    |A| {
        let mut out = out;
        let (sub, scs) = (&rec[t.start..t.stop], &scs[t.angle_start..]);
        kinematics_run(wide, model, sub, t.base, t.kin_root, at, scs, &mut out)
    }
}

/// What every record of passes 2 and 3 reads: the kernels' switches (`wide`: AVX2 + FMA,
/// `accel`: [`Level::Acceleration`]), the records, the active bodies' kinematics and `τ`.
#[derive(Clone, Copy)]
struct Run<'a> {
    wide: bool,
    accel: bool,
    rec: &'a [ActiveJoint],
    d: &'a Data,
    tau: &'a [f64],
    /// Per degree of freedom, the armature added to `D` (empty: none; `passive.rs`).
    armature: &'a [f64],
}

/// Pass 2 of the reduced ABA at record `idx` (leaves to root: every child of `idx` done
/// before), into the workspace `w` that starts at `at`: `U = Iᴬ S`, `D = Sᵀ U`,
/// `u = τ − Sᵀ pᴬ`, and the parent cluster gets `Iᵃ = Iᴬ − U D⁻¹ Uᵀ`,
/// `pᵃ = pᴬ + Iᵃ c + U D⁻¹ u`. False when `D` is not positive definite. A record touches
/// only its own entries and its parent's `Iᴬ`, `pᴬ`.
#[inline(always)]
fn articulate_record<A: Arith>(
    run: &Run,
    r: &ActiveJoint,
    idx: usize,
    at: Base,
    w: &mut Art,
    dinvs: &mut [f64],
) -> bool {
    let (wide, accel, d, tau) = (run.wide, run.accel, run.d, run.tau);
    let (k, dof) = (r.dof_count(), r.first_dof() - at.first_dof);
    let i = idx - at.record;
    let pa = w.pa[i];
    let parent = match r.pidx() {
        NO_PARENT => NO_PARENT,
        p => p - at.record,
    };
    let c = if accel {
        d.c[r.body()].to_array()
    } else {
        [0.0; 6]
    };
    if k == 1 {
        let ia = &w.ia[i].0;
        let s = d.s[r.v_offset()].to_array();
        // U = Iᴬ s (Iᴬ symmetric: a sum of its rows).
        // In two halves of three rows, then summed: the chain from a joint's Iᴬ to
        // its parent's is three multiply–adds and an addition here, not six.
        let (mut ua, mut ub) = ([0.0; 6], [0.0; 6]);
        for k in 0..3 {
            for rr in 0..6 {
                ua[rr] = A::mul_add(ia[k][rr], s[k], ua[rr]);
                ub[rr] = A::mul_add(ia[k + 3][rr], s[k + 3], ub[rr]);
            }
        }
        let mut u = [0.0; 6];
        for rr in 0..6 {
            u[rr] = ua[rr] + ub[rr];
        }
        let mut dd = dot6_pairs::<A>(&s, &u);
        if let Some(a) = run.armature.get(r.v_offset()) {
            dd += a;
        }
        let dinv = 1.0 / dd;
        let uu = tau[r.v_offset()] - dot6_pairs::<A>(&s, &pa);
        w.u[dof] = u;
        w.uu[dof] = uu;
        dinvs[i] = dinv;
        if parent != NO_PARENT {
            // Iᴬ c, a second sweep over the rows (read again: sweeping them once for
            // both products spilled them, and the broadcasts, to the stack).
            let mut ic = [0.0; 6];
            for (row, &cc) in ia.iter().zip(&c) {
                for rr in 0..6 {
                    ic[rr] = A::mul_add(row[rr], cc, ic[rr]);
                }
            }
            let g = dinv * (uu - dot6_pairs::<A>(&c, &u));
            let pp = &mut w.pa[parent];
            for rr in 0..6 {
                pp[rr] += pa[rr] + A::mul_add(u[rr], g, ic[rr]);
            }
            let (lo, hi) = w.ia.split_at_mut(i);
            add_sub_outer::<A>(&mut lo[parent], &hi[0], &u, dinv);
        }
        // Checked after the parent's update (which an error leaves unused: pass 1
        // rewrites every Iᴬ, pᴬ): the branch no longer splits the sweep over Iᴬ's rows.
        return !(dd.is_nan() || dd <= 0.0);
    }
    // Several degrees of freedom: the loops over them unrolled for three (the
    // humanoid's hips, shoulders, spine and neck); any other count takes the same
    // loops with their length read at run time (the same operations in the same
    // order). One unrolled copy per count a body's step runs is code the instruction
    // cache must hold for every body of a crowd: copies for 2 and 6 DOF too cost more
    // in instruction-cache misses and wall time than they save in instructions
    // (docs/performance.md#crowd), so only the humanoid's common count has one.
    let at = [i, parent, dof, r.v_offset()];
    let arm = run.armature;
    match k {
        3 => articulate::<3>(wide, &at, w, (&d.s, tau, arm), k, &c),
        _ => articulate::<0>(wide, &at, w, (&d.s, tau, arm), k, &c),
    }
}

/// Pass 3 of the reduced ABA over the records `range` (root to leaves: every parent done
/// before), into the workspace that starts at `at` (`io`'s `q̈`, `acc`, `dinv`), from
/// `chain`, the state after the record before `range.start`: `a' = a_parent + c`,
/// `q̈ = D⁻¹ (u − Uᵀ a')`, `a = a' + S q̈`. A parent before `at.rec` (the root of a subtree
/// run on its own) has acceleration `root`; none, `a0`. Returns the state after the last
/// record.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn accelerate_run<A: Arith>(
    run: &Run,
    range: std::ops::Range<usize>,
    at: Base,
    chain: Chain,
    a0: [f64; 6],
    root: [f64; 6],
    io: &mut Accel,
    acc: &mut [[f64; 6]],
    dinv: &[f64],
) -> Chain {
    let (wide, accel, d) = (run.wide, run.accel, run.d);
    let Chain {
        pidx: mut pidx1,
        accel: mut pap,
        subspace: mut ps,
        qdd: mut px,
    } = chain;
    let first = range.start;
    for (off, r) in run.rec[range].iter().enumerate() {
        let i = first + off - at.record;
        let (vo, k, dof) = (
            r.v_offset() - at.v_offset,
            r.dof_count(),
            r.first_dof() - at.first_dof,
        );
        let parent_acc = |acc: &[[f64; 6]]| match r.pidx() {
            NO_PARENT => a0,
            p if p < at.record => root,
            p => acc[p - at.record],
        };
        let c = if accel {
            d.c[r.body()].to_array()
        } else {
            [0.0; 6]
        };
        if k == 1 {
            let s = io.s[r.v_offset()].to_array();
            let ud = &io.u[dof];
            let (ap, x) = if r.pidx() == pidx1 {
                // The parent is the previous record: a' = (a'_p + S_p q̈_p) + c, and
                // q̈ = D⁻¹ (u − Uᵀ(a'_p + c) − (Uᵀ S_p) q̈_p), whose chain from the
                // parent's q̈ is one multiply–add and a product (the parent's a' is
                // known before its q̈).
                let mut base = pap;
                let mut ap: [f64; 6] = std::array::from_fn(|rr| A::mul_add(ps[rr], px, pap[rr]));
                if accel {
                    for rr in 0..6 {
                        base[rr] += c[rr];
                        ap[rr] += c[rr];
                    }
                }
                let sig = dot6_pairs::<A>(ud, &ps);
                let x = dinv[i] * A::neg_mul_add(sig, px, io.uu[dof] - dot6_pairs::<A>(&base, ud));
                (ap, x)
            } else {
                let mut ap = parent_acc(acc);
                if accel {
                    for rr in 0..6 {
                        ap[rr] += c[rr];
                    }
                }
                (ap, dinv[i] * (io.uu[dof] - dot6_pairs::<A>(&ap, ud)))
            };
            io.qdd[vo] = x;
            acc[i] = std::array::from_fn(|rr| A::mul_add(s[rr], x, ap[rr]));
            (pidx1, pap, ps, px) = (first + off, ap, s, x);
            continue;
        }
        pidx1 = usize::MAX;
        let mut ap = parent_acc(acc);
        if accel {
            for rr in 0..6 {
                ap[rr] += c[rr];
            }
        }
        let at = [i, dof, r.v_offset(), vo];
        acc[i] = match k {
            3 => accelerate::<3>(wide, &at, io, k, &ap),
            6 => accelerate::<6>(wide, &at, io, k, &ap),
            _ => accelerate::<0>(wide, &at, io, k, &ap),
        };
    }
    Chain {
        pidx: pidx1,
        accel: pap,
        subspace: ps,
        qdd: px,
    }
}

/// Pass 1 of [`Adaptive::reduced_aba`] for one record: its cluster's spatial inertia about the
/// computation origin (from its top-body frame), `I = [Ī, h×; h×ᵀ, m 1]` with
/// `Ī = E I_c Eᵀ + m (|c|² 1 − c cᵀ)`, `h = m c`, and bias force `pᴬ = v ×* I v − f_ext`
/// (zero at [`Level::Impulse`]). Reads only the record's own body, so records may be done in
/// any order, on any thread, with the same bits.
#[inline(always)]
fn cluster(
    r: &ActiveJoint,
    d: &Data,
    node_sums: &[SpatialForce],
    accel: bool,
    ia: &mut Mat6,
    pa: &mut [f64; 6],
) {
    let x = &d.x[r.body()];
    let rl = &r.cluster_mass;
    let m = rl.mass;
    // Ī = E I_c Eᵀ + m (|c|² 1 − c cᵀ) in lanes of four (the fourth unused), each
    // entry by glam's operations in glam's order: with `e_r` row r of E and
    // `ei_r = I_c e_r`, `ei_r[i] = (I_c[0][i] e_r,x + I_c[1][i] e_r,y) + I_c[2][i] e_r,z`
    // (`I_c[col][row]`) is lane r of `a_i`, a sum of E's columns; `Ī[r][c] = ei_r · e_c
    // − (m c_r) c_c` is lane r of column c (upper triangle used, r ≤ c).
    let ec = [lanes3(x.e.x_axis), lanes3(x.e.y_axis), lanes3(x.e.z_axis)];
    let icm = rl.inertia.to_cols_array_2d();
    let comb = |k: [f64; 3], v: &[[f64; 4]; 3]| -> [f64; 4] {
        let mut o = [0.0; 4];
        for l in 0..4 {
            o[l] = v[0][l] * k[0] + v[1][l] * k[1] + v[2][l] * k[2];
        }
        o
    };
    let a = [
        comb([icm[0][0], icm[1][0], icm[2][0]], &ec),
        comb([icm[0][1], icm[1][1], icm[2][1]], &ec),
        comb([icm[0][2], icm[1][2], icm[2][2]], &ec),
    ];
    let dl = rl.com - x.r;
    let cwl = comb([dl.x, dl.y, dl.z], &ec);
    let cc = cwl[0] * cwl[0] + cwl[1] * cwl[1] + cwl[2] * cwl[2];
    let mcw: [f64; 4] = [m * cwl[0], m * cwl[1], m * cwl[2], m * cwl[3]];
    let col = |c: usize| -> [f64; 4] {
        let dot = comb([ec[0][c], ec[1][c], ec[2][c]], &a);
        let mut o = [0.0; 4];
        for l in 0..4 {
            o[l] = dot[l] - mcw[l] * cwl[c];
        }
        o
    };
    let (c0, c1, c2) = (col(0), col(1), col(2));
    let (i00, i01, i02, i11, i12, i22) = (
        c0[0] + m * cc,
        c1[0],
        c2[0],
        c1[1] + m * cc,
        c2[1],
        c2[2] + m * cc,
    );
    let hv = DVec3::new(cwl[0] * m, cwl[1] * m, cwl[2] * m);
    // [Ī, h×; h×ᵀ, m 1].
    *ia = Mat6([
        [i00, i01, i02, 0.0, -hv.z, hv.y],
        [i01, i11, i12, hv.z, 0.0, -hv.x],
        [i02, i12, i22, -hv.y, hv.x, 0.0],
        [0.0, hv.z, -hv.y, m, 0.0, 0.0],
        [-hv.z, 0.0, hv.x, 0.0, m, 0.0],
        [hv.y, -hv.x, 0.0, 0.0, 0.0, m],
    ]);
    *pa = if accel {
        let v = d.v[r.body()];
        let ibw = DVec3::new(i00, i01, i02) * v.w.x
            + DVec3::new(i01, i11, i12) * v.w.y
            + DVec3::new(i02, i12, i22) * v.w.z;
        let iv = SpatialForce::new(ibw + hv.cross(v.v), v.v * m - hv.cross(v.w));
        (v.cross_force(iv) - node_sums[r.cluster()]).to_array()
    } else {
        [0.0; 6]
    };
}

/// [`cluster`] for a run of records (one task of the split pass 1), compiled for AVX2 + FMA
/// too (the same bits, wider vectors), run when `wide`.
#[cfg(feature = "parallel")]
fn clusters_run(
    wide: bool,
    rec: &[ActiveJoint],
    ia: &mut [Mat6],
    pa: &mut [[f64; 6]],
    d: &Data,
    node_sums: &[SpatialForce],
    accel: bool,
) {
    articula_spatial::fma_dispatch! {
        fn run(wide: bool, rec: &[ActiveJoint], ia: &mut [Mat6], pa: &mut [[f64; 6]], d: &Data, node_sums: &[SpatialForce], accel: bool);
        avx2_fma: wide, Portable;
        |A| for ((r, ia), pa) in rec.iter().zip(ia.iter_mut()).zip(pa.iter_mut()) {
            cluster(r, d, node_sums, accel, ia, pa);
        }
    }
    run(wide, rec, ia, pa, d, node_sums, accel)
}

#[cfg(feature = "parallel")]
impl Subtrees {
    /// The subtrees of the reduced tree `records` (none below [`PARALLEL_HYBRID_MIN_JOINTS`]
    /// records, or when the records are not a pre-order with coordinates in record order).
    /// `nb`: the model's bodies (the scratch is reserved for every body at once: a later
    /// re-selection allocates nothing).
    pub(crate) fn find(&mut self, model: &Model, rec: &[ActiveJoint]) {
        let nb = model.bodies.len();
        self.tasks.clear();
        let n = rec.len();
        if n < PARALLEL_HYBRID_MIN_JOINTS {
            return;
        }
        let size = &mut self.size;
        size.clear();
        size.reserve(nb);
        size.resize(n, 1);
        for idx in (1..n).rev() {
            match rec[idx].pidx() {
                NO_PARENT => {}
                p if p < idx => size[p] += size[idx],
                _ => return,
            }
        }
        // Pre-order: each record's run nests in its parent's (then a record's subtree fills
        // its run exactly). Coordinates and slots ascend with the records.
        for idx in 1..n {
            let (r, prev) = (&rec[idx], &rec[idx - 1]);
            let nests = match r.pidx() {
                NO_PARENT => true,
                p => idx + size[idx] as usize <= p + size[p] as usize,
            };
            if !nests
                || r.v_offset() < prev.v_offset() + prev.dof_count()
                || r.first_dof() != prev.first_dof() + prev.dof_count()
            {
                return;
            }
        }
        let most = n / 2;
        let mut idx = 0;
        while idx < n {
            let m = size[idx] as usize;
            if m > most {
                idx += 1;
                continue;
            }
            if m >= SUBTREE_MIN_RECORDS {
                let r = &rec[idx];
                self.tasks.push(Subtree {
                    start: idx,
                    stop: idx + m,
                    base: Base {
                        record: idx,
                        first_dof: r.first_dof(),
                        v_offset: r.v_offset(),
                        body: r.body(),
                    },
                    ..Subtree::default()
                });
            }
            idx += m;
        }
        // One subtree alone (a chain's lower half) would only move work to another thread.
        if self.tasks.len() < 2 {
            self.tasks.clear();
            return;
        }
        // The angles before each subtree and in it (one per closed-form joint, one per part),
        // and whether its kinematics may run on a task.
        let mut ang = 0;
        let mut next = 0;
        for (idx, r) in rec.iter().enumerate() {
            let Some(t) = self.tasks.get_mut(next) else {
                break;
            };
            if idx == t.start {
                (t.angle_start, t.kin_on_task) = (ang, true);
            }
            let joint = &model.bodies[r.body()].joint;
            ang += match (r.axis(), r.parts()) {
                (Some(_), _) => 1,
                (None, Some(_)) => joint.len(),
                (None, None) => {
                    if idx >= t.start {
                        t.kin_on_task &= matches!(joint.as_slice(), [part] if part.kind == articula_model::JointKind::Floating);
                    }
                    0
                }
            };
            if idx + 1 == t.stop {
                t.angle_stop = ang;
                next += 1;
            }
        }
    }
}

/// The smallest subtree of the reduced tree ([`Subtrees`]) the kinematics and passes 2 and 3
/// run as a task of its own (a smaller one stays in the serial part): the runs of the split
/// sweeps' size, some 0.2 ms of a hybrid step's work on one core of the test machine (about
/// 200 ns a joint, docs/scaling.md), against a few microseconds to hand a task to a thread.
#[cfg(feature = "parallel")]
const SUBTREE_MIN_RECORDS: usize = 1024;

/// Passes 2 and 3 of [`Adaptive::reduced_aba`] over the subtrees `tasks` on `threads`
/// ([`Subtrees`](crate::parts::subtrees::Subtrees)): each subtree below its root on a task, then the top and the roots serially
/// (pass 2); the top serially, then each subtree on a task (pass 3). The error is the serial
/// passes' (the record found singular first in descending order), as its record's index.
#[cfg(feature = "parallel")]
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn split_passes<A: Arith>(
    run: &Run,
    threads: &Threads,
    tasks: &mut [Subtree],
    mut w: Art,
    dinv: &mut [f64],
    acc: &mut [[f64; 6]],
    qdd: &mut [f64],
    a0: [f64; 6],
) -> Result<(), usize> {
    let (rec, n) = (run.rec, run.rec.len());
    let first = tasks[0].base;
    let bad = {
        let (_, from) = w.reborrow().split(Base::ZERO, first);
        let (tasks, dinv) = (&*tasks, &mut dinv[first.record..]);
        threads.install(|| articulate_tasks(run, tasks, from, dinv))
    };
    // The top records and the subtrees' roots in descending order (a subtree's records after
    // their root, its parent's other children in their places).
    // (A loop, not a closure: a closure is a function of its own, compiled without the
    // caller's AVX2 + FMA, where `Fused`'s multiply–adds are calls.)
    let mut end = n;
    let mut t = tasks.len();
    loop {
        // The top records after subtree `t` (or after the last one), then `t`'s root.
        let (from, root) = match t.checked_sub(1) {
            Some(k) => (tasks[k].stop, Some(tasks[k].start)),
            None => (0, None),
        };
        for idx in (from..end).rev().chain(root) {
            match bad {
                Some(b) if idx < b => return Err(b),
                _ if articulate_record::<A>(run, &rec[idx], idx, Base::ZERO, &mut w, dinv) => {}
                _ => return Err(idx),
            }
        }
        let Some(root) = root else {
            break;
        };
        (end, t) = (root, t - 1);
    }
    if let Some(b) = bad {
        return Err(b);
    }
    // Pass 3: the top, then the subtrees from their roots' parents.
    let (dinv, s) = (&*dinv, run.d.s.as_slice());
    let mut io = Accel {
        chol: &*w.chol,
        u: &*w.u,
        uu: &*w.uu,
        s,
        qdd,
    };
    let mut start = 0;
    for t in tasks.iter_mut() {
        let range = start..t.start;
        t.entry = accelerate_run::<A>(
            run,
            range,
            Base::ZERO,
            Chain::NONE,
            a0,
            a0,
            &mut io,
            acc,
            dinv,
        );
        start = t.stop;
    }
    accelerate_run::<A>(
        run,
        start..n,
        Base::ZERO,
        Chain::NONE,
        a0,
        a0,
        &mut io,
        acc,
        dinv,
    );
    for t in tasks.iter_mut() {
        t.root = match rec[t.start].pidx() {
            NO_PARENT => a0,
            p => acc[p],
        };
    }
    let tasks = &*tasks;
    let (r, k, v) = (first.record, first.first_dof, first.v_offset);
    let from = Accel {
        chol: &io.chol[r..],
        u: &io.u[k..],
        uu: &io.uu[k..],
        s,
        qdd: &mut io.qdd[v..],
    };
    let (acc, dinv) = (&mut acc[r..], &dinv[r..]);
    threads.install(|| accelerate_tasks(run, tasks, from, acc, dinv, a0));
    Ok(())
}

/// Pass 2 of the subtrees `tasks` below their roots, halves of the list on two tasks, into
/// the workspace `w` from the first's start: the greatest record found singular, if any.
#[cfg(feature = "parallel")]
fn articulate_tasks(run: &Run, tasks: &[Subtree], w: Art, dinv: &mut [f64]) -> Option<usize> {
    match tasks {
        [] => None,
        [t] => articulate_subtree(run.wide, run, t, w, dinv),
        _ => {
            let mid = tasks.len() / 2;
            let (from, at) = (tasks[0].base, tasks[mid].base);
            let (lo, hi) = w.split(from, at);
            let (d0, d1) = dinv.split_at_mut(at.record - from.record);
            let (a, b) = rayon::join(
                || articulate_tasks(run, &tasks[..mid], lo, d0),
                || articulate_tasks(run, &tasks[mid..], hi, d1),
            );
            a.max(b)
        }
    }
}

#[cfg(feature = "parallel")]
articula_spatial::fma_dispatch! {
    /// Pass 2 of one subtree below its root (the root's own record is the serial part's),
    /// compiled for AVX2 + FMA with fused multiply–adds when `wide` (the serial pass's
    /// arithmetic): the first record found singular, if any.
    fn articulate_subtree(wide: bool, run: &Run<'_>, t: &Subtree, w: Art<'_>, dinv: &mut [f64]) -> Option<usize>;
    avx2_fma: wide, Fused;
    |A| {
        let mut w = w;
        (t.start + 1..t.stop)
            .rev()
            .find(|&idx| !articulate_record::<A>(run, &run.rec[idx], idx, t.base, &mut w, dinv))
    }
}

/// Pass 3 of the subtrees `tasks`, halves of the list on two tasks, into the workspace (`io`'s
/// `q̈`, `acc`, `dinv`) from the first's start.
#[cfg(feature = "parallel")]
fn accelerate_tasks(
    run: &Run,
    tasks: &[Subtree],
    io: Accel,
    acc: &mut [[f64; 6]],
    dinv: &[f64],
    a0: [f64; 6],
) {
    match tasks {
        [] => {}
        [t] => accelerate_subtree(run.wide, run, t, io, acc, dinv, a0),
        _ => {
            let mid = tasks.len() / 2;
            let (from, at) = (tasks[0].base, tasks[mid].base);
            let (r, k, v) = (
                at.record - from.record,
                at.first_dof - from.first_dof,
                at.v_offset - from.v_offset,
            );
            let (q0, q1) = io.qdd.split_at_mut(v);
            let (io0, io1) = (
                Accel {
                    chol: io.chol,
                    u: io.u,
                    uu: io.uu,
                    s: io.s,
                    qdd: q0,
                },
                Accel {
                    chol: &io.chol[r..],
                    u: &io.u[k..],
                    uu: &io.uu[k..],
                    s: io.s,
                    qdd: q1,
                },
            );
            let (acc0, acc1) = acc.split_at_mut(r);
            let (d0, d1) = dinv.split_at(r);
            rayon::join(
                || accelerate_tasks(run, &tasks[..mid], io0, acc0, d0, a0),
                || accelerate_tasks(run, &tasks[mid..], io1, acc1, d1, a0),
            );
        }
    }
}

#[cfg(feature = "parallel")]
articula_spatial::fma_dispatch! {
    /// Pass 3 of one subtree from its entry state and its root's parent's acceleration,
    /// compiled for AVX2 + FMA with fused multiply–adds when `wide` (the serial pass's
    /// arithmetic).
    fn accelerate_subtree(wide: bool, run: &Run<'_>, t: &Subtree, io: Accel<'_>, acc: &mut [[f64; 6]], dinv: &[f64], a0: [f64; 6]);
    avx2_fma: wide, Fused;
    |A| {
        let mut io = io;
        accelerate_run::<A>(run, t.start..t.stop, t.base, t.entry, a0, t.root, &mut io, acc, dinv);
    }
}

/// Records (and angles) per task of a split sweep: a multiple of four (the lanes of
/// [`sin_cos_angles4`]), large enough that a task outweighs its scheduling.
#[cfg(feature = "parallel")]
const RECORD_GRAIN: usize = 1024;

/// The sines and cosines `sin_cos` of the signed angles `angles` (indices into `q`): four at a time in
/// AVX2 lanes when `wide` (the same bits as one at a time), the rest one at a time.
#[inline(always)]
fn sin_cos_angles(wide: bool, ang: &[(u32, f32)], scs: &mut [(f64, f64)], q: &[f64]) {
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if wide && ang.len() >= 4 {
        // SAFETY: `wide` is `fused`, set only where the CPU has AVX2 and FMA.
        done = unsafe { sin_cos_angles4(ang, scs, q) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = wide;
    for (&(qi, sign), sc) in ang[done..].iter().zip(&mut scs[done..]) {
        *sc = crate::trig::sin_cos(sign as f64 * q[qi as usize]);
    }
}

/// The first sweep of [`Adaptive::active_kinematics`] four angles at a time
/// ([`crate::trig::sin_cos4`]; out of line, so that a reduced tree of a few joints pays
/// nothing for it): `sin_cos` of the first `4 ⌊n/4⌋` angles, whose count it returns.
///
/// # Safety
/// The CPU must have AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
unsafe fn sin_cos_angles4(ang: &[(u32, f32)], scs: &mut [(f64, f64)], q: &[f64]) -> usize {
    for (a4, sc) in ang.chunks_exact(4).zip(scs.chunks_exact_mut(4)) {
        let mut x = [0.0; 4];
        for (xl, &(qi, sign)) in x.iter_mut().zip(a4) {
            *xl = sign as f64 * q[qi as usize];
        }
        let (s4, c4) = crate::trig::sin_cos4(&x);
        for (l, sc) in sc.iter_mut().enumerate() {
            *sc = (s4[l], c4[l]);
        }
    }
    ang.len() / 4 * 4
}

/// A rigid cluster's spatial inertia about the computation origin by its parts
/// ([`Adaptive::one_joint`]): axes `E` (and `Eᵀ`), central inertia `I_c` in its frame, mass,
/// centre of mass `c` (computation axes, from the origin), `|c|²` and `h = m c` (pass 1's
/// quantities).
struct Parts {
    e: glam::DMat3,
    et: glam::DMat3,
    ic: glam::DMat3,
    m: f64,
    cw: DVec3,
    cc: f64,
    hv: DVec3,
}

impl Parts {
    /// `I [a; b] = [Ī a + h × b; m b − h × a]` with `Ī a = E I_c Eᵀ a + m (|c|² a − c (c·a))`.
    #[inline(always)]
    fn inertia(&self, v: SpatialMotion) -> SpatialForce {
        let a = v.w;
        let ibar =
            self.e * (self.ic * (self.et * a)) + (a * self.cc - self.cw * self.cw.dot(a)) * self.m;
        SpatialForce::new(ibar + self.hv.cross(v.v), v.v * self.m - self.hv.cross(a))
    }
}

/// What pass 2 writes: `Iᴬ`, `pᴬ` (the parents'), `U`, `u` and the Cholesky factors — a
/// workspace that starts at a [`Base`].
struct Art<'a> {
    ia: &'a mut [Mat6],
    pa: &'a mut [[f64; 6]],
    u: &'a mut [[f64; 6]],
    uu: &'a mut [f64],
    chol: &'a mut [[[f64; 6]; 6]],
}

#[cfg(feature = "parallel")]
impl<'a> Art<'a> {
    /// The same workspace, borrowed.
    fn reborrow(&mut self) -> Art<'_> {
        Art {
            ia: self.ia,
            pa: self.pa,
            u: self.u,
            uu: self.uu,
            chol: self.chol,
        }
    }

    /// The workspace (which starts at `from`) before `at` and from `at` on.
    fn split(self, from: Base, at: Base) -> (Art<'a>, Art<'a>) {
        let (r, k) = (at.record - from.record, at.first_dof - from.first_dof);
        let (ia, ia1) = self.ia.split_at_mut(r);
        let (pa, pa1) = self.pa.split_at_mut(r);
        let (chol, chol1) = self.chol.split_at_mut(r);
        let (u, u1) = self.u.split_at_mut(k);
        let (uu, uu1) = self.uu.split_at_mut(k);
        (
            Art {
                ia,
                pa,
                u,
                uu,
                chol,
            },
            Art {
                ia: ia1,
                pa: pa1,
                u: u1,
                uu: uu1,
                chol: chol1,
            },
        )
    }
}

articula_spatial::fma_dispatch! {
    /// [`articulate_through_factor`] out of line (the one-degree-of-freedom path of the passes keeps
    /// its registers), compiled for AVX2 + FMA when `wide` (the same arithmetic: no fused
    /// multiply–adds, the same results to the bit).
    #[inline(never)]
    fn articulate<const K: usize>(wide: bool, at: &[usize; 4], w: &mut Art, inputs: (&[SpatialMotion], &[f64], &[f64]), k: usize, c: &[f64; 6]) -> bool;
    avx2_fma: wide, Portable;
    |A| articulate_through_factor::<K>(at, w, inputs, k, c)
}

/// Pass 2 of the reduced ABA for a joint of several degrees of freedom, at
/// `[record, parent record, first slot in U/u]` of the workspace `h` (the parent
/// [`NO_PARENT`] for none) and its first velocity coordinate: `U = Iᴬ S`, `D = Sᵀ U = L Lᵀ`,
/// `u = τ − Sᵀ pᴬ`, and the parent's `Iᵃ`, `pᵃ`; `inputs`: the subspace columns, `τ` and the
/// armature added to `D`'s diagonal (empty: none). `K`: the degrees of freedom when known at
/// compile time (loops unrolled; the same sums), 0: `k`. False when `D` is not positive
/// definite.
///
/// Not `articula_dca::internals::articulate_multi`'s computation: that one inverts `D` and
/// forms `U D⁻¹ Uᵀ`; this one keeps the factor `L` (pass 3 solves with it) and works through
/// `Y = U L⁻ᵀ`, `z = L⁻¹ u`: `Iᵃ = Iᴬ − Y Yᵀ`, `pᵃ = pᴬ + Iᵃ c + Y z`.
#[inline(always)]
fn articulate_through_factor<const K: usize>(
    &[idx, parent, dof, vo]: &[usize; 4],
    h: &mut Art,
    (s, tau, armature): (&[SpatialMotion], &[f64], &[f64]),
    k: usize,
    c: &[f64; 6],
) -> bool {
    let k = if K == 0 { k } else { K };
    let pa = h.pa[idx];
    let (lo, hi) = h.ia.split_at_mut(idx);
    let ia = &hi[0];
    let mut dm = [[0.0; 6]; 6];
    for p in 0..k {
        let u = ia.sym_mul_vec(&s[vo + p].to_array());
        h.u[dof + p] = u;
        for qq in 0..=p {
            let x = dot6_pairs::<Portable>(&s[vo + qq].to_array(), &u);
            dm[p][qq] = x;
            dm[qq][p] = x;
        }
        h.uu[dof + p] = tau[vo + p] - dot6_pairs::<Portable>(&s[vo + p].to_array(), &pa);
    }
    if let Some(a) = armature.get(vo..vo + k) {
        for p in 0..k {
            dm[p][p] += a[p];
        }
    }
    // D = L Lᵀ. With Y = U L⁻ᵀ (columns y_p) and z = L⁻¹ u: U D⁻¹ Uᵀ = Y Yᵀ and
    // U D⁻¹ u = Y z.
    // `1 / L_pp` as the factorisation forms it, reused by the substitutions below instead of
    // dividing again (the same numbers). The factor goes straight into `chol` (the lower
    // triangle of the leading k × k block: all that passes 2 and 3 read).
    let mut invs = [0.0; 6];
    // The joint's own block, tested as DCA, ABA and CRBA test theirs (a gimbal lock).
    if !joint_block_regular(&dm, k) || !cholesky_into(&dm, k, &mut h.chol[idx], &mut invs) {
        return false;
    }
    if parent == NO_PARENT {
        return true;
    }
    let l = &h.chol[idx];
    let mut y = [[0.0; 6]; 6];
    let mut z = [0.0; 6];
    for p in 0..k {
        let mut yp = h.u[dof + p];
        let mut zp = h.uu[dof + p];
        for qq in 0..p {
            let lpq = l[p][qq];
            zp -= lpq * z[qq];
            for rr in 0..6 {
                yp[rr] -= lpq * y[qq][rr];
            }
        }
        let inv = invs[p];
        z[p] = zp * inv;
        for rr in 0..6 {
            yp[rr] *= inv;
        }
        y[p] = yp;
    }
    // Iᵃ = Iᴬ − Y Yᵀ, pᵃ = pᴬ + Iᵃ c + Y z (Iᵃ c = Iᴬ c − Y (Yᵀ c)).
    let target = &mut lo[parent];
    let mut add = ia.sym_mul_vec(c);
    for p in 0..k {
        let g = z[p] - dot6_pairs::<Portable>(&y[p], c);
        for rr in 0..6 {
            add[rr] += y[p][rr] * g;
        }
    }
    let pp = &mut h.pa[parent];
    for rr in 0..6 {
        pp[rr] += pa[rr] + add[rr];
    }
    // Whole rows: entry (c, r) has the same sums as (r, c) (Iᴬ symmetric, the products
    // commute), so the result stays symmetric to the bit.
    for rr in 0..6 {
        let mut x: [f64; 6] = std::array::from_fn(|cc| target.0[rr][cc] + ia.0[rr][cc]);
        for p in 0..k {
            for cc in 0..6 {
                x[cc] -= y[p][rr] * y[p][cc];
            }
        }
        target.0[rr] = x;
    }
    true
}

/// What pass 3 of a several-degree-of-freedom joint reads and writes: the records' Cholesky
/// factors, `U`, `u` and `q̈` — a workspace that starts at a [`Base`] — and the subspace
/// columns (whole, read by velocity coordinate).
struct Accel<'a> {
    chol: &'a [[[f64; 6]; 6]],
    u: &'a [[f64; 6]],
    uu: &'a [f64],
    s: &'a [SpatialMotion],
    qdd: &'a mut [f64],
}

articula_spatial::fma_dispatch! {
    /// [`accelerate_through_factor`] out of line, compiled for AVX2 + FMA when `wide` (the same
    /// arithmetic).
    #[inline(never)]
    fn accelerate<const K: usize>(wide: bool, at: &[usize; 4], w: &mut Accel, k: usize, ap: &[f64; 6]) -> [f64; 6];
    avx2_fma: wide, Portable;
    |A| accelerate_through_factor::<K>(at, w, k, ap)
}

/// Pass 3 of the reduced ABA for a joint of several degrees of freedom, at `[record, first
/// slot in U/u, first velocity coordinate, its slot in q̈]` of the workspace `w`, from
/// `a' = a_parent + c`: `q̈ = L⁻ᵀ L⁻¹ (u − Uᵀ a')`, returns `a = a' + S q̈`. `K` as in
/// [`articulate`].
#[inline(always)]
fn accelerate_through_factor<const K: usize>(
    &[idx, dof, vo, vq]: &[usize; 4],
    w: &mut Accel,
    k: usize,
    ap: &[f64; 6],
) -> [f64; 6] {
    let (l, u, uu, s) = (&w.chol[idx], w.u, w.uu, w.s);
    let (qdd, ap) = (&mut *w.qdd, *ap);
    let k = if K == 0 { k } else { K };
    // q̈ = L⁻ᵀ L⁻¹ r.
    let mut x = [0.0; 6];
    for p in 0..k {
        let mut v = uu[dof + p] - dot6_pairs::<Portable>(&ap, &u[dof + p]);
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
        qdd[vq + p] = x[p];
        let s = s[vo + p].to_array();
        for rr in 0..6 {
            a[rr] += s[rr] * x[p];
        }
    }
    a
}

articula_spatial::fma_dispatch! {
    /// [`revolute_kinematics`], compiled for AVX2 + FMA when `wide` (the same arithmetic).
    #[inline(never)]
    fn revolute(wide: bool, body: &articula_model::Body, parts: &RevoluteParts, x0: &SpatialTransform, v0: &SpatialMotion, sc: &[(f64, f64)], qd: &[f64], s: Columns, out: KinOut);
    avx2_fma: wide, Portable;
    |A| revolute_kinematics_with(body, parts, x0, v0, sc, qd, s, out)
}

/// [`articula_dca::body_kinematics`] for a joint of [`RevoluteParts`]: the rotation by `q`
/// touches two columns of the pose and an identity part origin costs nothing. (Called out of
/// line, beside the closed-form one-axis path of `active_kinematics`.)
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn revolute_kinematics_with(
    body: &articula_model::Body,
    parts: &RevoluteParts,
    x0: &SpatialTransform,
    v0: &SpatialMotion,
    sc: &[(f64, f64)],
    qd: &[f64],
    (s, s0): Columns,
    out: KinOut,
) {
    let (mut x, mut v) = (*x0, *v0);
    let mut c = SpatialMotion::ZERO;
    // The body's origin in the computation frame, `p = −E r`: a part's rotation leaves it
    // (`E R Rᵀ r = E r`), a part's origin moves it.
    // (Formed before the first part only when that part's origin is the identity.) An origin
    // that only translates (`shift`) composes as `(E, r₀ + r)`: the full product's `E · 1` and
    // `1ᵀ r` are the same numbers but for the sign of an exact zero.
    let mut p = DVec3::ZERO;
    for ((k, part), &(sn, cs)) in body.joint.iter().enumerate().zip(sc) {
        let bit = 1 << k;
        if parts.moved & bit != 0 {
            if parts.shift & bit != 0 {
                x.r = part.origin.r + x.r;
            } else {
                x = x * part.origin;
            }
        }
        if k == 0 || parts.moved & bit != 0 {
            p = -(x.e * x.r);
        }
        let (i, sign) = parts.axis(k);
        let axis = turn(&mut x, i, sn, cs);
        // S = X [±e_i; 0] = [w; p × w], `w = ±` column i of E.
        let w = axis * sign;
        let sk = SpatialMotion::new(w, p.cross(w));
        s[part.v_offset - s0] = sk;
        let vj = sk * qd[part.v_offset];
        c += v.cross_motion(vj);
        v += vj;
    }
    *out.0 = x;
    *out.1 = v;
    *out.2 = c;
}

articula_spatial::fma_dispatch! {
    /// [`floating_kinematics`], compiled for AVX2 + FMA when `wide` (the same arithmetic).
    #[inline(never)]
    fn floating(wide: bool, part: &articula_model::JointPart, x0: &SpatialTransform, v0: &SpatialMotion, q: &[f64], qd: &[f64], s: Columns, out: KinOut);
    avx2_fma: wide, Portable;
    |A| floating_kinematics_with(part, x0, v0, q, qd, s, out)
}

/// [`articula_dca::body_kinematics`] for a joint of one floating part (a floating base):
/// the pose by the same products; the subspace columns `X [e_k; 0]`, `X [0; e_k]` written
/// out — `[E e_k; E (−r × e_k)]` and `[0; E e_k]`, the columns of `E` and two-term sums of
/// them (`apply_motion`'s products by the unit vector's zeros and ones add only zeros, and
/// the sums keep their order) — and `v_J = Σ S_k q̇_k` in the general path's order (its
/// zero terms dropped). The same numbers but for the sign of an exact zero.
#[inline(always)]
fn floating_kinematics_with(
    part: &articula_model::JointPart,
    x0: &SpatialTransform,
    v0: &SpatialMotion,
    q: &[f64],
    qd: &[f64],
    (s, s0): Columns,
    out: KinOut,
) {
    let mut x = *x0;
    let o = &part.origin;
    if o.e != glam::DMat3::IDENTITY || o.r != DVec3::ZERO {
        x = x * part.origin;
    }
    x = x * part.motion_transform(&q[part.q_offset..part.q_offset + 7]);
    let (e, r) = (&x.e, x.r);
    // −r × e_k: (0, −r_z, r_y), (r_z, 0, −r_x), (−r_y, r_x, 0).
    let w = [e.x_axis, e.y_axis, e.z_axis];
    let lin = [
        e.y_axis * -r.z + e.z_axis * r.y,
        e.x_axis * r.z + e.z_axis * -r.x,
        e.x_axis * -r.y + e.y_axis * r.x,
    ];
    let vo = part.v_offset;
    let (qd, s) = (&qd[vo..vo + 6], &mut s[vo - s0..vo - s0 + 6]);
    for k in 0..3 {
        s[k] = SpatialMotion::new(w[k], lin[k]);
        s[3 + k] = SpatialMotion::new(DVec3::ZERO, w[k]);
    }
    let vw = (w[0] * qd[0] + w[1] * qd[1]) + w[2] * qd[2];
    let vv = ((((lin[0] * qd[0] + lin[1] * qd[1]) + lin[2] * qd[2]) + w[0] * qd[3]) + w[1] * qd[4])
        + w[2] * qd[5];
    let vj = SpatialMotion::new(vw, vv);
    let mut c = SpatialMotion::ZERO;
    c += v0.cross_motion(vj);
    *out.0 = x;
    *out.1 = *v0 + vj;
    *out.2 = c;
}

/// Where a joint's subspace columns go: the columns from velocity coordinate `s0` on.
type Columns<'a> = (&'a mut [SpatialMotion], usize);

/// Where a joint's kinematics go: the body's pose, velocity and velocity product.
type KinOut<'a> = (
    &'a mut SpatialTransform,
    &'a mut SpatialMotion,
    &'a mut SpatialMotion,
);

/// `E ← E R(q)`, `r ← R(q)ᵀ r` for the rotation by `q` (`sin`, `cos` given) about coordinate
/// axis `i`: columns / components `(i+1, i+2)` turn by the angle; column `i` (the axis, which
/// it returns) stays.
#[inline(always)]
fn turn(x: &mut SpatialTransform, i: usize, sn: f64, cs: f64) -> DVec3 {
    let (e, r) = (&mut x.e, &mut x.r);
    match i {
        0 => {
            (e.y_axis, e.z_axis) = (e.y_axis * cs + e.z_axis * sn, e.z_axis * cs - e.y_axis * sn);
            (r.y, r.z) = (cs * r.y + sn * r.z, cs * r.z - sn * r.y);
            e.x_axis
        }
        1 => {
            (e.z_axis, e.x_axis) = (e.z_axis * cs + e.x_axis * sn, e.x_axis * cs - e.z_axis * sn);
            (r.z, r.x) = (cs * r.z + sn * r.x, cs * r.x - sn * r.z);
            e.y_axis
        }
        _ => {
            (e.x_axis, e.y_axis) = (e.x_axis * cs + e.y_axis * sn, e.y_axis * cs - e.x_axis * sn);
            (r.x, r.y) = (cs * r.x + sn * r.y, cs * r.y - sn * r.x);
            e.z_axis
        }
    }
}

/// A 3-vector as four lanes, the last zero.
#[inline(always)]
fn lanes3(v: DVec3) -> [f64; 4] {
    [v.x, v.y, v.z, 0.0]
}

/// `s += a − α u uᵀ` on symmetric 6 × 6 matrices, row by row: entry `(i, j)` is
/// `s_ij + (a_ij − α (u_i u_j))` (`u_i u_j = u_j u_i` to the bit, so the result stays
/// symmetric to the bit; a product, a multiply–add and an addition per lane, no shuffles, and
/// from `α` to the result a multiply–add and an addition).
#[inline(always)]
fn add_sub_outer<A: Arith>(s: &mut Mat6, a: &Mat6, u: &[f64; 6], alpha: f64) {
    for ((srow, arow), &ui) in s.0.iter_mut().zip(&a.0).zip(u) {
        let (lo, hi) = srow.split_at_mut(4);
        for j in 0..4 {
            lo[j] += A::neg_mul_add(alpha, ui * u[j], arow[j]);
        }
        for j in 0..2 {
            hi[j] += A::neg_mul_add(alpha, ui * u[j + 4], arow[j + 4]);
        }
    }
}

/// The error of a joint whose `Sᵀ Iᴬ S` is not positive definite.
fn singular(model: &Model, j: usize) -> DynamicsError {
    DynamicsError::Singular {
        joint: model.bodies[j].joint_name(),
        detail: "Sᵀ Iᴬ S of the hybrid body is not positive definite, or a pivot of a joint's \
                 own block is at most 1e-13 of its diagonal (its axes dependent: a gimbal lock)",
    }
}

#[cfg(all(test, feature = "parallel"))]
mod tests {
    use crate::{Adaptive, Settings};
    use articula_dca::State;
    use articula_model::{LoadOptions, Model};

    /// The subtrees found with every joint of `model` active: `(first record, records)`.
    fn subtrees(model: &Model) -> Vec<(usize, usize)> {
        let settings = Settings {
            budget: Some(model.nv),
            reselect_every: 4,
            ..Settings::default()
        };
        let mut ad = Adaptive::new(model, settings);
        let mut s = State::random(model, 3, 0.5);
        for _ in 0..2 {
            ad.step(model, &mut s, 1e-3).unwrap();
        }
        assert!(ad.hier.valid);
        assert_eq!(ad.hier.dofs, model.nv);
        ad.hier
            .split
            .tasks
            .iter()
            .map(|t| (t.start, t.stop - t.start))
            .collect()
    }

    fn branches(lengths: &[usize]) -> Model {
        let urdf = articula_testkit::branches_urdf(lengths);
        Model::from_urdf_str(&urdf, &LoadOptions::default()).unwrap()
    }

    #[test]
    fn subtrees_are_the_branches_or_the_lower_part_of_a_long_one() {
        // The head's record first, then each branch's run of records.
        let split = subtrees(&branches(&[3_000; 4]));
        assert_eq!(
            split,
            [(1, 3_000), (3_001, 3_000), (6_001, 3_000), (9_001, 3_000)]
        );
        // 11 801 records, at most 5 900 a subtree: the long branch's last 5 900 records.
        let split = subtrees(&branches(&[8_000, 1_500, 1_200, 1_100]));
        assert_eq!(
            split,
            [
                (2_101, 5_900),
                (8_001, 1_500),
                (9_501, 1_200),
                (10_701, 1_100)
            ]
        );
        // Short branches stay in the serial part.
        let split = subtrees(&branches(&[10_000, 1_000, 1_000]));
        assert_eq!(split, []);
    }

    #[test]
    fn a_chain_has_no_subtrees() {
        assert_eq!(subtrees(&articula_testkit::chain(12_000)), []);
    }
}
