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
            let mut chosen: Option<Step> = None;
            let mut m = 0u32;
            for _ in 0..h.max_iterations {
                if let Some(c) = candidate(rng) {
                    m += 1;
                    if rng.next_1d() * (m as f32) < 1.0 {
                        chosen = Some(c);
                    }
                }
            }
            chosen.map(|c| Step {
                weight: c.weight * (m as f32 / h.max_iterations as f32),
                ..c
            })
        }
    }
}
