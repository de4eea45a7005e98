//! Building a [`Sampler`] from the scene's `Sampler` directive (pbrt-v3
//! `MakeSampler` and the `Create*Sampler` functions), with pbrt-v3's
//! parameter names, defaults and warnings.

use super::{
    Halton, HaltonSampler, MaxMinDistSampler, RandomSampler, Sampler, Sobol, SobolSampler,
    StratifiedSampler, ZeroTwoSequenceSampler,
};
use farm_common::film::{sample_count, SamplerKind};
use farm_common::geometry::Bounds2i;
use farm_common::scene::{Entity, Params, Warning};

/// The sampler named by `entity` for images whose samples cover
/// `sample_bounds` (the film's sample bounds). `spp_override` replaces the
/// sample count (for stratified: the most nearly square `x`×`y` grid with
/// that many cells). Unknown names warn as pbrt-v3 does and fall back to
/// `"halton"`; unused parameters are reported.
pub fn create(
    entity: &Entity,
    sample_bounds: Bounds2i,
    spp_override: Option<u32>,
    warnings: &mut Vec<Warning>,
) -> Sampler {
    // The count is the film layout's, which the coordinator plans by.
    let params = Params::new(&entity.params);
    let (kind, n, (xs, ys)) = sample_count(entity, &params, spp_override, warnings);
    let dimensions = || params.int("dimensions", 4).max(0) as usize;
    let sampler = match kind {
        SamplerKind::ZeroTwoSequence => {
            Sampler::ZeroTwoSequence(ZeroTwoSequenceSampler::new(n, dimensions()))
        }
        SamplerKind::MaxMinDist => {
            // The count asked for, before rounding, picks pbrt-v3's matrix.
            let asked =
                spp_override.map_or_else(|| params.int("pixelsamples", 16).into(), i64::from);
            Sampler::MaxMinDist(MaxMinDistSampler::asked(n, asked, dimensions()))
        }
        SamplerKind::Sobol => Sampler::Sobol(SobolSampler::new(n, Sobol::new(sample_bounds))),
        SamplerKind::Random => {
            // pbrt-v3 takes the clock for a negative seed; we stay deterministic.
            let seed = params.int("seed", 0).max(0) as u64;
            Sampler::Random(RandomSampler::new(n, seed))
        }
        SamplerKind::Stratified => {
            let jitter = params.bool("jitter", true);
            let dims = dimensions();
            params.touch("seed");
            Sampler::Stratified(StratifiedSampler::new(xs, ys, jitter, dims))
        }
        SamplerKind::Halton => {
            let name = entity.name.as_str();
            if name != "halton" && !name.is_empty() {
                warnings.push(Warning::at(&entity.loc, format!("Sampler \"{name}\" unknown.")));
            }
            let center = params.bool("samplepixelcenter", false);
            Sampler::Halton(HaltonSampler::new(n, Halton::new(sample_bounds, center)))
        }
    };
    warnings.extend(params.unused_warnings());
    sampler
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::CameraDims;
    use farm_common::geometry::{Point2i, Vec2};
    use farm_common::rng::Rng;
    use farm_common::scene::{FileLoc, Param, ParamValue};

    fn entity(name: &str, ints: &[(&str, i32)]) -> Entity {
        let mut e = Entity::named(name);
        for &(n, v) in ints {
            e.params.add(Param {
                name: n.into(),
                value: ParamValue::Int(vec![v]),
                loc: FileLoc::default(),
            });
        }
        e
    }

    fn bounds() -> Bounds2i {
        Bounds2i::new(Point2i::new(-1, -2), Point2i::new(13, 9))
    }

    fn make(name: &str, ints: &[(&str, i32)]) -> Sampler {
        let mut w = Vec::new();
        let s = create(&entity(name, ints), bounds(), None, &mut w);
        assert!(w.is_empty(), "{w:?}");
        s
    }

    /// All values of the first `n` samples of pixel `p`.
    fn values(s: &mut Sampler, p: Point2i, n: usize) -> Vec<f32> {
        s.start_pixel(p);
        let mut out = Vec::new();
        for _ in 0..n {
            let c = s.camera_sample(p);
            out.extend([c.p_film.x, c.p_film.y, c.time, c.p_lens.x, c.p_lens.y]);
            let v = s.get_2d();
            out.extend([v.x, v.y, s.get_1d()]);
            s.start_next_sample();
        }
        out
    }

    /// Each half of a pixel's samples, as the film splits them for the
    /// error estimate, covers the whole pixel: for the (0,2)-sequence every
    /// elementary interval of area 2/spp holds exactly one of the half's
    /// points; for Halton (base 3 in y) every vertical strip of width 2/spp.
    #[test]
    fn each_half_of_a_pixels_samples_is_a_net_over_the_pixel() {
        for (name, spp) in [("halton", 16u32), ("02sequence", 16), ("02sequence", 32)] {
            let mut s = make(name, &[("pixelsamples", spp as i32)]).clone_with_seed(9);
            let halves = s.halves();
            for p in [Point2i::new(0, 0), Point2i::new(5, 3), Point2i::new(12, 8)] {
                s.start_pixel(p);
                let mut split = [Vec::new(), Vec::new()];
                for index in 0..spp {
                    let c = s.camera_sample(p);
                    let (x, y) = (c.p_film.x - p.x as f32, c.p_film.y - p.y as f32);
                    split[halves.is_second(index, Vec2::new(x, y)) as usize].push((x, y));
                    s.start_next_sample();
                }
                let m = (spp / 2).trailing_zeros();
                for (h, pts) in split.iter().enumerate() {
                    assert_eq!(pts.len(), spp as usize / 2, "{name} half {h}");
                    let shapes = if name == "halton" { m..=m } else { 0..=m };
                    for a in shapes {
                        let (nx, ny) = ((1u32 << a) as f32, (1u32 << (m - a)) as f32);
                        let mut cells: Vec<u32> = pts
                            .iter()
                            .map(|&(x, y)| (x * nx) as u32 * (1 << (m - a)) + (y * ny) as u32)
                            .collect();
                        cells.sort_unstable();
                        cells.dedup();
                        assert_eq!(cells.len(), pts.len(), "{name} spp {spp} half {h}, {a}");
                    }
                }
            }
        }
    }

    /// The stratified sampler's halves are the two colours of a
    /// checkerboard over its strata: one sample in each stratum of a colour.
    #[test]
    fn stratified_halves_are_the_checkerboard_colours() {
        let mut s = make("stratified", &[("xsamples", 4), ("ysamples", 3)]).clone_with_seed(4);
        let halves = s.halves();
        let p = Point2i::new(2, 1);
        s.start_pixel(p);
        let mut seen = [Vec::new(), Vec::new()];
        for index in 0..12 {
            let c = s.camera_sample(p);
            let o = c.p_film - Vec2::new(p.x as f32, p.y as f32);
            let stratum = ((o.x * 4.0) as u32, (o.y * 3.0) as u32);
            let h = halves.is_second(index, o) as usize;
            assert_eq!(((stratum.0 + stratum.1) & 1) as usize, h, "{stratum:?}");
            seen[h].push(stratum);
            s.start_next_sample();
        }
        for h in &mut seen {
            h.sort_unstable();
            h.dedup();
            assert_eq!(h.len(), 6, "{h:?}");
        }
    }

    #[test]
    fn film_samples_stay_inside_their_pixel() {
        let samplers = [
            make("halton", &[("pixelsamples", 8)]),
            make("sobol", &[("pixelsamples", 8)]),
            make("02sequence", &[("pixelsamples", 8)]),
            make("stratified", &[("xsamples", 3), ("ysamples", 2)]),
            make("maxmindist", &[("pixelsamples", 8)]),
            make("random", &[]),
        ];
        for base in samplers {
            let mut s = base.clone_with_seed(5);
            for p in bounds().iter() {
                s.start_pixel(p);
                loop {
                    let c = s.camera_sample(p);
                    let (fx, fy) = (c.p_film.x - p.x as f32, c.p_film.y - p.y as f32);
                    assert!((0.0..1.0).contains(&fx) && (0.0..1.0).contains(&fy), "{s:?} {p:?}");
                    assert!((0.0..=1.0).contains(&c.time));
                    if !s.start_next_sample() {
                        break;
                    }
                }
            }
        }
    }

    #[test]
    fn same_seed_same_values_and_seeds_differ() {
        for (name, ints) in [
            ("02sequence", &[("pixelsamples", 4)][..]),
            ("random", &[][..]),
            ("stratified", &[("xsamples", 2), ("ysamples", 2)][..]),
            ("maxmindist", &[][..]),
        ] {
            let base = make(name, ints);
            let p = Point2i::new(4, 3);
            let a = values(&mut base.clone_with_seed(7), p, 4);
            let b = values(&mut base.clone_with_seed(7), p, 4);
            assert_eq!(a, b, "{name}");
            let c = values(&mut base.clone_with_seed(8), p, 4);
            assert_ne!(a, c, "{name}");
        }
        for name in ["halton", "sobol"] {
            let base = make(name, &[("pixelsamples", 4)]);
            let p = Point2i::new(2, 2);
            let mut s = base.clone_with_seed(1);
            values(&mut s, Point2i::new(9, 1), 4);
            assert_eq!(values(&mut s, p, 4), values(&mut base.clone_with_seed(2), p, 4));
        }
    }

    #[test]
    fn random_sampler_is_the_rng_stream() {
        let mut s = make("random", &[("pixelsamples", 2)]).clone_with_seed(11);
        let mut r = Rng::new(11);
        s.start_pixel(Point2i::new(0, 0));
        for _ in 0..10 {
            assert_eq!(s.get_1d(), r.uniform_f32());
            let v = s.get_2d();
            assert_eq!((v.x, v.y), (r.uniform_f32(), r.uniform_f32()));
        }
    }

    #[test]
    fn names_defaults_and_warnings() {
        let mut w = Vec::new();
        let s = create(&entity("lowdiscrepancy", &[("pixelsamples", 10)]), bounds(), None, &mut w);
        assert!(matches!(s, Sampler::ZeroTwoSequence(_)));
        assert_eq!(s.samples_per_pixel(), 16);
        assert_eq!(w[0].message, "Pixel samples being rounded up to power of 2 (from 10 to 16).");
        w.clear();
        let s =
            create(&entity("bogus", &[("pixelsamples", 3), ("typo", 1)]), bounds(), None, &mut w);
        assert!(matches!(s, Sampler::Halton(_)));
        assert_eq!(s.samples_per_pixel(), 3);
        assert_eq!(w.len(), 2);
        assert_eq!(w[0].message, "Sampler \"bogus\" unknown.");
        assert_eq!(w[1].message, "Parameter \"typo\" not used");
        w.clear();
        let s = create(&entity("stratified", &[("pixelsamples", 3)]), bounds(), Some(12), &mut w);
        assert_eq!(s.samples_per_pixel(), 12);
        assert_eq!(w.len(), 1, "pixelsamples is not a stratified parameter");
        assert_eq!(make("random", &[]).samples_per_pixel(), 4);
        assert_eq!(make("halton", &[]).samples_per_pixel(), 16);
        assert_eq!(make("stratified", &[]).samples_per_pixel(), 16);
    }

    /// Skipping the time or lens dimensions, or a pair after them, leaves
    /// the film point and every later value as they were, for every
    /// sampler, with and without arrays (which Halton and Sobol' place
    /// right after the camera dimensions).
    #[test]
    fn skipped_camera_dimensions_leave_later_values_alone() {
        for name in ["halton", "sobol", "02sequence", "maxmindist", "stratified", "random"] {
            for arrays in [false, true] {
                for dims in [(false, false), (true, false), (false, true)] {
                    let dims = CameraDims { time: dims.0, lens: dims.1 };
                    let mut base = if name == "stratified" {
                        make(name, &[("xsamples", 2), ("ysamples", 4)])
                    } else {
                        make(name, &[("pixelsamples", 8)])
                    };
                    if arrays {
                        base.request_2d_array(2);
                    }
                    let (mut full, mut skip) = (base.clone_with_seed(3), base.clone_with_seed(3));
                    let p = Point2i::new(5, 2);
                    full.start_pixel(p);
                    skip.start_pixel(p);
                    loop {
                        let (a, b) = (full.camera_sample(p), skip.camera_sample_for(p, dims));
                        assert_eq!(a.p_film, b.p_film, "{name}");
                        if dims.time {
                            assert_eq!(a.time, b.time, "{name}");
                        }
                        if dims.lens {
                            assert_eq!(a.p_lens, b.p_lens, "{name}");
                        }
                        if arrays {
                            assert_eq!(full.get_2d_array(2), skip.get_2d_array(2), "{name}");
                        }
                        // A pair drawn and ignored (Whitted's specular lobes
                        // on a surface without them) is passed over too.
                        full.get_2d();
                        skip.skip_2d();
                        for _ in 0..3 {
                            assert_eq!(full.get_1d(), skip.get_1d(), "{name} {dims:?}");
                            assert_eq!(full.get_2d(), skip.get_2d(), "{name} {dims:?}");
                        }
                        let more = full.start_next_sample();
                        assert_eq!(more, skip.start_next_sample());
                        if !more {
                            break;
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn global_sampler_arrays_skip_dimensions() {
        let mut base = make("halton", &[("pixelsamples", 4)]);
        base.request_2d_array(3);
        let mut with = base.clone_with_seed(0);
        let mut without = make("halton", &[("pixelsamples", 4)]);
        for s in [&mut with, &mut without] {
            s.start_pixel(Point2i::new(1, 1));
            s.set_sample_number(2);
        }
        // Camera sample uses dims 0-4; the array takes 5-6; get_2d then reads 7-8.
        let (a, b) =
            (with.camera_sample(Point2i::new(1, 1)), without.camera_sample(Point2i::new(1, 1)));
        assert_eq!((a.p_film, a.time, a.p_lens), (b.p_film, b.time, b.p_lens));
        let arr = with.get_2d_array(3).map(|a| a.to_vec());
        assert_eq!(arr.as_ref().map(|a| a.len()), Some(3));
        let expected = {
            let _ = without.get_2d();
            without.get_2d()
        };
        assert_eq!(with.get_2d(), expected);
    }
}
