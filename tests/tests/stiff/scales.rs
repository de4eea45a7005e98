//! The same scene at very different scales and far from the origin, and
//! lit planes at grazing angles.

use super::*;
use farm_common::math;

/// A small still life: a ground mesh, a plastic sphere, a glass sphere and a
/// box mesh, lit by a distant and a point light.
fn still_life(f: &Frame) -> String {
    format!(
        r#"
        {look_at}
        Camera "perspective" "float fov" 40
        Film "image" "integer xresolution" 64 "integer yresolution" 48
        Sampler "halton" "integer pixelsamples" 4
        Integrator "whitted" "integer maxdepth" 5
        WorldBegin
        {world}
        LightSource "distant" "point from" [{from}] "point to" [0 0 0] "rgb L" [1.5 1.5 1.5]
        {point}
        AttributeBegin
          Material "matte" "rgb Kd" [0.5 0.5 0.5]
          Shape "trianglemesh" "point P" [{ground}] "integer indices" [0 1 2 0 2 3]
        AttributeEnd
        AttributeBegin
          Material "plastic" "rgb Kd" [0.2 0.3 0.6] "rgb Ks" [0.4 0.4 0.4] "float roughness" 0.1
          Translate {t1}
          Shape "sphere" "float radius" {r1}
        AttributeEnd
        AttributeBegin
          Material "glass"
          Translate {t2}
          Shape "sphere" "float radius" {r2}
        AttributeEnd
        AttributeBegin
          Material "matte" "rgb Kd" [0.6 0.3 0.2]
          Translate {t3}
          Rotate 30 0 1 0
          {box_mesh}
        AttributeEnd
        WorldEnd
        "#,
        look_at = f.look_at([0.0, 2.25, -6.0], [0.0, 0.5, 0.0]),
        world = f.world(),
        from = f.p(&[1.0, 4.0, -2.0]),
        point = f.point_light([-1.5, 2.5, -1.5], 4.0),
        ground = f.p(&[-5.0, 0.0, -5.0, 5.0, 0.0, -5.0, 5.0, 0.0, 5.0, -5.0, 0.0, 5.0]),
        t1 = f.p(&[0.9, 0.7, 0.3]),
        r1 = f.p(&[0.7]),
        t2 = f.p(&[0.2, 0.35, -1.3]),
        r2 = f.p(&[0.35]),
        t3 = f.p(&[-1.1, 0.0, 0.4]),
        box_mesh = box_mesh(f),
    )
}

/// Scaling the whole scene by 1e-4 … 1e5 (through the CTM or by writing
/// scaled coordinates) or moving it 1e6 away from the origin renders the
/// same image: a camera-centred render space and error-bounded ray offsets
/// have no absolute length in them.
#[test]
fn scaled_and_translated_scenes_render_the_same_image() {
    let reference = render_text("still-ref", &still_life(&Frame::UNIT), &opts());
    assert_eq!(non_finite(&reference.image), 0);
    let lit = reference.image.pixels.iter().filter(|p| p[1] > 0.01).count();
    assert!(lit > reference.image.pixels.len() / 2, "the reference is mostly black");
    let mut failures = vec![];
    for f in Frame::all() {
        let r = render_text(&format!("still-{}", f.name()), &still_life(&f), &opts());
        let e = compare(&r.image, &reference.image).expect("same size");
        if e.rel_mse >= 1e-3 || e.non_finite > 0 {
            failures.push(format!(
                "{f:?}: relMSE {:.2e}, {} non-finite, largest difference {:?}",
                e.rel_mse, e.non_finite, e.max_abs
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The grazing-light scene's camera.
const ACNE_EYE: [f64; 3] = [0.0, 1.0, -3.0];
const ACNE_LOOK: [f64; 3] = [0.0, 0.0, 2.0];
const ACNE_FOV: f64 = 50.0;
const ACNE_RES: (usize, usize) = (64, 48);
/// Half the ground's side.
const GROUND: f64 = 50.0;
/// The point light: low over the ground, so most of it is lit at 80–89°.
const POINT_AT: [f64; 3] = [0.3, 0.25, 1.0];
/// The distant light's angle from the ground's normal, in degrees.
const DISTANT_DEG: f64 = 84.0;

/// A Kd 0.5 ground lit only by one light, rendered with one sample at each
/// pixel's centre so that a pixel is exactly one camera ray's radiance.
fn lit_ground(f: &Frame, point: bool) -> String {
    let light = if point {
        f.point_light(POINT_AT, 1.0)
    } else {
        let a = DISTANT_DEG.to_radians();
        format!(
            "LightSource \"distant\" \"point from\" [0 {} {}] \"point to\" [0 0 0]",
            num(math::cos(a)),
            num(math::sin(a))
        )
    };
    let g = GROUND;
    format!(
        r#"
        {look_at}
        Camera "perspective" "float fov" {ACNE_FOV}
        Film "image" "integer xresolution" {} "integer yresolution" {}
        Sampler "stratified" "integer xsamples" 1 "integer ysamples" 1 "bool jitter" "false"
        Integrator "whitted"
        WorldBegin
        {world}
        {light}
        Material "matte" "rgb Kd" [0.5 0.5 0.5]
        Shape "trianglemesh" "point P" [{p}] "integer indices" [0 1 2 0 2 3]
        WorldEnd
        "#,
        ACNE_RES.0,
        ACNE_RES.1,
        look_at = f.look_at(ACNE_EYE, ACNE_LOOK),
        world = f.world(),
        p = f.p(&[-g, 0.0, -g, g, 0.0, -g, g, 0.0, g, -g, 0.0, g]),
    )
}

/// The radiance pbrt-v3's perspective camera and a lit Kd 0.5 ground give
/// at the centre of pixel (x, y) of the unit scene, in f64; `None` where the
/// ray misses the ground or ends near its edge.
fn expected_ground(x: usize, y: usize, point: bool) -> Option<f64> {
    let v = |a: [f64; 3]| DVec3::from_array(a);
    let (eye, look) = (v(ACNE_EYE), v(ACNE_LOOK));
    let dir = (look - eye).normalize();
    let right = DVec3::Y.cross(dir).normalize();
    let up = dir.cross(right);
    let (w, h) = (ACNE_RES.0 as f64, ACNE_RES.1 as f64);
    let (frame, tan) = (w / h, math::tan(ACNE_FOV.to_radians() / 2.0));
    let sx = -frame + (x as f64 + 0.5) / w * 2.0 * frame;
    let sy = 1.0 - (y as f64 + 0.5) / h * 2.0;
    let d = right * sx * tan + up * sy * tan + dir;
    if d.y >= 0.0 {
        return None;
    }
    let p = eye + d * (-eye.y / d.y);
    if p.x.abs() > 0.9 * GROUND || p.z.abs() > 0.9 * GROUND {
        return None;
    }
    let kd_over_pi = 0.5 / PI;
    Some(if point {
        let to_light = v(POINT_AT) - p;
        let d2 = to_light.length_squared();
        kd_over_pi * (to_light.y / d2.sqrt()) / d2
    } else {
        kd_over_pi * math::cos(DISTANT_DEG.to_radians())
    })
}

/// A ground with nothing between it and a point light low over it, or a
/// distant light 84° from its normal, has no pixel wrongly in shadow at any
/// scale or far from the origin: every ground pixel is within 1% of the
/// analytic radiance, and none (a shadow-ray self-hit gives 0) is below
/// half of it.
#[test]
fn grazing_light_on_a_plane_shows_no_shadow_acne() {
    let mut failures = vec![];
    for point in [true, false] {
        for f in std::iter::once(Frame::UNIT).chain(Frame::all()) {
            let kind = if point { "point" } else { "distant" };
            let r =
                render_text(&format!("acne-{kind}-{}", f.name()), &lit_ground(&f, point), &opts());
            let (mut ground, mut shadowed, mut off, mut worst) = (0, 0, 0, (0.0f64, 0, 0));
            for y in 0..ACNE_RES.1 {
                for x in 0..ACNE_RES.0 {
                    let got = pixel(&r.image, x, y);
                    let Some(want) = expected_ground(x, y, point) else { continue };
                    ground += 1;
                    // NaN fails neither test here; the film is checked for it below.
                    for c in got.map(f64::from) {
                        let rel = (c - want).abs() / want;
                        shadowed += (c < 0.5 * want) as usize;
                        off += (rel > 1e-2) as usize;
                        if rel > worst.0 {
                            worst = (rel, x, y);
                        }
                    }
                }
            }
            assert!(ground > ACNE_RES.0 * ACNE_RES.1 / 2, "the ground fills too little");
            if shadowed > 0 || off > 0 || non_finite(&r.image) > 0 {
                failures.push(format!(
                    "{kind} {f:?}: {shadowed} values shadowed and {off} off by >1% of {} \
                     (worst relative error {:.2e} at {:?})",
                    3 * ground,
                    worst.0,
                    (worst.1, worst.2)
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
