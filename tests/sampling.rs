//! χ² goodness-of-fit tests of every sampling routine against its density (in the manner of
//! Mitsuba's `chi2.py` and pbrt-v4's `Chi2Test`): histogram N samples over a grid, integrate the
//! density over each cell for the expected counts, pool cells expecting < 5, and reject when the
//! Wilson–Hilferty normal score of the χ² statistic exceeds a Šidák-corrected threshold.

use glam::{Vec2, Vec3A};
use nlos_rs::sampling::*;

mod common;

/// A warp of the unit square as a sampler for [`check`].
fn warp(f: impl Fn(Vec2) -> Vec2) -> impl FnMut(&mut Sampler) -> Option<Vec2> {
    move |rng| Some(f(rng.next_2d()))
}
use common::{N, Z_CRIT, check, chi2_z};
use std::f32::consts::PI;

#[test]
fn cosine_hemisphere_matches_pdf() {
    // Coordinates (cosθ, φ/2π); dω = d(cosθ) dφ, so the density there is pdf(ω)·2π.
    check(
        "cosine hemisphere",
        warp(|u| {
            let w = square_to_cosine_hemisphere(u);
            Vec2::new(w.z, (w.y.atan2(w.x) / (2.0 * PI)).rem_euclid(1.0))
        }),
        |c, _| {
            square_to_cosine_hemisphere_pdf(Vec3A::new(0.0, 0.0, c as f32)) as f64
                * 2.0
                * std::f64::consts::PI
        },
    );
}

#[test]
fn uniform_sphere_matches_pdf() {
    check(
        "uniform sphere",
        warp(|u| {
            let w = square_to_uniform_sphere(u);
            Vec2::new(
                (w.z + 1.0) / 2.0,
                (w.y.atan2(w.x) / (2.0 * PI)).rem_euclid(1.0),
            )
        }),
        |_, _| UNIFORM_SPHERE_PDF as f64 * 4.0 * std::f64::consts::PI,
    );
}

#[test]
fn concentric_disk_matches_pdf() {
    check(
        "concentric disk",
        warp(|u| (square_to_uniform_disk_concentric(u) + Vec2::ONE) / 2.0),
        |a, b| {
            square_to_uniform_disk_pdf(Vec2::new(2.0 * a as f32 - 1.0, 2.0 * b as f32 - 1.0)) as f64
                * 4.0
        },
    );
}

#[test]
fn triangle_is_uniform() {
    // Barycentrics are uniform on the simplex {b1 + b2 ≤ 1} (density 2).
    check(
        "uniform triangle",
        warp(square_to_uniform_triangle),
        |a, b| {
            if a + b <= 1.0 { 2.0 } else { 0.0 }
        },
    );
}

#[test]
fn discrete_alias_matches_pmf() {
    // Skewed weights, a zero, and a large table whose buckets need aliases.
    let mut w = vec![0.5, 3.0, 0.0, 1.25, 7.0, 0.25];
    w.extend((0..994).map(|i| ((i * 7919) % 97) as f64 * 0.01));
    let d = Discrete::new(&w).expect("valid weights");
    let total: f64 = w.iter().sum();
    let mut rng = Sampler::new(3, 0, 0);
    let mut obs = vec![0.0; w.len()];
    // The uniform left over: 20 equal cells, whatever the index drawn.
    let mut rest = vec![0.0; 20];
    for _ in 0..N {
        let (i, r) = d.sample(rng.next_u32());
        obs[i] += 1.0;
        rest[(r * 20.0) as usize] += 1.0;
    }
    assert!(
        chi2_z(&rest, &[N as f64 / 20.0; 20]) < Z_CRIT,
        "the remaining uniform"
    );
    for (i, wi) in w.iter().enumerate() {
        assert!((d.pmf(i) - wi / total).abs() < 1e-12);
    }
    assert_eq!(obs[2], 0.0, "a zero-weight entry was sampled");
    let exp: Vec<f64> = w.iter().map(|wi| wi / total * N as f64).collect();
    assert!(chi2_z(&obs, &exp) < Z_CRIT, "alias distribution");
}

#[test]
fn discrete_rejects_bad_weights() {
    assert!(Discrete::new(&[]).is_none());
    assert!(Discrete::new(&[0.0, 0.0]).is_none());
    assert!(Discrete::new(&[1.0, -1.0]).is_none());
    assert!(Discrete::new(&[1.0, f64::NAN]).is_none());
}

#[test]
fn streams_are_reproducible_and_distinct() {
    let draw = |a, b| {
        let mut s = Sampler::new(11, a, b);
        (0..4).map(|_| s.next_1d()).collect::<Vec<_>>()
    };
    assert_eq!(draw(5, 6), draw(5, 6));
    assert_ne!(draw(5, 6), draw(6, 5));
    assert_ne!(draw(5, 6), draw(5, 7));
}

/// A run of samples turned down by their first numbers takes exactly the numbers those samples
/// draw one at a time, and none of the first sample that goes on: with and without points read
/// before the judged one, and for a low-discrepancy sampler (one sample at most).
#[test]
fn turned_down_runs_take_the_numbers_of_their_samples() {
    // Asymmetric in x and y, so that the order of a pair's two numbers counts.
    let down = |x: u32, y: u32| unit(x) + 0.5 * unit(y) < 1.0;
    for skip in [0, 1] {
        let (mut run, mut one) = (
            Sampler::new(5, 6, skip as u64),
            Sampler::new(5, 6, skip as u64),
        );
        let mut runs = 0;
        for _ in 0..2000 {
            let n = run.turned_down(7, skip, down);
            // The same samples judged one at a time from a copy of the stream.
            let mut m = 0;
            while m < 7 {
                let mut ahead = one.clone();
                (0..skip).for_each(|_| _ = ahead.next_2d());
                let (x, y) = ahead.next_pair();
                if !down(x, y) {
                    break;
                }
                (one, m) = (ahead, m + 1);
            }
            assert_eq!(n, m);
            runs += usize::from(n > 1);
            // Both streams go on from the same place.
            assert_eq!(run.next_u32(), one.next_u32());
        }
        assert!(runs > 100, "too few runs to test: {runs}");
    }
    let (mut ld, mut reference) = (
        Sampler::low_discrepancy(3, 4, 0),
        Sampler::low_discrepancy(3, 4, 0),
    );
    let mut taken = 0;
    for i in 0..500 {
        ld.start(i);
        reference.start(i);
        let n = ld.turned_down(1, 1, down);
        let mut ahead = reference.clone();
        ahead.next_2d();
        let (x, y) = ahead.next_pair();
        let took = down(x, y);
        if took {
            reference = ahead;
        }
        assert_eq!((n == 1, ld.next_2d()), (took, reference.next_2d()));
        taken += n;
    }
    assert!((100..400).contains(&taken), "{taken} of 500 turned down");
}

#[test]
fn low_discrepancy_pairs_are_stratified_and_draws_uniform() {
    // Every draw k of samples 0..2^m is an Owen-scrambled (0, 2)-sequence: each of the 2^a × 2^(m−a)
    // elementary boxes holds exactly one point, for every a.
    let m = 8;
    for key in 0..4u64 {
        for k in 0..5 {
            let points: Vec<(u32, u32)> = (0..1u64 << m)
                .map(|i| {
                    let mut s = Sampler::low_discrepancy(7, key, 0);
                    s.start(i);
                    for _ in 0..k {
                        s.next_pair();
                    }
                    s.next_pair()
                })
                .collect();
            for a in 0..=m {
                let mut seen = vec![false; 1 << m];
                for &(x, y) in &points {
                    let (x, y) = (x as u64, y as u64);
                    let cell = ((x >> (32 - a)) << (m - a) | y >> (32 - (m - a))) as usize;
                    assert!(
                        !seen[cell],
                        "key {key}, draw {k}: box {a} × {} holds two points",
                        m - a
                    );
                    seen[cell] = true;
                }
            }
        }
    }
    // Over many keys (scrambles), each draw is uniform: χ² over 64 cells of (x, y) of draw 3.
    let mut obs = vec![0.0; 64];
    for key in 0..N as u64 / 16 {
        let mut s = Sampler::low_discrepancy(1, key, 0);
        s.start(key % 16);
        for _ in 0..3 {
            s.next_2d();
        }
        let u = s.next_2d();
        obs[(u.x * 8.0) as usize * 8 + (u.y * 8.0) as usize] += 1.0;
    }
    let total: f64 = obs.iter().sum();
    assert!(
        chi2_z(&obs, &[total / 64.0; 64]) < Z_CRIT,
        "scrambled draws are uniform"
    );
}

#[test]
fn quarter_angle_sin_cos_matches_libm() {
    // Over [-π/4, π/4], within 2 f32 ulps of 1 of the f64 values.
    let q = std::f64::consts::FRAC_PI_4;
    let worst = (0..=100_000)
        .map(|i| {
            let t = (-q + 2.0 * q * i as f64 / 100_000.0) as f32;
            let (s, c) = nlos_rs::sampling::sin_cos_quarter(t);
            let (s64, c64) = (t as f64).sin_cos();
            (s as f64 - s64).abs().max((c as f64 - c64).abs())
        })
        .fold(0.0f64, f64::max);
    assert!(worst < 1.2e-7, "worst error {worst:e}");
}

#[test]
fn hgrs_resampled_step_is_unbiased_with_and_without_candidate_roulette() {
    // Candidates visible with probability 0.3, weights uniform in [0, 2) (one-draw estimates of
    // mean 0.3): the resampled step's weight averages 0.3 with every candidate tested and with
    // the roulette (q = 1/4 after the first visible one), which tests fewer candidates.
    use nlos_rs::geometry::Interaction;
    use nlos_rs::integrator::{Step, hgrs};
    use nlos_rs::settings::{Hgrs, HgrsEstimator};
    for roulette in [1.0f32, 0.25] {
        let h = Hgrs {
            max_iterations: 10,
            estimator: HgrsEstimator::Resampled,
            roulette,
        };
        let mut rng = Sampler::new(7, 8, roulette.to_bits() as u64);
        let (n, mut sum, mut sum2, mut drawn) = (200_000, 0.0f64, 0.0f64, 0u64);
        for _ in 0..n {
            let w = hgrs::sample(h, &mut rng, |rng| {
                drawn += 1;
                let (visible, w) = (rng.next_1d() < 0.3, 2.0 * rng.next_1d());
                visible.then_some(Step {
                    next: Interaction {
                        p: Vec3A::ZERO,
                        ng: Vec3A::Z,
                        ns: Vec3A::Z,
                        shape: 0,
                        prim: 0,
                    },
                    dist: 1.0,
                    weight: Vec3A::splat(w),
                    eta: 1.0,
                })
            })
            .map_or(0.0, |s| s.weight.x as f64);
            (sum, sum2) = (sum + w, sum2 + w * w);
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        println!(
            "roulette {roulette}: mean {mean:.5} ± {se:.5}, {:.2} candidates per step",
            drawn as f64 / n as f64
        );
        assert!(
            (mean - 0.3).abs() < 4.0 * se,
            "roulette {roulette}: {mean} ± {se}"
        );
        // Expected: about 3.2 until the first visible one, then a quarter of the rest (1.7).
        assert!(roulette == 1.0 || (drawn as f64) < 5.5 * n as f64);
    }
}

/// The alias table's rescaling by a reciprocal gives the f32 of the f64 division bit for bit:
/// over random draws and bucket probabilities (3/4, 1/3 and 5/8 among them, whose quotients
/// land exactly on f32 rounding boundaries), in both branches of a bucket, and for quotients
/// within an f64 rounding of a boundary, where the product alone would differ (it fails
/// without the division there; checked).
#[test]
fn quotient_by_a_reciprocal_is_the_division() {
    let mut rng = Sampler::new(9, 0, 0);
    let mut keeps: Vec<f32> = vec![0.75, 1.0 / 3.0, 0.625, 0.999_999_9, 1e-6, 0.5, 0.1];
    keeps.extend((0..200).map(|_| rng.next_1d().max(1e-7)));
    let (mut checked, mut ties) = (0u64, 0u64);
    for &keep in &keeps {
        let keep = keep as f64;
        for _ in 0..20_000 {
            let r = rng.next_u32() as f64 * (1.0 / 4_294_967_296.0);
            let (num, den) = if r < keep {
                (r, keep)
            } else {
                (r - keep, 1.0 - keep)
            };
            let exact = (num / den) as f32;
            assert_eq!(
                quotient(num, den, 1.0 / den).to_bits(),
                exact.to_bits(),
                "{num} / {den}"
            );
            // A quotient on an f32 boundary (halfway between two f32): the product's rounding
            // alone could go either way.
            let d = num / den;
            let f = d as f32;
            let other = f32::from_bits(if (f as f64) < d {
                f.to_bits() + 1
            } else {
                f.to_bits() - 1
            });
            ties += u64::from(d == (f as f64 + other as f64) * 0.5);
            checked += 1;
        }
    }
    // Quotients within an f64 rounding of a boundary, where the product and the division can
    // fall on its two sides: numerators made as boundary × denominator.
    for _ in 0..200_000 {
        let f = rng.next_1d().max(1e-7);
        let boundary = (f as f64 + f32::from_bits(f.to_bits() + 1) as f64) * 0.5;
        let den = (rng.next_1d() as f64).max(1e-7);
        let num = boundary * den;
        let exact = (num / den) as f32;
        assert_eq!(
            quotient(num, den, 1.0 / den).to_bits(),
            exact.to_bits(),
            "{num} / {den}"
        );
        checked += 1;
    }
    println!("{checked} quotients, {ties} on a boundary");
    assert!(checked > 4_000_000 && ties > 100);
}
