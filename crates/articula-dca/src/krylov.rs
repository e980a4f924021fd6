//! DCA's refinement by GMRES, where the fixed-point refinement of `refine.rs` diverges.
//!
//! The fixed-point iteration `q̈ += P⁻¹ (τ − ID(q̈))`, with `P⁻¹` DCA's solve, converges only
//! when every eigenvalue of `P⁻¹H` lies within 1 of 1. A join whose 5×5 constraint system lost
//! a pivot to rounding (`ldl5` takes its magnitude) breaks that in a few directions. On a
//! uniform chain of 100,000 links hanging tilted at its first joint, a subassembly's compliance
//! about its handle holds the torsion of the whole rod (`1/Σ I_torsion`, ~2) beside its
//! out-of-plane bending (`12/(m ℓ²)`, ~1e-11 for ℓ = 10 km), mixed in world axes by the tilt: the
//! rounding of the first, amplified by the join's `K⁻¹`, exceeds the second. DCA's solve is then
//! wrong by a factor ~1,500 in a handful of directions, and each fixed-point step multiplies the
//! error by as much.
//!
//! GMRES (right-preconditioned by DCA, restarted) needs no such bound: it minimises the
//! residual over the Krylov space of `H P⁻¹`, and a few outlying eigenvalues cost about one
//! iteration each. Each iteration is one DCA solve (`P⁻¹ v`, without velocity products or
//! gravity) and one Newton–Euler product (`H z`, [`rnea_residual`] with `τ = 0`). The residual
//! that starts each cycle is the full one, `τ − ID(q, q̇, q̈)`, so the iteration refines the
//! exact system. Flexible GMRES keeps each `P⁻¹ v` (Saad, *Iterative Methods for Sparse Linear
//! Systems*, §9.4.1): DCA's solve is linear only up to rounding.

use crate::refine::{residual, solve_unbiased, CONVERGED, FLOOR};
use crate::residual::{rnea_residual, RneaInput};
use crate::{Data, DynamicsError};
use articula_model::Model;
use articula_spatial::SpatialForce;
use glam::DVec3;

/// Krylov vectors per cycle (each cycle restarts from the true residual).
const RESTART: usize = 24;

/// Cycles at most before the refinement gives up (the caller then answers with ABA): the
/// default of `KrylovData::max_cycles`. The 100,000-link tilted chain takes 4.
const MAX_CYCLES: usize = 6;

/// A cycle's Arnoldi process stops when its residual estimate falls below this fraction of the
/// residual it started from.
const INNER_TOLERANCE: f64 = 1e-14;

/// The vectors of one GMRES cycle, sized on first use (this path is rare).
#[derive(Clone, Debug)]
pub(crate) struct KrylovData {
    /// `RESTART + 1` orthonormal Arnoldi vectors `v_j`, `nv` each, one after another.
    basis: Vec<f64>,
    /// `RESTART` preconditioned vectors `z_j = P⁻¹ v_j`.
    preconditioned: Vec<f64>,
    /// `nv` zeros: the joint forces of the product `H z` (`τ = 0`).
    zero_tau: Vec<f64>,
    /// Cycles at most ([`MAX_CYCLES`]; the fallback's test sets 0).
    max_cycles: usize,
}

impl Default for KrylovData {
    fn default() -> KrylovData {
        KrylovData {
            basis: Vec::new(),
            preconditioned: Vec::new(),
            zero_tau: Vec::new(),
            max_cycles: MAX_CYCLES,
        }
    }
}

impl KrylovData {
    fn size(&mut self, nv: usize) {
        if self.zero_tau.len() != nv {
            self.basis = vec![0.0; (RESTART + 1) * nv];
            self.preconditioned = vec![0.0; RESTART * nv];
            self.zero_tau = vec![0.0; nv];
        }
    }
}

/// Refines `data.qdd` by restarted flexible GMRES until its correction is below
/// [`CONVERGED`] of `max |q̈|` (or, when cycles stop shrinking it, [`FLOOR`]); `Ok(false)` when
/// it does not converge in [`MAX_CYCLES`] cycles.
pub(crate) fn refine_gmres(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
) -> Result<bool, DynamicsError> {
    let nv = model.nv;
    data.refine.krylov.size(nv);
    let mut last = f64::INFINITY;
    for _ in 0..data.refine.krylov.max_cycles {
        let (_, rmax) = residual(model, tau, f_ext, data);
        if rmax == 0.0 {
            return Ok(true);
        }
        data.refine.corrections += 1;
        let dn = cycle(model, data)?;
        let xn = data.qdd.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if !xn.is_finite() {
            return Ok(false);
        }
        if dn <= CONVERGED * xn || (dn > 0.5 * last && dn <= FLOOR * xn) {
            return Ok(true);
        }
        last = dn;
    }
    Ok(false)
}

/// One GMRES cycle on `H Δ = r` for the residual `r` in `data.refine.r`: `q̈ += Δ`. Returns
/// `max |Δ|`.
fn cycle(model: &Model, data: &mut Data) -> Result<f64, DynamicsError> {
    let nv = model.nv;
    let mut kd = std::mem::take(&mut data.refine.krylov);
    let beta = norm(&data.refine.r);
    for (v, r) in kd.basis[..nv].iter_mut().zip(&data.refine.r) {
        *v = r / beta;
    }
    let mut arnoldi = Arnoldi::new(beta);
    let mut steps = 0;
    let result = (|| {
        for j in 0..RESTART {
            let z = &mut kd.preconditioned[j * nv..(j + 1) * nv];
            precondition(model, data, &kd.basis[j * nv..(j + 1) * nv], z)?;
            let (head, tail) = kd.basis.split_at_mut((j + 1) * nv);
            let w = &mut tail[..nv];
            product(model, data, &kd.zero_tau, z, w);
            steps = j + 1;
            if arnoldi.step(j, head, w, nv) <= INNER_TOLERANCE * beta {
                break;
            }
        }
        Ok(())
    })();
    let y = arnoldi.solution(steps);
    let mut dn = 0.0f64;
    for (i, q) in data.qdd.iter_mut().enumerate() {
        let delta: f64 = (0..steps)
            .map(|j| y[j] * kd.preconditioned[j * nv + i])
            .sum();
        dn = dn.max(delta.abs());
        *q += delta;
    }
    data.refine.krylov = kd;
    result.map(|()| dn)
}

/// The Hessenberg least-squares problem of one cycle, reduced by Givens rotations as it grows.
struct Arnoldi {
    /// Columns of the upper triangular `R` (column j holds rows 0..=j).
    r: [[f64; RESTART]; RESTART],
    /// The rotations' cosines and sines.
    cs: [f64; RESTART],
    sn: [f64; RESTART],
    /// The rotated right-hand side `β e₁`.
    g: [f64; RESTART + 1],
}

impl Arnoldi {
    fn new(beta: f64) -> Arnoldi {
        let mut g = [0.0; RESTART + 1];
        g[0] = beta;
        Arnoldi {
            r: [[0.0; RESTART]; RESTART],
            cs: [0.0; RESTART],
            sn: [0.0; RESTART],
            g,
        }
    }

    /// Orthogonalises `w = H z_j` against `basis` (`j + 1` vectors; twice, modified
    /// Gram–Schmidt), normalises it in place as `v_{j+1}`, and returns the new residual
    /// estimate `|g_{j+1}|`.
    fn step(&mut self, j: usize, basis: &[f64], w: &mut [f64], nv: usize) -> f64 {
        let mut h = [0.0; RESTART + 1];
        for _ in 0..2 {
            for (i, hi) in h.iter_mut().enumerate().take(j + 1) {
                let v = &basis[i * nv..(i + 1) * nv];
                let c: f64 = v.iter().zip(w.iter()).map(|(a, b)| a * b).sum();
                for (x, a) in w.iter_mut().zip(v) {
                    *x -= c * a;
                }
                *hi += c;
            }
        }
        let hn = norm(w);
        if hn > 0.0 {
            w.iter_mut().for_each(|x| *x /= hn);
        }
        h[j + 1] = hn;
        for i in 0..j {
            let (a, b) = (h[i], h[i + 1]);
            h[i] = self.cs[i] * a + self.sn[i] * b;
            h[i + 1] = -self.sn[i] * a + self.cs[i] * b;
        }
        let d = h[j].hypot(h[j + 1]);
        let (c, s) = if d == 0.0 {
            (1.0, 0.0)
        } else {
            (h[j] / d, h[j + 1] / d)
        };
        self.cs[j] = c;
        self.sn[j] = s;
        h[j] = d;
        self.g[j + 1] = -s * self.g[j];
        self.g[j] *= c;
        for (i, hi) in h.iter().enumerate().take(j + 1) {
            self.r[j][i] = *hi;
        }
        self.g[j + 1].abs()
    }

    /// `y` minimising the cycle's residual over its first `k` directions (`R y = g`).
    fn solution(&self, k: usize) -> [f64; RESTART] {
        let mut y = [0.0; RESTART];
        for i in (0..k).rev() {
            let s: f64 = (i + 1..k).map(|c| self.r[c][i] * y[c]).sum();
            y[i] = if self.r[i][i] == 0.0 {
                0.0
            } else {
                (self.g[i] - s) / self.r[i][i]
            };
        }
        y
    }
}

fn norm(x: &[f64]) -> f64 {
    let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if scale == 0.0 || !scale.is_finite() {
        return scale;
    }
    scale * x.iter().map(|v| (v / scale).powi(2)).sum::<f64>().sqrt()
}

/// `z = P⁻¹ v` ([`solve_unbiased`]), the current `q̈` kept.
fn precondition(
    model: &Model,
    data: &mut Data,
    v: &[f64],
    z: &mut [f64],
) -> Result<(), DynamicsError> {
    data.refine.qdd.copy_from_slice(&data.qdd);
    let result = solve_unbiased(model, data, v);
    z.copy_from_slice(&data.qdd);
    data.qdd.copy_from_slice(&data.refine.qdd);
    result
}

/// `w = H z` by the Newton–Euler pass with zero velocities, gravity and joint forces
/// (`τ − ID = −H z`), armature included.
fn product(model: &Model, data: &mut Data, zero_tau: &[f64], z: &[f64], w: &mut [f64]) {
    let rd = &mut data.refine;
    let input = RneaInput {
        x: &data.x,
        fk_plan: &data.fk_plan,
        v: &rd.zv,
        c: &rd.zc,
        s: &data.s,
        gravity: DVec3::ZERO,
        tau: zero_tau,
        f_ext: &[],
        qdd: Some(z),
        armature: &data.armature,
    };
    rnea_residual(model, &input, &mut rd.a, &mut rd.f, w);
    w.iter_mut().for_each(|x| *x = -*x);
}

#[cfg(test)]
mod tests {
    use crate::{forward_dynamics, Data, Method, State};
    use articula_testkit::{chain, rel_error};

    /// The 20,000-link chain hanging tilted by 0.2 rad, whose fixed-point refinement diverges:
    /// with GMRES it is DCA's own answer; with GMRES given no cycle, DCA cannot certify its
    /// answer and the fallback answers with ABA, counted once.
    #[test]
    fn dca_that_cannot_certify_falls_back_to_aba() {
        let model = chain(20_000);
        let mut s = State::neutral(&model);
        s.q[0] = 0.2;
        let mut data = Data::new(&model);
        let aba = forward_dynamics(&model, &mut data, &s, Method::Aba)
            .unwrap()
            .to_vec();
        let dca = forward_dynamics(&model, &mut data, &s, Method::Dca)
            .unwrap()
            .to_vec();
        assert_eq!(data.fallback_count(), 0);
        // Fixed-point steps and GMRES cycles.
        let corrections = data.refine.corrections;
        assert!(rel_error(&dca, &aba) < 1e-9, "{:e}", rel_error(&dca, &aba));
        data.refine.krylov.max_cycles = 0;
        let fallen = forward_dynamics(&model, &mut data, &s, Method::Dca)
            .unwrap()
            .to_vec();
        assert_eq!(data.fallback_count(), 1);
        assert!(corrections > 2, "{corrections}");
        // ABA's answer (refined as `aba_refined` refines it), not the diverged iterate.
        assert!(
            rel_error(&fallen, &aba) < 1e-12,
            "{:e}",
            rel_error(&fallen, &aba)
        );
    }
}
