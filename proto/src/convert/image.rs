//! Finished images on the wire: rows of little-endian f32 RGB (and the
//! per-pixel error estimate) in chunks well below the message limit, and
//! their reassembly, each chunk checked against the image so far.

use crate::error::{Error, Result};
use crate::v1;
use bytes::Bytes;
use farm_common::film::{PassEnd, PassStop};
use farm_common::image::RgbImage;
use farm_common::le::extend_f32s;
use farm_common::stats::RayStats;

/// Bytes of pixel rows per image event.
pub const IMAGE_CHUNK_BYTES: usize = 8 << 20;

/// What travels with a finished image.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImageFacts {
    /// The job's name as submitted (empty when the coordinator sent none).
    pub name: String,
    /// Samples per pixel.
    pub spp: u32,
    /// Seconds from the first assignment to the last tile.
    pub render_seconds: f64,
    /// Rays traced.
    pub stats: RayStats,
    /// A render in passes: each pass's end.
    pub passes: Vec<PassEnd>,
    /// Why a render in passes stopped.
    pub stopped: Option<PassStop>,
    /// The render's fireflies, when its estimate is a lower bound.
    pub fireflies: Option<FireflyFacts>,
}

/// A render's fireflies and edge pixels: how many, the relMSE counting
/// their error, and the brightest (image coordinates).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FireflyFacts {
    /// How many pixels are fireflies or edge pixels.
    pub pixels: u32,
    /// The estimate counting their error.
    pub rel_mse: f64,
    /// The brightest.
    pub brightest: (u32, u32),
}

/// A pass's end on the wire.
impl From<&PassEnd> for v1::PassEnd {
    fn from(p: &PassEnd) -> Self {
        v1::PassEnd { spp: p.spp, estimated_rel_mse: p.estimate, seconds: p.seconds }
    }
}

/// A pass's end from the wire.
impl From<&v1::PassEnd> for PassEnd {
    fn from(p: &v1::PassEnd) -> Self {
        PassEnd { spp: p.spp, estimate: p.estimated_rel_mse, seconds: p.seconds }
    }
}

/// Why a render in passes stopped, as the wire names it.
pub fn stop_name(s: Option<PassStop>) -> &'static str {
    match s {
        None => "",
        Some(PassStop::TargetReached) => "target",
        Some(PassStop::TimeLimit) => "time",
        Some(PassStop::Cap) => "cap",
    }
}

/// Why a render in passes stopped, from its wire name.
pub fn stop_from_name(s: &str) -> Option<PassStop> {
    match s {
        "target" => Some(PassStop::TargetReached),
        "time" => Some(PassStop::TimeLimit),
        "cap" => Some(PassStop::Cap),
        _ => None,
    }
}

/// An image put back together, with its error estimate if one was sent.
#[derive(Clone, Debug, PartialEq)]
pub struct AssembledImage {
    /// The image.
    pub image: RgbImage,
    /// The per-pixel relMSE estimate and the image's, when the render has one.
    pub error: Option<(Vec<f32>, f64)>,
    /// What came with it.
    pub facts: ImageFacts,
}

/// `values` as the wire's little-endian bytes, kept alive by `owner`: on a
/// little-endian host the values' own memory, shared and not copied (a
/// finished 2048² image is 50 MB, and every watcher and the journal send
/// or store it); elsewhere a copy.
pub fn le_bytes<O: Send + 'static>(owner: O, values: fn(&O) -> &[f32]) -> Bytes {
    struct Shared<O> {
        owner: O,
        values: fn(&O) -> &[f32],
    }
    impl<O> AsRef<[u8]> for Shared<O> {
        fn as_ref(&self) -> &[u8] {
            bytemuck::cast_slice((self.values)(&self.owner))
        }
    }
    if cfg!(target_endian = "little") {
        Bytes::from_owner(Shared { owner, values })
    } else {
        let mut out = Vec::new();
        extend_f32s(&mut out, values(&owner));
        Bytes::from(out)
    }
}

/// The chunks of rows a `width` × `height` image travels in: `rgb` is its
/// pixels as little-endian f32 RGB, and `error` the per-pixel estimate
/// (one little-endian f32 a pixel) and the image's, if any. Each chunk's
/// rows are a slice of these, not a copy.
pub fn image_chunks(
    (w, h): (usize, usize),
    rgb: &Bytes,
    error: Option<&(Bytes, f64)>,
    facts: &ImageFacts,
) -> Vec<v1::JobImage> {
    let rows_per_chunk = (IMAGE_CHUNK_BYTES / (w * 12).max(1)).max(1);
    let rows = |bytes: &Bytes, y0: usize, y1: usize, px: usize| {
        bytes.get(y0 * w * px..y1 * w * px).map_or_else(Bytes::new, |r| bytes.slice_ref(r))
    };
    (0..h.max(1))
        .step_by(rows_per_chunk)
        .map(|y0| {
            let y1 = (y0 + rows_per_chunk).min(h);
            v1::JobImage {
                width: w as u32,
                height: h as u32,
                rgb: rows(rgb, y0, y1, 12),
                first_row: y0 as u32,
                error_map: error.map_or_else(Bytes::new, |(e, _)| rows(e, y0, y1, 4)),
                estimated_rel_mse: error.map(|(_, e)| *e),
                name: facts.name.clone(),
                spp: facts.spp,
                render_seconds: facts.render_seconds,
                stats: Some(v1::RayStats::from(&facts.stats)),
                passes: facts.passes.iter().map(v1::PassEnd::from).collect(),
                stopped: stop_name(facts.stopped).to_string(),
                fireflies: facts.fireflies.map(|f| v1::Fireflies {
                    pixels: f.pixels,
                    estimated_rel_mse: f.rel_mse,
                    x: f.brightest.0,
                    y: f.brightest.1,
                }),
            }
        })
        .collect()
}

/// [`image_chunks`] of an image and error map held elsewhere, copied once.
pub fn image_chunks_copied(
    image: &RgbImage,
    error: Option<(&[f32], f64)>,
    facts: &ImageFacts,
) -> Vec<v1::JobImage> {
    let rgb = le_bytes(image.pixels.clone(), |p| p.as_flattened());
    let error = error.map(|(e, v)| (le_bytes(e.to_vec(), |e| e.as_slice()), v));
    image_chunks((image.width, image.height), &rgb, error.as_ref(), facts)
}

/// Collects an image sent as chunks of rows.
#[derive(Default)]
pub struct ImageAssembler {
    image: Option<RgbImage>,
    error_map: Vec<f32>,
    rows: usize,
}

/// Little-endian f32s from bytes whose length is a multiple of 4.
fn f32s(bytes: &[u8]) -> impl Iterator<Item = f32> + '_ {
    bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

impl ImageAssembler {
    /// Adds a chunk; returns the image once every row is in.
    pub fn add(&mut self, img: &v1::JobImage) -> Result<Option<AssembledImage>> {
        let (w, h) = (img.width as usize, img.height as usize);
        let image = self.image.get_or_insert_with(|| RgbImage {
            width: w,
            height: h,
            pixels: vec![[0.0; 3]; w * h],
        });
        let row_bytes = w * 12;
        let rows = img.rgb.len().checked_div(row_bytes).unwrap_or(h);
        let misfit = || Error::ImageChunk {
            row: img.first_row,
            bytes: img.rgb.len(),
            width: img.width,
            height: img.height,
        };
        if image.width != w
            || image.height != h
            || img.first_row as usize != self.rows
            || (row_bytes > 0 && !img.rgb.len().is_multiple_of(row_bytes))
            || (img.estimated_rel_mse.is_some() && img.error_map.len() != rows * w * 4)
            || self.rows + rows > h
        {
            return Err(misfit());
        }
        let dst = &mut image.pixels[self.rows * w..(self.rows + rows) * w];
        for (px, bytes) in dst.iter_mut().zip(img.rgb.chunks_exact(12)) {
            let mut c = f32s(bytes);
            *px = [0; 3].map(|_| c.next().unwrap_or(0.0));
        }
        self.error_map.extend(f32s(&img.error_map));
        self.rows += rows;
        if self.rows < h {
            return Ok(None);
        }
        let Some(image) = self.image.take() else { return Ok(None) };
        let error = img.estimated_rel_mse.map(|e| (std::mem::take(&mut self.error_map), e));
        let facts = ImageFacts {
            name: img.name.clone(),
            spp: img.spp,
            render_seconds: img.render_seconds,
            stats: img.stats.as_ref().map(RayStats::from).unwrap_or_default(),
            passes: img.passes.iter().map(PassEnd::from).collect(),
            stopped: stop_from_name(&img.stopped),
            fireflies: img.fireflies.map(|f| FireflyFacts {
                pixels: f.pixels,
                rel_mse: f.estimated_rel_mse,
                brightest: (f.x, f.y),
            }),
        };
        Ok(Some(AssembledImage { image, error, facts }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: usize, h: usize) -> RgbImage {
        let pixels = (0..w * h).map(|i| [i as f32, 0.5 * i as f32, -(i as f32)]).collect();
        RgbImage { width: w, height: h, pixels }
    }

    #[test]
    fn images_round_trip_in_several_chunks_with_their_error_map() {
        // Wide enough that one chunk holds fewer rows than the image has.
        let w = IMAGE_CHUNK_BYTES / 12 / 3 + 1;
        let img = image(w, 7);
        let map: Vec<f32> = (0..w * 7).map(|i| i as f32 * 1e-3).collect();
        let facts = ImageFacts {
            name: "chunks.pbrt".into(),
            spp: 16,
            render_seconds: 1.5,
            stats: RayStats::default(),
            passes: vec![
                PassEnd { spp: 4, estimate: Some(1e-2), seconds: 0.5 },
                PassEnd { spp: 8, estimate: None, seconds: 1.5 },
            ],
            stopped: Some(PassStop::TargetReached),
            fireflies: Some(FireflyFacts { pixels: 12, rel_mse: 0.5, brightest: (3, 4) }),
        };
        let chunks = image_chunks_copied(&img, Some((&map, 2e-3)), &facts);
        assert!(chunks.len() > 1, "{} chunks", chunks.len());
        let mut a = ImageAssembler::default();
        let mut done = None;
        for (i, c) in chunks.iter().enumerate() {
            let r = a.add(c).unwrap();
            assert_eq!(r.is_some(), i + 1 == chunks.len());
            done = r;
        }
        let done = done.unwrap();
        assert_eq!(done.image, img);
        assert_eq!(done.error, Some((map, 2e-3)));
        assert_eq!(done.facts, facts);
    }

    #[test]
    fn chunks_that_do_not_continue_the_image_are_refused() {
        let img = image(4, 3);
        let chunks = image_chunks_copied(&img, None, &ImageFacts::default());
        let mut late = chunks[0].clone();
        late.first_row = 1;
        assert!(matches!(ImageAssembler::default().add(&late), Err(Error::ImageChunk { .. })));
        let mut short = chunks[0].clone();
        short.rgb.truncate(short.rgb.len() - 1);
        assert!(ImageAssembler::default().add(&short).is_err());
        let mut tall = chunks[0].clone();
        tall.height = 2;
        assert!(ImageAssembler::default().add(&tall).is_err());
        assert_eq!(ImageAssembler::default().add(&chunks[0]).unwrap().unwrap().image, img);
    }
}
