//! Scene geometry: primitives (triangles and Mitsuba's analytic `sphere` and `disk`), their exact
//! ray intersection, and surface interactions. The BVH lives in [`bvh`].

pub mod bvh;
pub mod mesh;
// (Off x86-64 the scan is never built.)
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub mod small_scene;

use crate::math::{RAY_EPS, SHADOW_EPS};
use crate::sampling::{
    square_to_uniform_disk_concentric, square_to_uniform_sphere, square_to_uniform_triangle,
};
use glam::{Affine3A, Vec2, Vec3A};

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
}

impl Interaction {
    /// Origin for a ray leaving this point towards `d`, offset along the normal as Mitsuba's
    /// `Interaction::spawn_ray` does, so the ray cannot re-hit the surface it starts from.
    pub fn offset_origin(&self, d: Vec3A) -> Vec3A {
        let mag = (1.0 + self.p.abs().max_element()) * RAY_EPS;
        self.p + self.ng * mag.copysign(self.ng.dot(d))
    }
}

/// The ray-dependent part of the watertight triangle test: the axes permuted so that the largest
/// |d| component comes last (z), and the shear (sx, sy, sz) that maps `d` to +z.
#[inline]
pub(crate) fn watertight_shear(d: Vec3A) -> ([usize; 3], [f32; 3]) {
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

/// Watertight ray–triangle test (Woop, Benthin and Wald 2013, "Watertight ray/triangle
/// intersection"; the form of pbrt-v4's `IntersectTriangle`): translate to the ray origin, permute
/// so the dominant direction axis is z, shear, and evaluate the edge functions, falling back to f64
/// when one is exactly zero. Rays through shared edges and vertices never slip between triangles.
/// Returns `(t, b1, b2)`.
pub fn intersect_triangle(
    o: Vec3A,
    d: Vec3A,
    tmin: f32,
    tmax: f32,
    p: &[Vec3A; 3],
) -> Option<(f32, f32, f32)> {
    let ([kx, ky, kz], [sx, sy, sz]) = watertight_shear(d);
    let perm = |v: Vec3A| Vec3A::new(v[kx], v[ky], v[kz]);
    // Translate vertices to the ray origin, permute and shear.
    let shear = |v: Vec3A| {
        let v = perm(v - o);
        Vec3A::new(v.x + sx * v.z, v.y + sy * v.z, v.z * sz)
    };
    let (p0, p1, p2) = (shear(p[0]), shear(p[1]), shear(p[2]));
    // Edge functions; recompute in double precision when any is exactly zero.
    let mut e0 = p1.x * p2.y - p1.y * p2.x;
    let mut e1 = p2.x * p0.y - p2.y * p0.x;
    let mut e2 = p0.x * p1.y - p0.y * p1.x;
    if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
        let f = |a: Vec3A, b: Vec3A| (a.x as f64 * b.y as f64 - a.y as f64 * b.x as f64) as f32;
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
    let t = (e0 * p0.z + e1 * p1.z + e2 * p2.z) * inv_det;
    if !(t > tmin && t < tmax) {
        return None;
    }
    Some((t, e1 * inv_det, e2 * inv_det))
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
                (
                    p,
                    inv.matrix3.transpose().mul_vec3a(Vec3A::Z).normalize(),
                    [0.0; 2],
                )
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
            Prim::Disk { inv } => (
                o + d * hit.t,
                inv.matrix3.transpose().mul_vec3a(Vec3A::Z).normalize(),
            ),
        }
    }
}

/// A segment from `a` towards `b` as an origin, unit direction and distance limits, ending
/// `SHADOW_EPS` short of `b` (Mitsuba's `spawn_ray_to`).
pub fn shadow_segment(a: &Interaction, b: Vec3A) -> (Vec3A, Vec3A, f32) {
    let o = a.offset_origin(b - a.p);
    let v = b - o;
    let dist = v.length();
    (o, v / dist, dist * (1.0 - SHADOW_EPS))
}
