//! `transient_nlos_path`: transient path tracing for NLOS captures with laser sampling and
//! hidden-geometry sampling (Royo et al. 2022, "Non-line-of-sight transient rendering",
//! Computers & Graphics 107; mitransient 1.3.1 as specified in mitransient-nlos-spec §2–3).
//!
//! Where mitransient 1.3.1 is wrong (spec §7) this integrator is physically right instead:
//! hidden-geometry sampling tests visibility, the 50/50 technique choice does not double the
//! estimate, and the capture's time origin ignores the shutter. See docs/compatibility.md.

use super::{AreaSampler, Splat, diffuse_f, max_depth, russian_roulette, temporal_filter};
use crate::capture::{Capture, Spot};
use crate::error::{NlosError, Result};
use crate::film::{Film, TemporalKernel};
use crate::geometry::{Interaction, shadow_segment};
use crate::math::{COS_EPS, Frame, Spectrum};
use crate::props::Props;
use crate::sampling::{Sampler, square_to_cosine_hemisphere};
use glam::Vec3A;

/// Which points of the relay wall the laser illuminates (spec §5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CaptureType {
    /// One fixed laser spot (where the projector points).
    Single,
    /// The laser spot follows each scanned wall point.
    Confocal,
    /// Every laser point × every scan point.
    Exhaustive,
}

/// How `transient_nlos_path_rs` uses its N hidden-geometry draws (thesis §3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HgrsEstimator {
    /// As the thesis publishes it: redraw until a point is visible (at most N tries) and weight the
    /// accepted point as for one draw. Biased upwards where part of the hidden geometry is not
    /// visible: an accepted point's probability grows by Σ_{k<N} (1 − a)^k, a the visible fraction.
    Rejection,
    /// Unbiased: draw N candidates, continue from one chosen uniformly among the visible ones, and
    /// multiply the weight by (visible count / N) — resampled importance sampling with a visibility
    /// target (Talbot et al. 2005), i.e. the mean of N one-draw estimates carried by one path.
    Resampled,
}

/// Hidden Geometry Rejection Sampling settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Hgrs {
    /// Draws per vertex (N).
    pub max_iterations: u32,
    /// Estimator.
    pub estimator: HgrsEstimator,
}

impl Hgrs {
    fn parse(plugin: &str, max_iterations: i64, estimator: &str) -> Result<Self> {
        if !(1..=1_000_000).contains(&max_iterations) {
            return Err(NlosError::prop(
                plugin,
                "hgrs_max_iterations",
                format!("must be in [1, 1000000], got {max_iterations}"),
            ));
        }
        let estimator = match estimator {
            "resampled" => HgrsEstimator::Resampled,
            "rejection" => HgrsEstimator::Rejection,
            other => {
                return Err(NlosError::prop(
                    plugin,
                    "hgrs_estimator",
                    format!("must be 'resampled' or 'rejection', got '{other}'"),
                ));
            }
        };
        Ok(Self {
            max_iterations: max_iterations as u32,
            estimator,
        })
    }
}

/// The parameters of `transient_nlos_path` (mitransient-nlos-spec §2), validated.
#[derive(Clone, Debug)]
pub struct NlosSettings {
    /// Longest path in vertices as mitransient counts it; `u32::MAX` for -1 (unbounded).
    pub max_depth: u32,
    /// Loop depth from which Russian roulette applies.
    pub rr_depth: u32,
    /// Keep only contributions whose depth equals this (`filter_bounces + 1`).
    pub filter_depth: Option<u32>,
    /// Keep only contributions with depth > 2.
    pub discard_direct_paths: bool,
    /// Add the sensor→wall and wall→laser legs to the optical path.
    pub account_first_and_last_bounces: bool,
    /// Capture type.
    pub capture_type: CaptureType,
    /// Exhaustive: laser grid = sensor grid.
    pub force_equal_illumination_scanning: bool,
    /// Exhaustive with unequal grids: x-FOV (degrees) of the virtual scanning projector.
    pub illumination_scan_fov: f64,
    /// Connect every vertex to the laser spot (true) or do NEE to the projector (false).
    pub laser_sampling: bool,
    /// Sample directions towards hidden geometry.
    pub hidden_geometry_sampling: bool,
    /// Choose hidden-geometry or BSDF sampling with probability 1/2 at each vertex.
    pub hgs_rroulette: bool,
    /// Let hidden-geometry sampling pick the relay wall too.
    pub hgs_includes_relay_wall: bool,
    /// Use hidden-geometry sampling only at loop depths below this.
    pub hgs_max_depth: Option<u32>,
    /// `transient_nlos_path_rs`: rejection sampling of hidden geometry.
    pub hgrs: Option<Hgrs>,
    /// `temporal_filter='gaussian'` with `gaussian_stddev` (bins), applied to the film.
    pub temporal_kernel: Option<TemporalKernel>,
}

fn depth_param(p: &Props, key: &str, default: i64) -> Result<Option<u32>> {
    let v = p.int(key, default)?;
    match v {
        -1 => Ok(None),
        v if v >= 0 && v < u32::MAX as i64 => Ok(Some(v as u32)),
        v => Err(NlosError::prop(
            &p.plugin,
            key,
            format!("must be -1 or non-negative, got {v}"),
        )),
    }
}

impl NlosSettings {
    /// Read the integrator's properties; unknown ones are rejected.
    pub fn from_props(p: &Props) -> Result<Self> {
        let plugin = p.plugin.as_str();
        let max_depth = max_depth(p, 6)?;
        let rr_depth = p.int("rr_depth", 5)?;
        if rr_depth <= 0 {
            return Err(NlosError::prop(plugin, "rr_depth", "must be > 0"));
        }
        let filter_bounces = depth_param(p, "filter_bounces", -1)?;
        let filter_depth_raw = depth_param(p, "filter_depth", -1)?;
        let filter_depth = match (filter_bounces, filter_depth_raw) {
            (Some(_), Some(_)) => {
                return Err(NlosError::prop(
                    plugin,
                    "filter_depth",
                    "set either filter_bounces or filter_depth, not both",
                ));
            }
            (Some(b), None) => Some(b + 1),
            (None, d) => d,
        };
        let capture_type = match p.string("capture_type", "single")?.to_lowercase().as_str() {
            "single" | "1" => CaptureType::Single,
            "confocal" | "2" => CaptureType::Confocal,
            "exhaustive" | "3" => CaptureType::Exhaustive,
            other => {
                return Err(NlosError::prop(
                    plugin,
                    "capture_type",
                    format!("must be 'single', 'confocal' or 'exhaustive', got '{other}'"),
                ));
            }
        };
        let hgs_max_depth = match p.int("nlos_hidden_geometry_sampling_max_depth", -1)? {
            -1 => None,
            v if v > 0 && v < u32::MAX as i64 => Some(v as u32),
            v => {
                return Err(NlosError::prop(
                    plugin,
                    "nlos_hidden_geometry_sampling_max_depth",
                    format!("must be -1 or positive, got {v}"),
                ));
            }
        };
        let temporal_kernel = temporal_filter(p, 0.5)?;
        let hgrs = if plugin == "transient_nlos_path_rs" {
            Some(Hgrs::parse(
                plugin,
                p.int("hgrs_max_iterations", 10)?,
                &p.string("hgrs_estimator", "resampled")?,
            )?)
        } else {
            None
        };
        if p.bool("camera_unwarp", false)? {
            return Err(NlosError::prop(
                plugin,
                "camera_unwarp",
                "is not supported for an nlos_capture_meter",
            ));
        }
        // Accepted because mitransient accepts them; they have no effect there either.
        p.bool("discard_direct_light", false)?;
        p.bool("hide_emitters", false)?;
        p.int("block_size", 0)?;
        p.int("samples_per_pass", -1)?;
        let s = Self {
            max_depth,
            rr_depth: rr_depth.min(u32::MAX as i64) as u32,
            filter_depth,
            discard_direct_paths: p.bool("discard_direct_paths", false)?,
            account_first_and_last_bounces: p.bool("account_first_and_last_bounces", false)?,
            capture_type,
            force_equal_illumination_scanning: p.bool("force_equal_illumination_scanning", true)?,
            illumination_scan_fov: p.float("illumination_scan_fov", 20.0)?,
            laser_sampling: p.bool("nlos_laser_sampling", false)?,
            hidden_geometry_sampling: p.bool("nlos_hidden_geometry_sampling", false)?,
            hgs_rroulette: p.bool("nlos_hidden_geometry_sampling_do_rroulette", false)?,
            hgs_includes_relay_wall: p
                .bool("nlos_hidden_geometry_sampling_includes_relay_wall", false)?,
            hgs_max_depth,
            hgrs,
            temporal_kernel,
        };
        p.finish()?;
        if s.hgrs.is_some() && !s.hidden_geometry_sampling {
            return Err(NlosError::prop(
                plugin,
                "nlos_hidden_geometry_sampling",
                "transient_nlos_path_rs rejection-samples hidden geometry: it needs nlos_hidden_geometry_sampling=true",
            ));
        }
        if !(s.illumination_scan_fov > 0.0 && s.illumination_scan_fov < 180.0) {
            return Err(NlosError::prop(
                plugin,
                "illumination_scan_fov",
                "must be in (0, 180) degrees",
            ));
        }
        if s.capture_type != CaptureType::Single && !s.laser_sampling {
            return Err(NlosError::prop(
                plugin,
                "capture_type",
                "confocal and exhaustive captures need nlos_laser_sampling=true (mitransient silently ignores capture_type without it)",
            ));
        }
        Ok(s)
    }

    /// The same settings under another integrator name (`transient_nlos_path` or `..._rs`), with
    /// optional HGRS parameters, as `render(..., integrator=...)` does.
    pub fn switched(
        &self,
        name: &str,
        max_iterations: Option<i64>,
        estimator: Option<&str>,
    ) -> Result<Self> {
        let mut s = self.clone();
        match name {
            "transient_nlos_path" => {
                if max_iterations.is_some() || estimator.is_some() {
                    return Err(NlosError::prop(
                        "render",
                        "integrator",
                        "hgrs_* options need integrator='transient_nlos_path_rs'",
                    ));
                }
                s.hgrs = None;
            }
            "transient_nlos_path_rs" => {
                let cur = self.hgrs.unwrap_or(Hgrs {
                    max_iterations: 10,
                    estimator: HgrsEstimator::Resampled,
                });
                let est = match estimator {
                    Some(e) => e,
                    None if cur.estimator == HgrsEstimator::Rejection => "rejection",
                    None => "resampled",
                };
                s.hgrs = Some(Hgrs::parse(
                    name,
                    max_iterations.unwrap_or(cur.max_iterations as i64),
                    est,
                )?);
                if !s.hidden_geometry_sampling {
                    return Err(NlosError::prop(
                        name,
                        "nlos_hidden_geometry_sampling",
                        "transient_nlos_path_rs needs nlos_hidden_geometry_sampling=true",
                    ));
                }
            }
            other => {
                return Err(NlosError::prop(
                    "render",
                    "integrator",
                    format!(
                        "must be 'transient_nlos_path' or 'transient_nlos_path_rs', got '{other}'"
                    ),
                ));
            }
        }
        Ok(s)
    }

    /// Check the settings against the film.
    pub fn check(&self, film: &Film) -> Result<()> {
        let exhaustive = self.capture_type == CaptureType::Exhaustive;
        match (exhaustive, film.laser_scan) {
            (true, None) => Err(NlosError::prop(
                "transient_hdr_film",
                "exhaustive_scan",
                "capture_type='exhaustive' needs exhaustive_scan=true with laser_scan_width/height",
            )),
            (false, Some(_)) => Err(NlosError::prop(
                "transient_hdr_film",
                "exhaustive_scan",
                "exhaustive_scan=true needs the integrator's capture_type='exhaustive'",
            )),
            (true, Some((lw, lh)))
                if self.force_equal_illumination_scanning
                    && (lw, lh) != (film.width, film.height) =>
            {
                Err(NlosError::prop(
                    "transient_hdr_film",
                    "laser_scan_width",
                    format!(
                        "with force_equal_illumination_scanning the laser grid ({lw}x{lh}) must equal the film ({}x{})",
                        film.width, film.height
                    ),
                ))
            }
            _ => Ok(()),
        }
    }

    /// Does a contribution of this depth pass `filter_bounces` and `discard_direct_paths`?
    #[inline]
    fn keep(&self, depth: u32) -> bool {
        self.filter_depth.is_none_or(|f| depth == f) && (!self.discard_direct_paths || depth > 2)
    }
}

impl Capture<'_> {
    /// Laser sampling (spec §3.4 + §3.5): connect vertex `x` (incoming direction `wi`, throughput
    /// `beta`, path length `opl`) to the laser spot, whose NEE to the laser is cached in `spot`.
    #[inline]
    fn connect_spot(
        &self,
        x: &Interaction,
        wi: Vec3A,
        beta: Spectrum,
        opl: f64,
        spot: &Spot,
        slot: usize,
        out: &mut impl FnMut(Splat),
    ) {
        if spot.radiance == Spectrum::ZERO {
            return;
        }
        let u = spot.it.p - x.p;
        let r2 = u.length_squared();
        let r = r2.sqrt();
        let w = u / r;
        let cos_z = spot.it.ns.dot(-w);
        if cos_z <= 0.0 {
            return;
        }
        let Some(f) = diffuse_f(
            self.rho[self.scene.shapes[x.shape as usize].bsdf],
            x.ns,
            wi,
            w,
        ) else {
            return;
        };
        let (o, d, tmax) = shadow_segment(x, spot.it.p);
        if !self.scene.accel.unoccluded(o, d, 0.0, tmax) {
            return;
        }
        let value = beta * f * spot.radiance * (cos_z / r2);
        out((slot, opl + r as f64 + spot.last_leg, value));
    }

    /// Next-event estimation straight to the projector (spec §3.5), used without laser sampling.
    #[inline]
    fn nee_laser(
        &self,
        x: &Interaction,
        wi: Vec3A,
        beta: Spectrum,
        opl: f64,
        out: &mut impl FnMut(Splat),
    ) {
        let weight = self.laser.weight_at(x.p);
        if weight == 0.0 {
            return;
        }
        let u = self.laser.origin - x.p;
        let r = u.length();
        let Some(f) = diffuse_f(
            self.rho[self.scene.shapes[x.shape as usize].bsdf],
            x.ns,
            wi,
            u / r,
        ) else {
            return;
        };
        let (o, d, tmax) = shadow_segment(x, self.laser.origin);
        if !self.scene.accel.unoccluded(o, d, 0.0, tmax) {
            return;
        }
        let last = if self.settings.account_first_and_last_bounces {
            r as f64
        } else {
            0.0
        };
        out((0, opl + last, beta * f * self.irradiance * weight));
    }

    /// One hidden-geometry sample from `x` (spec §3.3) with the visibility test mitransient lacks:
    /// an invalid or occluded draw is a zero-valued sample of the area integral. Returns the next
    /// vertex, its distance and the weight f·A_total·cosθ_y/r².
    #[inline]
    fn hidden_candidate(
        &self,
        hg: &AreaSampler,
        x: &Interaction,
        wi: Vec3A,
        rho: Spectrum,
        rng: &mut Sampler,
    ) -> Option<(Interaction, f32, Spectrum)> {
        let y = hg.sample(self.scene, rng.next_1d(), rng.next_2d());
        let v = y.p - x.p;
        let r2 = v.length_squared();
        let r = r2.sqrt();
        let w = v / r;
        let cos_g = y.ns.dot(-w);
        if x.ng.dot(w) <= COS_EPS || cos_g <= COS_EPS || r2 / (hg.total_area() * cos_g) <= COS_EPS {
            return None;
        }
        let f = diffuse_f(rho, x.ns, wi, w)?;
        let (o, d, tmax) = shadow_segment(x, y.p);
        if !self.scene.accel.unoccluded(o, d, 0.0, tmax) {
            return None;
        }
        Some((y, r, f * (hg.total_area() * cos_g / r2)))
    }

    /// Hidden-geometry sampling, plain (one draw) or with rejection (thesis §3.1, HGRS).
    fn sample_hidden(
        &self,
        hg: &AreaSampler,
        x: &Interaction,
        wi: Vec3A,
        rho: Spectrum,
        rng: &mut Sampler,
    ) -> Option<(Interaction, f32, Spectrum)> {
        let Some(h) = self.settings.hgrs else {
            return self.hidden_candidate(hg, x, wi, rho, rng);
        };
        match h.estimator {
            // Redraw until a visible point turns up; weight as for one draw (biased, as published).
            HgrsEstimator::Rejection => {
                (0..h.max_iterations).find_map(|_| self.hidden_candidate(hg, x, wi, rho, rng))
            }
            // Keep one of the visible candidates uniformly (reservoir sampling), weight × m/N.
            HgrsEstimator::Resampled => {
                let mut chosen = None;
                let mut m = 0u32;
                for _ in 0..h.max_iterations {
                    if let Some(c) = self.hidden_candidate(hg, x, wi, rho, rng) {
                        m += 1;
                        if rng.next_1d() * (m as f32) < 1.0 {
                            chosen = Some(c);
                        }
                    }
                }
                chosen.map(|(y, r, w)| (y, r, w * (m as f32 / h.max_iterations as f32)))
            }
        }
    }

    /// Trace one path from the scan point of `pixel` (spec §3.2–3.3), emitting every contribution.
    pub fn trace(&self, pixel: usize, rng: &mut Sampler, out: &mut impl FnMut(Splat)) {
        let st = self.settings;
        let Some(x1) = self.sensor_targets[pixel] else {
            return;
        };
        let s = self.scene.meter.origin;
        let mut it = x1;
        let mut wi = (s - x1.p).normalize();
        let mut opl = if st.account_first_and_last_bounces {
            (s - x1.p).length() as f64
        } else {
            0.0
        };
        let mut beta = Spectrum::ONE;
        let mut depth: u32 = 0;
        // Contribution depth of a vertex at loop depth d: d + 2 with laser sampling (the spot is
        // an extra vertex), d with NEE (spec §2, filter_bounces).
        let offset = if st.laser_sampling { 2 } else { 0 };
        loop {
            if depth.saturating_add(1) >= st.max_depth {
                break;
            }
            // ---- Emitter sampling
            if st.keep(depth + offset) {
                if st.laser_sampling {
                    match st.capture_type {
                        CaptureType::Single => {
                            self.connect_spot(&it, wi, beta, opl, &self.spots[0], 0, out)
                        }
                        CaptureType::Confocal => {
                            self.connect_spot(&it, wi, beta, opl, &self.spots[pixel], 0, out)
                        }
                        CaptureType::Exhaustive => {
                            for (slot, spot) in self.spots.iter().enumerate() {
                                self.connect_spot(&it, wi, beta, opl, spot, slot, out);
                            }
                        }
                    }
                } else {
                    self.nee_laser(&it, wi, beta, opl, out);
                }
            }
            // No later vertex can pass filter_bounces: stop early (changes no result).
            if st.filter_depth.is_some_and(|f| depth + 1 + offset > f) {
                break;
            }
            // ---- Direction sampling: hidden geometry or the BSDF
            let rho = self.rho[self.scene.shapes[it.shape as usize].bsdf];
            let mut use_hgs = self.hidden.is_some() && st.hgs_max_depth.is_none_or(|m| depth < m);
            if use_hgs && st.hgs_rroulette {
                // One of the two techniques at random; each is unbiased on its own, so the
                // mixture is too (mitransient also divides by 1/2 here and doubles the result).
                use_hgs = rng.next_1d() < 0.5;
            }
            let (next, dist, weight) = if use_hgs {
                let Some(hg) = &self.hidden else { break };
                let Some(step) = self.sample_hidden(hg, &it, wi, rho, rng) else {
                    break;
                };
                step
            } else {
                // Cosine-weighted BSDF sampling: weight f/pdf = ρ.
                if it.ns.dot(wi) <= 0.0 {
                    break;
                }
                let wo = Frame::new(it.ns).to_world(square_to_cosine_hemisphere(rng.next_2d()));
                let o = it.offset_origin(wo);
                let Some((_, hit)) = self.scene.intersect(o, wo, f32::INFINITY) else {
                    break;
                };
                (hit, (hit.p - it.p).length(), rho)
            };
            beta *= weight;
            // ---- Russian roulette (spec §3.3 step 7)
            if !russian_roulette(&mut beta, depth, st.rr_depth, rng) {
                break;
            }
            wi = (it.p - next.p).normalize();
            opl += dist as f64;
            it = next;
            depth += 1;
        }
    }
}
