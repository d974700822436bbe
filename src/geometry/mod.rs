//! Scene geometry: primitives (triangles and Mitsuba's analytic `sphere` and `disk`), their exact
//! ray intersection, and surface interactions. The BVH lives in [`bvh`].

pub mod bvh;
pub mod mesh;
pub mod ray_packet;
// (Off x86-64 the scan is never built.)
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub mod small_scene;
mod triangle_pack;
mod wide;

use crate::math::{RAY_EPS, SHADOW_EPS};
use crate::sampling::{
    square_to_uniform_disk_concentric, square_to_uniform_sphere, square_to_uniform_triangle,
};
use glam::{Affine3A, Vec2, Vec3A, Vec3Swizzles};

/// A ray-traceable primitive in world space.
#[derive(Clone, Copy, Debug)]
pub enum Prim {
    /// Triangle; counter-clockwise winding gives the geometric normal `n`, computed once by
    /// [`Prim::triangle`] (hits and area samples read it instead of normalising a cross product).
    Triangle {
        /// Vertices.
        v: [Vec3A; 3],
        /// Unit geometric normal.
        n: Vec3A,
    },
    /// Sphere (`flip` turns the normal inwards).
    Sphere {
        /// Centre.
        center: Vec3A,
        /// Radius.
        radius: f32,
    },
    /// Unit disk in the local z = 0 plane, mapped by an affine `to_world` (stored inverted).
    Disk {
        /// World → local.
        inv: Affine3A,
    },
}

/// A ray `o + t d`, `t ∈ (tmin, tmax)`, with a unit direction.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Origin.
    pub o: Vec3A,
    /// Unit direction.
    pub d: Vec3A,
    /// Start of the valid range.
    pub tmin: f32,
    /// End of the valid range.
    pub tmax: f32,
}

/// A ray hit before shading: distance, primitive index and its barycentrics (triangles).
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the (unit) ray direction.
    pub t: f32,
    /// Index of the primitive in scene order.
    pub prim: u32,
    /// Barycentric weights of vertices 1 and 2 (triangles only).
    pub b: [f32; 2],
}

/// A point on a surface, with what shading needs.
#[derive(Clone, Copy, Debug)]
pub struct Interaction {
    /// Position.
    pub p: Vec3A,
    /// Geometric normal.
    pub ng: Vec3A,
    /// Shading normal (interpolated vertex normal, else `ng`).
    pub ns: Vec3A,
    /// Index of the shape the point lies on.
    pub shape: u32,
    /// Index of the primitive the point lies on (of `Scene::prims`).
    pub prim: u32,
}

impl Interaction {
    /// Origin for a ray leaving this point towards `d`, offset along the normal as Mitsuba's
    /// `Interaction::spawn_ray` does, so the ray cannot re-hit the surface it starts from.
    pub fn offset_origin(&self, d: Vec3A) -> Vec3A {
        offset_origin(self.p, self.ng, d)
    }
}

/// The ray-dependent part of the watertight triangle test: the axes permuted so that the largest
/// |d| component comes last (z), and the shear (sx, sy, sz) that maps `d` to +z.
#[inline]
fn watertight_shear(d: Vec3A) -> ([usize; 3], [f32; 3]) {
    let ad = d.abs();
    let kz = if ad.x > ad.y {
        if ad.x > ad.z { 0 } else { 2 }
    } else if ad.y > ad.z {
        1
    } else {
        2
    };
    let kx = (kz + 1) % 3;
    let ky = (kx + 1) % 3;
    // Read from an array, not through `Vec3A`'s `Index` (a branch per component).
    let d = d.to_array();
    ([kx, ky, kz], [-d[kx] / d[kz], -d[ky] / d[kz], 1.0 / d[kz]])
}

/// A ray set up for the watertight test ([`intersect_triangle`]) once, to test many triangles:
/// the axes permuted so that z is the dominant direction component, the permuted origin and the
/// shear.
#[derive(Clone, Copy)]
pub struct Watertight {
    /// The permutation (x, y, z from these axes).
    pub k: [usize; 3],
    /// The origin, permuted.
    pub ko: [f32; 3],
    /// The shear (sx, sy, sz).
    pub s: [f32; 3],
}

impl Watertight {
    /// The set-up of the ray `o + t d`.
    #[inline]
    pub fn new(o: Vec3A, d: Vec3A) -> Self {
        let (k, s) = watertight_shear(d);
        let o = o.to_array();
        Self {
            k,
            ko: k.map(|a| o[a]),
            s,
        }
    }

    /// Watertight ray–triangle test (Woop, Benthin and Wald 2013, "Watertight ray/triangle
    /// intersection"; the form of pbrt-v4's `IntersectTriangle`): translate to the ray origin,
    /// permute so the dominant direction axis is z, shear, and evaluate the edge functions,
    /// falling back to f64 when one is exactly zero. Rays through shared edges and vertices never
    /// slip between triangles. Returns `(t, b1, b2)`. In scalars read from arrays: `Vec3A`'s
    /// `Index` branches on the component, and its lanes serve no purpose here.
    #[inline(always)]
    pub fn triangle(&self, tmin: f32, tmax: f32, p: &[Vec3A; 3]) -> Option<(f32, f32, f32)> {
        let ([ox, oy, oz], [sx, sy, sz]) = (self.ko, self.s);
        // Translate vertices to the ray origin, permute and shear. The permutation is a rotation
        // of the axes (x, y, z from k = (z + 1, z + 2, z) mod 3): a swizzle, no indexing.
        let kz = self.k[2];
        let shear = |v: &Vec3A| {
            let v = match kz {
                0 => v.yzx(),
                1 => v.zxy(),
                _ => *v,
            };
            let z = v.z - oz;
            (v.x - ox + sx * z, v.y - oy + sy * z, z * sz)
        };
        let (p0, p1, p2) = (shear(&p[0]), shear(&p[1]), shear(&p[2]));
        // Edge functions; recompute in double precision when any is exactly zero.
        let mut e0 = p1.0 * p2.1 - p1.1 * p2.0;
        let mut e1 = p2.0 * p0.1 - p2.1 * p0.0;
        let mut e2 = p0.0 * p1.1 - p0.1 * p1.0;
        if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
            let f = |a: (f32, f32, f32), b: (f32, f32, f32)| {
                (a.0 as f64 * b.1 as f64 - a.1 as f64 * b.0 as f64) as f32
            };
            e0 = f(p1, p2);
            e1 = f(p2, p0);
            e2 = f(p0, p1);
        }
        if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
            return None;
        }
        let det = e0 + e1 + e2;
        if det == 0.0 {
            return None;
        }
        let inv_det = 1.0 / det;
        let t = (e0 * p0.2 + e1 * p1.2 + e2 * p2.2) * inv_det;
        if !(t > tmin && t < tmax) {
            return None;
        }
        Some((t, e1 * inv_det, e2 * inv_det))
    }
}

/// The watertight test ([`Watertight::triangle`]) of one ray against one triangle.
#[inline]
pub fn intersect_triangle(
    o: Vec3A,
    d: Vec3A,
    tmin: f32,
    tmax: f32,
    p: &[Vec3A; 3],
) -> Option<(f32, f32, f32)> {
    Watertight::new(o, d).triangle(tmin, tmax, p)
}

impl Prim {
    /// The triangle with vertices `v`.
    pub fn triangle(v: [Vec3A; 3]) -> Self {
        Prim::Triangle {
            v,
            n: (v[1] - v[0]).cross(v[2] - v[0]).normalize(),
        }
    }

    /// A uniformly distributed point on the primitive from `u` ∈ [0, 1)²: position, geometric
    /// normal and barycentrics (triangles; zero otherwise).
    #[inline]
    pub fn sample_area(&self, u: Vec2) -> (Vec3A, Vec3A, [f32; 2]) {
        match self {
            Prim::Triangle { v, n } => {
                let b = square_to_uniform_triangle(u);
                let p = v[0] * (1.0 - b.x - b.y) + v[1] * b.x + v[2] * b.y;
                (p, *n, b.to_array())
            }
            Prim::Sphere { center, radius } => {
                let n = square_to_uniform_sphere(u);
                (*center + n * *radius, n, [0.0; 2])
            }
            Prim::Disk { inv } => {
                let q = square_to_uniform_disk_concentric(u);
                let p = inv.inverse().transform_point3a(Vec3A::new(q.x, q.y, 0.0));
                (p, Prim::disk_normal(inv), [0.0; 2])
            }
        }
    }

    /// Distance to the nearest hit in `(tmin, tmax)` along a unit-direction ray, with barycentrics.
    #[inline]
    pub fn intersect(&self, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<(f32, [f32; 2])> {
        match self {
            Prim::Triangle { v, .. } => {
                intersect_triangle(o, d, tmin, tmax, v).map(|(t, b1, b2)| (t, [b1, b2]))
            }
            Prim::Sphere { center, radius } => {
                // Solve |o + t d - c|² = r² in double precision (d is unit length).
                let oc = (o - *center).as_dvec3();
                let dd = d.as_dvec3();
                let b = oc.dot(dd);
                let c = oc.length_squared() - (*radius as f64).powi(2);
                let disc = b * b - c;
                if disc < 0.0 {
                    return None;
                }
                let s = disc.sqrt();
                [-b - s, -b + s]
                    .into_iter()
                    .map(|t| t as f32)
                    .find(|&t| t > tmin && t < tmax)
                    .map(|t| (t, [0.0; 2]))
            }
            Prim::Disk { inv } => {
                let lo = inv.transform_point3a(o);
                let ld = inv.transform_vector3a(d);
                if ld.z == 0.0 {
                    return None;
                }
                let t = -lo.z / ld.z;
                let lp = lo + ld * t;
                (t > tmin && t < tmax && lp.x * lp.x + lp.y * lp.y <= 1.0).then_some((t, [0.0; 2]))
            }
        }
    }

    /// The unit normal of a disk mapped to the world by the inverse of `inv` (its local +z).
    #[inline]
    pub fn disk_normal(inv: &Affine3A) -> Vec3A {
        inv.matrix3.transpose().mul_vec3a(Vec3A::Z).normalize()
    }

    /// Axis-aligned bounds.
    pub fn bounds(&self) -> (Vec3A, Vec3A) {
        match self {
            Prim::Triangle { v: p, .. } => (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2])),
            Prim::Sphere { center, radius } => (*center - *radius, *center + *radius),
            Prim::Disk { inv } => {
                let m = inv.inverse();
                let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                    .map(|(x, y)| m.transform_point3a(Vec3A::new(x, y, 0.0)));
                let lo = corners.iter().fold(Vec3A::INFINITY, |a, &c| a.min(c));
                let hi = corners.iter().fold(Vec3A::NEG_INFINITY, |a, &c| a.max(c));
                (lo, hi)
            }
        }
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        match self {
            Prim::Triangle { v: p, .. } => 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length(),
            Prim::Sphere { radius, .. } => 4.0 * std::f32::consts::PI * radius * radius,
            Prim::Disk { inv } => {
                let m = inv.inverse().matrix3;
                std::f32::consts::PI * m.x_axis.cross(m.y_axis).length()
            }
        }
    }

    /// Position and geometric normal at a hit (`flip` reverses the normal).
    pub fn surface(&self, o: Vec3A, d: Vec3A, hit: &Hit) -> (Vec3A, Vec3A) {
        match self {
            Prim::Triangle { v: p, n } => {
                let [b1, b2] = hit.b;
                let pos = p[0] * (1.0 - b1 - b2) + p[1] * b1 + p[2] * b2;
                (pos, *n)
            }
            Prim::Sphere { center, .. } => {
                let pos = o + d * hit.t;
                (pos, (pos - *center).normalize())
            }
            Prim::Disk { inv } => (o + d * hit.t, Prim::disk_normal(inv)),
        }
    }
}

/// Origin for a ray leaving the surface point `p` (geometric normal `ng`) towards `d`
/// ([`Interaction::offset_origin`]).
#[inline]
pub fn offset_origin(p: Vec3A, ng: Vec3A, d: Vec3A) -> Vec3A {
    let mag = (1.0 + p.abs().max_element()) * RAY_EPS;
    p + ng * mag.copysign(ng.dot(d))
}

/// A segment from `a` towards `b` as an origin, unit direction and distance limits, ending
/// `SHADOW_EPS` short of `b` (Mitsuba's `spawn_ray_to`).
pub fn shadow_segment(a: &Interaction, b: Vec3A) -> (Vec3A, Vec3A, f32) {
    segment_from(a.p, a.ng, b)
}

/// [`shadow_segment`] from the surface point `p` of geometric normal `ng`.
#[inline]
pub fn segment_from(p: Vec3A, ng: Vec3A, b: Vec3A) -> (Vec3A, Vec3A, f32) {
    let o = offset_origin(p, ng, b - p);
    let v = b - o;
    let dist = v.length();
    (o, v / dist, dist * (1.0 - SHADOW_EPS))
}
