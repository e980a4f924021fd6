//! Divergence checks shared by `simulate` and `scene`: the energy balance against a bound the
//! user sets (`--max-energy-growth`), and a warning when a composed three-rotation joint nears
//! gimbal lock.

use articula_model::Model;

/// `--max-energy-growth` when not given: the run stops once the energy has grown by more than
/// half of the largest energy in play.
pub const DEFAULT_MAX_ENERGY_GROWTH: f64 = 0.5;

/// A composed three-rotation joint is reported once its axes span less than this volume
/// (`|cos|` of its middle angle: within ~11.5° of gimbal lock).
pub const GIMBAL_WARNING: f64 = 0.2;

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

/// The energy balance of a run: `growth = E − E₀ − W` with `E` the mechanical energy and `W`
/// the work of the applied forces (joint torques, pushes), which in exact arithmetic never
/// grows (the dynamics conserves energy; dampers only remove it). Its bound is relative to
/// the largest energy in play, `scale = max(|E₀|, max T, max |V − V₀|, max |W|)` (`T` the kinetic,
/// `V` the potential energy): a diverging run puts its energy into `T`, so that `growth / scale`
/// tends to 1, while an accurate run keeps it at its integration error.
#[derive(Clone, Debug)]
pub struct EnergyWatch {
    /// `E₀`, `V₀`.
    pub start: f64,
    v0: f64,
    /// The last energy seen.
    pub last: f64,
    /// The largest energy in play so far.
    pub scale: f64,
    /// The largest `|E − E₀ − W|` seen, and the step where it was seen.
    pub max_drift: f64,
    pub max_drift_step: u64,
    /// The bound on `growth / scale`.
    bound: f64,
}

impl EnergyWatch {
    /// Starts from kinetic `t0` and potential `v0` energy, with the bound `bound`.
    pub fn new(t0: f64, v0: f64, bound: f64) -> Self {
        let start = t0 + v0;
        EnergyWatch {
            start,
            v0,
            last: start,
            scale: start.abs().max(t0),
            max_drift: 0.0,
            max_drift_step: 0,
            bound,
        }
    }

    /// Records step `k`'s kinetic `t` and potential `v` energy with the work `w` done so far;
    /// `Err` names what went wrong (a non-finite energy, or a growth beyond the bound).
    pub fn check(&mut self, k: u64, t: f64, v: f64, w: f64) -> Result<(), String> {
        let e = t + v;
        self.last = e;
        if !e.is_finite() {
            return Err(format!("non-finite energy ({e} J)"));
        }
        self.scale = self.scale.max(t).max((v - self.v0).abs()).max(w.abs());
        let drift = e - self.start - w;
        if drift.abs() > self.max_drift {
            self.max_drift = drift.abs();
            self.max_drift_step = k;
        }
        if drift > self.bound * self.scale {
            return Err(format!(
                "the energy grew by {drift:.3e} J (E - E0 - work of the applied forces), more \
                 than --max-energy-growth {} × {:.3e} J, the largest energy in play: the \
                 integration diverges",
                self.bound, self.scale
            ));
        }
        Ok(())
    }

    /// `max_drift / scale` (0 for a run without energy).
    pub fn max_drift_relative(&self) -> f64 {
        if self.scale > 0.0 {
            self.max_drift / self.scale
        } else {
            0.0
        }
    }
}

/// Warns on stderr, once per joint, when a composed three-rotation joint nears gimbal lock
/// ([`articula_model::Body::euler_axes_volume`] below [`GIMBAL_WARNING`]).
#[derive(Clone, Debug, Default)]
pub struct GimbalWatch {
    /// Per body of the model: whether its joint was reported.
    warned: Vec<bool>,
}

impl GimbalWatch {
    /// Checks every composed joint of `model` at `q`; `who` names the character (empty for
    /// `simulate`) and `when` the step.
    pub fn check(&mut self, model: &Model, q: &[f64], who: &str, when: impl Fn() -> String) {
        self.warned.resize(model.bodies.len(), false);
        for (body, warned) in model.bodies.iter().zip(&mut self.warned) {
            if *warned {
                continue;
            }
            if let Some(v) = body.euler_axes_volume(q) {
                if v < GIMBAL_WARNING {
                    *warned = true;
                    eprintln!(
                        "warning: {}: {who}composed joint {} (moving link {}) is near gimbal lock: its \
                         axes span {v:.3} (|cos| of the middle angle; 0 is singular), where its \
                         coordinates' velocities grow like 1/cos and the integration loses \
                         accuracy (a smaller --dt; joint limits or springs keep it away)",
                        when(),
                        body.joint_name(),
                        body.name
                    );
                }
            }
        }
    }
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

    /// A conservative exchange between kinetic and potential energy passes; energy appearing
    /// from nowhere stops the run once it exceeds the bound times the largest energy in play;
    /// work done by the applied forces is not growth.
    #[test]
    fn energy_watch_stops_growth_not_exchange_or_work() {
        let mut w = EnergyWatch::new(0.0, 100.0, 0.5);
        for k in 1..=10 {
            let t = 10.0 * k as f64;
            w.check(k, t, 100.0 - t + 1e-9, 0.0).unwrap();
        }
        assert!(w.max_drift < 1e-8);
        // Work: the energy rises by what a torque put in.
        w.check(11, 600.0, 0.0, 500.0).unwrap();
        // Growth within half the largest energy in play passes (400 J of 1,000 J), beyond it
        // stops (1,400 J of 2,000 J).
        w.check(12, 1000.0, 0.0, 500.0).unwrap();
        let err = w.check(13, 2000.0, 0.0, 500.0).unwrap_err();
        assert!(err.contains("--max-energy-growth 0.5"), "{err}");
        assert_eq!(w.max_drift_step, 13);
        assert!((w.max_drift - 1400.0).abs() < 1e-9);
        assert!((w.max_drift_relative() - 0.7).abs() < 1e-12);
        let err = EnergyWatch::new(1.0, 1.0, 0.5)
            .check(1, f64::INFINITY, 0.0, 0.0)
            .unwrap_err();
        assert!(err.contains("non-finite energy"), "{err}");
    }
}
