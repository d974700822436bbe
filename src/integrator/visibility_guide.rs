//! Visibility-guided first hidden vertex (beyond the thesis: its §6 asks for hidden-geometry
//! sampling that wastes fewer samples). A shared light subpath contributes nothing unless its
//! first hidden vertex y₁ is lit by a laser spot, yet uniform hidden-geometry sampling puts y₁
//! anywhere: on geometry behind a second corner, on the back of an object, or on the relay wall
//! itself when a camera makes every shape hidden geometry (mitransient's `nlos-z-simple.xml`,
//! where most of the area is the wall). A pilot of uniform points, each tested against a few laser
//! spots by one shadow ray ([`NlosTracer::spot_lights`]), scores cells of the
//! hidden geometry (runs of consecutive primitives of one shape); y₁ is then drawn from the
//! defensive mixture p = α·uniform + (1 − α)·guided (Hesterberg 1995), α = 1/4, so every point
//! keeps an area density of at least α/A and the estimate stays unbiased: the subpath's source
//! weight is 1/p(y₁) instead of A. Deeper vertices stay uniform. The pilot's stream is fixed and
//! its size depends only on the render's spp, so the guide is the same for every seed, thread
//! count and render part.

use super::NlosTracer;
use crate::capture::Spot;
use crate::geometry::Interaction;
use crate::sampling::{Discrete, Sampler};
use crate::scene::{AreaSampler, Scene};
use crate::settings::CaptureType;
use rayon::prelude::*;

/// The uniform share α of the mixture: a guide that is wrong somewhere costs at most 1/α = 4× the
/// variance there.
const UNIFORM_SHARE: f64 = 0.25;

/// At most this many cells (each shape gets at least one).
const CELLS: usize = 256;

/// At most this many laser spots judge each pilot point (evenly spread over the capture's spots).
const PROBES: usize = 8;

/// The pilot's stream key (apart from every pixel's and the shared light samples').
const PILOT_STREAM: u64 = u64::MAX - 1;

/// A distribution of the first hidden vertex over the hidden geometry.
pub struct Guide {
    /// Picks a hidden primitive (as [`AreaSampler::sample_with`] indexes them).
    dist: Discrete,
    /// Per primitive: the inverse area density 1/p of a point on it.
    inv_density: Vec<f32>,
}

impl Guide {
    /// Learn the guide for `tracer`'s capture from a pilot of `pilot` uniform points; `None` if
    /// no pilot point is lit (then uniform sampling is as good as any).
    pub(super) fn learn(tracer: &NlosTracer, hg: &AreaSampler, pilot: usize) -> Option<Self> {
        let scene = tracer.scene;
        let spots = &tracer.scan.capture.spots;
        let probes: Vec<_> = match tracer.settings.capture_type {
            CaptureType::Single => spots.iter().take(1).collect(),
            _ => {
                let n = spots.len().min(PROBES);
                (0..n).map(|i| &spots[i * spots.len() / n]).collect()
            }
        };
        if probes.is_empty() {
            return None;
        }
        // ---- Cells: runs of consecutive primitives within a shape.
        let areas: Vec<(f64, u32)> = hg.areas().collect();
        let per_cell = areas.len().div_ceil(CELLS).max(1);
        let mut cell = Vec::with_capacity(areas.len());
        let (mut cells, mut run) = (0usize, 0usize);
        for (k, &(_, shape)) in areas.iter().enumerate() {
            if k == 0 || shape != areas[k - 1].1 || run == per_cell {
                (cells, run) = (cells + 1, 0);
            }
            run += 1;
            cell.push(cells - 1);
        }
        // ---- Pilot: the fraction of probe spots that light each uniform point, in blocks of
        // 256 points with a stream each (in parallel, collected in order).
        let scores: Vec<(usize, f64)> = (0..pilot.div_ceil(256))
            .into_par_iter()
            .flat_map_iter(|block| {
                let mut rng = Sampler::new(0, PILOT_STREAM, block as u64);
                (block * 256..(block * 256 + 256).min(pilot))
                    .map(|_| {
                        let (y, k) = hg.sample_with(hg.distribution(), scene, &mut rng);
                        (cell[k], lit_fraction(tracer, &y, &probes))
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        if scores.iter().all(|s| s.1 == 0.0) {
            return None;
        }
        // ---- Each cell's score, shrunk towards 1/2 by one pseudo-point each way (a cell that
        // the pilot missed is neither favoured nor dropped), and its area.
        let (mut sum, mut count, mut area) = (vec![1.0; cells], vec![2.0; cells], vec![0.0; cells]);
        for &(c, s) in &scores {
            sum[c] += s;
            count[c] += 1.0;
        }
        for (k, &(a, _)) in areas.iter().enumerate() {
            area[cell[k]] += a;
        }
        let score: Vec<f64> = sum.iter().zip(&count).map(|(s, n)| s / n).collect();
        let total: f64 = area.iter().sum();
        let mean: f64 = score.iter().zip(&area).map(|(s, a)| s * a).sum::<f64>() / total;
        // Density g/A on a cell of score s, g = α + (1 − α)·s/mean (g integrates to 1 over A).
        let g = |c: usize| UNIFORM_SHARE + (1.0 - UNIFORM_SHARE) * score[c] / mean;
        let weights: Vec<f64> = areas
            .iter()
            .enumerate()
            .map(|(k, &(a, _))| a * g(cell[k]))
            .collect();
        Some(Self {
            dist: Discrete::new(&weights)?,
            inv_density: (0..areas.len())
                .map(|k| (total / g(cell[k])) as f32)
                .collect(),
        })
    }

    /// A first hidden vertex and its inverse area density.
    #[inline]
    pub(super) fn sample(
        &self,
        hg: &AreaSampler,
        scene: &Scene,
        rng: &mut Sampler,
    ) -> (Interaction, f32) {
        let (y, k) = hg.sample_with(&self.dist, scene, rng);
        (y, self.inv_density[k])
    }
}

/// The fraction of `probes` whose spot lights `y` (facing it, unoccluded, sending light its way).
fn lit_fraction(tracer: &NlosTracer, y: &Interaction, probes: &[&Spot]) -> f64 {
    let lit = probes
        .iter()
        .filter(|spot| tracer.spot_lights(y, spot))
        .count();
    lit as f64 / probes.len() as f64
}
