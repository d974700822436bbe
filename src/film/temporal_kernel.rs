//! Temporal kernel density estimation (KDE): how one contribution of optical path length `opl`
//! is spread over the time bins (Tienda Hernando 2023, §3.2, after Jarabo et al. 2014, "A framework
//! for transient rendering", ACM TOG 33(6)).
//!
//! A contribution arrives at the continuous bin coordinate x = (opl − start_opl)/Δ. The box (a
//! plain histogram, mitransient) puts all of it in bin ⌊x⌋; a kernel centres a density K(u − x)
//! there and gives bin j the integral of K over [j, j + 1), so the weights sum to one (the
//! contribution's energy is conserved) and no bin is point-sampled. [`Splatter`] is the per-render
//! form: weights tabulated once per sub-bin offset.

use crate::error::{NlosError, Result};

/// The Gaussian kernel is truncated at this many standard deviations and renormalised.
pub const GAUSSIAN_CUTOFF_SIGMAS: f64 = 4.0;

/// The temporal kernel of a film. Every kernel but the Gaussian has compact support [−b, b]
/// (b in bins); the shapes are those Jarabo et al. 2014 (§5) compare, written for v = u/b.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TemporalKernel {
    /// A hard histogram (mitransient).
    Box,
    /// Gaussian with standard deviation σ (in bins), truncated at ±4σ.
    Gaussian(f64),
    /// Epanechnikov K(v) = 3/4·(1 − v²).
    Epanechnikov(f64),
    /// Triangular K(v) = 1 − |v|.
    Triangular(f64),
    /// Biweight (quartic) K(v) = 15/16·(1 − v²)².
    Biweight(f64),
    /// Triweight K(v) = 35/32·(1 − v²)³.
    Triweight(f64),
    /// Cosine K(v) = π/4·cos(πv/2).
    Cosine(f64),
}

/// Names of the kernels with a bandwidth, as `kernel=` takes them.
pub const BANDWIDTH_KERNELS: [&str; 5] = [
    "epanechnikov",
    "triangular",
    "biweight",
    "triweight",
    "cosine",
];

impl TemporalKernel {
    /// Kernel from the `kernel` name and `kernel_sigma` / `kernel_bandwidth` values. Without a
    /// name, `kernel_sigma` means Gaussian and `kernel_bandwidth` Epanechnikov (the thesis' two).
    pub fn from_params(
        plugin: &str,
        name: Option<&str>,
        sigma: Option<f64>,
        bandwidth: Option<f64>,
    ) -> Result<Self> {
        let width = |key: &str, v: f64| {
            if v > 0.0 && v.is_finite() {
                Ok(v)
            } else {
                Err(NlosError::prop(
                    plugin,
                    key,
                    format!("must be positive, got {v}"),
                ))
            }
        };
        let name = match (name, sigma, bandwidth) {
            (_, Some(_), Some(_)) => {
                return Err(NlosError::prop(
                    plugin,
                    "kernel_bandwidth",
                    "set kernel_sigma (Gaussian) or kernel_bandwidth (the other kernels), not both",
                ));
            }
            (Some(n), _, _) => n,
            (None, Some(_), None) => "gaussian",
            (None, None, Some(_)) => "epanechnikov",
            (None, None, None) => "box",
        };
        match (name, sigma, bandwidth) {
            ("box", None, None) => Ok(Self::Box),
            ("gaussian", Some(s), None) => Ok(Self::Gaussian(width("kernel_sigma", s)?)),
            ("gaussian", _, _) => Err(NlosError::prop(
                plugin,
                "kernel_sigma",
                "the Gaussian kernel takes kernel_sigma (in bins)",
            )),
            (n, None, Some(b)) if BANDWIDTH_KERNELS.contains(&n) => {
                let b = width("kernel_bandwidth", b)?;
                Ok(match n {
                    "epanechnikov" => Self::Epanechnikov(b),
                    "triangular" => Self::Triangular(b),
                    "biweight" => Self::Biweight(b),
                    "triweight" => Self::Triweight(b),
                    _ => Self::Cosine(b),
                })
            }
            (n, _, _) if n == "box" || BANDWIDTH_KERNELS.contains(&n) => Err(NlosError::prop(
                plugin,
                "kernel_bandwidth",
                format!(
                    "the {n} kernel takes {}",
                    if n == "box" {
                        "no width"
                    } else {
                        "kernel_bandwidth (in bins), not kernel_sigma"
                    }
                ),
            )),
            (n, _, _) => Err(NlosError::prop(
                plugin,
                "kernel",
                format!("must be 'box', 'gaussian' or one of {BANDWIDTH_KERNELS:?}, got '{n}'"),
            )),
        }
    }

    /// The kernel's name and width (σ or b, in bins; 0 for the box).
    pub fn name_and_width(&self) -> (&'static str, f64) {
        match *self {
            Self::Box => ("box", 0.0),
            Self::Gaussian(s) => ("gaussian", s),
            Self::Epanechnikov(b) => ("epanechnikov", b),
            Self::Triangular(b) => ("triangular", b),
            Self::Biweight(b) => ("biweight", b),
            Self::Triweight(b) => ("triweight", b),
            Self::Cosine(b) => ("cosine", b),
        }
    }

    /// The same kernel shape at width `w` (σ or b, in bins); the box stays the box.
    pub fn with_width(&self, w: f64) -> Self {
        match *self {
            Self::Box => Self::Box,
            Self::Gaussian(_) => Self::Gaussian(w),
            Self::Epanechnikov(_) => Self::Epanechnikov(w),
            Self::Triangular(_) => Self::Triangular(w),
            Self::Biweight(_) => Self::Biweight(w),
            Self::Triweight(_) => Self::Triweight(w),
            Self::Cosine(_) => Self::Cosine(w),
        }
    }

    /// Cumulative distribution of the kernel at offset u (bins) from its centre.
    pub fn cdf(&self, u: f64) -> f64 {
        let (_, b) = self.name_and_width();
        let v = if b > 0.0 {
            (u / b).clamp(-1.0, 1.0)
        } else {
            0.0
        };
        let (v2, half) = (v * v, 0.5);
        match *self {
            Self::Box => (u >= 0.0) as u8 as f64,
            Self::Gaussian(s) => {
                let r = GAUSSIAN_CUTOFF_SIGMAS;
                let z = (u / s).clamp(-r, r);
                let phi = |z: f64| 0.5 * libm::erfc(-z / std::f64::consts::SQRT_2);
                (phi(z) - phi(-r)) / (phi(r) - phi(-r))
            }
            Self::Epanechnikov(_) => half + 0.75 * v - 0.25 * v * v2,
            Self::Triangular(_) if v < 0.0 => half * (1.0 + v) * (1.0 + v),
            Self::Triangular(_) => 1.0 - half * (1.0 - v) * (1.0 - v),
            Self::Biweight(_) => half + 15.0 / 16.0 * v * (1.0 - v2 * (2.0 / 3.0 - v2 / 5.0)),
            Self::Triweight(_) => {
                half + 35.0 / 32.0 * v * (1.0 - v2 * (1.0 - v2 * (3.0 / 5.0 - v2 / 7.0)))
            }
            Self::Cosine(_) => half + half * (std::f64::consts::FRAC_PI_2 * v).sin(),
        }
    }

    /// Half-width of the kernel's support, in bins.
    pub fn radius(&self) -> f64 {
        match *self {
            Self::Gaussian(s) => GAUSSIAN_CUTOFF_SIGMAS * s,
            _ => self.name_and_width().1,
        }
    }
}

/// Sub-bin offsets at which kernel weights are tabulated (linear interpolation in between is
/// accurate to ~1e-7 and keeps the weights summing to one).
const OFFSETS: usize = 1024;

/// Spreads contributions over the time bins of a film (the per-render form of its kernel): the
/// weights of a kernel centred at x depend only on x − ⌊x⌋, so they are tabulated once.
pub struct Splatter {
    start_opl: f64,
    inv_bin_width: f64,
    bins: usize,
    /// Tabulated kernel weights: `OFFSETS + 1` rows of `len` bins, starting at bin ⌊x⌋ + `first`.
    table: Vec<f32>,
    len: usize,
    first: i64,
}

impl Splatter {
    /// For a film's bins and kernel.
    pub fn new(film: &super::Film) -> Self {
        let (mut table, mut len, mut first) = (Vec::new(), 0, 0);
        if film.kernel != TemporalKernel::Box {
            let r = film.kernel.radius();
            first = -(r.ceil() as i64) - 1;
            len = (2 * (r.ceil() as i64) + 3) as usize;
            for k in 0..=OFFSETS {
                let f = k as f64 / OFFSETS as f64;
                // Bin j (relative to ⌊x⌋) gets the kernel's integral over [j, j + 1) − f.
                let mut below = film.kernel.cdf(first as f64 - f);
                for j in 0..len as i64 {
                    let above = film.kernel.cdf((first + j + 1) as f64 - f);
                    table.push((above - below) as f32);
                    below = above;
                }
            }
        }
        Self {
            start_opl: film.start_opl,
            inv_bin_width: 1.0 / film.bin_width_opl,
            bins: film.temporal_bins,
            table,
            len,
            first,
        }
    }

    /// Spread a contribution of optical path length `opl`: `put(bin, weight)` for every bin of the
    /// time window it reaches (weights sum to one away from the window's ends).
    #[inline]
    pub fn splat(&self, opl: f64, mut put: impl FnMut(usize, f32)) {
        let x = (opl - self.start_opl) * self.inv_bin_width;
        if self.len == 0 {
            if x >= 0.0 && x < self.bins as f64 {
                put(x as usize, 1.0);
            }
            return;
        }
        let i = x.floor();
        let pos = (x - i) * OFFSETS as f64;
        let k = (pos as usize).min(OFFSETS - 1);
        let a = (pos - k as f64) as f32;
        let (r0, r1) = (
            &self.table[k * self.len..(k + 1) * self.len],
            &self.table[(k + 1) * self.len..(k + 2) * self.len],
        );
        let base = i as i64 + self.first;
        for j in 0..self.len {
            let bin = base + j as i64;
            let w = r0[j] + a * (r1[j] - r0[j]);
            if w != 0.0 && bin >= 0 && (bin as usize) < self.bins {
                put(bin as usize, w);
            }
        }
    }
}
