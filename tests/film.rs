//! Temporal kernel density estimation (thesis §3.2): bin weights are the kernel's integral over
//! each bin, they sum to one inside the window, and the box kernel is mitransient's histogram.
//! A film's memory kept for the next render comes back as zeros.

use nlos_rs::film::memory::{keep, zero_bins};
use nlos_rs::film::{Film, GAUSSIAN_CUTOFF_SIGMAS, Splatter, TemporalKernel};
use nlos_rs::sampling::Sampler;

fn film(kernel: TemporalKernel) -> Film {
    Film {
        width: 1,
        height: 1,
        temporal_bins: 200,
        bin_width_opl: 0.01,
        start_opl: 1.0,
        laser_scan: None,
        kernel,
        phasor: None,
    }
}

fn weights(s: &Splatter, opl: f64) -> Vec<f64> {
    let mut w = vec![0.0; 200];
    s.splat(opl, |j, v| w[j] += v as f64);
    w
}

/// Midpoint-rule integral of a density over [a, b].
fn integrate(pdf: impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    let n = 2000;
    let h = (b - a) / n as f64;
    (0..n).map(|i| pdf(a + (i as f64 + 0.5) * h)).sum::<f64>() * h
}

#[test]
fn box_is_the_histogram() {
    let f = film(TemporalKernel::Box).splatter();
    let w = weights(&f, 1.0 + 0.01 * 37.4);
    assert_eq!(w[37], 1.0);
    assert_eq!(w.iter().sum::<f64>(), 1.0);
    assert!(weights(&f, 0.999).iter().all(|&v| v == 0.0));
    assert!(weights(&f, 3.0).iter().all(|&v| v == 0.0));
}

#[test]
fn kernels_conserve_energy_inside_the_window() {
    let mut rng = Sampler::new(0, 0, 0);
    for k in [
        TemporalKernel::Gaussian(0.3),
        TemporalKernel::Gaussian(2.0),
        TemporalKernel::Epanechnikov(0.7),
        TemporalKernel::Epanechnikov(3.0),
        TemporalKernel::Triangular(0.4),
        TemporalKernel::Triangular(2.2),
        TemporalKernel::Biweight(1.3),
        TemporalKernel::Triweight(0.9),
        TemporalKernel::Triweight(4.5),
        TemporalKernel::Cosine(0.6),
        TemporalKernel::Cosine(3.3),
    ] {
        let f = film(k).splatter();
        for _ in 0..2000 {
            let x = 20.0 + 160.0 * rng.next_1d() as f64;
            let sum: f64 = weights(&f, 1.0 + 0.01 * x).iter().sum();
            assert!((sum - 1.0).abs() < 1e-6, "{k:?} at bin {x}: sum {sum}");
        }
    }
}

#[test]
fn gaussian_weights_are_bin_integrals_of_the_truncated_density() {
    let (sigma, x) = (1.7, 93.35);
    let f = film(TemporalKernel::Gaussian(sigma)).splatter();
    let w = weights(&f, 1.0 + 0.01 * x);
    let r = GAUSSIAN_CUTOFF_SIGMAS * sigma;
    let pdf = |t: f64| {
        if (t - x).abs() <= r {
            (-(t - x).powi(2) / (2.0 * sigma * sigma)).exp()
        } else {
            0.0
        }
    };
    let norm = integrate(pdf, x - r, x + r);
    for (j, wj) in w.iter().enumerate().take(107).skip(80) {
        let expect = integrate(pdf, j as f64, j as f64 + 1.0) / norm;
        assert!((wj - expect).abs() < 1e-6, "bin {j}: {wj} vs {expect}");
    }
    assert_eq!(w[(x - r).floor() as usize - 1], 0.0);
    assert_eq!(w[(x + r).floor() as usize + 1], 0.0);
}

#[test]
fn compact_kernel_weights_are_bin_integrals_of_their_density() {
    // Each kernel's density on v = u/b ∈ [−1, 1] (Jarabo et al. 2014), integrated numerically here
    // and in closed form by the splatter.
    type Kernel = (fn(f64) -> TemporalKernel, fn(f64) -> f64);
    let densities: [Kernel; 5] = [
        (TemporalKernel::Epanechnikov, |v| 0.75 * (1.0 - v * v)),
        (TemporalKernel::Triangular, |v| 1.0 - v.abs()),
        (TemporalKernel::Biweight, |v| {
            15.0 / 16.0 * (1.0 - v * v).powi(2)
        }),
        (TemporalKernel::Triweight, |v| {
            35.0 / 32.0 * (1.0 - v * v).powi(3)
        }),
        (TemporalKernel::Cosine, |v| {
            std::f64::consts::FRAC_PI_4 * (std::f64::consts::FRAC_PI_2 * v).cos()
        }),
    ];
    let (b, x) = (2.5, 50.8);
    for (kernel, k) in densities {
        let f = film(kernel(b)).splatter();
        let w = weights(&f, 1.0 + 0.01 * x);
        let pdf = |t: f64| {
            let v = (t - x) / b;
            if v.abs() <= 1.0 { k(v) / b } else { 0.0 }
        };
        for (j, wj) in w.iter().enumerate().take(57).skip(45) {
            let expect = integrate(pdf, j as f64, j as f64 + 1.0);
            assert!(
                (wj - expect).abs() < 1e-6,
                "{:?} bin {j}: {wj} vs {expect}",
                kernel(b)
            );
        }
        assert_eq!(w[47], 0.0); // 50.8 - 2.5 = 48.3: bin 47 is outside the support
        assert!(w[48] > 0.0 && w[53] > 0.0 && w[54] == 0.0);
    }
}

#[test]
fn kernel_parameters_are_validated() {
    assert!(TemporalKernel::from_params("f", None, Some(1.0), Some(1.0)).is_err());
    assert!(TemporalKernel::from_params("f", None, Some(0.0), None).is_err());
    assert!(TemporalKernel::from_params("f", None, None, Some(-1.0)).is_err());
    assert_eq!(
        TemporalKernel::from_params("f", Some("cosine"), None, Some(2.0)).unwrap(),
        TemporalKernel::Cosine(2.0)
    );
    assert_eq!(
        TemporalKernel::from_params("f", None, None, Some(2.0)).unwrap(),
        TemporalKernel::Epanechnikov(2.0)
    );
    for (name, sigma, bandwidth, key) in [
        ("gaussian", None, Some(1.0), "kernel_sigma"),
        ("triweight", Some(1.0), None, "kernel_bandwidth"),
        ("biweight", None, None, "kernel_bandwidth"),
        ("box", None, Some(1.0), "kernel_bandwidth"),
        ("parabolic", None, Some(1.0), "kernel"),
    ] {
        let e = TemporalKernel::from_params("f", Some(name), sigma, bandwidth).unwrap_err();
        assert!(e.to_string().contains(key), "{name}: {e}");
    }
    assert_eq!(
        TemporalKernel::from_params("f", None, None, None).unwrap(),
        TemporalKernel::Box
    );
}

#[test]
fn phasor_frequencies_follow_the_fft_grid_and_put_is_the_fourier_term() {
    use nlos_rs::film::Phasor;
    use nlos_rs::props::{Props, Value};
    let mut p = Props::new("phasor_hdr_film", None);
    p.insert("wl_mean", Value::Float(0.1)).unwrap();
    p.insert("wl_sigma", Value::Float(0.1)).unwrap();
    // 300 bins of 6 mm: FFT spacing 1/1.8 m⁻¹; mean index 18, ±3σ = ±9 → indices 9..=27.
    let ph = Phasor::from_props(&p, 300, 0.006).unwrap();
    assert_eq!(ph.frequencies.len(), 19);
    assert!(
        (ph.frequencies[0] - 9.0 / 1.8).abs() < 1e-5
            && (ph.frequencies[18] - 27.0 / 1.8).abs() < 1e-5
    );
    let mut out = vec![0.0f32; 38];
    ph.put(0.37, 2.0, &mut out);
    for (k, f) in ph.frequencies.iter().enumerate() {
        let phase = -2.0 * std::f64::consts::PI * f * 0.37;
        assert!((out[2 * k] as f64 - 2.0 * phase.cos()).abs() < 1e-5);
        assert!((out[2 * k + 1] as f64 - 2.0 * phase.sin()).abs() < 1e-5);
    }
}

/// `put` turns one phasor into the next (a run of consecutive FFT frequencies) instead of taking
/// every sine and cosine: against the Fourier term computed directly, within one f32 rounding, for
/// near and far optical paths (up to a million units: a million turns of the rotation), for
/// mitransient's `cbox_diffuse_freq.xml` film and for a film whose range wraps to the negative
/// Nyquist frequency (a second run).
#[test]
fn phasor_put_is_the_direct_fourier_term_across_runs_and_far_paths() {
    use nlos_rs::film::Phasor;
    use nlos_rs::props::{Props, Value};
    let film = |mean: f64, sigma: f64, bins: usize, width: f64| {
        let mut p = Props::new("phasor_hdr_film", None);
        p.insert("wl_mean", Value::Float(mean)).unwrap();
        p.insert("wl_sigma", Value::Float(sigma)).unwrap();
        Phasor::from_props(&p, bins, width).unwrap()
    };
    // 40 bins: indices 15..=20, the last the negative Nyquist frequency −20/40.
    let wrapped = film(40.0 / 19.0, 5.0, 40, 1.0);
    assert_eq!(wrapped.frequencies.len(), 6);
    assert!(wrapped.frequencies[5] < 0.0 && wrapped.frequencies[4] > 0.0);
    let mut rng = Sampler::new(5, 0, 0);
    for ph in [
        film(100.0, 100.0, 4000, 1.0),
        wrapped,
        film(0.1, 0.1, 300, 0.006),
    ] {
        let n = ph.frequencies.len();
        for scale in [1.0, 100.0, 1e4, 1e6] {
            for _ in 0..200 {
                let d = scale * (rng.next_1d() as f64 * 2.0 - 0.5);
                let v = 0.1 + rng.next_1d() * 3.0;
                let mut out = vec![0.0f32; 2 * n];
                ph.put(d, v, &mut out);
                for (k, f) in ph.frequencies.iter().enumerate() {
                    let phase = (-std::f64::consts::TAU * f * d).rem_euclid(std::f64::consts::TAU);
                    let (s, c) = phase.sin_cos();
                    for (got, want) in [(out[2 * k], v * c as f32), (out[2 * k + 1], v * s as f32)]
                    {
                        assert!(
                            (got - want).abs() <= 1.2e-7 * v,
                            "d {d} f {f}: {got} against {want}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn auto_width_weights_conserve_energy_and_the_risk_picks_by_noise() {
    use nlos_rs::film::auto_width::{expected_weights, risks, smoothers};
    for k in [
        TemporalKernel::Gaussian(0.7),
        TemporalKernel::Triweight(3.0),
        TemporalKernel::Cosine(1.3),
    ] {
        let sum: f64 = expected_weights(k).iter().sum();
        assert!((sum - 1.0).abs() < 1e-9, "{k:?}: {sum}");
    }
    let s = smoothers(TemporalKernel::Gaussian(1.0), 200);
    // A sharp pulse known exactly (no variance): the box has the least risk.
    let mut pulse = vec![0.0f32; 200];
    pulse[100] = 1.0;
    let r = risks(&pulse, &[0.0; 200], 1, &s);
    assert!(r.iter().skip(1).all(|&x| x > r[0]));
    // A broad pulse (σ = 30 bins) under noise: a wide kernel (σ ≥ 4 bins), far below the box's
    // risk.
    let mut rng = Sampler::new(1, 2, 3);
    let noisy: Vec<f32> = (0..200)
        .map(|i| (-((i as f32 - 100.0) / 30.0).powi(2) / 2.0).exp() + 0.3 * (rng.next_1d() - 0.5))
        .collect();
    let r = risks(&noisy, &[0.0075; 200], 1, &s);
    let best = (0..r.len()).min_by(|&a, &b| r[a].total_cmp(&r[b])).unwrap();
    assert!(best >= 7 && r[best] < 0.2 * r[0], "{best}: {r:?}");
}

#[test]
fn a_kept_film_comes_back_as_zeros() {
    // Kept films of 1 Mi, 0.6 Mi and 3 Mi bins (4, 2.4, 12 MB) with values written in them; the
    // films then asked for are all zeros, of the length asked, whether or not the kept one fits.
    for (kept, asked) in [(1 << 20, 1 << 20), (1 << 20, 600_000), (3 << 20, 1 << 20)] {
        let mut bins = zero_bins(kept);
        assert!(bins.len() == kept && bins.iter().all(|&b| b == 0.0));
        bins.fill(7.0);
        keep(bins);
        let again = zero_bins(asked);
        assert!(again.len() == asked && again.iter().all(|&b| b == 0.0));
    }
}
