//! Uniform sampling of scene surfaces by area: a point on a set of shapes with density
//! 1/A_total. Hidden-geometry sampling (mitransient-model §3.3) draws from the hidden shapes, and
//! next-event estimation from an area light's shape. A draw can also be judged from its first
//! uniform alone: whether the point it makes surely faces away from a given point
//! ([`AreaSampler::faces_away`]), which lets a scan point's sample end before it begins.

use super::Scene;
use crate::geometry::{Interaction, Prim};
use crate::sampling::{Discrete, Sampler, square_to_uniform_triangle, unit};
use glam::{Vec2, Vec3A, Vec4};

/// One primitive as a draw needs it, in one 64-byte cache line, so that a draw from a large mesh
/// touches two lines (the alias-table bucket and this entry) instead of five arrays of the scene.
/// A flat triangle is drawn from here: its vertices and flipped unit normal, with the scene index,
/// shape and `flip_normals` sign in the spare fourth lanes. Anything else (a sphere, a disk, a
/// triangle with vertex normals) is marked and drawn through the scene.
#[repr(C, align(64))]
struct Entry {
    /// Vertex 0 and the primitive's scene index (bits).
    v0: [f32; 4],
    /// Vertex 1 and its shape (bits).
    v1: [f32; 4],
    /// Vertex 2 and the normal's sign: -1 with `flip_normals`, else 1.
    v2: [f32; 4],
    /// Unit geometric normal (unflipped) and 1.0 for a flat triangle, 0.0 otherwise.
    n: [f32; 4],
}

impl Entry {
    fn new(scene: &Scene, i: usize) -> Self {
        let shape = scene.prim_shape[i];
        let sign = scene.normal_sign(shape as usize);
        let lane = |v: Vec3A, w: f32| [v.x, v.y, v.z, w];
        let (v, n, flat) = match scene.prims[i] {
            Prim::Triangle { v, n } => (v, n, scene.prim_normals[i].is_none()),
            _ => ([Vec3A::ZERO; 3], Vec3A::ZERO, false),
        };
        Self {
            v0: lane(v[0], f32::from_bits(i as u32)),
            v1: lane(v[1], f32::from_bits(shape)),
            v2: lane(v[2], sign),
            n: lane(n, if flat { 1.0 } else { 0.0 }),
        }
    }
}

/// Where a primitive of a one-sided BSDF faces away whole from a point p (a hidden-geometry draw
/// from p onto it ends there), as four half-spaces n·p < d (lane k of
/// `n[axis]` and `d`): its face plane and, for a triangle with vertex normals, one per vertex
/// normal n_i with d = min over its vertices v_j of n_i·v_j. Inside all four, every point y of the
/// triangle has a shading normal (Σ b_i n_i, normalised, with y = Σ b_j v_j) whose cosine towards
/// p, Σ_ij b_i b_j n_i·(p − v_j) over the normal's length, is below zero: a convex combination of
/// negative terms. The bounds hold a rounding margin: [`AreaSampler::faces_away`].
#[repr(C, align(64))]
#[derive(Clone, Copy)]
struct Away {
    n: [[f32; 4]; 3],
    d: [f32; 4],
}

impl Away {
    /// Never away (a sphere or a disk, a degenerate triangle, vertex normals more than 90° apart,
    /// whose sum may nearly cancel, or a BSDF that scatters behind its surface: `twosided`,
    /// glass).
    const NEVER: Self = Self {
        n: [[0.0; 4]; 3],
        d: [f32::NEG_INFINITY; 4],
    };

    /// For primitive `i`, the bounds lowered by `margin`; `behind`: per shape, whether its BSDF
    /// scatters behind its surface.
    fn new(scene: &Scene, i: usize, margin: f64, behind: &[bool]) -> Self {
        let Prim::Triangle { v, n } = &scene.prims[i] else {
            return Self::NEVER;
        };
        if behind[scene.prim_shape[i] as usize] {
            return Self::NEVER;
        }
        let sign = scene.normal_sign(scene.prim_shape[i] as usize) as f64;
        let v = v.map(|v| v.as_dvec3());
        let unit = |n: Vec3A| (n.as_dvec3() * sign).try_normalize();
        let face = unit(*n);
        let normals = match scene.prim_normals[i] {
            Some(ns) => ns.map(unit),
            None => [face; 3],
        };
        let (Some(face), [Some(a), Some(b), Some(c)]) = (face, normals) else {
            return Self::NEVER;
        };
        if a.dot(b) <= 0.0 || b.dot(c) <= 0.0 || c.dot(a) <= 0.0 {
            return Self::NEVER;
        }
        let mut away = Self::NEVER;
        for (k, n) in [face, a, b, c].into_iter().enumerate() {
            let d = v.iter().map(|v| n.dot(*v)).fold(f64::INFINITY, f64::min) - margin;
            for axis in 0..3 {
                away.n[axis][k] = n[axis] as f32;
            }
            away.d[k] = d as f32;
        }
        away
    }
}

/// Uniform area sampling over a set of primitives: p_A = 1 / A_total.
pub struct AreaSampler {
    dist: Discrete,
    entries: Vec<Entry>,
    /// Per shape of the scene: whether its primitives are sampled.
    covered: Vec<bool>,
    /// Per entry, where its primitive faces away whole ([`Self::faces_away`]); empty beyond
    /// [`MAX_AWAY`] primitives and where none can.
    away: Vec<Away>,
}

/// Most primitives whose [`Away`] bounds a sampler keeps (64 bytes each: 4 MB).
const MAX_AWAY: usize = 1 << 16;

/// Rounding margin of [`AreaSampler::faces_away`], relative to the coordinates' magnitude: the
/// cosine at a drawn point is then below −FACING_MARGIN/√3 (as the bounds of [`Away`] give it),
/// some eighty times the f32 rounding of the point (its barycentric sum), its shading normal,
/// the direction and the cosine.
const FACING_MARGIN: f32 = 1e-4;

impl AreaSampler {
    /// Over the primitives of the shapes `keep` accepts; `None` if they have no area.
    pub fn new(scene: &Scene, keep: impl Fn(usize) -> bool) -> Option<Self> {
        let prims: Vec<usize> = (0..scene.prims.len())
            .filter(|&i| keep(scene.prim_shape[i] as usize))
            .collect();
        let weights: Vec<f64> = prims
            .iter()
            .map(|&i| scene.prims[i].area() as f64)
            .collect();
        let entries = prims.iter().map(|&i| Entry::new(scene, i)).collect();
        let away = if prims.len() <= MAX_AWAY {
            // The margin's share from the primitives' own coordinates.
            let reach = prims
                .iter()
                .flat_map(|&i| {
                    let (lo, hi) = scene.prims[i].bounds();
                    [lo.abs().max_element(), hi.abs().max_element()]
                })
                .fold(0.0, f32::max);
            let margin = FACING_MARGIN as f64 * (1.0 + reach as f64);
            let behind: Vec<bool> = scene
                .shape_bsdfs(true)
                .iter()
                .map(|b| b.scatters_behind())
                .collect();
            let away: Vec<Away> = prims
                .iter()
                .map(|&i| Away::new(scene, i, margin, &behind))
                .collect();
            // None that can be away: nothing to judge.
            let some = away.iter().any(|a| a.d[0] > f32::NEG_INFINITY);
            if some { away } else { Vec::new() }
        } else {
            Vec::new()
        };
        Some(Self {
            dist: Discrete::new(&weights)?,
            entries,
            covered: (0..scene.shapes.len()).map(keep).collect(),
            away,
        })
    }

    /// Whether the points of shape `shape` are sampled (density 1/A_total there).
    #[inline]
    pub fn covers(&self, shape: u32) -> bool {
        self.covered[shape as usize]
    }

    /// Total sampled area A_total.
    pub fn total_area(&self) -> f32 {
        self.dist.total() as f32
    }

    /// A uniformly distributed point on the hidden geometry (density 1/A_total in area), from
    /// one pair of uniforms: the first picks the triangle and, with what is left of it, the first
    /// coordinate inside it (a stratified pair stays stratified over the whole area).
    #[inline]
    pub fn sample(&self, scene: &Scene, rng: &mut Sampler) -> Interaction {
        self.sample_with(&self.dist, scene, rng).0
    }

    /// A point drawn as [`Self::sample`] does, but with the primitives picked by `dist` (over
    /// [`Self::areas`]' indices) instead of by area; with the primitive's index. Always inlined:
    /// called out of line it returned its point through memory, and renders were measurably
    /// slower (docs/architecture.md, "The BVH", the last paragraph).
    #[inline(always)]
    pub fn sample_with(
        &self,
        dist: &Discrete,
        scene: &Scene,
        rng: &mut Sampler,
    ) -> (Interaction, usize) {
        let (x, y) = rng.next_pair();
        let (k, rest) = dist.sample(x);
        let e = &self.entries[k];
        let u = Vec2::new(rest, unit(y));
        if e.n[3] == 0.0 {
            let i = e.v0[3].to_bits() as usize;
            let (p, ng, b) = scene.prims[i].sample_area(u);
            return (scene.surface_point(i, p, ng, b), k);
        }
        // As `Prim::sample_area` and `Scene::surface_point` without vertex normals: ns = ng.
        let xyz = |a: &[f32; 4]| Vec3A::new(a[0], a[1], a[2]);
        let b = square_to_uniform_triangle(u);
        let p = xyz(&e.v0) * (1.0 - b.x - b.y) + xyz(&e.v1) * b.x + xyz(&e.v2) * b.y;
        let ng = xyz(&e.n) * e.v2[3];
        let it = Interaction {
            p,
            ng,
            ns: ng,
            shape: e.v1[3].to_bits(),
            prim: e.v0[3].to_bits(),
        };
        (it, k)
    }

    /// Whether [`Self::faces_away`] can judge this sampler's draws.
    pub fn judges_facing(&self) -> bool {
        !self.away.is_empty()
    }

    /// Whether the point [`Self::sample`] would draw from the first uniform `x` lies on a surface
    /// of a one-sided BSDF that surely faces away from every point within `radius` of `p`,
    /// whatever the second uniform: its shading normal's cosine towards such a point is below
    /// zero by more than rounding can move it (`Away`). A hidden-geometry draw from there ends
    /// (`HiddenEdge`), so it can be turned down from `x` alone, before the point is made. False
    /// for every draw where [`Self::judges_facing`] is false.
    #[inline(always)]
    pub fn faces_away(&self, x: u32, p: Vec3A, radius: f32) -> bool {
        let Some(a) = self.away.get(self.dist.sample(x).0) else {
            return false;
        };
        let dot = Vec4::from(a.n[0]) * p.x + Vec4::from(a.n[1]) * p.y + Vec4::from(a.n[2]) * p.z;
        // The bounds' unit normals move n·p by at most the radius over the ball.
        let margin = FACING_MARGIN * (p.abs().max_element() + radius) + radius;
        dot.cmplt(Vec4::from(a.d) - margin).all()
    }

    /// The distribution by area over the primitives (for [`Self::sample_with`]).
    pub fn distribution(&self) -> &Discrete {
        &self.dist
    }

    /// The sampled primitives' areas and shapes, in the order [`Self::sample_with`] indexes them.
    pub fn areas(&self) -> impl Iterator<Item = (f64, u32)> + '_ {
        (0..self.entries.len()).map(|k| {
            (
                self.dist.pmf(k) * self.dist.total(),
                self.entries[k].v1[3].to_bits(),
            )
        })
    }
}
