//! Rough conductors and rough plastics eight lanes at a time, for the lockstep path tracer
//! (`integrator::path_packet`): the value f·cos θ_o and density of the lanes on such
//! surfaces together, and a sampled direction for each. The formulas are the scalar BSDFs' own,
//! written once for an `f32` or for lanes ([`microfacet::distribution`], [`microfacet::masking`],
//! [`microfacet::polar`], [`fresnel::conductor_channel`], [`fresnel::dielectric`]), in the same
//! order: each lane's value and density have the bits [`Bsdf::eval_pdf`] gives.
//!
//! Sampling takes the lane's two numbers for its direction: the concentric disk's point gives the
//! microfacet normal's azimuth (its angle) and polar angle (its squared radius, uniform on [0, 1)
//! and independent of the angle), so no sine or cosine is taken; a rough plastic picks its lobe
//! with the first number and rescales it.

use super::microfacet::{self, Distribution};
use super::roughplastic::{coating_probability, transmittance_at};
use super::{Bsdf, fresnel};
use crate::math::Spectrum;
use crate::sampling::{ONE_MINUS_EPSILON, square_to_uniform_disk_concentric_lanes};
use crate::simd::{F8, LANES, M8};
use std::f32::consts::FRAC_1_PI;

/// A rough conductor's or rough plastic's parameters, as the lanes gather them.
#[derive(Clone, Debug)]
pub struct Rough {
    kind: Distribution,
    alpha: f32,
    /// A rough plastic (else a rough conductor).
    plastic: bool,
    /// The factor on the specular reflection.
    specular: [f32; 3],
    /// A conductor's η per channel; a plastic's coating η in each.
    eta: [f32; 3],
    /// A conductor's k per channel.
    k: [f32; 3],
    /// A plastic's base albedo over its internal reflections ([`super::RoughPlastic::base`]).
    base: [f32; 3],
    /// A plastic's weight of its specular lobe ([`super::RoughPlastic::specular_weight`]).
    weight: f32,
    /// A plastic's coating transmittance table.
    transmittance: Vec<f32>,
}

impl Rough {
    /// The lane form of `bsdf`, where it is a rough conductor or a rough plastic.
    pub fn of(bsdf: &Bsdf<Spectrum>) -> Option<Self> {
        match bsdf {
            Bsdf::RoughConductor(c) => Some(Self {
                kind: c.microfacet.kind,
                alpha: c.microfacet.alpha,
                plastic: false,
                specular: c.specular_reflectance.to_array(),
                eta: c.eta.to_array(),
                k: c.k.to_array(),
                base: [0.0; 3],
                weight: 0.0,
                transmittance: Vec::new(),
            }),
            Bsdf::RoughPlastic(p) => Some(Self {
                kind: p.microfacet.kind,
                alpha: p.microfacet.alpha,
                plastic: true,
                specular: p.specular_reflectance.to_array(),
                eta: [p.eta; 3],
                k: [0.0; 3],
                base: p.base().to_array(),
                weight: p.specular_weight(),
                transmittance: p.transmittance.clone(),
            }),
            _ => None,
        }
    }
}

/// The BSDFs of eight lanes (of `C` channels), gathered.
pub struct RoughLanes<'a, const C: usize> {
    /// The lanes gathered; the Beckmann lanes (the others GGX), whether some lane is of each, and
    /// the plastics'.
    lanes: M8,
    beckmann: M8,
    kinds: (bool, bool),
    plastic: M8,
    alpha: F8,
    specular: [F8; C],
    eta: [F8; C],
    k: [F8; C],
    base: [F8; C],
    weight: F8,
    /// Each lane's transmittance table (a plastic's).
    tables: [&'a [f32]; LANES],
    /// The local incident direction of each lane, a plastic's transmittance T(cos θ_i) into its
    /// coating there and its probability of sampling the coating.
    wi: [F8; 3],
    t_i: F8,
    prob_specular: F8,
}

/// A · b over the three axes, lane by lane (as `Vec3A::dot` adds: x, then y, then z).
#[inline(always)]
fn dot(a: &[F8; 3], b: &[F8; 3]) -> F8 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl<'a, const C: usize> RoughLanes<'a, C> {
    /// The BSDFs of the lanes where `rough` has one, each `rough[l]`, met from the local direction
    /// `wi` (the other lanes hold a GGX conductor of roughness NaN, their results unused: `exp`
    /// and `ln` of NaN return at once).
    #[inline(always)]
    pub fn gather(rough: [Option<&'a Rough>; LANES], wi: [F8; 3]) -> Self {
        let mut lanes = 0u32;
        let mut alpha = [f32::NAN; LANES];
        let (mut specular, mut eta, mut k, mut base) = (
            [[0.0; LANES]; C],
            [[1.5; LANES]; C],
            [[0.0; LANES]; C],
            [[0.0; LANES]; C],
        );
        let mut weight = [0.0; LANES];
        let (mut beckmann, mut plastic) = (0u32, 0u32);
        let mut tables: [&[f32]; LANES] = [&[]; LANES];
        for (l, r) in rough.iter().enumerate() {
            let Some(r) = r else {
                continue;
            };
            lanes |= 1 << l;
            alpha[l] = r.alpha;
            beckmann |= ((r.kind == Distribution::Beckmann) as u32) << l;
            plastic |= (r.plastic as u32) << l;
            for c in 0..C {
                specular[c][l] = r.specular[c];
                eta[c][l] = r.eta[c];
                k[c][l] = r.k[c];
                base[c][l] = r.base[c];
            }
            weight[l] = r.weight;
            tables[l] = &r.transmittance;
        }
        let zero = F8::splat(0.0);
        let mut channels = [[zero; C]; 4];
        for c in 0..C {
            for (to, from) in channels.iter_mut().zip([&specular, &eta, &k, &base]) {
                to[c] = F8::load(&from[c]);
            }
        }
        let [specular, eta, k, base] = channels;
        let mut bsdfs = Self {
            lanes: M8::from_bits(lanes),
            beckmann: M8::from_bits(beckmann),
            kinds: (beckmann & lanes != 0, lanes & !beckmann != 0),
            plastic: M8::from_bits(plastic),
            alpha: F8::load(&alpha),
            specular,
            eta,
            k,
            base,
            weight: F8::load(&weight),
            tables,
            wi,
            t_i: zero,
            prob_specular: zero,
        };
        bsdfs.t_i = bsdfs.transmittance(wi[2]);
        bsdfs.prob_specular = coating_probability(bsdfs.t_i, bsdfs.weight);
        bsdfs
    }

    /// D(h) and G(wi, wo, h) of each lane's distribution: one form where the lanes share one,
    /// else both, selected. (No closures or `map`s in this file: a closure is not compiled with
    /// its caller's target features, and its vector operations would be calls.)
    #[inline(always)]
    fn d_and_g(&self, wi: [F8; 3], wo: [F8; 3], h: [F8; 3]) -> (F8, F8) {
        match self.kinds {
            (true, false) => self.d_and_g_of(Distribution::Beckmann, wi, wo, h),
            (false, _) => self.d_and_g_of(Distribution::Ggx, wi, wo, h),
            (true, true) => {
                let b = self.d_and_g_of(Distribution::Beckmann, wi, wo, h);
                let g = self.d_and_g_of(Distribution::Ggx, wi, wo, h);
                (
                    F8::select(self.beckmann, b.0, g.0),
                    F8::select(self.beckmann, b.1, g.1),
                )
            }
        }
    }

    /// D(h) and G(wi, wo, h) of the distribution `kind` in every lane.
    #[inline(always)]
    fn d_and_g_of(&self, kind: Distribution, wi: [F8; 3], wo: [F8; 3], h: [F8; 3]) -> (F8, F8) {
        let g = microfacet::masking(kind, self.alpha, wi, h)
            * microfacet::masking(kind, self.alpha, wo, h);
        (microfacet::distribution(kind, self.alpha, h), g)
    }

    /// The polar angle's (cos θ, sin θ) of a microfacet normal for the uniform `u` of each lane
    /// ([`microfacet::polar`]), as [`Self::d_and_g`] picks its form.
    #[inline(always)]
    fn polar(&self, u: F8) -> (F8, F8) {
        match self.kinds {
            (true, false) => microfacet::polar(Distribution::Beckmann, self.alpha, u),
            (false, _) => microfacet::polar(Distribution::Ggx, self.alpha, u),
            (true, true) => {
                let b = microfacet::polar(Distribution::Beckmann, self.alpha, u);
                let g = microfacet::polar(Distribution::Ggx, self.alpha, u);
                (
                    F8::select(self.beckmann, b.0, g.0),
                    F8::select(self.beckmann, b.1, g.1),
                )
            }
        }
    }

    /// The local incident direction of each lane.
    #[inline(always)]
    pub fn incident(&self) -> [F8; 3] {
        self.wi
    }

    /// A plastic's coating transmittance T(cos θ) in each lane (its own table; 0 for others).
    #[inline(always)]
    fn transmittance(&self, cos: F8) -> F8 {
        let cos = cos.store();
        let mut t = [0.0; LANES];
        for l in 0..LANES {
            if !self.tables[l].is_empty() {
                t[l] = transmittance_at(self.tables[l], cos[l]);
            }
        }
        F8::load(&t)
    }

    /// f·cos θ_o and the density of the local direction `wo` of each lane ([`Bsdf::eval_pdf`]),
    /// and the lanes where the value is defined (both directions above the surface; for a
    /// conductor, D(h) > 0).
    #[inline(always)]
    pub fn eval_pdf(&self, wo: [F8; 3]) -> ([F8; C], F8, M8) {
        let (b, wi) = (F8::splat, self.wi);
        let valid = wi[2].gt(b(0.0)) & wo[2].gt(b(0.0));
        // The half vector, as `Vec3A::normalize` makes it (divided by its length).
        let sum = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let length = dot(&sum, &sum).sqrt();
        let h = [sum[0] / length, sum[1] / length, sum[2] / length];
        let (d, g) = self.d_and_g(wi, wo, h);
        let cos_ih = dot(&wi, &h);
        // D·h_z / (4 wo·h): the density of reflecting about h
        // ([`microfacet::Microfacet::reflection_pdf_at`]).
        let reflection_pdf = d * h[2].max(b(0.0)) / (b(4.0) * dot(&wo, &h));
        let mut f = [b(0.0); C];
        let mut pdf = reflection_pdf;
        if (!self.plastic & valid).bits() != 0 {
            // Conductors: F·specular·D·G / (4 cos θ_i).
            let value = d * g / (b(4.0) * wi[2]);
            for (c, f) in f.iter_mut().enumerate() {
                let fresnel = fresnel::conductor_channel(cos_ih, self.eta[c], self.k[c]);
                *f = fresnel * self.specular[c] * value;
            }
        }
        if (self.plastic & valid).bits() != 0 {
            // Plastics: the coating's F·D·G / (4 cos θ_i), and the base through it twice.
            let eta = self.eta[0];
            let coat = fresnel::dielectric(cos_ih, eta).0;
            let spec = coat * d * g / (b(4.0) * wi[2]);
            let scale = b(FRAC_1_PI) / (eta * eta) * wo[2] * self.t_i * self.transmittance(wo[2]);
            for (c, f) in f.iter_mut().enumerate() {
                let value = self.specular[c] * spec + self.base[c] * scale;
                *f = F8::select(self.plastic, value, *f);
            }
            let ps = self.prob_specular;
            let mixed = ps * reflection_pdf + (b(1.0) - ps) * wo[2] * b(FRAC_1_PI);
            pdf = F8::select(self.plastic, mixed, pdf);
        }
        // (A conductor's value is undefined where D(h) = 0; a plastic's base still scatters.)
        let some = valid & (self.plastic | d.ne(b(0.0)));
        for v in &mut f {
            *v = F8::select(some, *v, b(0.0));
        }
        (f, F8::select(valid, pdf, b(0.0)), some)
    }

    /// A local direction for each lane (met from above the surface) from its numbers `u` and
    /// `v`: the mirror direction about a microfacet normal drawn ∝ D·cos θ_m, or for a plastic
    /// with the probability of its base a cosine-weighted one.
    #[inline(always)]
    pub fn sample(&self, u: F8, v: F8) -> [F8; 3] {
        let (b, wi) = (F8::splat, self.wi);
        // A plastic's lobe, by the first number, which is then rescaled to [0, 1).
        let ps = F8::select(self.plastic, self.prob_specular, b(1.0));
        let coat = u.lt(ps);
        let u = F8::select(coat, u / ps, (u - ps) / (b(1.0) - ps)).min(b(ONE_MINUS_EPSILON));
        let (x, y) = square_to_uniform_disk_concentric_lanes(u, v);
        let r2 = x * x + y * y;
        // The azimuth's cosine and sine from the disk point (x itself at its centre).
        let r = r2.sqrt();
        let on_axis = r.eq(b(0.0));
        let inv = b(1.0) / r;
        let (cos_phi, sin_phi) = (
            F8::select(on_axis, b(1.0), x * inv),
            F8::select(on_axis, b(0.0), y * inv),
        );
        // (The other lanes' `ln` of NaN returns at once.)
        let (cos_t, sin_t) = self.polar(F8::select(self.lanes, r2, b(f32::NAN)));
        let m = [sin_t * cos_phi, sin_t * sin_phi, cos_t];
        let twice = b(2.0) * dot(&wi, &m);
        let z = (b(1.0) - r2).max(b(0.0)).sqrt();
        [
            F8::select(coat, twice * m[0] - wi[0], x),
            F8::select(coat, twice * m[1] - wi[1], y),
            F8::select(coat, twice * m[2] - wi[2], z),
        ]
    }
}
