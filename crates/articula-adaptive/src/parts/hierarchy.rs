//! The hierarchical state of the hybrid body (docs/design.md#adaptive): the reduced tree of
//! active joints, its articulated-body workspace and the rigid clusters' frames, which a step
//! between re-selections reads instead of the whole assembly tree. The passes that build and
//! read it are in `hierarchy.rs`.

use crate::parts::composites::Rigid;
use articula_spatial::{Mat6, SpatialTransform};
use glam::DVec3;

/// Lists and frames of the current hybrid body. (`repr(C)`: the fields a step between
/// re-selections reads come first, in a few cache lines; see `Adaptive`'s.)
#[derive(Clone, Debug, Default)]
#[repr(C)]
pub(crate) struct Hierarchy {
    /// The reduced tree, one record per active joint in the order of `ajoints` (parents
    /// first): what its kinematics and articulated-body passes read, contiguous.
    pub records: Vec<ActiveJoint>,
    /// Articulated-body workspace of the reduced tree, indexed like `records`.
    pub reduced_aba: ReducedAba,
    /// Per angle of the reduced tree — a closed-form revolute joint's, then each part of a
    /// joint of [`RevoluteParts`], in record order (the kinematics take them in turn) —
    /// its coordinate and sign (`angles`, built with the records) and the `sin`, `cos` of its
    /// signed value (`sin_cos`), computed in a first sweep of `Adaptive::active_kinematics`, four
    /// at a time, so that its main loop makes no call (every vector register is
    /// caller-saved). (`angles` in 8 bytes an angle, the sign `±1` exact in `f32`: a crowd's
    /// bodies run through more data than the 1 MB L2 holds, every byte read per step counts;
    /// `sin_cos` is written and read within one call: a `_with` call takes the scratch's.)
    pub angles: Vec<(u32, f32)>,
    pub sin_cos: Vec<(f64, f64)>,
    /// Active join nodes, then frontier nodes, each ascending (post-order).
    pub hnodes: Vec<usize>,
    pub fnodes: Vec<usize>,
    /// Per body: its joint's [`RevoluteParts`] (built with `axis`).
    pub parts: Vec<Option<RevoluteParts>>,
    /// Builds of the records so far (the reduced tree and the active flags change only with
    /// them), and per body the rigid cluster (frontier node) an external force on it goes to,
    /// with the build it was found in (`(gen, node)`, found on the first force after a build).
    pub gen: u64,
    pub force_cluster: Vec<(u64, usize)>,
    /// The records' degrees of freedom, `Σ k` (what `Adaptive::active_dofs` reports while
    /// `valid`, read once per step by a scene).
    pub dofs: usize,
    /// Built for the current hybrid body (cleared by a re-selection).
    pub valid: bool,
    /// Built by the cached re-selection (lists, clusters' mass properties and parent poses
    /// from the caches).
    pub from_cache: bool,
    /// The active bodies' kinematics in `data` are those of the coming hybrid step's state
    /// (set by a cached re-selection that kept the hybrid body, taken by the step).
    pub kin_fresh: bool,
    /// Per frontier node (rigid cluster): mass properties in its top body's frame.
    pub cluster_mass: Vec<Rigid>,
    /// Bodies whose joints are active, ascending (parents first).
    pub ajoints: Vec<usize>,
    /// Per body: its joint is active.
    pub abody: Vec<bool>,
    /// Per active body: the rigid cluster (frontier node) holding its parent body, or
    /// `usize::MAX` when the parent is an active body or the world; and the parent's pose in the
    /// cluster's top-body frame.
    pub parent_cluster: Vec<usize>,
    pub prel: Vec<SpatialTransform>,
    /// Per active body: its rigid cluster (the frontier node whose top body it is), and the
    /// active body topping the cluster that holds its parent (`usize::MAX`: the world or a
    /// cluster welded to the ground).
    pub own_cluster: Vec<usize>,
    pub parent_top: Vec<usize>,
    /// Per body: `(i, ±1)` for a joint of one revolute part about the coordinate axis `±e_i`
    /// (the usual URDF case, kinematics in closed form), else `None`. Built once per model.
    pub axis: Vec<Option<(usize, f64)>>,
    /// Per body: its record while building them (valid for the active bodies).
    pub ridx: Vec<usize>,
    /// The reduced tree's independent subtrees (built with the records when they are many;
    /// `hierarchy.rs`).
    pub split: crate::parts::subtrees::Subtrees,
}

/// Articulated-body workspace of the reduced tree (one rigid cluster per active joint),
/// indexed like `Hierarchy::records`; per degree of freedom at `records.first_dof()`. The short names are the
/// symbols of the articulated-body algorithm (docs/design.md#adaptive).
#[derive(Clone, Debug, Default)]
pub(crate) struct ReducedAba {
    /// The symbol `Iᴬ`: the cluster's articulated inertia, symmetric, stored whole with both
    /// halves equal to the bit (a [`Mat6`] whose rows are contiguous vectors).
    pub ia: Vec<Mat6>,
    /// The symbol `pᴬ`: the cluster's articulated bias force.
    pub pa: Vec<[f64; 6]>,
    /// The cluster's spatial acceleration.
    pub acceleration: Vec<[f64; 6]>,
    /// The symbol `D⁻¹` of a one-DOF joint.
    pub dinv: Vec<f64>,
    /// The Cholesky factor of `D` of a joint of several DOF.
    pub cholesky: Vec<[[f64; 6]; 6]>,
    /// Per degree of freedom: the symbol `U = Iᴬ s`.
    pub u: Vec<[f64; 6]>,
    /// Per degree of freedom: the symbol `u = τ − sᵀ pᴬ`.
    pub uu: Vec<f64>,
}

impl Hierarchy {
    /// The reduced tree's workspace at least as long as its records need (the
    /// articulated-body passes index it by record and degree of freedom): a shared buffer may
    /// have been sized for another body's reduced tree, and the workspace's own buffers for an
    /// older one of this body.
    #[inline]
    pub(crate) fn fit_reduced(&mut self, full: [usize; 2]) {
        let h = &*self;
        let na = h.records.len();
        let dof = h
            .records
            .last()
            .map_or(0, |r| r.first_dof() + r.dof_count());
        let fits = [
            h.reduced_aba.ia.len(),
            h.reduced_aba.pa.len(),
            h.reduced_aba.acceleration.len(),
            h.reduced_aba.dinv.len(),
            h.reduced_aba.cholesky.len(),
        ]
        .iter()
        .all(|&l| l >= na)
            && h.reduced_aba.u.len() >= dof
            && h.reduced_aba.uu.len() >= dof
            && h.sin_cos.len() >= h.angles.len();
        if !fits {
            self.grow_reduced(na, dof, full);
        }
    }

    #[cold]
    #[inline(never)]
    fn grow_reduced(&mut self, na: usize, dof: usize, [nb, nv]: [usize; 2]) {
        let h = self;
        grow(&mut h.reduced_aba.ia, na, nb, Mat6::ZERO);
        grow(&mut h.reduced_aba.pa, na, nb, [0.0; 6]);
        grow(&mut h.reduced_aba.acceleration, na, nb, [0.0; 6]);
        grow(&mut h.reduced_aba.dinv, na, nb, 0.0);
        grow(&mut h.reduced_aba.cholesky, na, nb, [[0.0; 6]; 6]);
        grow(&mut h.reduced_aba.u, dof, nv, [0.0; 6]);
        grow(&mut h.reduced_aba.uu, dof, nv, 0.0);
        grow(&mut h.sin_cos, h.angles.len(), nv, (0.0, 1.0));
    }
}

/// Grows `v` to at least `need` elements, reserving `full` at the first growth (a later one
/// then allocates nothing).
fn grow<T: Clone>(v: &mut Vec<T>, need: usize, full: usize, x: T) {
    if v.len() < need {
        if v.capacity() < full {
            v.reserve_exact(full - v.len());
        }
        v.resize(need, x);
    }
}

/// Where an active joint's parent body is. (Body indices as `u32`: eight bytes, not 16.)
#[derive(Clone, Copy, Debug)]
pub(crate) enum Parent {
    /// The world (no parent body): the computation frame.
    World,
    /// An active body.
    Active(u32),
    /// A rigid cluster topped by this body, at the record's constant pose in its frame.
    Cluster(u32),
    /// A cluster welded to the ground, at the record's constant pose in the world.
    Ground,
}

/// [`ActiveJoint::pidx`] of a joint whose parent is the world or a cluster welded to it.
pub(crate) const NO_PARENT: usize = u32::MAX as usize;

/// One active joint of the reduced tree. Narrow and line-aligned: indices as `u32`, the
/// axis index as `u8`, so that a record is four 64-byte lines (was 304 bytes, five or six
/// lines) — the indices, parent, flags and axis (all passes 2 and 3 read) in its first line,
/// `fixed_pose` (the kinematics) in the first three, `cluster_mass` (pass 1) in the last two.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct ActiveJoint {
    /// Body, offsets of its coordinates, degrees of freedom, first slot in `u`/`uu` (written by
    /// `Adaptive::build_records`, read through the methods of the same names).
    pub(crate) body: u32,
    pub(crate) q_offset: u32,
    pub(crate) v_offset: u32,
    pub(crate) dof_count: u32,
    pub(crate) first_dof: u32,
    /// Index (in `records`) of the active joint topping the cluster that holds the parent body
    /// ([`NO_PARENT`]: none).
    pub(crate) pidx: u32,
    /// The cluster this joint tops (frontier node).
    pub(crate) cluster: u32,
    pub parent: Parent,
    /// `fixed_pose` is not the identity.
    pub mulx: bool,
    /// `fixed_pose`'s rotation is the identity (a joint origin that only translates, the usual URDF
    /// link): the composition `X x0 = (E, r₀ + r)` costs three additions. (The full product's
    /// `E · 1` and `1ᵀ r` are the same numbers; only the sign of an exact zero may differ.)
    pub shift: bool,
    /// The number of parts of a joint of one or more revolute parts about coordinate axes
    /// ([`RevoluteParts`]) whose coordinates are contiguous (part `p` at `qo + p`, `vo + p`):
    /// the integration updates them as one-axis coordinates. 0 for any other joint.
    pub revs: u8,
    /// `(i, ±1)` of a closed-form revolute joint ([`ActiveJoint::axis`]; an `Option` of the
    /// pair would take 24 bytes). `axis_code` is [`AX_PARTS`] for a joint of [`RevoluteParts`]
    /// (then in `rev_parts`), `u8::MAX` for any other joint.
    pub(crate) axis_code: u8,
    pub(crate) sign: f64,
    pub rev_parts: RevoluteParts,
    /// Constant pose that follows the parent frame: for a closed-form revolute joint its
    /// origin, composed with the parent body's pose in its cluster; for other joints that pose
    /// alone (their origins are applied by the general kinematics).
    pub fixed_pose: SpatialTransform,
    /// The cluster's mass properties in this body's frame.
    pub cluster_mass: Rigid,
}

const _: () = assert!(std::mem::size_of::<ActiveJoint>() == 256);

/// [`ActiveJoint::axis_code`] of a joint of [`RevoluteParts`].
pub(crate) const AX_PARTS: u8 = 0xfe;

impl ActiveJoint {
    #[inline(always)]
    pub fn body(&self) -> usize {
        self.body as usize
    }
    #[inline(always)]
    pub fn q_offset(&self) -> usize {
        self.q_offset as usize
    }
    #[inline(always)]
    pub fn v_offset(&self) -> usize {
        self.v_offset as usize
    }
    #[inline(always)]
    pub fn dof_count(&self) -> usize {
        self.dof_count as usize
    }
    #[inline(always)]
    pub fn first_dof(&self) -> usize {
        self.first_dof as usize
    }
    #[inline(always)]
    pub fn pidx(&self) -> usize {
        self.pidx as usize
    }
    #[inline(always)]
    pub fn cluster(&self) -> usize {
        self.cluster as usize
    }
    /// `(i, ±1)` of a closed-form revolute joint about `±e_i`.
    #[inline(always)]
    pub fn axis(&self) -> Option<(usize, f64)> {
        (self.axis_code < 3).then_some((self.axis_code as usize, self.sign))
    }
    /// The joint's [`RevoluteParts`], if it is made of them.
    #[inline(always)]
    pub fn parts(&self) -> Option<&RevoluteParts> {
        (self.axis_code == AX_PARTS).then_some(&self.rev_parts)
    }
}

/// `(i, ±1)` when `body`'s joint is one revolute part about the coordinate axis `±e_i`.
pub(crate) fn coordinate_axis(body: &articula_model::Body) -> Option<(usize, f64)> {
    let [part] = body.joint.as_slice() else {
        return None;
    };
    part.coordinate_axis()
}

/// The parts of a joint made of revolute parts about coordinate axes (`±x`, `±y`, `±z`, the
/// usual URDF case): per part `(i, ±1)` of its axis `±e_i`, and a bit per part whose origin is
/// not the identity (the massless links of a composed joint often are). `None` for any other
/// joint. (Eight bytes: a copy sits in each composed joint's record, in its first line;
/// per part `i` in bits 0–1 and the sign in bit 7 of one byte.)
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
pub(crate) struct RevoluteParts {
    pub(crate) moved: u8,
    /// A bit per moved part whose origin's rotation is the identity (it only translates).
    pub(crate) shift: u8,
    pub(crate) axes: [u8; 6],
}

impl RevoluteParts {
    /// `(i, ±1)` of part `k`'s axis `±e_i` (the sign `±1.0` chosen by the byte's bit 7).
    #[inline(always)]
    pub(crate) fn axis(&self, k: usize) -> (usize, f64) {
        const SIGNS: [f64; 2] = [1.0, -1.0];
        let b = self.axes[k];
        ((b & 3) as usize, SIGNS[usize::from(b >> 7)])
    }
}

/// `body`'s joint as [`RevoluteParts`], when it is made of them.
pub(crate) fn revolute_parts(body: &articula_model::Body) -> Option<RevoluteParts> {
    let mut axes = [0u8; 6];
    let (mut moved, mut shift) = (0u8, 0u8);
    for (k, part) in body.joint.iter().enumerate() {
        if k >= 6 {
            return None;
        }
        let (i, sign) = part.coordinate_axis()?;
        axes[k] = i as u8 | if sign < 0.0 { 0x80 } else { 0 };
        if part.origin.e != glam::DMat3::IDENTITY || part.origin.r != DVec3::ZERO {
            moved |= 1 << k;
            if part.origin.e == glam::DMat3::IDENTITY {
                shift |= 1 << k;
            }
        }
    }
    Some(RevoluteParts { axes, moved, shift })
}
