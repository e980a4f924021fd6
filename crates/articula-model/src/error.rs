//! The one error type of model loading and validation.

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
    #[error("link '{link}' has invalid mass {mass}")]
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
    /// The rotational inertia is not positive semidefinite.
    #[error("link '{link}': rotational inertia is not positive semidefinite")]
    InertiaNotPositive {
        /// The link.
        link: String,
    },
    /// The principal moments break the triangle inequality (no physical body has them).
    #[error("link '{link}': principal moments of inertia break the triangle inequality")]
    TriangleInequality {
        /// The link.
        link: String,
    },
    /// A body (after merging fixed joints) whose spatial inertia is singular but not zero —
    /// a point or rod mass, or zero mass with rotational inertia. The divide-and-conquer
    /// algorithm inverts every body's inertia.
    #[error("body '{link}' has a singular spatial inertia (point or rod mass, or zero mass with rotational inertia): give it a full rotational inertia")]
    DegenerateInertia {
        /// The link.
        link: String,
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
    /// A non-finite joint origin.
    #[error("joint '{joint}' has a non-finite origin")]
    InvalidOrigin {
        /// The joint.
        joint: String,
    },
    /// A massless body at the end of a moving joint with nothing massive beyond it: the
    /// joint's acceleration is undetermined.
    #[error("link '{link}' is massless at the end of moving joint '{joint}' with nothing massive beyond it: the dynamics is singular")]
    SingularMassless {
        /// The massless link.
        link: String,
        /// The joint that moves it.
        joint: String,
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
}
