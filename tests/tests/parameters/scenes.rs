//! The scenes that exercise one constructor: where its directive goes,
//! values of the types pbrt-v3 reads, and the lookups it makes.

use super::table::{parse_default, Default, Row};
use farm_common::image::{write_image, ImageMetadata, RgbImage};
use farm_common::scene::{record_lookups, Lookup, Warning};
use farm_render::{RenderOptions, Renderer};
use std::path::Path;

/// Where a constructor's parameters are written in a scene.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Slot {
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

pub(crate) fn slot(function: &str) -> Option<Slot> {
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
pub(crate) fn special(function: &str, name: &str) -> Option<&'static str> {
    let mesh = matches!(function, "CreateTriangleMeshShape" | "MakeShapes");
    Some(match name {
        "cropwindow" => r#""float cropwindow" [0 1 0 1]"#,
        "screenwindow" => r#""float screenwindow" [-1 1 -1 1]"#,
        "pixelbounds" => r#""integer pixelbounds" [0 16 0 16]"#,
        "filename" if function == "CreateFilm" => r#""string filename" "out.exr""#,
        "filename" if function == "CreatePLYMesh" => r#""string filename" "quad.ply""#,
        "filename" => r#""string filename" "tex.pfm""#,
        "mapname" => r#""string mapname" "tex.pfm""#,
        "lensfile" => r#""string lensfile" "lens.dat""#,
        "bsdffile" => r#""string bsdffile" "table.bsdf""#,
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
        "nu" | "nv" | "uorder" | "vorder" if function == "CreateNURBS" => match name {
            "nu" => r#""integer nu" [2]"#,
            "nv" => r#""integer nv" [2]"#,
            "uorder" => r#""integer uorder" [2]"#,
            _ => r#""integer vorder" [2]"#,
        },
        "uknots" => r#""float uknots" [0 0 1 1]"#,
        "vknots" => r#""float vknots" [0 0 1 1]"#,
        "P" if function == "CreateNURBS" => r#""point3 P" [0 0 0 1 0 0 0 1 0 1 1 0]"#,
        "Pw" => r#""float Pw" [0 0 0 1 1 0 0 1 0 1 0 1 1 1 0 1]"#,
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
pub(crate) fn value(row: &Row) -> String {
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

/// The scene for one constructor, with the given parameter text; without
/// the directive under test when `with` is false (the baseline whose
/// lookups are taken away from the scene's, so only the constructor's own
/// remain). Options directives are never left out: a default one would be
/// built in their place.
pub(crate) fn scene(slot: Slot, params: &str, with: bool) -> String {
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
pub(crate) fn own_lookups(
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
pub(crate) fn required(function: &str) -> &'static str {
    match function {
        "CreatePLYMesh" => r#""string filename" "quad.ply""#,
        "CreateRealisticCamera" => r#""string lensfile" "lens.dat""#,
        // Control points come as "P" or, without it, as "Pw".
        "CreateNURBS" => {
            r#""integer nu" [2] "integer nv" [2] "integer uorder" [2] "integer vorder" [2]
               "float uknots" [0 0 1 1] "float vknots" [0 0 1 1]"#
        }
        _ => "",
    }
}

/// Parameters another must accompany for pbrt-v3 to read it at all.
pub(crate) fn companion(function: &str, name: &str) -> &'static str {
    let texture = function.ends_with("Texture");
    match name {
        "v1" | "v2" if texture => r#""string mapping" "planar""#,
        _ => "",
    }
}

/// Builds the scene's renderer, returning its warnings and the lookups made.
pub(crate) fn build(dir: &Path, text: &str) -> Result<(Vec<Warning>, Vec<Lookup>), String> {
    let (parsed, mut lookups) = record_lookups(|| farm_scene::parse_str(text, "params.pbrt", dir));
    let (desc, mut warnings) = parsed.map_err(|e| e.to_string())?;
    let (built, more) = record_lookups(|| Renderer::new(desc, &RenderOptions::default()));
    lookups.extend(more);
    let (_, w) = built.map_err(|e| e.to_string())?;
    warnings.extend(w);
    Ok((warnings, lookups))
}

pub(crate) fn write_assets(dir: &Path) {
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
    // A single thick lens with a stop behind it.
    std::fs::write(dir.join("lens.dat"), "40 6 1.5 20\n-40 2 1 20\n0 30 0 12\n").expect("lens");
    // A Fourier BSDF table: two zenith nodes, constant series.
    let table =
        farm_render::bxdf::FourierTable::to_bytes(1.0, &[-1.0, 1.0], 1, &vec![vec![0.1]; 4]);
    std::fs::write(dir.join("table.bsdf"), table).expect("bsdf");
}
