//! Caches of rigid subassemblies (docs/design.md#adaptive; the second update mechanism, Redon et
//! al.'s *linear coefficient tensors*).
//!
//! After a re-selection every joint outside the active region is locked (`q̇ = 0`), so a rigid
//! node C has a frozen internal configuration and all its bodies share one spatial velocity.
//! In C's *cache frame* — its top body's frame (the computation frame for a node holding the
//! ground) — its **articulated** coefficients (all its internal joints free, what the metric
//! needs) `Φ^C`, the metric's `Ψ^C` and the back-substitution maps `K`, `N` are constant, and
//! every bias-dependent quantity is linear in the 22 *monomials*
//! `w = [u_a u_b (a ≤ b, 21 of them); 1]` of the top body's spatial velocity `u` (own
//! coordinates): the velocity products `u ×* I_i u` are quadratic in `u`, the locked joints'
//! torques sit in the constant column.
//!
//! ```text
//! b^C_h = B_h w (+ a_g)     k = K_w w     n = N_w w     p^C = P w     η^C = wᵀ E w
//! ```
//!
//! Uniform gravity adds `a_g` to every handle's bias acceleration of a node that does not hold
//! the ground and changes no joint acceleration for given handle forces (it cancels in
//! `β = b^A_j − b^B_j`; tested), so it is left out of the tensors of such nodes and added at
//! evaluation. A node holding the ground has `u = 0`, and its constant column includes gravity.
//!
//! The tensors compose bottom-up with the same linear join as the main pass
//! ([`Adaptive::join`]'s bias maps `κ`, `ν`, applied to the 22 columns), and the metric pass
//! (`P` like `p`; `E` gets `Kwᵀ A Kw + Nwᵀ Ψ_X[jx,jx] Nw ± sym(Nwᵀ P_X,jx) + E_X` per child). A
//! child's tensors, built in its own frame, are carried into the parent's by the rigid motion
//! between the frames: rotations for the vectors (each handle's vectors are about its own
//! point, so only axes change) and the induced 22 × 22 map on monomials for `w`.
//!
//! Each handle's point must be fixed in the rigid node (revolute, continuous and fixed joints
//! whose parts after the first have no offset — every bundled model); otherwise the caches are
//! not used and every re-selection runs whole-body passes.

use crate::adaptive::Adaptive;
use crate::hybrid::rigid_phi;
use crate::parts::caches::{Caches, CONST, M6, NW};
use crate::parts::composites::Rigid;
use articula_dca::DynamicsError;
use articula_model::{Model, NodeKind};
use articula_spatial::numerics::{dot6, Portable};
use articula_spatial::{SpatialForce, SpatialMotion, SpatialTransform};
use glam::{DMat3, DVec3};

/// The monomial index of `u_a u_b`, `a ≤ b`.
const fn mono(a: usize, b: usize) -> usize {
    // Rows a of the upper triangle: 6 + 5 + … before row a.
    a * (11 - a) / 2 + b
}

/// `w(u)`: the 21 products `u_a u_b` (a ≤ b) and 1.
#[inline]
pub(crate) fn monomials(u: SpatialMotion) -> [f64; NW] {
    let u = u.to_array();
    let mut w = [0.0; NW];
    for a in 0..6 {
        for b in a..6 {
            w[mono(a, b)] = u[a] * u[b];
        }
    }
    w[CONST] = 1.0;
    w
}

/// `row · w` over the NW monomials, in two interleaved partial sums.
#[inline(always)]
fn wdot(row: &[f64], w: &[f64; NW]) -> f64 {
    let row: &[f64; NW] = row.try_into().expect("a row of NW");
    let mut acc = [0.0; 2];
    for i in 0..NW / 2 {
        acc[0] += row[2 * i] * w[2 * i];
        acc[1] += row[2 * i + 1] * w[2 * i + 1];
    }
    acc[0] + acc[1]
}

/// `M w` for six rows of NW entries (row-major), a loop rather than `array::from_fn`, whose
/// closure was not inlined.
#[inline(always)]
fn wdot6(rows: &[f64], w: &[f64; NW]) -> [f64; 6] {
    let mut v = [0.0; 6];
    for (x, row) in v.iter_mut().zip(rows.chunks_exact(NW)) {
        *x = wdot(row, w);
    }
    v
}

/// `wᵀ E w` for a symmetric NW × NW `E` (row-major): `(Σ_i w_i E_i) · w`, rows summed as
/// vectors (`wide`: in AVX2 lanes, see [`comb_rows`]).
#[inline(always)]
fn quad_w(e: &[f64], w: &[f64; NW], wide: bool) -> f64 {
    let t = comb_rows(&e[..NW * NW], w, false, wide);
    wdot(&t, w)
}

/// `Σ_i k_i M_i` over the rows `M_i` (NW long, row-major `m`, one per entry of `k`), each entry
/// summed in row order from zero (`t[x] += k_i M_i[x]`); rows whose `k_i` is zero are skipped
/// when `skip_zero`. `wide` (only where the CPU has AVX2: `Adaptive::fused`) takes the same
/// operations in 256-bit lanes written out ([`comb_rows_avx`]): left to the compiler, the
/// 22-long accumulator is vectorised only two lanes at a time (twice the instructions a
/// row).
#[inline(always)]
fn comb_rows(m: &[f64], k: &[f64], skip_zero: bool, wide: bool) -> [f64; NW] {
    assert_eq!(m.len(), k.len() * NW, "one row of NW per coefficient");
    #[cfg(target_arch = "x86_64")]
    if wide {
        // SAFETY: `wide` is `Adaptive::fused`, set only where `articula_spatial::numerics::fused_available()`
        // (the CPU has AVX2 and FMA); `m` holds `k.len()` rows of NW (asserted).
        return unsafe { comb_rows_avx(m, k, skip_zero) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = wide;
    let mut t = [0.0; NW];
    for (row, &ki) in m.chunks_exact(NW).zip(k) {
        if skip_zero && ki == 0.0 {
            continue;
        }
        for (x, &y) in t.iter_mut().zip(row) {
            *x += ki * y;
        }
    }
    t
}

/// [`comb_rows`] in AVX2 lanes: entries 0–19 in five 4-lane accumulators, 20–21 in a 2-lane
/// one; per entry `t + k_i · M_i` (a multiply, then an add: no fused multiply–add, the same
/// bits as the portable loop).
///
/// # Safety
/// The CPU must have AVX2, and `m` must hold `k.len()` rows of NW.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn comb_rows_avx(m: &[f64], k: &[f64], skip_zero: bool) -> [f64; NW] {
    use std::arch::x86_64::*;
    let mut t4 = [_mm256_setzero_pd(); 5];
    let mut t2 = _mm_setzero_pd();
    for (i, &ki) in k.iter().enumerate() {
        if skip_zero && ki == 0.0 {
            continue;
        }
        let row = m.as_ptr().add(i * NW);
        let k4 = _mm256_set1_pd(ki);
        for (c, t) in t4.iter_mut().enumerate() {
            *t = _mm256_add_pd(*t, _mm256_mul_pd(k4, _mm256_loadu_pd(row.add(4 * c))));
        }
        let k2 = _mm_set1_pd(ki);
        t2 = _mm_add_pd(t2, _mm_mul_pd(k2, _mm_loadu_pd(row.add(20))));
    }
    let mut t = [0.0; NW];
    for (c, v) in t4.iter().enumerate() {
        _mm256_storeu_pd(t.as_mut_ptr().add(4 * c), *v);
    }
    _mm_storeu_pd(t.as_mut_ptr().add(20), t2);
    t
}

/// The map `M` with `w(T u) = M w(u)` for a linear map `T` of velocities (6 × 6, row-major),
/// row-major 22 × 22: `(Tu)_a (Tu)_b = Σ_{c≤d} (T_ac T_bd + T_ad T_bc [c<d]) u_c u_d`.
#[inline]
fn monomial_map(t: &[[f64; 6]; 6], m: &mut [f64]) {
    m[..NW * NW].fill(0.0);
    for a in 0..6 {
        for b in a..6 {
            let row = mono(a, b) * NW;
            for c in 0..6 {
                m[row + mono(c, c)] = t[a][c] * t[b][c];
                for d in c + 1..6 {
                    m[row + mono(c, d)] = t[a][c] * t[b][d] + t[a][d] * t[b][c];
                }
            }
        }
    }
    m[CONST * NW + CONST] = 1.0;
}

/// A rotation as rows, `r[i][j]`.
#[inline]
pub(crate) fn rows3(e: &DMat3) -> [[f64; 3]; 3] {
    let t = e.transpose();
    [
        t.x_axis.to_array(),
        t.y_axis.to_array(),
        t.z_axis.to_array(),
    ]
}

/// `blkdiag(r, r) v`.
#[inline]
pub(crate) fn rot6(r: &[[f64; 3]; 3], v: &[f64; 6]) -> [f64; 6] {
    std::array::from_fn(|i| {
        let (o, k) = (3 * (i / 3), i % 3);
        r[k][0] * v[o] + r[k][1] * v[o + 1] + r[k][2] * v[o + 2]
    })
}

#[inline]
pub(crate) fn tr3(r: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| r[j][i]))
}

/// `M ← blkdiag(r, r, …) M` for a row-major `rows × cols` matrix (rows a multiple of 3).
pub(crate) fn left_rot(m: &mut [f64], rows: usize, cols: usize, r: &[[f64; 3]; 3]) {
    if cols == 0 {
        // No handles (the root of a fixed base, rigid at budget 0): nothing to turn.
        return;
    }
    for g in m[..rows * cols].chunks_exact_mut(3 * cols) {
        let (x, rest) = g.split_at_mut(cols);
        let (y, z) = rest.split_at_mut(cols);
        for ((a, b), c) in x.iter_mut().zip(y.iter_mut()).zip(z.iter_mut()) {
            let v = [*a, *b, *c];
            *a = r[0][0] * v[0] + r[0][1] * v[1] + r[0][2] * v[2];
            *b = r[1][0] * v[0] + r[1][1] * v[1] + r[1][2] * v[2];
            *c = r[2][0] * v[0] + r[2][1] * v[1] + r[2][2] * v[2];
        }
    }
}

/// `M ← M blkdiag(rᵀ, rᵀ, …)` (each row's 3-groups rotated by `r`; cols a multiple of 3).
pub(crate) fn right_rot(m: &mut [f64], rows: usize, cols: usize, r: &[[f64; 3]; 3]) {
    for v in m[..rows * cols].chunks_exact_mut(3) {
        let x = [v[0], v[1], v[2]];
        v[0] = r[0][0] * x[0] + r[0][1] * x[1] + r[0][2] * x[2];
        v[1] = r[1][0] * x[0] + r[1][1] * x[1] + r[1][2] * x[2];
        v[2] = r[2][0] * x[0] + r[2][1] * x[1] + r[2][2] * x[2];
    }
}

/// The 6 × 6 matrix (row-major) of `u ↦ X⁻¹ u` for a transform `X`.
#[inline]
fn inv_motion_matrix(x: &SpatialTransform) -> [[f64; 6]; 6] {
    let mut t = [[0.0; 6]; 6];
    for c in 0..6 {
        let mut e = [0.0; 6];
        e[c] = 1.0;
        let col = x.inv_apply_motion(SpatialMotion::from_array(e)).to_array();
        for r in 0..6 {
            t[r][c] = col[r];
        }
    }
    t
}

/// `c = a b` (row-major, `a`: m × r, `b`: r × n).
fn mul(a: &[f64], b: &[f64], m: usize, r: usize, n: usize, c: &mut [f64]) {
    crate::dense::a_b(a, b, m, r, n, c);
}

/// `a b`.
#[inline(always)]
fn m6_mul(a: &M6, b: &M6) -> M6 {
    // Plain loops (`array::from_fn`'s closures were called out of line in AVX2 code); each
    // entry's sum in the order of the iterator sum it replaced (which starts at −0.0, and
    // −0.0 + x = x: the first product).
    let mut o = [[0.0; 6]; 6];
    for (orow, arow) in o.iter_mut().zip(a) {
        for (c, x) in orow.iter_mut().enumerate() {
            let mut acc = arow[0] * b[0][c];
            for s in 1..6 {
                acc += arow[s] * b[s][c];
            }
            *x = acc;
        }
    }
    o
}

/// `aᵀ b`.
#[inline(always)]
fn m6_tmul(a: &M6, b: &M6) -> M6 {
    // As `m6_mul`.
    let mut o = [[0.0; 6]; 6];
    for (r, orow) in o.iter_mut().enumerate() {
        for (c, x) in orow.iter_mut().enumerate() {
            let mut acc = a[0][r] * b[0][c];
            for s in 1..6 {
                acc += a[s][r] * b[s][c];
            }
            *x = acc;
        }
    }
    o
}

/// `blkdiag(r, r) m`.
#[inline]
fn m6_rot(r: &[[f64; 3]; 3], m: &M6) -> M6 {
    let mut o = *m;
    left_rot(o.as_flattened_mut(), 6, 6, r);
    o
}

/// `m v`.
#[inline]
fn m6_x(m: &M6, v: &[f64; 6]) -> [f64; 6] {
    std::array::from_fn(|r| dot6::<Portable>(&m[r], v))
}

/// `J += s aᵀ B` for `a` 6 × 6 and `B` 6 × NW.
#[inline(always)]
fn add_at_b(j: &mut [[f64; NW]; 6], s: f64, a: &M6, b: &[[f64; NW]; 6]) {
    for (c, jr) in j.iter_mut().enumerate() {
        for (r, br) in b.iter().enumerate() {
            let f = s * a[r][c];
            for (x, &y) in jr.iter_mut().zip(br) {
                *x += f * y;
            }
        }
    }
}

/// Row `i` (NW long) of a row-major matrix of NW columns.
#[inline(always)]
fn row(m: &[f64], i: usize) -> &[f64; NW] {
    m[i * NW..(i + 1) * NW].try_into().expect("a row of NW")
}

/// Row `i` of a row-major matrix of NW columns, mutable.
#[inline(always)]
fn row_mut(m: &mut [f64], i: usize) -> &mut [f64; NW] {
    (&mut m[i * NW..(i + 1) * NW])
        .try_into()
        .expect("a row of NW")
}

/// `y += a x` over NW entries.
#[inline(always)]
fn axpy(y: &mut [f64; NW], a: f64, x: &[f64; NW]) {
    for (y, &x) in y.iter_mut().zip(x) {
        *y += a * x;
    }
}

/// Which parts of a cached node an evaluation writes into the workspace's slots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Part {
    /// `Φ` and `b` (the main pass).
    Coefficients,
    /// `Ψ`, `p`, `η` (the metric).
    Metric,
    /// `K`, `k`, `N`, `n` (back-substitution of a popped node).
    Maps,
}

/// A join of a dirty path as the delta and map passes see it ([`Adaptive::dirty_join`]).
/// The own-joint terms of a dirty join's map, shared by its children's
/// ([`Adaptive::join_map`]).
struct JoinMapOwn {
    /// `G_n`: the join force's gain on the dirty child's wrench.
    gdn: M6,
    /// `G_k` rows of the joint (the first `k` used).
    gdk: M6,
    /// `H`, the quadratic term of `Δη`.
    hq: M6,
    /// `J`, the term of `Δη` linear in the wrench and the velocity monomials.
    jw: [[f64; NW]; 6],
    /// `N_w` of the join (6 × NW).
    nw0: [[f64; NW]; 6],
    /// The joint's degrees of freedom.
    k: usize,
    /// The joint's velocity offset.
    vo: usize,
}

#[derive(Clone, Copy)]
struct DirtyJoin {
    joint: usize,
    a: usize,
    b: usize,
    hc: usize,
    nhc: usize,
    nc: usize,
    children: [(usize, usize, f64); 2],
    rel: [[[f64; 3]; 3]; 2],
    xdirty: [bool; 2],
}

impl Adaptive {
    /// Allocates the caches (first use).
    pub(crate) fn cache_alloc(&mut self, model: &Model) {
        if self.cache.allocated {
            return;
        }
        let sizes = [
            self.maps.qdd_gain.len(),
            self.maps.force_gain.len(),
            self.metric.quad.len(),
        ];
        self.cache.allocate(model, &self.coef.layout, sizes);
        let nn = model.assembly.nodes.len();
        // The hierarchy's lists, rebuilt by every cached re-selection, never reallocate.
        let h = &mut self.hier;
        h.hnodes.reserve(nn.saturating_sub(h.hnodes.len()));
        h.fnodes.reserve(nn.saturating_sub(h.fnodes.len()));
        h.ajoints
            .reserve(model.bodies.len().saturating_sub(h.ajoints.len()));
    }

    /// The pose of node `n`'s cache frame in the computation frame from the kinematics in
    /// `data` (its top body's; the computation frame for a node holding the ground).
    pub(crate) fn cache_frame(&self, n: usize) -> SpatialTransform {
        if self.composites.grounded[n] {
            SpatialTransform::xlt(self.data.origin)
        } else {
            self.data.x[self.composites.top_body[n]]
        }
    }

    /// Builds node `n`'s cache from its children's (or, for leaves, their bodies) at the
    /// configuration in `data`, `point` and the articulated slots of the last main and metric
    /// passes (`n`'s own Φ, K, N, Ψ and its children's Φ, Ψ, computation axes): the join is
    /// repeated to record its bias maps, then the 22 bias columns go through it.
    pub(crate) fn build_cache(
        &mut self,
        model: &Model,
        n: usize,
        q: &[f64],
        tau: &[f64],
    ) -> Result<(), DynamicsError> {
        // Also compiled for AVX2 + FMA (the same bits, wider vectors), run when `fused`.
        articula_spatial::fma_dispatch! {
            fn run(this: &mut Adaptive, model: &Model, n: usize, q: &[f64], tau: &[f64]) -> Result<(), DynamicsError>;
            avx2_fma: this.switches.fused, Portable;
            |A| this.build_cache_with(model, n, q, tau)
        }
        run(self, model, n, q, tau)
    }

    #[inline(always)]
    fn build_cache_with(
        &mut self,
        model: &Model,
        n: usize,
        q: &[f64],
        tau: &[f64],
    ) -> Result<(), DynamicsError> {
        let tree = &model.assembly;
        let NodeKind::Join {
            joint,
            parent_side: a,
            child_side: b,
        } = tree.nodes[n].kind
        else {
            return Ok(());
        };
        self.maps.record = true;
        let r = self.join(model, n, tau, crate::hybrid::Level::Acceleration);
        self.maps.record = false;
        r?;
        // Ψ of n and of its children in computation axes (the metric's bias part reads them).
        self.world_metric(model, n);
        let xn = self.cache_frame(n);
        let grounded = self.composites.grounded[n];
        // The children's frames in n's, from the cached poses and the joint's q alone (never
        // from world poses, which would feed the rounding of every rebuild into the next):
        // n's top body is on A's side (parents precede their children), so A's frame is n's,
        // and B's top body is the joint's child, at `hpose_A[ja] · X_J(q)`.
        self.cache.tensors.parent_pose[a] = SpatialTransform::IDENTITY;
        let pa = match tree.nodes[a].kind {
            NodeKind::Join { .. } => {
                self.cache.tensors.handle_pose[self.coef.layout.hoff[a] + self.coef.layout.ja[n]]
            }
            _ => SpatialTransform::IDENTITY,
        };
        let (xj, _, _) = articula_dca::body_kinematics(
            &model.bodies[joint],
            SpatialTransform::IDENTITY,
            SpatialMotion::ZERO,
            q,
            &self.cache.build.zero_velocity,
            &mut self.cache.build.subspace,
        );
        self.cache.tensors.parent_pose[b] = pa * xj;
        // Children's tensors over n's monomials, computation axes.
        for (side, x) in [(0usize, a), (1, b)] {
            let nhx = self.coef.handles[x];
            let rows = 6 * nhx;
            let rel = self.cache.tensors.parent_pose[x];
            let same = x == a && !grounded;
            let xx = xn * rel;
            // u_X = rel⁻¹ u_n (0 for a node holding the ground: nothing moves).
            let t = if grounded {
                [[0.0; 6]; 6]
            } else {
                inv_motion_matrix(&rel)
            };
            let c = &mut self.cache;
            c.build.child_b[side][..rows * NW].fill(0.0);
            c.build.child_p[side][..rows * NW].fill(0.0);
            c.build.child_e[side].fill(0.0);
            match tree.nodes[x].kind {
                NodeKind::Gather { .. } | NodeKind::Cluster { .. } => {
                    unreachable!("adaptive refuses models with gather nodes (`load_state`); `Model::assembly` has no leaf clusters")
                }
                NodeKind::Ground => {}
                NodeKind::Body(_) => {
                    self.leaf_columns(model, x, &xn, &xx, grounded, side);
                }
                NodeKind::Join { .. } => {
                    self.join_child_columns(x, side, &xx, &t, same, grounded);
                }
            }
        }
        self.join_columns(model, n, tau);
        self.store_in_cache_frame(model, n, &xn);
        let c = &mut self.cache;
        c.tensors.node_valid[n] = true;
        c.clock += 1;
        c.tensors.built_at[n] = c.clock;
        Ok(())
    }

    /// The tensors of join child `x` (on `side`, at `xx` in computation axes) over its
    /// parent's monomials: its own (`same`: the parent's frame) or carried by the monomial
    /// map of `t` (`u_X = t u_n`), a_g added when only the parent holds the ground.
    #[inline(always)]
    fn join_child_columns(
        &mut self,
        x: usize,
        side: usize,
        xx: &SpatialTransform,
        t: &[[f64; 6]; 6],
        same: bool,
        grounded: bool,
    ) {
        let nhx = self.coef.handles[x];
        let rows = 6 * nhx;
        let a_g = self.data.gravity;
        let (ho, rx) = (self.coef.layout.hoff[x], rows3(&xx.e));
        let c = &mut self.cache;
        let (bw, pw) = (
            &c.tensors.b_w[ho * 6 * NW..(ho * 6 + rows) * NW],
            &c.tensors.p_w[ho * 6 * NW..(ho * 6 + rows) * NW],
        );
        let e = &c.tensors.e[x * NW * NW..(x + 1) * NW * NW];
        if same {
            c.build.child_b[side][..rows * NW].copy_from_slice(bw);
            c.build.child_p[side][..rows * NW].copy_from_slice(pw);
            c.build.child_e[side].copy_from_slice(e);
        } else {
            monomial_map(t, &mut c.build.monomial_map);
            mul(
                bw,
                &c.build.monomial_map,
                rows,
                NW,
                NW,
                &mut c.build.child_b[side],
            );
            mul(
                pw,
                &c.build.monomial_map,
                rows,
                NW,
                NW,
                &mut c.build.child_p[side],
            );
            // E_X over n's monomials: Mᵀ E M.
            mul(e, &c.build.monomial_map, NW, NW, NW, &mut c.build.product);
            crate::dense::at_b(
                &c.build.monomial_map,
                &c.build.product,
                NW,
                NW,
                NW,
                &mut c.build.child_e[side],
            );
        }
        left_rot(&mut c.build.child_b[side], rows, NW, &rx);
        left_rot(&mut c.build.child_p[side], rows, NW, &rx);
        if grounded && !self.composites.grounded[x] {
            // A child not holding the ground left a_g out of its tensors.
            for h in 0..nhx {
                for r in 0..3 {
                    c.build.child_b[side][(6 * h + 3 + r) * NW + CONST] += a_g[r];
                }
            }
        }
    }

    /// Stores join `n`'s results in its cache frame `xn`: Φ, K, N, Ψ from the slots, the
    /// tensors from the results, the bias maps, the composite and the handles' parent poses.
    #[inline(always)]
    fn store_in_cache_frame(&mut self, model: &Model, n: usize, xn: &SpatialTransform) {
        let tree = &model.assembly;
        let NodeKind::Join {
            joint,
            parent_side: a,
            child_side: b,
        } = tree.nodes[n].kind
        else {
            return;
        };
        let rt = tr3(&rows3(&xn.e));
        let (nh, hc, bc) = (
            self.coef.handles[n],
            self.coef.layout.hoff[n],
            self.coef.layout.boff[n],
        );
        let nc = 6 * nh;
        let k = model.bodies[joint].nv;
        let vo = model.bodies[joint].v_offset;
        let c = &mut self.cache;
        for blk in 0..nh * nh {
            let mut m = self.coef.phi[bc + blk];
            left_rot(m.0.as_flattened_mut(), 6, 6, &rt);
            right_rot(m.0.as_flattened_mut(), 6, 6, &rt);
            c.tensors.phi[bc + blk] = m;
        }
        let ko = self.maps.qdd_gain_at[n];
        c.tensors.k[ko..ko + k * nc].copy_from_slice(&self.maps.qdd_gain[ko..ko + k * nc]);
        right_rot(&mut c.tensors.k[ko..ko + k * nc], k, nc, &rt);
        c.tensors.n[36 * hc..36 * hc + 6 * nc]
            .copy_from_slice(&self.maps.force_gain[36 * hc..36 * hc + 6 * nc]);
        left_rot(&mut c.tensors.n[36 * hc..36 * hc + 6 * nc], 6, nc, &rt);
        right_rot(&mut c.tensors.n[36 * hc..36 * hc + 6 * nc], 6, nc, &rt);
        let po = self.metric.quad_at[n];
        c.tensors.psi[po..po + nc * nc].copy_from_slice(&self.metric.quad[po..po + nc * nc]);
        left_rot(&mut c.tensors.psi[po..po + nc * nc], nc, nc, &rt);
        right_rot(&mut c.tensors.psi[po..po + nc * nc], nc, nc, &rt);
        left_rot(&mut c.build.out_b[..nc * NW], nc, NW, &rt);
        c.tensors.b_w[hc * 6 * NW..(hc * 6 + nc) * NW].copy_from_slice(&c.build.out_b[..nc * NW]);
        left_rot(&mut c.build.out_p[..nc * NW], nc, NW, &rt);
        c.tensors.p_w[hc * 6 * NW..(hc * 6 + nc) * NW].copy_from_slice(&c.build.out_p[..nc * NW]);
        left_rot(&mut c.build.out_n_w[..6 * NW], 6, NW, &rt);
        c.tensors.n_w[n * 6 * NW..(n + 1) * 6 * NW].copy_from_slice(&c.build.out_n_w[..6 * NW]);
        c.tensors.k_w[vo * NW..(vo + k) * NW].copy_from_slice(&c.build.out_k_w[..k * NW]);
        c.tensors.e[n * NW * NW..(n + 1) * NW * NW].copy_from_slice(&c.build.out_e);
        // κ_β R, κ_Q, Rᵀ ν_β R, Rᵀ ν_Q: the maps from cache-frame β to k and n.
        let mut jm = self.maps.recorded;
        right_rot(jm.kappa_beta.as_flattened_mut(), 6, 6, &rt);
        left_rot(jm.nu_beta.as_flattened_mut(), 6, 6, &rt);
        right_rot(jm.nu_beta.as_flattened_mut(), 6, 6, &rt);
        left_rot(jm.nu_q.as_flattened_mut(), 6, 6, &rt);
        c.tensors.bias_maps[n] = jm;
        // Composite and the poses of the handles' parent bodies, in n's frame (`rel` maps a
        // child's coordinates to n's).
        let into = |r: &Rigid, rel: &SpatialTransform| Rigid {
            mass: r.mass,
            com: rel.apply_point(r.com),
            inertia: rel.e * r.inertia * rel.e.transpose(),
        };
        let ra = into(&c.tensors.composite[a], &c.tensors.parent_pose[a]);
        let rb = into(&c.tensors.composite[b], &c.tensors.parent_pose[b]);
        c.tensors.composite[n] = ra.combine(&rb);
        for h in 0..nh {
            let (from_a, i) = self.coef.layout.from[hc + h];
            let x = if from_a { a } else { b };
            c.tensors.handle_pose[hc + h] = match tree.nodes[x].kind {
                NodeKind::Join { .. } => {
                    c.tensors.parent_pose[x] * c.tensors.handle_pose[self.coef.layout.hoff[x] + i]
                }
                _ => c.tensors.parent_pose[x],
            };
        }
    }

    /// The bias columns of leaf `x` (body `i`) over the monomials of its parent's velocity
    /// `u` (parent frame `xn`; `u = 0` when the parent holds the ground): with the body's
    /// world velocity `v = Xn u`, its velocity-product force `−v ×* I v` is bilinear,
    /// `F(x, y) = [−ω_x × I_c ω_y; −m ω_x × y_c]` at the centre of mass, and the handle bias is
    /// the rigid response `b_h = [J n_c; f/m + J n_c × (P_h − c)]` (`rigid_coefficients`).
    fn leaf_columns(
        &mut self,
        model: &Model,
        x: usize,
        xn: &SpatialTransform,
        xi: &SpatialTransform,
        grounded: bool,
        side: usize,
    ) {
        let NodeKind::Body(i) = model.assembly.nodes[x].kind else {
            unreachable!("leaf_columns() on a join or the ground")
        };
        let bi = &model.bodies[i].inertia;
        let (m, c) = (bi.mass, xi.apply_point(bi.com()));
        let ic = xi.e * bi.inertia_about_com() * xi.e.transpose();
        let j = ic.inverse();
        let cols: [SpatialMotion; 6] = std::array::from_fn(|k| {
            if grounded {
                SpatialMotion::ZERO
            } else {
                let mut e = [0.0; 6];
                e[k] = 1.0;
                xn.apply_motion(SpatialMotion::from_array(e))
            }
        });
        let bil = |x: &SpatialMotion, y: &SpatialMotion| {
            let yc = y.v + y.w.cross(c);
            (-x.w.cross(ic * y.w), -(x.w.cross(yc)) * m)
        };
        let handles = &model.assembly.nodes[x].handles;
        let out = &mut self.cache.build.child_b[side];
        let a_g = self.data.gravity;
        for a in 0..6 {
            for bb in a..6 {
                let (mut nc, mut f) = bil(&cols[a], &cols[bb]);
                if bb != a {
                    let (n2, f2) = bil(&cols[bb], &cols[a]);
                    nc += n2;
                    f += f2;
                }
                let aw = j * nc;
                let ac = f / m;
                for (h, &jh) in handles.iter().enumerate() {
                    let lin = ac + aw.cross(self.coef.point[jh] - c);
                    let col = mono(a, bb);
                    for r in 0..3 {
                        out[(6 * h + r) * NW + col] = aw[r];
                        out[(6 * h + 3 + r) * NW + col] = lin[r];
                    }
                }
            }
        }
        if grounded {
            for h in 0..handles.len() {
                for r in 0..3 {
                    out[(6 * h + 3 + r) * NW + CONST] = a_g[r];
                }
            }
        }
    }

    /// The bias part of the join of node `n` and of its metric, on the NW monomial columns at
    /// once (computation axes): the children's bias columns in `build.child_b[0]` (A),
    /// `build.child_b[1]` (B), their `P` columns in `build.child_p`, their `E` in
    /// `build.child_e`; the joint torques enter the constant column. With
    /// the join's maps `maps.recorded`, `G_F` (`scratch.g_force`), `K`, `N` and the children's
    /// Ψ from the slots:
    /// `β = B^A_j − B^B_j`, `k = κ_β β + κ_Q Q`, `n = ν_β β + ν_Q Q`,
    /// `B^C_h = B^X_h − G_F,hᵀ n` (into `build.out_b`, `build.out_k_w`, `build.out_n_w`),
    /// `P^C = 2 Kᵀ A k + Σ_X [Nᵀ s u_jx + u_i on the shared handles]` with
    /// `u_jx = 2 s Ψ_X[jx,jx] n + P_X,jx`, `u_i = P_X,i + 2 s Ψ_X[i,jx] n` (into
    /// `build.out_p`), and
    /// `E^C = k_wᵀ A k_w + Σ_X [E_X + n_wᵀ Ψ_X[jx,jx] n_w + s sym(n_wᵀ P_X,jx)]` (into
    /// `build.out_e`).
    ///
    /// Every product is a sum of rank-one updates of whole NW-long rows (`axpy`), which the
    /// compiler vectorises along the columns (in AVX2 lanes within `build_cache`'s AVX2
    /// compilation).
    #[inline(always)]
    fn join_columns(&mut self, model: &Model, n: usize, tau: &[f64]) {
        let tree = &model.assembly;
        let NodeKind::Join {
            joint,
            parent_side: a,
            child_side: b,
        } = tree.nodes[n].kind
        else {
            unreachable!("join_columns() on a leaf")
        };
        let body = &model.bodies[joint];
        let (vo, k) = (body.v_offset, body.nv);
        let (ja, jb) = (self.coef.layout.ja[n], self.coef.layout.jb[n]);
        let (nhc, hc) = (self.coef.handles[n], self.coef.layout.hoff[n]);
        let ncc = 6 * nhc;
        let jm = self.maps.recorded;
        let c = &mut self.cache;
        // β, then k_w = κ_β β (+ κ_Q τ in the constant column), n_w likewise.
        let mut beta = [[0.0; NW]; 6];
        for (r, br) in beta.iter_mut().enumerate() {
            let (xa, xb) = (
                row(&c.build.child_b[0], 6 * ja + r),
                row(&c.build.child_b[1], 6 * jb + r),
            );
            for ((x, &p), &q) in br.iter_mut().zip(xa).zip(xb) {
                *x = p - q;
            }
        }
        let mut kw = [[0.0; NW]; 6];
        for p in 0..k {
            for r in 0..6 {
                axpy(&mut kw[p], jm.kappa_beta[p][r], &beta[r]);
            }
            for qq in 0..k {
                kw[p][CONST] += jm.kappa_q[p][qq] * tau[vo + qq];
            }
            row_mut(&mut c.build.out_k_w, p).copy_from_slice(&kw[p]);
        }
        let mut nw = [[0.0; NW]; 6];
        for s in 0..6 {
            for r in 0..6 {
                axpy(&mut nw[s], jm.nu_beta[s][r], &beta[r]);
            }
            for qq in 0..k {
                nw[s][CONST] += jm.nu_q[s][qq] * tau[vo + qq];
            }
            row_mut(&mut c.build.out_n_w, s).copy_from_slice(&nw[s]);
        }
        // B^C_h = B^X_i − G_F,hᵀ n.
        for h in 0..nhc {
            let (from_a, i) = self.coef.layout.from[hc + h];
            let side = usize::from(!from_a);
            let g = &self.scratch.g_force[h].0;
            for r in 0..6 {
                let mut x = *row(&c.build.child_b[side], 6 * i + r);
                for s in 0..6 {
                    axpy(&mut x, -g[s][r], &nw[s]);
                }
                *row_mut(&mut c.build.out_b, 6 * h + r) = x;
            }
        }
        // P^C: own joint 2 Kᵀ A k; E^C: own joint k_wᵀ A k_w.
        let (ko, wo) = (self.maps.qdd_gain_at[n], self.metric.weight_at[joint]);
        let kmat = &self.maps.qdd_gain[ko..ko + k * ncc];
        let aw = &self.metric.accel_weights[wo..wo + k * k];
        let mut akw = [[0.0; NW]; 6];
        for p in 0..k {
            for q in 0..k {
                axpy(&mut akw[p], aw[p * k + q], &kw[q]);
            }
        }
        for i in 0..ncc {
            let mut x = [0.0; NW];
            for p in 0..k {
                axpy(&mut x, 2.0 * kmat[p * ncc + i], &akw[p]);
            }
            *row_mut(&mut c.build.out_p, i) = x;
        }
        for r in 0..NW {
            let mut x = [0.0; NW];
            for p in 0..k {
                axpy(&mut x, kw[p][r], &akw[p]);
            }
            *row_mut(&mut c.build.out_e, r) = x;
        }
        let nm = &self.maps.force_gain[36 * hc..36 * hc + 6 * ncc];
        for (side, x, jx, sign) in [(0usize, a, ja, -1.0), (1, b, jb, 1.0)] {
            let nx = 6 * self.coef.handles[x];
            let po = self.metric.quad_at[x];
            let psix = &self.metric.quad[po..po + nx * nx];
            let ps = |r: usize, t: usize| psix[r * nx + t];
            // ψn = Ψ_X[jx,jx] n (6 × NW), P_X,jx (6 × NW).
            let mut psin = [[0.0; NW]; 6];
            let mut pj = [[0.0; NW]; 6];
            for r in 0..6 {
                for t in 0..6 {
                    axpy(&mut psin[r], ps(6 * jx + r, 6 * jx + t), &nw[t]);
                }
                pj[r] = *row(&c.build.child_p[side], 6 * jx + r);
            }
            // P^C += Nᵀ (s u_jx), u_jx = 2 s ψn + P_X,jx.
            for t in 0..6 {
                let mut su = [0.0; NW];
                for ((v, &p), &q) in su.iter_mut().zip(&psin[t]).zip(&pj[t]) {
                    *v = sign * (2.0 * sign * p + q);
                }
                for i in 0..ncc {
                    axpy(row_mut(&mut c.build.out_p, i), nm[t * ncc + i], &su);
                }
            }
            // Shared handles: u_i = P_X,i + 2 s Ψ_X[i,jx] n.
            for h in 0..nhc {
                let (from_a, i) = self.coef.layout.from[hc + h];
                if usize::from(!from_a) != side {
                    continue;
                }
                for r in 0..6 {
                    let mut u = *row(&c.build.child_p[side], 6 * i + r);
                    for t in 0..6 {
                        axpy(&mut u, 2.0 * sign * ps(6 * i + r, 6 * jx + t), &nw[t]);
                    }
                    let o = row_mut(&mut c.build.out_p, 6 * h + r);
                    for (y, v) in o.iter_mut().zip(u) {
                        *y += v;
                    }
                }
            }
            // E^C += E_X + n_wᵀ Ψ_X[jx,jx] n_w + s sym(n_wᵀ P_X,jx): row r gets
            // Σ_t n_w[t][r] (ψn_t + s/2 P_t) + (s/2) P_t[r] n_w[t].
            let mut g = [[0.0; NW]; 6];
            for t in 0..6 {
                for ((v, &p), &q) in g[t].iter_mut().zip(&psin[t]).zip(&pj[t]) {
                    *v = p + 0.5 * sign * q;
                }
            }
            for r in 0..NW {
                let mut x = *row(&c.build.child_e[side], r);
                for t in 0..6 {
                    axpy(&mut x, nw[t][r], &g[t]);
                    axpy(&mut x, 0.5 * sign * pj[t][r], &nw[t]);
                }
                let o = row_mut(&mut c.build.out_e, r);
                for (y, v) in o.iter_mut().zip(x) {
                    *y += v;
                }
            }
        }
    }

    /// Evaluates node `n`'s cache at the pose `x` of its frame and its top body's velocity `u`
    /// (own coordinates; 0 for a node holding the ground) into the workspace's slots,
    /// computation axes: `Φ = R Φ⁰ Rᵀ`, `b_h = R B_h w + a_g`; or `Ψ = R Ψ⁰ Rᵀ`, `p = R P w`,
    /// `η = wᵀ E w`; or `K = K⁰ Rᵀ`, `k = K_w w`, `N = R N⁰ Rᵀ`, `n = R N_w w`
    /// (`R = blkdiag(E, E, …)` of the frame's axes).
    pub(crate) fn eval_cache(
        &mut self,
        model: &Model,
        n: usize,
        x: &SpatialTransform,
        u: SpatialMotion,
        part: Part,
    ) {
        // Also compiled for AVX2 + FMA (the same bits, wider vectors), run when `fused`.
        articula_spatial::fma_dispatch! {
            fn run(this: &mut Adaptive, model: &Model, n: usize, x: &SpatialTransform, u: SpatialMotion, part: Part);
            avx2_fma: this.switches.fused, Portable;
            |A| this.eval_cache_with(model, n, x, u, part)
        }
        run(self, model, n, x, u, part)
    }

    #[inline(always)]
    fn eval_cache_with(
        &mut self,
        model: &Model,
        n: usize,
        x: &SpatialTransform,
        u: SpatialMotion,
        part: Part,
    ) {
        let w = monomials(u);
        let r = rows3(&x.e);
        let (nh, hc, bc) = (
            self.coef.handles[n],
            self.coef.layout.hoff[n],
            self.coef.layout.boff[n],
        );
        let nc = 6 * nh;
        let c = &self.cache;
        let wdot = |row: &[f64]| wdot(row, &w);
        match part {
            Part::Coefficients => {
                for blk in 0..nh * nh {
                    let mut m = c.tensors.phi[bc + blk];
                    left_rot(m.0.as_flattened_mut(), 6, 6, &r);
                    right_rot(m.0.as_flattened_mut(), 6, 6, &r);
                    self.coef.phi[bc + blk] = m;
                }
                let a_g = if self.composites.grounded[n] {
                    DVec3::ZERO
                } else {
                    self.data.gravity
                };
                for h in 0..nh {
                    let o = (hc + h) * 6 * NW;
                    let mut v = wdot6(&c.tensors.b_w[o..o + 6 * NW], &w);
                    left_rot(&mut v, 6, 1, &r);
                    self.coef.bias[hc + h] =
                        SpatialMotion::from_array(v) + SpatialMotion::new(DVec3::ZERO, a_g);
                }
            }
            Part::Metric => {
                let po = self.metric.quad_at[n];
                let psi = &mut self.metric.quad[po..po + nc * nc];
                psi.copy_from_slice(&c.tensors.psi[po..po + nc * nc]);
                left_rot(psi, nc, nc, &r);
                right_rot(psi, nc, nc, &r);
                let pv = &mut self.metric.linear[6 * hc..6 * hc + nc];
                let o = hc * 6 * NW;
                for (row, p) in pv.iter_mut().enumerate() {
                    *p = wdot(&c.tensors.p_w[o + row * NW..o + row * NW + NW]);
                }
                left_rot(pv, nc, 1, &r);
                let e = &c.tensors.e[n * NW * NW..(n + 1) * NW * NW];
                self.metric.constant[n] = quad_w(e, &w, self.switches.fused);
                self.cache.reselection.metric_stamp[n] = self.cache.reselection.epoch;
            }
            Part::Maps => {
                let NodeKind::Join { joint, .. } = model.assembly.nodes[n].kind else {
                    return;
                };
                let body = &model.bodies[joint];
                let (vo, k) = (body.v_offset, body.nv);
                let ko = self.maps.qdd_gain_at[n];
                let km = &mut self.maps.qdd_gain[ko..ko + k * nc];
                km.copy_from_slice(&c.tensors.k[ko..ko + k * nc]);
                right_rot(km, k, nc, &r);
                for p in 0..k {
                    self.maps.qdd_bias[vo + p] =
                        wdot(&c.tensors.k_w[(vo + p) * NW..(vo + p + 1) * NW]);
                }
                let nm = &mut self.maps.force_gain[36 * hc..36 * hc + 6 * nc];
                nm.copy_from_slice(&c.tensors.n[36 * hc..36 * hc + 6 * nc]);
                left_rot(nm, 6, nc, &r);
                right_rot(nm, 6, nc, &r);
                let mut nv = wdot6(&c.tensors.n_w[n * 6 * NW..(n + 1) * 6 * NW], &w);
                left_rot(&mut nv, 6, 1, &r);
                self.maps.force_bias[n] = nv;
            }
        }
    }

    /// What the external forces on a dirty leaf add to its bias (its cache frame's axes):
    /// with its composite at `reselection.frame_pose` and the wrench `f_e` (computation frame, about its origin),
    /// `α = I_c⁻¹ (n_e − c × f_e)`, `Δb_h = [α; f_e/m + α × (P_h − c)]` — the force terms of
    /// [`Adaptive::rigid_coefficients`] (its velocity terms are in the cache).
    pub(crate) fn leaf_delta(&mut self, model: &Model, n: usize, fe: SpatialForce) {
        let x = self.cache.reselection.frame_pose[n];
        let r = self.cache.tensors.composite[n];
        let c = x.apply_point(r.com);
        let ic = x.e * r.inertia * x.e.transpose();
        let alpha = ic.inverse() * (fe.n - c.cross(fe.f));
        let a_c = fe.f / r.mass;
        let rt = tr3(&rows3(&x.e));
        let ho = self.coef.layout.hoff[n];
        for (h, &jh) in model.assembly.nodes[n].handles.iter().enumerate() {
            let bh = SpatialMotion::new(alpha, a_c + alpha.cross(self.coef.point[jh] - c));
            self.cache.dirty.delta_b[ho + h] = rot6(&rt, &bh.to_array());
        }
    }

    /// `Φ^X_{jx,i}ᵀ v` of a leaf child `x` of a dirty node (computation axes): its rigid block
    /// at its pose and handle points (the ground's is 0).
    fn leaf_phi_t(&self, model: &Model, x: usize, jx: usize, i: usize, v: &[f64; 6]) -> [f64; 6] {
        let NodeKind::Body(_) = model.assembly.nodes[x].kind else {
            return [0.0; 6];
        };
        let xf = self.cache.reselection.frame_pose[x];
        let r = self.cache.tensors.composite[x];
        let ic = xf.e * r.inertia * xf.e.transpose();
        let hs = &model.assembly.nodes[x].handles;
        let g = rigid_phi(
            r.mass,
            xf.apply_point(r.com),
            ic.inverse(),
            self.coef.point[hs[jx]],
            self.coef.point[hs[i]],
        );
        std::array::from_fn(|col| (0..6).map(|s| g.0[s][col] * v[s]).sum())
    }

    /// What [`Adaptive::dirty_delta`] and [`Adaptive::join_map`] read of join `n` of a dirty
    /// path (`None` for a leaf): its joint and children `a` (parent side) and `b`, its
    /// handles' offset and count (`nc = 6 nh` columns), each child as `(node, handle of the
    /// joint in it, sign)`, each child's frame rotation (rows) and whether the child is dirty
    /// in this epoch.
    fn dirty_join(&self, model: &Model, n: usize) -> Option<DirtyJoin> {
        let NodeKind::Join {
            joint,
            parent_side: a,
            child_side: b,
        } = model.assembly.nodes[n].kind
        else {
            return None;
        };
        let ep = self.cache.reselection.epoch;
        let (hc, nhc) = (self.coef.layout.hoff[n], self.coef.handles[n]);
        let (ja, jb) = (self.coef.layout.ja[n], self.coef.layout.jb[n]);
        Some(DirtyJoin {
            joint,
            a,
            b,
            hc,
            nhc,
            nc: 6 * nhc,
            children: [(a, ja, -1.0), (b, jb, 1.0)],
            rel: [a, b].map(|x| rows3(&self.cache.tensors.parent_pose[x].e)),
            xdirty: [a, b].map(|x| self.cache.dirty.dirty_stamp[x] == ep),
        })
    }

    /// What the external forces add to a dirty join `n`'s force-dependent values, from its
    /// children's (0 for a clean child), in n's cache frame: its configuration and velocity
    /// are those of its cache, so `Φ`, `K`, `N`, `Ψ` and the force-free `b`, `k`, `n`, `p`,
    /// `η` come from the cache, and only the bias maps carry the forces' part (all linear in
    /// it, `η` quadratic). A child's values are in its own cache frame, turned into n's by
    /// its relative pose's rotation `R_X` (`rel`). With `Δβ = Δb^A_j − Δb^B_j`:
    /// `Δk = κ_β Δβ`, `Δn = ν_β Δβ`, `Δb_h = Δb^X_i ∓ Φ^X_{j,i}ᵀ Δn`; the metric's bias part
    /// of [`Adaptive::metric_pass`] differenced at `k = k₀ + Δk`, `n = n₀ + Δn`,
    /// `p_X = p_X₀ + Δp_X` (`m_X = s n` on X's handle `j`):
    /// ```text
    /// Δp = 2 Kᵀ A Δk + Σ_X [s Nᵀ (2 s Ψ_X[j,j] Δn + Δp_X,j)  on C's rows,
    ///                        Δp_X,i + 2 s Ψ_X[i,j] Δn        on shared handles i]
    /// Δη = k₀ᵀAΔk + ΔkᵀAk₀ + ΔkᵀAΔk + Σ_X [Δη_X + 2 n₀ᵀΨ_X[j,j]Δn + ΔnᵀΨ_X[j,j]Δn
    ///                                    + s (Δnᵀ p_X₀,j + n₀ᵀ Δp_X,j + Δnᵀ Δp_X,j)]
    /// ```
    /// O(1) per node: no cached matrix rotated, no clean child evaluated (a clean join
    /// child: `Ψ_X[·,j]` and the six rows of `P_X,j` read from its cache).
    pub(crate) fn dirty_delta(&mut self, model: &Model, n: usize) {
        let Some(dj) = self.dirty_join(model, n) else {
            return;
        };
        let DirtyJoin {
            joint,
            hc,
            nc,
            children,
            rel,
            xdirty,
            ..
        } = dj;
        // Δβ = Δb^A_ja − Δb^B_jb.
        let mut beta = [0.0; 6];
        for (side, &(x, jx, sign)) in children.iter().enumerate() {
            if xdirty[side] {
                let d = rot6(
                    &rel[side],
                    &self.cache.dirty.delta_b[self.coef.layout.hoff[x] + jx],
                );
                for (bv, dv) in beta.iter_mut().zip(d) {
                    *bv -= sign * dv;
                }
            }
        }
        let body = &model.bodies[joint];
        let (vo, k) = (body.v_offset, body.nv);
        let jm = &self.cache.tensors.bias_maps[n];
        let dn: [f64; 6] = std::array::from_fn(|s| dot6::<Portable>(&jm.nu_beta[s], &beta));
        let mut dk = [0.0; 6];
        for p in 0..k {
            dk[p] = dot6::<Portable>(&jm.kappa_beta[p], &beta);
        }
        self.cache.dirty.delta_k[vo..vo + k].copy_from_slice(&dk[..k]);
        self.cache.dirty.delta_n[n] = dn;
        let wd = monomials(self.cache.reselection.frame_velocity[n]);
        // Own joint: Δp = 2 Kᵀ A Δk, Δη = k₀ᵀAΔk + ΔkᵀAk₀ + ΔkᵀAΔk.
        let mut k0 = [0.0; 6];
        for p in 0..k {
            k0[p] = wdot(&self.cache.tensors.k_w[(vo + p) * NW..][..NW], &wd);
        }
        let wo = self.metric.weight_at[joint];
        let aw = &self.metric.accel_weights[wo..wo + k * k];
        let (mut adk, mut ak0) = ([0.0; 6], [0.0; 6]);
        crate::dense::a_x(aw, &dk[..k], k, k, &mut adk);
        crate::dense::a_x(aw, &k0[..k], k, k, &mut ak0);
        let mut deta: f64 = (0..k)
            .map(|p| (k0[p] + dk[p]) * adk[p] + dk[p] * ak0[p])
            .sum();
        let ko = self.maps.qdd_gain_at[n];
        let km = &self.cache.tensors.k[ko..ko + k * nc];
        let dp = &mut self.cache.dirty.delta_p[6 * hc..6 * hc + nc];
        for (i, d) in dp.iter_mut().enumerate() {
            *d = 2.0 * (0..k).map(|p| km[p * nc + i] * adk[p]).sum::<f64>();
        }
        // n₀ (only a join child's metric reads it).
        let n0: [f64; 6] = if children
            .iter()
            .any(|c| matches!(model.assembly.nodes[c.0].kind, NodeKind::Join { .. }))
        {
            std::array::from_fn(|row| {
                wdot(&self.cache.tensors.n_w[(n * 6 + row) * NW..][..NW], &wd)
            })
        } else {
            [0.0; 6]
        };
        let mut sdu = [0.0; 6];
        for (side, &(x, ..)) in children.iter().enumerate() {
            if let NodeKind::Join { .. } = model.assembly.nodes[x].kind {
                deta += self.dirty_delta_join_side(&dj, side, &dn, &n0, &mut sdu);
            } else {
                self.dirty_delta_leaf_side(model, n, &dj, side, &dn);
            }
        }
        // Δp += Nᵀ Σ_X s Δu_jx.
        let nm = &self.cache.tensors.n[36 * hc..36 * hc + 6 * nc];
        let dp = &mut self.cache.dirty.delta_p[6 * hc..6 * hc + nc];
        for (t, &w) in sdu.iter().enumerate() {
            for (d, &nv) in dp.iter_mut().zip(&nm[t * nc..t * nc + nc]) {
                *d += w * nv;
            }
        }
        self.cache.dirty.delta_eta[n] = deta;
    }

    /// Leaf child on `side` of dirty join `n` (Ψ, p, η are 0): its shared handles' Δb through
    /// its rigid block, in computation axes.
    #[inline(always)]
    fn dirty_delta_leaf_side(
        &mut self,
        model: &Model,
        n: usize,
        dj: &DirtyJoin,
        side: usize,
        dn: &[f64; 6],
    ) {
        let DirtyJoin {
            hc,
            nhc,
            children,
            rel,
            xdirty,
            ..
        } = *dj;
        let (x, jx, sign) = children[side];
        let hx = self.coef.layout.hoff[x];
        let r = &rel[side];
        let rd = rows3(&self.cache.reselection.frame_pose[n].e);
        let dnw = rot6(&rd, dn);
        for h in 0..nhc {
            let (from_a, i) = self.coef.layout.from[hc + h];
            if from_a != (side == 0) {
                continue;
            }
            let g = self.leaf_phi_t(model, x, jx, i, &dnw);
            let mut bh = rot6(&tr3(&rd), &g);
            let own = if xdirty[side] {
                rot6(r, &self.cache.dirty.delta_b[hx + i])
            } else {
                [0.0; 6]
            };
            for (bv, ov) in bh.iter_mut().zip(own) {
                *bv = ov + sign * *bv;
            }
            self.cache.dirty.delta_b[hc + h] = bh;
        }
    }

    /// Join child on `side` of a dirty join (Δn, n₀ of the join): its shared handles' Δp and
    /// Δb, its `s Δu_jx` added to `sdu`; returns its share of Δη.
    #[inline(always)]
    fn dirty_delta_join_side(
        &mut self,
        dj: &DirtyJoin,
        side: usize,
        dn: &[f64; 6],
        n0: &[f64; 6],
        sdu: &mut [f64; 6],
    ) -> f64 {
        let DirtyJoin {
            hc,
            nhc,
            children,
            rel,
            xdirty,
            ..
        } = *dj;
        let (x, jx, sign) = children[side];
        let hx = self.coef.layout.hoff[x];
        let r = &rel[side];
        // X's frame: Δn, n₀ there; its cache's Ψ_X[·,jx], P_X,jx at its velocity.
        let rt = tr3(r);
        let dnx = rot6(&rt, dn);
        let n0x = rot6(&rt, n0);
        let wx = monomials(self.cache.reselection.frame_velocity[x]);
        let nx = 6 * self.coef.handles[x];
        let po = self.metric.quad_at[x];
        let c = &self.cache;
        let psi = &c.tensors.psi[po..po + nx * nx];
        // Ψ_X[i,jx] Δn for every handle i of X (6 each).
        let psidn = |i: usize| -> [f64; 6] {
            std::array::from_fn(|r| {
                let row = &psi[(6 * i + r) * nx + 6 * jx..][..6];
                dot6::<Portable>(row.try_into().expect("6"), &dnx)
            })
        };
        let g = psidn(jx);
        let mut du = [0.0; 6];
        let mut eta_x = if xdirty[side] {
            c.dirty.delta_eta[x]
        } else {
            0.0
        };
        for r in 0..6 {
            let row = 6 * jx + r;
            let p0 = wdot(&c.tensors.p_w[(hx * 6 + row) * NW..][..NW], &wx);
            let dpj = if xdirty[side] {
                c.dirty.delta_p[6 * hx + row]
            } else {
                0.0
            };
            eta_x +=
                (2.0 * n0x[r] + dnx[r]) * g[r] + sign * (dnx[r] * p0 + (n0x[r] + dnx[r]) * dpj);
            du[r] = 2.0 * sign * g[r] + dpj;
        }
        // s Δu_jx, summed over the children for one Nᵀ (n's frame).
        for (sv, dv) in sdu.iter_mut().zip(rot6(r, &du)) {
            *sv += sign * dv;
        }
        // Shared handles i → h: Δp_h += Δp_X,i + 2 s Ψ_X[i,jx] Δn,
        // Δb_h = Δb^X_i + s Φ^X_{jx,i}ᵀ Δn (s = −1 for A: `G_F = ±Φ^X_j·`).
        for h in 0..nhc {
            let (from_a, i) = self.coef.layout.from[hc + h];
            if from_a != (side == 0) {
                continue;
            }
            let c = &self.cache;
            let psi = &c.tensors.psi[po..po + nx * nx];
            let pd: [f64; 6] = std::array::from_fn(|r| {
                let row = &psi[(6 * i + r) * nx + 6 * jx..][..6];
                dot6::<Portable>(row.try_into().expect("6"), &dnx)
            });
            let g = &c.tensors.phi[self.coef.layout.boff[x] + jx * self.coef.handles[x] + i];
            let mut u = [0.0; 6];
            let mut bh: [f64; 6] =
                std::array::from_fn(|col| sign * (0..6).map(|s| g.0[s][col] * dnx[s]).sum::<f64>());
            for r in 0..6 {
                u[r] = 2.0 * sign * pd[r];
                if xdirty[side] {
                    u[r] += c.dirty.delta_p[6 * hx + 6 * i + r];
                    bh[r] += c.dirty.delta_b[hx + i][r];
                }
            }
            let (u, bh) = (rot6(r, &u), rot6(r, &bh));
            for (d, v) in self.cache.dirty.delta_p[6 * (hc + h)..6 * (hc + h) + 6]
                .iter_mut()
                .zip(u)
            {
                *d += v;
            }
            self.cache.dirty.delta_b[hc + h] = bh;
        }
        eta_x
    }

    /// Allocates the forced paths' maps (the first re-selection with external forces).
    pub(crate) fn map_alloc(&mut self, model: &Model) {
        if self.cache.maps.allocated {
            return;
        }
        let nn = model.assembly.nodes.len();
        let c = &mut self.cache;
        c.maps.leaf = vec![usize::MAX; nn];
        c.maps.built_at = vec![0; nn];
        c.maps.built = vec![false; nn];
        c.maps.leaf_pose = vec![SpatialTransform::IDENTITY; nn];
        c.maps.g_n = vec![[[0.0; 6]; 6]; nn];
        c.maps.h = vec![[[0.0; 6]; 6]; nn];
        c.maps.j_w = vec![[[0.0; NW]; 6]; nn];
        c.maps.g_b = vec![[[0.0; 6]; 6]; self.coef.layout.handles];
        c.maps.g_p = vec![[[0.0; 6]; 6]; self.coef.layout.handles];
        c.maps.g_k = vec![[0.0; 6]; model.nv];
        c.maps.allocated = true;
    }

    /// Whether dirty node `n`'s map record (one forced leaf below it) holds: made for this
    /// leaf, after n's cache was built and after its dirty child's record, which holds
    /// (`dirty.map_valid`, set bottom-up). A record is made the first time a path is seen and its map
    /// built the second time (a path seen once — the selection moving — is not worth six
    /// columns).
    pub(crate) fn map_holds(&self, model: &Model, n: usize) -> bool {
        let c = &self.cache;
        if c.maps.leaf[n] != c.dirty.forced_leaf[n] {
            return false;
        }
        match model.assembly.nodes[n].kind {
            NodeKind::Join {
                parent_side: a,
                child_side: b,
                ..
            } => {
                let x = if c.dirty.dirty_stamp[a] == c.reselection.epoch {
                    a
                } else {
                    b
                };
                c.maps.built_at[n] > c.tensors.built_at[n]
                    && c.maps.built_at[n] > c.maps.built_at[x]
                    && c.dirty.map_valid[x]
            }
            _ => true,
        }
    }

    /// A new map record for dirty node `n` (its map not built yet).
    pub(crate) fn map_record(&mut self, n: usize) {
        let c = &mut self.cache;
        c.maps.leaf[n] = c.dirty.forced_leaf[n];
        c.clock += 1;
        c.maps.built_at[n] = c.clock;
        c.maps.built[n] = false;
    }

    /// The map of a forced leaf `n`: `Δb_h = G_b,h f` for its wrench `f` in its own frame
    /// (about its origin), the columns of [`Adaptive::leaf_delta`] at the unit wrenches.
    pub(crate) fn leaf_map(&mut self, model: &Model, n: usize) {
        let x = self.cache.reselection.frame_pose[n];
        let (ho, nh) = (self.coef.layout.hoff[n], self.coef.handles[n]);
        for col in 0..6 {
            let mut e = [0.0; 6];
            e[col] = 1.0;
            self.leaf_delta(model, n, x.apply_force(SpatialForce::from_array(e)));
            for h in 0..nh {
                let d = self.cache.dirty.delta_b[ho + h];
                for (row, v) in d.iter().enumerate() {
                    self.cache.maps.g_b[ho + h][row][col] = *v;
                }
            }
        }
        let c = &mut self.cache;
        c.maps.leaf_pose[n] = SpatialTransform::IDENTITY;
        c.maps.built[n] = true;
        c.maps.builds += 1;
    }

    /// The map of a dirty join `n` with one forced leaf below it, from its dirty child's:
    /// [`Adaptive::dirty_delta`] with every delta a linear map of the leaf's wrench `f` (own
    /// frame, `maps.leaf_pose` in n's) and `Δη` a quadratic form plus a bilinear one in `f` and n's
    /// monomials `w`,
    /// ```text
    /// Δb_h = G_b,h f   Δp = G_p f   Δk = G_k f   Δn = G_n f   Δη = fᵀ H f + fᵀ J w
    /// ```
    /// all constant while n's cache and the maps below stay: `G_β = −s_X R_X G_b,jx^X`,
    /// `G_n = ν_β G_β`, `G_k = κ_β G_β`; the own joint adds `H += G_kᵀ A G_k`,
    /// `J += G_kᵀ (A + Aᵀ) K_w`, `G_p = 2 Kᵀ A G_k`; a join child X (`G_nx = R_Xᵀ G_n`,
    /// `N⁰_x = R_Xᵀ N_w`, `M_X` its monomial map, `w_X = M_X w`, `G_g = Ψ_X[jx,jx] G_nx`) adds
    /// `J += 2 G_gᵀ N⁰_x + s G_nxᵀ P_X,jx M_X`, `H += G_nxᵀ G_g`, and when dirty
    /// `J += s G_p,jxᵀ N⁰_x + J_X M_X`, `H += s G_nxᵀ G_p,jx + H_X` — the terms of `Δη` in
    /// [`Adaptive::dirty_delta`] with `n₀ = N_w w`, `k₀ = K_w w`, `p_X₀ = P_X w_X`.
    pub(crate) fn join_map(&mut self, model: &Model, n: usize) {
        // Also compiled for AVX2 + FMA (the same bits, wider vectors), run when `fused`.
        articula_spatial::fma_dispatch! {
            fn run(this: &mut Adaptive, model: &Model, n: usize);
            avx2_fma: this.switches.fused, Portable;
            |A| this.join_map_with(model, n)
        }
        run(self, model, n)
    }

    #[inline(always)]
    fn join_map_with(&mut self, model: &Model, n: usize) {
        let Some(dj) = self.dirty_join(model, n) else {
            return;
        };
        let mut own = self.join_map_own(model, n, &dj);
        // Σ_X s R_X G_du,X over the join children.
        let mut gsdu = [[0.0; 6]; 6];
        for side in 0..2 {
            let x = dj.children[side].0;
            if let NodeKind::Join { .. } = model.assembly.nodes[x].kind {
                self.join_map_join_side(n, &dj, side, &mut own, &mut gsdu);
            } else {
                self.join_map_leaf_side(model, n, &dj, side, &own.gdn);
            }
        }
        let DirtyJoin {
            a,
            b,
            hc,
            nc,
            xdirty,
            ..
        } = dj;
        let JoinMapOwn {
            gdn,
            gdk,
            hq,
            jw,
            k,
            vo,
            ..
        } = own;
        // G_p += Nᵀ Σ_X s R_X G_du,X.
        for i in 0..nc {
            for col in 0..6 {
                let add: f64 = (0..6)
                    .map(|t| self.cache.tensors.n[36 * hc + t * nc + i] * gsdu[t][col])
                    .sum();
                self.cache.maps.g_p[hc + i / 6][i % 6][col] += add;
            }
        }
        let xd = if xdirty[0] { a } else { b };
        let c = &mut self.cache;
        c.maps.g_n[n] = gdn;
        c.maps.g_k[vo..vo + k].copy_from_slice(&gdk[..k]);
        c.maps.h[n] = hq;
        c.maps.j_w[n] = jw;
        c.maps.leaf_pose[n] = c.tensors.parent_pose[xd] * c.maps.leaf_pose[xd];
        c.maps.built[n] = true;
        c.maps.builds += 1;
    }

    /// The own-joint terms of [`Adaptive::join_map`] at dirty join `n`: `G_n`, `G_k`, the
    /// joint's share of `H` and `J`, `G_p`'s start and `N_w`.
    #[inline(always)]
    fn join_map_own(&mut self, model: &Model, n: usize, dj: &DirtyJoin) -> JoinMapOwn {
        let DirtyJoin {
            joint,
            hc,
            nc,
            children,
            rel,
            xdirty,
            ..
        } = *dj;
        // G_β = −s_X R_X G_b,jx^X of the dirty child.
        let mut gbeta = [[0.0; 6]; 6];
        for (side, &(x, jx, sign)) in children.iter().enumerate() {
            if xdirty[side] {
                let d = m6_rot(
                    &rel[side],
                    &self.cache.maps.g_b[self.coef.layout.hoff[x] + jx],
                );
                for (br, dr) in gbeta.iter_mut().zip(&d) {
                    for (bv, dv) in br.iter_mut().zip(dr) {
                        *bv -= sign * dv;
                    }
                }
            }
        }
        let body = &model.bodies[joint];
        let (vo, k) = (body.v_offset, body.nv);
        let jm = self.cache.tensors.bias_maps[n];
        let gdn = m6_mul(&jm.nu_beta, &gbeta);
        let gdk = m6_mul(&jm.kappa_beta, &gbeta);
        // Own joint: A G_k, Aᵀ G_k (rows p < k).
        let wo = self.metric.weight_at[joint];
        let aw = &self.metric.accel_weights[wo..wo + k * k];
        let mut adk = [[0.0; 6]; 6];
        let mut atdk = [[0.0; 6]; 6];
        for p in 0..k {
            for q in 0..k {
                for col in 0..6 {
                    adk[p][col] += aw[p * k + q] * gdk[q][col];
                    atdk[p][col] += aw[q * k + p] * gdk[q][col];
                }
            }
        }
        let mut hq = [[0.0; 6]; 6];
        for p in 0..k {
            for r in 0..6 {
                for col in 0..6 {
                    hq[r][col] += gdk[p][r] * adk[p][col];
                }
            }
        }
        let mut jw = [[0.0; NW]; 6];
        for p in 0..k {
            let kw: &[f64; NW] = self.cache.tensors.k_w[(vo + p) * NW..][..NW]
                .try_into()
                .expect("NW");
            for (r, jr) in jw.iter_mut().enumerate() {
                let f = adk[p][r] + atdk[p][r];
                for (x, &y) in jr.iter_mut().zip(kw) {
                    *x += f * y;
                }
            }
        }
        let ko = self.maps.qdd_gain_at[n];
        for i in 0..nc {
            for col in 0..6 {
                self.cache.maps.g_p[hc + i / 6][i % 6][col] = 2.0
                    * (0..k)
                        .map(|p| self.cache.tensors.k[ko + p * nc + i] * adk[p][col])
                        .sum::<f64>();
            }
        }
        // N_w (6 × NW) of n.
        let mut nw0 = [[0.0; NW]; 6];
        for (row, r) in nw0.iter_mut().enumerate() {
            r.copy_from_slice(&self.cache.tensors.n_w[(n * 6 + row) * NW..][..NW]);
        }
        JoinMapOwn {
            gdn,
            gdk,
            hq,
            jw,
            nw0,
            k,
            vo,
        }
    }

    /// Leaf child on `side` of dirty join `n`: its shared handles' Δb through its rigid block
    /// (computation axes, turned into n's).
    #[inline(always)]
    fn join_map_leaf_side(
        &mut self,
        model: &Model,
        n: usize,
        dj: &DirtyJoin,
        side: usize,
        gdn: &M6,
    ) {
        let DirtyJoin {
            hc,
            nhc,
            children,
            rel,
            xdirty,
            ..
        } = *dj;
        let (x, jx, sign) = children[side];
        let hx = self.coef.layout.hoff[x];
        let r = &rel[side];
        let rd = rows3(&self.cache.reselection.frame_pose[n].e);
        for h in 0..nhc {
            let (from_a, i) = self.coef.layout.from[hc + h];
            if from_a != (side == 0) {
                continue;
            }
            let mut gb = if xdirty[side] {
                m6_rot(r, &self.cache.maps.g_b[hx + i])
            } else {
                [[0.0; 6]; 6]
            };
            for col in 0..6 {
                let mut v = [0.0; 6];
                for (row, x) in v.iter_mut().enumerate() {
                    *x = gdn[row][col];
                }
                let g = self.leaf_phi_t(model, x, jx, i, &rot6(&rd, &v));
                let bh = rot6(&tr3(&rd), &g);
                for row in 0..6 {
                    gb[row][col] += sign * bh[row];
                }
            }
            self.cache.maps.g_b[hc + h] = gb;
        }
    }

    /// Join child on `side` of dirty join `n`: its terms of `J` and `H` carried to n's
    /// monomials, its share of `G_du`, and its shared handles' `G_p`, `G_b`.
    #[inline(always)]
    fn join_map_join_side(
        &mut self,
        n: usize,
        dj: &DirtyJoin,
        side: usize,
        own: &mut JoinMapOwn,
        gsdu: &mut M6,
    ) {
        let DirtyJoin {
            hc,
            nhc,
            children,
            rel,
            xdirty,
            ..
        } = *dj;
        let (x, jx, sign) = children[side];
        let hx = self.coef.layout.hoff[x];
        let r = &rel[side];
        let JoinMapOwn {
            gdn, hq, jw, nw0, ..
        } = own;
        let (gdn, nw0) = (*gdn, *nw0);
        let rt = tr3(r);
        let gdnx = m6_rot(&rt, &gdn);
        let mut n0x = nw0;
        left_rot(n0x.as_flattened_mut(), 6, NW, &rt);
        // M_X: w_X = M_X w (u_X = rel⁻¹ u); a node holding the ground does not move
        // (`w = e_CONST`): only the constant column matters, which M_X keeps.
        let still = self.composites.grounded[n];
        if !still {
            let t = inv_motion_matrix(&self.cache.tensors.parent_pose[x]);
            monomial_map(&t, &mut self.cache.build.monomial_map);
        }
        let nx = 6 * self.coef.handles[x];
        let po = self.metric.quad_at[x];
        let psi_at = |c: &Caches, i: usize| -> M6 {
            let mut m = [[0.0; 6]; 6];
            for (r, mr) in m.iter_mut().enumerate() {
                mr.copy_from_slice(&c.tensors.psi[po + (6 * i + r) * nx + 6 * jx..][..6]);
            }
            m
        };
        let c = &self.cache;
        let gg = m6_mul(&psi_at(c, jx), &gdnx);
        // The terms over X's monomials, `s G_nxᵀ P_X,jx (+ J_X)`, carried to n's by one
        // product with M_X below.
        let mut p0 = [[0.0; NW]; 6];
        for (r, pr) in p0.iter_mut().enumerate() {
            pr.copy_from_slice(&c.tensors.p_w[(hx * 6 + 6 * jx + r) * NW..][..NW]);
        }
        let mut jxw = if xdirty[side] {
            c.maps.j_w[x]
        } else {
            [[0.0; NW]; 6]
        };
        add_at_b(&mut jxw, sign, &gdnx, &p0);
        for (jr, xr) in jw.iter_mut().zip(&jxw) {
            if still {
                jr[CONST] += xr[CONST];
                continue;
            }
            for (m, &xv) in xr.iter().enumerate() {
                for (o, &mv) in jr
                    .iter_mut()
                    .zip(&c.build.monomial_map[m * NW..(m + 1) * NW])
                {
                    *o += xv * mv;
                }
            }
        }
        add_at_b(jw, 2.0, &gg, &n0x);
        let h1 = m6_tmul(&gdnx, &gg);
        let mut du = [[0.0; 6]; 6];
        for (dr, gr) in du.iter_mut().zip(&gg) {
            for (d, &v) in dr.iter_mut().zip(gr) {
                *d = 2.0 * sign * v;
            }
        }
        if xdirty[side] {
            let gpj = c.maps.g_p[hx + jx];
            add_at_b(jw, sign, &gpj, &n0x);
            let h2 = m6_tmul(&gdnx, &gpj);
            let hx_ = c.maps.h[x];
            for rr in 0..6 {
                for cc in 0..6 {
                    hq[rr][cc] += h1[rr][cc] + sign * h2[rr][cc] + hx_[rr][cc];
                    du[rr][cc] += gpj[rr][cc];
                }
            }
        } else {
            for rr in 0..6 {
                for cc in 0..6 {
                    hq[rr][cc] += h1[rr][cc];
                }
            }
        }
        let du = m6_rot(r, &du);
        for rr in 0..6 {
            for cc in 0..6 {
                gsdu[rr][cc] += sign * du[rr][cc];
            }
        }
        // Shared handles i → h: G_p,h += R (G_p,i + 2 s Ψ_X[i,jx] G_nx),
        // G_b,h = R (G_b,i + s Φ^X_{jx,i}ᵀ G_nx).
        for h in 0..nhc {
            let (from_a, i) = self.coef.layout.from[hc + h];
            if from_a != (side == 0) {
                continue;
            }
            let c = &self.cache;
            let pd = m6_mul(&psi_at(c, i), &gdnx);
            let g = &c.tensors.phi[self.coef.layout.boff[x] + jx * self.coef.handles[x] + i];
            let mut bh = m6_tmul(&g.0, &gdnx);
            let mut u = [[0.0; 6]; 6];
            for rr in 0..6 {
                for cc in 0..6 {
                    bh[rr][cc] *= sign;
                    u[rr][cc] = 2.0 * sign * pd[rr][cc];
                    if xdirty[side] {
                        u[rr][cc] += c.maps.g_p[hx + i][rr][cc];
                        bh[rr][cc] += c.maps.g_b[hx + i][rr][cc];
                    }
                }
            }
            let (u, bh) = (m6_rot(r, &u), m6_rot(r, &bh));
            let gp = &mut self.cache.maps.g_p[hc + h];
            for rr in 0..6 {
                for cc in 0..6 {
                    gp[rr][cc] += u[rr][cc];
                }
            }
            self.cache.maps.g_b[hc + h] = bh;
        }
    }

    /// Dirty node `n`'s deltas from its map at its leaf's wrench (`f` in the leaf's frame, at
    /// `frame_pose[n] · leaf_pose`) and n's velocity: `Δb_h = G_b,h f`, `Δp = G_p f`, `Δk = G_k f`,
    /// `Δn = G_n f`, `Δη = fᵀ H f + fᵀ J w`.
    pub(crate) fn eval_map(&mut self, model: &Model, n: usize) {
        // Also compiled for AVX2 + FMA (the same bits, wider vectors), run when `fused`.
        articula_spatial::fma_dispatch! {
            fn run(this: &mut Adaptive, model: &Model, n: usize);
            avx2_fma: this.switches.fused, Portable;
            |A| this.eval_map_with(model, n)
        }
        run(self, model, n)
    }

    #[inline(always)]
    fn eval_map_with(&mut self, model: &Model, n: usize) {
        let c = &mut self.cache;
        let l = c.maps.leaf[n];
        let xl = c.reselection.frame_pose[n] * c.maps.leaf_pose[n];
        let f = xl.inv_apply_force(self.forces.node_sums[l]).to_array();
        let (hc, nh) = (self.coef.layout.hoff[n], self.coef.handles[n]);
        for h in 0..nh {
            c.dirty.delta_b[hc + h] = m6_x(&c.maps.g_b[hc + h], &f);
        }
        if let NodeKind::Join { joint, .. } = model.assembly.nodes[n].kind {
            for h in 0..nh {
                let p = m6_x(&c.maps.g_p[hc + h], &f);
                c.dirty.delta_p[6 * (hc + h)..6 * (hc + h) + 6].copy_from_slice(&p);
            }
            c.dirty.delta_n[n] = m6_x(&c.maps.g_n[n], &f);
            let body = &model.bodies[joint];
            for p in body.v_offset..body.v_offset + body.nv {
                c.dirty.delta_k[p] = dot6::<Portable>(&c.maps.g_k[p], &f);
            }
            let w = monomials(c.reselection.frame_velocity[n]);
            let hf = m6_x(&c.maps.h[n], &f);
            let jw = wdot6(c.maps.j_w[n].as_flattened(), &w);
            c.dirty.delta_eta[n] = (0..6).map(|r| f[r] * (hf[r] + jw[r])).sum();
        }
        c.dirty.delta_stamp[n] = c.reselection.epoch;
        c.maps.evaluations += 1;
    }

    /// Makes dirty node `n`'s deltas this re-selection's: a node inside a forced path with one
    /// leaf is evaluated from its map when the selection first reads it.
    pub(crate) fn ensure_delta(&mut self, model: &Model, n: usize) {
        if self.cache.dirty.dirty_stamp[n] == self.cache.reselection.epoch
            && self.cache.dirty.delta_stamp[n] != self.cache.reselection.epoch
        {
            self.eval_map(model, n);
        }
    }

    /// What the forces add to a dirty node's metric at the handle forces whose cache-frame
    /// components [`Adaptive::metric_local`] left in `fx`: `F⁰ᵀ Δp + Δη`.
    pub(crate) fn metric_delta(&self, n: usize) -> f64 {
        let nc = 6 * self.coef.handles[n];
        let o = 6 * self.coef.layout.hoff[n];
        self.scratch.handle_forces[..nc]
            .iter()
            .zip(&self.cache.dirty.delta_p[o..o + nc])
            .map(|(f, d)| f * d)
            .sum::<f64>()
            + self.cache.dirty.delta_eta[n]
    }

    /// Makes node `n`'s metric slots (Ψ, p, η, computation axes) valid for this re-selection:
    /// from its cache at its frame and velocity (`reselection.frame_pose`, `frame_velocity`) when it is rigid (p and η then
    /// without external forces: a build reads Ψ alone),
    /// otherwise from its children's by the metric pass (a leaf: zero).
    pub(crate) fn world_metric(&mut self, model: &Model, n: usize) {
        let ep = self.cache.reselection.epoch;
        if self.cache.reselection.metric_stamp[n] == ep {
            return;
        }
        match model.assembly.nodes[n].kind {
            NodeKind::Join {
                parent_side: a,
                child_side: b,
                ..
            } => {
                if self.cache.tensors.node_valid[n] {
                    let (x, u) = (
                        self.cache.reselection.frame_pose[n],
                        self.cache.reselection.frame_velocity[n],
                    );
                    self.eval_cache(model, n, &x, u, Part::Metric);
                } else {
                    self.world_metric(model, a);
                    self.world_metric(model, b);
                    self.metric_node(model, n);
                }
            }
            _ => self.metric_node(model, n),
        }
        self.cache.reselection.metric_stamp[n] = ep;
    }

    /// `A(n) = Fᵀ Ψ F + Fᵀ p + η` of a cached node at the handle forces in `f`, in its cache
    /// frame (`F⁰ = Rᵀ F`; `p = P w`, `η = wᵀ E w` at its velocity `u`): no rotation of Ψ.
    pub(crate) fn metric_local(&mut self, n: usize, x: &SpatialTransform, u: SpatialMotion) -> f64 {
        // Also compiled for AVX2 + FMA (the same bits, wider vectors), run when `fused`.
        articula_spatial::fma_dispatch! {
            fn run(this: &mut Adaptive, n: usize, x: &SpatialTransform, u: SpatialMotion) -> f64;
            avx2_fma: this.switches.fused, Portable;
            |A| this.metric_local_with(n, x, u)
        }
        run(self, n, x, u)
    }

    #[inline(always)]
    fn metric_local_with(&mut self, n: usize, x: &SpatialTransform, u: SpatialMotion) -> f64 {
        let w = monomials(u);
        let rt = tr3(&rows3(&x.e));
        let (nh, hc) = (self.coef.handles[n], self.coef.layout.hoff[n]);
        let nc = 6 * nh;
        for h in 0..nh {
            self.scratch.handle_forces[6 * h..6 * h + 6]
                .copy_from_slice(&self.coef.force[hc + h].to_array());
        }
        left_rot(&mut self.scratch.handle_forces[..nc], nc, 1, &rt);
        let c = &self.cache;
        let fx = &self.scratch.handle_forces[..nc];
        let po = self.metric.quad_at[n];
        let o = hc * 6 * NW;
        let mut a = crate::dense::quad(&c.tensors.psi[po..po + nc * nc], fx, nc);
        // Fᵀ P w = (Σ_row F_row P_row) · w.
        let pf = comb_rows(
            &c.tensors.p_w[o..o + nc * NW],
            fx,
            true,
            self.switches.fused,
        );
        a += wdot(&pf, &w);
        let e = &c.tensors.e[n * NW * NW..(n + 1) * NW * NW];
        a + quad_w(e, &w, self.switches.fused)
    }

    /// Builds the caches of every join node that is not selected, bottom-up, from the
    /// articulated slots of a whole-body main and metric pass and the whole-body kinematics in
    /// `data` (the initial O(n) build).
    pub(crate) fn build_all_caches(
        &mut self,
        model: &Model,
        q: &[f64],
        tau: &[f64],
    ) -> Result<(), DynamicsError> {
        self.cache_alloc(model);
        self.cache.all_valid = false;
        if !self.cache.handles_fixed {
            return Ok(());
        }
        // The whole-body metric pass filled every node's metric slots.
        self.cache.reselection.epoch += 1;
        self.cache
            .reselection
            .metric_stamp
            .fill(self.cache.reselection.epoch);
        for n in 0..model.assembly.nodes.len() {
            self.cache.tensors.node_valid[n] = false;
            if !self.queue.selected[n]
                && matches!(model.assembly.nodes[n].kind, NodeKind::Join { .. })
            {
                self.build_cache(model, n, q, tau)?;
            }
        }
        self.cache.torques.copy_from_slice(tau);
        self.cache.all_valid = true;
        Ok(())
    }
}
