//! The checks that stop or flag a run: the energy balance against a bound
//! ([`EnergyWatch`]) and composed three-rotation joints nearing gimbal lock
//! ([`GimbalWatch`]).

use articula_model::Model;

/// The default bound on the energy growth (`SimulationOptions::max_energy_growth`): a run
/// stops once the energy has grown by more than half of the largest energy in play.
pub const DEFAULT_MAX_ENERGY_GROWTH: f64 = 0.5;

/// A composed three-rotation joint is flagged once its axes span less than this volume
/// (`|cos|` of its middle angle: within ~11.5° of gimbal lock).
pub const GIMBAL_WARNING: f64 = 0.2;

/// Why the energy balance stopped a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EnergyStop {
    /// The mechanical energy is not finite (J).
    NotFinite {
        /// The energy found.
        energy: f64,
    },
    /// The energy grew beyond the bound: `growth > bound · scale`.
    Diverged {
        /// `E − E₀ − W` (J).
        growth: f64,
        /// The bound on `growth / scale` (the fraction the caller set).
        bound: f64,
        /// The largest energy in play (J).
        scale: f64,
    },
}

/// The energy balance of a run: `growth = E − E₀ − W` with `E` the mechanical energy and `W`
/// the work of the applied forces (joint torques, pushes), which in exact arithmetic never
/// grows (the dynamics conserves energy; dampers only remove it). Its bound is relative to
/// the largest energy in play, `scale = max(|E₀|, max T, max |V − V₀|, max |W|)` (`T` the kinetic,
/// `V` the potential energy): a diverging run puts its energy into `T`, so that `growth / scale`
/// tends to 1, while an accurate run keeps it at its integration error.
#[derive(Clone, Debug)]
pub struct EnergyWatch {
    /// The energy at the start, `E₀` (J).
    pub start: f64,
    /// The potential energy at the start, `V₀` (J).
    start_potential: f64,
    /// The last energy seen (J).
    pub last: f64,
    /// The largest energy in play so far (J).
    pub scale: f64,
    /// The largest `|E − E₀ − W|` seen (J).
    pub max_drift: f64,
    /// The step where `max_drift` was seen.
    pub max_drift_step: u64,
    /// The bound on `growth / scale` (`∞`: none).
    pub bound: f64,
}

impl EnergyWatch {
    /// Starts from kinetic `t0` and potential `v0` energy, with the bound `bound`.
    pub fn new(t0: f64, v0: f64, bound: f64) -> Self {
        let start = t0 + v0;
        EnergyWatch {
            start,
            start_potential: v0,
            last: start,
            scale: start.abs().max(t0),
            max_drift: 0.0,
            max_drift_step: 0,
            bound,
        }
    }

    /// Records step `k`'s kinetic `t` and potential `v` energy with the work `w` done so far;
    /// `Err` says what stops the run (a non-finite energy, or a growth beyond the bound).
    pub fn check(&mut self, k: u64, t: f64, v: f64, w: f64) -> Result<(), EnergyStop> {
        let e = t + v;
        self.last = e;
        if !e.is_finite() {
            return Err(EnergyStop::NotFinite { energy: e });
        }
        self.scale = self
            .scale
            .max(t)
            .max((v - self.start_potential).abs())
            .max(w.abs());
        let drift = e - self.start - w;
        if drift.abs() > self.max_drift {
            self.max_drift = drift.abs();
            self.max_drift_step = k;
        }
        if drift > self.bound * self.scale {
            return Err(EnergyStop::Diverged {
                growth: drift,
                bound: self.bound,
                scale: self.scale,
            });
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

/// A composed three-rotation joint near gimbal lock (reported once per joint).
#[derive(Clone, Debug, PartialEq)]
pub struct GimbalWarning {
    /// The body (index into `Model::bodies`) whose joint it is.
    pub body: usize,
    /// The volume its axes span, `|cos|` of the middle angle (0 is singular).
    pub volume: f64,
}

/// Flags, once per joint, a composed three-rotation joint nearing gimbal lock
/// ([`articula_model::Body::euler_axes_volume`] below [`GIMBAL_WARNING`]), where its
/// coordinates' velocities grow like `1 / cos` and the integration loses accuracy.
#[derive(Clone, Debug, Default)]
pub struct GimbalWatch {
    /// Per body of the model: whether its joint was flagged.
    warned: Vec<bool>,
}

impl GimbalWatch {
    /// Checks every composed joint of `model` at `q`; calls `warn` for each joint newly near
    /// gimbal lock.
    pub fn check(&mut self, model: &Model, q: &[f64], mut warn: impl FnMut(GimbalWarning)) {
        self.warned.resize(model.bodies.len(), false);
        for (body, (b, warned)) in model.bodies.iter().zip(&mut self.warned).enumerate() {
            if *warned {
                continue;
            }
            if let Some(volume) = b.euler_axes_volume(q) {
                if volume < GIMBAL_WARNING {
                    *warned = true;
                    warn(GimbalWarning { body, volume });
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert_eq!(
            err,
            EnergyStop::Diverged {
                growth: 1400.0,
                bound: 0.5,
                scale: 2000.0
            }
        );
        assert_eq!(w.max_drift_step, 13);
        assert!((w.max_drift - 1400.0).abs() < 1e-9);
        assert!((w.max_drift_relative() - 0.7).abs() < 1e-12);
        let err = EnergyWatch::new(1.0, 1.0, 0.5)
            .check(1, f64::INFINITY, 0.0, 0.0)
            .unwrap_err();
        assert!(matches!(err, EnergyStop::NotFinite { .. }), "{err:?}");
    }
}
