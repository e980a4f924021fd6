//! Armature (MJCF `armature`, a rotor's reflected inertia) in every method: DCA, ABA and CRBA
//! solve `(M + A) q̈ = τ − b`, inverse dynamics returns `(M + A) q̈ + b`, and the mass matrix
//! has `A` on its diagonal — checked against `mass_matrix` and `bias_forces` formed
//! independently (dense solve), on a model with hinge, slide, composed and free joints.

use articula_dca::{
    bias_forces, forward_dynamics, inverse_dynamics, mass_matrix, Data, Method, State,
};
use articula_model::{LoadOptions, Model};

// The models: a free torso with composed joints, armature and damping (its springs do not
// enter `forward_dynamics`), and a planar swimmer whose middle joint alone has armature.
use articula_testkit::{ARMATURE_MJCF as MJCF, SWIMMER_MJCF as SWIMMER};

/// `M q̈ = τ − b` by a dense LU-free solve (Gaussian elimination with partial pivoting).
fn solve(m: &[f64], rhs: &[f64]) -> Vec<f64> {
    let n = rhs.len();
    let mut a: Vec<Vec<f64>> = (0..n)
        .map(|r| {
            let mut row = m[r * n..(r + 1) * n].to_vec();
            row.push(rhs[r]);
            row
        })
        .collect();
    for c in 0..n {
        let p = (c..n)
            .max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))
            .unwrap();
        a.swap(c, p);
        let pivot_row = a[c].clone();
        for row in a.iter_mut().skip(c + 1) {
            let f = row[c] / pivot_row[c];
            for (x, p) in row.iter_mut().zip(&pivot_row).skip(c) {
                *x -= f * p;
            }
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (a[r][n] - s) / a[r][r];
    }
    x
}

#[test]
fn armature_is_on_the_mass_matrix_diagonal_and_in_every_method() {
    for (text, nv) in [(MJCF, 6 + 3 + 1 + 2 + 1), (SWIMMER, 5)] {
        let model = Model::from_mjcf_str(text, &LoadOptions::default()).unwrap();
        assert!(model.dynamics.has_armature());
        assert_eq!(model.nv, nv);
        // DCA with and without leaf clusters: its joins and its clusters' ABA passes.
        for clusters in [true, false] {
            check(&model, clusters);
        }
    }
}

fn check(model: &Model, clusters: bool) {
    let mut rigid = model.clone();
    rigid.dynamics = Default::default();
    let mut data = Data::new(model);
    data.set_leaf_clusters(model, clusters);
    let mut rd = Data::new(&rigid);
    for seed in 0..5 {
        let state = State::random(model, seed, 5.0);
        let m = mass_matrix(model, &mut data, &state.q).unwrap().to_vec();
        let m0 = mass_matrix(&rigid, &mut rd, &state.q).unwrap().to_vec();
        let nv = model.nv;
        for r in 0..nv {
            for c in 0..nv {
                let extra = if r == c {
                    model.dynamics.armature[r]
                } else {
                    0.0
                };
                assert!((m[r * nv + c] - m0[r * nv + c] - extra).abs() < 1e-12);
            }
        }
        let b = bias_forces(model, &mut data, &state.q, &state.qd)
            .unwrap()
            .to_vec();
        let rhs: Vec<f64> = state.tau.iter().zip(&b).map(|(t, b)| t - b).collect();
        let expected = solve(&m, &rhs);
        let scale = expected.iter().fold(1.0f64, |a, x| a.max(x.abs()));
        for method in [Method::Dca, Method::Aba, Method::Crba] {
            let qdd = forward_dynamics(model, &mut data, &state, method)
                .unwrap()
                .to_vec();
            let err = qdd
                .iter()
                .zip(&expected)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(
                err < 1e-10 * scale,
                "{method:?} seed {seed} clusters {clusters}: {err:e}"
            );
            let tau = inverse_dynamics(model, &mut data, &state.q, &state.qd, &qdd, &[])
                .unwrap()
                .to_vec();
            for (a, b) in tau.iter().zip(&state.tau) {
                assert!((a - b).abs() < 1e-9 * (1.0 + b.abs()), "{method:?} ID");
            }
        }
    }
}

/// A wheel (one hinge through its centre of mass, no gravity torque) with armature `a` and
/// damping `b`: the passive force is `−b q̇`, and a semi-implicit Euler step integrates it
/// implicitly, `q̇₁ = q̇₀ (I + a) / (I + a + h b)` exactly, so a damping 100 times too stiff
/// for an explicit step still decays monotonically — by every method.
#[test]
fn damping_is_a_passive_force_integrated_implicitly() {
    let wheel = r#"<mujoco><worldbody><body name="wheel">
        <joint name="spin" axis="0 0 1" armature="0.5" damping="200"/>
        <inertial pos="0 0 0" mass="2" diaginertia="1 1 1.5"/>
      </body></worldbody></mujoco>"#;
    let model = Model::from_mjcf_str(wheel, &LoadOptions::default()).unwrap();
    let (i, a, b, h) = (1.5, 0.5, 200.0, 0.01);
    let mut out = vec![0.0; 1];
    model.passive_forces(&[0.3], &[2.0], &mut out);
    assert_eq!(out, vec![-400.0]);
    for method in [Method::Dca, Method::Aba, Method::Crba] {
        let mut data = Data::new(&model);
        let mut state = State::neutral(&model);
        state.qd[0] = 2.0;
        // forward_dynamics with τ = 0 stays the rigid-body map: no passive force.
        let qdd = forward_dynamics(&model, &mut data, &state, method).unwrap()[0];
        assert_eq!(qdd, 0.0);
        let mut v = 2.0;
        for _ in 0..20 {
            articula_dca::step(
                &model,
                &mut data,
                &mut state,
                method,
                articula_dca::Integrator::SemiImplicitEuler,
                h,
            )
            .unwrap();
            v *= (i + a) / (i + a + h * b);
            assert!((state.qd[0] - v).abs() <= 1e-14 * 2.0, "{method:?}");
            assert!(state.qd[0] > 0.0);
        }
    }
}

/// A damped chain without armature (as a URDF's `<dynamics damping>` gives): its hinges take
/// DCA's one-axis join in `forward_dynamics` (armature 0) and the general join inside a step
/// (armature `h b`). Both agree with ABA and CRBA: q̈ of random states to 1e-10, and 200
/// semi-implicit Euler steps to 1e-9.
#[test]
fn damped_chain_without_armature_agrees_in_and_out_of_steps() {
    let urdf =
        articula_testkit::chain_urdf(12).replace("</joint>", "<dynamics damping=\"0.7\"/></joint>");
    let model = Model::from_urdf_str(&urdf, &LoadOptions::default()).unwrap();
    assert!(model.dynamics.damping.iter().all(|&b| b == 0.7));
    assert!(!model.dynamics.has_armature());
    for seed in 1..=3 {
        let state = State::random(&model, seed, 1.0);
        let mut data = Data::new(&model);
        let aba = forward_dynamics(&model, &mut data, &state, Method::Aba)
            .unwrap()
            .to_vec();
        for method in [Method::Dca, Method::Crba] {
            let qdd = forward_dynamics(&model, &mut data, &state, method).unwrap();
            let err = articula_testkit::rel_error(qdd, &aba);
            assert!(err < 1e-10, "{method:?} seed {seed}: {err:e}");
        }
    }
    let run = |method| {
        let mut data = Data::new(&model);
        let mut state = State::random(&model, 7, 1.0);
        for _ in 0..200 {
            articula_dca::step(
                &model,
                &mut data,
                &mut state,
                method,
                articula_dca::Integrator::SemiImplicitEuler,
                1e-3,
            )
            .unwrap();
        }
        state
    };
    let (dca, aba, crba) = (run(Method::Dca), run(Method::Aba), run(Method::Crba));
    for other in [&aba, &crba] {
        let eq = articula_testkit::rel_error(&dca.q, &other.q);
        let ev = articula_testkit::rel_error(&dca.qd, &other.qd);
        assert!(eq < 1e-9 && ev < 1e-9, "{eq:e} {ev:e}");
    }
}
