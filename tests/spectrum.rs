//! Spectrum → RGB against values Mitsuba 3.9.1 (`scalar_rgb`) gives for the same spectra
//! (`mi.spectrum_list_to_srgb`, and an emitter's uniform `<spectrum value="0.5"/>` in llvm_ad_rgb).
//! The live comparison with Mitsuba is tests/python/test_dropin.py.

use nlos_rs::spectrum::{to_srgb, uniform_illuminant_srgb};

/// Mitsuba sums the 1000 points in float32 and prints six digits: agreement to 1e-4 relative.
fn close(a: [f64; 3], b: [f64; 3]) {
    close_to(a, b, 1e-4);
}

fn close_to(a: [f64; 3], b: [f64; 3], rel: f64) {
    for k in 0..3 {
        assert!(
            (a[k] - b[k]).abs() <= 2e-6 + rel * b[k].abs(),
            "{a:?} vs {b:?}"
        );
    }
}

#[test]
fn flat_spectrum_as_emission_and_as_reflectance() {
    let flat = [(400.0, 1.0), (700.0, 1.0)];
    close(to_srgb(&flat, false), [1.199693, 0.9495215, 0.90344316]);
    close(to_srgb(&flat, true), [0.99534136, 0.99975574, 0.9949095]);
}

#[test]
fn out_of_gamut_channels_are_clamped() {
    // A narrow green band: sRGB blue would be negative.
    close(
        to_srgb(&[(550.0, 1.0), (560.0, 1.0)], false),
        [0.0122891, 0.133081, 0.0],
    );
    close(
        to_srgb(&[(550.0, 1.0), (560.0, 1.0)], true),
        [0.0124793, 0.137198, 0.0],
    );
}

#[test]
fn uneven_spectrum_and_uniform_illuminant() {
    let s = [(400.0, 0.2), (500.0, 0.8), (600.0, 0.1), (700.0, 0.5)];
    close(to_srgb(&s, false), [0.0588074, 0.499072, 0.478775]);
    close(to_srgb(&s, true), [0.0, 0.531782, 0.534254]);
    // Our equal-energy white is mi.spectrum_list_to_srgb([360, 830], [v, v]) to 1e-6; an
    // emitter's uniform <spectrum> in Mitsuba's XML goes another way that differs by < 4e-4.
    close_to(
        uniform_illuminant_srgb(0.5),
        [0.6024413, 0.47411445, 0.45463338],
        1e-5,
    );
    close_to(
        uniform_illuminant_srgb(0.5),
        [0.602397, 0.474146, 0.454458],
        4e-4,
    );
}
