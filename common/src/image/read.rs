//! Image decoding, as pbrt-v3's `ReadImage` returns images: RGB floats with
//! the top row first. 8-bit formats (PNG, TGA) give code values divided by
//! 255; the image texture applies the sRGB curve when its `gamma` parameter
//! says so. PNG goes through the `png` crate, EXR through `exr`, and TGA and
//! PFM are decoded here.

use super::{ImageError, RgbImage};
use std::io::Cursor;
use std::path::Path;

type Px = [f32; 3];
const ZERO: Px = [0.0; 3];

fn splat(v: f32) -> Px {
    [v; 3]
}

fn rgb(r: f32, g: f32, b: f32) -> Px {
    [r, g, b]
}

/// Reads the image file at `path`, in the format its extension names.
pub fn read_file(path: &Path) -> Result<RgbImage, ImageError> {
    let in_file = |e: ImageError| ImageError::InFile {
        path: path.display().to_string(),
        source: Box::new(e),
    };
    let bytes = std::fs::read(path).map_err(|e| in_file(ImageError::Io(e)))?;
    read_image(&bytes, &path.to_string_lossy()).map_err(in_file)
}

/// Decodes `bytes` according to `file_name`'s extension (`.exr`, `.tga`,
/// `.png`, `.pfm`, case-insensitive as pbrt-v3's `HasExtension`).
pub fn read_image(bytes: &[u8], file_name: &str) -> Result<RgbImage, ImageError> {
    let ext = file_name.rsplit_once('.').map(|(_, e)| e.to_ascii_lowercase()).unwrap_or_default();
    match ext.as_str() {
        "exr" => read_exr(bytes),
        "tga" => read_tga(bytes),
        "png" => read_png(bytes),
        "pfm" => read_pfm(bytes),
        _ => Err(ImageError::UnknownFormat(if ext.is_empty() { "(unknown)".into() } else { ext })),
    }
}

/// The most pixels an image a scene names may have (256 M: 3 GiB of RGB).
const MAX_IMAGE_PIXELS: usize = 1 << 28;

/// Refuses a header whose size could make the reader allocate more than
/// its bytes can hold: at most `ratio` pixels per input byte (the format's
/// best compression), and [`MAX_IMAGE_PIXELS`] in all. Checked before
/// anything is allocated for the pixels.
fn check_size(w: usize, h: usize, len: usize, ratio: usize) -> Result<(), ImageError> {
    let fits = |px: usize| px <= MAX_IMAGE_PIXELS && px <= len.saturating_mul(ratio) + 64;
    match w.checked_mul(h) {
        Some(px) if fits(px) => Ok(()),
        _ => Err(ImageError::Malformed(format!(
            "the header says {w}×{h} pixels, more than its {len} bytes can hold or over {MAX_IMAGE_PIXELS} pixels"
        ))),
    }
}

fn malformed(msg: &str) -> ImageError {
    ImageError::Malformed(msg.to_string())
}

/// PNG as lodepng's 24-bit decode gives it: palette and grey expanded,
/// 16-bit samples reduced to their high byte, alpha dropped.
fn read_png(bytes: &[u8]) -> Result<RgbImage, ImageError> {
    let mut decoder = png::Decoder::new(Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info()?;
    // Deflate packs at most 1032 bytes into one; a pixel takes at least 1 bit.
    check_size(reader.info().width as usize, reader.info().height as usize, bytes.len(), 8300)?;
    let size = reader.output_buffer_size().ok_or_else(|| malformed("PNG too large"))?;
    let mut buf = vec![0u8; size];
    let info = reader.next_frame(&mut buf)?;
    let (w, h) = (info.width as usize, info.height as usize);
    let channels = info.color_type.samples();
    let bytes_per_sample = if info.bit_depth == png::BitDepth::Sixteen { 2 } else { 1 };
    let stride = info.line_size;
    let mut pixels = Vec::with_capacity(w * h);
    for y in 0..h {
        let row = &buf[y * stride..];
        for x in 0..w {
            // High byte of each sample (big-endian for 16-bit PNG).
            let s = |c: usize| row[(x * channels + c) * bytes_per_sample] as f32 / 255.0;
            let px = match channels {
                1 | 2 => splat(s(0)),
                _ => rgb(s(0), s(1), s(2)),
            };
            pixels.push(px);
        }
    }
    Ok(RgbImage { width: w, height: h, pixels })
}

/// The first RGB(A) layer of an EXR, or its luminance channel `Y`.
fn read_exr(bytes: &[u8]) -> Result<RgbImage, ImageError> {
    use exr::prelude::{read, ReadChannels, ReadLayers, ReadSpecificChannel};
    // The pixel buffers below are allocated from the header's size.
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| ImageError::Malformed(format!("EXR header: {e}")))?;
    for h in &meta.headers {
        check_size(h.layer_size.width(), h.layer_size.height(), bytes.len(), 8300)?;
    }
    type Buf = (Vec<Px>, usize);
    let rgb = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |res, _| -> Buf { (vec![ZERO; res.width() * res.height()], res.width()) },
            |p: &mut Buf, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                p.0[pos.y() * p.1 + pos.x()] = rgb(r, g, b);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes));
    let (pixels, size) = match rgb {
        Ok(img) => (img.layer_data.channel_data.pixels.0, img.layer_data.size),
        Err(e) => {
            let y = read()
                .no_deep_data()
                .largest_resolution_level()
                .specific_channels()
                .required("Y")
                .collect_pixels(
                    |res, _| -> Buf { (vec![ZERO; res.width() * res.height()], res.width()) },
                    |p: &mut Buf, pos, (y,): (f32,)| {
                        p.0[pos.y() * p.1 + pos.x()] = splat(y);
                    },
                )
                .first_valid_layer()
                .all_attributes()
                .from_buffered(Cursor::new(bytes))
                .map_err(|_| e)?;
            (y.layer_data.channel_data.pixels.0, y.layer_data.size)
        }
    };
    Ok(RgbImage { width: size.width(), height: size.height(), pixels })
}

/// Uncompressed or RLE TGA: true-colour (15/16/24/32-bit), grey, or
/// colour-mapped, reoriented to top-to-bottom, left-to-right.
fn read_tga(bytes: &[u8]) -> Result<RgbImage, ImageError> {
    if bytes.len() < 18 {
        return Err(malformed("TGA header truncated"));
    }
    let u16le = |i: usize| u16::from_le_bytes([bytes[i], bytes[i + 1]]) as usize;
    let id_len = bytes[0] as usize;
    let cmap_type = bytes[1];
    let image_type = bytes[2];
    let (cmap_first, cmap_len, cmap_depth) = (u16le(3), u16le(5), bytes[7] as usize);
    let (w, h) = (u16le(12), u16le(14));
    let depth = bytes[16] as usize;
    let desc = bytes[17];
    let rle = image_type >= 9;
    let base = image_type & 7;
    if !matches!(base, 1..=3) {
        return Err(malformed("unsupported TGA image type"));
    }
    let bpp = depth.div_ceil(8);
    if bpp == 0 || bpp > 4 {
        return Err(malformed("unsupported TGA pixel depth"));
    }
    // A run-length packet of 1 + bpp bytes repeats a pixel up to 128 times.
    check_size(w, h, bytes.len(), if rle { 128 } else { 1 })?;
    let mut pos = 18 + id_len;
    // Colour map.
    let cmap_bpp = cmap_depth.div_ceil(8);
    let mut cmap: Vec<Px> = Vec::new();
    if cmap_type == 1 {
        let n = cmap_len * cmap_bpp;
        let data = bytes.get(pos..pos + n).ok_or_else(|| malformed("TGA colour map truncated"))?;
        cmap = data.chunks_exact(cmap_bpp.max(1)).map(|p| tga_colour(p, cmap_depth)).collect();
        pos += n;
    }
    if base == 1 && cmap.is_empty() {
        return Err(malformed("TGA colour-mapped image without a colour map"));
    }
    // Raw pixel bytes, decompressed.
    let count = w * h;
    let mut raw = Vec::with_capacity(count * bpp);
    if rle {
        while raw.len() < count * bpp {
            let hdr = *bytes.get(pos).ok_or_else(|| malformed("TGA RLE data truncated"))?;
            pos += 1;
            let n = (hdr & 0x7f) as usize + 1;
            if hdr & 0x80 != 0 {
                let px =
                    bytes.get(pos..pos + bpp).ok_or_else(|| malformed("TGA RLE data truncated"))?;
                for _ in 0..n {
                    raw.extend_from_slice(px);
                }
                pos += bpp;
            } else {
                let px = bytes
                    .get(pos..pos + n * bpp)
                    .ok_or_else(|| malformed("TGA RLE data truncated"))?;
                raw.extend_from_slice(px);
                pos += n * bpp;
            }
        }
        raw.truncate(count * bpp);
    } else {
        raw.extend_from_slice(
            bytes
                .get(pos..pos + count * bpp)
                .ok_or_else(|| malformed("TGA pixel data truncated"))?,
        );
    }
    let right_to_left = desc & 0x10 != 0;
    let top_to_bottom = desc & 0x20 != 0;
    let mut pixels = vec![ZERO; count];
    for (i, p) in raw.chunks_exact(bpp).enumerate() {
        let (fx, fy) = (i % w.max(1), i / w.max(1));
        let x = if right_to_left { w - 1 - fx } else { fx };
        let y = if top_to_bottom { fy } else { h - 1 - fy };
        pixels[y * w + x] = match base {
            1 => {
                let idx = if bpp == 1 {
                    p[0] as usize
                } else {
                    u16::from_le_bytes([p[0], p[1]]) as usize
                };
                *cmap.get(idx.wrapping_sub(cmap_first)).unwrap_or(&ZERO)
            }
            3 => splat(p[0] as f32 / 255.0),
            _ => tga_colour(p, depth),
        };
    }
    Ok(RgbImage { width: w, height: h, pixels })
}

/// One BGR(A) or 15/16-bit TGA colour.
fn tga_colour(p: &[u8], depth: usize) -> Px {
    if p.len() >= 3 {
        rgb(p[2] as f32 / 255.0, p[1] as f32 / 255.0, p[0] as f32 / 255.0)
    } else if p.len() == 2 && depth >= 15 {
        let v = u16::from_le_bytes([p[0], p[1]]);
        let c = |s: u16| (((v >> s) & 31) as f32 * 255.0 / 31.0).round() / 255.0;
        rgb(c(10), c(5), c(0))
    } else {
        splat(p.first().copied().unwrap_or(0) as f32 / 255.0)
    }
}

/// PFM ("PF" colour or "Pf" grey); rows are stored bottom to top.
fn read_pfm(bytes: &[u8]) -> Result<RgbImage, ImageError> {
    let mut pos = 0;
    let mut word = || -> Result<String, ImageError> {
        let start = pos.min(bytes.len());
        pos = start;
        while pos < bytes.len() && !matches!(bytes[pos], b' ' | b'\n' | b'\t') {
            pos += 1;
        }
        let w = String::from_utf8_lossy(&bytes[start..pos]).into_owned();
        pos += 1; // the terminating whitespace
        if w.is_empty() && pos > bytes.len() {
            return Err(malformed("PFM header truncated"));
        }
        Ok(w)
    };
    let channels = match word()?.as_str() {
        "Pf" => 1,
        "PF" => 3,
        _ => return Err(malformed("not a PFM file")),
    };
    let w: usize = word()?.trim().parse().map_err(|_| malformed("bad PFM width"))?;
    let h: usize = word()?.trim().parse().map_err(|_| malformed("bad PFM height"))?;
    let scale: f32 = word()?.trim().parse().map_err(|_| malformed("bad PFM scale"))?;
    let n = w.checked_mul(h).and_then(|p| p.checked_mul(channels));
    let end = n.and_then(|n| n.checked_mul(4)).and_then(|b| b.checked_add(pos));
    let data = end
        .and_then(|end| bytes.get(pos..end))
        .ok_or_else(|| malformed("PFM data truncated (or its size overflows)"))?;
    let little = scale < 0.0;
    let abs_scale = scale.abs();
    let vals: Vec<f32> = data
        .chunks_exact(4)
        .map(|b| {
            let b = [b[0], b[1], b[2], b[3]];
            let v = if little { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) };
            if abs_scale != 1.0 {
                v * abs_scale
            } else {
                v
            }
        })
        .collect();
    let mut pixels = vec![ZERO; w * h];
    for (file_row, row) in vals.chunks_exact((channels * w).max(1)).enumerate().take(h) {
        let y = h - 1 - file_row;
        for x in 0..w {
            pixels[y * w + x] = if channels == 1 {
                splat(row[x])
            } else {
                rgb(row[3 * x], row[3 * x + 1], row[3 * x + 2])
            };
        }
    }
    Ok(RgbImage { width: w, height: h, pixels })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_round_trips_8_and_16_bit_grey_and_palette() {
        let encode = |w: u32,
                      h: u32,
                      ct: png::ColorType,
                      bd: png::BitDepth,
                      data: &[u8],
                      pal: Option<Vec<u8>>| {
            let mut out = Vec::new();
            {
                let mut e = png::Encoder::new(&mut out, w, h);
                e.set_color(ct);
                e.set_depth(bd);
                if let Some(p) = pal {
                    e.set_palette(p);
                }
                let mut wr = e.write_header().unwrap();
                wr.write_image_data(data).unwrap();
            }
            out
        };
        let rgb8 = encode(
            2,
            1,
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            &[255, 0, 51, 0, 102, 255],
            None,
        );
        let img = read_image(&rgb8, "a.PNG").unwrap();
        assert_eq!((img.width, img.height), (2, 1));
        assert_eq!(img.pixels[0], rgb(1.0, 0.0, 0.2));
        assert_eq!(img.pixels[1], rgb(0.0, 0.4, 1.0));
        let rgba16 = encode(
            1,
            1,
            png::ColorType::Rgba,
            png::BitDepth::Sixteen,
            &[0x80, 0xff, 0, 0, 0xff, 0, 0, 0],
            None,
        );
        assert_eq!(read_image(&rgba16, "b.png").unwrap().pixels[0], rgb(128.0 / 255.0, 0.0, 1.0));
        let grey = encode(1, 2, png::ColorType::Grayscale, png::BitDepth::Eight, &[51, 255], None);
        let g = read_image(&grey, "g.png").unwrap();
        assert_eq!(g.pixels, vec![splat(0.2), [1.0; 3]]);
        let pal = encode(
            2,
            1,
            png::ColorType::Indexed,
            png::BitDepth::Eight,
            &[1, 0],
            Some(vec![0, 0, 255, 255, 0, 0]),
        );
        let p = read_image(&pal, "p.png").unwrap();
        assert_eq!(p.pixels, vec![rgb(1.0, 0.0, 0.0), rgb(0.0, 0.0, 1.0)]);
        assert!(read_image(&rgb8[..20], "t.png").is_err());
    }

    #[test]
    fn exr_round_trips() {
        use exr::prelude::*;
        let px = [[0.5f32, 2.0, 0.25], [1.0, 0.0, 8.0], [3.0, 0.125, 1.5]];
        let img = exr::image::Image::from_channels(
            (3, 1),
            SpecificChannels::rgb(|p: Vec2<usize>| (px[p.x()][0], px[p.x()][1], px[p.x()][2])),
        );
        let mut bytes = Cursor::new(Vec::new());
        img.write().to_buffered(&mut bytes).unwrap();
        let back = read_image(bytes.get_ref(), "x.exr").unwrap();
        assert_eq!((back.width, back.height), (3, 1));
        assert_eq!(back.pixels[1], rgb(1.0, 0.0, 8.0));
        assert!(read_image(&bytes.get_ref()[..30], "x.exr").is_err());
    }

    fn tga_header(image_type: u8, w: u16, h: u16, depth: u8, desc: u8) -> Vec<u8> {
        let mut v = vec![0u8, 0, image_type, 0, 0, 0, 0, 0, 0, 0, 0, 0];
        v.extend_from_slice(&w.to_le_bytes());
        v.extend_from_slice(&h.to_le_bytes());
        v.extend_from_slice(&[depth, desc]);
        v
    }

    #[test]
    fn tga_uncompressed_rle_and_grey() {
        // 2×2 bottom-up BGR: bottom row red, green; top row blue, white.
        let mut t = tga_header(2, 2, 2, 24, 0);
        t.extend_from_slice(&[0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255]);
        let img = read_image(&t, "c.tga").unwrap();
        assert_eq!(img.pixels[0], rgb(0.0, 0.0, 1.0));
        assert_eq!(img.pixels[3], rgb(0.0, 1.0, 0.0));
        assert_eq!(img.pixels[2], rgb(1.0, 0.0, 0.0));
        // RLE, top-down, 32-bit: a run of three reds then one raw green.
        let mut r = tga_header(10, 2, 2, 32, 0x20);
        r.extend_from_slice(&[0x82, 0, 0, 255, 255, 0x00, 0, 255, 0, 255]);
        let img = read_image(&r, "r.tga").unwrap();
        assert_eq!(img.pixels[..3], [rgb(1.0, 0.0, 0.0); 3]);
        assert_eq!(img.pixels[3], rgb(0.0, 1.0, 0.0));
        let mut g = tga_header(3, 1, 1, 8, 0);
        g.push(51);
        assert_eq!(read_image(&g, "g.tga").unwrap().pixels[0], splat(0.2));
        assert!(read_image(&r[..22], "r.tga").is_err());
    }

    #[test]
    fn pfm_both_endiannesses_and_flip() {
        let mut le = b"PF\n1 2\n-1.0\n".to_vec();
        for v in [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0] {
            le.extend_from_slice(&v.to_le_bytes());
        }
        let img = read_image(&le, "a.pfm").unwrap();
        // The file's first row is the bottom one.
        assert_eq!(img.pixels[1], rgb(1.0, 2.0, 3.0));
        assert_eq!(img.pixels[0], rgb(4.0, 5.0, 6.0));
        let mut be = b"Pf 1 1 2.0\n".to_vec();
        be.extend_from_slice(&1.5f32.to_be_bytes());
        assert_eq!(read_image(&be, "b.pfm").unwrap().pixels[0], splat(3.0));
        assert!(read_image(&be[..12], "b.pfm").is_err());
        assert!(matches!(read_image(&be, "b.jpg"), Err(ImageError::UnknownFormat(_))));
    }

    #[test]
    fn headers_claiming_more_pixels_than_their_bytes_are_refused_before_allocating() {
        // A 65535×65535 TGA (51 GB as RGB f32) with six bytes of pixels.
        let mut tga = vec![0u8, 0, 10, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0xff, 24, 0];
        tga.extend([0x81, 1, 2, 3, 0x81, 4, 5, 6]);
        let e = read_image(&tga, "x.tga").unwrap_err().to_string();
        assert!(e.contains("65535×65535"), "{e}");
        let e = read_pfm(b"PF\n99999999999 99999999999\n-1\n").unwrap_err().to_string();
        assert!(e.contains("truncated"), "{e}");
        assert!(read_pfm(b"PF").is_err());
    }
}
