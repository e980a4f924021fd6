//! Scenes built in code ([`SceneBuilder`], [`SceneSpec::resolve`]): the same scene as its JSON
//! file, and every invalid input — to the builder, to a hand-edited [`LoadedScene`], to the
//! bodies' states between steps — an error naming it, never a panic. Self-contained (the model
//! is inline).

use articula_model::{LoadOptions, Model};
use articula_view::{
    BodySpec, CameraRig, CameraSpec, CrowdSpec, KeySpec, LoadedScene, PushSpec, SceneBuilder,
    SceneSim, SceneSpec, SpringSpec, VelocitySpec, ViewError, VisibilitySpec,
};
use std::path::Path;

/// A torso with two arms on hinges, each arm with a forearm on a second hinge (four internal
/// degrees of freedom).
const BOT: &str = r#"<robot name="bot">
  <link name="torso"><inertial><mass value="10"/>
    <inertia ixx="0.3" iyy="0.3" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.3 0.2 0.6"/></geometry></collision></link>
  <link name="l_arm"><inertial><origin xyz="0 0 -0.15"/><mass value="2"/>
    <inertia ixx="0.02" iyy="0.02" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l_fore"><inertial><origin xyz="0 0 -0.15"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="r_arm"><inertial><origin xyz="0 0 -0.15"/><mass value="2"/>
    <inertia ixx="0.02" iyy="0.02" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="r_fore"><inertial><origin xyz="0 0 -0.15"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="l_shoulder" type="continuous"><parent link="torso"/><child link="l_arm"/>
    <origin xyz="0 0.2 0.3"/><axis xyz="0 1 0"/></joint>
  <joint name="l_elbow" type="continuous"><parent link="l_arm"/><child link="l_fore"/>
    <origin xyz="0 0 -0.3"/><axis xyz="1 0 0"/></joint>
  <joint name="r_shoulder" type="continuous"><parent link="torso"/><child link="r_arm"/>
    <origin xyz="0 -0.2 0.3"/><axis xyz="0 1 0"/></joint>
  <joint name="r_elbow" type="continuous"><parent link="r_arm"/><child link="r_fore"/>
    <origin xyz="0 0 -0.3"/><axis xyz="1 0 0"/></joint>
</robot>"#;

fn bot() -> Model {
    Model::from_urdf_str(BOT, &LoadOptions::default().with_floating_base(true)).unwrap()
}

/// A valid scene: a hero, a 2 × 3 crowd, a push, springs.
fn builder() -> SceneBuilder {
    SceneBuilder::new()
        .model("bot", bot())
        .body(BodySpec {
            name: Some("hero".into()),
            rpy: [0.0, 0.0, 0.5],
            velocity: VelocitySpec {
                linear: [1.0, 0.0, 0.0],
                angular: [0.0, 0.0, 0.3],
            },
            ..BodySpec::new("bot", [3.0, 0.0, 1.0])
        })
        .crowd(CrowdSpec {
            name: Some("crowd".into()),
            origin: [6.0, -2.0, 1.0],
            jitter: 0.2,
            seed: 11,
            yaw_jitter: 0.4,
            ..CrowdSpec::new("bot", 2, 3)
        })
        .camera(CameraSpec::look_at([0.0, 0.0, 1.5], [10.0, 0.0, 1.0]))
        .budget(6)
        .dt(0.005)
        .reselect_every(2)
        .push(PushSpec {
            point: [0.0, 0.0, -0.1],
            ..PushSpec::new("l_fore", [0.0, 30.0, 0.0], 0.0, 0.05)
        })
        .joint_springs(SpringSpec {
            frequency_hz: 2.0,
            damping_ratio: 0.3,
        })
}

fn build_err(b: SceneBuilder) -> String {
    match b.build() {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.to_string(),
    }
}

fn assert_err(e: String, field: &str) {
    assert!(e.contains("<built in code>"), "{e}");
    assert!(e.contains(field), "expected the field '{field}' in: {e}");
}

/// The scene built in code and the same scene written as a JSON file (its model in a
/// temporary folder) resolve to the same placements (bit for bit) and pushes, and step alike.
#[cfg(feature = "serde")]
#[test]
fn built_scene_equals_its_scene_file() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("articula-builder-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("bot.urdf"), BOT).unwrap();
    let json = r#"{"models": {"bot": "bot.urdf"},
      "bodies": [{"name": "hero", "model": "bot", "position": [3, 0, 1], "rpy": [0, 0, 0.5],
                  "velocity": {"linear": [1, 0, 0], "angular": [0, 0, 0.3]}}],
      "crowds": [{"name": "crowd", "model": "bot", "rows": 2, "columns": 3, "origin": [6, -2, 1],
                  "spacing": [2, 2], "jitter": 0.2, "seed": 11, "yaw_jitter": 0.4}],
      "camera": {"eye": [0, 0, 1.5], "target": [10, 0, 1]},
      "budget": 6, "dt": 0.005, "reselect_every": 2,
      "pushes": [{"bodies": "all", "link": "l_fore", "point": [0, 0, -0.1], "force": [0, 30, 0],
                  "t0": 0, "t1": 0.05}],
      "joint_springs": {"frequency_hz": 2, "damping_ratio": 0.3}}"#;
    let file = articula_view::SceneOptions::default()
        .parse(json, &dir.join("s.json"), &dir)
        .unwrap();
    let code = builder().build().unwrap();
    // The model file, read through the builder, is the same scene again.
    let by_path = SceneBuilder::from_spec(spec())
        .model_file("bot", dir.join("bot.urdf"))
        .build()
        .unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    for other in [&file, &by_path] {
        assert_eq!(code.placements.len(), 7);
        assert_eq!(other.placements.len(), code.placements.len());
        for (a, b) in code.placements.iter().zip(&other.placements) {
            assert_eq!(a.name, b.name);
            let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a.q), bits(&b.q), "{}", a.name);
            assert_eq!(bits(&a.qd), bits(&b.qd), "{}", a.name);
        }
        assert_eq!(other.pushes, code.pushes);
        assert_eq!(code.pushes.len(), 7);
        assert_eq!(other.camera, code.camera);
    }
    let (mut a, mut b) = (SceneSim::new(&code).unwrap(), SceneSim::new(&file).unwrap());
    for _ in 0..6 {
        assert_eq!(a.step().unwrap(), b.step().unwrap());
    }
    for (x, y) in a.bodies.iter().zip(&b.bodies) {
        assert_eq!(x.state.q, y.state.q);
    }
}

/// The scene of [`builder`] as a spec, without its model.
fn spec() -> SceneSpec {
    SceneSpec {
        bodies: vec![BodySpec {
            name: Some("hero".into()),
            rpy: [0.0, 0.0, 0.5],
            velocity: VelocitySpec {
                linear: [1.0, 0.0, 0.0],
                angular: [0.0, 0.0, 0.3],
            },
            ..BodySpec::new("bot", [3.0, 0.0, 1.0])
        }],
        crowds: vec![CrowdSpec {
            name: Some("crowd".into()),
            origin: [6.0, -2.0, 1.0],
            jitter: 0.2,
            seed: 11,
            yaw_jitter: 0.4,
            ..CrowdSpec::new("bot", 2, 3)
        }],
        camera: CameraSpec::look_at([0.0, 0.0, 1.5], [10.0, 0.0, 1.0]),
        budget: Some(6),
        dt: 0.005,
        reselect_every: 2,
        pushes: vec![PushSpec {
            point: [0.0, 0.0, -0.1],
            ..PushSpec::new("l_fore", [0.0, 30.0, 0.0], 0.0, 0.05)
        }],
        joint_springs: Some(SpringSpec {
            frequency_hz: 2.0,
            damping_ratio: 0.3,
        }),
        ..SceneSpec::default()
    }
}

/// A spec serialised to JSON and parsed back is the same scene.
#[cfg(feature = "serde")]
#[test]
fn specs_serialize_to_scene_files() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("articula-spec-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("bot.urdf"), BOT).unwrap();
    let mut spec = spec();
    spec.models.insert("bot".into(), "bot.urdf".into());
    spec.camera = CameraSpec::path(vec![
        KeySpec {
            t: 0.0,
            eye: [0.0, 0.0, 1.5],
            target: [10.0, 0.0, 1.0],
        },
        KeySpec {
            t: 1.0,
            eye: [0.0, 2.0, 1.5],
            target: [10.0, 0.0, 1.0],
        },
    ]);
    let json = serde_json::to_string_pretty(&spec).unwrap();
    let parsed = articula_view::SceneOptions::default()
        .parse(&json, &dir.join("s.json"), &dir)
        .unwrap();
    let direct = spec.resolve(&dir).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(matches!(direct.camera, CameraRig::Path(_)));
    assert_eq!(parsed.camera, direct.camera);
    assert_eq!(parsed.pushes, direct.pushes);
    for (a, b) in parsed.placements.iter().zip(&direct.placements) {
        assert_eq!((&a.name, &a.q, &a.qd), (&b.name, &b.q, &b.qd));
    }
}

/// Builders with a wrong model, body or crowd, and the field each error must name.
fn wrong_body_cases() -> Vec<(SceneBuilder, &'static str)> {
    let fixed = Model::from_urdf_str(BOT, &LoadOptions::default()).unwrap();
    vec![
        (builder().model("bot", bot()), "models.bot"),
        (
            SceneBuilder::new()
                .model("fixed", fixed)
                .crowd(CrowdSpec::new("fixed", 1, 1)),
            "models.fixed",
        ),
        (
            builder().crowd(CrowdSpec::new("ghost", 1, 1)),
            "crowds[1].model",
        ),
        (
            builder().body(BodySpec::new("ghost", [0.0; 3])),
            "bodies[1].model",
        ),
        (
            builder().crowd(CrowdSpec::new("bot", 0, 3)),
            "crowds[1].rows",
        ),
        (
            builder().crowd(CrowdSpec::new("bot", 2000, 2000)),
            "crowds[1].rows",
        ),
        (
            builder().crowd(CrowdSpec {
                origin: [f64::NAN, 0.0, 0.0],
                ..CrowdSpec::new("bot", 1, 1)
            }),
            "crowds[1].origin",
        ),
        (
            builder().crowd(CrowdSpec {
                jitter: -1.0,
                ..CrowdSpec::new("bot", 1, 1)
            }),
            "crowds[1].jitter",
        ),
        // Finite inputs whose positions would overflow (1e308 + 2e308) are refused at the
        // field that is out of range (distances at most 1e6 m), before any placement.
        (
            builder().crowd(CrowdSpec {
                origin: [1e308, 0.0, 1.0],
                spacing: [1.7e308, 1.0],
                ..CrowdSpec::new("bot", 2, 1)
            }),
            "crowds[1].origin",
        ),
        (
            builder().body(BodySpec {
                velocity: VelocitySpec {
                    linear: [f64::INFINITY, 0.0, 0.0],
                    angular: [0.0; 3],
                },
                ..BodySpec::new("bot", [0.0; 3])
            }),
            "bodies[1].velocity",
        ),
        (
            builder().body(BodySpec {
                name: Some("hero".into()),
                ..BodySpec::new("bot", [3.0, 0.0, 1.0])
            }),
            "bodies[1].name",
        ),
    ]
}

/// Builders with a wrong setting, camera or push, and the field each error must name.
fn wrong_setting_cases() -> Vec<(SceneBuilder, &'static str)> {
    vec![
        (builder().dt(0.0), "dt"),
        (builder().dt(f64::NAN), "dt"),
        (builder().reselect_every(0), "reselect_every"),
        (builder().tolerance(-1.0), "tolerance"),
        (builder().gravity([0.0, f64::NAN, 0.0]), "gravity"),
        (builder().image(0, 100), "image"),
        (
            builder().visibility(VisibilitySpec {
                depth_buffer: [usize::MAX, 2],
                ..VisibilitySpec::default()
            }),
            "visibility.depth_buffer",
        ),
        (
            builder().visibility(VisibilitySpec {
                occluded_factor: 2.0,
                ..VisibilitySpec::default()
            }),
            "visibility.occluded_factor",
        ),
        (
            builder().joint_springs(SpringSpec {
                frequency_hz: -1.0,
                damping_ratio: 0.1,
            }),
            "joint_springs.frequency_hz",
        ),
        (
            builder().camera(CameraSpec::look_at([1.0; 3], [1.0; 3])),
            "camera",
        ),
        (
            builder().camera(CameraSpec::path(Vec::new())),
            "camera.path",
        ),
        (
            builder().camera(CameraSpec {
                eye: None,
                ..CameraSpec::default()
            }),
            "camera",
        ),
        (
            builder().push(PushSpec::new("tail", [1.0; 3], 0.0, 1.0)),
            "pushes[1].link",
        ),
        (
            builder().push(PushSpec::new("torso", [1.0; 3], 1.0, 0.0)),
            "pushes[1].t0",
        ),
        (
            builder().push(PushSpec::new("torso", [f64::NAN; 3], 0.0, 1.0)),
            "pushes[1].force",
        ),
        (
            builder().push(PushSpec {
                bodies: articula_view::Targets::Names(vec!["nobody".into()]),
                ..PushSpec::new("torso", [1.0; 3], 0.0, 1.0)
            }),
            "pushes[1].bodies[0]",
        ),
        (SceneBuilder::new().model("bot", bot()), "bodies"),
        (SceneBuilder::new(), "models"),
        (
            builder().model_file("other", "/nonexistent/articula/bot.urdf"),
            "models.other",
        ),
    ]
}

#[test]
fn builder_inputs_are_checked() {
    let mut cases = wrong_body_cases();
    cases.extend(wrong_setting_cases());
    let duplicate = builder().body(BodySpec {
        name: Some("crowd".into()),
        ..BodySpec::new("bot", [3.0, 0.0, 1.0])
    });
    assert!(build_err(duplicate).contains("duplicate name 'crowd'"));
    for (b, field) in cases {
        let e = build_err(b);
        if field == "models.other" {
            // A model file that cannot be read: the loader's error, naming the model.
            assert!(
                e.contains("models.other") && e.contains("nonexistent"),
                "{e}"
            );
        } else {
            assert_err(e, field);
        }
    }
}

/// The scene's public fields changed by hand: each change that would have panicked in
/// `SceneSim::new` or its first step (a `q` one number short was a `copy_from_slice` length
/// mismatch) is an error naming the field.
#[test]
fn hand_edited_scenes_are_checked() {
    let good = builder().build().unwrap();
    SceneSim::new(&good).unwrap();
    type Edit = fn(&mut LoadedScene);
    let cases: Vec<(Edit, &str)> = vec![
        (
            |s| {
                s.placements[0].q.pop();
            },
            "placements[0].q",
        ),
        (|s| s.placements[2].q.push(0.0), "placements[2].q"),
        (
            |s| {
                s.placements[1].qd.pop();
            },
            "placements[1].qd",
        ),
        (|s| s.placements[1].qd[7] = f64::NAN, "placements[1].qd"),
        (|s| s.placements[3].model = 1, "placements[3].model"),
        (|s| s.placements.clear(), "placements"),
        (
            |s| {
                s.models[0].volumes.pop();
            },
            "models[0].volumes",
        ),
        (|s| s.pushes[0].body = 99, "pushes[0].body"),
        (|s| s.pushes[0].link_body = 99, "pushes[0].link_body"),
        (|s| s.pushes[0].t1 = -1.0, "pushes[0].t0"),
        (|s| s.dt = -1.0, "dt"),
        (|s| s.reselect_every = 0, "reselect_every"),
        (|s| s.visibility.depth_width = 0, "visibility.depth_width"),
        (|s| s.image.height = 0, "image"),
        (|s| s.tolerance = Some(f64::INFINITY), "tolerance"),
        (
            |s| {
                if let CameraRig::Fixed(c) = &mut s.camera {
                    c.near = 0.0;
                }
            },
            "camera",
        ),
        (
            |s| {
                let CameraRig::Fixed(c) = s.camera else {
                    unreachable!()
                };
                s.camera = CameraRig::Path(articula_view::CameraPath {
                    keys: Vec::new(),
                    up: glam::DVec3::Z,
                    fov_y_deg: 60.0,
                    aspect: c.aspect,
                    near: c.near,
                    far: c.far,
                });
            },
            "camera.path",
        ),
        (
            |s| {
                s.models[0].model.floating_base = false;
            },
            "models[0]",
        ),
    ];
    for (edit, field) in cases {
        let mut scene = good.clone();
        edit(&mut scene);
        let e = match SceneSim::new(&scene) {
            Ok(_) => panic!("expected an error for {field}"),
            Err(ViewError::Invalid { field: f, .. }) => f,
            Err(e) => panic!("{field}: {e}"),
        };
        assert_eq!(e, field);
    }
}

/// Bodies' states changed between steps: a wrong length or model index is an error naming the
/// body, never a panic; a non-finite number is the dynamics' error; rendering skips what no
/// longer fits.
#[test]
fn stepping_inputs_are_checked() {
    let scene = builder().build().unwrap();
    type Edit = fn(&mut SceneSim);
    let cases: Vec<(Edit, &str)> = vec![
        (
            |s| {
                s.bodies[0].state.q.pop();
            },
            "body 'hero': q has 10",
        ),
        (|s| s.bodies[2].state.qd.push(1.0), "qd has 11"),
        (
            |s| {
                s.bodies[3].state.tau.pop();
            },
            "tau has 9",
        ),
        (|s| s.bodies[1].model = 5, "no model 5"),
        // The root's quaternion: read by every step, exact, adaptive or rigid.
        (|s| s.bodies[4].state.q[3] = f64::NAN, "body 'crowd[1,0]'"),
    ];
    for (edit, expected) in cases {
        for steps_first in [0, 3] {
            let mut sim = SceneSim::new(&scene).unwrap();
            for _ in 0..steps_first {
                sim.step().unwrap();
            }
            edit(&mut sim);
            let mut groups = Vec::new();
            let _ = sim.frame(&mut groups);
            let e = sim.step().unwrap_err().to_string();
            assert!(e.contains(expected), "expected '{expected}' in: {e}");
        }
    }
}

/// `SceneSpec::resolve` checks a spec given whole, as the builder does.
#[test]
fn resolve_checks_a_spec() {
    let spec = SceneSpec {
        models: [("bot".to_string(), "bot.urdf".to_string())].into(),
        crowds: vec![CrowdSpec::new("bot", 1, 1)],
        dt: 0.0,
        ..SceneSpec::default()
    };
    let e = spec
        .resolve(Path::new("/nonexistent"))
        .unwrap_err()
        .to_string();
    assert_err(e, "dt");
}
