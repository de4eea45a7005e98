//! Image reconstruction filters (pbrt-v3 `core/filter.h` and `filters/`):
//!
//! ```text
//! PixelFilter "gaussian" "float xwidth" [2] "float ywidth" [2] "float alpha" [2]
//! ```
//!
//! The film weights each sample by [`Filter::evaluate`] at its offset from
//! the pixel centre, for offsets within [`Filter::radius`].

mod r#box;
mod create;
mod gaussian;
mod mitchell;
mod sinc;
mod triangle;

pub use create::create;
pub use gaussian::GaussianFilter;
pub use mitchell::MitchellFilter;
pub use r#box::BoxFilter;
pub use sinc::LanczosSincFilter;
pub use triangle::TriangleFilter;

use farm_common::geometry::Vec2;

/// One of pbrt-v3's filters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    /// `"box"`
    Box(BoxFilter),
    /// `"gaussian"`
    Gaussian(GaussianFilter),
    /// `"mitchell"`
    Mitchell(MitchellFilter),
    /// `"sinc"`
    LanczosSinc(LanczosSincFilter),
    /// `"triangle"`
    Triangle(TriangleFilter),
}

impl Filter {
    /// Half-widths of the filter's support in x and y.
    pub fn radius(&self) -> Vec2 {
        match self {
            Filter::Box(f) => f.radius,
            Filter::Gaussian(f) => f.radius,
            Filter::Mitchell(f) => f.radius,
            Filter::LanczosSinc(f) => f.radius,
            Filter::Triangle(f) => f.radius,
        }
    }

    /// The filter's weight at offset `p` from the pixel centre (inside the radius).
    #[inline]
    pub fn evaluate(&self, p: Vec2) -> f32 {
        match self {
            Filter::Box(f) => f.evaluate(p),
            Filter::Gaussian(f) => f.evaluate(p),
            Filter::Mitchell(f) => f.evaluate(p),
            Filter::LanczosSinc(f) => f.evaluate(p),
            Filter::Triangle(f) => f.evaluate(p),
        }
    }
}
