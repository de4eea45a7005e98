//! Shading and lighting edge cases, and non-finite data in the scene file.

use super::*;

/// A ground, `objects` and a distant, a point and a uniform infinite light,
/// seen from `eye`.
fn lit_set(eye: &str, objects: &str) -> String {
    format!(
        r#"
        LookAt {eye}  0 0.5 0  0 1 0
        Camera "perspective" "float fov" 50
        Film "image" "integer xresolution" 48 "integer yresolution" 36
        Sampler "halton" "integer pixelsamples" 4
        Integrator "whitted" "integer maxdepth" 8
        WorldBegin
        LightSource "distant" "point from" [1 3 -2] "point to" [0 0 0] "rgb L" [1 1 1]
        LightSource "point" "point from" [-2 3 -1] "rgb I" [5 5 5]
        LightSource "infinite" "rgb L" [0.3 0.3 0.3]
        AttributeBegin
          Material "matte" "rgb Kd" [0.5 0.5 0.5]
          Shape "trianglemesh" "point P" [-6 0 -6  6 0 -6  6 0 6  -6 0 6]
            "integer indices" [0 1 2 0 2 3]
        AttributeEnd
        {objects}
        WorldEnd
        "#
    )
}

/// One sphere of radius 0.6 per material, on a 4 × 4 grid over the ground.
fn spheres(materials: &[String]) -> String {
    let mut s = String::new();
    for (i, m) in materials.iter().enumerate() {
        let (x, z) = (-2.25 + 1.5 * (i % 4) as f64, -1.5 + 1.5 * (i / 4) as f64);
        s += &format!(
            "AttributeBegin\n{m}\nTranslate {x} 0.6 {z}\nShape \"sphere\" \"float radius\" 0.6\nAttributeEnd\n"
        );
    }
    s
}

/// A glass slab (a box mesh 4 × 0.25 × 4) with `material`.
fn slab(material: &str) -> String {
    format!(
        "AttributeBegin\n{material}\nTranslate 0 0.3 0\nScale 4 0.25 4\n{}\nAttributeEnd",
        box_mesh(&Frame::UNIT)
    )
}

/// The scene `source` describes, ready for rays.
fn build(source: &str) -> Renderer {
    let (desc, _) = parse_str(source, "scene.pbrt", Path::new("")).expect("parse");
    Renderer::new(desc, &RenderOptions::default()).expect("build").0
}

/// Where the camera ray through the middle of the film first hits the
/// scene, in render space.
fn middle_hit(r: &Renderer) -> Vec3 {
    let res = r.film.full_resolution;
    let p_film = Vec2::new(res.x as f32, res.y as f32) / 2.0;
    let (_, ray) = r.camera.generate_ray(&CameraSample { p_film, ..Default::default() });
    let mut si = Default::default();
    r.world.intersect(&ray, &mut si).expect("the middle ray hits");
    si.p()
}

/// A plastic ground at y = -3 and a sphere on it, seen from straight above by
/// a camera at the origin (so render space is world space), with one sample
/// at each pixel's centre.
fn from_above(light: &str) -> String {
    format!(
        r#"
        LookAt 0 0 0  0 -1 0  0 0 1
        Camera "perspective" "float fov" 60
        Film "image" "integer xresolution" 33 "integer yresolution" 33
        Sampler "stratified" "integer xsamples" 1 "integer ysamples" 1 "bool jitter" "false"
        Integrator "whitted"
        WorldBegin
        {light}
        Material "plastic"
        Shape "trianglemesh" "point P" [-6 -3 -6  6 -3 -6  6 -3 6  -6 -3 6]
          "integer indices" [0 1 2 0 2 3]
        Translate 1 -2.5 0
        Shape "sphere" "float radius" 0.5
        WorldEnd
        "#
    )
}

/// The shading edge cases, as (name, scene): glass of index 1 and 1e6,
/// total internal reflection (a camera inside an off-centre glass sphere, a
/// glass slab seen at grazing angles), every microfacet material at
/// roughness 0 and 1 with and without `remaproughness`, and point and spot
/// lights lying exactly on a lit surface.
fn shading_edge_cases() -> Vec<(String, String)> {
    let glass = |eta: &str| format!("Material \"glass\" \"float eta\" {eta}");
    let mut cases: Vec<(String, String)> = vec![];
    for eta in ["1", "1e6"] {
        let objects = format!(
            "{}\n{}",
            slab(&glass(eta)),
            spheres(&[
                glass(eta),
                format!("Material \"glass\" \"float index\" {eta} \"float uroughness\" 0.3"),
                format!("Material \"uber\" \"rgb Kt\" [0.5 0.5 0.5] \"rgb Kr\" [0.3 0.3 0.3] \"float eta\" {eta}"),
            ])
        );
        cases.push((format!("glass-eta-{eta}"), lit_set("0 2.5 -6", &objects)));
    }
    // Total internal reflection: from inside a sphere of index 1.5, and
    // through a slab seen nearly edge-on.
    let inside = format!(
        "AttributeBegin\n{}\nTranslate 0 1.2 -4.5\nShape \"sphere\" \"float radius\" 1.5\nAttributeEnd\n{}",
        glass("1.5"),
        spheres(&["Material \"plastic\"".into()])
    );
    cases.push(("inside-glass".into(), lit_set("0.3 1 -5.5", &inside)));
    cases.push(("grazing-slab".into(), lit_set("0 0.45 -7", &slab(&glass("1.5")))));
    for remap in [true, false] {
        let mut m = vec![];
        for r in [0, 1] {
            let uv = format!("\"float uroughness\" {r} \"float vroughness\" {r}");
            m.extend([
                format!("Material \"metal\" \"float roughness\" {r}"),
                format!("Material \"plastic\" \"float roughness\" {r}"),
                format!("Material \"uber\" \"float roughness\" {r} \"rgb Kr\" [0.2 0.2 0.2]"),
                format!("Material \"substrate\" {uv}"),
                format!("Material \"glass\" {uv}"),
                format!("Material \"translucent\" \"float roughness\" {r}"),
            ]);
        }
        m.push("Material \"metal\" \"float uroughness\" 0 \"float vroughness\" 1".into());
        m.push("Material \"substrate\" \"float uroughness\" 1 \"float vroughness\" 0".into());
        let m: Vec<String> =
            m.into_iter().map(|s| format!("{s} \"bool remaproughness\" \"{remap}\"")).collect();
        cases.push((format!("roughness-remap-{remap}"), lit_set("0 3.5 -6", &spheres(&m))));
    }
    // Lights exactly where the middle pixel's ray meets the ground (zero
    // distance to the shaded point), and one on top of the sphere.
    let hit = middle_hit(&build(&from_above("")));
    let at = [hit.x, hit.y, hit.z].map(|c| format!("{c:e}")).join(" ");
    let up = [hit.x, hit.y + 1.0, hit.z].map(|c| format!("{c:e}")).join(" ");
    let along = [hit.x + 1.0, hit.y, hit.z].map(|c| format!("{c:e}")).join(" ");
    for (name, light) in [
        ("point-on-ground", format!("LightSource \"point\" \"point from\" [{at}]")),
        (
            "spot-on-ground-up",
            format!("LightSource \"spot\" \"point from\" [{at}] \"point to\" [{up}]"),
        ),
        (
            "spot-on-ground-along",
            format!("LightSource \"spot\" \"point from\" [{at}] \"point to\" [{along}]"),
        ),
        ("point-on-sphere", "LightSource \"point\" \"point from\" [1 -2 0]".into()),
    ] {
        let scene = from_above(&format!("{light} \"rgb I\" [2 2 2]"));
        if name.contains("ground") {
            // The light really is where the middle ray meets the ground.
            let r = build(&scene);
            let p = match &r.world.lights[0] {
                Light::Point(l) => l.p,
                Light::Spot(l) => l.p,
                _ => unreachable!(),
            };
            assert_eq!(p, middle_hit(&r), "{name}");
        }
        cases.push((name.into(), scene));
    }
    cases
}

/// Every shading edge case leaves a finite film.
#[test]
fn shading_edge_cases_leave_the_film_finite() {
    let mut failures = vec![];
    for (name, scene) in shading_edge_cases() {
        let r = render_text(&name, &scene, &opts());
        let bad = non_finite(&r.image);
        if bad > 0 {
            failures.push(format!("{name}: {bad} non-finite film values"));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// No shading edge case makes bad radiance in the first place: the film
/// guard, which turns such samples black, never acts.
#[test]
fn shading_edge_cases_give_no_bad_samples() {
    let mut failures = vec![];
    for (name, scene) in shading_edge_cases() {
        let r = render_text(&format!("{name}-guard"), &scene, &opts());
        if guarded(&r) != "0/0/0" {
            failures.push(format!("{name}: nan/inf/negative samples {}", guarded(&r)));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Area lights of zero area (a sphere and a disk of radius 0, a triangle
/// with collinear corners) emit nothing: the image equals the one without
/// them, with no sample guarded.
#[test]
fn zero_area_lights_add_nothing() {
    let with = |lights: &str| {
        lit_set("0 2.5 -6", &format!("{lights}\n{}", spheres(&["Material \"plastic\"".into()])))
    };
    let zero = r#"
        AttributeBegin
          AreaLightSource "diffuse" "rgb L" [5 5 5]
          Translate 0 1.5 0
          Shape "sphere" "float radius" 0
          Translate 1 0 0
          Shape "disk" "float radius" 0
          Shape "trianglemesh" "point P" [0 0 0  1 0 0  2 0 0] "integer indices" [0 1 2]
        AttributeEnd
    "#;
    let reference = render_text("zero-area-ref", &with(""), &opts());
    let r = render_text("zero-area", &with(zero), &opts());
    assert_eq!(non_finite(&r.image), 0);
    assert_eq!(guarded(&r), "0/0/0");
    let e = compare(&r.image, &reference.image).expect("same size");
    assert!(e.rel_mse < 1e-6, "{e:?}");
}

/// Lights of zero power of every kind give a black, finite image and no
/// guarded samples.
#[test]
fn zero_power_lights_give_black() {
    let scene = r#"
        LookAt 0 2.5 -6  0 0.5 0  0 1 0
        Camera "perspective" "float fov" 50
        Film "image" "integer xresolution" 48 "integer yresolution" 36
        Sampler "halton" "integer pixelsamples" 4
        Integrator "whitted"
        WorldBegin
        LightSource "point" "point from" [0 2 0] "rgb I" [0 0 0]
        LightSource "spot" "point from" [0 2 0] "point to" [0 0 0] "rgb I" [0 0 0]
        LightSource "distant" "rgb L" [0 0 0]
        LightSource "infinite" "rgb L" [0 0 0]
        AttributeBegin
          AreaLightSource "diffuse" "rgb L" [0 0 0]
          Translate 1 1 0
          Shape "sphere" "float radius" 0.5
        AttributeEnd
        Material "plastic"
        Shape "trianglemesh" "point P" [-6 0 -6  6 0 -6  6 0 6  -6 0 6] "integer indices" [0 1 2 0 2 3]
        Material "glass"
        Translate -1 0.6 0
        Shape "sphere" "float radius" 0.6
        WorldEnd
    "#;
    let r = render_text("zero-power", scene, &opts());
    assert!(r.image.pixels.iter().flatten().all(|&v| v == 0.0), "not black");
    assert_eq!(guarded(&r), "0/0/0");
}

/// Radiance that really is bad — a light of intensity 1e39 (+inf in f32),
/// the same light on a surface with a zero channel (inf × 0 = NaN), a light
/// of negative intensity — is counted in the stats and kept off the film.
#[test]
fn bad_radiance_is_counted_and_kept_off_the_film() {
    let scene = |kd: &str, i: &str| {
        format!(
            r#"
            LookAt 0 2 -4  0 0 0  0 1 0
            Camera "perspective" "float fov" 40
            Film "image" "integer xresolution" 32 "integer yresolution" 24
            Sampler "halton" "integer pixelsamples" 2
            Integrator "whitted"
            WorldBegin
            LightSource "point" "point from" [0 1 0] "rgb I" [{i}]
            Material "matte" "rgb Kd" [{kd}]
            Shape "trianglemesh" "point P" [-6 0 -6  6 0 -6  6 0 6  -6 0 6] "integer indices" [0 1 2 0 2 3]
            WorldEnd
            "#
        )
    };
    let cases = [
        ("inf-light", "0.5 0.5 0.5", "1e39 1e39 1e39"),
        ("nan-light", "0.5 0 0.5", "1e39 1e39 1e39"),
        ("negative-light", "0.5 0.5 0.5", "-1 -1 -1"),
    ];
    for (i, (name, kd, intensity)) in cases.into_iter().enumerate() {
        let r = render_text(name, &scene(kd, intensity), &opts());
        let s = &r.stats;
        let count = [s.inf_samples, s.nan_samples, s.negative_samples];
        assert!(count[i] > 0, "{name}: inf/nan/negative {count:?}");
        assert_eq!(non_finite(&r.image), 0, "{name}");
        assert!(r.image.pixels.iter().flatten().all(|&v| v >= 0.0), "{name}");
    }
}

/// A mesh, lit and textured with a checkerboard over its uvs, whose one
/// `param` line is written as is (on the Shape's line).
fn mesh_scene(param: &str) -> String {
    format!(
        r#"
        LookAt 0 3 -3  0 0 0  0 1 0
        Camera "perspective" "float fov" 50
        Film "image" "integer xresolution" 32 "integer yresolution" 24
        Sampler "halton" "integer pixelsamples" 2
        Integrator "whitted"
        WorldBegin
        LightSource "distant" "point from" [1 3 -2] "point to" [0 0 0]
        LightSource "infinite" "rgb L" [0.2 0.2 0.2]
        Texture "check" "spectrum" "checkerboard" "float uscale" 4 "float vscale" 4
        Material "matte" "texture Kd" "check"
        Shape "trianglemesh" {param}
        WorldEnd
        "#
    )
}

/// Non-finite vertex positions (written 1e39, -1e39, inf or nan) drop the
/// triangles that use them, and non-finite normals or uvs are discarded:
/// the mesh renders exactly as if the bad data were not there, and a
/// warning at the Shape's file and line says what was dropped.
#[test]
fn non_finite_mesh_data_is_dropped_with_a_located_warning() {
    let p = |v4: &str| format!("\"point P\" [-1 0 -1  1 0 -1  1 0 1  -1 0 1  {v4} 0 0]");
    let two = "\"integer indices\" [0 1 2 0 2 3]";
    let three = "\"integer indices\" [0 1 2 0 2 3 1 4 2]";
    let normals = |n3: &str| format!("\"normal N\" [0 1 0  0 1 0  0 1 0  {n3} 1 0  0 1 0]");
    let uvs = |u2: &str| format!("\"float uv\" [0 0  1 0  {u2} 1  0 1  1 0.5]");
    let cases = [
        ("1e39", format!("{} {three}", p("1e39")), format!("{} {two}", p("0")), "skipped 1 of 3"),
        ("-1e39", format!("{} {three}", p("-1e39")), format!("{} {two}", p("0")), "skipped 1 of 3"),
        ("inf", format!("{} {three}", p("inf")), format!("{} {two}", p("0")), "skipped 1 of 3"),
        ("nan", format!("{} {three}", p("nan")), format!("{} {two}", p("0")), "skipped 1 of 3"),
        ("N", format!("{} {two} {}", p("3"), normals("nan")), format!("{} {two}", p("3")), "\"N\""),
        ("uv", format!("{} {two} {}", p("3"), uvs("1e39")), format!("{} {two}", p("3")), "\"uv\""),
    ];
    let mut failures = vec![];
    for (what, bad, good, says) in &cases {
        let name = format!("bad-mesh-{what}");
        let source = mesh_scene(bad);
        let r = render_text(&name, &source, &opts());
        let reference = render_text(&format!("{name}-ref"), &mesh_scene(good), &opts());
        assert!(reference.image.pixels.iter().any(|p| p[0] > 0.3), "{what}: the mesh is not seen");
        let line = 1 + source.lines().position(|l| l.contains("Shape")).expect("a Shape") as u32;
        let located = r.warnings.iter().any(|w| {
            w.loc
                .as_ref()
                .is_some_and(|l| l.file.ends_with(&format!("{name}.pbrt")) && l.line == line)
                && w.message.contains(says)
        });
        let same = r.image.pixels == reference.image.pixels;
        if !located || !same || non_finite(&r.image) > 0 {
            let w: Vec<String> = r.warnings.iter().map(|w| w.to_string()).collect();
            failures.push(format!("{what}: same image {same}, warnings at line {line}: {w:?}"));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
