//! Image error metrics, as defined in the shared reference README.

use crate::output::RgbImage;

/// How far an image is from a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    /// Mean over pixels and channels of (a − r)² / (r² + 0.01).
    pub rel_mse: f64,
    /// Mean squared error.
    pub mse: f64,
    /// Non-finite values in the image.
    pub non_finite: usize,
    /// Non-finite values in the reference.
    pub non_finite_reference: usize,
}

/// Compares `a` to the reference `r` (same size required).
pub fn compare(a: &RgbImage, r: &RgbImage) -> Option<ImageError> {
    if a.width != r.width || a.height != r.height {
        return None;
    }
    let (mut rel, mut mse, mut n) = (0.0f64, 0.0f64, 0usize);
    let (mut bad_a, mut bad_r) = (0, 0);
    for (pa, pr) in a.pixels.iter().zip(&r.pixels) {
        for c in 0..3 {
            let (x, y) = (pa[c] as f64, pr[c] as f64);
            bad_a += !x.is_finite() as usize;
            bad_r += !y.is_finite() as usize;
            if x.is_finite() && y.is_finite() {
                let d = x - y;
                rel += d * d / (y * y + 0.01);
                mse += d * d;
                n += 1;
            }
        }
    }
    let n = n.max(1) as f64;
    Some(ImageError {
        rel_mse: rel / n,
        mse: mse / n,
        non_finite: bad_a,
        non_finite_reference: bad_r,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rel_mse_follows_the_readme_formula() {
        let r = RgbImage { width: 1, height: 1, pixels: vec![[1.0, 0.0, 0.1]] };
        let a = RgbImage { width: 1, height: 1, pixels: vec![[1.1, 0.1, f32::NAN]] };
        let e = compare(&a, &r).unwrap();
        let want = (0.01f64 / 1.01 + 0.01 / 0.01) / 2.0;
        assert!((e.rel_mse - want).abs() < 1e-6, "{}", e.rel_mse);
        assert_eq!(e.non_finite, 1);
    }
}
