//! pbrt-v3's parameter table and its defaults as comparable values.

use farm_common::scene::Lookup;
use std::path::Path;

/// One row of the table.
#[derive(Clone, Debug)]
pub(crate) struct Row {
    pub(crate) function: String,
    pub(crate) read_as: String,
    pub(crate) name: String,
    pub(crate) default: String,
}

pub(crate) fn table(shared: &Path) -> Vec<Row> {
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

/// A table default, as a value this test can compare.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Default {
    Numbers(Vec<f64>),
    Bool(bool),
    Text(String),
    /// A list lookup (`&n`): no default.
    List,
}

pub(crate) fn number(s: &str) -> Option<f64> {
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

pub(crate) fn parse_default(d: &str) -> Option<Default> {
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
pub(crate) fn recorded(l: &Lookup) -> Option<Default> {
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

pub(crate) fn same(a: &Default, b: &Default) -> bool {
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

/// The type name our lookups record for a way pbrt-v3 reads a parameter.
pub(crate) fn kind(read_as: &str) -> &'static str {
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
