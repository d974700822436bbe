//! The render loop: every pixel's samples in parallel (rayon), traced by the scene's
//! [`Tracer`] and accumulated into the transient film through its splatter (mitransient-model
//! §3.8). Each pixel is rendered by one task from per-(seed, pixel, block) random streams (a film
//! of few pixels splits a pixel's blocks into chunks, summed in chunk order), so results are
//! bit-identical whatever the thread count. Progress and cancellation go through
//! atomics so that a caller (the Python binding) can poll them; cancellation is checked after
//! every sample. Work runs on a thread pool made for the render (never rayon's global pool, so a
//! forked process can render too), and the output's size is checked before it is allocated.

use crate::error::{NlosError, Result};
use crate::film::{Film, Splatter, TemporalKernel};
use crate::integrator::{NlosTracer, PathTracer, Splat, Tracer};
use crate::parallel::pool;
use crate::sampling::Sampler;
use crate::scene::{Scene, Setup};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Samples per random stream (and per cancellation check).
pub const BLOCK: u64 = 256;

/// Adaptive sampling judges a pixel's error only after this many samples (a variance estimated
/// from fewer misses rare bright paths too often).
pub const ADAPTIVE_MIN_SAMPLES: u64 = 4 * BLOCK;

/// Options of one render.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Samples per scan point; `None` takes the sampler's `sample_count`.
    pub spp: Option<u64>,
    /// Seed, added to the sampler's `seed`.
    pub seed: u64,
    /// Worker threads; `None` = all cores.
    pub threads: Option<usize>,
    /// One channel (`mono`) or three (`rgb`).
    pub mono: bool,
    /// Temporal kernel overriding the film's.
    pub kernel: Option<TemporalKernel>,
    /// Largest output (bytes) the render may allocate; `None`: 80 % of the memory available.
    pub max_memory: Option<u64>,
    /// Also estimate each transient bin's variance of the mean ([`Rendered::variance`]).
    pub variance: bool,
    /// Adaptive sampling: each pixel takes blocks of samples until the relative standard error of
    /// its total is at most this (then `spp` is the most it may take).
    pub target_rel_error: Option<f64>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            spp: None,
            seed: 0,
            threads: None,
            mono: true,
            kernel: None,
            max_memory: None,
            variance: false,
            target_rel_error: None,
        }
    }
}

/// Memory this process may still use: `MemAvailable` of /proc/meminfo where there is one.
fn available_memory() -> u64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("MemAvailable:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
        })
        .map_or(8 << 30, |kib| kib * 1024)
}

/// The memory a render may allocate: `max_memory`, or 80 % of the memory available.
pub fn memory_limit(max_memory: Option<u64>) -> u64 {
    max_memory.unwrap_or_else(|| available_memory() / 5 * 4)
}

/// A rendered capture in mitransient's layout.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// Steady image, (H, W, C).
    pub steady: Vec<f32>,
    /// Its shape.
    pub steady_shape: Vec<usize>,
    /// Transient, (H, W, T, C) or, exhaustive, (H, W, LH, LW, T, C).
    pub transient: Vec<f32>,
    /// Its shape.
    pub transient_shape: Vec<usize>,
    /// With [`RenderOptions::variance`]: each transient value's variance of the mean, same shape.
    pub variance: Option<Vec<f32>>,
    /// Samples each pixel took (all `spp` unless adaptive), row-major.
    pub samples: Vec<u64>,
}

/// Shared state a caller may watch and use to cancel.
#[derive(Default)]
pub struct Monitor {
    /// Samples finished so far.
    pub done: AtomicU64,
    /// Set to stop the render early (it then returns [`NlosError::Interrupted`]).
    pub cancel: AtomicBool,
}

/// Total samples a render will take (for progress bars).
pub fn total_samples(scene: &Scene, opts: &RenderOptions) -> u64 {
    let f = &scene.meter.film;
    ((f.width * f.height) as u64).saturating_mul(opts.spp.unwrap_or(scene.meter.spp))
}

/// How a render of a scene splits into work: every pixel's samples in chunks of whole blocks.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The film, with the render's temporal kernel.
    pub film: Film,
    /// Samples per pixel.
    pub spp: u64,
    /// Seed of the random streams (the sampler's `seed` + the render's).
    pub seed: u64,
    /// Channels (1 mono, 3 rgb).
    pub channels: usize,
    /// Pixels (scan points), row-major.
    pub pixels: usize,
    /// Chunks each pixel's samples are split into ([`chunks_per_pixel`]).
    pub chunks: u64,
    /// Samples per chunk (whole blocks; the last chunk may be shorter or empty).
    pub per_chunk: u64,
    /// Floats of transient per pixel.
    pub pixel_len: usize,
    /// Shape of the transient and of the steady image.
    pub transient_shape: Vec<usize>,
    /// Shape of the steady image.
    pub steady_shape: Vec<usize>,
    /// Per-bin variance estimates are accumulated.
    pub variance: bool,
    /// Adaptive sampling's target relative standard error of a pixel's total.
    pub target_rel_error: Option<f64>,
}

impl Plan {
    /// The plan of rendering `scene` with `opts` (checks the film and the options, not memory).
    pub fn new(scene: &Scene, opts: &RenderOptions) -> Result<Self> {
        let spp = opts.spp.unwrap_or(scene.meter.spp);
        if spp == 0 {
            return Err(NlosError::prop("render", "spp", "must be positive"));
        }
        let mut film = scene.meter.film.clone();
        if let Some(k) = opts.kernel {
            film.kernel = k;
        }
        if film.phasor.is_some() {
            if !opts.mono {
                return Err(NlosError::prop(
                    "phasor_hdr_film",
                    "variant",
                    "phasor films render mono only (as mitransient)",
                ));
            }
            if film.kernel != TemporalKernel::Box {
                return Err(NlosError::prop(
                    "phasor_hdr_film",
                    "kernel_sigma",
                    "a phasor film is exact in time: it takes no temporal kernel",
                ));
            }
        }
        film.check_kernel()?;
        if opts.variance && spp < 2 {
            return Err(NlosError::prop(
                "render",
                "return_variance",
                "a variance needs at least 2 samples per scan point",
            ));
        }
        if let Some(e) = opts.target_rel_error
            && !(e > 0.0 && e.is_finite())
        {
            return Err(NlosError::prop(
                "render",
                "target_rel_error",
                format!("must be a positive number, got {e}"),
            ));
        }
        let c = if opts.mono { 1 } else { 3 };
        // The whole output's size must be a number before anything multiplies its dimensions.
        let transient_shape = output_shape(&film, c);
        if transient_shape
            .iter()
            .try_fold(4u64, |acc, &d| acc.checked_mul(d as u64))
            .is_none()
        {
            return Err(NlosError::prop(
                "transient_hdr_film",
                "width",
                format!("the transient {transient_shape:?} has more than 2^64 bytes"),
            ));
        }
        let pixel_len = film.laser_slots() * film.slot_len(c);
        let pixels = film.width * film.height;
        // Variance and adaptive sampling follow each pixel's samples in order: one chunk.
        let whole = opts.variance || opts.target_rel_error.is_some();
        let chunks = if whole {
            1
        } else {
            chunks_per_pixel(pixels as u64, spp, (pixel_len * 4) as u64)
        };
        Ok(Self {
            transient_shape,
            steady_shape: vec![film.height, film.width, c],
            film,
            spp,
            seed: scene.meter.seed.wrapping_add(opts.seed),
            channels: c,
            pixels,
            chunks,
            per_chunk: spp.div_ceil(BLOCK).div_ceil(chunks) * BLOCK,
            pixel_len,
            variance: opts.variance,
            target_rel_error: opts.target_rel_error,
        })
    }

    /// Bytes of `pixels` pixels of transient (float32).
    pub fn bytes(&self, pixels: usize) -> u64 {
        (pixels as u64)
            .saturating_mul(self.pixel_len as u64)
            .saturating_mul(4)
    }

    /// Check that `bytes` fit in the render's memory limit; the error names `what` and the way out.
    pub fn check_memory(&self, opts: &RenderOptions, bytes: u64, what: &str) -> Result<()> {
        let limit = memory_limit(opts.max_memory);
        if bytes > limit {
            return Err(NlosError::prop(
                "transient_hdr_film",
                "width",
                format!(
                    "{what} {:?} (float32) needs more than the {limit} bytes allowed: render a smaller film, raise render(..., max_memory=...), or stream it to disk with nlos_rs.render_to_file",
                    self.transient_shape
                ),
            ));
        }
        Ok(())
    }

    /// Adaptive sampling's stopping rule after `n` samples whose totals have sums `t1` (of the
    /// totals) and `t2` (of their squares): at least [`ADAPTIVE_MIN_SAMPLES`] samples, a positive
    /// mean, and a standard error of the mean at most `target_rel_error` × the mean.
    fn precise_enough(&self, n: u64, t1: f64, t2: f64) -> bool {
        let Some(e) = self.target_rel_error else {
            return false;
        };
        if n < ADAPTIVE_MIN_SAMPLES || !(t1 > 0.0) {
            return false;
        }
        let nf = n as f64;
        let mean = t1 / nf;
        let s2 = ((t2 - nf * mean * mean) / (nf - 1.0)).max(0.0);
        (s2 / nf).sqrt() <= e * mean
    }

    /// Samples [first, end) of chunk `k`.
    fn chunk_samples(&self, k: u64) -> (u64, u64) {
        let first = (k * self.per_chunk).min(self.spp);
        (first, (first + self.per_chunk).min(self.spp))
    }
}

/// Raw sums (not yet divided by spp) of the chunks `chunks` of pixels `pixels`: what a worker
/// returns. [`assemble`] turns parts covering every chunk of a run of pixels into the render's
/// values, bit-identical to [`render`].
#[derive(Clone, Debug)]
pub struct Part {
    /// Pixels covered.
    pub pixels: Range<usize>,
    /// Chunks covered, of each pixel.
    pub chunks: Range<u64>,
    /// Per pixel, per chunk: `pixel_len` transient sums.
    pub transient: Vec<f32>,
    /// Per pixel, per chunk: three steady sums.
    pub steady: Vec<f64>,
}

/// Render `scene`.
pub fn render(scene: &Scene, opts: &RenderOptions, monitor: &Monitor) -> Result<Rendered> {
    let plan = Plan::new(scene, opts)?;
    let copies = if plan.variance { 2 } else { 1 };
    plan.check_memory(
        opts,
        plan.bytes(plan.pixels).saturating_mul(copies),
        "the transient (and its variance)",
    )?;
    pool(opts.threads)?.install(|| {
        with_tracer!(scene, opts, monitor, |tracer| {
            let job = Sampling::new(tracer, &plan, monitor);
            if plan.chunks == 1 {
                // Each pixel accumulates in place, in sample order.
                let (len, c) = (plan.pixel_len, plan.channels);
                let mut transient = vec![0.0f32; plan.pixels * len];
                let mut steady = vec![0.0f32; plan.pixels * c];
                let mut variance = vec![0.0f32; if plan.variance { plan.pixels * len } else { 0 }];
                let mut samples = vec![plan.spp; plan.pixels];
                let mut sqs: Vec<Option<&mut [f32]>> = if plan.variance {
                    variance.chunks_mut(len).map(Some).collect()
                } else {
                    (0..plan.pixels).map(|_| None).collect()
                };
                transient
                    .par_chunks_mut(len)
                    .zip(steady.par_chunks_mut(c))
                    .zip(samples.par_iter_mut())
                    .zip(sqs.par_iter_mut())
                    .enumerate()
                    .try_for_each(|(pixel, (((buf, st), n), sq))| {
                        let mut sum = [0.0f64; 3];
                        *n = job.trace(pixel, 0, plan.spp, buf, &mut sum, sq.as_deref_mut())?;
                        if let Some(sq) = sq.as_deref_mut() {
                            variance_of_mean(buf, sq, *n);
                        }
                        normalise(&plan, buf, &sum, st, *n);
                        Ok(())
                    })?;
                drop(sqs);
                let mut out = rendered(&plan, transient, steady);
                out.variance = plan.variance.then_some(variance);
                out.samples = samples;
                Ok(out)
            } else {
                let part = job.part(0..plan.pixels, 0..plan.chunks)?;
                let (transient, steady) = assemble(&plan, &[part])?;
                Ok(rendered(&plan, transient, steady))
            }
        })
    })
}

/// Turn a pixel's per-bin sums of squared per-sample values `sq` into the variance of the mean,
/// given its sums `buf` over `n` samples: s²/n with s² = (Σx² − n·x̄²)/(n − 1).
fn variance_of_mean(buf: &[f32], sq: &mut [f32], n: u64) {
    let n = n as f64;
    for (v, &s) in sq.iter_mut().zip(buf) {
        let mean = s as f64 / n;
        let s2 = ((*v as f64 - n * mean * mean) / (n - 1.0)).max(0.0);
        *v = (s2 / n) as f32;
    }
}

/// Render the chunks `chunks` of the pixels `pixels` of `scene` (a worker's task); the part's
/// memory is checked against `opts.max_memory`.
pub fn render_part(
    scene: &Scene,
    opts: &RenderOptions,
    pixels: Range<usize>,
    chunks: Range<u64>,
    monitor: &Monitor,
) -> Result<Part> {
    let plan = Plan::new(scene, opts)?;
    if pixels.start >= pixels.end || pixels.end > plan.pixels {
        return Err(NlosError::prop(
            "render",
            "pixels",
            format!(
                "{pixels:?} is not a run of the film's {} pixels",
                plan.pixels
            ),
        ));
    }
    if chunks.start >= chunks.end || chunks.end > plan.chunks {
        return Err(NlosError::prop(
            "render",
            "chunks",
            format!(
                "{chunks:?} is not a run of the {} chunks per pixel",
                plan.chunks
            ),
        ));
    }
    if plan.variance || plan.target_rel_error.is_some() {
        return Err(NlosError::prop(
            "render",
            if plan.variance {
                "return_variance"
            } else {
                "target_rel_error"
            },
            "is for nlos_rs.render (one process), not for renders in parts",
        ));
    }
    let n = (pixels.len() as u64 * (chunks.end - chunks.start)) as usize;
    plan.check_memory(opts, plan.bytes(n), "a part of the transient")?;
    pool(opts.threads)?.install(|| {
        with_tracer!(scene, opts, monitor, |tracer| {
            Sampling::new(tracer, &plan, monitor).part(pixels, chunks)
        })
    })
}

/// The render's transient and steady values of a run of pixels from parts that cover every chunk
/// of each of them, given in pixel order and, within a pixel, chunk order: per pixel the chunks'
/// sums are added in chunk order and divided by spp, exactly as [`render`] does.
pub fn assemble(plan: &Plan, parts: &[Part]) -> Result<(Vec<f32>, Vec<f32>)> {
    let (c, len) = (plan.channels, plan.pixel_len);
    let first = parts.first().map_or(0, |p| p.pixels.start);
    let end = parts.last().map_or(0, |p| p.pixels.end);
    let mut transient = vec![0.0f32; (end - first) * len];
    let mut steady = vec![0.0f32; (end - first) * c];
    let mut sums = vec![[0.0f64; 3]; end - first];
    // The next chunk each pixel expects.
    let mut next = vec![0u64; end - first];
    for part in parts {
        let k = part.chunks.end.saturating_sub(part.chunks.start) as usize;
        let n = part.pixels.len() * k;
        if part.transient.len() != n * len || part.steady.len() != n * 3 {
            return Err(NlosError::Scene(format!(
                "a part of pixels {:?}, chunks {:?} holds {} + {} values, not {} + {}",
                part.pixels,
                part.chunks,
                part.transient.len(),
                part.steady.len(),
                n * len,
                n * 3
            )));
        }
        for (i, pixel) in part.pixels.clone().enumerate() {
            let j = pixel.checked_sub(first).filter(|&j| j < end - first);
            let Some(j) = j.filter(|&j| next[j] == part.chunks.start) else {
                return Err(NlosError::Scene(format!(
                    "parts out of order: pixel {pixel}, chunks {:?}",
                    part.chunks
                )));
            };
            let buf = &mut transient[j * len..(j + 1) * len];
            for chunk in 0..k {
                let at = i * k + chunk;
                let src = &part.transient[at * len..(at + 1) * len];
                buf.iter_mut().zip(src).for_each(|(a, b)| *a += b);
                for (a, b) in sums[j].iter_mut().zip(&part.steady[at * 3..at * 3 + 3]) {
                    *a += b;
                }
            }
            next[j] = part.chunks.end;
        }
    }
    if next.iter().any(|&n| n != plan.chunks) {
        return Err(NlosError::Scene("parts do not cover every chunk".into()));
    }
    for (j, sum) in sums.iter().enumerate() {
        normalise(
            plan,
            &mut transient[j * len..(j + 1) * len],
            sum,
            &mut steady[j * c..(j + 1) * c],
            plan.spp,
        );
    }
    Ok((transient, steady))
}

/// The render's arrays with their shapes.
fn rendered(plan: &Plan, transient: Vec<f32>, steady: Vec<f32>) -> Rendered {
    Rendered {
        steady,
        steady_shape: plan.steady_shape.clone(),
        transient,
        transient_shape: plan.transient_shape.clone(),
        variance: None,
        samples: vec![plan.spp; plan.pixels],
    }
}

/// Divide a pixel's sums by its `n` samples; exhaustive steady images average the laser points.
fn normalise(plan: &Plan, buf: &mut [f32], sum: &[f64; 3], st: &mut [f32], n: u64) {
    let inv_spp = 1.0 / n as f64;
    for v in buf.iter_mut() {
        *v = (*v as f64 * inv_spp) as f32;
    }
    let slots = plan.film.laser_slots();
    for k in 0..plan.channels {
        st[k] = (sum[k] * inv_spp / slots as f64) as f32;
    }
}

/// Run `$body` with `$t` bound to the scene's tracer (each arm is compiled for its tracer type).
macro_rules! with_tracer {
    ($scene:expr, $opts:expr, $monitor:expr, |$t:ident| $body:expr) => {
        match &$scene.setup {
            Setup::Nlos(_) => {
                let $t = &NlosTracer::new($scene, $opts.mono, &$monitor.cancel)?;
                $body
            }
            Setup::Los(los) => {
                let $t = &PathTracer::new($scene, los, $opts.mono)?;
                $body
            }
        }
    };
}
use with_tracer;

/// A tracer's samples into sums: the per-(seed, pixel, block) streams, the splatter, progress and
/// cancellation.
struct Sampling<'a, T> {
    tracer: &'a T,
    plan: &'a Plan,
    monitor: &'a Monitor,
    splatter: Splatter,
}

impl<'a, T: Tracer> Sampling<'a, T> {
    fn new(tracer: &'a T, plan: &'a Plan, monitor: &'a Monitor) -> Self {
        Self {
            tracer,
            plan,
            monitor,
            splatter: plan.film.splatter(),
        }
    }

    /// Samples [first, end) of `pixel`, accumulated into its transient `buf` and steady `sum`,
    /// and each sample's squared per-bin values into `sq` if given. With adaptive sampling it stops
    /// after the first block at which the pixel's total is known well enough ([`Plan`]); it
    /// returns the samples taken.
    fn trace(
        &self,
        pixel: usize,
        first: u64,
        end: u64,
        buf: &mut [f32],
        sum: &mut [f64; 3],
        mut sq: Option<&mut [f32]>,
    ) -> Result<u64> {
        let (film, c) = (&self.plan.film, self.plan.channels);
        let slot_len = film.slot_len(c);
        // This sample's values (for the squares) and the indices it touched.
        let mut cur = vec![0.0f32; if sq.is_some() { buf.len() } else { 0 }];
        let mut touched: Vec<usize> = Vec::new();
        // Moments of the per-sample totals, for adaptive sampling.
        let (mut t1, mut t2) = (0.0f64, 0.0f64);
        let cancel = &self.monitor.cancel;
        let mut start = first;
        while start < end {
            if cancel.load(Ordering::Relaxed) {
                return Err(NlosError::Interrupted);
            }
            let n = BLOCK.min(end - start);
            let mut rng = Sampler::new(self.plan.seed, pixel as u64, start / BLOCK);
            for _ in 0..n {
                let mut total = 0.0f64;
                self.tracer.trace(pixel, &mut rng, &mut |s: Splat| {
                    // Nothing non-finite reaches the film (an overflowing product of extreme
                    // but valid parameters is dropped, not spread as Inf or NaN).
                    if !s.value.is_finite() || !s.opl.is_finite() {
                        return;
                    }
                    for (k, acc) in sum.iter_mut().enumerate().take(c) {
                        *acc += s.value[k] as f64;
                        total += s.value[k] as f64;
                    }
                    let at = s.slot * slot_len;
                    let slot = &mut buf[at..at + slot_len];
                    match &film.phasor {
                        Some(ph) => {
                            ph.put(s.opl - film.start_opl, s.value[0], slot);
                            if !cur.is_empty() {
                                ph.put(
                                    s.opl - film.start_opl,
                                    s.value[0],
                                    &mut cur[at..at + slot_len],
                                );
                                touched.extend(at..at + slot_len);
                            }
                        }
                        None => self.splatter.splat(s.opl, |bin, w| {
                            for k in 0..c {
                                let v = s.value[k] * w;
                                slot[bin * c + k] += v;
                                if let Some(x) = cur.get_mut(at + bin * c + k) {
                                    if *x == 0.0 {
                                        touched.push(at + bin * c + k);
                                    }
                                    *x += v;
                                }
                            }
                        }),
                    }
                });
                if let Some(sq) = sq.as_deref_mut() {
                    // A sample's value in a bin is the sum of its splats there.
                    for &i in &touched {
                        sq[i] += cur[i] * cur[i];
                        cur[i] = 0.0;
                    }
                    touched.clear();
                }
                t1 += total;
                t2 += total * total;
                if cancel.load(Ordering::Relaxed) {
                    return Err(NlosError::Interrupted);
                }
            }
            self.monitor.done.fetch_add(n, Ordering::Relaxed);
            start += n;
            if self.plan.precise_enough(start - first, t1, t2) {
                // The samples not taken count as done for progress.
                self.monitor.done.fetch_add(end - start, Ordering::Relaxed);
                break;
            }
        }
        Ok(start - first)
    }

    /// Every (pixel, chunk) of the ranges in parallel, each into its own slice of the part.
    fn part(&self, pixels: Range<usize>, chunks: Range<u64>) -> Result<Part> {
        let (len, k) = (self.plan.pixel_len, chunks.end - chunks.start);
        let tasks = pixels.len() * k as usize;
        let mut part = Part {
            transient: vec![0.0f32; tasks * len],
            steady: vec![0.0f64; tasks * 3],
            pixels,
            chunks,
        };
        let (first_pixel, first_chunk) = (part.pixels.start, part.chunks.start);
        part.transient
            .par_chunks_mut(len.max(1))
            .zip(part.steady.par_chunks_mut(3))
            .enumerate()
            .try_for_each(|(task, (buf, st))| {
                let pixel = first_pixel + task / k as usize;
                let (first, end) = self.plan.chunk_samples(first_chunk + task as u64 % k);
                let mut sum = [0.0f64; 3];
                self.trace(pixel, first, end, buf, &mut sum, None)?;
                st.copy_from_slice(&sum);
                Ok(())
            })?;
        Ok(part)
    }
}
/// The transient's shape: (H, W, T, C), exhaustive (H, W, LH, LW, T, C); for a phasor film
/// (frequencies, 2) in place of (T, C).
fn output_shape(film: &Film, c: usize) -> Vec<usize> {
    let tail = match &film.phasor {
        Some(ph) => [ph.frequencies.len(), 2],
        None => [film.temporal_bins, c],
    };
    let (h, w) = (film.height, film.width);
    match film.laser_scan {
        Some((lw, lh)) => vec![h, w, lh, lw, tail[0], tail[1]],
        None => vec![h, w, tail[0], tail[1]],
    }
}

/// Fewest parallel tasks a render is split into: a film with fewer pixels splits each pixel's
/// samples into chunks of whole blocks, so that a 1×1 or 4×4 capture uses every core.
const MIN_TASKS: u64 = 64;
/// Largest memory (bytes) the per-chunk buffers of a split render may take.
const CHUNK_MEMORY: u64 = 256 << 20;

/// Chunks each pixel's `spp` samples are split into. It depends on the capture only, never on the
/// thread count, so results stay bit-identical whatever the threads: one chunk (the whole pixel in
/// one task, in sample order) for films of [`MIN_TASKS`] pixels or more; otherwise enough chunks of
/// whole [`BLOCK`]s for [`MIN_TASKS`] tasks, within [`CHUNK_MEMORY`].
fn chunks_per_pixel(npix: u64, spp: u64, pixel_bytes: u64) -> u64 {
    let blocks = spp.div_ceil(BLOCK);
    let by_memory = (CHUNK_MEMORY / (npix * pixel_bytes).max(1)).max(1);
    MIN_TASKS.div_ceil(npix).min(blocks).min(by_memory).max(1)
}
