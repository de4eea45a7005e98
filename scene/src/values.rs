//! Parameter declarations and values (pbrt-v3 `parser.cpp` `lookupType` and
//! `AddParam`): decodes `"type name"`, checks the values against the type
//! and converts spectra to RGB.
//!
//! ```text
//! "float radius" 2   "rgb Kd" [.5 .5 .8]   "blackbody L" [3000 1.5]
//! "spectrum Kd" [300 .3  800 .6]   "spectrum eta" "spds/Cu.eta.spd"
//! ```

use crate::error::{Result, SceneError};
use farm_common::cie;
use farm_common::scene::{FileLoc, ParamValue, TextureRef};
use farm_common::Spectrum;
use std::path::Path;

/// A parameter's declared type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamType {
    /// `integer`
    Int,
    /// `bool`
    Bool,
    /// `float`
    Float,
    /// `point2`
    Point2,
    /// `vector2`
    Vector2,
    /// `point3` / `point`
    Point3,
    /// `vector3` / `vector`
    Vector3,
    /// `normal3` / `normal`
    Normal,
    /// `rgb` / `color`
    Rgb,
    /// `xyz`
    Xyz,
    /// `blackbody`
    Blackbody,
    /// `spectrum`
    Spectrum,
    /// `string`
    String,
    /// `texture`
    Texture,
}

impl ParamType {
    /// Whether the values are quoted strings (numbers otherwise; `spectrum`
    /// takes either).
    pub fn takes_strings(self) -> bool {
        matches!(self, ParamType::Bool | ParamType::String | ParamType::Texture)
    }
}

/// Splits `"type name"` into its type and name; `Err` says what is wrong.
pub fn parse_decl(decl: &str) -> std::result::Result<(ParamType, &str), String> {
    let mut words = decl.split([' ', '\t']).filter(|w| !w.is_empty());
    let Some(ty) = words.next() else {
        return Err("no type".into());
    };
    let ty = match ty {
        "integer" => ParamType::Int,
        "bool" => ParamType::Bool,
        "float" => ParamType::Float,
        "point2" => ParamType::Point2,
        "vector2" => ParamType::Vector2,
        "point3" | "point" => ParamType::Point3,
        "vector3" | "vector" => ParamType::Vector3,
        "normal3" | "normal" => ParamType::Normal,
        "rgb" | "color" => ParamType::Rgb,
        "xyz" => ParamType::Xyz,
        "blackbody" => ParamType::Blackbody,
        "spectrum" => ParamType::Spectrum,
        "string" => ParamType::String,
        "texture" => ParamType::Texture,
        other => return Err(format!("unknown type \"{other}\"")),
    };
    match words.next() {
        Some(name) => Ok((ty, name)),
        None => Err("no parameter name".into()),
    }
}

/// A number of a transform directive (`Translate`, `LookAt`, `Transform`…),
/// read in double precision: the transforms are composed in f64 until the
/// scene moves into camera-centred render space, so coordinates near 1e6
/// (geo-referenced scenes) keep their centimetres where pbrt-v3's `strtof`
/// would round them to sixteenths.
pub fn parse_transform_number(text: &str) -> Option<f64> {
    let first = text.bytes().next()?;
    if !(first.is_ascii_digit() || matches!(first, b'-' | b'+' | b'.')) {
        return None;
    }
    text.parse::<f64>().ok()
}

/// pbrt-v3's `parseNumber`: all-digit words are read as integers, others as
/// single-precision floats (`strtof`), then widened.
pub fn parse_number(text: &str) -> Option<f64> {
    if !text.is_empty() && text.bytes().all(|b| b.is_ascii_digit()) {
        if let Ok(i) = text.parse::<i64>() {
            return Some(i as f64);
        }
    }
    text.parse::<f32>().ok().map(f64::from)
}

/// What [`convert`] needs besides the values.
pub struct ValueContext<'a> {
    /// The declaration as written, for messages.
    pub decl: &'a str,
    /// Where the declaration is.
    pub loc: &'a FileLoc,
    /// The main scene file's directory (for spectrum files, as
    /// `assets::resolve` finds them).
    pub search: &'a Path,
    /// Directory of the file being parsed.
    pub dir: &'a Path,
}

/// Builds a typed value from the numbers or strings given (exactly one of
/// `nums`, `strs` is non-empty unless the list was empty).
pub fn convert(
    ty: ParamType,
    nums: &[f64],
    strs: &[String],
    cx: &ValueContext<'_>,
) -> Result<ParamValue> {
    let count_err = |expected: &str| SceneError::ValueCount {
        loc: cx.loc.clone(),
        decl: cx.decl.to_string(),
        count: nums.len().max(strs.len()),
        expected: expected.to_string(),
    };
    let tuples = |n: usize, what: &str| -> Result<Vec<f32>> {
        if !nums.len().is_multiple_of(n) {
            return Err(count_err(what));
        }
        Ok(nums.iter().map(|&v| v as f32).collect())
    };
    Ok(match ty {
        ParamType::Int => ParamValue::Int(nums.iter().map(|&v| v as i32).collect()),
        ParamType::Float => ParamValue::Float(nums.iter().map(|&v| v as f32).collect()),
        ParamType::Point2 => ParamValue::Point2(pairs(&tuples(2, "a multiple of 2")?)),
        ParamType::Vector2 => ParamValue::Vector2(pairs(&tuples(2, "a multiple of 2")?)),
        ParamType::Point3 => ParamValue::Point3(triples(&tuples(3, "a multiple of 3")?)),
        ParamType::Vector3 => ParamValue::Vector3(triples(&tuples(3, "a multiple of 3")?)),
        ParamType::Normal => ParamValue::Normal(triples(&tuples(3, "a multiple of 3")?)),
        ParamType::Rgb => {
            let v = tuples(3, "a multiple of 3")?;
            ParamValue::Spectrum(triples(&v).into_iter().map(Spectrum::from_array).collect())
        }
        ParamType::Xyz => {
            let v = tuples(3, "a multiple of 3")?;
            ParamValue::Spectrum(triples(&v).into_iter().map(cie::xyz_to_rgb).collect())
        }
        ParamType::Blackbody => {
            let v = tuples(2, "(temperature, scale) pairs")?;
            ParamValue::Spectrum(
                pairs(&v).into_iter().map(|[t, s]| cie::blackbody_rgb(t, s)).collect(),
            )
        }
        ParamType::Spectrum if !strs.is_empty() => {
            let mut out = Vec::with_capacity(strs.len());
            for s in strs {
                out.push(spectrum_file(s, cx)?);
            }
            ParamValue::Spectrum(out)
        }
        ParamType::Spectrum => {
            let v = tuples(2, "(wavelength, value) pairs")?;
            ParamValue::Spectrum(vec![sampled(&v)])
        }
        ParamType::Bool => {
            let mut out = Vec::with_capacity(strs.len());
            for s in strs {
                out.push(match s.as_str() {
                    "true" => true,
                    "false" => false,
                    _ => {
                        return Err(SceneError::BadValue {
                            loc: cx.loc.clone(),
                            decl: cx.decl.to_string(),
                            found: format!("\"{s}\""),
                            expected: "\"true\" or \"false\"".into(),
                        })
                    }
                });
            }
            ParamValue::Bool(out)
        }
        ParamType::String => ParamValue::String(strs.to_vec()),
        ParamType::Texture => {
            if strs.len() != 1 {
                return Err(count_err("exactly one texture name"));
            }
            ParamValue::Texture(TextureRef {
                name: strs[0].clone(),
                float_id: None,
                spectrum_id: None,
            })
        }
    })
}

fn pairs(v: &[f32]) -> Vec<[f32; 2]> {
    v.chunks_exact(2).map(|c| [c[0], c[1]]).collect()
}

fn triples(v: &[f32]) -> Vec<[f32; 3]> {
    v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// RGB of interleaved (wavelength, value) samples, sorted by wavelength as
/// pbrt-v3's `FromSampled` does.
fn sampled(v: &[f32]) -> Spectrum {
    let mut p = pairs(v);
    p.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let lambda: Vec<f32> = p.iter().map(|x| x[0]).collect();
    let values: Vec<f32> = p.iter().map(|x| x[1]).collect();
    cie::sampled_to_rgb(&lambda, &values)
}

/// Reads a `.spd` file (pbrt-v3 `ReadFloatFile`: numbers, `#` comments) and
/// converts its (wavelength, value) pairs.
fn spectrum_file(name: &str, cx: &ValueContext<'_>) -> Result<Spectrum> {
    let path = crate::assets::resolve(cx.search, cx.dir, name);
    let path_str = path.to_string_lossy().into_owned();
    let text = std::fs::read_to_string(&path).map_err(|source| SceneError::File {
        loc: cx.loc.clone(),
        path: path_str.clone(),
        source,
    })?;
    let bad = |what: String| SceneError::BadFile {
        loc: cx.loc.clone(),
        kind: "spectrum",
        path: path_str.clone(),
        what,
    };
    let mut v = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("");
        for word in line.split_whitespace() {
            match parse_number(word) {
                Some(x) => v.push(x as f32),
                None => return Err(bad(format!("line {}: \"{word}\" (expected a number)", i + 1))),
            }
        }
    }
    if v.len() % 2 != 0 || v.is_empty() {
        return Err(bad(format!("{} numbers (expected (wavelength, value) pairs)", v.len())));
    }
    Ok(sampled(&v))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cx<'a>(loc: &'a FileLoc, decl: &'a str) -> ValueContext<'a> {
        ValueContext { decl, loc, search: Path::new("."), dir: Path::new(".") }
    }

    #[test]
    fn decl_types_and_names() {
        assert_eq!(parse_decl("float radius"), Ok((ParamType::Float, "radius")));
        assert_eq!(parse_decl("  color\tKd "), Ok((ParamType::Rgb, "Kd")));
        assert_eq!(parse_decl("normal3 N"), Ok((ParamType::Normal, "N")));
        assert!(parse_decl("flaot radius").unwrap_err().contains("flaot"));
        assert!(parse_decl("float").is_err());
        assert!(parse_decl("").is_err());
    }

    #[test]
    fn numbers_like_pbrt() {
        assert_eq!(parse_number("16"), Some(16.0));
        assert_eq!(parse_number("-.4"), Some(f64::from(-0.4f32)));
        assert_eq!(parse_number("8.742277657347586e-08"), Some(f64::from(8.742_278e-8_f32)));
        assert_eq!(parse_number("abc"), None);
        assert_eq!(parse_transform_number("1000000.6"), Some(1000000.6));
        assert_eq!(parse_transform_number("-.25"), Some(-0.25));
        assert_eq!(parse_transform_number("inf"), None);
        assert_eq!(parse_transform_number("nan"), None);
    }

    #[test]
    fn counts_are_checked() {
        let loc = FileLoc { file: "a.pbrt".into(), line: 3, column: 9 };
        let e = convert(ParamType::Rgb, &[1.0, 2.0], &[], &cx(&loc, "rgb Kd")).unwrap_err();
        assert!(e.to_string().starts_with("a.pbrt:3:9: parameter \"rgb Kd\" has 2 values"), "{e}");
        let v =
            convert(ParamType::Point3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], &[], &cx(&loc, "point P"))
                .unwrap();
        assert_eq!(v, ParamValue::Point3(vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]));
        let v = convert(ParamType::Int, &[2.0, 7.0], &[], &cx(&loc, "integer i")).unwrap();
        assert_eq!(v, ParamValue::Int(vec![2, 7]));
        let e = convert(ParamType::Bool, &[], &["yes".into()], &cx(&loc, "bool b")).unwrap_err();
        assert!(matches!(e, SceneError::BadValue { .. }));
    }

    #[test]
    fn spectra_become_rgb() {
        let loc = FileLoc::default();
        let v = convert(ParamType::Rgb, &[0.5, 0.25, 1.0], &[], &cx(&loc, "rgb L")).unwrap();
        assert_eq!(v, ParamValue::Spectrum(vec![Spectrum::new(0.5, 0.25, 1.0)]));
        let v =
            convert(ParamType::Blackbody, &[3000.0, 1.5], &[], &cx(&loc, "blackbody L")).unwrap();
        assert_eq!(v, ParamValue::Spectrum(vec![cie::blackbody_rgb(3000.0, 1.5)]));
        let v =
            convert(ParamType::Spectrum, &[700.0, 1.0, 400.0, 0.5], &[], &cx(&loc, "spectrum s"))
                .unwrap();
        assert_eq!(
            v,
            ParamValue::Spectrum(vec![cie::sampled_to_rgb(&[400.0, 700.0], &[0.5, 1.0])])
        );
    }

    #[test]
    fn spectrum_files_are_read_relative_to_dir() {
        let dir = std::env::temp_dir().join(format!("farm-spd-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("a.spd"), "# comment\n400 0.5 # x\n700 1\n").unwrap();
        let loc = FileLoc::default();
        let c = ValueContext { decl: "spectrum eta", loc: &loc, search: &dir, dir: &dir };
        let v = convert(ParamType::Spectrum, &[], &["a.spd".into()], &c).unwrap();
        assert_eq!(
            v,
            ParamValue::Spectrum(vec![cie::sampled_to_rgb(&[400.0, 700.0], &[0.5, 1.0])])
        );
        assert!(matches!(
            convert(ParamType::Spectrum, &[], &["no.spd".into()], &c),
            Err(SceneError::File { .. })
        ));
        std::fs::remove_dir_all(&dir).ok();
    }
}
