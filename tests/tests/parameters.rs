//! Parameter parity with pbrt-v3, walked from the table of every parameter
//! pbrt-v3's constructors read (`../shared/reference/pbrt-v3-parameters.tsv`:
//! file, function, how it is read, name, default).
//!
//! For each constructor of a type farm has, two scenes are built:
//! - one that gives every parameter of the table, with a value of the type
//!   pbrt-v3 reads it as: none of them may draw a "not used" warning, and
//!   each must be looked up;
//! - one that gives none: every lookup that falls back on a default must
//!   fall back on pbrt-v3's.
//!
//! Where pbrt-v3 reads a name farm does not, or a constructor farm lacks,
//! the lists below say why.

use farm_common::image::{write_image, ImageMetadata, RgbImage};
use farm_common::scene::{record_lookups, Lookup, Warning};
use farm_render::{RenderOptions, Renderer};
use farm_tests::shared_dir;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Constructors farm does not have, and why.
const MISSING: &[(&str, &str)] = &[
    ("CreateAOIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreateBDPTIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreateDirectLightingIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreateMLTIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreatePathIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreateSPPMIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreateVolPathIntegrator", "farm renders with pbrt-v3's Whitted integrator only"),
    ("CreateKdTreeAccelerator", "farm builds a BVH for every scene, with a warning"),
    ("MakeMedium", "participating media: pbrt-v3's Whitted integrator ignores them"),
    ("pbrtMakeNamedMedium", "participating media: pbrt-v3's Whitted integrator ignores them"),
    ("CreatePtexFloatTexture", "no Ptex reader; the texture is refused with a warning naming it"),
    (
        "CreatePtexSpectrumTexture",
        "no Ptex reader; the texture is refused with a warning naming it",
    ),
    // Not yet built (issue 13); each leaves this list when it lands.
    ("CreateRealisticCamera", "not built yet"),
    ("CreateDisneyMaterial", "not built yet"),
    ("CreateHairMaterial", "not built yet"),
    ("CreateFourierMaterial", "not built yet"),
    ("CreateNURBS", "not built yet"),
];

/// Names a constructor farm has reads in pbrt-v3 but not in farm, and why.
const NOT_READ: &[(&str, &str, &str)] = &[];

/// Defaults the table gives as C++ expressions rather than values, and what
/// they are; the test checks these names are read, not their default.
const EXPRESSION_DEFAULTS: &[(&str, &str, &str)] = &[
    ("CreateCurveShape", "splitdepth", "read as a float, then as an integer: 3 either way"),
    ("CreateCurveShape", "width0", "defaults to `width`"),
    ("CreateCurveShape", "width1", "defaults to `width`"),
    (
        "CreateDiffuseAreaLight",
        "samples",
        "defaults to `nsamples`; the Whitted integrator ignores both",
    ),
    (
        "CreateInfiniteLight",
        "samples",
        "defaults to `nsamples`; the Whitted integrator ignores both",
    ),
    ("CreateImageFloatTexture", "gamma", "true for .tga and .png files, else false"),
    ("CreateImageSpectrumTexture", "gamma", "true for .tga and .png files, else false"),
    ("CreateLoopSubdiv", "levels", "defaults to `nlevels`, itself 3"),
    ("CreateMetalMaterial", "eta", "copper's measured index of refraction"),
    ("CreateMetalMaterial", "k", "copper's measured absorption"),
    ("CreateOrthographicCamera", "frameaspectratio", "the film's aspect ratio"),
    ("CreatePerspectiveCamera", "frameaspectratio", "the film's aspect ratio"),
    ("CreateEnvironmentCamera", "frameaspectratio", "the film's aspect ratio"),
    ("CreateKdSubsurfaceMaterial", "Kd", "grey 0.5, for the BSSRDF, which Whitted ignores"),
    (
        "CreateSubsurfaceMaterial",
        "sigma_a",
        "measured skim milk, for the BSSRDF, which Whitted ignores",
    ),
    (
        "CreateSubsurfaceMaterial",
        "sigma_s",
        "measured skim milk, for the BSSRDF, which Whitted ignores",
    ),
    ("CreateSphereShape", "zmin", "-radius"),
    ("CreateSphereShape", "zmax", "radius"),
];

/// One row of the table.
#[derive(Clone, Debug)]
struct Row {
    function: String,
    read_as: String,
    name: String,
    default: String,
}

fn table(shared: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(shared.join("reference/pbrt-v3-parameters.tsv"))
        .expect("pbrt-v3-parameters.tsv");
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            assert!(f.len() >= 5, "bad table line {l:?}");
            Row {
                function: f[2].to_string(),
                read_as: f[3].to_string(),
                name: f[4].to_string(),
                default: f.get(5).unwrap_or(&"").to_string(),
            }
        })
        .collect()
}

/// Where a constructor's parameters are written in a scene.
#[derive(Clone, Copy, Debug)]
enum Slot {
    /// A directive before `WorldBegin`: `Camera "name" …`.
    Options(&'static str, &'static str),
    /// A directive in the world, followed by a sphere.
    World(&'static str, &'static str),
    /// `Texture "t" "float"|"spectrum" "name" …`.
    Texture(&'static str, &'static str),
    /// `AreaLightSource "diffuse" …` on a sphere.
    AreaLight,
    /// `Shape "name" …`.
    Shape(&'static str),
}

fn slot(function: &str) -> Option<Slot> {
    use Slot::*;
    Some(match function {
        "CreateBVHAccelerator" => Options("Accelerator", "bvh"),
        "CreatePerspectiveCamera" => Options("Camera", "perspective"),
        "CreateOrthographicCamera" => Options("Camera", "orthographic"),
        "CreateEnvironmentCamera" => Options("Camera", "environment"),
        "CreateRealisticCamera" => Options("Camera", "realistic"),
        "CreateFilm" => Options("Film", "image"),
        "CreateBoxFilter" => Options("PixelFilter", "box"),
        "CreateGaussianFilter" => Options("PixelFilter", "gaussian"),
        "CreateMitchellFilter" => Options("PixelFilter", "mitchell"),
        "CreateSincFilter" => Options("PixelFilter", "sinc"),
        "CreateTriangleFilter" => Options("PixelFilter", "triangle"),
        "CreateWhittedIntegrator" => Options("Integrator", "whitted"),
        "CreateHaltonSampler" => Options("Sampler", "halton"),
        "CreateMaxMinDistSampler" => Options("Sampler", "maxmindist"),
        "CreateRandomSampler" => Options("Sampler", "random"),
        "CreateSobolSampler" => Options("Sampler", "sobol"),
        "CreateStratifiedSampler" => Options("Sampler", "stratified"),
        "CreateZeroTwoSequenceSampler" => Options("Sampler", "02sequence"),
        "CreateDistantLight" => World("LightSource", "distant"),
        "CreateInfiniteLight" => World("LightSource", "infinite"),
        "CreatePointLight" => World("LightSource", "point"),
        "CreateSpotLight" => World("LightSource", "spot"),
        "CreateGoniometricLight" => World("LightSource", "goniometric"),
        "CreateProjectionLight" => World("LightSource", "projection"),
        "CreateDiffuseAreaLight" => AreaLight,
        "CreateGlassMaterial" => World("Material", "glass"),
        "CreateMatteMaterial" => World("Material", "matte"),
        "CreateMetalMaterial" => World("Material", "metal"),
        "CreateMirrorMaterial" => World("Material", "mirror"),
        "CreateMixMaterial" | "MakeMaterial" => World("Material", "mix"),
        "pbrtMakeNamedMaterial" => World("MakeNamedMaterial", "m"),
        "CreatePlasticMaterial" => World("Material", "plastic"),
        "CreateSubstrateMaterial" => World("Material", "substrate"),
        "CreateTranslucentMaterial" => World("Material", "translucent"),
        "CreateUberMaterial" => World("Material", "uber"),
        "CreateDisneyMaterial" => World("Material", "disney"),
        "CreateHairMaterial" => World("Material", "hair"),
        "CreateKdSubsurfaceMaterial" => World("Material", "kdsubsurface"),
        "CreateSubsurfaceMaterial" => World("Material", "subsurface"),
        "CreateFourierMaterial" => World("Material", "fourier"),
        "CreateConeShape" => Shape("cone"),
        "CreateCurveShape" => Shape("curve"),
        "CreateCylinderShape" => Shape("cylinder"),
        "CreateDiskShape" => Shape("disk"),
        "CreateHeightfield" => Shape("heightfield"),
        "CreateHyperboloidShape" => Shape("hyperboloid"),
        "CreateLoopSubdiv" => Shape("loopsubdiv"),
        "CreateNURBS" => Shape("nurbs"),
        "CreatePLYMesh" => Shape("plymesh"),
        "CreateParaboloidShape" => Shape("paraboloid"),
        "CreateSphereShape" => Shape("sphere"),
        "CreateTriangleMeshShape" | "MakeShapes" => Shape("trianglemesh"),
        f if f.starts_with("Create") && f.ends_with("Texture") => {
            let (base, kind) = if let Some(b) = f.strip_suffix("FloatTexture") {
                (b, "float")
            } else {
                (f.strip_suffix("SpectrumTexture")?, "spectrum")
            };
            let name = match &base["Create".len()..] {
                "Bilerp" => "bilerp",
                "Checkerboard" => "checkerboard",
                "Constant" => "constant",
                "Dots" => "dots",
                "FBm" => "fbm",
                "Image" => "imagemap",
                "Marble" => "marble",
                "Mix" => "mix",
                "Ptex" => "ptex",
                "Scale" => "scale",
                "UV" => "uv",
                "Wrinkled" => "wrinkled",
                _ => return None,
            };
            Texture(kind, name)
        }
        _ => return None,
    })
}

/// A value for a parameter that pbrt-v3 reads as a list, or as a file.
fn special(function: &str, name: &str) -> Option<&'static str> {
    let mesh = matches!(function, "CreateTriangleMeshShape" | "MakeShapes");
    Some(match name {
        "cropwindow" => r#""float cropwindow" [0 1 0 1]"#,
        "screenwindow" => r#""float screenwindow" [-1 1 -1 1]"#,
        "pixelbounds" => r#""integer pixelbounds" [0 16 0 16]"#,
        "filename" if function == "CreateFilm" => r#""string filename" "out.exr""#,
        "filename" if function == "CreatePLYMesh" => r#""string filename" "quad.ply""#,
        "filename" => r#""string filename" "tex.pfm""#,
        "mapname" => r#""string mapname" "tex.pfm""#,
        "namedmaterial1" => r#""string namedmaterial1" "one""#,
        "namedmaterial2" => r#""string namedmaterial2" "two""#,
        "indices" if mesh => r#""integer indices" [0 1 2 0 2 3]"#,
        "P" if mesh => r#""point3 P" [0 0 0 1 0 0 1 1 0 0 1 0]"#,
        "uv" if mesh => r#""point2 uv" [0 0 1 0 1 1 0 1]"#,
        "st" if mesh => r#""point2 st" [0 0 1 0 1 1 0 1]"#,
        "N" if mesh => r#""normal N" [0 0 1 0 0 1 0 0 1 0 0 1]"#,
        "S" if mesh => r#""vector3 S" [1 0 0 1 0 0 1 0 0 1 0 0]"#,
        "faceIndices" if mesh => r#""integer faceIndices" [0 1]"#,
        "indices" => r#""integer indices" [0 1 2 0 2 3]"#,
        "P" if function == "CreateLoopSubdiv" => r#""point3 P" [0 0 0 1 0 0 1 1 0 0 1 0]"#,
        "P" if function == "CreateCurveShape" => r#""point3 P" [0 0 0 1 0 0 1 1 0 0 1 0]"#,
        "Pz" => r#""float Pz" [0 1 1 0]"#,
        "nu" if function == "CreateHeightfield" => r#""integer nu" [2]"#,
        "nv" if function == "CreateHeightfield" => r#""integer nv" [2]"#,
        "N" if function == "CreateCurveShape" => r#""normal N" [0 0 1 0 0 1]"#,
        "type" if function == "CreateCurveShape" => r#""string type" "flat""#,
        "basis" => r#""string basis" "bezier""#,
        "splitmethod" => r#""string splitmethod" "sah""#,
        "mapping" => r#""string mapping" "uv""#,
        "wrap" => r#""string wrap" "repeat""#,
        "bumpmap" | "alpha" | "shadowalpha" | "amount" | "tex1" | "tex2" | "tex" => {
            return None;
        }
        _ => return None,
    })
}

/// A parameter of the row's type, or `None` where only a list would do.
fn value(row: &Row) -> String {
    if let Some(v) = special(&row.function, &row.name) {
        return v.to_string();
    }
    let n = &row.name;
    let num = parse_default(&row.default)
        .and_then(|d| match d {
            Default::Numbers(v) if v.len() == 1 && v[0].is_finite() => Some(v[0]),
            _ => None,
        })
        .unwrap_or(1.0);
    let s = |x: f64| format!("{x}");
    match row.read_as.as_str() {
        "FindOneFloat" | "FindFloat" | "GetFloatTexture" | "GetFloatTextureOrNull" => {
            format!(r#""float {n}" [{}]"#, s(num))
        }
        "FindOneInt" | "FindInt" => format!(r#""integer {n}" [{}]"#, num.round() as i64),
        "FindOneBool" | "FindBool" => format!(r#""bool {n}" "true""#),
        "FindOneString" | "FindString" | "FindOneFilename" | "FindFilename" => {
            match parse_default(&row.default) {
                Some(Default::Text(t)) if !t.is_empty() => format!(r#""string {n}" "{t}""#),
                _ => format!(r#""string {n}" "x""#),
            }
        }
        "FindOneSpectrum" | "FindSpectrum" | "GetSpectrumTexture" | "GetSpectrumTextureOrNull" => {
            format!(r#""rgb {n}" [0.5 0.5 0.5]"#)
        }
        "FindOnePoint3f" | "FindPoint3f" => format!(r#""point3 {n}" [0 0 1]"#),
        "FindVector3f" => format!(r#""vector3 {n}" [0 0 1]"#),
        "FindNormal3f" => format!(r#""normal {n}" [0 0 1]"#),
        "FindPoint2f" => format!(r#""point2 {n}" [0 0]"#),
        "FindTexture" => format!(r#""texture {n}" "ftex""#),
        other => panic!("read_as {other} not known to this test"),
    }
}

/// A table default, as a value this test can compare.
#[derive(Clone, Debug, PartialEq)]
enum Default {
    Numbers(Vec<f64>),
    Bool(bool),
    Text(String),
    /// A list lookup (`&n`): no default.
    List,
}

fn number(s: &str) -> Option<f64> {
    let s = s.trim();
    if let Some((a, b)) = s.split_once('/') {
        return Some(number(a)? / number(b)?);
    }
    match s {
        "Infinity" => return Some(f64::INFINITY),
        "Pi" => return Some(std::f64::consts::PI),
        _ => {}
    }
    let s = s.strip_suffix('f').unwrap_or(s);
    let s = s.strip_prefix("Float(").and_then(|r| r.strip_suffix(')')).unwrap_or(s);
    s.parse::<f64>().ok()
}

fn parse_default(d: &str) -> Option<Default> {
    let d = d.trim();
    if d.is_empty() || d.starts_with('&') {
        return Some(Default::List);
    }
    if let Some(t) = d.strip_prefix('"').and_then(|r| r.strip_suffix('"')) {
        return Some(Default::Text(t.to_string()));
    }
    match d {
        "true" => return Some(Default::Bool(true)),
        "false" => return Some(Default::Bool(false)),
        _ => {}
    }
    if let Some(x) = number(d) {
        return Some(Default::Numbers(vec![x]));
    }
    for ctor in ["Spectrum(", "Vector3f(", "Point3f(", "Point2f(", "Normal3f("] {
        if let Some(args) = d.strip_prefix(ctor).and_then(|r| r.strip_suffix(')')) {
            let v: Option<Vec<f64>> = args.split(',').map(number).collect();
            let mut v = v?;
            if ctor == "Spectrum(" && v.len() == 1 {
                v = vec![v[0]; 3];
            }
            return Some(Default::Numbers(v));
        }
    }
    None
}

/// A recorded default (`{:?}` of the value) as a comparable value.
fn recorded(l: &Lookup) -> Option<Default> {
    let d = l.default.as_deref()?;
    // `Vec3(1.0, 0.0, 0.0)`: the numbers are inside the brackets.
    let d = d.split_once('(').map_or(d, |(_, r)| r);
    if l.kind == "string" {
        return Some(Default::Text(d.trim_matches('"').to_string()));
    }
    if l.kind == "bool" {
        return Some(Default::Bool(d == "true"));
    }
    let mut nums = Vec::new();
    let mut cur = String::new();
    for c in d.chars().chain([' ']) {
        if c.is_ascii_digit() || matches!(c, '.' | '-' | 'e' | 'i' | 'n' | 'f') {
            cur.push(c);
        } else {
            if let Some(x) = number(&cur).or(if cur == "inf" { Some(f64::INFINITY) } else { None })
            {
                nums.push(x);
            }
            cur.clear();
        }
    }
    Some(Default::Numbers(nums))
}

fn same(a: &Default, b: &Default) -> bool {
    match (a, b) {
        (Default::Numbers(x), Default::Numbers(y)) => {
            // pbrt-v3 converts a scalar default to a grey spectrum.
            let splat =
                |v: &Vec<f64>, n: usize| if v.len() == 1 { vec![v[0]; n] } else { v.clone() };
            let (x, y) = (splat(x, y.len()), splat(y, x.len()));
            x.len() == y.len()
                && x.iter().zip(&y).all(|(a, b)| a == b || (a - b).abs() <= 1e-6 * a.abs().max(1.0))
        }
        _ => a == b,
    }
}

/// The scene for one constructor, with the given parameter text; without
/// the directive under test when `with` is false (the baseline whose
/// lookups are taken away from the scene's, so only the constructor's own
/// remain). Options directives are never left out: a default one would be
/// built in their place.
fn scene(slot: Slot, params: &str, with: bool) -> String {
    let mut pre = String::new();
    let mut world = String::from(
        "Texture \"ftex\" \"float\" \"constant\" \"float value\" [0.5]\n\
         Texture \"stex\" \"spectrum\" \"constant\" \"rgb value\" [0.5 0.5 0.5]\n\
         MakeNamedMaterial \"one\" \"string type\" \"matte\"\n\
         MakeNamedMaterial \"two\" \"string type\" \"plastic\"\n",
    );
    let film = "Film \"image\" \"integer xresolution\" [16] \"integer yresolution\" [16]\n";
    let directive = match slot {
        Slot::Options(directive, name) => {
            if directive != "Film" {
                pre.push_str(film);
            }
            pre.push_str(&format!("{directive} \"{name}\" {params}\n"));
            String::new()
        }
        Slot::World(directive, name) => {
            pre.push_str(film);
            format!("{directive} \"{name}\" {params}\n")
        }
        Slot::Texture(kind, name) => {
            pre.push_str(film);
            format!("Texture \"t\" \"{kind}\" \"{name}\" {params}\n")
        }
        Slot::AreaLight => {
            pre.push_str(film);
            format!("AreaLightSource \"diffuse\" {params}\n")
        }
        Slot::Shape(name) => {
            pre.push_str(film);
            format!("Shape \"{name}\" {params}\n")
        }
    };
    if with {
        world.push_str(&directive);
    }
    if !matches!(slot, Slot::Shape(_)) {
        world.push_str("Shape \"sphere\"\n");
    }
    format!("{pre}WorldBegin\nAttributeBegin\n{world}AttributeEnd\nWorldEnd\n")
}

/// The lookups the directive under test made: the scene's, less the
/// baseline's (as multisets).
fn own_lookups(
    dir: &Path,
    function: &str,
    slot: Slot,
    params: &str,
) -> Result<(Vec<Warning>, Vec<Lookup>), String> {
    let params = format!("{} {params}", required(function));
    let (warnings, mut lookups) = build(dir, &scene(slot, &params, true))?;
    if !matches!(slot, Slot::Options(..)) {
        let (_, base) = build(dir, &scene(slot, "", false))?;
        for b in base {
            if let Some(i) = lookups.iter().position(|l| *l == b) {
                lookups.remove(i);
            }
        }
    }
    Ok((warnings, lookups))
}

/// Parameters a constructor cannot do without, given in every scene.
fn required(function: &str) -> &'static str {
    match function {
        "CreatePLYMesh" => r#""string filename" "quad.ply""#,
        _ => "",
    }
}

/// Parameters another must accompany for pbrt-v3 to read it at all.
fn companion(function: &str, name: &str) -> &'static str {
    let texture = function.ends_with("Texture");
    match name {
        "v1" | "v2" if texture => r#""string mapping" "planar""#,
        _ => "",
    }
}

/// The type name our lookups record for a way pbrt-v3 reads a parameter.
fn kind(read_as: &str) -> &'static str {
    match read_as {
        "FindOneFloat" | "FindFloat" | "GetFloatTexture" | "GetFloatTextureOrNull" => "float",
        "FindOneInt" | "FindInt" => "integer",
        "FindOneBool" | "FindBool" => "bool",
        "FindOneString" | "FindString" | "FindOneFilename" | "FindFilename" => "string",
        "FindOneSpectrum" | "FindSpectrum" | "GetSpectrumTexture" | "GetSpectrumTextureOrNull" => {
            "spectrum"
        }
        "FindOnePoint3f" | "FindPoint3f" => "point3",
        "FindVector3f" => "vector3",
        "FindNormal3f" => "normal",
        "FindPoint2f" => "point2",
        "FindTexture" => "texture",
        other => panic!("read_as {other} not known to this test"),
    }
}

/// Builds the scene's renderer, returning its warnings and the lookups made.
fn build(dir: &Path, text: &str) -> Result<(Vec<Warning>, Vec<Lookup>), String> {
    let (parsed, mut lookups) = record_lookups(|| farm_scene::parse_str(text, "params.pbrt", dir));
    let (desc, mut warnings) = parsed.map_err(|e| e.to_string())?;
    let (built, more) = record_lookups(|| Renderer::new(&desc, &RenderOptions::default()));
    lookups.extend(more);
    let (_, w) = built.map_err(|e| e.to_string())?;
    warnings.extend(w);
    Ok((warnings, lookups))
}

fn write_assets(dir: &Path) {
    let img = RgbImage {
        width: 2,
        height: 2,
        pixels: (0..4).map(|i| [0.25 * (i + 1) as f32; 3]).collect(),
    };
    write_image(&dir.join("tex.pfm"), &img, &ImageMetadata::default()).expect("texture");
    std::fs::write(
        dir.join("quad.ply"),
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n",
    )
    .expect("ply");
}

#[test]
fn every_parameter_pbrt_v3_reads_is_read_with_its_default() {
    let Some(shared) = shared_dir() else {
        eprintln!("SKIPPED: ../shared (with pbrt-v3's parameter table) is not present");
        return;
    };
    let rows = table(&shared);
    let dir = std::env::temp_dir().join(format!("farm-params-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write_assets(&dir);

    let mut by_function: BTreeMap<String, Vec<Row>> = BTreeMap::new();
    for r in rows {
        by_function.entry(r.function.clone()).or_default().push(r);
    }
    let missing: BTreeMap<&str, &str> = MISSING.iter().copied().collect();
    let not_read: BTreeSet<(&str, &str)> = NOT_READ.iter().map(|(f, n, _)| (*f, *n)).collect();
    let expressions: BTreeSet<(&str, &str)> =
        EXPRESSION_DEFAULTS.iter().map(|(f, n, _)| (*f, *n)).collect();
    let mut failures = Vec::new();
    let mut checked = (0, 0);

    for (function, rows) in &by_function {
        if missing.contains_key(function.as_str()) {
            continue;
        }
        let Some(slot) = slot(function) else {
            failures
                .push(format!("{function}: neither mapped to a directive nor listed as missing"));
            continue;
        };
        // Every parameter given: none unused, each looked up. A name that
        // is not read beside the others (pbrt-v3 reads `index` only without
        // `eta`) must be read when given alone.
        let mut names = BTreeSet::new();
        let given: Vec<(String, String)> = rows
            .iter()
            .filter(|r| !not_read.contains(&(function.as_str(), r.name.as_str())))
            .filter(|r| names.insert(r.name.clone()))
            .map(|r| (r.name.clone(), value(r)))
            .collect();
        let all: Vec<&str> = given.iter().map(|(_, v)| v.as_str()).collect();
        let together = own_lookups(&dir, function, slot, &all.join(" "));
        if let Err(e) = &together {
            failures.push(format!("{function}: all parameters given: {e}"));
        }
        for (name, v) in &given {
            let read = |r: &Result<(Vec<Warning>, Vec<Lookup>), String>| match r {
                Ok((warnings, lookups)) => {
                    let unused = format!("Parameter \"{name}\" not used");
                    match warnings.iter().find(|w| w.to_string().contains(&unused)) {
                        Some(w) => Err(w.to_string()),
                        None if !lookups.iter().any(|l| &l.name == name) => {
                            Err(format!("\"{name}\" is never looked up"))
                        }
                        None => Ok(()),
                    }
                }
                Err(e) => Err(e.clone()),
            };
            checked.0 += 1;
            if read(&together).is_ok() {
                continue;
            }
            let alone =
                own_lookups(&dir, function, slot, &format!("{v} {}", companion(function, name)));
            if let Err(e) = read(&alone) {
                failures.push(format!("{function}: {e}"));
            }
        }
        // None given: each default is pbrt-v3's.
        let lookups = match own_lookups(&dir, function, slot, "") {
            Err(e) => {
                failures.push(format!("{function}: no parameters given: {e}"));
                continue;
            }
            Ok((_, l)) => l,
        };
        for name in &names {
            let defaults: Vec<&Row> = rows.iter().filter(|r| &r.name == name).collect();
            let theirs: Vec<Option<Default>> =
                defaults.iter().map(|r| parse_default(&r.default)).collect();
            if theirs.iter().all(|d| matches!(d, Some(Default::List))) {
                continue;
            }
            if theirs.iter().any(|d| d.is_none()) {
                if !expressions.contains(&(function.as_str(), name.as_str())) {
                    failures.push(format!(
                        "{function}: \"{name}\" defaults to an expression ({}) not explained here",
                        defaults.iter().map(|r| r.default.as_str()).collect::<Vec<_>>().join(" | ")
                    ));
                }
                continue;
            }
            let kinds: BTreeSet<&str> = defaults.iter().map(|r| kind(&r.read_as)).collect();
            for l in lookups.iter().filter(|l| &l.name == name && kinds.contains(l.kind)) {
                let Some(ours) = recorded(l) else { continue };
                if !theirs.iter().flatten().any(|t| same(t, &ours)) {
                    failures.push(format!(
                        "{function}: \"{name}\" defaults to {} here, {} in pbrt-v3",
                        l.default.as_deref().unwrap_or("?"),
                        defaults.iter().map(|r| r.default.as_str()).collect::<Vec<_>>().join(" | ")
                    ));
                }
                checked.1 += 1;
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    println!("{} names read, {} defaults compared", checked.0, checked.1);
    assert!(
        failures.is_empty(),
        "{} mismatches with pbrt-v3:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
