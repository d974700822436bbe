//! The render loop: every pixel's samples in parallel (rayon), traced by the scene's
//! [`Tracer`] and accumulated into the transient film through its splatter (mitransient-model
//! §3.8). Each pixel is rendered by one task from per-(seed, pixel, block) random streams (a film
//! of few pixels splits a pixel's blocks into chunks, summed in chunk order), so results are
//! bit-identical whatever the thread count. Progress and cancellation go through
//! atomics so that a caller (the Python binding) can poll them; cancellation is checked after
//! every sample. Work runs on a thread pool made for the render (never rayon's global pool, so a
//! forked process can render too), and the output's size is checked before it is allocated.

use crate::error::{NlosError, Result};
use crate::film::{Film, TemporalKernel};
use crate::integrator::{NlosTracer, PathTracer, Splat, Tracer};
use crate::parallel::pool;
use crate::sampling::Sampler;
use crate::scene::{Scene, Setup};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Samples per random stream (and per cancellation check).
pub const BLOCK: u64 = 256;

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

/// Render `scene`.
pub fn render(scene: &Scene, opts: &RenderOptions, monitor: &Monitor) -> Result<Rendered> {
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
    let c = if opts.mono { 1 } else { 3 };
    let limit = opts
        .max_memory
        .unwrap_or_else(|| available_memory() / 5 * 4);
    let shape = output_shape(&film, c);
    shape
        .iter()
        .try_fold(4u64, |acc, &d| acc.checked_mul(d as u64))
        .filter(|&bytes| bytes <= limit)
        .ok_or_else(|| {
            NlosError::prop(
                "transient_hdr_film",
                "width",
                format!(
                    "the transient {shape:?} (float32) needs more than the {limit} bytes allowed: render a smaller film, or raise render(..., max_memory=...)"
                ),
            )
        })?;
    pool(opts.threads)?.install(|| match &scene.setup {
        Setup::Nlos(_) => run(
            &NlosTracer::new(scene, opts.mono, &monitor.cancel)?,
            &film,
            scene,
            spp,
            opts,
            monitor,
        ),
        Setup::Los(los) => run(
            &PathTracer::new(scene, los, opts.mono)?,
            &film,
            scene,
            spp,
            opts,
            monitor,
        ),
    })
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

/// The loop over pixels and sample blocks, for one tracer.
fn run(
    tracer: &impl Tracer,
    film: &Film,
    scene: &Scene,
    spp: u64,
    opts: &RenderOptions,
    monitor: &Monitor,
) -> Result<Rendered> {
    let seed = scene.meter.seed.wrapping_add(opts.seed);
    let splatter = film.splatter();
    let c = if opts.mono { 1 } else { 3 };
    let (slots, slot_len) = (film.laser_slots(), film.slot_len(c));
    let pixel_len = slots * slot_len;
    let npix = film.width * film.height;
    let mut transient = vec![0.0f32; npix * pixel_len];
    let mut steady = vec![0.0f32; npix * c];
    let inv_spp = 1.0 / spp as f64;

    // Samples [first, end) of `pixel`, accumulated into its transient `buf` and steady `sum`.
    let trace = |pixel: usize, first: u64, end: u64, buf: &mut [f32], sum: &mut [f64; 3]| {
        let mut splat = |s: Splat| {
            // Nothing non-finite reaches the film (an overflowing product of extreme
            // but valid parameters is dropped, not spread as Inf or NaN).
            if !s.value.is_finite() || !s.opl.is_finite() {
                return;
            }
            for (k, acc) in sum.iter_mut().enumerate().take(c) {
                *acc += s.value[k] as f64;
            }
            let slot = &mut buf[s.slot * slot_len..(s.slot + 1) * slot_len];
            match &film.phasor {
                Some(ph) => ph.put(s.opl - film.start_opl, s.value[0], slot),
                None => splatter.splat(s.opl, |bin, w| {
                    for k in 0..c {
                        slot[bin * c + k] += s.value[k] * w;
                    }
                }),
            }
        };
        let mut start = first;
        while start < end {
            if monitor.cancel.load(Ordering::Relaxed) {
                return Err(NlosError::Interrupted);
            }
            let n = BLOCK.min(end - start);
            let mut rng = Sampler::new(seed, pixel as u64, start / BLOCK);
            for _ in 0..n {
                tracer.trace(pixel, &mut rng, &mut splat);
                if monitor.cancel.load(Ordering::Relaxed) {
                    return Err(NlosError::Interrupted);
                }
            }
            monitor.done.fetch_add(n, Ordering::Relaxed);
            start += n;
        }
        Ok(())
    };
    // Normalise by the sample count; exhaustive steady images average the laser points.
    let normalise = |buf: &mut [f32], sum: &[f64; 3], st: &mut [f32]| {
        for v in buf.iter_mut() {
            *v = (*v as f64 * inv_spp) as f32;
        }
        for k in 0..c {
            st[k] = (sum[k] * inv_spp / slots as f64) as f32;
        }
    };

    let chunks = chunks_per_pixel(npix as u64, spp, (pixel_len * 4) as u64);
    if chunks == 1 {
        transient
            .par_chunks_mut(pixel_len)
            .zip(steady.par_chunks_mut(c))
            .enumerate()
            .try_for_each(|(pixel, (buf, st))| {
                let mut sum = [0.0f64; 3];
                trace(pixel, 0, spp, buf, &mut sum)?;
                normalise(buf, &sum, st);
                Ok(())
            })?;
    } else {
        // Each chunk (whole blocks) into a buffer of its own, then the chunks summed in order.
        let per_chunk = spp.div_ceil(BLOCK).div_ceil(chunks) * BLOCK;
        let parts = (0..npix as u64 * chunks)
            .into_par_iter()
            .map(|task| {
                let (pixel, chunk) = ((task / chunks) as usize, task % chunks);
                let first = (chunk * per_chunk).min(spp);
                let mut buf = vec![0.0f32; pixel_len];
                let mut sum = [0.0f64; 3];
                trace(
                    pixel,
                    first,
                    (first + per_chunk).min(spp),
                    &mut buf,
                    &mut sum,
                )?;
                Ok((buf, sum))
            })
            .collect::<Result<Vec<_>>>()?;
        for ((buf, st), pixel_parts) in transient
            .chunks_mut(pixel_len)
            .zip(steady.chunks_mut(c))
            .zip(parts.chunks(chunks as usize))
        {
            let mut sum = [0.0f64; 3];
            for (part, part_sum) in pixel_parts {
                buf.iter_mut().zip(part).for_each(|(a, b)| *a += b);
                sum.iter_mut().zip(part_sum).for_each(|(a, b)| *a += b);
            }
            normalise(buf, &sum, st);
        }
    }
    Ok(Rendered {
        steady,
        steady_shape: vec![film.height, film.width, c],
        transient,
        transient_shape: output_shape(film, c),
    })
}
