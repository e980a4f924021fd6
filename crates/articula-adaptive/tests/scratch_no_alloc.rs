//! Steps through a shared [`Scratch`] — re-selections by hand after node metrics, cached
//! re-selections, forces — allocate nothing once the workspaces are warm.

use articula_adaptive::{Adaptive, Scratch, Settings};
use articula_dca::State;
use articula_testkit::{count_allocations, CountingAllocator};

/// A workspace re-selecting through the caches (what these tests exercise; the library's
/// default route is `Reselection::ExactSolve`).
fn caches(mut ad: Adaptive) -> Adaptive {
    ad.set_reselection(articula_adaptive::Reselection::Caches);
    ad
}

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

#[test]
fn shared_scratch_steps_allocate_nothing() {
    let model = articula_testkit::bundled_with("humanoid", true);
    let n = 4;
    let mut scratch = None;
    let mut ads: Vec<Adaptive> = Vec::new();
    // The counter counts: the workspaces are allocated.
    let setup = count_allocations(|| {
        scratch = Some(Scratch::new(&model));
        ads = (0..n)
            .map(|i| {
                caches(Adaptive::new(
                    &model,
                    Settings {
                        budget: Some(6 + 3 * i),
                        reselect_every: 4,
                        ..Settings::default()
                    },
                ))
            })
            .collect();
    });
    assert!(setup > 10, "{setup}");
    let mut scratch = scratch.unwrap();
    let mut states: Vec<State> = (0..n)
        .map(|i| {
            let mut s = State::random(&model, 5 + i as u64, 0.5);
            s.randomize_forces(9 + i as u64, 0.2);
            s
        })
        .collect();
    let mut metrics = vec![vec![0.0; model.assembly.nodes.len()]; n];
    let mut run = |k: usize| {
        if k % 10 == 3 {
            for i in 0..n {
                let s = &states[i];
                ads[i]
                    .node_metrics_with(
                        &mut scratch,
                        &model,
                        &s.q,
                        &s.qd,
                        &s.tau,
                        &s.f_ext,
                        &mut metrics[i],
                    )
                    .unwrap();
            }
            for i in 0..n {
                // Alternating hybrid bodies: every other joint, then the first half.
                let pick = |j: usize| if k % 20 == 3 { j % 2 != 1 } else { j < 18 };
                ads[i]
                    .set_active_with(&mut scratch, &model, &mut states[i], pick)
                    .unwrap();
            }
        }
        for i in 0..n {
            ads[i]
                .step_with(&mut scratch, &model, &mut states[i], 1e-3)
                .unwrap();
        }
    };
    for k in 0..40 {
        run(k);
    }
    let steps = count_allocations(|| {
        for k in 40..140 {
            run(k);
        }
    });
    assert_eq!(steps, 0);
}
