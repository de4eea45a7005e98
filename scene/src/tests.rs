//! Tests of the whole parser on the shared real scenes, error locations
//! and speed.

use super::{parse_file, parse_str};
use crate::error::SceneError;
use farm_common::scene::{Params, SceneDescription, Warning};
use glam::DMat4;
use std::path::{Path, PathBuf};

const SCENES: &str = "/work/shared/scenes";

fn err(src: &str) -> String {
    parse_str(src, "t.pbrt", Path::new(".")).unwrap_err().to_string()
}

fn close(a: DMat4, b: DMat4) -> bool {
    a.abs_diff_eq(b, 1e-9)
}

/// A fresh temporary directory for files a test writes.
fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("farm-parser-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn shared(rel: &str) -> Option<(SceneDescription, Vec<Warning>)> {
    let path = Path::new(SCENES).join(rel);
    if !path.exists() {
        println!("skipping: {} is absent", path.display());
        return None;
    }
    Some(parse_file(&path).unwrap_or_else(|e| panic!("{e}")))
}

#[test]
fn every_shared_whitted_scene_parses() {
    let Ok(dirs) = std::fs::read_dir(SCENES) else {
        println!("skipping: {SCENES} is absent");
        return;
    };
    let mut n = 0;
    for d in dirs.flatten() {
        for f in std::fs::read_dir(d.path()).unwrap().flatten() {
            let name = f.file_name().to_string_lossy().into_owned();
            if name.ends_with("-whitted.pbrt") {
                let (scene, _) = parse_file(&f.path()).unwrap_or_else(|e| panic!("{e}"));
                assert_eq!(scene.integrator.name, "whitted", "{name}");
                assert!(!scene.shapes.is_empty() || !scene.instances.is_empty(), "{name}");
                n += 1;
            }
        }
    }
    assert!(n >= 7, "only {n} scenes");
}

#[test]
fn killeroo_counts() {
    let Some((s, _)) = shared("killeroo-simple/killeroo-simple-whitted.pbrt") else {
        return;
    };
    assert_eq!(s.name, "killeroo-simple-whitted");
    assert_eq!(s.shapes.len(), 5);
    assert_eq!(s.shapes.iter().filter(|x| x.entity.name == "loopsubdiv").count(), 2);
    let lit: Vec<_> = s.shapes.iter().filter(|x| x.area_light.is_some()).collect();
    assert_eq!(lit.len(), 1);
    assert_eq!(lit[0].area_light.as_ref().unwrap().name, "area");
    // The two killeroos have different plastic materials.
    let (a, b) = (s.shapes[3].material.unwrap(), s.shapes[4].material.unwrap());
    assert_ne!(a, b);
    assert_eq!(s.materials[a as usize].entity.name, "plastic");
    // The included file's locations name the included file.
    assert!(s.shapes[3].entity.loc.file.ends_with("geometry/killeroo.pbrt"));
}

#[test]
fn veach_mis_plymeshes_become_triangle_meshes() {
    let Some((s, w)) = shared("veach-mis/mis-whitted.pbrt") else {
        return;
    };
    let meshes: Vec<_> = s.shapes.iter().filter(|x| x.entity.name == "trianglemesh").collect();
    assert_eq!(meshes.len(), 5, "{w:?}");
    assert_eq!(s.shapes.iter().filter(|x| x.area_light.is_some()).count(), 5);
    let p = Params::new(&meshes[4].entity.params);
    assert_eq!(p.point3s("P").unwrap().len(), 8);
    assert_eq!(p.ints("indices").unwrap().len(), 12);
    assert!(p.string("filename", "").is_empty());
    let plate = Params::new(&meshes[0].entity.params);
    assert_eq!(plate.point3s("P").unwrap().len(), 4);
    assert_eq!(plate.ints("indices").unwrap().len(), 6);
    assert_eq!(s.sampler.name, "random");
    assert_eq!(s.filter.name, "gaussian");
}

#[test]
fn other_shared_scenes_have_sensible_counts() {
    if let Some((s, _)) = shared("instances/instances-whitted.pbrt") {
        assert_eq!(
            (s.objects.len(), s.instances.len(), s.shapes.len(), s.lights.len()),
            (1, 10, 1, 2)
        );
        assert_eq!(s.objects[0].shapes.len(), 1);
        assert_eq!(s.textures.len(), 1);
        let kd = Params::new(&s.materials[s.shapes[0].material.unwrap() as usize].entity.params)
            .texture("Kd")
            .cloned();
        assert_eq!(kd.unwrap().spectrum_id, Some(0));
    }
    if let Some((s, _)) =
        shared("spheres-differentials-texfilt/spheres-differentials-texfilt-whitted.pbrt")
    {
        assert_eq!(s.sampler.name, "lowdiscrepancy");
        assert_eq!(s.textures.len(), 2);
        let key = Params::new(&s.textures[1].entity.params).string("filename", "");
        assert_eq!(key, "textures/lines.png", "keys are relative to the scene's folder");
        assert_eq!(s.assets[&key].len(), 734);
        assert_eq!(s.materials[s.shapes[1].material.unwrap() as usize].entity.name, "mirror");
    }
    if let Some((s, _)) = shared("cornell-box/cornell-box-whitted.pbrt") {
        assert_eq!(s.shapes.len(), 6);
        assert_eq!(s.materials.iter().filter(|m| m.name.is_some()).count(), 5);
        let emitter = s.shapes.iter().find(|x| x.area_light.is_some()).unwrap();
        assert_eq!(
            s.materials[emitter.material.unwrap() as usize].name.as_deref(),
            Some("Emitter")
        );
    }
    if let Some((s, _)) = shared("all-shapes/all-shapes-whitted.pbrt") {
        assert_eq!((s.shapes.len(), s.lights.len()), (12, 2));
    }
    if let Some((s, _)) = shared("teapot-area-light/teapot-area-light-whitted.pbrt") {
        assert_eq!(s.accelerator.name, "kdtree");
        assert!(s.shapes.len() > 2000);
        // The point light is placed at the camera through CoordSysTransform.
        let cam = s.camera.world_from_camera.start;
        assert!(close(s.lights[0].world_from_light.start, cam));
    }
}

#[test]
fn teapot_parses_fast() {
    let path = Path::new(SCENES).join("teapot-area-light/teapot-area-light-whitted.pbrt");
    let Ok(text) = std::fs::read_to_string(&path) else {
        return;
    };
    let t = std::time::Instant::now();
    let (s, _) = parse_str(&text, "teapot.pbrt", path.parent().unwrap()).unwrap();
    let dt = t.elapsed();
    println!("teapot: {} shapes in {dt:?}", s.shapes.len());
    // Generous in debug builds; release takes a few milliseconds.
    assert!(dt.as_secs_f64() < if cfg!(debug_assertions) { 2.0 } else { 0.1 });
}

#[test]
fn error_locations() {
    let e = err("Shape \"sphere\"\n  Material \"matte\n");
    assert_eq!(e, "t.pbrt:2:12: unterminated string (expected a closing '\"')");
    let e = err("WorldBegin\n   Shaep \"sphere\"\n");
    assert!(e.starts_with("t.pbrt:2:4: unknown directive \"Shaep\""), "{e}");
    let e = err("WorldBegin\nShape \"sphere\" \"float radius\" [\"abc\"]\n");
    assert!(
        e.starts_with(
            "t.pbrt:2:32: value string \"abc\" for parameter \"float radius\" (expected a number)"
        ),
        "{e}"
    );
    let e = err("WorldBegin\nShape \"sphere\" \"flaot radius\" 1\n");
    assert!(e.starts_with("t.pbrt:2:16: bad parameter declaration \"flaot radius\""), "{e}");
    let e = err("WorldBegin\nMaterial \"matte\" \"rgb Kd\" [1 2]\n");
    assert!(e.starts_with("t.pbrt:2:18: parameter \"rgb Kd\" has 2 values"), "{e}");
    let e = err("WorldBegin\nShape \"sphere\" \"float radius\" [ 1 2\n");
    assert!(e.starts_with("t.pbrt:2:16: unexpected end of file in the values of parameter"), "{e}");
    let e = err("WorldBegin\n Include \"no/such/file.pbrt\"\n");
    assert!(e.starts_with("t.pbrt:2:2: cannot read \"./no/such/file.pbrt\""), "{e}");
    let e = err("Translate 1 2 x\n");
    assert!(
        e.starts_with("t.pbrt:1:15: unexpected \"x\" (expected a finite number for Translate)"),
        "{e}"
    );
    // NaN and infinite transforms are refused where they are written.
    let e = err("LookAt 0 0 5  nan 0 0  0 1 0\n");
    assert!(
        e.starts_with("t.pbrt:1:15: unexpected \"nan\" (expected a finite number for LookAt)"),
        "{e}"
    );
    let e = err("WorldBegin\nScale 1 1e39 1\n");
    assert!(e.starts_with("t.pbrt:2:9: unexpected \"1e39\""), "{e}");
    let e = err("Transform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 inf 1]\n");
    assert!(e.contains("(expected a finite number for Transform)"), "{e}");
    let e = err("WorldBegin Shape \"plymesh\" \"string filename\" \"none.ply\"");
    assert!(e.starts_with("t.pbrt:1:28: cannot read \"./none.ply\""), "{e}");
    for e in [err("\"Shape\""), err("Rotate 1 2 3")] {
        assert!(!e.contains('\n'), "{e}");
    }
}

#[test]
fn truncated_ply_is_an_error_with_path() {
    let dir = temp_dir("ply");
    let mut d = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
        .to_vec();
    d.extend([0u8; 36]);
    d.extend([3u8, 0, 0, 0, 0]);
    std::fs::write(dir.join("t.ply"), &d).unwrap();
    let src = "WorldBegin\n  Shape \"plymesh\" \"string filename\" \"t.ply\"\n";
    let e = parse_str(src, "s.pbrt", &dir).unwrap_err();
    assert!(matches!(e, SceneError::BadFile { kind: "PLY", .. }));
    let msg = e.to_string();
    assert!(msg.starts_with("s.pbrt:2:19: malformed PLY file \""), "{msg}");
    assert!(msg.contains("t.ply") && msg.contains("truncated"), "{msg}");
    std::fs::remove_dir_all(dir).ok();
}

/// Files are found as pbrt-v3 finds them: relative to the main file's
/// directory first (its search directory), then to the naming file's own.
/// An included file that names a PLY from the main directory (as San
/// Miguel's do) and one that names a file beside itself both load; a name
/// found in neither is an error naming the search directory's path.
#[test]
fn files_resolve_against_the_main_directory_then_the_including_one() {
    let dir = temp_dir("search");
    std::fs::create_dir_all(dir.join("geometry")).unwrap();
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    std::fs::write(dir.join("geometry/main-relative.ply"), ply).unwrap();
    std::fs::write(dir.join("geometry/beside.ply"), ply).unwrap();
    std::fs::write(dir.join("geometry/beside.pbrt"), "Shape \"sphere\"\n").unwrap();
    std::fs::write(
        dir.join("geometry/part.pbrt"),
        "Shape \"plymesh\" \"string filename\" \"geometry/main-relative.ply\"\n\
         Shape \"plymesh\" \"string filename\" \"beside.ply\"\n\
         Include \"beside.pbrt\"\n",
    )
    .unwrap();
    std::fs::write(dir.join("main.pbrt"), "WorldBegin\nInclude \"geometry/part.pbrt\"\nWorldEnd\n")
        .unwrap();
    let (s, w) = crate::parse_file(&dir.join("main.pbrt")).unwrap();
    assert!(w.is_empty(), "{w:?}");
    let names: Vec<&str> = s.shapes.iter().map(|s| s.entity.name.as_str()).collect();
    assert_eq!(names, ["trianglemesh", "trianglemesh", "sphere"]);

    std::fs::write(
        dir.join("geometry/part.pbrt"),
        "Shape \"plymesh\" \"string filename\" \"nowhere.ply\"\n",
    )
    .unwrap();
    let e = crate::parse_file(&dir.join("main.pbrt")).unwrap_err().to_string();
    assert!(
        e.contains("part.pbrt:1:") && e.contains(&*dir.join("nowhere.ply").to_string_lossy()),
        "{e}"
    );
    std::fs::remove_dir_all(dir).ok();
}

/// pbrt-v3's command line: files read as one stream, a scene ending at
/// each WorldEnd; options in one file and the world in another make one
/// scene; `.pbrt.gz` is read as pbrt-v4 reads it.
#[test]
fn several_files_are_one_stream_of_scenes() {
    use std::io::Write;
    let dir = temp_dir("stream");
    let two = "Film \"image\" \"integer xresolution\" [ 8 ]\nWorldBegin\nShape \"sphere\"\nWorldEnd\n\
               Film \"image\" \"integer xresolution\" [ 9 ]\nWorldBegin\nShape \"disk\"\nShape \"disk\"\nWorldEnd\n";
    std::fs::write(dir.join("two.pbrt"), two).unwrap();
    std::fs::write(dir.join("options.pbrt"), "Film \"image\" \"integer xresolution\" [ 7 ]\n")
        .unwrap();
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(b"WorldBegin\nShape \"sphere\"\nWorldEnd\n").unwrap();
    std::fs::write(dir.join("world.pbrt.gz"), gz.finish().unwrap()).unwrap();

    let scenes = crate::parse_files(&[dir.join("two.pbrt")]).unwrap();
    let res = |s: &SceneDescription| Params::new(&s.film.params).int("xresolution", 0);
    let got: Vec<(i32, usize)> = scenes.iter().map(|(s, _)| (res(s), s.shapes.len())).collect();
    assert_eq!(got, [(8, 1), (9, 2)]);
    assert!(scenes.iter().all(|(_, w)| w.is_empty()), "{scenes:?}");

    let scenes =
        crate::parse_files(&[dir.join("options.pbrt"), dir.join("world.pbrt.gz")]).unwrap();
    assert_eq!(scenes.len(), 1);
    assert_eq!((res(&scenes[0].0), scenes[0].0.shapes.len()), (7, 1));
    assert_eq!(scenes[0].0.name, "options");
    std::fs::write(dir.join("bad.pbrt.gz"), b"not gzip").unwrap();
    let e = crate::parse_files(&[dir.join("bad.pbrt.gz")]).unwrap_err().to_string();
    assert!(e.contains("bad.pbrt.gz"), "{e}");

    // As a stream: each scene comes as soon as the file it ends in is read,
    // with that file's index, before a later file is even opened.
    let files = [dir.join("two.pbrt"), dir.join("options.pbrt"), dir.join("world.pbrt.gz")];
    let mut stream = crate::SceneStream::new(&[&files[..], &[dir.join("missing.pbrt")]].concat());
    let mut got = Vec::new();
    for _ in 0..2 {
        let s = stream.next().unwrap().unwrap();
        got.push((res(&s.desc), s.file));
    }
    assert_eq!(got, [(8, 0), (9, 0)]);
    let s = stream.next().unwrap().unwrap();
    assert_eq!((res(&s.desc), s.file), (7, 2), "options and world make the third scene");
    let e = stream.next().unwrap().err().expect("the missing file").to_string();
    assert!(e.contains("missing.pbrt"), "{e}");
    assert!(stream.next().is_none(), "nothing after an error");
    std::fs::remove_dir_all(dir).ok();
}

/// `Material "fourier"` and a named one read their `bsdffile` into the
/// assets, under one key however often it is named; a missing file is an
/// error at the parameter.
#[test]
fn fourier_tables_are_assets() {
    let dir = temp_dir("fourier");
    std::fs::write(dir.join("t.bsdf"), b"SCATFUN\x01 whatever").unwrap();
    let src = "WorldBegin\nMaterial \"fourier\" \"string bsdffile\" \"t.bsdf\"\n\
               MakeNamedMaterial \"n\" \"string type\" \"fourier\" \"string bsdffile\" \"t.bsdf\"\n\
               WorldEnd\n";
    let (s, w) = parse_str(src, "s.pbrt", &dir).unwrap();
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(s.assets.len(), 1);
    assert_eq!(s.assets.values().next().unwrap(), b"SCATFUN\x01 whatever");
    let src = "WorldBegin\nMakeNamedMaterial \"n\" \"string type\" \"fourier\" \"string bsdffile\" \"gone.bsdf\"\n";
    let e = parse_str(src, "s.pbrt", &dir).unwrap_err().to_string();
    assert!(e.starts_with("s.pbrt:2:") && e.contains("gone.bsdf"), "{e}");
    std::fs::remove_dir_all(dir).ok();
}
