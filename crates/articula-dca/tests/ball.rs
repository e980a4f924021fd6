//! Ball (spherical) joints in every method: DCA, ABA and CRBA agree with each other and with the
//! double-double reference (whose ball joint is three axes with the velocity products of one
//! spherical joint, written separately in articula-testkit), inverse dynamics inverts forward
//! dynamics, the Jacobian maps `q̇` to the links' velocities, integration moves the quaternion
//! as the angular velocity says, and stepping conserves energy.

use articula_dca::{
    forward_dynamics, forward_kinematics, inverse_dynamics, mass_matrix, step, Data, Integrator,
    Method, ReferenceFrame, State,
};
use articula_model::{JointKind, LoadOptions, Model};
use articula_testkit::{rel_error, Dd, ReferenceModel};

/// An MJCF tree of `n` bodies in two branches from the root body: ball joints, hinges, a slide
/// and bodies with a ball and a hinge together (a composed joint), anchors off the body origin
/// and tilted bodies. `free`: the root body has a free joint (else a ball joint to the world).
fn ball_tree(n: usize, free: bool) -> String {
    let mut s = String::from(
        r#"<mujoco model="balls"><option gravity="0 0 -9.81"/><worldbody>
<body name="root" pos="0 0 1">"#,
    );
    s += if free {
        r#"<freejoint name="root_free"/>"#
    } else {
        r#"<joint name="root_ball" type="ball" pos="0 0 0.05"/>"#
    };
    s += r#"<geom type="box" size="0.1 0.08 0.05" mass="2"/>"#;
    for branch in 0..2 {
        let mut close = 0;
        for i in 0..n / 2 {
            let name = format!("b{branch}_{i}");
            let sign = if branch == 0 { 1.0 } else { -1.0 };
            s += &format!(
                r#"<body name="{name}" pos="{} 0.01 -0.2" euler="{} 0 {}">"#,
                0.05 * sign,
                7 * i,
                11 * branch
            );
            s += &match i % 4 {
                0 => format!(r#"<joint name="{name}_ball" type="ball" pos="0 0 0.1"/>"#),
                1 => format!(r#"<joint name="{name}_hinge" axis="0.3 1 0.2"/>"#),
                2 => format!(
                    r#"<joint name="{name}_ball" type="ball"/><joint name="{name}_hinge" axis="1 0 0" pos="0 0.02 0"/>"#
                ),
                _ => format!(
                    r#"<joint name="{name}_ball" type="ball" pos="0.01 0 0.05"/><joint name="{name}_slide" type="slide" axis="0 0 1"/>"#
                ),
            };
            s += &format!(
                r#"<geom type="capsule" fromto="0 0 0 0 {} -0.2" size="0.03" mass="{}"/>"#,
                0.02 * sign,
                0.3 + 0.1 * i as f64
            );
            close += 1;
        }
        s += &"</body>".repeat(close);
    }
    s + "</body></worldbody></mujoco>"
}

fn load(text: &str) -> Model {
    Model::from_mjcf_str(text, &LoadOptions::default()).expect("the ball tree loads")
}

/// The models under test: fixed base (ball to the world) and floating base, small and long.
fn models() -> Vec<(String, Model)> {
    let mut out = Vec::new();
    for n in [4, 8, 40] {
        for free in [false, true] {
            out.push((
                format!("ball tree {n} free={free}"),
                load(&ball_tree(n, free)),
            ));
        }
    }
    out
}

/// The models have the joints they say: a ball joint is 4 coordinates and 3 dofs.
#[test]
fn ball_trees_have_ball_joints() {
    let m = load(&ball_tree(8, false));
    let balls = m
        .joint_parts()
        .filter(|(_, p)| p.kind == JointKind::Ball)
        .count();
    assert_eq!(balls, 1 + 2 * 3);
    let hinges = m.joint_parts().filter(|(_, p)| p.kind.is_hinge()).count();
    let slides = m
        .joint_parts()
        .filter(|(_, p)| p.kind == JointKind::Prismatic)
        .count();
    assert_eq!(m.nq, 4 * balls + hinges + slides);
    assert_eq!(m.nv, 3 * balls + hinges + slides);
}

/// DCA, ABA and CRBA agree to 1e-10 on random states (external forces on odd seeds), and with
/// all three agree with the double-double reference to 1e-10.
#[test]
fn methods_agree_with_each_other_and_the_reference() {
    for (label, model) in models() {
        let mut data = Data::new(&model);
        let reference = Some(ReferenceModel::new(&model).unwrap());
        for seed in 0..6 {
            let mut s = State::random(&model, seed, 1.0);
            if seed % 2 == 1 {
                s.randomize_forces(seed, 0.5);
            }
            let mut solve = |method| {
                forward_dynamics(&model, &mut data, &s, method)
                    .unwrap()
                    .to_vec()
            };
            let dca = solve(Method::Dca);
            let aba = solve(Method::Aba);
            let crba = solve(Method::Crba);
            let (e_aba, e_crba) = (rel_error(&dca, &aba), rel_error(&dca, &crba));
            let e_ref = reference.as_ref().map_or(0.0, |r| {
                let exact: Vec<f64> = r
                    .aba::<Dd>(&s.q, &s.qd, &s.tau, &s.f_ext)
                    .into_iter()
                    .map(Dd::to_f64)
                    .collect();
                rel_error(&dca, &exact).max(rel_error(&aba, &exact))
            });
            eprintln!("{label} seed {seed}: ABA {e_aba:.1e}, CRBA {e_crba:.1e}, ref {e_ref:.1e}");
            assert!(e_aba < 1e-10, "{label} seed {seed}: DCA vs ABA {e_aba:e}");
            assert!(
                e_crba < 1e-10,
                "{label} seed {seed}: DCA vs CRBA {e_crba:e}"
            );
            assert!(e_ref < 1e-10, "{label} seed {seed}: vs reference {e_ref:e}");
        }
    }
}

/// Inverse dynamics returns the `τ` forward dynamics was given, and the mass matrix is
/// symmetric with `M q̈ = τ − b` (b the bias forces at `q̈ = 0`).
#[test]
fn inverse_dynamics_and_mass_matrix_invert_forward_dynamics() {
    for (label, model) in models() {
        let mut data = Data::new(&model);
        for seed in 0..4 {
            let s = State::random(&model, seed, 2.0);
            let qdd = forward_dynamics(&model, &mut data, &s, Method::Dca)
                .unwrap()
                .to_vec();
            let tau = inverse_dynamics(&model, &mut data, &s.q, &s.qd, &qdd, &s.f_ext)
                .unwrap()
                .to_vec();
            let e = rel_error(&tau, &s.tau);
            // (The round trip is amplified by M's condition number on the long trees.)
            assert!(e < 1e-8, "{label} seed {seed}: ID(FD(τ)) vs τ {e:e}");
            let nv = model.nv;
            let m = mass_matrix(&model, &mut data, &s.q).unwrap().to_vec();
            for r in 0..nv {
                for c in 0..r {
                    assert!((m[r * nv + c] - m[c * nv + r]).abs() < 1e-12, "{label}");
                }
            }
            let zero = vec![0.0; nv];
            let b = inverse_dynamics(&model, &mut data, &s.q, &s.qd, &zero, &s.f_ext)
                .unwrap()
                .to_vec();
            let mqdd: Vec<f64> = (0..nv)
                .map(|r| (0..nv).map(|c| m[r * nv + c] * qdd[c]).sum::<f64>())
                .collect();
            let rhs: Vec<f64> = (0..nv).map(|j| s.tau[j] - b[j]).collect();
            let e = rel_error(&mqdd, &rhs);
            assert!(e < 1e-10, "{label} seed {seed}: M q̈ vs τ − b {e:e}");
        }
    }
}

/// The world Jacobian of every link maps `q̇` to the link's spatial velocity, and the
/// velocity is the derivative of the pose along `q ⊕ h q̇` (central differences).
#[test]
fn jacobians_and_integration_match_velocities() {
    let model = load(&ball_tree(8, true));
    let mut data = Data::new(&model);
    for seed in 0..3 {
        let s = State::random(&model, seed, 0.0);
        forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
        for body in &model.bodies {
            let link = model.find_link(&body.name).unwrap();
            let j = data
                .link_jacobian(&model, &link, ReferenceFrame::LocalWorldAligned)
                .unwrap()
                .to_vec();
            let nv = model.nv;
            let jv: Vec<f64> = (0..6)
                .map(|r| (0..nv).map(|c| j[r * nv + c] * s.qd[c]).sum())
                .collect();
            // The link's velocity by differences of its world pose along q ⊕ h q̇.
            let h = 1e-6;
            let pose = |sign: f64, data: &mut Data| {
                let mut q = s.q.clone();
                articula_dca::integrate_q(&model, &mut q, &s.qd, sign * h);
                forward_kinematics(&model, &q, &s.qd, data).unwrap();
                data.link_pose(&link).unwrap()
            };
            let ((rp, pp), (rm, pm)) = (pose(1.0, &mut data), pose(-1.0, &mut data));
            let (r0, _) = {
                forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
                data.link_pose(&link).unwrap()
            };
            let dr = (rp - rm) * r0.transpose() * (0.5 / h);
            let w = [
                0.5 * (dr.y_axis.z - dr.z_axis.y),
                0.5 * (dr.z_axis.x - dr.x_axis.z),
                0.5 * (dr.x_axis.y - dr.y_axis.x),
            ];
            let v = ((pp - pm) * (0.5 / h)).to_array();
            let fd: Vec<f64> = w.into_iter().chain(v).collect();
            let e = rel_error(&jv, &fd);
            assert!(
                e < 1e-6,
                "{} seed {seed}: J q̇ vs differences {e:e}",
                body.name
            );
        }
    }
}

/// Energy is conserved when stepping ball-joint trees with RK4 (no damping, no forces): over
/// 0.5 s, halving dt divides the energy error by more than 6 (RK4 with the RKMK slopes is
/// fourth order on the quaternions too), or the error is at rounding level already (the free
/// tree, which only moves internally). Quaternions stay unit.
#[test]
fn stepping_conserves_energy() {
    for free in [false, true] {
        let model = load(&ball_tree(8, free));
        let mut data = Data::new(&model);
        let mut errors = Vec::new();
        for dt in [1e-3, 5e-4] {
            let mut s = State::random(&model, 3, 0.0);
            for x in s.qd.iter_mut() {
                *x *= 0.3;
            }
            let energy = |data: &mut Data, s: &State| {
                forward_kinematics(&model, &s.q, &s.qd, data).unwrap();
                data.kinetic_energy() + data.potential_energy()
            };
            let e0 = energy(&mut data, &s);
            let scale = data.kinetic_energy() + e0.abs();
            for _ in 0..(0.5 / dt) as usize {
                step(&model, &mut data, &mut s, Method::Dca, Integrator::Rk4, dt).unwrap();
            }
            errors.push(((energy(&mut data, &s) - e0) / scale).abs());
            for (_, p) in model.joint_parts() {
                if let Some(o) = p.kind.quaternion_offset() {
                    let n: f64 = s.q[p.q_offset + o..p.q_offset + o + 4]
                        .iter()
                        .map(|x| x * x)
                        .sum();
                    assert!((n.sqrt() - 1.0).abs() < 1e-12, "{}", p.name);
                }
            }
        }
        eprintln!("free={free}: relative energy errors {errors:?}");
        assert!(
            errors[1] < 1e-11 || errors[0] / errors[1] > 6.0,
            "free={free}: energy errors {errors:?} at dt = 1e-3, 5e-4"
        );
        assert!(errors[1] < 1e-4, "free={free}: energy errors {errors:?}");
    }
}
