//! Jacobians of a link: spatial (6 × nv) in three reference frames, and of a point on the link
//! (3 × nv), from the current kinematics.

use crate::data::sized;
use crate::{Data, DynamicsError};
use articula_model::{LinkFrame, Model};
use articula_spatial::{SpatialMotion, SpatialTransform};
use glam::DVec3;

/// The frame a link's spatial Jacobian ([`Data::link_jacobian`]) gives its velocity in. Rows
/// are `[ω; v]`, angular first as everywhere in articula (Pinocchio puts `v` first).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReferenceFrame {
    /// World axes, about the **world origin**: `v` is the velocity of the link-fixed point that
    /// is at the world origin (the spatial twist; Pinocchio's `WORLD`).
    World,
    /// The link's own axes, about the link's origin: the body twist (Pinocchio's `LOCAL`).
    Local,
    /// World axes, about the link's origin: `ω` and the velocity of the link's origin, both in
    /// world coordinates (Pinocchio's `LOCAL_WORLD_ALIGNED`).
    #[default]
    LocalWorldAligned,
}

impl Data {
    /// The spatial Jacobian `J` of a URDF link (6 × nv, row-major: entry `(r, j)` at
    /// `r·nv + j`, rows `[ω; v]`), so that the link's spatial velocity in `frame` is `J q̇`.
    /// Column `j` is the motion-subspace column `s_j` of a joint between the root and the
    /// link, expressed in `frame`; the other columns are zero (all of them for a link welded to
    /// the world). From the current kinematics (any dynamics call, or
    /// [`crate::forward_kinematics`]); sizes its buffer on the first call, then allocates
    /// nothing. An error when `self` was built for another model or `link` is not one of its
    /// links ([`DynamicsError::WrongModel`], [`DynamicsError::WrongLink`]).
    pub fn link_jacobian(
        &mut self,
        model: &Model,
        link: &LinkFrame,
        frame: ReferenceFrame,
    ) -> Result<&[f64], DynamicsError> {
        self.check_link(model, link)?;
        // X_{F←C}: the computation frame to the frame the columns are wanted in.
        let x_fc = match frame {
            ReferenceFrame::World => SpatialTransform::xlt(-self.origin),
            ReferenceFrame::Local => self.link_transform(link).inverse(),
            ReferenceFrame::LocalWorldAligned => {
                SpatialTransform::xlt(self.link_transform(link).apply_point(DVec3::ZERO))
            }
        };
        Ok(self.columns(model, link, 6, |s| x_fc.apply_motion(s).to_array()))
    }

    /// The point Jacobian `J_p` of a point on a URDF link (3 × nv, row-major: entry `(r, j)`
    /// at `r·nv + j`): the point's linear velocity in world coordinates is `J_p q̇`. `point` is
    /// given in the link's coordinates. Column `j` is `s_j.v + s_j.ω × p` for the joints
    /// between the root and the link, zero for the others. These are the last three rows of
    /// [`ReferenceFrame::LocalWorldAligned`]'s Jacobian of a frame at the point. From the
    /// current kinematics; sizes its buffer on the first call, then allocates nothing. Errors
    /// as [`Data::link_jacobian`]'s.
    pub fn point_jacobian(
        &mut self,
        model: &Model,
        link: &LinkFrame,
        point: DVec3,
    ) -> Result<&[f64], DynamicsError> {
        self.check_link(model, link)?;
        let p = self.link_transform(link).apply_point(point);
        Ok(self.columns(model, link, 3, |s| {
            let v = s.v + s.w.cross(p);
            [v.x, v.y, v.z, 0.0, 0.0, 0.0]
        }))
    }

    /// `Ok` when `self` was built for `model` and `link` names one of its bodies (or the
    /// world): a link of another model would index out of the kinematics.
    fn check_link(&self, model: &Model, link: &LinkFrame) -> Result<(), DynamicsError> {
        crate::inputs::check_data(model, self)?;
        match link.body {
            Some(body) if body >= model.bodies.len() => Err(DynamicsError::WrongLink {
                body,
                bodies: model.bodies.len(),
            }),
            _ => Ok(()),
        }
    }

    /// Writes a `rows × nv` Jacobian into the buffer: `column(s_j)` (its first `rows` entries)
    /// for every degree of freedom between the root and the link, zero elsewhere.
    fn columns(
        &mut self,
        model: &Model,
        link: &LinkFrame,
        rows: usize,
        column: impl Fn(SpatialMotion) -> [f64; 6],
    ) -> &[f64] {
        let nv = model.nv;
        let jac = sized(&mut self.quant.jacobian, rows * nv, 0.0);
        jac.fill(0.0);
        let mut body = link.body;
        while let Some(b) = body {
            let bd = &model.bodies[b];
            for j in bd.v_offset..bd.v_offset + bd.nv {
                let col = column(self.s[j]);
                for r in 0..rows {
                    jac[r * nv + j] = col[r];
                }
            }
            body = bd.parent;
        }
        jac
    }
}
