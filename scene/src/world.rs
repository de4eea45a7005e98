//! World-block directives (pbrt-v3 `core/api.cpp`): shapes, materials,
//! textures, lights, media and object instancing.
//!
//! ```text
//! Texture "checks" "spectrum" "checkerboard" "rgb tex1" [.1 .1 .1]
//! MakeNamedMaterial "red" "string type" "matte" "rgb Kd" [.5 0 0]
//! ObjectBegin "cube"  Shape "trianglemesh" ...  ObjectEnd
//! AttributeBegin  Translate 0 5 0  NamedMaterial "red"  ObjectInstance "cube"  AttributeEnd
//! ```
//!
//! Object instancing follows pbrt-v3's convention: a shape inside
//! `ObjectBegin` keeps the full CTM at the shape as its `world_from_object`,
//! and an instance's `world_from_instance` (the CTM at `ObjectInstance`) is
//! applied on top of it, so a shape's final transform is
//! `world_from_instance * world_from_object`.

use super::builder::{Builder, PendingMaterial};
use crate::error::Result;
use farm_common::scene::{
    Entity, FileLoc, InstanceEntity, LightEntity, MaterialEntity, MediumEntity, MediumInterface,
    ObjectEntity, ParamSet, ParamValue, ShapeEntity, TextureEntity, TextureKind, Warning,
};
use std::path::Path;

impl Builder {
    /// Fills in the texture ids of `"texture"` parameters from the textures
    /// in scope, warning about unknown names.
    pub(super) fn resolve_textures(&mut self, params: &mut ParamSet) {
        for p in &mut params.params {
            if let ParamValue::Texture(r) = &mut p.value {
                r.float_id = self.gs.float_textures.get(&r.name).copied();
                r.spectrum_id = self.gs.spectrum_textures.get(&r.name).copied();
                if r.float_id.is_none() && r.spectrum_id.is_none() {
                    let msg = format!(
                        "Couldn't find float or spectrum texture named \"{}\" for parameter \"{}\"",
                        r.name, p.name
                    );
                    self.warnings.push(Warning::at(&p.loc, msg));
                }
            }
        }
    }

    /// Replaces a mix material's `namedmaterial1/2` strings by material ids.
    fn resolve_mix(&mut self, entity: &mut Entity) {
        if entity.name != "mix" {
            return;
        }
        for p in &mut entity.params.params {
            if p.name != "namedmaterial1" && p.name != "namedmaterial2" {
                continue;
            }
            let ParamValue::String(names) = &p.value else {
                continue;
            };
            let name = names.first().cloned().unwrap_or_default();
            let id = match self.gs.named_materials.get(&name) {
                Some(&id) => id,
                None => {
                    let msg = format!("Named material \"{name}\" undefined.  Using \"matte\"");
                    self.warnings.push(Warning::at(&p.loc, msg));
                    0
                }
            };
            p.value = ParamValue::Material(id);
        }
    }

    /// The material a shape gets now (pbrt-v3 `GraphicsState::CreateMaterial`).
    fn material_for_shape(&mut self) -> Option<u32> {
        if let Some(name) = &self.gs.named_material {
            if let Some(&id) = self.gs.named_materials.get(name) {
                return Some(id);
            }
        }
        let pending = self.gs.material.clone()?;
        let uses_scope = pending.entity.name == "mix"
            || pending
                .entity
                .params
                .params
                .iter()
                .any(|p| matches!(p.value, ParamValue::Texture(_)));
        let key = if uses_scope {
            (pending.serial, self.gs.texture_generation, self.gs.named_generation)
        } else {
            (pending.serial, 0, 0)
        };
        if let Some(&id) = self.material_cache.get(&key) {
            return Some(id);
        }
        let mut entity = pending.entity;
        self.resolve_textures(&mut entity.params);
        self.resolve_mix(&mut entity);
        let id = self.scene.materials.len() as u32;
        self.scene.materials.push(MaterialEntity { name: None, entity });
        self.material_cache.insert(key, id);
        Some(id)
    }

    /// `Material "type" params`.
    pub fn material(&mut self, entity: Entity) {
        if !self.verify_world(&entity.loc, "Material") {
            return;
        }
        self.gs.named_material = None;
        self.gs.material = if entity.name.is_empty() || entity.name == "none" {
            None
        } else {
            Some(PendingMaterial { entity, serial: self.next_serial() })
        };
    }

    /// `MakeNamedMaterial "name" "string type" "..." params`.
    pub fn make_named_material(&mut self, name: &str, mut entity: Entity) {
        if !self.verify_world(&entity.loc, "MakeNamedMaterial") {
            return;
        }
        self.warn_if_animated(&entity.loc, "MakeNamedMaterial");
        let ty = match entity.params.take("type").map(|p| p.value) {
            Some(ParamValue::String(v)) if !v.is_empty() => v[0].clone(),
            _ => {
                self.warn(&entity.loc, "No parameter string \"type\" found in MakeNamedMaterial");
                return;
            }
        };
        if ty.is_empty() || ty == "none" {
            return;
        }
        entity.name = ty;
        self.resolve_textures(&mut entity.params);
        self.resolve_mix(&mut entity);
        let id = self.scene.materials.len() as u32;
        self.scene.materials.push(MaterialEntity { name: Some(name.to_string()), entity });
        self.gs.named_materials.insert(name.to_string(), id);
        self.gs.named_generation = self.next_serial();
    }

    /// `NamedMaterial "name"`.
    pub fn named_material(&mut self, name: &str, loc: &FileLoc) {
        if !self.verify_world(loc, "NamedMaterial") {
            return;
        }
        if !self.gs.named_materials.contains_key(name) {
            self.warn(loc, format!("NamedMaterial \"{name}\" unknown."));
            return;
        }
        self.gs.named_material = Some(name.to_string());
    }

    /// `Texture "name" "float"|"spectrum"|"color" "class" params`.
    pub fn texture(
        &mut self,
        name: &str,
        kind: &str,
        mut entity: Entity,
        dir: &Path,
    ) -> Result<()> {
        if !self.verify_world(&entity.loc, "Texture") {
            return Ok(());
        }
        let kind = match kind {
            "float" => TextureKind::Float,
            "spectrum" | "color" => TextureKind::Spectrum,
            _ => {
                self.warn(&entity.loc, format!("Texture type \"{kind}\" unknown."));
                return Ok(());
            }
        };
        self.warn_if_animated(&entity.loc, "Texture");
        if entity.name == "imagemap" {
            self.load_asset(&mut entity, "filename", dir)?;
        }
        self.resolve_textures(&mut entity.params);
        let id = self.scene.textures.len() as u32;
        let world_from_texture = self.ctm.t[0];
        self.scene.textures.push(TextureEntity {
            name: name.to_string(),
            kind,
            entity,
            world_from_texture,
        });
        let map = match kind {
            TextureKind::Float => &mut self.gs.float_textures,
            TextureKind::Spectrum => &mut self.gs.spectrum_textures,
        };
        map.insert(name.to_string(), id);
        self.gs.texture_generation = self.next_serial();
        Ok(())
    }

    /// `LightSource "type" params`.
    pub fn light_source(&mut self, mut entity: Entity, dir: &Path) -> Result<()> {
        if !self.verify_world(&entity.loc, "LightSource") {
            return Ok(());
        }
        self.warn_if_animated(&entity.loc, "LightSource");
        if matches!(entity.name.as_str(), "infinite" | "exinfinite" | "goniometric" | "projection")
        {
            self.load_asset(&mut entity, "mapname", dir)?;
        }
        let medium = self.medium_name(&self.gs.outside_medium.clone(), &entity.loc);
        let world_from_light = self.start_only();
        let shapes_before = self.scene.shapes.len() as u32;
        self.scene.lights.push(LightEntity { entity, world_from_light, medium, shapes_before });
        Ok(())
    }

    /// `AreaLightSource "type" params` (`""` turns it off).
    pub fn area_light_source(&mut self, entity: Entity) {
        if self.verify_world(&entity.loc, "AreaLightSource") {
            self.gs.area_light = if entity.name.is_empty() { None } else { Some(entity) };
        }
    }

    /// `Shape "type" params`.
    pub fn shape(&mut self, mut entity: Entity, dir: &Path) -> Result<()> {
        if !self.verify_world(&entity.loc, "Shape") {
            return Ok(());
        }
        if entity.name == "plymesh" {
            self.load_plymesh(&mut entity, dir)?;
        }
        self.resolve_textures(&mut entity.params);
        let mut area_light = self.gs.area_light.clone();
        if area_light.is_some() && self.ctm.is_animated() {
            self.warn(
                &entity.loc,
                "Ignoring currently set area light when creating animated shape",
            );
            area_light = None;
        }
        if area_light.is_some() && self.current_object.is_some() {
            // pbrt-v3 warns and keeps the light on the instance's shapes:
            // they emit where seen but light nothing (the renderer's glows).
            self.warn(&entity.loc, "Area lights not supported with object instancing");
        }
        let material = self.material_for_shape();
        let media = MediumInterface {
            inside: self.medium_name(&self.gs.inside_medium.clone(), &entity.loc),
            outside: self.medium_name(&self.gs.outside_medium.clone(), &entity.loc),
        };
        let shape = ShapeEntity {
            entity,
            world_from_object: self.animated(),
            reverse_orientation: self.gs.reverse_orientation,
            material,
            area_light,
            media,
        };
        match self.current_object {
            Some(i) => self.scene.objects[i].shapes.push(shape),
            None => self.scene.shapes.push(shape),
        }
        Ok(())
    }

    /// `MakeNamedMedium "name" "string type" "..." params`.
    pub fn make_named_medium(&mut self, name: &str, mut entity: Entity) {
        self.warn_if_animated(&entity.loc, "MakeNamedMedium");
        match entity.params.take("type").map(|p| p.value) {
            Some(ParamValue::String(v)) if !v.is_empty() && !v[0].is_empty() => {
                entity.name = v[0].clone()
            }
            _ => {
                self.warn(&entity.loc, "No parameter string \"type\" found in MakeNamedMedium");
                return;
            }
        }
        self.media_names.insert(name.to_string());
        let world_from_medium = self.ctm.t[0];
        self.scene.media.push(MediumEntity { name: name.to_string(), entity, world_from_medium });
    }

    /// `ObjectBegin "name"`.
    pub fn object_begin(&mut self, name: &str, loc: &FileLoc) {
        if !self.verify_world(loc, "ObjectBegin") {
            return;
        }
        self.attribute_begin(loc);
        if self.current_object.is_some() {
            self.warn(loc, "ObjectBegin called inside of instance definition");
        }
        let id = self.scene.objects.len();
        self.scene.objects.push(ObjectEntity {
            name: name.to_string(),
            shapes: Vec::new(),
            loc: loc.clone(),
        });
        self.object_names.insert(name.to_string(), id as u32);
        self.current_object = Some(id);
    }

    /// `ObjectEnd`.
    pub fn object_end(&mut self, loc: &FileLoc) {
        if !self.verify_world(loc, "ObjectEnd") {
            return;
        }
        if self.current_object.is_none() {
            self.warn(loc, "ObjectEnd called outside of instance definition");
        }
        self.current_object = None;
        self.attribute_end(loc);
    }

    /// `ObjectInstance "name"`.
    pub fn object_instance(&mut self, name: &str, loc: &FileLoc) {
        if !self.verify_world(loc, "ObjectInstance") {
            return;
        }
        if self.current_object.is_some() {
            self.warn(loc, "ObjectInstance can't be called inside instance definition");
            return;
        }
        let Some(&object) = self.object_names.get(name) else {
            self.warn(loc, format!("Unable to find instance named \"{name}\""));
            return;
        };
        if self.scene.objects[object as usize].shapes.is_empty() {
            return;
        }
        let world_from_instance = self.animated();
        self.scene.instances.push(InstanceEntity { object, world_from_instance, loc: loc.clone() });
    }
}
