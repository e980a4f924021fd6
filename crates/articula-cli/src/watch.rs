//! Divergence checks shared by `simulate` and `scene`: the energy balance against a bound the
//! user sets (`--max-energy-growth`), and a warning when a composed three-rotation joint nears
//! gimbal lock.
//!
//! The checks themselves are the library's (`articula_adaptive::simulation`); this module
//! parses the bound and words the messages in terms of the flags.

use articula_adaptive::simulation::{EnergyStop, GimbalWarning, StopReason};

/// `--max-energy-growth` when not given: the run stops once the energy has grown by more than
/// half of the largest energy in play.
pub use articula_adaptive::simulation::DEFAULT_MAX_ENERGY_GROWTH;
use articula_model::Model;

/// Parses `--max-energy-growth`: a number > 0, `inf` to turn the check off.
pub fn parse_growth(s: &str) -> Result<f64, String> {
    let x: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if x.is_nan() || x <= 0.0 {
        return Err(format!(
            "the energy growth bound must be a positive fraction (or inf: no bound), got '{s}'"
        ));
    }
    Ok(x)
}

/// The message of an energy stop, naming the flag that sets the bound.
pub fn energy_stop_message(stop: &EnergyStop) -> String {
    match *stop {
        EnergyStop::NotFinite { energy } => format!("non-finite energy ({energy} J)"),
        EnergyStop::Diverged {
            growth,
            bound,
            scale,
        } => format!(
            "the energy grew by {growth:.3e} J (E - E0 - work of the applied forces), more \
             than --max-energy-growth {bound} × {scale:.3e} J, the largest energy in play: the \
             integration diverges"
        ),
    }
}

/// Why a run stopped, in the words of the command line (the flags that set the bounds).
pub fn stop_message(reason: &StopReason) -> String {
    match reason {
        StopReason::Energy(e) => energy_stop_message(e),
        other => other.to_string(),
    }
}

/// Prints the warning for a composed joint near gimbal lock on stderr; `who` names the
/// character (empty for `simulate`) and `when` the step.
pub fn warn_gimbal(model: &Model, w: &GimbalWarning, who: &str, when: &str) {
    let body = &model.bodies[w.body];
    eprintln!(
        "warning: {when}: {who}composed joint {} (moving link {}) is near gimbal lock: its \
         axes span {:.3} (|cos| of the middle angle; 0 is singular), where its \
         coordinates' velocities grow like 1/cos and the integration loses \
         accuracy (a smaller --dt; joint limits or springs keep it away)",
        body.joint_name(),
        body.name,
        w.volume
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn growth_bound_parses_positive_numbers_and_inf() {
        assert_eq!(parse_growth("0.5"), Ok(0.5));
        assert_eq!(parse_growth("inf"), Ok(f64::INFINITY));
        for bad in ["0", "-1", "NaN", "x", ""] {
            assert!(parse_growth(bad).is_err(), "{bad}");
        }
    }
}
