//! The same scene and seed give the same bits whatever the thread count.

use farm_cli::embedded::{self as submit, SubmitOptions};
use farm_common::image::{write_image, ImageMetadata};
use farm_common::math;
use std::path::Path;

fn example() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/example.pbrt")
}

#[test]
fn renders_are_bit_identical_across_runs_and_thread_counts() {
    let render = |threads| {
        let opts = SubmitOptions { threads, spp: Some(2), ..Default::default() };
        submit::render(&example(), &opts, |_| {}).expect("render")
    };
    let one = render(1);
    let two = render(2);
    let again = render(2);
    let bits = |img: &farm_common::image::RgbImage| -> Vec<u32> {
        img.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect()
    };
    assert_eq!(bits(&one.image), bits(&two.image), "1 vs 2 threads");
    assert_eq!(bits(&two.image), bits(&again.image), "two runs");
    assert!(one.image.pixels.iter().any(|p| p[0] > 0.0), "image is not black");

    // The files written are byte-identical too (PFM carries no timing metadata).
    let tmp = tempfile::Builder::new().prefix("farm-det-").tempdir().expect("temp dir");
    let dir = tmp.path();
    let (a, b) = (dir.join("a.pfm"), dir.join("b.pfm"));
    write_image(&a, &one.image, &ImageMetadata::default()).expect("write");
    write_image(&b, &again.image, &ImageMetadata::default()).expect("write");
    assert_eq!(std::fs::read(&a).expect("read"), std::fs::read(&b).expect("read"));
}

/// `--cropwindow` renders exactly the full render's pixels there, for every
/// sampler: tiles lie on the full film's grid and keep its seeds, and the
/// low-discrepancy sequences are laid over the whole film (pbrt-v3 lays
/// them over the crop, which gives other, equally good, samples).
#[test]
fn a_crop_is_bit_identical_to_the_same_pixels_of_the_full_render() {
    let tmp = tempfile::Builder::new().prefix("farm-crop-").tempdir().unwrap();
    let dir = tmp.path();
    for sampler in ["halton", "sobol", "random", "stratified", "02sequence", "maxmindist"] {
        // A small film, a wide filter, a crop across tile edges.
        let scene = farm_tests::small_example(150, 100, sampler).replace(
            "PixelFilter \"gaussian\"",
            "PixelFilter \"mitchell\" \"float xwidth\" [ 2.5 ]",
        );
        let path = dir.join(format!("{sampler}.pbrt"));
        std::fs::write(&path, scene).unwrap();
        let render = |crop: Option<[f32; 4]>| {
            let mut opts = SubmitOptions { spp: Some(4), ..Default::default() };
            opts.overrides.crop_window = crop;
            submit::render(&path, &opts, |_| {}).expect("render").image
        };
        let full = render(None);
        let crop = render(Some([0.25, 0.75, 0.3, 0.8]));
        // pbrt-v3's rounding: pixels from ceil(res × fraction), in f32.
        let edge = |res: f32, f: f32| math::ceil(res * f) as usize;
        let (x0, y0) = (edge(150.0, 0.25), edge(100.0, 0.3));
        assert_eq!(crop.width, edge(150.0, 0.75) - x0, "{sampler}");
        assert_eq!(crop.height, edge(100.0, 0.8) - y0, "{sampler}");
        for y in 0..crop.height {
            for x in 0..crop.width {
                let a = crop.pixels[y * crop.width + x].map(f32::to_bits);
                let b = full.pixels[(y + y0) * full.width + x + x0].map(f32::to_bits);
                assert_eq!(a, b, "{sampler}: pixel ({}, {})", x + x0, y + y0);
            }
        }
    }
}

/// A torus of `n` × `n` quads (two triangles each) as a `trianglemesh`.
fn torus_mesh(n: usize) -> String {
    let (mut p, mut idx) = (String::new(), String::new());
    for i in 0..n {
        for j in 0..n {
            let (phi, theta) = (
                i as f32 / n as f32 * std::f32::consts::TAU,
                j as f32 / n as f32 * std::f32::consts::TAU,
            );
            let r = 1.0 + 0.35 * math::cos(theta);
            let v = [r * math::cos(phi), 0.35 * math::sin(theta), r * math::sin(phi)];
            p.push_str(&format!("{} {} {} ", v[0], v[1], v[2]));
            let at = |a: usize, b: usize| (a % n) * n + b % n;
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            idx.push_str(&format!("{a} {b} {c} {a} {c} {d} "));
        }
    }
    format!("Shape \"trianglemesh\" \"integer indices\" [ {idx}] \"point P\" [ {p}]\n")
}

/// The BVH's box test runs in AVX where the CPU has it and in SSE where it
/// does not (`farm_render::accel::simd`); a farm mixes such hosts, so a
/// render with each path forced must give the same bits. The scene's
/// 7,200-triangle torus, spheres and instances make a tree of many levels,
/// walked by camera, reflected, refracted and shadow rays.
#[test]
fn every_box_test_path_renders_the_same_bits() {
    use farm_render::accel::{detected_simd, force_simd, simd, Simd};
    let tmp = tempfile::Builder::new().prefix("farm-simd-").tempdir().expect("temp dir");
    let path = tmp.path().join("torus.pbrt");
    let scene = format!(
        "LookAt 0 2.5 -3.5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 45\n\
         Sampler \"halton\" \"integer pixelsamples\" 2\n\
         Film \"image\" \"integer xresolution\" 96 \"integer yresolution\" 64\nWorldBegin\n\
         LightSource \"point\" \"point from\" [2 4 -2] \"rgb I\" [20 20 20]\n\
         ObjectBegin \"ball\"\nMaterial \"glass\"\nShape \"sphere\" \"float radius\" 0.3\nObjectEnd\n\
         AttributeBegin\nTranslate 0 0.2 0\nObjectInstance \"ball\"\nAttributeEnd\n\
         AttributeBegin\nTranslate 1.6 0.2 -0.4\nObjectInstance \"ball\"\nAttributeEnd\n\
         AttributeBegin\nMaterial \"metal\" \"float roughness\" 0.02\n{}AttributeEnd\n\
         Material \"matte\"\nShape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3] \
         \"point P\" [-5 -0.4 -5  5 -0.4 -5  5 -0.4 5  -5 -0.4 5]\nWorldEnd\n",
        torus_mesh(60)
    );
    std::fs::write(&path, scene).expect("write scene");
    let render = |level: Simd| {
        assert!(force_simd(Some(level)), "{level:?} runs here");
        assert_eq!(simd(), level);
        let opts = SubmitOptions { threads: 2, ..Default::default() };
        let img = submit::render(&path, &opts, |_| {}).expect("render").image;
        img.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<u32>>()
    };
    // SSE on x86-64, where AVX is the other path; the portable test elsewhere.
    let base = if cfg!(target_arch = "x86_64") { Simd::Sse } else { Simd::Portable };
    let sse = render(base);
    // The torus is in view and lit.
    let lit = sse.chunks(3).filter(|p| f32::from_bits(p[0]) > 0.0).count();
    assert!(lit > 96 * 64 / 4, "only {lit} pixels are lit");
    if detected_simd() == Simd::Avx {
        assert_eq!(render(Simd::Avx), sse, "AVX against SSE");
    } else {
        eprintln!("this CPU has no AVX: only the {base:?} path was rendered");
    }
    force_simd(None);
}
