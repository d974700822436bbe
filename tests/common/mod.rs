//! Shared by the χ² tests (tests/sampling.rs, tests/bsdf.rs): histogram N samples over a grid,
//! integrate the density over each cell for the expected counts, pool cells expecting < 5, and
//! reject when the Wilson–Hilferty normal score of the χ² statistic exceeds a Šidák-corrected
//! threshold.

use glam::Vec2;
use nlos_rs::sampling::Sampler;

pub const N: usize = 400_000;
pub const RES: usize = 31; // odd, as Mitsuba's harness advises
/// One-sided normal quantile for α = 0.01 Šidák-corrected over the tests of a file (~8).
pub const Z_CRIT: f64 = 3.1;

/// χ² over (observed, expected) with pooling; returns the Wilson–Hilferty z score.
pub fn chi2_z(obs: &[f64], exp: &[f64]) -> f64 {
    let (mut chi2, mut dof) = (0.0, 0usize);
    let (mut po, mut pe) = (0.0, 0.0);
    for (&o, &e) in obs.iter().zip(exp) {
        if e < 5.0 {
            po += o;
            pe += e;
        } else {
            chi2 += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pe > 0.0 {
        chi2 += (po - pe) * (po - pe) / pe;
        dof += 1;
    } else {
        assert_eq!(po, 0.0, "samples fell where the density is zero");
    }
    let k = (dof - 1) as f64;
    ((chi2 / k).powf(1.0 / 3.0) - (1.0 - 2.0 / (9.0 * k))) / (2.0 / (9.0 * k)).sqrt()
}

/// χ² test of a 2D-parametrised sampler: `draw` gives cells (a, b) ∈ [0,1)² (or `None` for a
/// failed sample, whose mass is then missing from `pdf` too), `pdf(a, b)` the density in those
/// coordinates (already including the Jacobian).
#[allow(dead_code)] // (not every test file that shares this module uses it)
pub fn check(
    name: &str,
    mut draw: impl FnMut(&mut Sampler) -> Option<Vec2>,
    pdf: impl Fn(f64, f64) -> f64,
) {
    let mut rng = Sampler::new(7, 1, 2);
    let mut obs = vec![0.0; RES * RES];
    for _ in 0..N {
        if let Some(c) = draw(&mut rng) {
            let (i, j) = ((c.x * RES as f32) as usize, (c.y * RES as f32) as usize);
            obs[j.min(RES - 1) * RES + i.min(RES - 1)] += 1.0;
        }
    }
    let sub = 40; // fine enough that boundary cells are integrated to well under their noise
    let h = 1.0 / (RES * sub) as f64;
    let mut exp = vec![0.0; RES * RES];
    for j in 0..RES * sub {
        for i in 0..RES * sub {
            let (a, b) = ((i as f64 + 0.5) * h, (j as f64 + 0.5) * h);
            exp[(j / sub) * RES + i / sub] += pdf(a, b) * h * h * N as f64;
        }
    }
    let z = chi2_z(&obs, &exp);
    assert!(z < Z_CRIT, "{name}: chi-square z = {z:.2} (>= {Z_CRIT})");
}
