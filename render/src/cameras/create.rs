//! The scene's camera from its `Camera` directive: the name → constructor
//! table (pbrt-v3 `api.cpp` `MakeCamera`); each camera's constructor sits
//! in its own file.

use super::projective::{common, shutter};
use super::{
    read_lens_file, Camera, EnvironmentCamera, OrthographicCamera, PerspectiveCamera,
    RealisticCamera,
};
use farm_common::film::FilmGeometry;
use farm_common::geometry::AnimatedTransform;
use farm_common::scene::{Entity, Params, Warning};
use std::collections::BTreeMap;

/// The camera of a `Camera` directive placed by `render_from_camera`, for
/// a film of `film.full_resolution` pixels. Unknown or unsupported camera
/// types fall back to a perspective camera with a warning; unused
/// parameters are reported.
pub fn create(
    entity: &Entity,
    render_from_camera: AnimatedTransform,
    film: &FilmGeometry,
    assets: &BTreeMap<String, Vec<u8>>,
    warnings: &mut Vec<Warning>,
) -> Result<Camera, String> {
    let p = Params::new(&entity.params);
    if render_from_camera.has_scale() {
        warnings.push(Warning::at(
            &entity.loc,
            "Scaling detected in world-to-camera transformation!\n\
             The system has numerous assumptions, implicit and explicit,\n\
             that this transform will have no scale factors in it.\n\
             Proceed at your own risk; your image may have errors or\n\
             the system may crash as a result of this.",
        ));
    }
    let name = entity.name.as_str();
    match name {
        "perspective" | "orthographic" | "environment" | "realistic" => {}
        _ => warnings.push(Warning::at(&entity.loc, format!("Camera \"{name}\" unknown."))),
    }
    // pbrt-v3's environment camera reads a focal distance it never uses,
    // with its own default.
    let focal_default = if name == "environment" { 1e30 } else { 1e6 };
    if name == "realistic" {
        // pbrt-v3's realistic camera reads only its shutter besides its own.
        let (open, close) = shutter(&p, entity, warnings);
        let mut notes = Vec::new();
        let cam = realistic(&p, render_from_camera, (open, close), film, assets, &mut notes)?;
        warnings.extend(notes.into_iter().map(|n| Warning::at(&entity.loc, n)));
        warnings.extend(p.unused_warnings());
        return Ok(Camera::Realistic(Box::new(cam)));
    }
    let c = common(&p, entity, film, focal_default, warnings);
    let (rfc, res) = (render_from_camera, film.full_resolution);
    let camera = match name {
        "orthographic" => Camera::Orthographic(OrthographicCamera::create(rfc, &c, res)),
        "environment" => Camera::Environment(EnvironmentCamera::create(rfc, &c, res)),
        _ => Camera::Perspective(PerspectiveCamera::create(&p, rfc, &c, res)),
    };
    warnings.extend(p.unused_warnings());
    Ok(camera)
}

/// A `Camera "realistic"` (pbrt-v3 `CreateRealisticCamera`): its lens file
/// from the scene's assets, its aperture and focus.
fn realistic(
    p: &Params,
    rfc: AnimatedTransform,
    (open, close): (f32, f32),
    film: &FilmGeometry,
    assets: &BTreeMap<String, Vec<u8>>,
    notes: &mut Vec<String>,
) -> Result<RealisticCamera, String> {
    let lens_file = p.string("lensfile", "");
    let aperture = p.float("aperturediameter", 1.0);
    let focus = p.float("focusdistance", 10.0);
    let simple = p.bool("simpleweighting", true);
    if lens_file.is_empty() {
        return Err("No lens description file supplied!".into());
    }
    let bytes = assets.get(&lens_file).ok_or_else(|| format!("{lens_file}: not loaded"))?;
    let data = read_lens_file(bytes)
        .map_err(|e| format!("Error reading lens specification file \"{lens_file}\": {e}"))?;
    RealisticCamera::new(
        rfc,
        open,
        close,
        aperture,
        focus,
        simple,
        &data,
        film.diagonal,
        film.full_resolution,
        notes,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::CameraSample;
    use farm_common::geometry::{Bounds2i, Mat4, Point2i, Transform, Vec2, Vec3};
    use farm_common::math;
    use farm_common::scene::{FileLoc, Param, ParamValue};

    fn film(w: i32, h: i32) -> FilmGeometry {
        let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(w, h));
        FilmGeometry::new(
            Point2i::new(w, h),
            b,
            Vec2::splat(0.5),
            1.0,
            f32::INFINITY,
            "x.exr".into(),
            35.0,
        )
    }

    fn entity(name: &str, floats: &[(&str, &[f32])]) -> Entity {
        let mut e = Entity::named(name);
        for (n, v) in floats {
            let loc = FileLoc { file: "s.pbrt".into(), line: 1, column: 1 };
            e.params.add(Param { name: n.to_string(), value: ParamValue::Float(v.to_vec()), loc });
        }
        e
    }

    fn fixed() -> AnimatedTransform {
        AnimatedTransform::fixed(Transform::default())
    }

    #[test]
    fn defaults_follow_pbrt() {
        let mut w = Vec::new();
        let c =
            create(&Entity::named("perspective"), fixed(), &film(20, 10), &BTreeMap::new(), &mut w)
                .unwrap();
        assert!(w.is_empty(), "{w:?}");
        assert_eq!(c.shutter(), (0.0, 1.0));
        let p = c.projective().unwrap();
        assert_eq!((p.lens_radius, p.focal_distance), (0.0, 1e6));
        // Wide film: the 90° field of view is vertical, the window 2:1.
        let s = CameraSample { p_film: Vec2::new(0.0, 5.0), ..Default::default() };
        let (_, r) = c.generate_ray(&s);
        assert!((r.d.x / r.d.z + 2.0).abs() < 1e-5, "{:?}", r.d);
    }

    #[test]
    fn unknown_cameras_fall_back_with_warnings() {
        let mut w = Vec::new();
        let e = entity("fisheye", &[("fov", &[30.0]), ("bogus", &[1.0])]);
        let c = create(
            &Entity { loc: FileLoc { file: "s.pbrt".into(), line: 1, column: 1 }, ..e },
            fixed(),
            &film(8, 8),
            &BTreeMap::new(),
            &mut w,
        )
        .unwrap();
        assert!(matches!(c, Camera::Perspective(_)));
        let text: Vec<String> = w.iter().map(|w| w.to_string()).collect();
        assert_eq!(
            text,
            [
                "s.pbrt:1:1: warning: Camera \"fisheye\" unknown.",
                "s.pbrt:1:1: warning: Parameter \"bogus\" not used"
            ]
        );
    }

    #[test]
    fn parameters_are_read_and_checked() {
        let mut w = Vec::new();
        let e = entity(
            "perspective",
            &[
                ("shutteropen", &[2.0]),
                ("shutterclose", &[1.0]),
                ("halffov", &[22.5]),
                ("screenwindow", &[1.0, 2.0]),
            ],
        );
        let c = create(&e, fixed(), &film(8, 8), &BTreeMap::new(), &mut w).unwrap();
        assert_eq!(c.shutter(), (1.0, 2.0));
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(w[0]
            .message
            .starts_with("Shutter close time [1.000000] < shutter open [2.000000]"));
        assert_eq!(w[1].message, "\"screenwindow\" should have four values");
        // halffov 22.5 is a 45° field of view.
        let (_, r) =
            c.generate_ray(&CameraSample { p_film: Vec2::new(0.0, 4.0), ..Default::default() });
        assert!((r.d.x / r.d.z + math::tan(22.5f32.to_radians())).abs() < 1e-5);

        let mut w = Vec::new();
        let e = entity(
            "orthographic",
            &[("screenwindow", &[-1.0, 1.0, -3.0, 3.0]), ("lensradius", &[0.5])],
        );
        let scaled = AnimatedTransform::fixed(Transform::new(Mat4::from_scale(Vec3::splat(2.0))));
        let c = create(&e, scaled, &film(8, 8), &BTreeMap::new(), &mut w).unwrap();
        assert!(matches!(c, Camera::Orthographic(_)) && c.lens_radius() == 0.5);
        assert!(w.len() == 1 && w[0].message.starts_with("Scaling detected"), "{w:?}");
    }
}
