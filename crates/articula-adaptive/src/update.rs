//! Re-selection in O(active region) through the caches of the rigid subassemblies
//! (docs/design.md#adaptive; `cache.rs` holds the tensors).
//!
//! 1. Kinematics of the active joints (hierarchical state).
//! 2. Each frontier node's articulated `Φ`, `b`, `Ψ`, `p`, `η` evaluated from its cache at its
//!    current pose and velocity (a leaf: its rigid coefficients).
//! 3. Main pass and metric pass over the active region only.
//! 4. Top-down selection from the root; popping a rigid node evaluates its `K`, `N`, `k`, `n`
//!    and its children's `Ψ`, `p`, `η` from their caches (frames carried down by the cached
//!    relative poses).
//! 5. Caches rebuilt for the nodes that leave the active region (their subtrees moved),
//!    bottom-up from their children's caches.
//! 6. The new hierarchical state and the locking impulse over the new reduced tree, with each
//!    new cluster's momentum from the old clusters' (or its cache when it was rigid).

use crate::adaptive::Adaptive;
use crate::cache::{rot6, rows3, Part};
use crate::hybrid::Level;
use crate::parts::composites::Rigid;
use crate::parts::hierarchy::NO_PARENT;
use crate::parts::selection_queue::Selection;
use articula_dca::{DynamicsError, State};
use articula_model::{Model, NodeKind};
use articula_spatial::{SpatialForce, SpatialInertia, SpatialMotion, SpatialTransform};
use glam::DVec3;

impl Adaptive {
    /// Whether this re-selection can go through the caches: caches built for the current
    /// hybrid body, no velocity tolerance (it reads every joint's velocity), the locked joints'
    /// torques unchanged (they are in the caches' constant columns: an O(n) comparison of τ,
    /// bitwise by `memcmp` (`same_bits`), much cheaper than `==` on `f64`s when nothing
    /// changed).
    pub(crate) fn can_reselect_cached(&mut self, model: &Model, state: &State) -> bool {
        if !(self.switches.use_cache
            && self.cache.all_valid
            && self.hier.valid
            && !self.switches.full_passes
            && self.settings.velocity_tolerance.is_none()
            && state.tau.len() == model.nv)
        {
            return false;
        }
        if self.cache.check_torques && !same_bits(&state.tau, &self.cache.torques) {
            for (j, body) in model.bodies.iter().enumerate() {
                let r = body.v_offset..body.v_offset + body.nv;
                if !self.hier.abody[j] && state.tau[r.clone()] != self.cache.torques[r] {
                    self.cache.all_valid = false;
                    return false;
                }
            }
            self.cache.torques.copy_from_slice(&state.tau);
        }
        true
    }

    /// The re-selection through the caches (see the module doc). Returns whether joints were
    /// locked. `qdd` holds the selected joints' accelerations, zero for joints that left.
    pub(crate) fn cached_reselect(
        &mut self,
        model: &Model,
        state: &mut State,
    ) -> Result<bool, DynamicsError> {
        // Also compiled for AVX2 + FMA (the same bits, wider vectors), run when `fused`.
        articula_spatial::fma_dispatch! {
            fn run(this: &mut Adaptive, model: &Model, state: &mut State) -> Result<bool, DynamicsError>;
            avx2_fma: this.switches.fused, Portable;
            |A| this.cached_reselect_with(model, state)
        }
        run(self, model, state)
    }

    #[inline(always)]
    fn cached_reselect_with(
        &mut self,
        model: &Model,
        state: &mut State,
    ) -> Result<bool, DynamicsError> {
        let tree = &model.assembly;
        self.check_active_inputs(model, state)?;
        self.cache.reselection.epoch += 1;
        let ep = self.cache.reselection.epoch;
        self.data.origin = articula_dca::computation_origin(model, &state.q);
        self.active_kinematics(model, &state.q, &state.qd);
        for idx in 0..self.hier.ajoints.len() {
            let j = self.hier.ajoints[idx];
            self.coef.point[j] = self.data.x[j].apply_point(DVec3::ZERO);
        }
        let mut touched = 0;
        // External forces: on a frontier leaf they enter its rigid coefficients; on a body
        // inside a cached cluster they make its path up to the cluster dirty.
        for idx in 0..self.hier.fnodes.len() {
            let f = self.hier.fnodes[idx];
            self.forces.node_sums[f] = SpatialForce::ZERO;
        }
        touched += self.dirty_paths(model, ep);
        // 2. The frontier from the caches.
        for idx in 0..self.hier.fnodes.len() {
            let f = self.hier.fnodes[idx];
            touched += 1;
            self.cache.reselection.slots_stamp[f] = ep;
            match tree.nodes[f].kind {
                NodeKind::Gather { .. } | NodeKind::Cluster { .. } => {
                    unreachable!("adaptive refuses models with gather nodes (`load_state`); `Model::assembly` has no leaf clusters")
                }
                NodeKind::Ground => self.ground_coefficients(f),
                NodeKind::Body(i) => {
                    let x = self.data.x[i];
                    let r = self.cache.tensors.composite[f];
                    let world = Rigid {
                        mass: r.mass,
                        com: x.apply_point(r.com),
                        inertia: x.e * r.inertia * x.e.transpose(),
                    };
                    self.cache.reselection.frame_pose[f] = x;
                    self.cache.reselection.frame_velocity[f] = x.inv_apply_motion(self.data.v[i]);
                    let (v, fe) = (self.data.v[i], self.forces.node_sums[f]);
                    self.rigid_coefficients(model, f, &world, v, fe, Level::Acceleration)?;
                }
                NodeKind::Join { .. } => {
                    let x = self.cache_frame(f);
                    let u = if self.composites.grounded[f] {
                        SpatialMotion::ZERO
                    } else {
                        x.inv_apply_motion(self.data.v[self.composites.top_body[f]])
                    };
                    self.cache.reselection.frame_pose[f] = x;
                    self.cache.reselection.frame_velocity[f] = u;
                    self.eval_cache(model, f, &x, u, Part::Coefficients);
                    if self.cache.dirty.dirty_stamp[f] == ep {
                        // Plus what the forces on its dirty paths add.
                        let (hc, r) = (self.coef.layout.hoff[f], rows3(&x.e));
                        for h in 0..self.coef.handles[f] {
                            let db = rot6(&r, &self.cache.dirty.delta_b[hc + h]);
                            self.coef.bias[hc + h] += SpatialMotion::from_array(db);
                        }
                    }
                }
            }
        }
        // 3. The main pass over the active region (post-order).
        for idx in 0..self.hier.hnodes.len() {
            let n = self.hier.hnodes[idx];
            self.join(model, n, &state.tau, Level::Acceleration)?;
            self.cache.reselection.slots_stamp[n] = ep;
            touched += 1;
        }
        // The metric of every active and frontier node at its exact handle forces: one
        // back-substitution through the active region, each frontier node's quadratic form
        // at its handle forces (in its cache frame), then `A(n) = q̈ᵀ A q̈ + A(a) + A(b)`
        // bottom-up (what the metric pass's Ψ, p, η give at those forces; docs/design.md#adaptive).
        self.active_metrics(model, ep);
        // 4. Selection.
        self.last = self.select_cached(model, ep, &mut touched);
        // 5. Caches of the nodes leaving the active region, bottom-up.
        touched += self.build_leaving_caches(model, state)?;
        for idx in 0..self.cache.reselection.selected.len() {
            let n = self.cache.reselection.selected[idx];
            self.cache.tensors.node_valid[n] = false;
        }
        // 6. Old clusters' momenta (before the flags change), the new hierarchy, the impulse.
        let mut moving = false;
        for &j in &self.hier.ajoints {
            let body = &model.bodies[j];
            if !self.queue.selected[tree.joint_node[j]]
                && state.qd[body.v_offset..body.v_offset + body.nv]
                    .iter()
                    .any(|x| *x != 0.0)
            {
                moving = true;
            }
        }
        if moving {
            self.cluster_momenta(model);
        }
        let mut leaving = std::mem::take(&mut self.cache.reselection.leaving);
        leaving.clear();
        for &j in &self.hier.ajoints {
            if !self.queue.selected[tree.joint_node[j]] {
                leaving.push(j);
            }
        }
        let same = self.hier.valid
            && self.hier.from_cache
            && self.cache.reselection.selected == self.hier.hnodes;
        self.rebuild_hierarchy_cached(model);
        // Same active joints and no impulse: their kinematics in `data` are this step's.
        self.hier.kin_fresh = same && !moving;
        if moving {
            self.active_kinematics(model, &state.q, &state.qd);
            let mut gm = std::mem::take(&mut self.impulse.momenta);
            self.reduced_momenta(&mut gm);
            crate::rigidify::add_armature_momenta(model, &self.hier.ajoints, &state.qd, &mut gm);
            let r = self.reduced_aba(model, &gm, Level::Impulse);
            self.impulse.momenta = gm;
            r?;
            for &j in &self.hier.ajoints {
                let b = &model.bodies[j];
                let r = b.v_offset..b.v_offset + b.nv;
                state.qd[r.clone()].copy_from_slice(&self.body.qdd[r]);
            }
        }
        for &j in &leaving {
            let b = &model.bodies[j];
            state.qd[b.v_offset..b.v_offset + b.nv].fill(0.0);
            self.body.qdd[b.v_offset..b.v_offset + b.nv].fill(0.0);
        }
        self.cache.reselection.leaving = leaving;
        self.fresh.valid = false;
        self.touched = touched;
        Ok(moving)
    }

    /// Step 5 of [`Adaptive::cached_reselect`]: the caches of the old active region's nodes
    /// that leave it, bottom-up, with the torques their joints will have once locked
    /// ([`Adaptive::take_locked_torques`]: no damping force at `q̇ = 0`), which go into
    /// `cache.torques` for the next re-selection's comparison. Returns the nodes built.
    fn build_leaving_caches(
        &mut self,
        model: &Model,
        state: &State,
    ) -> Result<usize, DynamicsError> {
        let locked = self.take_locked_torques();
        let tau = if locked.is_empty() {
            &state.tau
        } else {
            &locked
        };
        let (mut built, mut count) = (Ok(()), 0);
        for idx in 0..self.hier.hnodes.len() {
            let n = self.hier.hnodes[idx];
            if self.queue.selected[n] {
                continue;
            }
            built = self.build_cache(model, n, &state.q, tau);
            if built.is_err() {
                break;
            }
            count += 1;
            if let (false, NodeKind::Join { joint, .. }) =
                (locked.is_empty(), model.assembly.nodes[n].kind)
            {
                let b = &model.bodies[joint];
                let r = b.v_offset..b.v_offset + b.nv;
                self.cache.torques[r.clone()].copy_from_slice(&locked[r]);
            }
        }
        if !locked.is_empty() {
            self.passive.locked = locked;
        }
        built.map(|()| count)
    }

    /// External forces on rigid parts (O(depth) per force): every node on the path from a
    /// forced body's leaf up to its cluster (old frontier node) is dirty. Its configuration
    /// and velocity are still its cache's, so only what the forces add is computed.
    /// Top-down, each dirty node gets its frame and velocity (the cluster's from its top
    /// body, the others' from their parent's by the cached relative pose), its children
    /// theirs, and its joint's point (its child body's origin: a leaf's handle); bottom-up,
    /// `Δb` of the forced leaves ([`Adaptive::leaf_delta`]) and `Δb`, `Δk`, `Δn`, `Δp`, `Δη`
    /// of the dirty joins ([`Adaptive::dirty_delta`]). The frontier adds `Δb` to its cached
    /// bias, a popped dirty node `Δk`, `Δn` to its cached maps, a dirty node's metric
    /// `Fᵀ Δp + Δη` to its cached quadratic form. A node with one forced leaf below it whose
    /// path was dirty at the previous re-selection too takes all of these from the path's
    /// linear maps of the leaf's wrench ([`Adaptive::join_map`], built once, reused while the
    /// caches below it stay): evaluated at the top of the mapped part, and inside it only
    /// when the selection reads a node. Returns the nodes marked.
    fn dirty_paths(&mut self, model: &Model, ep: u64) -> usize {
        let tree = &model.assembly;
        self.cache.dirty.nodes.clear();
        if !self.forces.sparse.is_empty() && !self.cache.without_maps {
            // The maps' storage, at the first re-selection with external forces.
            self.map_alloc(model);
        }
        self.mark_forced_paths(model, ep);
        if self.cache.dirty.nodes.is_empty() {
            return 0;
        }
        // Post-order: children before parents.
        self.cache.dirty.nodes.sort_unstable();
        // A node with one forced leaf below it takes its deltas from its path's map when its
        // record holds (`dirty.map_valid`; valid while the caches below it stay), built on the
        // second sighting; which maps must be built, bottom-up.
        let mut build = false;
        if !self.cache.without_maps {
            for idx in 0..self.cache.dirty.nodes.len() {
                let d = self.cache.dirty.nodes[idx];
                let ok = self.cache.dirty.forced_leaves[d] == 1 && self.map_holds(model, d);
                if self.cache.dirty.forced_leaves[d] == 1 && !ok {
                    self.map_record(d);
                }
                build |= ok && !self.cache.maps.built[d];
                self.cache.dirty.map_valid[d] = ok;
            }
        }
        // A mapped node is the top of its part of the path when its parent is not dirty (the
        // cluster) or not mapped (`dirty_delta` reads its deltas).
        let top = |ad: &Adaptive, d: usize| {
            tree.nodes[d]
                .parent
                .is_none_or(|p| ad.cache.dirty.dirty_stamp[p] != ep || !ad.cache.dirty.map_valid[p])
        };
        // Top-down (parents first): frames, velocities and joint points of the nodes a map
        // build or `dirty_delta` reads; with every map built, only of the nodes without a map
        // and of the tops (the selection sets the others' if it gets there).
        for idx in (0..self.cache.dirty.nodes.len()).rev() {
            let d = self.cache.dirty.nodes[idx];
            let mapped = !self.cache.without_maps && self.cache.dirty.map_valid[d];
            if !build && mapped && !top(self, d) {
                continue;
            }
            let parent_dirty = tree.nodes[d]
                .parent
                .is_some_and(|p| self.cache.dirty.dirty_stamp[p] == ep);
            if !parent_dirty {
                // The cluster: its frame from its top body.
                let x = self.cache_frame(d);
                self.cache.reselection.frame_pose[d] = x;
                self.cache.reselection.frame_velocity[d] = if self.composites.grounded[d] {
                    SpatialMotion::ZERO
                } else {
                    x.inv_apply_motion(self.data.v[self.composites.top_body[d]])
                };
            }
            self.cache.reselection.slots_stamp[d] = ep;
            if !build && mapped {
                continue;
            }
            let NodeKind::Join {
                joint,
                parent_side: a,
                child_side: b,
            } = tree.nodes[d].kind
            else {
                continue;
            };
            let (xd, ud) = (
                self.cache.reselection.frame_pose[d],
                self.cache.reselection.frame_velocity[d],
            );
            for ch in [a, b] {
                // The children's velocities; their frames when they are dirty or leaves, and
                // B's (its origin is the joint's point; a clean join's frame is set by the
                // selection if it gets there).
                let rel = self.cache.tensors.parent_pose[ch];
                self.cache.reselection.frame_velocity[ch] = rel.inv_apply_motion(ud);
                if ch == b
                    || self.cache.dirty.dirty_stamp[ch] == ep
                    || !matches!(tree.nodes[ch].kind, NodeKind::Join { .. })
                {
                    self.cache.reselection.frame_pose[ch] = xd * rel;
                    self.cache.reselection.slots_stamp[ch] = ep;
                }
            }
            // The joint's point (its child body's origin, B's top body: a leaf's handle).
            self.coef.point[joint] = self.cache.reselection.frame_pose[b].apply_point(DVec3::ZERO);
        }
        // Bottom-up: what the forces add, from the forced leaves up — maps (re)built where
        // invalid and evaluated at the tops, the nodes with several leaves by `dirty_delta`.
        for idx in 0..self.cache.dirty.nodes.len() {
            let d = self.cache.dirty.nodes[idx];
            if !self.cache.without_maps && self.cache.dirty.map_valid[d] {
                if !self.cache.maps.built[d] {
                    match tree.nodes[d].kind {
                        NodeKind::Join { .. } => self.join_map(model, d),
                        _ => self.leaf_map(model, d),
                    }
                }
                if top(self, d) {
                    self.eval_map(model, d);
                }
                continue;
            }
            match tree.nodes[d].kind {
                NodeKind::Gather { .. } | NodeKind::Cluster { .. } => {
                    unreachable!("adaptive refuses models with gather nodes (`load_state`); `Model::assembly` has no leaf clusters")
                }
                NodeKind::Ground => {}
                NodeKind::Body(_) => self.leaf_delta(model, d, self.forces.node_sums[d]),
                NodeKind::Join { .. } => self.dirty_delta(model, d),
            }
            self.cache.dirty.delta_stamp[d] = ep;
        }
        self.cache.dirty.nodes.len()
    }

    /// The first stage of [`Adaptive::dirty_paths`]: each external force summed into its
    /// leaf (a frontier leaf's own rigid coefficients take it), and the path from each forced
    /// leaf up to its cluster marked dirty (stamped `ep`, listed in `dirty.nodes`), with the
    /// number of forced leaves below each node (2: several) and the one leaf when there is one.
    fn mark_forced_paths(&mut self, model: &Model, ep: u64) {
        let tree = &model.assembly;
        let x_cw = SpatialTransform::xlt(self.data.origin);
        for k in 0..self.forces.sparse.len() {
            let (i, fe) = self.forces.sparse[k];
            let leaf = tree.body_leaf[i];
            if tree.nodes[leaf].parent.is_none_or(|p| self.body.active[p]) {
                // A frontier leaf: its own rigid coefficients take the force.
                self.forces.node_sums[leaf] += x_cw.apply_force(fe);
                continue;
            }
            let fresh = self.cache.dirty.dirty_stamp[leaf] != ep;
            if fresh {
                self.forces.node_sums[leaf] = SpatialForce::ZERO;
            }
            self.forces.node_sums[leaf] += x_cw.apply_force(fe);
            if !fresh {
                // Its path is marked (and counted) already.
                continue;
            }
            let mut n = leaf;
            loop {
                if self.cache.dirty.dirty_stamp[n] == ep {
                    // Below it another forced leaf's path: two or more leaves from here up.
                    self.cache.dirty.forced_leaves[n] = 2;
                } else {
                    self.cache.dirty.dirty_stamp[n] = ep;
                    self.cache.dirty.nodes.push(n);
                    self.cache.dirty.forced_leaves[n] = if self.cache.without_maps { 2 } else { 1 };
                    self.cache.dirty.forced_leaf[n] = leaf;
                }
                match tree.nodes[n].parent.filter(|&p| !self.body.active[p]) {
                    Some(p) => n = p,
                    None => break,
                }
            }
        }
    }

    /// `A` of every node of the old active region and its frontier at the exact handle forces
    /// (`reselection.exact_metric`, stamped `exact_metric_stamp`): see
    /// [`Adaptive::cached_reselect`].
    fn active_metrics(&mut self, model: &Model, ep: u64) {
        let tree = &model.assembly;
        let root = tree.root();
        let (ho, nh) = (self.coef.layout.hoff[root], self.coef.handles[root]);
        self.coef.force[ho..ho + nh].fill(SpatialForce::ZERO);
        for idx in (0..self.hier.hnodes.len()).rev() {
            let n = self.hier.hnodes[idx];
            self.expand(model, n);
        }
        for idx in 0..self.hier.fnodes.len() {
            let f = self.hier.fnodes[idx];
            self.cache.reselection.exact_metric[f] = match tree.nodes[f].kind {
                NodeKind::Join { .. } => {
                    let (x, u) = (
                        self.cache.reselection.frame_pose[f],
                        self.cache.reselection.frame_velocity[f],
                    );
                    let a = self.metric_local(f, &x, u);
                    if self.cache.dirty.dirty_stamp[f] == ep {
                        a + self.metric_delta(f)
                    } else {
                        a
                    }
                }
                _ => 0.0,
            };
            self.cache.reselection.exact_metric_stamp[f] = ep;
        }
        for idx in 0..self.hier.hnodes.len() {
            let n = self.hier.hnodes[idx];
            let NodeKind::Join {
                joint,
                parent_side: a,
                child_side: b,
            } = tree.nodes[n].kind
            else {
                continue;
            };
            let body = &model.bodies[joint];
            let (vo, k, wo) = (body.v_offset, body.nv, self.metric.weight_at[joint]);
            let own = crate::dense::quad(
                &self.metric.accel_weights[wo..wo + k * k],
                &self.body.qdd[vo..vo + k],
                k,
            );
            self.cache.reselection.exact_metric[n] = own
                + self.cache.reselection.exact_metric[a]
                + self.cache.reselection.exact_metric[b];
            self.cache.reselection.exact_metric_stamp[n] = ep;
        }
    }

    /// The selection of [`Adaptive::select`] over the slots of a cached re-selection: a
    /// popped node outside the old active region gets its `K`, `k`, `N`, `n` from its cache,
    /// its children their frames (`rel`), velocities and metric coefficients.
    fn select_cached(&mut self, model: &Model, ep: u64, touched: &mut usize) -> Selection {
        let tree = &model.assembly;
        for idx in 0..self.cache.reselection.selected.len() {
            let n = self.cache.reselection.selected[idx];
            self.queue.selected[n] = false;
        }
        self.cache.reselection.selected.clear();
        let total = self.cache.reselection.exact_metric[tree.root()];
        let sel = self.run_queue(
            model,
            total,
            |ad, n| {
                ad.cache.reselection.selected.push(n);
                if !ad.body.active[n] {
                    let (x, u) = (
                        ad.cache.reselection.frame_pose[n],
                        ad.cache.reselection.frame_velocity[n],
                    );
                    ad.eval_cache(model, n, &x, u, Part::Maps);
                    if ad.cache.dirty.dirty_stamp[n] == ep {
                        // Plus what the forces on its dirty paths add.
                        ad.ensure_delta(model, n);
                        if let NodeKind::Join { joint, .. } = tree.nodes[n].kind {
                            let body = &model.bodies[joint];
                            let r = body.v_offset..body.v_offset + body.nv;
                            ad.maps.qdd_bias[r.clone()]
                                .iter_mut()
                                .zip(&ad.cache.dirty.delta_k[r])
                                .for_each(|(k, d)| *k += d);
                        }
                        let dn = rot6(&rows3(&x.e), &ad.cache.dirty.delta_n[n]);
                        for (v, d) in ad.maps.force_bias[n].iter_mut().zip(dn) {
                            *v += d;
                        }
                    }
                }
                // The old active region was back-substituted by `active_metrics` (the same
                // forces from the same maps).
                ad.body.active[n]
            },
            |ad, n, c| {
                if !ad.body.active[n] && ad.cache.reselection.slots_stamp[c] != ep {
                    // Below the old frontier: the child's frame and velocity from n's.
                    let rel = ad.cache.tensors.parent_pose[c];
                    ad.cache.reselection.frame_pose[c] = ad.cache.reselection.frame_pose[n] * rel;
                    ad.cache.reselection.frame_velocity[c] =
                        rel.inv_apply_motion(ad.cache.reselection.frame_velocity[n]);
                    ad.cache.reselection.slots_stamp[c] = ep;
                }
                if !matches!(tree.nodes[c].kind, NodeKind::Join { .. }) {
                    return None;
                }
                Some(if ad.cache.reselection.exact_metric_stamp[c] == ep {
                    ad.cache.reselection.exact_metric[c]
                } else if ad.cache.reselection.metric_stamp[c] == ep {
                    ad.metric_at(c)
                } else {
                    *touched += 1;
                    let (x, u) = (
                        ad.cache.reselection.frame_pose[c],
                        ad.cache.reselection.frame_velocity[c],
                    );
                    let a = ad.metric_local(c, &x, u);
                    if ad.cache.dirty.dirty_stamp[c] == ep {
                        ad.ensure_delta(model, c);
                        a + ad.metric_delta(c)
                    } else {
                        a
                    }
                })
            },
        );
        // Post-order for the hierarchy.
        self.cache.reselection.selected.sort_unstable();
        sel
    }

    /// Spatial momentum (computation frame, about its origin) of every old cluster, summed up
    /// the old active region, and of the rigid nodes the selection reached below it (from
    /// their caches at their frames and velocities): `reselection.locking_momentum`.
    fn cluster_momenta(&mut self, model: &Model) {
        let tree = &model.assembly;
        let momentum = |r: &Rigid, x: &SpatialTransform, u: SpatialMotion| {
            let i = SpatialInertia::new(r.mass, r.com, r.inertia);
            x.apply_force(i.mul_motion(u))
        };
        for idx in 0..self.hier.fnodes.len() {
            let f = self.hier.fnodes[idx];
            self.cache.reselection.locking_momentum[f] = if self.composites.grounded[f] {
                SpatialForce::ZERO
            } else {
                momentum(
                    &self.hier.cluster_mass[f],
                    &self.cache.reselection.frame_pose[f],
                    self.cache.reselection.frame_velocity[f],
                )
            };
        }
        for idx in 0..self.hier.hnodes.len() {
            let n = self.hier.hnodes[idx];
            if let NodeKind::Join {
                parent_side: a,
                child_side: b,
                ..
            } = tree.nodes[n].kind
            {
                self.cache.reselection.locking_momentum[n] =
                    self.cache.reselection.locking_momentum[a]
                        + self.cache.reselection.locking_momentum[b];
            }
        }
        for idx in 0..self.cache.reselection.selected.len() {
            let n = self.cache.reselection.selected[idx];
            if self.body.active[n] {
                continue;
            }
            if let NodeKind::Join {
                parent_side: a,
                child_side: b,
                ..
            } = tree.nodes[n].kind
            {
                for c in [a, b] {
                    if !self.queue.selected[c] {
                        self.cache.reselection.locking_momentum[c] = if self.composites.grounded[c]
                        {
                            SpatialForce::ZERO
                        } else {
                            momentum(
                                &self.cache.tensors.composite[c],
                                &self.cache.reselection.frame_pose[c],
                                self.cache.reselection.frame_velocity[c],
                            )
                        };
                    }
                }
            }
        }
    }

    /// Generalized momenta of the new active joints over the new reduced tree:
    /// `p_j = S_jᵀ H_j`, `H_j = h(cluster of j) + Σ_{children j'} H_j'`.
    fn reduced_momenta(&mut self, gm: &mut [f64]) {
        let h = &mut self.hier;
        for idx in 0..h.records.len() {
            h.reduced_aba.pa[idx] =
                self.cache.reselection.locking_momentum[h.records[idx].cluster()].to_array();
        }
        for idx in (0..h.records.len()).rev() {
            let r = &h.records[idx];
            let hj = SpatialForce::from_array(h.reduced_aba.pa[idx]);
            for p in 0..r.dof_count() {
                gm[r.v_offset() + p] = self.data.s[r.v_offset() + p].dot(hj);
            }
            if r.pidx() != NO_PARENT {
                let pp = &mut h.reduced_aba.pa[r.pidx()];
                for (x, y) in pp.iter_mut().zip(hj.to_array()) {
                    *x += y;
                }
            }
        }
    }

    /// The hierarchical state of the newly selected hybrid body
    /// (`cache.reselection.selected`), touching the old and new active regions only: flags,
    /// node and joint lists, clusters' mass properties and the poses of active joints' parent
    /// bodies from the caches.
    fn rebuild_hierarchy_cached(&mut self, model: &Model) {
        let tree = &model.assembly;
        let h = &mut self.hier;
        if h.valid && h.from_cache && self.cache.reselection.selected == h.hnodes {
            // The same hybrid body, whose lists, clusters and poses came from the caches
            // already: nothing changes.
            return;
        }
        for &n in &h.hnodes {
            self.body.active[n] = false;
        }
        for &j in &h.ajoints {
            h.abody[j] = false;
        }
        h.hnodes.clear();
        h.fnodes.clear();
        h.ajoints.clear();
        for &n in &self.cache.reselection.selected {
            self.body.active[n] = true;
            h.hnodes.push(n);
        }
        for &n in &self.cache.reselection.selected {
            if let NodeKind::Join {
                joint,
                parent_side: a,
                child_side: b,
            } = tree.nodes[n].kind
            {
                h.abody[joint] = true;
                h.ajoints.push(joint);
                for c in [a, b] {
                    if !self.body.active[c] {
                        h.fnodes.push(c);
                    }
                }
            }
        }
        if h.hnodes.is_empty() {
            h.fnodes.push(tree.root());
        }
        h.fnodes.sort_unstable();
        h.ajoints.sort_unstable();
        for &f in &h.fnodes {
            if !self.composites.grounded[f] {
                h.cluster_mass[f] = self.cache.tensors.composite[f];
            }
        }
        let cluster = |mut n: usize, active: &[bool]| {
            while let Some(p) = tree.nodes[n].parent.filter(|&q| !active[q]) {
                n = p;
            }
            n
        };
        for idx in 0..h.ajoints.len() {
            let j = h.ajoints[idx];
            h.parent_cluster[j] = usize::MAX;
            h.parent_top[j] = usize::MAX;
            if let Some(p) = model.bodies[j].parent {
                if h.abody[p] {
                    h.parent_top[j] = p;
                } else {
                    let f = cluster(tree.body_leaf[p], &self.body.active);
                    h.parent_cluster[j] = f;
                    h.prel[j] = match tree.nodes[f].kind {
                        NodeKind::Join { .. } => {
                            let k = tree.nodes[f]
                                .handles
                                .iter()
                                .position(|&x| x == j)
                                .expect("an active joint on a cluster is one of its handles");
                            self.cache.tensors.handle_pose[self.coef.layout.hoff[f] + k]
                        }
                        _ => SpatialTransform::IDENTITY,
                    };
                    if !self.composites.grounded[f] {
                        h.parent_top[j] = self.composites.top_body[f];
                    }
                }
            }
            h.own_cluster[j] = cluster(tree.body_leaf[j], &self.body.active);
        }
        self.build_records(model);
        self.hier.valid = true;
        self.hier.from_cache = true;
    }
}

/// Whether two slices hold the same bits: compared as `u64`s, which the standard library's
/// slice equality does by `memcmp` (vectorised; about half the instructions of or-ing the
/// `f64` bit patterns together in blocks of eight).
pub(crate) fn same_bits(a: &[f64], b: &[f64]) -> bool {
    let bits = |x: &[f64]| -> &[u64] {
        // SAFETY: `f64` and `u64` have the same size and alignment, and every bit pattern is a
        // valid `u64`; the view borrows `x` for its lifetime.
        unsafe { std::slice::from_raw_parts(x.as_ptr().cast::<u64>(), x.len()) }
    };
    bits(a) == bits(b)
}

#[cfg(test)]
mod tests {
    use super::same_bits;

    /// `same_bits` is bitwise equality: `0.0` and `-0.0` differ, equal NaN payloads agree,
    /// lengths must match, and a difference anywhere (every position of several lengths) is
    /// found.
    #[test]
    fn same_bits_is_bitwise_equality() {
        assert!(same_bits(&[], &[]));
        assert!(!same_bits(&[1.0], &[1.0, 2.0]));
        assert!(!same_bits(&[0.0], &[-0.0]));
        assert!(same_bits(&[f64::NAN], &[f64::NAN]));
        assert!(!same_bits(&[f64::NAN], &[-f64::NAN]));
        for n in [1, 7, 8, 9, 31, 300] {
            let a: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
            assert!(same_bits(&a, &a.clone()));
            for k in 0..n {
                let mut b = a.clone();
                b[k] = f64::from_bits(b[k].to_bits() ^ 1);
                assert!(!same_bits(&a, &b), "n {n}, k {k}");
            }
        }
    }
}
