//! pbrt-v3's transformation matrices (`core/transform.cpp`) in double
//! precision, and the pair of current transforms (`TransformSet`) that
//! `ActiveTransform` selects between.
//!
//! ```text
//! LookAt 0 7 15   0 0 0   0 0 1
//! Rotate 45 0 0 1
//! Transform [ 1 0 0 0  0 1 0 0  0 0 1 0  0 0 0 1 ]   # column-major
//! ```

use farm_common::math;
use glam::{DMat4, DVec3, DVec4};

/// pbrt-v3 `Translate(delta)`.
pub fn translate(d: DVec3) -> DMat4 {
    DMat4::from_translation(d)
}

/// pbrt-v3 `Scale(x, y, z)`.
pub fn scale(x: f64, y: f64, z: f64) -> DMat4 {
    DMat4::from_scale(DVec3::new(x, y, z))
}

/// pbrt-v3 `Rotate(theta, axis)`: `theta` degrees about the normalised axis,
/// with pbrt-v3's element formulas.
pub fn rotate(theta_deg: f64, axis: DVec3) -> DMat4 {
    let a = axis.normalize();
    let (sin, cos) = math::sin_cos(theta_deg.to_radians());
    // Rows of pbrt-v3's matrix m[i][j].
    let m = [
        [
            a.x * a.x + (1.0 - a.x * a.x) * cos,
            a.x * a.y * (1.0 - cos) - a.z * sin,
            a.x * a.z * (1.0 - cos) + a.y * sin,
            0.0,
        ],
        [
            a.x * a.y * (1.0 - cos) + a.z * sin,
            a.y * a.y + (1.0 - a.y * a.y) * cos,
            a.y * a.z * (1.0 - cos) - a.x * sin,
            0.0,
        ],
        [
            a.x * a.z * (1.0 - cos) - a.y * sin,
            a.y * a.z * (1.0 - cos) + a.x * sin,
            a.z * a.z + (1.0 - a.z * a.z) * cos,
            0.0,
        ],
        [0.0, 0.0, 0.0, 1.0],
    ];
    from_rows(m)
}

/// pbrt-v3 `LookAt(pos, look, up)`: the camera-from-world matrix. `None` when
/// `up` is parallel to the viewing direction (pbrt-v3 then uses the identity).
pub fn look_at(pos: DVec3, look: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (look - pos).normalize();
    let cross = up.normalize().cross(dir);
    if cross.length() == 0.0 {
        return None;
    }
    let right = cross.normalize();
    let new_up = dir.cross(right);
    let world_from_camera = DMat4::from_cols(
        right.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        DVec4::new(pos.x, pos.y, pos.z, 1.0),
    );
    Some(world_from_camera.inverse())
}

/// The matrix of `Transform`/`ConcatTransform`'s 16 numbers, which pbrt-v3
/// reads in column-major order.
pub fn from_column_major(v: &[f64; 16]) -> DMat4 {
    DMat4::from_cols_array(v)
}

/// A matrix given by rows, as pbrt-v3's `Matrix4x4` constructor takes them.
pub fn from_rows(m: [[f64; 4]; 4]) -> DMat4 {
    DMat4::from_cols_array_2d(&m).transpose()
}

/// pbrt-v3's two current transforms (shutter open and close) and which of
/// them the transform directives change.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransformSet {
    /// `[start, end]`.
    pub t: [DMat4; 2],
    /// Bit 0: start is active; bit 1: end is active.
    pub active: u8,
}

impl Default for TransformSet {
    fn default() -> Self {
        TransformSet { t: [DMat4::IDENTITY; 2], active: 0b11 }
    }
}

impl TransformSet {
    /// Applies `f` to each active transform.
    pub fn update(&mut self, f: impl Fn(DMat4) -> DMat4) {
        for i in 0..2 {
            if self.active & (1 << i) != 0 {
                self.t[i] = f(self.t[i]);
            }
        }
    }

    /// Post-multiplies each active transform by `m` (pbrt-v3 `ct = ct * m`).
    pub fn concat(&mut self, m: DMat4) {
        self.update(|t| t * m);
    }

    /// Whether the two transforms differ.
    pub fn is_animated(&self) -> bool {
        self.t[0] != self.t[1]
    }

    /// Both transforms inverted.
    pub fn inverse(&self) -> [DMat4; 2] {
        [self.t[0].inverse(), self.t[1].inverse()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DMat4, b: DMat4) -> bool {
        a.abs_diff_eq(b, 1e-12)
    }

    #[test]
    fn rotate_z_90_maps_x_to_y() {
        let r = rotate(90.0, DVec3::Z);
        assert!(r.transform_point3(DVec3::X).abs_diff_eq(DVec3::Y, 1e-15));
        // Rotation about an arbitrary axis keeps the axis and is orthonormal.
        let axis = DVec3::new(-1.0, 1.0, 1.0);
        let r = rotate(65.0, axis);
        assert!(r.transform_vector3(axis).abs_diff_eq(axis, 1e-12));
        assert!(close(r * r.transpose(), DMat4::IDENTITY));
    }

    #[test]
    fn rotate_matches_hand_computed_matrix() {
        // 90 degrees about x: y -> z, z -> -y.
        let r = rotate(90.0, DVec3::new(2.0, 0.0, 0.0));
        let want = from_rows([
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, -1.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ]);
        assert!(close(r, want), "{r:?}");
    }

    #[test]
    fn look_at_is_camera_from_world() {
        // Eye at (0,0,5) looking at the origin with +y up: camera +z is world -z,
        // camera +x (right = up x dir) is world -x.
        let m = look_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y).unwrap();
        let want = from_rows([
            [-1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0, 5.0],
            [0.0, 0.0, 0.0, 1.0],
        ]);
        assert!(close(m, want), "{m:?}");
        assert!(m.transform_point3(DVec3::ZERO).abs_diff_eq(DVec3::new(0.0, 0.0, 5.0), 1e-12));
        assert!(look_at(DVec3::ZERO, DVec3::Z, DVec3::Z).is_none());
    }

    #[test]
    fn column_major_puts_translation_last() {
        let mut v = [0.0; 16];
        for i in [0, 5, 10, 15] {
            v[i] = 1.0;
        }
        v[12] = 3.0;
        v[13] = 4.0;
        v[14] = 5.0;
        let m = from_column_major(&v);
        assert_eq!(m.transform_point3(DVec3::ZERO), DVec3::new(3.0, 4.0, 5.0));
    }

    #[test]
    fn active_bits_select_transforms() {
        let mut ts = TransformSet { active: 0b10, ..Default::default() };
        ts.concat(translate(DVec3::X));
        assert_eq!(ts.t[0], DMat4::IDENTITY);
        assert!(ts.is_animated());
        assert_eq!(ts.inverse()[1].transform_point3(DVec3::X), DVec3::ZERO);
    }
}
