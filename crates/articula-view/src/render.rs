//! Software rendering (tiny-skia) of a scene: the camera's view, with every rigid subassembly
//! of every body in its own colour, and a top-down map with the frustum and each body's
//! active-joint count. The pixels ([`render_view`], [`render_map`], [`save_png`]) need the
//! `render` feature (default on); [`FrameBody`] (what [`SceneSim::frame`](crate::SceneSim::frame)
//! gives) does not.

#[cfg(feature = "render")]
use crate::camera::Camera;
use crate::visibility::Visibility;
use crate::volumes::BodyVolumes;
#[cfg(feature = "render")]
use crate::volumes::Volume;
#[cfg(feature = "render")]
use glam::DVec2;
use glam::{DMat3, DVec3};
#[cfg(feature = "render")]
use tiny_skia::{Color, FillRule, Paint, PathBuilder, Pixmap, Stroke, Transform};

/// One body as the renderer needs it.
#[derive(Clone, Copy, Debug)]
pub struct FrameBody<'a> {
    /// Volumes of its model's bodies.
    pub volumes: &'a [BodyVolumes],
    /// World pose of each model body.
    pub poses: &'a [(DMat3, DVec3)],
    /// Rigid subassembly of each model body: the index of the top body of the subassembly that
    /// inactive joints join it to.
    pub groups: &'a [usize],
    /// A number that makes this body's colours its own (its index in the scene).
    pub seed: u64,
    /// Its visibility summary.
    pub class: Visibility,
    /// Its active joints.
    pub active_joints: usize,
}

/// The rigid subassembly of each model body: bodies joined by inactive joints share one; an
/// active joint starts a new one. `active[i]` tells whether body `i`'s joint is active
/// (`parents` as in the model; roots start their own group). Returns, per body, the index of
/// the top body of its subassembly.
pub(crate) fn rigid_groups(parents: &[Option<usize>], active: &[bool], out: &mut Vec<usize>) {
    out.clear();
    for (i, p) in parents.iter().enumerate() {
        let g = match p {
            Some(p) if !active[i] => out[*p],
            _ => i,
        };
        out.push(g);
    }
}

/// A pleasant, well-separated colour for a key (golden-ratio hues).
#[cfg(feature = "render")]
pub(crate) fn colour(key: u64) -> [u8; 3] {
    let mut z = key.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    let h = (z % 360) as f64;
    let s = 0.55 + 0.35 * ((z >> 16) % 100) as f64 / 100.0;
    let v = 0.75 + 0.25 * ((z >> 32) % 100) as f64 / 100.0;
    hsv(h, s, v)
}

#[cfg(feature = "render")]
fn hsv(h: f64, s: f64, v: f64) -> [u8; 3] {
    let c = v * s;
    let x = c * (1.0 - ((h / 60.0) % 2.0 - 1.0).abs());
    let (r, g, b) = match (h / 60.0) as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [
        ((r + m) * 255.0) as u8,
        ((g + m) * 255.0) as u8,
        ((b + m) * 255.0) as u8,
    ]
}

#[cfg(feature = "render")]
fn paint(rgb: [u8; 3], a: u8) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color_rgba8(rgb[0], rgb[1], rgb[2], a);
    p.anti_alias = true;
    p
}

/// A capsule in camera space clipped to the near plane, projected: end points (pixels), radii
/// (pixels), mean depth.
#[cfg(feature = "render")]
struct Projected {
    a: DVec2,
    b: DVec2,
    ra: f64,
    rb: f64,
    depth: f64,
    rgb: [u8; 3],
}

#[cfg(feature = "render")]
fn project_capsule(
    cam: &Camera,
    w: f64,
    h: f64,
    a: DVec3,
    b: DVec3,
    r: f64,
    rgb: [u8; 3],
) -> Option<Projected> {
    let (mut ca, mut cb) = (cam.to_camera(a), cam.to_camera(b));
    let near = cam.near;
    if ca.z < near && cb.z < near {
        return None;
    }
    if ca.z < near {
        ca = ca.lerp(cb, (near - ca.z) / (cb.z - ca.z));
    } else if cb.z < near {
        cb = cb.lerp(ca, (near - cb.z) / (ca.z - cb.z));
    }
    let f = h / (2.0 * cam.tan_half_fov());
    let px = |c: DVec3| DVec2::new(0.5 * w + c.x / c.z * f, 0.5 * h - c.y / c.z * f);
    Some(Projected {
        a: px(ca),
        b: px(cb),
        ra: r * f / ca.z,
        rb: r * f / cb.z,
        depth: 0.5 * (ca.z + cb.z),
        rgb,
    })
}

#[cfg(feature = "render")]
fn draw_capsule(pix: &mut Pixmap, c: &Projected) {
    let mut pb = PathBuilder::new();
    let d = c.b - c.a;
    if d.length() > 1e-6 {
        let n = DVec2::new(-d.y, d.x).normalize();
        let (p1, p2) = (c.a + n * c.ra, c.b + n * c.rb);
        let (p3, p4) = (c.b - n * c.rb, c.a - n * c.ra);
        pb.move_to(p1.x as f32, p1.y as f32);
        pb.line_to(p2.x as f32, p2.y as f32);
        pb.line_to(p3.x as f32, p3.y as f32);
        pb.line_to(p4.x as f32, p4.y as f32);
        pb.close();
    }
    pb.push_circle(c.a.x as f32, c.a.y as f32, c.ra.max(0.5) as f32);
    pb.push_circle(c.b.x as f32, c.b.y as f32, c.rb.max(0.5) as f32);
    if let Some(path) = pb.finish() {
        // Farther is dimmer (a little fog).
        let fog = (1.0 - (c.depth / 120.0)).clamp(0.35, 1.0);
        let rgb = c.rgb.map(|x| (x as f64 * fog + 200.0 * (1.0 - fog)) as u8);
        pix.fill_path(
            &path,
            &paint(rgb, 255),
            FillRule::Winding,
            Transform::identity(),
            None,
        );
        let edge = rgb.map(|x| (x as f64 * 0.55) as u8);
        let stroke = Stroke {
            width: 0.8,
            ..Stroke::default()
        };
        pix.stroke_path(
            &path,
            &paint(edge, 200),
            &stroke,
            Transform::identity(),
            None,
        );
    }
}

#[cfg(feature = "render")]
fn new_pixmap(width: u32, height: u32) -> Result<Pixmap, String> {
    Pixmap::new(width, height).ok_or_else(|| format!("cannot make a {width}×{height} image"))
}

/// The camera's view: a ground grid (z = 0), then every skeleton capsule of every body,
/// farthest first, each rigid subassembly in its own colour; a bar of digits in the corner
/// (active joints of the frame).
#[cfg(feature = "render")]
pub fn render_view(
    cam: &Camera,
    width: u32,
    height: u32,
    bodies: &[FrameBody],
    active_total: usize,
) -> Result<Pixmap, String> {
    let mut pix = new_pixmap(width, height)?;
    let (w, h) = (width as f64, height as f64);
    pix.fill(Color::from_rgba8(236, 238, 242, 255));
    // Ground grid.
    let grid = paint([190, 194, 202], 255);
    let stroke = Stroke {
        width: 1.0,
        ..Stroke::default()
    };
    let (cx, cy) = (cam.position.x.round(), cam.position.y.round());
    for k in -60..=60 {
        let k = k as f64 * 2.0;
        for (a, b) in [
            (
                DVec3::new(cx + k, cy - 120.0, 0.0),
                DVec3::new(cx + k, cy + 120.0, 0.0),
            ),
            (
                DVec3::new(cx - 120.0, cy + k, 0.0),
                DVec3::new(cx + 120.0, cy + k, 0.0),
            ),
        ] {
            if let Some(p) = project_capsule(cam, w, h, a, b, 0.0, [0; 3]) {
                let mut pb = PathBuilder::new();
                pb.move_to(p.a.x as f32, p.a.y as f32);
                pb.line_to(p.b.x as f32, p.b.y as f32);
                if let Some(path) = pb.finish() {
                    pix.stroke_path(&path, &grid, &stroke, Transform::identity(), None);
                }
            }
        }
    }
    let frustum = cam.frustum();
    let mut caps = Vec::new();
    for body in bodies {
        for (i, vol) in body.volumes.iter().enumerate() {
            let (rot, pos) = body.poses[i];
            let (c, r) = vol.bound;
            if !frustum.sphere(rot * c + pos, r) {
                continue;
            }
            let rgb = colour(
                body.seed
                    .wrapping_mul(1_000_003)
                    .wrapping_add(body.groups[i] as u64),
            );
            for v in &vol.skeleton {
                if let Volume::Capsule { a, b, radius } = v.transformed(rot, pos) {
                    caps.extend(project_capsule(cam, w, h, a, b, radius, rgb));
                }
            }
        }
    }
    caps.sort_by(|x, y| y.depth.total_cmp(&x.depth));
    for c in &caps {
        draw_capsule(&mut pix, c);
    }
    draw_number(&mut pix, 8.0, 8.0, 3.0, active_total, [40, 40, 40]);
    Ok(pix)
}

/// The top-down map: the scene's extent in x and y, the frustum's footprint, each body as a
/// disc (green visible, orange occluded, grey invisible) with its active-joint count.
#[cfg(feature = "render")]
pub fn render_map(cam: &Camera, size: u32, bodies: &[FrameBody]) -> Result<Pixmap, String> {
    let mut pix = new_pixmap(size, size)?;
    pix.fill(Color::from_rgba8(250, 250, 250, 255));
    let mut lo = cam.position.truncate();
    let mut hi = lo;
    let roots: Vec<DVec2> = bodies
        .iter()
        .map(|b| b.poses.first().map_or(DVec2::ZERO, |p| p.1.truncate()))
        .collect();
    for p in &roots {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let margin = 0.08 * (hi - lo).max_element().max(4.0);
    lo -= DVec2::splat(margin);
    hi += DVec2::splat(margin);
    let span = (hi - lo).max_element();
    let s = size as f64 / span;
    // World x to the right, y up.
    let px = |p: DVec2| DVec2::new((p.x - lo.x) * s, size as f64 - (p.y - lo.y) * s);
    // Frustum footprint: the horizontal half angle around the viewing direction.
    let fwd = cam.forward().truncate();
    if fwd.length() > 1e-6 {
        let fwd = fwd.normalize();
        let half = (cam.tan_half_fov() * cam.aspect).atan();
        let reach = cam.far.min(2.0 * span);
        let rotate = |v: DVec2, a: f64| {
            DVec2::new(v.x * a.cos() - v.y * a.sin(), v.x * a.sin() + v.y * a.cos())
        };
        let e = cam.position.truncate();
        let (l, r) = (
            e + rotate(fwd, half) * reach,
            e + rotate(fwd, -half) * reach,
        );
        let mut pb = PathBuilder::new();
        let (pe, pl, pr) = (px(e), px(l), px(r));
        pb.move_to(pe.x as f32, pe.y as f32);
        pb.line_to(pl.x as f32, pl.y as f32);
        pb.line_to(pr.x as f32, pr.y as f32);
        pb.close();
        if let Some(path) = pb.finish() {
            pix.fill_path(
                &path,
                &paint([120, 160, 255], 50),
                FillRule::Winding,
                Transform::identity(),
                None,
            );
            let stroke = Stroke {
                width: 1.5,
                ..Stroke::default()
            };
            pix.stroke_path(
                &path,
                &paint([60, 90, 200], 255),
                &stroke,
                Transform::identity(),
                None,
            );
        }
        if let Some(path) = PathBuilder::from_circle(pe.x as f32, pe.y as f32, 5.0) {
            pix.fill_path(
                &path,
                &paint([30, 50, 160], 255),
                FillRule::Winding,
                Transform::identity(),
                None,
            );
        }
    }
    let dot = (0.35 * s).clamp(2.0, 10.0);
    let digit = (dot * 0.45).clamp(1.0, 3.0);
    for (b, p) in bodies.iter().zip(&roots) {
        let q = px(*p);
        let rgb = match b.class {
            Visibility::Visible => [40, 170, 70],
            Visibility::Occluded => [240, 150, 30],
            Visibility::Invisible => [170, 170, 170],
        };
        if let Some(path) = PathBuilder::from_circle(q.x as f32, q.y as f32, dot as f32) {
            pix.fill_path(
                &path,
                &paint(rgb, 255),
                FillRule::Winding,
                Transform::identity(),
                None,
            );
        }
        if b.active_joints > 0 {
            draw_number(
                &mut pix,
                q.x + dot + 1.0,
                q.y - 2.5 * digit,
                digit,
                b.active_joints,
                [20, 20, 20],
            );
        }
    }
    Ok(pix)
}

/// 3×5 bitmap digits, one row per `u8` (3 low bits, the leftmost column the highest bit).
#[cfg(feature = "render")]
const DIGITS: [[u8; 5]; 10] = [
    [7, 5, 5, 5, 7],
    [2, 6, 2, 2, 7],
    [7, 1, 7, 4, 7],
    [7, 1, 7, 1, 7],
    [5, 5, 7, 1, 1],
    [7, 4, 7, 1, 7],
    [7, 4, 7, 5, 7],
    [7, 1, 1, 1, 1],
    [7, 5, 7, 5, 7],
    [7, 5, 7, 1, 7],
];

/// Draws `n` in bitmap digits with its top-left corner at (x, y), `cell` pixels per dot.
#[cfg(feature = "render")]
pub(crate) fn draw_number(pix: &mut Pixmap, x: f64, y: f64, cell: f64, n: usize, rgb: [u8; 3]) {
    let text = n.to_string();
    let p = paint(rgb, 255);
    let mut pb = PathBuilder::new();
    for (k, ch) in text.bytes().enumerate() {
        let d = DIGITS[(ch - b'0') as usize];
        let x0 = x + k as f64 * 4.0 * cell;
        for (row, bits) in d.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) != 0 {
                    if let Some(r) = tiny_skia::Rect::from_xywh(
                        (x0 + col as f64 * cell) as f32,
                        (y + row as f64 * cell) as f32,
                        cell as f32,
                        cell as f32,
                    ) {
                        pb.push_rect(r);
                    }
                }
            }
        }
    }
    if let Some(path) = pb.finish() {
        pix.fill_path(&path, &p, FillRule::Winding, Transform::identity(), None);
    }
}

/// Writes a PNG, through a temporary name in the same folder renamed when complete
/// ([`articula_model::AtomicFile`]): a killed run or a full disk never leaves a cut image
/// under `path`.
#[cfg(feature = "render")]
pub fn save_png(pix: &Pixmap, path: &std::path::Path) -> Result<(), String> {
    let error = |e: &dyn std::fmt::Display| format!("cannot write {}: {e}", path.display());
    let bytes = pix.encode_png().map_err(|e| error(&e))?;
    articula_model::AtomicFile::write(path, &bytes).map_err(|e| error(&e))
}

#[cfg(all(test, feature = "render"))]
mod tests;
