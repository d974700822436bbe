//! Shadow rays and traces a render can answer without tracing: the faces nothing stands in
//! front of. A plane that has a set of points strictly on one side, and on that side no primitive
//! a shadow ray tests, separates every segment from those points to the triangle in it from
//! every such primitive: the segment stays strictly on that side, where nothing lies. So the
//! connections of a capture's scan points and laser spots to that triangle are unoccluded, and
//! need no shadow ray. Likewise a ray that leaves a triangle on a side of its plane where no
//! hidden geometry lies meets none: the BSDF draw of the mixture at hidden vertices
//! ([`super::hidden_mixture`]), which keeps only hidden geometry, ends there untraced.
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
        let prims = &scene.prims;
        if prims.len() > MAX_PRIMS {
            return Self::default();
        }
        let scan = Viewpoints::of(scene, scan);
        let spots = Viewpoints::of(scene, spots);
        let reach = |v: &Option<Viewpoints>| {
            v.as_ref()
                .map_or(0.0, |v| v.low.abs().max(v.high.abs()).max_element())
        };
        // The scene's largest coordinate, C.
        let c = prims
            .iter()
            .flat_map(|p| [DVec3::X, DVec3::Y, DVec3::Z].map(|a| extent(p, a, 0.0)))
            .fold(reach(&scan).max(reach(&spots)), |m, (lo, hi)| {
                m.max(lo.abs()).max(hi.abs())
            });
        if !(c < MAX_COORDINATE) {
            return Self::default();
        }
        let e = 5e-7 * (1.0 + c);
        let margin = 5.0 * e / SHADOW_EPS as f64;
        // Each face on its own (spread over the render's threads): 14 ms for 968 triangles on one.
        let flags = map_indices(prims.len(), |i| {
            let Prim::Triangle { v, .. } = &prims[i] else {
                return 0;
            };
            let [a, b, c] = v.map(|v| v.as_dvec3());
            // The plane, oriented as the interactions' normal (flip_normals included).
            let shape = scene.prim_shape[i];
            let n =
                (b - a).cross(c - a).normalize_or_zero() * scene.normal_sign(shape as usize) as f64;
            if n == DVec3::ZERO {
                return 0;
            }
            let d = n.dot(a);
            let sides = [&scan, &spots].map(|v| v.as_ref().and_then(|v| v.side(n, d, margin)));
            // How far past the plane, on each side, the primitives of each set reach; the
            // scan stops once no flag can be set.
            let mut past = Past::default();
            let open = |past: &Past| {
                (0..2).any(|k| sides[k].is_some_and(|s| past.tested[k][s] <= e))
                    || (hidden.is_some() && past.hidden.iter().any(|&h| h <= e))
            };
            for (j, p) in prims.iter().enumerate() {
                if !open(&past) {
                    break;
                }
                if j == i {
                    continue;
                }
                let (lo, hi) = extent(p, n, d);
                let key = scene.accel.plane_of(scene.prim_shape[j]);
                for (k, v) in [&scan, &spots].into_iter().enumerate() {
                    if v.as_ref()
                        .is_some_and(|v| v.key == NO_PLANE || v.key != key)
                    {
                        past.tested[k] = [past.tested[k][0].max(hi), past.tested[k][1].max(-lo)];
                    }
                }
                if hidden.is_some_and(|h| h.covers(scene.prim_shape[j])) {
                    past.hidden = [past.hidden[0].max(hi), past.hidden[1].max(-lo)];
                }
            }
            let mut f = 0;
            for (k, bit) in [FROM_SCAN, FROM_SPOTS].into_iter().enumerate() {
                if sides[k].is_some_and(|s| past.tested[k][s] <= e) {
                    f |= bit;
                }
            }
            if hidden.is_some() {
                if past.hidden[0] <= e {
                    f |= OPEN_FRONT;
                }
                if past.hidden[1] <= e {
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

/// How far past a plane the primitives reach on its front and back (index 0 and 1): those the
/// shadow rays from the scan points and from the spots test, and the hidden ones.
#[derive(Default)]
struct Past {
    tested: [[f64; 2]; 2],
    hidden: [f64; 2],
}
