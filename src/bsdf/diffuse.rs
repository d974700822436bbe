//! Mitsuba's `diffuse`: an ideal Lambertian reflector, one-sided (nothing below the shading
//! surface), f = ρ/π, sampled with the cosine-weighted hemisphere (pdf cos θ_o/π, weight ρ).
//!
//! | key | type | default |
//! |---|---|---|
//! | `reflectance` | float, rgb or spectrum | 0.5 |

use crate::error::Result;
use crate::math::{Frame, Spectrum};
use crate::props::{Colour, Props};
use crate::sampling::{Sampler, square_to_cosine_hemisphere};
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

use super::BsdfSample;

/// A Lambertian BSDF with reflectance ρ.
#[derive(Clone, Debug)]
pub struct Diffuse<S> {
    /// Reflectance ρ.
    pub reflectance: S,
}

impl Diffuse<Colour> {
    /// Read a `diffuse` plugin.
    pub fn from_props(p: &Props) -> Result<Self> {
        let reflectance = p.colour("reflectance", Colour::Uniform(0.5))?;
        p.finish()?;
        Ok(Self { reflectance })
    }
}

impl Diffuse<Spectrum> {
    /// ρ/π · cos θ_o, zero unless both directions are above the shading surface.
    #[inline]
    pub fn eval(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> Option<Spectrum> {
        let (ci, co) = (ns.dot(wi), ns.dot(wo));
        (ci > 0.0 && co > 0.0).then(|| self.reflectance * (FRAC_1_PI * co))
    }

    /// Cosine-weighted sampling: weight f·cos/pdf = ρ. Draws its random numbers only when `wi` is
    /// above the surface.
    #[inline]
    pub fn sample(&self, ns: Vec3A, wi: Vec3A, rng: &mut Sampler) -> Option<BsdfSample> {
        self.sample_where(ns, wi, rng, |_, _| true)
    }

    /// [`Self::sample`], ending early (`None`, the same random numbers drawn) where `keep` turns
    /// down the square sample u (drawn about the normal `ns`) before it is warped.
    #[inline]
    pub fn sample_where(
        &self,
        ns: Vec3A,
        wi: Vec3A,
        rng: &mut Sampler,
        keep: impl FnOnce(Vec3A, Vec2) -> bool,
    ) -> Option<BsdfSample> {
        if ns.dot(wi) <= 0.0 {
            return None;
        }
        let u = rng.next_2d();
        if !keep(ns, u) {
            return None;
        }
        let local = square_to_cosine_hemisphere(u);
        Some(BsdfSample {
            wo: Frame::new(ns).to_world(local),
            weight: self.reflectance,
            pdf: local.z * FRAC_1_PI,
            delta: false,
            eta: 1.0,
        })
    }

    /// cos θ_o / π above the surface, else 0 (whatever `wi`).
    #[inline]
    pub fn pdf(&self, ns: Vec3A, wo: Vec3A) -> f32 {
        ns.dot(wo).max(0.0) * FRAC_1_PI
    }
}
