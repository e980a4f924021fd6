//! Round trip: a recorded motion written as .glb, read back by the `gltf` crate (an
//! independent reader), gives every body node's pose at every sample as the simulation's
//! forward kinematics (`Data::body_pose`) computed it, to 1e-6.

use articula_dca::{forward_kinematics, step, Data, Integrator, Method, State};
use articula_gltf::{GltfRecorder, MeshOptions, ModelMeshes, TrajectoryRecorder};
use articula_model::{LoadOptions, Model};
use glam::{DMat3, DQuat, DVec3};
use std::path::Path;

fn models() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../models"))
}

/// `(node name → per sample (translation, rotation))` and the sample times, as the `gltf`
/// crate reads them.
type Tracks = std::collections::HashMap<String, (Vec<DVec3>, Vec<DQuat>)>;

fn read_back(glb: &[u8]) -> (Tracks, Vec<f32>, gltf::Document) {
    let (doc, buffers, _) = gltf::import_slice(glb).expect("the gltf crate reads the file");
    let mut tracks = Tracks::new();
    let mut times = Vec::new();
    let anim = doc.animations().next().expect("one animation");
    for ch in anim.channels() {
        let name = ch.target().node().name().unwrap().to_string();
        let reader = ch.reader(|b| Some(&buffers[b.index()]));
        times = reader.read_inputs().unwrap().collect();
        let entry = tracks.entry(name).or_default();
        match reader.read_outputs().unwrap() {
            gltf::animation::util::ReadOutputs::Translations(t) => {
                entry.0 = t.map(|v| glam::Vec3::from(v).as_dvec3()).collect()
            }
            gltf::animation::util::ReadOutputs::Rotations(r) => {
                entry.1 = r
                    .into_f32()
                    .map(|q| glam::Quat::from_array(q).as_dquat())
                    .collect()
            }
            _ => panic!("only translation and rotation channels"),
        }
    }
    (tracks, times, doc)
}

#[test]
fn every_node_pose_at_every_sample_matches_forward_kinematics() {
    let model = Model::from_urdf_file(
        models().join("humanoid.urdf"),
        &LoadOptions::default().with_floating_base(true),
    )
    .unwrap();
    let mut data = Data::new(&model);
    // A tumbling, flailing fall: random joint velocities and a spinning base.
    let mut state = State::neutral(&model);
    let random = State::random(&model, 7, 0.0);
    state.qd.copy_from_slice(&random.qd);
    let (dt, every, steps) = (1e-3, 7, 400);
    let urdf = models().join("humanoid.urdf");
    let mut rec = TrajectoryRecorder::new(&model, Some(&urdf), &MeshOptions::default());
    assert!(rec.warnings.is_empty(), "{:?}", rec.warnings);
    let mut sampled = vec![(0.0, state.q.clone())];
    rec.record(&model, 0.0, &state.q).unwrap();
    for k in 1..=steps {
        step(
            &model,
            &mut data,
            &mut state,
            Method::Dca,
            Integrator::SemiImplicitEuler,
            dt,
        )
        .unwrap();
        if k % every == 0 {
            let t = k as f64 * dt;
            rec.record(&model, t, &state.q).unwrap();
            sampled.push((t, state.q.clone()));
        }
    }
    let (glb, summary) = rec.recorder().to_glb().unwrap();
    assert_eq!(summary.samples, sampled.len());
    assert_eq!(summary.body_nodes, model.bodies.len());
    let (tracks, times, doc) = read_back(&glb);
    assert_eq!(tracks.len(), model.bodies.len());
    assert_eq!(times.len(), sampled.len());
    let mut worst = (0.0f64, 0.0f64);
    let mut moved = 0.0f64;
    for (j, (t, q)) in sampled.iter().enumerate() {
        // f32 times: within half an f32 ulp of 0.4 s.
        assert!((f64::from(times[j]) - t).abs() < 3e-8, "time {j}");
        forward_kinematics(&model, q, &vec![0.0; model.nv], &mut data).unwrap();
        for (b, body) in model.bodies.iter().enumerate() {
            let (tr, rot) = &tracks[&format!("{}/{}", model.name, body.name)];
            let (r, p) = data.body_pose(b);
            let r_read = DMat3::from_quat(rot[j]);
            worst.0 = worst.0.max((tr[j] - p).abs().max_element());
            let dr = (0..3)
                .map(|c| (r_read.col(c) - r.col(c)).abs().max_element())
                .fold(0.0, f64::max);
            worst.1 = worst.1.max(dr);
            moved = moved.max((p - tr[0]).length());
        }
    }
    // f32 storage: positions within ~2 m round to 1.2e-7, unit quaternions to 6e-8.
    assert!(worst.0 < 1e-6 && worst.1 < 1e-6, "worst error {worst:?}");
    assert!(
        moved > 0.3,
        "the fall moves the bodies ({moved} m): the test can fail"
    );
    // Body nodes sit under their character (no transform) under the root, which turns the
    // z-up world to glTF's y-up: their local poses are world poses.
    let root = doc.scenes().next().unwrap().nodes().next().unwrap();
    let (_, r, _) = root.transform().decomposed();
    let up = glam::Quat::from_array(r).as_dquat() * DVec3::Z;
    assert!((up - DVec3::Y).length() < 1e-7, "z up becomes y up: {up}");
    let character = root.children().next().unwrap();
    assert_eq!(
        character.transform().decomposed(),
        ([0.0; 3], [0.0, 0.0, 0.0, 1.0], [1.0; 3])
    );
    assert_eq!(character.children().count(), model.bodies.len());
    // Each body node has a mesh; the first sample is also the node's rest pose.
    for node in doc
        .nodes()
        .filter(|n| n.name().is_some_and(|s| s.contains('/')))
    {
        assert!(node.mesh().is_some(), "{:?} has a mesh", node.name());
        let (t, _, _) = node.transform().decomposed();
        let first = tracks[node.name().unwrap()].0[0];
        assert!((glam::Vec3::from(t).as_dvec3() - first).length() < 1e-6);
    }
}

#[test]
fn characters_share_their_model_meshes_and_samples_must_advance() {
    let model = Model::from_urdf_file(
        models().join("humanoid.urdf"),
        &LoadOptions::default().with_floating_base(true),
    )
    .unwrap();
    let mut rec = GltfRecorder::new();
    let m = rec.add_model(
        &model,
        ModelMeshes::load(&model, None, &MeshOptions::default()),
    );
    for c in 0..3 {
        rec.add_character(&format!("c{c}"), m).unwrap();
    }
    let poses = vec![(DMat3::IDENTITY, DVec3::ZERO); model.bodies.len()];
    rec.record(0.0, [&poses[..], &poses[..], &poses[..]])
        .unwrap();
    // Out of order, or the wrong number of characters: an error naming it, nothing recorded.
    let err = rec
        .record(0.0, [&poses[..], &poses[..], &poses[..]])
        .unwrap_err();
    assert!(err.to_string().contains("does not come after"), "{err}");
    let err = rec.record(1.0, [&poses[..]]).unwrap_err();
    assert!(
        err.to_string()
            .contains("poses of 1 characters given, 3 added"),
        "{err}"
    );
    assert!(rec.add_character("late", m).is_err());
    rec.record(1.0, [&poses[..], &poses[..], &poses[..]])
        .unwrap();
    let (glb, summary) = rec.to_glb().unwrap();
    let (tracks, times, doc) = read_back(&glb);
    assert_eq!(times, vec![0.0, 1.0]);
    assert_eq!(tracks.len(), 3 * model.bodies.len());
    // One mesh per body of the model, drawn by all three characters.
    assert_eq!(doc.meshes().count(), summary.meshes);
    assert!(summary.meshes <= model.bodies.len());
    let drawn = doc.nodes().filter(|n| n.mesh().is_some()).count();
    assert_eq!(drawn, 3 * summary.meshes);
}
