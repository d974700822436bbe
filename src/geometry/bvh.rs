//! The one module that talks to obvhs (0.4). It guards against three behaviours of that crate:
//! directions are canonicalised so that no component is
//! `-0.0` (CwBvh would miss such rays), hits use our watertight primitive tests instead of obvhs'
//! Möller–Trumbore ones (which leak through shared edges), and rays (nearly) parallel to an axis plane are
//! traced by brute force: obvhs' node test clamps the entry distance to 1e-4, so it culls a box
//! whose face contains such a ray (a scan ray in a symmetry plane of the scene). Padding the boxes
//! instead would cost every ray: CwBvh quantises child boxes outwards, turning a flat relay wall
//! into a slab that every shadow ray towards the wall enters.

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
/// box face with such a direction can be culled by obvhs' node test although it hits a primitive in
/// the box; random directions are this close with probability ~3e-6, scan rays in symmetry planes always.
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
}

/// Turn `-0.0` components into `+0.0` (CwBvh's node test misses rays with a `-0.0` component);
/// nothing else changes.
#[inline]
pub fn canonical_dir(d: Vec3A) -> Vec3A {
    d + Vec3A::ZERO
}

impl Accel {
    /// Build over `prims` (scene order).
    pub fn build(prims: &[Prim]) -> Self {
        let bvh = build_cwbvh(
            prims,
            BvhBuildParams::medium_build(),
            &mut Default::default(),
        );
        let slot_to_prim = bvh.primitive_indices.clone();
        let prims = slot_to_prim.iter().map(|&i| prims[i as usize]).collect();
        Self {
            bvh,
            prims,
            slot_to_prim,
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
        if near_axis_plane(d) {
            let hit = intersect_brute(&self.prims, o, d, tmin, tmax)?;
            return Some(Hit {
                prim: self.slot_to_prim[hit.prim as usize],
                ..hit
            });
        }
        let mut ray = Self::ray(o, d, tmin, tmax);
        let mut best: Option<Hit> = None;
        TRAVERSAL.with_borrow_mut(|state| {
            state.reinit(ray.direction);
            let mut node;
            obvhs::traverse!(
                self.bvh,
                node,
                state,
                node.intersect_ray(&ray, state.oct_inv4),
                {
                    let slot = state.primitive_id as usize;
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
                }
            );
        });
        best
    }

    /// True if nothing lies on the open segment `o + t d`, `t ∈ (tmin, tmax)`.
    pub fn unoccluded(&self, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> bool {
        if self.prims.is_empty() {
            return true;
        }
        if near_axis_plane(d) {
            return self
                .prims
                .iter()
                .all(|p| p.intersect(o, d, tmin, tmax).is_none());
        }
        let ray = Self::ray(o, d, tmin, tmax);
        TRAVERSAL.with_borrow_mut(|state| {
            state.reinit(ray.direction);
            let mut node;
            let mut miss = true;
            // Any hit ends the traversal (out of the macro's loops).
            'any: {
                obvhs::traverse!(
                    self.bvh,
                    node,
                    state,
                    node.intersect_ray(&ray, state.oct_inv4),
                    {
                        let slot = state.primitive_id as usize;
                        if self.prims[slot]
                            .intersect(ray.origin, ray.direction, ray.tmin, ray.tmax)
                            .is_some_and(|h| h.0 < ray.tmax)
                        {
                            miss = false;
                            break 'any;
                        }
                    }
                );
            }
            miss
        })
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
