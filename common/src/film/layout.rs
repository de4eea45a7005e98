//! A scene's film layout, computed once from its description by the one
//! function both sides call: the coordinator to split a job into tiles and
//! to know its samples per pixel, the renderer to render exactly those
//! tiles. It holds pbrt-v3's rules for the pieces that decide the layout:
//! each filter's default radius, and how each sampler rounds its sample
//! count (`MakeFilter`, `MakeSampler` and the `Create*` functions).

use super::FilmGeometry;
use crate::geometry::Vec2;
use crate::scene::{Entity, Params, SceneDescription, Warning};

/// The sampler a scene asked for (unknown names are Halton, as pbrt-v3's
/// default).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SamplerKind {
    /// `"halton"` (and any unknown name).
    Halton,
    /// `"sobol"`.
    Sobol,
    /// `"02sequence"` / `"lowdiscrepancy"`.
    ZeroTwoSequence,
    /// `"maxmindist"`.
    MaxMinDist,
    /// `"stratified"`.
    Stratified,
    /// `"random"`.
    Random,
}

impl SamplerKind {
    /// Whether a pixel's samples depend only on the pixel and their index
    /// (Halton and Sobol'), so a render can stop and later continue each
    /// pixel's sequence; the others draw from a generator per tile.
    #[inline]
    pub fn continues_sequence(self) -> bool {
        matches!(self, SamplerKind::Halton | SamplerKind::Sobol)
    }

    /// The sampler a scene's `Sampler` directive names (Halton when it
    /// names none, or one pbrt-v3 does not have).
    pub fn of(name: &str) -> SamplerKind {
        SamplerKind::named(name).0
    }

    /// The sampler `name` names, and whether pbrt-v3 has one of that name
    /// (otherwise Halton).
    pub fn named(name: &str) -> (SamplerKind, bool) {
        match name {
            "halton" => (SamplerKind::Halton, true),
            "sobol" => (SamplerKind::Sobol, true),
            "lowdiscrepancy" | "02sequence" => (SamplerKind::ZeroTwoSequence, true),
            "maxmindist" => (SamplerKind::MaxMinDist, true),
            "stratified" => (SamplerKind::Stratified, true),
            "random" => (SamplerKind::Random, true),
            _ => (SamplerKind::Halton, false),
        }
    }
}

/// The most samples per pixel the max-min-distance sampler has matrices for.
pub const MAX_MIN_DIST_MAX_SPP: i64 = 1 << 16;

/// Which half of its pixel's samples a sample belongs to. Each half must be
/// spread over the whole pixel, or the halves' difference measures the
/// image's gradient instead of its noise (Halton's even and odd samples fall
/// in the left and right halves of a pixel).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Halves {
    /// The first and second halves of the pixel's sample sequence (Halton,
    /// Sobol' and the random sampler: the sequence's first half covers the
    /// pixel, and the second fills its gaps).
    ByIndex {
        /// Samples in the first half.
        half: u32,
    },
    /// The (0,2)-sequence sampler shuffles its points, so the sequence's
    /// halves are random subsets. Its unshuffled first and second halves
    /// are each a (0, m−1, 2)-net, and they differ in the m-th binary digit
    /// of the x offset (2^m samples, scrambling only flips which is which),
    /// so that digit splits the points as the sequence would.
    ByPosition {
        /// Samples per pixel (a power of two).
        spp: f32,
    },
    /// The stratified sampler shuffles its jittered strata; the strata of
    /// a checkerboard's two colours are each spread over the whole pixel.
    ByStratum {
        /// Strata across a pixel.
        nx: f32,
        /// Strata down a pixel.
        ny: f32,
    },
}

impl Halves {
    /// How `kind`'s `spp` samples split (`strata`: the stratified sampler's
    /// strata across and down).
    pub fn of(kind: SamplerKind, spp: u32, strata: (usize, usize)) -> Halves {
        match kind {
            SamplerKind::ZeroTwoSequence if spp.is_power_of_two() && spp > 1 => {
                Halves::ByPosition { spp: spp as f32 }
            }
            SamplerKind::Stratified => {
                Halves::ByStratum { nx: strata.0 as f32, ny: strata.1 as f32 }
            }
            _ => Halves::ByIndex { half: spp / 2 },
        }
    }

    /// Whether sample `index` at offset `o` in its pixel ([0, 1)²)
    /// belongs to the second half.
    #[inline]
    pub fn is_second(self, index: u32, o: Vec2) -> bool {
        match self {
            Halves::ByIndex { half } => index >= half,
            Halves::ByPosition { spp } => ((o.x * spp) as u32) & 1 == 1,
            Halves::ByStratum { nx, ny } => (((o.x * nx) as u32) + ((o.y * ny) as u32)) & 1 == 1,
        }
    }
}

/// Everything about a render that follows from its film, filter and
/// sampler directives before anything is built.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmLayout {
    /// Pixels, samples and tiles, with the radius of the filter used.
    pub geometry: FilmGeometry,
    /// The sampler.
    pub sampler: SamplerKind,
    /// Samples per pixel as the sampler is built with them (pbrt-v3's
    /// 64-bit count, after rounding).
    pub samples: i64,
    /// The stratified sampler's strata across and down (`samples` is their
    /// product); (samples, 1) for the other samplers.
    pub strata: (usize, usize),
}

impl FilmLayout {
    /// Samples per pixel.
    pub fn spp(&self) -> u32 {
        self.samples as u32
    }

    /// How a pixel's samples split into the two halves the film keeps
    /// apart for the render's estimate of its own error.
    pub fn halves(&self) -> Halves {
        Halves::of(self.sampler, self.spp(), self.strata)
    }
}

/// Default filter radius of each pbrt-v3 filter; unknown names are the box
/// filter pbrt-v3 falls back to.
pub fn default_filter_radius(name: &str) -> f32 {
    match name {
        "gaussian" | "mitchell" | "triangle" => 2.0,
        "sinc" => 4.0,
        _ => 0.5,
    }
}

/// The radius a `PixelFilter` directive named `name` with parameters `p`
/// gives its filter (`xwidth`, `ywidth`, defaulting by name).
pub fn filter_radius(name: &str, p: &Params) -> Vec2 {
    let d = default_filter_radius(name);
    Vec2::new(p.float("xwidth", d), p.float("ywidth", d))
}

/// pbrt-v3 `IsPowerOf2` on a sample count.
pub fn is_power_of_2(v: i64) -> bool {
    v > 0 && v & (v - 1) == 0
}

/// The smallest power of two `>= v` (pbrt-v3 `RoundUpPow2`, for `v >= 1`).
pub fn round_up_pow2(v: i64) -> i64 {
    (v.max(1) as u64).next_power_of_two() as i64
}

/// The largest render a farm accepts, checked against a scene's film before
/// anything is allocated for it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Pixels of the film (`xresolution` × `yresolution`).
    pub max_pixels: u64,
    /// Samples per pixel.
    pub max_spp: u64,
    /// Samples in all: the film's sample pixels × samples per pixel.
    pub max_samples: u64,
}

impl Default for Limits {
    /// 8192² pixels (a 2 GiB film), 2^20 samples per pixel, 2^40 samples.
    fn default() -> Self {
        Limits { max_pixels: 1 << 26, max_spp: 1 << 20, max_samples: 1 << 40 }
    }
}

/// A film no render can have, or one over the [`Limits`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FilmError {
    /// A film or sample count over the limits, with how much it would need.
    #[error("the job is too large: {0}")]
    TooLarge(String),
    /// A resolution below one pixel (pbrt-v3 would render nothing).
    #[error(
        "{loc}: \"integer {name}\" is {value}: a film needs at least one pixel across and down"
    )]
    NoPixels {
        /// Where the `Film` directive is.
        loc: crate::scene::FileLoc,
        /// `xresolution` or `yresolution`.
        name: &'static str,
        /// The value given.
        value: i32,
    },
}

/// The longest side a film may have, whatever the limits: beyond it the
/// tile arithmetic would overflow.
const MAX_SIDE: u64 = 1 << 30;

/// [`layout`], refused with a message saying how much the job would need
/// when its film or its samples are over `limits`, or naming the `Film`
/// directive when a resolution is below one pixel. The film's resolution
/// is checked before its geometry is computed.
pub fn checked_layout(
    desc: &SceneDescription,
    spp_override: Option<u32>,
    limits: &Limits,
) -> Result<(FilmLayout, Vec<Warning>), FilmError> {
    let fp = Params::new(&desc.film.params);
    let side = |name: &'static str, default: i32| match fp.int(name, default) {
        v if v < 1 => Err(FilmError::NoPixels { loc: desc.film.loc.clone(), name, value: v }),
        v => Ok(v as u64),
    };
    let (x, y) = (side("xresolution", 1280)?, side("yresolution", 720)?);
    let pixels = x * y;
    if x > MAX_SIDE || y > MAX_SIDE || pixels > limits.max_pixels {
        let bytes = pixels as f64 * std::mem::size_of::<super::Pixel>() as f64;
        return Err(FilmError::TooLarge(format!(
            "the film has {pixels} pixels ({x}×{y}), over the limit of {} (--max-pixels); its sums alone would take {:.1} GB",
            limits.max_pixels,
            bytes / 1e9
        )));
    }
    let (l, warnings) = layout(desc, spp_override);
    let spp = l.samples.max(0) as u64;
    if spp > limits.max_spp {
        return Err(FilmError::TooLarge(format!(
            "{spp} samples per pixel are over the limit of {} (--max-spp)",
            limits.max_spp
        )));
    }
    let b = l.geometry.sample_bounds;
    let sample_pixels = b.width().max(0) as u64 * b.height().max(0) as u64;
    match sample_pixels.checked_mul(spp) {
        Some(n) if n <= limits.max_samples => Ok((l, warnings)),
        n => Err(FilmError::TooLarge(format!(
            "{} samples ({sample_pixels} pixels with the filter's margin × {spp} spp) are over the limit of {} (--max-samples)",
            n.map_or_else(|| "more than 2^64".to_string(), |n| n.to_string()),
            limits.max_samples
        ))),
    }
}

/// The film layout of `desc` with `spp_override` samples per pixel instead
/// of the sampler's count (for stratified: the most nearly square grid with
/// that many cells). The warnings are the `Film` directive's unused
/// parameters and the sampler's roundings of its count, as pbrt-v3 words
/// them; the renderer reports the filter's and sampler's other parameters.
pub fn layout(desc: &SceneDescription, spp_override: Option<u32>) -> (FilmLayout, Vec<Warning>) {
    let (geometry, mut warnings) = FilmGeometry::from_description(desc);
    let params = Params::new(&desc.sampler.params);
    let (sampler, samples, strata) =
        sample_count(&desc.sampler, &params, spp_override, &mut warnings);
    (FilmLayout { geometry, sampler, samples, strata }, warnings)
}

/// The sampler `entity` names, its samples per pixel read from `params`
/// (the entity's) with `spp_override` applied and pbrt-v3's rounding (with
/// its warnings), and for stratified its strata across and down.
pub fn sample_count(
    entity: &Entity,
    params: &Params,
    spp_override: Option<u32>,
    warnings: &mut Vec<Warning>,
) -> (SamplerKind, i64, (usize, usize)) {
    let mut warn = |msg: String| warnings.push(Warning::at(&entity.loc, msg));
    let pixel_samples = |default: i32| -> i64 {
        let n = params.int("pixelsamples", default);
        spp_override.map_or(n as i64, |o| o as i64).max(1)
    };
    let name = if entity.name.is_empty() { "halton" } else { entity.name.as_str() };
    let (kind, _) = SamplerKind::named(name);
    let n = match kind {
        SamplerKind::ZeroTwoSequence => {
            let n = pixel_samples(16);
            let up = round_up_pow2(n);
            if n != up {
                warn(format!("Pixel samples being rounded up to power of 2 (from {n} to {up})."));
            }
            up
        }
        SamplerKind::MaxMinDist => {
            let mut n = pixel_samples(16);
            if n > MAX_MIN_DIST_MAX_SPP {
                warn(format!(
                    "No more than {MAX_MIN_DIST_MAX_SPP} samples per pixel are supported with MaxMinDistSampler. Rounding down."
                ));
                n = MAX_MIN_DIST_MAX_SPP;
            }
            if !is_power_of_2(n) {
                n = round_up_pow2(n);
                warn(format!(
                    "Non power-of-two sample count rounded up to {n} for MaxMinDistSampler."
                ));
            }
            n
        }
        SamplerKind::Sobol => {
            let n = pixel_samples(16);
            let up = round_up_pow2(n);
            if n != up {
                warn(format!("Non power-of-two sample count rounded up to {up} for SobolSampler."));
            }
            up
        }
        SamplerKind::Random => pixel_samples(4),
        SamplerKind::Halton => pixel_samples(16),
        SamplerKind::Stratified => {
            let mut xs = params.int("xsamples", 4).max(1) as usize;
            let mut ys = params.int("ysamples", 4).max(1) as usize;
            if let Some(n) = spp_override {
                (xs, ys) = stratified_grid(n as usize);
            }
            return (kind, (xs * ys) as i64, (xs, ys));
        }
    };
    (kind, n, (n.max(0) as usize, 1))
}

/// The strata across and down a pixel for `n` stratified samples: the
/// widest grid no wider than tall whose cells are exactly `n`.
pub fn stratified_grid(n: usize) -> (usize, usize) {
    let n = n.max(1);
    let mut xs = (n as f64).sqrt() as usize;
    while xs > 1 && n / xs * xs != n {
        xs -= 1;
    }
    (xs, n / xs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{FileLoc, Param, ParamValue};

    fn scene(filter: &str, sampler: &str, ints: &[(&str, i32)]) -> SceneDescription {
        let mut desc = SceneDescription {
            filter: Entity::named(filter),
            sampler: Entity::named(sampler),
            ..Default::default()
        };
        for &(n, v) in ints {
            desc.sampler.params.add(Param {
                name: n.into(),
                value: ParamValue::Int(vec![v]),
                loc: FileLoc::default(),
            });
        }
        desc
    }

    #[test]
    fn filter_radii_follow_pbrt_and_unknown_filters_are_boxes() {
        for (name, r) in [("box", 0.5), ("gaussian", 2.0), ("mitchell", 2.0), ("sinc", 4.0)] {
            let (l, _) = layout(&scene(name, "halton", &[]), None);
            assert_eq!(l.geometry.filter_radius, Vec2::splat(r), "{name}");
        }
        // An unknown filter renders as a box, so its tiles are a box's tiles.
        let (l, _) = layout(&scene("bogus", "halton", &[]), None);
        assert_eq!(l.geometry.filter_radius, Vec2::splat(0.5));
        let (l, _) = layout(&scene("", "", &[]), None);
        assert_eq!(l.geometry.filter_radius, Vec2::splat(0.5));
        assert_eq!((l.sampler, l.spp()), (SamplerKind::Halton, 16));
    }

    #[test]
    fn sample_counts_round_as_pbrt_does() {
        let count = |s: &str, ints: &[(&str, i32)], o: Option<u32>| {
            let (l, w) = layout(&scene("box", s, ints), o);
            (l.spp(), w.len())
        };
        assert_eq!(count("02sequence", &[("pixelsamples", 12)], None), (16, 1));
        assert_eq!(count("lowdiscrepancy", &[], None), (16, 0));
        assert_eq!(count("sobol", &[], Some(5)), (8, 1));
        assert_eq!(count("maxmindist", &[("pixelsamples", 3)], None), (4, 1));
        assert_eq!(count("maxmindist", &[], Some(1 << 20)), (1 << 16, 1));
        assert_eq!(count("random", &[], None), (4, 0));
        assert_eq!(count("halton", &[("pixelsamples", 7)], None), (7, 0));
        assert_eq!(count("stratified", &[("xsamples", 3), ("ysamples", 2)], None), (6, 0));
        let (l, _) = layout(&scene("box", "stratified", &[]), Some(12));
        assert_eq!((l.strata, l.spp()), ((3, 4), 12));
        assert_eq!(l.halves(), Halves::ByStratum { nx: 3.0, ny: 4.0 });
        let (l, _) = layout(&scene("box", "02sequence", &[]), Some(8));
        assert_eq!(l.halves(), Halves::ByPosition { spp: 8.0 });
        let (l, _) = layout(&scene("box", "sobol", &[]), Some(8));
        assert_eq!(l.halves(), Halves::ByIndex { half: 4 });
    }

    fn film(x: i32, y: i32) -> SceneDescription {
        let mut desc = scene("gaussian", "halton", &[]);
        for (n, v) in [("xresolution", x), ("yresolution", y)] {
            desc.film.params.add(Param {
                name: n.into(),
                value: ParamValue::Int(vec![v]),
                loc: FileLoc::default(),
            });
        }
        desc
    }

    #[test]
    fn oversize_films_and_sample_counts_are_refused_with_what_they_need() {
        let limits = Limits::default();
        let (l, _) = checked_layout(&film(1920, 1080), None, &limits).expect("an HD film");
        assert_eq!(l.spp(), 16);
        let e = checked_layout(&film(100_000, 100_000), None, &limits).unwrap_err().to_string();
        assert!(e.contains("10000000000 pixels (100000×100000)"), "{e}");
        assert!(e.contains("--max-pixels") && e.contains("GB"), "{e}");
        // Sides whose tile arithmetic would overflow are refused before it runs.
        let e =
            checked_layout(&film(i32::MAX, 1), None, &Limits { max_pixels: u64::MAX, ..limits });
        assert!(e.unwrap_err().to_string().contains("pixels"));
        let e = checked_layout(&film(64, 64), Some(u32::MAX), &limits).unwrap_err().to_string();
        assert!(e.contains("4294967295 samples per pixel") && e.contains("--max-spp"), "{e}");
        let tight = Limits { max_samples: 1000, ..limits };
        let e = checked_layout(&film(64, 64), None, &tight).unwrap_err().to_string();
        assert!(e.contains("--max-samples") && e.contains("16 spp"), "{e}");
        let huge = Limits { max_pixels: u64::MAX, max_spp: u64::MAX, max_samples: u64::MAX };
        assert!(checked_layout(&film(1 << 20, 1 << 20), None, &huge).is_ok());
        // A product past 64 bits is refused, not wrapped.
        let e =
            checked_layout(&film(1 << 20, 1 << 20), Some(u32::MAX), &huge).unwrap_err().to_string();
        assert!(e.contains("more than 2^64"), "{e}");
    }

    #[test]
    fn a_film_below_one_pixel_is_an_error_naming_the_film() {
        for (x, y, name, value) in [(0, 10, "xresolution", 0), (10, -5, "yresolution", -5)] {
            let mut desc = film(x, y);
            desc.film.loc = FileLoc { file: "s.pbrt".into(), line: 4, column: 1 };
            let e = checked_layout(&desc, None, &Limits::default()).unwrap_err();
            assert_eq!(e, FilmError::NoPixels { loc: desc.film.loc.clone(), name, value });
            assert!(e
                .to_string()
                .starts_with(&format!("s.pbrt:4:1: \"integer {name}\" is {value}")));
        }
    }
}
