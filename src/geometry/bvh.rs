//! The one module that talks to obvhs (0.4). It guards against three behaviours of that crate:
//! directions are canonicalised so that no component is
//! `-0.0` (CwBvh would miss such rays), hits use our watertight primitive tests instead of obvhs'
//! Möller–Trumbore ones (which leak through shared edges), and rays (nearly) parallel to an axis
//! plane do not use obvhs' ray–node test: it clamps the entry distance to 1e-4, so it culls a box
//! whose face contains such a ray (a scan ray in a symmetry plane of the scene). Such a ray visits
//! instead every node whose box overlaps the bounding box of its segment (clipped to the scene):
//! conservative, and few nodes for a ray along an axis (a laser aimed straight at a wall).
//! Padding the boxes instead would cost every ray: CwBvh quantises child boxes outwards, turning a
//! flat relay wall into a slab that every shadow ray towards the wall enters.

use super::{Hit, Prim};
use glam::{UVec2, Vec3A};
use obvhs::{
    Boundable, BvhBuildParams,
    aabb::Aabb,
    cwbvh::{CwBvh, Traversal, builder::build_cwbvh},
    ray::Ray,
};
use std::cell::RefCell;

thread_local! {
    /// Each thread's traversal state, reused from ray to ray: obvhs' own entry points build a
    /// fresh one per ray, zeroing its 256-byte stack (a `memset` that took a tenth of a render's
    /// time); [`Traversal::reinit`] only resets the stack's top.
    static TRAVERSAL: RefCell<Traversal> = RefCell::new(Traversal::default());
}

impl Boundable for Prim {
    fn aabb(&self) -> Aabb {
        let (min, max) = self.bounds();
        Aabb { min, max }
    }
}

/// Is the (unit) direction parallel, to within rounding, to an axis plane? A ray starting on a
/// box face with such a direction can be culled by obvhs' ray–node test although it hits a
/// primitive in the box; random directions are this close with probability ~3e-6, scan rays in
/// symmetry planes always.
#[inline]
fn near_axis_plane(d: Vec3A) -> bool {
    d.abs().min_element() < 1e-6
}

/// A compressed-wide BVH over the scene's primitives, kept in BVH slot order.
pub struct Accel {
    bvh: CwBvh,
    /// Primitives in slot order.
    prims: Vec<Prim>,
    /// Slot → index of the primitive in scene order.
    slot_to_prim: Vec<u32>,
    /// Slot → the plane its primitive lies in: its shape's index if the whole shape is planar,
    /// else [`NO_PLANE`].
    plane: Vec<u32>,
    /// Per shape: all its primitives are triangles in one plane.
    planar: Vec<bool>,
    /// Per shape: its number of primitives.
    shape_prims: Vec<u32>,
    /// Bounds of every primitive (where an unbounded ray's segment ends).
    bounds: Aabb,
}

/// The plane key of a primitive on no shared plane.
pub const NO_PLANE: u32 = u32::MAX;

/// Whether a primitive of plane key `key` lies on one of the planes `skip`.
#[inline]
fn on_skipped(key: u32, skip: [u32; 2]) -> bool {
    key != NO_PLANE && (key == skip[0] || key == skip[1])
}

/// Per shape (of `shapes`, owning `prims` by `prim_shape`): whether all its primitives are
/// triangles whose vertices lie within rounding (1e-6 of the coordinates' magnitude) of one plane
/// (a rectangle, a relay wall, a flat letter).
fn planar_shapes(prims: &[Prim], prim_shape: &[u32], shapes: usize) -> Vec<bool> {
    let mut plane: Vec<Option<(Vec3A, f32)>> = vec![None; shapes];
    let mut planar = vec![true; shapes];
    for (p, &s) in prims.iter().zip(prim_shape) {
        let s = s as usize;
        if !planar[s] {
            continue;
        }
        let Prim::Triangle { v, n } = p else {
            planar[s] = false;
            continue;
        };
        let (n0, d0) = *plane[s].get_or_insert((*n, n.dot(v[0])));
        planar[s] = v
            .iter()
            .all(|v| (n0.dot(*v) - d0).abs() <= 1e-6 * (1.0 + v.abs().max_element()));
    }
    planar
}

/// Turn `-0.0` components into `+0.0` (CwBvh's node test misses rays with a `-0.0` component);
/// nothing else changes.
#[inline]
pub fn canonical_dir(d: Vec3A) -> Vec3A {
    d + Vec3A::ZERO
}

impl Accel {
    /// Build over `prims` (scene order), owned by the `shapes` shapes by `prim_shape`.
    pub fn build(prims: &[Prim], prim_shape: &[u32], shapes: usize) -> Self {
        let bvh = build_cwbvh(
            prims,
            BvhBuildParams::medium_build(),
            &mut Default::default(),
        );
        let slot_to_prim = bvh.primitive_indices.clone();
        let planar = planar_shapes(prims, prim_shape, shapes);
        let plane = slot_to_prim
            .iter()
            .map(|&i| {
                let s = prim_shape[i as usize];
                if planar[s as usize] { s } else { NO_PLANE }
            })
            .collect();
        let mut shape_prims = vec![0u32; shapes];
        for &s in prim_shape {
            shape_prims[s as usize] += 1;
        }
        let bounds = prims.iter().fold(Aabb::empty(), |b, p| b.union(&p.aabb()));
        let prims = slot_to_prim.iter().map(|&i| prims[i as usize]).collect();
        Self {
            bvh,
            prims,
            slot_to_prim,
            plane,
            planar,
            shape_prims,
            bounds,
        }
    }

    /// The plane key of a point on shape `shape`: the shape if it is planar, else [`NO_PLANE`].
    #[inline]
    pub fn plane_of(&self, shape: u32) -> u32 {
        match self.planar.get(shape as usize) {
            Some(true) => shape,
            _ => NO_PLANE,
        }
    }

    fn ray(o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Ray {
        Ray::new(o, canonical_dir(d), tmin, tmax)
    }

    /// Closest hit of the ray `o + t d`, `t ∈ (tmin, tmax)`; `d` must be unit length.
    pub fn intersect(&self, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<Hit> {
        if self.prims.is_empty() {
            return None;
        }
        let mut best: Option<Hit> = None;
        self.traverse(Self::ray(o, d, tmin, tmax), |slot, ray| {
            // Closest hit: a candidate is accepted only if it shortens the ray.
            if let Some((t, b)) =
                self.prims[slot].intersect(ray.origin, ray.direction, ray.tmin, ray.tmax)
                && t < ray.tmax
            {
                ray.tmax = t;
                best = Some(Hit {
                    t,
                    prim: self.slot_to_prim[slot],
                    b,
                });
            }
            false
        });
        best
    }

    /// True if nothing lies on the open segment `o + t d`, `t ∈ (tmin, tmax)`, where the segment
    /// starts off one of the planes `skip` and ends short of the other ([`Self::plane_of`]): a
    /// segment meets a plane at most once, so it meets no primitive of either plane, and those
    /// are not tested (a shadow ray from a flat relay wall to a flat hidden shape tests nothing of
    /// either).
    pub fn unoccluded(&self, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32, skip: [u32; 2]) -> bool {
        // Nothing but the two planes (a flat hidden shape behind a flat relay wall): nothing to test.
        let on_plane = |k: u32| match k {
            NO_PLANE => 0,
            k => self.shape_prims[k as usize] as usize,
        };
        let skipped = on_plane(skip[0])
            + if skip[1] != skip[0] {
                on_plane(skip[1])
            } else {
                0
            };
        if self.prims.len() == skipped {
            return true;
        }
        let mut miss = true;
        self.traverse(Self::ray(o, d, tmin, tmax), |slot, ray| {
            // Any hit ends the traversal.
            miss = on_skipped(self.plane[slot], skip)
                || self.prims[slot]
                    .intersect(ray.origin, ray.direction, ray.tmin, ray.tmax)
                    .is_none_or(|h| h.0 >= ray.tmax);
            !miss
        });
        miss
    }

    /// Traverse the BVH along `ray` on this thread's reused state, calling `visit(slot, ray)` for
    /// each candidate primitive in traversal order; `visit` may shorten the ray and returns
    /// whether to stop. A ray near an axis plane visits the nodes its segment's box overlaps.
    #[inline]
    fn traverse(&self, mut ray: Ray, mut visit: impl FnMut(usize, &mut Ray) -> bool) {
        let segment = near_axis_plane(ray.direction).then(|| self.segment_box(&ray));
        TRAVERSAL.with_borrow_mut(|state| {
            state.reinit(ray.direction);
            let mut node;
            // Out of the macro's loops.
            'stop: {
                obvhs::traverse!(
                    self.bvh,
                    node,
                    state,
                    match &segment {
                        Some(b) => node.intersect_aabb(b, state.oct_inv4),
                        None => node.intersect_ray(&ray, state.oct_inv4),
                    },
                    {
                        if visit(state.primitive_id as usize, &mut ray) {
                            break 'stop;
                        }
                    }
                );
            }
        });
    }

    /// The bounding box of the segment of `ray` inside the scene's bounds, padded by rounding: it
    /// overlaps the box of every primitive the segment meets.
    fn segment_box(&self, ray: &Ray) -> Aabb {
        let (o, d) = (ray.origin, ray.direction);
        // Where the ray leaves the scene's bounds, along the axes it moves on.
        let exit = (0..3)
            .filter(|&a| d[a] != 0.0)
            .map(|a| {
                let far = if d[a] > 0.0 {
                    self.bounds.max[a]
                } else {
                    self.bounds.min[a]
                };
                (far - o[a]) / d[a]
            })
            .fold(ray.tmax, f32::min)
            .max(ray.tmin);
        let (a, b) = (o + ray.tmin * d, o + exit * d);
        let pad = 1e-5 * (1.0 + a.abs().max(b.abs()).max_element());
        Aabb::new(a.min(b) - pad, a.max(b) + pad)
    }
}

/// Brute-force closest hit over every primitive: the test oracle for [`Accel`].
pub fn intersect_brute(prims: &[Prim], o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for (i, p) in prims.iter().enumerate() {
        let lim = best.map_or(tmax, |h| h.t);
        if let Some((t, b)) = p.intersect(o, d, tmin, lim) {
            best = Some(Hit {
                t,
                prim: i as u32,
                b,
            });
        }
    }
    best
}
