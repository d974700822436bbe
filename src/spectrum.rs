//! Spectra given as `wavelength:value` pairs (or a uniform value in a `spectrum` tag), reduced to
//! RGB and mono the way Mitsuba 3's RGB and mono variants reduce them, so that the same scene
//! file means the same light:
//!
//! 1. integrate the piecewise-linear spectrum against the CIE 1931 colour-matching functions over
//!    [360, 830] nm with 1000 evenly spaced points (a reflectance is weighted by the D65
//!    illuminant, so a flat reflectance stays white), scaled by the CIE Y normalisation;
//! 2. convert XYZ to linear sRGB;
//! 3. clamp negative channels to 0 and, for a reflectance, channels above 1 to 1;
//! 4. mono variants use the luminance of that RGB value.
//!
//! A uniform `spectrum` on an emitter is the equal-energy illuminant of that value (its RGB is not
//! grey); on a BSDF it is the value itself. A plain float is always the value itself.

/// CIE 1931 2° colour-matching functions x̄, ȳ, z̄ and the CIE D65 illuminant (relative), every
/// 5 nm from 360 to 830 nm (the standard CIE tables, as Mitsuba 3 tabulates them).
const CIE_TABLE: [[f32; 4]; 95] = include!("data/cie1931_d65.in");

const CIE_MIN: f64 = 360.0;
const CIE_MAX: f64 = 830.0;
/// 1 / ∫ȳ(λ) dλ, as Mitsuba 3 normalises.
const CIE_Y_NORMALIZATION: f64 = 0.009_367_658_735_689_113;

/// Linear sRGB from CIE XYZ (rows).
const XYZ_TO_SRGB: [[f64; 3]; 3] = [
    [3.240_479, -1.537_150, -0.498_535],
    [-0.969_256, 1.875_991, 0.041_556],
    [0.055_648, -0.204_043, 1.057_311],
];

/// x̄, ȳ, z̄ and D65 at `w` nm, linearly interpolated in the table.
fn cie(w: f64) -> [f64; 4] {
    let x = ((w - CIE_MIN) / 5.0).clamp(0.0, (CIE_TABLE.len() - 1) as f64);
    let i = (x as usize).min(CIE_TABLE.len() - 2);
    let t = x - i as f64;
    let (a, b) = (CIE_TABLE[i], CIE_TABLE[i + 1]);
    [0, 1, 2, 3].map(|k| a[k] as f64 * (1.0 - t) + b[k] as f64 * t)
}

/// Linear sRGB of a spectrum given as (wavelength nm, value) pairs with increasing wavelengths,
/// zero outside them. `reflectance`: weighted by D65 and clamped to [0, 1]; else (emission)
/// clamped below at 0.
pub fn to_srgb(pairs: &[(f64, f64)], reflectance: bool) -> [f64; 3] {
    const STEPS: usize = 1000;
    let mut xyz = [0.0f64; 3];
    let (Some(first), Some(last)) = (pairs.first(), pairs.last()) else {
        return [0.0; 3];
    };
    for i in 0..STEPS {
        let w = CIE_MIN + i as f64 / (STEPS - 1) as f64 * (CIE_MAX - CIE_MIN);
        if w < first.0 || w > last.0 {
            continue;
        }
        let k = pairs
            .partition_point(|p| p.0 <= w)
            .clamp(1, pairs.len() - 1);
        let ((w0, v0), (w1, v1)) = (pairs[k - 1], pairs[k]);
        let t = if w1 > w0 { (w - w0) / (w1 - w0) } else { 0.0 };
        let c = cie(w);
        let v = (v0 * (1.0 - t) + v1 * t) * if reflectance { c[3] } else { 1.0 };
        for (acc, cmf) in xyz.iter_mut().zip(c) {
            *acc += cmf * v;
        }
    }
    let scale = (CIE_MAX - CIE_MIN) / STEPS as f64 * CIE_Y_NORMALIZATION;
    XYZ_TO_SRGB.map(|row| {
        let c = (row[0] * xyz[0] + row[1] * xyz[1] + row[2] * xyz[2]) * scale;
        if reflectance {
            c.clamp(0.0, 1.0)
        } else {
            c.max(0.0)
        }
    })
}

/// Linear sRGB of the equal-energy illuminant of value `v` (a uniform `spectrum` on an emitter).
pub fn uniform_illuminant_srgb(v: f64) -> [f64; 3] {
    to_srgb(&[(CIE_MIN, v), (CIE_MAX, v)], false)
}
