//! The farm's one image type, its readers and writers, and the error
//! metrics between two images. Renders, references, textures and
//! environment maps all pass through [`RgbImage`].

mod metrics;
mod read;
mod write;

pub use metrics::{compare, ImageDiff};
pub use read::{read_file, read_image};
pub use write::write_image;

/// A linear RGB image, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width × height` pixels (8-bit formats as code values / 255).
    pub pixels: Vec<[f32; 3]>,
}

/// A piece of a larger image, as a live display is sent it.
#[derive(Clone, Debug, PartialEq)]
pub struct ImagePiece {
    /// Where it is in the image (the image's top-left pixel at 0, 0).
    pub bounds: crate::geometry::Bounds2i,
    /// Its pixels, row-major.
    pub image: RgbImage,
    /// The render's per-pixel estimate of its own relMSE over it, where
    /// the render has one yet.
    pub error: Option<Vec<f32>>,
}

/// Facts about a render stored with the image where the format allows.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImageMetadata {
    /// The scene's name (an EXR's `sceneName`, as its UTF-8 bytes).
    pub scene: String,
    /// Samples per pixel.
    pub spp: u32,
    /// Wall-clock seconds spent rendering.
    pub render_seconds: f32,
    /// The render's estimate of its own relMSE, if it has one.
    pub rel_mse_estimate: Option<f32>,
}

/// Why an image could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The extension names no format pbrt-v3 reads.
    #[error("unable to load image stored in format \"{0}\"")]
    UnknownFormat(String),
    /// The extension names no format we write.
    #[error("{0}: unsupported image format (use .exr, .pfm or .png)")]
    UnsupportedFormat(String),
    /// A PNG decoding error.
    #[error("PNG: {0}")]
    Png(#[from] png::DecodingError),
    /// An EXR decoding error.
    #[error("EXR: {0}")]
    Exr(#[from] exr::error::Error),
    /// Malformed TGA or PFM data.
    #[error("{0}")]
    Malformed(String),
    /// Encoding an EXR or PNG failed.
    #[error("{0}")]
    Encode(String),
    /// The file system failed.
    #[error("{0}")]
    Io(std::io::Error),
    /// Any of the above, in a named file.
    #[error("{path}: {source}")]
    InFile {
        /// The file.
        path: String,
        /// What went wrong.
        source: Box<ImageError>,
    },
}
