//! The quantities around forward dynamics, by identities with independent computations on the
//! bundled models (fixed and floating base) at seeded random states:
//! - `M(q) q̈ + b(q, q̇) = τ` for the `q̈` of DCA and ABA, and `ID(FD(τ)) = τ` with external
//!   forces (the mass matrix by CRBA, the bias forces and inverse dynamics by RNEA, forward
//!   dynamics by two other algorithms);
//! - a link's Jacobians against central differences of its pose along `q ⊕ ε e_j` (the
//!   floating base included), and `J q̇` against the body velocity of the kinematics;
//! - the centre of mass against `Σ mᵢ cᵢ / M` from the body poses, its Jacobian against central
//!   differences;
//! - power balance `d(T + V)/dt = q̇ᵀτ` along an RK4 trajectory, and `T = ½ q̇ᵀ M q̇`;
//! - momentum against the sum of the bodies' momenta from their poses, `p = M J_c q̇`, and the
//!   centroidal momentum's moment against `n − c × p`.

use articula_dca::{
    bias_forces, forward_dynamics, forward_kinematics, integrate_q, inverse_dynamics, mass_matrix,
    step, Data, Integrator, Method, ReferenceFrame, State,
};
use articula_model::{LinkFrame, Model};
use articula_spatial::{SpatialForce, SpatialMotion, SpatialTransform};
use glam::{DMat3, DVec3};

fn load(name: &str, floating_base: bool) -> Model {
    articula_testkit::bundled_with(name, floating_base)
}

/// The models of the identities: a humanoid (composed joints), a chain, a branching plant and
/// an 80-link rope, each with a fixed and a floating base.
fn models() -> impl Iterator<Item = (String, Model)> {
    ["humanoid", "chain10", "chain30", "plant", "rope"]
        .into_iter()
        .flat_map(|name| {
            [false, true].map(move |fb| (format!("{name} floating={fb}"), load(name, fb)))
        })
}

fn max_abs(xs: impl IntoIterator<Item = f64>) -> f64 {
    xs.into_iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn mat_vec(m: &[f64], rows: usize, x: &[f64]) -> Vec<f64> {
    let cols = x.len();
    (0..rows)
        .map(|r| (0..cols).map(|c| m[r * cols + c] * x[c]).sum())
        .collect()
}

/// A random state with joint forces of the model's size (the rope's segments weigh grams).
fn state(model: &Model, seed: u64) -> State {
    State::random(model, seed, 0.5 * model.moving_mass())
}

#[test]
fn mass_matrix_and_bias_forces_give_the_forward_dynamics() {
    for (label, model) in models() {
        let nv = model.nv;
        let mut data = Data::new(&model);
        for seed in 0..4 {
            let s = state(&model, seed);
            let m = mass_matrix(&model, &mut data, &s.q).unwrap().to_vec();
            // Symmetric, with a positive diagonal.
            for r in 0..nv {
                assert!(
                    m[r * nv + r] > 0.0,
                    "{label}: M[{r},{r}] = {}",
                    m[r * nv + r]
                );
                for c in 0..r {
                    assert_eq!(m[r * nv + c], m[c * nv + r], "{label}: M not symmetric");
                }
            }
            let b = bias_forces(&model, &mut data, &s.q, &s.qd)
                .unwrap()
                .to_vec();
            for method in [Method::Dca, Method::Aba] {
                let qdd = forward_dynamics(&model, &mut data, &s, method)
                    .unwrap()
                    .to_vec();
                let mq = mat_vec(&m, nv, &qdd);
                let scale = max_abs(s.tau.iter().chain(&b).chain(&mq).copied());
                let err = max_abs((0..nv).map(|j| mq[j] + b[j] - s.tau[j]));
                assert!(
                    err <= 1e-9 * scale,
                    "{label} seed {seed} {method:?}: |M q̈ + b − τ| = {err:e} (scale {scale:e})"
                );
            }
        }
    }
}

#[test]
fn inverse_dynamics_inverts_forward_dynamics() {
    for (label, model) in models() {
        let mut data = Data::new(&model);
        for seed in 0..4 {
            let mut s = state(&model, seed);
            s.randomize_forces(seed, 0.1 * model.moving_mass());
            for method in [Method::Dca, Method::Aba] {
                let qdd = forward_dynamics(&model, &mut data, &s, method)
                    .unwrap()
                    .to_vec();
                let tau = inverse_dynamics(&model, &mut data, &s.q, &s.qd, &qdd, &s.f_ext)
                    .unwrap()
                    .to_vec();
                let scale = max_abs(s.tau.iter().copied());
                let err = max_abs(tau.iter().zip(&s.tau).map(|(a, b)| a - b));
                // The accuracy of forward dynamics in joint-force terms: DCA's floating-base
                // refinement triggers above 1e-8 (the rope's floating solves stay below).
                assert!(
                    err <= 1e-8 * scale,
                    "{label} seed {seed} {method:?}: |ID(FD(τ)) − τ| = {err:e} (scale {scale:e})"
                );
            }
            // Without external forces ID(q̈) = M q̈ + b, the bias forces being ID(0).
            let qdd: Vec<f64> = (0..model.nv).map(|j| (j as f64 * 0.37).sin()).collect();
            let tau = inverse_dynamics(&model, &mut data, &s.q, &s.qd, &qdd, &[])
                .unwrap()
                .to_vec();
            let b = bias_forces(&model, &mut data, &s.q, &s.qd)
                .unwrap()
                .to_vec();
            let m = mass_matrix(&model, &mut data, &s.q).unwrap().to_vec();
            let mq = mat_vec(&m, model.nv, &qdd);
            let scale = max_abs(tau.iter().copied());
            let err = max_abs((0..model.nv).map(|j| mq[j] + b[j] - tau[j]));
            assert!(
                err <= 1e-12 * scale,
                "{label} seed {seed}: |M q̈ + b − ID| = {err:e}"
            );
        }
    }
}

/// `q ⊕ ε e_j`.
fn displaced(model: &Model, q: &[f64], j: usize, eps: f64) -> Vec<f64> {
    let mut dir = vec![0.0; model.nv];
    dir[j] = 1.0;
    let mut q = q.to_vec();
    integrate_q(model, &mut q, &dir, eps);
    q
}

/// The angular velocity `ω` with `R₊ R₋ᵀ = exp(2ε [ω]×)` (world axes).
fn rotation_rate(r_plus: DMat3, r_minus: DMat3, eps: f64) -> DVec3 {
    let d = r_plus * r_minus.transpose();
    // vee(log d) for a small rotation: the skew part (the angle is ~2ε, its sine to 1e-12).
    let w = DVec3::new(
        d.y_axis.z - d.z_axis.y,
        d.z_axis.x - d.x_axis.z,
        d.x_axis.y - d.y_axis.x,
    ) * 0.5;
    let s = w.length();
    let w = if s > 0.0 { w * (s.asin() / s) } else { w };
    w / (2.0 * eps)
}

/// Links of the humanoid to check: a body's own link, a link welded to a body (the palm), the
/// end of a composed joint (the thigh), and the root.
const HUMANOID_LINKS: [&str; 5] = ["l_hand", "l_hand_palm", "r_thigh", "head_camera", "pelvis"];

#[test]
fn link_lookup_finds_welded_and_ground_links() {
    let fixed = load("humanoid", false);
    let palm = fixed.find_link("l_hand_palm").unwrap();
    let hand = fixed.find_link("l_hand").unwrap();
    assert_eq!(palm.body, hand.body);
    assert_eq!(fixed.bodies[hand.body.unwrap()].name, "l_hand");
    assert_eq!(hand.to_body, SpatialTransform::IDENTITY);
    // The palm's origin is (0, −0.02, −0.07) in the hand's frame.
    let (_, p) = palm.to_body.to_pose();
    assert!((p - DVec3::new(0.0, -0.02, -0.07)).length() < 1e-15);
    // The fixed base's root is the ground; a floating base's root moves.
    assert_eq!(fixed.find_link("pelvis").unwrap().body, None);
    let floating = load("humanoid", true);
    assert_eq!(floating.find_link("pelvis").unwrap().body, Some(0));
    // Massless links inside composed joints, and unknown names, are not found.
    assert!(fixed.find_link("l_hip_link1").is_none());
    assert!(fixed.find_link("no_such_link").is_none());
}

#[test]
fn link_jacobians_are_the_derivatives_of_the_link_pose() {
    let eps = 1e-6;
    for floating_base in [false, true] {
        let model = load("humanoid", floating_base);
        let nv = model.nv;
        let mut data = Data::new(&model);
        for seed in 0..3 {
            let s = state(&model, seed);
            for name in HUMANOID_LINKS {
                let link = model.find_link(name).unwrap();
                let point = DVec3::new(0.03, -0.05, 0.08);
                forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
                let (r0, p0) = data.link_pose(&link).unwrap();
                let jw = data
                    .link_jacobian(&model, &link, ReferenceFrame::World)
                    .unwrap()
                    .to_vec();
                let jl = data
                    .link_jacobian(&model, &link, ReferenceFrame::Local)
                    .unwrap()
                    .to_vec();
                let ja = data
                    .link_jacobian(&model, &link, ReferenceFrame::LocalWorldAligned)
                    .unwrap()
                    .to_vec();
                let jp = data.point_jacobian(&model, &link, point).unwrap().to_vec();
                let label = format!("{name} floating={floating_base} seed {seed}");
                for j in 0..nv {
                    let pose = |data: &mut Data, e: f64| {
                        let q = displaced(&model, &s.q, j, e);
                        forward_kinematics(&model, &q, &s.qd, data).unwrap();
                        data.link_pose(&link).unwrap()
                    };
                    let (rp, pp) = pose(&mut data, eps);
                    let (rm, pm) = pose(&mut data, -eps);
                    // Finite differences: ω, the origin's velocity, the point's velocity.
                    let w = rotation_rate(rp, rm, eps);
                    let vo = (pp - pm) / (2.0 * eps);
                    let vx = (rp * point + pp - (rm * point + pm)) / (2.0 * eps);
                    let col = |jac: &[f64], rows: usize| -> Vec<f64> {
                        (0..rows).map(|r| jac[r * nv + j]).collect()
                    };
                    // The three frames from the derivatives: world axes about the link origin;
                    // about the world origin (v + ω × (0 − p)); link axes.
                    let aligned = SpatialMotion::new(w, vo);
                    let world = SpatialMotion::new(w, vo - w.cross(p0));
                    let local = SpatialMotion::new(r0.transpose() * w, r0.transpose() * vo);
                    for (what, jac, want) in [
                        ("aligned", &ja, aligned),
                        ("world", &jw, world),
                        ("local", &jl, local),
                    ] {
                        let got = col(jac, 6);
                        let err = max_abs(got.iter().zip(want.to_array()).map(|(a, b)| a - b));
                        assert!(err < 1e-8, "{label} {what} column {j}: {got:?} vs {want:?}");
                    }
                    let got = col(&jp, 3);
                    let err = max_abs(got.iter().zip(vx.to_array()).map(|(a, b)| a - b));
                    assert!(err < 1e-8, "{label} point column {j}: {got:?} vs {vx:?}");
                }
            }
        }
    }
}

#[test]
fn jacobian_times_velocity_is_the_body_velocity() {
    for (label, model) in models() {
        let mut data = Data::new(&model);
        let s = state(&model, 11);
        forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
        for (i, body) in model.bodies.iter().enumerate() {
            let link = model.find_link(&body.name).unwrap();
            assert_eq!(link.body, Some(i));
            // The kinematics' velocity about the world origin, and in the body's frame.
            let world = SpatialTransform::xlt(-data.origin).apply_motion(data.v[i]);
            let local = data.x[i].inv_apply_motion(data.v[i]);
            for (frame, want) in [
                (ReferenceFrame::World, world),
                (ReferenceFrame::Local, local),
            ] {
                let jac = data.link_jacobian(&model, &link, frame).unwrap().to_vec();
                let got = mat_vec(&jac, 6, &s.qd);
                let err = max_abs(got.iter().zip(want.to_array()).map(|(a, b)| a - b));
                let scale = want.norm().max(1.0);
                assert!(
                    err <= 1e-12 * scale,
                    "{label} body {} {frame:?}: J q̇ = {got:?}, v = {want:?}",
                    body.name
                );
            }
        }
    }
}

#[test]
fn center_of_mass_and_its_jacobian() {
    for (label, model) in models() {
        let nv = model.nv;
        let mut data = Data::new(&model);
        let mut s = state(&model, 4);
        if model.floating_base {
            // Far from the world origin: the computation frame's origin is the base position,
            // and a centre of mass left about it would be off by 100 m.
            s.q[0] += 100.0;
        }
        forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
        let com = data.center_of_mass();
        // Σ mᵢ (Rᵢ cᵢ + pᵢ) / M from the poses and the bodies' own inertias.
        let mut sum = DVec3::ZERO;
        for (i, body) in model.bodies.iter().enumerate() {
            let (r, p) = data.body_pose(i);
            sum += (r * body.inertia.com() + p) * body.inertia.mass;
        }
        let want = sum / model.moving_mass();
        assert!(
            (com - want).length() < 1e-12 * want.length().max(1.0),
            "{label}: {com} vs {want}"
        );
        let jc = data.com_jacobian(&model).unwrap().to_vec();
        // Every solver leaves the same kinematics (DCA runs them inside its own pass, with
        // fused multiply–adds where the CPU has them: to rounding).
        for method in [Method::Dca, Method::Aba, Method::Crba] {
            let mut d = Data::new(&model);
            forward_dynamics(&model, &mut d, &s, method).unwrap();
            let err = (d.center_of_mass() - com).length();
            assert!(
                err < 1e-12 * com.length().max(1.0),
                "{label} {method:?}: {err:e}"
            );
            let err = max_abs(
                d.com_jacobian(&model)
                    .unwrap()
                    .iter()
                    .zip(&jc)
                    .map(|(a, b)| a - b),
            );
            assert!(err < 1e-12, "{label} {method:?}: J_c off by {err:e}");
        }
        // ċ = J_c q̇ = p / M (the linear momentum).
        let cdot = mat_vec(&jc, 3, &s.qd);
        let p = data.momentum().f / model.moving_mass();
        let err = max_abs((0..3).map(|r| cdot[r] - p[r]));
        assert!(
            err < 1e-12 * p.length().max(1.0),
            "{label}: J_c q̇ {cdot:?} vs p/M {p}"
        );
        // Central differences of c along q ⊕ ε e_j.
        let eps = 1e-6;
        for j in 0..nv {
            let mut c = |e: f64| {
                let q = displaced(&model, &s.q, j, e);
                forward_kinematics(&model, &q, &s.qd, &mut data).unwrap();
                data.center_of_mass()
            };
            let d = (c(eps) - c(-eps)) / (2.0 * eps);
            let err = max_abs((0..3).map(|r| jc[r * nv + j] - d[r]));
            assert!(
                err < 1e-7,
                "{label}: J_c column {j} vs finite differences {d}"
            );
        }
    }
}

#[test]
fn kinetic_energy_is_half_qd_m_qd_and_power_balances() {
    for (label, model) in models() {
        let nv = model.nv;
        let mut data = Data::new(&model);
        data.momentum_projection = false;
        for gravity in [DVec3::ZERO, DVec3::new(0.0, 0.0, -9.81)] {
            data.gravity = gravity;
            let s = state(&model, 8);
            let m = mass_matrix(&model, &mut data, &s.q).unwrap().to_vec();
            forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
            let t = data.kinetic_energy();
            let mqd = mat_vec(&m, nv, &s.qd);
            let quad = 0.5 * s.qd.iter().zip(&mqd).map(|(a, b)| a * b).sum::<f64>();
            assert!(
                (t - quad).abs() <= 1e-12 * t,
                "{label}: T = {t}, ½ q̇ᵀMq̇ = {quad}"
            );
            // d(T + V)/dt by central differences over one RK4 step each way.
            let h = 1e-6;
            let mut energy = |dt: f64| {
                let mut x = s.clone();
                step(&model, &mut data, &mut x, Method::Dca, Integrator::Rk4, dt).unwrap();
                forward_kinematics(&model, &x.q, &x.qd, &mut data).unwrap();
                data.kinetic_energy() + data.potential_energy()
            };
            let rate = (energy(h) - energy(-h)) / (2.0 * h);
            let power: f64 = s.qd.iter().zip(&s.tau).map(|(a, b)| a * b).sum();
            let scale = power.abs().max(t);
            assert!(
                (rate - power).abs() <= 1e-6 * scale,
                "{label} g = {gravity}: dE/dt = {rate}, q̇ᵀτ = {power}"
            );
        }
    }
}

#[test]
fn momentum_is_the_sum_of_the_body_momenta() {
    for (label, model) in models() {
        let mut data = Data::new(&model);
        let mut s = state(&model, 6);
        if model.floating_base {
            s.q[1] -= 30.0;
        }
        forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
        // Each body: its inertia moved to the world by its pose, times its velocity about the
        // world origin (the kinematics' velocity moved from the computation origin).
        let mut sum = SpatialForce::ZERO;
        for (i, body) in model.bodies.iter().enumerate() {
            let (r, p) = data.body_pose(i);
            let inertia = SpatialTransform::from_pose(r, p).apply_inertia(&body.inertia);
            let v = SpatialTransform::xlt(-data.origin).apply_motion(data.v[i]);
            sum += inertia.mul_motion(v);
        }
        let h = data.momentum();
        let err = (h - sum).norm();
        assert!(
            err <= 1e-12 * sum.norm().max(1.0),
            "{label}: {h:?} vs {sum:?}"
        );
        // About the centre of mass: the moment n − c × p, the same linear momentum.
        let g = data.centroidal_momentum();
        let c = data.center_of_mass();
        let want = SpatialForce::new(h.n - c.cross(h.f), h.f);
        let err = (g - want).norm();
        assert!(
            err <= 1e-12 * h.norm().max(1.0),
            "{label}: {g:?} vs {want:?}"
        );
    }
}

#[test]
fn errors_name_the_input() {
    let model = load("humanoid", true);
    let mut data = Data::new(&model);
    let s = State::neutral(&model);
    let mut qdd = vec![0.0; model.nv];
    qdd[7] = f64::NAN;
    let err = inverse_dynamics(&model, &mut data, &s.q, &s.qd, &qdd, &[]).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "non-finite qdd at {}",
            model
                .joint_parts()
                .find(|(_, p)| p.v_offset == 7)
                .unwrap()
                .1
                .name
        )
    );
    let err = inverse_dynamics(&model, &mut data, &s.q, &s.qd, &qdd[1..], &[]).unwrap_err();
    assert_eq!(err.to_string(), "qdd has length 39, the model needs 40");
    let err = mass_matrix(&model, &mut data, &s.q[1..]).unwrap_err();
    assert_eq!(err.to_string(), "q has length 40, the model needs 41");
    let err = bias_forces(&model, &mut data, &s.q, &s.qd[..3]).unwrap_err();
    assert_eq!(err.to_string(), "qd has length 3, the model needs 40");
}

#[test]
fn a_link_welded_to_the_world_does_not_move() {
    let model = load("humanoid", false);
    let mut data = Data::new(&model);
    let s = state(&model, 2);
    forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
    let root: LinkFrame = model.find_link("pelvis").unwrap();
    let (r, p) = data.link_pose(&root).unwrap();
    assert_eq!((r, p), (DMat3::IDENTITY, DVec3::ZERO));
    let jac = data
        .link_jacobian(&model, &root, ReferenceFrame::World)
        .unwrap();
    assert!(jac.iter().all(|&x| x == 0.0));
}
