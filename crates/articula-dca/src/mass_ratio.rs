//! DCA across extreme neighbour mass ratios (docs/algorithms.md#mass-ratio): a light body held
//! between heavy neighbours enters DCA's solve with a heavier leaf, and the Newton–Euler
//! refinement (`refine.rs`) takes the solve to the exact system's `q̈`.
//!
//! **Why.** A subassembly whose handle sits on a light body `L` (mass `m`) with a heavy
//! neighbour `H` (mass `M`) inside has, at that handle,
//!
//! ```text
//! Φ_LL ≈ X Φ_HH Xᵀ + s sᵀ / d,     |X Φ_HH Xᵀ| ~ 1/M,   1/d ~ 1/(m ℓ²)
//! ```
//!
//! (`s` the motion of `L` about its joint to `H`, `d` `L`'s inertia about it): a rank-one term
//! `M/m` times larger than the compliance in the directions the joint holds rigid. Stored in
//! `f64`, Φ keeps those directions to `ε M/m` relative only; when that handle is then joined
//! to another heavy body (Φ ~ 1/M), the join's `K = Φ^A_jj + Φ^B_jj` inherits the loss (at
//! `M/m = 1e9`, pivots lost to rounding and solves ~1e-4 off). It happens exactly where `L` has
//! two or more heavy neighbours (or the ground of a fixed base), whatever the assembly tree:
//! every join at one of `L`'s joints has either `L` alone on its side (harmless) or `L` with
//! another heavy neighbour behind it.
//!
//! **What DCA does.** Such a body's leaf inverts `σ I` instead of `I` (its spatial inertia
//! scaled by `σ > 1`, centre of mass unchanged), with `σ` bringing its mass to
//! [`INFLATED_RATIO`] below its lightest heavy neighbour's: DCA then solves `H' q̈ = τ − C'` for a
//! nearby model `H' = H + Σ_L J_Lᵀ (σ_L − 1) I_L J_L ⪰ H`, whose joins lose at most
//! `log10 INFLATED_RATIO` digits. The refinement's residual `r = τ − ID(q̈)` uses the exact
//! inertias, and each step `q̈ += H'⁻¹ r` multiplies the error by `E = H'⁻¹ (H' − H)`, whose
//! eigenvalues lie in `[0, 1)` (`H' − H ⪰ 0`, `H ≻ 0`): the share of a motion's kinetic
//! energy that the added inertia carries. As long as `L` cannot move without its heavy
//! neighbours, that share is about `σ m / M = 1 / INFLATED_RATIO` (measured: ~2e-4 per step on
//! the chains of alternating 0.1 kg and 1e8 kg links), and two correction steps reach
//! `refine.rs`' stop. `L` can move alone when
//! the subspaces of its joints to its heavy neighbours share a direction (two revolute joints
//! on one axis line): such a body is left as it is ([`leaf_scales`]). A near-coincident pair
//! contracts slowly, and the refinement's step limit then reports the solve as not
//! converged, never a silently wrong `q̈`.
//!
//! Only the leaf's `Φ = (σ I)⁻¹` and its bias `b = a_g + (σ I)⁻¹ (f_ext − v ×* I v)` change:
//! the body's world inertia (`Data::inertia`, which the residual reads), the leaf clusters and
//! gather hubs (inertia form, which have no such loss) keep the exact `I`.
//!
//! **A light floating base.** The join at a six-axis (floating) joint factors
//! `K = Φ^A_jj + Φ^B_jj = L Lᵀ` like any other (`dca::join`); on a light base with heavy bodies
//! behind it `K` is the whole body's compliance at the base, whose rigid directions rounding
//! has lost (the Cholesky factorisation fails). But with `S` invertible the join needs no `K`:
//! `Z = L⁻¹ S` is invertible, so the projector `Q = 1 − Z (ZᵀZ)⁻¹ Zᵀ` is zero, `W = L⁻ᵀ Q L⁻¹ = 0`
//! (the handles on either side are not coupled) and the joint force is `S⁻ᵀ τ`, whatever the
//! SPD `K`. For models with a neighbour mass ratio above `MASS_RATIO` the join factors the
//! identity instead ([`IDENTITY`], `DcaData::free_identity`): `Φ`, `b` and the joint force of
//! the new node are the same equations, with no quantity that depends on `K`'s rigid
//! directions. Only the joint's `q̈ = S⁻¹ (K f − y)` (the handles' relative acceleration, `f =
//! S⁻ᵀ τ`, `y` the back-substitution's `β + Σ Φ f`) reads `K`, as a product: the
//! back-substitution computes `q̈ = D⁻¹ (τ − Zᵀ L⁻¹ y)`, which with `L = 1` is
//! `S⁻¹ (f − y)`, so the join stores `β' = β − (K − 1) f` in place of `β` ([`free_beta`]).

use articula_model::{JointKind, Model};
use articula_spatial::SpatialMotion;

/// The factor `L = 1` (in `cholesky_inv_diag`'s storage: `1 / L_jj` on the diagonal)
/// a free joint's join uses in place of `K`'s (see the module's equations).
pub(crate) const IDENTITY: [[f64; 6]; 6] = {
    let mut l = [[0.0; 6]; 6];
    let mut i = 0;
    while i < 6 {
        l[i][i] = 1.0;
        i += 1;
    }
    l
};

/// The neighbour mass ratio above which DCA refines every solve to convergence (see
/// `refine.rs`): at 1e4 the join's cancellation costs ~4 digits.
pub(crate) const MASS_RATIO: f64 = 1e4;

/// Whether some body's mass and its parent's differ by more than [`MASS_RATIO`] (massless
/// bodies do not count).
pub(crate) fn large_mass_ratio(model: &Model) -> bool {
    model.bodies.iter().any(|b| {
        b.parent.is_some_and(|p| {
            let (m, mp) = (b.inertia.mass, model.bodies[p].inertia.mass);
            m > 0.0 && mp > 0.0 && (m > MASS_RATIO * mp || mp > MASS_RATIO * m)
        })
    })
}

/// `β' = β − (K − 1) f` with the free joint's force `f = S⁻ᵀ τ = (Z D⁻¹) τ` (`zd`: the rows of
/// `Z D⁻¹`, `Z = S` with `L = 1`), for the back-substitution of a free joint's join that
/// factored the identity (see the module's equations); `k` the `6×6` `K = Φ^A_jj + Φ^B_jj`.
pub(crate) fn free_beta(
    k: &[[f64; 6]; 6],
    zd: &[[f64; 6]; 6],
    tau: &[f64],
    beta: SpatialMotion,
) -> SpatialMotion {
    let f: [f64; 6] = std::array::from_fn(|i| (0..6).map(|p| zd[p][i] * tau[p]).sum());
    let b = beta.to_array();
    SpatialMotion::from_array(std::array::from_fn(|r| {
        let kf: f64 = (0..6).map(|c| k[r][c] * f[c]).sum();
        b[r] - (kf - f[r])
    }))
}

/// The mass ratio an inflated light body keeps to its lightest heavy neighbour: each solve
/// loses about `log10` of it in digits to the joins' cancellation, and each refinement step
/// multiplies the error by about its inverse. The ratio above which the model is refined at
/// all ([`MASS_RATIO`]): the joins lose at most what they lose on
/// any model that is not inflated.
pub(crate) const INFLATED_RATIO: f64 = MASS_RATIO;

/// Per body, the factor `σ ≥ 1` its DCA leaf scales its spatial inertia by (see the module's
/// equations): `σ = M_min / (INFLATED_RATIO · m)` for a body of mass `m` that has two or more heavy
/// neighbours — across a one-axis joint, heavier than [`MASS_RATIO`]
/// `· m`, or the ground a fixed base's root body hangs from (`M_min` the lightest such
/// neighbour's mass) — two of whose joint axes to them differ (so that it cannot move while
/// they stand still); `1` for every other body.
pub(crate) fn leaf_scales(model: &Model) -> Vec<f64> {
    let ratio = MASS_RATIO;
    model
        .bodies
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let m = b.inertia.mass;
            if !(m > 0.0 && m.is_finite()) {
                return 1.0;
            }
            // The heavy neighbours' masses (∞: the ground) and their joints' subspaces in the
            // body's frame, about its origin.
            let mut heavy: Vec<(f64, SpatialMotion)> = Vec::new();
            if let Some(s) = own_axis(model, i) {
                let mp = match b.parent {
                    Some(p) => model.bodies[p].inertia.mass,
                    None if !model.floating_base => f64::INFINITY,
                    None => 0.0,
                };
                if mp > ratio * m {
                    heavy.push((mp, s));
                }
            }
            for &c in &b.children {
                let mc = model.bodies[c].inertia.mass;
                if mc > ratio * m {
                    if let Some(s) = child_axis(model, c) {
                        heavy.push((mc, s));
                    }
                }
            }
            let apart = heavy
                .iter()
                .enumerate()
                .any(|(k, a)| heavy[k + 1..].iter().any(|b| !parallel(&a.1, &b.1)));
            let lightest = heavy.iter().map(|h| h.0).fold(f64::INFINITY, f64::min);
            if heavy.len() < 2 || !apart || !lightest.is_finite() {
                return 1.0;
            }
            (lightest / (INFLATED_RATIO * m)).max(1.0)
        })
        .collect()
}

/// Body `i`'s own joint's subspace in its frame, for a one-axis joint (`None` otherwise).
fn own_axis(model: &Model, i: usize) -> Option<SpatialMotion> {
    let parts = &model.bodies[i].joint;
    match parts.as_slice() {
        [p] if one_axis(p.kind) => Some(p.subspace_column(0)),
        _ => None,
    }
}

/// Child body `c`'s joint's subspace in its parent's frame, about the parent's origin, for a
/// one-axis joint (`None` otherwise): the axis does not move with the joint's own angle.
fn child_axis(model: &Model, c: usize) -> Option<SpatialMotion> {
    let parts = &model.bodies[c].joint;
    match parts.as_slice() {
        [p] if one_axis(p.kind) => Some(p.origin.apply_motion(p.subspace_column(0))),
        _ => None,
    }
}

fn one_axis(kind: JointKind) -> bool {
    kind.is_scalar()
}

/// Whether two joint subspace columns are parallel (to 1e-9 of their lengths, as 6-vectors).
fn parallel(a: &SpatialMotion, b: &SpatialMotion) -> bool {
    let (a, b) = (a.to_array(), b.to_array());
    let dot = |x: &[f64; 6], y: &[f64; 6]| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>();
    let (aa, bb, ab) = (dot(&a, &a), dot(&b, &b), dot(&a, &b));
    aa * bb - ab * ab <= 1e-9 * aa * bb
}

#[cfg(test)]
mod tests {
    use super::{leaf_scales, INFLATED_RATIO};
    use articula_model::{LoadOptions, Model};
    use articula_testkit::ratio_chain_urdf;

    fn ratio_chain(n: usize, ratio: f64, floating_base: bool) -> Model {
        let options = LoadOptions::default().with_floating_base(floating_base);
        Model::from_urdf_str(&ratio_chain_urdf(n, ratio), &options).expect("loads")
    }

    /// In a chain of alternating light (0.1 kg) and heavy links, every light link between two
    /// heavy ones (or the ground and a heavy one) is brought to `INFLATED_RATIO` below them; a
    /// light tip, a light link next to the floating base, heavy links and the 1e3 chain are not.
    #[test]
    fn light_links_between_heavy_ones_are_inflated() {
        let model = ratio_chain(7, 1e9, false);
        let s = leaf_scales(&model);
        let want = 1e8 / (INFLATED_RATIO * 0.1);
        // Bodies 0..7 are links 1..7: light, heavy, …, light tip.
        for (i, &x) in s.iter().enumerate() {
            let expected = if i % 2 == 0 && i < 6 { want } else { 1.0 };
            assert!((x - expected).abs() <= 1e-9 * expected, "body {i}: {x}");
        }
        let floating = ratio_chain(7, 1e9, true);
        let s = leaf_scales(&floating);
        // Body 0 is the floating base (1 kg), body 1 link 1: its neighbours are the base and
        // one heavy link.
        assert_eq!(&s[..3], &[1.0, 1.0, 1.0]);
        assert!((s[3] - want).abs() <= 1e-9 * want);
        assert!(leaf_scales(&ratio_chain(8, 1e3, false))
            .iter()
            .all(|&x| x == 1.0));
        for name in ["chain300", "humanoid", "plant", "rope"] {
            let model = articula_testkit::bundled_with(name, false);
            assert!(leaf_scales(&model).iter().all(|&x| x == 1.0), "{name}");
        }
    }

    /// A light link whose two joints share one axis line spins alone between its heavy
    /// neighbours: it is not inflated (its motion would make the refinement crawl).
    #[test]
    fn a_light_link_on_one_axis_line_is_not_inflated() {
        // The chain's joints are on its axis (z) with axis y: put them all on the y axis line
        // by offsetting along y instead.
        let urdf =
            ratio_chain_urdf(4, 1e9).replace("origin xyz=\"0 0 -0.1\"", "origin xyz=\"0 -0.1 0\"");
        let model = Model::from_urdf_str(&urdf, &LoadOptions::default()).expect("loads");
        assert!(leaf_scales(&model).iter().all(|&x| x == 1.0));
    }
}
