//! Stiff cases for motion (issue 4): quaternion slerp between identical,
//! nearly identical, opposite and nearly opposite rotations; animated
//! transforms whose motion bounds hold every sampled position; interval
//! arithmetic that contains the exact result.

use farm_common::geometry::{
    slerp, AnimatedTransform, Bounds3f, Interval, Mat4, Quaternion, Transform, Vec3,
};
use farm_common::math;
use farm_common::rng::Rng;

fn unit(rng: &mut Rng) -> Vec3 {
    loop {
        let v = Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32()) * 2.0 - 1.0;
        let l = v.length_squared();
        if l > 1e-4 && l <= 1.0 {
            return v / l.sqrt();
        }
    }
}

fn quat(axis: Vec3, angle: f32) -> Quaternion {
    Quaternion::from_transform(&Transform::new(Mat4::from_axis_angle(axis, angle)))
}

/// Slerp stays unit length, starts and ends at its keys (up to sign), and
/// moves along the short arc by the fraction t of the angle, for identical,
/// nearly identical (1e-6 rad), opposite-sign and nearly opposite pairs.
#[test]
fn slerp_is_unit_and_uniform_for_stiff_pairs() {
    let mut rng = Rng::new(17);
    for _ in 0..5000 {
        let axis = unit(&mut rng);
        let q0 = quat(axis, 6.0 * rng.uniform_f32() - 3.0);
        let k = rng.uniform_u32() % 4;
        let delta = [0.0f32, 1e-6, 1e-3, 3.1415925][k as usize];
        let mut q1 = q0;
        if delta > 0.0 {
            // Compose with a small (or half-turn) rotation about another axis.
            let r = Transform::new(Mat4::from_axis_angle(unit(&mut rng), delta));
            q1 = Quaternion::from_transform(&r.compose(&q0.to_transform()));
        }
        if rng.uniform_f32() < 0.5 {
            q1 = -q1; // the same rotation
        }
        let theta = math::acos(q0.dot(&q1).abs().min(1.0));
        for t in [0.0f32, 0.25, 0.5, 0.75, 1.0] {
            let s = slerp(t, &q0, &q1);
            assert!(s.v.is_finite() && s.w.is_finite());
            assert!((s.dot(&s) - 1.0).abs() < 1e-5, "norm {}", s.dot(&s));
            let a0 = math::acos(s.dot(&q0).abs().min(1.0));
            let a1 = math::acos(s.dot(&q1).abs().min(1.0));
            assert!((a0 - t * theta).abs() < 2e-3, "k={k} t={t}: {a0} vs {}", t * theta);
            assert!((a1 - (1.0 - t) * theta).abs() < 2e-3, "k={k} t={t}");
        }
    }
}

fn keyframe(rng: &mut Rng, base: Option<&Mat4>) -> Mat4 {
    let t = Mat4::from_translation(unit(rng) * 10.0 * rng.uniform_f32());
    let s = Mat4::from_scale(Vec3::new(
        0.1 + 3.0 * rng.uniform_f32(),
        0.1 + 3.0 * rng.uniform_f32(),
        0.1 + 3.0 * rng.uniform_f32(),
    ));
    let angle = match rng.uniform_u32() % 5 {
        0 => std::f32::consts::PI,
        1 => std::f32::consts::PI - 1e-3,
        2 => 1e-2,
        3 => 0.0,
        _ => 6.0 * rng.uniform_f32(),
    };
    let r = Mat4::from_axis_angle(unit(rng), angle);
    match base {
        Some(b) => t * r * *b,
        None => t * r * s,
    }
}

/// Motion bounds of a box contain the box's points at every sampled time,
/// for random keyframe pairs including half turns, nearly half turns, tiny
/// rotations (down to a few hundredths of a degree, where pbrt-v3 bounds
/// the motion by the end boxes alone and the arc bulges out of them) and
/// rotation with non-uniform scale, over several seeds.
#[test]
fn motion_bounds_contain_every_sampled_position() {
    let mut worst = 0.0f32;
    for (seed, i) in (23..28).flat_map(|seed| (0..2000).map(move |i| (seed, i))) {
        let mut rng = Rng::new(seed * 10_007 + i);
        let m0 = keyframe(&mut rng, None);
        let m1 = match rng.uniform_u32() % 10 {
            0..=2 => keyframe(&mut rng, Some(&m0)),
            // A small extra turn of the same keyframe, about any axis.
            3..=4 => {
                let angle = [5e-4f32, 3e-3, 1e-2, 3e-2][(rng.uniform_u32() % 4) as usize];
                let turn = Mat4::from_axis_angle(unit(&mut rng), angle);
                let shift = Mat4::from_translation(unit(&mut rng) * rng.uniform_f32());
                shift * m0 * turn
            }
            _ => keyframe(&mut rng, None),
        };
        let at = AnimatedTransform::new(Transform::new(m0), 0.0, Transform::new(m1), 1.0);
        let lo = unit(&mut rng) * 2.0;
        let b = Bounds3f::new(lo, lo + Vec3::new(0.5, 1.5, 0.2) * (0.1 + rng.uniform_f32()));
        let mb = at.motion_bounds(&b);
        let d = b.diagonal();
        for i in 0..64 {
            let time = i as f32 / 63.0;
            let f = Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32());
            let f = if i % 4 == 0 { f.round() } else { f };
            let p = at.point(time, b.min + f * d);
            let out = (mb.min - p).max(p - mb.max).max_element();
            let scale = mb.min.abs().max(mb.max.abs()).max_element();
            worst = worst.max(out / scale);
        }
    }
    assert!(worst <= 0.0, "a position lies outside its motion bounds by {worst} relative");
}

/// Interval sums, differences, products, sines and cosines contain the exact
/// (double-precision) result for every pair of points drawn from the operands.
#[test]
fn interval_arithmetic_is_conservative() {
    let mut rng = Rng::new(29);
    let draw = |rng: &mut Rng| {
        let e = (rng.uniform_u32() % 20) as i32 - 10;
        let a = (rng.uniform_f32() * 2.0 - 1.0) * 2f32.powi(e);
        let b = a + rng.uniform_f32() * 2f32.powi(e);
        Interval::new(a, b)
    };
    let pick = |rng: &mut Rng, i: Interval| {
        let u = rng.uniform_f32();
        let x = i.low + u * (i.high - i.low);
        x.clamp(i.low, i.high) as f64
    };
    let inside = |x: f64, i: Interval| i.low as f64 <= x && x <= i.high as f64;
    for _ in 0..100_000 {
        let (a, b) = (draw(&mut rng), draw(&mut rng));
        let (x, y) = (pick(&mut rng, a), pick(&mut rng, b));
        assert!(inside(x + y, a + b), "{x}+{y} not in {:?}", a + b);
        assert!(inside(x - y, a - b), "{x}-{y} not in {:?}", a - b);
        assert!(inside(x * y, a * b), "{x}*{y} not in {:?}", a * b);
        let lo = rng.uniform_f32() * 6.0;
        let ang = Interval::new(lo, (lo + rng.uniform_f32() * 2.0).min(2.0 * std::f32::consts::PI));
        let z = pick(&mut rng, ang);
        assert!(inside(math::sin(z), ang.sin()), "sin {z} not in {:?}", ang.sin());
        assert!(inside(math::cos(z), ang.cos()), "cos {z} not in {:?}", ang.cos());
    }
}
