//! Eight rays at once against every triangle of a small scene: the closest hit and shadow rays of
//! paths traced in lockstep lanes (the line-of-sight path tracer's). Each triangle is tested
//! against all eight rays in one [`F8`] (an AVX2 vector on x86-64).
//!
//! The test maps the ray's point on the triangle's plane to barycentrics by two affine maps
//! computed once per triangle (Baldwin and Weber 2016, "Fast Ray-Triangle Intersections by
//! Coordinate Transformation", JCGT 5(3)): t = −(n·o + w)/(n·d) with the plane's unit normal n
//! and offset w, then b1 and b2 of x = o + t d, each a·x + w — in fused multiply-adds. A hit's
//! barycentrics may fall [`EDGE_SLACK`] outside the triangle, so that no ray slips between two
//! triangles of a mesh through the f32 rounding of their shared edge.
//!
//! Rays start on surfaces: a ray skips the triangles of up to two plane keys (its origin's plane,
//! and a shadow ray's end's), which it could meet only at t = 0, instead of being offset off them.

use super::Prim;
use crate::simd::{F8, M8};
use glam::Vec3A;

/// Rays per packet.
pub const LANES: usize = crate::simd::LANES;
/// Most triangles a packet scene may have: each ray tests every one.
pub const MAX_TRIANGLES: usize = 64;
/// How far outside a triangle, in barycentric units, a hit is still taken.
pub const EDGE_SLACK: f32 = 1e-6;
/// The plane key of no plane (a ray that starts off every surface).
pub const NO_PLANE: f32 = -1.0;

/// A triangle, or a parallelogram made of two, as the test reads it: (n, w), (a1, w1), (a2, w2),
/// its plane key and the primitives a hit reports.
#[derive(Clone, Copy, Debug)]
struct Tri {
    m: [[f32; 4]; 3],
    plane: f32,
    /// Two triangles of one shape that make a parallelogram (a rectangle's, a box face's): hit
    /// where both barycentrics are in [0, 1].
    quad: bool,
    /// The triangle hit where b1 + b2 ≤ 1, and where b1 + b2 > 1 (a parallelogram's second
    /// triangle; `prim` again for a triangle).
    prim: u32,
    far_prim: u32,
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

/// The triangles of a small scene, ready for packets.
#[derive(Clone, Debug)]
pub struct PacketScene {
    tris: Vec<Tri>,
    /// The triangles a segment between two points of the scene's surfaces may cross: all but
    /// those whose plane has the whole scene on one side (the walls, floor and ceiling of a
    /// room), which such a segment meets at most at an end.
    occluders: Vec<Tri>,
    /// Each primitive's plane key.
    planes: Vec<f32>,
}

impl PacketScene {
    /// The packet scene of `prims` if they are at most [`MAX_TRIANGLES`] triangles and the CPU
    /// runs [`F8`]'s vectors ([`crate::simd::available`]); `same_shape(i, j)` tells whether two
    /// primitives belong to one shape (only then may they be tested as one parallelogram).
    pub fn new(prims: &[Prim], same_shape: impl Fn(usize, usize) -> bool) -> Option<Self> {
        if prims.len() > MAX_TRIANGLES || !crate::simd::available() {
            return None;
        }
        let (keys, extent) = plane_keys(prims)?;
        let mut tris = Vec::new();
        let mut paired = vec![false; prims.len()];
        for i in 0..prims.len() {
            if paired[i] {
                continue;
            }
            let Prim::Triangle { v, .. } = prims[i] else {
                unreachable!("plane_keys took triangles only");
            };
            // A later triangle of the same shape and plane that shares an edge with this one and
            // completes a parallelogram: the corner `q` opposite the shared edge, and the edge's
            // ends, are then the parallelogram's corner and its two edges' ends.
            let partner = (i + 1..prims.len()).find_map(|j| {
                let Prim::Triangle { v: w, .. } = prims[j] else {
                    return None;
                };
                if paired[j] || keys[j] != keys[i] || !same_shape(i, j) {
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
                    (c, j)
                }
                None => (v, i),
            };
            let n = (corner[1] - corner[0])
                .cross(corner[2] - corner[0])
                .normalize();
            let [b1, b2] = barycentric_maps(corner);
            tris.push(Tri {
                m: [[n.x, n.y, n.z, -n.dot(corner[0])], b1, b2],
                plane: keys[i] as f32,
                quad: far_prim != i,
                prim: i as u32,
                far_prim: far_prim as u32,
            });
        }
        let planes = keys.iter().map(|&k| k as f32).collect();
        let occluders = (tris.iter())
            .filter(|t| !bounds_scene(&t.m[0], prims, 1e-5 * extent))
            .copied()
            .collect();
        Some(Self {
            tris,
            occluders,
            planes,
        })
    }

    /// The plane key of primitive `prim`: triangles in one plane share it.
    pub fn plane(&self, prim: u32) -> f32 {
        self.planes[prim as usize]
    }

    /// Each ray's closest hit among the triangles it does not skip: distance and triangle
    /// (`u32::MAX` for none).
    pub fn closest(&self, r: &Packet) -> ([f32; LANES], [u32; LANES]) {
        // SAFETY: the scene was made where the CPU runs `F8`'s vectors.
        unsafe { closest(&self.tris, r) }
    }

    /// The rays of the lanes `lanes` (bit per lane) that meet no triangle they do not skip, as
    /// bits, for rays that join two points of the scene's surfaces (origin and `o + tmax d`).
    pub fn unoccluded(&self, r: &Packet, lanes: u32) -> u32 {
        // SAFETY: as in `closest`.
        unsafe { unoccluded(&self.occluders, r, lanes) }
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
    tmin: F8,
    skip: [F8; 2],
}

impl Rays {
    #[inline(always)]
    fn new(r: &Packet) -> Self {
        Self {
            o: r.o.each_ref().map(F8::load),
            d: r.d.each_ref().map(F8::load),
            tmin: F8::load(&r.tmin),
            skip: r.skip.each_ref().map(F8::load),
        }
    }
}

/// a·x + w in fused multiply-adds, for the map `m` = (a, w).
#[inline(always)]
fn affine(m: &[f32; 4], x: &[F8; 3]) -> F8 {
    let b = F8::splat;
    b(m[2]).mul_add(x[2], b(m[1]).mul_add(x[1], b(m[0]).mul_add(x[0], b(m[3]))))
}

/// `tri` against the rays within (tmin, `tmax`): distances, the lanes hit, and the lanes whose
/// point has b1 + b2 > 1 (in a parallelogram's second triangle).
#[inline(always)]
fn test(tri: &Tri, r: &Rays, tmax: F8) -> (F8, M8, M8) {
    let n = &tri.m[0];
    let b = F8::splat;
    let nd = b(n[2]).mul_add(r.d[2], b(n[1]).mul_add(r.d[1], b(n[0]) * r.d[0]));
    let t = (b(0.0) - affine(n, &r.o)) / nd;
    let x = [
        r.d[0].mul_add(t, r.o[0]),
        r.d[1].mul_add(t, r.o[1]),
        r.d[2].mul_add(t, r.o[2]),
    ];
    let (u, v) = (affine(&tri.m[1], &x), affine(&tri.m[2], &x));
    let key = b(tri.plane);
    let top = b(1.0 + EDGE_SLACK);
    let sum = u + v;
    let inside = if tri.quad {
        u.le(top) & v.le(top)
    } else {
        sum.le(top)
    };
    let hit = u.ge(b(-EDGE_SLACK))
        & v.ge(b(-EDGE_SLACK))
        & inside
        & t.gt(r.tmin)
        & t.lt(tmax)
        & key.ne(r.skip[0])
        & key.ne(r.skip[1]);
    (t, hit, sum.gt(b(1.0)))
}

#[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,fma"))]
unsafe fn closest(tris: &[Tri], p: &Packet) -> ([f32; LANES], [u32; LANES]) {
    let r = Rays::new(p);
    let mut best = F8::load(&p.tmax);
    // The triangle's index in f32 lanes (exact below 2²⁴), chosen as the distance is.
    let mut prim = F8::splat(-1.0);
    for tri in tris {
        let (t, hit, far) = test(tri, &r, best);
        best = F8::select(hit, t, best);
        let id = F8::select(
            far,
            F8::splat(tri.far_prim as f32),
            F8::splat(tri.prim as f32),
        );
        prim = F8::select(hit, id, prim);
    }
    let k = prim.store();
    let mut index = [u32::MAX; LANES];
    for l in 0..LANES {
        if k[l] >= 0.0 {
            index[l] = k[l] as u32;
        }
    }
    (best.store(), index)
}

#[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,fma"))]
unsafe fn unoccluded(tris: &[Tri], p: &Packet, lanes: u32) -> u32 {
    let r = Rays::new(p);
    let tmax = F8::load(&p.tmax);
    let mut open = lanes;
    for tri in tris {
        open &= !test(tri, &r, tmax).1.bits();
        if open == 0 {
            break;
        }
    }
    open
}

/// Whether every vertex of `prims` lies on one side of the plane n·x + w = 0 (`plane` = (n, w)),
/// or within `tol` of it: a segment between two points of the scene then crosses the plane at
/// most at its ends (which a shadow ray's open interval leaves out), or by the rounding of a point
/// within `tol` of it.
fn bounds_scene(plane: &[f32; 4], prims: &[Prim], tol: f32) -> bool {
    let (mut below, mut above) = (false, false);
    for p in prims {
        let Prim::Triangle { v, .. } = p else {
            return false;
        };
        for x in v {
            let h = plane[0] * x.x + plane[1] * x.y + plane[2] * x.z + plane[3];
            below |= h < -tol;
            above |= h > tol;
        }
    }
    !(below && above)
}

/// Plane keys of `prims` (`None` unless all are triangles): triangles in one plane, facing either
/// way (unit normals and offsets equal to 1e-5, or opposite, the offsets relative to the scene's
/// extent), share one, the lowest index among them; and that extent (at least 1).
fn plane_keys(prims: &[Prim]) -> Option<(Vec<u32>, f32)> {
    let mut planes = Vec::with_capacity(prims.len());
    let mut extent = 1.0f32;
    for p in prims {
        let Prim::Triangle { v, n } = *p else {
            return None;
        };
        planes.push((n, n.dot(v[0])));
        extent = v.iter().fold(extent, |e, x| e.max(x.abs().max_element()));
    }
    let mut keys: Vec<u32> = Vec::with_capacity(planes.len());
    for (i, &(n, w)) in planes.iter().enumerate() {
        let same = planes[..i].iter().position(|&(m, e)| {
            let close = |m: Vec3A, e: f32| {
                (n - m).abs().max_element() <= 1e-5 && (w - e).abs() <= 1e-5 * extent
            };
            close(m, e) || close(-m, -e)
        });
        keys.push(same.map_or(i as u32, |j| keys[j]));
    }
    Some((keys, extent))
}
