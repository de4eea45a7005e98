//! Counts of work done while rendering.

/// Counts of rays traced, for progress and benchmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RayStats {
    /// Camera rays.
    pub camera_rays: u64,
    /// Shadow rays (one per light per hit with a non-black contribution).
    pub shadow_rays: u64,
    /// Rays spawned for specular reflection and transmission, and past
    /// material-less surfaces.
    pub secondary_rays: u64,
    /// Samples whose radiance was NaN and were set to black.
    pub nan_samples: u64,
    /// Samples whose radiance was infinite and were set to black.
    pub inf_samples: u64,
    /// Samples with negative luminance, set to black.
    pub negative_samples: u64,
}

impl RayStats {
    /// Adds another tile's counts.
    pub fn add(&mut self, o: &RayStats) {
        self.camera_rays += o.camera_rays;
        self.shadow_rays += o.shadow_rays;
        self.secondary_rays += o.secondary_rays;
        self.nan_samples += o.nan_samples;
        self.inf_samples += o.inf_samples;
        self.negative_samples += o.negative_samples;
    }

    /// All rays traced.
    pub fn total_rays(&self) -> u64 {
        self.camera_rays + self.shadow_rays + self.secondary_rays
    }
}
