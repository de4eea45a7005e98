//! Reads directives and their arguments from the tokens (pbrt-v3
//! `core/parser.cpp` `parse`) and hands them to the [`Builder`].
//!
//! ```text
//! Shape "sphere" "float radius" 2          # name, then "type name" value(s)
//! Transform [ 1 0 0 0  0 1 0 0  0 0 1 0  0 0 5 1 ]
//! Include "geometry/killeroo.pbrt"         # as assets::resolve finds files
//! ```

use super::builder::{Block, Builder};
use super::tokenizer::{Token, TokenKind, Tokenizer};
use super::transform;
use super::values::{self, ParamType, ValueContext};
use crate::error::{Result, SceneError};
use farm_common::scene::{Entity, FileLoc, Param, ParamSet, ParamValue, SceneDescription, Warning};
use glam::DVec3;
use std::path::Path;

/// How deeply `Include`s may nest (a guard against cycles).
const MAX_INCLUDE_DEPTH: usize = 64;

/// The parser: the builder plus scratch buffers reused across parameters.
pub struct Parser {
    /// Where the directives go.
    pub builder: Builder,
    nums: Vec<f64>,
    strs: Vec<String>,
    depth: usize,
    /// Whether a directive has been read since the last scene ended.
    pub started: bool,
    /// Scenes finished by a `WorldEnd`: as in pbrt-v3, the input may go on
    /// to describe another scene, from fresh options.
    pub finished: Vec<(SceneDescription, Vec<Warning>)>,
    /// The end of the main file, for end-of-scene warnings.
    pub end: FileLoc,
}

impl Parser {
    /// A parser for a scene called `name`.
    pub fn new(name: &str) -> Self {
        Parser {
            builder: Builder::new(name),
            nums: Vec::new(),
            strs: Vec::new(),
            depth: 0,
            started: false,
            finished: Vec::new(),
            end: FileLoc::default(),
        }
    }

    /// Parses the text of one file; `dir` is its directory.
    pub fn parse_text(&mut self, text: &str, file: &str, dir: &Path) -> Result<()> {
        let mut t = Tokenizer::new(text, file);
        loop {
            if self.builder.block == Block::Done {
                self.next_scene();
            }
            let Some(tok) = t.next()? else { break };
            self.started = true;
            if tok.kind != TokenKind::Bare {
                return Err(SceneError::Syntax {
                    loc: t.loc(&tok),
                    found: tok.describe(),
                    expected: "a directive such as Shape or AttributeBegin".into(),
                });
            }
            self.directive(&mut t, tok, dir)?;
        }
        self.end = t.end_loc();
        Ok(())
    }

    /// Hands the scene a `WorldEnd` closed to `finished`, if one did (at
    /// the end of a file: otherwise it waits for the next directive).
    pub fn close_ended(&mut self) {
        if self.builder.block == Block::Done {
            self.next_scene();
        }
    }

    /// The scene the input ended in without a `WorldEnd`.
    pub fn finish_rest(&mut self) -> (SceneDescription, Vec<Warning>) {
        let end = std::mem::take(&mut self.end);
        std::mem::replace(&mut self.builder, Builder::new("")).finish(&end)
    }

    /// Finishes the scene a `WorldEnd` closed and starts the next from
    /// pbrt-v3's defaults (the files it reads still resolve as before).
    fn next_scene(&mut self) {
        let mut fresh = Builder::new(&self.builder.scene.name);
        fresh.root.clone_from(&self.builder.root);
        fresh.search_dir.clone_from(&self.builder.search_dir);
        let done = std::mem::replace(&mut self.builder, fresh);
        self.finished.push(done.finish(&FileLoc::default()));
        self.started = false;
    }

    fn directive<'a>(&mut self, t: &mut Tokenizer<'a>, tok: Token<'a>, dir: &Path) -> Result<()> {
        let loc = t.loc(&tok);
        let b = &mut self.builder;
        match tok.text.as_ref() {
            "AttributeBegin" => b.attribute_begin(&loc),
            "AttributeEnd" => b.attribute_end(&loc),
            "TransformBegin" => b.transform_begin(&loc),
            "TransformEnd" => b.transform_end(&loc),
            "WorldBegin" => b.world_begin(&loc),
            "WorldEnd" => b.world_end(&loc),
            "ReverseOrientation" => b.reverse_orientation(&loc),
            "ObjectEnd" => b.object_end(&loc),
            "Identity" => b.ctm.update(|_| glam::DMat4::IDENTITY),
            "ActiveTransform" | "Translate" | "Scale" | "Rotate" | "LookAt" | "Transform"
            | "ConcatTransform" | "TransformTimes" => self.transform_directive(t, &tok, &loc)?,
            "CoordinateSystem" | "CoordSysTransform" | "NamedMaterial" | "ObjectBegin"
            | "ObjectInstance" | "MediumInterface" | "Include" => {
                self.named_directive(t, &tok, &loc, dir)?
            }
            "Camera" | "Sampler" | "Film" | "PixelFilter" | "Integrator" | "Accelerator"
            | "Shape" | "Material" | "LightSource" | "AreaLightSource" | "MakeNamedMaterial"
            | "MakeNamedMedium" | "Texture" => self.entity_directive(t, &tok, loc, dir)?,
            other => return Err(SceneError::UnknownDirective { loc, name: other.to_string() }),
        }
        Ok(())
    }

    /// The directives that change the current transformation.
    fn transform_directive(
        &mut self,
        t: &mut Tokenizer<'_>,
        tok: &Token<'_>,
        loc: &FileLoc,
    ) -> Result<()> {
        let loc = loc.clone();
        match tok.text.as_ref() {
            "ActiveTransform" => {
                let a = self.word(t, &loc, "ActiveTransform")?;
                self.builder.ctm.active = match a.text.as_ref() {
                    "All" => 0b11,
                    "StartTime" => 0b01,
                    "EndTime" => 0b10,
                    _ => {
                        return Err(SceneError::Syntax {
                            loc: t.loc(&a),
                            found: a.describe(),
                            expected: "All, StartTime or EndTime after ActiveTransform".into(),
                        })
                    }
                };
            }
            "Translate" => {
                let v = self.numbers::<3>(t, &loc, "Translate")?;
                self.builder.ctm.concat(transform::translate(DVec3::from(v)));
            }
            "Scale" => {
                let v = self.numbers::<3>(t, &loc, "Scale")?;
                self.builder.ctm.concat(transform::scale(v[0], v[1], v[2]));
            }
            "Rotate" => {
                let v = self.numbers::<4>(t, &loc, "Rotate")?;
                self.builder.ctm.concat(transform::rotate(v[0], DVec3::new(v[1], v[2], v[3])));
            }
            "LookAt" => {
                let v = self.numbers::<9>(t, &loc, "LookAt")?;
                let (eye, look, up) = (
                    DVec3::new(v[0], v[1], v[2]),
                    DVec3::new(v[3], v[4], v[5]),
                    DVec3::new(v[6], v[7], v[8]),
                );
                match transform::look_at(eye, look, up) {
                    Some(m) => self.builder.ctm.concat(m),
                    None => self.builder.warn(
                        &loc,
                        format!("\"up\" vector {up} and viewing direction {} passed to LookAt are pointing in the same direction.  Using the identity transformation.", look - eye),
                    ),
                }
            }
            "Transform" | "ConcatTransform" => {
                let m = self.matrix(t, &loc, &tok.text)?;
                if tok.text == "Transform" {
                    self.builder.ctm.update(|_| m);
                } else {
                    self.builder.ctm.concat(m);
                }
            }
            "TransformTimes" => {
                let v = self.numbers::<2>(t, &loc, "TransformTimes")?;
                self.builder.transform_times(v[0] as f32, v[1] as f32, &loc);
            }
            other => return Err(SceneError::UnknownDirective { loc, name: other.to_string() }),
        }
        Ok(())
    }

    /// The directives that take names: coordinate systems, named
    /// materials, objects, media and `Include`.
    fn named_directive(
        &mut self,
        t: &mut Tokenizer<'_>,
        tok: &Token<'_>,
        loc: &FileLoc,
        dir: &Path,
    ) -> Result<()> {
        let loc = loc.clone();
        match tok.text.as_ref() {
            "CoordinateSystem" => {
                let n = self.string(t, &loc, "CoordinateSystem")?;
                self.builder.coordinate_system(&n);
            }
            "CoordSysTransform" => {
                let n = self.string(t, &loc, "CoordSysTransform")?;
                self.builder.coord_sys_transform(&n, &loc);
            }
            "NamedMaterial" => {
                let n = self.string(t, &loc, "NamedMaterial")?;
                self.builder.named_material(&n, &loc);
            }
            "ObjectBegin" => {
                let n = self.string(t, &loc, "ObjectBegin")?;
                self.builder.object_begin(&n, &loc);
            }
            "ObjectInstance" => {
                let n = self.string(t, &loc, "ObjectInstance")?;
                self.builder.object_instance(&n, &loc);
            }
            "MediumInterface" => {
                let inside = self.string(t, &loc, "MediumInterface")?;
                let outside = match t.peek()? {
                    Some(p) if p.kind == TokenKind::Str => {
                        self.string(t, &loc, "MediumInterface")?
                    }
                    _ => inside.clone(),
                };
                self.builder.medium_interface(&inside, &outside);
            }
            "Include" => {
                let n = self.string(t, &loc, "Include")?;
                self.include(&n, &loc, dir)?;
            }
            other => return Err(SceneError::UnknownDirective { loc, name: other.to_string() }),
        }
        Ok(())
    }

    /// The directives that declare an entity with a parameter list.
    fn entity_directive(
        &mut self,
        t: &mut Tokenizer<'_>,
        tok: &Token<'_>,
        loc: FileLoc,
        dir: &Path,
    ) -> Result<()> {
        match tok.text.as_ref() {
            "Camera" | "Sampler" | "Film" | "PixelFilter" | "Integrator" | "Accelerator" => {
                let mut e = self.entity(t, loc, &tok.text, dir)?;
                if tok.text == "Camera" && e.name == "realistic" {
                    self.builder.load_asset(&mut e, "lensfile", dir)?;
                }
                self.builder.option(&tok.text, e);
            }
            "Shape" => {
                let e = self.entity(t, loc, "Shape", dir)?;
                self.builder.shape(e, dir)?;
            }
            "Material" => {
                let mut e = self.entity(t, loc, "Material", dir)?;
                if e.name == "fourier" {
                    self.builder.load_asset(&mut e, "bsdffile", dir)?;
                }
                self.builder.material(e);
            }
            "LightSource" => {
                let e = self.entity(t, loc, "LightSource", dir)?;
                self.builder.light_source(e, dir)?;
            }
            "AreaLightSource" => {
                let e = self.entity(t, loc, "AreaLightSource", dir)?;
                self.builder.area_light_source(e);
            }
            "MakeNamedMaterial" | "MakeNamedMedium" => {
                let name = self.string(t, &loc, &tok.text)?;
                let mut e = Entity { name: String::new(), params: self.params(t, dir)?, loc };
                if tok.text == "MakeNamedMaterial" {
                    let fourier = e.params.params.iter().any(|p| {
                        p.name == "type"
                            && matches!(&p.value, ParamValue::String(v) if v.first().is_some_and(|t| t == "fourier"))
                    });
                    if fourier {
                        self.builder.load_asset(&mut e, "bsdffile", dir)?;
                    }
                    self.builder.make_named_material(&name, e);
                } else {
                    self.builder.make_named_medium(&name, e);
                }
            }
            "Texture" => {
                let name = self.string(t, &loc, "Texture")?;
                let kind = self.string(t, &loc, "Texture")?;
                let e = self.entity(t, loc, "Texture", dir)?;
                self.builder.texture(&name, &kind, e, dir)?;
            }
            other => return Err(SceneError::UnknownDirective { loc, name: other.to_string() }),
        }
        Ok(())
    }

    fn include(&mut self, name: &str, loc: &FileLoc, dir: &Path) -> Result<()> {
        let path = crate::assets::resolve(&self.builder.search_dir, dir, name);
        let file = path.to_string_lossy().into_owned();
        if self.depth >= MAX_INCLUDE_DEPTH {
            return Err(SceneError::Syntax {
                loc: loc.clone(),
                found: format!("Include \"{file}\" nested {MAX_INCLUDE_DEPTH} deep"),
                expected: "Includes without cycles".into(),
            });
        }
        let text = crate::read_scene_text(&path, loc)?;
        let sub_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        self.depth += 1;
        let end = std::mem::take(&mut self.end);
        let r = self.parse_text(&text, &file, &sub_dir);
        self.end = end;
        self.depth -= 1;
        r
    }

    /// The next token, or an end-of-file error naming `context`.
    fn required<'a>(
        t: &mut Tokenizer<'a>,
        loc: &FileLoc,
        context: &str,
        expected: &str,
    ) -> Result<Token<'a>> {
        t.next()?.ok_or_else(|| SceneError::UnexpectedEof {
            loc: loc.clone(),
            context: format!("in the arguments of {context}"),
            expected: expected.to_string(),
        })
    }

    fn word<'a>(&self, t: &mut Tokenizer<'a>, loc: &FileLoc, context: &str) -> Result<Token<'a>> {
        Self::required(t, loc, context, "a word")
    }

    fn string(&self, t: &mut Tokenizer<'_>, loc: &FileLoc, context: &str) -> Result<String> {
        let tok = Self::required(t, loc, context, "a quoted string")?;
        if tok.kind != TokenKind::Str {
            return Err(SceneError::Syntax {
                loc: t.loc(&tok),
                found: tok.describe(),
                expected: format!("a quoted string after {context}"),
            });
        }
        Ok(tok.text.into_owned())
    }

    /// A directive's numeric argument. It must be finite: a NaN or
    /// infinite transform (`LookAt nan ...`, `Scale 1e39 ...`) would turn
    /// every point it touches into NaN and render a black image.
    fn number(&self, t: &mut Tokenizer<'_>, loc: &FileLoc, context: &str) -> Result<f64> {
        let tok = Self::required(t, loc, context, "a number")?;
        match tok.kind {
            TokenKind::Bare => values::parse_transform_number(&tok.text),
            _ => None,
        }
        .filter(|v| v.is_finite() && v.abs() <= f64::from(f32::MAX))
        .ok_or_else(|| SceneError::Syntax {
            loc: t.loc(&tok),
            found: tok.describe(),
            expected: format!("a finite number for {context}"),
        })
    }

    fn numbers<const N: usize>(
        &self,
        t: &mut Tokenizer<'_>,
        loc: &FileLoc,
        context: &str,
    ) -> Result<[f64; N]> {
        let mut v = [0.0; N];
        for x in &mut v {
            *x = self.number(t, loc, context)?;
        }
        Ok(v)
    }

    /// 16 numbers in column-major order, with optional brackets.
    fn matrix(&self, t: &mut Tokenizer<'_>, loc: &FileLoc, context: &str) -> Result<glam::DMat4> {
        let bracket = matches!(t.peek()?, Some(p) if p.kind == TokenKind::Open);
        if bracket {
            t.next()?;
        }
        let v = self.numbers::<16>(t, loc, context)?;
        if bracket {
            let close = Self::required(t, loc, context, "']'")?;
            if close.kind != TokenKind::Close {
                return Err(SceneError::Syntax {
                    loc: t.loc(&close),
                    found: close.describe(),
                    expected: format!("']' after the 16 numbers of {context}"),
                });
            }
        }
        Ok(transform::from_column_major(&v))
    }

    /// `"type" params` of directives such as `Shape`.
    fn entity(
        &mut self,
        t: &mut Tokenizer<'_>,
        loc: FileLoc,
        context: &str,
        dir: &Path,
    ) -> Result<Entity> {
        let name = self.string(t, &loc, context)?;
        let params = self.params(t, dir)?;
        Ok(Entity { name, params, loc })
    }

    /// A parameter list: `"type name"` followed by a value or `[ values ]`,
    /// repeated while the next token is a quoted string.
    fn params(&mut self, t: &mut Tokenizer<'_>, dir: &Path) -> Result<ParamSet> {
        let mut set = ParamSet::default();
        while matches!(t.peek()?, Some(p) if p.kind == TokenKind::Str) {
            let Some(decl) = t.next()? else { break };
            let loc = t.loc(&decl);
            let (ty, name) =
                values::parse_decl(&decl.text).map_err(|problem| SceneError::BadDeclaration {
                    loc: loc.clone(),
                    decl: decl.text.to_string(),
                    problem,
                })?;
            self.nums.clear();
            self.strs.clear();
            let eof = || SceneError::UnexpectedEof {
                loc: loc.clone(),
                context: format!("in the values of parameter \"{}\"", decl.text),
                expected: "a value or ']'".into(),
            };
            let first = t.next()?.ok_or_else(eof)?;
            if first.kind == TokenKind::Open {
                loop {
                    let v = t.next()?.ok_or_else(eof)?;
                    if v.kind == TokenKind::Close {
                        break;
                    }
                    self.value(t, ty, &decl.text, v)?;
                }
            } else {
                self.value(t, ty, &decl.text, first)?;
            }
            let search = &self.builder.search_dir;
            let cx = ValueContext { decl: &decl.text, loc: &loc, search, dir };
            let value = values::convert(ty, &self.nums, &self.strs, &cx)?;
            set.add(Param { name: name.to_string(), value, loc });
        }
        Ok(set)
    }

    /// One value of a parameter of type `ty`, checked against the type.
    fn value(&mut self, t: &Tokenizer<'_>, ty: ParamType, decl: &str, v: Token<'_>) -> Result<()> {
        let bad = |expected: &str| SceneError::BadValue {
            loc: t.loc(&v),
            decl: decl.to_string(),
            found: v.describe(),
            expected: expected.to_string(),
        };
        let is_bool_word = ty == ParamType::Bool && (v.text == "true" || v.text == "false");
        match v.kind {
            TokenKind::Str | TokenKind::Bare
                if ty.takes_strings()
                    || (ty == ParamType::Spectrum && v.kind == TokenKind::Str) =>
            {
                if v.kind == TokenKind::Bare && !is_bool_word {
                    return Err(bad("a quoted string"));
                }
                if !self.nums.is_empty() {
                    return Err(bad("numbers only (mixed string and numeric values)"));
                }
                self.strs.push(v.text.into_owned());
            }
            TokenKind::Bare => {
                if !self.strs.is_empty() {
                    return Err(bad("strings only (mixed string and numeric values)"));
                }
                let x = values::parse_number(&v.text).ok_or_else(|| bad("a number"))?;
                self.nums.push(x);
            }
            TokenKind::Str => return Err(bad("a number")),
            TokenKind::Open | TokenKind::Close => return Err(bad("a value")),
        }
        Ok(())
    }
}
