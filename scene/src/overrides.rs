//! What pbrt-v3's command line changes in a scene after it is parsed:
//! `--cropwindow` and `--quick` (pbrt-v3 `PbrtOptions`, read by
//! `CreateFilm` and the `Create*Sampler` functions), and farm's own
//! `--sampler`.

use farm_common::scene::{FileLoc, Param, ParamValue, Params, SceneDescription, Warning};

/// Command-line settings that change the scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overrides {
    /// `--cropwindow x0 x1 y0 y1`: the part of the film to render, in
    /// [0, 1] fractions of its width and height, where the scene's `Film`
    /// gives no `cropwindow` of its own (pbrt-v3 lets the file's win).
    pub crop_window: Option<[f32; 4]>,
    /// `--quick`: a quarter of the resolution each way and one sample per
    /// pixel, as pbrt-v3 reduces every sampler but `random`.
    pub quick: bool,
    /// `--sampler NAME`: render with this sampler instead of the scene's
    /// (one of pbrt-v3's names), keeping its sample count, so one scene
    /// can be measured under every sampler.
    pub sampler: Option<String>,
}

/// pbrt-v3's sampler names, as `--sampler` takes them.
pub const SAMPLER_NAMES: [&str; 7] =
    ["halton", "sobol", "02sequence", "lowdiscrepancy", "maxmindist", "stratified", "random"];

impl Overrides {
    /// Applies the settings to `desc`, warning where the scene overrides them.
    pub fn apply(&self, desc: &mut SceneDescription, warnings: &mut Vec<Warning>) {
        if let Some(name) = &self.sampler {
            switch_sampler(desc, name);
        }
        let loc = desc.film.loc.clone();
        if let Some(crop) = self.crop_window {
            if desc.film.params.get("cropwindow").is_some() {
                warnings.push(Warning::at(
                    &loc,
                    "the Film's own \"cropwindow\" is used, not --cropwindow (as pbrt-v3 does)",
                ));
            } else {
                desc.film.params.add(param("cropwindow", ParamValue::Float(crop.to_vec()), &loc));
            }
        }
        if self.quick {
            let (x, y) = {
                let p = Params::new(&desc.film.params);
                (p.int("xresolution", 1280), p.int("yresolution", 720))
            };
            for (name, v) in [("xresolution", x), ("yresolution", y)] {
                desc.film.params.add(param(name, ParamValue::Int(vec![(v / 4).max(1)]), &loc));
            }
            let loc = desc.sampler.loc.clone();
            let s = &mut desc.sampler;
            match s.name.as_str() {
                "random" => {}
                "stratified" => {
                    for name in ["xsamples", "ysamples"] {
                        s.params.add(param(name, ParamValue::Int(vec![1]), &loc));
                    }
                }
                _ => s.params.add(param("pixelsamples", ParamValue::Int(vec![1]), &loc)),
            }
        }
    }
}

/// Puts the sampler `name` in place of the scene's, with the scene's
/// sample count as pbrt-v3 reads it (the stratified sampler's strata
/// factored as `--spp` factors a count, `stratified_grid`).
fn switch_sampler(desc: &mut SceneDescription, name: &str) {
    if desc.sampler.name == name {
        return;
    }
    let params = Params::new(&desc.sampler.params);
    let (_, count, _) =
        farm_common::film::sample_count(&desc.sampler, &params, None, &mut Vec::new());
    let count = count.clamp(1, i32::MAX as i64) as usize;
    let loc = desc.sampler.loc.clone();
    let s = &mut desc.sampler;
    s.name = name.to_string();
    s.params = Default::default();
    if name == "stratified" {
        let (nx, ny) = farm_common::film::stratified_grid(count);
        for (n, v) in [("xsamples", nx), ("ysamples", ny)] {
            s.params.add(param(n, ParamValue::Int(vec![v as i32]), &loc));
        }
    } else {
        s.params.add(param("pixelsamples", ParamValue::Int(vec![count as i32]), &loc));
    }
}

fn param(name: &str, value: ParamValue, loc: &FileLoc) -> Param {
    Param { name: name.to_string(), value, loc: loc.clone() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::film::layout;

    fn scene(text: &str) -> SceneDescription {
        crate::parse_str(text, "s.pbrt", std::path::Path::new(".")).unwrap().0
    }

    #[test]
    fn quick_quarters_the_film_and_takes_one_sample_but_for_random() {
        let quick = Overrides { quick: true, ..Default::default() };
        for (sampler, spp) in [("halton", 1), ("sobol", 1), ("stratified", 1), ("random", 4)] {
            let mut d = scene(&format!(
                "Film \"image\" \"integer xresolution\" [ 403 ] \"integer yresolution\" [ 3 ]\n\
                 Sampler \"{sampler}\"\nWorldBegin\nWorldEnd\n"
            ));
            let mut w = Vec::new();
            quick.apply(&mut d, &mut w);
            let (l, _) = layout(&d, None);
            assert_eq!((l.geometry.full_resolution.x, l.geometry.full_resolution.y), (100, 1));
            assert_eq!(l.samples, spp, "{sampler}");
            assert!(w.is_empty());
        }
    }

    #[test]
    fn another_sampler_takes_the_scenes_sample_count() {
        use farm_common::film::SamplerKind as K;
        let cases = [
            ("\"halton\" \"integer pixelsamples\" [ 16 ]", "stratified", K::Stratified, 16, (4, 4)),
            ("\"halton\" \"integer pixelsamples\" [ 8 ]", "stratified", K::Stratified, 8, (2, 4)),
            (
                "\"stratified\" \"integer xsamples\" [ 2 ] \"integer ysamples\" [ 3 ]",
                "random",
                K::Random,
                6,
                (6, 1),
            ),
            ("\"random\" \"integer pixelsamples\" [ 5 ]", "sobol", K::Sobol, 8, (8, 1)),
            ("\"sobol\"", "02sequence", K::ZeroTwoSequence, 16, (16, 1)),
            ("\"halton\" \"integer pixelsamples\" [ 4 ]", "maxmindist", K::MaxMinDist, 4, (4, 1)),
        ];
        for (from, to, kind, spp, strata) in cases {
            let mut d = scene(&format!("Sampler {from}\nWorldBegin\nWorldEnd\n"));
            let o = Overrides { sampler: Some(to.into()), ..Default::default() };
            o.apply(&mut d, &mut Vec::new());
            let (l, w) = layout(&d, None);
            assert_eq!((l.sampler, l.samples, l.strata), (kind, spp, strata), "{from} as {to}");
            // Only pbrt-v3's own rounding warns (random's 5 to Sobol's 8).
            assert_eq!(w.len(), usize::from(spp == 8 && to == "sobol"), "{w:?}");
            // With --spp as well, the count is --spp's.
            let (l, _) = layout(&d, Some(64));
            assert_eq!(l.samples, 64, "{from} as {to}");
        }
        for name in SAMPLER_NAMES {
            assert!(farm_common::film::SamplerKind::named(name).1, "{name}");
        }
    }

    #[test]
    fn the_scenes_crop_window_wins_with_a_warning() {
        let crop = Overrides { crop_window: Some([0.25, 0.75, 0.5, 1.0]), ..Default::default() };
        let mut d = scene("Film \"image\" \"integer xresolution\" [ 8 ] \"integer yresolution\" [ 8 ]\nWorldBegin\nWorldEnd\n");
        let mut w = Vec::new();
        crop.apply(&mut d, &mut w);
        let (l, _) = layout(&d, None);
        let b = l.geometry.cropped_pixel_bounds;
        assert_eq!((b.min.x, b.max.x, b.min.y, b.max.y), (2, 6, 4, 8));
        let mut d =
            scene("Film \"image\" \"float cropwindow\" [ 0 0.5 0 0.5 ]\nWorldBegin\nWorldEnd\n");
        crop.apply(&mut d, &mut w);
        assert_eq!(w.len(), 1, "{w:?}");
        let (l, _) = layout(&d, None);
        assert_eq!(l.geometry.cropped_pixel_bounds.max.x, 640);
    }
}
