//! Directions from a scan point that cannot reach the hidden scene, told before they are traced.
//!
//! With hidden-geometry sampling off (mitransient's plugin default) a path leaves its scan point
//! on the relay wall in a cosine-weighted direction, and most of those directions meet nothing:
//! the hidden scene fills a small part of the hemisphere, yet each such ray was set up and
//! traced. A ray leaving a flat wall cannot meet that wall again, so everything it can meet lies
//! in one sphere bounding the rest of the scene, and from a scan point that sphere is a cone of
//! directions. Each scan point keeps its cone twice over:
//! - in the square of the warp's sample u, as a ring and a sector about the square's centre: the
//!   concentric map (Shirley & Chiu 1997) sends u's Chebyshev radius about the centre to the disk
//!   radius, sin θ of the direction, and each line through the centre to one azimuth, so u is
//!   tested before it is warped ([`ScanCone::may_reach_square`]);
//! - as the cone itself, for the directions that pass that test ([`ScanCone::may_reach`]).
//!
//! A sample turned down ends its path as its ray would have ended it, meeting nothing, and after
//! the same random numbers: the render is the same bit for bit. Every bound is widened by
//! `MARGIN`, far beyond the rounding of the warp, the frame and the ray's offset origin.
//!
//! With a camera as the sensor a pixel's first vertices spread over its footprint on the wall:
//! its cone is made from the central ray's point with the sphere widened by the footprint's reach
//! ([`pixel_footprints`]), and holds for a first vertex on that shape within it. Where the cone of
//! a pixel's own rays passes outside the sphere (or, for a camera inside a room, where nothing
//! else enters the pyramid of its rays up to the wall), the camera ray can meet the wall alone
//! ([`Footprints::sole_shapes`]), and where moreover the wall is a flat sheet whose outline lies
//! clear of the pixel's footprint, every one of its rays meets it ([`Footprints::covered`]): a
//! path's first direction can then be judged before its camera ray is traced. Line-of-sight
//! renders (`transient_path`) take the sole shapes as well: a camera ray of such a pixel is
//! tested against that shape's few triangles instead of the whole scene.

use crate::bsdf::Bsdf;
use crate::geometry::{Interaction, Prim, Ray};
use crate::math::{Frame, RAY_EPS, Spectrum};
use crate::parallel::map_indices;
use crate::scene::Scene;
use crate::sensor::Camera;
use glam::{Vec2, Vec3A};
use std::f32::consts::{FRAC_PI_2, PI};
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};

/// Widening of every angle of a cone (radians) and of its ring's radii.
const MARGIN: f32 = 1e-3;
/// Most primitives of a relay wall checked to lie behind each of its scan points (a rectangle has
/// two); a larger wall gets no cones.
const MAX_WALL_PRIMS: usize = 64;
/// Widest azimuth half-width a sector keeps (radians): below it the sector spans less than a
/// half-turn in the square as well (the map bends an angle by at most 0.071 rad per side).
const MAX_SECTOR: f32 = 1.4;

/// The directions from one scan point (or from anywhere within `reach` of it on its wall: a
/// camera pixel's footprint) that may meet something other than its wall.
#[derive(Clone, Copy, Debug)]
pub struct ScanCone {
    /// The scan point, its shape, and the squared distance from it within which a path's first
    /// vertex on that shape may leave by this cone.
    anchor: Vec3A,
    shape: u32,
    reach2: f32,
    /// The normal about which the cone's square sample is drawn.
    n: Vec3A,
    /// Least and greatest disk radius (sin θ about the sampling normal) of a direction in the
    /// cone.
    ring: [f32; 2],
    /// The sector's edges in the square, about its centre, counter-clockwise from the first (none
    /// where the cone holds every azimuth).
    sector: Option<[Vec2; 2]>,
    /// The cone's unit axis (world space).
    axis: Vec3A,
    /// Cosine of its half-angle.
    cos_half: f32,
}

impl ScanCone {
    /// The cone of the rays leaving `x`, or a point of its shape within `reach` of it, in a
    /// direction sampled about the normal `n` (on `x`'s side) towards the sphere
    /// `(center, radius)`; `None` where `x` is inside it.
    pub fn new(
        x: &Interaction,
        n: Vec3A,
        reach: f32,
        (center, radius): (Vec3A, f32),
    ) -> Option<Self> {
        // A ray starts within `reach` of x, and up to its offset from there
        // (`Interaction::offset_origin`): seen from x, the points it can reach lie in the sphere
        // widened by as much.
        let radius = radius + reach + 2.0 * (1.0 + x.p.abs().max_element() + reach) * RAY_EPS;
        let (axis, angle) = seen_from(x.p, (center, radius))?;
        let half = angle + MARGIN;
        let a = Frame::new(n).to_local(axis);
        let theta = a.z.clamp(-1.0, 1.0).acos();
        let (lo, hi) = (theta - half, theta + half);
        let ring = [
            if lo <= 0.0 {
                0.0
            } else if lo >= FRAC_PI_2 {
                f32::INFINITY // the cone lies below the surface: nothing is reached
            } else {
                lo.sin() - MARGIN
            },
            if hi >= FRAC_PI_2 {
                1.0
            } else {
                hi.sin() + MARGIN
            },
        ];
        // The azimuths of a cone that holds neither pole: its axis' azimuth φ ± asin(sin α / sin θ).
        let sector = (half.sin() < theta.sin())
            .then(|| (half.sin() / theta.sin()).asin() + MARGIN)
            .filter(|&width| width <= MAX_SECTOR)
            .map(|width| {
                let phi = a.y.atan2(a.x);
                [square_edge(phi - width), square_edge(phi + width)]
            });
        Some(Self {
            anchor: x.p,
            shape: x.shape,
            reach2: reach * reach,
            n,
            ring,
            sector,
            axis,
            cos_half: half.cos(),
        })
    }

    /// Whether a path's first vertex at `x` leaves by this cone: on its shape, within its reach.
    #[inline(always)]
    pub fn holds_at(&self, x: &Interaction) -> bool {
        x.shape == self.shape && (x.p - self.anchor).length_squared() <= self.reach2
    }

    /// Whether directions drawn about the normal `n` are the cone's: `n` is its own normal, to
    /// within rounding (the other side of a two-sided wall is not).
    #[inline(always)]
    pub fn drawn_about(&self, n: Vec3A) -> bool {
        (n - self.n).length_squared() <= 1e-10
    }

    /// Whether the square sample `u`, drawn about the cone's normal, may warp to a direction in
    /// the cone.
    #[inline(always)]
    pub fn may_reach_square(&self, u: Vec2) -> bool {
        // The concentric map's own first step (the same rounding).
        let q = Vec2::new(2.0 * u.x - 1.0, 2.0 * u.y - 1.0);
        let r = q.x.abs().max(q.y.abs());
        // Every test made, without branches between them: the caller's one branch on the answer
        // is the only one a sample can mispredict.
        let sector = match self.sector {
            Some([a, b]) => (a.perp_dot(q) >= 0.0) & (q.perp_dot(b) >= 0.0),
            None => true,
        };
        (r >= self.ring[0]) & (r <= self.ring[1]) & sector
    }

    /// Whether the unit direction `w` lies in the cone.
    #[inline(always)]
    pub fn may_reach(&self, w: Vec3A) -> bool {
        w.dot(self.axis) >= self.cos_half
    }
}

/// The line through the square's centre that the concentric map sends to azimuth `phi`: in the
/// wedge about +x it is the map's (1, (4/π)·φ), turned by the wedge's quarter turns elsewhere.
fn square_edge(phi: f32) -> Vec2 {
    let k = (phi / FRAC_PI_2).round();
    let v = Vec2::new(1.0, (phi - k * FRAC_PI_2) * (4.0 / PI));
    match (k as i32).rem_euclid(4) {
        0 => v,
        1 => v.perp(),
        2 => -v,
        _ => -v.perp(),
    }
}

/// Each scan point's cone — `(x, wi, reach)`: the point, the direction back to the sensor and how
/// far from it on its shape a path's first vertex may lie — where its path's first direction is
/// sampled by a diffuse BSDF about its geometric normal and its relay wall (a flat shape of at
/// most `MAX_WALL_PRIMS` triangles) lies behind it; `None` for the other scan points and for
/// those not in `pixels` (a render part's).
pub fn scan_cones(
    scene: &Scene,
    bsdfs: &[Bsdf<Spectrum>],
    scan_points: &[Option<(Interaction, Vec3A, f32)>],
    pixels: Range<usize>,
) -> Vec<Option<ScanCone>> {
    // The sphere around everything but each shape a scan point lies on, made once.
    let mut spheres = Spheres::default();
    for (x, _, _) in scan_points.iter().flatten() {
        spheres.around_all_but(scene, x.shape);
    }
    map_indices(scan_points.len(), |pixel| {
        let (x, wi, reach) = scan_points[pixel]
            .as_ref()
            .filter(|_| pixels.contains(&pixel))?;
        let n = bsdfs[x.shape as usize].diffuse_normal(x.ns, *wi)?;
        if !(n == x.ng || n == -x.ng) || !wall_behind(scene, x, n) {
            return None;
        }
        ScanCone::new(x, n, *reach, spheres.made(x.shape).flatten()?)
    })
}

/// What a camera's pixels see ([`pixel_footprints`]).
pub struct Footprints {
    /// Each pixel's footprint on what its central ray meets (`None` where it meets nothing): that
    /// point, the direction back to the camera, and the farthest from it that the pixel's corner
    /// rays meet its plane (any ray through the pixel meets that plane within it; a path whose
    /// first vertex lies farther, or elsewhere, leaves without a cone).
    pub points: Vec<Option<(Interaction, Vec3A, f32)>>,
    /// Per pixel, the one shape (of at most `MAX_WALL_PRIMS` primitives) its rays can meet:
    /// where the pixel's rays all pass outside the sphere around the rest of the scene, or where
    /// they all end on that planar shape and no other primitive enters their pyramid
    /// ([`pyramid_clear`]: a camera inside a room).
    pub sole_shapes: Vec<Option<u32>>,
    /// Per pixel with a sole shape, whether every one of its rays meets that shape: a flat sheet
    /// ([`Scene::is_flat`]) whose outline lies clear of the pixel's footprint, within the
    /// camera's clipping range.
    pub covered: Vec<bool>,
}

/// The footprints of a camera's pixels `pixels` (`None` for the others: a render part's). Stops
/// early, all `None`, once `cancel` is set.
pub fn pixel_footprints(
    scene: &Scene,
    camera: &Camera,
    cancel: &AtomicBool,
    pixels: Range<usize>,
) -> Footprints {
    let (w, h) = (scene.meter.film.width, scene.meter.film.height);
    // The corner rays, shared by the pixels around each corner.
    let corner =
        |i: usize, j: usize| camera.ray(Vec2::new(i as f32 / w as f32, j as f32 / h as f32));
    let corners: Vec<_> = (0..=h)
        .flat_map(|j| (0..=w).map(move |i| (i, j)))
        .map(|(i, j)| corner(i, j))
        .collect();
    let mut spheres = Spheres::default();
    let mut outlines: Vec<(u32, Option<Vec<[Vec3A; 2]>>)> = Vec::new();
    let mut in_rooms = Vec::new();
    let (mut points, mut sole_shapes, mut covered) = (
        Vec::with_capacity(w * h),
        Vec::with_capacity(w * h),
        Vec::with_capacity(w * h),
    );
    for pixel in 0..w * h {
        if pixel % 4096 == 4095 && cancel.load(Ordering::Relaxed) {
            return Footprints {
                points: vec![None; w * h],
                sole_shapes: vec![None; w * h],
                covered: vec![false; w * h],
            };
        }
        if !pixels.contains(&pixel) {
            points.push(None);
            sole_shapes.push(None);
            covered.push(false);
            continue;
        }
        let (px, py) = (pixel % w, pixel / w);
        let pixel_corners = [(px, py), (px + 1, py), (px, py + 1), (px + 1, py + 1)]
            .map(|(i, j)| &corners[j * (w + 1) + i]);
        let r = camera.pixel_ray(pixel, w, h, Vec2::splat(0.5));
        let Some(hit) = scene.accel.intersect(r.o, r.d, r.tmin, r.tmax) else {
            points.push(None);
            sole_shapes.push(None);
            covered.push(false);
            continue;
        };
        let x = scene.interaction(r.o, r.d, &hit);
        // Where the corner rays meet x's plane, in order around the pixel.
        let quad = plane_corners(&x, [0, 1, 3, 2].map(|k| pixel_corners[k]));
        points.push(quad.as_ref().map(|quad| {
            let reach = quad.iter().fold(0.0f32, |m, c| m.max((c.p - x.p).length()));
            let reach = reach * (1.0 + MARGIN) + 1e-6 * (1.0 + x.p.abs().max_element());
            (x, (r.o - x.p).normalize(), reach)
        }));
        // The pixel's rays lie within `spread` of its central one; they meet nothing but x's
        // shape if that cone passes outside the sphere around everything else.
        let spread = pixel_corners
            .iter()
            .map(|c| r.d.dot(c.d).clamp(-1.0, 1.0).acos())
            .fold(0.0f32, f32::max);
        let small = scene.shapes[x.shape as usize].prims.len() <= MAX_WALL_PRIMS;
        let clear_cone = small
            && spheres
                .around_all_but(scene, x.shape)
                .and_then(|sphere| seen_from(r.o, sphere))
                .is_some_and(|(axis, angle)| {
                    r.d.dot(axis).clamp(-1.0, 1.0).acos() > spread + angle + 2.0 * MARGIN
                });
        let few =
            scene.prims.len() - scene.shapes[x.shape as usize].prims.len() <= MAX_PYRAMID_PRIMS;
        // The planar shape's outline (made once per shape), if a test below needs it.
        let outline = (small && (clear_cone || few)).then(|| {
            outlines
                .iter()
                .position(|(s, _)| *s == x.shape)
                .unwrap_or_else(|| {
                    let outline = scene
                        .is_planar(x.shape as usize)
                        .then(|| planar_outline(scene, x.shape));
                    outlines.push((x.shape, outline));
                    outlines.len() - 1
                })
        });
        sole_shapes.push(clear_cone.then_some(x.shape));
        covered.push(
            clear_cone
                && scene.is_flat(x.shape as usize)
                && outline
                    .zip(quad.as_ref())
                    .is_some_and(|(k, quad)| meets_outline(camera, &outlines[k].1, &x, quad)),
        );
        // Inside a room the sphere around the rest holds the camera: then the rays, which end
        // on the shape, meet nothing else if they meet it inside its outline and no other
        // primitive enters the pyramid from the pinhole to their quadrilateral on it (tested
        // below, over the render's threads).
        if let (false, Some(k), Some(quad)) = (clear_cone, outline.filter(|_| few), quad) {
            in_rooms.push((pixel, x, r.o, quad, k));
        }
    }
    let boxes = if in_rooms.is_empty() {
        Vec::new()
    } else {
        shape_boxes(scene)
    };
    let clear = map_indices(in_rooms.len(), |i| {
        let (_, x, o, quad, k) = &in_rooms[i];
        meets_outline(camera, &outlines[*k].1, x, quad) && pyramid_clear(scene, &boxes, x, *o, quad)
    });
    for ((pixel, x, ..), clear) in in_rooms.iter().zip(clear) {
        if clear {
            sole_shapes[*pixel] = Some(x.shape);
            // Every ray meets the shape; its cone holds for them on a flat sheet alone.
            covered[*pixel] = scene.is_flat(x.shape as usize);
        }
    }
    Footprints {
        points,
        sole_shapes,
        covered,
    }
}

/// The outline of a planar shape's triangles: each edge not shared by two triangles on either side
/// of it (the same two vertices).
fn planar_outline(scene: &Scene, shape: u32) -> Vec<[Vec3A; 2]> {
    let prims = &scene.prims[scene.shapes[shape as usize].prims.clone()];
    let key = |v: Vec3A| v.to_array().map(f32::to_bits);
    // Each edge, its vertices in order of their bits, with the third vertex of every triangle on it.
    let mut edges: Vec<([Vec3A; 2], Vec<Vec3A>)> = Vec::new();
    for p in prims {
        let Prim::Triangle { v, .. } = p else {
            continue;
        };
        for (a, b, c) in [(0, 1, 2), (1, 2, 0), (2, 0, 1)] {
            let e = if key(v[a]) <= key(v[b]) {
                [v[a], v[b]]
            } else {
                [v[b], v[a]]
            };
            match edges.iter_mut().find(|(f, _)| f.map(key) == e.map(key)) {
                Some((_, thirds)) => thirds.push(v[c]),
                None => edges.push((e, vec![v[c]])),
            }
        }
    }
    edges
        .into_iter()
        .filter(|([a, b], thirds)| {
            let side = |c: &Vec3A| (*b - *a).cross(*c - *a);
            !(thirds.len() == 2 && side(&thirds[0]).dot(side(&thirds[1])) < 0.0)
        })
        .map(|(e, _)| e)
        .collect()
}

/// Where a corner ray of a pixel meets the plane of the central ray's point.
struct PlaneCorner {
    /// The point.
    p: Vec3A,
    /// Its distance along the ray.
    t: f32,
    /// The ray's near clip.
    tmin: f32,
}

/// Where the corner rays `rays` meet the plane of `x` (its geometric normal), each ahead; `None`
/// where one does not.
fn plane_corners(x: &Interaction, rays: [&Ray; 4]) -> Option<[PlaneCorner; 4]> {
    let corners = rays.map(|r| {
        let t = x.ng.dot(x.p - r.o) / x.ng.dot(r.d);
        PlaneCorner {
            p: r.o + r.d * t,
            t,
            tmin: r.tmin,
        }
    });
    corners
        .iter()
        .all(|c| c.t > 0.0 && c.t.is_finite())
        .then_some(corners)
}

/// Whether every ray through the pixel whose corner rays meet the plane of `x` (the central
/// ray's point on a planar shape with outline `outline`) at `quad`, in order around it, meets that
/// shape: the rays meet the plane within the camera's clipping range, in a quadrilateral that
/// holds `x` and that no edge of the outline comes near (so that it lies within the shape).
fn meets_inside(
    camera: &Camera,
    x: &Interaction,
    quad: &[PlaneCorner; 4],
    outline: &[[Vec3A; 2]],
) -> bool {
    let n = x.ng;
    let to_plane = n.dot(x.p - camera.origin);
    // The rays' distance to the plane is at least its distance from the pinhole, and at most the
    // corners' (1/t is concave over the pixel's directions ahead); a ray's near clip is at
    // most the corners' (it grows with the film coordinates' length).
    let corners = quad.each_ref().map(|c| c.p);
    let t_far = quad.iter().fold(0.0f32, |m, c| m.max(c.t));
    let near = quad.iter().fold(0.0f32, |m, c| m.max(c.tmin));
    let dist = (camera.origin - x.p).length();
    if !(to_plane.abs() > (near * (1.0 + MARGIN)).max(MARGIN * dist)
        && t_far * (1.0 + MARGIN) < camera.clip[1])
    {
        return false;
    }
    // Separating axes in the plane (Gottschalk et al. 1996): the normals of the quadrilateral's
    // edges and of the outline edge's; an edge separated from it by `gap` along one of them
    // cannot reach it.
    let gap = 1e-4 * (1.0 + x.p.abs().max_element());
    let span = |axis: Vec3A, points: &[Vec3A]| {
        points
            .iter()
            .map(|p| axis.dot(*p))
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), d| {
                (lo.min(d), hi.max(d))
            })
    };
    let apart = |axis: Vec3A, edge: &[Vec3A; 2]| {
        let axis = axis.normalize_or_zero();
        let ((q0, q1), (e0, e1)) = (span(axis, &corners), span(axis, edge));
        axis != Vec3A::ZERO && (e0 > q1 + gap || e1 < q0 - gap)
    };
    outline.iter().all(|edge| {
        (0..4).any(|k| apart(n.cross(corners[(k + 1) % 4] - corners[k]), edge))
            || apart(n.cross(edge[1] - edge[0]), edge)
    })
}

/// Most primitives besides a camera's wall for which [`pyramid_clear`] is tried (a room's few
/// walls and objects): it bounds the work per pixel.
const MAX_PYRAMID_PRIMS: usize = 256;

/// Whether no primitive but those of `x`'s shape enters the pyramid from the pinhole `o` to the
/// quadrilateral `quad` on `x`'s plane (in order around it), beyond which the pixel's rays do not
/// go: each shape's box (`boxes`, by shape), else each of its triangles, lies wholly outside one
/// of the pyramid's five planes, or the pyramid wholly on one side of the triangle's plane, by a
/// gap far beyond rounding (separating planes, Gottschalk et al. 1996); any other primitive
/// counts as entering.
fn pyramid_clear(
    scene: &Scene,
    boxes: &[[Vec3A; 2]],
    x: &Interaction,
    o: Vec3A,
    quad: &[PlaneCorner; 4],
) -> bool {
    let c = quad.each_ref().map(|c| c.p);
    let apex_and_base = [o, c[0], c[1], c[2], c[3]];
    // Outward unit normals and points of the four sides and of the base (the shape's plane,
    // facing away from the pinhole).
    let side = |k: usize| {
        let n = (c[k] - o).cross(c[(k + 1) % 4] - o).normalize_or_zero();
        // Outward: away from the quadrilateral's other corners.
        let inner = c[(k + 2) % 4] - o;
        if n.dot(inner) > 0.0 { -n } else { n }
    };
    let base = if x.ng.dot(o - x.p) > 0.0 { -x.ng } else { x.ng };
    let planes = [
        (base, x.p),
        (side(0), o),
        (side(1), o),
        (side(2), o),
        (side(3), o),
    ];
    if planes.iter().any(|(n, _)| *n == Vec3A::ZERO) {
        return false;
    }
    let scale = o.abs().max_element().max(x.p.abs().max_element());
    let gap = |points: &[Vec3A]| {
        1e-4 * (1.0
            + points
                .iter()
                .fold(scale, |m, v| m.max(v.abs().max_element())))
    };
    let outside = |points: &[Vec3A]| {
        let gap = gap(points);
        planes
            .iter()
            .any(|(n, at)| points.iter().all(|v| n.dot(*v - *at) > gap))
    };
    scene.shapes.iter().enumerate().all(|(k, shape)| {
        if k == x.shape as usize {
            return true;
        }
        let [lo, hi] = boxes[k];
        let corners: [Vec3A; 8] = std::array::from_fn(|i| {
            Vec3A::select(
                glam::BVec3A::new(i & 1 != 0, i & 2 != 0, i & 4 != 0),
                hi,
                lo,
            )
        });
        outside(&corners)
            || scene.prims[shape.prims.clone()].iter().all(|p| {
                let Prim::Triangle { v, .. } = p else {
                    return false;
                };
                let own = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
                let gap = gap(v);
                outside(v)
                    || own != Vec3A::ZERO && {
                        let d = apex_and_base.map(|q| own.dot(q - v[0]));
                        d.iter().all(|&d| d > gap) || d.iter().all(|&d| d < -gap)
                    }
            })
    })
}

/// Each shape's bounding box (low and high corners), by shape.
fn shape_boxes(scene: &Scene) -> Vec<[Vec3A; 2]> {
    scene
        .shapes
        .iter()
        .map(|s| {
            scene.prims[s.prims.clone()].iter().map(Prim::bounds).fold(
                [Vec3A::INFINITY, Vec3A::NEG_INFINITY],
                |[lo, hi], (a, b)| [lo.min(a), hi.max(b)],
            )
        })
        .collect()
}

/// Whether every ray of the pixel meets the planar shape of `outline` (`None` for a shape that
/// is not planar) inside it, within the clipping range ([`meets_inside`]).
fn meets_outline(
    camera: &Camera,
    outline: &Option<Vec<[Vec3A; 2]>>,
    x: &Interaction,
    quad: &[PlaneCorner; 4],
) -> bool {
    outline
        .as_ref()
        .is_some_and(|outline| meets_inside(camera, x, quad, outline))
}

/// The sphere `(center, radius)` seen from `p`: the unit direction to its centre and its angular
/// radius; `None` where `p` is inside it.
fn seen_from(p: Vec3A, (center, radius): (Vec3A, f32)) -> Option<(Vec3A, f32)> {
    let to = center - p;
    let dist = to.length();
    (dist > radius).then(|| (to / dist, (radius / dist).asin()))
}

/// Bounding spheres around all shapes but one, made once per shape left out.
#[derive(Default)]
struct Spheres(Vec<(u32, Option<(Vec3A, f32)>)>);

impl Spheres {
    fn around_all_but(&mut self, scene: &Scene, shape: u32) -> Option<(Vec3A, f32)> {
        match self.made(shape) {
            Some(sphere) => sphere,
            None => {
                let sphere = bounding_sphere(scene, shape as usize);
                self.0.push((shape, sphere));
                sphere
            }
        }
    }

    /// The sphere around everything but `shape`, if made already (and if there is one).
    fn made(&self, shape: u32) -> Option<Option<(Vec3A, f32)>> {
        self.0
            .iter()
            .find(|(s, _)| *s == shape)
            .map(|(_, sphere)| *sphere)
    }
}

/// Whether every vertex of `x`'s shape (triangles, at most `MAX_WALL_PRIMS`) lies behind the
/// plane through `x` facing `n`, or within a quarter of the ray offset in front of it: a ray
/// leaving `x` on `n`'s side stays at least its offset away from the shape.
fn wall_behind(scene: &Scene, x: &Interaction, n: Vec3A) -> bool {
    let prims = &scene.prims[scene.shapes[x.shape as usize].prims.clone()];
    let offset = (1.0 + x.p.abs().max_element()) * RAY_EPS;
    prims.len() <= MAX_WALL_PRIMS
        && prims.iter().all(|p| match p {
            Prim::Triangle { v, .. } => v.iter().all(|v| n.dot(*v - x.p) <= 0.25 * offset),
            _ => false,
        })
}

/// A sphere holding every primitive of the scene but shape `wall`'s (the centre of their box,
/// the radius to the farthest corner of any primitive's box), if there is one.
fn bounding_sphere(scene: &Scene, wall: usize) -> Option<(Vec3A, f32)> {
    let others = || {
        scene
            .shapes
            .iter()
            .enumerate()
            .filter(move |(k, _)| *k != wall)
            .flat_map(|(_, s)| scene.prims[s.prims.clone()].iter().map(Prim::bounds))
    };
    let (lo, hi) = others().fold(
        (Vec3A::INFINITY, Vec3A::NEG_INFINITY),
        |(lo, hi), (a, b)| (lo.min(a), hi.max(b)),
    );
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let center = (lo + hi) * 0.5;
    let radius = others()
        .map(|(a, b)| (a - center).abs().max((b - center).abs()).length())
        .fold(0.0f32, f32::max);
    Some((
        center,
        radius * (1.0 + 1e-4) + 1e-6 * (1.0 + center.abs().max_element()),
    ))
}
