//! Named indices of refraction. Dielectrics: Mitsuba's table of real indices. Conductors: the
//! complex indices of refraction of Mitsuba's named conductor materials (`material` of
//! `conductor` and `roughconductor`), as linear-sRGB triples: Mitsuba 3 tabulates these spectra
//! (the data PBRT distributes, after Palik et al., "Handbook of Optical Constants of Solids") and
//! reduces them to RGB in its RGB variants; these are the values it uses there. Mono variants use
//! their luminance.

/// (name, η, k) per material.
pub const CONDUCTORS: [(&str, [f64; 3], [f64; 3]); 65] = include!("../data/conductor_ior.in");

/// η and k of a named material, if Mitsuba knows it.
pub fn conductor(name: &str) -> Option<([f64; 3], [f64; 3])> {
    CONDUCTORS
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|(_, eta, k)| (*eta, *k))
}

/// Mitsuba's named indices of refraction of dielectrics (`int_ior`, `ext_ior`).
pub const DIELECTRICS: [(&str, f32); 23] = include!("../data/dielectric_ior.in");

/// An index of refraction given as a number or a name (`int_ior`, `ext_ior`), as Mitsuba reads it.
pub fn read_ior(p: &crate::props::Props, key: &str, default: &str) -> crate::error::Result<f32> {
    let v = match p.string_or_float(key)? {
        Some(Ok(v)) => v as f32,
        Some(Err(name)) => lookup(p, key, &name)?,
        None => lookup(p, key, default)?,
    };
    if !(v > 0.0 && v.is_finite()) {
        return Err(crate::error::NlosError::prop(
            &p.plugin,
            key,
            "must be positive",
        ));
    }
    Ok(v)
}

fn lookup(p: &crate::props::Props, key: &str, name: &str) -> crate::error::Result<f32> {
    DIELECTRICS
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(name))
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            crate::error::NlosError::prop(
                &p.plugin,
                key,
                format!("unknown index of refraction '{name}'"),
            )
        })
}
