use super::float::gamma;
use super::ray::Ray;
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// An integer point (pixel coordinates).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Point2i {
    /// Column.
    pub x: i32,
    /// Row.
    pub y: i32,
}

impl Point2i {
    /// The point (x, y).
    pub const fn new(x: i32, y: i32) -> Self {
        Point2i { x, y }
    }
}

/// A half-open integer rectangle `[min, max)` of pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Bounds2i {
    /// First pixel inside.
    pub min: Point2i,
    /// One past the last pixel in x and y.
    pub max: Point2i,
}

impl Bounds2i {
    /// The rectangle `[min, max)`.
    pub const fn new(min: Point2i, max: Point2i) -> Self {
        Bounds2i { min, max }
    }
    /// Width (zero if empty).
    #[inline]
    pub fn width(&self) -> i32 {
        (self.max.x - self.min.x).max(0)
    }
    /// Height (zero if empty).
    #[inline]
    pub fn height(&self) -> i32 {
        (self.max.y - self.min.y).max(0)
    }
    /// Number of pixels.
    #[inline]
    pub fn area(&self) -> usize {
        self.width() as usize * self.height() as usize
    }
    /// Whether no pixel is inside.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.max.x <= self.min.x || self.max.y <= self.min.y
    }
    /// The overlap of two rectangles (possibly empty).
    #[inline]
    pub fn intersect(&self, o: &Bounds2i) -> Bounds2i {
        Bounds2i::new(
            Point2i::new(self.min.x.max(o.min.x), self.min.y.max(o.min.y)),
            Point2i::new(self.max.x.min(o.max.x), self.max.y.min(o.max.y)),
        )
    }
    /// Whether `p` lies inside the half-open rectangle.
    #[inline]
    pub fn contains(&self, p: Point2i) -> bool {
        p.x >= self.min.x && p.x < self.max.x && p.y >= self.min.y && p.y < self.max.y
    }
    /// Row-major offset of `p` inside the rectangle.
    #[inline]
    pub fn offset(&self, p: Point2i) -> usize {
        ((p.y - self.min.y) * self.width() + (p.x - self.min.x)) as usize
    }
    /// The pixels of `self` outside `o`, as up to four rectangles (some
    /// possibly empty): the rows above `o`, the rows below, and left and
    /// right of it in between.
    pub fn minus(&self, o: &Bounds2i) -> [Bounds2i; 4] {
        let cut = self.intersect(o);
        if cut.is_empty() {
            return [*self, Bounds2i::default(), Bounds2i::default(), Bounds2i::default()];
        }
        let (x0, x1) = (self.min.x, self.max.x);
        let (y0, y1) = (cut.min.y, cut.max.y);
        let b = |ax, ay, bx, by| Bounds2i::new(Point2i::new(ax, ay), Point2i::new(bx, by));
        [
            b(x0, self.min.y, x1, y0),
            b(x0, y1, x1, self.max.y),
            b(x0, y0, cut.min.x, y1),
            b(cut.max.x, y0, x1, y1),
        ]
    }
    /// The pixels in row-major order.
    pub fn iter(self) -> impl Iterator<Item = Point2i> {
        let (x0, x1) = (self.min.x, self.max.x);
        (self.min.y..self.max.y).flat_map(move |y| (x0..x1).map(move |x| Point2i::new(x, y)))
    }
}

/// A float rectangle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bounds2f {
    /// Lower corner.
    pub min: Vec2,
    /// Upper corner.
    pub max: Vec2,
}

/// An axis-aligned box; the default is empty (min = +∞, max = −∞).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bounds3f {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Default for Bounds3f {
    fn default() -> Self {
        Bounds3f { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) }
    }
}

impl Bounds3f {
    /// The box spanned by two corners in any order.
    pub fn new(a: Vec3, b: Vec3) -> Self {
        Bounds3f { min: a.min(b), max: a.max(b) }
    }
    /// The box holding one point.
    pub fn from_point(p: Vec3) -> Self {
        Bounds3f { min: p, max: p }
    }
    /// Smallest box containing both.
    #[inline]
    pub fn union(&self, o: &Bounds3f) -> Bounds3f {
        Bounds3f { min: self.min.min(o.min), max: self.max.max(o.max) }
    }
    /// Smallest box containing the box and `p`.
    #[inline]
    pub fn union_point(&self, p: Vec3) -> Bounds3f {
        Bounds3f { min: self.min.min(p), max: self.max.max(p) }
    }
    /// Whether the box holds no point.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }
    /// `max - min`.
    #[inline]
    pub fn diagonal(&self) -> Vec3 {
        self.max - self.min
    }
    /// Centre of the box.
    #[inline]
    pub fn centroid(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }
    /// Surface area (zero for an empty box).
    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.diagonal();
        2.0 * (d.x * d.y + d.x * d.z + d.y * d.z)
    }
    /// Index of the longest axis.
    pub fn maximum_extent(&self) -> usize {
        let d = self.diagonal();
        if d.x > d.y && d.x > d.z {
            0
        } else if d.y > d.z {
            1
        } else {
            2
        }
    }
    /// Position of `p` relative to the corners: 0 at `min`, 1 at `max`.
    pub fn offset(&self, p: Vec3) -> Vec3 {
        let mut o = p - self.min;
        for i in 0..3 {
            if self.max[i] > self.min[i] {
                o[i] /= self.max[i] - self.min[i];
            }
        }
        o
    }
    /// Whether `p` is inside (closed box).
    pub fn inside(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }
    /// A sphere (centre, radius) enclosing the box.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        let c = self.centroid();
        let r = if self.inside(c) { c.distance(self.max) } else { 0.0 };
        (c, r)
    }
    /// The box grown by `delta` on every side.
    pub fn expand(&self, delta: f32) -> Bounds3f {
        Bounds3f { min: self.min - Vec3::splat(delta), max: self.max + Vec3::splat(delta) }
    }

    /// Parametric range `(t0, t1)` of the ray inside the box, with the far
    /// end rounded up by 2γ₃ so that a ray grazing the box is never
    /// missed (pbrt-v3 `Bounds3::IntersectP`).
    #[inline]
    pub fn intersect_p(&self, ray: &Ray) -> Option<(f32, f32)> {
        let (mut t0, mut t1) = (0.0f32, ray.t_max);
        for i in 0..3 {
            let inv = 1.0 / ray.d[i];
            let mut t_near = (self.min[i] - ray.o[i]) * inv;
            let mut t_far = (self.max[i] - ray.o[i]) * inv;
            if t_near > t_far {
                std::mem::swap(&mut t_near, &mut t_far);
            }
            t_far *= 1.0 + 2.0 * gamma(3);
            t0 = if t_near > t0 { t_near } else { t0 };
            t1 = if t_far < t1 { t_far } else { t1 };
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }

    /// The slab test with a precomputed reciprocal direction, for BVH
    /// traversal; conservative in the same way as [`Bounds3f::intersect_p`].
    #[inline(always)]
    pub fn hit(&self, o: Vec3, inv_d: Vec3, t_max: f32) -> bool {
        let t_a = (self.min - o) * inv_d;
        let t_b = (self.max - o) * inv_d;
        let t_near = t_a.min(t_b);
        let t_far = t_a.max(t_b) * (1.0 + 2.0 * gamma(3));
        let t0 = t_near.max_element().max(0.0);
        let t1 = t_far.min_element().min(t_max);
        t0 <= t1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grazing_ray_along_a_face_still_hits() {
        let b = Bounds3f::new(Vec3::ZERO, Vec3::ONE);
        let r = Ray::new(Vec3::new(-1.0, 1.0, 0.5), Vec3::X, 0.0);
        assert!(b.intersect_p(&r).is_some());
        assert!(b.hit(r.o, r.d.recip(), r.t_max));
        let miss = Ray::new(Vec3::new(-1.0, 1.0001, 0.5), Vec3::X, 0.0);
        assert!(b.intersect_p(&miss).is_none());
        assert!(!b.hit(miss.o, miss.d.recip(), miss.t_max));
    }

    #[test]
    fn tile_bounds_iterate_row_major() {
        let b = Bounds2i::new(Point2i::new(2, 3), Point2i::new(4, 5));
        let v: Vec<_> = b.iter().collect();
        assert_eq!(
            v,
            vec![Point2i::new(2, 3), Point2i::new(3, 3), Point2i::new(2, 4), Point2i::new(3, 4)]
        );
        assert_eq!(b.offset(Point2i::new(3, 4)), 3);
    }
}
