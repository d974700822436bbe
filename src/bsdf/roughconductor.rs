//! Mitsuba's `roughconductor`: a metal with microfacet roughness (Walter et al. 2007),
//! f = F(wi·h)·D(h)·G(wi, wo, h) / (4 cos θ_i cos θ_o) with h the half vector, one-sided.
//! Sampled by picking a microfacet normal ∝ D·cos θ_m and reflecting `wi` about it.
//!
//! | key | type | default |
//! |---|---|---|
//! | `material`, `eta`, `k` | as `conductor` | `none` |
//! | `distribution` | `beckmann` or `ggx` | `beckmann` |
//! | `alpha` (or equal `alpha_u`, `alpha_v`) | float > 0: roughness | 0.1 |
//! | `sample_visible` | bool: Mitsuba's sampling strategy; accepted, results are the same in expectation | true |
//! | `specular_reflectance` | float, rgb or spectrum | 1 |

use super::conductor::complex_ior;
use super::microfacet::{Distribution, Microfacet};
use super::{LocalBsdf, fresnel};
use crate::error::{NlosError, Result};
use crate::math::Spectrum;
use crate::props::{Colour, Props};
use crate::sampling::Sampler;
use glam::Vec3A;

/// A rough conductor.
#[derive(Clone, Debug)]
pub struct RoughConductor<S> {
    /// Real part of the index of refraction.
    pub eta: S,
    /// Imaginary part.
    pub k: S,
    /// Factor on the reflectance.
    pub specular_reflectance: S,
    /// Microfacet distribution.
    pub microfacet: Microfacet,
}

/// `distribution` and `alpha` (or `alpha_u` = `alpha_v`), as Mitsuba's microfacet plugins read them.
pub(super) fn microfacet(p: &Props) -> Result<Microfacet> {
    let kind = match p
        .string("distribution", "beckmann")?
        .to_lowercase()
        .as_str()
    {
        "beckmann" => Distribution::Beckmann,
        "ggx" => Distribution::Ggx,
        other => {
            return Err(NlosError::prop(
                &p.plugin,
                "distribution",
                format!("must be 'beckmann' or 'ggx', got '{other}'"),
            ));
        }
    };
    let alpha = match (p.has("alpha_u") || p.has("alpha_v"), p.has("alpha")) {
        (true, true) => {
            return Err(NlosError::prop(
                &p.plugin,
                "alpha",
                "give either alpha or alpha_u and alpha_v",
            ));
        }
        (true, false) => {
            let (u, v) = (p.float("alpha_u", 0.0)?, p.float("alpha_v", 0.0)?);
            if u != v {
                return Err(NlosError::prop(
                    &p.plugin,
                    "alpha_u",
                    "anisotropic roughness (alpha_u != alpha_v) is not supported",
                ));
            }
            u
        }
        (false, _) => p.float("alpha", 0.1)?,
    };
    if !(alpha > 1e-4 && alpha < 1e3) {
        return Err(NlosError::prop(
            &p.plugin,
            "alpha",
            format!("must be in (1e-4, 1e3), got {alpha}"),
        ));
    }
    p.bool("sample_visible", true)?;
    Ok(Microfacet {
        kind,
        alpha: alpha as f32,
    })
}

impl RoughConductor<Colour> {
    /// Read a `roughconductor`.
    pub fn from_props(p: &Props) -> Result<Self> {
        let (eta, k) = complex_ior(p)?;
        let microfacet = microfacet(p)?;
        let specular_reflectance = p.colour("specular_reflectance", Colour::Uniform(1.0))?;
        p.finish()?;
        Ok(Self {
            eta,
            k,
            specular_reflectance,
            microfacet,
        })
    }
}

impl LocalBsdf for RoughConductor<Spectrum> {
    fn microfacet(&self) -> &Microfacet {
        &self.microfacet
    }

    fn eval_half(&self, wi: Vec3A, wo: Vec3A, h: Vec3A, d: f32) -> Option<Spectrum> {
        if d == 0.0 {
            return None;
        }
        let value = d * self.microfacet.g(wi, wo, h) / (4.0 * wi.z);
        let f = fresnel::conductor(wi.dot(h), self.eta, self.k);
        Some(f * self.specular_reflectance * value)
    }

    fn pdf_half(&self, _wi: Vec3A, wo: Vec3A, h: Vec3A, d: f32) -> f32 {
        Microfacet::reflection_pdf_at(wo, h, d)
    }

    /// Reflect `wi` about a microfacet normal drawn ∝ D·cos θ_m.
    fn propose(&self, wi: Vec3A, rng: &mut Sampler) -> Vec3A {
        self.microfacet.reflect(wi, rng)
    }
}
