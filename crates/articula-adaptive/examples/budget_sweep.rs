//! How the error of adaptive forward dynamics falls as the budget grows, on the bundled
//! 300-link chain: `cargo run --release -p articula-adaptive --example budget_sweep`.

use articula_adaptive::{Adaptive, Settings};
use articula_dca::{forward_dynamics_slices, Data, Method, State};
use articula_model::{LoadOptions, Model};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = format!("{}/../../models/chain300.urdf", env!("CARGO_MANIFEST_DIR"));
    let model = Model::from_urdf_file(&path, &LoadOptions::default())?;
    let state = State::random(&model, 1, 0.5);
    let mut data = Data::new(&model);
    let exact = forward_dynamics_slices(
        &model,
        &mut data,
        &state.q,
        &state.qd,
        &state.tau,
        &state.f_ext,
        Method::Dca,
    )?
    .to_vec();
    let total: f64 = exact.iter().map(|x| x * x).sum();
    println!("chain300, random state: Σ q̈ᵀq̈ = {total:.6e} (exact DCA)");
    println!(
        "{:>6} {:>14} {:>14} {:>12}",
        "budget", "predicted", "actual", "relative"
    );
    for budget in [0, 1, 5, 10, 25, 50, 100, 150, 200, 250, 300] {
        let mut ad = Adaptive::new(
            &model,
            Settings {
                budget: Some(budget),
                ..Settings::default()
            },
        );
        let qdd = ad.forward_dynamics(&model, &state.q, &state.qd, &state.tau, &state.f_ext)?;
        let actual: f64 = qdd.iter().zip(&exact).map(|(a, e)| (a - e) * (a - e)).sum();
        let sel = ad.selection();
        println!(
            "{budget:>6} {:>14.6e} {actual:>14.6e} {:>12.3e}",
            sel.predicted_error,
            actual / total
        );
    }
    Ok(())
}
