//! Ground contact in adaptive dynamics (`docs/contact.md#adaptive-dynamics`): a fully rigid
//! floating humanoid (budget 0) lands and rests on its lowest contact point; with every joint
//! active the adaptive contact step is articula-dca's exact one to rounding.

use articula_adaptive::{Adaptive, HybridContact, Settings};
use articula_dca::{
    forward_kinematics, step_with_contact, ContactData, ContactSettings, Data, Ground, Method,
    State,
};
use articula_model::Model;

/// A workspace re-selecting through the caches (what these tests exercise; the library's
/// default route is `Reselection::ExactSolve`).
fn caches(mut ad: Adaptive) -> Adaptive {
    ad.set_reselection(articula_adaptive::Reselection::Caches);
    ad
}

const DT: f64 = 1e-3;

/// The height of the lowest point of `model`'s contact spheres at `q`.
fn lowest_point(model: &Model, contact: &ContactData, q: &[f64]) -> f64 {
    let mut data = Data::new(model);
    forward_kinematics(model, q, &vec![0.0; model.nv], &mut data).unwrap();
    contact.lowest_point(&data)
}

fn settings() -> ContactSettings {
    ContactSettings {
        ground: Some(Ground::horizontal(0.0)),
        ..ContactSettings::default()
    }
}

#[test]
fn rigid_humanoid_lands_on_its_lowest_point() {
    let model = articula_testkit::bundled_with("humanoid", true);
    let mut contact = HybridContact::new(&model);
    let mut state = State::neutral(&model);
    state.f_ext.clear();
    let start = lowest_point(&model, &contact.contact, &state.q);
    let drop = 0.5;
    state.q[2] += drop - start;
    let q0 = state.q.clone();
    let mut ad = caches(Adaptive::new(
        &model,
        Settings {
            budget: Some(0),
            ..Settings::default()
        },
    ));
    let mut worst = 0.0f64;
    let mut contacts = 0;
    for _ in 0..1500 {
        let report = ad
            .step_with_contact(&model, &mut state, DT, &[], &mut contact, &settings())
            .unwrap();
        assert_eq!(report.active_dofs, 6, "only the floating base moves");
        worst = worst.max(contact.contact.stats.max_penetration);
        contacts = contact.contact.stats.contacts;
    }
    let rest = lowest_point(&model, &contact.contact, &state.q);
    let speed = state.qd.iter().map(|v| v * v).sum::<f64>().sqrt();
    eprintln!(
        "rigid humanoid: lowest point {rest:.3e} m, root fell {:.6} m, speed {speed:.1e}, \
         penetration {worst:.2e} m, {contacts} contacts",
        q0[2] - state.q[2]
    );
    // Resting on the floor: the lowest point at the floor's height (within the slop the
    // position correction leaves), at rest, the root dropped by the gap.
    assert!(rest.abs() < 2e-4, "lowest point at {rest} m");
    assert!(speed < 1e-6, "speed {speed}");
    assert!((q0[2] - state.q[2] - drop).abs() < 2e-4);
    assert!(worst < 5e-3, "penetration {worst} m");
    assert!(contacts >= 3, "stands on {contacts} contact points");
    // A rigid body: every internal joint kept its coordinate and has no velocity.
    assert_eq!(&state.q[7..], &q0[7..]);
    assert!(state.qd[6..].iter().all(|v| *v == 0.0));
}

#[test]
fn full_budget_matches_exact_contact_step() {
    let model = articula_testkit::bundled_with("humanoid", true);
    full_budget_matches(&model);
}

/// The same with armature, damping and springs on the joints (not the floating base): the
/// free motion with the passive forces and damping implicit over the step, the impulses'
/// response with `M + A + h B`, as articula-dca's contact step.
#[test]
fn full_budget_matches_exact_contact_step_with_armature_damping_and_springs() {
    let mut model = articula_testkit::bundled_with("humanoid", true);
    let per_joint = |lo: f64, step: f64| -> Vec<f64> {
        (0..model.nv)
            .map(|i| {
                if i < 6 {
                    0.0
                } else {
                    lo + step * (i % 5) as f64
                }
            })
            .collect()
    };
    let (a, b, k) = (
        per_joint(0.01, 0.01),
        per_joint(2.0, 1.0),
        per_joint(5.0, 2.0),
    );
    model.dynamics.armature = a;
    model.dynamics.damping = b;
    model.dynamics.spring_ref = vec![0.0; model.nv];
    model.dynamics.stiffness = k;
    full_budget_matches(&model);
}

fn full_budget_matches(model: &Model) {
    let model = model.clone();
    let mut exact = State::random(&model, 11, 0.0);
    exact.f_ext.clear();
    exact.tau.iter_mut().for_each(|t| *t = 0.0);
    // Upright, the feet 1 mm above the floor, joints moving: contacts from the first steps.
    exact.q[3..7].copy_from_slice(&[1.0, 0.0, 0.0, 0.0]);
    for v in exact.qd.iter_mut() {
        *v *= 0.3;
    }
    let mut data = Data::new(&model);
    let mut cd = ContactData::new(&model);
    let low = lowest_point(&model, &cd, &exact.q);
    exact.q[2] += 1e-3 - low;
    let mut adaptive = exact.clone();
    let mut hc = HybridContact::new(&model);
    let mut ad = caches(Adaptive::new(&model, Settings::default()));
    let mut worst = 0.0f64;
    let mut rows = 0;
    for _ in 0..20 {
        step_with_contact(
            &model,
            &mut data,
            &mut cd,
            &mut exact,
            Method::Dca,
            DT,
            &settings(),
        )
        .unwrap();
        ad.step_with_contact(&model, &mut adaptive, DT, &[], &mut hc, &settings())
            .unwrap();
        assert_eq!(hc.contact.stats.rows, cd.stats.rows);
        rows = rows.max(cd.stats.rows);
        for (a, e) in adaptive
            .q
            .iter()
            .chain(&adaptive.qd)
            .zip(exact.q.iter().chain(&exact.qd))
        {
            worst = worst.max((a - e).abs());
        }
    }
    eprintln!(
        "full budget vs exact DCA: largest difference {worst:.2e} over 20 steps, up to {rows} rows"
    );
    assert!(rows > 0, "the feet touched");
    assert!(worst < 1e-9, "largest difference {worst}");
}
