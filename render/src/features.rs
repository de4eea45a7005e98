//! What a scene uses, found from its description before anything is built,
//! so that a render pays only for that: no ray differentials when no
//! texture filters over a footprint and no material bump-maps, no motion
//! interpolation for static transforms.
//!
//! Static transforms are already free: static shapes are baked into render
//! space at build time and an [`AnimatedTransform`] whose keyframes agree
//! applies one matrix. Texture-valued material parameters are looked up per
//! hit only when a texture was given; constants are stored as values. This
//! analysis reports those choices and decides the one left to make per ray:
//! whether camera rays carry differentials.
//!
//! [`AnimatedTransform`]: farm_common::geometry::AnimatedTransform

use farm_common::scene::{AnimatedXform, Params, SceneDescription, TextureEntity};

/// The features a scene uses.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Features {
    /// Textures, by scene name, whose lookups filter over the ray's
    /// footprint on the surface (image maps, noise, closed-form
    /// anti-aliased checkerboards).
    pub filtering_textures: Vec<String>,
    /// Textures of every kind.
    pub textures: usize,
    /// Materials with a `bumpmap` (its finite differences are scaled by the
    /// footprint too).
    pub bump_maps: usize,
    /// Shapes, lights and object instances whose transform moves during the
    /// shutter interval.
    pub moving: usize,
    /// Whether the camera moves.
    pub moving_camera: bool,
    /// Object instances.
    pub instances: usize,
    /// Files the scene reads (meshes, images), and their total size in bytes.
    pub assets: (usize, usize),
}

/// Whether a texture's lookups use the ray's footprint (pbrt-v3's
/// textures that read `dstdx`/`dstdy` or `dpdx`/`dpdy`).
pub fn texture_filters(t: &TextureEntity) -> bool {
    let p = Params::new(&t.entity.params);
    match t.entity.name.as_str() {
        "imagemap" | "fbm" | "wrinkled" | "windy" | "marble" => true,
        "checkerboard" => {
            p.int("dimension", 2) == 2 && p.string("aamode", "closedform") == "closedform"
        }
        _ => false,
    }
}

fn moves(x: &AnimatedXform) -> bool {
    x.start != x.end
}

impl Features {
    /// Analyses a scene description.
    pub fn of(desc: &SceneDescription) -> Features {
        let object_shapes = desc.objects.iter().flat_map(|o| &o.shapes);
        Features {
            filtering_textures: desc
                .textures
                .iter()
                .filter(|t| texture_filters(t))
                .map(|t| t.name.clone())
                .collect(),
            textures: desc.textures.len(),
            bump_maps: desc
                .materials
                .iter()
                .filter(|m| m.entity.params.get("bumpmap").is_some())
                .count(),
            moving: desc
                .shapes
                .iter()
                .chain(object_shapes)
                .filter(|s| moves(&s.world_from_object))
                .count()
                + desc.lights.iter().filter(|l| moves(&l.world_from_light)).count()
                + desc.instances.iter().filter(|i| moves(&i.world_from_instance)).count(),
            moving_camera: moves(&desc.camera.world_from_camera),
            instances: desc.instances.len(),
            assets: (desc.assets.len(), desc.assets.values().map(Vec::len).sum()),
        }
    }

    /// Whether camera rays need differentials: some texture filters over
    /// the footprint, or some material is bump-mapped.
    pub fn needs_differentials(&self) -> bool {
        !self.filtering_textures.is_empty() || self.bump_maps > 0
    }

    /// One line per feature: what the scene uses and what the render skips.
    pub fn describe(&self) -> Vec<String> {
        let mut lines = Vec::new();
        if self.needs_differentials() {
            let mut why = Vec::new();
            if !self.filtering_textures.is_empty() {
                why.push(format!("filtering textures {}", self.filtering_textures.join(", ")));
            }
            if self.bump_maps > 0 {
                why.push(format!("{} bump-mapped materials", self.bump_maps));
            }
            lines.push(format!("ray differentials: used ({})", why.join("; ")));
        } else {
            lines.push(
                "ray differentials: skipped (no texture filters over the footprint, no bump map)"
                    .into(),
            );
        }
        lines.push(if self.textures == 0 {
            "textures: none (materials use constant parameters only)".into()
        } else {
            format!("textures: {} ({} filtering)", self.textures, self.filtering_textures.len())
        });
        lines.push(if self.moving == 0 && !self.moving_camera {
            "motion: skipped (every transform is static)".into()
        } else {
            format!(
                "motion: {} moving shapes, lights or instances{}",
                self.moving,
                if self.moving_camera { ", moving camera" } else { "" }
            )
        });
        lines.push(format!("object instances: {}", self.instances));
        let bytes = self.assets.1 as f64;
        let size = if bytes < 1e6 {
            format!("{:.1} kB", bytes / 1e3)
        } else {
            format!("{:.1} MB", bytes / 1e6)
        };
        lines.push(format!("assets: {} files, {size}", self.assets.0));
        lines
    }
}

#[cfg(test)]
mod filter_tests {
    use super::texture_filters;
    use farm_common::geometry::{DMat4, Transform};
    use farm_common::scene::{Entity, TextureEntity, TextureKind};
    use std::collections::BTreeMap;

    /// The analysis that decides whether camera rays carry differentials
    /// reads texture names; the textures themselves know whether they
    /// filter. The two must agree for every texture type, or a scene
    /// renders without the differentials its textures need.
    #[test]
    fn the_name_list_agrees_with_the_textures() {
        let names = [
            "constant",
            "scale",
            "mix",
            "bilerp",
            "checkerboard",
            "dots",
            "imagemap",
            "uv",
            "fbm",
            "wrinkled",
            "windy",
            "marble",
        ];
        for name in names {
            let e = TextureEntity {
                name: "t".into(),
                kind: TextureKind::Spectrum,
                entity: Entity::named(name),
                world_from_texture: DMat4::IDENTITY,
            };
            let mut w = Vec::new();
            let set = crate::textures::build(
                std::slice::from_ref(&e),
                &Transform::default(),
                &BTreeMap::new(),
                &mut w,
            );
            let built = set.spectra[0].as_ref().is_some_and(|t| t.uses_differentials());
            assert_eq!(texture_filters(&e), built, "{name}");
        }
    }
}
