//! Rays in a scene of a few dozen triangles without walking a tree: every triangle of the packs a
//! ray enters is tested, sixteen per step in an AVX-512 vector or eight in an AVX2 one. The triangles
//! sit in up to sixteen packs, runs of scene order cut so that the rays a scene's paths trace
//! enter few of their bounding boxes ([`runs`]: a Cornell box's five walls, its light and each box
//! in it a pack of their own). A ray is first tested against the packs' boxes, in the same
//! vectors (the slab test of [`super::bvh::Accel`]'s nodes, lane for lane), then the packs it
//! enters are scanned — closest hits and shadow rays alike, in open scenes and closed ones.
//! Micro-benchmark figures are in docs/architecture.md ("The BVH").
//!
//! Hits are those of the scalar watertight test ([`super::intersect_triangle`]) bit for bit: each
//! lane runs its operations in its order (no fused multiply-add), and a lane with an edge function
//! of exactly zero is redone by the scalar test and its double-precision fallback
//! ([`super::triangle_pack`]). The closest hit takes the lowest primitive index among equal
//! distances, as the brute-force oracle [`super::bvh::intersect_brute`] does.
//!
//! The scan is compiled for AVX-512 and for AVX2 and picked at run time: the widest the CPU has,
//! or AVX2 where eight lanes hold every pack and its packs take few more eight-lane steps than
//! sixteen-lane ones (on Zen 4, with its AVX-512 operations issued as two halves: mitransient's
//! room 1.03× with hidden-geometry sampling on and 1.11× with it off, the Cornell boxes 1.03×). A
//! CPU with neither (or another architecture) uses the BVH.

use super::bvh::slab;
use super::triangle_pack::Pack;
#[cfg(target_arch = "x86_64")]
use super::wide::x86;
use super::wide::{Isa, Mask, Wide, WideClosest, WideTest, supported};
use super::{Hit, Prim, Watertight};
use glam::Vec3A;

/// Triangles per step.
const LANES: usize = 16;
/// Most triangles a scene may have to be scanned instead of traversed (four full packs).
pub const MAX_TRIANGLES: usize = 64;
/// Most packs of a small scene: their boxes are tested as the lanes of one step's vectors.
const MAX_PACKS: usize = LANES;

/// Every triangle of a small scene, in at most [`MAX_PACKS`] packs of up to sixteen, in scene
/// order: consecutive runs cut so that the scene's rays enter few of their boxes ([`runs`]), and
/// a ray scans only the packs whose boxes it enters.
#[derive(Clone)]
pub struct SmallScene {
    packs: Vec<Pack<LANES>>,
    /// Each pack's bounding box by lane, `boxes[corner][axis][pack]` (low and high corners), for
    /// the slab test; lanes without a pack hold an empty box (low +∞, high −∞) and are masked
    /// off by `all`.
    boxes: [[[f32; LANES]; 3]; 2],
    /// A bit for each pack.
    all: u32,
    isa: Isa,
}

/// Which packs a [`Query`] scans.
#[derive(Clone, Copy, Debug)]
pub enum Packs {
    /// Those whose boxes the ray enters before `tmax`: the slab test, which a ray within 1e-6 of
    /// an axis plane must not take (as [`super::bvh::Accel`]'s traversal).
    Entered,
    /// These (bit per pack: [`ALL_PACKS`] for every one, or [`SmallScene::overlapping`] a
    /// segment's box for a ray too close to an axis plane for the slab test).
    Only(u32),
}

/// A ray query of the scan: the ray `o + t d` (`d` of unit length), `t ∈ (tmin, tmax)`, over the
/// packs `packs`.
#[derive(Clone, Copy, Debug)]
pub struct Query {
    /// Origin.
    pub o: Vec3A,
    /// Unit direction.
    pub d: Vec3A,
    /// Where the open interval starts.
    pub tmin: f32,
    /// Where it ends.
    pub tmax: f32,
    /// The packs to scan.
    pub packs: Packs,
}

impl SmallScene {
    /// The scan over `prims` (plane keys by `plane`, for shadow rays) if they are at most
    /// [`MAX_TRIANGLES`] triangles and the CPU has AVX-512 or AVX2 (the widest is used).
    pub fn new(prims: &[Prim], plane: impl Fn(usize) -> u32) -> Option<Self> {
        let isas = supported();
        if isas.is_empty() || prims.len() > MAX_TRIANGLES {
            return None;
        }
        let tris = prims
            .iter()
            .map(|p| match p {
                Prim::Triangle { v, .. } => Some(*v),
                _ => None,
            })
            .collect::<Option<Vec<_>>>()?;
        let mut packs = Vec::new();
        let mut boxes = [[[f32::INFINITY; LANES]; 3], [[f32::NEG_INFINITY; LANES]; 3]];
        for run in runs(&tris) {
            let mut pack = Pack::EMPTY;
            for i in run.clone() {
                pack.push(&tris[i], i as u32, plane(i));
            }
            let bb = bounding_box(&tris[run]);
            for a in 0..3 {
                boxes[0][a][packs.len()] = bb[0][a];
                boxes[1][a][packs.len()] = bb[1][a];
            }
            packs.push(pack);
        }
        // The narrowest extension where eight lanes hold every pack's box and the packs take
        // fewer than 1.5 times as many eight-lane steps as sixteen-lane ones, else the widest: on
        // Zen 4 an AVX-512 operation issues as two 256-bit halves. (A room of walls, packs of up
        // to six triangles: as many steps either way. A Cornell box, six packs of two and two of
        // twelve: ten against eight, 1.03×. The Z, packs of 16, 16, 4 and 2: six against four,
        // 0.95–0.97× when it took eight lanes.)
        let steps = |w: u32| {
            packs
                .iter()
                .map(|p| p.valid.count_ones().div_ceil(w))
                .sum::<u32>()
        };
        let eight = packs.len() <= 8 && 2 * steps(8) < 3 * steps(16);
        let isa = if eight { isas[isas.len() - 1] } else { isas[0] };
        Some(Self {
            all: (1 << packs.len()) - 1,
            packs,
            boxes,
            isa,
        })
    }

    /// The scan over `prims` once for each SIMD extension this CPU has (tests compare them):
    /// the same packs, cut once.
    pub fn each_extension(prims: &[Prim], plane: impl Fn(usize) -> u32) -> Vec<Self> {
        let Some(scan) = Self::new(prims, plane) else {
            return Vec::new();
        };
        supported()
            .into_iter()
            .map(|isa| Self {
                isa,
                ..scan.clone()
            })
            .collect()
    }

    /// Each pack's bounding box (low and high corners), in pack order: bit `k` of a
    /// [`Packs::Only`] mask.
    pub fn bounds(&self) -> Vec<[Vec3A; 2]> {
        (0..self.packs.len()).map(|k| self.pack_box(k)).collect()
    }

    /// Pack `k`'s bounding box (low and high corners), read from its lanes of `boxes`.
    fn pack_box(&self, k: usize) -> [Vec3A; 2] {
        let [lo, hi] = &self.boxes;
        [lo, hi].map(|c| Vec3A::new(c[0][k], c[1][k], c[2][k]))
    }

    /// The packs whose boxes overlap the box `[low, high]` (bit per pack; the traversal's test
    /// of a node against a segment's box, for rays near an axis plane).
    #[cold]
    pub fn overlapping(&self, [low, high]: [Vec3A; 2]) -> u32 {
        (0..self.packs.len()).fold(0, |m, k| {
            let [lo, hi] = self.pack_box(k);
            m | ((lo.cmple(high) & hi.cmpge(low)).all() as u32) << k
        })
    }

    /// The closest hit of the query's ray among its packs.
    // (Off x86-64 no scan is built, and `isa` has no value.)
    #[cfg_attr(not(target_arch = "x86_64"), allow(unused_variables))]
    pub fn intersect(&self, q: Query) -> Option<Hit> {
        // SAFETY: `isa` was detected on this CPU.
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => unsafe { self.intersect_avx512(q) },
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => unsafe { self.intersect_avx2(q) },
        }
    }

    /// True if no triangle of the query's packs off the planes `skip` lies on its open segment
    /// (as [`super::bvh::Accel::unoccluded`]).
    #[cfg_attr(not(target_arch = "x86_64"), allow(unused_variables))]
    pub fn unoccluded(&self, q: Query, skip: [u32; 2]) -> bool {
        // SAFETY: `isa` was detected on this CPU.
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => unsafe { self.unoccluded_avx512(q, skip) },
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => unsafe { self.unoccluded_avx2(q, skip) },
        }
    }

    // A shadow ray's box test is in the call and its scan out of line: most shadow rays of an
    // NLOS scene enter no pack and return from a short function.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn unoccluded_avx512(&self, q: Query, skip: [u32; 2]) -> bool {
        let packs = self.packs_of::<x86::Z16>(&q);
        packs == 0 || self.any_hit_avx512(&q, packs, skip)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    #[inline(never)]
    fn any_hit_avx512(&self, q: &Query, packs: u32, skip: [u32; 2]) -> bool {
        self.any_hit::<x86::Z16>(q, packs, skip)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn unoccluded_avx2(&self, q: Query, skip: [u32; 2]) -> bool {
        let packs = self.packs_of::<x86::Y8>(&q);
        packs == 0 || self.any_hit_avx2(&q, packs, skip)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    fn any_hit_avx2(&self, q: &Query, packs: u32, skip: [u32; 2]) -> bool {
        self.any_hit::<x86::Y8>(q, packs, skip)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn intersect_avx512(&self, q: Query) -> Option<Hit> {
        self.closest::<x86::Z16>(q)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn intersect_avx2(&self, q: Query) -> Option<Hit> {
        self.closest::<x86::Y8>(q)
    }

    /// The packs the query scans (bit per pack): the tree's slab test ([`slab`], its distances
    /// bit for bit) on the packs' boxes, so a ray enters the boxes the tree's nodes would let it
    /// enter (lanes without a pack, whose empty boxes the branch-free test enters, masked off).
    #[inline(always)]
    fn packs_of<V: Wide>(&self, q: &Query) -> u32 {
        match q.packs {
            Packs::Only(packs) => packs & self.all,
            Packs::Entered => {
                let (o, inv) = (q.o.to_array(), q.d.recip().to_array());
                let mut m = 0;
                // A plain loop, no closure: a closure is not compiled with the caller's target
                // features, and its vector operations would be calls.
                let mut at = 0;
                while at < MAX_PACKS && self.all >> at != 0 {
                    m |= slab::<V, LANES, false>(&self.boxes, at, o, inv, q.tmin, q.tmax)
                        .0
                        .bits()
                        << at;
                    at += V::WIDTH;
                }
                m & self.all
            }
        }
    }

    /// The closest hit, without a branch per lane or per pack: each lane keeps the least
    /// distance its triangles in the packs entered reach (and, at equal distances, the earliest
    /// pack's), then among the lanes at the least distance over all, the lowest primitive index —
    /// the hit a scan in scene order that accepts a triangle only if it shortens the ray keeps.
    /// With a lane to redo in the scalar test (an edge function exactly zero), that scan itself.
    #[inline(always)]
    fn closest<V: WideClosest>(&self, q: Query) -> Option<Hit> {
        let Query {
            o, d, tmin, tmax, ..
        } = q;
        let packs = self.packs_of::<V>(&q);
        if packs == 0 {
            return None;
        }
        let sh = Watertight::new(o, d);
        let inf = V::splat(f32::INFINITY);
        let (mut t, mut b1, mut b2, mut prim) = (inf, inf, inf, inf);
        let (mut left, mut redo) = (packs, V::Mask::from_bits(0));
        while left != 0 {
            let p = &self.packs[left.trailing_zeros() as usize];
            left &= left - 1;
            for at in p.steps::<V>() {
                let l = p.test::<V>(at, &sh, tmin, tmax);
                redo = redo | l.redo;
                let closer = l.hit & l.t.lt(t);
                t = V::select(closer, l.t, t);
                b1 = V::select(closer, l.b1, b1);
                b2 = V::select(closer, l.b2, b2);
                prim = V::select(closer, V::load_bits(&p.prim, at), prim);
            }
        }
        if redo.bits() != 0 {
            return self.scan::<V>(&sh, o, d, tmin, tmax, packs);
        }
        let least = t.reduce_min();
        if least == f32::INFINITY {
            return None;
        }
        let (mut at_least, prims) = (t.eq(V::splat(least)).bits(), prim.store());
        let mut lane = at_least.trailing_zeros() as usize;
        at_least &= at_least - 1;
        while at_least != 0 {
            let other = at_least.trailing_zeros() as usize;
            at_least &= at_least - 1;
            if prims[other].to_bits() < prims[lane].to_bits() {
                lane = other;
            }
        }
        Some(Hit {
            t: least,
            prim: prims[lane].to_bits(),
            b: [b1.lane(lane), b2.lane(lane)],
        })
    }

    /// The closest hit over the packs `packs` in scene order, a lane accepted only if it shortens
    /// the ray; lanes to redo go to the scalar test.
    #[cold]
    #[inline(never)]
    fn scan<V: WideTest>(
        &self,
        sh: &Watertight,
        o: Vec3A,
        d: Vec3A,
        tmin: f32,
        tmax: f32,
        packs: u32,
    ) -> Option<Hit> {
        let (mut best, mut shortest) = (None, tmax);
        for (k, p) in self.packs.iter().enumerate() {
            if packs >> k & 1 == 0 {
                continue;
            }
            for at in p.steps::<V>() {
                let l = p.test::<V>(at, sh, tmin, tmax);
                let hit = l.hit.bits();
                let mut lanes = hit | l.redo.bits();
                while lanes != 0 {
                    let i = lanes.trailing_zeros() as usize;
                    lanes &= lanes - 1;
                    let found = if hit >> i & 1 != 0 {
                        Some((l.t.lane(i), l.b1.lane(i), l.b2.lane(i)))
                    } else {
                        p.lane(at + i, o, d, tmin, shortest)
                    };
                    if let Some((t, b1, b2)) = found
                        && t < shortest
                    {
                        shortest = t;
                        best = Some(Hit {
                            t,
                            prim: p.prim[at + i],
                            b: [b1, b2],
                        });
                    }
                }
            }
        }
        best
    }

    /// Whether the segment is free of triangles off the planes `skip` in the packs `packs`: every
    /// pack is tested before one branch on the result; a lane to redo goes to the scalar test.
    #[inline(always)]
    fn any_hit<V: WideTest>(&self, q: &Query, packs: u32, skip: [u32; 2]) -> bool {
        let Query {
            o, d, tmin, tmax, ..
        } = *q;
        let sh = Watertight::new(o, d);
        let (mut hit, mut redo) = (false, false);
        let mut left = packs;
        while left != 0 {
            let p = &self.packs[left.trailing_zeros() as usize];
            left &= left - 1;
            for at in p.steps::<V>() {
                let l = p.test::<V>(at, &sh, tmin, tmax);
                let (h, r) = (l.hit.bits(), l.redo.bits());
                if h | r != 0 {
                    let kept = !(p.on_planes((h | r) << at, skip) >> at);
                    hit |= h & kept != 0;
                    redo |= r & kept != 0;
                }
            }
        }
        !(hit || redo && self.redo_hits(o, d, tmin, tmax, skip, packs))
    }

    /// Whether a triangle off the planes `skip` meets the segment in the scalar test: the answer
    /// once a lane had to be redone and no other lane met it (rare).
    #[cold]
    #[inline(never)]
    fn redo_hits(
        &self,
        o: Vec3A,
        d: Vec3A,
        tmin: f32,
        tmax: f32,
        skip: [u32; 2],
        packs: u32,
    ) -> bool {
        self.packs.iter().enumerate().any(|(k, p)| {
            packs >> k & 1 != 0
                && (0..LANES).any(|lane| {
                    p.valid >> lane & 1 != 0
                        && p.on_planes(1 << lane, skip) == 0
                        && p.lane(lane, o, d, tmin, tmax).is_some()
                })
        })
    }
}

/// Every pack, as a [`SmallScene::intersect`] or [`SmallScene::unoccluded`] mask.
pub const ALL_PACKS: u32 = (1 << MAX_PACKS) - 1;

/// Scene order cut into at most [`MAX_PACKS`] consecutive runs of at most [`LANES`] triangles,
/// so that the rays the scene's paths trace enter as few of the runs' bounding boxes as they can
/// (every box a ray enters is a pack it scans). Those rays are modelled by probes ([`probes`]):
/// rays leaving each triangle's front (closest hits) and segments between triangles (shadow
/// rays), weighted by area. A ray that leaves a flat box never enters it again, and a segment
/// inside a room meets none of its walls, so a Cornell box's walls come out as packs of their own
/// (the surface area heuristic, which counts lines from outside the boxes, would keep the room in
/// one box, which every ray inside it enters), and each box standing in the room as another.
/// Runs keep scene order, so the scan's tie rule (the lowest primitive index among equal
/// distances) still follows pack and lane order. Dynamic programming over the cut points (at
/// most 64 triangles, 16 runs).
fn runs(tris: &[[Vec3A; 3]]) -> Vec<std::ops::Range<usize>> {
    /// What a pack costs beyond its scan: its lane of the box test (fewer packs on a tie).
    const PACK: f32 = 0.01;
    /// What each four packs cost every ray: one node's box test, about a quarter of a pack's
    /// scan (with the Z's shadow rays, which rarely enter a pack, six packs rendered 0.81× as
    /// fast as four).
    const NODE: f32 = 0.25;
    let n = tris.len();
    let probes = probes(tris);
    let total: f32 = probes.iter().map(|p| p.3).sum();
    // entered[i][len - 1]: the probes' weight (a share of the total) entering the box of
    // i..i + len.
    let entered: Vec<Vec<f32>> = (0..n)
        .map(|i| {
            (i + 1..=n.min(i + LANES))
                .map(|j| {
                    let [lo, hi] = bounding_box(&tris[i..j]);
                    let w: f32 = probes
                        .iter()
                        .filter(|(o, inv, tmax, _)| enters(lo, hi, *o, *inv, *tmax))
                        .map(|p| p.3)
                        .sum();
                    if total > 0.0 { w / total } else { 0.0 }
                })
                .collect()
        })
        .collect();
    // cost[k][j]: the least cost of j triangles in k runs, and where the last run starts.
    let mut cost = vec![vec![(f32::INFINITY, 0); n + 1]; MAX_PACKS + 1];
    cost[0][0] = (0.0, 0);
    for k in 1..=MAX_PACKS {
        for j in 1..=n {
            for i in j.saturating_sub(LANES)..j {
                let c = cost[k - 1][i].0 + entered[i][j - i - 1] + PACK;
                if c < cost[k][j].0 {
                    cost[k][j] = (c, i);
                }
            }
        }
    }
    let total = |k: usize| cost[k][n].0 + NODE * k.div_ceil(4) as f32;
    let mut k = (1..=MAX_PACKS)
        .min_by(|&a, &b| total(a).total_cmp(&total(b)).then(a.cmp(&b)))
        .unwrap_or(1);
    let (mut j, mut out) = (n, Vec::new());
    while j > 0 {
        let i = cost[k][j].1;
        out.push(i..j);
        (j, k) = (i, k - 1);
    }
    out.reverse();
    out
}

/// Probes for [`runs`], as (origin, reciprocal direction, end, weight), half of the weight in
/// rays and half in segments. Rays: from each triangle's centroid, just off its front face, in
/// each of 16 fixed directions (a Fibonacci sphere, none along an axis) in front of it, weighted
/// by the triangle's area. Segments: from each triangle's centroid to those of up to eight others
/// spread through scene order, ending just short, weighted by the product of their areas.
fn probes(tris: &[[Vec3A; 3]]) -> Vec<(Vec3A, Vec3A, f32, f32)> {
    const DIRECTIONS: usize = 16;
    const PARTNERS: usize = 8;
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let dirs: Vec<Vec3A> = (0..DIRECTIONS)
        .map(|i| {
            let z = 1.0 - (2 * i + 1) as f32 / DIRECTIONS as f32;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f32;
            Vec3A::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect();
    let eps = 1e-4
        * (1.0
            + tris
                .iter()
                .flatten()
                .fold(0.0f32, |m, v| m.max(v.abs().max_element())));
    // Each triangle's centroid, unit normal and area (degenerate ones have none).
    let faces: Vec<(Vec3A, Vec3A, f32)> = tris
        .iter()
        .filter_map(|[a, b, c]| {
            let n = (*b - *a).cross(*c - *a);
            Some(((*a + *b + *c) / 3.0, n.try_normalize()?, 0.5 * n.length()))
        })
        .collect();
    let (mut rays, mut segments) = (Vec::new(), Vec::new());
    for (i, &(c, n, area)) in faces.iter().enumerate() {
        let front: Vec<Vec3A> = dirs.iter().copied().filter(|d| n.dot(*d) > 0.0).collect();
        let w = area / front.len().max(1) as f32;
        rays.extend(
            front
                .into_iter()
                .map(|d| (c + n * eps, d.recip(), f32::INFINITY, w)),
        );
        for m in 0..PARTNERS.min(faces.len() - 1) {
            let (c2, _, area2) = faces[(i + 1 + m * faces.len() / PARTNERS) % faces.len()];
            let o = c + n * eps.copysign(n.dot(c2 - c));
            let Some(d) = (c2 - o).try_normalize() else {
                continue;
            };
            segments.push((o, d.recip(), (c2 - o).length() - eps, area * area2));
        }
    }
    // Half the weight each.
    let sum = |v: &[(Vec3A, Vec3A, f32, f32)]| v.iter().map(|p| p.3).sum::<f32>();
    let (wr, ws) = (sum(&rays), sum(&segments));
    for p in &mut rays {
        p.3 /= wr;
    }
    for p in &mut segments {
        p.3 /= ws;
    }
    rays.extend(segments);
    rays
}

/// Whether the ray from `o` with reciprocal direction `inv` enters the box `lo`–`hi` before
/// `tmax`.
fn enters(lo: Vec3A, hi: Vec3A, o: Vec3A, inv: Vec3A, tmax: f32) -> bool {
    let (t0, t1) = ((lo - o) * inv, (hi - o) * inv);
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element().min(tmax);
    near <= far
}

/// The bounding box of triangles (low and high corners).
fn bounding_box(tris: &[[Vec3A; 3]]) -> [Vec3A; 2] {
    tris.iter().flatten().fold(
        [Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY)],
        |[lo, hi], &v| [lo.min(v), hi.max(v)],
    )
}
