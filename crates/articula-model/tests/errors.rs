//! Every bad input fails with the right `ModelError` variant naming the right link or joint;
//! sloppy but harmless input loads; merging, composition and the assembly tree are right on
//! hand-made and bundled models.

mod common;

use articula_model::{
    InertiaDefectKind, InertiaPolicy, JointKind, LoadOptions, LoadWarning, MasslessLeafPolicy,
    Model, ModelError, FLOATING_BASE_JOINT,
};
use common::*;
use glam::{DMat3, DVec3};

fn s(x: &str) -> String {
    x.to_string()
}

// ---------------------------------------------------------------------------------------------
// Not a URDF at all.

#[test]
fn malformed_xml_unclosed_tag() {
    let text = "<robot name=\"r\">\n  <link name=\"a\">\n</robot>\n";
    let e = load_err(text);
    assert!(
        matches!(e, ModelError::Xml { line: 3, .. }),
        "expected Xml at line 3, got {e:?}"
    );
}

#[test]
fn truncated_file() {
    let text = read_model("chain10");
    let mut cut = text.len() / 2;
    while !text.is_char_boundary(cut) {
        cut -= 1;
    }
    let e = load_err(&text[..cut]);
    assert!(matches!(e, ModelError::Xml { .. }), "got {e:?}");
}

#[test]
fn truncated_after_root_start_tag() {
    let e = load_err("<robot name=\"r\">");
    assert!(matches!(e, ModelError::Xml { .. }), "got {e:?}");
}

#[test]
fn empty_string() {
    assert_eq!(load_err(""), ModelError::Empty);
}

#[test]
fn whitespace_only() {
    assert_eq!(load_err(" \n\t\r\n  "), ModelError::Empty);
}

#[test]
fn nul_byte() {
    let text = "<robot name=\"r\">\0<link name=\"a\"/></robot>";
    assert_eq!(
        load_err(text),
        ModelError::NotText {
            reason: s("NUL byte"),
            offset: 16
        }
    );
}

#[test]
fn binary_content_with_nul_bytes() {
    let bytes: Vec<u8> = (0u8..=127).cycle().take(600).collect();
    let text = String::from_utf8(bytes).unwrap();
    assert_eq!(
        load_err(&text),
        ModelError::NotText {
            reason: s("NUL byte"),
            offset: 0
        }
    );
}

fn temp_path(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!(
        "articula-model-errors-{}-{name}",
        std::process::id()
    ))
}

#[test]
fn invalid_utf8_file() {
    let path = temp_path("invalid-utf8.urdf");
    let mut bytes = b"<robot name=\"r\"><link name=\"a".to_vec();
    let offset = bytes.len();
    bytes.extend_from_slice(&[0xff, 0xfe, 0x80]);
    bytes.extend_from_slice(b"\"/></robot>");
    std::fs::write(&path, &bytes).unwrap();
    let e = Model::from_urdf_file(&path, &LoadOptions::default()).unwrap_err();
    std::fs::remove_file(&path).ok();
    let ModelError::InFile { source: e, .. } = e else {
        panic!("expected the file named, got {e:?}");
    };
    assert_eq!(
        *e,
        ModelError::NotText {
            reason: s("invalid UTF-8"),
            offset
        }
    );
}

#[test]
fn valid_file_loads_from_path() {
    let path = temp_path("pendulum.urdf");
    std::fs::write(&path, pendulum()).unwrap();
    let m = Model::from_urdf_file(&path, &LoadOptions::default());
    std::fs::remove_file(&path).ok();
    assert_eq!(m.unwrap().nv, 1);
}

#[test]
fn nonexistent_file() {
    let path = models_dir().join("no-such-model.urdf");
    let e = Model::from_urdf_file(&path, &LoadOptions::default()).unwrap_err();
    match e {
        ModelError::Io { path: p, message } => {
            assert_eq!(p, path.display().to_string());
            assert!(!message.is_empty());
        }
        e => panic!("expected Io, got {e:?}"),
    }
}

#[test]
fn root_element_not_robot() {
    let text = "<?xml version=\"1.0\"?>\n<model name=\"m\"><link name=\"a\"/></model>";
    assert_eq!(load_err(text), ModelError::NotARobot { found: s("model") });
}

#[test]
fn robot_without_links() {
    assert_eq!(load_err("<robot name=\"r\"/>"), ModelError::NoLinks);
}

// ---------------------------------------------------------------------------------------------
// Names and topology.

#[test]
fn duplicate_link_names() {
    let text = robot(
        &[
            link("base", 1.0),
            link("arm", 1.0),
            link("arm", 2.0),
            joint("j", "revolute", "base", "arm"),
        ]
        .concat(),
    );
    assert_eq!(
        load_err(&text),
        ModelError::DuplicateLink { link: s("arm") }
    );
}

#[test]
fn duplicate_joint_names() {
    let text = robot(
        &[
            link("base", 1.0),
            link("a", 1.0),
            link("b", 1.0),
            joint("j", "revolute", "base", "a"),
            joint("j", "revolute", "a", "b"),
        ]
        .concat(),
    );
    assert_eq!(
        load_err(&text),
        ModelError::DuplicateJoint { joint: s("j") }
    );
}

#[test]
fn joint_parent_link_missing() {
    let text = robot(
        &[
            link("base", 1.0),
            link("a", 1.0),
            joint("j", "revolute", "nowhere", "a"),
        ]
        .concat(),
    );
    assert_eq!(
        load_err(&text),
        ModelError::MissingLink {
            joint: s("j"),
            role: "parent",
            link: s("nowhere")
        }
    );
}

#[test]
fn joint_child_link_missing() {
    let text = robot(
        &[
            link("base", 1.0),
            link("a", 1.0),
            joint("j1", "revolute", "base", "a"),
            joint("j2", "revolute", "a", "ghost"),
        ]
        .concat(),
    );
    assert_eq!(
        load_err(&text),
        ModelError::MissingLink {
            joint: s("j2"),
            role: "child",
            link: s("ghost")
        }
    );
}

#[test]
fn link_child_of_two_joints() {
    let text = robot(
        &[
            link("base", 1.0),
            link("a", 1.0),
            link("b", 1.0),
            joint("ja", "revolute", "base", "a"),
            joint("jb1", "revolute", "base", "b"),
            joint("jb2", "revolute", "a", "b"),
        ]
        .concat(),
    );
    assert_eq!(
        load_err(&text),
        ModelError::MultipleParents {
            link: s("b"),
            joints: vec![s("jb1"), s("jb2")]
        }
    );
}

#[test]
fn two_root_links() {
    let text = robot(
        &[
            link("base", 1.0),
            link("a", 1.0),
            link("island", 1.0),
            joint("j", "revolute", "base", "a"),
        ]
        .concat(),
    );
    assert_eq!(
        load_err(&text),
        ModelError::MultipleRoots {
            roots: vec![s("base"), s("island")]
        }
    );
}

#[test]
fn cycle_beside_a_root() {
    // `root` is the only parentless link; A and B are each other's parent.
    let text = robot(
        &[
            link("root", 1.0),
            link("A", 1.0),
            link("B", 1.0),
            joint("ab", "revolute", "A", "B"),
            joint("ba", "revolute", "B", "A"),
        ]
        .concat(),
    );
    assert_eq!(load_err(&text), ModelError::Cycle { link: s("A") });
}

#[test]
fn cycle_hanging_off_a_rooted_tree() {
    // root → r1 is a proper tree; C → D → E → C is a cycle (no link in it is parentless).
    let text = robot(
        &[
            link("root", 1.0),
            link("r1", 1.0),
            link("C", 1.0),
            link("D", 1.0),
            link("E", 1.0),
            joint("j0", "revolute", "root", "r1"),
            joint("cd", "revolute", "C", "D"),
            joint("de", "revolute", "D", "E"),
            joint("ec", "revolute", "E", "C"),
        ]
        .concat(),
    );
    assert_eq!(load_err(&text), ModelError::Cycle { link: s("C") });
}

#[test]
fn pure_cycle_without_root() {
    let text = robot(
        &[
            link("A", 1.0),
            link("B", 1.0),
            joint("ab", "revolute", "A", "B"),
            joint("ba", "revolute", "B", "A"),
        ]
        .concat(),
    );
    assert_eq!(load_err(&text), ModelError::Cycle { link: s("A") });
}

#[test]
fn self_loop_joint() {
    let text = robot(
        &[
            link("base", 1.0),
            link("A", 1.0),
            joint("j", "revolute", "base", "A"),
            joint("loop", "revolute", "A", "A"),
        ]
        .concat(),
    );
    assert_eq!(
        load_err(&text),
        ModelError::MultipleParents {
            link: s("A"),
            joints: vec![s("j"), s("loop")]
        }
    );
}

// ---------------------------------------------------------------------------------------------
// Mass and inertia.

fn one_link_on_a_joint(l: &str) -> String {
    robot(
        &[
            link("base", 1.0),
            l.to_string(),
            joint("j", "revolute", "base", "arm"),
        ]
        .concat(),
    )
}

#[test]
fn negative_mass() {
    let text = one_link_on_a_joint(&link_raw("arm", "-1", "0.01", "0.01", "0.01"));
    assert_eq!(
        load_err(&text),
        ModelError::InvalidMass {
            link: s("arm"),
            mass: -1.0
        }
    );
}

#[test]
fn nan_mass() {
    let text = one_link_on_a_joint(&link_raw("arm", "NaN", "0.01", "0.01", "0.01"));
    let e = load_err(&text);
    assert!(
        matches!(&e, ModelError::InvalidMass { link, mass } if link == "arm" && mass.is_nan()),
        "got {e:?}"
    );
}

#[test]
fn infinite_mass() {
    let text = one_link_on_a_joint(&link_raw("arm", "inf", "0.01", "0.01", "0.01"));
    assert_eq!(
        load_err(&text),
        ModelError::InvalidMass {
            link: s("arm"),
            mass: f64::INFINITY
        }
    );
}

#[test]
fn non_finite_inertia_entry() {
    let text = one_link_on_a_joint(&link_raw("arm", "1", "0.01", "nan", "0.01"));
    assert_eq!(
        load_err(&text),
        ModelError::NonFiniteInertia { link: s("arm") }
    );
    let text = one_link_on_a_joint(&link_raw("arm", "1", "0.01", "0.01", "-inf"));
    assert_eq!(
        load_err(&text),
        ModelError::NonFiniteInertia { link: s("arm") }
    );
}

#[test]
fn non_finite_inertial_origin() {
    let l = "  <link name=\"arm\"><inertial><origin xyz=\"0 inf 0\"/><mass value=\"1\"/>\
             <inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/>\
             </inertial></link>\n";
    assert_eq!(
        load_err(&one_link_on_a_joint(l)),
        ModelError::NonFiniteInertia { link: s("arm") }
    );
}

/// The kinds of the inertia defects of a refusal, with their bodies.
fn refused_kinds(e: ModelError) -> Vec<(String, InertiaDefectKind)> {
    match e {
        ModelError::Inertia { defects, .. } => {
            defects.into_iter().map(|d| (d.body, d.kind)).collect()
        }
        e => panic!("expected an inertia refusal, got {e}"),
    }
}

fn load_with(text: &str, p: InertiaPolicy) -> Result<Model, ModelError> {
    Model::from_urdf_str(text, &LoadOptions::default().with_inertia(p))
}

#[test]
fn inertia_not_positive_semidefinite() {
    let text = one_link_on_a_joint(&link_raw("arm", "1", "-1", "1", "1"));
    let e = load_err(&text);
    assert!(e.to_string().contains("--inertia repair"), "{e}");
    assert_eq!(
        refused_kinds(e),
        vec![(s("arm"), InertiaDefectKind::NotPositive)]
    );
}

#[test]
fn inertia_with_positive_diagonal_but_indefinite() {
    // Diagonal positive, but ixy = 2 makes the xy minor 1·1 − 4 < 0: moments −1, 1, 3.
    let l = "  <link name=\"arm\"><inertial><mass value=\"1\"/>\
             <inertia ixx=\"1\" ixy=\"2\" ixz=\"0\" iyy=\"1\" iyz=\"0\" izz=\"1\"/>\
             </inertial></link>\n";
    let e = load_err(&one_link_on_a_joint(l));
    let ModelError::Inertia { defects, .. } = e else {
        panic!("{e}")
    };
    assert_eq!(defects[0].kind, InertiaDefectKind::NotPositive);
    let m = defects[0].moments;
    assert!((m[0] + 1.0).abs() < 1e-12 && (m[1] - 1.0).abs() < 1e-12 && (m[2] - 3.0).abs() < 1e-12);
    // 3 > −1 + 1 too.
    assert_eq!(defects.len(), 1, "accept refuses for the sign only");
}

#[test]
fn inertia_breaks_triangle_inequality() {
    let text = one_link_on_a_joint(&link_raw("arm", "1", "1", "1", "3"));
    // Accepted as written, with one warning naming the body and the excess 3 − 1 − 1 = 1.
    let m = load(&text).unwrap();
    assert_eq!(m.bodies[0].inertia.ibar.z_axis.z, 3.0);
    assert_eq!(m.warnings.len(), 1);
    let w = m.warnings[0].to_string();
    assert!(
        w.contains("'arm'") && w.contains("triangle") && w.contains("by 1.000e0"),
        "{w}"
    );
    assert_eq!(
        refused_kinds(load_with(&text, InertiaPolicy::Strict).unwrap_err()),
        vec![(s("arm"), InertiaDefectKind::TriangleInequality)]
    );
}

#[test]
fn inertia_on_the_triangle_boundary_loads() {
    // A thin disc: izz = ixx + iyy exactly.
    let text = one_link_on_a_joint(&link_raw("arm", "1", "1", "1", "2"));
    let m = load_with(&text, InertiaPolicy::Strict).unwrap();
    assert!(m.warnings.is_empty());
}

#[test]
fn point_mass_loads_as_written_and_repair_bounds_it() {
    let text = one_link_on_a_joint(&link_raw("arm", "1", "0", "0", "0"));
    assert_eq!(
        refused_kinds(load_with(&text, InertiaPolicy::Strict).unwrap_err()),
        vec![(s("arm"), InertiaDefectKind::Singular)]
    );
    // Accept: a point mass stays a point mass, with a warning.
    let m = load(&text).unwrap();
    assert_eq!(m.bodies[0].inertia.inertia_about_com(), DMat3::ZERO);
    assert!(m.bodies[0].inertia.inverse().is_none());
    assert!(matches!(&m.warnings[0], LoadWarning::OddInertia(d)
        if d[0].kind == InertiaDefectKind::Singular));
    // Repair: centre of mass at the link origin, so the scale is m·(1 mm)², the moments 1e-9
    // of it.
    let m = load_with(&text, InertiaPolicy::Repair).unwrap();
    let ic = m.bodies[0].inertia.inertia_about_com();
    assert_eq!(ic, DMat3::from_diagonal(DVec3::splat(1e-15)));
    assert!(m.bodies[0].inertia.inverse().is_some());
    assert!(matches!(m.warnings[0], LoadWarning::InertiaChanged(_)));
}

#[test]
fn zero_mass_with_rotational_inertia() {
    let text = one_link_on_a_joint(&link_raw("arm", "0", "0.01", "0.01", "0.01"));
    let e = load_err(&text);
    assert!(e.to_string().contains("--inertia repair"), "{e}");
    assert_eq!(
        refused_kinds(e),
        vec![(s("arm"), InertiaDefectKind::MasslessWithInertia)]
    );
    // Repair bounds the mass (1e-6 of the largest body mass: the base's 1 kg).
    let m = load_with(&text, InertiaPolicy::Repair).unwrap();
    let arm = m.bodies.iter().find(|b| b.name == "arm").unwrap();
    assert_eq!(arm.inertia.mass, 1e-6);
    assert!(
        m.warnings[0].to_string().contains("boundmass"),
        "{}",
        m.warnings[0]
    );
}

#[test]
fn point_mass_welded_to_a_full_body_loads() {
    // The merged body (full inertia + point mass) is invertible.
    let text = robot(
        &[
            link("base", 1.0),
            link("arm", 1.0),
            link_raw("weight", "2", "0", "0", "0"),
            joint("j", "revolute", "base", "arm"),
            joint_with(
                "weld",
                "fixed",
                "arm",
                "weight",
                "<origin xyz=\"0.5 0 0\"/>",
            ),
        ]
        .concat(),
    );
    let m = load(&text).unwrap();
    assert_eq!(m.bodies.len(), 1);
    assert!((m.bodies[0].inertia.mass - 3.0).abs() < 1e-12);
}

#[test]
fn missing_mass_in_inertial() {
    let l = "  <link name=\"arm\"><inertial>\
             <inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/>\
             </inertial></link>\n";
    assert_eq!(
        load_err(&one_link_on_a_joint(l)),
        ModelError::Malformed {
            element: "link",
            name: s("arm"),
            message: s("<inertial> lacks <mass>")
        }
    );
}

#[test]
fn missing_inertia_in_inertial() {
    let l = "  <link name=\"arm\"><inertial><mass value=\"1\"/></inertial></link>\n";
    assert_eq!(
        load_err(&one_link_on_a_joint(l)),
        ModelError::Malformed {
            element: "link",
            name: s("arm"),
            message: s("<inertial> lacks <inertia>")
        }
    );
}

#[test]
fn missing_inertia_attribute() {
    let l = "  <link name=\"arm\"><inertial><mass value=\"1\"/>\
             <inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" izz=\"0.01\"/>\
             </inertial></link>\n";
    let e = load_err(&one_link_on_a_joint(l));
    assert!(
        matches!(&e, ModelError::Malformed { element: "link", name, message }
            if name == "arm" && message.contains("iyz")),
        "got {e:?}"
    );
}

#[test]
fn malformed_mass_value() {
    let text = one_link_on_a_joint(&link_raw("arm", "1kg", "0.01", "0.01", "0.01"));
    let e = load_err(&text);
    assert!(
        matches!(&e, ModelError::Malformed { element: "link", name, message }
            if name == "arm" && message.contains("1kg")),
        "got {e:?}"
    );
}

#[test]
fn malformed_inertial_origin() {
    let l = "  <link name=\"arm\"><inertial><origin xyz=\"0 0\"/><mass value=\"1\"/>\
             <inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/>\
             </inertial></link>\n";
    let e = load_err(&one_link_on_a_joint(l));
    assert!(
        matches!(&e, ModelError::Malformed { element: "link", name, .. } if name == "arm"),
        "got {e:?}"
    );
}

#[test]
fn link_without_name() {
    let text = robot(&[link("base", 1.0), s("  <link/>\n")].concat());
    assert_eq!(
        load_err(&text),
        ModelError::Malformed {
            element: "link",
            name: s(""),
            message: s("missing 'name' attribute")
        }
    );
}

// ---------------------------------------------------------------------------------------------
// Joints.

fn joint_text(kind: &str, inner: &str) -> String {
    robot(
        &[
            link("base", 1.0),
            link("arm", 1.0),
            joint_with("elbow", kind, "base", "arm", inner),
        ]
        .concat(),
    )
}

#[test]
fn unknown_joint_type() {
    assert_eq!(
        load_err(&joint_text("hinge", "<axis xyz=\"0 0 1\"/>")),
        ModelError::UnknownJointType {
            joint: s("elbow"),
            kind: s("hinge")
        }
    );
}

#[test]
fn joint_type_is_case_sensitive() {
    assert_eq!(
        load_err(&joint_text("Revolute", "<axis xyz=\"0 0 1\"/>")),
        ModelError::UnknownJointType {
            joint: s("elbow"),
            kind: s("Revolute")
        }
    );
}

#[test]
fn planar_joint_unsupported() {
    assert_eq!(
        load_err(&joint_text("planar", "<axis xyz=\"0 0 1\"/>")),
        ModelError::UnsupportedJointType {
            joint: s("elbow"),
            kind: s("planar")
        }
    );
}

#[test]
fn spherical_joint_unsupported() {
    assert_eq!(
        load_err(&joint_text("spherical", "")),
        ModelError::UnsupportedJointType {
            joint: s("elbow"),
            kind: s("spherical")
        }
    );
}

#[test]
fn joint_without_type() {
    let text = robot(
        &[
            link("base", 1.0),
            link("arm", 1.0),
            s("  <joint name=\"elbow\"><parent link=\"base\"/><child link=\"arm\"/></joint>\n"),
        ]
        .concat(),
    );
    assert_eq!(
        load_err(&text),
        ModelError::Malformed {
            element: "joint",
            name: s("elbow"),
            message: s("missing 'type' attribute")
        }
    );
}

#[test]
fn joint_without_child() {
    let text = robot(
        &[
            link("base", 1.0),
            link("arm", 1.0),
            s("  <joint name=\"elbow\" type=\"revolute\"><parent link=\"base\"/></joint>\n"),
        ]
        .concat(),
    );
    assert_eq!(
        load_err(&text),
        ModelError::Malformed {
            element: "joint",
            name: s("elbow"),
            message: s("missing <child>")
        }
    );
}

#[test]
fn zero_axis() {
    assert_eq!(
        load_err(&joint_text("revolute", "<axis xyz=\"0 0 0\"/>")),
        ModelError::InvalidAxis {
            joint: s("elbow"),
            reason: s("zero length")
        }
    );
}

#[test]
fn zero_axis_on_a_fixed_joint_is_fine() {
    let m = load(&joint_text("fixed", "<axis xyz=\"0 0 0\"/>")).unwrap();
    assert_eq!(m.bodies.len(), 0);
    assert_eq!(m.ground_links.len(), 2);
    assert!((m.ground_mass - 2.0).abs() < 1e-12);
}

#[test]
fn axis_with_two_numbers() {
    let e = load_err(&joint_text("revolute", "<axis xyz=\"1 0\"/>"));
    assert!(
        matches!(&e, ModelError::InvalidAxis { joint, reason } if joint == "elbow" && reason.contains("1 0")),
        "got {e:?}"
    );
}

#[test]
fn axis_with_garbage_number() {
    let e = load_err(&joint_text("prismatic", "<axis xyz=\"1 x 0\"/>"));
    assert!(
        matches!(&e, ModelError::InvalidAxis { joint, reason } if joint == "elbow" && reason.contains("1 x 0")),
        "got {e:?}"
    );
}

#[test]
fn axis_without_xyz() {
    let e = load_err(&joint_text("revolute", "<axis/>"));
    assert!(
        matches!(&e, ModelError::InvalidAxis { joint, .. } if joint == "elbow"),
        "got {e:?}"
    );
}

#[test]
fn non_finite_axis() {
    assert_eq!(
        load_err(&joint_text("continuous", "<axis xyz=\"0 nan 1\"/>")),
        ModelError::InvalidAxis {
            joint: s("elbow"),
            reason: s("non-finite component")
        }
    );
}

#[test]
fn non_finite_joint_origin() {
    assert_eq!(
        load_err(&joint_text(
            "revolute",
            "<origin xyz=\"nan 0 0\"/><axis xyz=\"0 0 1\"/>"
        )),
        ModelError::InvalidOrigin { joint: s("elbow") }
    );
    assert_eq!(
        load_err(&joint_text(
            "revolute",
            "<origin xyz=\"0 0 0\" rpy=\"0 -inf 0\"/><axis xyz=\"0 0 1\"/>"
        )),
        ModelError::InvalidOrigin { joint: s("elbow") }
    );
}

#[test]
fn malformed_number_in_joint_origin() {
    let e = load_err(&joint_text(
        "revolute",
        "<origin xyz=\"0 0 0.1.2\"/><axis xyz=\"0 0 1\"/>",
    ));
    assert!(
        matches!(&e, ModelError::Malformed { element: "joint", name, message }
            if name == "elbow" && message.contains("0.1.2")),
        "got {e:?}"
    );
}

#[test]
fn empty_joint_origin_attribute() {
    let e = load_err(&joint_text(
        "revolute",
        "<origin xyz=\"\"/><axis xyz=\"0 0 1\"/>",
    ));
    assert!(
        matches!(&e, ModelError::Malformed { element: "joint", name, .. } if name == "elbow"),
        "got {e:?}"
    );
}

#[test]
fn duplicate_joint_origin() {
    assert_eq!(
        load_err(&joint_text(
            "revolute",
            "<origin xyz=\"0 0 1\"/><origin xyz=\"0 0 2\"/><axis xyz=\"0 0 1\"/>"
        )),
        ModelError::Malformed {
            element: "joint",
            name: s("elbow"),
            message: s("duplicate <origin>")
        }
    );
}

#[test]
fn duplicate_joint_axis_parent_child() {
    for (inner, tag) in [
        ("<axis xyz=\"0 0 1\"/><axis xyz=\"0 1 0\"/>", "axis"),
        ("<parent link=\"base\"/>", "parent"),
        ("<child link=\"arm\"/>", "child"),
    ] {
        assert_eq!(
            load_err(&joint_text("revolute", inner)),
            ModelError::Malformed {
                element: "joint",
                name: s("elbow"),
                message: format!("duplicate <{tag}>")
            }
        );
    }
}

#[test]
fn duplicate_inertial_parts() {
    let inertia = "<inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/>";
    for (inner, tag) in [
        (format!("<inertial><mass value=\"1\"/>{inertia}</inertial><inertial><mass value=\"1\"/>{inertia}</inertial>"), "inertial"),
        (format!("<inertial><mass value=\"1\"/><mass value=\"2\"/>{inertia}</inertial>"), "mass"),
        (format!("<inertial><mass value=\"1\"/>{inertia}{inertia}</inertial>"), "inertia"),
        (format!("<inertial><origin xyz=\"0 0 1\"/><origin/><mass value=\"1\"/>{inertia}</inertial>"), "origin"),
    ] {
        let l = format!("  <link name=\"arm\">{inner}</link>\n");
        assert_eq!(
            load_err(&one_link_on_a_joint(&l)),
            ModelError::Malformed {
                element: "link",
                name: s("arm"),
                message: format!("duplicate <{tag}>")
            }
        );
    }
}

#[test]
fn duplicate_geometry_is_fine() {
    // Several visuals, collisions and limits are not dynamics' business.
    let l = "  <link name=\"arm\"><inertial><mass value=\"1\"/>\
             <inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/>\
             </inertial><visual><geometry><box size=\"1 1 1\"/></geometry></visual>\
             <visual><geometry><sphere radius=\"1\"/></geometry></visual>\
             <collision><geometry/></collision><collision><geometry/></collision></link>\n";
    load(&one_link_on_a_joint(l)).unwrap();
    let m = load(&joint_text(
        "revolute",
        "<axis xyz=\"0 0 1\"/><limit effort=\"1\"/><limit lower=\"0\"/><mimic joint=\"x\"/><mimic joint=\"y\"/>",
    ))
    .unwrap();
    assert_eq!(m.warnings.len(), 2);
}

#[test]
fn empty_namespace_prefix_in_a_kept_attribute() {
    // roxmltree reads `:ixy` as `ixy`; urdf-rs's parser rejects it. Found by the fuzz test.
    let l = "  <link name=\"arm\"><inertial><mass value=\"1\"/>\n\
             <inertia ixx=\"0.01\" :ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/>\
             </inertial></link>\n";
    let e = load_err(&one_link_on_a_joint(l));
    assert!(
        matches!(&e, ModelError::Xml { line: 11, column: 21, message } if message.contains("prefix")),
        "got {e:?}"
    );
}

#[test]
fn empty_namespace_prefix_in_a_kept_element() {
    let text = robot(
        &[
            link("base", 1.0),
            link("arm", 1.0),
            s("  <joint name=\"elbow\" type=\"revolute\"><:parent link=\"base\"/><child link=\"arm\"/></joint>\n"),
        ]
        .concat(),
    );
    let e = load_err(&text);
    assert!(matches!(&e, ModelError::Xml { .. }), "got {e:?}");
}

#[test]
fn empty_namespace_prefix_in_ignored_geometry_is_fine() {
    let text = robot(
        &[
            link("base", 1.0),
            s("  <link name=\"arm\"><visual :name=\"v\"><geometry><:box/></geometry></visual></link>\n"),
            link("hand", 1.0),
            joint("j", "revolute", "base", "hand"),
            joint("weld", "fixed", "base", "arm"),
        ]
        .concat(),
    );
    load(&text).unwrap();
}

#[test]
fn empty_namespace_prefix_in_an_end_tag() {
    // roxmltree matches `</:robot>` with `<robot>`; urdf-rs's parser rejects it. Found by the
    // fuzz test.
    let text = pendulum().replace("</robot>", "</:robot>");
    let e = load_err(&text);
    assert!(
        matches!(&e, ModelError::Xml { message, .. } if message.contains("prefix")),
        "got {e:?}"
    );
}

#[test]
fn fixed_joint_origins_adding_up_to_infinity() {
    // Each origin is finite; their sum along the fixed run is not.
    let text = robot(
        &[
            link("base", 1.0),
            link("a", 1.0),
            link("b", 1.0),
            link("c", 1.0),
            joint_with("w1", "fixed", "base", "a", "<origin xyz=\"1e308 0 0\"/>"),
            joint_with("w2", "fixed", "a", "b", "<origin xyz=\"1e308 0 0\"/>"),
            joint("j", "revolute", "b", "c"),
        ]
        .concat(),
    );
    // Each origin is beyond `MAX_LENGTH` already: refused by name, before any sum.
    assert_eq!(load_err(&text), absurd("joint 'w1' origin (m)", 1e308, 1e6));
}

fn absurd(what: &str, value: f64, limit: f64) -> ModelError {
    ModelError::Absurd {
        what: s(what),
        value,
        limit,
    }
}

#[test]
fn moving_joint_origin_overflowing_after_a_fixed_joint() {
    let text = robot(
        &[
            link("base", 1.0),
            bare_link("a"),
            link("c", 1.0),
            joint_with("w", "fixed", "base", "a", "<origin xyz=\"0 -1e308 0\"/>"),
            joint_with(
                "j",
                "revolute",
                "a",
                "c",
                "<origin xyz=\"0 -1e308 0\"/><axis xyz=\"0 0 1\"/>",
            ),
        ]
        .concat(),
    );
    assert_eq!(load_err(&text), absurd("joint 'w' origin (m)", -1e308, 1e6));
}

#[test]
fn huge_mass_far_from_its_link_origin() {
    // Finite numbers whose first moment m·c overflows.
    let l = "  <link name=\"arm\"><inertial><origin xyz=\"1e200 0 0\"/><mass value=\"1e200\"/>\
             <inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" iyy=\"1\" iyz=\"0\" izz=\"1\"/>\
             </inertial></link>\n";
    assert_eq!(
        load_err(&one_link_on_a_joint(l)),
        absurd("link 'arm' mass (kg)", 1e200, 1e12)
    );
    // Within the limits the message prints the number sanely, not 309 digits.
    let e = load_err(&one_link_on_a_joint(
        &l.replace("mass value=\"1e200\"", "mass value=\"1e308\""),
    ));
    assert!(e.to_string().contains("1e308"), "{e}");
    assert!(e.to_string().len() < 200, "{e}");
}

#[test]
fn huge_welded_mass_far_away() {
    // Finite on its own; welded 1e200 m away its inertia overflows.
    let text = robot(
        &[
            link("base", 1.0),
            link("arm", 1.0),
            link_raw("lump", "1e200", "1e198", "1e198", "1e198"),
            joint("j", "revolute", "base", "arm"),
            joint_with("w", "fixed", "arm", "lump", "<origin xyz=\"1e200 0 0\"/>"),
        ]
        .concat(),
    );
    assert_eq!(
        load_err(&text),
        absurd("link 'lump' mass (kg)", 1e200, 1e12)
    );
}

#[test]
fn huge_axis_is_normalised_not_zeroed() {
    // |axis|² overflows; the axis must still come out as a unit vector.
    let m = load(&joint_text("revolute", "<axis xyz=\"1e300 1e300 0\"/>")).unwrap();
    let axis = m.bodies[0].joint[0].axis;
    let h = std::f64::consts::FRAC_1_SQRT_2;
    assert!((axis - DVec3::new(h, h, 0.0)).length() < 1e-12, "{axis:?}");
}

fn quat_robot(version: &str, origin: &str) -> String {
    format!(
        "<robot name=\"q\" version=\"{version}\">\n{}{}{}</robot>\n",
        link("base", 1.0),
        link("arm", 1.0),
        joint_with(
            "elbow",
            "revolute",
            "base",
            "arm",
            &format!("<origin {origin}/><axis xyz=\"0 0 1\"/>")
        )
    )
}

#[test]
fn quaternion_origin_urdf_1_1() {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let m = load(&quat_robot(
        "1.1",
        &format!("xyz=\"1 2 3\" quat_xyzw=\"0 0 {h} {h}\""),
    ))
    .unwrap();
    let (rot, pos) = m.bodies[0].joint[0].origin.to_pose();
    assert!(
        (pos - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12,
        "{pos:?}"
    );
    let rz = DMat3::from_rotation_z(std::f64::consts::FRAC_PI_2);
    assert_mat_close(rot, rz, 1e-9);
}

#[test]
fn quaternion_ignored_before_urdf_1_1() {
    // Like urdfdom, URDF 1.0 ignores quat_xyzw (even a meaningless one).
    let m = load(&quat_robot("1.0", "quat_xyzw=\"nan nan nan nan\"")).unwrap();
    assert_eq!(m.bodies[0].joint[0].origin.e, DMat3::IDENTITY);
}

#[test]
fn non_finite_quaternion() {
    assert_eq!(
        load_err(&quat_robot("1.1", "quat_xyzw=\"nan nan nan nan\"")),
        ModelError::InvalidOrigin { joint: s("elbow") }
    );
    let l = "  <link name=\"arm\"><inertial><origin quat_xyzw=\"0 inf 0 1\"/><mass value=\"1\"/>\
             <inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/>\
             </inertial></link>\n";
    let text = format!(
        "<robot name=\"q\" version=\"1.1\">{}{l}{}</robot>",
        link("base", 1.0),
        joint("j", "revolute", "base", "arm")
    );
    assert_eq!(
        load_err(&text),
        ModelError::NonFiniteInertia { link: s("arm") }
    );
}

#[test]
fn zero_quaternion() {
    assert_eq!(
        load_err(&quat_robot("1.1", "quat_xyzw=\"0 0 0 0\"")),
        ModelError::Malformed {
            element: "joint",
            name: s("elbow"),
            message: s("<origin> 'quat_xyzw' is the zero quaternion")
        }
    );
}

#[test]
fn quaternion_and_rpy_together() {
    assert_eq!(
        load_err(&quat_robot("1.1", "rpy=\"0 0 0\" quat_xyzw=\"0 0 0 1\"")),
        ModelError::Malformed {
            element: "joint",
            name: s("elbow"),
            message: s("<origin> has both 'rpy' and 'quat_xyzw'")
        }
    );
}

#[test]
fn malformed_quaternion() {
    let e = load_err(&quat_robot("1.0", "quat_xyzw=\"0 0 1\""));
    assert!(
        matches!(&e, ModelError::Malformed { element: "joint", name, .. } if name == "elbow"),
        "got {e:?}"
    );
}

#[test]
fn document_type_declaration_is_rejected() {
    let text = format!(
        "<!DOCTYPE robot [<!ENTITY m \"2\">]>\n{}",
        pendulum().replace("<?xml version=\"1.0\"?>\n", "")
    );
    assert!(matches!(load_err(&text), ModelError::Xml { line: 1, .. }));
}

#[test]
fn character_references_are_decoded() {
    let text = robot(
        &[
            link("base", 1.0),
            link_raw("a&amp;b", "&#50;", "0.01", "0.01", "0.01"),
            joint("j&lt;1&gt;", "revolute", "base", "a&amp;b"),
        ]
        .concat(),
    );
    let m = load(&text).unwrap();
    assert_eq!(m.bodies[0].name, "a&b");
    assert_eq!(m.bodies[0].joint[0].name, "j<1>");
    assert!((m.bodies[0].inertia.mass - 2.0).abs() < 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Massless links.

fn load_refusing_massless(text: &str) -> Result<Model, ModelError> {
    Model::from_urdf_str(
        text,
        &LoadOptions::default().with_massless_leaf(MasslessLeafPolicy::Refuse),
    )
}

#[test]
fn massless_leaf_on_a_moving_joint() {
    let text = robot(
        &[
            link("base", 1.0),
            bare_link("tip"),
            joint("wrist", "revolute", "base", "tip"),
        ]
        .concat(),
    );
    assert_eq!(
        load_refusing_massless(&text).unwrap_err(),
        ModelError::SingularMassless {
            leaves: vec![(s("tip"), s("wrist"))]
        }
    );
    // Locked by default: welded to the ground, its coordinate kept.
    let m = load(&text).unwrap();
    assert_eq!((m.bodies.len(), m.nq, m.nv), (0, 1, 1));
    assert_eq!(m.locked_joints(), vec!["wrist"]);
    assert_eq!(m.ground_links.len(), 2);
}

#[test]
fn massless_run_ending_in_nothing_massive() {
    // base → j1 → m1 (massless) → j2 → m2 (massless, only a fixed massless link beyond).
    let text = robot(
        &[
            link("base", 1.0),
            bare_link("m1"),
            bare_link("m2"),
            bare_link("sensor"),
            joint("j1", "revolute", "base", "m1"),
            joint("j2", "prismatic", "m1", "m2"),
            joint("weld", "fixed", "m2", "sensor"),
        ]
        .concat(),
    );
    assert_eq!(
        load_refusing_massless(&text).unwrap_err(),
        ModelError::SingularMassless {
            leaves: vec![(s("m1"), s("j1"))]
        }
    );
    let m = load(&text).unwrap();
    assert_eq!(m.locked_joints(), vec!["j1", "j2"]);
    assert_eq!(m.locked[1].links, vec![s("m2"), s("sensor")]);
    assert_eq!((m.nq, m.nv), (2, 2));
}

#[test]
fn massless_link_branching_into_two_moving_joints() {
    let text = robot(
        &[
            link("base", 1.0),
            bare_link("hub"),
            link("a", 1.0),
            link("b", 1.0),
            joint("j0", "revolute", "base", "hub"),
            joint("ja", "revolute", "hub", "a"),
            joint("jb", "revolute", "hub", "b"),
        ]
        .concat(),
    );
    assert_eq!(
        load_err(&text),
        ModelError::MasslessBranch {
            link: s("hub"),
            joints: vec![s("ja"), s("jb")]
        }
    );
}

#[test]
fn massless_floating_root_with_nothing_beyond() {
    let text = robot(&bare_link("alone"));
    assert_eq!(
        load_floating(&text).unwrap_err(),
        ModelError::SingularMassless {
            leaves: vec![(s("alone"), s(FLOATING_BASE_JOINT))]
        }
    );
    // With a fixed base the same robot is just the ground.
    let m = load(&text).unwrap();
    assert_eq!((m.bodies.len(), m.nq, m.nv), (0, 0, 0));
    check_invariants(&m);
}

// ---------------------------------------------------------------------------------------------
// Sloppy but harmless input loads.

#[test]
fn sloppy_geometry_and_extras_load() {
    let text = r#"<?xml version="1.0"?>
<!-- a comment -->
<robot name="sloppy" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <material name="paint"><color rgba="red please"/></material>
  <link name="base">
    <inertial>
      <mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
    <visual>
      <geometry><mesh/></geometry>
      <material name="x"><color rgba="1 2"/><texture/></material>
    </visual>
    <visual>
      <origin xyz="a b c"/>
      <geometry><teapot spout="long"/></geometry>
    </visual>
    <collision>
      <geometry><box size="1 2"/></geometry>
    </collision>
    <collision><geometry/></collision>
    <surprise>whatever</surprise>
  </link>
  <link name="arm">
    <inertial>
      <origin xyz="0 0 0.5" rpy="0 0 0"/>
      <mass value="2"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/>
      <comment>ignored</comment>
    </inertial>
    <visual><geometry><cylinder radius="x"/></geometry><material name=""/></visual>
  </link>
  <joint name="elbow" type="revolute">
    <parent link="base"/>
    <child link="arm"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10"/>
    <safety_controller k_velocity="?"/>
    <calibration rising="never"/>
  </joint>
  <gazebo reference="arm"><material>Gazebo/Red</material><mu1>0.2</mu1><plugin name="x" filename="y"><anything><at all="1"/></anything></plugin></gazebo>
  <gazebo>not even xml-ish content &amp; stuff</gazebo>
  <transmission name="t1"><type>transmission_interface/SimpleTransmission</type>
    <joint name="nonexistent"><hardwareInterface>Effort</hardwareInterface></joint>
    <actuator name="m"><mechanicalReduction>many</mechanicalReduction></actuator>
  </transmission>
  <xacro:macro name="m" params="a"><link name="${a}"/></xacro:macro>
  <ros2_control name="x" type="system"><hardware/></ros2_control>
</robot>
"#;
    // Damping is dynamics now (it enters every step as a passive force): a value that is not a
    // number is refused, naming the joint, as the other dynamic values are.
    let bad = text.replacen("</joint>", "<dynamics damping=\"lots\"/></joint>", 1);
    let err = load(&bad).unwrap_err().to_string();
    assert!(err.contains("elbow") && err.contains("damping"), "{err}");
    let m = load(text).unwrap();
    assert_eq!(m.name, "sloppy");
    assert_eq!(m.bodies.len(), 1);
    assert_eq!(m.bodies[0].name, "arm");
    assert_eq!(m.bodies[0].joint[0].name, "elbow");
    assert_eq!(m.bodies[0].joint[0].axis, DVec3::Y);
    assert!((m.bodies[0].inertia.mass - 2.0).abs() < 1e-12);
    check_invariants(&m);
}

#[test]
fn limit_missing_velocity_loads() {
    let m = load(&joint_text(
        "revolute",
        "<axis xyz=\"1 0 0\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\"/>",
    ))
    .unwrap();
    assert_eq!(m.nv, 1);
    assert_eq!(m.bodies[0].joint[0].kind, JointKind::Revolute);
}

#[test]
fn missing_axis_defaults_to_x() {
    let m = load(&joint_text("continuous", "")).unwrap();
    assert_eq!(m.bodies[0].joint[0].axis, DVec3::X);
}

#[test]
fn mimic_joint_loads_with_a_warning() {
    let text = robot(
        &[
            link("base", 1.0),
            link("a", 1.0),
            link("b", 1.0),
            joint("leader", "revolute", "base", "a"),
            joint_with(
                "follower",
                "revolute",
                "a",
                "b",
                "<axis xyz=\"0 0 1\"/><mimic joint=\"leader\" multiplier=\"2\"/>",
            ),
        ]
        .concat(),
    );
    let m = load(&text).unwrap();
    assert_eq!(m.nv, 2);
    assert_eq!(m.warnings.len(), 1, "warnings: {:?}", m.warnings);
    let w = m.warnings[0].to_string();
    assert!(w.contains("'follower'"), "{w}");
    assert!(w.contains("'leader'"), "{w}");
}

#[test]
fn non_unit_axis_is_normalised_with_a_warning() {
    let m = load(&joint_text("prismatic", "<axis xyz=\"0 0 2\"/>")).unwrap();
    assert_eq!(m.bodies[0].joint[0].axis, DVec3::Z);
    assert_eq!(m.warnings.len(), 1);
    assert!(
        m.warnings[0].to_string().contains("'elbow'"),
        "{:?}",
        m.warnings
    );
}

// ---------------------------------------------------------------------------------------------
// Composition of joints through massless links, and fixed-joint merging.

#[test]
fn three_revolute_joints_through_massless_links_compose() {
    let text = robot(
        &[
            link("pelvis", 10.0),
            bare_link("hip_a"),
            s("  <link name=\"hip_b\"><inertial><mass value=\"0\"/>\
               <inertia ixx=\"0\" ixy=\"0\" ixz=\"0\" iyy=\"0\" iyz=\"0\" izz=\"0\"/>\
               </inertial></link>\n"),
            link("thigh", 5.0),
            joint("hip_yaw", "revolute", "pelvis", "hip_a"),
            joint_with(
                "hip_roll",
                "revolute",
                "hip_a",
                "hip_b",
                "<axis xyz=\"1 0 0\"/>",
            ),
            joint_with(
                "hip_pitch",
                "revolute",
                "hip_b",
                "thigh",
                "<origin xyz=\"0 0 -0.1\"/><axis xyz=\"0 1 0\"/>",
            ),
        ]
        .concat(),
    );
    let m = load(&text).unwrap();
    assert_eq!(m.bodies.len(), 1);
    let b = &m.bodies[0];
    assert_eq!(b.name, "thigh");
    let names: Vec<&str> = b.joint.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["hip_yaw", "hip_roll", "hip_pitch"]);
    let axes: Vec<DVec3> = b.joint.iter().map(|p| p.axis).collect();
    assert_eq!(axes, [DVec3::Z, DVec3::X, DVec3::Y]);
    assert_eq!(b.massless_links, ["hip_a", "hip_b"]);
    assert_eq!(b.joint_name(), "hip_yaw+hip_roll+hip_pitch");
    assert_eq!((b.nq, b.nv, m.nq, m.nv), (3, 3, 3, 3));
    let offsets: Vec<(usize, usize)> = b.joint.iter().map(|p| (p.q_offset, p.v_offset)).collect();
    assert_eq!(offsets, [(0, 0), (1, 1), (2, 2)]);
    assert_eq!(m.find_joint("hip_roll").map(|(i, _)| i), Some(0));
    assert_eq!(m.assembly.nodes.len(), 3);
    check_invariants(&m);
}

/// `Σ m |d|² 1 − m d dᵀ`: the parallel-axis term of a mass `m` at offset `d`.
fn parallel_axis(m: f64, d: DVec3) -> DMat3 {
    let outer = DMat3::from_cols(d * d.x, d * d.y, d * d.z);
    (DMat3::IDENTITY * d.length_squared() - outer) * m
}

fn assert_mat_close(a: DMat3, b: DMat3, tol: f64) {
    let diff = (a - b).to_cols_array();
    assert!(
        diff.iter().all(|x| x.abs() < tol),
        "matrices differ:\n{a:?}\n{b:?}"
    );
}

#[test]
fn fixed_joint_merging_at_joint_offsets() {
    // Two 1 kg links, each with its COM at its frame origin; `b` is welded 0.3 m along x and
    // 0.2 m along z from `a`.
    let text = robot(
        &[
            link("base", 1.0),
            link_raw("a", "1", "0.01", "0.02", "0.03"),
            link_raw("b", "1", "0.04", "0.05", "0.06"),
            joint("j", "revolute", "base", "a"),
            joint_with("weld", "fixed", "a", "b", "<origin xyz=\"0.3 0 0.2\"/>"),
        ]
        .concat(),
    );
    let m = load(&text).unwrap();
    assert_eq!(m.bodies.len(), 1);
    let body = &m.bodies[0];
    assert_eq!(body.name, "a");
    let link_names: Vec<&str> = body.links.iter().map(|l| l.0.as_str()).collect();
    assert_eq!(link_names, ["a", "b"]);
    let (ca, cb) = (DVec3::ZERO, DVec3::new(0.3, 0.0, 0.2));
    let com = (ca + cb) / 2.0;
    assert!((body.inertia.mass - 2.0).abs() < 1e-12);
    assert!(
        (body.inertia.com() - com).length() < 1e-12,
        "{:?}",
        body.inertia.com()
    );
    let expect = DMat3::from_diagonal(DVec3::new(0.01, 0.02, 0.03))
        + DMat3::from_diagonal(DVec3::new(0.04, 0.05, 0.06))
        + parallel_axis(1.0, ca - com)
        + parallel_axis(1.0, cb - com);
    // By hand: d = ±(0.15, 0, 0.1), |d|² = 0.0325; per mass diag(0.01, 0.0325, 0.0225) and
    // xz entry −0.015.
    let by_hand = DMat3::from_cols(
        DVec3::new(0.05 + 0.02, 0.0, -0.03),
        DVec3::new(0.0, 0.07 + 0.065, 0.0),
        DVec3::new(-0.03, 0.0, 0.09 + 0.045),
    );
    assert_mat_close(expect, by_hand, 1e-12);
    assert_mat_close(body.inertia.inertia_about_com(), by_hand, 1e-12);
    check_invariants(&m);
}

#[test]
fn fixed_joint_merging_with_inertial_origins() {
    // `a` has its COM at (0, 0, 0.1); `b`, welded 0.3 m along x, at (0, 0.2, 0) in its own
    // frame, i.e. (0.3, 0.2, 0) in `a`'s.
    let la = "  <link name=\"a\"><inertial><origin xyz=\"0 0 0.1\"/><mass value=\"1\"/>\
              <inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.02\" iyz=\"0\" izz=\"0.03\"/>\
              </inertial></link>\n";
    let lb = "  <link name=\"b\"><inertial><origin xyz=\"0 0.2 0\"/><mass value=\"1\"/>\
              <inertia ixx=\"0.04\" ixy=\"0\" ixz=\"0\" iyy=\"0.05\" iyz=\"0\" izz=\"0.06\"/>\
              </inertial></link>\n";
    let text = robot(
        &[
            link("base", 1.0),
            s(la),
            s(lb),
            joint("j", "revolute", "base", "a"),
            joint_with("weld", "fixed", "a", "b", "<origin xyz=\"0.3 0 0\"/>"),
        ]
        .concat(),
    );
    let m = load(&text).unwrap();
    let body = &m.bodies[0];
    let (ca, cb) = (DVec3::new(0.0, 0.0, 0.1), DVec3::new(0.3, 0.2, 0.0));
    let com = DVec3::new(0.15, 0.1, 0.05);
    assert!((body.inertia.mass - 2.0).abs() < 1e-12);
    assert!(
        (body.inertia.com() - com).length() < 1e-12,
        "COM {:?}, expected {com:?}",
        body.inertia.com()
    );
    // d = ±(0.15, 0.1, −0.05), |d|² = 0.035; for both masses together:
    // 2 (|d|² 1 − d dᵀ) = [[0.025, −0.03, 0.015], [−0.03, 0.05, 0.01], [0.015, 0.01, 0.065]].
    let by_hand = DMat3::from_cols(
        DVec3::new(0.05 + 0.025, -0.03, 0.015),
        DVec3::new(-0.03, 0.07 + 0.05, 0.01),
        DVec3::new(0.015, 0.01, 0.09 + 0.065),
    );
    let expect = DMat3::from_diagonal(DVec3::new(0.05, 0.07, 0.09))
        + parallel_axis(1.0, ca - com)
        + parallel_axis(1.0, cb - com);
    assert_mat_close(expect, by_hand, 1e-12);
    assert_mat_close(body.inertia.inertia_about_com(), by_hand, 1e-12);
}

#[test]
fn fixed_joint_merging_with_a_rotated_weld() {
    // `b` is welded at (0.3, 0, 0) turned 90° about z; its COM (0, 0.2, 0) in its own frame is
    // (0.1, 0, 0) in `a`'s, and its principal moments (0.04, 0.05, 0.06) about its own x, y, z
    // become (0.05, 0.04, 0.06) about `a`'s.
    let lb = "  <link name=\"b\"><inertial><origin xyz=\"0 0.2 0\"/><mass value=\"1\"/>\
              <inertia ixx=\"0.04\" ixy=\"0\" ixz=\"0\" iyy=\"0.05\" iyz=\"0\" izz=\"0.06\"/>\
              </inertial></link>\n";
    let text = robot(
        &[
            link("base", 1.0),
            link_raw("a", "1", "0.01", "0.02", "0.03"),
            s(lb),
            joint("j", "revolute", "base", "a"),
            joint_with(
                "weld",
                "fixed",
                "a",
                "b",
                "<origin xyz=\"0.3 0 0\" rpy=\"0 0 1.5707963267948966\"/>",
            ),
        ]
        .concat(),
    );
    let m = load(&text).unwrap();
    let body = &m.bodies[0];
    let com = DVec3::new(0.05, 0.0, 0.0);
    assert!(
        (body.inertia.com() - com).length() < 1e-12,
        "{:?}",
        body.inertia.com()
    );
    // Each mass 0.05 m from the COM along x: 2 · 1 · 0.05² = 0.005 added to yy and zz.
    let by_hand = DMat3::from_diagonal(DVec3::new(0.06, 0.06 + 0.005, 0.09 + 0.005));
    assert_mat_close(body.inertia.inertia_about_com(), by_hand, 1e-12);
    // The weld is recorded as b's frame → a's frame.
    let (_, xb) = &body.links[1];
    assert!((xb.apply_point(DVec3::ZERO) - DVec3::new(0.3, 0.0, 0.0)).length() < 1e-12);
}

#[test]
fn floating_base_adds_a_six_dof_joint() {
    let text = robot(&link("torso", 3.0));
    let m = load_floating(&text).unwrap();
    assert!(m.floating_base);
    assert_eq!((m.nq, m.nv), (7, 6));
    assert_eq!(m.bodies.len(), 1);
    let b = &m.bodies[0];
    assert_eq!(b.name, "torso");
    assert_eq!(b.joint.len(), 1);
    assert_eq!(b.joint[0].name, FLOATING_BASE_JOINT);
    assert_eq!(b.joint[0].kind, JointKind::Floating);
    assert_eq!(m.neutral_q(), [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
    assert!(m.ground_links.is_empty());
    check_invariants(&m);

    // The same robot with a fixed base has nothing moving.
    let m = load(&text).unwrap();
    assert_eq!((m.nq, m.nv, m.bodies.len()), (0, 0, 0));
    assert!((m.ground_mass - 3.0).abs() < 1e-12);
}

#[test]
fn floating_base_on_a_pendulum() {
    let m = load_floating(&pendulum()).unwrap();
    assert_eq!((m.nq, m.nv), (8, 7));
    assert_eq!(m.bodies[0].joint[0].name, FLOATING_BASE_JOINT);
    assert_eq!(m.bodies[1].joint[0].name, "swing");
    assert_eq!(m.bodies[1].parent, Some(0));
    assert_eq!((m.bodies[1].q_offset, m.bodies[1].v_offset), (7, 6));
    check_invariants(&m);
}

#[test]
fn floating_base_name_clash_is_renamed() {
    let text = robot(
        &[
            link("base", 1.0),
            link("bob", 1.0),
            joint(FLOATING_BASE_JOINT, "revolute", "base", "bob"),
        ]
        .concat(),
    );
    let m = load_floating(&text).unwrap();
    assert_ne!(m.bodies[0].joint[0].name, m.bodies[1].joint[0].name);
    assert_eq!(m.bodies[1].joint[0].name, FLOATING_BASE_JOINT);
}

#[test]
fn floating_joint_inside_the_urdf() {
    let m = load(&joint_text("floating", "")).unwrap();
    assert_eq!((m.nq, m.nv), (7, 6));
    assert_eq!(m.bodies[0].joint[0].kind, JointKind::Floating);
    check_invariants(&m);
}

// ---------------------------------------------------------------------------------------------
// Bundled models and the assembly tree.

fn is_chain(m: &Model) -> bool {
    m.bodies.iter().all(|b| b.children.len() <= 1)
        && m.bodies.iter().filter(|b| b.parent.is_none()).count() <= 1
}

#[test]
fn every_bundled_model_loads_with_a_valid_assembly_tree() {
    let paths = bundled_models();
    assert!(paths.len() >= 8, "found {paths:?}");
    for path in &paths {
        for floating_base in [false, true] {
            let m = Model::from_urdf_file(
                path,
                &LoadOptions::default().with_floating_base(floating_base),
            )
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(!m.bodies.is_empty(), "{}", path.display());
            assert_eq!(m.floating_base, floating_base);
            assert!(
                m.bodies
                    .iter()
                    .all(|b| b.inertia.is_finite() && b.inertia.mass > 0.0),
                "{}",
                path.display()
            );
            check_invariants(&m);
            if is_chain(&m) {
                let n = m.bodies.len();
                let bound = ceil_log2(n + 1) + 1;
                assert!(
                    m.assembly.depth() <= bound,
                    "{} (floating {floating_base}): chain of {n} bodies has depth {} > {bound}",
                    path.display(),
                    m.assembly.depth()
                );
                assert!(m.assembly.max_handles() <= 2, "{}", path.display());
            }
        }
    }
}

#[test]
fn chain300_tree_is_shallow_with_two_handles() {
    let m =
        Model::from_urdf_file(models_dir().join("chain300.urdf"), &LoadOptions::default()).unwrap();
    assert_eq!(m.bodies.len(), 300);
    assert!(is_chain(&m));
    assert!(m.assembly.depth() <= 10, "depth {}", m.assembly.depth());
    assert!(
        m.assembly.max_handles() <= 2,
        "handles {}",
        m.assembly.max_handles()
    );
}

#[test]
fn bundled_chains_have_the_expected_size() {
    for n in [10usize, 30, 100, 300, 1000] {
        let m = load(&read_model(&format!("chain{n}"))).unwrap();
        assert_eq!((m.bodies.len(), m.nv, m.urdf_links), (n, n, n + 1));
        let bound = ceil_log2(n + 1) + 1;
        assert!(
            m.assembly.depth() <= bound,
            "chain{n}: depth {}",
            m.assembly.depth()
        );
    }
}

#[test]
fn humanoid_has_composed_joints() {
    let m = load(&read_model("humanoid")).unwrap();
    assert!(m.bodies.iter().any(|b| b.joint.len() > 1));
    for b in &m.bodies {
        assert!(b.massless_links.len() >= b.joint.len() - 1);
    }
}

#[test]
fn hand_made_trees_have_valid_assembly_trees() {
    // A star, a comb and a binary tree, each with fixed and floating base.
    let mut star = vec![link("hub", 1.0)];
    for i in 0..7 {
        star.push(link(&format!("s{i}"), 1.0));
        star.push(joint(
            &format!("js{i}"),
            "revolute",
            "hub",
            &format!("s{i}"),
        ));
    }
    let mut comb = vec![link("c0", 1.0)];
    for i in 1..12 {
        comb.push(link(&format!("c{i}"), 1.0));
        comb.push(joint(
            &format!("jc{i}"),
            "revolute",
            &format!("c{}", i - 1),
            &format!("c{i}"),
        ));
        comb.push(link(&format!("t{i}"), 1.0));
        comb.push(joint(
            &format!("jt{i}"),
            "prismatic",
            &format!("c{i}"),
            &format!("t{i}"),
        ));
    }
    let mut bin = vec![link("n1", 1.0)];
    for i in 2..32 {
        bin.push(link(&format!("n{i}"), 1.0));
        bin.push(joint(
            &format!("jn{i}"),
            "revolute",
            &format!("n{}", i / 2),
            &format!("n{i}"),
        ));
    }
    for parts in [star, comb, bin] {
        let text = robot(&parts.concat());
        check_invariants(&load(&text).unwrap());
        check_invariants(&load_floating(&text).unwrap());
    }
}

/// A hub `hub` with `k` children `{hub}_c{i}` on revolute joints (the link elements too).
fn star_parts(hub: &str, k: usize) -> String {
    (0..k)
        .map(|i| {
            let child = format!("{hub}_c{i}");
            link(&child, 0.1) + &joint(&format!("j_{child}"), "revolute", hub, &child)
        })
        .collect()
}

/// Hubs with more than `GATHER_ABOVE` children become gather nodes (nested ones too, and the
/// ground of a fixed base), every node then has at most two handles, and the tree keeps its
/// invariants; a hub with exactly `GATHER_ABOVE` children stays a balanced-cut tree.
#[test]
fn many_children_are_gathered() {
    let k = articula_model::GATHER_ABOVE;
    let star = |children: usize| robot(&(link("hub", 1.0) + &star_parts("hub", children)));
    for floating_base in [false, true] {
        let ld = |t: &str| {
            if floating_base {
                load_floating(t)
            } else {
                load(t)
            }
            .unwrap()
        };
        let m = ld(&star(k));
        check_invariants(&m);
        assert!(!m.assembly.has_gather());
        let m = ld(&star(40 * k));
        check_invariants(&m);
        assert!(m.assembly.has_gather());
        assert!(
            m.assembly.max_handles() <= 2,
            "{}",
            m.assembly.max_handles()
        );
        // A hub of hubs: every child of the hub has k + 1 children.
        let mut text = link("hub", 1.0) + &star_parts("hub", k + 1);
        for i in 0..=k {
            text += &star_parts(&format!("hub_c{i}"), k + 1);
        }
        let m = ld(&robot(&text));
        check_invariants(&m);
        let gathers = m
            .assembly
            .nodes
            .iter()
            .filter(|n| matches!(n.kind, articula_model::NodeKind::Gather { .. }))
            .count();
        assert_eq!(gathers, k + 2, "the hub and each of its children");
        assert!(
            m.assembly.max_handles() <= 2,
            "{}",
            m.assembly.max_handles()
        );
        assert!(m.assembly.depth() <= 4, "depth {}", m.assembly.depth());
    }
}

#[test]
fn repair_bounds_are_checked() {
    let text = one_link_on_a_joint(&link_raw("arm", "1", "0", "0", "0"));
    // A bound without the repair policy would do nothing: refused, naming the option.
    for policy in [InertiaPolicy::Accept, InertiaPolicy::Strict] {
        let options = LoadOptions::default()
            .with_inertia(policy)
            .with_bound_inertia(1e-4);
        let e = Model::from_urdf_str(&text, &options).unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::BadOption {
                    option: "bound_inertia",
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains(policy.name()), "{e}");
    }
    let repair = LoadOptions::default().with_inertia(InertiaPolicy::Repair);
    for bad in [-1e-4, f64::NAN, f64::INFINITY] {
        let e = Model::from_urdf_str(&text, &repair.with_bound_mass(bad)).unwrap_err();
        assert!(
            matches!(
                e,
                ModelError::BadOption {
                    option: "bound_mass",
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("finite number ≥ 0"), "{e}");
    }
    // Under repair: the point mass's moments are raised to the bound, and it is the one change
    // (the base is welded to the world: not a body of the dynamics).
    let m = Model::from_urdf_str(&text, &repair.with_bound_inertia(1e-4)).unwrap();
    let arm = m.bodies.iter().find(|b| b.name == "arm").unwrap();
    let ic = arm.inertia.inertia_about_com();
    assert!((ic - DMat3::from_diagonal(DVec3::splat(1e-4))).abs_diff_eq(DMat3::ZERO, 1e-19));
    assert_eq!(m.warnings.len(), 1, "{:?}", m.warnings);
    assert!(m.warnings[0].to_string().contains("bound_inertia"));
}

/// URDF joint friction is not modelled: one warning lists every joint that has it, in file
/// order, instead of one warning per joint.
#[test]
fn joint_friction_is_one_warning_listing_every_joint() {
    let joint = |name: &str, parent: &str, child: &str| {
        format!(
            r#"<link name="{child}"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/><dynamics damping="0.1" friction="0.5"/></joint>"#
        )
    };
    let text = format!(
        r#"<robot name="r"><link name="base"/>{}{}{}</robot>"#,
        joint("j1", "base", "a"),
        joint("j2", "a", "b"),
        joint("j3", "b", "c")
    );
    let m = load(&text).unwrap();
    let lines: Vec<String> = m
        .warnings
        .iter()
        .map(|w| w.to_string())
        .filter(|w| w.contains("friction"))
        .collect();
    assert_eq!(
        lines,
        ["joint friction (URDF <dynamics friction>) not modelled, ignored (3): j1, j2, j3"]
    );
}
