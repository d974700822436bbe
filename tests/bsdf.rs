//! BSDFs: χ² of each BSDF's `sample` against its `pdf` over the whole sphere of directions
//! (the method of tests/common), for normals tilted off the axes and `wi` on either side, and the
//! sampled weight equal to eval/pdf.

use glam::{Vec2, Vec3A};
use nlos_rs::bsdf::{Bsdf, Diffuse, Rough, RoughLanes, TwoSided};
use nlos_rs::math::{Frame, Spectrum};
use nlos_rs::sampling::Sampler;
use nlos_rs::simd::{F8, LANES};
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

/// χ² of `bsdf.sample` against `bsdf.pdf` for `wi`, and weight = eval/pdf on the samples. A
/// sample may fail (a microfacet reflection below the surface) or be a delta (a coating's
/// mirror reflection): that mass is missing from both the histogram and the pdf, whose integral
/// is then below one.
fn check_bsdf(name: &str, bsdf: &Bsdf<Spectrum>, n: Vec3A, wi: Vec3A) {
    let mut rng = Sampler::new(5, 6, 7);
    for _ in 0..2000 {
        let Some(s) = bsdf.sample(n, wi, &mut rng).filter(|s| !s.delta) else {
            continue;
        };
        let f = bsdf.eval(n, wi, s.wo).unwrap_or(Spectrum::ZERO);
        let pdf = bsdf.pdf(n, wi, s.wo);
        assert!((s.pdf - pdf).abs() <= 1e-3 * pdf.max(1.0), "{name}: pdf");
        assert!(
            (s.weight - f / pdf).abs().max_element() <= 1e-3 * s.weight.max_element().max(1.0),
            "{name}: weight"
        );
    }
    check(
        name,
        // Delta samples (a coating's mirror reflection) are outside `pdf`: not binned.
        |rng| {
            bsdf.sample(n, wi, rng)
                .filter(|s| !s.delta)
                .map(|s| to_cell(n, s.wo))
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

fn rough(kind: nlos_rs::bsdf::microfacet::Distribution, alpha: f32) -> Bsdf<Spectrum> {
    Bsdf::RoughConductor(nlos_rs::bsdf::RoughConductor {
        eta: Spectrum::new(0.2, 0.92, 1.1),
        k: Spectrum::new(3.9, 2.45, 2.14),
        specular_reflectance: Spectrum::ONE,
        microfacet: nlos_rs::bsdf::microfacet::Microfacet { kind, alpha },
    })
}

#[test]
fn roughconductor_samples_its_pdf() {
    use nlos_rs::bsdf::microfacet::Distribution::{Beckmann, Ggx};
    let n = Vec3A::new(0.2, 0.3, 0.9).normalize();
    for (kind, alpha) in [(Beckmann, 0.1), (Beckmann, 0.5), (Ggx, 0.2), (Ggx, 0.8)] {
        for wi in [n, Vec3A::new(0.7, -0.2, 0.4).normalize()] {
            check_bsdf(
                &format!("{kind:?} alpha {alpha}"),
                &rough(kind, alpha),
                n,
                wi,
            );
        }
    }
}

#[test]
fn conductor_fresnel_and_mirror_reflection() {
    use nlos_rs::bsdf::{Conductor, fresnel};
    let (eta, k) = (
        Spectrum::new(0.2, 0.92, 1.1),
        Spectrum::new(3.9, 2.45, 2.14),
    );
    // Normal incidence: ((η − 1)² + k²) / ((η + 1)² + k²); grazing: 1.
    let f0 = fresnel::conductor(1.0, eta, k);
    let expect = ((eta - 1.0) * (eta - 1.0) + k * k) / ((eta + 1.0) * (eta + 1.0) + k * k);
    assert!(
        (f0 - expect).abs().max_element() < 1e-6,
        "{f0:?} vs {expect:?}"
    );
    assert!(
        (fresnel::conductor(0.0, eta, k) - Spectrum::ONE)
            .abs()
            .max_element()
            < 1e-6
    );
    // η = 0, k = 1 (material 'none') is a perfect mirror at every angle.
    for c in [0.1, 0.5, 0.9] {
        let f = fresnel::conductor(c, Spectrum::ZERO, Spectrum::ONE);
        assert!((f - Spectrum::ONE).abs().max_element() < 1e-5, "{f:?}");
    }
    let mirror = Bsdf::Conductor(Conductor {
        eta,
        k,
        specular_reflectance: Spectrum::splat(0.5),
    });
    let (n, wi) = (Vec3A::Z, Vec3A::new(0.6, 0.0, 0.8));
    let mut rng = Sampler::new(1, 2, 3);
    let s = mirror.sample(n, wi, &mut rng).expect("reflects");
    assert!(s.delta && (s.wo - Vec3A::new(-0.6, 0.0, 0.8)).length() < 1e-6);
    assert!(
        (s.weight - fresnel::conductor(0.8, eta, k) * 0.5)
            .abs()
            .max_element()
            < 1e-7
    );
    assert!(
        mirror.is_delta() && mirror.eval(n, wi, s.wo).is_none() && mirror.pdf(n, wi, s.wo) == 0.0
    );
    assert!(mirror.sample(n, -wi, &mut rng).is_none());
}

#[test]
fn plastic_diffuse_part_samples_its_pdf_and_the_coating_reflects_with_fresnel() {
    use nlos_rs::bsdf::{Plastic, fresnel};
    let plastic = Bsdf::Plastic(Plastic {
        diffuse_reflectance: Spectrum::new(0.6, 0.3, 0.1),
        specular_reflectance: Spectrum::ONE,
        eta: 1.49,
        nonlinear: false,
    });
    let n = Vec3A::new(0.1, -0.3, 0.9).normalize();
    let wi = Vec3A::new(0.5, 0.1, 0.6).normalize();
    check_bsdf("plastic", &plastic, n, wi);
    // The delta part: the mirror direction, with weight F_i / P(specular); averaged over the
    // lobe choice the specular weight is F_i.
    let (mut rng, mut spec) = (Sampler::new(1, 1, 1), Spectrum::ZERO);
    let trials = 200_000;
    for _ in 0..trials {
        if let Some(s) = plastic.sample(n, wi, &mut rng).filter(|s| s.delta) {
            assert!((s.wo - (2.0 * n.dot(wi) * n - wi)).length() < 1e-5);
            spec += s.weight;
        }
    }
    let f_i = fresnel::dielectric(n.dot(wi), 1.49).0;
    assert!(
        (spec.x / trials as f32 - f_i).abs() < 0.01 * f_i + 1e-3,
        "{spec:?} vs {f_i}"
    );
}

#[test]
fn dielectric_refracts_by_snell_and_chooses_by_fresnel() {
    use nlos_rs::bsdf::{Dielectric, ThinDielectric, fresnel};
    let glass = Bsdf::Dielectric(Dielectric {
        eta: 1.5,
        specular_reflectance: Spectrum::ONE,
        specular_transmittance: Spectrum::ONE,
    });
    let n = Vec3A::Z;
    let wi = Vec3A::new(0.6, 0.0, 0.8);
    let (r, cos_t, eta_it, _) = fresnel::dielectric(0.8, 1.5);
    assert!((eta_it - 1.5).abs() < 1e-6 && cos_t < 0.0);
    let mut rng = Sampler::new(2, 2, 2);
    let (mut reflected, trials) = (0usize, 100_000);
    for _ in 0..trials {
        let s = glass.sample(n, wi, &mut rng).expect("an event");
        assert!(s.delta);
        if s.wo.z > 0.0 {
            reflected += 1;
            assert!(s.eta == 1.0 && (s.weight - Spectrum::ONE).abs().max_element() < 1e-6);
        } else {
            // Snell: sin θ_t = sin θ_i / η; radiance scaled by (1/η)².
            assert!((s.wo.x - (-0.6 / 1.5)).abs() < 1e-5 && (s.wo.length() - 1.0).abs() < 1e-5);
            assert!(s.eta == 1.5 && (s.weight.x - 1.0 / 2.25).abs() < 1e-5);
        }
    }
    let frac = reflected as f32 / trials as f32;
    assert!(
        (frac - r).abs() < 4.0 * (r * (1.0 - r) / trials as f32).sqrt(),
        "{frac} vs {r}"
    );
    // From inside at a grazing angle: total internal reflection.
    let inside = Vec3A::new(0.9, 0.0, -(1.0f32 - 0.81).sqrt());
    for _ in 0..100 {
        let s = glass.sample(n, inside, &mut rng).expect("an event");
        assert!(s.wo.z < 0.0 && s.eta == 1.0);
    }
    // A thin sheet: straight through or mirrored, the optical speed unchanged.
    let sheet = Bsdf::ThinDielectric(ThinDielectric(Dielectric {
        eta: 1.5,
        specular_reflectance: Spectrum::ONE,
        specular_transmittance: Spectrum::ONE,
    }));
    for _ in 0..100 {
        let s = sheet.sample(n, wi, &mut rng).expect("an event");
        assert!(s.eta == 1.0 && ((s.wo + wi).length() < 1e-6 || (s.wo.z - 0.8).abs() < 1e-6));
    }
}

#[test]
fn roughplastic_samples_its_pdf() {
    use nlos_rs::bsdf::microfacet::{Distribution, Microfacet};
    use nlos_rs::bsdf::{Bsdf, RoughPlastic};
    use nlos_rs::props::{Colour, Props, Value};
    for (dist, alpha) in [("ggx", 0.2), ("beckmann", 0.5)] {
        let mut p = Props::new("roughplastic", None);
        p.insert("distribution", Value::Str(dist.into())).unwrap();
        p.insert("alpha", Value::Float(alpha)).unwrap();
        p.insert("diffuse_reflectance", Value::Rgb([0.6, 0.3, 0.1]))
            .unwrap();
        let b: Bsdf<Colour> = Bsdf::from_props(&p).unwrap();
        let Bsdf::RoughPlastic(rp) = &b else {
            panic!("roughplastic")
        };
        // The coating lets most light through at normal incidence and little at grazing.
        let RoughPlastic {
            transmittance: t,
            microfacet: Microfacet { kind, .. },
            ..
        } = rp;
        assert_eq!(
            *kind,
            if dist == "ggx" {
                Distribution::Ggx
            } else {
                Distribution::Beckmann
            }
        );
        assert!(
            t[63] > 0.9 && t[63] < 0.97 && t[1] < t[63],
            "{:?}",
            (t[1], t[63])
        );
        assert!(rp.internal_reflectance > 0.3 && rp.internal_reflectance < 0.8);
        let bsdf = b.resolve(false);
        let n = Vec3A::new(0.2, 0.1, 0.95).normalize();
        check_bsdf(
            &format!("roughplastic {dist}"),
            &bsdf,
            n,
            Vec3A::new(-0.4, 0.3, 0.7).normalize(),
        );
    }
}

#[test]
fn blendbsdf_samples_its_mixture_pdf_and_mask_lets_the_rest_through() {
    use nlos_rs::bsdf::Blend;
    use nlos_rs::bsdf::microfacet::Distribution::Ggx;
    let blend = Bsdf::Blend(Blend {
        weight: 0.3,
        first: Some(Box::new(diffuse(0.8))),
        second: Box::new(rough(Ggx, 0.2)),
    });
    let n = Vec3A::new(-0.3, 0.2, 0.9).normalize();
    let wi = Vec3A::new(0.4, 0.4, 0.6).normalize();
    check_bsdf("blendbsdf", &blend, n, wi);
    // f = 0.7 f_diffuse + 0.3 f_rough.
    let wo = Vec3A::new(-0.2, -0.1, 0.95).normalize();
    let mix = blend.eval(n, wi, wo).unwrap();
    let parts = diffuse(0.8).eval(n, wi, wo).unwrap() * 0.7
        + rough(Ggx, 0.2).eval(n, wi, wo).unwrap() * 0.3;
    assert!((mix - parts).abs().max_element() < 1e-6);
    let mask = Bsdf::Blend(Blend {
        weight: 0.25,
        first: None,
        second: Box::new(diffuse(0.8)),
    });
    assert!(mask.has_delta() && !mask.is_delta());
    let mut rng = Sampler::new(4, 4, 4);
    let through = (0..100_000)
        .filter(|_| {
            let s = mask.sample(n, wi, &mut rng).unwrap();
            s.delta && (s.wo + wi).length() < 1e-6 && s.weight == Spectrum::ONE
        })
        .count() as f32
        / 100_000.0;
    assert!((through - 0.75).abs() < 0.006, "{through}");
    check_bsdf("mask", &mask, n, wi);
}

/// `eval_pdf` (value and density found together: the lanes' light samples on general BSDFs)
/// gives `eval`'s and `pdf`'s bits for every kind of BSDF, on random normals and directions on
/// either side.
#[test]
fn eval_pdf_gives_the_bits_of_eval_and_pdf() {
    use nlos_rs::bsdf::Blend;
    use nlos_rs::bsdf::microfacet::Distribution::{Beckmann, Ggx};
    use nlos_rs::props::{Colour, Props, Value};
    let read = |plugin: &str, keys: &[(&str, Value)]| {
        let mut p = Props::new(plugin, None);
        for (k, v) in keys {
            p.insert(*k, v.clone()).unwrap();
        }
        Bsdf::<Colour>::from_props(&p).unwrap().resolve(false)
    };
    let bsdfs = [
        diffuse(0.7),
        twosided(),
        rough(Beckmann, 0.05),
        rough(Ggx, 0.4),
        read("roughplastic", &[("alpha", Value::Float(0.2))]),
        read(
            "plastic",
            &[("diffuse_reflectance", Value::Rgb([0.6, 0.3, 0.1]))],
        ),
        read("conductor", &[]),
        read("dielectric", &[]),
        Bsdf::Blend(Blend {
            weight: 0.3,
            first: Some(Box::new(diffuse(0.8))),
            second: Box::new(rough(Ggx, 0.2)),
        }),
        Bsdf::Blend(Blend {
            weight: 0.6,
            first: None,
            second: Box::new(read("roughplastic", &[("alpha", Value::Float(0.5))])),
        }),
    ];
    let bits = |f: Option<Spectrum>| f.map(|f| f.to_array().map(f32::to_bits));
    let mut rng = Sampler::new(9, 9, 9);
    let mut unit = || {
        let v = Vec3A::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 2.0 - Vec3A::ONE;
        v.normalize()
    };
    let mut some = 0;
    for bsdf in &bsdfs {
        for _ in 0..20_000 {
            let (n, wi, wo) = (unit(), unit(), unit());
            let (f, pdf) = bsdf.eval_pdf(n, wi, wo);
            assert_eq!(bits(f), bits(bsdf.eval(n, wi, wo)), "{bsdf:?}");
            assert_eq!(pdf.to_bits(), bsdf.pdf(n, wi, wo).to_bits(), "{bsdf:?}");
            some += f.is_some() as usize;
        }
    }
    // (Most pairs lie on one side of some BSDF: many values are found, not only `None`s.)
    assert!(some > 40_000, "{some}");
}

/// Three coordinates of eight lanes.
type Dirs = [[f32; LANES]; 3];

/// Eight lanes' rough BSDFs `rough` gathered ([`RoughLanes`]): each lane's value, density and
/// defined flag at the local directions `wi`, `wo`, and its sampled direction for `wi` from the
/// numbers `u`.
#[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,fma"))]
unsafe fn rough_lanes(
    rough: [Option<&Rough>; LANES],
    wi: Dirs,
    wo: Dirs,
    u: [[f32; LANES]; 2],
) -> (Dirs, [f32; LANES], u32, Dirs) {
    let (wi, wo) = (wi.map(|a| F8::load(&a)), wo.map(|a| F8::load(&a)));
    let lanes = RoughLanes::<3>::gather(rough, wi);
    let (f, pdf, some) = lanes.eval_pdf(wo);
    let s = lanes.sample(F8::load(&u[0]), F8::load(&u[1]));
    (f.map(F8::store), pdf.store(), some.bits(), s.map(F8::store))
}

/// The rough BSDFs the lanes take: conductors and plastics (linear and not) of either
/// distribution, rgb.
fn rough_bsdfs() -> Vec<Bsdf<Spectrum>> {
    use nlos_rs::bsdf::microfacet::Distribution::{Beckmann, Ggx};
    use nlos_rs::props::{Colour, Props, Value};
    let read = |keys: &[(&str, Value)]| {
        let mut p = Props::new("roughplastic", None);
        for (k, v) in keys {
            p.insert(*k, v.clone()).unwrap();
        }
        Bsdf::<Colour>::from_props(&p).unwrap().resolve(false)
    };
    vec![
        rough(Beckmann, 0.05),
        rough(Ggx, 0.4),
        read(&[("alpha", Value::Float(0.2))]),
        read(&[
            ("alpha", Value::Float(0.5)),
            ("distribution", Value::Str("ggx".into())),
            ("diffuse_reflectance", Value::Rgb([0.6, 0.3, 0.1])),
        ]),
        read(&[
            ("alpha", Value::Float(0.1)),
            ("nonlinear", Value::Bool(true)),
            ("int_ior", Value::Float(1.9)),
        ]),
    ]
}

/// Lanes of rough conductors and plastics, mixed, give each lane the bits of its BSDF's
/// `eval_pdf` (value, or none, and density), for random normals and directions on either side.
#[test]
fn rough_lanes_give_the_bits_of_eval_pdf() {
    if !nlos_rs::simd::available() {
        return; // no AVX2 on this x86-64 CPU: the lanes never run here
    }
    let bsdfs = rough_bsdfs();
    let rough: Vec<Rough> = bsdfs.iter().map(|b| Rough::of(b).expect("rough")).collect();
    let mut rng = Sampler::new(4, 4, 4);
    let mut unit = || {
        let v = Vec3A::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 2.0 - Vec3A::ONE;
        v.normalize()
    };
    let mut some = 0;
    for round in 0..20_000 {
        let pick: [usize; LANES] = std::array::from_fn(|l| (round + 3 * l) % bsdfs.len());
        let (mut wi, mut wo) = ([[0.0; LANES]; 3], [[0.0; LANES]; 3]);
        let mut world = [(Vec3A::ZERO, Vec3A::ZERO, Vec3A::ZERO); LANES];
        for l in 0..LANES {
            let (n, i, o) = (unit(), unit(), unit());
            let f = Frame::new(n);
            let (li, lo) = (f.to_local(i), f.to_local(o));
            for a in 0..3 {
                (wi[a][l], wo[a][l]) = (li[a], lo[a]);
            }
            world[l] = (n, i, o);
        }
        // SAFETY: the CPU runs AVX2 and FMA (checked above).
        let (f, pdf, defined, _) =
            unsafe { rough_lanes(pick.map(|k| Some(&rough[k])), wi, wo, [[0.5; LANES]; 2]) };
        for l in 0..LANES {
            let (n, i, o) = world[l];
            let (f_s, pdf_s) = bsdfs[pick[l]].eval_pdf(n, i, o);
            let lane_f =
                (defined >> l & 1 != 0).then(|| [f[0][l], f[1][l], f[2][l]].map(f32::to_bits));
            assert_eq!(
                lane_f,
                f_s.map(|f| f.to_array().map(f32::to_bits)),
                "{:?}",
                bsdfs[pick[l]]
            );
            assert_eq!(pdf[l].to_bits(), pdf_s.to_bits(), "{:?}", bsdfs[pick[l]]);
            some += f_s.is_some() as usize;
        }
    }
    assert!(some > 20_000, "{some}");
}

/// The lanes' sampling of rough conductors and plastics (a microfacet normal from the concentric
/// disk, a plastic's lobe by a rescaled number) against the BSDF's density, χ² over the sphere,
/// at normal and oblique incidence.
#[test]
fn rough_lanes_sample_their_pdf() {
    if !nlos_rs::simd::available() {
        return;
    }
    let n = Vec3A::new(0.2, 0.3, 0.9).normalize();
    let frame = Frame::new(n);
    for bsdf in rough_bsdfs() {
        let rough = Rough::of(&bsdf).expect("rough");
        for wi in [n, Vec3A::new(0.7, -0.2, 0.4).normalize()] {
            let li = frame.to_local(wi);
            let local = [[li.x; LANES], [li.y; LANES], [li.z; LANES]];
            check(
                &format!("lanes {bsdf:?}"),
                |rng| {
                    let u = [[rng.next_1d(); LANES], [rng.next_1d(); LANES]];
                    // SAFETY: as above.
                    let (_, _, _, wo) =
                        unsafe { rough_lanes([Some(&rough); LANES], local, local, u) };
                    let wo = frame.to_world(Vec3A::new(wo[0][0], wo[1][0], wo[2][0]));
                    // (A microfacet reflection below the surface has no value: not binned.)
                    (wo.dot(n) > 0.0).then(|| to_cell(n, wo))
                },
                |a, b| bsdf.pdf(n, wi, from_cell(n, a, b)) as f64 * 4.0 * PI,
            );
        }
    }
}
