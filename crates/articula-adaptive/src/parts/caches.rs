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
pub(crate) type M6 = [[f64; 6]; 6];

/// Per-node caches (layouts of the workspace's slots, cache-frame axes) and the scratch of the
/// cached re-selection.
#[derive(Clone, Debug, Default)]
pub(crate) struct Caches {
    /// Allocated for the model.
    pub alloc: bool,
    /// Every rigid node's cache is valid for the current hybrid body.
    pub ready: bool,
    /// Per node: cache valid (its configuration is frozen as cached).
    pub valid: Vec<bool>,
    /// Per node: composite inertia in its cache frame.
    pub rig: Vec<Rigid>,
    /// Per node: its top frame's pose in its parent's cache frame (valid while the parent's
    /// cache is).
    pub rel: Vec<SpatialTransform>,
    /// Per handle: pose of the handle joint's parent body in the node's cache frame (when
    /// that body is in the node).
    pub hpose: Vec<SpatialTransform>,
    pub phi: Vec<Mat6>,
    /// Per handle: `B_h` (6 × NW).
    pub bw: Vec<f64>,
    pub kmat: Vec<f64>,
    /// Per degree of freedom: a row of `K_w` (NW).
    pub kw: Vec<f64>,
    pub nmat: Vec<f64>,
    /// Per node: `N_w` (6 × NW).
    pub nw: Vec<f64>,
    pub psi: Vec<f64>,
    /// Per handle: 6 rows of `P` (NW each).
    pub pw: Vec<f64>,
    /// Per node: `E` (NW × NW, symmetric).
    pub e: Vec<f64>,
    /// Per node: the join's bias maps κ, ν (cache-frame axes; a dirty path's join).
    pub jm: Vec<BiasMaps>,
    /// The joint torques the caches were built with, and whether each re-selection compares
    /// them (O(n)) with the state's (see `Adaptive::set_check_locked_torques`).
    pub tau: Vec<f64>,
    pub check_tau: bool,
    /// Whether the model's handle points are fixed in their rigid nodes (see the module doc).
    pub supported: bool,
    // Scratch of a re-selection: per node, the pose of its cache frame and its top body's
    // velocity in it (own coordinates), and the re-selection that evaluated its slots.
    pub cx: Vec<SpatialTransform>,
    pub cu: Vec<SpatialMotion>,
    pub stamp: Vec<u64>,
    pub epoch: u64,
    /// The nodes of the last selection (ascending), the joints leaving the active region, and
    /// per node a spatial momentum (the locking impulse).
    pub sel: Vec<usize>,
    pub leaving: Vec<usize>,
    /// Per node: the re-selection whose external forces made it dirty (on the path from a
    /// forced body up to its cluster); the dirty nodes of this one.
    pub dstamp: Vec<u64>,
    pub dirty: Vec<usize>,
    /// Per dirty node, what the external forces add to its force-free (cached) values:
    /// per handle `Δb` and `Δp` (6 rows), per node `Δn` and `Δη` (all in its cache frame's
    /// axes), per degree of freedom `Δk`.
    pub db: Vec<[f64; 6]>,
    pub dp: Vec<f64>,
    pub dn: Vec<[f64; 6]>,
    pub deta: Vec<f64>,
    pub dk: Vec<f64>,
    /// Forced paths as linear maps of one leaf's wrench (`Adaptive::join_map`): per node
    /// the number of forced leaves below it on this re-selection's dirty paths (saturating at
    /// 2), the one leaf when there is one, whether its map is valid, and the re-selection
    /// that evaluated its deltas.
    pub nforced: Vec<u8>,
    pub fleaf: Vec<usize>,
    pub mok: Vec<bool>,
    pub dvstamp: Vec<u64>,
    /// A clock stamping cache builds (`cgen`, per node) and map builds (`mtime`): a map is
    /// valid while it is younger than its node's cache and its dirty child's map.
    pub clock: u64,
    pub cgen: Vec<u64>,
    /// Off: every dirty node by `Adaptive::dirty_delta` (the reference for tests).
    pub no_maps: bool,
    /// The maps (allocated at the first re-selection with external forces), per node: the
    /// leaf they are for, their record's time, whether built, the leaf's frame in the node's
    /// (`mpose`), `G_n`, `H`, `J`; per handle `G_b`, `G_p`; per degree of freedom a row of
    /// `G_k`.
    pub malloc: bool,
    pub mleaf: Vec<usize>,
    pub mtime: Vec<u64>,
    pub mbuilt: Vec<bool>,
    pub mpose: Vec<SpatialTransform>,
    pub mgn: Vec<M6>,
    pub mhq: Vec<M6>,
    pub mjw: Vec<[[f64; NW]; 6]>,
    pub mgb: Vec<M6>,
    pub mgp: Vec<M6>,
    pub mgk: Vec<[f64; 6]>,
    /// Maps built and evaluated (for tests: the maps are used).
    pub map_builds: u64,
    pub map_evals: u64,
    /// Per node: the re-selection whose computation-axes metric slots (Ψ, p, η) it holds;
    /// its metric `A` at the exact handle forces and the re-selection that computed it.
    pub pstamp: Vec<u64>,
    pub amet: Vec<f64>,
    pub astamp: Vec<u64>,
    pub hm: Vec<articula_spatial::SpatialForce>,
    // Scratch of a build: the children's tensors over the parent's monomials (computation
    // axes), the results, a monomial map and a product.
    pub xb: [Vec<f64>; 2],
    pub xp: [Vec<f64>; 2],
    pub xe: [Vec<f64>; 2],
    pub ob: Vec<f64>,
    pub op: Vec<f64>,
    pub oe: Vec<f64>,
    pub okw: Vec<f64>,
    pub onw: Vec<f64>,
    pub mm: Vec<f64>,
    pub tmp: Vec<f64>,
    /// Scratch of a joint transform (`X_J(q)` alone): zero velocities and subspace columns
    /// (length nv).
    pub qd0: Vec<f64>,
    pub s0: Vec<SpatialMotion>,
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
        c.valid = vec![false; nn];
        c.rig = vec![Rigid::default(); nn];
        c.rel = vec![SpatialTransform::IDENTITY; nn];
        c.hpose = vec![SpatialTransform::IDENTITY; lay.handles];
        c.phi = vec![Mat6::ZERO; lay.blocks];
        c.bw = vec![0.0; 6 * NW * lay.handles];
        c.kmat = vec![0.0; k_len];
        c.kw = vec![0.0; NW * model.nv];
        c.nmat = vec![0.0; n_len];
        c.nw = vec![0.0; 6 * NW * nn];
        c.psi = vec![0.0; psi_len];
        c.pw = vec![0.0; 6 * NW * lay.handles];
        c.e = vec![0.0; NW * NW * nn];
        c.jm = vec![BiasMaps::default(); nn];
        c.tau = vec![0.0; model.nv];
        c.cx = vec![SpatialTransform::IDENTITY; nn];
        c.cu = vec![SpatialMotion::ZERO; nn];
        c.stamp = vec![0; nn];
        c.hm = vec![articula_spatial::SpatialForce::ZERO; nn];
        c.sel = Vec::with_capacity(nn);
        c.dstamp = vec![0; nn];
        c.pstamp = vec![0; nn];
        c.amet = vec![0.0; nn];
        c.astamp = vec![0; nn];
        c.dirty = Vec::with_capacity(nn);
        c.db = vec![[0.0; 6]; lay.handles];
        c.dp = vec![0.0; 6 * lay.handles];
        c.dn = vec![[0.0; 6]; nn];
        c.deta = vec![0.0; nn];
        c.dk = vec![0.0; model.nv];
        c.nforced = vec![0; nn];
        c.fleaf = vec![0; nn];
        c.mok = vec![false; nn];
        c.dvstamp = vec![0; nn];
        c.cgen = vec![0; nn];
        c.leaving = Vec::with_capacity(model.bodies.len());
        let mh = 6 * tree.max_handles().max(1);
        for s in 0..2 {
            c.xb[s] = vec![0.0; mh * NW];
            c.xp[s] = vec![0.0; mh * NW];
            c.xe[s] = vec![0.0; NW * NW];
        }
        c.ob = vec![0.0; mh * NW];
        c.op = vec![0.0; mh * NW];
        c.oe = vec![0.0; NW * NW];
        c.okw = vec![0.0; 6 * NW];
        c.onw = vec![0.0; 6 * NW];
        c.mm = vec![0.0; NW * NW];
        c.tmp = vec![0.0; (mh * NW).max(NW * NW)];
        c.qd0 = vec![0.0; model.nv];
        c.s0 = vec![SpatialMotion::ZERO; model.nv];
        // Leaves: a body's composite in its own frame.
        for (n, node) in tree.nodes.iter().enumerate() {
            if let NodeKind::Body(i) = node.kind {
                let bi = &model.bodies[i].inertia;
                c.rig[n] = Rigid {
                    m: bi.mass,
                    c: bi.com(),
                    ic: bi.inertia_about_com(),
                };
            }
        }
        // Handle points fixed in their rigid nodes: every joint below the root is revolute,
        // continuous or fixed, and its parts after the first carry no offset.
        c.supported = model.bodies.iter().all(|b| {
            b.parent.is_none()
                || b.joint.iter().enumerate().all(|(k, p)| {
                    matches!(
                        p.kind,
                        JointKind::Revolute | JointKind::Continuous | JointKind::Fixed
                    ) && (k == 0 || p.origin.r == DVec3::ZERO)
                })
        });
        c.alloc = true;
    }
}
