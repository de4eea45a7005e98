//! Sample generators (pbrt-v3 `core/sampler.h` and `samplers/`):
//!
//! ```text
//! Sampler "halton" "integer pixelsamples" [16]
//! ```
//!
//! A [`Sampler`] is created once per render from the scene's `Sampler`
//! directive and cloned per tile with the tile index as seed
//! ([`Sampler::clone_with_seed`], pbrt-v3 `Sampler::Clone`). For each pixel
//! the integrator calls [`Sampler::start_pixel`], then draws values with
//! [`Sampler::camera_sample`], [`Sampler::get_1d`] and [`Sampler::get_2d`]
//! until [`Sampler::start_next_sample`] returns false. Values depend only
//! on (seed, pixel, sample index, dimension) and equal pbrt-v3's.

mod create;
mod halton;
pub mod lowdiscrepancy;
mod maxmindist;
mod pixel;
mod random;
mod sobol;
mod sobolmatrices;
mod stratified;
mod zerotwosequence;

pub use create::create;
pub use halton::{Halton, HaltonSampler};
pub use maxmindist::{MaxMinDistSampler, C_MAX_MIN_DIST};
pub use pixel::{GlobalSampler, GlobalSequence, PixelSampler, SamplerCore, ARRAY_START_DIM};
pub use random::RandomSampler;
pub use sobol::{Sobol, SobolSampler};
pub use stratified::StratifiedSampler;
pub use zerotwosequence::ZeroTwoSequenceSampler;

pub use farm_common::film::Halves;

use crate::sampling::CameraSample;
use farm_common::film::{round_up_pow2, stratified_grid, SamplerKind};
use farm_common::geometry::{Point2i, Vec2};

/// One of pbrt-v3's samplers.
#[derive(Clone, Debug)]
pub enum Sampler {
    /// `"halton"`
    Halton(HaltonSampler),
    /// `"sobol"`
    Sobol(SobolSampler),
    /// `"02sequence"` / `"lowdiscrepancy"`
    ZeroTwoSequence(ZeroTwoSequenceSampler),
    /// `"maxmindist"`
    MaxMinDist(MaxMinDistSampler),
    /// `"stratified"`
    Stratified(StratifiedSampler),
    /// `"random"`
    Random(RandomSampler),
}

/// Which optional dimensions of a camera sample the camera reads: time only
/// matters when something moves, the lens point only with a lens radius.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CameraDims {
    /// The shutter time.
    pub time: bool,
    /// The point on the lens.
    pub lens: bool,
}

impl CameraDims {
    /// Every dimension (pbrt-v3's `GetCameraSample`).
    pub const ALL: CameraDims = CameraDims { time: true, lens: true };
}

macro_rules! dispatch {
    ($self:expr, $s:ident => $global:expr, $pixel:expr, $random:expr) => {
        match $self {
            Sampler::Halton($s) => $global,
            Sampler::Sobol($s) => $global,
            Sampler::ZeroTwoSequence($s) => $pixel,
            Sampler::MaxMinDist($s) => $pixel,
            Sampler::Stratified($s) => $pixel,
            Sampler::Random($s) => $random,
        }
    };
}

impl Sampler {
    fn core(&self) -> &SamplerCore {
        dispatch!(self, s => &s.core, &s.px.core, &s.core)
    }

    fn core_mut(&mut self) -> &mut SamplerCore {
        dispatch!(self, s => &mut s.core, &mut s.px.core, &mut s.core)
    }

    /// Samples taken in each pixel.
    pub fn samples_per_pixel(&self) -> u32 {
        self.core().spp as u32
    }

    /// Which of pbrt-v3's samplers it is.
    pub fn kind(&self) -> SamplerKind {
        match self {
            Sampler::Halton(_) => SamplerKind::Halton,
            Sampler::Sobol(_) => SamplerKind::Sobol,
            Sampler::ZeroTwoSequence(_) => SamplerKind::ZeroTwoSequence,
            Sampler::MaxMinDist(_) => SamplerKind::MaxMinDist,
            Sampler::Stratified(_) => SamplerKind::Stratified,
            Sampler::Random(_) => SamplerKind::Random,
        }
    }

    /// How a pixel's samples split into the two halves the film keeps apart
    /// for the render's estimate of its own error.
    pub fn halves(&self) -> Halves {
        let strata = match self {
            Sampler::Stratified(st) => st.strata(),
            _ => (0, 0),
        };
        Halves::of(self.kind(), self.samples_per_pixel(), strata)
    }

    /// Whether a pixel's samples depend on the pixel alone (Halton and
    /// Sobol'), not on the pixels drawn before it in the tile. Such a
    /// sampler computes a dimension from the sample index alone, so
    /// [`Sampler::skip_2d`] saves work; the others must still draw it.
    #[inline]
    pub fn is_stateless(&self) -> bool {
        self.kind().continues_sequence()
    }

    /// A copy for one tile (pbrt-v3 `Clone(seed)`): pixel samplers and the
    /// random sampler restart their generator on stream `seed`; Halton and
    /// Sobol' are deterministic and ignore it.
    pub fn clone_with_seed(&self, seed: u64) -> Sampler {
        let mut s = self.clone();
        match &mut s {
            Sampler::Halton(_) | Sampler::Sobol(_) => {}
            Sampler::ZeroTwoSequence(z) => z.px.rng.set_sequence(seed),
            Sampler::MaxMinDist(m) => m.px.rng.set_sequence(seed),
            Sampler::Stratified(t) => t.px.rng.set_sequence(seed),
            Sampler::Random(r) => r.rng.set_sequence(seed),
        }
        s
    }

    /// A sampler of the same kind and parameters taking `spp` samples per
    /// pixel: one pass of a render in passes
    /// (`farm_common::film::PassPlan`) for the samplers with state, whose
    /// passes are each a set of their own size. Halton and Sobol' continue
    /// one sequence and are returned as they are.
    pub fn with_spp(&self, spp: u32) -> Sampler {
        let n = i64::from(spp.max(1));
        let dims = |px: &PixelSampler| px.samples_1d.len();
        let mut s = match self {
            Sampler::Halton(_) | Sampler::Sobol(_) => return self.clone(),
            Sampler::ZeroTwoSequence(z) => {
                Sampler::ZeroTwoSequence(ZeroTwoSequenceSampler::new(round_up_pow2(n), dims(&z.px)))
            }
            Sampler::MaxMinDist(m) => {
                Sampler::MaxMinDist(MaxMinDistSampler::new(round_up_pow2(n), dims(&m.px)))
            }
            Sampler::Stratified(t) => {
                let (xs, ys) = stratified_grid(spp as usize);
                Sampler::Stratified(StratifiedSampler::new(xs, ys, t.jitter, dims(&t.px)))
            }
            Sampler::Random(_) => Sampler::Random(RandomSampler::new(n, 0)),
        };
        let core = self.core();
        for &k in &core.array_1d_sizes {
            s.request_1d_array(k);
        }
        for &k in &core.array_2d_sizes {
            s.request_2d_array(k);
        }
        s
    }

    /// Starts the first sample of pixel `p`.
    pub fn start_pixel(&mut self, p: Point2i) {
        match self {
            Sampler::Halton(s) => s.start_pixel(p),
            Sampler::Sobol(s) => s.start_pixel(p),
            Sampler::ZeroTwoSequence(s) => s.start_pixel(p),
            Sampler::MaxMinDist(s) => s.start_pixel(p),
            Sampler::Stratified(s) => s.start_pixel(p),
            Sampler::Random(s) => s.start_pixel(p),
        }
    }

    /// Moves to the pixel's next sample; false when all have been taken.
    pub fn start_next_sample(&mut self) -> bool {
        dispatch!(self, s => s.start_next_sample(), s.px.start_next_sample(), s.core.start_next_sample())
    }

    /// Jumps to sample `n` of the pixel; false if past the last (pbrt-v3 `SetSampleNumber`).
    pub fn set_sample_number(&mut self, n: u64) -> bool {
        let n = n as i64;
        dispatch!(self, s => s.set_sample_number(n), s.px.set_sample_number(n), s.core.set_sample_number(n))
    }

    /// The next value of the current sample.
    #[inline]
    pub fn get_1d(&mut self) -> f32 {
        dispatch!(self, s => s.get_1d(), s.px.get_1d(), s.get_1d())
    }

    /// The next pair of values of the current sample.
    #[inline]
    pub fn get_2d(&mut self) -> Vec2 {
        dispatch!(self, s => s.get_2d(), s.px.get_2d(), s.get_2d())
    }

    /// pbrt-v3 `GetCameraSample`: film point `p_raster + get_2d()`, then
    /// time `get_1d()`, then lens point `get_2d()`.
    #[inline]
    pub fn camera_sample(&mut self, p_raster: Point2i) -> CameraSample {
        self.camera_sample_for(p_raster, CameraDims::ALL)
    }

    /// [`Sampler::camera_sample`] for a camera that reads only the
    /// dimensions in `dims`. The others are passed over without being
    /// computed where the sampler allows it (Halton, Sobol') and left at 0;
    /// every later value is the same as with [`Sampler::camera_sample`].
    #[inline]
    pub fn camera_sample_for(&mut self, p_raster: Point2i, dims: CameraDims) -> CameraSample {
        let p_film = Vec2::new(p_raster.x as f32, p_raster.y as f32) + self.get_2d();
        let time = if dims.time {
            self.get_1d()
        } else {
            self.skip_1d();
            0.0
        };
        let p_lens = if dims.lens {
            self.get_2d()
        } else {
            self.skip_2d();
            Vec2::ZERO
        };
        CameraSample { p_film, p_lens, time }
    }

    /// Passes over the next 1D value.
    #[inline]
    fn skip_1d(&mut self) {
        match self {
            Sampler::Halton(s) => s.skip_1d(),
            Sampler::Sobol(s) => s.skip_1d(),
            // Their values are precomputed per pixel or drawn from a generator
            // whose state must advance.
            _ => {
                self.get_1d();
            }
        }
    }

    /// Passes over the next 2D value.
    #[inline]
    pub(crate) fn skip_2d(&mut self) {
        match self {
            Sampler::Halton(s) => s.skip_2d(),
            Sampler::Sobol(s) => s.skip_2d(),
            _ => {
                self.get_2d();
            }
        }
    }

    /// The array length the sampler prefers for a request of `n` (pbrt-v3 `RoundCount`).
    pub fn round_count(&self, n: usize) -> usize {
        match self {
            Sampler::ZeroTwoSequence(_) | Sampler::MaxMinDist(_) => n.max(1).next_power_of_two(),
            _ => n,
        }
    }

    /// Requests an array of `n` values in every sample (before cloning).
    pub fn request_1d_array(&mut self, n: usize) {
        self.core_mut().request_1d_array(n);
    }

    /// Requests an array of `n` 2D values in every sample (before cloning).
    pub fn request_2d_array(&mut self, n: usize) {
        self.core_mut().request_2d_array(n);
    }

    /// The next requested 1D array of the current sample.
    pub fn get_1d_array(&mut self, n: usize) -> Option<&[f32]> {
        self.core_mut().get_1d_array(n)
    }

    /// The next requested 2D array of the current sample.
    pub fn get_2d_array(&mut self, n: usize) -> Option<&[Vec2]> {
        self.core_mut().get_2d_array(n)
    }
}
