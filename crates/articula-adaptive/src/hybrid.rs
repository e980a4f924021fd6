//! The main pass of the hybrid body (docs/design.md#adaptive): articulated coefficients of
//! active nodes, the rigid coefficients of rigidified ones, composites, and the back-substitution.
//!
//! Conventions follow `articula-dca`: every spatial quantity is in the computation frame (world
//! axes, origin at the floating base for a floating model), and each handle's vectors are taken
//! about the origin of the handle joint's child body (`point`), so that long bodies keep their
//! digits. A force array is `[n; f]`, a motion array `[ω; v]`.

use crate::adaptive::Adaptive;
use crate::parts::composites::Rigid;
use crate::parts::join_maps::BiasMaps;
use articula_dca::DynamicsError;
use articula_model::{Body, JointKind, Model, NodeKind};
use articula_spatial::numerics::{
    cholesky, cholesky_into, dot6, invert_spd_into, solve_llt_k, Portable,
};
use articula_spatial::numerics::{solve_lower, solve_lower_t};
use articula_spatial::{Mat6, SpatialForce, SpatialMotion};
use glam::{DMat3, DVec3};

/// `Σ_p a[p][r] b[p][c]` (p < 5, ascending) for `r, c < 6`, the sums started with their first
/// product: a row at a time over all eight lanes of `b`'s rows (two 4-wide vectors).
#[inline(always)]
fn gram8(a: &[[f64; 8]; 5], b: &[[f64; 8]; 5]) -> [[f64; 6]; 6] {
    let mut g = [[0.0; 6]; 6];
    for r in 0..6 {
        let x = a[0][r];
        let mut acc = [0.0; 8];
        for c in 0..8 {
            acc[c] = x * b[0][c];
        }
        for p in 1..5 {
            let x = a[p][r];
            for c in 0..8 {
                acc[c] += x * b[p][c];
            }
        }
        g[r].copy_from_slice(&acc[..6]);
    }
    g
}

/// `x s`, a row of six.
#[inline(always)]
fn row_scaled(x: &[f64; 6], s: f64) -> [f64; 6] {
    let mut o = [0.0; 6];
    for c in 0..6 {
        o[c] = x[c] * s;
    }
    o
}

/// `v += s x`, a row of six.
#[inline(always)]
fn row_add_scaled(v: &mut [f64; 6], s: f64, x: &[f64; 6]) {
    for c in 0..6 {
        v[c] += s * x[c];
    }
}

/// `v −= s x`, a row of six.
#[inline(always)]
fn row_sub_scaled(v: &mut [f64; 6], s: f64, x: &[f64; 6]) {
    for c in 0..6 {
        v[c] -= s * x[c];
    }
}

/// `W yₖ = T (L Lᵀ)⁻¹ Tᵀ yₖ` for three right-hand sides side by side (lanes of four, the last
/// unused): per lane the operations of `solve_llt_k`, in its order, except that each
/// step multiplies by `linv[i] = 1 / L_ii` instead of dividing by `L_ii` (ten divisions in a
/// row were the join's longest dependency chain).
#[inline(always)]
fn w_apply3(
    t: &AxisBasis,
    l: &[[f64; 6]; 6],
    linv: &[f64; 5],
    ys: [&[f64; 6]; 3],
) -> [[f64; 6]; 3] {
    // Written out rather than `ys.map(..)` / `array::from_fn(..)`: their closures are called
    // out of line (std's generic code is not compiled for AVX2).
    let us = [t.tr(ys[0]), t.tr(ys[1]), t.tr(ys[2])];
    let mut x = [[0.0; 4]; 5];
    for i in 0..5 {
        for k in 0..3 {
            x[i][k] = us[k][i];
        }
    }
    // L x = u
    for i in 0..5 {
        let mut v = x[i];
        for p in 0..i {
            let lip = l[i][p];
            for k in 0..4 {
                v[k] -= lip * x[p][k];
            }
        }
        let d = linv[i];
        for k in 0..4 {
            x[i][k] = v[k] * d;
        }
    }
    // Lᵀ λ = x
    for i in (0..5).rev() {
        let mut v = x[i];
        for p in (i + 1)..5 {
            let lpi = l[p][i];
            for k in 0..4 {
                v[k] -= lpi * x[p][k];
            }
        }
        let d = linv[i];
        for k in 0..4 {
            x[i][k] = v[k] * d;
        }
    }
    let col = |k: usize| t.apply(&[x[0][k], x[1][k], x[2][k], x[3][k], x[4][k]]);
    [col(0), col(1), col(2)]
}

/// The basis `T` of the forces that do no work along one axis `s` (`sᵀ T = 0`): for a
/// revolute axis `s = [v; 0]` (a prismatic one `[0; v]`), with `m` the largest component of `v`,
/// the columns `e_a − r_a e_m`, `e_b − r_b e_m` (`r = v / v_m`, so `|r| ≤ 1`) and the three unit
/// vectors of the other half.
struct AxisBasis {
    m: usize,
    a: usize,
    b: usize,
    keep: [usize; 3],
    ra: f64,
    rb: f64,
}

impl AxisBasis {
    fn new(s: &[f64; 6], off: usize) -> AxisBasis {
        let v = [s[off], s[off + 1], s[off + 2]];
        let m = if v[0].abs() >= v[1].abs() && v[0].abs() >= v[2].abs() {
            0
        } else if v[1].abs() >= v[2].abs() {
            1
        } else {
            2
        };
        let (a, b) = ((m + 1) % 3, (m + 2) % 3);
        let o = 3 - off;
        AxisBasis {
            m: off + m,
            a: off + a,
            b: off + b,
            keep: [o, o + 1, o + 2],
            ra: v[a] / v[m],
            rb: v[b] / v[m],
        }
    }

    /// `Tᵀ x`.
    #[inline(always)]
    fn tr(&self, x: &[f64; 6]) -> [f64; 5] {
        [
            x[self.a] - self.ra * x[self.m],
            x[self.b] - self.rb * x[self.m],
            x[self.keep[0]],
            x[self.keep[1]],
            x[self.keep[2]],
        ]
    }

    /// `T u`.
    #[inline(always)]
    fn apply(&self, u: &[f64; 5]) -> [f64; 6] {
        let mut f = [0.0; 6];
        f[self.a] = u[0];
        f[self.b] = u[1];
        f[self.m] = -self.ra * u[0] - self.rb * u[1];
        f[self.keep[0]] = u[2];
        f[self.keep[1]] = u[3];
        f[self.keep[2]] = u[4];
        f
    }
}

/// Which terms the main pass includes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Level {
    /// Accelerations: gravity, velocity products, external forces, joint forces.
    Acceleration,
    /// Velocities after an impulse: no bias terms; the "joint forces" are generalized momenta.
    Impulse,
}

impl Adaptive {
    /// Composite inertia, ground flag, top body and external-force sum of every node, bottom-up.
    pub(crate) fn composites(&mut self, model: &Model) {
        self.composites_with(model, true);
    }

    /// [`Adaptive::composites`] for a hybrid body set by hand ([`Adaptive::set_active`], its
    /// `active` flags already closed upward): the composite inertias of the nodes outside the
    /// active region only — every body leaf, every locked join, all that
    /// [`Adaptive::build_hierarchy`] reads (an active join's children may be active, a locked
    /// join's are not) — and no force sums (an impulse has no external force; the next step
    /// sums the frontier's). Ground flags and top bodies of every node.
    pub(crate) fn rigid_composites(&mut self, model: &Model) {
        self.composites_with(model, false);
    }

    #[inline(always)]
    fn composites_with(&mut self, model: &Model, all: bool) {
        let tree = &model.assembly;
        for (n, node) in tree.nodes.iter().enumerate() {
            match node.kind {
                NodeKind::Gather { .. } | NodeKind::Cluster { .. } => {
                    unreachable!("adaptive refuses models with gather nodes (`load_state`); `Model::assembly` has no leaf clusters")
                }
                NodeKind::Ground => {
                    self.composites.rigid[n] = Rigid::default();
                    self.composites.grounded[n] = true;
                    self.composites.top_body[n] = usize::MAX;
                    if all {
                        self.forces.node_sums[n] = SpatialForce::ZERO;
                    }
                }
                NodeKind::Body(i) => {
                    // From the body-frame inertia: about a far origin, I_c would lose digits.
                    let (rot, _) = self.data.x[i].to_pose();
                    let bi = &model.bodies[i].inertia;
                    self.composites.rigid[n] = Rigid {
                        mass: bi.mass,
                        com: self.data.x[i].apply_point(bi.com()),
                        inertia: rot * bi.inertia_about_com() * rot.transpose(),
                    };
                    self.composites.grounded[n] = false;
                    self.composites.top_body[n] = i;
                    if all {
                        self.forces.node_sums[n] = self
                            .forces
                            .computation
                            .get(i)
                            .copied()
                            .unwrap_or(SpatialForce::ZERO);
                    }
                }
                NodeKind::Join {
                    parent_side: a,
                    child_side: b,
                    ..
                } => {
                    if all || !self.body.active[n] {
                        self.composites.rigid[n] =
                            self.composites.rigid[a].combine(&self.composites.rigid[b]);
                    }
                    self.composites.grounded[n] =
                        self.composites.grounded[a] || self.composites.grounded[b];
                    self.composites.top_body[n] =
                        self.composites.top_body[a].min(self.composites.top_body[b]);
                    if all {
                        self.forces.node_sums[n] =
                            self.forces.node_sums[a] + self.forces.node_sums[b];
                    }
                }
            }
        }
    }

    /// Φ and b of node `n` moving as one rigid body with composite inertia `inertia` (about the
    /// computation origin), common spatial velocity `v` and net external wrench `fe`
    /// (docs/design.md#adaptive): `Φ_hk = I⁻¹` and `b_h = a_g + I⁻¹ (f_ext − v ×* I v)`,
    /// each handle's rows and columns about its own point. About the centre of mass c, where
    /// `I = diag(I_c, m 1)`: with `a = c − P_h`, `e = c − P_k`, `J = I_c⁻¹`,
    /// `Φ_hk = [J, −J e×; a× J, −a× J e× + 1/m]`.
    pub(crate) fn rigid_coefficients(
        &mut self,
        model: &Model,
        n: usize,
        inertia: &Rigid,
        v: SpatialMotion,
        fe: SpatialForce,
        level: Level,
    ) -> Result<(), DynamicsError> {
        // Also compiled for AVX2 + FMA (the same bits, wider vectors), run when `fused`.
        articula_spatial::fma_dispatch! {
            fn run(this: &mut Adaptive, model: &Model, n: usize, inertia: &Rigid, v: SpatialMotion, fe: SpatialForce, level: Level) -> Result<(), DynamicsError>;
            avx2_fma: this.switches.fused, Portable;
            |A| this.rigid_coefficients_with(model, n, inertia, v, fe, level)
        }
        run(self, model, n, inertia, v, fe, level)
    }

    #[inline(always)]
    fn rigid_coefficients_with(
        &mut self,
        model: &Model,
        n: usize,
        inertia: &Rigid,
        v: SpatialMotion,
        fe: SpatialForce,
        level: Level,
    ) -> Result<(), DynamicsError> {
        let node = &model.assembly.nodes[n];
        let (ho, bo, nh) = (
            self.coef.layout.hoff[n],
            self.coef.layout.boff[n],
            self.coef.handles[n],
        );
        let (m, ic, c) = (inertia.mass, inertia.inertia, inertia.com);
        if m.is_nan() || m <= 0.0 || ic.determinant() <= 0.0 {
            let body = self.composites.top_body[n].min(model.bodies.len() - 1);
            return Err(DynamicsError::Singular {
                joint: model.bodies[body].joint_name(),
                detail: "a rigid subassembly's spatial inertia is not positive definite",
            });
        }
        let j = ic.inverse();
        let (acc_w, acc_c) = match level {
            Level::Acceleration => {
                let v_c = v.v + v.w.cross(c);
                let n_c = fe.n - c.cross(fe.f) - v.w.cross(ic * v.w);
                let f_c = fe.f - v.w.cross(v_c) * m;
                (j * n_c, f_c / m)
            }
            Level::Impulse => (DVec3::ZERO, DVec3::ZERO),
        };
        let a_g = match level {
            Level::Acceleration => SpatialMotion::new(DVec3::ZERO, self.data.gravity),
            Level::Impulse => SpatialMotion::ZERO,
        };
        for (h, &jh) in node.handles.iter().enumerate() {
            let ah = c - self.coef.point[jh];
            // Φ is symmetric (`Φ_kh = Φ_hkᵀ`): the blocks on and above the diagonal, mirrored.
            for (k, &jk) in node.handles.iter().enumerate().skip(h) {
                let blk = rigid_phi(m, c, j, self.coef.point[jh], self.coef.point[jk]);
                if k > h {
                    self.coef.phi[bo + k * nh + h] = blk.transpose();
                }
                self.coef.phi[bo + h * nh + k] = blk;
            }
            // b at P_h: [α; a_c + α × (P_h − c)] + a_g
            self.coef.bias[ho + h] = a_g + SpatialMotion::new(acc_w, acc_c + acc_w.cross(-ah));
        }
        Ok(())
    }

    /// Coefficients of the ground or of a subassembly welded to it: Φ = 0, b = 0.
    pub(crate) fn ground_coefficients(&mut self, n: usize) {
        let (ho, bo, nh) = (
            self.coef.layout.hoff[n],
            self.coef.layout.boff[n],
            self.coef.handles[n],
        );
        self.coef.phi[bo..bo + nh * nh].fill(Mat6::ZERO);
        self.coef.bias[ho..ho + nh].fill(SpatialMotion::ZERO);
    }

    /// Joins A and B at node `n`'s principal joint (docs/design.md#dca), records the affine maps
    /// `q̈ = K F + k` and `f = N F + n` of the back-substitution. With `G_F` the 6 × 6nh map
    /// `y = β + G_F F` (`+Φ^A_jh` for handles from A, `−Φ^B_jh` from B), `V = (Φ^A_jj +
    /// Φ^B_jj)⁻¹ = L⁻ᵀ L⁻¹`, `D = Sᵀ V S`: `K = −D⁻¹ SᵀV G_F`, `k = D⁻¹ (Q − SᵀV β)`,
    /// `N = V (G_F + S K)`, `n = V (β + S k)` (= γ), all through the Cholesky factor:
    /// `Z = L⁻¹ S`, `Y = L⁻¹ G_F`, `U = Y + Z K`, `N = L⁻ᵀ U`. Then
    /// `Φ^C_hk = Φ^X_hk [same side] ∓ Φ^X_hj N_k = Φ^X_hk [same side] − Y_hᵀ U_k` and
    /// `b^C_h = b^X_h ∓ Φ^X_hj γ = b^X_h − G_F,hᵀ γ` (`assemble`).
    pub(crate) fn join(
        &mut self,
        model: &Model,
        n: usize,
        tau: &[f64],
        level: Level,
    ) -> Result<(), DynamicsError> {
        // Also compiled for AVX2 + FMA (the same bits, wider vectors), run when `fused`.
        articula_spatial::fma_dispatch! {
            fn run(this: &mut Adaptive, model: &Model, n: usize, tau: &[f64], level: Level) -> Result<(), DynamicsError>;
            avx2_fma: this.switches.fused, Portable;
            |A| this.join_with(model, n, tau, level)
        }
        run(self, model, n, tau, level)
    }

    #[inline(always)]
    fn join_with(
        &mut self,
        model: &Model,
        n: usize,
        tau: &[f64],
        level: Level,
    ) -> Result<(), DynamicsError> {
        let tree = &model.assembly;
        let NodeKind::Join {
            joint,
            parent_side: a,
            child_side: b,
        } = tree.nodes[n].kind
        else {
            unreachable!("join() on a leaf")
        };
        let body = &model.bodies[joint];
        let (ja, jb) = (self.coef.layout.ja[n], self.coef.layout.jb[n]);
        let (nhc, hc) = (self.coef.handles[n], self.coef.layout.hoff[n]);
        let g = add6(
            &self.coef.phi_at(a, ja, ja).0,
            &self.coef.phi_at(b, jb, jb).0,
        );
        // S, c at the joint's point P_j; β = b^A_j − b^B_j + c (no velocity product at impulse
        // level); G_F,h per handle of C.
        let pj = self.coef.point[joint];
        let shift = |m: SpatialMotion| SpatialMotion::new(m.w, m.v + m.w.cross(pj)).to_array();
        let mut beta = self.coef.bias[self.coef.layout.hoff[a] + ja]
            - self.coef.bias[self.coef.layout.hoff[b] + jb];
        if level == Level::Acceleration {
            beta += SpatialMotion::from_array(shift(self.data.c[joint]));
        }
        let beta = beta.to_array();
        for h in 0..nhc {
            self.scratch.g_force[h] = match self.coef.layout.from[hc + h] {
                (true, i) => *self.coef.phi_at(a, ja, i),
                (false, i) => -*self.coef.phi_at(b, jb, i),
            };
        }
        let (vo, k) = (body.v_offset, body.nv);
        // A joint with armature takes the general join (as in articula-dca): the one-axis
        // join takes the joint force along the axis to be `Q`, where armature leaves
        // `Q − a q̈`.
        let armature = self.data.armature().get(vo..vo + k);
        if let [part] = body.joint.as_slice() {
            if part.kind.is_scalar() && armature.is_none_or(|a| a[0] == 0.0) {
                let s = shift(self.data.s[vo]);
                let prismatic = part.kind == JointKind::Prismatic;
                return self.join_one_axis(model, n, tau, &g, s, prismatic, &beta);
            }
        }
        // L Lᵀ = Φ^A_jj + Φ^B_jj = V⁻¹
        let l = cholesky(&g, 6).ok_or_else(|| DynamicsError::Singular {
            joint: body.joint_name(),
            detail: "Φ_jj^A + Φ_jj^B is not positive definite",
        })?;
        // Z = L⁻¹ S, D = Zᵀ Z
        let mut z = [[0.0; 6]; 6];
        for p in 0..k {
            z[p] = solve_lower(&l, &shift(self.data.s[vo + p]));
        }
        let mut d = [[0.0; 6]; 6];
        for p in 0..k {
            for q in 0..k {
                d[p][q] = dot6::<Portable>(&z[p], &z[q]);
            }
        }
        // Armature A (docs/loading.md#armature-and-damping): D = SᵀVS + A. From `G f = y + S q̈`
        // and `Sᵀ f = Q − A q̈`, `(D + A) q̈ = Q − SᵀV y`: the maps below with `D + A`
        // (and `Φ^C = Φ^X − Y_hᵀ U_k` still, `U` from the K of `D + A`).
        if let Some(a) = armature {
            for p in 0..k {
                d[p][p] += a[p];
            }
        }
        let mut dinv = [[0.0f64; 6]; 6];
        if !invert_spd_into(&d, k, &mut dinv) {
            return Err(DynamicsError::Singular {
                joint: body.joint_name(),
                detail: "Sᵀ V S is not positive definite",
            });
        }
        if self.maps.record {
            self.maps.recorded = bias_maps(&l, &z, &dinv, k);
        }
        // w = L⁻¹ β
        let mut w = solve_lower(&l, &beta);
        // k = D⁻¹ (Q − Zᵀ w);  w ← w + Z k;  n = γ = L⁻ᵀ w
        let mut t = [0.0; 6];
        for p in 0..k {
            t[p] = tau[vo + p] - dot6::<Portable>(&z[p], &w);
        }
        for p in 0..k {
            self.maps.qdd_bias[vo + p] = (0..k).map(|q| dinv[p][q] * t[q]).sum();
        }
        for p in 0..k {
            let kp = self.maps.qdd_bias[vo + p];
            for r in 0..6 {
                w[r] += z[p][r] * kp;
            }
        }
        let nv = solve_lower_t(&l, &w);
        self.maps.force_bias[n] = nv;
        self.join_handle_gains(n, body, &l, &z, &dinv);
        self.assemble(n, a, b, false);
        Ok(())
    }

    /// Per handle h of join `n` (joint `body`): `Y_h = L⁻¹ G_F,h` (`G_F,h = +Φ^A_jh` from A,
    /// `−Φ^B_jh` from B), `K_h = −D⁻¹ Zᵀ Y_h`, `U_h = Y_h + Z K_h`, `N_h = L⁻ᵀ U_h`; Y and U
    /// stored column-wise in `scratch.y_cols`/`u_cols`.
    #[inline(always)]
    fn join_handle_gains(
        &mut self,
        n: usize,
        body: &Body,
        l: &[[f64; 6]; 6],
        z: &[[f64; 6]; 6],
        dinv: &[[f64; 6]; 6],
    ) {
        let k = body.nv;
        let (nhc, hc) = (self.coef.handles[n], self.coef.layout.hoff[n]);
        let ko = self.maps.qdd_gain_at[n];
        let wd = 6 * nhc;
        for h in 0..nhc {
            let gt = self.scratch.g_force[h].transpose(); // row c = column c of G_F,h
            let mut yc = [[0.0; 6]; 6];
            let mut uc = [[0.0; 6]; 6];
            for c in 0..6 {
                yc[c] = solve_lower(l, &gt.0[c]);
            }
            for p in 0..k {
                for c in 0..6 {
                    let zy: f64 = (0..k)
                        .map(|q| dinv[p][q] * dot6::<Portable>(&z[q], &yc[c]))
                        .sum();
                    self.maps.qdd_gain[ko + p * wd + 6 * h + c] = -zy;
                }
            }
            for c in 0..6 {
                let mut col = yc[c];
                for p in 0..k {
                    let kp = self.maps.qdd_gain[ko + p * wd + 6 * h + c];
                    for r in 0..6 {
                        col[r] += z[p][r] * kp;
                    }
                }
                uc[c] = col;
                let ncol = solve_lower_t(l, &col);
                for r in 0..6 {
                    self.maps.force_gain[36 * hc + r * wd + 6 * h + c] = ncol[r];
                }
            }
            self.scratch.y_cols[h] = yc;
            self.scratch.u_cols[h] = uc;
        }
    }

    /// `Φ^C_hk = Φ^X_hk [same side] − Y_hᵀ U_k` (columns of Y_h and U_k in `scratch.y_cols`,
    /// `scratch.u_cols`) and `b^C_h = b^X_h − G_F,hᵀ γ` (`G_F,h` in `scratch.g_force`,
    /// γ = `maps.force_bias[n]`) for the joined node `n`. `gram`: U = Y with five rows (the
    /// one-axis join, `scratch.y_rows[h]` holding the rows of Ỹ_h), so
    /// `Y_hᵀ Y_h` is symmetric to the bit.
    #[inline(always)]
    fn assemble(&mut self, n: usize, a: usize, b: usize, gram: bool) {
        let (nhc, hc, bc) = (
            self.coef.handles[n],
            self.coef.layout.hoff[n],
            self.coef.layout.boff[n],
        );
        for h in 0..nhc {
            let (ah, ih) = self.coef.layout.from[hc + h];
            let x = if ah { a } else { b };
            for kk in h..nhc {
                let (ak, ik) = self.coef.layout.from[hc + kk];
                // Y_hᵀ U_k.
                let yu: [[f64; 6]; 6] = if gram {
                    // The five rows of Ỹ_h, Ỹ_k in yt: Σ_p Ỹ_h[p][r] Ỹ_k[p][c], p ascending (the
                    // products commute, so a diagonal block is symmetric to the bit).
                    gram8(&self.scratch.y_rows[h].0, &self.scratch.y_rows[kk].0)
                } else {
                    std::array::from_fn(|r| {
                        std::array::from_fn(|c| {
                            dot6::<Portable>(
                                &self.scratch.y_cols[h][r],
                                &self.scratch.u_cols[kk][c],
                            )
                        })
                    })
                };
                // Φ^X_hk − Y_hᵀ U_k on the same side, −Y_hᵀ U_k across.
                let mut blk = Mat6(yu);
                if ah == ak {
                    let phi = &self.coef.phi_at(x, ih, ik).0;
                    for r in 0..6 {
                        for c in 0..6 {
                            blk.0[r][c] = phi[r][c] - yu[r][c];
                        }
                    }
                } else {
                    for row in &mut blk.0 {
                        for v in row {
                            *v = -*v;
                        }
                    }
                }
                if h == kk {
                    blk = *blk.symmetric_part().as_mat6();
                    self.coef.phi[bc + h * nhc + h] = blk;
                } else {
                    self.coef.phi[bc + h * nhc + kk] = blk;
                    self.coef.phi[bc + kk * nhc + h] = blk.transpose();
                }
            }
            let db = tr_mul_vec(&self.scratch.g_force[h], &self.maps.force_bias[n]);
            self.coef.bias[hc + h] =
                self.coef.bias[self.coef.layout.hoff[x] + ih] - SpatialMotion::from_array(db);
        }
    }

    /// The join of a single revolute or prismatic axis s, through the forces that do no work
    /// along it: `T` (6 × 5) spans `{f : sᵀf = 0}`, `M = Tᵀ G T` with `G = Φ^A_jj + Φ^B_jj`, and
    /// `W = T M⁻¹ Tᵀ`. Only `M` must be positive definite — `G` itself may not be, numerically,
    /// along the free direction (long straight chains). From `G f = y + s q̈` and `sᵀf = Q`
    /// with `f = T λ + f₀ Q`, `f₀ = e_m / s_m`: `f = W y + f_τ Q`, `f_τ = f₀ − W G f₀`, and
    /// `q̈ = gᵀ y / sᵀs + q̈_τ Q` with `g = W G s − s`, `q̈_τ = sᵀ G f_τ / sᵀs`. So
    /// `K = gᵀ G_F / sᵀs`, `N = W G_F`, `n = γ = W β + f_τ Q`,
    /// `Φ^C_hk = Φ^X_hk [same side] − G_F,hᵀ N_k`, `b^C_h = b^X_h − G_F,hᵀ γ`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn join_one_axis(
        &mut self,
        model: &Model,
        n: usize,
        tau: &[f64],
        g: &[[f64; 6]; 6],
        mut sv: [f64; 6],
        prismatic: bool,
        beta: &[f64; 6],
    ) -> Result<(), DynamicsError> {
        let NodeKind::Join {
            joint,
            parent_side: a,
            child_side: b,
        } = model.assembly.nodes[n].kind
        else {
            unreachable!("join() on a leaf")
        };
        let body = &model.bodies[joint];
        let nhc = self.coef.handles[n];
        let vo = body.v_offset;
        // The axis passes through P_j: the other half is rounding.
        let off = if prismatic { 3 } else { 0 };
        for x in &mut sv[3 - off..6 - off] {
            *x = 0.0;
        }
        let t = AxisBasis::new(&sv, off);
        // M = Tᵀ G T (5×5) and its Cholesky factor.
        // Columns of T are sparse: G T e_0 = G_a − r_a G_m, G T e_1 = G_b − r_b G_m, the others
        // columns of G (the same sums as the dense product: two terms at most).
        let mut m5 = [[0.0; 6]; 6];
        for c in 0..5 {
            let gt: [f64; 6] = match c {
                0 => std::array::from_fn(|r| g[r][t.a] + g[r][t.m] * -t.ra),
                1 => std::array::from_fn(|r| g[r][t.b] + g[r][t.m] * -t.rb),
                _ => std::array::from_fn(|r| g[r][t.keep[c - 2]]),
            };
            let r = t.tr(&gt);
            for i in 0..5 {
                m5[i][c] = r[i];
            }
        }
        // L Lᵀ of the leading 5×5 block and the reciprocals 1 / L_jj of its diagonal.
        let (mut l5, mut ldinv) = ([[0.0f64; 6]; 6], [0.0f64; 5]);
        if !cholesky_into(&m5, 5, &mut l5, &mut ldinv) {
            return Err(DynamicsError::Singular {
                joint: body.joint_name(),
                detail: "Φ_jj^A + Φ_jj^B is not positive definite on the constraint forces",
            });
        }
        let w_apply = |y: &[f64; 6]| -> [f64; 6] {
            let u = t.tr(y);
            let mut lam = u;
            solve_llt_k(&l5, 5, &mut lam);
            t.apply(&lam)
        };
        let ss: f64 = sv.iter().map(|x| x * x).sum();
        let gs = Mat6(*g).mul_vec(&sv);
        let mut f0 = [0.0; 6];
        f0[t.m] = 1.0 / sv[t.m];
        let gf0: [f64; 6] = std::array::from_fn(|r| g[r][t.m] * f0[t.m]);
        // W G s, W G f₀ and W β: three independent right-hand sides, solved side by side.
        let [wgs, wgf0, wb] = w_apply3(&t, &l5, &ldinv, [&gs, &gf0, beta]);
        let gv: [f64; 6] = std::array::from_fn(|i| wgs[i] - sv[i]);
        let ft: [f64; 6] = std::array::from_fn(|i| f0[i] - wgf0[i]);
        let gft = Mat6(*g).mul_vec(&ft);
        let qt = dot6::<Portable>(&sv, &gft) / ss;
        let q = tau[vo];
        self.maps.qdd_bias[vo] = dot6::<Portable>(&gv, beta) / ss + qt * q;
        let nv: [f64; 6] = std::array::from_fn(|i| wb[i] + ft[i] * q);
        if self.maps.record {
            // κ_β = gᵀ / sᵀs, κ_Q = q̈_τ, ν_β = W, ν_Q = f_τ.
            let mut jm = BiasMaps::default();
            for r in 0..6 {
                jm.kappa_beta[0][r] = gv[r] / ss;
                let mut e = [0.0; 6];
                e[r] = 1.0;
                let c = w_apply(&e);
                for s in 0..6 {
                    jm.nu_beta[s][r] = c[s];
                }
                jm.nu_q[r][0] = ft[r];
            }
            jm.kappa_q[0][0] = qt;
            self.maps.recorded = jm;
        }
        self.maps.force_bias[n] = nv;
        // The substitutions below multiply by reciprocals (`ldinv` from the factorisation: a
        // division's latency would sit on their critical path).
        let ssinv = 1.0 / ss;
        // Per handle h, all six columns of G_F,h at once, row by row (each column's sums in
        // the order of one column at a time): K_h = gᵀ G_F,h / sᵀs, Ỹ_h = L⁻¹ Tᵀ G_F,h
        // (5 × 6, its rows kept in yc[h][0..5]), N_h = T L⁻ᵀ Ỹ_h.
        for h in 0..nhc {
            self.one_axis_handle(n, h, &t, (&l5, &ldinv), &gv, ssinv);
        }
        // Ỹ_hᵀ Ỹ_k is a Gram product: the subtracted part stays positive semidefinite.
        self.assemble(n, a, b, true);
        Ok(())
    }

    /// Handle `h` of the one-axis join `n`, all six columns of G_F,h at once, row by row
    /// (each column's sums in the order of one column at a time): K_h = gᵀ G_F,h / sᵀs,
    /// Ỹ_h = L⁻¹ Tᵀ G_F,h (5 × 6, its rows kept in `scratch.y_rows[h]`), N_h = T L⁻ᵀ Ỹ_h.
    /// `factor`: L of `M = Tᵀ G T` and the reciprocals of its diagonal.
    #[inline(always)]
    fn one_axis_handle(
        &mut self,
        n: usize,
        h: usize,
        t: &AxisBasis,
        factor: (&[[f64; 6]; 6], &[f64; 5]),
        gv: &[f64; 6],
        ssinv: f64,
    ) {
        let (l5, ldinv) = factor;
        let hc = self.coef.layout.hoff[n];
        let ko = self.maps.qdd_gain_at[n];
        let wd = 6 * self.coef.handles[n];
        let gfm = &self.scratch.g_force[h].0;
        let mut kr = row_scaled(&gfm[0], gv[0]);
        for r in 1..6 {
            row_add_scaled(&mut kr, gv[r], &gfm[r]);
        }
        let krow: &mut [f64; 6] = (&mut self.maps.qdd_gain[ko + 6 * h..ko + 6 * h + 6])
            .try_into()
            .expect("a row of 6");
        *krow = row_scaled(&kr, ssinv);
        // Tᵀ G_F,h, then the forward substitution row by row.
        let mut y = [[0.0; 6]; 5];
        y[0] = gfm[t.a];
        row_sub_scaled(&mut y[0], t.ra, &gfm[t.m]);
        y[1] = gfm[t.b];
        row_sub_scaled(&mut y[1], t.rb, &gfm[t.m]);
        y[2] = gfm[t.keep[0]];
        y[3] = gfm[t.keep[1]];
        y[4] = gfm[t.keep[2]];
        for i in 0..5 {
            let mut v = y[i];
            for p in 0..i {
                row_sub_scaled(&mut v, l5[i][p], &y[p]);
            }
            y[i] = row_scaled(&v, ldinv[i]);
        }
        // L⁻ᵀ Ỹ_h, then T.
        let mut z = y;
        for i in (0..5).rev() {
            let mut v = z[i];
            for p in (i + 1)..5 {
                row_sub_scaled(&mut v, l5[p][i], &z[p]);
            }
            z[i] = row_scaled(&v, ldinv[i]);
        }
        let mut nr = [[0.0; 6]; 6];
        nr[t.a] = z[0];
        nr[t.b] = z[1];
        // −r_a z₀ − r_b z₁
        let mut zm = row_scaled(&z[0], -t.ra);
        row_sub_scaled(&mut zm, t.rb, &z[1]);
        nr[t.m] = zm;
        nr[t.keep[0]] = z[2];
        nr[t.keep[1]] = z[3];
        nr[t.keep[2]] = z[4];
        // N's six rows of width 6·nhc, this handle's six columns of each (one range
        // check for the node's block, then fixed-size row slices).
        let blk = &mut self.maps.force_gain[36 * hc..36 * hc + 6 * wd];
        for (dst, row) in blk.chunks_exact_mut(wd).zip(&nr) {
            let dst: &mut [f64; 6] = (&mut dst[6 * h..6 * h + 6])
                .try_into()
                .expect("six columns per handle");
            *dst = *row;
        }
        for (dst, src) in self.scratch.y_rows[h].0.iter_mut().zip(&y) {
            dst[..6].copy_from_slice(src);
        }
    }

    /// Back-substitution at join node `n` with its handle forces in `f`: writes its joint's
    /// `q̈ = K F + k` into `qdd` and its children's handle forces.
    pub(crate) fn expand(&mut self, model: &Model, n: usize) {
        // Also compiled for AVX2 + FMA (the same bits, wider vectors), run when `fused`.
        articula_spatial::fma_dispatch! {
            fn run(this: &mut Adaptive, model: &Model, n: usize);
            avx2_fma: this.switches.fused, Portable;
            |A| this.expand_with(model, n)
        }
        run(self, model, n)
    }

    #[inline(always)]
    fn expand_with(&mut self, model: &Model, n: usize) {
        let tree = &model.assembly;
        let NodeKind::Join {
            joint,
            parent_side: a,
            child_side: b,
        } = tree.nodes[n].kind
        else {
            return;
        };
        let body = &model.bodies[joint];
        let (vo, k) = (body.v_offset, body.nv);
        let (nhc, hc) = (self.coef.handles[n], self.coef.layout.hoff[n]);
        let w = 6 * nhc;
        let ko = self.maps.qdd_gain_at[n];
        let mut fj = self.maps.force_bias[n];
        if nhc == 2 {
            // Two handles (a chain's inner nodes): fixed-length rows, the same sums in the
            // same order (from the first product on, as `Iterator::sum` from −0).
            let (f0, f1) = (
                self.coef.force[hc].to_array(),
                self.coef.force[hc + 1].to_array(),
            );
            let fx: [f64; 12] = std::array::from_fn(|c| if c < 6 { f0[c] } else { f1[c - 6] });
            let dot12 = |row: &[f64; 12]| {
                let mut acc = row[0] * fx[0];
                for c in 1..12 {
                    acc += row[c] * fx[c];
                }
                acc
            };
            let kr = &self.maps.qdd_gain[ko..ko + 12 * k];
            for p in 0..k {
                let row: &[f64; 12] = kr[12 * p..12 * p + 12].try_into().expect("a row of 12");
                self.body.qdd[vo + p] = self.maps.qdd_bias[vo + p] + dot12(row);
            }
            let nm: &[f64; 72] = self.maps.force_gain[36 * hc..36 * hc + 72]
                .try_into()
                .expect("six rows of 12");
            for (r, x) in fj.iter_mut().enumerate() {
                let row: &[f64; 12] = nm[12 * r..12 * r + 12].try_into().expect("a row of 12");
                *x += dot12(row);
            }
        } else {
            for h in 0..nhc {
                self.scratch.handle_forces[6 * h..6 * h + 6]
                    .copy_from_slice(&self.coef.force[hc + h].to_array());
            }
            for p in 0..k {
                let row = &self.maps.qdd_gain[ko + p * w..ko + p * w + w];
                self.body.qdd[vo + p] = self.maps.qdd_bias[vo + p]
                    + row
                        .iter()
                        .zip(&self.scratch.handle_forces)
                        .map(|(x, y)| x * y)
                        .sum::<f64>();
            }
            for (r, x) in fj.iter_mut().enumerate() {
                let row = &self.maps.force_gain[36 * hc + r * w..36 * hc + r * w + w];
                *x += row
                    .iter()
                    .zip(&self.scratch.handle_forces)
                    .map(|(x, y)| x * y)
                    .sum::<f64>();
            }
        }
        let fj = SpatialForce::from_array(fj);
        let (hoa, hob) = (self.coef.layout.hoff[a], self.coef.layout.hoff[b]);
        for h in 0..nhc {
            let fh = self.coef.force[hc + h];
            match self.coef.layout.from[hc + h] {
                (true, i) => self.coef.force[hoa + i] = fh,
                (false, i) => self.coef.force[hob + i] = fh,
            }
        }
        self.coef.force[hoa + self.coef.layout.ja[n]] = -fj;
        self.coef.force[hob + self.coef.layout.jb[n]] = fj;
    }

    /// Main pass over the hybrid body: active joins are joined, the frontier (children of
    /// active nodes that are not active, or the root when nothing is) moves rigidly, nodes below
    /// the frontier are not visited. With `all_active`, every node is articulated.
    pub(crate) fn main_pass(
        &mut self,
        model: &Model,
        tau: &[f64],
        level: Level,
        all_active: bool,
    ) -> Result<(), DynamicsError> {
        let tree = &model.assembly;
        for (h, x) in self.data.x.iter().enumerate() {
            self.coef.point[h] = x.apply_point(DVec3::ZERO);
        }
        self.touched = 0;
        for n in 0..tree.nodes.len() {
            let node = &tree.nodes[n];
            let is_join = matches!(node.kind, NodeKind::Join { .. });
            let active = is_join && (all_active || self.body.active[n]);
            let frontier = !active
                && node
                    .parent
                    .is_none_or(|p| all_active || self.body.active[p]);
            if !active && !frontier {
                continue;
            }
            self.touched += 1;
            if active {
                self.join(model, n, tau, level)?;
            } else if self.composites.grounded[n] {
                self.ground_coefficients(n);
            } else {
                let v = match level {
                    Level::Acceleration => self.data.v[self.composites.top_body[n]],
                    Level::Impulse => SpatialMotion::ZERO,
                };
                let r = self.composites.rigid[n];
                self.rigid_coefficients(model, n, &r, v, self.forces.node_sums[n], level)?;
            }
        }
        Ok(())
    }

    /// Top-down back-substitution through the active region (all joins with `all_active`);
    /// every other joint gets `q̈ = 0`.
    pub(crate) fn back_substitution(&mut self, model: &Model, all_active: bool) {
        let tree = &model.assembly;
        self.body.qdd.fill(0.0);
        let root = tree.root();
        let (ho, nh) = (self.coef.layout.hoff[root], self.coef.handles[root]);
        self.coef.force[ho..ho + nh].fill(SpatialForce::ZERO);
        for n in (0..tree.nodes.len()).rev() {
            if all_active || self.body.active[n] {
                self.expand(model, n);
            }
        }
    }
}

/// `a + b` entry by entry, row by row (`Mat6 + Mat6` took each entry by a scalar load in the
/// join: the same sums).
#[inline(always)]
fn add6(a: &[[f64; 6]; 6], b: &[[f64; 6]; 6]) -> [[f64; 6]; 6] {
    let mut g = *a;
    for (gr, br) in g.iter_mut().zip(b) {
        for (x, y) in gr.iter_mut().zip(br) {
            *x += y;
        }
    }
    g
}

/// `aᵀ x` ([`Mat6::tr_mul_vec`]'s operations, in its order), inlined into the AVX2 join
/// (the crate's own copy was called out of line, unvectorised).
#[inline(always)]
fn tr_mul_vec(a: &Mat6, x: &[f64; 6]) -> [f64; 6] {
    let mut y = [0.0; 6];
    for (r, &xi) in a.0.iter().zip(x) {
        for j in 0..6 {
            y[j] += r[j] * xi;
        }
    }
    y
}

/// A rigid body's handle block `Φ_hk` (mass `m`, centre of mass `c`, `j = I_c⁻¹`, handle
/// points `P_h`, `P_k`; computation axes): `[j, −j E_k; E_h j, 1/m − E_h j E_k]` with
/// `E_x = [c − P_x]×`.
///
/// In closed form, row by row: the columns of `E_h j` are `a × j_k` (`a = c − P_h`) and those
/// of `X E_k` are `[X_y e_z − X_z e_y, X_z e_x − X_x e_z, X_x e_y − X_y e_x]` (`e = c − P_k`,
/// `X_x` the columns of X). The products by a skew matrix as 3 × 3 products (as
/// [`rigid_phi_product`] writes them) add a zero to each of these two-term differences, so the
/// results are the same numbers but for the sign of an exact zero.
#[inline(always)]
pub(crate) fn rigid_phi(m: f64, c: DVec3, j: DMat3, ph: DVec3, pk: DVec3) -> Mat6 {
    let (a, e) = (c - ph, c - pk);
    let jc = [j.x_axis, j.y_axis, j.z_axis];
    // Columns of E_h j, of j E_k and of E_h j E_k.
    let axj = [a.cross(jc[0]), a.cross(jc[1]), a.cross(jc[2])];
    let times_ek = |x: &[DVec3; 3]| {
        [
            x[1] * e.z - x[2] * e.y,
            x[2] * e.x - x[0] * e.z,
            x[0] * e.y - x[1] * e.x,
        ]
    };
    let jek = times_ek(&jc);
    let aje = times_ek(&axj);
    let im = 1.0 / m;
    let row = |r: usize| -> [f64; 6] {
        [
            jc[0][r], jc[1][r], jc[2][r], -jek[0][r], -jek[1][r], -jek[2][r],
        ]
    };
    let low = |r: usize| -> [f64; 6] {
        let d = |k: usize| if k == r { -aje[k][r] + im } else { -aje[k][r] };
        [axj[0][r], axj[1][r], axj[2][r], d(0), d(1), d(2)]
    };
    Mat6([row(0), row(1), row(2), low(0), low(1), low(2)])
}

/// [`rigid_phi`] by 3 × 3 matrix products, as it was computed before its closed form (the
/// reference of the test that they agree).
/// The maps from a join's bias β and joint forces Q to its joint accelerations and join
/// force, from `L` (`L Lᵀ = Φ^A_jj + Φ^B_jj`), `Z = L⁻¹ S` and `D⁻¹` (`k` axes):
/// κ_β = −D⁻¹ Zᵀ L⁻¹, ν_β = L⁻ᵀ (L⁻¹ + Z κ_β), κ_Q = D⁻¹, ν_Q = L⁻ᵀ Z D⁻¹.
#[inline(always)]
fn bias_maps(l: &[[f64; 6]; 6], z: &[[f64; 6]; 6], dinv: &[[f64; 6]; 6], k: usize) -> BiasMaps {
    let mut jm = BiasMaps::default();
    for r in 0..6 {
        let mut e = [0.0; 6];
        e[r] = 1.0;
        let wr = solve_lower(l, &e);
        let zw: [f64; 6] = std::array::from_fn(|p| {
            if p < k {
                dot6::<Portable>(&z[p], &wr)
            } else {
                0.0
            }
        });
        let mut col = wr;
        for p in 0..k {
            let x: f64 = -(0..k).map(|q| dinv[p][q] * zw[q]).sum::<f64>();
            jm.kappa_beta[p][r] = x;
            for s in 0..6 {
                col[s] += z[p][s] * x;
            }
        }
        let nc = solve_lower_t(l, &col);
        for s in 0..6 {
            jm.nu_beta[s][r] = nc[s];
        }
    }
    for q in 0..k {
        let mut col = [0.0; 6];
        for p in 0..k {
            jm.kappa_q[p][q] = dinv[p][q];
            for s in 0..6 {
                col[s] += z[p][s] * dinv[p][q];
            }
        }
        let nc = solve_lower_t(l, &col);
        for s in 0..6 {
            jm.nu_q[s][q] = nc[s];
        }
    }
    jm
}

#[cfg(test)]
pub(crate) fn rigid_phi_product(m: f64, c: DVec3, j: DMat3, ph: DVec3, pk: DVec3) -> Mat6 {
    use articula_spatial::skew;
    let axj = skew(c - ph) * j;
    let ek = skew(c - pk);
    let br = -(axj * ek) + DMat3::from_diagonal(DVec3::splat(1.0 / m));
    Mat6::from_blocks(j, -(j * ek), axj, br)
}

#[cfg(test)]
mod tests {
    use super::{rigid_phi, rigid_phi_product};
    use glam::{DMat3, DVec3};

    /// The closed-form handle block equals the 3 × 3-product one entry by entry, to the bit
    /// for every non-zero entry (`==` also lets an exact zero differ in sign), over random
    /// inertias and points, and points with zero components or on the centre of mass.
    #[test]
    fn rigid_phi_closed_form_is_the_product_form() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut checked = 0;
        for case in 0..500 {
            let l = DMat3::from_cols_array(&std::array::from_fn(|_| rnd()));
            // I_c = L Lᵀ + 0.1: symmetric positive definite, and its inverse as the code forms it.
            let ic = l * l.transpose() + DMat3::from_diagonal(DVec3::splat(0.1));
            let j = ic.inverse();
            let m = 0.5 + rnd().abs();
            let c = DVec3::new(rnd(), rnd(), rnd());
            let mut ph = DVec3::new(rnd(), rnd(), rnd());
            let mut pk = DVec3::new(rnd(), rnd(), rnd());
            match case % 5 {
                1 => ph = c,
                2 => pk = DVec3::new(c.x, 0.0, c.z),
                3 => (ph, pk) = (DVec3::new(0.0, ph.y, 0.0), ph),
                _ => {}
            }
            let (a, b) = (
                rigid_phi(m, c, j, ph, pk),
                rigid_phi_product(m, c, j, ph, pk),
            );
            for r in 0..6 {
                for k in 0..6 {
                    let (x, y) = (a.0[r][k], b.0[r][k]);
                    assert!(x == y, "case {case} entry ({r}, {k}): {x} vs {y}");
                    if x != 0.0 {
                        assert_eq!(x.to_bits(), y.to_bits());
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 500 * 20);
    }
}
