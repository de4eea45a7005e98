//! The film's pixel and sample bounds, its grid of 16×16 tiles, and film
//! tiles of weighted sums (pbrt-v3 `core/film.h`).

mod tile;
mod tiling;

pub use tile::{FilmTile, Pixel};
pub use tiling::{FilmGeometry, TILE_SIZE};
