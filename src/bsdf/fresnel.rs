//! Fresnel reflectance of a conductor (complex index of refraction η + ik), for unpolarised
//! light: the exact expression for an absorbing medium (e.g. K. D. Möller, "Optics", 1988, as
//! in pbrt and Mitsuba), per colour channel.

use crate::math::Spectrum;
use crate::simd::Real;

/// Reflectance at incidence cosine `cos_i` ∈ [0, 1] of a conductor with index `eta` + i`k`.
pub fn conductor(cos_i: f32, eta: Spectrum, k: Spectrum) -> Spectrum {
    Spectrum::new(
        conductor_channel(cos_i, eta.x, k.x),
        conductor_channel(cos_i, eta.y, k.y),
        conductor_channel(cos_i, eta.z, k.z),
    )
}

/// [`conductor`]'s reflectance in one channel of index `eta` + i`k`, for an `f32` or lanes of them
/// ([`crate::simd::F8`], the same bits).
#[inline(always)]
pub fn conductor_channel<T: Real>(cos_i: T, eta: T, k: T) -> T {
    let c = T::from;
    let c2 = cos_i * cos_i;
    let s2 = c(1.0) - c2;
    let s4 = s2 * s2;
    let t1 = eta * eta - k * k - s2;
    let a2pb2 = (t1 * t1 + c(4.0) * eta * eta * k * k).max(c(0.0)).sqrt();
    let a = (c(0.5) * (a2pb2 + t1)).max(c(0.0)).sqrt();
    let (term1, term2) = (a2pb2 + c2, c(2.0) * cos_i * a);
    let rs = (term1 - term2) / (term1 + term2);
    let (term3, term4) = (a2pb2 * c2 + s4, term2 * s2);
    let rp = rs * (term3 - term4) / (term3 + term4);
    c(0.5) * (rs + rp)
}

/// Fresnel reflectance of a dielectric interface with relative index `eta` (inside / outside) at
/// incidence cosine `cos_i` (negative: arriving from inside). Returns (F, cos θ_t, η_it, η_ti):
/// cos θ_t carries the opposite sign of `cos_i`; η_it is the relative index in the direction of
/// travel, η_ti its reciprocal (the scale of a refracted direction's tangential part).
#[inline(always)]
pub fn dielectric<T: Real>(cos_i: T, eta: T) -> (T, T, T, T) {
    let c = T::from;
    let outside = cos_i.ge(c(0.0));
    let (eta_it, eta_ti) = (
        T::select(outside, eta, c(1.0) / eta),
        T::select(outside, c(1.0) / eta, eta),
    );
    let cos_t2 = c(1.0) - (c(1.0) - cos_i * cos_i) * eta_ti * eta_ti;
    let (ci, ct) = (cos_i.abs(), cos_t2.max(c(0.0)).sqrt());
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    let r = c(0.5) * (a_s * a_s + a_p * a_p);
    // No interface (η = 1) reflects nothing; a grazing ray (cos 0) is reflected whole.
    let r = T::select(eta.eq(c(1.0)), c(0.0), T::select(ci.eq(c(0.0)), c(1.0), r));
    (r, T::select(outside, -ct, ct), eta_it, eta_ti)
}

/// Mean Fresnel reflectance over a cosine-weighted hemisphere (Egan and Hilgeman 1973 for
/// η < 1, d'Eon and Irving 2011 otherwise), as Mitsuba approximates it for `plastic`.
pub fn diffuse_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        let c = [0.919317, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881];
        c.iter().rev().fold(0.0, |acc, k| acc * inv + k)
    }
}
