//! Singular configurations and DCA's fallback (issue 39, item 2).
//!
//! - At the exact gimbal lock of the humanoid's composed hip (`l_hip_x = π/2`: the z and y
//!   axes coincide) DCA, ABA and CRBA all refuse, naming the hip, by the one test they share
//!   (`joint_block_regular`), fixed and floating base; a little away from the lock all three
//!   solve and agree.
//! - A uniform chain hanging at rest, tilted as a whole at its first joint: 20,000 links at
//!   0.2, 0.3 and 0.5 rad, DCA refines its own answer (the Newton–Euler residual about each
//!   body's own origin) to 1e-9 of the double-double reference; 100,000 links at 0.2, 0.3 and
//!   0.5 rad, where the fixed-point refinement diverges at 0.2 and 0.3, GMRES does, with no
//!   fallback (`Data::fallback_count`).
//! - The fallback itself: a DCA solve that cannot be certified is answered by ABA and counted
//!   (`dca_that_cannot_certify_falls_back_to_aba`).

use articula_dca::{forward_dynamics, Data, DynamicsError, Method, State};
use articula_model::Model;
use articula_testkit::{chain, rel_error, Dd, ReferenceModel};

const METHODS: [Method; 3] = [Method::Dca, Method::Aba, Method::Crba];

fn humanoid_at(floating: bool, hip_x: f64) -> (Model, State) {
    let model = articula_testkit::bundled_with("humanoid", floating);
    let mut s = State::neutral(&model);
    let (_, part) = model
        .find_joint("l_hip_x")
        .expect("the humanoid has l_hip_x");
    s.q[part.q_offset] = hip_x;
    (model, s)
}

#[test]
fn gimbal_lock_is_singular_for_every_method() {
    for floating in [false, true] {
        let (model, s) = humanoid_at(floating, std::f64::consts::FRAC_PI_2);
        let mut data = Data::new(&model);
        for m in METHODS {
            match forward_dynamics(&model, &mut data, &s, m) {
                Err(DynamicsError::Singular { joint, detail }) => {
                    assert!(
                        joint.contains("l_hip_x"),
                        "{m:?} floating={floating}: {joint}"
                    );
                    assert!(detail.contains("gimbal lock"), "{m:?}: {detail}");
                }
                other => panic!("{m:?} floating={floating}: expected singular, got {other:?}"),
            }
        }
    }
}

#[test]
fn near_gimbal_lock_solves_and_methods_agree() {
    for floating in [false, true] {
        let (model, s) = humanoid_at(floating, std::f64::consts::FRAC_PI_2 - 1e-3);
        let mut data = Data::new(&model);
        // The double-double reference has no floating joint: ABA is the reference there.
        let exact: Vec<f64> = match ReferenceModel::new(&model) {
            Ok(reference) => reference
                .aba::<Dd>(&s.q, &s.qd, &s.tau, &s.f_ext)
                .iter()
                .map(|x| x.to_f64())
                .collect(),
            Err(_) => forward_dynamics(&model, &mut data, &s, Method::Aba)
                .unwrap()
                .to_vec(),
        };
        for m in METHODS {
            let qdd = forward_dynamics(&model, &mut data, &s, m).unwrap();
            let e = rel_error(qdd, &exact);
            // 1 mrad from the lock the system's condition is ~1e6: ~1e-10 left.
            assert!(e < 1e-8, "{m:?} floating={floating}: {e:e}");
        }
    }
}

/// DCA (with its fallback) and ABA on the chain of `links` links tilted by `angle` at its
/// first joint, hanging at rest: their errors against the double-double reference and the
/// number of fallbacks DCA took.
fn tilted_chain(links: usize, angle: f64) -> (f64, f64, u64) {
    let model = chain(links);
    let mut s = State::neutral(&model);
    s.q[0] = angle;
    let reference = ReferenceModel::new(&model).unwrap();
    let exact: Vec<f64> = reference
        .aba::<Dd>(&s.q, &s.qd, &s.tau, &s.f_ext)
        .iter()
        .map(|x| x.to_f64())
        .collect();
    let mut data = Data::new(&model);
    let dca = rel_error(
        forward_dynamics(&model, &mut data, &s, Method::Dca).unwrap(),
        &exact,
    );
    let fallbacks = data.fallback_count();
    let aba = rel_error(
        forward_dynamics(&model, &mut data, &s, Method::Aba).unwrap(),
        &exact,
    );
    (dca, aba, fallbacks)
}

#[test]
fn tilted_hanging_chain_20000_solved_by_dca_itself() {
    for angle in [0.2, 0.3, 0.5] {
        let (dca, aba, fallbacks) = tilted_chain(20_000, angle);
        eprintln!("chain 20,000 tilted {angle}: DCA {dca:.2e} ABA {aba:.2e}, {fallbacks} fallback");
        assert!(dca < 1e-9 && aba < 1e-9, "{angle}: {dca:e} {aba:e}");
        assert_eq!(fallbacks, 0, "{angle}");
    }
}

/// 100,000 links (10 km) tilted by 0.2, 0.3 and 0.5 rad: at 0.2 and 0.3 rad a join loses
/// pivots in the out-of-plane directions, DCA's solve of a correction is then ~1,500 times off
/// in a few directions and the fixed-point refinement diverges; GMRES preconditioned by DCA
/// (`krylov.rs`) converges, with no fallback to ABA, to 1e-9 of the reference.
#[test]
fn tilted_hanging_chain_100000_solved_by_dca_itself() {
    for angle in [0.2, 0.3, 0.5] {
        let (dca, aba, fallbacks) = tilted_chain(100_000, angle);
        eprintln!(
            "chain 100,000 tilted {angle}: DCA {dca:.2e} ABA {aba:.2e}, {fallbacks} fallback"
        );
        assert!(dca < 1e-9 && aba < 1e-9, "{angle}: {dca:e} {aba:e}");
        assert_eq!(fallbacks, 0, "{angle}");
    }
}
