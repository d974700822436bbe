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
