//! BSDFs: χ² of each BSDF's `sample` against its `pdf` over the whole sphere of directions
//! (the method of tests/common), for normals tilted off the axes and `wi` on either side, and the
//! sampled weight equal to eval/pdf.

use glam::{Vec2, Vec3A};
use nlos_rs::bsdf::{Bsdf, Diffuse, TwoSided};
use nlos_rs::math::{Frame, Spectrum};
use nlos_rs::sampling::Sampler;
use std::f64::consts::PI;

mod common;
use common::check;

fn diffuse(r: f32) -> Bsdf<Spectrum> {
    Bsdf::Diffuse(Diffuse {
        reflectance: Spectrum::new(r, 0.5 * r, 0.25 * r),
    })
}

fn twosided() -> Bsdf<Spectrum> {
    Bsdf::TwoSided(TwoSided {
        front: Box::new(diffuse(0.8)),
        back: Box::new(diffuse(0.3)),
    })
}

/// Directions in a frame around `n` as (a, b) = ((1 + cos θ)/2, φ/2π): dω = 4π da db.
fn to_cell(n: Vec3A, w: Vec3A) -> Vec2 {
    let f = Frame::new(n);
    let (x, y, z) = (w.dot(f.s), w.dot(f.t), w.dot(f.n));
    Vec2::new(
        ((1.0 + z) / 2.0).clamp(0.0, 0.999_999),
        (y.atan2(x) / (2.0 * std::f32::consts::PI)).rem_euclid(1.0),
    )
}

fn from_cell(n: Vec3A, a: f64, b: f64) -> Vec3A {
    let f = Frame::new(n);
    let z = 2.0 * a - 1.0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * b;
    f.to_world(Vec3A::new(
        (r * phi.cos()) as f32,
        (r * phi.sin()) as f32,
        z as f32,
    ))
}

/// χ² of `bsdf.sample` against `bsdf.pdf` for `wi`, and weight = eval/pdf on the samples.
fn check_bsdf(name: &str, bsdf: &Bsdf<Spectrum>, n: Vec3A, wi: Vec3A) {
    let mut rng = Sampler::new(5, 6, 7);
    for _ in 0..2000 {
        let s = bsdf.sample(n, wi, &mut rng).expect("a direction");
        let f = bsdf.eval(n, wi, s.wo).unwrap_or(Spectrum::ZERO);
        let pdf = bsdf.pdf(n, wi, s.wo);
        assert!((s.pdf - pdf).abs() <= 1e-4 * pdf.max(1.0), "{name}: pdf");
        assert!(
            (s.weight - f / pdf).abs().max_element() < 1e-3,
            "{name}: weight"
        );
    }
    let rng = std::cell::RefCell::new(Sampler::new(9, 8, 7));
    check(
        name,
        |_| {
            let s = bsdf
                .sample(n, wi, &mut rng.borrow_mut())
                .expect("a direction");
            to_cell(n, s.wo)
        },
        |a, b| bsdf.pdf(n, wi, from_cell(n, a, b)) as f64 * 4.0 * PI,
    );
}

#[test]
fn diffuse_samples_its_pdf() {
    let n = Vec3A::new(0.3, -0.5, 0.8).normalize();
    check_bsdf(
        "diffuse",
        &diffuse(0.7),
        n,
        Vec3A::new(0.1, 0.2, 0.9).normalize(),
    );
}

#[test]
fn twosided_samples_its_pdf_from_both_sides() {
    let n = Vec3A::new(-0.2, 0.9, 0.4).normalize();
    check_bsdf("twosided front", &twosided(), n, n);
    check_bsdf(
        "twosided back",
        &twosided(),
        n,
        -Vec3A::new(-0.1, 0.8, 0.5).normalize(),
    );
}

#[test]
fn twosided_reflects_each_side_with_its_own_bsdf_and_never_transmits() {
    let (bsdf, n) = (twosided(), Vec3A::Z);
    let (wi, wo) = (Vec3A::new(0.0, 0.6, 0.8), Vec3A::new(0.6, 0.0, 0.8));
    let front = bsdf.eval(n, wi, wo).expect("front");
    let back = bsdf.eval(n, -wi, -wo).expect("back");
    assert!((front.x / back.x - 0.8 / 0.3).abs() < 1e-5);
    assert!(bsdf.eval(n, wi, -wo).is_none() && bsdf.eval(n, -wi, wo).is_none());
    assert_eq!(bsdf.pdf(n, wi, -wo), 0.0);
}
