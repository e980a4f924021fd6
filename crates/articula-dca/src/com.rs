//! Centre of mass and its Jacobian, from the current kinematics.

use crate::data::sized;
use crate::{Data, DynamicsError};
use articula_model::Model;
use articula_spatial::SpatialInertia;
use glam::DVec3;

impl Data {
    /// Centre of mass of the moving bodies in **world coordinates**:
    /// `c = origin + Σ hᵢ / Σ mᵢ`, where `hᵢ = mᵢ (cᵢ − origin)` are the first moments in
    /// `Data::inertia` (taken about [`Data::origin`]; `Σ hᵢ / Σ mᵢ` alone is off by `origin`
    /// for a floating base). From the current kinematics (any dynamics call, or
    /// [`crate::forward_kinematics`]). The mass welded to the world with a fixed base
    /// (`Model::ground_mass`) is not counted; a model without moving mass gives `origin`.
    pub fn center_of_mass(&self) -> DVec3 {
        let (m, h) = self
            .inertia
            .iter()
            .fold((0.0, DVec3::ZERO), |(m, h), i| (m + i.mass, h + i.h));
        if m > 0.0 {
            self.origin + h / m
        } else {
            self.origin
        }
    }

    /// The centre-of-mass Jacobian `J_c` (3 × nv, row-major: entry `(r, j)` at `r·nv + j`),
    /// world coordinates: `ċ = J_c q̇`. Column `j`, a degree of freedom of body `b`, is
    /// `(m_b s_j.v + s_j.ω × h_b) / M`: the velocity the joint gives the centre of mass of
    /// `b`'s subtree (mass `m_b`, first moment `h_b`), weighted by its share of the moving
    /// mass `M`. From the current kinematics; sizes its buffer on the first call, then
    /// allocates nothing. (With zero moving mass the Jacobian is zero.) An error when `self`
    /// was built for another model ([`DynamicsError::WrongModel`]).
    pub fn com_jacobian(&mut self, model: &Model) -> Result<&[f64], DynamicsError> {
        crate::inputs::check_data(model, self)?;
        let nv = model.nv;
        let ic = sized(&mut self.quant.ic, model.bodies.len(), SpatialInertia::ZERO);
        ic.copy_from_slice(&self.inertia);
        for (i, body) in model.bodies.iter().enumerate().rev() {
            if let Some(p) = body.parent {
                let c = ic[i];
                ic[p] += c;
            }
        }
        let total: f64 = self.inertia.iter().map(|i| i.mass).sum();
        let scale = if total > 0.0 { 1.0 / total } else { 0.0 };
        let jc = sized(&mut self.quant.com_jacobian, 3 * nv, 0.0);
        for (i, body) in model.bodies.iter().enumerate() {
            let (m, h) = (ic[i].mass, ic[i].h);
            for j in body.v_offset..body.v_offset + body.nv {
                let s = self.s[j];
                let col = (s.v * m + s.w.cross(h)) * scale;
                for r in 0..3 {
                    jc[r * nv + j] = col[r];
                }
            }
        }
        Ok(jc)
    }
}
