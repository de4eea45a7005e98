//! Ray counts on the wire.

use crate::v1;
use farm_common::stats::RayStats;

impl From<&RayStats> for v1::RayStats {
    fn from(s: &RayStats) -> Self {
        v1::RayStats {
            camera_rays: s.camera_rays,
            shadow_rays: s.shadow_rays,
            secondary_rays: s.secondary_rays,
            nan_samples: s.nan_samples,
            inf_samples: s.inf_samples,
            negative_samples: s.negative_samples,
        }
    }
}

impl From<&v1::RayStats> for RayStats {
    fn from(s: &v1::RayStats) -> Self {
        RayStats {
            camera_rays: s.camera_rays,
            shadow_rays: s.shadow_rays,
            secondary_rays: s.secondary_rays,
            nan_samples: s.nan_samples,
            inf_samples: s.inf_samples,
            negative_samples: s.negative_samples,
        }
    }
}
