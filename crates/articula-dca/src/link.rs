//! World poses of bodies and of URDF links ([`articula_model::Model::find_link`]), from the
//! current kinematics.

use crate::{Data, DynamicsError};
use articula_model::LinkFrame;
use articula_spatial::SpatialTransform;
use glam::{DMat3, DVec3};

impl Data {
    /// World-frame pose of body `i` from the current kinematics: its axes `R` (columns, world
    /// coordinates) and the position `p` of its origin, so that a point `x` given in the body's
    /// coordinates is at `R x + p` in the world.
    pub fn body_pose(&self, i: usize) -> (DMat3, DVec3) {
        let (r, p) = self.x[i].to_pose();
        (r, p + self.origin)
    }

    /// World-frame pose `(R, p)` of a URDF link (found with
    /// [`articula_model::Model::find_link`]) from the current kinematics: `R` its axes
    /// (columns, world coordinates), `p` the position of its origin; a point `x` in the link's
    /// coordinates is at `R x + p`. A link welded to the world has its fixed pose. An error
    /// ([`DynamicsError::WrongLink`]) for a frame on a body this workspace does not have (a
    /// link found in another model), never an index out of bounds.
    pub fn link_pose(&self, link: &LinkFrame) -> Result<(DMat3, DVec3), DynamicsError> {
        if let Some(body) = link.body.filter(|&b| b >= self.x.len()) {
            return Err(DynamicsError::WrongLink {
                body,
                bodies: self.x.len(),
            });
        }
        let (r, p) = self.link_transform(link).to_pose();
        Ok((r, p + self.origin))
    }

    /// `X_{C←link}`: the map from the link's coordinates to the computation frame's.
    pub(crate) fn link_transform(&self, link: &LinkFrame) -> SpatialTransform {
        match link.body {
            Some(b) => self.x[b] * link.to_body,
            // X_{C←W} X_{W←link}
            None => SpatialTransform::xlt(self.origin) * link.to_body,
        }
    }
}
