//! Scene files: placements, crowds, pushes, and clear errors naming the field.

use articula_dca::{forward_kinematics, Data};
use articula_view::{CameraRig, SceneOptions, ViewError};
use glam::DVec3;
use std::path::{Path, PathBuf};

fn models() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

fn parse(text: &str) -> Result<articula_view::LoadedScene, ViewError> {
    SceneOptions::default().parse(text, Path::new("test.json"), &models())
}

fn err(text: &str) -> String {
    match parse(text) {
        Ok(_) => panic!("expected an error for {text}"),
        Err(e) => e.to_string(),
    }
}

const CAM: &str = r#""camera": {"eye": [0, 0, 1.5], "target": [10, 0, 1]}"#;

fn with(extra: &str) -> String {
    format!(r#"{{"models": {{"h": "humanoid.urdf"}}, {CAM}, {extra}}}"#)
}

#[test]
fn bodies_and_crowds_are_placed() {
    let s = parse(&with(
        r#""bodies": [{"name": "hero", "model": "h", "position": [3, 1, 1.2], "rpy": [0, 0, 1.5707963267948966],
             "velocity": {"linear": [1, 2, 3], "angular": [0, 0, 0.5]}}],
           "crowds": [{"model": "h", "rows": 3, "columns": 4, "origin": [10, -3, 1.2], "spacing": [2, 1.5],
             "jitter": 0.25, "seed": 9, "yaw_jitter": 0.3}],
           "budget": 40, "dt": 0.01"#,
    ))
    .unwrap();
    assert_eq!(s.placements.len(), 13);
    assert_eq!(s.placements[0].name, "hero");
    assert_eq!(s.placements[1].name, "crowd0[0,0]");
    assert_eq!(s.placements[12].name, "crowd0[2,3]");
    assert_eq!(s.budget, Some(40));
    assert!(matches!(s.camera, CameraRig::Fixed(_)));
    let model = &s.models[0].model;
    let mut data = Data::new(model);
    // The hero: pose and world velocity as written.
    let hero = &s.placements[0];
    forward_kinematics(model, &hero.q, &hero.qd, &mut data).unwrap();
    let (rot, pos) = data.body_pose(0);
    assert!((pos - DVec3::new(3.0, 1.0, 1.2)).length() < 1e-12);
    assert!((rot * DVec3::X - DVec3::Y).length() < 1e-12);
    // data.v is about the computation origin, which is the root's position: its linear part is
    // the root origin's velocity in world axes.
    let v = data.v[0];
    assert!(
        (v.v - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12,
        "{}",
        v.v
    );
    assert!((v.w - DVec3::new(0.0, 0.0, 0.5)).length() < 1e-12);
    // Crowd grid within the jitter, distinct jitters, same result for the same seed.
    for r in 0..3 {
        for c in 0..4 {
            let q = &s.placements[1 + r * 4 + c].q;
            let grid = DVec3::new(10.0 + 2.0 * r as f64, -3.0 + 1.5 * c as f64, 1.2);
            let d = DVec3::new(q[0], q[1], q[2]) - grid;
            assert!(d.x.abs() <= 0.25 && d.y.abs() <= 0.25 && d.z == 0.0, "{d}");
            // Yaw within ±0.3: the quaternion is about z.
            let yaw = 2.0 * q[6].atan2(q[3]);
            assert!(yaw.abs() <= 0.3 + 1e-12 && q[4] == 0.0 && q[5] == 0.0);
        }
    }
    let again = parse(&with(
        r#""crowds": [{"model": "h", "rows": 3, "columns": 4, "origin": [10, -3, 1.2], "spacing": [2, 1.5],
             "jitter": 0.25, "seed": 9, "yaw_jitter": 0.3}]"#,
    ))
    .unwrap();
    assert_eq!(again.placements[0].q, s.placements[1].q);
    let other_seed = parse(&with(
        r#""crowds": [{"model": "h", "rows": 3, "columns": 4, "origin": [10, -3, 1.2], "spacing": [2, 1.5],
             "jitter": 0.25, "seed": 10, "yaw_jitter": 0.3}]"#,
    ))
    .unwrap();
    assert_ne!(other_seed.placements[0].q, s.placements[1].q);
}

#[test]
fn pushes_resolve_to_bodies_and_points() {
    let s = parse(&with(
        r#""bodies": [{"name": "a", "model": "h", "position": [3, 0, 1]}, {"name": "b", "model": "h", "position": [5, 0, 1]}],
           "crowds": [{"name": "c", "model": "h", "rows": 1, "columns": 2, "origin": [8, 0, 1], "spacing": [1, 1]}],
           "pushes": [{"bodies": "all", "link": "chest", "point": [0, 0, 0.1], "force": [100, 0, 0], "t0": 0, "t1": 0.5},
                      {"bodies": ["b", "c"], "link": "head_camera", "force": [0, 1, 0], "t0": 1, "t1": 1}]"#,
    ))
    .unwrap();
    assert_eq!(s.pushes.len(), 4 + 3);
    assert_eq!(
        s.pushes[4..].iter().map(|p| p.body).collect::<Vec<_>>(),
        vec![1, 2, 3]
    );
    let model = &s.models[0].model;
    let chest = model.bodies.iter().position(|b| b.name == "chest").unwrap();
    assert_eq!(s.pushes[0].link_body, chest);
    assert!((s.pushes[0].point - DVec3::new(0.0, 0.0, 0.1)).length() < 1e-15);
    // head_camera is welded to the head: the point is the camera link's origin in head frame.
    let head = model.bodies.iter().position(|b| b.name == "head").unwrap();
    assert_eq!(s.pushes[4].link_body, head);
    let (_, x) = model.bodies[head]
        .links
        .iter()
        .find(|l| l.0 == "head_camera")
        .unwrap();
    assert!((s.pushes[4].point - x.to_pose().1).length() < 1e-15);
    assert!(s.pushes[4].point.length() > 0.01);
}

#[test]
fn moving_camera_from_keyframes() {
    let s = parse(
        r#"{"models": {"h": "humanoid.urdf"}, "bodies": [{"model": "h", "position": [3, 0, 1]}],
            "camera": {"path": [{"t": 0, "eye": [0, 0, 1], "target": [1, 0, 1]},
                                {"t": 1, "eye": [0, 2, 1], "target": [1, 2, 1]}], "fov_y_deg": 50},
            "image": {"width": 400, "height": 200}}"#,
    )
    .unwrap();
    let c = s.camera.at(0.5);
    assert!((c.position - DVec3::new(0.0, 1.0, 1.0)).length() < 1e-15);
    assert_eq!(c.aspect, 2.0);
}

#[test]
fn errors_name_the_file_and_the_field() {
    let cases: Vec<(String, &[&str])> = vec![
        ("hello".into(), &["test.json", "top level", "expected value", "line 1"]),
        ("{".into(), &["EOF"]),
        ("42".into(), &["invalid type"]),
        (format!(r#"{{"models": {{}}, {CAM}}}"#), &["models", "names no model"]),
        (r#"{"models": {"h": "humanoid.urdf"}}"#.into(), &["missing field `camera`"]),
        (with(r#""bodys": []"#), &["unknown field `bodys`"]),
        (with(r#""bodies": [{"model": "h", "position": [1, 2]}]"#), &["bodies[0].position"]),
        (with(r#""bodies": [{"model": "h", "position": "here"}]"#), &["bodies[0].position", "invalid type"]),
        (with(r#""bodies": [{"model": "robot", "position": [1, 2, 3]}]"#), &["bodies[0].model", "no model named 'robot'"]),
        (with(r#""crowds": [{"model": "h", "rows": -3, "columns": 2, "origin": [0,0,0], "spacing": [1,1]}]"#), &["crowds[0].rows"]),
        (with(r#""crowds": [{"model": "h", "rows": 0, "columns": 2, "origin": [0,0,0], "spacing": [1,1]}]"#), &["crowds[0].rows", "at least 1"]),
        (with(r#""crowds": [{"model": "h", "rows": 1, "columns": 2, "origin": [0,0,0], "spacing": [1,1], "jitter": -1}]"#), &["crowds[0].jitter"]),
        (with(r#""bodies": [{"model": "h", "position": [1, 2, 3]}], "budget": -5"#), &["budget", "invalid value"]),
        (with(r#""bodies": [{"model": "h", "position": [1, 2, 3]}], "tolerance": -1"#), &["tolerance", "non-negative"]),
        (with(r#""bodies": [{"model": "h", "position": [1, 2, 3]}], "dt": 0"#), &["dt", "positive"]),
        (with(r#""bodies": [{"model": "h", "position": [1, 2, 3]}], "reselect_every": 0"#), &["reselect_every"]),
        (with(r#""bodies": []"#), &["no body"]),
        (with(r#""bodies": [{"model": "h", "position": [1, 2, 3]}], "pushes": [{"bodies": "all", "link": "tail", "force": [1,0,0], "t0": 0, "t1": 1}]"#), &["pushes[0].link", "no link 'tail'"]),
        (with(r#""bodies": [{"model": "h", "position": [1, 2, 3]}], "pushes": [{"bodies": "everyone", "link": "chest", "force": [1,0,0], "t0": 0, "t1": 1}]"#), &["pushes[0].bodies", "\"all\""]),
        (with(r#""bodies": [{"model": "h", "position": [1, 2, 3]}], "pushes": [{"bodies": ["nobody"], "link": "chest", "force": [1,0,0], "t0": 0, "t1": 1}]"#), &["pushes[0].bodies[0]", "'nobody'"]),
        (with(r#""bodies": [{"model": "h", "position": [1, 2, 3]}], "pushes": [{"bodies": "all", "link": "chest", "force": [1,0,0], "t0": 2, "t1": 1}]"#), &["pushes[0].t0"]),
        (with(r#""bodies": [{"model": "h", "position": [1, 2, 3]}], "pushes": [{"bodies": "all", "link": "lumbar_link1", "force": [1,0,0], "t0": 0, "t1": 1}]"#), &["pushes[0].link", "massless"]),
        (with(r#""bodies": [{"name": "x", "model": "h", "position": [1, 2, 3]}, {"name": "x", "model": "h", "position": [1, 2, 3]}]"#), &["bodies[1].name", "duplicate"]),
        (with(r#""bodies": [{"model": "h", "position": [1, 2, 3]}], "visibility": {"occluded_factor": 2}"#), &["visibility.occluded_factor"]),
        (with(r#""bodies": [{"model": "h", "position": [1, 2, 3]}], "image": {"width": 0}"#), &["image"]),
        (
            r#"{"models": {"h": "humanoid.urdf"}, "bodies": [{"model": "h", "position": [1, 2, 3]}], "camera": {"eye": [0,0,0]}}"#.into(),
            &["camera", "either both"],
        ),
        (
            r#"{"models": {"h": "humanoid.urdf"}, "bodies": [{"model": "h", "position": [1, 2, 3]}], "camera": {"eye": [0,0,0], "target": [0,0,5]}}"#.into(),
            &["camera", "parallel"],
        ),
        (
            r#"{"models": {"h": "humanoid.urdf"}, "bodies": [{"model": "h", "position": [1, 2, 3]}], "camera": {"eye": [0,0,0], "target": [1,0,0], "fov_y_deg": 200}}"#.into(),
            &["camera", "field of view"],
        ),
        (
            r#"{"models": {"h": "humanoid.urdf"}, "bodies": [{"model": "h", "position": [1, 2, 3]}], "camera": {"path": [{"t": 1, "eye": [0,0,0], "target": [1,0,0]}, {"t": 0, "eye": [0,0,0], "target": [1,0,0]}]}}"#.into(),
            &["camera.path", "keyframe 1"],
        ),
        (
            format!(r#"{{"models": {{"h": "missing.urdf"}}, {CAM}, "bodies": [{{"model": "h", "position": [1, 2, 3]}}]}}"#),
            &["models.h", "missing.urdf", "cannot read"],
        ),
        (
            format!(r#"{{"models": {{"bad": "../Cargo.toml"}}, {CAM}, "bodies": [{{"model": "bad", "position": [1, 2, 3]}}]}}"#),
            &["models.bad", "Cargo.toml", "malformed XML"],
        ),
    ];
    for (text, needles) in cases {
        let e = err(&text);
        for n in needles {
            assert!(e.contains(n), "error for {text}\n  is: {e}\n  lacks: {n}");
        }
        assert!(
            e.starts_with("scene file test.json") || e.contains("test.json"),
            "{e}"
        );
    }
}

#[test]
fn missing_scene_file_is_an_io_error() {
    let e = articula_view::load_scene("/nonexistent/scene.json").unwrap_err();
    assert!(matches!(e, ViewError::Io { .. }));
    assert!(e.to_string().contains("/nonexistent/scene.json"));
}

/// Blocks given as JSON arrays are refused naming the field (serde would read them by
/// position: `"ground": [5.0, 0.3]` as a floor at 5 m with μ 0.3).
#[test]
fn blocks_must_be_objects() {
    let body = r#""bodies": [{"model": "h", "position": [0, 0, 1.2]}]"#;
    for (extra, field) in [
        (format!(r#"{body}, "ground": []"#), "ground"),
        (format!(r#"{body}, "ground": [5.0, 0.3]"#), "ground"),
        (format!(r#"{body}, "visibility": [0.5]"#), "visibility"),
        (format!(r#"{body}, "joint_springs": [1, 2]"#), "joint_springs"),
        (r#""bodies": [["h", [0, 0, 1.2]]]"#.to_string(), "bodies[0]"),
        (
            r#""crowds": [{"model": "h", "rows": 1, "columns": 1, "origin": [0, 0, 1], "spacing": [1, 1], "velocity": [[1,0,0],[0,0,0]]}]"#.to_string(),
            "crowds[0].velocity",
        ),
    ] {
        let e = err(&with(&extra));
        assert!(
            e.contains(&format!("{field}:")) && e.contains("must be a JSON object") && e.contains("array"),
            "{extra}: {e}"
        );
    }
    // The camera as an array of points.
    let text = format!(
        r#"{{"models": {{"h": "humanoid.urdf"}}, "camera": [[0, 0, 1.5], [10, 0, 1]], {body}}}"#
    );
    let e = err(&text);
    assert!(
        e.contains("camera:") && e.contains("must be a JSON object"),
        "{e}"
    );
    // The top level too.
    assert!(err("[1, 2]").contains("must be a JSON object"));
    // Objects and absent or null optional blocks still load.
    parse(&with(&format!(
        r#"{body}, "ground": {{"height": 0}}, "joint_springs": null"#
    )))
    .unwrap();
}

/// Finite but absurd values are refused at load, naming the field, instead of failing at the
/// first step ("non-finite tau at lumbar_z").
#[test]
fn absurd_values_are_refused_at_load() {
    let crowd = |origin: &str, spacing: &str| {
        format!(
            r#""crowds": [{{"model": "h", "rows": 2, "columns": 2, "origin": {origin}, "spacing": {spacing}}}]"#
        )
    };
    for (extra, field) in [
        (r#""bodies": [{"model": "h", "position": [1e308, 0, 1.2]}]"#.to_string(), "bodies[0].position"),
        (crowd("[1e308, 0, 1]", "[1, 1]"), "crowds[0].origin"),
        (crowd("[0, 0, 1]", "[1e300, 1]"), "crowds[0].spacing"),
        (crowd("[9e5, 0, 1]", "[1e5, 1]"), "crowds[0].spacing"),
        (
            r#""bodies": [{"model": "h", "position": [0, 0, 1.2]}], "joint_springs": {"frequency_hz": 1e308, "damping_ratio": 1}"#.to_string(),
            "joint_springs.frequency_hz",
        ),
        (
            r#""bodies": [{"model": "h", "position": [0, 0, 1.2], "velocity": {"linear": [1e300, 0, 0]}}]"#.to_string(),
            "bodies[0].velocity",
        ),
        (
            r#""bodies": [{"model": "h", "position": [0, 0, 1.2]}], "gravity": [0, 0, -1e300]"#.to_string(),
            "gravity",
        ),
        (
            r#""bodies": [{"model": "h", "position": [0, 0, 1.2]}], "ground": {"max_iterations": 1000000000000}"#.to_string(),
            "ground.max_iterations",
        ),
        (
            r#""bodies": [{"model": "h", "position": [0, 0, 1.2]}], "ground": {"height": 1e308}"#.to_string(),
            "ground.height",
        ),
    ] {
        let e = err(&with(&extra));
        assert!(e.contains(&format!("{field}:")), "{extra}: {e}");
    }
}

/// The options struct is the one entry to scene files: its memory limit refuses a scene whose
/// estimate (the sum of `body_memory_estimate` over its bodies) is above it, and accepts it at
/// exactly that estimate.
#[test]
fn scene_options_carry_the_memory_limit() {
    let path = models().join("scenes/crowd200.json");
    let scene = SceneOptions::default().load(&path).unwrap();
    let estimate: u64 = scene
        .placements
        .iter()
        .map(|p| articula_view::body_memory_estimate(&scene.models[p.model].model))
        .sum();
    assert_eq!(scene.placements.len(), 200);
    let at = SceneOptions::default().with_memory_limit(estimate);
    assert_eq!(at.load(&path).unwrap().placements.len(), 200);
    match at.with_memory_limit(estimate - 1).load(&path) {
        Err(ViewError::TooLarge {
            bodies,
            estimate: e,
            ..
        }) => assert_eq!((bodies, e), (200, estimate)),
        other => panic!(
            "expected TooLarge, got {:?}",
            other.map(|s| s.placements.len())
        ),
    }
}
