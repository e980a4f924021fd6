//! The one error type of model loading and validation.

use crate::body_inertia::InertiaDefect;
use crate::InertiaPolicy;
use thiserror::Error;

/// Everything that can go wrong turning a URDF into a [`crate::Model`]. Every variant that
/// concerns a particular link or joint names it.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ModelError {
    /// The file could not be read.
    #[error("cannot read {path}: {message}")]
    Io {
        /// The path given.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// The input is empty (or only white space).
    #[error("the URDF is empty")]
    Empty,
    /// The input is not UTF-8 text (a binary file, or a NUL byte).
    #[error("the URDF is not text: {reason} at byte {offset}")]
    NotText {
        /// What was found.
        reason: String,
        /// Byte offset of the first offending byte.
        offset: usize,
    },
    /// Malformed or truncated XML.
    #[error("malformed XML at line {line}, column {column}: {message}")]
    Xml {
        /// 1-based line.
        line: u32,
        /// 1-based column.
        column: u32,
        /// The parser's message.
        message: String,
    },
    /// The document's root element is not `<robot>`.
    #[error("the root element is <{found}>, expected <robot>")]
    NotARobot {
        /// The element found.
        found: String,
    },
    /// A required element or attribute is missing or unparsable.
    #[error("{element} '{name}': {message}")]
    Malformed {
        /// `link` or `joint`.
        element: &'static str,
        /// The link or joint name (empty when the name itself is missing).
        name: String,
        /// What is wrong.
        message: String,
    },
    /// An MJCF file articula cannot read as written: the file, the element (with its name and
    /// line) and the attribute at fault.
    #[error("{file}: {element}{}: {message}", attribute.as_ref().map(|a| format!(", attribute '{a}'")).unwrap_or_default())]
    Mjcf {
        /// The file (or `<string>`).
        file: String,
        /// The element, as `<joint name="knee"> (line 12)`.
        element: String,
        /// The attribute, when one is at fault.
        attribute: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// The robot has no links.
    #[error("the robot has no links")]
    NoLinks,
    /// Two links share a name.
    #[error("duplicate link name '{link}'")]
    DuplicateLink {
        /// The name.
        link: String,
    },
    /// Two joints share a name.
    #[error("duplicate joint name '{joint}'")]
    DuplicateJoint {
        /// The name.
        joint: String,
    },
    /// A joint names a parent or child link that does not exist.
    #[error("joint '{joint}' names {role} link '{link}', which does not exist")]
    MissingLink {
        /// The joint.
        joint: String,
        /// `parent` or `child`.
        role: &'static str,
        /// The missing link.
        link: String,
    },
    /// A link is the child of more than one joint.
    #[error("link '{link}' is the child of several joints: {joints:?}")]
    MultipleParents {
        /// The link.
        link: String,
        /// The joints.
        joints: Vec<String>,
    },
    /// More than one link has no parent joint.
    #[error("the robot has several root links: {roots:?}")]
    MultipleRoots {
        /// The parentless links.
        roots: Vec<String>,
    },
    /// The joints form a cycle.
    #[error("the joints form a cycle through link '{link}'")]
    Cycle {
        /// A link on the cycle.
        link: String,
    },
    /// Mass negative, NaN or infinite.
    #[error("link '{link}' has invalid mass {}", crate::error::number(*mass))]
    InvalidMass {
        /// The link.
        link: String,
        /// The value read.
        mass: f64,
    },
    /// An inertia entry or the inertial origin is not finite.
    #[error("link '{link}' has a non-finite inertia or inertial origin")]
    NonFiniteInertia {
        /// The link.
        link: String,
    },
    /// Bodies (after fixed-joint merging) whose inertia the policy refuses, every one listed
    /// with its numbers.
    #[error("{}", inertia_message(*policy, defects))]
    Inertia {
        /// The policy that refused them.
        policy: InertiaPolicy,
        /// Every broken condition of every refused body.
        defects: Vec<InertiaDefect>,
    },
    /// A load option that cannot be used (a repair bound that is negative or not finite, or
    /// given without [`InertiaPolicy::Repair`]).
    #[error("load option {option} {message}")]
    BadOption {
        /// The [`crate::LoadOptions`] field.
        option: &'static str,
        /// What is wrong.
        message: String,
    },
    /// A joint type articula does not know.
    #[error("joint '{joint}' has unknown type '{kind}'")]
    UnknownJointType {
        /// The joint.
        joint: String,
        /// The type attribute.
        kind: String,
    },
    /// A joint type articula refuses (planar, spherical).
    #[error("joint '{joint}' has type '{kind}', which articula does not support (model it with revolute/prismatic joints and massless links)")]
    UnsupportedJointType {
        /// The joint.
        joint: String,
        /// The type.
        kind: String,
    },
    /// A zero, non-finite or malformed joint axis.
    #[error("joint '{joint}' has an invalid axis: {reason}")]
    InvalidAxis {
        /// The joint.
        joint: String,
        /// What is wrong.
        reason: String,
    },
    /// A finite value too large for the dynamics to stay finite on ([`MAX_MASS`](crate::MAX_MASS),
    /// [`MAX_LENGTH`](crate::MAX_LENGTH), [`MAX_INERTIA`](crate::MAX_INERTIA)).
    #[error(
        "{what} is {}, beyond the limit of {} (docs/loading.md, \"Limits\")",
        crate::error::number(*value),
        crate::error::number(*limit)
    )]
    Absurd {
        /// The field, naming its link or joint (`link 'a' mass (kg)`).
        what: String,
        /// The value read.
        value: f64,
        /// The limit it passes.
        limit: f64,
    },
    /// A non-finite joint origin.
    #[error("joint '{joint}' has a non-finite origin")]
    InvalidOrigin {
        /// The joint.
        joint: String,
    },
    /// Moving joints that carry no mass (nothing massive beyond them), refused by
    /// [`crate::MasslessLeafPolicy::Refuse`] — or a floating base with no mass at all.
    #[error("{}", massless_message(leaves))]
    SingularMassless {
        /// Every such joint with its first massless link: `(link, joint)`.
        leaves: Vec<(String, String)>,
    },
    /// A massless link carries several moving joints to massive subtrees; it cannot be composed
    /// into one multi-DOF joint.
    #[error(
        "massless link '{link}' branches into several moving joints: {joints:?}; give it a mass"
    )]
    MasslessBranch {
        /// The link.
        link: String,
        /// Its moving child joints.
        joints: Vec<String>,
    },
    /// An input larger than its limit (read no further).
    #[error("{what} is larger than the limit of {limit} bytes (read {size} bytes)")]
    TooLarge {
        /// What was read (`the URDF file x.urdf`).
        what: String,
        /// Bytes read before stopping (the limit plus one when the input goes on).
        size: u64,
        /// The limit.
        limit: u64,
    },
    /// XML elements nested deeper than the limit (the parser would exhaust the stack).
    #[error(
        "malformed XML at line {line}, column {column}: elements nested deeper than {limit} levels"
    )]
    TooDeep {
        /// 1-based line of the element past the limit.
        line: u32,
        /// 1-based column.
        column: u32,
        /// The limit.
        limit: usize,
    },
    /// An error located in a file's text (malformed XML, nesting, attributes, not text, empty),
    /// with the file it is in ([`Model::from_urdf_file`](crate::Model::from_urdf_file)).
    #[error("{path}: {source}")]
    InFile {
        /// The file.
        path: String,
        /// The error in its text.
        source: Box<ModelError>,
    },
    /// An element with more attributes than [`MAX_XML_ATTRIBUTES`](crate::MAX_XML_ATTRIBUTES),
    /// counted before the XML parser (whose duplicate check is quadratic in them) runs.
    #[error(
        "malformed XML at line {line}, column {column}: an element with more than {limit} attributes"
    )]
    TooManyAttributes {
        /// 1-based line of the element.
        line: u32,
        /// 1-based column.
        column: u32,
        /// The limit.
        limit: usize,
    },
}

fn inertia_message(policy: InertiaPolicy, defects: &[InertiaDefect]) -> String {
    let mut bodies: Vec<&str> = defects.iter().map(|d| d.body.as_str()).collect();
    bodies.dedup();
    let n = bodies.len();
    let mut out = format!(
        "{n} bod{} with an inertia no rigid body has:",
        if n == 1 { "y" } else { "ies" }
    );
    for d in defects {
        out.push_str("\n  - ");
        out.push_str(&d.to_string());
    }
    out.push('\n');
    out.push_str(match policy {
        InertiaPolicy::Strict => {
            "refused by the strict inertia policy (--inertia strict); --inertia accept loads \
             them as written where dynamics is defined, --inertia repair fixes them"
        }
        _ => {
            "an indefinite or massless inertia has no dynamics: load with --inertia repair \
             (InertiaPolicy::Repair) to fix it, or correct the URDF"
        }
    });
    out
}

fn massless_message(leaves: &[(String, String)]) -> String {
    let list: Vec<String> = leaves
        .iter()
        .map(|(link, joint)| format!("link '{link}' (joint '{joint}')"))
        .collect();
    format!(
        "{} moving joint{} with nothing massive beyond: {}: the dynamics is singular (the default \
         massless-leaf policy locks such joints; a floating base needs some mass)",
        leaves.len(),
        if leaves.len() == 1 { "" } else { "s" },
        list.join(", ")
    )
}

/// A number for a message: plain for ordinary magnitudes, in scientific notation beyond
/// (`1e308`, never a 309-digit integer).
pub(crate) fn number(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-4..1e6).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}
