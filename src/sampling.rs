//! Random numbers and warps. Every warp comes with its density so that it can be χ²-tested
//! (tests/sampling.rs). Streams are keyed by (seed, pixel, block) so a render is bit-identical
//! whatever the number of threads.

use crate::simd::{F8, Real};
use glam::{Vec2, Vec3A};
use rand_core::Rng;
use rand_pcg::Pcg32;
use std::f32::consts::{FRAC_1_PI, PI};

/// The uniform numbers of one sample: independent (PCG32, O'Neill 2014), or a scrambled
/// low-discrepancy sequence ([`LowDiscrepancy`]) with PCG32 kept for draws from distributions.
#[derive(Clone)]
pub struct Sampler {
    rng: Pcg32,
    ld: Option<LowDiscrepancy>,
}

/// SplitMix64 finaliser: decorrelates the structured keys that seed the streams.
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Owen-scrambled Sobol' points, padded in pairs of dimensions (Burley 2020, "Practical
/// Hash-based Owen Scrambling", JCGT 9(4)). Sample `index` of a pixel takes, for its k-th draw,
/// a point of the first two Sobol' dimensions — a (0, 2)-sequence, so every 2^m consecutive points
/// stratify the square in all 2^a × 2^b elementary boxes with a + b = m — whose index is shuffled by
/// a nested uniform scramble and whose coordinates are Owen-scrambled, each with its own hash of
/// (stream key, k): every draw is uniform, every pair is stratified over a pixel's samples, and
/// different draws are independent.
#[derive(Clone)]
struct LowDiscrepancy {
    key: u32,
    index: u32,
    draw: u32,
}

/// Burley 2020's hash-based Laine–Karras permutation: an Owen scramble of the bits of `x` read
/// from the least significant (a nested uniform scramble after a bit reversal).
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// A nested uniform (Owen) scramble of the 32-bit fraction `x`.
fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// The first two Sobol' dimensions of `index`: van der Corput, and the Pascal-matrix dimension.
fn sobol_pair(index: u32) -> (u32, u32) {
    let (mut y, mut v, mut i) = (0u32, 1u32 << 31, index);
    while i != 0 {
        if i & 1 != 0 {
            y ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    (index.reverse_bits(), y)
}

impl LowDiscrepancy {
    /// The next pair of the current sample, as 32-bit fractions.
    fn pair(&mut self) -> (u32, u32) {
        let seed = mix64(((self.key as u64) << 32) | self.draw as u64) as u32;
        self.draw += 1;
        let index = owen_scramble(self.index, seed);
        let (x, y) = sobol_pair(index);
        let h = mix64(seed as u64) as u32;
        (owen_scramble(x, h), owen_scramble(y, h ^ 0x5bd1_e995))
    }
}

/// The largest f32 below one.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// 32-bit fraction → [0, 1) in f32 (24 bits).
pub fn unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

impl Sampler {
    /// The independent stream for `(seed, key_a, key_b)`, e.g. (seed, pixel, sample block). Both
    /// keys enter the LCG's increment as well as its state: PCG generators that share an increment
    /// walk the same cycle, and the streams of a shared render's light samples and of its pixels
    /// in one block were measurably correlated that way.
    pub fn new(seed: u64, key_a: u64, key_b: u64) -> Self {
        let state = mix64(seed ^ mix64(key_a.wrapping_add(0x9e37_79b9_7f4a_7c15)));
        let stream = mix64(key_b ^ mix64(seed.wrapping_add(1) ^ mix64(key_a)));
        Self {
            rng: Pcg32::new(state, stream),
            ld: None,
        }
    }
    /// The low-discrepancy sequence of `(seed, key)` (e.g. a pixel); [`Sampler::start`] picks
    /// the sample. Its PCG32 stream (for [`Sampler::sample`]) is keyed by (seed, key, block).
    pub fn low_discrepancy(seed: u64, key: u64, block: u64) -> Self {
        let mut s = Self::new(seed, key, block);
        s.ld = Some(LowDiscrepancy {
            key: mix64(seed ^ mix64(key ^ 0x243f_6a88_85a3_08d3)) as u32,
            index: 0,
            draw: 0,
        });
        s
    }
    /// Whether this is an independent sampler (not a low-discrepancy sequence): its samples
    /// follow one another in one stream, and [`Self::start`] does nothing.
    #[inline]
    pub fn is_independent(&self) -> bool {
        self.ld.is_none()
    }
    /// How many samples in a row, at most `max`, `down` turns down by their first random
    /// numbers (`skip` 2D points, then the pair `down` judges, as [`Self::next_pair`] draws it);
    /// their numbers are taken, and none of the next sample's. Samples follow one another in the
    /// stream of an independent sampler only (a low-discrepancy one starts each by its index):
    /// for one, `max` is at most 1.
    #[inline(always)]
    pub fn turned_down(&mut self, max: u64, skip: usize, down: impl Fn(u32, u32) -> bool) -> u64 {
        debug_assert!(max <= 1 || self.is_independent());
        let mut n = 0;
        if self.ld.is_none() {
            // On a copy of the stream alone (held in registers), put back once.
            let mut rng = self.rng.clone();
            while n < max {
                let mut ahead = rng.clone();
                for _ in 0..2 * skip {
                    ahead.next_u32();
                }
                // `next_pair`'s order: x, then y.
                let x = ahead.next_u32();
                if !down(x, ahead.next_u32()) {
                    break;
                }
                rng = ahead;
                n += 1;
            }
            self.rng = rng;
        } else if max > 0 {
            let mut ahead = self.clone();
            for _ in 0..skip {
                ahead.next_2d();
            }
            let (x, y) = ahead.next_pair();
            if down(x, y) {
                *self = ahead;
                n = 1;
            }
        }
        n
    }
    /// Begin sample `index` of the sequence (a pixel's sample number); an independent sampler
    /// just goes on.
    #[inline]
    pub fn start(&mut self, index: u64) {
        if let Some(ld) = self.ld.as_mut() {
            (ld.index, ld.draw) = (index as u32, 0);
        }
    }
    /// Uniform in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        match self.ld.as_mut() {
            Some(ld) => unit(ld.pair().0),
            None => unit(self.rng.next_u32()),
        }
    }
    /// A uniform 32-bit integer.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        match self.ld.as_mut() {
            Some(ld) => ld.pair().0,
            None => self.rng.next_u32(),
        }
    }
    /// Two uniform 32-bit integers (one stratified pair of a low-discrepancy sequence).
    #[inline]
    pub fn next_pair(&mut self) -> (u32, u32) {
        match self.ld.as_mut() {
            Some(ld) => ld.pair(),
            None => (self.rng.next_u32(), self.rng.next_u32()),
        }
    }
    /// A draw from a `rand_distr` distribution on this stream (always independent).
    #[inline]
    pub fn sample<T, D: rand_distr::Distribution<T>>(&mut self, d: &D) -> T {
        d.sample(&mut self.rng)
    }
    /// Two uniforms in [0, 1)² (one stratified pair of a low-discrepancy sequence).
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        match self.ld.as_mut() {
            Some(ld) => {
                let (x, y) = ld.pair();
                Vec2::new(unit(x), unit(y))
            }
            None => Vec2::new(self.next_1d(), self.next_1d()),
        }
    }
}

/// Chris Wellons' `triple32` integer hash (2018, "Prospecting for Hash Functions": three
/// xorshift-multiply rounds, the lowest bias of those he measured): a bijection of u32 whose every
/// output bit flips with about half of the input bits.
#[inline(always)]
pub fn triple32(mut x: u32) -> u32 {
    x ^= x >> 17;
    x = x.wrapping_mul(0xed5a_d4bb);
    x ^= x >> 11;
    x = x.wrapping_mul(0xac4c_1b51);
    x ^= x >> 15;
    x = x.wrapping_mul(0x3184_8bab);
    x ^ (x >> 14)
}

/// The key of a pixel's counter-based numbers ([`lane_uniform`]) for a seed.
#[derive(Clone, Copy, Debug)]
pub struct PixelKey(u64);

/// The key of pixel `pixel`'s counter-based numbers under `seed`.
pub fn lane_key(seed: u64, pixel: u64) -> PixelKey {
    PixelKey(mix64(seed ^ mix64(pixel ^ 0x1312_d6a1_7c4e_90b5)))
}

impl PixelKey {
    /// The key of sample `index` of the pixel: distinct samples (of fewer than 2³² per pixel)
    /// get distinct keys.
    #[inline]
    pub fn sample(self, index: u64) -> u32 {
        let (lo, hi) = (self.0 as u32, (self.0 >> 32) as u32);
        triple32(triple32(hi ^ index as u32) ^ lo ^ (index >> 32) as u32)
    }
}

/// The `dim`-th uniform in [0, 1) of the sample keyed `key` ([`PixelKey::sample`]): a hash of the
/// key and the count (a Weyl step apart, then [`triple32`]), so that a sample's numbers need no
/// state and lanes in lockstep draw them in vectors.
#[inline(always)]
pub fn lane_uniform(key: u32, dim: u32) -> f32 {
    unit(triple32(key.wrapping_add(dim.wrapping_mul(0x9e37_79b9))))
}

/// Cosine-weighted hemisphere around +z (Malley's method over Shirley–Chiu's concentric disk).
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3A {
    let p = square_to_uniform_disk_concentric(u);
    let z = (1.0 - p.length_squared()).max(0.0).sqrt();
    Vec3A::new(p.x, p.y, z)
}

/// Density of [`square_to_cosine_hemisphere`] (solid angle).
pub fn square_to_cosine_hemisphere_pdf(v: Vec3A) -> f32 {
    if v.z > 0.0 { v.z * FRAC_1_PI } else { 0.0 }
}

/// Shirley–Chiu concentric map of the square onto the unit disk.
pub fn square_to_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let (x, y) = (2.0 * u.x - 1.0, 2.0 * u.y - 1.0);
    if x == 0.0 && y == 0.0 {
        return Vec2::ZERO;
    }
    // The angle is π/4 · (y/x) in the wedges around ±x, π/2 − π/4 · (x/y) around ±y: a quarter
    // angle θ in [−π/4, π/4] either way, and cos(π/2 − θ) = sin θ.
    if x.abs() > y.abs() {
        let (s, c) = sin_cos_quarter(PI / 4.0 * (y / x));
        Vec2::new(x * c, x * s)
    } else {
        let (s, c) = sin_cos_quarter(PI / 4.0 * (x / y));
        Vec2::new(y * s, y * c)
    }
}

/// (sin θ, cos θ) for |θ| ≤ π/4 from their Taylor polynomials to θ⁹ and θ⁸ (truncation error
/// below 3e-8, under f32 rounding): libm's general `sincosf` took a quarter of a line-of-sight
/// render's time in cosine-weighted sampling. For an `f32`, or for lanes of them
/// ([`crate::simd::F8`]).
#[inline(always)]
pub fn sin_cos_quarter<T: Real>(t: T) -> (T, T) {
    let k = T::from;
    let t2 = t * t;
    let s = t
        * (k(1.0)
            + t2 * (k(-1.0 / 6.0)
                + t2 * (k(1.0 / 120.0) + t2 * (k(-1.0 / 5040.0) + t2 * k(1.0 / 362_880.0)))));
    let c = k(1.0)
        + t2 * (k(-0.5) + t2 * (k(1.0 / 24.0) + t2 * (k(-1.0 / 720.0) + t2 * k(1.0 / 40_320.0))));
    (s, c)
}

/// Density of [`square_to_uniform_disk_concentric`] (area).
pub fn square_to_uniform_disk_pdf(p: Vec2) -> f32 {
    if p.length_squared() <= 1.0 {
        FRAC_1_PI
    } else {
        0.0
    }
}

/// Uniform direction on the unit sphere.
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3A {
    let z = 1.0 - 2.0 * u.y;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * u.x).sin_cos();
    Vec3A::new(r * c, r * s, z)
}

/// Density of [`square_to_uniform_sphere`] (solid angle).
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform barycentrics (b1, b2) on a triangle (Heitz 2019's area-preserving low-distortion map).
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    let (b0, b1) = if u.x < u.y {
        let b0 = u.x / 2.0;
        (b0, u.y - b0)
    } else {
        let b1 = u.y / 2.0;
        (u.x - b1, b1)
    };
    Vec2::new(b1, 1.0 - b0 - b1)
}

/// [`square_to_uniform_triangle`] over eight lanes ([`F8`]): barycentrics (b1, b2), each lane's
/// bits those of the scalar routine.
#[inline(always)]
pub fn square_to_uniform_triangle_lanes(x: F8, y: F8) -> (F8, F8) {
    let (half, lower) = (F8::splat(0.5), x.lt(y));
    let b0 = F8::select(lower, x * half, x - y * half);
    let b1 = F8::select(lower, y - x * half, y * half);
    (b1, F8::splat(1.0) - b0 - b1)
}

/// [`square_to_uniform_disk_concentric`] over eight lanes ([`F8`]), each lane's bits those of the
/// scalar routine.
#[inline(always)]
pub fn square_to_uniform_disk_concentric_lanes(u: F8, v: F8) -> (F8, F8) {
    let (one, two, zero) = (F8::splat(1.0), F8::splat(2.0), F8::splat(0.0));
    let (x, y) = (two * u - one, two * v - one);
    let wide = x.abs().gt(y.abs());
    let (r, num) = (F8::select(wide, x, y), F8::select(wide, y, x));
    let q = F8::select(r.eq(zero), zero, num / r);
    let (s, c) = sin_cos_quarter(F8::splat(PI / 4.0) * q);
    (
        F8::select(wide, r * c, r * s),
        F8::select(wide, r * s, r * c),
    )
}

/// A discrete distribution over non-negative weights, sampled in O(1) with Walker's alias method
/// (Vose 1991, "A linear algorithm for generating random numbers with a given distribution"):
/// a 32-bit uniform picks one of n equal buckets and, with its remaining bits, keeps the bucket's
/// own index with probability `keep[i]` or takes its alias.
#[derive(Clone, Debug, Default)]
pub struct Discrete {
    buckets: Vec<Bucket>,
    pmf: Vec<f64>,
    total: f64,
}

/// A bucket of the alias table: the probability of keeping its own index, its alias, and the
/// reciprocals of that probability and of its complement, by which what is left of a draw is
/// rescaled ([`quotient`]).
#[derive(Clone, Copy, Debug)]
struct Bucket {
    keep: f32,
    alias: u32,
    inv_keep: f64,
    inv_pass: f64,
}

/// The f32 of the f64 quotient `num / den`, by a multiplication with `inv` = 1/den: the product
/// is within two f64 rounding steps of the quotient, so it gives the same f32 unless an f32
/// rounding boundary lies that close to it, where the division is done. (Two divisions sat on
/// the path of every area draw: a single scan point rendered 1.04× as fast without them.)
#[inline(always)]
pub fn quotient(num: f64, den: f64, inv: f64) -> f32 {
    let q = num * inv;
    let f = q as f32;
    // The f32 boundary on q's side of f: halfway to the neighbour (exact in f64; NaN for f = 0
    // = q, where nothing is ambiguous).
    let next = f32::from_bits(if (f as f64) < q {
        f.to_bits() + 1
    } else {
        f.to_bits().wrapping_sub(1)
    });
    let boundary = (f as f64 + next as f64) * 0.5;
    if (q - boundary).abs() <= q * 1e-15 {
        divided(num, den)
    } else {
        f
    }
}

/// [`quotient`]'s rare case, out of the way of the common one (inlined, it ran the line-of-sight
/// Cornell box 0.87× as fast).
#[cold]
#[inline(never)]
fn divided(num: f64, den: f64) -> f32 {
    (num / den) as f32
}

impl Discrete {
    /// From weights; `None` if they are empty, negative, non-finite or sum to zero.
    pub fn new(weights: &[f64]) -> Option<Self> {
        if weights.iter().any(|w| !(*w >= 0.0) || !w.is_finite())
            || weights.len() > u32::MAX as usize
        {
            return None;
        }
        let total: f64 = weights.iter().sum();
        if !(total > 0.0) {
            return None;
        }
        let n = weights.len();
        let pmf: Vec<f64> = weights.iter().map(|w| w / total).collect();
        // Scaled so that the mean bucket holds 1; split into under- and over-full buckets.
        let mut scaled: Vec<f64> = pmf.iter().map(|p| p * n as f64).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        let mut keep = vec![1.0f32; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
            keep[s] = scaled[s] as f32;
            alias[s] = l as u32;
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        Some(Self {
            buckets: keep
                .into_iter()
                .zip(alias)
                .map(|(keep, alias)| Bucket {
                    keep,
                    alias,
                    inv_keep: 1.0 / keep as f64,
                    inv_pass: 1.0 / (1.0 - keep as f64),
                })
                .collect(),
            pmf,
            total,
        })
    }
    /// Sum of the weights.
    pub fn total(&self) -> f64 {
        self.total
    }
    /// Probability of index `i`.
    pub fn pmf(&self, i: usize) -> f64 {
        self.pmf[i]
    }
    /// An index drawn with probability [`Discrete::pmf`] from one 32-bit uniform `x`, and a
    /// fresh uniform in [0, 1) made of what is left of `x`: the high part of x·n picks a bucket,
    /// the low part decides between the bucket and its alias and is rescaled past that test. A
    /// stratified `x` thus stays stratified within each index's share.
    #[inline]
    pub fn sample(&self, x: u32) -> (usize, f32) {
        let scaled = x as u64 * self.buckets.len() as u64;
        let bucket = (scaled >> 32) as usize;
        let r = (scaled & 0xffff_ffff) as f64 * (1.0 / 4_294_967_296.0);
        let b = self.buckets[bucket];
        let keep = b.keep as f64;
        let (i, rest) = if r < keep {
            (bucket, quotient(r, keep, b.inv_keep))
        } else {
            (b.alias as usize, quotient(r - keep, 1.0 - keep, b.inv_pass))
        };
        (i, rest.min(ONE_MINUS_EPSILON))
    }
}
