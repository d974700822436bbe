//! Mitsuba's `thindielectric`: a thin sheet (a window pane). Light is reflected with the sheet's
//! total reflectance R' = 2R / (1 + R), counting every internal bounce, or passes straight
//! through without refraction; either event is a Dirac delta and neither changes the optical
//! path's speed.
//!
//! | key | type | default |
//! |---|---|---|
//! | `int_ior`, `ext_ior` | float or a name | `bk7`, `air` |
//! | `specular_reflectance`, `specular_transmittance` | float, rgb or spectrum | 1 |

use super::{BsdfSample, fresnel, ior};
use crate::error::Result;
use crate::math::Spectrum;
use crate::props::{Colour, Props};
use crate::sampling::Sampler;
use glam::Vec3A;

/// A thin dielectric sheet.
#[derive(Clone, Debug)]
pub struct ThinDielectric<S> {
    /// Relative index of refraction of the sheet.
    pub eta: f32,
    /// Factor on reflection.
    pub specular_reflectance: S,
    /// Factor on transmission.
    pub specular_transmittance: S,
}

impl ThinDielectric<Colour> {
    /// Read a `thindielectric`.
    pub fn from_props(p: &Props) -> Result<Self> {
        let eta = ior::read_ior(p, "int_ior", "bk7")? / ior::read_ior(p, "ext_ior", "air")?;
        let specular_reflectance = p.colour("specular_reflectance", Colour::Uniform(1.0))?;
        let specular_transmittance = p.colour("specular_transmittance", Colour::Uniform(1.0))?;
        p.finish()?;
        Ok(Self {
            eta,
            specular_reflectance,
            specular_transmittance,
        })
    }
}

impl ThinDielectric<Spectrum> {
    /// Reflect, or pass straight through.
    #[inline]
    pub fn sample(&self, ns: Vec3A, wi: Vec3A, rng: &mut Sampler) -> Option<BsdfSample> {
        let cos_i = ns.dot(wi);
        let r = fresnel::dielectric(cos_i.abs(), self.eta).0;
        let r = r * 2.0 / (1.0 + r);
        Some(if rng.next_1d() <= r {
            BsdfSample {
                wo: 2.0 * cos_i * ns - wi,
                weight: self.specular_reflectance,
                pdf: r,
                delta: true,
                eta: 1.0,
            }
        } else {
            BsdfSample {
                wo: -wi,
                weight: self.specular_transmittance,
                pdf: 1.0 - r,
                delta: true,
                eta: 1.0,
            }
        })
    }
}
