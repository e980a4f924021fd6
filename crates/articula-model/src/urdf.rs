//! URDF text → validated links and joints.
//!
//! One `roxmltree` pass reads what dynamics needs — link names and inertials, joint names,
//! types, origins, parents, children and axes — strictly, so that errors name the offending
//! link or joint, and skips everything else (visual and collision geometry, materials, limits,
//! `<gazebo>`, `<transmission>`, unknown tags), so sloppy geometry never makes loading fail.
//! Collision and visual primitives (box, cylinder, sphere, capsule, mesh) and joint limits are
//! read leniently on the side: a malformed one is dropped, never an error.
//! The values read are then validated (finite, positive semidefinite inertia, triangle
//! inequality, unit axes, one root, no cycles).

use crate::{LoadWarning, ModelError};
use articula_spatial::{SpatialInertia, SpatialTransform};
use glam::{DMat3, DVec3};
use std::borrow::Cow;
use std::collections::HashMap;

pub use crate::joint::JointKind;

/// A link as read from the URDF.
#[derive(Clone, Debug)]
pub(crate) struct RawLink {
    pub name: String,
    /// Spatial inertia in the link frame.
    pub inertia: SpatialInertia,
    /// Its `<collision>` primitives, or its `<visual>` ones when it has no collision geometry
    /// (link frame).
    pub geometry: Vec<Geometry>,
}

/// A joint as read from the URDF.
#[derive(Clone, Debug)]
pub(crate) struct RawJoint {
    pub name: String,
    pub kind: JointKind,
    /// Joint frame → parent link frame (the joint origin as a pose).
    pub origin: SpatialTransform,
    /// Unit axis in the joint frame.
    pub axis: DVec3,
    /// `<limit lower upper>` of a revolute or prismatic joint (see [`read_limits`]).
    pub limits: Option<[f64; 2]>,
    pub parent: usize,
    pub child: usize,
    /// Armature, damping and springs (URDF: `<dynamics damping>`).
    pub dynamics: crate::JointDynamics,
}

/// A validated robot: links, joints, the root link, and warnings.
#[derive(Clone, Debug)]
pub(crate) struct RawRobot {
    pub name: String,
    pub links: Vec<RawLink>,
    pub joints: Vec<RawJoint>,
    pub root: usize,
    pub warnings: Vec<LoadWarning>,
}

/// The largest URDF read, in bytes (64 MiB: a 10,000-link chain takes about 10 MiB).
pub const MAX_URDF_BYTES: u64 = 64 << 20;

/// The deepest element nesting read (a URDF needs about six levels). The XML parser recurses
/// once per level, so without a limit a small file of deeply nested elements exhausts the stack.
pub const MAX_XML_DEPTH: usize = 256;

/// The most attributes one element may carry (a URDF element has at most about ten). The XML
/// parser's duplicate-attribute check is quadratic in an element's attributes (a 4.9 MB
/// element of 300,000 attributes takes hours), so they are counted before it runs.
pub const MAX_XML_ATTRIBUTES: usize = 256;

/// Reads at most `limit` bytes of a file. A longer input (`/dev/zero` included) is an error of
/// kind [`std::io::ErrorKind::FileTooLarge`] after reading `limit + 1` bytes, never an
/// unbounded read. A FIFO (named pipe) or a socket is refused before it is opened (an error
/// of kind [`std::io::ErrorKind::InvalidInput`]): opening a FIFO without a writer blocks for
/// ever.
pub fn read_limited(path: &std::path::Path, limit: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    refuse_pipes(path)?;
    let file = std::fs::File::open(path)?;
    let mut bytes = Vec::new();
    file.take(limit.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(std::io::Error::new(
            std::io::ErrorKind::FileTooLarge,
            format!("larger than the limit of {limit} bytes"),
        ));
    }
    Ok(bytes)
}

/// `Err` for a FIFO or a socket (by `stat`, which never blocks); anything else passes
/// (a missing file is reported by the `open` that follows).
fn refuse_pipes(path: &std::path::Path) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if let Ok(meta) = std::fs::metadata(path) {
            let t = meta.file_type();
            let what = if t.is_fifo() {
                Some("a FIFO (named pipe)")
            } else if t.is_socket() {
                Some("a socket")
            } else {
                None
            };
            if let Some(what) = what {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!("{what}, not a file: articula reads only files, which it can size"),
                ));
            }
        }
    }
    #[cfg(not(unix))]
    let _ = path;
    Ok(())
}

/// A model file's bytes, at most [`MAX_URDF_BYTES`]; `kind` ("URDF", "MJCF") names the file
/// in the size error.
pub(crate) fn read_model_bytes(path: &std::path::Path, kind: &str) -> Result<Vec<u8>, ModelError> {
    read_limited(path, MAX_URDF_BYTES).map_err(|e| {
        if e.kind() == std::io::ErrorKind::FileTooLarge {
            ModelError::TooLarge {
                what: format!("the {kind} file {}", path.display()),
                size: MAX_URDF_BYTES + 1,
                limit: MAX_URDF_BYTES,
            }
        } else {
            ModelError::Io {
                path: path.display().to_string(),
                message: e.to_string(),
            }
        }
    })
}

/// Reads a URDF file (bytes are checked for being text first).
pub(crate) fn read_file(path: &std::path::Path) -> Result<RawRobot, ModelError> {
    let bytes = read_model_bytes(path, "URDF")?;
    let in_file = |e: ModelError| match e {
        ModelError::Xml { .. }
        | ModelError::TooDeep { .. }
        | ModelError::TooManyAttributes { .. }
        | ModelError::NotText { .. }
        | ModelError::Empty => ModelError::InFile {
            path: path.display().to_string(),
            source: Box::new(e),
        },
        e => e,
    };
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        in_file(ModelError::NotText {
            reason: "invalid UTF-8".into(),
            offset: e.valid_up_to(),
        })
    })?;
    read_str(text).map_err(in_file)
}

/// Reads a URDF from text.
pub(crate) fn read_str(text: &str) -> Result<RawRobot, ModelError> {
    validate(read_data(text)?)
}

/// Parses the text into links and joints as written (checks of size, text, nesting, XML, and
/// the strict reading of what dynamics needs).
pub(crate) fn read_data(text: &str) -> Result<RobotData<'_>, ModelError> {
    if text.len() as u64 > MAX_URDF_BYTES {
        return Err(ModelError::TooLarge {
            what: "the URDF text".into(),
            size: text.len() as u64,
            limit: MAX_URDF_BYTES,
        });
    }
    if text.trim().is_empty() {
        return Err(ModelError::Empty);
    }
    if let Some(offset) = text.bytes().position(|b| b == 0) {
        return Err(ModelError::NotText {
            reason: "NUL byte".into(),
            offset,
        });
    }
    check_markup(text, MAX_XML_DEPTH, MAX_XML_ATTRIBUTES)?;
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        let pos = e.pos();
        ModelError::Xml {
            line: pos.row,
            column: pos.col,
            message: e.to_string(),
        }
    })?;
    extract(&doc)
}

/// Fails when elements nest deeper than `limit` or an element carries more than `max_attributes`
/// attributes (each is one `=` outside quotes in its start tag), by a linear scan of the markup
/// that skips comments, CDATA sections, processing instructions, declarations and quoted
/// attribute values. Text that is not well-formed may be counted loosely; the parser reports
/// it afterwards, before it can recurse past the point the scan stopped trusting.
pub(crate) fn check_markup(
    text: &str,
    limit: usize,
    max_attributes: usize,
) -> Result<(), ModelError> {
    let position = |at: usize| {
        let before = &text[..at];
        let line = before.matches('\n').count() + 1;
        let column = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
        (
            u32::try_from(line).unwrap_or(u32::MAX),
            u32::try_from(column).unwrap_or(u32::MAX),
        )
    };
    let b = text.as_bytes();
    let find = |from: usize, pat: &[u8]| -> usize {
        b[from.min(b.len())..]
            .windows(pat.len())
            .position(|w| w == pat)
            .map_or(b.len(), |p| from + p + pat.len())
    };
    let mut depth = 0usize;
    let mut i = 0;
    while i < b.len() {
        let Some(off) = b[i..].iter().position(|&c| c == b'<') else {
            break;
        };
        let at = i + off;
        let rest = &b[at..];
        if rest.starts_with(b"<!--") {
            i = find(at + 4, b"-->");
        } else if rest.starts_with(b"<![CDATA[") {
            i = find(at + 9, b"]]>");
        } else if rest.starts_with(b"<?") {
            i = find(at + 2, b"?>");
        } else if rest.starts_with(b"<!") || rest.starts_with(b"</") {
            if rest.starts_with(b"</") {
                depth = depth.saturating_sub(1);
            }
            i = find(at + 2, b">");
        } else {
            // A start tag: to its '>' outside quotes.
            let mut quote = None;
            let mut end = b.len();
            let mut attributes = 0usize;
            for (k, &c) in b.iter().enumerate().skip(at + 1) {
                match (quote, c) {
                    (None, b'"' | b'\'') => quote = Some(c),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'=') => {
                        attributes += 1;
                        if attributes > max_attributes {
                            let (line, column) = position(at);
                            return Err(ModelError::TooManyAttributes {
                                line,
                                column,
                                limit: max_attributes,
                            });
                        }
                    }
                    (None, b'>') => {
                        end = k;
                        break;
                    }
                    _ => {}
                }
            }
            if end < b.len() && b[end - 1] != b'/' {
                depth += 1;
                if depth > limit {
                    let (line, column) = position(at);
                    return Err(ModelError::TooDeep {
                        line,
                        column,
                        limit,
                    });
                }
            }
            i = end.saturating_add(1);
        }
    }
    Ok(())
}

fn malformed(element: &'static str, name: &str, message: impl Into<String>) -> ModelError {
    ModelError::Malformed {
        element,
        name: name.to_string(),
        message: message.into(),
    }
}

/// Strictly parses exactly `N` whitespace-separated numbers.
pub(crate) fn numbers<const N: usize>(s: &str) -> Option<[f64; N]> {
    let mut tokens = s.split_whitespace();
    let mut out = [0.0; N];
    for x in &mut out {
        *x = tokens.next()?.parse().ok()?;
    }
    tokens.next().is_none().then_some(out)
}

/// The `N` numbers of attribute `attr` of `node`, `None` when it is absent (an error when it is
/// `required`).
fn attr_numbers<const N: usize>(
    node: roxmltree::Node,
    attr: &str,
    element: &'static str,
    name: &str,
    required: bool,
) -> Result<Option<[f64; N]>, ModelError> {
    match node.attribute(attr) {
        Some(s) => numbers(s).map(Some).ok_or_else(|| {
            malformed(
                element,
                name,
                format!(
                    "<{}> attribute '{attr}' must hold {N} number(s), found \"{s}\"",
                    node.tag_name().name()
                ),
            )
        }),
        None if required => Err(malformed(
            element,
            name,
            format!("<{}> lacks attribute '{attr}'", node.tag_name().name()),
        )),
        None => Ok(None),
    }
}

/// The one number of the required attribute `attr` of `node`.
fn attr_number(
    node: roxmltree::Node,
    attr: &str,
    element: &'static str,
    name: &str,
) -> Result<f64, ModelError> {
    let [x] = attr_numbers::<1>(node, attr, element, name, true)?
        .expect("a required attribute is present");
    Ok(x)
}

/// Whether `quat_xyzw` is read (URDF 1.1 and later; like urdfdom, a missing or malformed
/// `version` means 1.0, and older versions ignore `quat_xyzw`).
pub(crate) fn supports_quat(robot: roxmltree::Node) -> bool {
    robot
        .attribute("version")
        .and_then(|v| {
            let (major, minor) = v.trim().split_once('.')?;
            Some((major.parse::<u32>().ok()?, minor.parse::<u32>().ok()?))
        })
        .is_some_and(|version| version >= (1, 1))
}

/// Converts a quaternion `(x, y, z, w)` to roll, pitch, yaw like urdfdom's
/// `urdf::Rotation::getRPY` (the conversion urdf-rs made, kept so that quaternion origins give
/// the same rotations as before). Near pitch ±π/2 it snaps the pitch to ±π/2 (so the rotation
/// differs slightly from the quaternion's), and a quaternion whose norm overflows or
/// underflows reads as the identity.
fn quaternion_to_rpy([x, y, z, w]: [f64; 4]) -> DVec3 {
    let norm = (x * x + y * y + z * z + w * w).sqrt();
    let [x, y, z, w] = if norm > 0.0 {
        [x / norm, y / norm, z / norm, w / norm]
    } else {
        [0.0, 0.0, 0.0, 1.0]
    };
    let sin_pitch = -2.0 * (x * z - w * y);
    if sin_pitch <= -0.99999 {
        DVec3::new(0.0, -std::f64::consts::FRAC_PI_2, 2.0 * x.atan2(-y))
    } else if sin_pitch >= 0.99999 {
        DVec3::new(0.0, std::f64::consts::FRAC_PI_2, 2.0 * (-x).atan2(y))
    } else {
        let (sqx, sqy, sqz, sqw) = (x * x, y * y, z * z, w * w);
        DVec3::new(
            (2.0 * (y * z + w * x)).atan2(sqw - sqx - sqy + sqz),
            sin_pitch.asin(),
            (2.0 * (x * y + w * z)).atan2(sqw + sqx - sqy - sqz),
        )
    }
}

/// An `<origin>` as read (not yet checked for being finite); a URDF 1.1 `quat_xyzw` is already
/// converted to `rpy`. Absent attributes are zero.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Origin {
    pub(crate) xyz: DVec3,
    pub(crate) rpy: DVec3,
}

fn read_origin(
    node: roxmltree::Node,
    element: &'static str,
    name: &str,
    supports_quat: bool,
) -> Result<Origin, ModelError> {
    let xyz = attr_numbers::<3>(node, "xyz", element, name, false)?;
    let rpy = attr_numbers::<3>(node, "rpy", element, name, false)?;
    let quat = attr_numbers::<4>(node, "quat_xyzw", element, name, false)?;
    let mut origin = Origin {
        xyz: xyz.map_or(DVec3::ZERO, DVec3::from_array),
        rpy: rpy.map_or(DVec3::ZERO, DVec3::from_array),
    };
    let Some(quat) = quat.filter(|_| supports_quat) else {
        return Ok(origin);
    };
    if rpy.is_some() {
        return Err(malformed(
            element,
            name,
            "<origin> has both 'rpy' and 'quat_xyzw'",
        ));
    }
    if quat.iter().any(|x| !x.is_finite()) {
        return Err(if element == "joint" {
            ModelError::InvalidOrigin { joint: name.into() }
        } else {
            ModelError::NonFiniteInertia { link: name.into() }
        });
    }
    // The conversion would read the zero quaternion as the identity.
    if quat.iter().all(|&x| x == 0.0) {
        return Err(malformed(
            element,
            name,
            "<origin> 'quat_xyzw' is the zero quaternion",
        ));
    }
    origin.rpy = quaternion_to_rpy(quat);
    Ok(origin)
}

/// Stores `node` as the one `<tag>` inside a link or joint, failing on a second occurrence.
fn once<'a, 'input>(
    slot: &mut Option<roxmltree::Node<'a, 'input>>,
    node: roxmltree::Node<'a, 'input>,
    element: &'static str,
    name: &str,
) -> Result<(), ModelError> {
    if slot.is_some() {
        return Err(malformed(
            element,
            name,
            format!("duplicate <{}>", node.tag_name().name()),
        ));
    }
    *slot = Some(node);
    Ok(())
}

/// Rejects a name written `:x` (which roxmltree reads as `x` with an empty namespace prefix)
/// in the start tag, end tag or attributes of `node`, with its position. Only the elements
/// read are checked: such names in ignored geometry are harmless.
fn check_prefixes(doc: &roxmltree::Document, node: roxmltree::Node) -> Result<(), ModelError> {
    let text = doc.input_text();
    let range = node.range();
    let raw = &text[range.clone()];
    // The end tag, if any, must match the start tag, so `</:x>` goes with `<:x>`; check it too.
    let end_tag = (!raw.ends_with("/>"))
        .then(|| raw.rfind("</").map(|i| range.start + i + 1))
        .flatten();
    let bad = std::iter::once(range.start)
        .chain(end_tag)
        .map(|lt| lt + 1)
        .chain(node.attributes().map(|a| a.range_qname().start))
        .find(|&at| text[at..].starts_with(':'));
    match bad {
        Some(at) => {
            let pos = doc.text_pos_at(at);
            Err(ModelError::Xml {
                line: pos.row,
                column: pos.col,
                message: "name with an empty namespace prefix".into(),
            })
        }
        None => Ok(()),
    }
}

/// The value of attribute `attr` of `node` as written, references decoded but white space kept.
/// Names (of the robot, links, joints, and the links joints connect) are read this way — as
/// urdf-rs read them — while roxmltree, following XML, turns tabs and line breaks in attribute
/// values into spaces (and error messages of the reading pass name links and joints that way).
fn verbatim<'a>(
    doc: &roxmltree::Document<'a>,
    node: roxmltree::Node,
    attr: &str,
) -> Option<Cow<'a, str>> {
    let a = node
        .attributes()
        .find(|a| a.namespace().is_none() && a.name() == attr)?;
    let raw = &doc.input_text()[a.range_value()];
    if !raw.contains('&') {
        return Some(Cow::Borrowed(raw));
    }
    // roxmltree has checked the references (only the predefined entities and character
    // references: a document type declaration, which could declare others, is rejected).
    let mut out = String::with_capacity(raw.len());
    let mut parts = raw.split('&');
    out.push_str(parts.next().unwrap_or_default());
    for part in parts {
        let (reference, rest) = part.split_once(';')?;
        let c = match reference {
            "quot" => '"',
            "apos" => '\'',
            "gt" => '>',
            "lt" => '<',
            "amp" => '&',
            r => {
                let code = match r.strip_prefix("#x") {
                    Some(hex) => u32::from_str_radix(hex, 16).ok()?,
                    None => r.strip_prefix('#')?.parse().ok()?,
                };
                char::from_u32(code)?
            }
        };
        out.push(c);
        out.push_str(rest);
    }
    Some(Cow::Owned(out))
}

/// A link as read, before validation.
pub(crate) struct LinkData<'a> {
    pub(crate) name: Cow<'a, str>,
    pub(crate) origin: Origin,
    pub(crate) mass: f64,
    /// `ixx ixy ixz iyy iyz izz`.
    pub(crate) inertia: [f64; 6],
    /// Collision geometry if any was readable, else visual geometry.
    pub(crate) geometry: Vec<Geometry>,
}

/// A geometric primitive of a link's `<collision>` or `<visual>` (dimensions in metres, in the
/// geometry's own frame: a box centred on its origin, a cylinder along its z axis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// `<box size="x y z">`: full edge lengths.
    Box {
        /// Edge lengths along x, y, z.
        size: DVec3,
    },
    /// `<cylinder radius length>`, its axis along z, centred on the origin.
    Cylinder {
        /// Radius.
        radius: f64,
        /// Length along z.
        length: f64,
    },
    /// `<sphere radius>`.
    Sphere {
        /// Radius.
        radius: f64,
    },
    /// `<capsule radius length>` (not in the URDF specification, written by some exporters):
    /// a cylinder of `length` along z, centred on the origin, capped by two hemispheres.
    Capsule {
        /// Radius of the cylinder and of the end spheres.
        radius: f64,
        /// Distance between the end spheres' centres, along z.
        length: f64,
    },
    /// `<mesh>`: its extent is unknown without reading the mesh file (users fall back to the
    /// link's inertia).
    Mesh,
}

/// Which element a [`Geometry`] came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeometryRole {
    /// `<collision>`.
    Collision,
    /// `<visual>`.
    Visual,
}

/// One `<collision>` or `<visual>` primitive of a link.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// The shape.
    pub shape: Shape,
    /// Geometry frame → link frame (the element's `<origin>`); in a [`crate::Body`], geometry
    /// frame → body frame.
    pub origin: SpatialTransform,
    /// Where it came from.
    pub role: GeometryRole,
}

/// Leniently reads one `<collision>` or `<visual>` element: anything malformed (a missing or
/// unparsable size, a negative or non-finite dimension, an unknown shape, a bad origin) makes
/// it `None` — geometry never makes loading fail.
pub(crate) fn read_geometry(
    el: roxmltree::Node,
    role: GeometryRole,
    quat: bool,
) -> Option<Geometry> {
    let mut origin = Origin::default();
    let mut shape = None;
    for c in el.children().filter(|n| n.is_element()) {
        match c.tag_name().name() {
            "origin" => origin = read_origin(c, "link", "", quat).ok()?,
            "geometry" => {
                let g = c.children().find(|n| n.is_element())?;
                let num = |attr: &str| -> Option<f64> {
                    let [x] = numbers::<1>(g.attribute(attr)?)?;
                    (x.is_finite() && x >= 0.0).then_some(x)
                };
                shape = Some(match g.tag_name().name() {
                    "box" => {
                        let s = numbers::<3>(g.attribute("size")?)?;
                        if s.iter().any(|x| !x.is_finite() || *x < 0.0) {
                            return None;
                        }
                        Shape::Box {
                            size: DVec3::from_array(s),
                        }
                    }
                    "cylinder" => Shape::Cylinder {
                        radius: num("radius")?,
                        length: num("length")?,
                    },
                    "sphere" => Shape::Sphere {
                        radius: num("radius")?,
                    },
                    "capsule" => Shape::Capsule {
                        radius: num("radius")?,
                        length: num("length")?,
                    },
                    "mesh" => Shape::Mesh,
                    _ => return None,
                });
            }
            _ => {}
        }
    }
    Some(Geometry {
        shape: shape?,
        origin: pose(&origin)?,
        role,
    })
}

/// A joint as read, before validation.
pub(crate) struct JointData<'a> {
    pub(crate) name: Cow<'a, str>,
    /// The kind, or the name of a known type articula does not support.
    pub(crate) kind: Result<JointKind, &'static str>,
    pub(crate) origin: Origin,
    pub(crate) parent: Cow<'a, str>,
    pub(crate) child: Cow<'a, str>,
    pub(crate) axis: DVec3,
    /// `<limit lower upper>`, read leniently ([`read_limits`]).
    pub(crate) limits: Option<[f64; 2]>,
    /// `<dynamics damping>` (N·m·s/rad or N·s/m), 0 when absent.
    pub(crate) damping: f64,
}

/// Reads `<limit lower="..." upper="...">` leniently: `Some([lower, upper])` when both are
/// finite numbers with `lower < upper`; `None` otherwise (a missing attribute, which URDF
/// defaults to 0, included: a range `[0, 0]` is read as "no limit", never as a locked joint).
/// Used for revolute and prismatic joints only (continuous joints have no limits).
pub(crate) fn read_limits(el: roxmltree::Node) -> Option<[f64; 2]> {
    let get = |a: &str| -> Option<f64> {
        let [x] = numbers::<1>(el.attribute(a)?)?;
        x.is_finite().then_some(x)
    };
    let (lower, upper) = (get("lower")?, get("upper")?);
    (lower < upper).then_some([lower, upper])
}

/// Reads `<dynamics damping friction>`: the damping (a finite number ≥ 0, else an error
/// naming the joint); a non-zero `friction` is reported as not modelled.
fn read_dynamics(
    el: roxmltree::Node,
    joint: &str,
    warnings: &mut Vec<LoadWarning>,
) -> Result<f64, ModelError> {
    let get = |a: &str| -> Result<f64, ModelError> {
        let Some(text) = el.attribute(a) else {
            return Ok(0.0);
        };
        match numbers::<1>(text) {
            Some([x]) if x.is_finite() && x >= 0.0 => Ok(x),
            _ => Err(malformed(
                "joint",
                joint,
                format!("<dynamics {a}=\"{text}\"> must be a finite number ≥ 0"),
            )),
        }
    };
    if get("friction")? != 0.0 {
        LoadWarning::not_modelled(warnings, "joint friction (URDF <dynamics friction>)", joint);
    }
    get("damping")
}

/// The robot as read, before validation.
pub(crate) struct RobotData<'a> {
    pub(crate) name: Cow<'a, str>,
    pub(crate) links: Vec<LinkData<'a>>,
    pub(crate) joints: Vec<JointData<'a>>,
    pub(crate) warnings: Vec<LoadWarning>,
}

fn read_link<'input>(
    doc: &roxmltree::Document<'input>,
    el: roxmltree::Node,
    quat: bool,
) -> Result<LinkData<'input>, ModelError> {
    check_prefixes(doc, el)?;
    let name = el
        .attribute("name")
        .ok_or_else(|| malformed("link", "", "missing 'name' attribute"))?;
    // Without <inertial>, a link is massless with its inertial frame at its origin.
    let mut link = LinkData {
        name: verbatim(doc, el, "name").unwrap_or_else(|| name.to_string().into()),
        origin: Origin::default(),
        mass: 0.0,
        inertia: [0.0; 6],
        geometry: Vec::new(),
    };
    let mut inertial = None;
    let mut visual = Vec::new();
    for c in el.children().filter(|n| n.is_element()) {
        match c.tag_name().name() {
            "inertial" => {}
            "collision" => {
                link.geometry
                    .extend(read_geometry(c, GeometryRole::Collision, quat));
                continue;
            }
            "visual" => {
                visual.extend(read_geometry(c, GeometryRole::Visual, quat));
                continue;
            }
            _ => continue,
        }
        once(&mut inertial, c, "link", name)?;
        check_prefixes(doc, c)?;
        let (mut origin, mut mass, mut inertia) = (None, None, None);
        for p in c.children().filter(|n| n.is_element()) {
            let slot = match p.tag_name().name() {
                "origin" => &mut origin,
                "mass" => &mut mass,
                "inertia" => &mut inertia,
                _ => continue,
            };
            once(slot, p, "link", name)?;
            check_prefixes(doc, p)?;
            match p.tag_name().name() {
                "origin" => link.origin = read_origin(p, "link", name, quat)?,
                "mass" => link.mass = attr_number(p, "value", "link", name)?,
                _ => {
                    for (i, a) in ["ixx", "ixy", "ixz", "iyy", "iyz", "izz"]
                        .into_iter()
                        .enumerate()
                    {
                        link.inertia[i] = attr_number(p, a, "link", name)?;
                    }
                }
            }
        }
        if mass.is_none() {
            return Err(malformed("link", name, "<inertial> lacks <mass>"));
        }
        if inertia.is_none() {
            return Err(malformed("link", name, "<inertial> lacks <inertia>"));
        }
    }
    if link.geometry.is_empty() {
        link.geometry = visual;
    }
    Ok(link)
}

fn read_joint<'input>(
    doc: &roxmltree::Document<'input>,
    el: roxmltree::Node,
    quat: bool,
    warnings: &mut Vec<LoadWarning>,
) -> Result<JointData<'input>, ModelError> {
    check_prefixes(doc, el)?;
    let name = el
        .attribute("name")
        .ok_or_else(|| malformed("joint", "", "missing 'name' attribute"))?;
    let kind = el
        .attribute("type")
        .ok_or_else(|| malformed("joint", name, "missing 'type' attribute"))?;
    let kind = match kind {
        "revolute" => Ok(JointKind::Revolute),
        "continuous" => Ok(JointKind::Continuous),
        "prismatic" => Ok(JointKind::Prismatic),
        "fixed" => Ok(JointKind::Fixed),
        "floating" => Ok(JointKind::Floating),
        "planar" => Err("planar"),
        "spherical" => Err("spherical"),
        _ => {
            return Err(ModelError::UnknownJointType {
                joint: name.into(),
                kind: kind.into(),
            })
        }
    };
    let mut joint = JointData {
        name: verbatim(doc, el, "name").unwrap_or_else(|| name.to_string().into()),
        kind,
        origin: Origin::default(),
        parent: Cow::Borrowed(""),
        child: Cow::Borrowed(""),
        // URDF's default axis.
        axis: DVec3::X,
        limits: None,
        damping: 0.0,
    };
    let (mut origin, mut axis, mut parent, mut child) = (None, None, None, None);
    for c in el.children().filter(|n| n.is_element()) {
        let tag = c.tag_name().name();
        let slot = match tag {
            "origin" => &mut origin,
            "axis" => &mut axis,
            "parent" => &mut parent,
            "child" => &mut child,
            "limit" => {
                joint.limits = read_limits(c);
                continue;
            }
            "dynamics" => {
                joint.damping = read_dynamics(c, name, warnings)?;
                continue;
            }
            "mimic" => {
                warnings.push(LoadWarning::Mimic {
                    joint: name.to_string(),
                    leader: c.attribute("joint").unwrap_or("?").to_string(),
                });
                continue;
            }
            _ => continue,
        };
        once(slot, c, "joint", name)?;
        check_prefixes(doc, c)?;
        match tag {
            "origin" => joint.origin = read_origin(c, "joint", name, quat)?,
            "axis" => {
                let xyz = attr_numbers::<3>(c, "xyz", "joint", name, true)
                    .ok()
                    .flatten()
                    .ok_or_else(|| ModelError::InvalidAxis {
                        joint: name.into(),
                        reason: format!(
                            "'xyz' must hold 3 numbers, found {:?}",
                            c.attribute("xyz").unwrap_or("")
                        ),
                    })?;
                joint.axis = DVec3::from_array(xyz);
            }
            _ => {
                let link = c.attribute("link").ok_or_else(|| {
                    malformed("joint", name, format!("<{tag}> lacks attribute 'link'"))
                })?;
                let link = verbatim(doc, c, "link").unwrap_or_else(|| link.to_string().into());
                if tag == "parent" {
                    joint.parent = link;
                } else {
                    joint.child = link;
                }
            }
        }
    }
    if parent.is_none() {
        return Err(malformed("joint", name, "missing <parent>"));
    }
    if child.is_none() {
        return Err(malformed("joint", name, "missing <child>"));
    }
    Ok(joint)
}

/// Reads the links and joints of the document strictly, failing on the first malformed or
/// missing thing dynamics needs, in document order.
fn extract<'input>(doc: &roxmltree::Document<'input>) -> Result<RobotData<'input>, ModelError> {
    let robot = doc.root_element();
    if robot.tag_name().name() != "robot" {
        return Err(ModelError::NotARobot {
            found: robot.tag_name().name().to_string(),
        });
    }
    check_prefixes(doc, robot)?;
    let quat = supports_quat(robot);
    let mut data = RobotData {
        name: verbatim(doc, robot, "name").unwrap_or_default(),
        links: Vec::new(),
        joints: Vec::new(),
        warnings: Vec::new(),
    };
    for el in robot.children().filter(|n| n.is_element()) {
        match el.tag_name().name() {
            "link" => data.links.push(read_link(doc, el, quat)?),
            "joint" => data
                .joints
                .push(read_joint(doc, el, quat, &mut data.warnings)?),
            _ => {}
        }
    }
    Ok(data)
}

/// URDF `rpy` (fixed-axis roll about x, then pitch about y, then yaw about z) as a rotation
/// matrix `Rz(y) Ry(p) Rx(r)`.
pub fn rpy_to_matrix(rpy: DVec3) -> DMat3 {
    DMat3::from_rotation_z(rpy.z) * DMat3::from_rotation_y(rpy.y) * DMat3::from_rotation_x(rpy.x)
}

pub(crate) fn pose(o: &Origin) -> Option<SpatialTransform> {
    (o.xyz.is_finite() && o.rpy.is_finite())
        .then(|| SpatialTransform::from_pose(rpy_to_matrix(o.rpy), o.xyz))
}

/// The largest mass of a link (kg): finite masses above it are refused. Sums and products of
/// the dynamics (total mass, `m |c|²`, momenta) must stay finite and keep their digits.
pub const MAX_MASS: f64 = 1e12;
/// The largest distance (m) of a joint or inertial origin from its frame: 1,000 km.
pub const MAX_LENGTH: f64 = 1e6;
/// The largest inertia entry (kg·m²): [`MAX_MASS`] · [`MAX_LENGTH`]².
pub const MAX_INERTIA: f64 = 1e24;

/// `Err` naming `what` when `value` (finite) is above `limit` in magnitude.
fn within(what: impl FnOnce() -> String, value: f64, limit: f64) -> Result<(), ModelError> {
    if value.abs() > limit {
        return Err(ModelError::Absurd {
            what: what(),
            value,
            limit,
        });
    }
    Ok(())
}

pub(crate) fn validate(robot: RobotData) -> Result<RawRobot, ModelError> {
    let mut warnings = robot.warnings;
    if robot.links.is_empty() {
        return Err(ModelError::NoLinks);
    }
    let mut link_index = HashMap::new();
    let mut links = Vec::with_capacity(robot.links.len());
    for l in &robot.links {
        if link_index.insert(&*l.name, links.len()).is_some() {
            return Err(ModelError::DuplicateLink {
                link: l.name.to_string(),
            });
        }
        links.push(validate_link(l)?);
    }

    let mut joint_names = HashMap::new();
    let mut joints = Vec::with_capacity(robot.joints.len());
    let mut parent_joint: Vec<Option<usize>> = vec![None; links.len()];
    for j in &robot.joints {
        if joint_names.insert(&*j.name, joints.len()).is_some() {
            return Err(ModelError::DuplicateJoint {
                joint: j.name.to_string(),
            });
        }
        let find = |role: &'static str, link: &str| {
            link_index
                .get(link)
                .copied()
                .ok_or_else(|| ModelError::MissingLink {
                    joint: j.name.to_string(),
                    role,
                    link: link.to_string(),
                })
        };
        let parent = find("parent", &j.parent)?;
        let child = find("child", &j.child)?;
        let kind = j.kind.map_err(|kind| ModelError::UnsupportedJointType {
            joint: j.name.to_string(),
            kind: kind.into(),
        })?;
        let origin = pose(&j.origin).ok_or_else(|| ModelError::InvalidOrigin {
            joint: j.name.to_string(),
        })?;
        for x in j.origin.xyz.to_array() {
            within(|| format!("joint '{}' origin (m)", j.name), x, MAX_LENGTH)?;
        }
        let axis = joint_axis(j, kind, &mut warnings)?;
        if let Some(first) = parent_joint[child] {
            let first: &RawJoint = &joints[first];
            return Err(ModelError::MultipleParents {
                link: links[child].name.clone(),
                joints: vec![first.name.clone(), j.name.to_string()],
            });
        }
        parent_joint[child] = Some(joints.len());
        joints.push(RawJoint {
            name: j.name.to_string(),
            kind,
            origin,
            axis,
            limits: if kind.takes_limits() { j.limits } else { None },
            parent,
            child,
            dynamics: crate::JointDynamics {
                damping: j.damping,
                ..Default::default()
            },
        });
    }

    let root = find_root(&links, &joints, &parent_joint)?;
    Ok(RawRobot {
        name: robot.name.into_owned(),
        links,
        joints,
        root,
        warnings,
    })
}

/// A link's mass, inertia and inertial origin checked (finite, not absurd) and its spatial
/// inertia in link coordinates.
fn validate_link(l: &LinkData) -> Result<RawLink, ModelError> {
    let m = l.mass;
    if !m.is_finite() || m < 0.0 {
        return Err(ModelError::InvalidMass {
            link: l.name.to_string(),
            mass: m,
        });
    }
    within(|| format!("link '{}' mass (kg)", l.name), m, MAX_MASS)?;
    // Positive semidefiniteness and the triangle inequality are checked on the bodies
    // after fixed-joint merging (`body_inertia`), where dynamics sees them.
    let [ixx, ixy, ixz, iyy, iyz, izz] = l.inertia;
    for x in l.inertia.into_iter().filter(|x| x.is_finite()) {
        within(
            || format!("link '{}' inertia entry (kg·m²)", l.name),
            x,
            MAX_INERTIA,
        )?;
    }
    for x in l
        .origin
        .xyz
        .to_array()
        .into_iter()
        .filter(|x| x.is_finite())
    {
        within(
            || format!("link '{}' inertial origin (m)", l.name),
            x,
            MAX_LENGTH,
        )?;
    }
    let ic = DMat3::from_cols(
        DVec3::new(ixx, ixy, ixz),
        DVec3::new(ixy, iyy, iyz),
        DVec3::new(ixz, iyz, izz),
    );
    let origin = pose(&l.origin);
    let (Some(origin), true) = (origin, ic.is_finite()) else {
        return Err(ModelError::NonFiniteInertia {
            link: l.name.to_string(),
        });
    };
    // The inertial frame (origin, rpy) in link coordinates: com = xyz, I_com rotated.
    let (rot, com) = origin.to_pose();
    let inertia = SpatialInertia::new(m, com, rot * ic * rot.transpose());
    // Finite inputs can still overflow (a huge mass far from the link origin).
    if !inertia.is_finite() {
        return Err(ModelError::NonFiniteInertia {
            link: l.name.to_string(),
        });
    }
    Ok(RawLink {
        name: l.name.to_string(),
        inertia,
        geometry: l.geometry.clone(),
    })
}

/// The unit axis of a revolute, continuous or prismatic joint (a warning when the file's
/// was not of unit length); other kinds keep the axis as read.
fn joint_axis(
    j: &JointData,
    kind: JointKind,
    warnings: &mut Vec<LoadWarning>,
) -> Result<DVec3, ModelError> {
    let mut axis = j.axis;
    if matches!(
        kind,
        JointKind::Revolute | JointKind::Continuous | JointKind::Prismatic
    ) {
        if !axis.is_finite() {
            return Err(ModelError::InvalidAxis {
                joint: j.name.to_string(),
                reason: "non-finite component".into(),
            });
        }
        // Scaled first, so huge components do not overflow the length to infinity (and
        // the axis to zero).
        let max = axis.abs().max_element();
        let len = if max > 0.0 {
            max * (axis / max).length()
        } else {
            0.0
        };
        if len < 1e-9 {
            return Err(ModelError::InvalidAxis {
                joint: j.name.to_string(),
                reason: "zero length".into(),
            });
        }
        if (len - 1.0).abs() > 1e-6 {
            warnings.push(LoadWarning::AxisNormalised {
                joint: j.name.to_string(),
                length: len,
            });
        }
        axis = (axis / max).normalize();
    }
    Ok(axis)
}

/// The one link without a parent joint, every link reachable from it (the unreachable ones
/// sit on a cycle).
fn find_root(
    links: &[RawLink],
    joints: &[RawJoint],
    parent_joint: &[Option<usize>],
) -> Result<usize, ModelError> {
    let roots: Vec<usize> = (0..links.len())
        .filter(|&l| parent_joint[l].is_none())
        .collect();
    if roots.len() > 1 {
        return Err(ModelError::MultipleRoots {
            roots: roots.iter().map(|&l| links[l].name.clone()).collect(),
        });
    }
    let Some(&root) = roots.first() else {
        return Err(ModelError::Cycle {
            link: links[0].name.clone(),
        });
    };
    // Every link must be reachable from the root; the unreachable ones sit on a cycle.
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); links.len()];
    for j in joints {
        children[j.parent].push(j.child);
    }
    let mut seen = vec![false; links.len()];
    let mut stack = vec![root];
    while let Some(l) = stack.pop() {
        seen[l] = true;
        stack.extend(children[l].iter().copied().filter(|&c| !seen[c]));
    }
    if let Some(l) = seen.iter().position(|s| !s) {
        return Err(ModelError::Cycle {
            link: links[l].name.clone(),
        });
    }
    Ok(root)
}

#[cfg(test)]
// The recorded values and test quaternions are near π/2 and 1/√2 on purpose.
#[allow(clippy::approx_constant)]
mod tests {
    use super::*;
    use glam::DQuat;

    /// Quaternions and the roll, pitch, yaw urdf-rs 0.9 (urdfdom's `getRPY`) made of them,
    /// recorded from urdf-rs itself.
    const URDF_RS_RPY: [([f64; 4], [f64; 3]); 10] = [
        ([0.0, 0.0, 0.7071, 0.7071], [0.0, -0.0, 1.5707963267948966]),
        ([0.1, 0.0, 0.0, 1.0], [0.19933730498232408, -0.0, 0.0]),
        (
            [0.3, -0.2, 0.5, 0.8],
            [0.3529903878269105, -0.6533415013784495, 0.9964914966201948],
        ),
        (
            [-0.5, 0.5, -0.5, 0.5],
            [-1.5707963267948966, -0.0, -1.5707963267948966],
        ),
        (
            [1.0, 2.0, 3.0, -4.0],
            [0.19739555984988083, -0.8232119771258756, -1.373400766945016],
        ),
        (
            [0.0, 0.7071067811865476, 0.0, 0.7071067811865476],
            [0.0, 1.5707963267948966, -0.0],
        ),
        (
            [0.2, 0.7, -0.1, 0.68],
            [1.9822525702085971, 1.426622195886408, 1.5541312030809544],
        ),
        (
            [0.001, 0.7071, 0.0, 0.70711],
            [0.0, 1.5707963267948966, -0.0028284523640824395],
        ),
        ([1e-200, 0.0, 0.0, 1e-200], [0.0, -0.0, 0.0]),
        ([1e300, 0.0, 1e300, 0.0], [0.0, -0.0, 0.0]),
    ];

    fn max_diff(a: DMat3, b: DMat3) -> f64 {
        (a - b)
            .to_cols_array()
            .iter()
            .fold(0.0, |m, x| m.max(x.abs()))
    }

    fn direct(q: [f64; 4]) -> DMat3 {
        DMat3::from_quat(DQuat::from_array(q).normalize())
    }

    #[test]
    fn quaternion_to_rpy_is_bit_identical_to_urdf_rs() {
        for (q, rpy) in URDF_RS_RPY {
            let got = quaternion_to_rpy(q).to_array();
            assert_eq!(
                got.map(f64::to_bits),
                rpy.map(f64::to_bits),
                "{q:?}: {got:?}"
            );
        }
    }

    #[test]
    fn quaternion_rotation_matches_the_normalised_quaternion() {
        // Away from pitch ±π/2 (and exactly at it), the rpy path and the direct path give the
        // same rotation.
        let mut quats: Vec<[f64; 4]> = URDF_RS_RPY[..7].iter().map(|(q, _)| *q).collect();
        quats.extend([
            [0.0, 0.0, 0.0, 1.0],
            [0.0, 0.0, 0.0, -3.0],
            [0.6, 0.0, 0.0, 0.8],
            [-0.1, 0.9, 0.3, -0.2],
            [0.5, -0.5, 0.5, 0.5],
            [
                0.0,
                -std::f64::consts::FRAC_1_SQRT_2,
                0.0,
                std::f64::consts::FRAC_1_SQRT_2,
            ],
        ]);
        for q in quats {
            let via_rpy = rpy_to_matrix(quaternion_to_rpy(q));
            let d = max_diff(via_rpy, direct(q));
            assert!(d < 1e-12, "{q:?}: differs by {d}");
        }
    }

    #[test]
    fn quaternion_conversion_keeps_the_getrpy_quirks() {
        // Within 1e-5 of pitch ±π/2, getRPY snaps the pitch: the rotation differs from the
        // quaternion's by a few milliradians. That is how urdf-rs read it, and is kept.
        let q = [0.001, 0.7071, 0.0, 0.70711];
        let d = max_diff(rpy_to_matrix(quaternion_to_rpy(q)), direct(q));
        assert!(d > 1e-3 && d < 1e-2, "{d}");
        // A quaternion whose squared norm underflows or overflows reads as the identity.
        for q in [[1e-200, 0.0, 0.0, 1e-200], [1e300, 0.0, 1e300, 0.0]] {
            assert_eq!(rpy_to_matrix(quaternion_to_rpy(q)), DMat3::IDENTITY);
        }
    }

    #[test]
    fn names_keep_their_white_space_and_decode_references() {
        // As urdf-rs read them: roxmltree alone would turn the tab and line breaks into spaces.
        let text = "<robot name=\"r\tx\"><link name=\"a\tb&amp;c&#10;\"/><link name=\"d\"/>\
                    <joint name=\"j\r\n1\" type=\"fixed\"><parent link=\"a\tb&amp;c&#10;\"/>\
                    <child link=\"d\"/></joint></robot>";
        let robot = read_str(text).unwrap();
        assert_eq!(robot.name, "r\tx");
        assert_eq!(robot.links[0].name, "a\tb&c\n");
        assert_eq!(robot.joints[0].name, "j\r\n1");
        assert_eq!(robot.joints[0].parent, 0);
        // A tab is not a space.
        let text = text.replace("<parent link=\"a\tb", "<parent link=\"a b");
        assert_eq!(
            read_str(&text).unwrap_err(),
            ModelError::MissingLink {
                joint: "j\r\n1".into(),
                role: "parent",
                link: "a b&c\n".into()
            }
        );
    }

    #[test]
    fn numbers_are_strict() {
        assert_eq!(numbers::<3>(" 1\t2\n3 "), Some([1.0, 2.0, 3.0]));
        assert_eq!(numbers::<3>("1 2"), None);
        assert_eq!(numbers::<3>("1 2 3 4"), None);
        assert_eq!(numbers::<3>("1 2 x"), None);
        assert_eq!(numbers::<1>(""), None);
        assert_eq!(numbers::<1>("1e"), None);
    }
}
