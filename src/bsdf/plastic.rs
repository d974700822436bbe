//! Mitsuba's `plastic`: a diffuse base under a smooth dielectric coating. The coating reflects
//! specularly (a Dirac delta, Fresnel F_i); the light it lets in scatters diffusely, bounces
//! between base and coating (Fresnel's mean internal reflectance F_dr) and leaves through the
//! coating again: f_diffuse = ρ / (1 − F_dr) · (1 − F_i)(1 − F_o) / (π η²) (or, with `nonlinear`,
//! ρ / (1 − ρ F_dr)). Sampling picks the coating or the base with probabilities proportional to
//! F_i·w_s and (1 − F_i)(1 − w_s), w_s = mean specular / (mean specular + mean diffuse).
//! Connections (laser, lights) evaluate the diffuse part.
//!
//! | key | type | default |
//! |---|---|---|
//! | `diffuse_reflectance` | float, rgb or spectrum | 0.5 |
//! | `specular_reflectance` | float, rgb or spectrum | 1 |
//! | `int_ior`, `ext_ior` | float or a name | `polypropylene`, `air` |
//! | `nonlinear` | bool | false |

use super::{BsdfSample, fresnel, ior};
use crate::error::Result;
use crate::math::{Frame, Spectrum};
use crate::props::{Colour, Props};
use crate::sampling::{Sampler, square_to_cosine_hemisphere};
use glam::Vec3A;
use std::f32::consts::FRAC_1_PI;

/// A smooth plastic.
#[derive(Clone, Debug)]
pub struct Plastic<S> {
    /// Base albedo ρ.
    pub diffuse_reflectance: S,
    /// Factor on the coating's reflection.
    pub specular_reflectance: S,
    /// Relative index of refraction of the coating.
    pub eta: f32,
    /// ρ / (1 − ρ F_dr) instead of ρ / (1 − F_dr).
    pub nonlinear: bool,
}

impl Plastic<Colour> {
    /// Read a `plastic`.
    pub fn from_props(p: &Props) -> Result<Self> {
        let eta =
            ior::read_ior(p, "int_ior", "polypropylene")? / ior::read_ior(p, "ext_ior", "air")?;
        let diffuse_reflectance = p.colour("diffuse_reflectance", Colour::Uniform(0.5))?;
        let specular_reflectance = p.colour("specular_reflectance", Colour::Uniform(1.0))?;
        let nonlinear = p.bool("nonlinear", false)?;
        p.finish()?;
        Ok(Self {
            diffuse_reflectance,
            specular_reflectance,
            eta,
            nonlinear,
        })
    }
}

impl Plastic<Spectrum> {
    /// Probability of sampling the coating's reflection at incidence `f_i`.
    fn prob_specular(&self, f_i: f32) -> f32 {
        let s = self.specular_reflectance.element_sum() / 3.0;
        let d = self.diffuse_reflectance.element_sum() / 3.0;
        let w = if s + d > 0.0 { s / (s + d) } else { 0.5 };
        let (ps, pd) = (f_i * w, (1.0 - f_i) * (1.0 - w));
        if ps + pd > 0.0 { ps / (ps + pd) } else { 0.0 }
    }

    /// The diffuse lobe's f·cos (without the coating's Fresnel factors).
    fn diffuse(&self, f_i: f32, cos_o: f32) -> Spectrum {
        let fdr = fresnel::diffuse_reflectance(1.0 / self.eta);
        let rho = self.diffuse_reflectance;
        let base = if self.nonlinear {
            rho / (Spectrum::ONE - rho * fdr)
        } else {
            rho / (1.0 - fdr)
        };
        let f_o = fresnel::dielectric(cos_o, self.eta).0;
        base * (cos_o * FRAC_1_PI / (self.eta * self.eta) * (1.0 - f_i) * (1.0 - f_o))
    }

    /// f·cos of the diffuse part (the coating's reflection is a delta).
    #[inline]
    pub fn eval(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> Option<Spectrum> {
        let (ci, co) = (ns.dot(wi), ns.dot(wo));
        if ci <= 0.0 || co <= 0.0 {
            return None;
        }
        Some(self.diffuse(fresnel::dielectric(ci, self.eta).0, co))
    }

    /// The coating's reflection or the base's cosine-weighted scattering.
    #[inline]
    pub fn sample(&self, ns: Vec3A, wi: Vec3A, rng: &mut Sampler) -> Option<BsdfSample> {
        let ci = ns.dot(wi);
        if ci <= 0.0 {
            return None;
        }
        let f_i = fresnel::dielectric(ci, self.eta).0;
        let ps = self.prob_specular(f_i);
        if rng.next_1d() < ps {
            let weight = self.specular_reflectance * (f_i / ps);
            return Some(BsdfSample::mirror(ns, wi, ci, weight, ps));
        }
        let local = square_to_cosine_hemisphere(rng.next_2d());
        let pdf = (1.0 - ps) * local.z * FRAC_1_PI;
        (pdf > 0.0).then(|| BsdfSample {
            wo: Frame::new(ns).to_world(local),
            weight: self.diffuse(f_i, local.z) / pdf,
            pdf,
            delta: false,
            eta: 1.0,
        })
    }

    /// [`Plastic::eval`] and [`Plastic::pdf`] at once (the coating's Fresnel reflectance found
    /// once), with their bits.
    #[inline]
    pub fn eval_pdf(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> (Option<Spectrum>, f32) {
        let (ci, co) = (ns.dot(wi), ns.dot(wo));
        if ci <= 0.0 || co <= 0.0 {
            return (None, 0.0);
        }
        let f_i = fresnel::dielectric(ci, self.eta).0;
        let pdf = (1.0 - self.prob_specular(f_i)) * co * FRAC_1_PI;
        (Some(self.diffuse(f_i, co)), pdf)
    }

    /// Density with which [`Plastic::sample`] picks `wo` from the base.
    #[inline]
    pub fn pdf(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> f32 {
        let (ci, co) = (ns.dot(wi), ns.dot(wo));
        if ci <= 0.0 || co <= 0.0 {
            return 0.0;
        }
        (1.0 - self.prob_specular(fresnel::dielectric(ci, self.eta).0)) * co * FRAC_1_PI
    }
}
