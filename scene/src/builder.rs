//! The parser's target (pbrt-v3 `core/api.cpp`): the current transforms, the
//! graphics state and its stacks, the options block, and the finished
//! [`SceneDescription`]. World directives (shapes, materials, textures,
//! lights, instances) are in `world.rs`; file assets in `assets.rs`.
//!
//! ```text
//! LookAt 3 4 1.5  .5 .5 0  0 0 1
//! Camera "perspective" "float fov" 45
//! WorldBegin
//! AttributeBegin
//!   Material "matte" "rgb Kd" [.5 .5 .8]
//!   Shape "sphere"
//! AttributeEnd
//! WorldEnd
//! ```

use super::transform::TransformSet;
use farm_common::scene::{
    AnimatedXform, CameraEntity, Entity, FileLoc, MaterialEntity, SceneDescription, Warning,
};
use glam::DMat4;
use std::collections::{HashMap, HashSet};

/// Which block of the file the parser is in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Block {
    /// Before `WorldBegin`: options and the camera.
    Options,
    /// Between `WorldBegin` and `WorldEnd`.
    World,
    /// After `WorldEnd`: nothing more is read.
    Done,
}

/// A `Material` directive not yet turned into a [`MaterialEntity`]: pbrt-v3
/// creates materials when a shape uses them, with the textures in scope then.
#[derive(Clone, Debug)]
pub struct PendingMaterial {
    /// Type and parameters, texture references unresolved.
    pub entity: Entity,
    /// Distinguishes `Material` directives, for the cache of resolved ones.
    pub serial: u64,
}

/// pbrt-v3's `GraphicsState`, saved by `AttributeBegin`.
#[derive(Clone, Debug, Default)]
pub struct GraphicsState {
    /// The current `Material`; `None` after `Material "none"`.
    pub material: Option<PendingMaterial>,
    /// The current `NamedMaterial`, which wins over `material` when defined.
    pub named_material: Option<String>,
    /// Named materials in scope: name to index in `materials`.
    pub named_materials: HashMap<String, u32>,
    /// Float textures in scope: name to index in `textures`.
    pub float_textures: HashMap<String, u32>,
    /// Spectrum textures in scope.
    pub spectrum_textures: HashMap<String, u32>,
    /// Changes whenever the textures in scope change.
    pub texture_generation: u64,
    /// Changes whenever the named materials in scope change.
    pub named_generation: u64,
    /// The `AreaLightSource` in effect.
    pub area_light: Option<Entity>,
    /// `ReverseOrientation` parity.
    pub reverse_orientation: bool,
    /// `MediumInterface` inside name ("" for none).
    pub inside_medium: String,
    /// `MediumInterface` outside name ("" for none).
    pub outside_medium: String,
}

/// Accumulates the scene while the parser calls it.
pub struct Builder {
    /// The scene so far.
    pub scene: SceneDescription,
    /// The folder of the scene's main file (canonical when it exists):
    /// asset keys are relative to it.
    pub root: std::path::PathBuf,
    /// The main scene file's directory, against which pbrt-v3 resolves
    /// every file a scene names (`assets::resolve`).
    pub search_dir: std::path::PathBuf,
    /// Warnings so far.
    pub warnings: Vec<Warning>,
    /// Which block the parser is in.
    pub block: Block,
    /// The current transformation matrices.
    pub ctm: TransformSet,
    pub(super) named_coords: HashMap<String, [DMat4; 2]>,
    pub(super) gs: GraphicsState,
    pub(super) gs_stack: Vec<GraphicsState>,
    pub(super) xf_stack: Vec<TransformSet>,
    pub(super) start_time: f32,
    pub(super) end_time: f32,
    /// Index into `scene.objects` while inside `ObjectBegin`.
    pub(super) current_object: Option<usize>,
    pub(super) object_names: HashMap<String, u32>,
    pub(super) media_names: HashSet<String>,
    /// Resolved anonymous materials by (serial, texture generation, named generation).
    pub(super) material_cache: HashMap<(u64, u64, u64), u32>,
    pub(super) counter: u64,
}

impl Builder {
    /// A builder for a scene called `name`, with pbrt-v3's defaults.
    pub fn new(name: &str) -> Self {
        let scene = SceneDescription {
            name: name.to_string(),
            camera: CameraEntity { entity: Entity::named("perspective"), ..Default::default() },
            film: Entity::named("image"),
            sampler: Entity::named("halton"),
            filter: Entity::named("box"),
            integrator: Entity::named("path"),
            accelerator: Entity::named("bvh"),
            materials: vec![MaterialEntity { name: None, entity: Entity::named("matte") }],
            ..Default::default()
        };
        let gs = GraphicsState {
            material: Some(PendingMaterial { entity: Entity::named("matte"), serial: 0 }),
            ..Default::default()
        };
        let mut material_cache = HashMap::new();
        material_cache.insert((0, 0, 0), 0);
        Builder {
            scene,
            root: std::path::PathBuf::new(),
            search_dir: std::path::PathBuf::new(),
            warnings: Vec::new(),
            block: Block::Options,
            ctm: TransformSet::default(),
            named_coords: HashMap::new(),
            gs,
            gs_stack: Vec::new(),
            xf_stack: Vec::new(),
            start_time: 0.0,
            end_time: 1.0,
            current_object: None,
            object_names: HashMap::new(),
            media_names: HashSet::new(),
            material_cache,
            counter: 0,
        }
    }

    /// Records a warning.
    pub fn warn(&mut self, loc: &FileLoc, msg: impl Into<String>) {
        self.warnings.push(Warning::at(loc, msg));
    }

    /// A fresh number for generations and serials.
    pub(super) fn next_serial(&mut self) -> u64 {
        self.counter += 1;
        self.counter
    }

    /// pbrt-v3's `VERIFY_WORLD`: warns and returns false outside the world block.
    pub fn verify_world(&mut self, loc: &FileLoc, directive: &str) -> bool {
        if self.block == Block::World {
            return true;
        }
        self.warn(
            loc,
            format!("Scene description must be inside world block; \"{directive}\" not allowed. Ignoring."),
        );
        false
    }

    /// pbrt-v3's `VERIFY_OPTIONS`: warns and returns false inside the world block.
    pub fn verify_options(&mut self, loc: &FileLoc, directive: &str) -> bool {
        if self.block == Block::Options {
            return true;
        }
        self.warn(
            loc,
            format!(
                "Options cannot be set inside world block; \"{directive}\" not allowed.  Ignoring."
            ),
        );
        false
    }

    /// pbrt-v3's `WARN_IF_ANIMATED_TRANSFORM`.
    pub(super) fn warn_if_animated(&mut self, loc: &FileLoc, directive: &str) {
        if self.ctm.is_animated() {
            self.warn(
                loc,
                format!("Animated transformations set; ignoring for \"{directive}\" and using the start transform only"),
            );
        }
    }

    /// The current transforms with the shutter times.
    pub fn animated(&self) -> AnimatedXform {
        AnimatedXform {
            start: self.ctm.t[0],
            end: self.ctm.t[1],
            start_time: self.start_time,
            end_time: self.end_time,
        }
    }

    /// The start transform only, as a fixed transform with the shutter times.
    pub(super) fn start_only(&self) -> AnimatedXform {
        AnimatedXform { end: self.ctm.t[0], ..self.animated() }
    }

    /// `CoordinateSystem "name"`.
    pub fn coordinate_system(&mut self, name: &str) {
        self.named_coords.insert(name.to_string(), self.ctm.t);
    }

    /// `CoordSysTransform "name"`.
    pub fn coord_sys_transform(&mut self, name: &str, loc: &FileLoc) {
        match self.named_coords.get(name) {
            Some(t) => self.ctm.t = *t,
            None => self.warn(loc, format!("Couldn't find named coordinate system \"{name}\"")),
        }
    }

    /// `TransformTimes start end`.
    pub fn transform_times(&mut self, start: f32, end: f32, loc: &FileLoc) {
        if self.verify_options(loc, "TransformTimes") {
            self.start_time = start;
            self.end_time = end;
        }
    }

    /// `Camera`, `Sampler`, `Film`, `PixelFilter`, `Integrator` and
    /// `Accelerator` (`directive` says which).
    pub fn option(&mut self, directive: &str, entity: Entity) {
        if !self.verify_options(&entity.loc, directive) {
            return;
        }
        match directive {
            "Camera" => {
                let inv = self.ctm.inverse();
                self.named_coords.insert("camera".to_string(), inv);
                let medium = self.medium_name(&self.gs.outside_medium.clone(), &entity.loc);
                self.scene.camera = CameraEntity {
                    entity,
                    world_from_camera: AnimatedXform {
                        start: inv[0],
                        end: inv[1],
                        start_time: 0.0,
                        end_time: 1.0,
                    },
                    medium,
                };
            }
            "Sampler" => self.scene.sampler = entity,
            "Film" => self.scene.film = entity,
            "PixelFilter" => self.scene.filter = entity,
            "Integrator" => self.scene.integrator = entity,
            _ => self.scene.accelerator = entity,
        }
    }

    /// `WorldBegin`.
    pub fn world_begin(&mut self, loc: &FileLoc) {
        if !self.verify_options(loc, "WorldBegin") {
            return;
        }
        self.block = Block::World;
        self.ctm = TransformSet::default();
        self.named_coords.insert("world".to_string(), self.ctm.t);
    }

    /// `WorldEnd`: reports unclosed blocks and stops the parse.
    pub fn world_end(&mut self, loc: &FileLoc) {
        if !self.verify_world(loc, "WorldEnd") {
            return;
        }
        while self.gs_stack.pop().is_some() {
            self.warn(loc, "Missing end to pbrtAttributeBegin()");
            self.xf_stack.pop();
        }
        while self.xf_stack.pop().is_some() {
            self.warn(loc, "Missing end to pbrtTransformBegin()");
        }
        self.block = Block::Done;
    }

    /// `AttributeBegin`.
    pub fn attribute_begin(&mut self, loc: &FileLoc) {
        if self.verify_world(loc, "AttributeBegin") {
            self.gs_stack.push(self.gs.clone());
            self.xf_stack.push(self.ctm);
        }
    }

    /// `AttributeEnd`.
    pub fn attribute_end(&mut self, loc: &FileLoc) {
        if !self.verify_world(loc, "AttributeEnd") {
            return;
        }
        let Some(gs) = self.gs_stack.pop() else {
            self.warn(loc, "Unmatched pbrtAttributeEnd() encountered. Ignoring it.");
            return;
        };
        self.gs = gs;
        if let Some(ctm) = self.xf_stack.pop() {
            self.ctm = ctm;
        }
    }

    /// `TransformBegin`.
    pub fn transform_begin(&mut self, loc: &FileLoc) {
        if self.verify_world(loc, "TransformBegin") {
            self.xf_stack.push(self.ctm);
        }
    }

    /// `TransformEnd`.
    pub fn transform_end(&mut self, loc: &FileLoc) {
        if !self.verify_world(loc, "TransformEnd") {
            return;
        }
        match self.xf_stack.pop() {
            Some(ctm) => self.ctm = ctm,
            None => self.warn(loc, "Unmatched pbrtTransformEnd() encountered. Ignoring it."),
        }
    }

    /// `ReverseOrientation`.
    pub fn reverse_orientation(&mut self, loc: &FileLoc) {
        if self.verify_world(loc, "ReverseOrientation") {
            self.gs.reverse_orientation = !self.gs.reverse_orientation;
        }
    }

    /// `MediumInterface "inside" "outside"`.
    pub fn medium_interface(&mut self, inside: &str, outside: &str) {
        self.gs.inside_medium = inside.to_string();
        self.gs.outside_medium = outside.to_string();
    }

    /// A medium name as entities carry it: `None` for "" and, with pbrt-v3's
    /// error as a warning, for undefined media.
    pub(super) fn medium_name(&mut self, name: &str, loc: &FileLoc) -> Option<String> {
        if name.is_empty() {
            return None;
        }
        if !self.media_names.contains(name) {
            self.warn(loc, format!("Named medium \"{name}\" undefined."));
            return None;
        }
        Some(name.to_string())
    }

    /// The finished scene and warnings.
    pub fn finish(mut self, end: &FileLoc) -> (SceneDescription, Vec<Warning>) {
        match self.block {
            Block::Options => self.warn(end, "No WorldBegin in the scene; it has no geometry"),
            Block::World => self.warn(end, "Missing WorldEnd at the end of the scene"),
            Block::Done => {}
        }
        let cam = &mut self.scene.camera.world_from_camera;
        cam.start_time = self.start_time;
        cam.end_time = self.end_time;
        (self.scene, self.warnings)
    }
}
