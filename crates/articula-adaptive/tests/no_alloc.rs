//! A step — a cached re-selection included — allocates nothing once the workspace is warm.

use articula_adaptive::{Adaptive, Settings};
use articula_dca::State;
use articula_spatial::SpatialForce;
mod counting;

#[test]
fn cached_reselection_steps_allocate_nothing() {
    let model = articula_benches::chain(300);
    let mut s = State::random(&model, 42, 0.0);
    s.f_ext.clear();
    // Forces on locked bodies (dirty paths) and a budget that changes (caches rebuilt).
    let forces: Vec<(usize, SpatialForce)> = [17usize, 150, 290]
        .iter()
        .map(|&b| {
            (
                b,
                SpatialForce::new(glam::DVec3::ZERO, glam::DVec3::new(0.5, 0.0, 1.0)),
            )
        })
        .collect();
    for budget in [1usize, 50] {
        let start = counting::allocations();
        let mut ad = Adaptive::new(
            &model,
            Settings {
                budget: Some(budget),
                reselect_every: 1,
                ..Settings::default()
            },
        );
        for _ in 0..50 {
            ad.step_with_forces(&model, &mut s, 1e-4, &forces).unwrap();
        }
        let before = counting::allocations();
        // The counter counts: the workspace and the first step's caches were allocated.
        assert!(before > start + 10, "budget {budget}");
        let mut cached = 0;
        for _ in 0..200 {
            let r = ad.step_with_forces(&model, &mut s, 1e-4, &forces).unwrap();
            assert!(r.reselected);
            cached += usize::from(r.nodes_touched < model.assembly.nodes.len());
        }
        let after = counting::allocations();
        assert_eq!(
            cached, 200,
            "budget {budget}: every re-selection through the caches"
        );
        assert_eq!(
            after - before,
            0,
            "budget {budget}: allocations in 200 steps"
        );
    }
}
