//! The **visual geometry** of a model, for viewers and exporters: every `<visual>` element of
//! the URDF with its origin, its shape (a primitive, or a mesh file with its scale) and its
//! material colour, placed in the frame of the body it moves with.
//!
//! Loading a [`Model`] keeps collision primitives only (`Body::geometry`, for contact); this
//! reading is separate and lenient: a visual that cannot be read (a bad origin, an unknown
//! shape, a mesh without a file name) is skipped and counted in [`Visuals::skipped`], never an
//! error. Named materials (`<material name="..."><color rgba="..."/></material>` at the robot
//! level) are resolved for visuals that refer to them by name.

use crate::urdf::{numbers, read_geometry, supports_quat, GeometryRole};
use crate::{Model, ModelError, Shape};
use articula_spatial::SpatialTransform;
use glam::DVec3;
use std::collections::HashMap;
use std::path::Path;

/// What a visual draws.
#[derive(Clone, Debug, PartialEq)]
pub enum VisualShape {
    /// A primitive (box, cylinder, sphere, capsule), in its own frame as in [`Shape`].
    Primitive(Shape),
    /// A mesh file: the `filename` attribute as written (`package://`, `file://`, relative or
    /// absolute), and its `scale` per axis (1 when absent).
    Mesh {
        /// The file name as written in the URDF.
        filename: String,
        /// Scale along x, y, z of the mesh frame.
        scale: DVec3,
    },
}

/// One `<visual>` element, placed on its body.
#[derive(Clone, Debug, PartialEq)]
pub struct Visual {
    /// The URDF link it belongs to.
    pub link: String,
    /// The body the link is part of ([`Model::bodies`] index); `None` for a link welded to the
    /// world (a fixed base's root and its fixed children).
    pub body: Option<usize>,
    /// Geometry frame → body frame (→ world frame when `body` is `None`): the visual's
    /// `<origin>` composed with the link's place in its body.
    pub origin: SpatialTransform,
    /// The shape.
    pub shape: VisualShape,
    /// Colour `[r, g, b, a]` in 0..=1 from its `<material>` (inline, or a named material of
    /// the robot); `None` when it has none.
    pub rgba: Option<[f64; 4]>,
}

/// The visual geometry of a model.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Visuals {
    /// Every readable visual, in URDF order.
    pub items: Vec<Visual>,
    /// Visuals skipped: unreadable, or on a link the model does not keep (a massless link
    /// inside a composed joint, or beyond a locked joint).
    pub skipped: usize,
}

impl Visuals {
    /// Reads the `<visual>` elements of the URDF file `path` that `model` was loaded from.
    pub fn from_urdf_file(path: &Path, model: &Model) -> Result<Visuals, ModelError> {
        let bytes =
            crate::read_limited(path, crate::MAX_URDF_BYTES).map_err(|e| ModelError::Io {
                path: path.display().to_string(),
                message: e.to_string(),
            })?;
        let text = std::str::from_utf8(&bytes).map_err(|e| ModelError::NotText {
            reason: "invalid UTF-8".into(),
            offset: e.valid_up_to(),
        })?;
        Visuals::from_urdf_str(text, model)
    }

    /// Reads the `<visual>` elements of a URDF text that `model` was loaded from.
    pub fn from_urdf_str(text: &str, model: &Model) -> Result<Visuals, ModelError> {
        let doc = roxmltree::Document::parse(text).map_err(|e| ModelError::Xml {
            line: e.pos().row,
            column: e.pos().col,
            message: e.to_string(),
        })?;
        let robot = doc.root_element();
        let quat = supports_quat(robot);
        let named: HashMap<&str, [f64; 4]> = children(robot)
            .filter(|c| c.has_tag_name("material"))
            .filter_map(|m| Some((m.attribute("name")?, color(m)?)))
            .collect();
        let mut out = Visuals::default();
        for link in children(robot).filter(|c| c.has_tag_name("link")) {
            let name = link.attribute("name").unwrap_or_default();
            let frame = model.find_link(name);
            for v in children(link).filter(|c| c.has_tag_name("visual")) {
                match (frame, read_visual(v, quat, &named)) {
                    (Some(f), Some((origin, shape, rgba))) => out.items.push(Visual {
                        link: name.to_string(),
                        body: f.body,
                        origin: f.to_body * origin,
                        shape,
                        rgba,
                    }),
                    _ => out.skipped += 1,
                }
            }
        }
        Ok(out)
    }

    /// The model's kept geometry as visuals ([`crate::Body::geometry`]: collision primitives,
    /// or visual ones where a link has no collision), for a model with no URDF to read; meshes
    /// are left out (their file names are not kept).
    pub fn from_body_geometry(model: &Model) -> Visuals {
        let mut out = Visuals::default();
        for (b, body) in model.bodies.iter().enumerate() {
            for g in &body.geometry {
                if g.shape == Shape::Mesh {
                    out.skipped += 1;
                    continue;
                }
                out.items.push(Visual {
                    link: body.name.clone(),
                    body: Some(b),
                    origin: g.origin,
                    shape: VisualShape::Primitive(g.shape),
                    rgba: None,
                });
            }
        }
        out
    }
}

/// `<color rgba>` of a `<material>` element, each component finite and clamped to 0..=1.
fn color(material: roxmltree::Node) -> Option<[f64; 4]> {
    let c = material.children().find(|c| c.has_tag_name("color"))?;
    let rgba = numbers::<4>(c.attribute("rgba")?)?;
    rgba.iter()
        .all(|x| x.is_finite())
        .then(|| rgba.map(|x| x.clamp(0.0, 1.0)))
}

/// One `<visual>`: its origin (geometry → link), shape and colour; `None` when unreadable.
fn read_visual(
    v: roxmltree::Node,
    quat: bool,
    named: &HashMap<&str, [f64; 4]>,
) -> Option<(SpatialTransform, VisualShape, Option<[f64; 4]>)> {
    let g = read_geometry(v, GeometryRole::Visual, quat)?;
    let shape = match g.shape {
        Shape::Mesh => {
            let mesh = v
                .children()
                .find(|c| c.has_tag_name("geometry"))?
                .children()
                .find(|c| c.has_tag_name("mesh"))?;
            let filename = mesh.attribute("filename")?.trim();
            if filename.is_empty() {
                return None;
            }
            let scale = match mesh.attribute("scale") {
                None => DVec3::ONE,
                Some(s) => DVec3::from_array(numbers::<3>(s)?),
            };
            if !scale.is_finite() {
                return None;
            }
            VisualShape::Mesh {
                filename: filename.to_string(),
                scale,
            }
        }
        s => VisualShape::Primitive(s),
    };
    let rgba = v
        .children()
        .find(|c| c.has_tag_name("material"))
        .and_then(|m| color(m).or_else(|| named.get(m.attribute("name")?).copied()));
    Some((g.origin, shape, rgba))
}

/// The element children of `n`.
fn children<'a, 'i>(n: roxmltree::Node<'a, 'i>) -> impl Iterator<Item = roxmltree::Node<'a, 'i>> {
    n.children().filter(|c| c.is_element())
}
