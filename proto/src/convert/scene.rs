//! Scene descriptions on the wire: a manifest blob (the description,
//! without asset bytes, and the blake3 hash of each asset) plus one blob per
//! asset. Blobs are content-addressed, so each is sent to a worker at most
//! once however many jobs use it.

use crate::error::Error;
use farm_common::scene::SceneDescription;
use std::sync::Arc;

/// A blake3 hash.
pub type Hash = [u8; 32];

/// Bytes and their hash.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Blob {
    /// blake3 of `data`.
    pub hash: Hash,
    /// The bytes.
    pub data: Arc<Vec<u8>>,
}

impl Blob {
    /// Hashes `data`.
    pub fn new(data: Vec<u8>) -> Self {
        Blob { hash: blake3::hash(&data).into(), data: Arc::new(data) }
    }
}

/// The manifest blob and the asset blobs of a scene.
pub fn encode_scene(desc: &SceneDescription) -> Result<(Blob, Vec<Blob>), Error> {
    let assets: Vec<(String, Blob)> =
        desc.assets.iter().map(|(k, v)| (k.clone(), Blob::new(v.clone()))).collect();
    let refs: Vec<(&str, Hash)> = assets.iter().map(|(k, b)| (k.as_str(), b.hash)).collect();
    let bytes = postcard::to_stdvec(&(desc, refs)).map_err(|e| Error::Malformed(e.to_string()))?;
    Ok((Blob::new(bytes), assets.into_iter().map(|(_, b)| b).collect()))
}

/// The description in a manifest (with no assets yet) and the assets it
/// needs, by key and hash.
pub fn decode_manifest(bytes: &[u8]) -> Result<(SceneDescription, Vec<(String, Hash)>), Error> {
    postcard::from_bytes(bytes).map_err(|e| Error::Malformed(e.to_string()))
}

/// The full description: the manifest's, with each asset looked up by hash
/// through `fetch` and checked against its hash.
pub fn decode_scene(
    manifest: &[u8],
    mut fetch: impl FnMut(&Hash) -> Option<Arc<Vec<u8>>>,
) -> Result<SceneDescription, Error> {
    let (mut desc, assets) = decode_manifest(manifest)?;
    for (key, hash) in assets {
        let data = fetch(&hash).filter(|d| blake3::hash(d).as_bytes() == &hash);
        let Some(data) = data else {
            return Err(Error::Asset { key });
        };
        desc.assets.insert(key, data.as_ref().clone());
    }
    Ok(desc)
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::scene::{Entity, ShapeEntity};

    #[test]
    fn scenes_round_trip_with_assets_by_hash() {
        let mut desc = SceneDescription { name: "t".into(), ..Default::default() };
        desc.assets.insert("tex.png".into(), vec![1, 2, 3]);
        desc.shapes.push(ShapeEntity {
            entity: Entity::named("sphere"),
            world_from_object: Default::default(),
            reverse_orientation: true,
            material: Some(0),
            area_light: None,
            media: Default::default(),
        });
        let (manifest, assets) = encode_scene(&desc).unwrap();
        assert_eq!(assets.len(), 1);
        let back = decode_scene(&manifest.data, |h| {
            (h == &assets[0].hash).then(|| assets[0].data.clone())
        })
        .unwrap();
        assert_eq!(back, desc);
        // The manifest does not carry the asset bytes, and a corrupt asset is refused.
        assert!(decode_scene(&manifest.data, |_| Some(Arc::new(vec![9]))).is_err());
    }
}
