//! Integrators: `transient_nlos_path` (and `_rs`) in [`nlos`], `transient_path` in [`path`], and
//! what they share (Lambertian BSDF, area sampling, the contribution record).

pub mod nlos;
pub mod path;

pub use nlos::{CaptureType, Hgrs, HgrsEstimator, NlosSettings};
pub use path::PathSettings;

use crate::error::{NlosError, Result};
use crate::film::TemporalKernel;
use crate::geometry::{Interaction, Prim};
use crate::math::Spectrum;
use crate::props::Props;
use crate::sampling::{
    Discrete, Sampler, square_to_uniform_disk_concentric, square_to_uniform_sphere,
    square_to_uniform_triangle,
};
use crate::scene::Scene;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// Uniform area sampling over a set of primitives: p_A = 1 / A_total. Used for hidden-geometry
/// sampling (spec §3.3) and for area lights.
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
    pub fn sample(&self, scene: &Scene, u1: f32, u2: Vec2) -> Interaction {
        let (k, _) = self.dist.sample_reuse(u1);
        let i = self.prims[k] as usize;
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

/// Lambertian BSDF with cosine: ρ/π · cosθ_o, zero unless both directions are above the shading
/// surface (Mitsuba's one-sided `diffuse`).
#[inline]
pub(crate) fn diffuse_f(rho: Spectrum, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> Option<Spectrum> {
    let (ci, co) = (ns.dot(wi), ns.dot(wo));
    (ci > 0.0 && co > 0.0).then(|| rho * (FRAC_1_PI * co))
}

/// A contribution: laser slot, optical path length, value.
pub type Splat = (usize, f64, Spectrum);

/// `max_depth`: -1 means unbounded (`u32::MAX`), else a non-negative count.
pub(crate) fn max_depth(p: &Props, default: i64) -> Result<u32> {
    match p.int("max_depth", default)? {
        -1 => Ok(u32::MAX),
        v if v >= 0 && v < u32::MAX as i64 => Ok(v as u32),
        v => Err(NlosError::prop(
            &p.plugin,
            "max_depth",
            format!("must be -1 or non-negative, got {v}"),
        )),
    }
}

/// mitransient's `temporal_filter` / `gaussian_stddev`, which it accepts and ignores: here `'gaussian'`
/// is the Gaussian temporal kernel with σ = `gaussian_stddev` bins.
pub(crate) fn temporal_filter(p: &Props, default_stddev: f64) -> Result<Option<TemporalKernel>> {
    let plugin = p.plugin.as_str();
    let stddev = p.float("gaussian_stddev", default_stddev)?;
    match p.string("temporal_filter", "")?.as_str() {
        "" | "box" => Ok(None),
        "gaussian" => TemporalKernel::from_params(plugin, Some(stddev), None)
            .map(Some)
            .map_err(|_| NlosError::prop(plugin, "gaussian_stddev", "must be positive")),
        other => Err(NlosError::prop(
            plugin,
            "temporal_filter",
            format!("must be 'box' or 'gaussian', got '{other}'"),
        )),
    }
}

/// Russian roulette as Mitsuba does it: a path with zero throughput ends; from loop depth `rr_depth`
/// on it survives with probability q = min(max β, 0.95) and β is divided by q. Returns whether the
/// path goes on.
#[inline]
pub(crate) fn russian_roulette(
    beta: &mut Spectrum,
    depth: u32,
    rr_depth: u32,
    rng: &mut Sampler,
) -> bool {
    let m = beta.max_element();
    if !(m > 0.0) {
        return false;
    }
    if depth >= rr_depth {
        let q = m.min(0.95);
        if rng.next_1d() >= q {
            return false;
        }
        *beta /= q;
    }
    true
}
