//! `--cat` and `--toply` (pbrt-v3's): the scene written back as pbrt-v3
//! text parses to the same description, on the project's scenes and the
//! shared pbrt-v3 scenes.

use farm_common::scene::SceneDescription;
use farm_scene::{parse_file, parse_str, write_scene, Meshes};
use farm_tests::shared_dir;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// The description as JSON with what the text cannot carry taken out:
/// source locations, the order of a directive's parameters, and which
/// shapes shared one anonymous material (each shape's material is put in
/// its place by content). The camera's matrices are compared apart, to
/// the rounding of inverting them twice.
fn normalised(s: &SceneDescription) -> Value {
    let mut v = serde_json::to_value(s).unwrap();
    let materials = v["materials"].clone();
    let place = |shapes: &mut Value| {
        for shape in shapes.as_array_mut().unwrap() {
            let m = shape["material"].as_u64().map(|i| materials[i as usize]["entity"].clone());
            shape["material"] = m.unwrap_or(Value::Null);
        }
    };
    place(&mut v["shapes"]);
    for o in v["objects"].as_array_mut().unwrap() {
        place(&mut o["shapes"]);
    }
    // Named materials by name; anonymous ones live on in their shapes.
    let mut named: Vec<Value> =
        materials.as_array().unwrap().iter().filter(|m| !m["name"].is_null()).cloned().collect();
    named.sort_by_key(|m| m["name"].to_string());
    v["materials"] = Value::Array(named);
    v["name"] = Value::Null;
    v["camera"]["world_from_camera"]["start"] = Value::Null;
    v["camera"]["world_from_camera"]["end"] = Value::Null;
    strip(&mut v);
    v
}

fn strip(v: &mut Value) {
    match v {
        Value::Object(m) => {
            m.remove("loc");
            if let Some(Value::Array(p)) = m.get_mut("params") {
                p.sort_by_key(|p| p["name"].to_string());
            }
            m.values_mut().for_each(strip);
        }
        Value::Array(a) => a.iter_mut().for_each(strip),
        _ => {}
    }
}

fn check(path: &Path, meshes: Meshes) -> Result<(), String> {
    let (a, _) = parse_file(path).map_err(|e| e.to_string())?;
    let text = write_scene(&a, meshes).map_err(|e| e.to_string())?;
    let dir = path.parent().unwrap();
    let (b, w) = parse_str(&text, "cat.pbrt", dir).map_err(|e| format!("{e}\n{text}"))?;
    // Where each light is among the shapes (not in the JSON compared below).
    let order = |s: &SceneDescription| s.lights.iter().map(|l| l.shapes_before).collect::<Vec<_>>();
    if order(&a) != order(&b) {
        return Err(format!("lights among the shapes {:?} became {:?}", order(&a), order(&b)));
    }
    if let Some(w) =
        w.iter().find(|w| w.message.contains("not used") || w.message.contains("unknown"))
    {
        return Err(format!("re-reading warns: {w}"));
    }
    let (ca, cb) = (&a.camera.world_from_camera, &b.camera.world_from_camera);
    for (x, y) in [(ca.start, cb.start), (ca.end, cb.end)] {
        if !x.abs_diff_eq(y, 1e-9 * x.abs().to_cols_array().iter().fold(1.0, |m: f64, v| m.max(*v)))
        {
            return Err(format!("camera {x} became {y}"));
        }
    }
    if a.assets != b.assets {
        return Err("assets differ".into());
    }
    let (na, nb) = (normalised(&a), normalised(&b));
    if na != nb {
        let (sa, sb) = (na.to_string(), nb.to_string());
        let at = sa.bytes().zip(sb.bytes()).position(|(x, y)| x != y).unwrap_or(0);
        let lo = at.saturating_sub(200);
        return Err(format!(
            "descriptions differ at byte {at}:\n  {}\n  {}",
            &sa[lo..(at + 200).min(sa.len())],
            &sb[lo..(at + 200).min(sb.len())]
        ));
    }
    Ok(())
}

fn scenes() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let mut v = vec![root.join("example.pbrt")];
    for f in std::fs::read_dir(root.join("parity")).unwrap() {
        let p = f.unwrap().path();
        if p.extension().is_some_and(|e| e == "pbrt") && p.file_stem().is_some_and(|s| s != "room")
        {
            v.push(p);
        }
    }
    match shared_dir() {
        Some(shared) => {
            for d in std::fs::read_dir(shared.join("scenes")).unwrap() {
                for f in std::fs::read_dir(d.unwrap().path()).unwrap() {
                    let p = f.unwrap().path();
                    if p.extension().is_some_and(|e| e == "pbrt") {
                        v.push(p);
                    }
                }
            }
        }
        None => eprintln!("SKIPPED the shared scenes: ../shared is not present"),
    }
    v.sort();
    // Some shared originals name files their folder lacks (their
    // `-whitted` variants are fixed); those cannot be read to begin with.
    // The project's own scenes must all read.
    v.retain(|p| match parse_file(p) {
        Ok(_) => true,
        Err(e) if p.starts_with(&root) => panic!("{}: {e}", p.display()),
        Err(e) => {
            eprintln!("skipping {}: {e}", p.display());
            false
        }
    });
    v
}

#[test]
fn cat_output_parses_back_to_the_same_scene() {
    let failures: Vec<String> = scenes()
        .iter()
        .filter_map(|p| check(p, Meshes::Inline).err().map(|e| format!("{}: {e}", p.display())))
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn toply_meshes_read_back_the_same() {
    let dir = std::env::temp_dir().join(format!("farm-toply-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut failures = Vec::new();
    for p in scenes() {
        // The PLY files are written beside a copy of the text, so the
        // scene's other files must be found from there: only scenes that
        // name none.
        let (a, _) = parse_file(&p).unwrap();
        if !a.assets.is_empty() {
            continue;
        }
        let text = write_scene(&a, Meshes::Ply { dir: &dir, prefix: "mesh" }).unwrap();
        let copy = dir.join("scene.pbrt");
        std::fs::write(&copy, &text).unwrap();
        if text.contains("\"trianglemesh\"") {
            failures.push(format!("{}: a mesh was written inline", p.display()));
        }
        let (b, _) = parse_file(&copy).unwrap();
        if normalised(&a)["shapes"].as_array().map(Vec::len)
            != normalised(&b)["shapes"].as_array().map(Vec::len)
        {
            failures.push(format!("{}: shape counts differ", p.display()));
        }
        if let Err(e) = check(&copy, Meshes::Inline) {
            failures.push(format!("{}: {e}", p.display()));
        }
        let meshes = |s: &SceneDescription| -> Vec<Value> {
            s.shapes
                .iter()
                .filter(|s| s.entity.name == "trianglemesh")
                .map(|s| {
                    let mut v = serde_json::to_value(&s.entity.params).unwrap();
                    strip(&mut v);
                    v
                })
                .collect()
        };
        if meshes(&a) != meshes(&b) {
            failures.push(format!("{}: meshes differ after PLY", p.display()));
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
