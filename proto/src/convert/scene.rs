//! Scene descriptions on the wire: a manifest blob (the description,
//! without asset bytes, and the blake3 hash of each asset) plus one blob per
//! asset. Blobs are content-addressed, so each is sent to a worker at most
//! once however many jobs use it.

use crate::error::Error;
use farm_common::scene::{SceneDescription, ShapeEntity};
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

/// A shape whose parameters take at least this many bytes on the wire (a
/// mesh of about 1,000 triangles and up) has them sent as a blob of their
/// own, named in the manifest like an asset: a mesh that several frames of
/// a shot share is then uploaded, stored and fetched once.
pub const SHAPE_BLOB_FROM: usize = 16 << 10;

/// The asset key of a shape's parameters sent apart: `\0shape/I` for
/// the scene's shape I, `\0shape/O/I` for shape I of object O. No file
/// name starts with a NUL, so these never meet a real asset's key.
const SHAPE_KEY: &str = "\u{0}shape/";

/// The manifest blob and the asset blobs of a scene (each blob once). The
/// large shapes' parameters are taken out of `desc` while the manifest is
/// written, and put back.
pub fn encode_scene(desc: &mut SceneDescription) -> Result<(Blob, Vec<Blob>), Error> {
    let mut assets: Vec<(String, Blob)> =
        desc.assets.iter().map(|(k, v)| (k.clone(), Blob::new(v.clone()))).collect();
    // Each large shape's parameters, as a blob, and where they came from.
    let mut moved: Vec<(String, farm_common::scene::ParamSet)> = Vec::new();
    let mut shapes: Vec<(String, &mut ShapeEntity)> =
        desc.shapes.iter_mut().enumerate().map(|(i, s)| (format!("{SHAPE_KEY}{i}"), s)).collect();
    for (o, obj) in desc.objects.iter_mut().enumerate() {
        shapes.extend(
            obj.shapes.iter_mut().enumerate().map(|(i, s)| (format!("{SHAPE_KEY}{o}/{i}"), s)),
        );
    }
    for (key, shape) in shapes {
        let bytes = postcard::to_stdvec(&shape.entity.params)
            .map_err(|e| Error::Malformed(e.to_string()))?;
        if bytes.len() < SHAPE_BLOB_FROM {
            continue;
        }
        assets.push((key.clone(), Blob::new(bytes)));
        moved.push((key, std::mem::take(&mut shape.entity.params)));
    }
    let refs: Vec<(&str, Hash)> = assets.iter().map(|(k, b)| (k.as_str(), b.hash)).collect();
    // Where each light's directive was among the shapes, after the
    // description and its assets, so a manifest journalled before it (the
    // two alone) still decodes. Workers from before it are refused at
    // registration (`PROTOCOL_VERSION` 4), as they would render the lights
    // in another order.
    let light_order: Vec<u32> = desc.lights.iter().map(|l| l.shapes_before).collect();
    let bytes = postcard::to_stdvec(&(&*desc, refs, light_order));
    for (key, params) in moved {
        if let Some(shape) = shape_at(desc, &key) {
            shape.entity.params = params;
        }
    }
    let bytes = bytes.map_err(|e| Error::Malformed(e.to_string()))?;
    let mut blobs: Vec<Blob> = assets.into_iter().map(|(_, b)| b).collect();
    blobs.sort_by_key(|b| b.hash);
    blobs.dedup_by_key(|b| b.hash);
    Ok((Blob::new(bytes), blobs))
}

/// Whether an asset key names a shape's parameters sent apart.
pub fn is_shape_key(key: &str) -> bool {
    key.starts_with(SHAPE_KEY)
}

/// The shape a [`SHAPE_KEY`] key names, if it is one and the scene has it.
fn shape_at<'d>(desc: &'d mut SceneDescription, key: &str) -> Option<&'d mut ShapeEntity> {
    let rest = key.strip_prefix(SHAPE_KEY)?;
    match rest.split_once('/') {
        None => desc.shapes.get_mut(rest.parse::<usize>().ok()?),
        Some((o, i)) => {
            desc.objects.get_mut(o.parse::<usize>().ok()?)?.shapes.get_mut(i.parse::<usize>().ok()?)
        }
    }
}

/// The description in a manifest (with no assets yet, and no parameters
/// in the shapes sent apart) and the assets it needs, by key and hash;
/// then, where the manifest has it, each light's place among the shapes
/// (`LightEntity::shapes_before`).
pub fn decode_manifest(bytes: &[u8]) -> Result<(SceneDescription, Vec<(String, Hash)>), Error> {
    let malformed = |e: postcard::Error| Error::Malformed(e.to_string());
    let ((mut desc, refs), rest): ((SceneDescription, Vec<(String, Hash)>), _) =
        postcard::take_from_bytes(bytes).map_err(malformed)?;
    // A manifest from before the lights' order ends here: every light
    // comes before the shapes, as farm then made them.
    if !rest.is_empty() {
        let order: Vec<u32> = postcard::from_bytes(rest).map_err(malformed)?;
        if order.len() != desc.lights.len() {
            return Err(Error::Malformed(format!(
                "{} light positions for {} lights",
                order.len(),
                desc.lights.len()
            )));
        }
        for (l, n) in desc.lights.iter_mut().zip(order) {
            l.shapes_before = n;
        }
    }
    Ok((desc, refs))
}

/// The full description: the manifest's, with each asset looked up by hash
/// through `fetch` and checked against its hash, and each shape's
/// parameters sent apart put back.
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
        attach_asset(&mut desc, key, &data)?;
    }
    Ok(desc)
}

/// Puts an asset a manifest names (already checked against its hash) into
/// the description from [`decode_manifest`]: a file's bytes into its
/// assets, a shape's parameters sent apart back into the shape.
pub fn attach_asset(desc: &mut SceneDescription, key: String, data: &[u8]) -> Result<(), Error> {
    if !is_shape_key(&key) {
        desc.assets.insert(key, data.to_vec());
        return Ok(());
    }
    let params = postcard::from_bytes(data)
        .map_err(|e| Error::Malformed(format!("a shape's parameters: {e}")))?;
    let Some(shape) = shape_at(desc, &key) else {
        return Err(Error::Malformed(format!("no shape {:?} in the scene", &key[1..])));
    };
    shape.entity.params = params;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::scene::Entity;

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
        let (manifest, assets) = encode_scene(&mut desc).unwrap();
        assert_eq!(assets.len(), 1);
        let back = decode_scene(&manifest.data, |h| {
            (h == &assets[0].hash).then(|| assets[0].data.clone())
        })
        .unwrap();
        assert_eq!(back, desc);
        // The manifest does not carry the asset bytes, and a corrupt asset is refused.
        assert!(decode_scene(&manifest.data, |_| Some(Arc::new(vec![9]))).is_err());
    }

    fn mesh(ints: usize) -> ShapeEntity {
        use farm_common::scene::{Param, ParamValue};
        let mut e = Entity::named("trianglemesh");
        let value = ParamValue::Int((0..ints as i32).collect());
        e.params.add(Param { name: "indices".into(), value, loc: Default::default() });
        ShapeEntity {
            entity: e,
            world_from_object: Default::default(),
            reverse_orientation: false,
            material: None,
            area_light: None,
            media: Default::default(),
        }
    }

    /// A large mesh travels as a blob of its own, so two scenes (two
    /// frames of a shot) that share it send it once; small shapes stay in
    /// the manifest; the scene decodes as it was.
    #[test]
    fn large_shapes_travel_apart_and_frames_share_them() {
        use farm_common::scene::ObjectEntity;
        let scene = |camera_x: f32| {
            let mut d = SceneDescription { name: "f".into(), ..Default::default() };
            d.shapes.push(mesh(10));
            d.shapes.push(mesh(100_000));
            d.objects.push(ObjectEntity {
                name: "o".into(),
                shapes: vec![mesh(12), mesh(50_000)],
                loc: Default::default(),
            });
            d.film.name = format!("{camera_x}");
            d
        };
        let (mut a, mut b) = (scene(1.0), scene(2.0));
        let (ma, blobs_a) = encode_scene(&mut a).unwrap();
        let (mb, blobs_b) = encode_scene(&mut b).unwrap();
        assert_eq!(a, scene(1.0), "the parameters are put back");
        assert_eq!(blobs_a.len(), 2, "the two large meshes");
        assert_eq!(blobs_a, blobs_b, "the frames' meshes are the same blobs");
        assert_ne!(ma.hash, mb.hash);
        assert!(ma.data.len() < 4096, "the manifest is {} bytes", ma.data.len());
        let find = |h: &Hash| blobs_a.iter().find(|x| &x.hash == h).map(|x| x.data.clone());
        assert_eq!(decode_scene(&ma.data, find).unwrap(), scene(1.0));
        assert_eq!(decode_scene(&mb.data, find).unwrap(), scene(2.0));
        // A manifest naming a shape the scene lacks is refused.
        let (desc, mut refs) = decode_manifest(&ma.data).unwrap();
        refs[0].0 = format!("{SHAPE_KEY}7");
        let bad = postcard::to_stdvec(&(&desc, &refs)).unwrap();
        let e = decode_scene(&bad, find).unwrap_err().to_string();
        assert!(e.contains("no shape"), "{e}");
    }

    /// Each light's place among the shapes travels after the description;
    /// a manifest without it (written before it) decodes with every light
    /// first, and one whose count disagrees with the lights is refused.
    #[test]
    fn the_lights_place_among_the_shapes_travels() {
        use farm_common::scene::{Entity, LightEntity};
        let mut d = SceneDescription { name: "l".into(), ..Default::default() };
        d.shapes.push(mesh(3));
        d.shapes.push(mesh(4));
        for n in [0, 2, 1] {
            d.lights.push(LightEntity {
                entity: Entity::named("point"),
                world_from_light: Default::default(),
                medium: None,
                shapes_before: n,
            });
        }
        let (m, blobs) = encode_scene(&mut d.clone()).unwrap();
        assert!(blobs.is_empty());
        let (back, _) = decode_manifest(&m.data).unwrap();
        assert_eq!(back, d);
        let before: Vec<u32> = back.lights.iter().map(|l| l.shapes_before).collect();
        assert_eq!(before, [0, 2, 1]);
        let refs: Vec<(String, Hash)> = Vec::new();
        let old = postcard::to_stdvec(&(&d, &refs)).unwrap();
        let (back, _) = decode_manifest(&old).unwrap();
        assert!(back.lights.iter().all(|l| l.shapes_before == 0));
        let bad = postcard::to_stdvec(&(&d, &refs, vec![1u32])).unwrap();
        let e = decode_manifest(&bad).unwrap_err().to_string();
        assert!(e.contains("light positions"), "{e}");
    }
}
