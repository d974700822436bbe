//! Fresnel reflectance of a conductor (complex index of refraction η + ik), for unpolarised
//! light: the exact expression for an absorbing medium (e.g. K. D. Möller, "Optics", 1988, as
//! in pbrt and Mitsuba), per colour channel.

use crate::math::Spectrum;

/// Reflectance at incidence cosine `cos_i` ∈ [0, 1] of a conductor with index `eta` + i`k`.
pub fn conductor(cos_i: f32, eta: Spectrum, k: Spectrum) -> Spectrum {
    let c2 = cos_i * cos_i;
    let s2 = 1.0 - c2;
    let s4 = s2 * s2;
    let channel = |eta: f32, k: f32| {
        let t1 = eta * eta - k * k - s2;
        let a2pb2 = (t1 * t1 + 4.0 * eta * eta * k * k).max(0.0).sqrt();
        let a = (0.5 * (a2pb2 + t1)).max(0.0).sqrt();
        let (term1, term2) = (a2pb2 + c2, 2.0 * cos_i * a);
        let rs = (term1 - term2) / (term1 + term2);
        let (term3, term4) = (a2pb2 * c2 + s4, term2 * s2);
        let rp = rs * (term3 - term4) / (term3 + term4);
        0.5 * (rs + rp)
    };
    Spectrum::new(
        channel(eta.x, k.x),
        channel(eta.y, k.y),
        channel(eta.z, k.z),
    )
}

/// Fresnel reflectance of a dielectric interface with relative index `eta` (inside / outside) at
/// incidence cosine `cos_i` (negative: arriving from inside). Returns (F, cos θ_t, η_it, η_ti):
/// cos θ_t carries the opposite sign of `cos_i`; η_it is the relative index in the direction of
/// travel, η_ti its reciprocal (the scale of a refracted direction's tangential part).
pub fn dielectric(cos_i: f32, eta: f32) -> (f32, f32, f32, f32) {
    let (eta_it, eta_ti) = if cos_i >= 0.0 {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let cos_t2 = 1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti;
    let (ci, ct) = (cos_i.abs(), cos_t2.max(0.0).sqrt());
    let r = if eta == 1.0 {
        0.0
    } else if ci == 0.0 {
        1.0
    } else {
        let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
        let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    (r, if cos_i >= 0.0 { -ct } else { ct }, eta_it, eta_ti)
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
