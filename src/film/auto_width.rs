//! Automatic temporal kernel width (`kernel_sigma="auto"`, `kernel_bandwidth="auto"`): the width
//! is chosen per scan point (and laser point) from its own samples.
//!
//! The render records the box histogram H of a scan point and each bin's variance of the mean V
//! (from the per-sample values, as `return_variance`). A kernel of width h turns H into A_h·H, where
//! A_h holds the kernel's expected bin weights for a path placed uniformly inside its bin (the
//! temporal KDE of [`super::temporal_kernel`] in expectation). Stein's unbiased risk estimate
//! (Stein 1981, "Estimation of the mean of a multivariate normal distribution", Ann. Stat. 9(6);
//! for linear smoothers Mallows' C_p) of the squared error of A_h·H against the true transient μ is
//!
//!   R(h) = ‖A_h·H − H‖² + 2·Σ_j (A_h)_jj·V_j − Σ_j V_j,
//!
//! unbiased when bins are uncorrelated. One scan point's estimate of R is noisy where its samples
//! are few, so the width is chosen by R summed over the scan point and its eight neighbours (the
//! same laser point): still a width per scan point, chosen with a ninth of the selection noise. The
//! box (A = I, R = ΣV) is a candidate. At high sample counts V is small and R favours the box or a
//! narrow kernel (no bias is bought); at low counts it widens the kernel until bias outweighs the
//! noise removed. docs/techniques.md has the measured errors.

use super::TemporalKernel;

/// Candidate widths (σ for the Gaussian, b for the others), in bins: a √2 grid from ½ to 16.
pub fn candidates(family: TemporalKernel) -> Vec<TemporalKernel> {
    (0..11)
        .map(|i| family.with_width(0.5 * 2f64.powf(i as f64 / 2.0)))
        .collect()
}

/// A_h's weights by offset: `weights[r + d]` is the share a path in bin i gives bin i + d,
/// averaged over the path's position inside bin i (64 midpoints).
pub fn expected_weights(kernel: TemporalKernel) -> Vec<f64> {
    let r = kernel.radius().ceil() as i64 + 1;
    const POSITIONS: usize = 64;
    (-r..=r)
        .map(|d| {
            (0..POSITIONS)
                .map(|k| {
                    let s = (k as f64 + 0.5) / POSITIONS as f64;
                    kernel.cdf(d as f64 + 1.0 - s) - kernel.cdf(d as f64 - s)
                })
                .sum::<f64>()
                / POSITIONS as f64
        })
        .collect()
}

/// A kernel's smoothing of a slot of `bins` × `c` values by its expected bin weights.
pub struct Smoother {
    weights: Vec<f64>,
    radius: usize,
}

impl Smoother {
    /// For `kernel`.
    pub fn new(kernel: TemporalKernel) -> Self {
        let weights = expected_weights(kernel);
        Self {
            radius: weights.len() / 2,
            weights,
        }
    }

    /// `out[j·c + k] = Σ_i A[j − i]·x[i·c + k]`, squared weights instead if `square` (the
    /// variance of a smoothed value from independent bins).
    fn apply(&self, x: &[f32], c: usize, square: bool, out: &mut [f64]) {
        let bins = x.len() / c;
        out.iter_mut().for_each(|v| *v = 0.0);
        if c == 1 {
            // The same sums over contiguous slices (which the compiler vectorises).
            for (i, &v) in x.iter().enumerate() {
                if v == 0.0 {
                    continue;
                }
                let v = v as f64;
                let (lo, hi) = (
                    i.saturating_sub(self.radius),
                    (i + self.radius + 1).min(bins),
                );
                let w = &self.weights[lo + self.radius - i..hi + self.radius - i];
                let o = &mut out[lo..hi];
                if square {
                    o.iter_mut().zip(w).for_each(|(o, w)| *o += w * w * v);
                } else {
                    o.iter_mut().zip(w).for_each(|(o, w)| *o += w * v);
                }
            }
            return;
        }
        for i in 0..bins {
            for k in 0..c {
                let v = x[i * c + k] as f64;
                if v == 0.0 {
                    continue;
                }
                let lo = i.saturating_sub(self.radius);
                let hi = (i + self.radius + 1).min(bins);
                for j in lo..hi {
                    let w = self.weights[j + self.radius - i];
                    out[j * c + k] += if square { w * w * v } else { w * v };
                }
            }
        }
    }
}

/// The smoothers of `family`'s [`candidates`] that fit a window of `bins` bins.
pub fn smoothers(family: TemporalKernel, bins: usize) -> Vec<Smoother> {
    candidates(family)
        .into_iter()
        .filter(|k| k.radius() <= bins as f64)
        .map(Smoother::new)
        .collect()
}

/// Stein's unbiased risk estimate of one slot (`values` with their `variance`, `c` channels) for
/// the box (first) and each smoother.
pub fn risks(values: &[f32], variance: &[f32], c: usize, smoothers: &[Smoother]) -> Vec<f64> {
    let total_var: f64 = variance.iter().map(|&v| v as f64).sum();
    let mut smoothed = vec![0.0f64; values.len()];
    let mut out = vec![total_var];
    for s in smoothers {
        s.apply(values, c, false, &mut smoothed);
        let fit: f64 = smoothed
            .iter()
            .zip(values)
            .map(|(a, &h)| (a - h as f64).powi(2))
            .sum();
        out.push(fit + 2.0 * s.weights[s.radius] * total_var - total_var);
    }
    out
}

/// Smooth one slot in place by `smoother`; its `variance` becomes that of the smoothed values.
pub fn smooth(values: &mut [f32], variance: &mut [f32], c: usize, smoother: &Smoother) {
    let mut out = vec![0.0f64; values.len()];
    smoother.apply(values, c, false, &mut out);
    values
        .iter_mut()
        .zip(&out)
        .for_each(|(v, s)| *v = *s as f32);
    smoother.apply(variance, c, true, &mut out);
    variance
        .iter_mut()
        .zip(&out)
        .for_each(|(v, s)| *v = *s as f32);
}
