//! Eight rays at once against every triangle of a small scene, and against a few spheres
//! ([`Balls`]): the closest hit and shadow rays of paths traced in lockstep lanes (the
//! line-of-sight path tracer's). Each triangle or sphere is tested against all eight rays in one
//! [`F8`] (an AVX2 vector on x86-64).
//!
//! The test maps the ray's point on the triangle's plane to barycentrics by two affine maps
//! computed once per triangle (Baldwin and Weber 2016, "Fast Ray-Triangle Intersections by
//! Coordinate Transformation", JCGT 5(3)). In the coordinates of the normal's largest axis k (and
//! i, j the other two) the plane is scaled to x_k + p_i x_i + p_j x_j + p_w = 0, so that
//! t = −(o_k + p_i o_i + p_j o_j + p_w)/(d_k + p_i d_i + p_j d_j); a point of the plane is given
//! by its x_i and x_j, and b1 and b2 are each a_i x_i + a_j x_j + w — ten fused multiply-adds and a
//! division a triangle. Triangles are grouped by that axis, so each group's loop knows it. A hit's
//! barycentrics may fall [`EDGE_SLACK`] outside the triangle, so that no ray slips between two
//! triangles of a mesh through the f32 rounding of their shared edge.
//!
//! A shape of several triangles (a Cornell box's box) is tested behind its bounding box: the
//! eight rays' slab test skips it when none enters the box before its closest hit so far.
//!
//! Rays start on surfaces: a ray skips the triangles of up to two plane keys (its origin's plane,
//! and a shadow ray's end's), which it could meet only at t = 0, instead of being offset off them.

use super::Prim;
use crate::simd::{F8, M8, on_cpu};
use glam::Vec3A;

/// Rays per packet.
pub const LANES: usize = crate::simd::LANES;
/// Most triangles a packet scene may have: each ray tests every one.
pub const MAX_TRIANGLES: usize = 64;
/// How far outside a triangle, in barycentric units, a hit is still taken.
pub const EDGE_SLACK: f32 = 1e-6;
/// The plane key of no plane (a ray that starts off every surface).
pub const NO_PLANE: f32 = -1.0;

/// A triangle, or a parallelogram made of two, as the test reads it, in the coordinates (x_k, x_i,
/// x_j) of its normal's largest axis k (then i, j = k + 1, k + 2 mod 3): its plane scaled to
/// x_k + p_i x_i + p_j x_j + p_w = 0, the maps of (x_i, x_j) in its plane to its barycentrics
/// b1 and b2, its plane key and the primitives a hit reports.
#[derive(Clone, Copy, Debug)]
struct Tri {
    /// (p_i, p_j, p_w), and (−p_i, −p_j).
    plane: [f32; 5],
    /// (a_i, a_j, w) of b1 = a_i x_i + a_j x_j + w, and of b2.
    b: [[f32; 3]; 2],
    key: f32,
    /// The normal's largest axis k.
    axis: usize,
    /// Two triangles of one shape that make a parallelogram (a rectangle's, a box face's): hit
    /// where both barycentrics are in [0, 1].
    quad: bool,
    /// The triangle hit where b1 + b2 ≤ 1, and where b1 + b2 > 1 (a parallelogram's second
    /// triangle; `prim` again for a triangle).
    prim: u32,
    far_prim: u32,
}

impl Tri {
    /// The test of triangle `v` (or of the parallelogram `v[0]`, `v[1]`, `v[1] + v[2] − v[0]`).
    fn new(v: [Vec3A; 3], key: f32, prim: usize, far_prim: usize) -> Self {
        let n = (v[1] - v[0]).cross(v[2] - v[0]);
        let axis = n.abs().max_position();
        let (k, i, j) = (axis, (axis + 1) % 3, (axis + 2) % 3);
        let (pi, pj) = (n[i] / n[k], n[j] / n[k]);
        let pw = -(v[0][k] + pi * v[0][i] + pj * v[0][j]);
        // Barycentrics in the plane from the projections onto (x_i, x_j): q − p0 = b1 e1 + b2 e2.
        let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
        let det = e1[i] * e2[j] - e1[j] * e2[i];
        let map = |ai: f32, aj: f32| [ai, aj, -(ai * v[0][i] + aj * v[0][j])];
        Self {
            plane: [pi, pj, pw, -pi, -pj],
            b: [
                map(e2[j] / det, -e2[i] / det),
                map(-e1[j] / det, e1[i] / det),
            ],
            key,
            axis,
            quad: far_prim != prim,
            prim: prim as u32,
            far_prim: far_prim as u32,
        }
    }
}

/// Eight rays `o + t d`, t in (tmin, tmax), each skipping the triangles of the plane keys `skip`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Packet {
    /// Origins, by axis then lane.
    pub o: [[f32; LANES]; 3],
    /// Unit directions, by axis then lane.
    pub d: [[f32; LANES]; 3],
    /// Where each ray's open interval starts.
    pub tmin: [f32; LANES],
    /// Where it ends.
    pub tmax: [f32; LANES],
    /// Plane keys whose triangles each ray skips ([`NO_PLANE`] for none).
    pub skip: [[f32; LANES]; 2],
}

/// Triangles to test, grouped by kind (parallelograms first) and by their normal's largest axis:
/// each group is tested by its own loop.
#[derive(Clone, Debug)]
struct Tris {
    tris: Vec<Tri>,
    /// Group g = 3 · (not a parallelogram) + axis is `tris[starts[g]..starts[g + 1]]`.
    starts: [usize; 7],
}

impl Tris {
    fn new(mut tris: Vec<Tri>) -> Self {
        let group = |t: &Tri| 3 * (!t.quad as usize) + t.axis;
        tris.sort_by_key(group);
        let starts = std::array::from_fn(|g| tris.iter().filter(|t| group(t) < g).count());
        Self { tris, starts }
    }

    /// The triangles of group `g`.
    #[inline(always)]
    fn group(&self, g: usize) -> &[Tri] {
        &self.tris[self.starts[g]..self.starts[g + 1]]
    }
}

/// Triangles tested together: those of one shape of [`BOXED_TESTS`] tests or more behind its
/// bounding box, which a packet passes by when none of its rays enters it (a Cornell box's
/// boxes: six parallelograms each), or all the others, always tested (`bounds` `None`); a
/// shape that is the whole scene is not boxed.
#[derive(Clone, Debug)]
struct Part {
    tris: Tris,
    /// Low and high corners, padded.
    bounds: Option<[Vec3A; 2]>,
}

/// Fewest tests (triangles or parallelograms) of a shape that are tested behind its bounding
/// box. (mitransient's Z, three parallelograms at which the camera file's rays aim, behind its
/// box measured 0.93–1.00×.)
const BOXED_TESTS: usize = 4;

/// The triangles of a small scene, ready for packets.
#[derive(Clone, Debug)]
pub struct PacketScene {
    /// The unboxed part first.
    tris: Box<[Part]>,
    /// The triangles a segment between two points of the scene's surfaces may cross: all but
    /// those whose plane has the whole scene on one side (the walls, floor and ceiling of a
    /// room), which such a segment meets at most at an end.
    occluders: Box<[Part]>,
    /// Each primitive's plane key.
    planes: Box<[f32]>,
    /// The parallelograms tested as one: (first, second, corners).
    parallelograms: Box<[(u32, u32, [Vec3A; 3])]>,
    /// Tested by the AVX-512 form of the code ([`crate::simd::on_cpu`]).
    wide: bool,
}

impl PacketScene {
    /// The packet scene of `prims` if they are at most [`MAX_TRIANGLES`] triangles and the CPU
    /// runs [`F8`]'s vectors ([`crate::simd::available`]); `same_shape(i, j)` tells whether two
    /// primitives belong to one shape (only then may they be tested as one parallelogram).
    pub fn new(prims: &[Prim], same_shape: impl Fn(usize, usize) -> bool) -> Option<Self> {
        Self::of(prims, same_shape, |_| true)
    }

    /// The packet scene of the primitives of `prims` that `take` picks (triangles, at most
    /// [`MAX_TRIANGLES`]): the others are met by none of its rays and keep their own index as
    /// plane key; a triangle is left out of shadow rays only if its plane bounds every primitive.
    pub fn of(
        prims: &[Prim],
        same_shape: impl Fn(usize, usize) -> bool,
        take: impl Fn(usize) -> bool,
    ) -> Option<Self> {
        if (0..prims.len()).filter(|&i| take(i)).count() > MAX_TRIANGLES
            || !crate::simd::available()
        {
            return None;
        }
        let (keys, extent) = plane_keys(prims, &take)?;
        let (mut tris, mut parallelograms) = (Vec::new(), Vec::new());
        // Each test's first primitive, corners and whether it may block a shadow ray.
        let mut kept = Vec::new();
        let mut paired = vec![false; prims.len()];
        for i in 0..prims.len() {
            if paired[i] || !take(i) {
                continue;
            }
            let Prim::Triangle { v, n } = prims[i] else {
                unreachable!("plane_keys took triangles only");
            };
            // A later triangle of the same shape and plane that shares an edge with this one and
            // completes a parallelogram: the corner `q` opposite the shared edge, and the edge's
            // ends, are then the parallelogram's corner and its two edges' ends.
            let partner = (i + 1..prims.len()).find_map(|j| {
                let Prim::Triangle { v: w, .. } = prims[j] else {
                    return None;
                };
                if paired[j] || !take(j) || keys[j] != keys[i] || !same_shape(i, j) {
                    return None;
                }
                let shared: Vec<usize> = (0..3).filter(|&a| w.contains(&v[a])).collect();
                let [a, b] = shared[..] else {
                    return None;
                };
                let q = 3 - a - b;
                let other = w.iter().find(|x| **x != v[a] && **x != v[b])?;
                let gap = (v[q] + *other - v[a] - v[b]).abs().max_element();
                (gap <= 1e-6 * (1.0 + v[q].abs().max_element())).then_some((j, [v[q], v[a], v[b]]))
            });
            let (corner, far_prim) = match partner {
                Some((j, c)) => {
                    paired[j] = true;
                    parallelograms.push((i as u32, j as u32, c));
                    (c, j)
                }
                None => (v, i),
            };
            tris.push(Tri::new(corner, keys[i] as f32, i, far_prim));
            let fourth = corner[1] + corner[2] - corner[0];
            let corners = [
                corner[0],
                corner[1],
                corner[2],
                if far_prim != i { fourth } else { corner[0] },
            ];
            kept.push((i, corners, !bounds_scene(n, v[0], prims, 1e-5 * extent)));
        }
        let planes = keys.iter().map(|&k| k as f32).collect();
        // Each test's shape, by its first test.
        let shape: Vec<usize> = (0..kept.len())
            .map(|k| {
                (0..k)
                    .find(|&m| same_shape(kept[m].0, kept[k].0))
                    .unwrap_or(k)
            })
            .collect();
        let parts = |occluders: bool| {
            let wanted = |k: usize| !occluders || kept[k].2;
            let count = |of: &dyn Fn(usize) -> bool| {
                (0..kept.len()).filter(|&k| wanted(k) && of(k)).count()
            };
            let all = count(&|_| true);
            let boxed = |first: usize| (BOXED_TESTS..all).contains(&count(&|k| shape[k] == first));
            let part = |of: &dyn Fn(usize) -> bool, bounds| Part {
                tris: Tris::new(
                    (0..kept.len())
                        .filter(|&k| wanted(k) && of(k))
                        .map(|k| tris[k])
                        .collect(),
                ),
                bounds,
            };
            let mut out = vec![part(&|k| !boxed(shape[k]), None)];
            for first in (0..kept.len()).filter(|&k| shape[k] == k && boxed(k)) {
                let corners = (0..kept.len())
                    .filter(|&k| shape[k] == first && wanted(k))
                    .flat_map(|k| kept[k].1);
                let (lo, hi) = corners
                    .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), x| {
                        (lo.min(x), hi.max(x))
                    });
                // (Padded past the rounding of the test's plane and slack.)
                let pad = 1e-5 * extent;
                out.push(part(&|k| shape[k] == first, Some([lo - pad, hi + pad])));
            }
            out.into_boxed_slice()
        };
        Some(Self {
            tris: parts(false),
            occluders: parts(true),
            planes,
            parallelograms: parallelograms.into_boxed_slice(),
            wide: crate::simd::wide_available(),
        })
    }

    /// This scene once for each form of the tests this CPU runs, AVX-512's first where it has
    /// it, then AVX2's (tests compare them).
    pub fn each_extension(&self) -> Vec<Self> {
        crate::simd::each_form(self.wide, |wide| Self {
            wide,
            ..self.clone()
        })
    }

    /// The pairs of triangles tested as one parallelogram: (first, second, corners c), the
    /// parallelogram c0 + a (c1 − c0) + b (c2 − c0) for a, b in [0, 1].
    pub fn parallelograms(&self) -> &[(u32, u32, [Vec3A; 3])] {
        &self.parallelograms
    }

    /// The plane key of primitive `prim`: triangles in one plane share it.
    pub fn plane(&self, prim: u32) -> f32 {
        self.planes[prim as usize]
    }

    /// Each ray's closest hit among the triangles it does not skip (`skip[0]`'s: a ray from a
    /// surface skips its own plane; `skip[1]` is for shadow rays), distance and triangle
    /// (`u32::MAX` for none).
    pub fn closest(&self, r: &Packet) -> ([f32; LANES], [u32; LANES]) {
        let parts = &self.tris[..];
        // SAFETY: the scene was made where the CPU runs `F8`'s vectors.
        unsafe {
            on_cpu!(self.wide, closest(parts: &[Part], r: &Packet) -> ([f32; LANES], [u32; LANES]))
        }
    }

    /// The rays of the lanes `lanes` (bit per lane) that meet no triangle they do not skip, as
    /// bits, for rays that join two points of the scene's surfaces (origin and `o + tmax d`).
    pub fn unoccluded(&self, r: &Packet, lanes: u32) -> u32 {
        let parts = &self.occluders[..];
        // SAFETY: as in `closest`.
        unsafe { on_cpu!(self.wide, unoccluded(parts: &[Part], r: &Packet, lanes: u32) -> u32) }
    }
}

/// The affine maps (a, w) that give the barycentrics b1 and b2 (of `v[1]` and `v[2]`) of a point x
/// in the plane of triangle `v` as a·x + w (Baldwin and Weber 2016).
pub fn barycentric_maps(v: [Vec3A; 3]) -> [[f32; 4]; 2] {
    let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
    let big_n = e1.cross(e2);
    let n2 = big_n.length_squared();
    let map = |a: Vec3A| [a.x, a.y, a.z, -a.dot(v[0])];
    [map(e2.cross(big_n) / n2), map(big_n.cross(e1) / n2)]
}

/// The packet's rays in lanes.
struct Rays {
    o: [F8; 3],
    d: [F8; 3],
    /// −d.
    neg_d: [F8; 3],
    tmin: F8,
    skip: [F8; 2],
}

impl Rays {
    #[inline(always)]
    fn new(r: &Packet) -> Self {
        // (Arrays built whole, not by `map`: a generic left out of line where two compiled
        // forms call it runs its vector operations as calls, 4x slower.)
        let load3 = |a: &[[f32; LANES]; 3]| [F8::load(&a[0]), F8::load(&a[1]), F8::load(&a[2])];
        let d = load3(&r.d);
        let zero = F8::splat(0.0);
        Self {
            o: load3(&r.o),
            d,
            neg_d: [zero - d[0], zero - d[1], zero - d[2]],
            tmin: F8::load(&r.tmin),
            skip: [F8::load(&r.skip[0]), F8::load(&r.skip[1])],
        }
    }
}

/// `tri` (a parallelogram if `QUAD`, its normal's largest axis `K`) against the rays within
/// (tmin, `tmax`), skipping the plane keys of `r.skip[..SKIPS]`: distances, the lanes hit, and the
/// lanes whose point has b1 + b2 > 1 (in a parallelogram's second triangle).
#[inline(always)]
fn test<const QUAD: bool, const K: usize, const SKIPS: usize>(
    tri: &Tri,
    r: &Rays,
    tmax: F8,
) -> (F8, M8, M8) {
    let (i, j) = ((K + 1) % 3, (K + 2) % 3);
    let b = F8::splat;
    let p = &tri.plane;
    // t = −(o_k + p_i o_i + p_j o_j + p_w) / (d_k + p_i d_i + p_j d_j).
    let num = b(p[0]).mul_add(r.o[i], b(p[1]).mul_add(r.o[j], r.o[K] + b(p[2])));
    let den = b(p[3]).mul_add(r.d[i], b(p[4]).mul_add(r.d[j], r.neg_d[K]));
    let t = num / den;
    let (xi, xj) = (r.d[i].mul_add(t, r.o[i]), r.d[j].mul_add(t, r.o[j]));
    let bary = |m: &[f32; 3]| b(m[0]).mul_add(xi, b(m[1]).mul_add(xj, b(m[2])));
    let (u, v) = (bary(&tri.b[0]), bary(&tri.b[1]));
    let key = b(tri.key);
    let top = b(1.0 + EDGE_SLACK);
    let sum = u + v;
    let inside = if QUAD {
        u.le(top) & v.le(top)
    } else {
        sum.le(top)
    };
    let hit = (r.skip[..SKIPS].iter()).fold(
        u.ge(b(-EDGE_SLACK)) & v.ge(b(-EDGE_SLACK)) & inside & t.gt(r.tmin) & t.lt(tmax),
        |hit, &skip| hit & key.ne(skip),
    );
    (t, hit, sum.gt(b(1.0)))
}

/// The closest hits of the group of parallelograms (`QUAD`) or triangles of largest axis `K`,
/// into the distances `best` and the triangles `prim` so far.
#[inline(always)]
fn closest_in<const QUAD: bool, const K: usize>(
    tris: &[Tri],
    r: &Rays,
    best: &mut F8,
    prim: &mut F8,
) {
    for tri in tris {
        let (t, hit, far) = test::<QUAD, K, 1>(tri, r, *best);
        *best = F8::select(hit, t, *best);
        let id = if QUAD {
            F8::select(
                far,
                F8::splat(tri.far_prim as f32),
                F8::splat(tri.prim as f32),
            )
        } else {
            F8::splat(tri.prim as f32)
        };
        *prim = F8::select(hit, id, *prim);
    }
}

/// The closest hits of `tris`, as [`closest_in`].
#[inline(always)]
fn closest_of(tris: &Tris, r: &Rays, best: &mut F8, prim: &mut F8) {
    closest_in::<true, 0>(tris.group(0), r, best, prim);
    closest_in::<true, 1>(tris.group(1), r, best, prim);
    closest_in::<true, 2>(tris.group(2), r, best, prim);
    closest_in::<false, 0>(tris.group(3), r, best, prim);
    closest_in::<false, 1>(tris.group(4), r, best, prim);
    closest_in::<false, 2>(tris.group(5), r, best, prim);
}

#[inline(always)]
unsafe fn closest(parts: &[Part], p: &Packet) -> ([f32; LANES], [u32; LANES]) {
    let r = Rays::new(p);
    let mut best = F8::load(&p.tmax);
    // The triangle's index in f32 lanes (exact below 2²⁴), chosen as the distance is.
    let mut prim = F8::splat(-1.0);
    // The unboxed part first: its hits shorten the intervals the boxes are tested on.
    let slabs = if parts.len() > 1 {
        Some(Slabs::new(&r))
    } else {
        None
    };
    for part in parts {
        if let (Some(bounds), Some(slabs)) = (&part.bounds, &slabs)
            && slabs.enter(&r, best, bounds).bits() == 0
        {
            continue;
        }
        closest_of(&part.tris, &r, &mut best, &mut prim);
    }
    // −1 (no hit) becomes u32::MAX.
    (best.store(), prim.to_int().map(|k| k as u32))
}

/// Clears from `open` the lanes the group of parallelograms (`QUAD`) or triangles of largest axis
/// `K` blocks; whether any stays open.
#[inline(always)]
fn open_past<const QUAD: bool, const K: usize>(
    tris: &[Tri],
    r: &Rays,
    tmax: F8,
    open: &mut u32,
) -> bool {
    for tri in tris {
        *open &= !test::<QUAD, K, 2>(tri, r, tmax).1.bits();
        if *open == 0 {
            return false;
        }
    }
    true
}

#[inline(always)]
unsafe fn unoccluded(parts: &[Part], p: &Packet, lanes: u32) -> u32 {
    let r = Rays::new(p);
    let tmax = F8::load(&p.tmax);
    let slabs = if parts.len() > 1 {
        Some(Slabs::new(&r))
    } else {
        None
    };
    let mut open = lanes;
    for part in parts {
        if let (Some(bounds), Some(slabs)) = (&part.bounds, &slabs)
            && slabs.enter(&r, tmax, bounds).bits() & open == 0
        {
            continue;
        }
        let tris = &part.tris;
        let clear = open_past::<true, 0>(tris.group(0), &r, tmax, &mut open)
            && open_past::<true, 1>(tris.group(1), &r, tmax, &mut open)
            && open_past::<true, 2>(tris.group(2), &r, tmax, &mut open)
            && open_past::<false, 0>(tris.group(3), &r, tmax, &mut open)
            && open_past::<false, 1>(tris.group(4), &r, tmax, &mut open)
            && open_past::<false, 2>(tris.group(5), &r, tmax, &mut open);
        if !clear {
            break;
        }
    }
    open
}

/// Whether every vertex of `prims` lies on one side of the plane through `at` of unit normal `n`,
/// or within `tol` of it: a segment between two points of the scene then crosses the plane at
/// most at its ends (which a shadow ray's open interval leaves out), or by the rounding of a point
/// within `tol` of it.
fn bounds_scene(n: Vec3A, at: Vec3A, prims: &[Prim], tol: f32) -> bool {
    let (mut below, mut above) = (false, false);
    let mut side = |x: Vec3A| {
        let h = n.dot(x - at);
        below |= h < -tol;
        above |= h > tol;
    };
    for p in prims {
        match p {
            Prim::Triangle { v, .. } => v.iter().for_each(|x| side(*x)),
            // (Another primitive lies within its box: its corners.)
            _ => {
                let (lo, hi) = p.bounds();
                for k in 0..8 {
                    side(Vec3A::select(
                        glam::BVec3A::new(k & 1 != 0, k & 2 != 0, k & 4 != 0),
                        hi,
                        lo,
                    ));
                }
            }
        }
    }
    !(below && above)
}

/// Plane keys of `prims` (`None` unless those `take` picks are triangles): the picked triangles
/// that lie in one plane, facing either way (unit normals and offsets equal to 1e-5, or opposite,
/// the offsets relative to the scene's extent), share one, the lowest index among them, and any
/// other primitive has its own index; and that extent (at least 1).
fn plane_keys(prims: &[Prim], take: impl Fn(usize) -> bool) -> Option<(Vec<u32>, f32)> {
    let mut planes = Vec::with_capacity(prims.len());
    let mut extent = 1.0f32;
    for (i, p) in prims.iter().enumerate() {
        match *p {
            Prim::Triangle { v, n } => {
                planes.push(Some((n, n.dot(v[0]))));
                extent = v.iter().fold(extent, |e, x| e.max(x.abs().max_element()));
            }
            _ if !take(i) => {
                planes.push(None);
                let (lo, hi) = p.bounds();
                extent = extent.max(lo.abs().max(hi.abs()).max_element());
            }
            _ => return None,
        }
    }
    let mut keys: Vec<u32> = Vec::with_capacity(planes.len());
    for (i, plane) in planes.iter().enumerate() {
        let same = plane.filter(|_| take(i)).and_then(|(n, w)| {
            (0..i).find(|&j| {
                let close = |m: Vec3A, e: f32| {
                    (n - m).abs().max_element() <= 1e-5 && (w - e).abs() <= 1e-5 * extent
                };
                take(j) && planes[j].is_some_and(|(m, e)| close(m, e) || close(-m, -e))
            })
        });
        keys.push(same.map_or(i as u32, |j| keys[j]));
    }
    Some((keys, extent))
}

/// The lanes `lanes` (bit per lane) whose rays within (tmin, `tmax`) may meet the box `bounds`
/// (low and high corners), as bits: those of a nonempty interval that enter it (the slab test,
/// eight rays at once), or whose direction lies too near an axis plane for the test to tell (a
/// component below 1e-6).
pub fn may_meet_box(r: &Packet, tmax: &[f32; LANES], bounds: &[Vec3A; 2], lanes: u32) -> u32 {
    // SAFETY: packets are made where the CPU runs `F8`'s vectors.
    unsafe { box_lanes(r, tmax, bounds) & lanes }
}

#[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,fma"))]
unsafe fn box_lanes(r: &Packet, tmax: &[f32; LANES], bounds: &[Vec3A; 2]) -> u32 {
    let rays = Rays::new(r);
    Slabs::new(&rays)
        .enter(&rays, F8::load(tmax), bounds)
        .bits()
}

/// What the slab test of the rays needs: 1/d on each axis, and the lanes whose direction lies
/// too near an axis plane for the test to tell (a component below 1e-6), which it lets in.
struct Slabs {
    inv: [F8; 3],
    flat: M8,
}

impl Slabs {
    #[inline(always)]
    fn new(r: &Rays) -> Self {
        let b = F8::splat;
        let least = r.d[0].abs().min(r.d[1].abs()).min(r.d[2].abs());
        Self {
            inv: [b(1.0) / r.d[0], b(1.0) / r.d[1], b(1.0) / r.d[2]],
            flat: least.lt(b(1e-6)),
        }
    }

    /// The lanes whose rays within (tmin, `tmax`) may meet the box `bounds` (low and high
    /// corners): those of a nonempty interval that enter it, or that are too flat to tell.
    #[inline(always)]
    fn enter(&self, r: &Rays, tmax: F8, bounds: &[Vec3A; 2]) -> M8 {
        let b = F8::splat;
        let (mut near, mut far) = (r.tmin, tmax);
        let (lo, hi) = (bounds[0].to_array(), bounds[1].to_array());
        for (a, (lo, hi)) in lo.into_iter().zip(hi).enumerate() {
            let (t0, t1) = (
                (b(lo) - r.o[a]) * self.inv[a],
                (b(hi) - r.o[a]) * self.inv[a],
            );
            near = near.max(t0.min(t1));
            far = far.min(t0.max(t1));
        }
        (near.le(far) | self.flat) & tmax.gt(r.tmin)
    }
}

/// Most spheres [`Balls`] takes: each ray tests every one.
pub const MAX_BALLS: usize = 8;

/// A few spheres, each tested against the eight rays at once (a split scene's, beside its packet
/// of triangles). A ray leaving a sphere starts off it, offset as the scalar tracer's rays are,
/// and skips nothing. The roots are taken in the forms that lose no precision (Haines et al.
/// 2019, "Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7): the
/// discriminant from the ray's closest approach to the centre, and the near root of the two from
/// the far one by their product.
#[derive(Clone, Debug, Default)]
pub struct Balls {
    /// Centre, squared radius and primitive index of each.
    balls: Vec<([f32; 3], f32, u32)>,
    /// Tested by the AVX-512 form of the code ([`crate::simd::on_cpu`]).
    wide: bool,
}

impl Balls {
    /// The spheres (centre, radius, primitive index), at most [`MAX_BALLS`].
    pub fn new(balls: impl IntoIterator<Item = (Vec3A, f32, u32)>) -> Self {
        let balls: Vec<_> = (balls.into_iter())
            .map(|(c, r, prim)| (c.to_array(), r * r, prim))
            .collect();
        assert!(balls.len() <= MAX_BALLS, "at most {MAX_BALLS} balls");
        Self {
            balls,
            wide: crate::simd::wide_available(),
        }
    }

    /// These spheres once for each form of the tests this CPU runs, as
    /// [`PacketScene::each_extension`].
    pub fn each_extension(&self) -> Vec<Self> {
        crate::simd::each_form(self.wide, |wide| Self {
            wide,
            ..self.clone()
        })
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.balls.is_empty()
    }

    /// Lowers each ray's closest hit `t` (within its `tmin`, at most its `tmax`), primitive
    /// `prim`, to a sphere's it meets nearer.
    pub fn closest(&self, r: &Packet, t: &mut [f32; LANES], prim: &mut [u32; LANES]) {
        let balls = &self.balls[..];
        // SAFETY: balls are made beside a packet scene, where the CPU runs `F8`'s vectors.
        unsafe {
            on_cpu!(self.wide, balls_closest(balls: &[([f32; 3], f32, u32)], r: &Packet,
                t: &mut [f32; LANES], prim: &mut [u32; LANES]) -> ())
        }
    }

    /// The rays of the lanes `lanes` (bit per lane) that meet no sphere within (tmin, tmax), as
    /// bits.
    pub fn unoccluded(&self, r: &Packet, lanes: u32) -> u32 {
        let balls = &self.balls[..];
        // SAFETY: as in `closest`.
        unsafe {
            on_cpu!(self.wide, balls_unoccluded(balls: &[([f32; 3], f32, u32)], r: &Packet, lanes: u32) -> u32)
        }
    }
}

/// The sphere (centre `c`, squared radius `r2`) against the rays: the near and far roots, and the
/// lanes whose line meets it.
#[inline(always)]
fn ball_roots(c: &[f32; 3], r2: f32, r: &Rays) -> (F8, F8, M8) {
    let b = F8::splat;
    let f = [r.o[0] - b(c[0]), r.o[1] - b(c[1]), r.o[2] - b(c[2])];
    let dot = |x: &[F8; 3], y: &[F8; 3]| x[0].mul_add(y[0], x[1].mul_add(y[1], x[2] * y[2]));
    // |o + t d − c|² = r², d a unit vector: t² + 2 h t + (|f|² − r²) = 0 with h = f·d.
    let h = dot(&f, &r.d);
    // The discriminant r² − |f − h d|², from the closest approach (not h² − |f|² + r²).
    let q = [
        r.neg_d[0].mul_add(h, f[0]),
        r.neg_d[1].mul_add(h, f[1]),
        r.neg_d[2].mul_add(h, f[2]),
    ];
    let disc = b(r2) - dot(&q, &q);
    let s = disc.max(b(0.0)).sqrt();
    // The root farther from 0, −(h + sign(h) s), has no cancellation; the other is their
    // product, |f|² − r², over it.
    let far = b(0.0) - s.mul_add(h.signum(), h);
    let near = (dot(&f, &f) - b(r2)) / far;
    let first = near.lt(far);
    (
        F8::select(first, near, far),
        F8::select(first, far, near),
        disc.ge(b(0.0)),
    )
}

#[inline(always)]
unsafe fn balls_closest(
    balls: &[([f32; 3], f32, u32)],
    p: &Packet,
    t: &mut [f32; LANES],
    prim: &mut [u32; LANES],
) {
    let r = Rays::new(p);
    let mut best = F8::load(t).min(F8::load(&p.tmax));
    for &(c, r2, id) in balls {
        let (near, far, meets) = ball_roots(&c, r2, &r);
        let t = F8::select(near.gt(r.tmin), near, far);
        let hit = meets & t.gt(r.tmin) & t.lt(best);
        best = F8::select(hit, t, best);
        let mut bits = hit.bits();
        while bits != 0 {
            prim[bits.trailing_zeros() as usize] = id;
            bits &= bits - 1;
        }
    }
    *t = best.store();
}

#[inline(always)]
unsafe fn balls_unoccluded(balls: &[([f32; 3], f32, u32)], p: &Packet, lanes: u32) -> u32 {
    let r = Rays::new(p);
    let tmax = F8::load(&p.tmax);
    let mut open = lanes;
    for (c, r2, _) in balls {
        let (near, far, meets) = ball_roots(c, *r2, &r);
        let within = |t: F8| t.gt(r.tmin) & t.lt(tmax);
        open &= !(meets & (within(near) | within(far))).bits();
        if open == 0 {
            break;
        }
    }
    open
}
