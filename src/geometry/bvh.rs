//! The scene's ray-tracing acceleration structure: a 16-wide BVH (Dammertz, Hanika and Keller
//! 2008, "Shallow bounding volume hierarchies for fast SIMD ray tracing of incoherent rays";
//! Wald, Benthin and Boulos 2008, "Getting rid of packets"). Each node holds up to sixteen
//! children's boxes, tested against a ray in one AVX-512 vector, two AVX2 ones or four of glam's
//! `Vec4` (SSE2 on x86-64, NEON on aarch64), whichever the CPU has ([`super::wide`]); leaves hold
//! up to eight triangles in one pack ([`super::triangle_pack`]), tested in one AVX2 vector (with
//! AVX-512 too) or two `Vec4`s.
//!
//! The tree's shape comes from a binary tree built top-down by the binned surface-area heuristic
//! ([`sah_tree`], in O(n log n) whatever the input), collapsed here to sixteen children per node,
//! always opening the child with the largest surface, without recursion.
//! Closest-hit traversal is front to back (a popped node farther than the closest hit so far is
//! skipped); shadow rays stop at the first hit.
//!
//! Three points keep hits exact:
//! - triangles use the watertight test (Woop, Benthin and Wald 2013) lane by lane with the very
//!   operations of the scalar [`intersect_triangle`], so both give the same bits; a lane with an
//!   edge function of exactly zero goes to the scalar test and its double-precision fallback;
//! - the slab test widens each far distance by 2γ₃ (pbrt-v4, `Bounds3::IntersectP`), so rounding
//!   never culls a box that the ray meets;
//! - rays parallel to within rounding of an axis plane (a laser aimed straight at a wall, scan rays
//!   in a symmetry plane) do not use the slab test, where 0·∞ and a ray lying in a box face are
//!   ill-conditioned: they visit every node whose box overlaps the box of their segment (clipped
//!   to the scene), which is conservative and few nodes for a ray along an axis.

use super::small_scene::{Packs, Query, SmallScene};
use super::triangle_pack::Pack;
#[cfg(target_arch = "x86_64")]
use super::wide::x86;
use super::wide::{Isa, Mask, Q4, Wide, WideTest, supported};
use super::{Hit, Prim, Watertight};
use crate::cache::prefetch;
use glam::Vec3A;
use std::mem::MaybeUninit;

/// Entries (node code, entry distance) of the traversal stack a ray keeps on its own frame, 2 KiB:
/// room for a tree whose deepest path passes some seventeen full nodes ([`Accel::stack_need`]);
/// a deeper tree's rays each allocate theirs. (A stack kept per thread and reached through
/// thread-local storage cost a call to `__tls_get_addr` and a move of the vector each way, every
/// ray.)
const FRAME_STACK: usize = 256;

/// An axis-aligned box (empty: min +∞, max −∞).
#[derive(Clone, Copy, Debug)]
struct Aabb {
    min: Vec3A,
    max: Vec3A,
}

impl Aabb {
    const EMPTY: Self = Self {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
    };
    fn of(prim: &Prim) -> Self {
        let (min, max) = prim.bounds();
        Self { min, max }
    }
    fn point(p: Vec3A) -> Self {
        Self { min: p, max: p }
    }
    fn union(&self, other: &Self) -> Self {
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }
    fn centre(&self) -> Vec3A {
        (self.min + self.max) * 0.5
    }
    /// Half the surface area (the surface-area heuristic's measure).
    fn half_area(&self) -> f32 {
        let d = self.max - self.min;
        d.x * d.y + d.y * d.z + d.z * d.x
    }
    /// The axis along which the box is longest (the first of equals).
    fn largest_axis(&self) -> usize {
        let d = self.max - self.min;
        if d.x >= d.y && d.x >= d.z {
            0
        } else if d.y >= d.z {
            1
        } else {
            2
        }
    }
}

/// A node of the binary tree [`sah_tree`] builds: a leaf holds `count` primitives from `first`
/// on in the tree's order; an inner node (`count` 0) is the parent of nodes `first` and
/// `first + 1`.
#[derive(Clone, Copy)]
struct BinaryNode {
    bounds: Aabb,
    first: u32,
    count: u32,
}

/// The binary tree: its nodes (the root first) and the primitives' indices in leaf order.
struct BinaryTree {
    nodes: Vec<BinaryNode>,
    order: Vec<u32>,
}

/// Is the (unit) direction parallel, to within rounding, to an axis plane? Such rays take the
/// segment-box traversal (see the module's notes); random directions are this close with
/// probability ~3e-6, scan rays in symmetry planes always.
#[inline]
fn near_axis_plane(d: Vec3A) -> bool {
    d.abs().min_element() < 1e-6
}

/// A child code with this bit set is a leaf (the rest is its index in [`Accel::leaves`]); without
/// it, a node index.
const LEAF: u32 = 1 << 31;
/// A leaf code with this bit set too is a leaf of one triangle pack and nothing else (most are):
/// the rest is the pack's index, so the traversal reads no [`Leaf`] for it. (Indices stay below
/// 2³⁰: that many primitives would take 64 GiB before any tree is built.)
const ONE_PACK: u32 = 1 << 30;
/// An unused child slot (its box is empty, so no ray or segment enters it).
const EMPTY: u32 = u32::MAX;
/// At most this many primitives per leaf (one pack of triangles): the binary tree is split down
/// to leaves of this many or fewer.
const LEAF_PRIMS: u32 = 8;
/// Lanes of a leaf's triangle packs: a leaf in one pack, one AVX2 vector (with AVX-512 as well:
/// packs of sixteen in one AVX-512 vector traced no faster, 0.99–1.01×).
const LEAF_LANES: usize = LEAF_PRIMS as usize;
/// 1 + 2γ₃ (pbrt-v4): the factor that makes the slab test conservative under rounding.
pub(super) const SLAB_PAD: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Children per node: the lanes of one AVX-512 vector.
const WIDTH: usize = 16;

/// A node: its children's boxes, one child per lane: `b[0][axis]` the low and `b[1][axis]` the
/// high bounds.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Node {
    b: [[[f32; WIDTH]; 3]; 2],
    child: [u32; WIDTH],
}

/// A node with every lane unused (empty boxes: low +∞, high −∞).
const EMPTY_NODE: Node = Node {
    b: [[[f32::INFINITY; WIDTH]; 3], [[f32::NEG_INFINITY; WIDTH]; 3]],
    child: [EMPTY; WIDTH],
};

/// The slab test (Kay and Kajiya 1986) of lanes `at..at + V::WIDTH` of the boxes `b` (low and
/// high bounds by axis and lane) against the ray from `org` with inverse direction `inv` over
/// `[tmin, tmax]`: the lanes it enters, and where. Far distances are widened by [`SLAB_PAD`].
/// `inv` must be finite (rays near an axis plane take another test).
///
/// Per axis the bound met first is picked either `BY_SIGN` of the direction, a branch, or by
/// `min` and `max` of both distances, without one: the same distances either way. The tree picks
/// by sign: a ray takes the same branches at every node, and the branch-free test ran the
/// 200k-triangle mesh 0.78× as fast. The small-scene scan tests its boxes once a ray, where the
/// branches go either way at random, and goes without (the branches ran the Cornell box 0.95× as
/// fast). By sign an empty box (low +∞, high −∞) is never entered; without, it is.
#[inline(always)]
pub(super) fn slab<V: Wide, const N: usize, const BY_SIGN: bool>(
    b: &[[[f32; N]; 3]; 2],
    at: usize,
    org: [f32; 3],
    inv: [f32; 3],
    tmin: f32,
    tmax: f32,
) -> (V::Mask, V) {
    let (mut near, mut far) = (V::splat(tmin), V::splat(tmax));
    for a in 0..3 {
        let (o, i) = (V::splat(org[a]), V::splat(inv[a]));
        let (t_near, t_far) = if BY_SIGN {
            let (n, f) = if inv[a] < 0.0 {
                (&b[1][a], &b[0][a])
            } else {
                (&b[0][a], &b[1][a])
            };
            (V::load(n, at).sub(o).mul(i), V::load(f, at).sub(o).mul(i))
        } else {
            let t0 = V::load(&b[0][a], at).sub(o).mul(i);
            let t1 = V::load(&b[1][a], at).sub(o).mul(i);
            (t0.min(t1), t0.max(t1))
        };
        near = near.max(t_near);
        far = far.min(t_far.mul(V::splat(SLAB_PAD)));
    }
    (near.le(far), near)
}

/// A leaf: its triangle packs and its other primitives, as ranges.
#[derive(Clone, Copy)]
struct Leaf {
    packs: (u32, u32),
    others: (u32, u32),
}

/// A 16-wide BVH over the scene's primitives.
pub struct Accel {
    /// Node 0 is the root (when there are primitives).
    nodes: Vec<Node>,
    leaves: Vec<Leaf>,
    packs: Vec<Pack<LEAF_LANES>>,
    /// Spheres and disks, with their index in scene order and plane key ([`Self::plane_of`]).
    others: Vec<(Prim, u32, u32)>,
    /// Per shape: all its primitives are triangles or disks in one plane.
    planar: Vec<bool>,
    /// Per shape: its number of primitives.
    shape_prims: Vec<u32>,
    /// Number of primitives.
    len: usize,
    /// Bounds of every primitive (where an unbounded ray's segment ends).
    bounds: Aabb,
    /// A scene of a few dozen triangles is scanned instead (on a CPU with AVX2), pack by pack: a
    /// ray scans the packs whose boxes it enters.
    small: Option<SmallScene>,
    /// The extension the nodes are tested with (`None`: four lanes at a time in glam's `Vec4`).
    isa: Option<Isa>,
    /// Most entries a traversal's stack can hold: over the paths from the root, the most of the
    /// children a path's nodes have besides the one it goes on to.
    stack_need: usize,
}

/// [`Accel::stack_need`] of the tree `nodes` (node 0 the root, each node's children after it).
fn stack_need(nodes: &[Node]) -> usize {
    let mut need = vec![0usize; nodes.len()];
    for i in (0..nodes.len()).rev() {
        let kids = nodes[i].child.iter().filter(|&&c| c != EMPTY);
        let deepest = kids
            .clone()
            .filter(|&&c| c & LEAF == 0)
            .map(|&c| need[c as usize])
            .max();
        need[i] = kids.count().saturating_sub(1) + deepest.unwrap_or(0);
    }
    need.first().copied().unwrap_or(0)
}

/// The plane key of a primitive on no shared plane.
pub const NO_PLANE: u32 = u32::MAX;

/// Per shape (of `shapes`, owning `prims` by `prim_shape`): whether all its primitives are
/// triangles or disks whose points lie within rounding (1e-6 of the coordinates' magnitude) of
/// one plane (a rectangle, a relay wall, a flat letter, a disk; a disk is judged by its centre and
/// two points of its rim).
fn planar_shapes(prims: &[Prim], prim_shape: &[u32], shapes: usize) -> Vec<bool> {
    let mut plane: Vec<Option<(Vec3A, f32)>> = vec![None; shapes];
    let mut planar = vec![true; shapes];
    for (p, &s) in prims.iter().zip(prim_shape) {
        let s = s as usize;
        if !planar[s] {
            continue;
        }
        let (v, n) = match p {
            Prim::Triangle { v, n } => (*v, *n),
            Prim::Disk { inv } => {
                let m = inv.inverse();
                let on = [Vec3A::ZERO, Vec3A::X, Vec3A::Y].map(|q| m.transform_point3a(q));
                (on, Prim::disk_normal(inv))
            }
            Prim::Sphere { .. } => {
                planar[s] = false;
                continue;
            }
        };
        let (n0, d0) = *plane[s].get_or_insert((n, n.dot(v[0])));
        planar[s] = v
            .iter()
            .all(|v| (n0.dot(*v) - d0).abs() <= 1e-6 * (1.0 + v.abs().max_element()));
    }
    planar
}

/// A ray prepared for the tree's tests.
struct TreeRay {
    tmin: f32,
    /// Slab test: origin and inverse direction per axis.
    org: [f32; 3],
    inv: [f32; 3],
    /// Near an axis plane: the box of the segment (low and high corners, per axis), tested for
    /// overlap instead.
    segment: Option<[[f32; 3]; 2]>,
}

impl TreeRay {
    #[inline]
    fn new(accel: &Accel, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Self {
        let segment =
            near_axis_plane(d).then(|| accel.segment_box(o, d, tmin, tmax).map(|c| c.to_array()));
        Self {
            tmin,
            org: o.to_array(),
            inv: d.recip().to_array(),
            segment,
        }
    }

    /// Which of `node`'s children the ray enters before `tmax` (bit per lane), and where, tested
    /// `V::WIDTH` lanes at a time.
    #[inline(always)]
    fn enter<V: Wide>(&self, node: &Node, tmax: f32) -> (u32, [f32; WIDTH]) {
        let (mut mask, mut near) = (0, [self.tmin; WIDTH]);
        for at in (0..WIDTH).step_by(V::WIDTH) {
            let m = if let Some([lo, hi]) = &self.segment {
                let mut m = V::Mask::from_bits(u32::MAX);
                for a in 0..3 {
                    m = m
                        & V::load(&node.b[0][a], at).le(V::splat(hi[a]))
                        & V::splat(lo[a]).le(V::load(&node.b[1][a], at));
                }
                m
            } else {
                let (m, n) =
                    slab::<V, WIDTH, true>(&node.b, at, self.org, self.inv, self.tmin, tmax);
                n.store_at(&mut near, at);
                m
            };
            mask |= m.bits() << at;
        }
        (mask, near)
    }
}

/// Builds the 16-wide tree from the binary one, without recursion (degenerate input, such as
/// thousands of coincident triangles, makes a deep binary tree).
struct Collapse<'a> {
    tree: &'a BinaryTree,
    prims: &'a [Prim],
    plane: &'a dyn Fn(usize) -> u32,
    nodes: Vec<Node>,
    leaves: Vec<Leaf>,
    packs: Vec<Pack<LEAF_LANES>>,
    others: Vec<(Prim, u32, u32)>,
}

impl<'a> Collapse<'a> {
    fn new(tree: &'a BinaryTree, prims: &'a [Prim], plane: &'a dyn Fn(usize) -> u32) -> Self {
        Self {
            tree,
            prims,
            plane,
            nodes: Vec::new(),
            leaves: Vec::new(),
            packs: Vec::new(),
            others: Vec::new(),
        }
    }

    /// Whether binary node `i` becomes a leaf: a leaf of the binary tree (up to [`LEAF_PRIMS`]
    /// primitives).
    fn is_leaf(&self, i: usize) -> bool {
        self.tree.nodes[i].count > 0
    }

    /// Collapse the whole tree; node 0 is the root.
    fn run(&mut self) {
        let root = if self.is_leaf(0) {
            vec![0]
        } else {
            self.open(0)
        };
        self.nodes.push(EMPTY_NODE);
        let mut todo = vec![(0usize, root)];
        while let Some((id, kids)) = todo.pop() {
            let mut node = EMPTY_NODE;
            for (lane, &k) in kids.iter().enumerate() {
                let bounds = self.tree.nodes[k].bounds;
                for a in 0..3 {
                    node.b[0][a][lane] = bounds.min[a];
                    node.b[1][a][lane] = bounds.max[a];
                }
                node.child[lane] = if self.is_leaf(k) {
                    self.leaf(k)
                } else {
                    self.nodes.push(EMPTY_NODE);
                    todo.push((self.nodes.len() - 1, self.open(k)));
                    (self.nodes.len() - 1) as u32
                };
            }
            self.nodes[id] = node;
        }
    }

    /// Up to [`WIDTH`] binary descendants of inner node `i` that cover it: its children, then,
    /// while fewer, the children of the largest one that is no leaf instead of it.
    fn open(&self, i: usize) -> Vec<usize> {
        let nodes = &self.tree.nodes;
        let first = nodes[i].first as usize;
        let mut kids = vec![first, first + 1];
        while kids.len() < WIDTH {
            let Some(at) = (0..kids.len())
                .filter(|&k| !self.is_leaf(kids[k]))
                .max_by(|&a, &b| {
                    let area = |k: usize| nodes[kids[k]].bounds.half_area();
                    area(a).total_cmp(&area(b))
                })
            else {
                break;
            };
            let first = nodes[kids[at]].first as usize;
            kids[at] = first;
            kids.push(first + 1);
        }
        kids
    }

    /// The leaf of binary leaf `i`: its triangles in packs of [`LEAF_LANES`], its other
    /// primitives apart.
    fn leaf(&mut self, i: usize) -> u32 {
        let (first_pack, first_other) = (self.packs.len() as u32, self.others.len() as u32);
        let n = &self.tree.nodes[i];
        let range = n.first as usize..(n.first + n.count) as usize;
        for &index in &self.tree.order[range] {
            let prim = self.prims[index as usize];
            let plane = (self.plane)(index as usize);
            let Prim::Triangle { v, .. } = prim else {
                self.others.push((prim, index, plane));
                continue;
            };
            // Into this leaf's last pack, or a new one when it is full (or the leaf has none).
            let put = self.packs.len() > first_pack as usize
                && self
                    .packs
                    .last_mut()
                    .is_some_and(|p| p.push(&v, index, plane));
            if !put {
                let mut pack = Pack::EMPTY;
                pack.push(&v, index, plane);
                self.packs.push(pack);
            }
        }
        let leaf = Leaf {
            packs: (first_pack, self.packs.len() as u32),
            others: (first_other, self.others.len() as u32),
        };
        if leaf.packs.1 == first_pack + 1 && leaf.others.0 == leaf.others.1 && first_pack < ONE_PACK
        {
            return LEAF | ONE_PACK | first_pack;
        }
        self.leaves.push(leaf);
        LEAF | (self.leaves.len() - 1) as u32
    }
}

impl Accel {
    /// Build over `prims` (scene order), owned by the `shapes` shapes by `prim_shape`: the tree,
    /// and for a small scene the scan that answers its rays instead ([`super::small_scene`]).
    pub fn build(prims: &[Prim], prim_shape: &[u32], shapes: usize) -> Self {
        let mut accel = Self::build_tree(prims, prim_shape, shapes);
        accel.small = SmallScene::new(prims, |i| accel.plane_of(prim_shape[i]));
        accel
    }

    /// The packs a small scene's ray scans: those whose boxes it enters, or near an axis plane
    /// those whose boxes overlap its segment's (as the traversal chooses).
    #[inline]
    fn packs_to_scan(&self, scan: &SmallScene, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Packs {
        match near_axis_plane(d) {
            true => Packs::Only(scan.overlapping(self.segment_box(o, d, tmin, tmax))),
            false => Packs::Entered,
        }
    }

    /// The tree alone, even for a small scene (what a CPU without AVX2 uses; tests compare both).
    pub fn build_tree(prims: &[Prim], prim_shape: &[u32], shapes: usize) -> Self {
        let planar = planar_shapes(prims, prim_shape, shapes);
        let mut shape_prims = vec![0u32; shapes];
        for &s in prim_shape {
            shape_prims[s as usize] += 1;
        }
        let plane = |i: usize| {
            let s = prim_shape[i];
            if planar[s as usize] { s } else { NO_PLANE }
        };
        let tree = sah_tree(prims);
        // The root's box is the scene's (empty for no primitives).
        let bounds = tree.nodes[0].bounds;
        let mut c = Collapse::new(&tree, prims, &plane);
        if !prims.is_empty() {
            c.run();
        }
        let (nodes, leaves, packs, others) = (c.nodes, c.leaves, c.packs, c.others);
        Self {
            stack_need: stack_need(&nodes),
            nodes,
            leaves,
            packs,
            others,
            planar,
            shape_prims,
            len: prims.len(),
            bounds,
            small: None,
            isa: supported().first().copied(),
        }
    }

    /// The tree alone once for each node test this CPU runs (each extension it has, widest
    /// first, then four lanes of glam's `Vec4`), then four lanes again with each ray's stack
    /// allocated as a tree too deep for [`FRAME_STACK`] has it: tests compare them.
    pub fn each_node_test(prims: &[Prim], prim_shape: &[u32], shapes: usize) -> Vec<Self> {
        let tree = |isa| Self {
            isa,
            ..Self::build_tree(prims, prim_shape, shapes)
        };
        let mut trees: Vec<Self> = supported()
            .into_iter()
            .map(Some)
            .chain([None])
            .map(tree)
            .collect();
        trees.push(Self {
            stack_need: FRAME_STACK + 1,
            ..tree(None)
        });
        trees
    }

    /// The plane key of a point on shape `shape`: the shape if it is planar, else [`NO_PLANE`].
    #[inline]
    pub fn plane_of(&self, shape: u32) -> u32 {
        match self.planar.get(shape as usize) {
            Some(true) => shape,
            _ => NO_PLANE,
        }
    }

    /// Closest hit of the ray `o + t d`, `t ∈ (tmin, tmax)`; `d` must be unit length.
    #[inline]
    pub fn intersect(&self, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<Hit> {
        match &self.small {
            Some(scan) => scan.intersect(Query {
                o,
                d,
                tmin,
                tmax,
                packs: self.packs_to_scan(scan, o, d, tmin, tmax),
            }),
            None => self.intersect_tree(o, d, tmin, tmax),
        }
    }

    /// [`Self::intersect`] through the tree (out of line: the scan's callers stay small), its
    /// nodes tested with the tree's extension.
    #[inline(never)]
    fn intersect_tree(&self, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<Hit> {
        // SAFETY: `isa` was detected on this CPU.
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            Some(Isa::Avx512) => unsafe { self.intersect_tree_avx512(o, d, tmin, tmax) },
            #[cfg(target_arch = "x86_64")]
            Some(Isa::Avx2) => unsafe { self.intersect_tree_avx2(o, d, tmin, tmax) },
            _ => self.closest_in_tree::<Q4, Q4>(o, d, tmin, tmax),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn intersect_tree_avx512(&self, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<Hit> {
        self.closest_in_tree::<x86::Z16, x86::Y8>(o, d, tmin, tmax)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn intersect_tree_avx2(&self, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<Hit> {
        self.closest_in_tree::<x86::Y8, x86::Y8>(o, d, tmin, tmax)
    }

    /// The closest hit through the tree, nodes tested `V::WIDTH` lanes at a time and leaves'
    /// packs `L::WIDTH` (the leaf visits are inlined closures: a closure is not compiled with its
    /// caller's target features, and out of line its AVX2 tests would be calls).
    #[inline(always)]
    fn closest_in_tree<V: Wide, L: WideTest>(
        &self,
        o: Vec3A,
        d: Vec3A,
        tmin: f32,
        tmax: f32,
    ) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let ray = TreeRay::new(self, o, d, tmin, tmax);
        let mut best: Option<Hit> = None;
        let mut tmax = tmax;
        let mut shear = None;
        self.traverse::<V, true>(
            &ray,
            &mut tmax,
            #[inline(always)]
            |leaf, tmax| {
                for p in &self.packs[leaf.packs.0 as usize..leaf.packs.1 as usize] {
                    let sh = shear.get_or_insert_with(|| Watertight::new(o, d));
                    for at in p.steps::<L>() {
                        let l = p.test::<L>(at, sh, tmin, *tmax);
                        let hit = l.hit.bits();
                        let mut lanes = hit | l.redo.bits();
                        if lanes == 0 {
                            continue;
                        }
                        let (t, b1, b2) = (l.t.store(), l.b1.store(), l.b2.store());
                        // The lanes hit or to redo, in order, a candidate accepted only if it
                        // shortens the ray.
                        while lanes != 0 {
                            let i = lanes.trailing_zeros() as usize;
                            lanes &= lanes - 1;
                            let prim = p.prim[at + i];
                            let found = if hit >> i & 1 != 0 {
                                Hit {
                                    t: t[i],
                                    prim,
                                    b: [b1[i], b2[i]],
                                }
                            } else if let Some((t, b1, b2)) = p.lane(at + i, o, d, tmin, *tmax) {
                                Hit {
                                    t,
                                    prim,
                                    b: [b1, b2],
                                }
                            } else {
                                continue;
                            };
                            if found.t < *tmax {
                                *tmax = found.t;
                                best = Some(found);
                            }
                        }
                    }
                }
                for (prim, index, _) in &self.others[leaf.others.0 as usize..leaf.others.1 as usize]
                {
                    if let Some((t, b)) = prim.intersect(o, d, tmin, *tmax) {
                        *tmax = t;
                        best = Some(Hit { t, prim: *index, b });
                    }
                }
                false
            },
        );
        best
    }

    /// True if nothing lies on the open segment `o + t d`, `t ∈ (tmin, tmax)`, where the segment
    /// starts off one of the planes `skip` and ends short of the other ([`Self::plane_of`]): a
    /// segment meets a plane at most once, so it meets no primitive of either plane, and those
    /// are not tested (a shadow ray from a flat relay wall to a flat hidden shape tests nothing of
    /// either).
    #[inline(always)]
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
        if self.len == skipped {
            return true;
        }
        match &self.small {
            Some(scan) => {
                let packs = self.packs_to_scan(scan, o, d, tmin, tmax);
                scan.unoccluded(
                    Query {
                        o,
                        d,
                        tmin,
                        tmax,
                        packs,
                    },
                    skip,
                )
            }
            None => self.unoccluded_tree(o, d, tmin, tmax, skip),
        }
    }

    /// [`Self::unoccluded`] through the tree (out of line, as [`Self::intersect_tree`]).
    #[inline(never)]
    fn unoccluded_tree(&self, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32, skip: [u32; 2]) -> bool {
        // SAFETY: `isa` was detected on this CPU.
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            Some(Isa::Avx512) => unsafe { self.unoccluded_tree_avx512(o, d, tmin, tmax, skip) },
            #[cfg(target_arch = "x86_64")]
            Some(Isa::Avx2) => unsafe { self.unoccluded_tree_avx2(o, d, tmin, tmax, skip) },
            _ => self.unoccluded_in_tree::<Q4, Q4>(o, d, tmin, tmax, skip),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn unoccluded_tree_avx512(
        &self,
        o: Vec3A,
        d: Vec3A,
        tmin: f32,
        tmax: f32,
        skip: [u32; 2],
    ) -> bool {
        self.unoccluded_in_tree::<x86::Z16, x86::Y8>(o, d, tmin, tmax, skip)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn unoccluded_tree_avx2(
        &self,
        o: Vec3A,
        d: Vec3A,
        tmin: f32,
        tmax: f32,
        skip: [u32; 2],
    ) -> bool {
        self.unoccluded_in_tree::<x86::Y8, x86::Y8>(o, d, tmin, tmax, skip)
    }

    /// Whether the segment is unoccluded through the tree, nodes tested `V::WIDTH` lanes at a time
    /// and leaves' packs `L::WIDTH` (as [`Self::closest_in_tree`]).
    #[inline(always)]
    fn unoccluded_in_tree<V: Wide, L: WideTest>(
        &self,
        o: Vec3A,
        d: Vec3A,
        tmin: f32,
        tmax: f32,
        skip: [u32; 2],
    ) -> bool {
        let ray = TreeRay::new(self, o, d, tmin, tmax);
        let mut tmax = tmax;
        let mut miss = true;
        let mut shear = None;
        self.traverse::<V, false>(
            &ray,
            &mut tmax,
            #[inline(always)]
            |leaf, tmax| {
                for p in &self.packs[leaf.packs.0 as usize..leaf.packs.1 as usize] {
                    let sh = shear.get_or_insert_with(|| Watertight::new(o, d));
                    for at in p.steps::<L>() {
                        let l = p.test::<L>(at, sh, tmin, *tmax);
                        let (hit, redo) = (l.hit.bits(), l.redo.bits());
                        if hit | redo == 0 {
                            continue;
                        }
                        // Triangles on the planes `skip` do not count.
                        let kept = !(p.on_planes((hit | redo) << at, skip) >> at);
                        let redo = redo & kept;
                        if hit & kept != 0
                            || (0..L::WIDTH).any(|i| {
                                redo >> i & 1 != 0 && p.lane(at + i, o, d, tmin, *tmax).is_some()
                            })
                        {
                            miss = false;
                            return true;
                        }
                    }
                }
                // Nor do disks on them.
                miss = !self.others[leaf.others.0 as usize..leaf.others.1 as usize]
                    .iter()
                    .any(|(prim, _, plane)| {
                        (*plane == NO_PLANE || !skip.contains(plane))
                            && prim.intersect(o, d, tmin, *tmax).is_some()
                    });
                !miss
            },
        );
        miss
    }

    /// Traverse the tree along `ray` on a stack of its own ([`FRAME_STACK`]), calling
    /// `visit(leaf, tmax)` for each leaf the ray enters before `tmax`; `visit` may shorten `tmax`
    /// and returns whether to stop. With `NEAREST_FIRST` (closest hits) children are visited front to back and a
    /// popped node beyond `tmax` is skipped; without (any hit) in lane order.
    #[inline(always)]
    fn traverse<V: Wide, const NEAREST_FIRST: bool>(
        &self,
        ray: &TreeRay,
        tmax: &mut f32,
        visit: impl FnMut(&Leaf, &mut f32) -> bool,
    ) {
        let mut frame = [MaybeUninit::uninit(); FRAME_STACK];
        let mut deep;
        let stack = if self.stack_need <= FRAME_STACK {
            &mut frame[..]
        } else {
            deep = vec![MaybeUninit::uninit(); self.stack_need];
            &mut deep[..]
        };
        self.walk::<V, NEAREST_FIRST>(stack, ray, tmax, visit);
    }

    /// [`Self::traverse`] on `stack`.
    #[inline(always)]
    fn walk<V: Wide, const NEAREST_FIRST: bool>(
        &self,
        stack: &mut [MaybeUninit<(u32, f32)>],
        ray: &TreeRay,
        tmax: &mut f32,
        mut visit: impl FnMut(&Leaf, &mut f32) -> bool,
    ) {
        // `stack[..top]` holds the entries pushed and not yet popped.
        let mut top = 0;
        let mut code = 0u32;
        loop {
            if code & LEAF != 0 {
                let leaf = match code & ONE_PACK {
                    0 => self.leaves[(code & !LEAF) as usize],
                    _ => {
                        let pack = code & !(LEAF | ONE_PACK);
                        Leaf {
                            packs: (pack, pack + 1),
                            others: (0, 0),
                        }
                    }
                };
                if visit(&leaf, tmax) {
                    return;
                }
            } else {
                let node = &self.nodes[code as usize];
                let (mut mask, near) = ray.enter::<V>(node, *tmax);
                if mask != 0 {
                    // Go on with the nearest entered child; push the others farthest first.
                    let mut entered = [(0u32, 0f32); WIDTH];
                    let mut n = 0;
                    while mask != 0 {
                        let lane = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let t = near[lane];
                        let mut at = n;
                        while NEAREST_FIRST && at > 0 && entered[at - 1].1 < t {
                            entered[at] = entered[at - 1];
                            at -= 1;
                        }
                        self.prefetch(node.child[lane]);
                        entered[at] = (node.child[lane], t);
                        n += 1;
                    }
                    for &e in &entered[..n - 1] {
                        stack[top] = MaybeUninit::new(e);
                        top += 1;
                    }
                    code = entered[n - 1].0;
                    continue;
                }
            }
            // The next node on the stack still in reach.
            loop {
                if top == 0 {
                    return;
                }
                top -= 1;
                // SAFETY: every entry below the old `top` was written by a push.
                let (c, t) = unsafe { stack[top].assume_init() };
                if !NEAREST_FIRST || t <= *tmax {
                    code = c;
                    break;
                }
            }
        }
    }

    /// Start loading the node or the one pack of child code `code` (seven or six cache lines,
    /// nodes and packs being aligned to lines) as soon as a ray is known to enter it: a traversal
    /// waits mostly on these loads (a 13k-triangle mesh's tree sits in L2, not L1), and a child
    /// pushed for later, or the nearest one taken next, is then on its way while the ray's other
    /// children are ordered. With four children a node, on two threads (`benchmarks/ab.py`), the
    /// 200k-triangle mesh with hidden-geometry sampling off rendered 1.03× as fast (one thread
    /// 1.06×), its single capture with it on 1.03×, tal's bunny 1.05× (one thread 0.99–1.05×);
    /// with sixteen, the nodes' prefetch alone is worth 1.04× and 1.02× on the mesh and the bunny.
    #[inline(always)]
    fn prefetch(&self, code: u32) {
        // A node's boxes and child codes (not the padding after them), or a whole pack.
        if code & LEAF == 0 {
            let bytes = size_of::<[[[f32; WIDTH]; 3]; 2]>() + size_of::<[u32; WIDTH]>();
            prefetch(self.nodes.as_ptr().wrapping_add(code as usize), bytes);
        } else if code & ONE_PACK != 0 {
            let at = (code & !(LEAF | ONE_PACK)) as usize;
            prefetch(
                self.packs.as_ptr().wrapping_add(at),
                size_of::<Pack<LEAF_LANES>>(),
            );
        }
    }

    /// The bounding box of the segment `o + t d`, `t ∈ (tmin, tmax)`, inside the scene's bounds,
    /// padded by rounding: it overlaps the box of every primitive the segment meets.
    #[cold]
    fn segment_box(&self, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> [Vec3A; 2] {
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
            .fold(tmax, f32::min)
            .max(tmin);
        let (a, b) = (o + tmin * d, o + exit * d);
        let pad = 1e-5 * (1.0 + a.abs().max(b.abs()).max_element());
        [a.min(b) - pad, a.max(b) + pad]
    }
}

/// Bins per axis of the binned surface-area heuristic (Wald 2007, "On fast construction of
/// SAH-based bounding volume hierarchies").
const SAH_BINS: usize = 16;

/// A binary tree of `prims` by the binned surface-area heuristic, in O(n log n) whatever the
/// input: each node's primitives are binned by their boxes' centres along each axis and split
/// at the bin boundary of least cost (area × count on either side, Wald 2007). Where the centres
/// do not spread, or the node lies deeper than `2 log₂ n + 16` (a run of lopsided splits, as
/// nested boxes give), the split is at the median along the axis of most spread (by index where
/// the centres do not spread at all), so no input takes more than O(n log n). Leaves hold up to
/// [`LEAF_PRIMS`] primitives. The halves of large nodes build in parallel (on the caller's pool),
/// into the same tree whatever the threads.
fn sah_tree(prims: &[Prim]) -> BinaryTree {
    // The primitives' boxes move with them (contiguous passes over a node's part, not gathers).
    let mut items: Vec<Item> = (prims.iter().enumerate())
        .map(|(index, p)| {
            let bounds = Aabb::of(p);
            Item {
                bounds,
                centre: bounds.centre(),
                index: index as u32,
            }
        })
        .collect();
    let deepest = 2 * (usize::BITS - prims.len().leading_zeros()) as usize + 16;
    BinaryTree {
        nodes: subtree(&mut items, 0, 0, deepest),
        order: items.iter().map(|it| it.index).collect(),
    }
}

/// Parts of at least this many primitives have their two halves built in parallel.
const PARALLEL_PART: usize = 1 << 14;

/// The binary tree over `part`, the primitives from `start` on in the tree's order, at `depth`:
/// its root first, children indexed within it. Large parts split, then build their halves in
/// parallel (the same tree as one thread would build).
fn subtree(part: &mut [Item], start: usize, depth: usize, deepest: usize) -> Vec<BinaryNode> {
    if part.len() < PARALLEL_PART {
        return subtree_serial(part, start, depth, deepest);
    }
    let (bounds, Some(half)) = divide(part, depth < deepest) else {
        // (A part this large always splits; were it a leaf, the serial build makes it one.)
        return subtree_serial(part, start, depth, deepest);
    };
    let (left, right) = part.split_at_mut(half);
    let (l, r) = rayon::join(
        || subtree(left, start, depth + 1, deepest),
        || subtree(right, start + half, depth + 1, deepest),
    );
    // The root, the halves' roots (nodes 1 and 2), then the rest of each half.
    let moved = |n: &BinaryNode, by: usize| match n.count {
        0 => BinaryNode {
            first: n.first + by as u32,
            ..*n
        },
        _ => *n,
    };
    let mut nodes = Vec::with_capacity(1 + l.len() + r.len());
    nodes.push(BinaryNode {
        bounds,
        first: 1,
        count: 0,
    });
    nodes.extend([moved(&l[0], 2), moved(&r[0], l.len() + 1)]);
    nodes.extend(l[1..].iter().map(|n| moved(n, 2)));
    nodes.extend(r[1..].iter().map(|n| moved(n, l.len() + 1)));
    nodes
}

/// [`subtree`] on one thread, without recursion.
fn subtree_serial(
    items: &mut [Item],
    start: usize,
    depth: usize,
    deepest: usize,
) -> Vec<BinaryNode> {
    let node = |bounds, first, count| BinaryNode {
        bounds,
        first: first as u32,
        count: count as u32,
    };
    let mut nodes = vec![node(Aabb::EMPTY, 0, 0)];
    let mut todo = vec![(0, 0..items.len(), depth)];
    while let Some((id, range, depth)) = todo.pop() {
        let (bounds, half) = divide(&mut items[range.clone()], depth < deepest);
        let Some(half) = half else {
            nodes[id] = node(bounds, start + range.start, range.len());
            continue;
        };
        let first = nodes.len();
        nodes.extend([node(Aabb::EMPTY, 0, 0); 2]);
        nodes[id] = node(bounds, first, 0);
        let mid = range.start + half;
        todo.push((first, range.start..mid, depth + 1));
        todo.push((first + 1, mid..range.end, depth + 1));
    }
    nodes
}

/// A node's box and, unless it is a leaf (up to [`LEAF_PRIMS`] primitives), how many of its
/// primitives go to its first child once `part` is reordered: by the binned SAH where `sah`, or
/// at the median along the axis of most spread where it is not or finds no split.
fn divide(part: &mut [Item], sah: bool) -> (Aabb, Option<usize>) {
    let (bounds, spread) = part.iter().fold((Aabb::EMPTY, Aabb::EMPTY), |(b, c), it| {
        (b.union(&it.bounds), c.union(&Aabb::point(it.centre)))
    });
    if part.len() <= LEAF_PRIMS as usize {
        return (bounds, None);
    }
    let half = match sah.then(|| sah_split(part, &spread)).flatten() {
        Some(split) => partition(part, |it| split.left(it.centre)),
        None => {
            let axis = spread.largest_axis();
            let half = part.len() / 2;
            part.select_nth_unstable_by(half, |a, b| {
                (a.centre[axis].total_cmp(&b.centre[axis])).then(a.index.cmp(&b.index))
            });
            half
        }
    };
    (bounds, Some(half))
}

/// A primitive in the builder: its box, the box's centre and its index in the scene.
#[derive(Clone, Copy)]
struct Item {
    bounds: Aabb,
    centre: Vec3A,
    index: u32,
}

/// A split of a node's primitives: those whose centres fall in the bins below `bin` along `axis`
/// go left.
#[derive(Clone, Copy)]
struct Split {
    axis: usize,
    lo: f32,
    scale: f32,
    bin: usize,
}

impl Split {
    /// The bin of `c` along the axis.
    fn bin_of(&self, c: Vec3A) -> usize {
        (((c[self.axis] - self.lo) * self.scale) as usize).min(SAH_BINS - 1)
    }
    fn left(&self, c: Vec3A) -> bool {
        self.bin_of(c) < self.bin
    }
}

/// The binned-SAH split of `part` (centres spanning `spread`): the axis and bin boundary with
/// the least area × count on its two sides, or `None` where no axis puts primitives on both
/// sides of any boundary.
fn sah_split(part: &[Item], spread: &Aabb) -> Option<Split> {
    // The axes along which the centres spread, each binned in the same pass over `part`.
    let axes = [0, 1, 2].map(|axis| {
        let (lo, extent) = (spread.min[axis], spread.max[axis] - spread.min[axis]);
        (extent > 0.0).then(|| Split {
            axis,
            lo,
            scale: SAH_BINS as f32 / extent,
            bin: 0,
        })
    });
    let mut bins = [[(Aabb::EMPTY, 0u32); SAH_BINS]; 3];
    for it in part {
        for (bins, at) in bins.iter_mut().zip(&axes) {
            if let Some(at) = at {
                let b = &mut bins[at.bin_of(it.centre)];
                b.0 = b.0.union(&it.bounds);
                b.1 += 1;
            }
        }
    }
    let mut best: Option<(f32, Split)> = None;
    for (bins, at) in bins.iter().zip(axes) {
        let Some(at) = at else { continue };
        // Cost of the right side of each boundary, swept from the right.
        let mut right = [0.0f32; SAH_BINS];
        let (mut acc, mut n) = (Aabb::EMPTY, 0u32);
        for k in (1..SAH_BINS).rev() {
            acc = acc.union(&bins[k].0);
            n += bins[k].1;
            right[k] = if n > 0 {
                acc.half_area() * n as f32
            } else {
                f32::INFINITY
            };
        }
        let (mut acc, mut n) = (Aabb::EMPTY, 0u32);
        for k in 1..SAH_BINS {
            acc = acc.union(&bins[k - 1].0);
            n += bins[k - 1].1;
            let cost = if n > 0 {
                acc.half_area() * n as f32 + right[k]
            } else {
                f32::INFINITY
            };
            if cost.is_finite() && best.is_none_or(|b| cost < b.0) {
                best = Some((cost, Split { bin: k, ..at }));
            }
        }
    }
    best.map(|b| b.1)
}

/// Reorder `part` so that the items `left` holds for come first; returns how many there are.
fn partition(part: &mut [Item], left: impl Fn(&Item) -> bool) -> usize {
    let mut at = 0;
    for k in 0..part.len() {
        if left(&part[k]) {
            part.swap(at, k);
            at += 1;
        }
    }
    at
}

/// Brute-force closest hit over every primitive: the test oracle for [`Accel`] (and a camera
/// pixel's few wall triangles), the ray set up for the watertight test once.
pub fn intersect_brute(prims: &[Prim], o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<Hit> {
    let w = Watertight::new(o, d);
    let mut best: Option<Hit> = None;
    for (i, p) in prims.iter().enumerate() {
        let lim = best.map_or(tmax, |h| h.t);
        let found = match p {
            Prim::Triangle { v, .. } => w.triangle(tmin, lim, v).map(|(t, b1, b2)| (t, [b1, b2])),
            _ => p.intersect(o, d, tmin, lim),
        };
        if let Some((t, b)) = found {
            best = Some(Hit {
                t,
                prim: i as u32,
                b,
            });
        }
    }
    best
}
