//! Hidden Geometry Rejection Sampling (HGRS), `transient_nlos_path_rs`: Tienda Hernando 2023,
//! "Técnicas de muestreo para simulación de transporte de luz sin línea de visión" (Sampling
//! techniques for non-line-of-sight light transport simulation), §3.1.
//!
//! Plain hidden-geometry sampling draws one point on the hidden geometry per vertex and loses the
//! sample when that point is not visible. HGRS draws up to N candidates (`hgrs_max_iterations`),
//! each a one-draw estimate whose weight is zero when the candidate is invisible or faces away:
//! * [`HgrsEstimator::Rejection`] (the thesis' estimator): the first visible candidate, weighted as
//!   one draw. Biased upwards where part of the hidden geometry is not visible: an accepted point's
//!   probability grows by Σ_{k<N} (1 − a)^k, `a` the visible fraction.
//! * [`HgrsEstimator::Resampled`] (unbiased): one of the m visible candidates chosen uniformly
//!   (reservoir sampling), its weight times m/N — resampled importance sampling with a visibility
//!   target (Talbot et al. 2005), i.e. the mean of the N one-draw estimates carried by one path.
//!
//!   With `hgrs_candidate_roulette` q < 1, once a candidate is visible each later one is drawn
//!   (and its shadow ray cast) only with probability q and then counts 1/q in the reservoir:
//!   E[Σ v_i] keeps every one-draw estimate's expectation, so the step stays unbiased, for about
//!   q·(N − first) fewer shadow rays where most candidates are visible.
//!
//! Cost: up to N shadow rays per vertex instead of one.

use super::Step;
use crate::sampling::Sampler;
use crate::settings::{Hgrs, HgrsEstimator};

/// One HGRS step from N draws of `candidate` (a one-draw hidden-geometry sample: `None` when it
/// contributes nothing).
#[inline]
pub fn sample(
    h: Hgrs,
    rng: &mut Sampler,
    mut candidate: impl FnMut(&mut Sampler) -> Option<Step>,
) -> Option<Step> {
    match h.estimator {
        HgrsEstimator::Rejection => (0..h.max_iterations).find_map(|_| candidate(rng)),
        HgrsEstimator::Resampled => {
            // Weighted reservoir over the candidates that are drawn: a candidate drawn with
            // probability q counts 1/q (Russian roulette after the first visible one).
            let mut chosen: Option<Step> = None;
            let mut total = 0.0f32;
            for _ in 0..h.max_iterations {
                let q = if chosen.is_some() { h.roulette } else { 1.0 };
                if q < 1.0 && rng.next_1d() >= q {
                    continue;
                }
                if let Some(c) = candidate(rng) {
                    let v = 1.0 / q;
                    total += v;
                    if rng.next_1d() * total < v {
                        chosen = Some(c);
                    }
                }
            }
            chosen.map(|c| Step {
                weight: c.weight * (total / h.max_iterations as f32),
                ..c
            })
        }
    }
}
