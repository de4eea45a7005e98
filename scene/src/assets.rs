//! Files a scene names, read on the parsing host so workers never touch its
//! file system: image maps and light maps go into
//! `SceneDescription::assets`, and `plymesh` shapes become `trianglemesh`.
//!
//! ```text
//! Texture "grid" "spectrum" "imagemap" "string filename" "textures/grid.png"
//! LightSource "infinite" "string mapname" "sky.exr"
//! Shape "plymesh" "string filename" "geometry/plate1.ply"
//! ```

use super::builder::Builder;
use crate::error::{Result, SceneError};
use crate::ply;
use farm_common::scene::{Entity, FileLoc, Param, ParamValue};
use std::path::{Path, PathBuf};

/// Reads a whole file, with the scene location for the error.
pub fn read_file(path: &Path, loc: &FileLoc) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| SceneError::File {
        loc: loc.clone(),
        path: path.to_string_lossy().into_owned(),
        source,
    })
}

/// A file a scene names, found as pbrt-v3 finds it: relative to the main
/// scene file's directory (`search`, pbrt-v3's search directory), else,
/// if there is no such file, relative to `dir`, the directory of the file
/// that names it. Large scenes rely on both: San Miguel's geometry files
/// name their PLYs from the main file's directory, while hand-split scenes
/// often name them from their own. An absolute path stands as written.
pub fn resolve(search: &Path, dir: &Path, name: &str) -> PathBuf {
    let name = Path::new(name);
    if name.is_absolute() {
        return name.to_path_buf();
    }
    let primary = search.join(name);
    if search == dir || primary.exists() {
        return primary;
    }
    let local = dir.join(name);
    if local.exists() {
        local
    } else {
        primary
    }
}

/// The file named by a string parameter, resolved by [`resolve`].
fn string_param(
    entity: &Entity,
    name: &str,
    search: &Path,
    dir: &Path,
) -> Option<(PathBuf, FileLoc)> {
    entity.params.params.iter().find_map(|p| match &p.value {
        ParamValue::String(v) if p.name == name && !v.is_empty() => {
            Some((resolve(search, dir, &v[0]), p.loc.clone()))
        }
        _ => None,
    })
}

/// The key of the asset at `path`: its path relative to the scene's folder
/// `root`, with `/` between components, so the description a client sends
/// never carries the client's absolute paths. A file outside the folder
/// gets a key that starts with `../` ([`is_outside`]); symbolic links are
/// followed first, so a link cannot hide where a file really is.
pub fn asset_key(root: &Path, path: &Path) -> String {
    let file = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    let mut file = file.components().peekable();
    let mut base = root.components().peekable();
    while let (Some(a), Some(b)) = (file.peek(), base.peek()) {
        if a != b {
            break;
        }
        file.next();
        base.next();
    }
    let up = base.map(|_| "..".to_string());
    let down = file.map(|c| c.as_os_str().to_string_lossy().into_owned());
    up.chain(down).collect::<Vec<_>>().join("/")
}

/// Whether an asset key names a file outside the scene's folder.
pub fn is_outside(key: &str) -> bool {
    key == ".." || key.starts_with("../")
}

impl Builder {
    /// Reads the file named by `"string <param>"` into the assets and
    /// rewrites the parameter to the asset's key.
    pub(super) fn load_asset(
        &mut self,
        entity: &mut Entity,
        param: &str,
        dir: &Path,
    ) -> Result<()> {
        let Some((path, loc)) = string_param(entity, param, &self.search_dir, dir) else {
            return Ok(());
        };
        let key = asset_key(&self.root, &path);
        if !self.scene.assets.contains_key(&key) {
            let bytes = read_file(&path, &loc)?;
            self.scene.assets.insert(key.clone(), bytes);
        }
        for p in &mut entity.params.params {
            if p.name == param {
                if let ParamValue::String(v) = &mut p.value {
                    v[0].clone_from(&key);
                }
            }
        }
        Ok(())
    }

    /// Reads a `plymesh`'s file and turns the shape into a `trianglemesh`
    /// with `P`, `N` (if present), `uv` (if present) and `indices`.
    pub(super) fn load_plymesh(&mut self, entity: &mut Entity, dir: &Path) -> Result<()> {
        let Some((path, loc)) = string_param(entity, "filename", &self.search_dir, dir) else {
            return Err(SceneError::BadValue {
                loc: entity.loc.clone(),
                decl: "string filename".into(),
                found: "nothing".into(),
                expected: "the PLY file's name for Shape \"plymesh\"".into(),
            });
        };
        let bytes = read_file(&path, &loc)?;
        let path_str = path.to_string_lossy().into_owned();
        let mut mesh = ply::parse(&bytes).map_err(|e| SceneError::BadFile {
            loc: loc.clone(),
            kind: "PLY",
            path: path_str.clone(),
            what: e.0,
        })?;
        for w in std::mem::take(&mut mesh.warnings) {
            self.warn(&loc, w);
        }
        let discard = entity.params.take("discarddegenerateUVs");
        if let Some(Param { value: ParamValue::Bool(b), .. }) = discard {
            if b.first() == Some(&true) && mesh.n.is_some() && degenerate_uvs(&mesh) {
                self.warn(&loc, "Degenerate uv coordinates in triangle mesh.  Discarding all uv.");
                mesh.uv = None;
            }
        }
        entity.params.take("filename");
        let at = entity.loc.clone();
        let mut add = |name: &str, value: ParamValue| {
            entity.params.add(Param { name: name.to_string(), value, loc: at.clone() });
        };
        add("P", ParamValue::Point3(mesh.p));
        if let Some(n) = mesh.n {
            add("N", ParamValue::Normal(n));
        }
        if let Some(uv) = mesh.uv {
            add("uv", ParamValue::Point2(uv));
        }
        add("indices", ParamValue::Int(mesh.indices));
        entity.name = "trianglemesh".to_string();
        Ok(())
    }
}

/// pbrt-v3 plymesh's test for uv coordinates that repeat on a
/// non-degenerate triangle.
fn degenerate_uvs(mesh: &ply::PlyMesh) -> bool {
    let Some(uv) = &mesh.uv else { return false };
    let p = |i: i32| glam::Vec3::from(mesh.p[i as usize]);
    for t in mesh.indices.chunks_exact(3) {
        let area = 0.5 * (p(t[0]) - p(t[1])).cross(p(t[2]) - p(t[1])).length();
        if area < 1e-7 {
            continue;
        }
        let (a, b, c) = (uv[t[0] as usize], uv[t[1] as usize], uv[t[2] as usize]);
        if a == b || b == c || c == a {
            return true;
        }
    }
    false
}
