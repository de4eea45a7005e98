//! The film's pixel and sample bounds, its grid of 16×16 tiles, and film
//! tiles of weighted sums (pbrt-v3 `core/film.h`).

mod layout;
mod passes;
mod tile;
mod tiling;

pub use layout::{
    checked_layout, default_filter_radius, filter_radius, is_power_of_2, layout, round_up_pow2,
    sample_count, stratified_grid, FilmError, FilmLayout, Halves, Limits, SamplerKind,
    MAX_MIN_DIST_MAX_SPP,
};
pub use passes::{
    sum_order_bound, PassEnd, PassPlan, PassStop, SampleRange, DEFAULT_PASS_CAP, FIRST_PASS_SPP,
};
pub use tile::{resolve, FilmTile, Pixel};
pub use tiling::{FilmGeometry, HalfImages, TILE_PARTS, TILE_SIZE};
