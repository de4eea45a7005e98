//! `Camera "realistic"` (pbrt-v3 `cameras/realistic.cpp`): rays traced
//! from the film through a system of spherical lens elements and an
//! aperture stop read from a lens file, focused by moving the film, with
//! the exit pupil bounded for sampling as pbrt-v3 bounds it.

use crate::bxdf::reflection::refract;
use crate::sampler::lowdiscrepancy::radical_inverse;
use crate::sampling::CameraSample;
use farm_common::geometry::{
    face_forward, AnimatedTransform, Point2i, Ray, RayDifferential, Vec2, Vec3,
};
use rayon::prelude::*;

/// One interface of the lens system (pbrt-v3 `LensElementInterface`), in
/// metres; a curvature radius of 0 is the aperture stop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LensElement {
    /// Signed radius of the spherical surface.
    pub curvature_radius: f32,
    /// Distance to the next interface toward the film.
    pub thickness: f32,
    /// Index of refraction on the film side (0 for air at the stop).
    pub eta: f32,
    /// Radius of the element's opening.
    pub aperture_radius: f32,
}

/// An axis-aligned rectangle on the rear element's plane; empty when `min > max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PupilBounds {
    /// Lower corner.
    pub min: Vec2,
    /// Upper corner.
    pub max: Vec2,
}

impl PupilBounds {
    const EMPTY: PupilBounds =
        PupilBounds { min: Vec2::splat(f32::MAX), max: Vec2::splat(-f32::MAX) };

    fn inside(&self, p: Vec2) -> bool {
        p.x >= self.min.x && p.x <= self.max.x && p.y >= self.min.y && p.y <= self.max.y
    }

    /// pbrt-v3's `Area` (negative extents give nothing sensible; callers
    /// never ask an empty bound).
    pub fn area(&self) -> f32 {
        let d = self.max - self.min;
        d.x * d.y
    }
}

/// The realistic camera.
#[derive(Clone, Debug)]
pub struct RealisticCamera {
    /// Render-from-camera.
    pub render_from_camera: AnimatedTransform,
    /// When the shutter opens.
    pub shutter_open: f32,
    /// When the shutter closes.
    pub shutter_close: f32,
    /// The lens system, from the scene side to the film side.
    pub elements: Vec<LensElement>,
    /// Exit pupil bounds for 64 rings of film radius.
    pub exit_pupil_bounds: Vec<PupilBounds>,
    simple_weighting: bool,
    /// The film's half-extent in metres (x, y).
    film_extent: Vec2,
    film_diagonal: f32,
    resolution: Vec2,
}

/// pbrt-v3 `Quadratic`, with its double-precision discriminant.
fn quadratic(a: f32, b: f32, c: f32) -> Option<(f32, f32)> {
    let discrim = b as f64 * b as f64 - 4.0 * a as f64 * c as f64;
    if discrim < 0.0 {
        return None;
    }
    let root = discrim.sqrt();
    let q = if b < 0.0 { -0.5 * (b as f64 - root) } else { -0.5 * (b as f64 + root) };
    let (t0, t1) = ((q / a as f64) as f32, (c as f64 / q) as f32);
    Some(if t0 > t1 { (t1, t0) } else { (t0, t1) })
}

/// pbrt-v3 `IntersectSphericalElement`: `t` and the normal facing the ray.
fn intersect_element(radius: f32, z_center: f32, ray: &Ray) -> Option<(f32, Vec3)> {
    let o = ray.o - Vec3::new(0.0, 0.0, z_center);
    let d = ray.d;
    let a = d.x * d.x + d.y * d.y + d.z * d.z;
    let b = 2.0 * (d.x * o.x + d.y * o.y + d.z * o.z);
    let c = o.x * o.x + o.y * o.y + o.z * o.z - radius * radius;
    let (t0, t1) = quadratic(a, b, c)?;
    let closer = (d.z > 0.0) ^ (radius < 0.0);
    let t = if closer { t0.min(t1) } else { t0.max(t1) };
    if t < 0.0 {
        return None;
    }
    let n = face_forward((o + t * d).normalize(), -d);
    Some((t, n))
}

/// The point along `ray` at `t`.
fn at(ray: &Ray, t: f32) -> Vec3 {
    ray.o + ray.d * t
}

/// Flips z: camera space (+z toward the scene) to lens space and back.
fn flip(r: &Ray) -> Ray {
    let mut r = *r;
    r.o.z = -r.o.z;
    r.d.z = -r.d.z;
    r
}

impl RealisticCamera {
    /// A camera from a lens file's values (four per interface: curvature
    /// radius, thickness and aperture diameter in millimetres, and eta),
    /// focused at `focus_distance` metres, its stop opened to
    /// `aperture_diameter` millimetres. `Err` says why the lens cannot form
    /// an image.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        render_from_camera: AnimatedTransform,
        shutter_open: f32,
        shutter_close: f32,
        aperture_diameter: f32,
        focus_distance: f32,
        simple_weighting: bool,
        lens_data: &[f32],
        film_diagonal_mm: f32,
        full_resolution: Point2i,
        warnings: &mut Vec<String>,
    ) -> Result<Self, String> {
        let mut elements = Vec::new();
        for v in lens_data.chunks_exact(4) {
            let mut aperture = v[3];
            if v[0] == 0.0 {
                if aperture_diameter > v[3] {
                    warnings.push(format!(
                        "Specified aperture diameter {aperture_diameter:.6} is greater than maximum possible {:.6}.  Clamping it.",
                        v[3]
                    ));
                } else {
                    aperture = aperture_diameter;
                }
            }
            elements.push(LensElement {
                curvature_radius: v[0] * 0.001,
                thickness: v[1] * 0.001,
                eta: v[2],
                aperture_radius: aperture * 0.001 / 2.0,
            });
        }
        if elements.is_empty() {
            return Err("the lens file describes no lens elements".into());
        }
        let (rx, ry) = (full_resolution.x as f32, full_resolution.y as f32);
        let diagonal = film_diagonal_mm * 0.001;
        let aspect = ry / rx;
        let x = (diagonal * diagonal / (1.0 + aspect * aspect)).sqrt();
        let mut cam = RealisticCamera {
            render_from_camera,
            shutter_open,
            shutter_close,
            elements,
            exit_pupil_bounds: Vec::new(),
            simple_weighting,
            film_extent: Vec2::new(x / 2.0, aspect * x / 2.0),
            film_diagonal: diagonal,
            resolution: Vec2::new(rx, ry),
        };
        let thickness = cam.focus_thick_lens(focus_distance)?;
        if let Some(last) = cam.elements.last_mut() {
            last.thickness = thickness;
        }
        let n = 64;
        cam.exit_pupil_bounds = (0..n)
            .into_par_iter()
            .map(|i| {
                let r0 = i as f32 / n as f32 * diagonal / 2.0;
                let r1 = (i + 1) as f32 / n as f32 * diagonal / 2.0;
                cam.bound_exit_pupil(r0, r1)
            })
            .collect();
        if simple_weighting {
            warnings.push("\"simpleweighting\" option with RealisticCamera no longer necessarily matches regular camera images. Further, pixel values will vary a bit depending on the aperture size. See this discussion for details: https://github.com/mmp/pbrt-v3/issues/162#issuecomment-348625837".into());
        }
        Ok(cam)
    }

    fn lens_rear_z(&self) -> f32 {
        self.elements.last().map_or(0.0, |e| e.thickness)
    }

    fn lens_front_z(&self) -> f32 {
        self.elements.iter().map(|e| e.thickness).sum()
    }

    fn rear_element_radius(&self) -> f32 {
        self.elements.last().map_or(0.0, |e| e.aperture_radius)
    }

    /// pbrt-v3 `TraceLensesFromFilm`: the ray leaving the front element,
    /// in camera space, or `None` where the lens blocks it.
    pub fn trace_from_film(&self, r_camera: &Ray) -> Option<Ray> {
        let mut element_z = 0.0;
        let mut r = flip(r_camera);
        for i in (0..self.elements.len()).rev() {
            let e = &self.elements[i];
            element_z -= e.thickness;
            let stop = e.curvature_radius == 0.0;
            let (t, n) = if stop {
                if r.d.z >= 0.0 {
                    return None;
                }
                ((element_z - r.o.z) / r.d.z, Vec3::ZERO)
            } else {
                let z_center = element_z + e.curvature_radius;
                intersect_element(e.curvature_radius, z_center, &r)?
            };
            let p = at(&r, t);
            if p.x * p.x + p.y * p.y > e.aperture_radius * e.aperture_radius {
                return None;
            }
            r.o = p;
            if !stop {
                let eta_i = e.eta;
                let eta_t = if i > 0 && self.elements[i - 1].eta != 0.0 {
                    self.elements[i - 1].eta
                } else {
                    1.0
                };
                r.d = refract((-r.d).normalize(), n, eta_i / eta_t)?;
            }
        }
        Some(flip(&r))
    }

    /// pbrt-v3 `TraceLensesFromScene`.
    fn trace_from_scene(&self, r_camera: &Ray) -> Option<Ray> {
        let mut element_z = -self.lens_front_z();
        let mut r = flip(r_camera);
        for (i, e) in self.elements.iter().enumerate() {
            let stop = e.curvature_radius == 0.0;
            let (t, n) = if stop {
                ((element_z - r.o.z) / r.d.z, Vec3::ZERO)
            } else {
                let z_center = element_z + e.curvature_radius;
                intersect_element(e.curvature_radius, z_center, &r)?
            };
            let p = at(&r, t);
            if p.x * p.x + p.y * p.y > e.aperture_radius * e.aperture_radius {
                return None;
            }
            r.o = p;
            if !stop {
                let eta_i = if i == 0 || self.elements[i - 1].eta == 0.0 {
                    1.0
                } else {
                    self.elements[i - 1].eta
                };
                let eta_t = if e.eta != 0.0 { e.eta } else { 1.0 };
                r.d = refract((-r.d).normalize(), n, eta_i / eta_t)?;
            }
            element_z += e.thickness;
        }
        Some(flip(&r))
    }

    /// pbrt-v3 `ComputeCardinalPoints`: (principal plane z, focal point z).
    fn cardinal_points(r_in: &Ray, r_out: &Ray) -> (f32, f32) {
        let tf = -r_out.o.x / r_out.d.x;
        let tp = (r_in.o.x - r_out.o.x) / r_out.d.x;
        (-at(r_out, tp).z, -at(r_out, tf).z)
    }

    /// pbrt-v3 `FocusThickLens`: the rear element's thickness that focuses
    /// at `focus_distance`, from a thick-lens approximation.
    fn focus_thick_lens(&self, focus_distance: f32) -> Result<f32, String> {
        let x = 0.001 * self.film_diagonal;
        let blocked = || {
            "the lens is too stopped down to trace the rays that focus it (is the aperture stop extremely small?)".to_string()
        };
        let r_scene = Ray::new(Vec3::new(x, 0.0, self.lens_front_z() + 1.0), -Vec3::Z, 0.0);
        let r_film = self.trace_from_scene(&r_scene).ok_or_else(blocked)?;
        let (pz0, fz0) = Self::cardinal_points(&r_scene, &r_film);
        let r_film = Ray::new(Vec3::new(x, 0.0, self.lens_rear_z() - 1.0), Vec3::Z, 0.0);
        let r_scene = self.trace_from_film(&r_film).ok_or_else(blocked)?;
        let (pz1, _) = Self::cardinal_points(&r_film, &r_scene);
        let f = fz0 - pz0;
        let z = -focus_distance;
        let c = (pz1 - z - pz0) * (pz1 - z - 4.0 * f - pz0);
        if c.is_nan() || c < 0.0 {
            return Err(format!(
                "the lens cannot focus at {focus_distance} m (its focal length is {:.1} mm)",
                f * 1000.0
            ));
        }
        let delta = 0.5 * (pz1 - z + pz0 - c.sqrt());
        Ok(self.lens_rear_z() + delta)
    }

    /// pbrt-v3 `BoundExitPupil`: the rear-plane rectangle through which
    /// rays from film points at radii `x0..x1` (on the x axis) leave the
    /// lens, found with a million low-discrepancy rays, grown by one
    /// sample spacing.
    pub fn bound_exit_pupil(&self, x0: f32, x1: f32) -> PupilBounds {
        const N: usize = 1024 * 1024;
        let rear = self.rear_element_radius();
        let proj = PupilBounds { min: Vec2::splat(-1.5 * rear), max: Vec2::splat(1.5 * rear) };
        let mut bounds = PupilBounds::EMPTY;
        let mut exiting = 0;
        let lerp = |t: f32, a: f32, b: f32| (1.0 - t) * a + t * b;
        for i in 0..N {
            let p_film = Vec3::new(lerp((i as f32 + 0.5) / N as f32, x0, x1), 0.0, 0.0);
            let u = (radical_inverse(0, i as u64), radical_inverse(1, i as u64));
            let p_rear = Vec3::new(
                lerp(u.0, proj.min.x, proj.max.x),
                lerp(u.1, proj.min.y, proj.max.y),
                self.lens_rear_z(),
            );
            let q = Vec2::new(p_rear.x, p_rear.y);
            if bounds.inside(q)
                || self.trace_from_film(&Ray::new(p_film, p_rear - p_film, 0.0)).is_some()
            {
                bounds.min = bounds.min.min(q);
                bounds.max = bounds.max.max(q);
                exiting += 1;
            }
        }
        if exiting == 0 {
            return proj;
        }
        let delta = 2.0 * (proj.max - proj.min).length() / (N as f32).sqrt();
        PupilBounds { min: bounds.min - Vec2::splat(delta), max: bounds.max + Vec2::splat(delta) }
    }

    /// pbrt-v3 `SampleExitPupil`: a point on the rear plane for a film
    /// point, and the area of the bounds it was drawn from.
    fn sample_exit_pupil(&self, p_film: Vec2, u: Vec2) -> (Vec3, f32) {
        let r_film = p_film.length();
        let n = self.exit_pupil_bounds.len();
        let index = ((r_film / (self.film_diagonal / 2.0) * n as f32) as usize).min(n - 1);
        let b = self.exit_pupil_bounds[index];
        let p =
            Vec2::new((1.0 - u.x) * b.min.x + u.x * b.max.x, (1.0 - u.y) * b.min.y + u.y * b.max.y);
        let (sin, cos) =
            if r_film != 0.0 { (p_film.y / r_film, p_film.x / r_film) } else { (0.0, 1.0) };
        (Vec3::new(cos * p.x - sin * p.y, sin * p.x + cos * p.y, self.lens_rear_z()), b.area())
    }

    /// The ray through a film sample (pbrt-v3 `GenerateRay`), weight 0
    /// where the lens blocks it.
    #[inline]
    pub fn generate_ray(&self, s: &CameraSample) -> (f32, Ray) {
        let st = s.p_film / self.resolution;
        let e = self.film_extent;
        let p2 = Vec2::new((1.0 - st.x) * -e.x + st.x * e.x, (1.0 - st.y) * -e.y + st.y * e.y);
        let p_film = Vec3::new(-p2.x, p2.y, 0.0);
        let (p_rear, area) = self.sample_exit_pupil(Vec2::new(p_film.x, p_film.y), s.p_lens);
        let u = s.time;
        let time = (1.0 - u) * self.shutter_open + u * self.shutter_close;
        let r_film = Ray::new(p_film, p_rear - p_film, time);
        let Some(ray) = self.trace_from_film(&r_film) else {
            return (0.0, Ray::new(Vec3::ZERO, Vec3::Z, time));
        };
        let mut ray = self.render_from_camera.ray(&ray);
        ray.d = ray.d.normalize();
        let cos = r_film.d.normalize().z;
        let cos4 = (cos * cos) * (cos * cos);
        let w = if self.simple_weighting {
            cos4 * area / self.exit_pupil_bounds[0].area()
        } else {
            let z = self.lens_rear_z();
            (self.shutter_close - self.shutter_open) * (cos4 * area) / (z * z)
        };
        (w, ray)
    }

    /// pbrt-v3's generic differentials (`Camera::GenerateRayDifferential`):
    /// rays a twentieth of a pixel over, scaled up to a pixel, trying the
    /// other side where the lens blocks the first.
    pub fn generate_ray_differential(&self, s: &CameraSample) -> (f32, RayDifferential) {
        let (w, ray) = self.generate_ray(s);
        let mut rd = RayDifferential::new(ray);
        if w == 0.0 {
            return (0.0, rd);
        }
        for axis in 0..2 {
            let mut found = false;
            for eps in [0.05f32, -0.05] {
                let mut shifted = *s;
                if axis == 0 {
                    shifted.p_film.x += eps;
                } else {
                    shifted.p_film.y += eps;
                }
                let (wt, r) = self.generate_ray(&shifted);
                let (o, d) = (ray.o + (r.o - ray.o) / eps, ray.d + (r.d - ray.d) / eps);
                if axis == 0 {
                    (rd.rx_o, rd.rx_d) = (o, d);
                } else {
                    (rd.ry_o, rd.ry_d) = (o, d);
                }
                if wt != 0.0 {
                    found = true;
                    break;
                }
            }
            if !found {
                return (0.0, rd);
            }
        }
        rd.has_differentials = true;
        (w, rd)
    }
}

/// The numbers of a lens file (pbrt-v3 `ReadFloatFile`: `#` to the end of
/// a line is a comment).
pub fn read_lens_file(bytes: &[u8]) -> Result<Vec<f32>, String> {
    let text = std::str::from_utf8(bytes).map_err(|_| "the lens file is not text".to_string())?;
    let mut v = Vec::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("");
        for word in line.split_whitespace() {
            v.push(word.parse::<f32>().map_err(|_| format!("\"{word}\" is not a number"))?);
        }
    }
    if v.len() % 4 != 0 {
        return Err(format!(
            "Excess values in lens specification file; must be multiple-of-four values, read {}.",
            v.len()
        ));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::geometry::Transform;
    use farm_common::rng::Rng;

    const DGAUSS: &str = include_str!("../../../scenes/parity/lenses/dgauss.50mm.dat");

    fn camera(focus: f32) -> RealisticCamera {
        let data = read_lens_file(DGAUSS.as_bytes()).unwrap();
        let mut notes = Vec::new();
        let xf = AnimatedTransform::fixed(Transform::default());
        RealisticCamera::new(
            xf,
            0.0,
            1.0,
            8.0,
            focus,
            true,
            &data,
            35.0,
            Point2i::new(64, 48),
            &mut notes,
        )
        .unwrap()
    }

    /// pbrt-v3's `TestExitPupilBounds`: every ray from a film point that
    /// gets through the lens left the rear element inside the bounds of the
    /// point's ring (or the next); the lens focuses where it was asked to,
    /// and an impossible lens is an error, not a panic.
    #[test]
    fn exit_pupil_bounds_hold_every_ray_through_the_lens_and_focus_holds() {
        let cam = camera(2.0);
        let mut rng = Rng::new(7);
        let n = cam.exit_pupil_bounds.len();
        let (mut through, rear) = (0, cam.rear_element_radius());
        for _ in 0..200 {
            let x = rng.uniform_f32() * cam.film_diagonal / 2.0;
            let i = ((x / (cam.film_diagonal / 2.0) * (n - 1) as f32) as usize).min(n - 1);
            let mut b = cam.exit_pupil_bounds[i];
            if i + 1 < n {
                let c = cam.exit_pupil_bounds[i + 1];
                b = PupilBounds { min: b.min.min(c.min), max: b.max.max(c.max) };
            }
            for _ in 0..100 {
                let d = crate::sampling::concentric_sample_disk(Vec2::new(
                    rng.uniform_f32(),
                    rng.uniform_f32(),
                )) * rear;
                let p_film = Vec3::new(x, 0.0, 0.0);
                let ray = Ray::new(p_film, Vec3::new(d.x, d.y, cam.lens_rear_z()) - p_film, 0.0);
                if cam.trace_from_film(&ray).is_some() {
                    through += 1;
                    assert!(b.inside(d), "ray through {d} at film x {x} outside {b:?}");
                }
            }
        }
        assert!(through > 1000, "only {through} rays got through");
        // A ray from the film's centre through the lens crosses the axis at
        // the focus distance (the thick-lens focus is refined no further).
        let lu = 0.1 * cam.bound_exit_pupil(0.0, 0.001 * cam.film_diagonal).max.x;
        let z = cam.lens_rear_z();
        let out = cam
            .trace_from_film(&Ray::new(Vec3::new(0.0, 0.0, 0.0), Vec3::new(lu, 0.0, z), 0.0))
            .unwrap();
        let t = -out.o.x / out.d.x;
        let focus = out.o.z + t * out.d.z;
        assert!((focus - 2.0).abs() < 0.05, "focused at {focus} m");
        let data = read_lens_file(DGAUSS.as_bytes()).unwrap();
        let xf = AnimatedTransform::fixed(Transform::default());
        let tiny = RealisticCamera::new(
            xf,
            0.0,
            1.0,
            1e-6,
            0.001,
            true,
            &data,
            35.0,
            Point2i::new(8, 8),
            &mut Vec::new(),
        );
        assert!(tiny.is_err(), "a lens cannot focus a millimetre in front of itself");
        assert!(read_lens_file(b"1 2 3").is_err());
    }
}
