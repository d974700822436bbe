//! Shadow rays and traces a render can answer without tracing: the faces nothing stands in
//! front of. A plane that has a set of points strictly on one side, and on that side no primitive
//! a shadow ray tests, separates every segment from those points to the triangle in it from
//! every such primitive: the segment stays strictly on that side, where nothing lies. A primitive
//! on that side but apart from the box around the points and the triangle, which holds every
//! segment between them, is out of reach too (the secondary wall of a two-corner scene, whose
//! occluder stands beside that box). So the connections of a capture's scan points and laser
//! spots to that triangle are unoccluded, and need no shadow ray. Likewise a ray that leaves a
//! triangle on a side of its plane where no hidden geometry lies meets none: the BSDF draw of the
//! mixture at hidden vertices ([`super::hidden_mixture`]), which keeps only hidden geometry, ends
//! there untraced, and a vertex whose every side its BSDF leaves by is such a side ends its path
//! before any draw.
//!
//! The other way round, a face can be proved hidden from every scan point (or laser spot): a
//! planar shape whose triangles make one convex polygon (a rectangle: the occluder of a
//! two-corner scene) blocks every segment between two convex sets that lie beyond its plane on
//! either side when each segment's crossing of that plane falls inside the polygon. The
//! crossings make a convex set, the plane's section of the hull of both sets, whose corners are
//! the crossings of the segments between their corners; so it is enough that the 64 crossings
//! between the corners of the points' box and of the face's box lie inside each outline edge.
//! Where two of its triangles share an edge, a ray through that edge meets one of them
//! (the watertight test); at the outline a margin keeps the rays' rounding inside. A vertex there
//! then connects to no scan point (the T behind two corners: no shadow ray from the relay wall
//! to it).
//!
//! The Z behind one corner is the case in point: its front faces look at the relay wall with
//! nothing in between (the wall itself, on the scan points' plane, is skipped by their shadow rays),
//! and a ray from a front face towards the wall meets no other part of the Z. A single scan point
//! rendered about 1.35× as fast (two shadow rays and half a trace of its typical path gone), the
//! Z's single capture about 1.6×, with the same bits (docs/architecture.md, "The BVH").
//!
//! The answers are those the rays would give. Distances are taken in f64 from the f32
//! vertices; a primitive within `e` = 5·10⁻⁷·(1 + C) of a plane (C the scene's largest
//! coordinate) counts as on it, as f32 rounding leaves the corners of a flat sheet or a point
//! drawn on a triangle. A shadow ray starts `RAY_EPS`·(1 + |p|) off its surface and ends
//! `SHADOW_EPS` of its length short of its target ([`crate::geometry::shadow_segment`]), so
//! the points are asked to lie at least 5e/`SHADOW_EPS` from the plane, and the scene to be
//! small enough (C < 28) that the offset is beyond 5e: every tested segment then keeps farther
//! than 4e from the plane, out of reach of anything on it or behind it. A traced ray is skipped
//! only where its direction leaves the plane clearly (the offset side, by more than 10⁻⁴).

use crate::geometry::{Interaction, Prim, bvh::NO_PLANE};
use crate::math::{RAY_EPS, SHADOW_EPS};
use crate::parallel::map_indices;
use crate::scene::{AreaSampler, Scene};
use glam::{DVec3, Vec2, Vec3A};

/// Most primitives a scene may have to be judged here (each face against every primitive).
pub const MAX_PRIMS: usize = 1024;
/// Largest coordinate for which the shadow rays' offsets clear the rounding margin (see above).
const MAX_COORDINATE: f64 = 28.0;

// A primitive's flags: every scan point sees it whole; every laser spot does; no hidden geometry
// lies beyond its front (the side its interactions' normal points to); none beyond its back.
const FROM_SCAN: u8 = 1;
const FROM_SPOTS: u8 = 2;
const OPEN_FRONT: u8 = 4;
const OPEN_BACK: u8 = 8;
// Every scan point's shadow ray to any point of it is blocked; every laser spot's is.
const HIDDEN_FROM_SCAN: u8 = 16;
const HIDDEN_FROM_SPOTS: u8 = 32;

/// Which triangles the scan points and the laser spots see whole, and which sides of each
/// triangle have no hidden geometry beyond them: flags per primitive (none for a scene too large
/// to judge).
#[derive(Default)]
pub struct ClearView {
    flags: Vec<u8>,
}

/// Points that shadow rays connect faces to (the scan points or the laser spots): their bounding
/// box and the plane key of the surface they all lie on (skipped by their shadow rays), if one.
struct Viewpoints {
    low: DVec3,
    high: DVec3,
    key: u32,
}

impl Viewpoints {
    fn of<'a>(scene: &Scene, points: impl Iterator<Item = &'a Interaction>) -> Option<Self> {
        let mut it = points.peekable();
        let first = it.peek()?;
        let key = scene.accel.plane_of(first.shape);
        let mut v = Self {
            low: first.p.as_dvec3(),
            high: first.p.as_dvec3(),
            key,
        };
        for p in it {
            v.low = v.low.min(p.p.as_dvec3());
            v.high = v.high.max(p.p.as_dvec3());
            if scene.accel.plane_of(p.shape) != v.key {
                v.key = NO_PLANE;
            }
        }
        // The shadow rays' origins, offset off these points' surfaces.
        let offset = (1.0 + v.low.abs().max(v.high.abs()).max_element()) * RAY_EPS as f64;
        v.low -= offset;
        v.high += offset;
        Some(v)
    }

    /// The side of the plane `n·x = d` all the box lies on, farther than `margin` (0: along
    /// n, 1: against it), if one.
    fn side(&self, n: DVec3, d: f64, margin: f64) -> Option<usize> {
        let (lo, hi) = extent_of_box(self.low, self.high, n, d);
        if lo > margin {
            Some(0)
        } else if hi < -margin {
            Some(1)
        } else {
            None
        }
    }
}

/// The range of `n·x − d` over the box [low, high].
fn extent_of_box(low: DVec3, high: DVec3, n: DVec3, d: f64) -> (f64, f64) {
    let (a, b) = (n * low, n * high);
    let (lo, hi) = (a.min(b), a.max(b));
    (lo.element_sum() - d, hi.element_sum() - d)
}

/// The range of `n·x − d` over a primitive's points.
fn extent(prim: &Prim, n: DVec3, d: f64) -> (f64, f64) {
    match prim {
        Prim::Triangle { v, .. } => v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |r, v| {
            let s = n.dot(v.as_dvec3()) - d;
            (r.0.min(s), r.1.max(s))
        }),
        Prim::Sphere { center, radius } => {
            let c = n.dot(center.as_dvec3()) - d;
            (c - *radius as f64, c + *radius as f64)
        }
        Prim::Disk { inv } => {
            // The unit disk's image: its centre ± the reach of its two mapped axes along n.
            let m = inv.inverse();
            let c = n.dot(m.translation.as_dvec3()) - d;
            let (a, b) = (
                n.dot(m.matrix3.x_axis.as_dvec3()),
                n.dot(m.matrix3.y_axis.as_dvec3()),
            );
            let r = (a * a + b * b).sqrt();
            (c - r, c + r)
        }
    }
}

/// A planar shape whose triangles make one convex polygon: its plane n·x = d (n unit) and its
/// outline, each edge as a point on it and its unit normal in the plane, pointing inwards.
struct Blocker {
    shape: usize,
    n: DVec3,
    d: f64,
    outline: Vec<(DVec3, DVec3)>,
}

impl Blocker {
    /// Shape `shape` as a blocker: planar ([`Scene::is_planar`]; every vertex within `e` of the
    /// plane of its first triangle), each edge shared by at most two triangles, which lie on
    /// either side of it, and convex (every vertex within `e` inside every outline edge, so the
    /// polygon is the intersection of their inner sides).
    fn of(scene: &Scene, shape: usize, e: f64) -> Option<Self> {
        if !scene.is_planar(shape) {
            return None;
        }
        let tris: Vec<[Vec3A; 3]> = scene.prims[scene.shapes[shape].prims.clone()]
            .iter()
            .map(|p| match p {
                Prim::Triangle { v, .. } => Some(*v),
                _ => None,
            })
            .collect::<Option<_>>()?;
        let [a, b, c] = tris.first()?.map(|v| v.as_dvec3());
        let n = (b - a).cross(c - a).normalize_or_zero();
        let d = n.dot(a);
        let vertices = || tris.iter().flatten().map(|v| v.as_dvec3());
        if n == DVec3::ZERO || vertices().any(|v| (n.dot(v) - d).abs() > e) {
            return None;
        }
        // Each edge keyed by its ends' bits (shared edges have the same vertices, bit for bit),
        // with its ends and the third vertex of its triangle.
        let key = |v: Vec3A| v.to_array().map(f32::to_bits);
        let mut edges: Vec<_> = tris
            .iter()
            .flat_map(|t| {
                (0..3).map(move |k| {
                    let (p, q, r) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                    let (p, q) = if key(p) <= key(q) { (p, q) } else { (q, p) };
                    ((key(p), key(q)), [p, q, r].map(|v| v.as_dvec3()))
                })
            })
            .collect();
        edges.sort_by_key(|(k, _)| *k);
        let mut outline = Vec::new();
        for run in edges.chunk_by(|x, y| x.0 == y.0) {
            let [p, q, r] = run[0].1;
            let side = |r: DVec3| n.dot((q - p).cross(r - p));
            match run {
                [_] => {
                    let m = n.cross(q - p).normalize_or_zero();
                    outline.push((p, if m.dot(r - p) < 0.0 { -m } else { m }));
                }
                [_, other] if side(r) * side(other.1[2]) < 0.0 => {}
                _ => return None,
            }
        }
        let convex = outline
            .iter()
            .all(|&(p, m)| m != DVec3::ZERO && vertices().all(|v| m.dot(v - p) >= -e));
        convex.then_some(Self {
            shape,
            n,
            d,
            outline,
        })
    }

    /// Whether every shadow ray between a point of box `a` and a point of box `b` (either way
    /// round; both boxes hold the rays' offset origins) meets the polygon: both boxes lie beyond
    /// its plane on either side by more than the rays' shortening and the margin 5e, and the
    /// crossings between their corners lie inside every outline edge by 20e, widened where the
    /// segments run slanted to the plane (a direction's rounding moves a crossing farther).
    fn blocks(&self, a: &[DVec3; 2], b: &[DVec3; 2], e: f64) -> bool {
        let (ca, cb) = (corners(a), corners(b));
        let reach = (a[1].max(b[1]) - a[0].min(b[0])).length();
        let beyond = 2.0 * SHADOW_EPS as f64 * reach + 5.0 * e;
        let (sa, sb) = (
            ca.map(|c| self.n.dot(c) - self.d),
            cb.map(|c| self.n.dot(c) - self.d),
        );
        let apart = |s: &[f64; 8], sign: f64| s.iter().all(|&v| v * sign > beyond);
        let sign = if sa[0] > 0.0 { 1.0 } else { -1.0 };
        if !(apart(&sa, sign) && apart(&sb, -sign)) {
            return false;
        }
        let gap = sa
            .iter()
            .chain(&sb)
            .map(|v| v.abs())
            .fold(f64::INFINITY, f64::min);
        let inside = 20.0 * e * (1.0 + reach / (2.0 * gap));
        (0..64).all(|k| {
            let (i, j) = (k / 8, k % 8);
            let c = ca[i] + (cb[j] - ca[i]) * (sa[i] / (sa[i] - sb[j]));
            self.outline.iter().all(|&(p, m)| m.dot(c - p) >= inside)
        })
    }
}

/// The eight corners of the box [low, high].
fn corners([lo, hi]: &[DVec3; 2]) -> [DVec3; 8] {
    std::array::from_fn(|i| {
        DVec3::new(
            if i & 1 != 0 { hi.x } else { lo.x },
            if i & 2 != 0 { hi.y } else { lo.y },
            if i & 4 != 0 { hi.z } else { lo.z },
        )
    })
}

/// A primitive's bounding box [low, high] (its extent along each axis).
fn bounding_box(prim: &Prim) -> [DVec3; 2] {
    let [x, y, z] = [DVec3::X, DVec3::Y, DVec3::Z].map(|a| extent(prim, a, 0.0));
    [DVec3::new(x.0, y.0, z.0), DVec3::new(x.1, y.1, z.1)]
}

/// The rounding margin e of a scene whose largest coordinate, counting `reach` (the viewpoints'),
/// is C; `None` for a scene of more than [`MAX_PRIMS`] primitives or beyond [`MAX_COORDINATE`].
fn rounding_margin(scene: &Scene, reach: f64) -> Option<f64> {
    if scene.prims.len() > MAX_PRIMS {
        return None;
    }
    let c = scene
        .prims
        .iter()
        .flat_map(|p| [DVec3::X, DVec3::Y, DVec3::Z].map(|a| extent(p, a, 0.0)))
        .fold(reach, |m, (lo, hi)| m.max(lo.abs()).max(hi.abs()));
    (c < MAX_COORDINATE).then_some(5e-7 * (1.0 + c))
}

/// The plane n·x = d of primitive `i`, n oriented as its interactions' normal (flip_normals
/// included), if it is a triangle with one.
fn face_plane(scene: &Scene, i: usize) -> Option<(DVec3, f64)> {
    let Prim::Triangle { v, .. } = &scene.prims[i] else {
        return None;
    };
    let [a, b, c] = v.map(|v| v.as_dvec3());
    let shape = scene.prim_shape[i] as usize;
    let n = (b - a).cross(c - a).normalize_or_zero() * scene.normal_sign(shape) as f64;
    (n != DVec3::ZERO).then(|| (n, n.dot(a)))
}

/// How far past the plane (n, d) of primitive `i` the hidden geometry reaches on its front and
/// its back; the scan stops once both are beyond `e`.
fn hidden_reach(
    scene: &Scene,
    hidden: &AreaSampler,
    i: usize,
    (n, d): (DVec3, f64),
    e: f64,
) -> [f64; 2] {
    let mut past = [0.0f64; 2];
    for (j, p) in scene.prims.iter().enumerate() {
        if past[0] > e && past[1] > e {
            break;
        }
        if j != i && hidden.covers(scene.prim_shape[j]) {
            let (lo, hi) = extent(p, n, d);
            past = [past[0].max(hi), past[1].max(-lo)];
        }
    }
    past
}

/// Whether a step can leave a triangle by no side with hidden geometry beyond, given which of
/// its sides (front, back) are open: the front alone counts where `front_only` (a one-sided BSDF
/// over flat shading), both otherwise. The one rule of [`ClearView::reaches_no_hidden`] (per
/// vertex) and [`paths_end_on`] (per primitive, before a render).
#[inline]
fn dead_end(open: [bool; 2], front_only: bool) -> bool {
    open[0] && (open[1] || front_only)
}

/// Whether no path goes on from the surfaces of the shapes `picked` selects, judged from the scene
/// alone: each of their primitives is a triangle with no hidden geometry beyond a side a step
/// leaves by ([`ClearView::reaches_no_hidden`]: the front alone where its shape's BSDF is
/// one-sided, `either_side` false, and it has no vertex normals; both sides otherwise). False in
/// a scene too large to judge.
pub fn paths_end_on(
    scene: &Scene,
    hidden: &AreaSampler,
    picked: impl Fn(usize) -> bool,
    either_side: impl Fn(usize) -> bool,
) -> bool {
    let Some(e) = rounding_margin(scene, 0.0) else {
        return false;
    };
    (0..scene.prims.len())
        .filter(|&i| picked(scene.prim_shape[i] as usize))
        .all(|i| {
            face_plane(scene, i).is_some_and(|plane| {
                let past = hidden_reach(scene, hidden, i, plane, e);
                let front_only =
                    !either_side(scene.prim_shape[i] as usize) && scene.prim_normals[i].is_none();
                dead_end([past[0] <= e, past[1] <= e], front_only)
            })
        })
}

impl ClearView {
    /// Judge the scene's triangles from its scan points (`scan`, none with a camera) and laser
    /// spots (`spots`), and their sides against the hidden geometry (`hidden`'s shapes, if
    /// hidden-geometry sampling is on). Nothing is judged in a scene of more than
    /// [`MAX_PRIMS`] primitives or beyond coordinate [`MAX_COORDINATE`].
    pub fn new<'a>(
        scene: &Scene,
        scan: impl Iterator<Item = &'a Interaction>,
        spots: impl Iterator<Item = &'a Interaction>,
        hidden: Option<&AreaSampler>,
    ) -> Self {
        let scan = Viewpoints::of(scene, scan);
        let spots = Viewpoints::of(scene, spots);
        let reach = |v: &Option<Viewpoints>| {
            v.as_ref()
                .map_or(0.0, |v| v.low.abs().max(v.high.abs()).max_element())
        };
        let Some(e) = rounding_margin(scene, reach(&scan).max(reach(&spots))) else {
            return Self::default();
        };
        let margin = 5.0 * e / SHADOW_EPS as f64;
        let prims = &scene.prims;
        let boxes: Vec<[DVec3; 2]> = prims.iter().map(bounding_box).collect();
        let blockers: Vec<Blocker> = (0..scene.shapes.len())
            .filter_map(|s| Blocker::of(scene, s, e))
            .collect();
        // Each face on its own (spread over the render's threads): 14 ms for 968 triangles on one.
        let flags = map_indices(prims.len(), |i| {
            let Some((n, d)) = face_plane(scene, i) else {
                return 0;
            };
            let sides = [&scan, &spots].map(|v| v.as_ref().and_then(|v| v.side(n, d, margin)));
            // The box around each set of points and the triangle, widened by 5e: a primitive
            // apart from it meets none of their segments.
            let [lo, hi] = boxes[i];
            let reach = [&scan, &spots].map(|v| {
                v.as_ref()
                    .map(|v| [v.low.min(lo) - 5.0 * e, v.high.max(hi) + 5.0 * e])
            });
            // How far past the plane, on each side, the primitives each set's shadow rays test
            // reach; the scan stops once no flag can be set.
            let mut tested = [[0.0f64; 2]; 2];
            let open = |tested: &[[f64; 2]; 2]| {
                (0..2).any(|k| sides[k].is_some_and(|s| tested[k][s] <= e))
            };
            for (j, p) in prims.iter().enumerate() {
                if !open(&tested) {
                    break;
                }
                if j == i {
                    continue;
                }
                let (lo, hi) = extent(p, n, d);
                let key = scene.accel.plane_of(scene.prim_shape[j]);
                let within = |r: &Option<[DVec3; 2]>| {
                    r.is_some_and(|[l, h]| boxes[j][0].cmple(h).all() && boxes[j][1].cmpge(l).all())
                };
                for (k, v) in [&scan, &spots].into_iter().enumerate() {
                    if v.as_ref()
                        .is_some_and(|v| v.key == NO_PLANE || v.key != key)
                        && within(&reach[k])
                    {
                        tested[k] = [tested[k][0].max(hi), tested[k][1].max(-lo)];
                    }
                }
            }
            let mut f = 0;
            for (k, bit) in [FROM_SCAN, FROM_SPOTS].into_iter().enumerate() {
                if sides[k].is_some_and(|s| tested[k][s] <= e) {
                    f |= bit;
                }
            }
            // Hidden behind a blocker: the face's box widened by its shadow rays' offset (they
            // start off it towards a spot) and 5e (a point drawn on it may stray by rounding).
            let pad = (1.0 + lo.abs().max(hi.abs()).max_element()) * RAY_EPS as f64 + 5.0 * e;
            let face = [lo - pad, hi + pad];
            let shape = scene.prim_shape[i] as usize;
            for (k, bit) in [HIDDEN_FROM_SCAN, HIDDEN_FROM_SPOTS]
                .into_iter()
                .enumerate()
            {
                let Some(v) = [&scan, &spots][k] else {
                    continue;
                };
                let points = [v.low, v.high];
                if f & [FROM_SCAN, FROM_SPOTS][k] == 0
                    && blockers.iter().any(|b| {
                        b.shape != shape && b.shape as u32 != v.key && b.blocks(&points, &face, e)
                    })
                {
                    f |= bit;
                }
            }
            if let Some(hidden) = hidden {
                let past = hidden_reach(scene, hidden, i, (n, d), e);
                if past[0] <= e {
                    f |= OPEN_FRONT;
                }
                if past[1] <= e {
                    f |= OPEN_BACK;
                }
            }
            f
        });
        Self { flags }
    }

    #[inline]
    fn has(&self, prim: u32, bit: u8) -> bool {
        self.flags.get(prim as usize).is_some_and(|f| f & bit != 0)
    }

    /// Whether every scan point sees all of the triangle `x` lies on (the shadow ray between them
    /// would find nothing).
    #[inline]
    pub fn seen_from_scan_points(&self, x: &Interaction) -> bool {
        self.has(x.prim, FROM_SCAN)
    }

    /// Whether no scan point sees any of the triangle `x` lies on (the shadow ray between them
    /// would meet a blocker).
    #[inline]
    pub fn hidden_from_scan_points(&self, x: &Interaction) -> bool {
        self.has(x.prim, HIDDEN_FROM_SCAN)
    }

    /// Whether no laser spot sees any of the triangle `x` lies on.
    #[inline]
    pub fn hidden_from_spots(&self, x: &Interaction) -> bool {
        self.has(x.prim, HIDDEN_FROM_SPOTS)
    }

    /// Whether every laser spot sees all of the triangle `x` lies on.
    #[inline]
    pub fn seen_from_spots(&self, x: &Interaction) -> bool {
        self.has(x.prim, FROM_SPOTS)
    }

    /// Whether a ray leaving `x` along `d` surely meets no hidden geometry: it leaves on a side
    /// of `x`'s triangle with none beyond.
    #[inline]
    pub fn misses_hidden(&self, x: &Interaction, d: Vec3A) -> bool {
        let c = x.ng.dot(d);
        (c > 1e-4 && self.has(x.prim, OPEN_FRONT)) || (c < -1e-4 && self.has(x.prim, OPEN_BACK))
    }

    /// Whether no step from `x` reaches hidden geometry: every side of its triangle that a step
    /// may leave by has none beyond. A one-sided BSDF over flat shading (shading normal equal to
    /// the geometric one) leaves by the front alone: its draws lie about that normal, and a
    /// hidden-geometry edge must face it; any other leaves by either side. What lies within the
    /// rounding margin of the plane (the rest of a flat sheet) meets `x` at a cosine of zero, so
    /// the path ends there with nothing lost.
    #[inline]
    pub fn reaches_no_hidden(&self, x: &Interaction, either_side: bool) -> bool {
        dead_end(
            [self.has(x.prim, OPEN_FRONT), self.has(x.prim, OPEN_BACK)],
            !either_side && x.ns == x.ng,
        )
    }

    /// [`Self::misses_hidden`] for a cosine-weighted direction about `n` from the square sample
    /// `u`, before the warp: `n` is `x`'s geometric normal or its opposite, that side is open,
    /// and u lies inside the concentric disk (of radius max |2u − 1|) well enough that the
    /// lifted direction leaves the plane with a cosine above 8·10⁻⁴, beyond the warp's rounding
    /// and the margin of `misses_hidden`, which would then say the same.
    #[inline]
    pub fn misses_hidden_about(&self, x: &Interaction, n: Vec3A, u: Vec2) -> bool {
        let r = (2.0 * u - Vec2::ONE).abs().max_element();
        1.0 - r * r > 1e-6
            && ((n == x.ng && self.has(x.prim, OPEN_FRONT))
                || (n == -x.ng && self.has(x.prim, OPEN_BACK)))
    }
}
