//! Mitsuba's `roughplastic`: a diffuse base under a rough dielectric coating. The coating
//! reflects by the microfacet model, f_s = F(wi·h) D(h) G / (4 cos θ_i cos θ_o); the base's light
//! crosses the coating twice, each time scaled by the coating's transmittance T(cos θ), and bounces
//! between base and coating (mean internal reflectance R_int): f_d = ρ / (1 − R_int) · T_i T_o /
//! (π η²) (or ρ / (1 − ρ R_int) with `nonlinear`). T is tabulated at 64 cosines and R_int is
//! 2·mean(R(μ)·μ) over them, as Mitsuba does; both integrals over microfacet normals are computed
//! here by Gauss–Legendre quadrature. Sampling picks the coating or the base with probabilities
//! ∝ (1 − T_i)·w_s and T_i·(1 − w_s).
//!
//! | key | type | default |
//! |---|---|---|
//! | `diffuse_reflectance` | float, rgb or spectrum | 0.5 |
//! | `specular_reflectance` | float, rgb or spectrum | 1 |
//! | `int_ior`, `ext_ior` | float or a name | `polypropylene`, `air` |
//! | `distribution`, `alpha`, `sample_visible` | as `roughconductor` | `beckmann`, 0.1 |
//! | `nonlinear` | bool | false |

use super::microfacet::Microfacet;
use super::roughconductor::microfacet;
use super::{LocalBsdf, fresnel, ior};
use crate::error::{NlosError, Result};
use crate::math::Spectrum;
use crate::props::{Colour, Props};
use crate::sampling::{Sampler, square_to_cosine_hemisphere};
use crate::simd::Real;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// Cosines at which the coating's transmittance is tabulated.
const RES: usize = 64;

/// A rough plastic.
#[derive(Clone, Debug)]
pub struct RoughPlastic<S> {
    /// Base albedo ρ.
    pub diffuse_reflectance: S,
    /// Factor on the coating's reflection.
    pub specular_reflectance: S,
    /// Relative index of refraction of the coating.
    pub eta: f32,
    /// ρ / (1 − ρ R_int) instead of ρ / (1 − R_int).
    pub nonlinear: bool,
    /// The coating's roughness.
    pub microfacet: Microfacet,
    /// Transmittance into the coating at cos θ = k / (RES − 1).
    pub transmittance: Vec<f32>,
    /// Mean internal reflectance R_int.
    pub internal_reflectance: f32,
}

/// Gauss–Legendre nodes and weights on [0, 1] (Golub–Welsch by Newton iteration on P_n).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            ((x + 1.0) / 2.0, 1.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// E over visible microfacet normals m seen from `wi` of `g(m)`: ∫ g(m) G1(wi, m) (wi·m)⁺ D(m) /
/// cos θ_i dm, integrated in the coordinates where m has density D(m)·cos θ_m.
fn visible_mean(mf: &Microfacet, wi: Vec3A, g: impl Fn(Vec3A) -> f64) -> f64 {
    let nodes = gauss_legendre(64);
    let mut sum = 0.0;
    for &(u, wu) in &nodes {
        for &(v, wv) in &nodes {
            let m = mf.sample(Vec2::new(u as f32, v as f32));
            let wm = wi.dot(m);
            if wm <= 0.0 || m.z <= 0.0 {
                continue;
            }
            let w = mf.g1(wi, m) as f64 * wm as f64 / (wi.z as f64 * m.z as f64);
            sum += wu * wv * w * g(m);
        }
    }
    sum
}

impl RoughPlastic<Colour> {
    /// Read a `roughplastic`.
    pub fn from_props(p: &Props) -> Result<Self> {
        let eta =
            ior::read_ior(p, "int_ior", "polypropylene")? / ior::read_ior(p, "ext_ior", "air")?;
        if eta == 1.0 {
            return Err(NlosError::prop(
                &p.plugin,
                "int_ior",
                "the interior and exterior indices of refraction must differ",
            ));
        }
        let diffuse_reflectance = p.colour("diffuse_reflectance", Colour::Uniform(0.5))?;
        let specular_reflectance = p.colour("specular_reflectance", Colour::Uniform(1.0))?;
        let nonlinear = p.bool("nonlinear", false)?;
        let microfacet = microfacet(p)?;
        p.finish()?;
        // The coating's transmittance T(μ) into the material, and its reflectance from inside.
        let mus: Vec<f32> = (0..RES)
            .map(|k| (k as f32 / (RES - 1) as f32).max(1e-6))
            .collect();
        let wi_of = |mu: f32| Vec3A::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
        let transmittance = mus
            .iter()
            .map(|&mu| {
                let wi = wi_of(mu);
                visible_mean(&microfacet, wi, |m| {
                    let (f, cos_t, _, eta_ti) = fresnel::dielectric(wi.dot(m), eta);
                    let wo = m * (wi.dot(m) * eta_ti + cos_t) - wi * eta_ti;
                    if wo.z * wi.z >= 0.0 {
                        0.0
                    } else {
                        (microfacet.g1(wo, m) * (1.0 - f)) as f64
                    }
                }) as f32
            })
            .collect();
        let internal: f64 = mus
            .iter()
            .map(|&mu| {
                let wi = wi_of(mu);
                let r = visible_mean(&microfacet, wi, |m| {
                    let wo = 2.0 * wi.dot(m) * m - wi;
                    if wo.z <= 0.0 {
                        0.0
                    } else {
                        let f = fresnel::dielectric(wi.dot(m), 1.0 / eta).0;
                        (microfacet.g1(wo, m) * f) as f64
                    }
                });
                r * mu as f64
            })
            .sum::<f64>()
            / RES as f64
            * 2.0;
        Ok(Self {
            diffuse_reflectance,
            specular_reflectance,
            eta,
            nonlinear,
            microfacet,
            transmittance,
            internal_reflectance: internal as f32,
        })
    }
}

impl<S> RoughPlastic<S> {
    /// T(cos θ), linearly interpolated in the table.
    fn t(&self, cos: f32) -> f32 {
        transmittance_at(&self.transmittance, cos)
    }
}

/// The probability of sampling a coating of transmittance `t_i` into it and lobe weight `w`
/// ([`RoughPlastic::specular_weight`]): (1 − T_i)·w against T_i·(1 − w); for an `f32` or lanes.
#[inline(always)]
pub(super) fn coating_probability<T: Real>(t_i: T, w: T) -> T {
    let k = T::from;
    let (ps, pd) = ((k(1.0) - t_i) * w, t_i * (k(1.0) - w));
    T::select((ps + pd).gt(k(0.0)), ps / (ps + pd), k(0.0))
}

/// T(cos θ) from a coating's transmittance `table` (at cos θ = k / (RES − 1)), linearly
/// interpolated.
#[inline]
pub(super) fn transmittance_at(table: &[f32], cos: f32) -> f32 {
    let x = cos.clamp(0.0, 1.0) * (RES - 1) as f32;
    let i = (x as usize).min(RES - 2);
    let a = x - i as f32;
    table[i] * (1.0 - a) + table[i + 1] * a
}

impl RoughPlastic<Spectrum> {
    /// The weight of the coating's lobe in sampling, by the mean specular and diffuse
    /// reflectances.
    pub(super) fn specular_weight(&self) -> f32 {
        let s = self.specular_reflectance.element_sum() / 3.0;
        let d = self.diffuse_reflectance.element_sum() / 3.0;
        if s + d > 0.0 { s / (s + d) } else { 0.5 }
    }

    /// The probability of sampling the coating, of transmittance `t_i` into it.
    fn prob_specular(&self, t_i: f32) -> f32 {
        coating_probability(t_i, self.specular_weight())
    }

    /// The base's albedo over its internal reflections: ρ / (1 − R_int), or ρ / (1 − ρ R_int)
    /// with `nonlinear`.
    pub(super) fn base(&self) -> Spectrum {
        let rho = self.diffuse_reflectance;
        if self.nonlinear {
            rho / (Spectrum::ONE - rho * self.internal_reflectance)
        } else {
            rho / (1.0 - self.internal_reflectance)
        }
    }
}

impl LocalBsdf for RoughPlastic<Spectrum> {
    fn microfacet(&self) -> &Microfacet {
        &self.microfacet
    }

    fn eval_half(&self, wi: Vec3A, wo: Vec3A, h: Vec3A, d: f32) -> Option<Spectrum> {
        let f = fresnel::dielectric(wi.dot(h), self.eta).0;
        let spec =
            self.specular_reflectance * (f * d * self.microfacet.g(wi, wo, h) / (4.0 * wi.z));
        let diffuse =
            self.base() * (FRAC_1_PI / (self.eta * self.eta) * wo.z * self.t(wi.z) * self.t(wo.z));
        Some(spec + diffuse)
    }

    fn pdf_half(&self, wi: Vec3A, wo: Vec3A, h: Vec3A, d: f32) -> f32 {
        let ps = self.prob_specular(self.t(wi.z));
        ps * Microfacet::reflection_pdf_at(wo, h, d) + (1.0 - ps) * wo.z * FRAC_1_PI
    }

    /// The coating's microfacet reflection or the base's cosine-weighted scattering.
    fn propose(&self, wi: Vec3A, rng: &mut Sampler) -> Vec3A {
        if rng.next_1d() < self.prob_specular(self.t(wi.z)) {
            self.microfacet.reflect(wi, rng)
        } else {
            square_to_cosine_hemisphere(rng.next_2d())
        }
    }
}
