//! Writing images: OpenEXR (32-bit float RGB with render metadata), PFM,
//! and a tone-mapped sRGB PNG preview. The format follows the file
//! extension.

use super::{ImageError, ImageMetadata, RgbImage};
use crate::math;
use std::path::Path;

fn encode_err(path: &Path, message: String) -> ImageError {
    ImageError::InFile {
        path: path.display().to_string(),
        source: Box::new(ImageError::Encode(message)),
    }
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> ImageError + '_ {
    move |source| ImageError::InFile {
        path: path.display().to_string(),
        source: Box::new(ImageError::Io(source)),
    }
}

/// Writes `img` in the format its extension names, creating parent folders.
pub fn write_image(path: &Path, img: &RgbImage, meta: &ImageMetadata) -> Result<(), ImageError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if !matches!(ext.as_str(), "exr" | "pfm" | "png") {
        return Err(ImageError::UnsupportedFormat(path.display().to_string()));
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io_err(path))?;
    }
    match ext.as_str() {
        "exr" => write_exr(path, img, meta),
        "pfm" => write_pfm(path, img),
        _ => write_png(path, img),
    }
}

fn write_exr(path: &Path, img: &RgbImage, meta: &ImageMetadata) -> Result<(), ImageError> {
    use exr::meta::attribute::{AttributeValue, Text};
    use exr::prelude::*;
    let mut attrs = LayerAttributes {
        software_name: Some(Text::from(concat!("farm ", env!("CARGO_PKG_VERSION")))),
        ..Default::default()
    };
    attrs.other.insert(Text::from("spp"), AttributeValue::I32(meta.spp as i32));
    attrs.other.insert(Text::from("renderTimeSeconds"), AttributeValue::F32(meta.render_seconds));
    if let Some(e) = meta.rel_mse_estimate {
        attrs.other.insert(Text::from("relMSEEstimate"), AttributeValue::F32(e));
    }
    // The name's UTF-8 bytes, as C++ OpenEXR keeps a std::string: any name
    // a client gave its job, where the crate's own conversion takes
    // Latin-1 only (and panics on the rest).
    let scene = Text::from_slice_unchecked(meta.scene.as_bytes());
    attrs.other.insert(Text::from("sceneName"), AttributeValue::Text(scene));
    let w = img.width;
    let layer = Layer::new(
        (img.width, img.height),
        attrs,
        Encoding::SMALL_LOSSLESS,
        SpecificChannels::rgb(|p: Vec2<usize>| {
            let [r, g, b] = img.pixels[p.y() * w + p.x()];
            (r, g, b)
        }),
    );
    Image::from_layer(layer).write().to_file(path).map_err(|e| encode_err(path, e.to_string()))
}

fn write_pfm(path: &Path, img: &RgbImage) -> Result<(), ImageError> {
    // PFM stores rows bottom to top; a negative scale means little-endian.
    let mut out = format!("PF\n{} {}\n-1.0\n", img.width, img.height).into_bytes();
    for y in (0..img.height).rev() {
        for p in &img.pixels[y * img.width..(y + 1) * img.width] {
            for c in p {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    std::fs::write(path, out).map_err(io_err(path))
}

/// sRGB encoding of a linear value clamped to [0, 1].
fn srgb8(v: f32) -> u8 {
    let v = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 };
    let s = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * math::powf(v, 1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

fn write_png(path: &Path, img: &RgbImage) -> Result<(), ImageError> {
    let file = std::fs::File::create(path).map_err(io_err(path))?;
    let png_err = |e: png::EncodingError| encode_err(path, e.to_string());
    let mut enc =
        png::Encoder::new(std::io::BufWriter::new(file), img.width as u32, img.height as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().map_err(png_err)?;
    let data: Vec<u8> = img.pixels.iter().flat_map(|p| p.map(srgb8)).collect();
    writer.write_image_data(&data).map_err(png_err)?;
    writer.finish().map_err(png_err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A job may carry any name its client gave it: an EXR keeps its UTF-8
    /// bytes (the crate's own text conversion took Latin-1 only and
    /// panicked on the rest), and the pixels round-trip.
    #[test]
    fn an_exr_keeps_any_scene_name_as_utf8() {
        let tmp = tempfile::Builder::new().prefix("farm-exr-name-").tempdir().unwrap();
        let img = RgbImage { width: 2, height: 1, pixels: vec![[1.0, 0.5, 0.25], [0.0, 2.0, 4.0]] };
        for name in ["scene.pbrt", "café.pbrt", "シーン 🎬.pbrt"] {
            let path = tmp.path().join("a.exr");
            let meta = ImageMetadata { scene: name.into(), ..Default::default() };
            write_image(&path, &img, &meta).unwrap();
            let header = exr::meta::MetaData::read_from_file(&path, false).unwrap();
            let key = exr::meta::attribute::Text::from("sceneName");
            let Some(exr::meta::attribute::AttributeValue::Text(t)) =
                header.headers[0].own_attributes.other.get(&key)
            else {
                panic!("no sceneName")
            };
            assert_eq!(t.as_slice(), name.as_bytes());
            assert_eq!(crate::image::read_file(&path).unwrap(), img);
        }
    }
}
