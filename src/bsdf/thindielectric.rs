//! Mitsuba's `thindielectric`: a thin sheet (a window pane). Light is reflected with the sheet's
//! total reflectance R' = 2R / (1 + R), counting every internal bounce, or passes straight
//! through without refraction; either event is a Dirac delta and neither changes the optical
//! path's speed.
//!
//! | key | type | default |
//! |---|---|---|
//! | `int_ior`, `ext_ior` | float or a name | `bk7`, `air` |
//! | `specular_reflectance`, `specular_transmittance` | float, rgb or spectrum | 1 |

use super::{BsdfSample, Dielectric, fresnel};
use crate::math::Spectrum;
use crate::sampling::Sampler;
use glam::Vec3A;

/// A thin dielectric sheet: the parameters of a `dielectric`.
#[derive(Clone, Debug)]
pub struct ThinDielectric<S>(pub Dielectric<S>);

impl ThinDielectric<Spectrum> {
    /// Reflect, or pass straight through.
    #[inline]
    pub fn sample(&self, ns: Vec3A, wi: Vec3A, rng: &mut Sampler) -> Option<BsdfSample> {
        let d = &self.0;
        let cos_i = ns.dot(wi);
        let r = fresnel::dielectric(cos_i.abs(), d.eta).0;
        let r = r * 2.0 / (1.0 + r);
        Some(if rng.next_1d() <= r {
            BsdfSample::mirror(ns, wi, cos_i, d.specular_reflectance, r)
        } else {
            BsdfSample {
                wo: -wi,
                weight: d.specular_transmittance,
                pdf: 1.0 - r,
                delta: true,
                eta: 1.0,
            }
        })
    }
}
