//! A scene pays only for what it uses: the analysis finds the features a
//! scene uses, skipping ray differentials and unread camera-sample
//! dimensions leaves the image bit for bit, and
//! the analysis agrees with the textures the renderer builds.

use farm_cli::embedded::SubmitOptions;
use farm_render::features::Features;
use farm_render::{RenderOptions, Renderer};
use farm_tests::render_text;

const HEAD: &str = "LookAt 0 1 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 45\n\
    Sampler \"halton\" \"integer pixelsamples\" 4\n\
    Film \"image\" \"integer xresolution\" 48 \"integer yresolution\" 32\nWorldBegin\n\
    LightSource \"point\" \"point from\" [1 3 -3] \"rgb I\" [10 10 10]\n";

const GLASS_AND_PLANE: &str = "Material \"glass\"\nShape \"sphere\" \"float radius\" 0.7\n\
    Material \"plastic\" \"rgb Kd\" [0.3 0.5 0.2]\n\
    Shape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3] \
    \"point P\" [-5 -1 -5  5 -1 -5  5 -1 5  -5 -1 5] \"float uv\" [0 0 1 0 1 1 0 1]\nWorldEnd\n";

/// Parses `source` and builds it; returns the analysis and whether the
/// built texture set needs differentials.
fn analyse(name: &str, source: &str) -> (Features, bool) {
    let tmp = tempfile::Builder::new().prefix("farm-features-").tempdir().expect("temp dir");
    let dir = tmp.path();
    let path = dir.join(format!("{name}.pbrt"));
    std::fs::write(&path, source).expect("write");
    let (desc, _) = farm_scene::parse_file(&path).expect("parses");
    let (r, _) = Renderer::new(desc, &RenderOptions::default()).expect("builds");
    let built = farm_render::textures::uses_differentials(&r.world.textures);
    (r.features.clone(), built)
}

#[test]
fn an_untextured_static_scene_skips_differentials_and_renders_the_same_bits() {
    let scene = format!("{HEAD}{GLASS_AND_PLANE}");
    let (features, _) = analyse("plain", &scene);
    assert!(!features.needs_differentials());
    assert_eq!((features.textures, features.moving, features.moving_camera), (0, 0, false));
    let lines = features.describe().join("\n");
    assert!(lines.contains("ray differentials: skipped"), "{lines}");
    assert!(lines.contains("motion: skipped"), "{lines}");

    // Skipping differentials, the unread time and lens dimensions of the
    // camera samples and the pairs Whitted ignores (the point light's, the
    // plastic's specular ones) leaves the image bit for bit, for both
    // samplers that pass over dimensions without computing them. A
    // spherical light after the point light reads the dimensions after
    // those pairs, so a pair passed over by the wrong count shows.
    let lit = format!(
        "{HEAD}AttributeBegin\nTranslate 0 2.5 -1\n\
         AreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\n\
         Shape \"sphere\" \"float radius\" 0.4\nAttributeEnd\n{GLASS_AND_PLANE}"
    );
    for sampler in ["halton", "sobol"] {
        let scene = lit.replace("\"halton\"", &format!("\"{sampler}\""));
        let skipped = render_text("plain", &scene, &SubmitOptions::default());
        let all =
            render_text("plain", &scene, &SubmitOptions { all_paths: true, ..Default::default() });
        let bits = |s: &farm_cli::embedded::RenderSummary| -> Vec<u32> {
            s.image.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect()
        };
        assert!(skipped.image.pixels.iter().any(|p| p[1] > 0.0), "image is not black");
        assert_eq!(bits(&skipped), bits(&all), "{sampler}: skipping changed the image");
        assert_eq!(skipped.stats.total_rays(), all.stats.total_rays());
    }
}

#[test]
fn filtering_textures_and_bump_maps_keep_differentials() {
    let with = |decl: &str, material: &str| {
        format!(
            "{HEAD}{decl}\n{material}\nShape \"trianglemesh\" \"integer indices\" [0 1 2 0 2 3] \
             \"point P\" [-5 -1 -5  5 -1 -5  5 -1 5  -5 -1 5] \"float uv\" [0 0 1 0 1 1 0 1]\nWorldEnd\n"
        )
    };
    let checks =
        "Texture \"c\" \"spectrum\" \"checkerboard\" \"float uscale\" 8 \"float vscale\" 8";
    let cases = [
        ("closedform", with(checks, "Material \"matte\" \"texture Kd\" \"c\""), true, true),
        (
            "aa-none",
            with(
                &format!("{checks} \"string aamode\" \"none\""),
                "Material \"matte\" \"texture Kd\" \"c\"",
            ),
            false,
            false,
        ),
        (
            "checks-3d",
            with(
                "Texture \"c\" \"spectrum\" \"checkerboard\" \"integer dimension\" 3",
                "Material \"matte\" \"texture Kd\" \"c\"",
            ),
            false,
            false,
        ),
        (
            "fbm",
            with("Texture \"n\" \"float\" \"fbm\"", "Material \"matte\" \"texture sigma\" \"n\""),
            true,
            true,
        ),
        (
            // A bump map of a constant texture: its finite differences are
            // still scaled by the footprint.
            "bump",
            with(
                "Texture \"b\" \"float\" \"constant\" \"float value\" 0.1",
                "Material \"matte\" \"texture bumpmap\" \"b\"",
            ),
            false,
            true,
        ),
    ];
    for (name, scene, filtering, needs) in cases {
        let (features, built) = analyse(name, &scene);
        assert_eq!(!features.filtering_textures.is_empty(), filtering, "{name}: {features:?}");
        assert_eq!(built, filtering, "{name}: the built textures disagree with the analysis");
        assert_eq!(features.needs_differentials(), needs, "{name}: {features:?}");
        assert_eq!(features.textures, 1, "{name}");
    }
}

#[test]
fn moving_shapes_and_cameras_are_found() {
    let scene = "LookAt 0 1 -4  0 0 0  0 1 0\nActiveTransform EndTime\nTranslate 0.1 0 0\nActiveTransform All\n\
         Camera \"perspective\"\nFilm \"image\" \"integer xresolution\" 8 \"integer yresolution\" 8\n\
         WorldBegin\nAttributeBegin\nActiveTransform EndTime\nTranslate 0 1 0\nActiveTransform All\n\
         Shape \"sphere\"\nAttributeEnd\nShape \"sphere\" \"float radius\" 0.5\nWorldEnd\n";
    let (features, _) = analyse("moving", scene);
    assert_eq!(features.moving, 1);
    assert!(features.moving_camera);
    let lines = features.describe().join("\n");
    assert!(
        lines.contains("motion: 1 moving shapes, lights or instances, moving camera"),
        "{lines}"
    );
}

/// The camera, film and Whitted integrator the warning tests' scenes open with.
const WHITTED_HEAD: &str = "Camera \"perspective\"\nFilm \"image\" \"integer xresolution\" 8 \"integer yresolution\" 8\nIntegrator \"whitted\"\nWorldBegin\n";

/// The renderer built from scene text (written to a file, so warnings
/// name its lines), and its warnings.
fn build(scene: &str) -> (Renderer, Vec<farm_common::scene::Warning>) {
    let tmp = tempfile::Builder::new().prefix("farm-features-").tempdir().expect("temp dir");
    let path = tmp.path().join("scene.pbrt");
    std::fs::write(&path, scene).expect("write");
    let (desc, _) = farm_scene::parse_file(&path).expect("parses");
    Renderer::new(desc, &RenderOptions::default()).expect("builds")
}

/// A scene without an Integrator directive is warned about without a
/// place in the file (there is none to name), one with an unsupported
/// integrator at its directive.
#[test]
fn the_integrator_warning_names_the_directive_only_where_there_is_one() {
    let head = "Camera \"perspective\"\nFilm \"image\" \"integer xresolution\" 8 \"integer yresolution\" 8\n";
    for (integrator, loc) in
        [("", None), ("Integrator \"path\"\n", Some(3)), ("Integrator \"whitted\"\n", None)]
    {
        let (_, warnings) = build(&format!("{head}{integrator}WorldBegin\n{GLASS_AND_PLANE}"));
        let w: Vec<_> = warnings.iter().filter(|w| w.message.contains("rendering with")).collect();
        match loc {
            None if integrator.is_empty() => {
                assert!(w.len() == 1 && w[0].loc.is_none(), "{w:?}");
                assert!(w[0].to_string().starts_with("warning: no Integrator directive"), "{w:?}");
            }
            None => assert!(w.is_empty(), "{w:?}"),
            Some(line) => assert_eq!(w[0].loc.as_ref().map(|l| l.line), Some(line), "{w:?}"),
        }
    }
}

/// An area light on a shape pbrt-v3 cannot sample (it aborts there) is
/// a warning at its `AreaLightSource`; on a sphere it is none. Either
/// way the render goes on.
#[test]
fn an_area_light_on_a_shape_that_cannot_be_sampled_warns() {
    for shape in ["cone", "paraboloid", "hyperboloid", "sphere"] {
        let (_, warnings) = build(&format!(
            "{WHITTED_HEAD}AttributeBegin\nTranslate 0 0 5\nAreaLightSource \"diffuse\"\nShape \"{shape}\"\nAttributeEnd\n"
        ));
        let w: Vec<_> =
            warnings.iter().filter(|w| w.message.contains("cannot be sampled")).collect();
        if shape == "sphere" {
            assert!(w.is_empty(), "{w:?}");
        } else {
            assert_eq!(w.len(), 1, "{shape}: {warnings:?}");
            assert_eq!(w[0].loc.as_ref().map(|l| l.line), Some(7), "{w:?}");
            assert!(w[0].message.contains(shape), "{w:?}");
        }
    }
}

/// The renderer lists lights in directive order (a `LightSource` after
/// the area lights of the shapes before it), and an area light inside an
/// object instance is a glow: seen, with the instance's normal, but not
/// among the lights.
#[test]
fn lights_keep_directive_order_and_instanced_area_lights_glow() {
    use farm_common::geometry::Vec3;
    use farm_render::lights::Light;
    use farm_render::world::GLOW;
    let scene = "LightSource \"point\"\n\
        AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [2 2 2]\nShape \"disk\"\nAttributeEnd\n\
        ObjectBegin \"lamp\"\nAreaLightSource \"diffuse\" \"rgb L\" [3 3 3]\nShape \"sphere\"\nObjectEnd\n\
        LightSource \"spot\"\nShape \"sphere\"\nObjectInstance \"lamp\"\nLightSource \"distant\"\n";
    let (r, _) = build(&format!("{WHITTED_HEAD}{scene}"));
    let kinds: Vec<&str> = r
        .world
        .lights
        .iter()
        .map(|l| match l {
            Light::Point(_) => "point",
            Light::Area(_) => "area",
            Light::Spot(_) => "spot",
            Light::Distant(_) => "distant",
            _ => "other",
        })
        .collect();
    assert_eq!(kinds, ["point", "area", "spot", "distant"]);
    assert_eq!(r.world.glows.len(), 1);
    let out = r.world.emitted(GLOW, Vec3::Z, Vec3::Z);
    assert_eq!((out[0], r.world.emitted(GLOW, Vec3::Z, -Vec3::Z)[0]), (3.0, 0.0));
    assert_eq!(r.world.emitted(1, Vec3::Z, Vec3::Z)[0], 2.0, "the disk's light");
}

/// Subsurface materials draw pbrt-v3's warning that the Whitted
/// integrator renders only their specular interface, at the directive.
#[test]
fn subsurface_materials_warn_that_whitted_ignores_their_scattering() {
    let scene = "Material \"kdsubsurface\"\nShape \"sphere\"\n\
        MakeNamedMaterial \"skin\" \"string type\" \"subsurface\"\nMaterial \"matte\"\nShape \"sphere\"\n";
    let (_, warnings) = build(&format!("{WHITTED_HEAD}{scene}"));
    let lines: Vec<u32> = warnings
        .iter()
        .filter(|w| w.message.contains("doesn't support subsurface scattering"))
        .filter_map(|w| w.loc.as_ref().map(|l| l.line))
        .collect();
    assert_eq!(lines, [5, 7], "{warnings:?}");
}
