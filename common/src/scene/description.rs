//! The entities of a parsed scene (pbrt-v4's `SceneEntity` idea applied to
//! pbrt-v3's format). Transforms are kept in double precision, in world
//! space; workers move everything into a camera-centred render space.

use super::loc::FileLoc;
use super::params::ParamSet;
use glam::DMat4;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A directive's type name, parameters and location, e.g.
/// `Sampler "halton" "integer pixelsamples" 16`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Entity {
    /// The quoted type name (`"halton"`).
    pub name: String,
    /// Its parameters.
    pub params: ParamSet,
    /// Where the directive starts.
    pub loc: FileLoc,
}

impl Entity {
    /// An entity with no parameters.
    pub fn named(name: &str) -> Self {
        Entity { name: name.to_string(), ..Default::default() }
    }
}

/// A transform at the two shutter times (pbrt-v3 `TransformSet` with
/// `TransformTimes`). Static when both matrices are equal.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AnimatedXform {
    /// The transform at `start_time`.
    pub start: DMat4,
    /// The transform at `end_time`.
    pub end: DMat4,
    /// Time of `start` (`TransformTimes`, default 0).
    pub start_time: f32,
    /// Time of `end` (`TransformTimes`, default 1).
    pub end_time: f32,
}

impl AnimatedXform {
    /// A transform that does not move.
    pub fn fixed(m: DMat4) -> Self {
        AnimatedXform { start: m, end: m, start_time: 0.0, end_time: 1.0 }
    }
    /// Whether both keyframes are the same matrix.
    pub fn is_static(&self) -> bool {
        self.start == self.end
    }
}

impl Default for AnimatedXform {
    fn default() -> Self {
        AnimatedXform::fixed(DMat4::IDENTITY)
    }
}

/// The `Camera` directive, with the camera's placement in the world.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraEntity {
    /// Type and parameters.
    pub entity: Entity,
    /// World-from-camera (the inverse of the CTM at the `Camera` directive).
    pub world_from_camera: AnimatedXform,
    /// The camera's medium (`MediumInterface` outside), if any.
    pub medium: Option<String>,
}

/// Whether a texture yields floats or spectra.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TextureKind {
    /// `Texture "name" "float" ...`
    Float,
    /// `Texture "name" "spectrum" ...` (or `"color"`)
    Spectrum,
}

/// A `Texture` directive.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TextureEntity {
    /// The name the scene gave it.
    pub name: String,
    /// Float or spectrum.
    pub kind: TextureKind,
    /// Class (`"imagemap"`, `"checkerboard"`...) and parameters; texture
    /// parameters are resolved to earlier textures.
    pub entity: Entity,
    /// World-from-texture (the CTM at the directive).
    pub world_from_texture: DMat4,
}

/// A `Material` or `MakeNamedMaterial` directive. `"texture"` parameters
/// refer to earlier textures; a mix material's `namedmaterial1/2` are
/// resolved to earlier materials.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaterialEntity {
    /// The name for `MakeNamedMaterial`, `None` for an anonymous `Material`.
    pub name: Option<String>,
    /// Type (`"matte"`...) and parameters.
    pub entity: Entity,
}

/// Media on the two sides of a surface (`MediumInterface`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MediumInterface {
    /// Inside the surface.
    pub inside: Option<String>,
    /// Outside the surface.
    pub outside: Option<String>,
}

/// A `Shape` directive with the graphics state it was written in.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShapeEntity {
    /// Type and parameters. `plymesh` files are read by the parser and
    /// arrive here as `trianglemesh` with the same parameters the file gave.
    pub entity: Entity,
    /// World-from-object (or, inside `ObjectBegin`, instance-from-object).
    pub world_from_object: AnimatedXform,
    /// `ReverseOrientation` was in effect.
    pub reverse_orientation: bool,
    /// Index into `SceneDescription::materials`; `None` for `Material "none"`.
    pub material: Option<u32>,
    /// The `AreaLightSource` in effect, if any.
    pub area_light: Option<Entity>,
    /// Media on either side.
    pub media: MediumInterface,
}

/// A `LightSource` directive.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LightEntity {
    /// Type and parameters.
    pub entity: Entity,
    /// World-from-light (the CTM at the directive).
    pub world_from_light: AnimatedXform,
    /// The outside medium in effect.
    pub medium: Option<String>,
    /// How many top-level shapes came before the directive: pbrt-v3 lists
    /// the scene's lights in the order of their directives, this light
    /// after the area lights of those shapes. Not in the serialized form,
    /// so manifests written before it keep their layout: a manifest
    /// carries these after the description (farm-proto `encode_scene`).
    #[serde(skip)]
    pub shapes_before: u32,
}

/// An `ObjectBegin`/`ObjectEnd` block.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectEntity {
    /// Its name.
    pub name: String,
    /// Its shapes, placed relative to the instance.
    pub shapes: Vec<ShapeEntity>,
    /// Where `ObjectBegin` was.
    pub loc: FileLoc,
}

/// An `ObjectInstance` directive.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InstanceEntity {
    /// Index into `SceneDescription::objects`.
    pub object: u32,
    /// World-from-instance (the CTM at the directive).
    pub world_from_instance: AnimatedXform,
    /// Where the directive was.
    pub loc: FileLoc,
}

/// A `MakeNamedMedium` directive (parsed and carried; the Whitted integrator
/// ignores participating media, as pbrt-v3's does).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MediumEntity {
    /// Its name.
    pub name: String,
    /// Type and parameters.
    pub entity: Entity,
    /// World-from-medium.
    pub world_from_medium: DMat4,
}

/// Everything a worker needs to render a scene.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SceneDescription {
    /// A short name (the scene file's stem), for metadata and progress.
    pub name: String,
    /// The camera.
    pub camera: CameraEntity,
    /// `Film` (default `"image"`).
    pub film: Entity,
    /// `Sampler` (default `"halton"`, 16 samples).
    pub sampler: Entity,
    /// `PixelFilter` (default `"box"`).
    pub filter: Entity,
    /// `Integrator` (default `"path"`; this renderer only has `"whitted"`).
    pub integrator: Entity,
    /// `Accelerator` (always a BVH here; kept for warnings).
    pub accelerator: Entity,
    /// Textures, in the order defined; later ones may refer to earlier ones.
    pub textures: Vec<TextureEntity>,
    /// Materials, in the order defined. Index 0 is the default `matte`.
    pub materials: Vec<MaterialEntity>,
    /// Shapes outside object definitions.
    pub shapes: Vec<ShapeEntity>,
    /// Light sources (area lights travel with their shapes).
    pub lights: Vec<LightEntity>,
    /// Object definitions.
    pub objects: Vec<ObjectEntity>,
    /// Object instances.
    pub instances: Vec<InstanceEntity>,
    /// Named media.
    pub media: Vec<MediumEntity>,
    /// Files the scene refers to (image maps), by the path string the scene
    /// used after resolving it against the including file's directory. Not
    /// serialized: assets travel separately, content-addressed, so a worker
    /// that holds one already is not sent it again.
    #[serde(skip)]
    pub assets: BTreeMap<String, Vec<u8>>,
}
