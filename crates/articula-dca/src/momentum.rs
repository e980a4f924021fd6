//! Spatial momentum of the current kinematics: about the world origin and about the centre of
//! mass.

use crate::Data;
use articula_spatial::{SpatialForce, SpatialTransform};

impl Data {
    /// Total spatial momentum `h = Σ Iᵢvᵢ` of the current kinematics, world coordinates, about
    /// the world origin: `[n; p]`, the angular momentum about the world origin and the linear
    /// momentum `p = M ċ` (`M` the moving mass, `ċ` the centre of mass's velocity).
    pub fn momentum(&self) -> SpatialForce {
        // X*_{W←C} = xlt(−origin)*
        SpatialTransform::xlt(-self.origin).apply_force(self.momentum_about_origin())
    }

    /// Centroidal momentum: the total spatial momentum with world axes about the centre of
    /// mass ([`Data::center_of_mass`]): `[n_G; p]`, the angular momentum about the centre of
    /// mass and the linear momentum. (`n_G = n − c × p` from [`Data::momentum`]'s `[n; p]`.)
    pub fn centroidal_momentum(&self) -> SpatialForce {
        let com = self.center_of_mass();
        // X*_{G←C} = xlt(c − origin)*
        SpatialTransform::xlt(com - self.origin).apply_force(self.momentum_about_origin())
    }

    /// `Σ Iᵢvᵢ` in the computation frame.
    fn momentum_about_origin(&self) -> SpatialForce {
        self.v
            .iter()
            .zip(&self.inertia)
            .fold(SpatialForce::ZERO, |acc, (v, i)| acc + i.mul_motion(*v))
    }
}
