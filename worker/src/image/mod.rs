//! Image maps: decoding the image files a scene ships (pbrt-v3
//! `core/imageio.cpp`) and pbrt-v3's MIP maps for filtered lookups
//! (`core/mipmap.h`).

mod io;
mod mipmap;

pub use io::{inverse_gamma_correct, read_image, Image, ImageError};
pub use mipmap::{MipMap, Texel, WrapMode};
