//! The workspace beside the immutable model: every per-step buffer, allocated once.

use crate::kinematics::FkPlan;
use crate::small::{SmallSpd, SymT};
use crate::DynamicsError;
use articula_model::{Model, NodeKind};
use articula_spatial::numerics::fused_available;
use articula_spatial::SymMat6;
use articula_spatial::{Mat6, SpatialForce, SpatialInertia, SpatialMotion, SpatialTransform};
use glam::DVec3;

/// Which side of a join a handle of the joined node comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Side {
    /// The principal joint's parent side ("A").
    A,
    /// The child side ("B").
    B,
}

/// Per-step buffers of every algorithm. Build once with [`Data::new`] (DCA's own buffers are
/// built by the first DCA call, [`Data::ensure_dca`]); a dynamics call or a step allocates
/// nothing after that. `Data` also caches a few constants of the model's joints (their
/// kinematic fast paths and offsets) and bodies (inverse inertias): build a new one for a
/// changed model.
#[derive(Clone, Debug)]
pub struct Data {
    /// Gravity acceleration in world coordinates (default `(0, 0, -9.81)`).
    pub gravity: DVec3,
    /// With a floating base, check ABA's `q̈` (and DCA's, from 100 bodies on) against the
    /// Newton–Euler residual and refine it once when the residual is large (default `true`;
    /// see `docs/algorithms.md`). It costs one Newton–Euler pass per such solve and buys ~1e-11
    /// instead of ~1e-9 on 1,000-link floating chains; turn it off where ~1e-9 relative is
    /// enough.
    pub refine_floating: bool,
    /// Per degree of freedom, the armature every solve adds to the joint-space inertia's
    /// diagonal: the model's (`Model::dynamics`), plus `h b` while a step integrates damping
    /// `b` implicitly. Empty for a model with neither armature nor damping (every algorithm
    /// then runs as without them). Set through [`Data::set_damping_step`].
    pub(crate) armature: Vec<f64>,
    /// A step's joint forces `τ` plus the passive forces (`integrate::with_passive_forces`).
    pub(crate) passive: Vec<f64>,
    /// Whether DCA's `q̈` goes through that check (when `refine_floating` is set): with a
    /// floating base of at least `REFINE_MIN_BODIES` (100) bodies, or when some body's
    /// rotational inertia is tiny for its mass and size (`docs/loading.md`) and the body is in
    /// no leaf cluster (`cluster.rs`), where the joins of a body between two handles lose up to
    /// ~1e-5 relative. Set in [`Data::new`] and [`Data::set_leaf_clusters`].
    pub(crate) refine_dca: bool,
    /// Origin of the computation frame in world coordinates. The world origin for a fixed
    /// base; the floating base's position otherwise (for accuracy). Every spatial quantity
    /// below (`x`, `v`, `c`, `inertia`, `s`) is in this frame: world axes, taken **about
    /// `origin`, not about the world origin** (a first moment `inertia[i].h` is `m (c − origin)`,
    /// a linear velocity is that of the point at `origin`). [`Data::center_of_mass`],
    /// [`Data::body_pose`], [`Data::momentum`] and the other accessors convert back to the world.
    pub origin: DVec3,
    /// Per body: the map from body coordinates to computation-frame coordinates.
    pub x: Vec<SpatialTransform>,
    /// Per body: spatial velocity, computation frame (world axes, about `origin`).
    pub v: Vec<SpatialMotion>,
    /// Per body: velocity-product term of its joint, `c = Σ_k v_{k-1} × s_k q̇_k`
    /// (computation frame).
    pub c: Vec<SpatialMotion>,
    /// Per body: spatial inertia, computation frame (world axes, about `origin`).
    pub inertia: Vec<SpatialInertia>,
    /// Per degree of freedom: the motion-subspace column, computation frame (world axes,
    /// about `origin`).
    pub s: Vec<SpatialMotion>,
    /// The joint accelerations of the last solve (length `nv`).
    pub qdd: Vec<f64>,
    /// Momentum projection in [`crate::step`] (default `true`; it acts only on a free-floating
    /// model, see [`crate::step`]): after each step the floating base's velocity is corrected so
    /// that the total spatial momentum equals its exact value — the momentum at the start of
    /// the step plus the exact impulse of gravity and of the (constant, world-frame) external
    /// wrenches. Set to `false` for the integrator's raw result.
    pub momentum_projection: bool,
    /// External wrenches in the computation frame (empty when none were given).
    pub(crate) f_ext_c: Vec<SpatialForce>,
    /// Per body: the forward-kinematics path of its joint.
    pub(crate) fk_plan: Vec<FkPlan>,
    /// Per body: parent, velocity offset and DOF count, compact (the recursions read these
    /// for every body; `Body` itself spans several cache lines).
    pub(crate) topo: Vec<Topo>,
    pub(crate) dca: DcaData,
    pub(crate) aba: AbaData,
    pub(crate) refine: RefineData,
    pub(crate) rk: RkData,
    pub(crate) quant: QuantityData,
    /// The model this workspace was built for (`inputs::check_data`).
    pub(crate) fingerprint: Fingerprint,
}

/// Buffers of the quantities around forward dynamics (inverse dynamics, bias forces, mass
/// matrix, Jacobians): each is sized by the first call that needs it, so that a workspace that
/// never asks (one of a crowd's) carries none of them (the mass matrix of a 1,000-link chain
/// is 8 MB); later calls allocate nothing.
#[derive(Clone, Debug, Default)]
pub(crate) struct QuantityData {
    /// Joint forces of the last [`crate::inverse_dynamics`] or [`crate::bias_forces`] (`nv`).
    pub tau: Vec<f64>,
    /// `nv` zeros (a zero `τ` or `q̇` input).
    pub zero: Vec<f64>,
    /// Per body: RNEA accelerations and forces.
    pub a: Vec<SpatialMotion>,
    pub f: Vec<SpatialForce>,
    /// Per body: composite (subtree) inertias.
    pub ic: Vec<SpatialInertia>,
    /// The joint-space mass matrix (`nv × nv`).
    pub mass_matrix: Vec<f64>,
    /// A link's spatial (`6 × nv`) or point (`3 × nv`) Jacobian.
    pub jacobian: Vec<f64>,
    /// The centre-of-mass Jacobian (`3 × nv`).
    pub com_jacobian: Vec<f64>,
}

/// `v` with length `len` (new entries `fill`): allocates only when `v` has never been this
/// long, so the first call of a quantity sizes its buffer and later calls reuse it.
pub(crate) fn sized<T: Clone>(v: &mut Vec<T>, len: usize, fill: T) -> &mut [T] {
    v.resize(len, fill);
    v
}

/// A body's place in the recursions.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Topo {
    /// The parent body, `usize::MAX` for a root.
    pub parent: usize,
    pub vo: usize,
    pub nv: usize,
}

/// DCA buffers (docs/design.md#dca), laid out over the assembly tree.
#[derive(Clone, Debug)]
pub(crate) struct DcaData {
    /// Whether the buffers below are allocated: [`Data::new`] leaves them empty, the first
    /// DCA call builds them ([`Data::ensure_dca`]).
    pub built: bool,
    /// Run the passes compiled for AVX2 + FMA (`fma_dispatch!` in `dca.rs`, `aba.rs`): set in
    /// [`Data::new`] when the CPU has both (x86-64 only); tests clear it to check the portable
    /// compilation.
    pub fused: bool,
    /// Whether DCA's tree has leaf clusters (`Data::set_leaf_clusters`).
    pub clusters: bool,
    /// Whether `forward_dynamics` runs the kinematics inside the main pass: each body's at its
    /// parent's leaf (the root bodies' at the ground's), which needs the ground first and every
    /// body's leaf after its parent's (true for the assembly trees of `articula-model`, whose
    /// post-order visits a join's parent side first, and false with gather nodes and leaf
    /// clusters; checked in
    /// [`DcaData::build`]). The pose,
    /// velocity, `c` and `S` are then used while in cache instead of read back from memory.
    pub leaf_kinematics: bool,
    /// Whether the back-substitution prefetches what the join a few nodes ahead reads: set in
    /// [`DcaData::build`] when the per-join streams it reads (`rev` and the cross blocks) exceed
    /// [`PREFETCH_ABOVE`] bytes. Below that they stay in cache from the main pass, and the
    /// prefetches would only cost instructions.
    pub prefetch: bool,
    /// Whether the slots and the join scratch are laid out in banks for the parallel driver
    /// (`parallel_dca.rs`): each subtree that one task solves has slots and scratch of its own
    /// (see [`DcaData::build`]). The arithmetic is the same either way.
    pub banked: bool,
    /// Handles per scratch bank in `y` and `u` (the largest handle count of a node).
    pub max_h: usize,
    /// Per node, what the passes read of it, in one compact record (see [`DNode`]).
    pub node: Vec<DNode>,
    /// Per handle (flat, `DNode::hoff`): its joint.
    pub hj: Vec<u32>,
    /// Per handle of a join node (flat, `DNode::hoff`): the side it comes from and its index
    /// there.
    pub from: Vec<(Side, u32)>,
    /// Joins of the last pass whose constraint factorisation met a pivot that rounding had
    /// made non-positive ([`ldl5`](articula_spatial::numerics::ldl5)); reset by each pass.
    pub clamped: u32,
    /// Whether a six-axis (floating) joint's join factors the identity instead of
    /// `K = Φ^A_jj + Φ^B_jj` (`mass_ratio.rs`): set for models with a neighbour mass ratio above
    /// [`MASS_RATIO`](crate::mass_ratio::MASS_RATIO), where a light base's `K` loses its rigid directions to rounding.
    pub free_identity: bool,
    /// The gather nodes' buffers (`gather.rs`).
    pub gather: GatherBuffers,
    /// The leaf clusters' buffers (`cluster.rs`).
    pub cluster: ClusterBuffers,
    /// What a node hands its parent join, in a slot per (depth, side) (see [`SlotBuffers::dg`]).
    pub slots: SlotBuffers,
    /// Per join node: the factors the main pass leaves for the back-substitution, and the join scratch.
    pub joins: JoinBuffers,
    /// Per body, joint or degree of freedom: leaf constants, points, arms and the joint factors.
    pub bodies: BodyBuffers,
}

/// The gather nodes' buffers (`gather.rs`).
#[derive(Clone, Debug, Default)]
pub(crate) struct GatherBuffers {
    /// The gather nodes' children (node indices, `DKind::Gather::first`), and per child `K =
    /// Φ_jj⁻¹`, its articulated inertia at its joint to the hub (`gather.rs`).
    pub gathered: Vec<u32>,
    pub gk: Vec<Mat6>,
}

/// The leaf clusters' buffers (`cluster.rs`).
#[derive(Clone, Debug, Default)]
pub(crate) struct ClusterBuffers {
    /// The bodies the cluster nodes absorb (`DKind::Cluster::first`), parents first.
    pub clustered: Vec<u32>,
    /// Per body of a cluster (empty without clusters): whether its ABA terms set its parent's
    /// sums (the first of its siblings in the main pass's order) rather than add to them, and
    /// whether it has sums (absorbed children); the sums `Iᵃ`, `pᵃ` of its absorbed children;
    /// its acceleration relative to gravity (the back-substitution's `a'`).
    pub cfirst: Vec<bool>,
    pub csums: Vec<bool>,
    pub cia: Vec<SymMat6>,
    pub cpa: Vec<SpatialForce>,
    pub ca: Vec<SpatialMotion>,
}

/// What a node hands its parent join, in a slot per (depth, side) (see [`SlotBuffers::dg`]).
#[derive(Clone, Debug, Default)]
pub(crate) struct SlotBuffers {
    /// Φ's diagonal blocks `Φ_hh` (symmetric, upper 2×2 tiles) and the bias accelerations `b_h`: only the
    /// parent join reads them, so they live in a slot per (depth, side) instead of per node —
    /// in post-order, the child visited first waits while its sibling's subtree (deeper
    /// nodes, and the sibling itself on the other side) is built, so no live slot is reused.
    /// A few kB, cache-resident however long the chain.
    pub dg: Vec<SymT>,
    pub b: Vec<SpatialMotion>,
    /// Handle forces (back-substitution): set by the parent join and read by the node itself,
    /// so in the node's slot like `dg` and `b` (in reverse post-order the child processed last
    /// waits while its sibling's subtree is solved).
    pub f: Vec<SpatialForce>,
}

/// Per join node: the factors the main pass leaves for the back-substitution, and the join scratch.
#[derive(Clone, Debug, Default)]
pub(crate) struct JoinBuffers {
    /// Φ's cross blocks.
    pub phi: Vec<Mat6>,
    /// Per join node off the one-axis path: the Cholesky factor L of `Φ^A_jj + Φ^B_jj = V⁻¹`
    /// (its diagonal stored inverted, see [`cholesky_inv_diag`](articula_spatial::numerics::cholesky_inv_diag)), and β.
    pub l: Vec<[[f64; 6]; 6]>,
    pub beta: Vec<SpatialMotion>,
    /// Per join (`DNode::jix`): what a one-axis join keeps for the back-substitution, dense in
    /// post-order (a back-substitution stream without the leaves' gaps).
    pub rev: Vec<RevJoin>,
    /// Scratch per handle of the node being joined: `Ỹ_h = Q L⁻¹ Φ_jh` (or, one axis,
    /// `Z_h = L⁻¹ Tᵀ Φ_jh`).
    pub y: Vec<[[f64; 6]; 6]>,
    /// Scratch per handle of a one-axis join: `D⁻¹ Z_h`, the rows of `Z_h` (in `y`) divided by
    /// the pivots (see `dca::y_reduced`).
    pub u: Vec<[[f64; 6]; 6]>,
}

/// Per body, joint or degree of freedom: leaf constants, points, arms and the joint factors.
#[derive(Clone, Debug, Default)]
pub(crate) struct BodyBuffers {
    /// Per body: what the back-substitution needs of its leaf.
    pub leafk: Vec<LeafK>,
    /// Per body: the constants of its leaf.
    pub leaf: Vec<LeafConst>,
    /// The rotational inertias with products of inertia (see [`LeafConst::full`]).
    pub leaf_full: Vec<[[f64; 6]; 2]>,
    /// Per joint h: the point P_h (origin of body h, computation frame) about which every
    /// handle-h vector is taken.
    pub point: Vec<DVec3>,
    /// Per joint h: the arm `P_h − P_parent` from its parent's origin
    /// ([`kinematics::arm`](crate::kinematics::arm)): the leaves take their handle lever arms
    /// from it, not from the difference of two far points.
    pub arm: Vec<DVec3>,
    /// Per body of a banked layout (empty otherwise): `(sin θ, cos θ)` of its joint angle on
    /// the one-axis revolute fast path, computed on all threads before the pose chain of the
    /// parallel driver (`parallel_dca.rs`).
    pub trig: Vec<(f64, f64)>,
    /// Per degree of freedom: the column of `Z = L⁻¹ S`.
    pub z: Vec<[f64; 6]>,
    /// Per joint (= body): `D⁻¹ = (Sᵀ V S)⁻¹`.
    pub dinv: Vec<SmallSpd>,
}

/// A node of the assembly tree as DCA's passes read it: 44 bytes (the tree's own node and the
/// flat offsets would be ~90), one stream.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DNode {
    pub kind: DKind,
    /// Offset of its handles in the flat per-handle arrays (`hj`, `from`), and their count.
    pub hoff: u32,
    pub nh: u32,
    /// Offset of its cross blocks in `phi`: the nh (nh − 1) / 2 blocks `Φ_hk`, h < k, row by
    /// row (`Φ_kh = Φ_hkᵀ`). A leaf's (the ground's) are in a slot like `dg`, ahead of the
    /// joins' (see `DcaData::build`).
    pub boff: u32,
    /// Offset of its handles in the slot arrays `dg`, `b` and `f`.
    pub slot: u32,
    /// A join: its index among the joins (post-order, for `rev`), the principal joint's index
    /// among A's and among B's handles, and whether it is a single revolute joint (the 5×5
    /// path, [`RevJoin`]).
    pub jix: u32,
    pub ja: u16,
    pub jb: u16,
    pub one_dof: bool,
    /// A one-axis join whose joint is damped: in a step (damping implicit) its armature is
    /// `dt b` and it takes the general join (`dca::one_axis`).
    pub damped: bool,
    /// A join: its scratch bank, at `ys · max_h` in `y` and `u` (0 unless
    /// [`DcaData::banked`]).
    pub ys: u16,
}

/// [`articula_model::NodeKind`] with 32-bit indices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum DKind {
    Ground,
    Body(u32),
    /// Joint, parent side A, child side B.
    Join {
        joint: u32,
        a: u32,
        b: u32,
    },
    /// Hub body (`u32::MAX`: the ground), its children at `gathered[first..first + count]`.
    Gather {
        body: u32,
        first: u32,
        count: u32,
    },
    /// A leaf cluster's body (`u32::MAX`: the ground), its absorbed bodies at
    /// `clustered[first..first + count]`.
    Cluster {
        body: u32,
        first: u32,
        count: u32,
    },
}

/// A leaf's `Φ = I⁻¹` in closed form, written by its leaf for the back-substitution (see
/// `dca::leaf`): the computation-frame `J = R I_c⁻¹ Rᵀ` (upper triangle, row by row), the
/// centre of mass `c` relative to the body's origin `P_i` (computation-frame axes) and `1/m`.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct LeafK {
    pub j: [f64; 6],
    pub c: [f64; 3],
    pub im: f64,
}

/// A body's inertia as its DCA leaf uses it, in body coordinates: 64 bytes, one cache line
/// (the main pass reads one per body: at 10,000 links a stream from beyond L2).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct LeafConst {
    /// Centre of mass.
    pub com: [f64; 3],
    /// `1/m`; NaN when the spatial inertia is not positive definite (the dynamics call reports
    /// it).
    pub im: f64,
    /// With principal axes along the body's (`full == u32::MAX`, the common case): the
    /// principal moments, the diagonal of `I_c` (the leaf takes their inverses).
    pub ic: [f64; 3],
    /// Otherwise: the index of `I_c` and `I_c⁻¹` in `DcaData::leaf_full`.
    pub full: u32,
}

impl LeafConst {
    /// The constants of `inertia`; a rotational inertia with products of inertia goes to
    /// `full` (`I_c` and its inverse: upper triangles, row by row, `xx, xy, xz, yy, yz, zz`).
    /// With `regularised` (a singular body, see [`regularised_inverse`]) the inverse is that
    /// matrix instead of `I_c⁻¹`, and the body goes to `full` too: `I_c` stays exact for the
    /// bias forces and the world inertia. With `scale` `σ ≠ 1` (a light body between heavy
    /// neighbours, see `mass_ratio.rs`) the leaf inverts `σ I`: `1/(σ m)` and `I_c⁻¹ / σ`, in
    /// `full` with the exact `I_c`.
    fn of(
        inertia: &SpatialInertia,
        regularised: Option<glam::DMat3>,
        scale: f64,
        full: &mut Vec<[[f64; 6]; 2]>,
    ) -> LeafConst {
        let ic = inertia.inertia_about_com();
        let m = inertia.mass;
        let ok = !m.is_nan() && m > 0.0 && (regularised.is_some() || ic.determinant() > 0.0);
        let up = |a: glam::DMat3| {
            [
                a.x_axis.x, a.y_axis.x, a.z_axis.x, a.y_axis.y, a.z_axis.y, a.z_axis.z,
            ]
        };
        let u = up(ic);
        let diagonal =
            regularised.is_none() && scale == 1.0 && u[1] == 0.0 && u[2] == 0.0 && u[4] == 0.0;
        let index = if diagonal {
            u32::MAX
        } else {
            let inverse = match regularised {
                _ if !ok => [f64::NAN; 6],
                Some(j) => up(j * scale.recip()),
                None if scale != 1.0 => up(ic.inverse() * scale.recip()),
                None => up(ic.inverse()),
            };
            full.push([u, inverse]);
            // (At most one per body: `DcaData::build` checked the body count.)
            u32::try_from(full.len() - 1).expect("body count checked in DcaData::build")
        };
        LeafConst {
            com: inertia.com().to_array(),
            im: if ok { 1.0 / (scale * m) } else { f64::NAN },
            ic: [u[0], u[3], u[5]],
            full: index,
        }
    }
}

/// What a one-axis join keeps (see `dca::join`): with `s = [ω; 0]` the revolute joint's
/// subspace column at its point and `p`, `q` an orthogonal pair perpendicular to ω,
/// `T = [p 0; q 0; 0 1]ᵀ` (6×5: columns `[p; 0]`, `[q; 0]`, `[0; e_x]`, `[0; e_y]`, `[0; e_z]`)
/// spans the forces that do no work along `s`. (A prismatic joint takes the general path.)
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct RevJoin {
    /// The pair p, q.
    pub p: [f64; 3],
    pub q: [f64; 3],
    /// The `L D Lᵀ` factors of the 5×5 `TᵀKT`, lower triangle packed row by row
    /// (`(i, j)` at `i (i + 1) / 2 + j`): L's entries below the diagonal, `1 / d_i` on it.
    pub l: [f64; 15],
    /// `(W K s − s) / sᵀs`: `q̈ = gᵀ y + q̈_τ τ` in the back-substitution; `−g` is the joint
    /// force per unit torque.
    pub g: [f64; 6],
    /// The joint force and `q̈` for zero handle forces: `γ = W β − g τ`, `gᵀβ + q̈_τ τ`.
    pub gamma: [f64; 6],
    pub qdd: f64,
}

/// ABA buffers.
#[derive(Clone, Debug)]
pub(crate) struct AbaData {
    /// The children's articulated inertias `Σ Iᵃ` and bias forces `Σ pᵃ` of the bodies
    /// pass 2 has reached a child of but not the body itself, by slot (`acc`); `pa` is also
    /// per-body scratch for the floating-base refinement.
    pub ia: Vec<SymMat6>,
    pub pa: Vec<SpatialForce>,
    /// Per body: the slot of its children's sums (`u32::MAX` without children), and whether it
    /// is the first of its parent's children that pass 2 reaches (the highest index: it sets
    /// the parent's sums, later siblings add). A slot is reused once its body is done, so a
    /// chain needs one: the sums stay in cache instead of a per-body stream.
    pub acc: Vec<u32>,
    pub first: Vec<bool>,
    /// Per degree of freedom: `U = Iᴬ s` and `u = τ − sᵀ pᴬ`.
    pub u: Vec<[f64; 6]>,
    pub uu: Vec<f64>,
    /// `D⁻¹` of every joint (k×k row-major), body i's at `doff[i]`.
    pub dinv: Vec<f64>,
    pub doff: Vec<usize>,
    /// Spatial accelerations of the bodies pass 3 has reached but not all of whose children,
    /// by slot (`aslot`; a chain needs one); also per-body scratch for the refinement.
    pub a: Vec<SpatialMotion>,
    pub aslot: Vec<u32>,
    /// Per body: the arm `pᵢ − p_parent` from its parent's origin to its own (the computation
    /// origin for a root), and its velocity product `c` about its origin; per degree of
    /// freedom: `S` about the body's origin (pass 2 writes them, pass 3 reads them).
    pub arm: Vec<glam::DVec3>,
    pub cl: Vec<SpatialMotion>,
    pub sl: Vec<SpatialMotion>,
}

/// Integrator buffers.
#[derive(Clone, Debug)]
pub(crate) struct RkData {
    pub q0: Vec<f64>,
    pub qd0: Vec<f64>,
    pub kv: Vec<f64>,
    pub ka: Vec<f64>,
    /// RKMK: the Lie-algebra increment of the current stage (floating joints' entries).
    pub theta: Vec<f64>,
}

/// The size of the back-substitution's per-join streams (each join's `RevJoin` and cross
/// block) above which it prefetches (see [`DcaData::prefetch`]): a quarter of a 1 MB L2.
const PREFETCH_ABOVE: usize = 256 * 1024;

/// A cheap fingerprint of a model: its sizes and the shape of three of its bodies (first,
/// middle, last: parent, degrees of freedom, offsets). O(1) to compare, so every entry point
/// checks that a [`Data`] belongs to the model it is given (`inputs::check_data`); two models
/// of the same sizes and probed shape share buffers safely in every algorithm, whose loops
/// are bounded by these sizes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Fingerprint {
    nq: usize,
    nv: usize,
    bodies: usize,
    floating: bool,
    locked: usize,
    /// (parent or `usize::MAX`, nv, q offset, v offset) of bodies 0, n/2 and n − 1.
    probe: [(usize, usize, usize, usize); 3],
}

impl Fingerprint {
    pub(crate) fn of(model: &Model) -> Fingerprint {
        let n = model.bodies.len();
        let probe = [0, n / 2, n.saturating_sub(1)].map(|i| {
            model.bodies.get(i).map_or((0, 0, 0, 0), |b| {
                (b.parent.unwrap_or(usize::MAX), b.nv, b.q_offset, b.v_offset)
            })
        });
        Fingerprint {
            nq: model.nq,
            nv: model.nv,
            bodies: n,
            floating: model.floating_base,
            locked: model.locked.len(),
            probe,
        }
    }

    /// For messages: the sizes (and "same sizes, other shape" when only the probe differs).
    pub(crate) fn describe(&self, other: &Fingerprint) -> String {
        let base = if self.floating { "floating" } else { "fixed" };
        let same_sizes = (self.nq, self.nv, self.bodies, self.floating)
            == (other.nq, other.nv, other.bodies, other.floating);
        format!(
            "{} bodies, nq {}, nv {}, {base} base{}",
            self.bodies,
            self.nq,
            self.nv,
            if same_sizes {
                ", another tree shape"
            } else {
                ""
            }
        )
    }
}

/// Buffers of DCA's iterative refinement (`refine.rs`).
#[derive(Clone, Debug)]
pub(crate) struct RefineData {
    pub(crate) a: Vec<SpatialMotion>,
    pub(crate) f: Vec<SpatialForce>,
    pub(crate) r: Vec<f64>,
    pub(crate) qdd: Vec<f64>,
    /// Zero velocities and velocity products, swapped in for the correction solve.
    pub(crate) zv: Vec<SpatialMotion>,
    pub(crate) zc: Vec<SpatialMotion>,
    /// Solves whose residual was above rounding level (a counter for tests); with
    /// `regularised`, every correction step.
    pub(crate) corrections: u64,
    /// DCA solves answered by ABA instead (`forward::dca_or_fall_back`): a refinement that did
    /// not converge, or a join that rounding made singular where ABA is not.
    pub(crate) fallbacks: u64,
    /// Some body's DCA leaf inverts a regularised inertia: refine every solve to convergence.
    pub(crate) regularised: bool,
    /// Some body's mass differs from its parent's by more than [`MASS_RATIO`](crate::mass_ratio::MASS_RATIO): the same.
    pub(crate) mass_ratio: bool,
    /// GMRES's vectors, where the fixed-point refinement diverges (`krylov.rs`).
    pub(crate) krylov: crate::krylov::KrylovData,
}

impl RefineData {
    pub(crate) fn new(model: &Model, regularised: bool) -> RefineData {
        let n = model.bodies.len();
        RefineData {
            a: vec![SpatialMotion::ZERO; n],
            f: vec![SpatialForce::ZERO; n],
            r: vec![0.0; model.nv],
            qdd: vec![0.0; model.nv],
            zv: vec![SpatialMotion::ZERO; n],
            zc: vec![SpatialMotion::ZERO; n],
            corrections: 0,
            fallbacks: 0,
            regularised,
            mass_ratio: crate::mass_ratio::large_mass_ratio(model),
            krylov: Default::default(),
        }
    }
}

/// A body's rotational inertia about its centre of mass is ill-conditioned when its smallest
/// principal moment is below this fraction of its scale (see [`conditioning`]).
const ILL_CONDITIONED: f64 = 1e-6;

/// A body's rotational inertia is singular for DCA when its smallest principal moment is at
/// most this fraction of its scale (a point or rod mass, loaded as written: `docs/loading.md`).
/// DCA's leaf then inverts a regularised copy ([`regularised_inverse`]), and the Newton–Euler
/// refinement, whose residual uses the exact inertia, brings `q̈` to the exact solution
/// (`refine.rs`). Each refinement step shrinks the error by about the relative change of
/// the dynamics, ~`REGULARISE · s / (m d²)` for a point mass at distance `d` from a joint axis;
/// a smaller value costs digits in the joins instead (measured on icub, whose 1.3 kg head is
/// 0.4 mm from its neck axis).
pub(crate) const REGULARISE: f64 = 1e-9;

/// The body's principal moments about its centre of mass (ascending), their axes, and its
/// scale `s = max(λ3, m ℓ²)`, `ℓ` the largest distance from its centre of mass to its joint or
/// a child's, at least `min_size`.
fn conditioning(
    model: &Model,
    b: &articula_model::Body,
    min_size: f64,
) -> ([f64; 3], glam::DMat3, f64) {
    let c = b.inertia.com();
    let mut size2 = c.length_squared();
    for &ch in &b.children {
        let (_, at) = model.bodies[ch].joint[0].origin.to_pose();
        size2 = size2.max((at - c).length_squared());
    }
    let (l, axes) = articula_model::body_inertia::principal_moments(b.inertia.inertia_about_com());
    let size2 = size2.max(min_size * min_size);
    (l, axes, l[2].max(b.inertia.mass * size2))
}

/// Floating bases with at least this many bodies go through the Newton–Euler check. The root
/// join's rounding residue grows with the length of the body (~4e-10 relative on a floating
/// 1,000-link chain); below this size DCA's floating-base `q̈` is within ~1e-13 of the
/// reference without it (`cargo xtask corpus`: every floating robot of example-robot-data), and
/// the check would cost a Newton–Euler pass per solve.
pub(crate) const REFINE_MIN_BODIES: usize = 100;

/// Whether DCA's result needs the Newton–Euler check: a floating base of at least
/// [`REFINE_MIN_BODIES`] bodies, or a body whose rotational inertia is ill-conditioned
/// ([`ILL_CONDITIONED`]).
/// A body of a leaf cluster (with `clusters`) is left out: DCA never inverts its inertia
/// (`cluster.rs`).
pub(crate) fn needs_refinement(model: &Model, clusters: bool) -> bool {
    let absorbed = absorbed(model, clusters);
    (model.floating_base && model.bodies.len() >= REFINE_MIN_BODIES)
        || model
            .bodies
            .iter()
            .zip(&absorbed)
            .any(|(b, &a)| !a && !well_conditioned(model, b))
}

/// The largest subtree (in bodies) a leaf cluster absorbs.
pub(crate) const CLUSTER_MAX: usize = 16;

/// Per body, whether it belongs to a leaf cluster. DCA absorbs a body's subtree (at most
/// [`CLUSTER_MAX`] bodies) into its parent's leaf (the ground's for a root body) when
///
/// - the parent is a branch point (2 to [`articula_model::GATHER_ABOVE`] children; more make a gather node),
///   or the subtree is branched itself and as large as it can be (its parent is the ground or
///   heads a subtree of more than [`CLUSTER_MAX`] bodies): a small branched robot such as an
///   arm with a two-finger gripper is then one cluster, solved as ABA solves it;
/// - and the parent is the ground or a body whose own inertia is well-conditioned (so that
///   the cluster's articulated inertia, which DCA inverts, is positive definite).
///
/// Chains have no branch point: their trees, and their bits, are as without clusters. Without
/// `clusters` (`Data::set_leaf_clusters`), none.
pub(crate) fn absorbed(model: &Model, clusters: bool) -> Vec<bool> {
    let n = model.bodies.len();
    if !clusters {
        return vec![false; n];
    }
    let ground = n;
    let parent = |i: usize| model.bodies[i].parent.unwrap_or(ground);
    let mut kids = vec![0usize; n + 1];
    let mut size = vec![1usize; n];
    for i in 0..n {
        kids[parent(i)] += 1;
    }
    // Whether a body's subtree has a branch point.
    let mut branched: Vec<bool> = (0..n).map(|i| kids[i] >= 2).collect();
    for i in (0..n).rev() {
        if let Some(p) = model.bodies[i].parent {
            size[p] += size[i];
            branched[p] |= branched[i];
        }
    }
    let mut out = vec![false; n];
    for i in 0..n {
        let p = parent(i);
        let largest = p == ground || size[p] > CLUSTER_MAX;
        out[i] = (p != ground && out[p])
            || (size[i] <= CLUSTER_MAX
                && kids[p] <= articula_model::GATHER_ABOVE
                && (kids[p] >= 2 || (branched[i] && largest))
                && (p == ground || well_conditioned(model, &model.bodies[p])));
    }
    out
}

/// Whether a body's mass is positive and its rotational inertia not ill-conditioned
/// ([`ILL_CONDITIONED`]).
pub(crate) fn well_conditioned(model: &Model, b: &articula_model::Body) -> bool {
    let (l, _, s) = conditioning(model, b, 0.0);
    b.inertia.mass > 0.0 && l[0] >= ILL_CONDITIONED * s
}

/// For a body whose smallest principal moment is at most [`REGULARISE`] times its scale `s`
/// (with a positive mass; ℓ at least 1 mm): `(R diag(λ'_k) Rᵀ)⁻¹` with `λ'_k = max(λ_k, REGULARISE · s)`, what its
/// DCA leaf uses for `I_c⁻¹`. `None` for every other body.
fn regularised_inverse(model: &Model, b: &articula_model::Body) -> Option<glam::DMat3> {
    let (l, axes, s) = conditioning(model, b, articula_model::body_inertia::MIN_SIZE);
    let floor = REGULARISE * s;
    if !(b.inertia.mass > 0.0 && l[0] <= floor && floor > 0.0) {
        return None;
    }
    let d = glam::DVec3::from_array(l.map(|x| 1.0 / x.max(floor)));
    Some(axes * glam::DMat3::from_diagonal(d) * axes.transpose())
}

/// Whether some body's DCA leaf inverts a regularised inertia ([`regularised_inverse`]); a
/// body of a leaf cluster (with `clusters`) has no leaf of its own (`cluster.rs`).
fn regularised(model: &Model, clusters: bool) -> bool {
    let absorbed = absorbed(model, clusters);
    model
        .bodies
        .iter()
        .zip(&absorbed)
        .any(|(b, &a)| !a && regularised_inverse(model, b).is_some())
}

impl Data {
    /// Allocates the buffers every method shares and ABA's; DCA's are built by the first DCA
    /// call (see [`Data::ensure_dca`]), so a workspace used only with ABA or CRBA never holds
    /// them.
    pub fn new(model: &Model) -> Data {
        let n = model.bodies.len();
        let nv = model.nv;
        // ABA's slots for children's sums: in pass 2's order (reverse index), a body's slot is
        // taken when its first child is reached and freed when the body is (its sums are read
        // before its parent's are written, so the parent may take the freed slot).
        let (mut acc, mut first) = (vec![u32::MAX; n], vec![false; n]);
        let (mut free, mut acc_slots) = (Vec::new(), 0u32);
        for (i, b) in model.bodies.iter().enumerate().rev() {
            if acc[i] != u32::MAX {
                free.push(acc[i]);
            }
            if let Some(p) = b.parent.filter(|&p| acc[p] == u32::MAX) {
                first[i] = true;
                acc[p] = free.pop().unwrap_or_else(|| {
                    acc_slots += 1;
                    acc_slots - 1
                });
            }
        }
        let acc_slots = acc_slots as usize;
        // ABA pass 3's slots for accelerations: in index order, a body's slot is freed once its
        // last child has read it (a childless body's at once), and the child may take it.
        let mut last = vec![usize::MAX; n];
        for (i, b) in model.bodies.iter().enumerate() {
            if let Some(p) = b.parent {
                last[p] = i;
            }
        }
        let (mut aslot, mut free, mut a_slots) = (vec![0u32; n], Vec::new(), 0u32);
        for (i, b) in model.bodies.iter().enumerate() {
            if let Some(p) = b.parent.filter(|&p| last[p] == i) {
                free.push(aslot[p]);
            }
            aslot[i] = free.pop().unwrap_or_else(|| {
                a_slots += 1;
                a_slots - 1
            });
            if last[i] == usize::MAX {
                free.push(aslot[i]);
            }
        }
        let regularised = regularised(model, true);
        Data {
            gravity: model.gravity,
            refine_floating: true,
            armature: armature_of(model),
            passive: Vec::new(),
            refine_dca: needs_refinement(model, true),
            origin: DVec3::ZERO,
            f_ext_c: Vec::with_capacity(n),
            x: vec![SpatialTransform::IDENTITY; n],
            v: vec![SpatialMotion::ZERO; n],
            c: vec![SpatialMotion::ZERO; n],
            // The masses, which DCA's leaves read here (they set the rest).
            inertia: model
                .bodies
                .iter()
                .map(|b| SpatialInertia {
                    mass: b.inertia.mass,
                    ..SpatialInertia::ZERO
                })
                .collect(),
            s: vec![SpatialMotion::ZERO; nv],
            qdd: vec![0.0; nv],
            momentum_projection: true,
            dca: DcaData::empty(fused_available()),
            fk_plan: model.bodies.iter().map(FkPlan::of).collect(),
            topo: model
                .bodies
                .iter()
                .map(|b| Topo {
                    parent: b.parent.unwrap_or(usize::MAX),
                    vo: b.v_offset,
                    nv: b.nv,
                })
                .collect(),
            refine: RefineData::new(model, regularised),
            aba: AbaData {
                ia: vec![SymMat6::ZERO; acc_slots],
                acc,
                first,
                pa: vec![SpatialForce::ZERO; n],
                u: vec![[0.0; 6]; nv],
                uu: vec![0.0; nv],
                dinv: vec![0.0; model.bodies.iter().map(|b| b.nv * b.nv).sum()],
                doff: model
                    .bodies
                    .iter()
                    .scan(0, |o, b| {
                        let here = *o;
                        *o += b.nv * b.nv;
                        Some(here)
                    })
                    .collect(),
                a: vec![SpatialMotion::ZERO; n.max(a_slots as usize)],
                aslot,
                arm: vec![glam::DVec3::ZERO; n],
                cl: vec![SpatialMotion::ZERO; n],
                sl: vec![SpatialMotion::ZERO; nv],
            },
            rk: RkData {
                q0: vec![0.0; model.nq],
                qd0: vec![0.0; nv],
                kv: vec![0.0; nv],
                ka: vec![0.0; nv],
                theta: vec![0.0; nv],
            },
            quant: QuantityData::default(),
            fingerprint: Fingerprint::of(model),
        }
    }

    /// Builds DCA's buffers if this workspace has not yet run DCA (the first DCA call does it:
    /// [`Data::new`] allocates only what every method shares and ABA's). Calls after the first
    /// allocate nothing. Fails with [`DynamicsError::TooLarge`] when the model's assembly tree
    /// needs indices beyond 32 bits.
    pub fn ensure_dca(&mut self, model: &Model) -> Result<(), DynamicsError> {
        if !self.dca.built {
            self.dca = DcaData::build(model, self.dca.fused, self.dca.clusters, false)?;
        }
        Ok(())
    }

    /// [`Data::ensure_dca`] with the banked layout of the parallel driver (`parallel_dca.rs`):
    /// rebuilds DCA's buffers once if they were laid out for the serial passes only. Returns
    /// whether the layout is banked (a tree with gather nodes or leaf clusters never is).
    pub(crate) fn ensure_dca_banked(&mut self, model: &Model) -> Result<bool, DynamicsError> {
        let bankable = !model.assembly.has_gather() && self.dca.cluster.clustered.is_empty();
        if !self.dca.built || (!self.dca.banked && bankable) {
            self.dca = DcaData::build(
                model,
                self.dca.fused,
                self.dca.clusters,
                !model.assembly.has_gather(),
            )?;
        }
        Ok(self.dca.banked)
    }

    /// The world wrench (about the world origin) of a force `force` (world coordinates) applied
    /// at the point `point` given in body `body`'s coordinates. Needs the kinematics of the
    /// current state (any dynamics call, or [`crate::forward_kinematics`]).
    pub fn point_force(&self, body: usize, point: DVec3, force: DVec3) -> SpatialForce {
        let p = self.x[body].apply_point(point) + self.origin;
        SpatialForce::new(p.cross(force), force)
    }

    /// Runs the DCA pass compiled with fused multiply–adds (`true`, the default where
    /// [`crate::internals::fused_available`]) or the portable compilation (`false`); `true` on
    /// a CPU without AVX2 and FMA is ignored. For comparing the two compilations (tests,
    /// `cargo xtask hash`); returns the compilation now in use (`true`: fused). Needs the
    /// `internals` feature.
    #[cfg(feature = "internals")]
    pub fn set_fused_dca(&mut self, fused: bool) -> bool {
        self.dca.fused = fused && fused_available();
        self.dca.fused
    }

    /// Whether DCA folds the small subtrees below branch points into leaf clusters, solved in
    /// inertia form as ABA solves them (`true`, the default; see `docs/algorithms.md`, *Leaf
    /// clusters*), or runs on the model's own assembly tree (`false`: the same `q̈` to
    /// rounding, with other bits, at the speed DCA had without clusters). DCA's buffers are
    /// rebuilt by the next DCA call.
    pub fn set_leaf_clusters(&mut self, model: &Model, on: bool) {
        if self.dca.clusters != on {
            self.dca = DcaData::empty(self.dca.fused);
            self.dca.clusters = on;
        }
        self.refine_dca = needs_refinement(model, on);
        self.refine.regularised = regularised(model, on);
    }

    /// How many DCA solves on this workspace took a refinement step: with a floating base,
    /// DCA checks its `q̈` against the Newton–Euler residual and corrects it once when the
    /// residual is above rounding level (see `docs/algorithms.md`).
    pub fn refinement_count(&self) -> u64 {
        self.refine.corrections
    }

    /// Per degree of freedom, the armature every solve on this workspace adds to the
    /// joint-space inertia's diagonal: the model's, plus `dt b` after
    /// [`Data::set_damping_step`]. Empty for a model with neither armature nor damping.
    pub fn armature(&self) -> &[f64] {
        &self.armature
    }

    /// Integrates the model's damping `b` implicitly over a step of `dt` in every following
    /// solve: the armature they add to the joint-space inertia becomes the model's plus
    /// `dt b` (MuJoCo's implicit damping: `(M + A + dt B) q̈ = τ + passive(q, q̇)`); `dt = 0`
    /// restores the model's own, to the bit. Nothing changes for a model without damping.
    /// articula's own steps do this around each solve; a stepper of its own (articula-
    /// adaptive's) calls it.
    pub fn set_damping_step(&mut self, model: &Model, dt: f64) {
        let d = &model.dynamics;
        if d.damping.is_empty() {
            return;
        }
        self.armature.resize(model.nv, 0.0);
        for (i, (a, b)) in self.armature.iter_mut().zip(&d.damping).enumerate() {
            *a = d.armature.get(i).copied().unwrap_or(0.0);
            *a += dt * b;
        }
    }

    /// How many `Method::Dca` solves on this workspace were answered by ABA instead, because
    /// DCA could not certify its own answer: its iterative refinement stopped contracting above
    /// the accuracy it promises, or one of its joins was singular to rounding where ABA's
    /// articulated inertias are not (docs/algorithms.md, "When DCA falls back to ABA"). Callers
    /// report it as a warning; the `q̈` returned is ABA's, exact to rounding.
    pub fn fallback_count(&self) -> u64 {
        self.refine.fallbacks
    }
}

impl SlotBuffers {
    /// `slots` zeroed slots.
    fn new(slots: usize) -> SlotBuffers {
        SlotBuffers {
            dg: vec![SymT::ZERO; slots],
            b: vec![SpatialMotion::ZERO; slots],
            f: vec![SpatialForce::ZERO; slots],
        }
    }
}

impl JoinBuffers {
    /// Zeroed: `blocks` cross blocks, `nodes` factors and β (per node), `joins` one-axis
    /// records and `scratch` handles of join scratch.
    fn new(blocks: usize, nodes: usize, joins: usize, scratch: usize) -> JoinBuffers {
        JoinBuffers {
            phi: vec![Mat6::ZERO; blocks],
            l: vec![[[0.0; 6]; 6]; nodes],
            beta: vec![SpatialMotion::ZERO; nodes],
            rev: vec![RevJoin::default(); joins],
            y: vec![[[0.0; 6]; 6]; scratch],
            u: vec![[[0.0; 6]; 6]; scratch],
        }
    }
}

impl DcaData {
    /// DCA's buffers before the first DCA call: none (see [`Data::ensure_dca`]).
    fn empty(fused: bool) -> DcaData {
        DcaData {
            built: false,
            fused,
            clusters: true,
            leaf_kinematics: false,
            prefetch: false,
            banked: false,
            max_h: 0,
            node: Vec::new(),
            hj: Vec::new(),
            from: Vec::new(),
            clamped: 0,
            free_identity: false,
            gather: GatherBuffers::default(),
            cluster: ClusterBuffers::default(),
            slots: SlotBuffers::default(),
            joins: JoinBuffers::default(),
            bodies: BodyBuffers::default(),
        }
    }

    /// Every DCA buffer for `model`, laid out over its assembly tree; `fused` as in
    /// [`DcaData::fused`]. Every index DCA stores is 32-bit: a model whose tree needs more is
    /// refused with [`DynamicsError::TooLarge`]. With `clusters`, DCA's tree folds small
    /// subtrees into leaf clusters (`cluster.rs`). With `banked` (a tree without gather nodes
    /// or leaf clusters: the model's own), the slots and the join scratch are laid out for the
    /// parallel driver ([`crate::banked::banked_slots`]).
    fn build(
        model: &Model,
        fused: bool,
        clusters: bool,
        banked: bool,
    ) -> Result<DcaData, DynamicsError> {
        let n = model.bodies.len();
        let nv = model.nv;
        // DCA's own tree, with leaf clusters (`cluster.rs`).
        let absorbed = absorbed(model, clusters);
        let own = if absorbed.contains(&true) {
            articula_model::AssemblyTree::build_clustered(model, &absorbed)
        } else {
            model.assembly.clone()
        };
        let tree = &own;
        let nn = tree.nodes.len();
        // The shared layout (articula-model), with DCA's sentinel and side type.
        let layout = tree.handle_layout();
        let u = |x: usize| u32::try_from(x).expect("checked against u32::MAX above");
        let from: Vec<(Side, u32)> = layout
            .from
            .iter()
            .map(|&(a, i)| (if a { Side::A } else { Side::B }, u(i)))
            .collect();
        let max_h = tree.max_handles().max(1);
        // Slots of the diagonal blocks and b (see `DcaData::dg`): node x at depth δ, the
        // parent side (0) or child side (1) of its parent's join, has max_h handles at
        // (2 δ + side) max_h.
        let mut side = vec![0usize; nn];
        for node in &tree.nodes {
            if let NodeKind::Join { child_side, .. } = node.kind {
                side[child_side] = 1;
            }
        }
        // A gather's children wait in a slot each (all of them are at one depth and side),
        // ahead of the per-depth slots (a join's slot lies below its children's, which
        // `dca::c_blocks` relies on); `gslot`: their index among the gathered children.
        let mut gslot = vec![usize::MAX; nn];
        for (k, &c) in tree.gathered.iter().enumerate() {
            gslot[c] = k;
        }
        let gathered = tree.gathered.len();
        // Per node its slot index (`2 δ + side`, or the banked one), their count, and per node
        // its join scratch bank and the bank count.
        // The parallel driver walks the model's assembly tree: not DCA's own with clusters.
        let banked = banked && !tree.has_gather() && !absorbed.contains(&true);
        let (si, nsi, ys, nys) = if banked {
            crate::banked::banked_slots(tree, &side)
        } else {
            let si = tree.nodes.iter().zip(&side).map(|(nd, s)| 2 * nd.depth + s);
            (si.collect(), 2 * tree.depth() + 2, vec![0; nn], 1)
        };
        let slots = gathered + nsi * max_h;
        // Every index DCA stores is 32-bit; this bounds them all (node and handle indices and
        // offsets, slots, cross-block offsets).
        let mb = max_h * (max_h - 1) / 2;
        fits_u32(&[
            nn,
            layout.handles,
            n + 1,
            nv,
            slots,
            nsi * mb + layout.blocks,
            nys * max_h,
        ])?;
        // Φ's cross blocks: see `node_records`.
        let slot_of = |i: usize| {
            u(if gslot[i] != usize::MAX {
                gslot[i]
            } else {
                gathered + si[i] * max_h
            })
        };
        let (node, blk, joins) = node_records(model, tree, &layout, slot_of, &si, &ys, mb, nsi);
        let leaf_kinematics = leaf_kinematics_first(model, tree);
        // A cluster body's ABA sums (see `DcaData::cfirst`): the main pass visits a cluster's
        // bodies in reverse index order, so the first of a parent's absorbed children is its
        // last in index order.
        let per_body = if tree.clustered.is_empty() { 0 } else { n };
        let (cfirst, csums) = cluster_firsts(model, tree);
        let mut leaf_full = Vec::new();
        // Light bodies between heavy neighbours: a heavier leaf (`mass_ratio.rs`).
        let scales = crate::mass_ratio::leaf_scales(model);
        let leaf = model
            .bodies
            .iter()
            .zip(&scales)
            .map(|(b, &scale)| {
                LeafConst::of(
                    &b.inertia,
                    regularised_inverse(model, b),
                    scale,
                    &mut leaf_full,
                )
            })
            .collect();
        Ok(DcaData {
            built: true,
            fused,
            clusters,
            prefetch: joins * (std::mem::size_of::<RevJoin>() + std::mem::size_of::<Mat6>())
                > PREFETCH_ABOVE,
            leaf_kinematics,
            banked,
            max_h,
            node,
            hj: tree
                .nodes
                .iter()
                .flat_map(|node| node.handles.iter().map(|&h| u(h)))
                .collect(),
            from,
            clamped: 0,
            free_identity: crate::mass_ratio::large_mass_ratio(model),
            gather: GatherBuffers {
                gathered: tree.gathered.iter().map(|&c| u(c)).collect(),
                gk: vec![Mat6::ZERO; tree.gathered.len()],
            },
            cluster: ClusterBuffers {
                clustered: tree.clustered.iter().map(|&c| u(c)).collect(),
                cfirst,
                csums,
                cia: vec![SymMat6::ZERO; per_body],
                cpa: vec![SpatialForce::ZERO; per_body],
                ca: vec![SpatialMotion::ZERO; per_body],
            },
            slots: SlotBuffers::new(slots),
            joins: JoinBuffers::new(blk, nn, joins, nys * max_h),
            bodies: BodyBuffers {
                leafk: vec![LeafK::default(); n],
                leaf,
                leaf_full,
                point: vec![DVec3::ZERO; n],
                arm: vec![DVec3::ZERO; n],
                trig: if banked {
                    vec![(0.0, 1.0); n]
                } else {
                    Vec::new()
                },
                z: vec![[0.0; 6]; nv],
                dinv: vec![SmallSpd::default(); n],
            },
        })
    }
}

/// One record per node of `tree` (see [`DNode`]): its kind, handle offset and count, its
/// cross blocks' offset, slot (`slot_of`), join index, ja/jb and scratch bank (`ys`); with
/// the cross-block count and the number of joins. Φ: the nh (nh − 1) / 2 cross blocks above
/// the diagonal of each node (the diagonal ones in the slots). A join's stay for the
/// back-substitution, in post-order after the leaves' slots (a leaf's are read by its parent
/// join only: the back-substitution multiplies by a leaf's Φ in closed form, `LeafK`).
#[allow(clippy::too_many_arguments)]
fn node_records(
    model: &Model,
    tree: &articula_model::AssemblyTree,
    layout: &articula_model::HandleLayout,
    slot_of: impl Fn(usize) -> u32,
    si: &[usize],
    ys: &[usize],
    mb: usize,
    nsi: usize,
) -> (Vec<DNode>, usize, usize) {
    let u = |x: usize| u32::try_from(x).expect("checked against u32::MAX");
    let nn = tree.nodes.len();
    let mut blk = nsi * mb;
    let mut joins = 0;
    let mut node = Vec::with_capacity(nn);
    for (i, nd) in tree.nodes.iter().enumerate() {
        let nh = nd.handles.len();
        let slot = slot_of(i);
        let u16_of = |x: usize| u16::try_from(x).expect("more than 65535 handles on a node");
        let (kind, boff, jix, one_dof, damped) = match nd.kind {
            NodeKind::Join {
                joint,
                parent_side,
                child_side,
            } => {
                let at = (blk, joins);
                blk += nh * nh.saturating_sub(1) / 2;
                joins += 1;
                let one_dof = one_dof_join(model, joint);
                let vo = model.bodies[joint].v_offset;
                let damped = model.dynamics.damping.get(vo).is_some_and(|&b| b != 0.0);
                let kind = DKind::Join {
                    joint: u(joint),
                    a: u(parent_side),
                    b: u(child_side),
                };
                (kind, at.0, at.1, one_dof, damped)
            }
            NodeKind::Body(b) => (DKind::Body(u(b)), si[i] * mb, 0, false, false),
            NodeKind::Ground => (DKind::Ground, si[i] * mb, 0, false, false),
            // One handle: no cross blocks.
            NodeKind::Gather { body, first, count } => {
                let kind = DKind::Gather {
                    body: body.map_or(u32::MAX, u),
                    first: u(first),
                    count: u(count),
                };
                (kind, 0, 0, false, false)
            }
            NodeKind::Cluster { body, first, count } => {
                let kind = DKind::Cluster {
                    body: body.map_or(u32::MAX, u),
                    first: u(first),
                    count: u(count),
                };
                (kind, si[i] * mb, 0, false, false)
            }
        };
        node.push(DNode {
            kind,
            hoff: u(layout.hoff[i]),
            nh: u(nh),
            boff: u(boff),
            slot,
            jix: u(jix),
            ja: u16_of(layout.ja[i]),
            jb: u16_of(layout.jb[i]),
            one_dof,
            damped,
            ys: u16_of(ys[i]),
        });
    }
    (node, blk, joins)
}

/// `Err` unless every size in `sizes` fits DCA's 32-bit indices.
fn fits_u32(sizes: &[usize]) -> Result<(), DynamicsError> {
    let largest = sizes.iter().copied().max().unwrap_or(0);
    if largest >= u32::MAX as usize {
        return Err(DynamicsError::TooLarge {
            what: "DCA's workspace (assembly-tree nodes, handles, slots or blocks)",
            size: largest,
            limit: u32::MAX as usize - 1,
        });
    }
    Ok(())
}

/// Whether joint `joint` can take the one-axis join: a single hinge without armature (a
/// joint with armature takes the general join; so does a damped one in a step, where its
/// damping joins the armature: `dca::one_axis`).
fn one_dof_join(model: &Model, joint: usize) -> bool {
    let vo = model.bodies[joint].v_offset;
    matches!(
        model.bodies[joint].joint.as_slice(),
        [p] if p.kind.is_hinge()
    ) && model.dynamics.armature.get(vo).is_none_or(|&a| a == 0.0)
}

/// Whether the main pass can run each body's kinematics at its parent's leaf (the roots' at
/// the ground's) before anything reads it (see `DcaData::leaf_kinematics`).
fn leaf_kinematics_first(model: &Model, tree: &articula_model::AssemblyTree) -> bool {
    let n = model.bodies.len();
    let mut done = vec![false; n];
    tree.nodes.iter().all(|nd| match nd.kind {
        NodeKind::Ground => nd.handles.iter().all(|&h| {
            done[h] = true;
            model.bodies[h].parent.is_none()
        }),
        NodeKind::Body(b) => {
            let ok = done[b];
            for &h in nd.handles.iter().filter(|&&h| h != b) {
                done[h] = true;
            }
            ok
        }
        NodeKind::Join { joint, .. } => done[joint],
        // A gather's children come before its hub (whose pose they need).
        NodeKind::Gather { .. } | NodeKind::Cluster { .. } => false,
    }) && done.iter().all(|&x| x)
}

/// A cluster body's ABA sums (see `DcaData::cfirst`): the main pass visits a cluster's
/// bodies in reverse index order, so the first of a parent's absorbed children is its last
/// in index order. Empty without clusters.
fn cluster_firsts(model: &Model, tree: &articula_model::AssemblyTree) -> (Vec<bool>, Vec<bool>) {
    let per_body = if tree.clustered.is_empty() {
        0
    } else {
        model.bodies.len()
    };
    let mut cfirst = vec![false; per_body];
    let mut csums = vec![false; per_body];
    for &i in tree.clustered.iter().rev() {
        if let Some(p) = model.bodies[i].parent {
            cfirst[i] = !csums[p];
            csums[p] = true;
        }
    }
    (cfirst, csums)
}

impl RkData {
    pub(crate) fn empty() -> RkData {
        RkData {
            q0: Vec::new(),
            qd0: Vec::new(),
            kv: Vec::new(),
            ka: Vec::new(),
            theta: Vec::new(),
        }
    }
}

/// Index of the cross block Φ_hk (h < k) among a node's: only the blocks above the diagonal
/// are stored, row by row (`Φ_kh = Φ_hkᵀ`); the diagonal ones are packed per handle (`dg`).
#[inline(always)]
pub(crate) fn ub(nh: usize, h: usize, k: usize) -> usize {
    debug_assert!(h < k && k < nh);
    // Two handles (a chain's nodes): the one block.
    if nh == 2 {
        return 0;
    }
    h * nh - h * (h + 1) / 2 + (k - h - 1)
}

/// The armature a new [`Data`] starts with: the model's per degree of freedom, zeros where it
/// has none when it has damping (a step adds `h b` there), empty when it has neither.
pub(crate) fn armature_of(model: &Model) -> Vec<f64> {
    let d = &model.dynamics;
    if d.has_armature() {
        d.armature.clone()
    } else if !d.damping.is_empty() {
        vec![0.0; model.nv]
    } else {
        Vec::new()
    }
}

#[cfg(test)]
mod refinement_tests {
    use super::needs_refinement;

    /// The check runs on long floating bases only for every bundled model: their bodies are
    /// well-conditioned, so fixed-base DCA costs and gives what it did.
    #[test]
    fn bundled_fixed_bases_need_no_refinement() {
        for (name, floating_base, model) in crate::bundled_models() {
            let long = model.bodies.len() >= super::REFINE_MIN_BODIES;
            assert_eq!(
                needs_refinement(&model, true),
                floating_base && long,
                "{name}"
            );
        }
    }
}
