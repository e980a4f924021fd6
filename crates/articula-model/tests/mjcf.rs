//! The MJCF reader: frames, default classes, joints, inertia from geoms, warnings and refusals,
//! each against a value computed by hand or the same model written another way. (Agreement
//! with MuJoCo on whole models: `cargo xtask mjcf-corpus`, docs/mjcf.md.)

use articula_model::{JointKind, LoadOptions, LoadWarning, Model, ModelError};
use glam::DVec3;

fn load(text: &str) -> Result<Model, ModelError> {
    Model::from_mjcf_str(text, &LoadOptions::default())
}

fn wrap(body: &str) -> String {
    format!("<mujoco><worldbody>{body}</worldbody></mujoco>")
}

/// The five ways to write an orientation give the same frame: a quarter turn about z, with
/// the default degrees.
#[test]
fn orientations_agree() {
    let ways = [
        r#"quat="0.7071067811865476 0 0 0.7071067811865476""#,
        r#"axisangle="0 0 1 90""#,
        r#"euler="0 0 90""#,
        r#"xyaxes="0 1 0 -1 0 0""#,
    ];
    let mut poses = Vec::new();
    for w in ways {
        let m = load(&wrap(&format!(
            r#"<body name="b" pos="1 2 3" {w}><joint name="j" axis="1 0 0"/>
               <inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body>"#
        )))
        .unwrap();
        poses.push(m.bodies[0].joint[0].origin.to_pose());
    }
    for (r, p) in &poses {
        assert!((*p - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
        assert!((r.x_axis - DVec3::Y).length() < 1e-12, "{r:?}");
    }
    // zaxis: z onto x by the shortest arc (a quarter turn about y).
    let m = load(&wrap(
        r#"<body name="b" zaxis="1 0 0"><joint name="j"/>
           <inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body>"#,
    ))
    .unwrap();
    let (r, _) = m.bodies[0].joint[0].origin.to_pose();
    assert!((r.z_axis - DVec3::X).length() < 1e-12);
}

/// Nested default classes and childclass: the joint takes its class's damping and its parent
/// class's armature; a range makes it limited (autolimits), in radians.
#[test]
fn default_classes_and_limits() {
    let m = load(
        r#"<mujoco><default><joint armature="0.2"/>
             <default class="leg"><joint damping="3" range="-90 45"/></default></default>
           <worldbody><body name="b" childclass="leg"><joint name="knee" axis="0 1 0"/>
             <geom type="sphere" size="0.1"/></body></worldbody></mujoco>"#,
    )
    .unwrap();
    let p = &m.bodies[0].joint[0];
    assert_eq!(p.kind, JointKind::Revolute);
    let [lo, hi] = p.limits.unwrap();
    assert!(
        (lo + std::f64::consts::FRAC_PI_2).abs() < 1e-15
            && (hi - std::f64::consts::FRAC_PI_4).abs() < 1e-15
    );
    assert_eq!(m.dynamics.armature, vec![0.2]);
    assert_eq!(m.dynamics.damping, vec![3.0]);
    // A sphere of radius 0.1 at density 1000.
    let mass = 1000.0 * 4.0 / 3.0 * std::f64::consts::PI * 1e-3;
    assert!((m.bodies[0].inertia.mass - mass).abs() < 1e-12);
}

/// A capsule by `fromto` has MuJoCo's mass, and its inertia about its axis is that of the
/// cylinder plus two hemispheres.
#[test]
fn capsule_from_fromto() {
    let m = load(&wrap(
        r#"<body name="b"><joint name="j" axis="0 0 1"/>
           <geom type="capsule" fromto="0 0 0 0 0 0.4" size="0.05" density="500"/></body>"#,
    ))
    .unwrap();
    let (r, h) = (0.05f64, 0.4f64);
    let pi = std::f64::consts::PI;
    let mass = 500.0 * pi * r * r * (h + 4.0 / 3.0 * r);
    let body = &m.bodies[0].inertia;
    assert!((body.mass - mass).abs() < 1e-12 * mass);
    assert!((body.com() - DVec3::new(0.0, 0.0, 0.2)).length() < 1e-12);
    let ms = 500.0 * 4.0 / 3.0 * pi * r.powi(3);
    let mc = 500.0 * pi * r * r * h;
    let izz = mc * r * r / 2.0 + ms * 0.4 * r * r;
    assert!((body.inertia_about_com().z_axis.z - izz).abs() < 1e-12 * izz);
}

/// Two joints in one body become one composed joint; a free body alone under the world is the
/// floating base and keeps its joint's name.
#[test]
fn composed_joints_and_free_base() {
    let m = load(&wrap(
        r#"<body name="torso"><freejoint name="root"/><geom type="sphere" size="0.1"/>
             <body name="arm" pos="0.2 0 0"><joint name="a1" axis="1 0 0" pos="0 0 0.1"/>
               <joint name="a2" type="slide" axis="0 1 0"/>
               <geom type="box" size="0.1 0.05 0.05"/></body></body>"#,
    ))
    .unwrap();
    assert!(m.floating_base);
    assert_eq!(m.nq, 7 + 2);
    assert_eq!(m.bodies[0].joint[0].name, "root");
    assert_eq!(m.bodies[1].name, "arm");
    assert_eq!(m.bodies[1].joint_name(), "a1+a2");
    assert!(m.find_link("arm").is_some());
}

/// Refusals name the file, element and attribute; what is not modelled is one warning per kind.
#[test]
fn refusals_and_warnings() {
    let e = load(&wrap(
        r#"<body name="b"><joint name="neck" type="ball" stiffness="2"/><geom size="0.1"/></body>"#,
    ))
    .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("\"neck\"") && msg.contains("stiffness") && msg.contains("ball"),
        "{msg}"
    );
    let e = load(&wrap(
        r#"<body name="b"><joint name="j"/><geom type="mesh" mesh="m"/></body>"#,
    ))
    .unwrap_err();
    assert!(e.to_string().contains("mesh geom"), "{e}");
    let e = load(r#"<mujoco><include file="x.xml"/></mujoco>"#).unwrap_err();
    assert!(e.to_string().contains("include"), "{e}");
    let m = load(
        r#"<mujoco><worldbody><body name="b"><joint name="j" frictionloss="1"/>
             <geom size="0.1"/><site name="s1"/><site name="s2"/></body></worldbody>
           <actuator><motor name="m" joint="j"/></actuator></mujoco>"#,
    )
    .unwrap();
    let not: Vec<_> = m
        .warnings
        .iter()
        .filter_map(|w| match w {
            LoadWarning::NotModelled { what, items } => Some((what.clone(), items.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(not.len(), 3, "{not:?}");
    assert!(not
        .iter()
        .any(|(w, i)| w.contains("site") && i == &["s1", "s2"]));
    assert!(not
        .iter()
        .any(|(w, i)| w.contains("actuator") && i == &["m"]));
}

/// `from_file` picks the format by content.
#[test]
fn from_file_chooses_by_content() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("articula-mjcf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mj = dir.join("m.model");
    std::fs::write(
        &mj,
        r#"<?xml version="1.0"?><!-- a model --><mujoco model="x"><worldbody>
           <body name="b"><joint name="j"/><geom size="0.1"/></body></worldbody></mujoco>"#,
    )
    .unwrap();
    let m = Model::from_file(&mj, &LoadOptions::default()).unwrap();
    assert_eq!(m.name, "x");
    let urdf = dir.join("r.model");
    std::fs::write(
        &urdf,
        r#"<robot name="r"><link name="a"/><link name="b"><inertial><mass value="1"/>
           <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
           <joint name="j" type="continuous"><parent link="a"/><child link="b"/>
           <dynamics damping="0.7"/></joint></robot>"#,
    )
    .unwrap();
    let m = Model::from_file(&urdf, &LoadOptions::default()).unwrap();
    assert_eq!(m.name, "r");
    assert_eq!(m.dynamics.damping, vec![0.7]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A ball joint: a quaternion in `q`, three degrees of freedom, turning about its anchor; a
/// cone limit is reported as not modelled.
#[test]
fn ball_joint_loads() {
    let m = load(&wrap(
        r#"<body name="b" pos="0 0 1"><joint name="neck" type="ball" pos="0 0 0.1" range="0 45"
             damping="0.5" armature="0.01"/><geom size="0.1"/></body>"#,
    ))
    .unwrap();
    assert_eq!((m.nq, m.nv), (4, 3));
    let p = &m.bodies[0].joint[0];
    assert_eq!((p.name.as_str(), p.kind), ("neck", JointKind::Ball));
    assert_eq!(m.neutral_q(), vec![1.0, 0.0, 0.0, 0.0]);
    assert_eq!(m.dynamics.damping, vec![0.5; 3]);
    assert_eq!(m.dynamics.armature, vec![0.01; 3]);
    assert!(
        format!("{:?}", m.warnings).contains("ball joint cone limit"),
        "{:?}",
        m.warnings
    );
}

/// `<option gravity>` becomes the model's gravity (MuJoCo's default without one, zero when a
/// `<flag gravity="disable">` switches it off); a URDF's is the default.
#[test]
fn option_gravity_is_the_models() {
    let body = r#"<body><joint type="hinge"/><geom type="sphere" size="0.1" mass="1"/></body>"#;
    let with = |option: &str| {
        let text = format!("<mujoco>{option}<worldbody>{body}</worldbody></mujoco>");
        load(&text).expect("loads").gravity
    };
    assert_eq!(with(""), DVec3::new(0.0, 0.0, -9.81));
    assert_eq!(
        with(r#"<option gravity="0.5 -1 -3.7"/>"#),
        DVec3::new(0.5, -1.0, -3.7)
    );
    assert_eq!(
        with(r#"<option gravity="0 0 -1.62"><flag gravity="disable"/></option>"#),
        DVec3::ZERO
    );
    let text =
        format!(r#"<mujoco><option gravity="0 0 x"/><worldbody>{body}</worldbody></mujoco>"#);
    let err = load(&text).expect_err("a word is not a number").to_string();
    assert!(err.contains("gravity"), "{err}");
    let urdf = Model::from_urdf_file(
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/chain10.urdf"),
        &LoadOptions::default(),
    )
    .expect("loads");
    assert_eq!(urdf.gravity, DVec3::new(0.0, 0.0, -9.81));
}
