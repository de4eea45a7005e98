//! Integrators. pbrt-v3's Whitted integrator is the one this farm renders with.

mod whitted;

pub use whitted::{RayStats, Whitted};
