//! Kinetic and potential energy of the current kinematics.

use crate::Data;

impl Data {
    /// Kinetic energy `T = Σ ½ vᵢ·Iᵢvᵢ` of the current kinematics (any dynamics call, or
    /// [`crate::forward_kinematics`]); equal to `½ q̇ᵀ M(q) q̇` ([`crate::mass_matrix`]).
    /// A scalar: the same about any point, so the computation frame's numbers are used as they
    /// are.
    pub fn kinetic_energy(&self) -> f64 {
        self.v
            .iter()
            .zip(&self.inertia)
            .map(|(v, i)| i.kinetic_energy(*v))
            .sum()
    }

    /// Gravitational potential energy `V = −Σ mᵢ g·cᵢ` of the current kinematics (`cᵢ` the
    /// bodies' centres of mass in world coordinates: zero at the world origin), so that
    /// `d(T + V)/dt = q̇ᵀτ` plus the power of the external forces.
    pub fn potential_energy(&self) -> f64 {
        self.inertia
            .iter()
            .map(|i| -self.gravity.dot(i.h + self.origin * i.mass))
            .sum()
    }
}
