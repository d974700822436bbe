//! The SPAD capture model's maths without a scene: instrument response, Poisson counts, pile-up,
//! Coates, afterpulsing, crosstalk, determinism. Statistical checks are seeded and their tolerances
//! follow from the variance of what they average (stated at each).

use nlos_rs::spad::detection::{coates, detect};
use nlos_rs::spad::irf::{FWHM_PER_SIGMA, Kernel};
use nlos_rs::spad::{Layout, Spad};

fn moments(taps: &[f64], lag0: usize, bin: f64) -> (f64, f64, f64) {
    let sum: f64 = taps.iter().sum();
    let t = |k: usize| (k as f64 - lag0 as f64) * bin;
    let mean = taps.iter().enumerate().map(|(k, w)| w * t(k)).sum::<f64>() / sum;
    let var = taps
        .iter()
        .enumerate()
        .map(|(k, w)| w * (t(k) - mean).powi(2))
        .sum::<f64>()
        / sum;
    (sum, mean, var)
}

#[test]
fn irf_sums_to_one_and_adds_the_pulse_and_jitter_variances() {
    for (pulse, jitter, tail, bin) in [
        (30.0, 20.0, 0.0, 4.0),
        (50.0, 0.0, 0.0, 16.0),
        (30.0, 20.0, 50.0, 8.0),
        (0.0, 0.0, 40.0, 4.0),
    ] {
        let spad = Spad {
            pulse_fwhm_ps: pulse,
            jitter_fwhm_ps: jitter,
            jitter_tail_ps: tail,
            ..Spad::default()
        };
        let k = Kernel::new(&spad, bin).expect("kernel");
        let (sum, mean, var) = moments(&k.taps, k.lag0, bin);
        let s2 = (pulse * pulse + jitter * jitter) / FWHM_PER_SIGMA.powi(2);
        // Binning adds Δ²/12; the exponential tail adds τ² and shifts the mean by τ.
        let want = s2 + tail * tail + bin * bin / 12.0;
        assert!((sum - 1.0).abs() < 1e-12, "{sum}");
        assert!(
            (var / want - 1.0).abs() < 0.01,
            "variance {var} vs {want} ({pulse}, {jitter}, {tail}, {bin})"
        );
        assert!(
            (mean - tail).abs() < 0.05 * bin + 0.01 * tail,
            "mean {mean} vs {tail}"
        );
    }
}

#[test]
fn convolution_conserves_energy_and_grows_the_variance() {
    let bin = 4.0;
    let spad = Spad {
        pulse_fwhm_ps: 30.0,
        jitter_fwhm_ps: 20.0,
        ..Spad::default()
    };
    let k = Kernel::new(&spad, bin).expect("kernel");
    // A Gaussian-shaped signal in the middle of a 1000-bin window.
    let signal: Vec<f64> = (0..1000)
        .map(|i| (-0.5 * ((i as f64 - 500.0) / 6.0).powi(2)).exp())
        .collect();
    let mut out = vec![0.0; 1000];
    k.convolve(&signal, &mut out);
    let (s0, _, v0) = moments(&signal, 0, bin);
    let (s1, _, v1) = moments(&out, 0, bin);
    assert!((s1 / s0 - 1.0).abs() < 1e-9, "energy {s0} -> {s1}");
    let added = (30.0f64.powi(2) + 20.0f64.powi(2)) / FWHM_PER_SIGMA.powi(2) + bin * bin / 12.0;
    assert!(
        ((v1 - v0) / added - 1.0).abs() < 0.01,
        "variance grew {} vs {added}",
        v1 - v0
    );
}

#[test]
fn a_measured_irf_is_normalised_with_zero_delay_at_its_peak() {
    let spad = Spad {
        irf: Some(vec![0.0, 1.0, 4.0, 2.0, 1.0]),
        ..Spad::default()
    };
    let k = Kernel::new(&spad, 4.0).expect("kernel");
    assert_eq!(k.lag0, 2);
    assert_eq!(k.taps, vec![0.0, 0.125, 0.5, 0.25, 0.125]);
    let mut out = vec![0.0; 8];
    k.convolve(&[0.0, 0.0, 0.0, 8.0, 0.0, 0.0, 0.0, 0.0], &mut out);
    assert_eq!(out, vec![0.0, 0.0, 1.0, 4.0, 2.0, 1.0, 0.0, 0.0]);
}

fn layout(histograms: usize, bins: usize, film: (usize, usize)) -> Layout {
    Layout {
        histograms,
        bins,
        bin_ps: 32.0,
        start_ps: 0.0,
        film,
        slots: 1,
    }
}

#[test]
fn poisson_counts_have_the_mean_and_variance_of_lambda() {
    // 4096 histograms × 4 bins at λ ∈ {0.5, 3, 20, 400}: the sample mean of n = 4096 draws has a
    // standard error sqrt(λ/n); 5 standard errors bound it; the variance within 5 %
    // (its relative standard error is about sqrt(2/n) = 2.2 %).
    let lams = [0.5, 3.0, 20.0, 400.0];
    let n = 4096;
    let lam: Vec<f64> = (0..n).flat_map(|_| lams).collect();
    let spad = Spad::default();
    let c = detect(&lam, &layout(n, 4, (64, 64)), &spad, 7).expect("detect");
    for (b, &l) in lams.iter().enumerate() {
        let xs: Vec<f64> = (0..n).map(|h| c[h * 4 + b] as f64).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        assert!(
            (mean - l).abs() < 5.0 * (l / n as f64).sqrt(),
            "mean {mean} vs {l}"
        );
        assert!((var / l - 1.0).abs() < 0.1, "variance {var} vs {l}");
    }
    // Deterministic for a seed; another seed differs.
    assert_eq!(
        c,
        detect(&lam, &layout(n, 4, (64, 64)), &spad, 7).expect("detect")
    );
    assert_ne!(
        c,
        detect(&lam, &layout(n, 4, (64, 64)), &spad, 8).expect("detect")
    );
}

/// p_i = (1 − e^{−r_i}) e^{−Σ_{j<i} r_j}: a period's first detection falls in bin i.
fn first_photon_law(r: &[f64]) -> Vec<f64> {
    let mut before = 0.0;
    r.iter()
        .map(|&ri| {
            let p = (1.0 - (-ri).exp()) * f64::exp(-before);
            before += ri;
            p
        })
        .collect()
}

#[test]
fn pile_up_follows_the_first_photon_law_and_coates_inverts_it() {
    // High flux: 2 photons per period in total over 50 bins, N = 10⁴ periods; early bins take
    // most detections.
    let spad = Spad {
        pile_up: true,
        exposure_s: 1e-3,
        rep_rate_hz: 1e7,
        dark_count_rate_hz: 0.0,
        ..Spad::default()
    };
    let n = spad.periods();
    let bins = 50;
    let r: Vec<f64> = (0..bins)
        .map(|i| 0.04 * (1.0 + (i as f64 / 7.0).sin().abs()))
        .collect();
    let hist = 400;
    let lam: Vec<f64> = (0..hist).flat_map(|_| r.iter().map(|x| x * n)).collect();
    let lay = layout(hist, bins, (20, 20));
    let c = detect(&lam, &lay, &spad, 3).expect("detect");
    let p = first_photon_law(&r);
    for i in 0..bins {
        let p = p[i];
        let mean = (0..hist).map(|h| c[h * bins + i] as f64).sum::<f64>() / hist as f64;
        // Binomial standard error of a mean of `hist` draws: sqrt(N p (1 − p) / hist).
        let se = (n * p * (1.0 - p) / hist as f64).sqrt();
        assert!(
            (mean - n * p).abs() < 5.0 * se + 1e-9,
            "bin {i}: {mean} vs {}",
            n * p
        );
    }
    // Coates: λ back within 5 % in every bin with more than 100 expected detections.
    let est = coates(&c, &lay, &spad).expect("coates");
    for i in 0..bins {
        let p = p[i];
        if n * p < 100.0 {
            continue;
        }
        let mean = (0..hist).map(|h| est[h * bins + i]).sum::<f64>() / hist as f64;
        assert!(
            (mean / (r[i] * n) - 1.0).abs() < 0.05,
            "bin {i}: {mean} vs {}",
            r[i] * n
        );
    }
}

#[test]
fn afterpulses_and_crosstalk_add_their_expected_counts() {
    // Afterpulsing p: a bin's mean gains p × (the mean one dead time earlier) (chains included).
    let bins = 40;
    let spad = Spad {
        afterpulse_prob: 0.2,
        dead_time_ns: 0.32,
        dark_count_rate_hz: 0.0,
        ..Spad::default()
    };
    let hist = 2000;
    let mut one = vec![0.0; bins];
    one[5] = 100.0;
    let lam: Vec<f64> = (0..hist).flat_map(|_| one.clone()).collect();
    let c = detect(&lam, &layout(hist, bins, (50, 40)), &spad, 1).expect("detect");
    let mean = |i: usize| (0..hist).map(|h| c[h * bins + i] as f64).sum::<f64>() / hist as f64;
    // dead time 320 ps = 10 bins of 32 ps: afterpulses at bins 15, 25, 35 with means 20, 4, 0.8.
    for (i, want) in [(15, 20.0), (25, 4.0), (35, 0.8)] {
        assert!(
            (mean(i) / want - 1.0).abs() < 0.05,
            "bin {i}: {} vs {want}",
            mean(i)
        );
    }
    // Crosstalk p: an interior pixel gains p/4 of each neighbour's counts.
    let spad = Spad {
        crosstalk_prob: 0.1,
        dark_count_rate_hz: 0.0,
        ..Spad::default()
    };
    let (w, h) = (32, 32);
    let lam: Vec<f64> = (0..w * h)
        .map(|i| {
            if (i / w + i % w) % 2 == 0 {
                1000.0
            } else {
                0.0
            }
        })
        .collect();
    let c = detect(&lam, &layout(w * h, 1, (w, h)), &spad, 2).expect("detect");
    let dark: Vec<f64> = (0..w * h)
        .filter(|i| {
            (i / w + i % w) % 2 == 1 && i / w > 0 && i / w < h - 1 && i % w > 0 && i % w < w - 1
        })
        .map(|i| c[i] as f64)
        .collect();
    let mean = dark.iter().sum::<f64>() / dark.len() as f64;
    // Each such pixel has 4 lit neighbours: 4 × 0.025 × 1000 = 100 (standard error ≈ 0.5).
    assert!((mean - 100.0).abs() < 3.0, "{mean}");
}

/// The literal process, one laser period at a time, for comparison: in each period the bins are
/// visited in time order while the detector is open; a detection in bin i (at its centre) keeps it
/// blind until t_i + dead time − period in the next period.
fn brute_force(
    r: &[f64],
    n: u64,
    bin_ps: f64,
    dead_ps: f64,
    period_ps: f64,
    seed: u64,
) -> Vec<u64> {
    let mut rng = nlos_rs::sampling::Sampler::new(seed, 0, 99);
    let mut c = vec![0u64; r.len()];
    let mut open_from = 0.0f64; // time (ps from the window start) from which the detector is open
    for _ in 0..n {
        let mut next_open = 0.0;
        for (i, &ri) in r.iter().enumerate() {
            if (i as f64) * bin_ps < open_from {
                continue;
            }
            if (rng.next_1d() as f64) < 1.0 - (-ri).exp() {
                c[i] += 1;
                next_open = (i as f64 + 0.5) * bin_ps + dead_ps - period_ps;
                break;
            }
        }
        open_from = next_open;
    }
    c
}

#[test]
fn dead_time_into_the_next_period_matches_the_period_by_period_process() {
    // 20 bins of 32 ps at the start of a 1 ns period; a 0.9 ns dead time blinds the next period's
    // first bins after a late detection. 400 replicates of 2000 periods: per bin, the difference of
    // the two means has standard error sqrt(2 var / 400); 5 of them bound it.
    let (bins, bin_ps, period_ps, dead_ps) = (20, 32.0, 1000.0, 900.0);
    let r: Vec<f64> = (0..bins)
        .map(|i| if i >= 12 { 0.15 } else { 0.01 })
        .collect();
    let n = 2000u64;
    let spad = Spad {
        pile_up: true,
        rep_rate_hz: 1e12 / period_ps,
        exposure_s: n as f64 * period_ps * 1e-12,
        dead_time_ns: dead_ps * 1e-3,
        dark_count_rate_hz: 0.0,
        ..Spad::default()
    };
    let reps = 400;
    let lam: Vec<f64> = (0..reps)
        .flat_map(|_| r.iter().map(|x| x * n as f64))
        .collect();
    let ours = detect(&lam, &layout(reps, bins, (20, 20)), &spad, 5).expect("detect");
    let theirs: Vec<Vec<u64>> = (0..reps)
        .map(|k| brute_force(&r, n, bin_ps, dead_ps, period_ps, k as u64))
        .collect();
    let mut blinded_bins_differ = false;
    for i in 0..bins {
        let a: Vec<f64> = (0..reps).map(|h| ours[h * bins + i] as f64).collect();
        let b: Vec<f64> = theirs.iter().map(|c| c[i] as f64).collect();
        let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
        let var = |x: &[f64]| {
            let m = mean(x);
            x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64
        };
        let se = ((var(&a) + var(&b)) / reps as f64).sqrt();
        assert!(
            (mean(&a) - mean(&b)).abs() < 5.0 * se + 1e-9,
            "bin {i}: {} vs {}",
            mean(&a),
            mean(&b)
        );
        // Without the dead time the first bins would see the full armed rate.
        let armed: f64 = (0..i).map(|j| r[j]).sum();
        let no_dead = n as f64 * (1.0 - (-r[i]).exp()) * (-armed).exp();
        blinded_bins_differ |= i < 3 && mean(&a) < 0.9 * no_dead;
    }
    assert!(
        blinded_bins_differ,
        "the dead time had no effect: not a dead-time test"
    );
}
