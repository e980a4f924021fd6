//! Camera, frustum and projected size against analytic cases and independent computations.

use articula_view::{Camera, CameraPath, Keyframe};
use glam::{DMat3, DVec3};

fn cam() -> Camera {
    // At the origin looking along +x, z up, 60° vertical, 2:1.
    Camera::look_at(DVec3::ZERO, DVec3::X, DVec3::Z, 60.0, 2.0, 0.5, 100.0).unwrap()
}

/// A tiny deterministic generator.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    fn vec(&mut self, s: f64) -> DVec3 {
        DVec3::new(self.range(-s, s), self.range(-s, s), self.range(-s, s))
    }
}

#[test]
fn look_at_axes_and_projection() {
    let c = cam();
    assert!((c.forward() - DVec3::X).length() < 1e-15);
    // Right of a camera looking along +x with z up is −y.
    assert!((c.axes.x_axis + DVec3::Y).length() < 1e-15);
    assert!((c.axes.y_axis - DVec3::Z).length() < 1e-15);
    let t = (30f64).to_radians().tan();
    let (uv, depth) = c.project(DVec3::new(10.0, 0.0, 0.0)).unwrap();
    assert!(uv.length() < 1e-15 && (depth - 10.0).abs() < 1e-15);
    // The top edge of the image at depth 10 is 10 tan 30° up; the right edge twice as far, at −y.
    let (uv, _) = c.project(DVec3::new(10.0, 0.0, 10.0 * t)).unwrap();
    assert!((uv.y - 1.0).abs() < 1e-12 && uv.x.abs() < 1e-12);
    let (uv, _) = c.project(DVec3::new(10.0, -20.0 * t, 0.0)).unwrap();
    assert!((uv.x - 1.0).abs() < 1e-12 && uv.y.abs() < 1e-12);
    assert!(c.project(DVec3::new(-1.0, 0.0, 0.0)).is_none());
}

#[test]
fn frustum_planes_agree_with_projection() {
    // A point is inside every plane exactly when it projects into the image between near and far.
    let mut rng = Rng(7);
    let cams = [
        cam(),
        Camera::look_at(
            DVec3::new(3.0, -4.0, 2.0),
            DVec3::new(-1.0, 2.0, 0.5),
            DVec3::Z,
            45.0,
            1.5,
            0.1,
            30.0,
        )
        .unwrap(),
    ];
    for c in cams {
        let f = c.frustum();
        let (mut inside, mut outside) = (0, 0);
        for _ in 0..20000 {
            let p = c.position + rng.vec(40.0);
            let by_planes = f.planes.iter().all(|pl| pl.distance(p) >= 0.0);
            let by_projection = match c.project(p) {
                Some((uv, z)) => {
                    uv.x.abs() <= 1.0 && uv.y.abs() <= 1.0 && z >= c.near && z <= c.far
                }
                None => false,
            };
            // Points within 1e-9 of a plane may go either way.
            let near_boundary = f.planes.iter().any(|pl| pl.distance(p).abs() < 1e-9);
            if !near_boundary {
                assert_eq!(by_planes, by_projection, "{p}");
            }
            if by_planes {
                inside += 1
            } else {
                outside += 1
            }
        }
        assert!(inside > 100 && outside > 100, "{inside} {outside}");
    }
}

#[test]
fn sphere_test_at_the_right_plane() {
    // Right plane (at −y): a point (x, −y) at depth x is at signed distance
    // (x·t·aspect − y) / √(1 + (t·aspect)²).
    let c = cam();
    let f = c.frustum();
    let ta = 2.0 * (30f64).to_radians().tan();
    let (x, r) = (10.0, 0.5);
    let edge = x * ta; // |y| of the right edge at depth x
    let n = (1.0 + ta * ta).sqrt();
    // Centre outside by exactly r ± ε (signed distance −(r ± ε)).
    for (eps, expect) in [(1e-6, false), (-1e-6, true)] {
        let y = edge + (r + eps) * n;
        assert_eq!(f.sphere(DVec3::new(x, -y, 0.0), r), expect, "eps {eps}");
    }
    // Behind the eye, beyond far, before near.
    assert!(!f.sphere(DVec3::new(-2.0, 0.0, 0.0), 1.0));
    assert!(!f.sphere(DVec3::new(102.0, 0.0, 0.0), 1.0));
    assert!(f.sphere(DVec3::new(100.5, 0.0, 0.0), 1.0));
    assert!(!f.sphere(DVec3::new(0.2, 0.0, 0.0), 0.2));
    assert!(f.sphere(DVec3::new(0.2, 0.0, 0.0), 0.31));
}

#[test]
fn capsules_and_boxes_are_never_culled_while_a_point_of_them_is_inside() {
    // Soundness against sampling: whenever the test says "outside", no sampled point of the
    // volume is inside the frustum; and volumes with a sampled point inside are "inside".
    let c = cam();
    let f = c.frustum();
    let inside = |p: DVec3| f.planes.iter().all(|pl| pl.distance(p) >= 0.0);
    let mut rng = Rng(11);
    let (mut culled, mut kept) = (0, 0);
    for _ in 0..3000 {
        let a = DVec3::new(rng.range(-20.0, 60.0), 0.0, 0.0) + rng.vec(40.0);
        let b = a + rng.vec(8.0);
        let r = rng.range(0.0, 3.0);
        let verdict = f.capsule(a, b, r);
        let mut any = false;
        for i in 0..=20 {
            let p = a.lerp(b, i as f64 / 20.0);
            for _ in 0..10 {
                let d = rng.vec(1.0);
                let d = if d.length() > 1.0 { d / d.length() } else { d };
                any |= inside(p + d * r);
            }
        }
        if any {
            assert!(verdict, "capsule {a} {b} {r} has a point inside");
        }
        if verdict {
            kept += 1
        } else {
            culled += 1
        }
    }
    assert!(culled > 300 && kept > 300, "{culled} {kept}");
    // Boxes: random orientation.
    let (mut culled, mut kept) = (0, 0);
    for _ in 0..3000 {
        let center = DVec3::new(rng.range(-20.0, 60.0), 0.0, 0.0) + rng.vec(40.0);
        let axes = DMat3::from_euler(
            glam::EulerRot::ZYX,
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
        );
        let half = DVec3::new(
            rng.range(0.1, 4.0),
            rng.range(0.1, 4.0),
            rng.range(0.1, 4.0),
        );
        let verdict = f.oriented_box(center, axes, half);
        let mut any = false;
        for _ in 0..200 {
            let s = DVec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            any |= inside(center + axes * (s * half));
        }
        if any {
            assert!(verdict, "box at {center} has a point inside");
        }
        // A box whose every corner is outside the same plane is culled.
        let same_plane = f.planes.iter().any(|pl| {
            (0..8).all(|k| {
                let s = DVec3::new(
                    if k & 1 == 0 { -1.0 } else { 1.0 },
                    if k & 2 == 0 { -1.0 } else { 1.0 },
                    if k & 4 == 0 { -1.0 } else { 1.0 },
                );
                pl.distance(center + axes * (s * half)) < 0.0
            })
        });
        assert_eq!(!verdict, same_plane);
        if verdict {
            kept += 1
        } else {
            culled += 1
        }
    }
    assert!(culled > 300 && kept > 300, "{culled} {kept}");
}

#[test]
fn projected_size_is_the_silhouette_height() {
    // On the axis, the silhouette's top is the tangent point center + r (0, cos α, −sin α) in
    // camera coordinates, α = asin(r/d); its image height (as a fraction of the half-height)
    // is the projected diameter as a fraction of the full height.
    let c = cam();
    for (d, r) in [(10.0, 0.5), (3.0, 1.0), (50.0, 0.2)] {
        let alpha = f64::asin(r / d);
        let center = DVec3::new(d, 0.0, 0.0);
        // Camera y is world z here; camera z (depth) is world x.
        let tangent = center + DVec3::new(-r * alpha.sin(), 0.0, r * alpha.cos());
        let (uv, _) = c.project(tangent).unwrap();
        assert!(
            (c.projected_size(center, r) - uv.y).abs() < 1e-12,
            "{d} {r}"
        );
    }
    assert_eq!(
        c.projected_size(DVec3::new(0.1, 0.0, 0.0), 1.0),
        f64::INFINITY
    );
    // Twice as far: half the size (nearly: √(d² − r²)).
    let s1 = c.projected_size(DVec3::new(20.0, 0.0, 0.0), 0.1);
    let s2 = c.projected_size(DVec3::new(40.0, 0.0, 0.0), 0.1);
    assert!((s1 / s2 - 2.0).abs() < 1e-4);
}

#[test]
fn camera_errors_are_clear() {
    let e = |r: Result<Camera, articula_view::ViewError>| r.unwrap_err().to_string();
    let (o, x, z) = (DVec3::ZERO, DVec3::X, DVec3::Z);
    assert!(e(Camera::look_at(o, x, z, 0.0, 1.0, 0.1, 10.0)).contains("field of view"));
    assert!(e(Camera::look_at(o, x, z, 180.0, 1.0, 0.1, 10.0)).contains("field of view"));
    assert!(e(Camera::look_at(o, o, z, 60.0, 1.0, 0.1, 10.0)).contains("coincides"));
    assert!(e(Camera::look_at(o, z, z, 60.0, 1.0, 0.1, 10.0)).contains("parallel"));
    assert!(e(Camera::look_at(o, x, z, 60.0, 1.0, 1.0, 0.5)).contains("near"));
    assert!(e(Camera::look_at(o, x, z, 60.0, -1.0, 0.1, 10.0)).contains("aspect"));
    assert!(e(Camera::look_at(o, x * f64::NAN, z, 60.0, 1.0, 0.1, 10.0)).contains("finite"));
}

#[test]
fn camera_path_interpolates_and_holds() {
    let keys = vec![
        Keyframe {
            t: 0.0,
            eye: DVec3::new(0.0, 0.0, 1.0),
            target: DVec3::new(10.0, 0.0, 1.0),
        },
        Keyframe {
            t: 2.0,
            eye: DVec3::new(0.0, 4.0, 1.0),
            target: DVec3::new(10.0, 4.0, 1.0),
        },
    ];
    let path = CameraPath::new(keys.clone(), DVec3::Z, 60.0, 1.0, 0.1, 100.0).unwrap();
    assert_eq!(path.at(-1.0).unwrap().position, keys[0].eye);
    assert_eq!(path.at(5.0).unwrap().position, keys[1].eye);
    let mid = path.at(0.5).unwrap();
    assert!((mid.position - DVec3::new(0.0, 1.0, 1.0)).length() < 1e-15);
    assert!((mid.forward() - DVec3::X).length() < 1e-15);
    let mut bad = keys.clone();
    bad[1].t = 0.0;
    assert!(CameraPath::new(bad, DVec3::Z, 60.0, 1.0, 0.1, 100.0)
        .unwrap_err()
        .to_string()
        .contains("increase"));
    assert!(CameraPath::new(vec![], DVec3::Z, 60.0, 1.0, 0.1, 100.0).is_err());
}
