//! Visibility classes and joint weights from a camera.
//!
//! Per link (a model body: a URDF link plus those welded to it):
//! - **invisible**: its bounding sphere, grown by a motion margin (how far it may move before
//!   the next reselection), lies entirely outside one frustum plane;
//! - **occluded**: inside the frustum but hidden: every cell of a coarse depth buffer under its
//!   projected bounding sphere holds a depth nearer than the sphere's nearest point;
//! - **visible** otherwise.
//!
//! The depth buffer rasterises *occluders conservatively*: every link in the frustum is
//! approximated by balls inside its volumes ([`crate::Volume::inner_spheres`]); a ball writes its
//! far depth (centre depth + radius) into the cells lying wholly inside its projected disc (of
//! radius `r f / z`, smaller than the true perspective outline). A cell's depth is therefore
//! never nearer than the geometry really covering all of it, so a link is only called occluded
//! when it really is hidden (behind the balls' far sides, which is stricter still). The
//! *occludee* test is conservative the other way: the projected disc of the link's bounding
//! sphere is over-estimated (`r f / √(z² − r²)`) and compared at the sphere's nearest depth.
//!
//! Weights (the scalar `wᵢ` of the acceleration-metric weights `Aᵢ = wᵢ 1`): a link weighs
//! `s` when visible, `s · occluded_factor` when occluded and 0 when invisible, with `s` the
//! whole body's projected size relative to `full_detail_size` (capped at 1): distant bodies
//! weigh less. A joint weighs the largest weight of the links it moves (the subtree below it),
//! so a hidden hand does not switch off a visible elbow.

use crate::camera::Camera;
use crate::volumes::BodyVolumes;
use articula_dca::Threads;
use glam::{DMat3, DVec3};
use std::sync::Mutex;

/// How visibility turns into weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VisibilitySettings {
    /// Weight factor of an occluded link (0..=1).
    pub occluded_factor: f64,
    /// Projected size (fraction of the image height) from which a body gets full weight; a
    /// smaller body's weights are scaled by `size / full_detail_size`.
    pub full_detail_size: f64,
    /// Depth-buffer resolution (cells).
    pub depth_width: usize,
    /// Depth-buffer resolution (cells).
    pub depth_height: usize,
}

impl Default for VisibilitySettings {
    fn default() -> Self {
        VisibilitySettings {
            occluded_factor: 0.1,
            full_detail_size: 0.25,
            depth_width: 96,
            depth_height: 54,
        }
    }
}

/// A visibility class.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize),
    serde(rename_all = "snake_case")
)]
pub enum Visibility {
    /// In the frustum and not hidden.
    Visible,
    /// In the frustum, hidden behind other geometry.
    Occluded,
    /// Outside the frustum.
    Invisible,
}

/// Camera lengths at depth 1 → cells, per axis.
#[derive(Clone, Copy, Debug)]
struct Lens {
    fx: f64,
    fy: f64,
    /// The image centre in cells: half the buffer's width and height.
    half_width: f64,
    half_height: f64,
    /// World → camera rotation (the camera axes transposed) and the eye.
    rt: DMat3,
    eye: DVec3,
}

impl Lens {
    /// [`Camera::to_camera`] with the transpose done once.
    #[inline]
    fn camera_point(&self, p: DVec3) -> DVec3 {
        self.rt * (p - self.eye)
    }
}

/// A coarse depth buffer over the image (cells in rows, `f64::INFINITY` = empty).
#[derive(Clone, Debug)]
pub(crate) struct DepthBuffer {
    /// Width in cells.
    pub width: usize,
    /// Height in cells.
    pub height: usize,
    /// Depths, row-major from the top-left cell.
    pub depth: Vec<f64>,
    /// Scratch of the raster: `A(i)` of the columns of one ball (width + 1 entries).
    cols: Vec<f64>,
}

impl DepthBuffer {
    /// An empty buffer.
    pub fn new(width: usize, height: usize) -> DepthBuffer {
        let (width, height) = (width.max(1), height.max(1));
        DepthBuffer {
            width,
            height,
            depth: vec![f64::INFINITY; width * height],
            cols: vec![0.0; width + 1],
        }
    }

    /// Empties the buffer.
    pub fn clear(&mut self) {
        self.depth.iter_mut().for_each(|d| *d = f64::INFINITY);
    }

    /// Camera point → continuous cell coordinates (x from the left, y from the top) and the
    /// scale from camera lengths at depth 1 to cells.
    fn to_cells(&self, lens: &Lens, c: DVec3) -> (f64, f64, f64) {
        let (fx, fy) = (lens.fx, lens.fy);
        let x = (c.x / c.z) * fx + lens.half_width;
        let y = -(c.y / c.z) * fy + lens.half_height;
        (x, y, fx.min(fy))
    }

    /// The camera's scales for this buffer (computed once per classification: `tan` is not
    /// free).
    fn lens(&self, cam: &Camera) -> Lens {
        let t = cam.tan_half_fov();
        // Cells per unit of the image plane at depth 1 (vertical; cells are square in image
        // space only when width/height matches the aspect ratio: use each axis' own scale).
        Lens {
            fy: self.height as f64 / (2.0 * t),
            fx: self.width as f64 / (2.0 * t * cam.aspect),
            half_width: 0.5 * self.width as f64,
            half_height: 0.5 * self.height as f64,
            rt: cam.axes.transpose(),
            eye: cam.position,
        }
    }

    /// Writes a ball (world centre, radius) as an occluder: its far depth into every cell wholly
    /// inside its (under-estimated) projected disc.
    #[cfg(test)]
    pub fn rasterize_ball(&mut self, cam: &Camera, center: DVec3, radius: f64) {
        let lens = self.lens(cam);
        self.raster(cam, &lens, center, radius);
    }

    /// [`DepthBuffer::rasterize_ball`] with the lens computed once (inlined into the
    /// classification's loop over a link's balls: most balls of a crowd end in the one-cell
    /// test below).
    #[inline]
    fn raster(&mut self, cam: &Camera, lens: &Lens, center: DVec3, radius: f64) {
        let c = lens.camera_point(center);
        if c.z - radius <= cam.near || radius <= 0.0 {
            return;
        }
        let (fx, fy) = (lens.fx, lens.fy);
        let (x, y, _) = self.to_cells(lens, c);
        let (rx, ry) = (radius / c.z * fx, radius / c.z * fy);
        let far = c.z + radius;
        // Cells [i, i+1] × [j, j+1] wholly inside the ellipse ((u−x)/rx)² + ((v−y)/ry)² ≤ 1:
        // its four corners inside (the ellipse is convex), each tested as
        // `((u − x)/rx)² + ((v − y)/ry)² ≤ 1` in floating point. That test is monotone in
        // |u − x| and in |v − y| (rounding is monotone and symmetric), so a cell's four tests
        // pass exactly when the one at its corner farthest from the centre on both axes does.
        if rx < 1.0 && ry < 1.0 {
            // A small ellipse (most balls of a distant crowd): a cell with its four corners
            // inside has them within less than one cell of the centre on each axis, so it is
            // the cell holding the centre: test its farthest corner. (No cell can fit when
            // the centred unit square does not, `(0.5/rx)² + (0.5/ry)² > 1`: that corner is
            // at least half a cell away on both axes, so this test rejects it too.)
            // (The cell must lie in the buffer: 0 ≤ x < width, 0 ≤ y < height; NaN fails.)
            if !(x >= 0.0 && y >= 0.0 && x < as_f64(self.width) && y < as_f64(self.height)) {
                return;
            }
            let (i, j) = (floor_index(x), floor_index(y));
            let (u, v) = (as_f64(i), as_f64(j));
            let u = if x < u + 0.5 { u + 1.0 } else { u };
            let v = if y < v + 0.5 { v + 1.0 } else { v };
            let (a, b) = ((u - x) / rx, (v - y) / ry);
            if a * a + b * b <= 1.0 {
                let d = &mut self.depth[j * self.width + i];
                *d = if far < *d { far } else { *d };
            }
            return;
        }
        self.raster_wide(x, y, rx, ry, far);
    }

    /// [`DepthBuffer::raster`] of an ellipse at least one cell across on one axis (centre
    /// `(x, y)` and radii in cells, depth `far`).
    ///
    /// With `aa(u) = ((u − x)/rx)²` per corner column and `bb(v) = ((v − y)/ry)²` per grid
    /// line, cell (i, j) is inside when `A(i) + B(j) ≤ 1` for `A(i) = max(aa(i), aa(i + 1))`,
    /// `B(j) = max(bb(j), bb(j + 1))` (its farthest corner's test: the rounded sum is monotone
    /// in each term, so this is the largest of its four corner tests). `A` falls to the column
    /// holding x and rises after it, `B` likewise around y, so each row's cells are one run
    /// around x's column, the runs shrink row by row away from y's row, and the rows with
    /// cells are consecutive around it: the centre row's run is grown from x's column
    /// (computing `A` of the columns it reaches), then rows are walked from it outward, each
    /// run shrunk from the previous one's ends, until a row is empty — a few tests a row, one
    /// division per column reached and per grid line. (Nothing here is NaN: x, y, rx and ry
    /// are finite once the bounding box below is non-empty. The shortcut of the one-cell path,
    /// no cell when `(0.5/rx)² + (0.5/ry)² > 1`, is left out: it never applies to an ellipse
    /// this wide unless it is very eccentric.)
    #[inline(never)]
    fn raster_wide(&mut self, x: f64, y: f64, rx: f64, ry: f64, far: f64) {
        // Cells i0..i1 × j0..j1: those between the bounding box's corner columns and lines.
        let i0 = floor_index(x - rx);
        let i1 = ceil_index(x + rx).min(self.width);
        if i0 >= i1 {
            return;
        }
        let j0 = floor_index(y - ry);
        let j1 = ceil_index(y + ry).min(self.height);
        if j0 >= j1 {
            return;
        }
        let aa = |u: usize| {
            let a = (as_f64(u) - x) / rx;
            a * a
        };
        let bb = |v: usize| {
            let b = (as_f64(v) - y) / ry;
            b * b
        };
        let max = |p: f64, q: f64| if q > p { q } else { p };
        // A cell's test on the sum `A(i) + B(j)` (false for NaN).
        let fits = |sum: f64| sum <= 1.0;
        // The least A and B: the column and row holding the centre (clamped to the box).
        let ic = floor_index(x).clamp(i0, i1 - 1);
        let jc = floor_index(y).clamp(j0, j1 - 1);
        let (bc, bn) = (bb(jc), bb(jc + 1));
        let b = max(bc, bn);
        let (al, ar) = (aa(ic), aa(ic + 1));
        let a = max(al, ar);
        if !fits(a + b) {
            return;
        }
        // The centre row's run, with A of its columns in `cols[i − i0]`: later rows only
        // test columns inside it.
        let cols = &mut self.cols;
        cols[ic - i0] = a;
        let (mut lo, mut right) = (ic, al);
        while lo > i0 {
            let left = aa(lo - 1);
            let a = max(left, right);
            if !fits(a + b) {
                break;
            }
            lo -= 1;
            cols[lo - i0] = a;
            right = left;
        }
        let (mut hi, mut left) = (ic, ar);
        while hi + 1 < i1 {
            let right = aa(hi + 2);
            let a = max(left, right);
            if !fits(a + b) {
                break;
            }
            hi += 1;
            cols[hi - i0] = a;
            left = right;
        }
        let cols = &self.cols;
        let inside = |i: usize, b: f64| cols[i - i0] + b <= 1.0;
        let width = self.width;
        let depth = &mut self.depth;
        let mut write = |j: usize, lo: usize, hi: usize| {
            for d in &mut depth[j * width + lo..=j * width + hi] {
                *d = if far < *d { far } else { *d };
            }
        };
        write(jc, lo, hi);
        // A later row's run lies within the previous one's and holds ic when not empty.
        let shrink = |(mut lo, mut hi): (usize, usize), b: f64| {
            if !inside(ic, b) {
                return None;
            }
            while !inside(lo, b) {
                lo += 1;
            }
            while !inside(hi, b) {
                hi -= 1;
            }
            Some((lo, hi))
        };
        // Rows above (towards j0), the upper line's bb from one row to the next.
        let (mut run, mut upper) = ((lo, hi), bc);
        for j in (j0..jc).rev() {
            let top = bb(j);
            match shrink(run, max(upper, top)) {
                Some(r) => run = r,
                None => break,
            }
            write(j, run.0, run.1);
            upper = top;
        }
        // Rows below.
        let (mut run, mut lower) = ((lo, hi), bn);
        for j in jc + 1..j1 {
            let bottom = bb(j + 1);
            match shrink(run, max(lower, bottom)) {
                Some(r) => run = r,
                None => break,
            }
            write(j, run.0, run.1);
            lower = bottom;
        }
    }

    /// Whether a ball (world centre, radius) is hidden: every cell its (over-estimated)
    /// projected disc's bounding rectangle touches holds a depth nearer than the ball's nearest
    /// point. A ball reaching the near plane, or partly off the image, is never hidden by
    /// cells outside the image (they count as empty).
    #[cfg(test)]
    pub fn is_hidden(&self, cam: &Camera, center: DVec3, radius: f64) -> bool {
        self.hidden(cam, &self.lens(cam), center, radius)
    }

    fn hidden(&self, cam: &Camera, lens: &Lens, center: DVec3, radius: f64) -> bool {
        let c = lens.camera_point(center);
        let near = c.z - radius;
        if near <= cam.near {
            return false;
        }
        let (fx, fy) = (lens.fx, lens.fy);
        let (x, y, _) = self.to_cells(lens, c);
        let k = radius / (c.z * c.z - radius * radius).sqrt();
        let (rx, ry) = (k * fx, k * fy);
        let (xa, xb, ya, yb) = (x - rx, x + rx, y - ry, y + ry);
        if xa < 0.0 || ya < 0.0 || xb > as_f64(self.width) || yb > as_f64(self.height) {
            return false;
        }
        let (i0, i1) = (floor_index(xa), ceil_index(xb).min(self.width));
        let (j0, j1) = (floor_index(ya), ceil_index(yb).min(self.height));
        for j in j0..j1 {
            for i in i0..i1 {
                if self.depth[j * self.width + i] >= near {
                    return false;
                }
            }
        }
        true
    }
}

/// Largest cell index [`floor_index`] and [`ceil_index`] return (2⁵²: past any buffer; every
/// caller clamps to its width or height).
const INDEX_CAP: f64 = 4503599627370496.0;

/// `⌊x⌋` as a cell index, 0 below 0 (and for NaN), at most 2⁵²: `x.floor().max(0.0) as
/// usize` without the `floor` call (a library call on baseline x86-64; truncation is the floor
/// of x ≥ 0) nor the saturating conversion's range checks.
#[inline]
#[allow(clippy::manual_clamp)] // `clamp` keeps a NaN, which the conversion must not see
fn floor_index(x: f64) -> usize {
    // `max` turns NaN into 0; `min` keeps it in i64's range.
    let t = x.max(0.0).min(INDEX_CAP);
    // SAFETY: t is finite and in [0, 2⁵²], which i64 represents.
    unsafe { t.to_int_unchecked::<i64>() as usize }
}

/// `⌈x⌉` as a cell index, 0 below 0 (and for NaN), at most 2⁵² + 1: `x.ceil().max(0.0) as
/// usize` without the `ceil` call.
#[inline]
fn ceil_index(x: f64) -> usize {
    let t = floor_index(x);
    if as_f64(t) < x {
        t + 1
    } else {
        t
    }
}

/// A cell index (at most 2⁵² + 1) as a float, exactly: through `i64`, whose conversion is one
/// instruction on x86-64 (`usize`'s is not).
#[inline]
fn as_f64(i: usize) -> f64 {
    i as i64 as f64
}

/// One articulated body placed in the world, as visibility sees it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Placed<'a> {
    /// Its model's volumes (per model body).
    pub volumes: &'a [BodyVolumes],
    /// World pose of each model body: rotation and origin.
    pub poses: &'a [(DMat3, DVec3)],
    /// Parent of each model body (`None` at the root), for joint weights.
    pub parents: &'a [Option<usize>],
    /// How far (m) any point of the body may move before the next classification: grows the
    /// frustum test so that "invisible" means "cannot enter the view meanwhile".
    pub margin: f64,
}

/// What the camera sees of one articulated body.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BodyView {
    /// Summary: visible if any link is, else occluded if any link is, else invisible.
    pub class: Option<Visibility>,
    /// Per link (model body).
    pub links: Vec<Visibility>,
    /// Projected size of the whole body (fraction of the image height).
    pub projected_size: f64,
    /// Per link weight.
    pub link_weights: Vec<f64>,
    /// Per joint (= model body) weight: the largest link weight of its subtree.
    pub joint_weights: Vec<f64>,
}

impl BodyView {
    /// The summary class (invisible for a body without links).
    pub fn summary(&self) -> Visibility {
        self.class.unwrap_or(Visibility::Invisible)
    }
}

/// Scratch of [`Classifier::classify`], reused between calls.
#[derive(Debug)]
pub(crate) struct Classifier {
    /// The depth buffer of the last call (every thread's occluders).
    pub buffer: DepthBuffer,
    /// One per thread: see [`ClassWorker`].
    workers: Vec<Mutex<ClassWorker>>,
}

/// What one thread of a classification needs: the depth buffer its bodies' occluders are
/// rasterised into (the threads' buffers are merged cell by cell afterwards), the world
/// spheres of the body at hand and which of its links occlude.
#[derive(Debug)]
struct ClassWorker {
    buffer: DepthBuffer,
    world: Vec<(DVec3, f64)>,
    occluder: Vec<bool>,
}

impl Classifier {
    /// Scratch for the given settings.
    pub fn new(settings: &VisibilitySettings) -> Classifier {
        let buffer = DepthBuffer::new(settings.depth_width, settings.depth_height);
        Classifier {
            workers: vec![Mutex::new(ClassWorker {
                buffer: buffer.clone(),
                world: Vec::new(),
                occluder: Vec::new(),
            })],
            buffer,
        }
    }

    /// Classifies every link of every body and computes the weights (into `out`, one entry a
    /// body).
    #[cfg(test)]
    pub fn classify(
        &mut self,
        cam: &Camera,
        settings: &VisibilitySettings,
        bodies: &[Placed],
        out: &mut Vec<BodyView>,
    ) {
        let (threads, body) = (Threads::serial(), |b| bodies[b]);
        self.rasterize_with(cam, &threads, 1, bodies.len(), &body, out);
        self.occlude_with(cam, settings, &threads, 1, &body, out);
    }

    /// The first half of a classification of bodies `0..n`, body `b` given by `body(b)`: no
    /// list of the bodies to build. Frustum culling of every link into `out`, and the bodies'
    /// occluders into the depth buffer (`self.buffer`). The bodies are classified on
    /// `threads`, in chunks of `chunk` bodies ([`Threads::for_each_chunk`]): each thread
    /// rasterises its bodies' occluders into a depth buffer of its own, and the buffers are
    /// merged cell by cell, keeping the nearest depth — a minimum, which is the same whatever
    /// the order the balls were written in, so the buffer, and every class and weight, are the
    /// same bits for any thread count. A scene split over processes merges the processes'
    /// buffers the same way before [`Classifier::occlude_with`].
    pub fn rasterize_with<'a>(
        &mut self,
        cam: &Camera,
        threads: &Threads,
        chunk: usize,
        n: usize,
        body: &(impl Fn(usize) -> Placed<'a> + Sync),
        out: &mut Vec<BodyView>,
    ) {
        let frustum = cam.frustum();
        let lens = self.buffer.lens(cam);
        // Depth-buffer cells per unit length at depth 1 (the larger of the two axes' scales,
        // so that the skip below is conservative).
        let t = cam.tan_half_fov();
        let cells_per_unit = (self.buffer.height as f64 / (2.0 * t))
            .max(self.buffer.width as f64 / (2.0 * t * cam.aspect));
        let (width, height) = (self.buffer.width, self.buffer.height);
        self.workers.resize_with(threads.count(), || {
            Mutex::new(ClassWorker {
                buffer: DepthBuffer::new(width, height),
                world: Vec::new(),
                occluder: Vec::new(),
            })
        });
        for w in &mut self.workers {
            unlocked(w).buffer.clear();
        }
        out.resize_with(n, BodyView::default);
        let out = &mut out[..n];
        // 1. Frustum culling on world bounding spheres; occluders into the depth buffers.
        threads.for_each_chunk(out, &self.workers, chunk, |w, first, views| {
            for (j, view) in views.iter_mut().enumerate() {
                let placed = &body(first + j);
                let world = &mut w.world;
                world_spheres(placed, world);
                view.links.clear();
                // The whole body's sphere (also its projected size). When it lies well
                // inside every plane (`Frustum::holds_sphere`), so does each link's centre:
                // its least plane distance is at least 0, so both tests below pass for a link
                // of radius ≥ 0 and a margin ≥ 0 (NaN fails them) without the six plane
                // distances. (A link's centre is within `|c − centre| ≤ (its rounded value +
                // r)(1 + 1e-15)` of the body's centre, inside `radius (1 + 1e-12)`.)
                let (center, radius) = enclosing_sphere(world);
                view.projected_size = cam.projected_size(center, radius);
                let inside = placed.margin >= 0.0 && frustum.holds_sphere(center, radius);
                let occluder = &mut w.occluder;
                occluder.clear();
                for &(center, r) in world.iter() {
                    // Frustum::sphere with the margin and without, from one pass over the
                    // planes.
                    let (visible, occludes) = if inside && r >= 0.0 {
                        (true, true)
                    } else {
                        let d = frustum.nearest_plane_distance(center);
                        (d >= -(r + placed.margin), d >= -r)
                    };
                    view.links.push(if visible {
                        Visibility::Visible
                    } else {
                        Visibility::Invisible
                    });
                    occluder.push(visible && occludes);
                }
                for (((vol, &(rot, pos)), &(center, r)), _) in placed
                    .volumes
                    .iter()
                    .zip(placed.poses)
                    .zip(world.iter())
                    .zip(occluder.iter())
                    .filter(|(_, occludes)| **occludes)
                {
                    // Balls whose projected disc cannot hold a whole cell write nothing: skip
                    // volumes that thin at this distance (depth ≥ distance − r).
                    let depth = (cam.to_camera(center).z - r).max(cam.near);
                    let min_radius = 0.7 * depth / cells_per_unit;
                    for (inner, range) in &vol.inner {
                        if *inner >= min_radius {
                            for &(c, r) in &vol.balls[range.clone()] {
                                w.buffer.raster(cam, &lens, rot * c + pos, r);
                            }
                        }
                    }
                }
            }
        });
        // The threads' buffers into one: per cell the nearest depth (no depth is NaN: the
        // raster never writes one).
        let (first, rest) = self.workers.split_first_mut().expect("one worker at least");
        std::mem::swap(&mut self.buffer, &mut unlocked(first).buffer);
        for w in rest {
            for (d, e) in self.buffer.depth.iter_mut().zip(&unlocked(w).buffer.depth) {
                *d = if *e < *d { *e } else { *d };
            }
        }
    }

    /// The second half of a classification ([`Classifier::rasterize_with`] first): the occlusion test of every visible
    /// link of the bodies of `out` against the depth buffer, and the weights.
    pub fn occlude_with<'a>(
        &mut self,
        cam: &Camera,
        settings: &VisibilitySettings,
        threads: &Threads,
        chunk: usize,
        body: &(impl Fn(usize) -> Placed<'a> + Sync),
        out: &mut [BodyView],
    ) {
        let lens = self.buffer.lens(cam);
        // 2. Occlusion, weights.
        let buffer = &self.buffer;
        threads.for_each_chunk(out, &self.workers, chunk, |w, first, views| {
            for (j, view) in views.iter_mut().enumerate() {
                let placed = &body(first + j);
                let world = &mut w.world;
                world_spheres(placed, world);
                for (l, &(c, r)) in world.iter().enumerate() {
                    if view.links[l] == Visibility::Visible && buffer.hidden(cam, &lens, c, r) {
                        view.links[l] = Visibility::Occluded;
                    }
                }
                view.class = view.links.iter().copied().min();
                let s = (view.projected_size / settings.full_detail_size).min(1.0);
                view.link_weights.clear();
                view.link_weights.extend(view.links.iter().map(|c| match c {
                    Visibility::Visible => s,
                    Visibility::Occluded => s * settings.occluded_factor,
                    Visibility::Invisible => 0.0,
                }));
                view.joint_weights.clear();
                view.joint_weights.extend_from_slice(&view.link_weights);
                for i in (0..placed.parents.len()).rev() {
                    if let Some(p) = placed.parents[i] {
                        view.joint_weights[p] = view.joint_weights[p].max(view.joint_weights[i]);
                    }
                }
            }
        });
    }
}

/// A worker of a classifier held by nobody else (`&mut`: no call is running).
fn unlocked(w: &mut Mutex<ClassWorker>) -> &mut ClassWorker {
    w.get_mut().unwrap_or_else(|p| p.into_inner())
}

/// Each link's bounding sphere in the world (centre, radius), into `world`.
fn world_spheres(placed: &Placed, world: &mut Vec<(DVec3, f64)>) {
    world.clear();
    world.extend(
        placed
            .volumes
            .iter()
            .zip(placed.poses)
            .map(|(vol, &(rot, pos))| (rot * vol.bound.0 + pos, vol.bound.1)),
    );
}

/// A sphere enclosing the spheres `(centre, radius)`: centred on their mean, the radius the
/// largest `|cᵢ − centre| + rᵢ` (a body's whole sphere; centre 0 and radius 0 for none).
fn enclosing_sphere(spheres: &[(DVec3, f64)]) -> (DVec3, f64) {
    let n = spheres.len().max(1) as f64;
    let center = spheres.iter().map(|s| s.0).sum::<DVec3>() / n;
    let radius = spheres
        .iter()
        .map(|(c, r)| (*c - center).length() + r)
        .fold(0.0, f64::max);
    (center, radius)
}

/// World pose of body `i` of `model` at configuration `q` (rotation, origin): the pose-only
/// part of forward kinematics along the path from the root to `i`. Prepares a [`PosePlan`]
/// each call: for repeated calls keep one and use [`PosePlan::pose`].
#[cfg(test)]
pub(crate) fn body_pose(model: &articula_model::Model, q: &[f64], i: usize) -> (DMat3, DVec3) {
    PosePlan::new(model).pose(model, q, i)
}

/// World poses of every body of `model` at configuration `q` (rotation, origin), parents
/// first: the pose-only part of forward kinematics. Prepares a [`PosePlan`] each call: for
/// repeated calls keep one and use [`PosePlan::poses`].
#[cfg(test)]
pub(crate) fn body_poses(model: &articula_model::Model, q: &[f64], out: &mut Vec<(DMat3, DVec3)>) {
    PosePlan::new(model).poses(model, q, out);
}

/// The pose-only forward kinematics of one model, prepared once: per joint part, its origin
/// as a pose (absent when it is the identity: the massless links of a composed joint) and its
/// motion, a rotation about `±e_i` where the axis is a coordinate axis (the usual URDF case).
/// Its [`PosePlan::pose`] and [`PosePlan::poses`] give the same numbers as composing each
/// part's general transform (the products skipped are exact zeros and ones).
#[derive(Clone, Debug)]
pub struct PosePlan {
    /// Per model body: its parent and the range of its parts in `parts`.
    bodies: Vec<(Option<usize>, std::ops::Range<usize>)>,
    parts: Vec<PlanPart>,
}

#[derive(Clone, Copy, Debug)]
struct PlanPart {
    /// The part's origin as a pose (rotation, translation); `None` for the identity.
    origin: Option<(DMat3, DVec3)>,
    /// Whether that origin's rotation is the identity (a pure offset, the usual URDF joint):
    /// composing it then only moves the position (`r · 1` is `r`, up to the sign of zeros).
    offset_only: bool,
    motion: PlanMotion,
}

#[derive(Clone, Copy, Debug)]
enum PlanMotion {
    /// Rotation by `q[q]` about `sign · e_i`.
    Axis { i: usize, sign: f64, q: usize },
    /// Any other motion: part `part` of body `body`'s joint.
    General { body: usize, part: usize },
}

impl PosePlan {
    /// The plan of `model`.
    pub fn new(model: &articula_model::Model) -> PosePlan {
        let mut plan = PosePlan {
            bodies: Vec::with_capacity(model.bodies.len()),
            parts: Vec::new(),
        };
        for (b, body) in model.bodies.iter().enumerate() {
            let first = plan.parts.len();
            for (k, part) in body.joint.iter().enumerate() {
                let o = &part.origin;
                let origin = (o.e != DMat3::IDENTITY || o.r != DVec3::ZERO).then(|| o.to_pose());
                let motion = match part.coordinate_axis() {
                    Some((i, sign)) => PlanMotion::Axis {
                        i,
                        sign,
                        q: part.q_offset,
                    },
                    None => PlanMotion::General { body: b, part: k },
                };
                let offset_only = o.e == DMat3::IDENTITY;
                plan.parts.push(PlanPart {
                    origin,
                    offset_only,
                    motion,
                });
            }
            plan.bodies.push((body.parent, first..plan.parts.len()));
        }
        plan
    }

    /// World poses of every body at configuration `q`, parents first (`model`: the one the
    /// plan was made from).
    pub fn poses(&self, model: &articula_model::Model, q: &[f64], out: &mut Vec<(DMat3, DVec3)>) {
        out.clear();
        for (parent, parts) in &self.bodies {
            let (mut r, mut p) = match *parent {
                Some(i) => out[i],
                None => (DMat3::IDENTITY, DVec3::ZERO),
            };
            for part in &self.parts[parts.clone()] {
                self.compose(part, model, q, &mut r, &mut p);
            }
            out.push((r, p));
        }
    }

    /// World pose of body `i` at configuration `q`: its root path only.
    ///
    /// No recursion (a 100,000-link chain must not overflow the stack): a path of up to 64
    /// bodies is composed root first, exactly as [`PosePlan::poses`] does (the same numbers);
    /// a deeper one from `i` up, each body's joint on the left of what lies below it (the same
    /// pose up to rounding).
    pub fn pose(&self, model: &articula_model::Model, q: &[f64], i: usize) -> (DMat3, DVec3) {
        let mut path = [0usize; POSE_PATH];
        let mut depth = 0;
        let mut k = Some(i);
        while let Some(j) = k {
            if depth == POSE_PATH {
                return self.pose_upward(model, q, i);
            }
            path[depth] = j;
            depth += 1;
            k = self.bodies[j].0;
        }
        let (mut r, mut p) = (DMat3::IDENTITY, DVec3::ZERO);
        for &j in path[..depth].iter().rev() {
            for part in &self.parts[self.bodies[j].1.clone()] {
                self.compose(part, model, q, &mut r, &mut p);
            }
        }
        (r, p)
    }

    /// World position of the point `local` (body `i`'s coordinates) at configuration `q`:
    /// `x ← origin · motion(q) · x` for each joint part from body `i` up to the root, the
    /// point carried through each part instead of a pose composed down to it (a rotation about
    /// a coordinate axis mixes two coordinates). The same point as `r · local + p` of
    /// [`PosePlan::pose`] up to rounding, at about half the work: what a push needs.
    pub fn point(&self, model: &articula_model::Model, q: &[f64], i: usize, local: DVec3) -> DVec3 {
        let mut x = local;
        let mut k = Some(i);
        while let Some(j) = k {
            let (parent, parts) = &self.bodies[j];
            for part in self.parts[parts.clone()].iter().rev() {
                match part.motion {
                    PlanMotion::Axis { i, sign, q: qi } => {
                        // Rot(±e_i, q) x: the sign of the axis is the sign of the sine.
                        let (sn, cs) = q[qi].sin_cos();
                        let sn = sn * sign;
                        let DVec3 { x: u, y: v, z: w } = x;
                        x = match i {
                            0 => DVec3::new(u, cs * v - sn * w, sn * v + cs * w),
                            1 => DVec3::new(sn * w + cs * u, v, cs * w - sn * u),
                            _ => DVec3::new(cs * u - sn * v, sn * u + cs * v, w),
                        };
                    }
                    PlanMotion::General { body, part } => {
                        let jp = &model.bodies[body].joint[part];
                        let qj = &q[jp.q_offset..jp.q_offset + jp.nq()];
                        x = if jp.kind == articula_model::JointKind::Floating {
                            // Position, then the unit quaternion (w, x, y, z) normalised as
                            // `motion_transform` does, rotating the point directly.
                            let rot =
                                glam::DQuat::from_xyzw(qj[4], qj[5], qj[6], qj[3]).normalize();
                            rot * x + DVec3::new(qj[0], qj[1], qj[2])
                        } else {
                            // Every kind's own motion (`JointKind::motion_transform`).
                            let (rm, pm) = jp.motion_transform(qj).to_pose();
                            rm * x + pm
                        };
                    }
                }
                if let Some((ro, po)) = part.origin {
                    x = if part.offset_only { x } else { ro * x } + po;
                }
            }
            k = *parent;
        }
        x
    }

    /// [`PosePlan::pose`] from `i` up to the root: `(r, p) ← J_j · (r, p)` for each body `j`
    /// on the way, `J_j` the pose of its joint (origin · motion · … over its parts) in its
    /// parent.
    fn pose_upward(&self, model: &articula_model::Model, q: &[f64], i: usize) -> (DMat3, DVec3) {
        let (mut r, mut p) = (DMat3::IDENTITY, DVec3::ZERO);
        let mut k = Some(i);
        while let Some(j) = k {
            let (parent, parts) = &self.bodies[j];
            let (mut rj, mut pj) = (DMat3::IDENTITY, DVec3::ZERO);
            for part in &self.parts[parts.clone()] {
                self.compose(part, model, q, &mut rj, &mut pj);
            }
            p = rj * p + pj;
            r = rj * r;
            k = *parent;
        }
        (r, p)
    }

    /// `(r, p) ← (r, p) · origin · motion(q)` for one joint part.
    #[inline]
    fn compose(
        &self,
        part: &PlanPart,
        model: &articula_model::Model,
        q: &[f64],
        r: &mut DMat3,
        p: &mut DVec3,
    ) {
        if let Some((ro, po)) = part.origin {
            *p += *r * po;
            if !part.offset_only {
                *r *= ro;
            }
        }
        match part.motion {
            PlanMotion::Axis { i, sign, q: qi } => {
                // `r · Rot(±e_i, q)` mixes two of r's columns (the general product's other
                // terms are exact zeros and ones, and the sign of the axis is the sign of the
                // sine: the same numbers).
                let (x, y, z) = (r.x_axis, r.y_axis, r.z_axis);
                let (sn, cs) = q[qi].sin_cos();
                let sn = sn * sign;
                match i {
                    0 => (r.y_axis, r.z_axis) = (y * cs + z * sn, y * -sn + z * cs),
                    1 => (r.x_axis, r.z_axis) = (x * cs + z * -sn, x * sn + z * cs),
                    _ => (r.x_axis, r.y_axis) = (x * cs + y * sn, x * -sn + y * cs),
                }
            }
            PlanMotion::General { body, part } => {
                let jp = &model.bodies[body].joint[part];
                if jp.kind.is_hinge() {
                    *r *= DMat3::from_axis_angle(jp.axis, q[jp.q_offset])
                } else {
                    // Every kind's own motion (`JointKind::motion_transform`).
                    let (rm, pm) = jp
                        .motion_transform(&q[jp.q_offset..jp.q_offset + jp.nq()])
                        .to_pose();
                    *p += *r * pm;
                    *r *= rm;
                }
            }
        }
    }
}

/// Longest root path [`PosePlan::pose`] composes root first (on the stack).
const POSE_PATH: usize = 64;

#[cfg(test)]
mod tests;
