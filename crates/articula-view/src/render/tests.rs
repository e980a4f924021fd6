//! Frames: one colour per rigid subassembly, at the projected places of the bodies.

use super::{colour, render_map, render_view, rigid_groups, FrameBody};
use crate::visibility::body_poses;
use crate::volumes::body_volumes;
use crate::{Camera, Visibility};
use articula_model::{LoadOptions, Model};
use glam::DVec3;

fn humanoid() -> Model {
    let path =
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models/humanoid.urdf");
    Model::from_urdf_file(path, &LoadOptions::default().with_floating_base(true)).unwrap()
}

#[test]
fn rigid_groups_split_at_active_joints() {
    let m = humanoid();
    let parents: Vec<Option<usize>> = m.bodies.iter().map(|b| b.parent).collect();
    let elbow = m.bodies.iter().position(|b| b.name == "l_forearm").unwrap();
    let hand = m.bodies.iter().position(|b| b.name == "l_hand").unwrap();
    let mut active = vec![false; m.bodies.len()];
    active[elbow] = true;
    let mut g = Vec::new();
    rigid_groups(&parents, &active, &mut g);
    for (i, gi) in g.iter().enumerate() {
        let expect = if i == elbow || i == hand { elbow } else { 0 };
        assert_eq!(*gi, expect, "{}", m.bodies[i].name);
    }
    rigid_groups(&parents, &vec![true; m.bodies.len()], &mut g);
    assert_eq!(g, (0..m.bodies.len()).collect::<Vec<_>>());
}

/// The pixel at a world point.
fn pixel(img: &tiny_skia::Pixmap, cam: &Camera, p: DVec3) -> [u8; 3] {
    let (uv, _) = cam.project(p).unwrap();
    let (w, h) = (img.width() as f64, img.height() as f64);
    let x = ((uv.x + 1.0) * 0.5 * w) as u32;
    let y = ((1.0 - uv.y) * 0.5 * h) as u32;
    let c = img.pixel(x, y).unwrap();
    [c.red(), c.green(), c.blue()]
}

fn close(a: [u8; 3], b: [u8; 3]) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| (*x as i32 - y as i32).abs() <= 3)
}

#[test]
fn each_rigid_subassembly_has_its_own_colour() {
    let m = humanoid();
    let vols = body_volumes(&m);
    let parents: Vec<Option<usize>> = m.bodies.iter().map(|b| b.parent).collect();
    let mut q = m.neutral_q();
    q[0] = 4.0; // 4 m in front of the camera, facing it
    let mut poses = Vec::new();
    body_poses(&m, &q, &mut poses);
    let cam = Camera::look_at(
        DVec3::new(0.0, 0.0, 0.3),
        DVec3::new(4.0, 0.0, 0.3),
        DVec3::Z,
        50.0,
        4.0 / 3.0,
        0.1,
        100.0,
    )
    .unwrap();
    let head = m.bodies.iter().position(|b| b.name == "head").unwrap();
    let thigh = m.bodies.iter().position(|b| b.name == "l_thigh").unwrap();
    let shank = m.bodies.iter().position(|b| b.name == "l_shank").unwrap();
    let head_point = poses[head].0 * m.bodies[head].inertia.com() + poses[head].1;
    // The middle of the thigh's skeleton capsule (hip to knee): clear of the capsules' outlines.
    let thigh_point = (poses[thigh].1 + poses[shank].1) * 0.5;
    // The renderer's fog at depth d: rgb · f + 200 (1 − f), f = 1 − d/120.
    let fogged = |rgb: [u8; 3], d: f64| {
        let f = 1.0 - d / 120.0;
        rgb.map(|x| (x as f64 * f + 200.0 * (1.0 - f)) as u8)
    };
    let background = [236, 238, 242];
    for neck_active in [false, true] {
        let mut active = vec![false; m.bodies.len()];
        active[head] = neck_active;
        let mut groups = Vec::new();
        rigid_groups(&parents, &active, &mut groups);
        let body = FrameBody {
            volumes: &vols,
            poses: &poses,
            groups: &groups,
            seed: 7,
            class: Visibility::Visible,
            active_joints: if neck_active { 3 } else { 0 },
        };
        let img = render_view(&cam, 400, 300, &[body], 0).unwrap();
        let ph = pixel(&img, &cam, head_point);
        let pc = pixel(&img, &cam, thigh_point);
        assert!(!close(ph, background) && !close(pc, background));
        let key = |g: usize| 7u64.wrapping_mul(1_000_003).wrapping_add(g as u64);
        // Depths of the two points (the capsules' mean depths are within a few cm of them).
        let (dh, dc) = (cam.to_camera(head_point).z, cam.to_camera(thigh_point).z);
        assert!(
            close(pc, fogged(colour(key(0)), dc)),
            "thigh {pc:?} vs {:?}",
            fogged(colour(key(0)), dc)
        );
        if neck_active {
            assert!(close(ph, fogged(colour(key(head)), dh)), "head {ph:?}");
            assert!(!close(ph, pc), "the head's subassembly has its own colour");
        } else {
            assert!(close(ph, fogged(colour(key(0)), dh)), "head {ph:?}");
        }
        // Off the body: background or ground grid, not a body colour.
        let aside = pixel(&img, &cam, DVec3::new(4.0, 1.5, 1.2));
        assert!(close(aside, background), "{aside:?}");
        render_map(&cam, 200, &[body]).unwrap();
    }
}
