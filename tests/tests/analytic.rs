//! Scenes whose Whitted image is known in closed form.

use farm_cli::embedded::SubmitOptions;
use farm_tests::{pixel, render_text};

fn opts() -> SubmitOptions {
    SubmitOptions { threads: 2, ..Default::default() }
}

/// Inside a closed Lambertian sphere (Kd 0.5) with a point light of
/// intensity π at its centre, every point has radiance Kd/π · π/r² = 0.5.
#[test]
fn inside_a_diffuse_sphere_every_pixel_is_one_half() {
    let scene = r#"
        LookAt 0 0 0  0.3 0.2 1  0 1 0
        Camera "perspective" "float fov" 120
        Film "image" "integer xresolution" 48 "integer yresolution" 32
        Sampler "halton" "integer pixelsamples" 4
        Integrator "whitted"
        WorldBegin
        LightSource "point" "rgb I" [3.14159265358979 3.14159265358979 3.14159265358979]
        Material "matte" "rgb Kd" [0.5 0.5 0.5]
        Shape "sphere" "float radius" 1
        WorldEnd
    "#;
    let r = render_text("inside-sphere", scene, &opts());
    for p in &r.image.pixels {
        for c in p {
            assert!((c - 0.5).abs() < 1e-4, "pixel value {c}");
        }
    }
}

fn sphere_in_sky(material: &str) -> String {
    format!(
        r#"
        LookAt 0 0 -5  0 0 0  0 1 0
        Camera "perspective" "float fov" 1
        Film "image" "integer xresolution" 33 "integer yresolution" 33
        Sampler "halton" "integer pixelsamples" 4
        Integrator "whitted" "integer maxdepth" 5
        WorldBegin
        LightSource "infinite" "rgb L" [1 1 1]
        {material}
        Shape "sphere" "float radius" 1
        WorldEnd
    "#
    )
}

/// A mirror (Kr 0.9, no Fresnel term) in a uniform sky of radiance 1.
#[test]
fn mirror_sphere_reflects_kr_times_the_sky() {
    let r = render_text("mirror", &sphere_in_sky(r#"Material "mirror""#), &opts());
    let c = pixel(&r.image, 16, 16);
    for v in c {
        assert!((v - 0.9).abs() < 1e-4, "{c:?}");
    }
}

/// A glass sphere (η 1.5) seen head-on in a uniform sky: the front reflection
/// F plus the light transmitted through, with internal reflections up to
/// maxdepth 5: F + T²(1 + F + F²), F = ((η−1)/(η+1))², T = 1 − F.
#[test]
fn glass_sphere_gives_fresnel_at_normal_incidence() {
    let r = render_text("glass", &sphere_in_sky(r#"Material "glass""#), &opts());
    let eta = 1.5f64;
    let f = ((eta - 1.0) / (eta + 1.0)).powi(2);
    let t = 1.0 - f;
    let expected = f + t * t * (1.0 + f + f * f);
    let c = pixel(&r.image, 16, 16);
    for v in c {
        assert!((v as f64 - expected).abs() < 1e-4, "{c:?} vs {expected}");
    }
}
