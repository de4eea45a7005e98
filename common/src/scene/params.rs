//! Named, typed parameter lists (pbrt-v3 `ParamSet`) and a reader that
//! remembers which parameters were looked up, so unused ones can be reported
//! with pbrt-v3's warning.

use super::loc::{FileLoc, Warning};
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};
use std::cell::{Cell, RefCell};

/// A texture named by a `"texture name"` parameter, resolved against the
/// float and spectrum textures in scope where the parameter was written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TextureRef {
    /// The texture's name in the scene file.
    pub name: String,
    /// Index into `SceneDescription::textures` of the float texture of that name, if any.
    pub float_id: Option<u32>,
    /// Index into `SceneDescription::textures` of the spectrum texture of that name, if any.
    pub spectrum_id: Option<u32>,
}

/// The values of one parameter. Spectra (`rgb`, `color`, `spectrum`,
/// `blackbody`) are already converted to RGB by the parser.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ParamValue {
    /// `integer`
    Int(Vec<i32>),
    /// `float`
    Float(Vec<f32>),
    /// `point2`
    Point2(Vec<[f32; 2]>),
    /// `vector2`
    Vector2(Vec<[f32; 2]>),
    /// `point3` / `point`
    Point3(Vec<[f32; 3]>),
    /// `vector3` / `vector`
    Vector3(Vec<[f32; 3]>),
    /// `normal3` / `normal`
    Normal(Vec<[f32; 3]>),
    /// `rgb` / `color` / `spectrum` / `blackbody`, as RGB.
    Spectrum(Vec<Spectrum>),
    /// `bool`
    Bool(Vec<bool>),
    /// `string`
    String(Vec<String>),
    /// `texture`
    Texture(TextureRef),
    /// A named material resolved by the parser (`mix`'s `namedmaterial1/2`):
    /// an index into `SceneDescription::materials`.
    Material(u32),
}

impl ParamValue {
    /// The type name as written in a scene file.
    pub fn type_name(&self) -> &'static str {
        match self {
            ParamValue::Int(_) => "integer",
            ParamValue::Float(_) => "float",
            ParamValue::Point2(_) => "point2",
            ParamValue::Vector2(_) => "vector2",
            ParamValue::Point3(_) => "point3",
            ParamValue::Vector3(_) => "vector3",
            ParamValue::Normal(_) => "normal",
            ParamValue::Spectrum(_) => "spectrum",
            ParamValue::Bool(_) => "bool",
            ParamValue::String(_) => "string",
            ParamValue::Texture(_) => "texture",
            ParamValue::Material(_) => "string",
        }
    }
}

/// One parameter: `"type name" [values]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Param {
    /// The name after the type.
    pub name: String,
    /// The typed values.
    pub value: ParamValue,
    /// Where it was written.
    pub loc: FileLoc,
}

/// The parameters of one directive, in the order written.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ParamSet {
    /// The parameters.
    pub params: Vec<Param>,
}

impl ParamSet {
    /// Adds a parameter, replacing an earlier one of the same name and type
    /// (pbrt-v3 keeps the last).
    pub fn add(&mut self, p: Param) {
        self.params.retain(|q| !(q.name == p.name && q.value.type_name() == p.value.type_name()));
        self.params.push(p);
    }

    /// The first parameter of that name, of any type.
    pub fn get(&self, name: &str) -> Option<&Param> {
        self.params.iter().find(|p| p.name == name)
    }

    /// Removes and returns every parameter of that name.
    pub fn take(&mut self, name: &str) -> Option<Param> {
        note(name, "any", None);
        let i = self.params.iter().position(|p| p.name == name)?;
        Some(self.params.remove(i))
    }
}

/// One parameter lookup made by a constructor: what it asked for, and the
/// default it falls back on (`None` for lookups of a whole list, which have
/// none). Collected by [`record_lookups`], so a test can compare every
/// constructor's names and defaults with pbrt-v3's.
#[derive(Clone, Debug, PartialEq)]
pub struct Lookup {
    /// The parameter's name.
    pub name: String,
    /// The type asked for, as written in a scene file.
    pub kind: &'static str,
    /// The default, formatted with `{:?}`.
    pub default: Option<String>,
}

thread_local! {
    static LOOKUPS: RefCell<Option<Vec<Lookup>>> = const { RefCell::new(None) };
}

/// Runs `f` and returns, beside its result, every parameter lookup made on
/// this thread while it ran, in order. Outside a call, lookups cost a
/// thread-local read and nothing is kept.
pub fn record_lookups<R>(f: impl FnOnce() -> R) -> (R, Vec<Lookup>) {
    let outer = LOOKUPS.with(|l| l.borrow_mut().replace(Vec::new()));
    let r = f();
    let got = LOOKUPS.with(|l| std::mem::replace(&mut *l.borrow_mut(), outer));
    (r, got.unwrap_or_default())
}

fn note(name: &str, kind: &'static str, default: Option<&dyn std::fmt::Debug>) {
    LOOKUPS.with(|l| {
        if let Some(v) = l.borrow_mut().as_mut() {
            v.push(Lookup {
                name: name.to_string(),
                kind,
                default: default.map(|d| format!("{d:?}")),
            });
        }
    });
}

/// A reader over a [`ParamSet`] that records which parameters were used.
/// Lookups match on name and type, as pbrt-v3's `FindOne*` do.
pub struct Params<'a> {
    set: &'a ParamSet,
    used: Vec<Cell<bool>>,
}

macro_rules! finders {
    ($one:ident, $many:ident, $variant:ident, $kind:literal, $elem:ty, $out:ty, $conv:expr) => {
        /// The first value of the parameter, or `default`.
        pub fn $one(&self, name: &str, default: $out) -> $out {
            note(name, $kind, Some(&default));
            match self.find(name, |v| matches!(v, ParamValue::$variant(_))) {
                Some(ParamValue::$variant(v)) if !v.is_empty() => $conv(&v[0]),
                _ => default,
            }
        }
        /// All values of the parameter, if given.
        pub fn $many(&self, name: &str) -> Option<&'a [$elem]> {
            note(name, $kind, None);
            match self.find(name, |v| matches!(v, ParamValue::$variant(_))) {
                Some(ParamValue::$variant(v)) => Some(v.as_slice()),
                _ => None,
            }
        }
    };
}

impl<'a> Params<'a> {
    /// A reader with nothing used yet.
    pub fn new(set: &'a ParamSet) -> Self {
        Params { set, used: set.params.iter().map(|_| Cell::new(false)).collect() }
    }

    /// The underlying parameters.
    pub fn set(&self) -> &'a ParamSet {
        self.set
    }

    fn find(&self, name: &str, is_type: impl Fn(&ParamValue) -> bool) -> Option<&'a ParamValue> {
        let set: &'a ParamSet = self.set;
        for (i, p) in set.params.iter().enumerate() {
            if p.name == name && is_type(&p.value) {
                self.used[i].set(true);
                return Some(&p.value);
            }
        }
        None
    }

    finders!(int, ints, Int, "integer", i32, i32, |v: &i32| *v);
    finders!(float, floats, Float, "float", f32, f32, |v: &f32| *v);
    finders!(bool, bools, Bool, "bool", bool, bool, |v: &bool| *v);
    finders!(point2, point2s, Point2, "point2", [f32; 2], Vec2, |v: &[f32; 2]| Vec2::from(*v));
    finders!(vector2, vector2s, Vector2, "vector2", [f32; 2], Vec2, |v: &[f32; 2]| Vec2::from(*v));
    finders!(point3, point3s, Point3, "point3", [f32; 3], Vec3, |v: &[f32; 3]| Vec3::from(*v));
    finders!(vector3, vector3s, Vector3, "vector3", [f32; 3], Vec3, |v: &[f32; 3]| Vec3::from(*v));
    finders!(normal, normals, Normal, "normal", [f32; 3], Vec3, |v: &[f32; 3]| Vec3::from(*v));
    finders!(spectrum, spectra, Spectrum, "spectrum", Spectrum, Spectrum, |v: &Spectrum| *v);

    /// The first string value, or `default`.
    pub fn string(&self, name: &str, default: &str) -> String {
        note(name, "string", Some(&default));
        match self.find(name, |v| matches!(v, ParamValue::String(_))) {
            Some(ParamValue::String(v)) if !v.is_empty() => v[0].clone(),
            _ => default.to_string(),
        }
    }

    /// All string values, if given.
    pub fn strings(&self, name: &str) -> Option<&'a [String]> {
        note(name, "string", None);
        match self.find(name, |v| matches!(v, ParamValue::String(_))) {
            Some(ParamValue::String(v)) => Some(v.as_slice()),
            _ => None,
        }
    }

    /// The texture named by `"texture name"`, if given.
    pub fn texture(&self, name: &str) -> Option<&'a TextureRef> {
        note(name, "texture", None);
        match self.find(name, |v| matches!(v, ParamValue::Texture(_))) {
            Some(ParamValue::Texture(t)) => Some(t),
            _ => None,
        }
    }

    /// The material resolved for a `namedmaterial1/2`-style parameter.
    pub fn material(&self, name: &str) -> Option<u32> {
        note(name, "string", None);
        match self.find(name, |v| matches!(v, ParamValue::Material(_))) {
            Some(ParamValue::Material(m)) => Some(*m),
            _ => None,
        }
    }

    /// Marks a parameter as used without reading it (for parameters pbrt-v3
    /// reads but this renderer has no use for, such as `nsamples`).
    pub fn touch(&self, name: &str) {
        note(name, "any", None);
        let _ = self.find(name, |_| true);
    }

    /// Whether a parameter of that name and type (as written in a scene
    /// file) has been looked up.
    pub fn was_used(&self, name: &str, type_name: &str) -> bool {
        self.set
            .params
            .iter()
            .zip(&self.used)
            .any(|(p, u)| u.get() && p.name == name && p.value.type_name() == type_name)
    }

    /// pbrt-v3's `Parameter "name" not used` warning for each unread parameter.
    pub fn unused_warnings(&self) -> Vec<Warning> {
        self.set
            .params
            .iter()
            .zip(&self.used)
            .filter(|(_, u)| !u.get())
            .map(|(p, _)| Warning::at(&p.loc, format!("Parameter \"{}\" not used", p.name)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn param(name: &str, value: ParamValue) -> Param {
        Param {
            name: name.into(),
            value,
            loc: FileLoc { file: "a.pbrt".into(), line: 3, column: 5 },
        }
    }

    #[test]
    fn lookups_match_type_and_report_unused() {
        let mut set = ParamSet::default();
        set.add(param("radius", ParamValue::Float(vec![2.0])));
        set.add(param("radius", ParamValue::Int(vec![7])));
        set.add(param("typo", ParamValue::Float(vec![1.0])));
        let p = Params::new(&set);
        assert_eq!(p.float("radius", 1.0), 2.0);
        assert_eq!(p.float("zmin", -1.0), -1.0);
        let w = p.unused_warnings();
        assert_eq!(w.len(), 2, "{w:?}");
        assert_eq!(w[1].to_string(), "a.pbrt:3:5: warning: Parameter \"typo\" not used");
    }

    #[test]
    fn later_parameter_replaces_earlier_of_same_type() {
        let mut set = ParamSet::default();
        set.add(param("Kd", ParamValue::Spectrum(vec![Spectrum::splat(0.1)])));
        set.add(param("Kd", ParamValue::Spectrum(vec![Spectrum::splat(0.7)])));
        assert_eq!(Params::new(&set).spectrum("Kd", Spectrum::ZERO), Spectrum::splat(0.7));
    }
}
