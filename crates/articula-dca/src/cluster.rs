//! DCA's leaf clusters (docs/algorithms.md#leaf-clusters): a small subtree hanging from a
//! branch point is absorbed into its parent body's leaf in inertia form, as ABA absorbs a
//! body's children, so that DCA's joins see only the coarse tree.
//!
//! At a cluster node (body `v`, or the ground, with the absorbed bodies `i`), the main pass
//! runs ABA's pass 2 over the absorbed bodies, leaves first, in the computation frame (about
//! its origin, the floating base's origin or the world's; accelerations relative to gravity,
//! `a' = a − a_g`), so that a child's `Iᵃ` and `pᵃ` add to its parent's sums unmoved:
//!
//! ```text
//! Iᴬ_i = I_i + Σ_children Iᵃ,   pᴬ_i = v_i ×* I_i v_i − f_ext,i + Σ_children pᵃ,
//! U = Iᴬ S,  D = Sᵀ U,  u = τ − Sᵀ pᴬ,  Iᵃ = Iᴬ − U D⁻¹ Uᵀ,  pᵃ = pᴬ + Iᵃ c + U D⁻¹ u,
//! ```
//!
//! so that `v` obeys `Iᴬ_v a'_v + pᴬ_v = Σ_h f_h` for the forces `f_h` at its handles. Taken
//! about `v`'s point `P` (`Iᴬ_P = Xᵀ Iᴬ_v X`, `X` the motion transform from `P` to the origin),
//! with `Φ₀ = (Iᴬ_P)⁻¹` and `T_h` the motion transform from `P` to handle `h`'s point `P_h`
//! (`[ω; v] ↦ [ω; v + ω × (P_h − P)]`):
//!
//! ```text
//! a_h = Σ_k Φ_hk f_k + b_h,   Φ_hk = T_h Φ₀ T_kᵀ,   b_h = T_h b₀,   b₀ = a_g − Φ₀ pᴬ_P,
//! ```
//!
//! a leaf's equations with a general `Φ₀` in place of a rigid body's `I⁻¹`. Only `Iᴬ_P` is
//! inverted, never a single body's inertia: a point-mass body inside a cluster needs no
//! regularisation (its joint's `D > 0` as long as the joint moves its mass), and `Iᴬ_P ⪰ I_v`
//! is positive definite when `v`'s own inertia is ([`crate::data::absorbed`] asks that). The ground as a
//! cluster does not move (`a'_v = −a_g`); its handles' `Φ` and `b` are zero, as the ground's.
//!
//! The back-substitution takes the handle forces the joins above found, `a_v = Φ₀ Σ_h T_hᵀ f_h
//! + b₀`, and runs ABA's pass 3 over the absorbed bodies, parents first:
//! `a'_i = a'_parent + c_i`, `q̈_i = D⁻¹ (u − Uᵀ a'_i)`, `a'_i += S q̈_i`.
//!
//! Accuracy against speed: ABA takes each body about its own origin instead, moving each
//! child's `Iᵃ` by the short arm to its parent. In a cluster that costs every absorbed body a
//! 6×6 shift and the shifts of its `v`, `c` and `S`: about 20% of DCA's time on the branched
//! example robots (median over the corpus, the two builds timed alternately), for an accuracy
//! that only icub needs: its 1.3 kg head sits 0.4 mm from its neck axis, 0.5 m from the
//! floating base, and about the base DCA is 6.8e-10 from the double-double reference (ABA
//! 4.7e-11; about each body's origin DCA was 4.8e-11). The computation frame is kept.

use crate::aba::{force_back, motion_at};
use crate::gather::{sym_tiles, transform};
use crate::{Data, DynamicsError};
use articula_model::Model;
use articula_spatial::numerics::{
    cholesky_inv_diag, invert_factor_inv_diag, solve_lower_inv_diag, solve_lower_t_inv_diag,
};
use articula_spatial::numerics::{dot6, Arith};
use articula_spatial::{Mat6, SpatialForce, SpatialMotion, SymMat6};
use glam::DVec3;

use articula_spatial::numerics::M6;

/// What a cluster node is made of: its body (`None`: the ground) and where its absorbed bodies
/// are in `DcaData::clustered`.
#[derive(Clone, Copy)]
pub(crate) struct Cluster {
    pub body: Option<usize>,
    pub first: usize,
    pub count: usize,
}

impl Cluster {
    /// From `DKind::Cluster`'s fields.
    pub(crate) fn of(body: u32, first: u32, count: u32) -> Cluster {
        Cluster {
            body: (body != u32::MAX).then_some(body as usize),
            first: first as usize,
            count: count as usize,
        }
    }
}

/// The main pass at cluster node `n` (see the module's equations): ABA's pass 2 over the
/// absorbed bodies, then the node's `Φ` blocks and `b` per handle, in its slots (handle
/// offset `ho`, `nh` handles, cross-block offset `bo`, slot `top`). Without `bias` the
/// velocity products `v ×* I v` and the external forces are left out. Sets the world inertia
/// `data.inertia` of every body of the cluster, as leaves do.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn main<A: Arith>(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    bias: bool,
    data: &mut Data,
    n: usize,
    g: Cluster,
    (ho, nh, bo, top): (usize, usize, usize, usize),
) -> Result<(), DynamicsError> {
    for k in (g.first..g.first + g.count).rev() {
        let i = data.dca.cluster.clustered[k] as usize;
        articulate::<A>(model, tau, f_ext, bias, data, i)?;
    }
    let d = &mut data.dca;
    let Some(v) = g.body else {
        // The ground: Φ = 0, b = 0 at its handles.
        for k in 0..nh * nh.saturating_sub(1) / 2 {
            d.joins.phi[bo + k] = Mat6::ZERO;
        }
        for h in 0..nh {
            d.slots.dg[top + h] = crate::small::SymT::ZERO;
            d.slots.b[top + h] = SpatialMotion::ZERO;
        }
        return Ok(());
    };
    let (mut ia_v, pa) = own_terms(model, f_ext, bias, data, v);
    let d = &mut data.dca;
    ia_v.add_assign(&d.cluster.cia[v]);
    let pa_v = pa + d.cluster.cpa[v];
    // From the origin to P, by the arm `r = −P`: Iᴬ_P = Xᵀ Iᴬ X, pᴬ_P = [n + r × f; f].
    let p = d.bodies.point[v];
    let ia_p = ia_v.shifted((-p).to_array()).to_mat6().0;
    let pa_p = force_back(pa_v, -p);
    let pa_p = [pa_p.n, pa_p.f];
    let l = cholesky_inv_diag(&ia_p, 6).ok_or_else(|| DynamicsError::Singular {
        joint: model.bodies[v].joint_name(),
        detail: "the articulated inertia of a leaf cluster is not positive definite",
    })?;
    let phi0 = invert_factor_inv_diag(&l);
    let pa_arr = [
        pa_p[0].x, pa_p[0].y, pa_p[0].z, pa_p[1].x, pa_p[1].y, pa_p[1].z,
    ];
    let g_v = data.gravity;
    let b0 = {
        let x = mul_vec6(&phi0, &pa_arr);
        SpatialMotion::new(
            -DVec3::new(x[0], x[1], x[2]),
            g_v - DVec3::new(x[3], x[4], x[5]),
        )
    };
    d.joins.l[n] = l;
    d.joins.beta[n] = b0;
    // Per handle: T_h Φ₀, then Φ_hh = (T_h Φ₀) T_hᵀ and Φ_hk = (T_h Φ₀) T_kᵀ (h < k).
    for h in 0..nh {
        let ph = d.bodies.point[d.hj[ho + h] as usize] - p;
        let th = transform(ph);
        let tp = mat_mul(&th, &phi0);
        d.slots.dg[top + h] = sym_tiles(&mat_mul_tr(&tp, &th));
        d.slots.b[top + h] = SpatialMotion::new(b0.w, b0.v + b0.w.cross(ph));
        for k in h + 1..nh {
            let pk = d.bodies.point[d.hj[ho + k] as usize] - p;
            let blk = mat_mul_tr(&tp, &transform(pk));
            d.joins.phi[bo + crate::data::ub(nh, h, k)] = Mat6(blk);
        }
    }
    Ok(())
}

/// A body's spatial inertia `I` and its bias `v ×* I v − f_ext` (zero without `bias`) in the
/// computation frame. Sets the world inertia `data.inertia[i]`, as leaves do.
#[inline(always)]
fn own_terms(
    model: &Model,
    f_ext: &[SpatialForce],
    bias: bool,
    data: &mut Data,
    i: usize,
) -> (SymMat6, SpatialForce) {
    let world = crate::kinematics::world_inertia(&data.x[i], &model.bodies[i].inertia);
    data.inertia[i] = world;
    let pa = if bias {
        let v = data.v[i];
        v.cross_force(world.mul_motion(v)) - crate::inputs::f_ext_of(f_ext, i)
    } else {
        SpatialForce::ZERO
    };
    (SymMat6::from_inertia(&world), pa)
}

/// ABA's pass 2 at absorbed body `i`, in the computation frame (see the module's equations
/// and `aba.rs`, whose `U`, `u`, `D⁻¹`, `S` and `c` buffers it fills): `Iᵃ` and `pᵃ` set into
/// or added to the parent's sums (`DcaData::cia`, `cpa`; none for a root body, whose parent is
/// the ground).
#[inline(always)]
fn articulate<A: Arith>(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    bias: bool,
    data: &mut Data,
    i: usize,
) -> Result<(), DynamicsError> {
    let (mut ia, mut pa_i) = own_terms(model, f_ext, bias, data, i);
    let d = &mut data.dca;
    if d.cluster.csums[i] {
        ia.add_assign(&d.cluster.cia[i]);
        pa_i += d.cluster.cpa[i];
    }
    let t = data.topo[i];
    let (vo, k, parent) = (t.vo, t.nv, t.parent);
    let aba = &mut data.aba;
    let c = data.c[i];
    aba.cl[i] = c;
    let body = crate::aba::BodyJoint {
        ia,
        pa: pa_i,
        c,
        origin: None,
        vo,
        k,
        doff: aba.doff[i],
        axis_through_origin: false,
    };
    // Iᵃ and pᵃ straight into the parent's sums.
    let cl = &mut d.cluster;
    let sums = (parent != usize::MAX).then(|| {
        let (cia, cpa) = (&mut cl.cia[parent], &mut cl.cpa[parent]);
        (cia, cpa, cl.cfirst[i])
    });
    let ok = if k == 1 {
        crate::aba::articulate_hinge::<A>(aba, &data.s, tau, &data.armature, body, sums)
    } else {
        crate::aba::articulate_joint::<A>(aba, &data.s, tau, &data.armature, body, sums)
    };
    if !ok {
        return Err(DynamicsError::Singular {
            joint: model.bodies[i].joint_name(),
            detail: "Sᵀ Iᴬ S is not positive definite in a leaf cluster",
        });
    }
    Ok(())
}

/// The back-substitution at cluster node `n` (slot `top`, handle offset `ho`, `nh` handles):
/// the body's acceleration from its handle forces, then ABA's pass 3 over the absorbed bodies
/// (see the module's equations), writing their `q̈`.
#[inline(always)]
pub(crate) fn back<A: Arith>(
    data: &mut Data,
    n: usize,
    g: Cluster,
    (ho, nh, top): (usize, usize, usize),
) {
    let a_g = SpatialMotion::new(DVec3::ZERO, data.gravity);
    let d = &mut data.dca;
    if let Some(v) = g.body {
        let p = d.bodies.point[v];
        // Σ_h T_hᵀ f_h = Σ_h [n_h + (P_h − P) × f_h; f_h].
        let (mut nn, mut ff) = (DVec3::ZERO, DVec3::ZERO);
        for h in 0..nh {
            let f = d.slots.f[top + h];
            let ph = d.bodies.point[d.hj[ho + h] as usize] - p;
            nn += f.n + ph.cross(f.f);
            ff += f.f;
        }
        let l = &d.joins.l[n];
        let x = solve_lower_t_inv_diag(
            l,
            &solve_lower_inv_diag(l, &[nn.x, nn.y, nn.z, ff.x, ff.y, ff.z]),
        );
        let b0 = d.joins.beta[n];
        let (w, a) = (
            DVec3::new(x[0], x[1], x[2]) + b0.w,
            DVec3::new(x[3], x[4], x[5]) + b0.v,
        );
        // About the origin (from P by the arm −P), relative to gravity.
        d.cluster.ca[v] = motion_at(SpatialMotion::new(w, a), -p) - a_g;
    }
    // ABA's pass 3 in the computation frame (`aba.rs`): a' = a_parent + c.
    let aba = &data.aba;
    for k in g.first..g.first + g.count {
        let i = d.cluster.clustered[k] as usize;
        let t = data.topo[i];
        let (vo, nv, doff) = (t.vo, t.nv, aba.doff[i]);
        let a_parent = if t.parent == usize::MAX {
            -a_g
        } else {
            d.cluster.ca[t.parent]
        };
        let ap = a_parent + aba.cl[i];
        if nv == 1 {
            let x = aba.dinv[doff] * (aba.uu[vo] - dot6::<A>(&ap.to_array(), &aba.u[vo]));
            data.qdd[vo] = x;
            d.cluster.ca[i] = ap + aba.sl[vo] * x;
            continue;
        }
        let args = (
            &aba.uu[vo..vo + nv],
            &aba.u[vo..vo + nv],
            &aba.dinv[doff..doff + nv * nv],
            &aba.sl[vo..vo + nv],
            &mut data.qdd[vo..vo + nv],
        );
        use crate::aba::accelerate_multi as acc;
        d.cluster.ca[i] = match nv {
            0 => acc::<A, 0>(args, ap),
            2 => acc::<A, 2>(args, ap),
            3 => acc::<A, 3>(args, ap),
            4 => acc::<A, 4>(args, ap),
            5 => acc::<A, 5>(args, ap),
            _ => acc::<A, 6>(args, ap),
        };
    }
}

/// `Φ_jh f` (j ≠ h) of cluster node `n` (handle offset `ho`): `T_j Φ₀ T_hᵀ f` on the stored
/// Cholesky factor of `Iᴬ_P`; zero for the ground.
#[inline(always)]
pub(crate) fn phi_mul(
    d: &crate::data::DcaData,
    body: u32,
    n: usize,
    ho: usize,
    j: usize,
    h: usize,
    f: SpatialForce,
) -> SpatialMotion {
    if body == u32::MAX {
        return SpatialMotion::ZERO;
    }
    let p = d.bodies.point[body as usize];
    let (pj, ph) = (
        d.bodies.point[d.hj[ho + j] as usize] - p,
        d.bodies.point[d.hj[ho + h] as usize] - p,
    );
    let nn = f.n + ph.cross(f.f);
    let l = &d.joins.l[n];
    let x = solve_lower_t_inv_diag(
        l,
        &solve_lower_inv_diag(l, &[nn.x, nn.y, nn.z, f.f.x, f.f.y, f.f.z]),
    );
    let w = DVec3::new(x[0], x[1], x[2]);
    SpatialMotion::new(w, DVec3::new(x[3], x[4], x[5]) + w.cross(pj))
}

/// `M x`.
fn mul_vec6(m: &M6, x: &[f64; 6]) -> [f64; 6] {
    std::array::from_fn(|r| (0..6).map(|k| m[r][k] * x[k]).sum())
}

/// `A B`.
fn mat_mul(a: &M6, b: &M6) -> M6 {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..6).map(|k| a[r][k] * b[k][c]).sum()))
}

/// `A Bᵀ`.
fn mat_mul_tr(a: &M6, b: &M6) -> M6 {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..6).map(|k| a[r][k] * b[c][k]).sum()))
}

#[cfg(test)]
mod tests {
    use crate::{forward_dynamics_slices, inverse_dynamics, Data, Method, State};
    use articula_model::{LoadOptions, Model};
    use articula_testkit::{
        bundled_with, point_mass_humanoid_urdf, random_tree_urdf, Dd, ReferenceModel,
    };

    fn load(urdf: &str, floating_base: bool) -> Model {
        Model::from_urdf_str(
            urdf,
            &LoadOptions::default().with_floating_base(floating_base),
        )
        .expect("the model loads")
    }

    /// Branched models, fixed and floating base: the bundled humanoid, the point-mass humanoid
    /// and random trees of 40 links.
    fn branched() -> Vec<(String, Model)> {
        let mut out = Vec::new();
        for floating in [false, true] {
            out.push((
                format!("humanoid floating={floating}"),
                bundled_with("humanoid", floating),
            ));
            out.push((
                format!("point-mass humanoid floating={floating}"),
                load(&point_mass_humanoid_urdf(), floating),
            ));
            for seed in 1..=4 {
                out.push((
                    format!("random tree {seed} floating={floating}"),
                    load(&random_tree_urdf(40, seed), floating),
                ));
            }
        }
        out
    }

    /// `max |a − b| / max(1, max |b|)`.
    fn rel(a: &[f64], b: &[f64]) -> f64 {
        let scale = b.iter().fold(1.0f64, |m, x| m.max(x.abs()));
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
            / scale
    }

    /// The bound on the Newton–Euler residual: it weighs q̈'s error by `H`, and on random tree 2
    /// DCA's joins (above its clusters) leave 5e-11 to 1.1e-10 of it where ABA leaves 9e-14,
    /// with q̈ within 1e-13 of the double-double reference either way.
    const RESIDUAL: f64 = 2e-10;

    /// DCA with leaf clusters gives ABA's and CRBA's q̈ to 1e-10 (relative to the largest
    /// entry, at least 1) at random states, with random external forces on odd seeds, in both
    /// compilations of the pass; with a fixed base the double-double reference's
    /// (`ReferenceModel`) too; and the Newton–Euler residual `τ − ID(q̈)` is within [`RESIDUAL`].
    /// Every model has clusters.
    #[test]
    fn clusters_agree_with_aba_crba_and_the_reference() {
        for (label, model) in branched() {
            assert!(
                crate::data::absorbed(&model, true).contains(&true),
                "{label}: no cluster"
            );
            let reference = Some(ReferenceModel::new(&model).unwrap());
            let mut data = Data::new(&model);
            for seed in 0..4u64 {
                let mut s = State::random(&model, seed, 1.0);
                if seed % 2 == 1 {
                    s.randomize_forces(seed, 0.5);
                }
                let mut solve = |m, fused| {
                    data.set_fused_dca(fused);
                    forward_dynamics_slices(&model, &mut data, &s.q, &s.qd, &s.tau, &s.f_ext, m)
                        .unwrap_or_else(|e| panic!("{label} seed {seed}: {e}"))
                        .to_vec()
                };
                let aba = solve(Method::Aba, false);
                let crba = solve(Method::Crba, false);
                let exact: Option<Vec<f64>> = reference.as_ref().map(|r| {
                    r.aba::<Dd>(&s.q, &s.qd, &s.tau, &s.f_ext)
                        .into_iter()
                        .map(Dd::to_f64)
                        .collect()
                });
                for fused in [false, true] {
                    let dca = solve(Method::Dca, fused);
                    let ea = rel(&dca, &aba);
                    let ec = rel(&dca, &crba);
                    let ex = exact.as_ref().map_or(0.0, |x| rel(&dca, x));
                    let mut id = Data::new(&model);
                    let tau =
                        inverse_dynamics(&model, &mut id, &s.q, &s.qd, &dca, &s.f_ext).unwrap();
                    let er = rel(tau, &s.tau);
                    let mut id2 = Data::new(&model);
                    let era = rel(
                        inverse_dynamics(&model, &mut id2, &s.q, &s.qd, &aba, &s.f_ext).unwrap(),
                        &s.tau,
                    );
                    let exr = exact.as_ref().map_or(0.0, |x| {
                        rel(
                            inverse_dynamics(&model, &mut id2, &s.q, &s.qd, x, &s.f_ext).unwrap(),
                            &s.tau,
                        )
                    });
                    eprintln!("{label} seed {seed} fused={fused}: dca res {er:.1e} aba res {era:.1e} exact res {exr:.1e}");
                    assert!(
                        ea <= 1e-10 && ec <= 1e-10 && ex <= 1e-10 && er <= RESIDUAL,
                        "{label} seed {seed} fused={fused}: {ea:.1e} from ABA, {ec:.1e} from \
                         CRBA, {ex:.1e} from the reference, residual {er:.1e}"
                    );
                }
            }
            assert!(
                !data.dca.cluster.clustered.is_empty(),
                "{label}: DCA's tree has no cluster"
            );
        }
    }

    /// The point-mass humanoid's singular bodies all sit in leaf clusters: DCA inverts no
    /// regularised inertia and runs no Newton–Euler refinement (it would without clusters).
    #[test]
    fn point_masses_in_clusters_need_no_refinement() {
        for floating in [false, true] {
            let model = load(&point_mass_humanoid_urdf(), floating);
            let absorbed = crate::data::absorbed(&model, true);
            let singular: Vec<usize> = (0..model.bodies.len())
                .filter(|&i| !crate::data::well_conditioned(&model, &model.bodies[i]))
                .collect();
            assert_eq!(singular.len(), 6, "floating={floating}");
            assert!(singular.iter().all(|&i| absorbed[i]), "floating={floating}");
            let data = Data::new(&model);
            assert!(
                !data.refine_dca && !data.refine.regularised,
                "floating={floating}"
            );
        }
    }

    /// `Data::set_leaf_clusters(false)` runs DCA on the model's own tree: no cluster, the same
    /// q̈ to 1e-10 (the agreement test's bound; the point-mass humanoid then goes through the
    /// regularised leaves and the refinement), and back on, the same bits as before.
    #[test]
    fn clusters_can_be_turned_off() {
        for (label, model) in branched() {
            let s = State::random(&model, 5, 1.0);
            let mut data = Data::new(&model);
            let solve = |data: &mut Data| {
                forward_dynamics_slices(&model, data, &s.q, &s.qd, &s.tau, &[], Method::Dca)
                    .unwrap()
                    .to_vec()
            };
            let with = solve(&mut data);
            assert!(!data.dca.cluster.clustered.is_empty(), "{label}");
            data.set_leaf_clusters(&model, false);
            let without = solve(&mut data);
            assert!(data.dca.cluster.clustered.is_empty(), "{label}");
            let e = rel(&with, &without);
            assert!(e <= 1e-10, "{label}: {e:.1e}");
            if label.starts_with("point-mass") {
                assert!(data.refine_dca && data.refine.regularised, "{label}");
            }
            data.set_leaf_clusters(&model, true);
            assert_eq!(solve(&mut data), with, "{label}");
            assert!(!data.dca.cluster.clustered.is_empty(), "{label}");
        }
    }

    /// A chain has no branch point, so no cluster: DCA's tree (and its bits) are the model's.
    #[test]
    fn chains_have_no_clusters() {
        for floating in [false, true] {
            for name in ["chain10", "chain300"] {
                let model = bundled_with(name, floating);
                assert!(
                    !crate::data::absorbed(&model, true).contains(&true),
                    "{name}"
                );
            }
        }
    }
}
