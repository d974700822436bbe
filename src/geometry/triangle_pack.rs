//! Triangles in packs of `N`, one per SIMD lane, tested against a ray `V::WIDTH` lanes at a time
//! ([`super::wide`]) with the watertight test (Woop, Benthin and Wald 2013): each lane runs the
//! operations of the scalar [`intersect_triangle`] in its order (no fused multiply-add), so a
//! lane's hit is the scalar test's, bit for bit; a lane with an edge function of exactly zero is
//! left to the scalar test and its double-precision fallback ([`Pack::lane`]). The tree's leaves
//! ([`super::bvh`]) and the small-scene scan ([`super::small_scene`]) both keep their triangles
//! so.

use super::bvh::NO_PLANE;
use super::wide::{Mask, Wide, WideTest};
use super::{Watertight, intersect_triangle};
use glam::Vec3A;

/// `N` triangles, one per lane.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub(super) struct Pack<const N: usize> {
    /// `v[vertex][axis][lane]`.
    v: [[[f32; N]; 3]; 3],
    /// Each lane's primitive index in scene order.
    pub prim: [u32; N],
    /// Each lane's plane key ([`super::bvh::Accel::plane_of`]).
    plane: [u32; N],
    /// Lanes holding a triangle (bit per lane).
    pub valid: u32,
}

/// One step's lanes: hit in `(tmin, tmax)` and to redo in the scalar test, and each lane's
/// distance and barycentrics (meaningful in the hit lanes).
#[derive(Clone, Copy)]
pub(super) struct Lanes<V: WideTest> {
    pub hit: V::Mask,
    pub redo: V::Mask,
    pub t: V,
    pub b1: V,
    pub b2: V,
}

impl<const N: usize> Pack<N> {
    /// A pack with no triangle.
    pub const EMPTY: Self = Self {
        v: [[[0.0; N]; 3]; 3],
        prim: [0; N],
        plane: [NO_PLANE; N],
        valid: 0,
    };

    /// Put triangle `v` (primitive `prim`, plane key `plane`) in the first free lane; false if
    /// the pack is full.
    pub fn push(&mut self, v: &[Vec3A; 3], prim: u32, plane: u32) -> bool {
        let lane = self.valid.count_ones() as usize;
        if lane == N {
            return false;
        }
        for (k, vk) in v.iter().enumerate() {
            for a in 0..3 {
                self.v[k][a][lane] = vk[a];
            }
        }
        self.prim[lane] = prim;
        self.plane[lane] = plane;
        self.valid |= 1 << lane;
        true
    }

    /// The watertight test on lanes `at..at + V::WIDTH` in a vector `V`, each lane with the
    /// operations of [`intersect_triangle`] in its order.
    #[inline(always)]
    pub fn test<V: WideTest>(&self, at: usize, sh: &Watertight, tmin: f32, tmax: f32) -> Lanes<V> {
        const { assert!(V::WIDTH <= N, "a pack narrower than the vector") };
        let ko = [V::splat(sh.ko[0]), V::splat(sh.ko[1]), V::splat(sh.ko[2])];
        let s = [V::splat(sh.s[0]), V::splat(sh.s[1]), V::splat(sh.s[2])];
        let p0 = vertex(&self.v[0], at, sh.k, ko, s);
        let p1 = vertex(&self.v[1], at, sh.k, ko, s);
        let p2 = vertex(&self.v[2], at, sh.k, ko, s);
        let e0 = p1[0].mul(p2[1]).sub(p1[1].mul(p2[0]));
        let e1 = p2[0].mul(p0[1]).sub(p2[1].mul(p0[0]));
        let e2 = p0[0].mul(p1[1]).sub(p0[1].mul(p1[0]));
        let zero = V::splat(0.0);
        let valid = V::Mask::from_bits(self.valid >> at);
        let redo = (e0.eq(zero) | e1.eq(zero) | e2.eq(zero)) & valid;
        // Where no edge function is zero (the lanes not redone), some are negative and some
        // positive exactly where their sign bits differ; and where they all share a sign their
        // sum is not zero, so the scalar test's `det == 0` rejects nothing more here.
        let mixed = V::signs_differ(e0, e1, e2);
        let det = e0.add(e1).add(e2);
        let inv_det = V::splat(1.0).div(det);
        let t = e0
            .mul(p0[2])
            .add(e1.mul(p1[2]))
            .add(e2.mul(p2[2]))
            .mul(inv_det);
        let hit = !mixed & V::splat(tmin).lt(t) & t.lt(V::splat(tmax)) & valid & !redo;
        Lanes {
            hit,
            redo,
            t,
            b1: e1.mul(inv_det),
            b2: e2.mul(inv_det),
        }
    }

    /// The steps of `V::WIDTH` lanes this pack takes (lanes are filled from the first): where
    /// each starts.
    #[inline(always)]
    pub fn steps<V: Wide>(&self) -> impl Iterator<Item = usize> {
        (0..N)
            .step_by(V::WIDTH)
            .take_while(|&at| self.valid >> at != 0)
    }

    /// Those of the lanes `lanes` (bit per lane) of this pack that lie on one of the planes `skip`
    /// (only the lanes asked for are read: a step's few hit lanes).
    #[inline(always)]
    pub fn on_planes(&self, lanes: u32, skip: [u32; 2]) -> u32 {
        let (mut on, mut left) = (0, lanes);
        while left != 0 {
            let lane = left.trailing_zeros() as usize;
            left &= left - 1;
            let key = self.plane[lane];
            if key != NO_PLANE && (key == skip[0] || key == skip[1]) {
                on |= 1 << lane;
            }
        }
        on
    }

    /// The scalar watertight test on lane `lane` (rare: an edge function was exactly zero).
    #[cold]
    #[inline(never)]
    pub fn lane(
        &self,
        lane: usize,
        o: Vec3A,
        d: Vec3A,
        tmin: f32,
        tmax: f32,
    ) -> Option<(f32, f32, f32)> {
        let v = self
            .v
            .map(|v| Vec3A::new(v[0][lane], v[1][lane], v[2][lane]));
        intersect_triangle(o, d, tmin, tmax, &v)
    }
}

/// One vertex `v` of lanes `at..at + V::WIDTH` relative to the ray's origin, permuted by `k` and
/// sheared.
#[inline(always)]
fn vertex<V: WideTest, const N: usize>(
    v: &[[f32; N]; 3],
    at: usize,
    k: [usize; 3],
    ko: [V; 3],
    s: [V; 3],
) -> [V; 3] {
    let z = V::load(&v[k[2]], at).sub(ko[2]);
    [
        V::load(&v[k[0]], at).sub(ko[0]).add(s[0].mul(z)),
        V::load(&v[k[1]], at).sub(ko[1]).add(s[1].mul(z)),
        z.mul(s[2]),
    ]
}
