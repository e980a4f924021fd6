//! Adaptive dynamics on a model with ball joints (models/humanoid_ball.xml, fixed and floating
//! base): at full budget it is exact DCA, for both re-selection routes; rigidifying keeps the
//! momentum and never adds energy; a budget below the model's still steps.

use articula_adaptive::{Adaptive, Reselection, Settings};
use articula_dca::{forward_dynamics_slices, forward_kinematics, Data, Method, State};
use articula_model::{LoadOptions, Model};
use articula_spatial::SpatialForce;

fn model(floating_base: bool) -> Model {
    let path = format!(
        "{}/../../models/humanoid_ball.xml",
        env!("CARGO_MANIFEST_DIR")
    );
    let mut text = std::fs::read_to_string(&path).unwrap();
    if !floating_base {
        text = text.replace(r#"<freejoint name="root"/>"#, "");
    }
    Model::from_mjcf_str(&text, &LoadOptions::default()).unwrap()
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

#[test]
fn full_budget_is_exact_dca() {
    for floating in [false, true] {
        let model = model(floating);
        let mut data = Data::new(&model);
        for seed in 0..4 {
            let mut s = State::random(&model, seed, 2.0);
            s.randomize_forces(seed ^ 0x5a5a, 3.0);
            let exact = forward_dynamics_slices(
                &model,
                &mut data,
                &s.q,
                &s.qd,
                &s.tau,
                &s.f_ext,
                Method::Dca,
            )
            .unwrap()
            .to_vec();
            let scale = exact.iter().fold(1.0f64, |m, x| m.max(x.abs()));
            for route in [Reselection::Caches, Reselection::ExactSolve] {
                for settings in [
                    Settings::default(),
                    Settings {
                        budget: Some(model.nv),
                        ..Settings::default()
                    },
                ] {
                    let mut ad = Adaptive::new(&model, settings);
                    ad.set_reselection(route);
                    let qdd = ad
                        .forward_dynamics(&model, &s.q, &s.qd, &s.tau, &s.f_ext)
                        .unwrap();
                    let err = max_diff(qdd, &exact);
                    assert!(
                        err <= 1e-10 * scale,
                        "floating={floating} seed {seed} {route:?}: {err:e} from DCA"
                    );
                }
            }
        }
    }
}

fn momentum_and_energy(model: &Model, s: &State) -> (SpatialForce, f64) {
    let mut data = Data::new(model);
    forward_kinematics(model, &s.q, &s.qd, &mut data).unwrap();
    (data.momentum(), data.kinetic_energy())
}

#[test]
fn rigidifying_ball_joints_keeps_momentum_and_never_adds_energy() {
    let model = model(true);
    for budget in [0, 3, 8, 20] {
        let mut s = State::random(&model, 40 + budget as u64, 0.0);
        let (h0, k0) = momentum_and_energy(&model, &s);
        let mut ad = Adaptive::new(
            &model,
            Settings {
                budget: Some(budget),
                ..Settings::default()
            },
        );
        ad.set_reselection(Reselection::Caches);
        assert!(ad.reselect(&model, &mut s).unwrap());
        for (i, b) in model.bodies.iter().enumerate() {
            if !ad.is_active(&model, i) {
                assert!(s.qd[b.v_offset..b.v_offset + b.nv]
                    .iter()
                    .all(|x| *x == 0.0));
            }
        }
        assert!(ad.active_dofs(&model) <= budget + 6);
        let (h1, k1) = momentum_and_energy(&model, &s);
        let dh = (h1 - h0).to_array();
        let rel = dh.iter().map(|x| x * x).sum::<f64>().sqrt()
            / h0.to_array().iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(rel <= 1e-12, "budget {budget}: momentum change {rel:e}");
        assert!(k1 <= k0 * (1.0 + 1e-12), "budget {budget}: {k1} > {k0}");
        // Stepping with the reduced budget (RK4 and Euler paths of the workspace).
        for _ in 0..20 {
            ad.step(&model, &mut s, 1e-3).unwrap();
        }
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
}
