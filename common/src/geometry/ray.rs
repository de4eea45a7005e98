use glam::Vec3;

/// A ray `o + t·d` for `t` in `(0, t_max)`, at a time within the shutter.
///
/// Laid out as two 16-byte halves, the origin and `t_max`, then the
/// direction and the time: a copied ray is stored a half at a time, and a
/// load of the origin or the direction then comes from one store. With the
/// direction at byte 12, across the seam, no store could forward it, and
/// every walk of a copied ray (an instance's, a shortened one) began by
/// waiting for it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct Ray {
    /// Origin.
    pub o: Vec3,
    /// The far end of the segment; intersection routines shrink it.
    pub t_max: f32,
    /// Direction (not necessarily normalised).
    pub d: Vec3,
    /// Time of the ray, for moving geometry.
    pub time: f32,
}

impl Ray {
    /// A ray with no far end.
    #[inline]
    pub fn new(o: Vec3, d: Vec3, time: f32) -> Self {
        Ray { o, d, t_max: f32::INFINITY, time }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// A ray with two offset rays one pixel away in x and y on the film, used to
/// filter textures (pbrt-v3 `RayDifferential`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayDifferential {
    /// The main ray.
    pub ray: Ray,
    /// Whether the offset rays are meaningful.
    pub has_differentials: bool,
    /// Origin of the ray offset in x.
    pub rx_o: Vec3,
    /// Origin of the ray offset in y.
    pub ry_o: Vec3,
    /// Direction of the ray offset in x.
    pub rx_d: Vec3,
    /// Direction of the ray offset in y.
    pub ry_d: Vec3,
}

impl RayDifferential {
    /// A ray with no differentials.
    #[inline]
    pub fn new(ray: Ray) -> Self {
        RayDifferential {
            ray,
            has_differentials: false,
            rx_o: Vec3::ZERO,
            ry_o: Vec3::ZERO,
            rx_d: Vec3::ZERO,
            ry_d: Vec3::ZERO,
        }
    }

    /// Shrink the differentials to an estimated sample spacing `s`
    /// (pbrt-v3 `ScaleDifferentials`, used with `1/sqrt(spp)`).
    pub fn scale_differentials(&mut self, s: f32) {
        let (o, d) = (self.ray.o, self.ray.d);
        self.rx_o = o + (self.rx_o - o) * s;
        self.ry_o = o + (self.ry_o - o) * s;
        self.rx_d = d + (self.rx_d - d) * s;
        self.ry_d = d + (self.ry_d - d) * s;
    }
}
