//! The caches of rigid subassemblies (docs/design.md#adaptive, docs/adaptive.md): per rigid
//! node its articulated coefficients in its own cache frame, with the velocity-dependent terms
//! as tensors in the 22 monomials of its rigid velocity, and the scratch of a cached
//! re-selection. The passes that build and evaluate them are in `cache.rs`.

use crate::parts::composites::Rigid;
use crate::parts::join_maps::BiasMaps;
use articula_model::{HandleLayout, JointKind, Model, NodeKind};
use articula_spatial::{Mat6, SpatialMotion, SpatialTransform};
use glam::DVec3;

/// Number of monomials: 21 quadratic `u_a u_b` and the constant.
pub(crate) const NW: usize = 22;
/// Index of the constant monomial.
pub(crate) const CONST: usize = 21;

/// A 6 × 6 matrix, row-major `[row][col]`.
pub(crate) use articula_spatial::numerics::M6;

/// Per-node caches (layouts of the workspace's slots, cache-frame axes) and the scratch of the
/// cached re-selection, in named parts.
#[derive(Clone, Debug, Default)]
pub(crate) struct Caches {
    /// Allocated for the model.
    pub allocated: bool,
    /// Every rigid node's cache is valid for the current hybrid body.
    pub all_valid: bool,
    /// Whether the model's handle points are fixed in their rigid nodes (see the module doc).
    pub handles_fixed: bool,
    /// The joint torques the caches were built with.
    pub torques: Vec<f64>,
    /// Whether each re-selection compares `torques` (O(n)) with the state's (see
    /// `Adaptive::set_check_locked_torques`).
    pub check_torques: bool,
    /// Off: every dirty node by `Adaptive::dirty_delta` (the reference for tests).
    pub without_maps: bool,
    /// A clock stamping cache builds (`tensors.built_at`, per node) and map builds
    /// (`maps.built_at`): a map is valid while it is younger than its node's cache and its
    /// dirty child's map.
    pub clock: u64,
    /// Per node: the cached coefficients.
    pub tensors: CacheTensors,
    /// The scratch of a cached re-selection.
    pub reselection: ReselectionScratch,
    /// What external forces add on their dirty paths.
    pub dirty: DirtyDeltas,
    /// Forced paths as linear maps of one leaf's wrench.
    pub maps: LinearMaps,
    /// The scratch of a cache build.
    pub build: BuildScratch,
}

/// Per rigid node, its articulated coefficients in its own cache frame; the velocity-dependent
/// terms as tensors over the `NW` monomials of its rigid velocity. Fields named by a single
/// symbol hold that symbol of docs/adaptive.md#caches.
#[derive(Clone, Debug, Default)]
pub(crate) struct CacheTensors {
    /// Per node: cache valid (its configuration is frozen as cached).
    pub node_valid: Vec<bool>,
    /// Per node: the clock time its cache was built.
    pub built_at: Vec<u64>,
    /// Per node: composite inertia in its cache frame.
    pub composite: Vec<Rigid>,
    /// Per node: its top frame's pose in its parent's cache frame (valid while the parent's
    /// cache is).
    pub parent_pose: Vec<SpatialTransform>,
    /// Per handle: pose of the handle joint's parent body in the node's cache frame (when
    /// that body is in the node).
    pub handle_pose: Vec<SpatialTransform>,
    /// Per handle-pair block of every node: the symbol `Φ` (the node's handle-to-handle
    /// coefficients), cache-frame axes.
    pub phi: Vec<Mat6>,
    /// Per handle: the symbol `B_h` as a tensor `B_w` (6 × NW).
    pub b_w: Vec<f64>,
    /// The symbol `K` of `q̈ = K F + k` (per join node, nv × 6nh), laid out as
    /// `JoinMaps::qdd_gain`.
    pub k: Vec<f64>,
    /// Per degree of freedom: a row of the symbol `K_w` (NW).
    pub k_w: Vec<f64>,
    /// The symbol `N` of `f = N F + n` (per join node, 6 × 6nh), laid out as `JoinMaps`'s.
    pub n: Vec<f64>,
    /// Per node: the symbol `N_w` (6 × NW).
    pub n_w: Vec<f64>,
    /// The symbol `Ψ` of the acceleration metric, laid out as `MetricCoefficients`'s.
    pub psi: Vec<f64>,
    /// Per handle: 6 rows of the symbol `P_w` (NW each).
    pub p_w: Vec<f64>,
    /// Per node: the symbol `E` (NW × NW, symmetric).
    pub e: Vec<f64>,
    /// Per node: the join's bias maps κ, ν (cache-frame axes; a dirty path's join).
    pub bias_maps: Vec<BiasMaps>,
}

/// The scratch of a cached re-selection: per node the pose of its cache frame and its top
/// body's velocity in it (own coordinates), the re-selection that evaluated its slots, the
/// selection and the locking impulses.
#[derive(Clone, Debug, Default)]
pub(crate) struct ReselectionScratch {
    /// Per node: the pose of its cache frame.
    pub frame_pose: Vec<SpatialTransform>,
    /// Per node: its top body's velocity in its cache frame.
    pub frame_velocity: Vec<SpatialMotion>,
    /// Per node: the re-selection that evaluated its slots.
    pub slots_stamp: Vec<u64>,
    /// The current re-selection's number.
    pub epoch: u64,
    /// The nodes of the last selection (ascending).
    pub selected: Vec<usize>,
    /// The joints leaving the active region.
    pub leaving: Vec<usize>,
    /// Per node: the re-selection whose computation-axes metric slots (Ψ, p, η) it holds.
    pub metric_stamp: Vec<u64>,
    /// Per node: its metric `A` at the exact handle forces.
    pub exact_metric: Vec<f64>,
    /// Per node: the re-selection that computed `exact_metric`.
    pub exact_metric_stamp: Vec<u64>,
    /// Per node: a spatial momentum (the locking impulse).
    pub locking_momentum: Vec<articula_spatial::SpatialForce>,
}

/// What the external forces add to the force-free (cached) values of the nodes on their
/// paths (a forced body up to its cluster), all in the node's cache-frame axes.
#[derive(Clone, Debug, Default)]
pub(crate) struct DirtyDeltas {
    /// Per node: the re-selection whose external forces made it dirty.
    pub dirty_stamp: Vec<u64>,
    /// The dirty nodes of this re-selection.
    pub nodes: Vec<usize>,
    /// Per handle: `Δb`.
    pub delta_b: Vec<[f64; 6]>,
    /// Per handle: `Δp` (6 rows).
    pub delta_p: Vec<f64>,
    /// Per node: `Δn`.
    pub delta_n: Vec<[f64; 6]>,
    /// Per node: `Δη`.
    pub delta_eta: Vec<f64>,
    /// Per degree of freedom: `Δk`.
    pub delta_k: Vec<f64>,
    /// Per node: the number of forced leaves below it on this re-selection's dirty paths
    /// (saturating at 2).
    pub forced_leaves: Vec<u8>,
    /// Per node: the one forced leaf when there is one.
    pub forced_leaf: Vec<usize>,
    /// Per node: whether its linear map is valid.
    pub map_valid: Vec<bool>,
    /// Per node: the re-selection that evaluated its deltas.
    pub delta_stamp: Vec<u64>,
}

/// Forced paths as linear maps of one leaf's wrench (`Adaptive::join_map`), allocated at the
/// first re-selection with external forces. Fields named by a symbol hold that map of
/// docs/adaptive.md#caches.
#[derive(Clone, Debug, Default)]
pub(crate) struct LinearMaps {
    /// Allocated.
    pub allocated: bool,
    /// Per node: the leaf the maps are for.
    pub leaf: Vec<usize>,
    /// Per node: the clock time of its maps' record.
    pub built_at: Vec<u64>,
    /// Per node: whether built.
    pub built: Vec<bool>,
    /// Per node: the leaf's frame in the node's.
    pub leaf_pose: Vec<SpatialTransform>,
    /// Per node: the symbol `G_n` of docs/adaptive.md#caches.
    pub g_n: Vec<M6>,
    /// Per node: the symbol `H` of docs/adaptive.md#caches.
    pub h: Vec<M6>,
    /// Per node: the symbol `J` of docs/adaptive.md#caches (6 rows over the NW monomials).
    pub j_w: Vec<[[f64; NW]; 6]>,
    /// Per handle: the symbol `G_b` of docs/adaptive.md#caches.
    pub g_b: Vec<M6>,
    /// Per handle: the symbol `G_p` of docs/adaptive.md#caches.
    pub g_p: Vec<M6>,
    /// Per degree of freedom: a row of the symbol `G_k` of docs/adaptive.md#caches.
    pub g_k: Vec<[f64; 6]>,
    /// Maps built (for tests: the maps are used).
    pub builds: u64,
    /// Maps evaluated.
    pub evaluations: u64,
}

/// The scratch of a cache build: the children's tensors over the parent's monomials
/// (computation axes), the results, a monomial map and a product; and of a joint transform.
#[derive(Clone, Debug, Default)]
pub(crate) struct BuildScratch {
    /// The two children's `B_w`.
    pub child_b: [Vec<f64>; 2],
    /// The two children's `P_w`.
    pub child_p: [Vec<f64>; 2],
    /// The two children's `E`.
    pub child_e: [Vec<f64>; 2],
    /// The parent's `B_w`.
    pub out_b: Vec<f64>,
    /// The parent's `P_w`.
    pub out_p: Vec<f64>,
    /// The parent's `E`.
    pub out_e: Vec<f64>,
    /// A row block of `K_w`.
    pub out_k_w: Vec<f64>,
    /// The parent's `N_w`.
    pub out_n_w: Vec<f64>,
    /// A map of monomials (NW × NW).
    pub monomial_map: Vec<f64>,
    /// A product.
    pub product: Vec<f64>,
    /// Zero joint velocities (length nv), for `X_J(q)` alone.
    pub zero_velocity: Vec<f64>,
    /// Subspace columns (length nv).
    pub subspace: Vec<SpatialMotion>,
}

impl Caches {
    /// Allocates the caches for `model` (first use), their slots as long as the main pass's
    /// and metric pass's: `K` and `N` (`k_len`, `n_len`, see `JoinMaps`) and `Ψ` (`psi_len`,
    /// see `MetricCoefficients`).
    pub(crate) fn allocate(
        &mut self,
        model: &Model,
        lay: &HandleLayout,
        [k_len, n_len, psi_len]: [usize; 3],
    ) {
        let tree = &model.assembly;
        let nn = tree.nodes.len();
        let c = self;
        c.tensors.node_valid = vec![false; nn];
        c.tensors.composite = vec![Rigid::default(); nn];
        c.tensors.parent_pose = vec![SpatialTransform::IDENTITY; nn];
        c.tensors.handle_pose = vec![SpatialTransform::IDENTITY; lay.handles];
        c.tensors.phi = vec![Mat6::ZERO; lay.blocks];
        c.tensors.b_w = vec![0.0; 6 * NW * lay.handles];
        c.tensors.k = vec![0.0; k_len];
        c.tensors.k_w = vec![0.0; NW * model.nv];
        c.tensors.n = vec![0.0; n_len];
        c.tensors.n_w = vec![0.0; 6 * NW * nn];
        c.tensors.psi = vec![0.0; psi_len];
        c.tensors.p_w = vec![0.0; 6 * NW * lay.handles];
        c.tensors.e = vec![0.0; NW * NW * nn];
        c.tensors.bias_maps = vec![BiasMaps::default(); nn];
        c.torques = vec![0.0; model.nv];
        c.reselection.frame_pose = vec![SpatialTransform::IDENTITY; nn];
        c.reselection.frame_velocity = vec![SpatialMotion::ZERO; nn];
        c.reselection.slots_stamp = vec![0; nn];
        c.reselection.locking_momentum = vec![articula_spatial::SpatialForce::ZERO; nn];
        c.reselection.selected = Vec::with_capacity(nn);
        c.dirty.dirty_stamp = vec![0; nn];
        c.reselection.metric_stamp = vec![0; nn];
        c.reselection.exact_metric = vec![0.0; nn];
        c.reselection.exact_metric_stamp = vec![0; nn];
        c.dirty.nodes = Vec::with_capacity(nn);
        c.dirty.delta_b = vec![[0.0; 6]; lay.handles];
        c.dirty.delta_p = vec![0.0; 6 * lay.handles];
        c.dirty.delta_n = vec![[0.0; 6]; nn];
        c.dirty.delta_eta = vec![0.0; nn];
        c.dirty.delta_k = vec![0.0; model.nv];
        c.dirty.forced_leaves = vec![0; nn];
        c.dirty.forced_leaf = vec![0; nn];
        c.dirty.map_valid = vec![false; nn];
        c.dirty.delta_stamp = vec![0; nn];
        c.tensors.built_at = vec![0; nn];
        c.reselection.leaving = Vec::with_capacity(model.bodies.len());
        let mh = 6 * tree.max_handles().max(1);
        for s in 0..2 {
            c.build.child_b[s] = vec![0.0; mh * NW];
            c.build.child_p[s] = vec![0.0; mh * NW];
            c.build.child_e[s] = vec![0.0; NW * NW];
        }
        c.build.out_b = vec![0.0; mh * NW];
        c.build.out_p = vec![0.0; mh * NW];
        c.build.out_e = vec![0.0; NW * NW];
        c.build.out_k_w = vec![0.0; 6 * NW];
        c.build.out_n_w = vec![0.0; 6 * NW];
        c.build.monomial_map = vec![0.0; NW * NW];
        c.build.product = vec![0.0; (mh * NW).max(NW * NW)];
        c.build.zero_velocity = vec![0.0; model.nv];
        c.build.subspace = vec![SpatialMotion::ZERO; model.nv];
        // Leaves: a body's composite in its own frame.
        for (n, node) in tree.nodes.iter().enumerate() {
            if let NodeKind::Body(i) = node.kind {
                let bi = &model.bodies[i].inertia;
                c.tensors.composite[n] = Rigid {
                    mass: bi.mass,
                    com: bi.com(),
                    inertia: bi.inertia_about_com(),
                };
            }
        }
        // Handle points fixed in their rigid nodes: every joint below the root is revolute,
        // continuous or fixed, and its parts after the first carry no offset.
        c.handles_fixed = model.bodies.iter().all(|b| {
            b.parent.is_none()
                || b.joint.iter().enumerate().all(|(k, p)| {
                    (p.kind.is_hinge() || p.kind == JointKind::Fixed)
                        && (k == 0 || p.origin.r == DVec3::ZERO)
                })
        });
        c.allocated = true;
    }
}
