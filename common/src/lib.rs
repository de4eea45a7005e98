//! Types shared by the farm's coordinator and workers: geometry with
//! pbrt-v3's floating-point error bounds, RGB spectra, the serializable
//! scene description that the coordinator's parser produces and the workers
//! build from, and the film tiling both sides agree on.
#![warn(missing_docs)]

/// CIE matching functions and conversions of sampled spectra to RGB.
pub mod cie;
/// Film geometry, tile layout and film tiles.
pub mod film;
/// Points, vectors, rays, bounds and transforms.
pub mod geometry;
/// Typed identifiers.
pub mod ids;
/// The RGB image type, its readers and writers, and image metrics.
pub mod image;
/// Floats as little-endian bytes.
pub mod le;
/// Transcendental functions with the same bits on every host.
pub mod math;
/// pbrt-v3's PCG32 random number generator.
pub mod rng;
/// The scene description: entities, parameters and file locations.
pub mod scene;
/// RGB spectra.
pub mod spectrum;
/// Ray counts.
pub mod stats;

/// What a caught panic said (`std::panic::catch_unwind`'s payload), or
/// "unknown panic" when it was neither a `&str` nor a `String`.
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".to_string())
}

/// Asks for every cache line of `v` ahead of its use: a hint only, which
/// changes nothing the program can see (nothing where the CPU has no such
/// hint here).
#[inline]
pub fn prefetch<T>(v: &[T]) {
    #[cfg(target_arch = "x86_64")]
    {
        let (start, end) = (v.as_ptr() as usize, v.as_ptr() as usize + std::mem::size_of_val(v));
        let mut line = start & !63;
        while line < end {
            // SAFETY: a prefetch never faults, whatever the address, and
            // reads or writes nothing.
            unsafe {
                use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
                _mm_prefetch::<_MM_HINT_T0>(line as *const i8);
            }
            line += 64;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = v;
}

pub use geometry::{Bounds2i, Bounds3f, Point2i, Ray, Transform, Vec2, Vec3};
pub use spectrum::Spectrum;
