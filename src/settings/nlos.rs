//! The parameters of `transient_nlos_path` and `transient_nlos_path_rs` (mitransient-model §2 in
//! docs/mitransient-model.md), validated: the capture type, laser and hidden-geometry sampling, the
//! depth filters and, for `_rs`, Hidden Geometry Rejection Sampling (the technique itself is in
//! `integrator/hgrs.rs`).

use super::{accept_inert, max_depth, rr_depth, temporal_filter};
use crate::error::{NlosError, Result};
use crate::film::{Film, TemporalKernel};
use crate::props::Props;

/// Which points of the relay wall the laser illuminates (mitransient-model §4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CaptureType {
    /// One fixed laser spot (where the projector points).
    Single,
    /// The laser spot follows each scanned wall point.
    Confocal,
    /// Every laser point × every scan point.
    Exhaustive,
}

/// How `transient_nlos_path_rs` uses its N hidden-geometry draws (Tienda Hernando 2023, §3.1;
/// the estimators are in `integrator/hgrs.rs`).
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
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hgrs {
    /// Draws per vertex (N).
    pub max_iterations: u32,
    /// Estimator.
    pub estimator: HgrsEstimator,
    /// `hgrs_candidate_roulette`: once a vertex has a visible candidate, each later candidate of
    /// the resampled estimator is drawn and tested only with this probability (1: all are).
    pub roulette: f32,
}

impl Hgrs {
    fn parse(plugin: &str, max_iterations: i64, estimator: &str, roulette: f64) -> Result<Self> {
        if !(roulette > 0.0 && roulette <= 1.0) {
            return Err(NlosError::prop(
                plugin,
                "hgrs_candidate_roulette",
                format!("must be in (0, 1], got {roulette}"),
            ));
        }
        // Bounded so that one sample stays short enough for Ctrl-C to act within a poll.
        if !(1..=10_000).contains(&max_iterations) {
            return Err(NlosError::prop(
                plugin,
                "hgrs_max_iterations",
                format!("must be in [1, 10000], got {max_iterations}"),
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
        if roulette < 1.0 && estimator == HgrsEstimator::Rejection {
            return Err(NlosError::prop(
                plugin,
                "hgrs_candidate_roulette",
                "applies to hgrs_estimator='resampled' only (rejection stops at its first visible candidate)",
            ));
        }
        Ok(Self {
            max_iterations: max_iterations as u32,
            estimator,
            roulette: roulette as f32,
        })
    }
}

/// The parameters of `transient_nlos_path` (mitransient-model §2), validated.
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
    /// `nlos_sample_reuse`: share each light subpath among all scan points where the estimator
    /// allows it (`integrator/sample_reuse.rs` says where); off renders one path per scan point,
    /// as mitransient does.
    pub sample_reuse: bool,
    /// `nlos_visibility_guiding`: a shared light subpath's first hidden vertex is drawn from a
    /// distribution learnt from laser-spot visibility, mixed with the uniform one
    /// (`integrator/visibility_guide.rs`).
    pub visibility_guiding: bool,
}

impl NlosSettings {
    /// Read the integrator's properties; unknown ones are rejected.
    pub fn from_props(p: &Props) -> Result<Self> {
        let plugin = p.plugin.as_str();
        let max_depth = max_depth(p)?;
        let rr_depth = rr_depth(p)?;
        let filter_bounces = p.optional_count("filter_bounces", -1, 0)?;
        let filter_depth_raw = p.optional_count("filter_depth", -1, 0)?;
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
        let capture_type = match p
            .string_or_int("capture_type", "single")?
            .to_lowercase()
            .as_str()
        {
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
        let hgs_max_depth = p.optional_count("nlos_hidden_geometry_sampling_max_depth", -1, 1)?;
        let temporal_kernel = temporal_filter(p, 0.5)?;
        let hgrs = if plugin == "transient_nlos_path_rs" {
            Some(Hgrs::parse(
                plugin,
                p.int("hgrs_max_iterations", 10)?,
                &p.string("hgrs_estimator", "resampled")?,
                p.float("hgrs_candidate_roulette", 1.0)?,
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
        accept_inert(p)?;
        let s = Self {
            max_depth,
            rr_depth,
            filter_depth,
            discard_direct_paths: p.bool("discard_direct_paths", false)?,
            account_first_and_last_bounces: p.bool("account_first_and_last_bounces", false)?,
            capture_type,
            force_equal_illumination_scanning: p.bool("force_equal_illumination_scanning", true)?,
            illumination_scan_fov: p.float("illumination_scan_fov", 20.0)?,
            laser_sampling: p.bool("nlos_laser_sampling", hgrs.is_some())?,
            hidden_geometry_sampling: p.bool("nlos_hidden_geometry_sampling", hgrs.is_some())?,
            hgs_rroulette: p.bool("nlos_hidden_geometry_sampling_do_rroulette", false)?,
            hgs_includes_relay_wall: p
                .bool("nlos_hidden_geometry_sampling_includes_relay_wall", false)?,
            hgs_max_depth,
            hgrs,
            temporal_kernel,
            sample_reuse: p.bool("nlos_sample_reuse", true)?,
            visibility_guiding: p.bool("nlos_visibility_guiding", true)?,
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
                    roulette: 1.0,
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
                    // The roulette belongs to the resampled estimator: dropped on a switch to
                    // rejection.
                    if est == "rejection" {
                        1.0
                    } else {
                        cur.roulette as f64
                    },
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
            // Without a laser axis on the film, mitransient sums every laser point into the one
            // transient (tal 0.21 writes this for its per-laser-point exhaustive scans).
            (true, None) if self.force_equal_illumination_scanning => Ok(()),
            (true, None) => Err(NlosError::prop(
                "transient_hdr_film",
                "exhaustive_scan",
                "capture_type='exhaustive' needs exhaustive_scan=true with laser_scan_width/height (or force_equal_illumination_scanning, to sum the laser points)",
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
    pub fn keep(&self, depth: u32) -> bool {
        self.filter_depth.is_none_or(|f| depth == f) && (!self.discard_direct_paths || depth > 2)
    }
}
