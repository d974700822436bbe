//! The render loop: every pixel's samples in parallel (rayon), traced by the scene's
//! [`Tracer`] and accumulated into the transient film through its splatter (mitransient-model
//! §3.8). Each pixel is rendered by one task from per-(seed, pixel, block) random streams (a film
//! of few pixels splits a pixel's blocks into chunks, summed in chunk order), so results are
//! bit-identical whatever the thread count; a task keeps [`Tracer::IN_FLIGHT`] paths in flight,
//! each pixel's in sample order ([`Sampling::run`]). Progress and cancellation go through
//! atomics so that a caller (the Python binding) can poll them; cancellation is checked after
//! every sample. Work runs on a thread pool made for the render (never rayon's global pool, so a
//! forked process can render too), and the output's size is checked before it is allocated.

use crate::cache::prefetch;
use crate::error::{NlosError, Result};
use crate::film::memory::zero_bins;
use crate::film::{Film, Splatter, TemporalKernel};
use crate::integrator::{NlosTracer, PathTracer, Splat, Tracer};
use crate::parallel::pool;
use crate::sampling::Sampler;
use crate::scene::{Scene, Setup};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

/// Samples per random stream (and per cancellation check).
pub const BLOCK: u64 = 256;

/// Most pixels that connect, one after another, to a few shared light subpaths: meanwhile those
/// subpaths and the geometry around their vertices (the BVH nodes a shadow ray towards them
/// visits) stay in cache. 1.3x faster on the 200k-triangle mesh than a pixel connecting to a whole
/// pass of subpaths at once.
const PIXEL_GROUP: usize = 256;

/// The film a group of pixels may write to at most (bytes): the group's buffers stay in a core's
/// L2 cache while it connects them to a tile of subpaths (an exhaustive capture's pixel holds one
/// transient per laser point: 77 KB for 8×8 points and 300 bins, so groups of four).
const GROUP_BYTES: usize = 320 << 10;

/// Consecutive groups covering `n` pixels of `len` floats each, largest first (guided
/// self-scheduling, Polychronopoulos and Kuck 1987): each takes 1/(2·threads) of the pixels left,
/// at least one and at most [`PIXEL_GROUP`] or [`GROUP_BYTES`] of film, so that the last groups
/// handed out are small and no thread waits long for another at the end of a pass (with equal
/// groups of 256, one thread ran alone for the last group, 6 % of a 64×64 render).
fn guided_groups(n: usize, len: usize, threads: usize) -> Vec<Range<usize>> {
    let most = (GROUP_BYTES / (4 * len.max(1))).clamp(1, PIXEL_GROUP);
    let mut groups = Vec::new();
    let mut at = 0;
    while at < n {
        let size = ((n - at) / (2 * threads.max(1))).clamp(1, most).min(n - at);
        groups.push(at..at + size);
        at += size;
    }
    groups
}

/// Ask for up to [`PREFETCH_BYTES`] of a pixel's transient `buf` in cache (out of line: the render
/// loop it is called from keeps its own code as it was).
#[inline(never)]
fn prefetch_film(buf: &[f32]) {
    prefetch(buf.as_ptr(), size_of_val(buf).min(PREFETCH_BYTES));
}

/// The largest pixel transient asked for in cache when a lane starts its task ([`Sampling::lane`]):
/// a quarter of a 32 KiB first-level data cache, so two lanes' fit with the tree's nodes.
const PREFETCH_BYTES: usize = 8 << 10;

/// Light subpaths a group of pixels connects to at a time; a camera's pixel draws one first
/// vertex per tile of this many light samples.
const LIGHT_TILE: u64 = 8;

/// The stream key of a shared render's light samples (pixel keys are below it).
const SHARED_STREAM: u64 = u64::MAX;

/// Adaptive sampling judges a pixel's error only after this many samples (a variance estimated
/// from fewer misses rare bright paths too often).
pub const ADAPTIVE_MIN_SAMPLES: u64 = 4 * BLOCK;

/// The two-sided 90 % quantile of the standard normal: adaptive sampling stops once a total's
/// relative error is within `target_rel_error` with 90 % confidence.
pub const ADAPTIVE_Z: f64 = 1.644_853_626_951_472_2;

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
    /// The kernel's width is chosen per scan point ([`crate::film::auto_width`]); `kernel` gives
    /// the shape.
    pub auto_width: bool,
    /// Draw from a low-discrepancy sequence (true) or independently (false) instead of as the
    /// scene's sampler says.
    pub low_discrepancy: Option<bool>,
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
            auto_width: false,
            low_discrepancy: None,
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
    /// Per-bin variance estimates are accumulated (asked for, or for an automatic kernel width).
    pub variance: bool,
    /// Automatic kernel width: the kernel shape, whose width is chosen per scan point after a box
    /// render (the plan's film has the box).
    pub auto_kernel: Option<TemporalKernel>,
    /// Adaptive sampling's target relative standard error of a pixel's total.
    pub target_rel_error: Option<f64>,
    /// Samples come from a scrambled low-discrepancy sequence (the scene's sampler).
    pub low_discrepancy: bool,
    /// Each sample is a light subpath shared by every pixel ([`crate::integrator::sample_reuse`]):
    /// a chunk is a run of light samples over the whole film.
    pub shared: bool,
    /// Blocks of light samples a shared render traces (in parallel) before connecting them to
    /// the pixels: several, so that tracing them uses every thread and the film is swept less
    /// often; one for a film with laser slots, whose subpaths carry a link per laser point.
    pub pass_blocks: u64,
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
        let auto_kernel = match (opts.auto_width, film.kernel) {
            (false, _) => None,
            (true, TemporalKernel::Box) => {
                return Err(NlosError::prop(
                    "render",
                    "kernel",
                    "an automatic width needs a kernel shape other than the box",
                ));
            }
            (true, _) => Some(std::mem::replace(&mut film.kernel, TemporalKernel::Box)),
        };
        if (opts.variance || auto_kernel.is_some()) && spp < 2 {
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
        // Adaptive sampling follows each pixel's samples in order: one chunk.
        let whole = opts.target_rel_error.is_some();
        // A single scan point has no one to share its light samples with.
        let shared = !whole && pixels > 1 && crate::integrator::shares_samples(scene);
        let chunks = if whole {
            1
        } else {
            chunks_per_pixel(pixels as u64, spp, (pixel_len * 4) as u64)
        };
        Ok(Self {
            pass_blocks: if film.laser_slots() > 1 { 1 } else { 8 },
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
            variance: opts.variance || auto_kernel.is_some(),
            auto_kernel,
            target_rel_error: opts.target_rel_error,
            low_discrepancy: opts.low_discrepancy.unwrap_or(scene.meter.low_discrepancy),
            shared,
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

    /// Whether a render may trace in lockstep lanes
    /// ([`crate::integrator::path_packet`]): it keeps no per-sample values (variance, adaptive
    /// sampling) and draws independent numbers.
    pub fn lockstep(&self) -> bool {
        !self.variance && self.target_rel_error.is_none() && !self.low_discrepancy && !self.shared
    }

    /// Adaptive sampling's stopping rule after `n` samples whose totals have sums `t1` (of the
    /// totals) and `t2` (of their squares): at least [`ADAPTIVE_MIN_SAMPLES`] samples, a positive
    /// mean, and a relative error of at most `target_rel_error` at 90 % confidence — the standard
    /// error of the mean times [`ADAPTIVE_Z`] at most `target_rel_error` × the mean (normal
    /// approximation).
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
        ADAPTIVE_Z * (s2 / nf).sqrt() <= e * mean
    }

    /// (pixel, chunk) tasks per rayon task where each traces its own paths: at most a block of
    /// samples' worth. Rayon's own split leaves up to a quarter of the film in one task, and the
    /// other threads idled while it finished (a 1024-pixel line-of-sight render at 2 threads ran
    /// on one thread 4.3 % of its time, after this 0.2 %).
    fn tasks_per_job(&self) -> usize {
        BLOCK.div_ceil(self.spp.min(self.per_chunk)) as usize
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
    /// Per pixel, per chunk: sums of each sample's squared transient values (empty unless the
    /// plan estimates variance).
    pub squares: Vec<f32>,
}

/// Render `scene`.
pub fn render(scene: &Scene, opts: &RenderOptions, monitor: &Monitor) -> Result<Rendered> {
    let plan = Plan::new(scene, opts)?;
    let mut out = render_by(scene, opts, monitor, &plan)?;
    if let Some(kernel) = plan.auto_kernel {
        // On the render's own pool (never rayon's global one: fork-safe).
        pool(opts.threads)?.install(|| choose_widths(&plan, kernel, &mut out));
        if !opts.variance {
            out.variance = None;
        }
    }
    Ok(out)
}

/// Smooth every scan point's (and laser point's) transient at the kernel width of least
/// estimated risk, pooled over its 3×3 neighbourhood of scan points ([`crate::film::auto_width`]).
fn choose_widths(plan: &Plan, kernel: TemporalKernel, out: &mut Rendered) {
    use crate::film::auto_width::{risks, smooth, smoothers};
    let Some(variance) = out.variance.as_mut() else {
        return;
    };
    let smoothers = smoothers(kernel, plan.film.temporal_bins);
    let (slot, c) = (plan.film.slot_len(plan.channels), plan.channels);
    let risk: Vec<Vec<f64>> = out
        .transient
        .par_chunks(slot)
        .zip(variance.par_chunks(slot))
        .map(|(v, var)| risks(v, var, c, &smoothers))
        .collect();
    let (w, h, slots) = (plan.film.width, plan.film.height, plan.film.laser_slots());
    let choice: Vec<usize> = (0..risk.len())
        .into_par_iter()
        .map(|i| {
            let (pixel, s) = (i / slots, i % slots);
            let (x, y) = ((pixel % w) as i64, (pixel / w) as i64);
            let mut pooled = vec![0.0f64; smoothers.len() + 1];
            for (dx, dy) in (-1..=1).flat_map(|dx| (-1..=1).map(move |dy| (dx, dy))) {
                let (nx, ny) = (x + dx, y + dy);
                if nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64 {
                    let n = (ny as usize * w + nx as usize) * slots + s;
                    pooled.iter_mut().zip(&risk[n]).for_each(|(a, b)| *a += b);
                }
            }
            (0..pooled.len())
                .min_by(|&a, &b| pooled[a].total_cmp(&pooled[b]))
                .unwrap_or(0)
        })
        .collect();
    out.transient
        .par_chunks_mut(slot)
        .zip(variance.par_chunks_mut(slot))
        .zip(choice)
        .for_each(|((v, var), n)| {
            if n > 0 {
                smooth(v, var, c, &smoothers[n - 1]);
            }
        });
}

/// Render `scene` by `plan`.
fn render_by(
    scene: &Scene,
    opts: &RenderOptions,
    monitor: &Monitor,
    plan: &Plan,
) -> Result<Rendered> {
    let copies = if plan.variance { 2 } else { 1 };
    plan.check_memory(
        opts,
        plan.bytes(plan.pixels).saturating_mul(copies),
        "the transient (and its variance)",
    )?;
    pool(opts.threads)?.install(|| {
        with_tracer!(scene, opts, plan, monitor, 0..plan.pixels, |tracer| {
            let job = Sampling::new(tracer, plan, monitor);
            if plan.chunks == 1 {
                // Each pixel accumulates in place, in sample order (a shared render's pixels
                // all together, light sample by light sample), then is finished: one film.
                let (len, c) = (plan.pixel_len, plan.channels);
                let mut transient = zero_bins(plan.pixels * len);
                let mut steady = vec![0.0f32; plan.pixels * c];
                let mut variance = zero_bins(if plan.variance { plan.pixels * len } else { 0 });
                let mut sums = vec![[0.0f64; 3]; plan.pixels];
                let mut samples = vec![plan.spp; plan.pixels];
                let out = RunSums {
                    transient: &mut transient,
                    steady: &mut sums,
                    squares: &mut variance,
                };
                if plan.shared {
                    job.trace_shared(0..plan.pixels, 0, plan.spp, out)?;
                } else {
                    job.trace_film(out, &mut samples)?;
                }
                let sqs = per_task(&mut variance, len, plan.pixels);
                transient
                    .par_chunks_mut(len)
                    .zip(steady.par_chunks_mut(c))
                    .zip(samples.par_iter())
                    .zip(sqs)
                    .zip(sums.par_iter())
                    .for_each(|((((buf, st), &n), sq), sum)| {
                        if let Some(sq) = sq {
                            variance_of_mean(buf, sq, n);
                        }
                        normalise(plan, buf, sum, st, n);
                    });
                let mut out = rendered(plan, transient, steady);
                out.variance = plan.variance.then_some(variance);
                out.samples = samples;
                Ok(out)
            } else {
                let part = job.part(0..plan.pixels, 0..plan.chunks)?;
                let a = assemble(plan, &[part])?;
                let mut out = rendered(plan, a.transient, a.steady);
                out.variance = a.variance;
                Ok(out)
            }
        })
    })
}

/// `tasks` slices of `len` of `buf`, or `tasks` times `None` when `buf` is empty (no variance).
fn per_task(buf: &mut [f32], len: usize, tasks: usize) -> Vec<Option<&mut [f32]>> {
    if buf.is_empty() {
        (0..tasks).map(|_| None).collect()
    } else {
        buf.chunks_mut(len).map(Some).collect()
    }
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
        with_tracer!(scene, opts, plan, monitor, pixels.clone(), |tracer| {
            Sampling::new(tracer, &plan, monitor).part(pixels, chunks)
        })
    })
}

/// The render's transient and steady values of a run of pixels from parts that cover every chunk
/// of each of them, given in pixel order and, within a pixel, chunk order: per pixel the chunks'
/// sums are added in chunk order and divided by spp, exactly as [`render`] does.
pub fn assemble(plan: &Plan, parts: &[Part]) -> Result<Assembled> {
    let (c, len) = (plan.channels, plan.pixel_len);
    let first = parts.first().map_or(0, |p| p.pixels.start);
    let end = parts.last().map_or(0, |p| p.pixels.end);
    let mut transient = zero_bins((end - first) * len);
    let mut squares = zero_bins(if plan.variance {
        (end - first) * len
    } else {
        0
    });
    let mut steady = vec![0.0f32; (end - first) * c];
    let mut sums = vec![[0.0f64; 3]; end - first];
    // The next chunk each pixel expects.
    let mut next = vec![0u64; end - first];
    for part in parts {
        let k = part.chunks.end.saturating_sub(part.chunks.start) as usize;
        let n = part.pixels.len() * k;
        let n_squares = if plan.variance { n * len } else { 0 };
        if part.transient.len() != n * len
            || part.steady.len() != n * 3
            || part.squares.len() != n_squares
        {
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
                if plan.variance {
                    let src = &part.squares[at * len..(at + 1) * len];
                    let sq = &mut squares[j * len..(j + 1) * len];
                    sq.iter_mut().zip(src).for_each(|(a, b)| *a += b);
                }
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
        let buf = &mut transient[j * len..(j + 1) * len];
        if plan.variance {
            variance_of_mean(buf, &mut squares[j * len..(j + 1) * len], plan.spp);
        }
        normalise(plan, buf, sum, &mut steady[j * c..(j + 1) * c], plan.spp);
    }
    Ok(Assembled {
        transient,
        steady,
        variance: plan.variance.then_some(squares),
    })
}

/// Values of a run of pixels put together from parts.
pub struct Assembled {
    /// Transient values.
    pub transient: Vec<f32>,
    /// Steady values.
    pub steady: Vec<f32>,
    /// Each transient value's variance of the mean, if the plan estimates it.
    pub variance: Option<Vec<f32>>,
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

/// Run `$body` with `$t` bound to the scene's tracer, prepared for the pixels `$pixels` (each arm
/// is compiled for its tracer type).
macro_rules! with_tracer {
    ($scene:expr, $opts:expr, $plan:expr, $monitor:expr, $pixels:expr, |$t:ident| $body:expr) => {
        match &$scene.setup {
            Setup::Nlos(_) => {
                let shared = $plan.shared.then_some($plan.spp);
                let $t = &NlosTracer::new(
                    $scene,
                    $opts.mono,
                    &$monitor.cancel,
                    shared,
                    $pixels,
                    $plan.lockstep(),
                )?;
                $body
            }
            Setup::Los(los) => {
                let $t = &PathTracer::new(
                    $scene,
                    los,
                    $opts.mono,
                    $plan.spp,
                    &$monitor.cancel,
                    $pixels,
                    $plan.lockstep(),
                )?;
                $body
            }
        }
    };
}
use with_tracer;

/// A chunk's sums over a run of pixels: the chunk, transient, steady and squares ([`RunSums`]).
type ChunkSums = (u64, Vec<f32>, Vec<[f64; 3]>, Vec<f32>);

/// Where a run of pixels' sums go, pixel by pixel: transient, steady, and (with variance) each
/// sample's squared transient values.
struct RunSums<'a> {
    transient: &'a mut [f32],
    steady: &'a mut [[f64; 3]],
    squares: &'a mut [f32],
}

/// The values one sample adds to a buffer, kept apart so that their squares can be summed once
/// the sample is complete (a sample's value in a bin is the sum of its splats there).
struct SampleValues {
    cur: Vec<f32>,
    touched: Vec<usize>,
}

impl SampleValues {
    fn new(len: usize) -> Self {
        Self {
            cur: vec![0.0; len],
            touched: Vec::new(),
        }
    }

    #[inline]
    fn add(&mut self, i: usize, v: f32) {
        let x = &mut self.cur[i];
        if *x == 0.0 {
            self.touched.push(i);
        }
        *x += v;
    }

    /// The sample is complete: its squared values into `squares` (an index listed twice adds
    /// nothing the second time: its value is already cleared).
    fn finish(&mut self, squares: &mut [f32]) {
        for &i in &self.touched {
            squares[i] += self.cur[i] * self.cur[i];
            self.cur[i] = 0.0;
        }
        self.touched.clear();
    }
}

/// A run of one pixel's samples, [first, end), and where their sums go: its transient `buf`,
/// steady `sum` and (with variance) each sample's squared values `squares`; the samples taken
/// go to `taken` where the caller counts them (fewer than asked with adaptive sampling).
struct Task<'b> {
    pixel: usize,
    first: u64,
    end: u64,
    buf: &'b mut [f32],
    sum: &'b mut [f64; 3],
    squares: Option<&'b mut [f32]>,
    taken: Option<&'b mut u64>,
}

/// A task being traced ([`Sampling::run`]): its stream, its next sample, the path in flight and
/// what its samples keep (the fixed contributions, one sample's values for variance, one
/// sample's total and the totals' first two moments for adaptive sampling).
struct Lane<'b, P> {
    task: Task<'b>,
    rng: Sampler,
    next: u64,
    path: Option<P>,
    fixed: Vec<Splat>,
    values: Option<SampleValues>,
    total: f64,
    moments: (f64, f64),
}

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

    /// The random stream of block `block` of `key` (a pixel, or the shared light samples):
    /// independent, or the key's low-discrepancy sequence ([`Sampler::start`] picks the sample).
    fn stream(&self, key: u64, block: u64) -> Sampler {
        if self.plan.low_discrepancy {
            Sampler::low_discrepancy(self.plan.seed, key, block)
        } else {
            Sampler::new(self.plan.seed, key, block)
        }
    }

    /// Add one contribution to a pixel's transient `buf` (at `base` in `values`' buffer) and
    /// steady `sum`; returns the value it added over all channels.
    #[inline]
    fn deposit(
        &self,
        s: &Splat,
        buf: &mut [f32],
        sum: &mut [f64; 3],
        values: Option<&mut SampleValues>,
        base: usize,
    ) -> f64 {
        // Nothing non-finite reaches the film (an overflowing product of extreme but valid
        // parameters is dropped, not spread as Inf or NaN).
        if !s.value.is_finite() || !s.opl.is_finite() {
            return 0.0;
        }
        let (film, c) = (&self.plan.film, self.plan.channels);
        let mut total = 0.0;
        for (k, acc) in sum.iter_mut().enumerate().take(c) {
            *acc += s.value[k] as f64;
            total += s.value[k] as f64;
        }
        let slot_len = film.slot_len(c);
        let at = s.slot * slot_len;
        let slot = &mut buf[at..at + slot_len];
        match (&film.phasor, values) {
            (Some(ph), values) => {
                ph.put(s.opl - film.start_opl, s.value[0], slot);
                if let Some(values) = values {
                    let range = base + at..base + at + slot_len;
                    ph.put(
                        s.opl - film.start_opl,
                        s.value[0],
                        &mut values.cur[range.clone()],
                    );
                    values.touched.extend(range);
                }
            }
            (None, None) => self.splatter.splat(s.opl, |bin, w| {
                for k in 0..c {
                    slot[bin * c + k] += s.value[k] * w;
                }
            }),
            (None, Some(values)) => self.splatter.splat(s.opl, |bin, w| {
                for k in 0..c {
                    let v = s.value[k] * w;
                    slot[bin * c + k] += v;
                    values.add(base + at + bin * c + k, v);
                }
            }),
        }
        total
    }

    /// Trace `tasks` (each a run of a pixel's samples), [`Tracer::IN_FLIGHT`] paths at a time:
    /// each lane takes the next task, traces its samples in order from the pixel's own streams
    /// and, when it is done, the next; the lanes' paths advance a bounce at a time in turn. Each
    /// sample's contributions go to its task's sums as it makes them, so a pixel's sums are
    /// those of its samples traced one after another.
    fn run<'b>(&self, tasks: impl IntoIterator<Item = Task<'b>>) -> Result<()> {
        let mut tasks = tasks.into_iter();
        if let Some(packet) = self.tracer.packet() {
            for task in tasks {
                prefetch_film(task.buf); // as `lane` does
                let (buf, sum) = (task.buf, task.sum);
                packet.trace(
                    task.pixel,
                    task.first..task.end,
                    self.plan.seed,
                    self.tracer.first_cone(task.pixel),
                    &self.monitor.cancel,
                    &mut |s: Splat| {
                        self.deposit(&s, buf, sum, None, 0);
                    },
                )?;
                self.monitor
                    .done
                    .fetch_add(task.end - task.first, Ordering::Relaxed);
                if let Some(t) = task.taken {
                    *t = task.end - task.first;
                }
            }
            return Ok(());
        }
        let mut lanes: Vec<Option<Lane<'b, T::Path>>> = (0..T::IN_FLIGHT).map(|_| None).collect();
        loop {
            let mut busy = false;
            for slot in &mut lanes {
                if slot.is_none() {
                    *slot = tasks.next().map(|task| self.lane(task));
                }
                let Some(lane) = slot else { continue };
                busy = true;
                if lane.path.is_none() && !self.start_sample(lane)? {
                    *slot = None;
                    continue;
                }
                // The path is there now; the `else` is never taken. (Beginning the path here
                // instead, by `get_or_insert_with`, ran the Cornell box 0.92× as fast.)
                let Lane {
                    task,
                    rng,
                    path: Some(p),
                    values,
                    total,
                    ..
                } = lane
                else {
                    continue;
                };
                let going = self.tracer.bounce(p, rng, &mut |s: Splat| {
                    *total += self.deposit(&s, task.buf, task.sum, values.as_mut(), 0);
                });
                if !going && self.finish_sample(lane)? {
                    *slot = None;
                }
            }
            if !busy {
                return Ok(());
            }
        }
    }

    /// A lane starting `task`: the paths every sample of its pixel adds unchanged, traced once,
    /// and (with variance) a buffer for each sample's values.
    fn lane<'b>(&self, task: Task<'b>) -> Lane<'b, T::Path> {
        // The pixel's transient is asked for now, while the lane's first paths are traced: its
        // bins were last written when the film was made, and a path's contribution lands in
        // one of them at random (a cache miss each without this, on a film larger than the
        // caches). Of a larger buffer (an exhaustive capture's pixel holds a transient per laser
        // point) only the first `PREFETCH_BYTES`.
        prefetch_film(task.buf);
        let mut fixed = Vec::new();
        self.tracer
            .fixed_contributions(task.pixel, &mut |s| fixed.push(s));
        Lane {
            rng: self.stream(task.pixel as u64, task.first / BLOCK),
            next: task.first,
            path: None,
            fixed,
            values: task.squares.as_ref().map(|sq| SampleValues::new(sq.len())),
            total: 0.0,
            moments: (0.0, 0.0),
            task,
        }
    }

    /// Start the lane's next sample (a block's first: its stream, after a check for
    /// cancellation) with the fixed contributions, finishing at once each one the tracer turns
    /// down ([`Tracer::turned_down`]); false once its task is done.
    fn start_sample(&self, lane: &mut Lane<'_, T::Path>) -> Result<bool> {
        loop {
            let (k, task) = (lane.next, &mut lane.task);
            if k == task.end {
                return Ok(false);
            }
            if (k - task.first).is_multiple_of(BLOCK) {
                if self.monitor.cancel.load(Ordering::Relaxed) {
                    return Err(NlosError::Interrupted);
                }
                if k > task.first {
                    lane.rng = self.stream(task.pixel as u64, k / BLOCK);
                }
            }
            lane.rng.start(k);
            // A sample whose first random numbers end it is finished here, and the next begun
            // at once (in scenes whose hidden part fills little of a scan point's hemisphere,
            // most samples). Where such samples add nothing at all (no fixed contributions, no
            // values kept) a run of them is passed over up to the block's last sample, which
            // ends as usual (a block's progress is counted there); an independent sampler's
            // samples need no `start`.
            let mut goes_on = false;
            if lane.fixed.is_empty() && lane.values.is_none() && lane.rng.is_independent() {
                let block_end = task.first + ((k - task.first) / BLOCK + 1) * BLOCK;
                let run = block_end.min(task.end) - 1 - k;
                let passed = self.tracer.turned_down(task.pixel, &mut lane.rng, run);
                lane.next += passed;
                // A run that stopped short stopped at a sample that goes on.
                goes_on = passed < run;
            }
            lane.total = 0.0;
            for s in &lane.fixed {
                lane.total += self.deposit(s, task.buf, task.sum, lane.values.as_mut(), 0);
            }
            if goes_on || self.tracer.turned_down(task.pixel, &mut lane.rng, 1) == 0 {
                lane.path = Some(self.tracer.begin(task.pixel, &mut lane.rng));
                return Ok(true);
            }
            if self.finish_sample(lane)? {
                return Ok(false);
            }
        }
    }

    /// The lane's sample has ended: its squared values and total are kept, and at the end of a
    /// block progress is counted; true once the task is done (all its samples, or with
    /// adaptive sampling those of the first block at which its total is known well enough,
    /// [`Plan::precise_enough`]).
    // Inlined into both callers: out of line, the line-of-sight Cornell box ran 0.89× as fast
    // (its path loop lost the inlining it had).
    #[inline(always)]
    fn finish_sample(&self, lane: &mut Lane<'_, T::Path>) -> Result<bool> {
        let task = &mut lane.task;
        lane.path = None;
        if let (Some(v), Some(sq)) = (lane.values.as_mut(), task.squares.as_deref_mut()) {
            v.finish(sq);
        }
        lane.moments.0 += lane.total;
        lane.moments.1 += lane.total * lane.total;
        if self.monitor.cancel.load(Ordering::Relaxed) {
            return Err(NlosError::Interrupted);
        }
        lane.next += 1;
        let taken = lane.next - task.first;
        if !(taken.is_multiple_of(BLOCK) || lane.next == task.end) {
            return Ok(false);
        }
        self.monitor
            .done
            .fetch_add(taken - (taken - 1) / BLOCK * BLOCK, Ordering::Relaxed);
        if let Some(t) = task.taken.as_deref_mut() {
            *t = taken;
        }
        if lane.next == task.end {
            return Ok(true);
        }
        let precise = self
            .plan
            .precise_enough(taken, lane.moments.0, lane.moments.1);
        if precise {
            // The samples not taken count as done for progress.
            self.monitor
                .done
                .fetch_add(task.end - lane.next, Ordering::Relaxed);
        }
        Ok(precise)
    }

    /// Tasks per parallel job: [`Plan::tasks_per_job`], and at least a task per path in flight.
    fn group(&self) -> usize {
        self.plan.tasks_per_job().max(T::IN_FLIGHT)
    }

    /// Every sample of every pixel into `out` (a render whose pixels trace their own paths),
    /// groups of pixels in parallel; each pixel's samples taken into `samples`.
    fn trace_film(&self, out: RunSums, samples: &mut [u64]) -> Result<()> {
        let (len, g) = (self.plan.pixel_len, self.group());
        let mut sqs = per_task(out.squares, len, samples.len());
        out.transient
            .par_chunks_mut(len * g)
            .zip(out.steady.par_chunks_mut(g))
            .zip(sqs.par_chunks_mut(g))
            .zip(samples.par_chunks_mut(g))
            .enumerate()
            .with_max_len(1)
            .try_for_each(|(i, (((bufs, sums), sqs), taken))| {
                self.run(
                    bufs.chunks_mut(len)
                        .zip(sums)
                        .zip(sqs)
                        .zip(taken)
                        .enumerate()
                        .map(|(j, (((buf, sum), sq), taken))| Task {
                            pixel: i * g + j,
                            first: 0,
                            end: self.plan.spp,
                            buf,
                            sum,
                            squares: sq.as_deref_mut(),
                            taken: Some(taken),
                        }),
                )
            })
    }

    /// Light samples [first, end) of a shared render, connected to the pixels `pixels`. Pass by
    /// pass of [`Plan::pass_blocks`] blocks, the light subpaths are traced once (the blocks in
    /// parallel, each in sample order from its own stream, then their deterministic rest in
    /// parallel), then connected to groups of pixels in parallel, each pixel to every subpath in
    /// sample order, so no pixel's sums depend on the threads, the passes or the groups.
    fn trace_shared(&self, pixels: Range<usize>, first: u64, end: u64, out: RunSums) -> Result<()> {
        let len = self.plan.pixel_len;
        let cancel = &self.monitor.cancel;
        // A pass's subpaths, a list per block, kept from pass to pass: made afresh, these lists
        // came from new pages of memory every pass (page faults, 2 % of tal's confocal file).
        let mut lights: Vec<Vec<Option<T::Light>>> = (0..self.plan.pass_blocks)
            .map(|_| Vec::with_capacity(BLOCK as usize))
            .collect();
        let mut start = first;
        while start < end {
            let pass_end = (start + self.plan.pass_blocks * BLOCK).min(end);
            let n = pass_end - start;
            // The pass's blocks in parallel, each in sample order from its own stream (the
            // same for every pixel).
            let blocks = n.div_ceil(BLOCK) as usize;
            lights[..blocks]
                .par_iter_mut()
                .with_max_len(1)
                .enumerate()
                .try_for_each(|(b, block)| {
                    let block_start = start + b as u64 * BLOCK;
                    let mut rng = self.stream(SHARED_STREAM, block_start / BLOCK);
                    let count = ((block_start + BLOCK).min(pass_end) - block_start) as usize;
                    if block.len() < count {
                        block.resize_with(count, || None);
                    }
                    block.truncate(count);
                    for (k, light) in (block_start..).zip(block.iter_mut()) {
                        rng.start(k);
                        self.tracer.trace_light(&mut rng, light);
                        // A light subpath can be expensive (HGRS candidates): stay responsive.
                        if cancel.load(Ordering::Relaxed) {
                            return Err(NlosError::Interrupted);
                        }
                    }
                    Ok(())
                })?;
            lights[..blocks]
                .par_iter_mut()
                .flatten()
                .flatten()
                .for_each(|light| self.tracer.link_light(light));
            let mut squares = per_task(out.squares, len, pixels.len());
            // Pixels in groups, each group a few subpaths at a time ([`PIXEL_GROUP`]), handed out
            // largest first to whichever thread is free ([`guided_groups`]), so that the threads
            // finish the pass together; each pixel still adds in sample order, so the grouping
            // changes no bits.
            let threads = rayon::current_num_threads();
            let mut groups = Vec::new();
            let (mut bufs_left, mut sums_left, mut sqs_left) =
                (&mut *out.transient, &mut *out.steady, &mut squares[..]);
            for r in guided_groups(pixels.len(), len, threads) {
                let (bufs, b) = std::mem::take(&mut bufs_left).split_at_mut(r.len() * len);
                let (sums, s) = std::mem::take(&mut sums_left).split_at_mut(r.len());
                let (sqs, q) = std::mem::take(&mut sqs_left).split_at_mut(r.len());
                (bufs_left, sums_left, sqs_left) = (b, s, q);
                groups.push(Mutex::new(Some((pixels.start + r.start, bufs, sums, sqs))));
            }
            let next = AtomicUsize::new(0);
            (0..threads)
                .into_par_iter()
                .with_max_len(1)
                .try_for_each(|_| {
                    let mut values = self.plan.variance.then(|| SampleValues::new(len));
                    let (mut fixed, mut rngs, mut own) = (Vec::new(), Vec::new(), Vec::new());
                    while let Some(g) = groups.get(next.fetch_add(1, Ordering::Relaxed)) {
                        // Each index is claimed once, so the group is there to take (a lock
                        // poisoned by another thread's panic still holds it: never skip pixels).
                        let Some((group, bufs, sums, sqs)) =
                            g.lock().unwrap_or_else(PoisonError::into_inner).take()
                        else {
                            continue;
                        };
                        fixed.resize_with(sums.len(), Vec::new);
                        for (j, f) in fixed.iter_mut().enumerate().take(sums.len()) {
                            f.clear();
                            self.tracer
                                .fixed_contributions(group + j, &mut |s| f.push(s));
                        }
                        let mut k0 = start;
                        while k0 < pass_end {
                            // Each pixel's own stream of the block, for its first vertex.
                            if k0 == start || k0.is_multiple_of(BLOCK) {
                                rngs.clear();
                                rngs.extend(
                                    (group..group + sums.len())
                                        .map(|pixel| self.stream(pixel as u64, k0 / BLOCK)),
                                );
                            }
                            // Tiles of LIGHT_TILE samples aligned on the sample index, so
                            // that no split of the samples moves them.
                            let k1 = ((k0 / LIGHT_TILE + 1) * LIGHT_TILE)
                                .min((k0 / BLOCK + 1) * BLOCK)
                                .min(pass_end);
                            // (A tile lies within a block, and passes start on a block.)
                            let (b, at) = ((k0 - start) / BLOCK, (k0 - start) % BLOCK);
                            let tile = &lights[b as usize][at as usize..(at + k1 - k0) as usize];
                            for (j, (((buf, sum), sq), pixel_rng)) in bufs
                                .chunks_mut(len.max(1))
                                .zip(sums.iter_mut())
                                .zip(sqs.iter_mut())
                                .zip(rngs.iter_mut())
                                .enumerate()
                            {
                                let pixel = group + j;
                                // The pixel's first vertex for the tile, and its own paths.
                                pixel_rng.start(k0);
                                own.clear();
                                let x = self
                                    .tracer
                                    .pixel_vertex(pixel, pixel_rng, &mut |s| own.push(s));
                                // The steady sum is kept here while the pixel connects to the
                                // tile: the sums of pixels in neighbouring groups share cache
                                // lines, and another thread writes there (same additions, in order).
                                let mut steady = *sum;
                                for light in tile {
                                    for s in fixed[j].iter().chain(own.iter()) {
                                        self.deposit(s, buf, &mut steady, values.as_mut(), 0);
                                    }
                                    if let Some(x) = &x {
                                        self.tracer.connect_light(
                                            pixel,
                                            x,
                                            light.as_ref(),
                                            pixel_rng,
                                            &mut |s| {
                                                self.deposit(
                                                    &s,
                                                    buf,
                                                    &mut steady,
                                                    values.as_mut(),
                                                    0,
                                                );
                                            },
                                        );
                                    }
                                    if let (Some(v), Some(sq)) =
                                        (values.as_mut(), sq.as_deref_mut())
                                    {
                                        v.finish(sq);
                                    }
                                }
                                *sum = steady;
                            }
                            if cancel.load(Ordering::Relaxed) {
                                return Err(NlosError::Interrupted);
                            }
                            k0 = k1;
                        }
                    }
                    Ok(())
                })?;
            self.monitor
                .done
                .fetch_add(n * pixels.len() as u64, Ordering::Relaxed);
            start = pass_end;
        }
        Ok(())
    }

    /// An empty part of `pixels` × `chunks`.
    fn empty_part(&self, pixels: Range<usize>, chunks: Range<u64>) -> Part {
        let n = pixels.len() * (chunks.end - chunks.start) as usize;
        let len = self.plan.pixel_len;
        Part {
            transient: zero_bins(n * len),
            steady: vec![0.0f64; n * 3],
            squares: zero_bins(if self.plan.variance { n * len } else { 0 }),
            pixels,
            chunks,
        }
    }

    /// A shared render's part: its chunks of light samples in parallel, each over all its pixels.
    fn part_shared(&self, pixels: Range<usize>, chunks: Range<u64>) -> Result<Part> {
        let (len, k) = (self.plan.pixel_len, (chunks.end - chunks.start) as usize);
        let n = pixels.len();
        let sq_len = if self.plan.variance { n * len } else { 0 };
        let done: Vec<ChunkSums> = (0..k)
            .into_par_iter()
            .with_max_len(1)
            .map(|i| {
                let chunk = chunks.start + i as u64;
                let (first, end) = self.plan.chunk_samples(chunk);
                let (mut t, mut st, mut sq) =
                    (zero_bins(n * len), vec![[0.0f64; 3]; n], zero_bins(sq_len));
                let out = RunSums {
                    transient: &mut t,
                    steady: &mut st,
                    squares: &mut sq,
                };
                self.trace_shared(pixels.clone(), first, end, out)?;
                Ok((chunk, t, st, sq))
            })
            .collect::<Result<_>>()?;
        // Into the part's layout: per pixel, per chunk.
        let mut part = self.empty_part(pixels, chunks);
        for (chunk, transient, steady, squares) in done {
            let kc = (chunk - part.chunks.start) as usize;
            for (i, sum) in steady.iter().enumerate() {
                let at = i * k + kc;
                let (to, from) = (at * len..(at + 1) * len, i * len..(i + 1) * len);
                part.transient[to.clone()].copy_from_slice(&transient[from.clone()]);
                if self.plan.variance {
                    part.squares[to].copy_from_slice(&squares[from]);
                }
                part.steady[at * 3..at * 3 + 3].copy_from_slice(sum);
            }
        }
        Ok(part)
    }

    /// Every (pixel, chunk) of the ranges in parallel, each into its own slice of the part.
    fn part(&self, pixels: Range<usize>, chunks: Range<u64>) -> Result<Part> {
        if self.plan.shared {
            return self.part_shared(pixels, chunks);
        }
        let (len, k) = (self.plan.pixel_len, chunks.end - chunks.start);
        let mut part = self.empty_part(pixels, chunks);
        let (first_pixel, first_chunk) = (part.pixels.start, part.chunks.start);
        let tasks = part.steady.len() / 3;
        let mut squares = per_task(&mut part.squares, len.max(1), tasks);
        let g = self.group();
        part.transient
            .par_chunks_mut(len.max(1) * g)
            .zip(part.steady.par_chunks_mut(3 * g))
            .zip(squares.par_chunks_mut(g))
            .enumerate()
            .with_max_len(1)
            .try_for_each(|(i, ((bufs, sts), sqs))| {
                let mut sums = vec![[0.0f64; 3]; sqs.len()];
                self.run(
                    bufs.chunks_mut(len.max(1))
                        .zip(&mut sums)
                        .zip(sqs)
                        .enumerate()
                        .map(|(j, ((buf, sum), sq))| {
                            let task = i * g + j;
                            let (first, end) =
                                self.plan.chunk_samples(first_chunk + task as u64 % k);
                            Task {
                                pixel: first_pixel + task / k as usize,
                                first,
                                end,
                                buf,
                                sum,
                                squares: sq.as_deref_mut(),
                                // A split render's parts count no samples taken.
                                taken: None,
                            }
                        }),
                )?;
                for (st, sum) in sts.chunks_mut(3).zip(&sums) {
                    st.copy_from_slice(sum);
                }
                Ok(())
            })?;
        drop(squares);
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

/// Chunks each pixel's `spp` samples (or a shared render's light samples) are split into. It
/// depends on the capture only, never on the thread count, so results stay bit-identical whatever
/// the threads: one chunk (the whole pixel in one task, in sample order) for films of
/// [`MIN_TASKS`] pixels or more; otherwise enough chunks of whole [`BLOCK`]s for [`MIN_TASKS`]
/// tasks, within [`CHUNK_MEMORY`]. A shared render runs its chunks in parallel and, inside each,
/// its pixels.
fn chunks_per_pixel(npix: u64, spp: u64, pixel_bytes: u64) -> u64 {
    let blocks = spp.div_ceil(BLOCK);
    let by_memory = (CHUNK_MEMORY / (npix * pixel_bytes).max(1)).max(1);
    MIN_TASKS.div_ceil(npix).min(blocks).min(by_memory).max(1)
}
