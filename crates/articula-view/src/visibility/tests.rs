//! Visibility classes, the depth buffer's conservativeness, joint weights, body poses.

use super::{
    body_pose, body_poses, ceil_index, floor_index, Classifier, DepthBuffer, Placed, PosePlan,
    Visibility, VisibilitySettings,
};
use crate::volumes::{body_volumes, BodyVolumes};
use crate::Camera;
use articula_dca::{forward_kinematics, Data, State};
use articula_model::{LoadOptions, Model};
use glam::{DMat3, DVec3};

fn models() -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

fn load(file: &str, floating_base: bool) -> Model {
    Model::from_urdf_file(
        models().join(file),
        &LoadOptions::default().with_floating_base(floating_base),
    )
    .unwrap()
}

/// Largest absolute entry of `a − b`.
fn max_diff(a: DMat3, b: DMat3) -> f64 {
    (a - b)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()))
}

fn cam() -> Camera {
    Camera::look_at(
        DVec3::ZERO,
        DVec3::X,
        DVec3::Z,
        60.0,
        16.0 / 9.0,
        0.1,
        200.0,
    )
    .unwrap()
}

/// A one-body floating model: a ball of the given radius (collision sphere).
fn ball(radius: f64) -> (Model, Vec<BodyVolumes>) {
    let i = 0.4 * radius * radius;
    let urdf = format!(
        r#"<robot name="ball"><link name="ball"><inertial><mass value="1"/>
        <inertia ixx="{i}" ixy="0" ixz="0" iyy="{i}" iyz="0" izz="{i}"/></inertial>
        <collision><geometry><sphere radius="{radius}"/></geometry></collision></link></robot>"#
    );
    let m = Model::from_urdf_str(&urdf, &LoadOptions::default().with_floating_base(true)).unwrap();
    let v = body_volumes(&m);
    (m, v)
}

/// A floating box "wall" (collision box of the given size).
fn wall(size: DVec3) -> (Model, Vec<BodyVolumes>) {
    let urdf = format!(
        r#"<robot name="wall"><link name="wall"><inertial><mass value="10"/>
        <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
        <collision><geometry><box size="{} {} {}"/></geometry></collision></link></robot>"#,
        size.x, size.y, size.z
    );
    let m = Model::from_urdf_str(&urdf, &LoadOptions::default().with_floating_base(true)).unwrap();
    let v = body_volumes(&m);
    (m, v)
}

const ROOT: [Option<usize>; 1] = [None];

fn classify(cam: &Camera, bodies: &[(&[BodyVolumes], DVec3, f64)]) -> Vec<super::BodyView> {
    let settings = VisibilitySettings::default();
    let poses: Vec<Vec<(DMat3, DVec3)>> = bodies
        .iter()
        .map(|b| vec![(DMat3::IDENTITY, b.1)])
        .collect();
    let placed: Vec<Placed> = bodies
        .iter()
        .zip(&poses)
        .map(|(b, p)| Placed {
            volumes: b.0,
            poses: p,
            parents: &ROOT,
            margin: b.2,
        })
        .collect();
    let mut c = Classifier::new(&settings);
    let mut out = Vec::new();
    c.classify(cam, &settings, &placed, &mut out);
    out
}

#[test]
fn frustum_classes_and_the_motion_margin() {
    let (_, b) = ball(0.5);
    let c = cam();
    let v = classify(
        &c,
        &[
            (&b, DVec3::new(10.0, 0.0, 0.0), 0.0),  // in front
            (&b, DVec3::new(-10.0, 0.0, 0.0), 0.0), // behind
            (&b, DVec3::new(10.0, 30.0, 0.0), 0.0), // far to the left
            // Just outside the left edge by 0.5 m beyond its radius: invisible without margin,
            // "may enter" with a 1 m margin.
            (&b, DVec3::new(10.0, 0.0, 0.0), 0.0),
        ],
    );
    assert_eq!(v[0].summary(), Visibility::Visible);
    assert_eq!(v[1].summary(), Visibility::Invisible);
    assert_eq!(v[2].summary(), Visibility::Invisible);
    assert_eq!(v[1].joint_weights, vec![0.0]);
    // Left plane distance of (x, y) at depth x: (x ta − y)/√(1 + ta²).
    let ta = 16.0 / 9.0 * (30f64).to_radians().tan();
    let n = (1.0 + ta * ta).sqrt();
    let y = 10.0 * ta + (0.5 + 0.5) * n;
    let out = classify(
        &c,
        &[
            (&b, DVec3::new(10.0, y, 0.0), 0.0),
            (&b, DVec3::new(10.0, y, 0.0), 1.0),
        ],
    );
    assert_eq!(out[0].summary(), Visibility::Invisible);
    assert_eq!(out[1].summary(), Visibility::Visible);
}

#[test]
fn a_wall_occludes_what_is_behind_it() {
    let (_, b) = ball(0.3);
    let (_, w) = wall(DVec3::new(0.2, 6.0, 4.0));
    let c = cam();
    let v = classify(
        &c,
        &[
            (&w, DVec3::new(5.0, 0.0, 0.0), 0.0),
            (&b, DVec3::new(15.0, 0.0, 0.0), 0.0), // behind the wall
            (&b, DVec3::new(15.0, 6.0, 0.0), 0.0), // beside it, in view
            (&b, DVec3::new(3.0, 0.0, 0.0), 0.0),  // in front of the wall
        ],
    );
    assert_eq!(v[0].summary(), Visibility::Visible);
    assert_eq!(v[1].summary(), Visibility::Occluded);
    assert_eq!(v[2].summary(), Visibility::Visible);
    assert_eq!(v[3].summary(), Visibility::Visible);
    // Occluded weight = visible weight × factor at the same projected size; farther = smaller.
    let s = VisibilitySettings::default();
    let size_w = |view: &super::BodyView| (view.projected_size / s.full_detail_size).min(1.0);
    assert!((v[1].joint_weights[0] - size_w(&v[1]) * s.occluded_factor).abs() < 1e-15);
    assert!((v[2].joint_weights[0] - size_w(&v[2])).abs() < 1e-15);
    assert!(v[1].joint_weights[0] < v[2].joint_weights[0]);
}

/// Whether the ray from the eye to `p` meets a ball before reaching p's depth.
fn ray_blocked(eye: DVec3, p: DVec3, balls: &[(DVec3, f64)]) -> bool {
    let d = (p - eye).normalize();
    let len = (p - eye).length();
    balls.iter().any(|&(c, r)| {
        let t = (c - eye).dot(d);
        let closest = (eye + d * t - c).length();
        if closest > r {
            return false;
        }
        let t_in = t - (r * r - closest * closest).sqrt();
        t_in < len
    })
}

#[test]
fn the_depth_buffer_never_hides_a_ball_that_a_ray_can_see() {
    // Random balls: rasterise them all; a ball the buffer calls hidden must have every sampled
    // point of its camera-facing side behind some *other* ball along its ray.
    let c = cam();
    let mut seed = 3u64;
    let mut rnd = |lo: f64, hi: f64| {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
    };
    let mut hidden_total = 0;
    for _ in 0..30 {
        let balls: Vec<(DVec3, f64)> = (0..40)
            .map(|_| {
                let x = rnd(2.0, 30.0);
                (
                    DVec3::new(x, rnd(-0.5, 0.5) * x, rnd(-0.3, 0.3) * x),
                    rnd(0.1, 2.5),
                )
            })
            .collect();
        let mut buf = DepthBuffer::new(64, 36);
        for &(p, r) in &balls {
            buf.rasterize_ball(&c, p, r);
        }
        for (k, &(p, r)) in balls.iter().enumerate() {
            if !buf.is_hidden(&c, p, r) {
                continue;
            }
            hidden_total += 1;
            let others: Vec<(DVec3, f64)> = balls
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != k)
                .map(|(_, b)| *b)
                .collect();
            for i in 0..200 {
                // Points on the sphere facing the camera.
                let u = rnd(-1.0, 1.0);
                let phi = i as f64 * 2.399963;
                let s = (1.0 - u * u).sqrt();
                let mut n = DVec3::new(u, s * phi.cos(), s * phi.sin());
                if n.dot(c.position - p) < 0.0 {
                    n = -n;
                }
                let q = p + n * r;
                assert!(
                    ray_blocked(c.position, q, &others),
                    "ball {k} is called hidden but {q} is seen"
                );
            }
        }
    }
    assert!(
        hidden_total > 20,
        "the test must exercise hidden balls: {hidden_total}"
    );
}

#[test]
fn joint_weights_take_the_largest_weight_below() {
    // Humanoid at a distance with its left arm out of the frustum is hard to arrange; instead
    // place one humanoid so that only part of it is in view and check the subtree rule directly.
    let model = load("humanoid.urdf", true);
    let vols = body_volumes(&model);
    let parents: Vec<Option<usize>> = model.bodies.iter().map(|b| b.parent).collect();
    let mut poses = Vec::new();
    let mut q = model.neutral_q();
    // Standing 4 m in front, shifted so that the image's left edge cuts through the body.
    let c = Camera::look_at(DVec3::ZERO, DVec3::X, DVec3::Z, 30.0, 1.0, 0.1, 100.0).unwrap();
    let edge = 4.0 * (15f64).to_radians().tan();
    q[0] = 4.0;
    q[1] = edge + 0.25;
    body_poses(&model, &q, &mut poses);
    let settings = VisibilitySettings::default();
    let mut cl = Classifier::new(&settings);
    let mut out = Vec::new();
    cl.classify(
        &c,
        &settings,
        &[Placed {
            volumes: &vols,
            poses: &poses,
            parents: &parents,
            margin: 0.0,
        }],
        &mut out,
    );
    let v = &out[0];
    let classes: std::collections::BTreeSet<_> = v.links.iter().collect();
    assert!(
        classes.contains(&Visibility::Invisible) && classes.contains(&Visibility::Visible),
        "{:?}",
        v.links
    );
    // Recompute the subtree maximum independently (walk every body's ancestors).
    let mut expect = vec![0.0f64; parents.len()];
    for (i, &w) in v.link_weights.iter().enumerate() {
        let mut at = Some(i);
        while let Some(j) = at {
            expect[j] = expect[j].max(w);
            at = parents[j];
        }
    }
    assert_eq!(v.joint_weights, expect);
    for (l, c) in v.links.iter().enumerate() {
        assert_eq!(v.link_weights[l] == 0.0, *c == Visibility::Invisible);
    }
    assert_eq!(v.summary(), Visibility::Visible);
}

#[test]
fn body_poses_about_signed_coordinate_axes_match_forward_kinematics() {
    // A chain whose revolute axes are ±x, ±y, ±z (the two-column path of the poses) and one
    // tilted axis (the general rotation), with rotated joint origins.
    let axes = [
        "1 0 0",
        "0 -1 0",
        "0 0 1",
        "-1 0 0",
        "0 1 0",
        "0 0 -1",
        "0.6 0 0.8",
    ];
    let mut urdf = String::from(
        r#"<robot name="axes"><link name="l0"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>"#,
    );
    for (k, a) in axes.iter().enumerate() {
        urdf += &format!(
            r#"<link name="l{c}"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link><joint name="j{c}" type="revolute"><parent link="l{k}"/><child link="l{c}"/><origin xyz="0.1 0.2 0.3" rpy="0.3 -0.2 0.1"/><axis xyz="{a}"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>"#,
            c = k + 1
        );
    }
    urdf += "</robot>";
    let model = Model::from_urdf_str(&urdf, &LoadOptions::default()).unwrap();
    let mut data = Data::new(&model);
    let mut poses = Vec::new();
    for seed in 0..5 {
        let s = State::random(&model, seed, 1.0);
        forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
        body_poses(&model, &s.q, &mut poses);
        for (i, &(r, p)) in poses.iter().enumerate() {
            let (r2, p2) = data.body_pose(i);
            assert!((p - p2).length() < 1e-12, "body {i}");
            let d = max_diff(r, r2);
            assert!(d < 1e-12, "body {i}: {d}");
        }
    }
}

#[test]
fn body_poses_match_forward_kinematics() {
    for (file, floating) in [
        ("humanoid.urdf", true),
        ("plant.urdf", false),
        ("chain30.urdf", true),
    ] {
        let model = load(file, floating);
        let mut data = Data::new(&model);
        let mut poses = Vec::new();
        for seed in 0..5 {
            let s = State::random(&model, seed, 1.0);
            forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
            body_poses(&model, &s.q, &mut poses);
            for (i, &(r, p)) in poses.iter().enumerate() {
                let (r2, p2) = data.body_pose(i);
                assert!((p - p2).length() < 1e-9, "{file} body {i}");
                assert!(max_diff(r, r2) < 1e-12, "{file} body {i}");
            }
        }
    }
}

#[test]
fn a_point_carried_up_its_root_path_is_where_forward_kinematics_puts_it() {
    // `PosePlan::point` (a push's point of application) against the body pose of the
    // dynamics' own forward kinematics, on floating and fixed bases, composed and tilted axes.
    for (file, floating) in [
        ("humanoid.urdf", true),
        ("plant.urdf", false),
        ("chain30.urdf", true),
    ] {
        let model = load(file, floating);
        let plan = PosePlan::new(&model);
        let mut data = Data::new(&model);
        let mut farthest = 0.0f64;
        for seed in 0..10 {
            let s = State::random(&model, seed, 2.0);
            forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
            for i in 0..model.bodies.len() {
                let local = DVec3::new(0.1, -0.2, 0.3) * (1.0 + seed as f64);
                let (r, p) = data.body_pose(i);
                let want = r * local + p;
                let got = plan.point(&model, &s.q, i, local);
                let scale = 1.0 + want.length();
                assert!(
                    (got - want).length() < 1e-12 * scale,
                    "{file} body {i}: {got} against {want}"
                );
                farthest = farthest.max((want - p).length());
            }
        }
        assert!(farthest > 0.3, "{file}: the points must be off the origins");
    }
}

#[test]
fn a_rasterised_ball_fills_exactly_the_cells_wholly_inside_its_disc() {
    // Brute force: a cell gets the ball's far depth when its four corners lie in the projected
    // ellipse ((u − x)/rx)² + ((v − y)/ry)² ≤ 1 (same camera → cell mapping as the buffer).
    let c = cam();
    let (w, h) = (64usize, 36usize);
    let t = c.tan_half_fov();
    let (fx, fy) = (w as f64 / (2.0 * t * c.aspect), h as f64 / (2.0 * t));
    let mut seed = 11u64;
    let mut rnd = |lo: f64, hi: f64| {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
    };
    let (mut filled_total, mut one_cell) = (0, 0);
    for k in 0..3000 {
        let x = rnd(0.5, 40.0);
        let p = DVec3::new(x, rnd(-1.5, 1.5) * x, rnd(-1.0, 1.0) * x);
        // Small to huge discs, some crossing the image border; every fourth about one cell
        // across (the buffer's one-cell path: radii of 0.6–1.3 cells).
        let r = if k % 4 == 3 {
            rnd(0.6, 1.3) * x / fy
        } else if k % 3 == 0 {
            rnd(0.01, 0.3)
        } else {
            rnd(0.1, 0.6) * x
        };
        let mut buf = DepthBuffer::new(w, h);
        buf.rasterize_ball(&c, p, r);
        let q = c.axes.transpose() * (p - c.position);
        let visible = q.z - r > c.near;
        let (cx, cy) = (
            (q.x / q.z) * fx + 0.5 * w as f64,
            -(q.y / q.z) * fy + 0.5 * h as f64,
        );
        let (rx, ry) = (r / q.z * fx, r / q.z * fy);
        let inside = |u: f64, v: f64| {
            let (a, b) = ((u - cx) / rx, (v - cy) / ry);
            a * a + b * b <= 1.0
        };
        for j in 0..h {
            for i in 0..w {
                let (u, v) = (i as f64, j as f64);
                let full = visible
                    && inside(u, v)
                    && inside(u + 1.0, v)
                    && inside(u, v + 1.0)
                    && inside(u + 1.0, v + 1.0);
                let want = if full { q.z + r } else { f64::INFINITY };
                filled_total += usize::from(full);
                one_cell += usize::from(full && k % 4 == 3 && rx < 1.0 && ry < 1.0);
                assert_eq!(
                    buf.depth[j * w + i],
                    want,
                    "ball {k} ({p}, {r}), cell ({i}, {j})"
                );
            }
        }
    }
    assert!(
        filled_total > 10_000,
        "the test must fill cells: {filled_total}"
    );
    assert!(
        one_cell > 10,
        "the test must fill single cells of small discs: {one_cell}"
    );
}

#[test]
fn body_pose_of_one_body_equals_all_poses() {
    // A root path of up to 64 bodies is composed root first as `body_poses` does: the same
    // bits. The 1,000-link chain's deeper links take the upward composition (same pose up to
    // rounding); 20,000 links deep a recursive walk would overflow a 2 MiB test thread.
    for (file, floating) in [
        ("humanoid.urdf", true),
        ("plant.urdf", false),
        ("chain1000.urdf", false),
    ] {
        let model = load(file, floating);
        // Bodies on the root path, the body included (parents come first).
        let mut depth = vec![0usize; model.bodies.len()];
        for (i, b) in model.bodies.iter().enumerate() {
            depth[i] = 1 + b.parent.map_or(0, |j| depth[j]);
        }
        let mut poses = Vec::new();
        for seed in 0..3 {
            let s = State::random(&model, seed, 1.0);
            body_poses(&model, &s.q, &mut poses);
            for (i, &(r, p)) in poses.iter().enumerate() {
                let (r1, p1) = body_pose(&model, &s.q, i);
                if depth[i] <= 64 {
                    assert_eq!((r1, p1), (r, p), "{file} body {i}");
                } else {
                    let scale = 1.0 + p.length();
                    assert!((p1 - p).length() < 1e-10 * scale, "{file} body {i}");
                    let d = max_diff(r1, r);
                    assert!(d < 1e-10, "{file} body {i}: {d}");
                }
            }
        }
    }
    let deep = articula_testkit::chain(20_000);
    let q = vec![0.01; deep.nq];
    let mut poses = Vec::new();
    body_poses(&deep, &q, &mut poses);
    let (_, p) = body_pose(&deep, &q, deep.bodies.len() - 1);
    let p_all = poses.last().unwrap().1;
    assert!((p - p_all).length() < 1e-8 * (1.0 + p_all.length()));
}

#[test]
fn cell_indices_equal_floor_and_ceil() {
    let mut xs = vec![
        f64::NAN,
        f64::NEG_INFINITY,
        f64::INFINITY,
        -0.0,
        0.0,
        1e300,
        -1e300,
        4503599627370495.5,
        f64::EPSILON,
    ];
    for k in -400..=400 {
        let x = k as f64 * 0.25;
        xs.extend([x, x + 1e-12, x - 1e-12, f64::from_bits(x.to_bits() + 1)]);
    }
    // Above 2⁵² (where every f64 is an integer) the indices stop at the cap.
    let cap = |i: usize| i.min(1 << 52);
    for x in xs {
        assert_eq!(
            floor_index(x),
            cap(x.floor().max(0.0) as usize),
            "floor of {x}"
        );
        let c = ceil_index(x);
        assert_eq!(cap(c), cap(x.ceil().max(0.0) as usize), "ceil of {x}");
        assert!(c <= (1 << 52) + 1, "ceil of {x}");
    }
}
