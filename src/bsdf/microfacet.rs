//! Isotropic microfacet distributions (Walter et al. 2007, "Microfacet models for refraction
//! through rough surfaces"): Beckmann and GGX normal distributions D(m), Smith's masking G1 with
//! Mitsuba's conventions (Beckmann's G1 by its rational fit, < 0.35 % error), and sampling of m
//! proportional to D(m)·cos θ_m. Directions are in the local frame (z = shading normal).

use crate::simd::Real;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// Which distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    /// Beckmann (Mitsuba's default).
    Beckmann,
    /// GGX (Trowbridge–Reitz).
    Ggx,
}

/// A distribution with roughness α.
#[derive(Clone, Copy, Debug)]
pub struct Microfacet {
    /// Which distribution.
    pub kind: Distribution,
    /// Roughness α (the RMS slope for Beckmann).
    pub alpha: f32,
}

/// D(m) for a distribution `kind` of roughness `alpha`: microfacet normals per unit solid angle
/// and projected area (Walter et al. 2007, eqs. 25 and 33), zero below the surface and where
/// D·cos θ_m ≤ 1e-20; for an `f32` or lanes of them ([`crate::simd::F8`], the same bits).
#[inline(always)]
pub fn distribution<T: Real>(kind: Distribution, alpha: T, m: [T; 3]) -> T {
    let k = T::from;
    let a2 = alpha * alpha;
    let c2 = m[2] * m[2];
    let xy = m[0] * m[0] + m[1] * m[1];
    let d = match kind {
        Distribution::Beckmann => (-xy / (a2 * c2)).each(exp_above_cut) / (k(PI) * a2 * c2 * c2),
        Distribution::Ggx => {
            let t = xy / a2 + c2;
            k(1.0) / (k(PI) * a2 * t * t)
        }
    };
    T::select(m[2].gt(k(0.0)) & (d * m[2]).gt(k(1e-20)), d, k(0.0))
}

/// e^x, or 0 below x = −87: there D·cos θ_m is under [`distribution`]'s cut for every α read
/// (1e-4 to 1e3), and `exp`'s underflow is slow.
fn exp_above_cut(x: f32) -> f32 {
    if x < -87.0 { 0.0 } else { x.exp() }
}

/// Smith's masking G1 of direction `v` by microfacets of normal `m` (Walter et al. 2007, eqs. 27
/// and 34; Beckmann's by its rational fit), zero where `v` and `m` face opposite sides; for an
/// `f32` or lanes of them.
#[inline(always)]
pub fn masking<T: Real>(kind: Distribution, alpha: T, v: [T; 3], m: [T; 3]) -> T {
    let k = T::from;
    let vm = v[0] * m[0] + v[1] * m[1] + v[2] * m[2];
    let xy_a2 = alpha * alpha * (v[0] * v[0] + v[1] * v[1]);
    let tan2 = xy_a2 / (v[2] * v[2]);
    let g = match kind {
        Distribution::Beckmann => {
            let a = k(1.0) / tan2.sqrt();
            let fit =
                (k(3.535) * a + k(2.181) * a * a) / (k(1.0) + k(2.276) * a + k(2.577) * a * a);
            T::select(a.ge(k(1.6)), k(1.0), fit)
        }
        Distribution::Ggx => k(2.0) / (k(1.0) + (k(1.0) + tan2).sqrt()),
    };
    let g = T::select(xy_a2.eq(k(0.0)), k(1.0), g);
    T::select((vm * v[2]).le(k(0.0)), k(0.0), g)
}

/// The polar angle of a microfacet normal drawn ∝ D(m)·cos θ_m from the uniform number `u`: its
/// (cos θ, sin θ) (the azimuth is uniform and drawn apart); for an `f32` or lanes of them.
#[inline(always)]
pub fn polar<T: Real>(kind: Distribution, alpha: T, u: T) -> (T, T) {
    let k = T::from;
    let a2 = alpha * alpha;
    let tan2 = match kind {
        Distribution::Beckmann => -a2 * (k(1.0) - u).each(f32::ln),
        Distribution::Ggx => a2 * u / (k(1.0) - u),
    };
    let cos = k(1.0) / (k(1.0) + tan2).sqrt();
    (cos, (k(1.0) - cos * cos).max(k(0.0)).sqrt())
}

impl Microfacet {
    /// D(m): microfacet normals per unit solid angle and projected area ([`distribution`]).
    pub fn d(&self, m: Vec3A) -> f32 {
        distribution(self.kind, self.alpha, m.to_array())
    }

    /// Smith's masking of direction `v` by microfacets of normal `m` ([`masking`]).
    pub fn g1(&self, v: Vec3A, m: Vec3A) -> f32 {
        masking(self.kind, self.alpha, v.to_array(), m.to_array())
    }

    /// G(wi, wo, m) = G1(wi, m)·G1(wo, m).
    pub fn g(&self, wi: Vec3A, wo: Vec3A, m: Vec3A) -> f32 {
        self.g1(wi, m) * self.g1(wo, m)
    }

    /// A normal m with density D(m)·cos θ_m (per solid angle of m).
    pub fn sample(&self, u: Vec2) -> Vec3A {
        let (cos, sin) = polar(self.kind, self.alpha, u.y);
        let (s, c) = (2.0 * PI * u.x).sin_cos();
        Vec3A::new(sin * c, sin * s, cos)
    }

    /// Density of [`Microfacet::sample`].
    pub fn pdf(&self, m: Vec3A) -> f32 {
        self.d(m) * m.z.max(0.0)
    }

    /// `wi` reflected about a normal drawn by [`Microfacet::sample`].
    pub fn reflect(&self, wi: Vec3A, rng: &mut crate::sampling::Sampler) -> Vec3A {
        let m = self.sample(rng.next_2d());
        2.0 * wi.dot(m) * m - wi
    }

    /// Solid-angle density of [`Microfacet::reflect`]'s directions: pdf(h) / (4 wo·h).
    pub fn reflection_pdf(&self, wi: Vec3A, wo: Vec3A) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let h = (wi + wo).normalize();
        Self::reflection_pdf_at(wo, h, self.d(h))
    }

    /// [`Microfacet::reflection_pdf`] given the half vector `h` and D(h) = `d`.
    #[inline]
    pub fn reflection_pdf_at(wo: Vec3A, h: Vec3A, d: f32) -> f32 {
        d * h.z.max(0.0) / (4.0 * wo.dot(h))
    }
}
