//! The next vertex at a hidden vertex by one-sample multiple importance sampling of
//! hidden-geometry sampling and BSDF sampling (Veach 1997, "Robust Monte Carlo methods for light
//! transport simulation", §9.2.4, the balance heuristic).
//!
//! Hidden-geometry sampling draws the next vertex uniformly over the hidden area: the right
//! technique from the relay wall, which sees the hidden scene small and far away, and the one
//! mitransient uses at every vertex. From a vertex on the hidden geometry itself, most light comes
//! from what is near — a 1/r² peak that a point drawn uniformly over the hidden area almost never
//! reaches while visible; inside clutter (a soup of small crossing triangles) hidden-geometry
//! sampling alone rendered none of the light the surfaces exchange (docs/compatibility.md). BSDF
//! sampling finds it at once but misses small far shapes. So beyond the first vertex (and on light
//! subpaths wherever the light's side is known) one of the two draws the next vertex — hidden
//! geometry with probability [`HGS_SHARE`] — and the step is weighted by the mixture's density
//! over the hidden area, which keeps it unbiased for the same integral as a hidden-geometry step
//! while each technique covers what the other misses. HGRS (`transient_nlos_path_rs`) and the
//! technique roulette (`nlos_hidden_geometry_sampling_do_rroulette`) keep their own steps.

use super::nlos::HiddenEdge;
use super::{NlosTracer, Step};
use crate::geometry::Interaction;
use crate::sampling::Sampler;
use crate::scene::AreaSampler;
use glam::Vec3A;

/// Share of hidden-geometry sampling in the mixture that draws the next vertex at a hidden vertex
/// ([`NlosTracer::mixture_draw`]); BSDF sampling draws the rest.
pub const HGS_SHARE: f32 = 0.5;

impl HiddenEdge {
    /// The area density with which the mixture of [`NlosTracer::mixture_draw`] picks the edge's
    /// far end, of geometric normal `far_ng`: HGS_SHARE/A where hidden-geometry sampling takes the
    /// step, plus (1 − HGS_SHARE) times the BSDF's solid-angle density `bsdf_pdf` of the direction
    /// towards it, converted to area by |cos θ|/r² (Veach 1997, §9.2.4: the balance heuristic's
    /// one-sample estimator divides by this sum).
    #[inline]
    fn mixture_density(&self, area: f32, bsdf_pdf: f32, far_ng: Vec3A) -> f32 {
        let hgs = if self.drawable { HGS_SHARE / area } else { 0.0 };
        hgs + (1.0 - HGS_SHARE) * bsdf_pdf * far_ng.dot(self.w).abs() / self.r2
    }
}

impl NlosTracer<'_> {
    /// A draw of the next vertex from the hidden vertex `x` (`wi` its direction back along the
    /// path, or towards the light on a light subpath) by one-sample multiple importance sampling of
    /// two techniques (Veach 1997, §9.2.4): with probability [`HGS_SHARE`] a hidden-geometry draw
    /// (uniform by area), else BSDF sampling (what the sampled ray hits, if it is hidden geometry),
    /// and whether hidden-geometry sampling drew it (its visibility is then still to test). Each
    /// covers what the other misses: BSDF sampling the light that nearby surfaces exchange (a 1/r²
    /// peak that uniform area draws almost never hit while visible), hidden-geometry sampling small
    /// or far shapes. The caller weights the step by [`HiddenEdge::mixture_density`].
    #[inline]
    fn mixture_draw(
        &self,
        hg: &AreaSampler,
        x: &Interaction,
        wi: Vec3A,
        rng: &mut Sampler,
    ) -> Option<(Interaction, bool)> {
        if rng.next_1d() < HGS_SHARE {
            return Some((hg.sample(self.scene, rng), true));
        }
        Some((self.bsdf_step(x, wi, rng, None, Some(hg))?.next, false))
    }

    /// The next vertex y from the hidden vertex `from` by the mixture of [`Self::mixture_draw`]
    /// (`back`: the direction back along the path), weighted by the terms of a hidden-geometry
    /// step over the mixture's area density at y: f·cos θ / (r²·p), unbiased for the same area
    /// integral. On a path from a scan point (`from_light` false) the step is `from` → y, f is
    /// `from`'s BSDF from `back` towards y and θ is at y. On a light subpath (`from_light`) it is
    /// the same step seen from the light's end: the edge runs y → `from` (y on the scan points'
    /// side), f is `from`'s BSDF from y towards the light and θ is at `from`. With `onto_delta`
    /// the step ends unless y lies on a surface whose BSDF is all delta (a delta prefix's step,
    /// `sample_reuse::delta_prefix`).
    #[inline]
    pub(super) fn mixture_step(
        &self,
        hg: &AreaSampler,
        from: &Interaction,
        back: Vec3A,
        from_light: bool,
        onto_delta: bool,
        rng: &mut Sampler,
    ) -> Option<Step> {
        let area = hg.total_area();
        let (y, drawn) = self.mixture_draw(hg, from, back, rng)?;
        if onto_delta && !self.delta[y.shape as usize].0 {
            return None;
        }
        // The edge from the scan points' side.
        let (near, far) = if from_light { (&y, from) } else { (from, &y) };
        let e = self
            .facing_edge(near, far, area)
            .filter(|e| e.drawable || !drawn)?;
        // The direction from `from` towards y, and the BSDF's pair of directions.
        let out = if from_light { -e.w } else { e.w };
        let (wi, wo) = if from_light { (out, back) } else { (back, out) };
        let bsdf = self.bsdf(from);
        let f = bsdf.eval(from.ns, wi, wo)?;
        if drawn && !self.scene.visible_to(near, far) {
            return None;
        }
        let density = e.mixture_density(area, bsdf.pdf(from.ns, back, out), y.ng);
        // Zero only for a BSDF draw whose recomputed direction falls off its lobe (rounding) or
        // that grazes y: a sample of nothing.
        if !(density > 0.0) {
            return None;
        }
        Some(Step {
            next: y,
            dist: e.r,
            weight: f * (e.cos_y / e.r2 / density),
            eta: 1.0,
        })
    }
}
