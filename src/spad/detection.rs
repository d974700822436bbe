//! Detection: how a SPAD turns the mean photon flux into counts.
//!
//! * **Poisson counts**: without pile-up each bin counts Poisson(λ_i) detections.
//! * **Background**: dark counts and detected ambient light arrive uniformly over the laser period:
//!   (dark + ambient rate) × exposure × f_rep × Δt per bin.
//! * **Pile-up** (`pile_up`): time-correlated single-photon counting records at most the first
//!   detection of each laser period. With N = exposure × f_rep periods and r_i = λ_i / N the mean
//!   per period in bin i (bins in time order, after r_pre, the background before the window), a
//!   period's first detection is in bin i with p_i = (1 − e^{−r_i}) e^{−r_pre − Σ_{j<i} r_j}; the
//!   histogram is drawn as successive binomials over the periods still without a detection.
//! * **Dead time** with pile-up: a detection also blinds the detector for `dead_time_ns`; where that
//!   can reach into the next period's window, the capture is drawn event by event instead (a
//!   geometric wait between detections from an armed period; a blinded period detects only from its
//!   first open bin on). A dead time longer than the laser period is refused.
//! * **Afterpulsing**: each detection is followed, with probability `afterpulse_prob`, by another one
//!   dead time later (which may afterpulse in turn), as in tal's open SPAD pull request (#13).
//! * **Crosstalk**: each detection triggers, with probability `crosstalk_prob`/4 each, a count in
//!   the same bin of its four grid neighbours (same laser slot); crosstalk counts do not cascade.
//! * **Coates** (1968, "The correction of photon pile-up in the measurement of radiative
//!   lifetimes"): r̂_i = −ln(1 − c_i / (N_0 − Σ_{j<i} c_j)), λ̂_i = N r̂_i, with N_0 = N e^{−r_pre}.

use super::{Layout, Spad};
use crate::error::Result;
use crate::sampling::Sampler;
use rand_distr::{Binomial, Geometric, Open01, Poisson};
use rayon::prelude::*;

/// Stream keys of the detection steps (the render's streams use the pixel index).
const PRIMARY: u64 = 0x5350_4144_0001;
const CROSSTALK: u64 = 0x5350_4144_0002;

/// Mean background (dark + ambient) detections per bin of `bin_ps` over the exposure.
pub fn background_per_bin(spad: &Spad, bin_ps: f64) -> f64 {
    (spad.dark_count_rate_hz + spad.ambient_rate_hz)
        * spad.exposure_s
        * spad.rep_rate_hz
        * bin_ps
        * 1e-12
}

/// Mean background detections per laser period before the window starts.
fn background_before_window(spad: &Spad, layout: &Layout) -> f64 {
    (spad.dark_count_rate_hz + spad.ambient_rate_hz) * layout.start_ps.max(0.0) * 1e-12
}

/// A Poisson(λ) draw (0 for λ ≤ 0).
fn poisson(rng: &mut Sampler, lam: f64) -> u64 {
    match Poisson::new(lam) {
        Ok(d) => rng.sample(&d) as u64,
        Err(_) => 0,
    }
}

/// A Binomial(n, p) draw.
fn binomial(rng: &mut Sampler, n: u64, p: f64) -> u64 {
    if n == 0 || p <= 0.0 {
        return 0;
    }
    match Binomial::new(n, p.min(1.0)) {
        Ok(d) => rng.sample(&d),
        Err(_) => 0,
    }
}

/// Laser periods of the exposure, as a count.
fn periods(spad: &Spad) -> u64 {
    spad.periods().round() as u64
}

/// One capture: counts per bin from the mean detections `lam` (laid out as the transient).
pub fn detect(lam: &[f64], layout: &Layout, spad: &Spad, seed: u64) -> Result<Vec<u64>> {
    let bins = layout.bins;
    let n = periods(spad);
    let r_pre = background_before_window(spad, layout);
    let delay = if spad.afterpulse_prob > 0.0 {
        ((spad.dead_time_ns * 1e3 / layout.bin_ps).round() as usize).max(1)
    } else {
        0
    };
    // Dead time reaching into the next period: a detection in bin i (at its centre) blinds the next
    // period until t_i + dead time − period, i.e. its bins before `blind[i]`.
    let period_ps = 1e12 / spad.rep_rate_hz;
    let blind: Vec<usize> = (0..bins)
        .map(|i| {
            let until = (i as f64 + 0.5) * layout.bin_ps + spad.dead_time_ns * 1e3 - period_ps;
            (until / layout.bin_ps).ceil().clamp(0.0, bins as f64) as usize
        })
        .collect();
    let spills = blind.iter().any(|&b| b > 0);
    let mut counts = vec![0u64; lam.len()];
    counts
        .par_chunks_mut(bins)
        .zip(lam.par_chunks(bins))
        .enumerate()
        .for_each(|(hist, (c, l))| {
            let mut rng = Sampler::new(seed, hist as u64, PRIMARY);
            if spad.pile_up && spills {
                first_photons_with_dead_time(c, l, n, r_pre, &blind, &mut rng);
            } else if spad.pile_up {
                let mut alive = n - binomial(&mut rng, n, 1.0 - (-r_pre).exp());
                for (ci, &li) in c.iter_mut().zip(l) {
                    *ci = binomial(&mut rng, alive, 1.0 - (-li / n as f64).exp());
                    alive -= *ci;
                }
            } else {
                for (ci, &li) in c.iter_mut().zip(l) {
                    *ci = poisson(&mut rng, li);
                }
            }
            if delay > 0 {
                // In time order, so that afterpulses of afterpulses are drawn too.
                for i in 0..bins.saturating_sub(delay) {
                    let a = binomial(&mut rng, c[i], spad.afterpulse_prob);
                    c[i + delay] += a;
                }
            }
        });
    if spad.crosstalk_prob > 0.0 {
        counts = crosstalk(&counts, layout, spad, seed);
    }
    Ok(counts)
}

/// First-photon counting over `n` periods when a detection can blind the start of the next
/// period (`blind[i]`: bins lost after a detection in bin i). Event by event: from an armed
/// period, the wait to the next detection is geometric and its bin follows the first-photon law
/// (an exponential arrival over the cumulative rates); a blinded period can detect only from its
/// first open bin on. `r_pre` is the background before the window (a detection there is taken at
/// the window's start, which cannot blind the window).
fn first_photons_with_dead_time(
    c: &mut [u64],
    lam: &[f64],
    n: u64,
    r_pre: f64,
    blind: &[usize],
    rng: &mut Sampler,
) {
    // cum[k] = r_pre + Σ_{j<k} r_j: the rate up to the start of bin k in an armed period.
    let mut cum = Vec::with_capacity(lam.len() + 1);
    cum.push(r_pre);
    for &l in lam {
        cum.push(cum[cum.len() - 1] + l / n as f64);
    }
    let total = cum[lam.len()];
    // The bin whose cumulative rate interval holds `e` (None: before the window).
    let bin_at = |e: f64| -> Option<usize> {
        let k = cum.partition_point(|&x| x <= e);
        (k > 0).then(|| (k - 1).min(lam.len() - 1))
    };
    let armed = 1.0 - (-total).exp();
    let Ok(wait) = Geometric::new(armed) else {
        return; // nothing to detect
    };
    let (mut period, mut open) = (0u64, 0usize);
    while period < n {
        let bin = if open == 0 {
            period = period.saturating_add(rng.sample(&wait));
            if period >= n {
                break;
            }
            // Given a detection in the period: an exponential arrival truncated to `total`.
            let u: f64 = rng.sample(&Open01);
            bin_at(-(-u * armed).ln_1p())
        } else {
            let (from, to) = (cum[open], total);
            let u: f64 = rng.sample(&Open01);
            let e = from - (-u).ln_1p();
            (open < lam.len() && e < to).then(|| bin_at(e)).flatten()
        };
        open = bin.map_or(0, |i| {
            c[i] += 1;
            blind[i]
        });
        period += 1;
    }
}

/// Add crosstalk: each histogram gathers, per bin, its four neighbours' triggered counts.
fn crosstalk(counts: &[u64], layout: &Layout, spad: &Spad, seed: u64) -> Vec<u64> {
    let (w, h) = layout.film;
    let (bins, slots) = (layout.bins, layout.slots);
    let p = spad.crosstalk_prob / 4.0;
    let mut out = counts.to_vec();
    out.par_chunks_mut(bins)
        .enumerate()
        .for_each(|(hist, target)| {
            let (pixel, slot) = (hist / slots, hist % slots);
            let (x, y) = ((pixel % w) as isize, (pixel / w) as isize);
            // Direction k from a source to its neighbour: right, left, down, up.
            for (k, (dx, dy)) in [(1, 0), (-1, 0), (0, 1), (0, -1)].into_iter().enumerate() {
                let (sx, sy) = (x - dx, y - dy);
                if sx < 0 || sy < 0 || sx >= w as isize || sy >= h as isize {
                    continue;
                }
                let source = (sy as usize * w + sx as usize) * slots + slot;
                let key = CROSSTALK + k as u64;
                let mut rng = Sampler::new(seed ^ key.rotate_left(32), source as u64, key);
                for (t, &c) in target
                    .iter_mut()
                    .zip(&counts[source * bins..(source + 1) * bins])
                {
                    *t += binomial(&mut rng, c, p);
                }
            }
        });
    out
}

/// Coates' estimate of the mean detections per bin from pile-up counts.
pub fn coates(counts: &[u64], layout: &Layout, spad: &Spad) -> Result<Vec<f64>> {
    let n = periods(spad) as f64;
    let n0 = n * (-background_before_window(spad, layout)).exp();
    let mut est = vec![0.0f64; counts.len()];
    est.par_chunks_mut(layout.bins)
        .zip(counts.par_chunks(layout.bins))
        .for_each(|(e, c)| {
            let mut alive = n0;
            for (ei, &ci) in e.iter_mut().zip(c) {
                let ci = ci as f64;
                // A bin that took every remaining period is read as half a period short of it.
                let frac = if alive > 0.0 {
                    (ci / alive).min(1.0 - 0.5 / alive.max(1.0))
                } else {
                    0.0
                };
                *ei = -(1.0 - frac).ln() * n;
                alive -= ci;
            }
        });
    Ok(est)
}
