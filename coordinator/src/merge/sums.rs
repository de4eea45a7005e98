//! The whole film's sums, kept as two planes: each pixel's Σw·r, Σw·g,
//! Σw·b, Σw side by side with its neighbours', and the second half's sums
//! apart. The image and every watcher read the first plane only, so a row
//! of it goes out as one copy of its bytes; the error estimate reads both.

use farm_common::film::{FilmTile, Pixel};
use farm_common::geometry::{Bounds2i, Point2i};

/// The film's sums over its cropped pixel bounds.
#[derive(Debug)]
pub(super) struct Sums {
    pub bounds: Bounds2i,
    /// Row-major over `bounds`: Σw·r, Σw·g, Σw·b, Σw.
    pub value: Vec<[f32; 4]>,
    /// The same sums over the second half of each pixel's samples.
    pub second: Vec<[f32; 4]>,
}

/// `n` zero sums, their pages mapped writable before the first tile.
/// Left to the allocator's zero pages, the first tile merged into a page
/// (a read, then a write) takes a second fault that copies it and flushes
/// every core's TLB for it: 15–20% of a coordinator's CPU on a 2048² film.
/// Writing the zeros takes one fault a page (8% of it); asking the kernel
/// to map them all in one call (`MADV_POPULATE_WRITE`, Linux 5.14) takes
/// none. Where it cannot, the zeros are written.
fn mapped_zeros(n: usize) -> Vec<[f32; 4]> {
    let mut v = vec![[0.0f32; 4]; n];
    if !crate::pages::populate(&mut v) {
        v.fill([0.0; 4]);
    }
    v
}

/// The sums' floats one after another, in the same allocation.
fn flat_floats(v: Vec<[f32; 4]>) -> Vec<f32> {
    let mut v = std::mem::ManuallyDrop::new(v);
    let (ptr, len, cap) = (v.as_mut_ptr().cast::<f32>(), v.len() * 4, v.capacity() * 4);
    // SAFETY: `[f32; 4]` is four `f32`s with no padding and the same
    // alignment, so the block holds `cap` floats: the same layout the
    // allocator was given (size 16·capacity, alignment 4), which the new
    // vector hands back when it frees it. `v` is never used again.
    unsafe { Vec::from_raw_parts(ptr, len, cap) }
}

/// `v`'s floats as RGB triples, in the same allocation where its capacity
/// allows (a multiple of three), else copied.
fn triples(v: Vec<f32>) -> Vec<[f32; 3]> {
    if !v.len().is_multiple_of(3) || !v.capacity().is_multiple_of(3) {
        return v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    }
    let mut v = std::mem::ManuallyDrop::new(v);
    let (ptr, len, cap) = (v.as_mut_ptr().cast::<[f32; 3]>(), v.len() / 3, v.capacity() / 3);
    // SAFETY: as in `flat_floats`: `[f32; 3]` is three `f32`s with no
    // padding and the same alignment, and `cap` triples are the block's
    // size exactly, so the layout is the one it was allocated (or
    // reallocated) with.
    unsafe { Vec::from_raw_parts(ptr, len, cap) }
}

/// A pixel's eight sums as its two planes' four.
#[inline]
fn split(p: [f32; 8]) -> [[f32; 4]; 2] {
    [[p[0], p[1], p[2], p[3]], [p[4], p[5], p[6], p[7]]]
}

impl Sums {
    /// Zero sums over `bounds`.
    pub fn new(bounds: Bounds2i) -> Self {
        let n = bounds.area();
        Sums { bounds, value: mapped_zeros(n), second: mapped_zeros(n) }
    }

    /// Pixel `i` (row-major) with all its sums.
    #[inline]
    pub fn pixel(&self, i: usize) -> Pixel {
        let (v, s) = (self.value[i], self.second[i]);
        Pixel {
            contrib: [v[0], v[1], v[2]],
            weight: v[3],
            second_contrib: [s[0], s[1], s[2]],
            second_weight: s[3],
        }
    }

    /// The index of pixel `p` (which must lie in the bounds).
    #[inline]
    pub fn offset(&self, p: Point2i) -> usize {
        self.bounds.offset(p)
    }

    /// Adds a tile's sums where it overlaps: each sum gets the one
    /// addition [`FilmTile::merge`] gives it, so the bits are the same.
    pub fn merge(&mut self, t: &FilmTile) {
        let o = self.bounds.intersect(&t.pixel_bounds);
        if o.is_empty() {
            return;
        }
        let n = o.width() as usize;
        // The tile's rows lie a film row apart, in lines no cache holds
        // yet: ask for all of them first, so their misses overlap rather
        // than follow one another row by row.
        for y in o.min.y..o.max.y {
            let d = self.bounds.offset(Point2i::new(o.min.x, y));
            farm_common::prefetch(&self.value[d..d + n]);
            farm_common::prefetch(&self.second[d..d + n]);
        }
        for y in o.min.y..o.max.y {
            let row = Point2i::new(o.min.x, y);
            let (s, d) = (t.pixel_bounds.offset(row), self.bounds.offset(row));
            let src = &t.pixels[s..s + n];
            let value = &mut self.value[d..d + n];
            let second = &mut self.second[d..d + n];
            for ((v, h), p) in value.iter_mut().zip(second.iter_mut()).zip(src) {
                // The same four additions a plane, written lane-wise so
                // they are one vector addition.
                let [a, b] = split(p.to_array());
                (0..4).for_each(|c| v[c] += a[c]);
                (0..4).for_each(|c| h[c] += b[c]);
            }
        }
    }

    /// The finished image's pixels, `f(Σw·rgb, Σw)` for each, written
    /// over the first plane's own memory once the second is freed, so a
    /// film that is done with never holds its sums and its image at once
    /// (16 and 12 bytes a pixel).
    pub fn into_pixels(mut self, f: impl Fn([f32; 3], f32) -> [f32; 3]) -> Vec<[f32; 3]> {
        self.second = Vec::new();
        let n = self.value.len();
        let mut flat = flat_floats(std::mem::take(&mut self.value));
        // Pixel i's three floats go to 3i..3i + 3, below its own sums at
        // 4i..4i + 4 and those of every pixel after it: nothing is
        // overwritten before it is read.
        for i in 0..n {
            let s = 4 * i;
            let rgb = f([flat[s], flat[s + 1], flat[s + 2]], flat[s + 3]);
            flat[3 * i..3 * i + 3].copy_from_slice(&rgb);
        }
        flat.truncate(3 * n);
        // The allocator shortens the block where it lies and gives its
        // last quarter back.
        flat.shrink_to_fit();
        triples(flat)
    }

    /// Adds these sums to `part` where the two overlap, as merging a tile
    /// of them into it would (through a copy of the overlap: for display).
    pub fn add_into(&self, part: &mut FilmTile) {
        let o = self.bounds.intersect(&part.pixel_bounds);
        if o.is_empty() {
            return;
        }
        let pixels = o.iter().map(|p| self.pixel(self.offset(p))).collect();
        part.merge(&FilmTile { pixel_bounds: o, pixels });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::Spectrum;

    fn tile(x0: i32, y0: i32, x1: i32, y1: i32, k: f32) -> FilmTile {
        let mut t = FilmTile::new(Bounds2i::new(Point2i::new(x0, y0), Point2i::new(x1, y1)));
        for p in t.pixel_bounds.iter() {
            let v = 0.1 + (p.x * 7 + p.y * 3) as f32 * 1e-3 * k;
            t.add(p, Spectrum::new(v, v / 3.0, 0.7), 0.3 + v, (p.x + p.y) % 2 == 0);
        }
        t
    }

    #[test]
    fn two_planes_hold_the_bits_one_tile_would() {
        let bounds = Bounds2i::new(Point2i::new(2, 1), Point2i::new(30, 20));
        let tiles = [tile(0, 0, 18, 12, 1.0), tile(14, -3, 40, 7, 2.9), tile(10, 5, 25, 22, 0.4)];
        let mut planes = Sums::new(bounds);
        let mut whole = FilmTile::new(bounds);
        for t in &tiles {
            planes.merge(t);
            whole.merge(t);
        }
        let bits = |p: Pixel| p.to_array().map(f32::to_bits);
        for (i, p) in whole.pixels.iter().enumerate() {
            assert_eq!(bits(planes.pixel(i)), bits(*p), "pixel {i}");
        }
        // Added into a part that reaches past the film, as a tile would be.
        let reach = Bounds2i::new(Point2i::new(20, 15), Point2i::new(35, 25));
        let (mut a, mut b) = (tile(20, 15, 35, 25, 0.7), tile(20, 15, 35, 25, 0.7));
        planes.add_into(&mut a);
        b.merge(&whole);
        assert_eq!(a.pixel_bounds, reach);
        assert_eq!(a, b);
    }

    /// The image is each pixel's first-plane sums resolved, as a copy
    /// would be, and it is written in the sums' own block: under a page,
    /// and large enough for pages of its own (which shrink in place).
    #[test]
    fn the_image_takes_the_sums_place() {
        for (w, h) in [(7, 5), (1, 1), (900, 700)] {
            let bounds = Bounds2i::new(Point2i::new(-3, 2), Point2i::new(w - 3, h + 2));
            let mut planes = Sums::new(bounds);
            planes.merge(&tile(-10, 0, w + 5, h + 9, 1.3));
            let want: Vec<[f32; 3]> = (0..planes.value.len())
                .map(|i| {
                    let p = planes.pixel(i);
                    farm_common::film::resolve(p.contrib, p.weight, 0.75)
                })
                .collect();
            let block = planes.value.as_ptr() as usize;
            let got = planes.into_pixels(|rgb, w| farm_common::film::resolve(rgb, w, 0.75));
            assert_eq!(got.as_ptr() as usize, block, "{w}×{h}: the image was copied");
            let bits = |v: &[[f32; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got), bits(&want), "{w}×{h}");
            assert_eq!(got.capacity(), got.len());
        }
    }

    #[test]
    fn fresh_sums_are_zero_whatever_their_size() {
        // Under a page, across pages, and large enough for its own pages.
        for n in [0, 1, 255, 257, 4096, (40 << 20) / 16 + 3] {
            let v = mapped_zeros(n);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|p| p.iter().all(|c| c.to_bits() == 0)), "{n}");
        }
    }
}
