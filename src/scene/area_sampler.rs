//! Uniform sampling of scene surfaces by area: a point on a set of shapes with density
//! 1/A_total. Hidden-geometry sampling (mitransient-model §3.3) draws from the hidden shapes, and
//! next-event estimation from an area light's shape.

use super::Scene;
use crate::geometry::{Interaction, Prim};
use crate::sampling::{
    Discrete, Sampler, square_to_uniform_disk_concentric, square_to_uniform_sphere,
    square_to_uniform_triangle,
};
use glam::Vec3A;

/// Uniform area sampling over a set of primitives: p_A = 1 / A_total.
pub struct AreaSampler {
    dist: Discrete,
    prims: Vec<u32>,
}
impl AreaSampler {
    /// Over the primitives of the shapes `keep` accepts; `None` if they have no area.
    pub fn new(scene: &Scene, keep: impl Fn(usize) -> bool) -> Option<Self> {
        let prims: Vec<u32> = (0..scene.prims.len() as u32)
            .filter(|&i| keep(scene.prim_shape[i as usize] as usize))
            .collect();
        let weights: Vec<f64> = prims
            .iter()
            .map(|&i| scene.prims[i as usize].area() as f64)
            .collect();
        Some(Self {
            dist: Discrete::new(&weights)?,
            prims,
        })
    }

    /// Total sampled area A_total.
    pub fn total_area(&self) -> f32 {
        self.dist.total() as f32
    }

    /// A uniformly distributed point on the hidden geometry (density 1/A_total in area).
    pub fn sample(&self, scene: &Scene, rng: &mut Sampler) -> Interaction {
        let i = self.prims[self.dist.sample(rng)] as usize;
        let u2 = rng.next_2d();
        let (p, ng, b) = match scene.prims[i] {
            Prim::Triangle(v) => {
                let b = square_to_uniform_triangle(u2);
                let p = v[0] * (1.0 - b.x - b.y) + v[1] * b.x + v[2] * b.y;
                (
                    p,
                    (v[1] - v[0]).cross(v[2] - v[0]).normalize(),
                    b.to_array(),
                )
            }
            Prim::Sphere { center, radius } => {
                let n = square_to_uniform_sphere(u2);
                (center + n * radius, n, [0.0; 2])
            }
            Prim::Disk { inv } => {
                let q = square_to_uniform_disk_concentric(u2);
                let p = inv.inverse().transform_point3a(Vec3A::new(q.x, q.y, 0.0));
                (
                    p,
                    inv.matrix3.transpose().mul_vec3a(Vec3A::Z).normalize(),
                    [0.0; 2],
                )
            }
        };
        scene.surface_point(i, p, ng, b)
    }
}
