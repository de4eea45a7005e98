//! Image error metrics, as defined in the shared reference README.

use super::RgbImage;

/// How far an image is from a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageDiff {
    /// Mean over pixels and channels of (a − r)² / (r² + 0.01).
    pub rel_mse: f64,
    /// Mean squared error.
    pub mse: f64,
    /// Mean of |a − r|.
    pub mean_abs: f64,
    /// Largest |a − r|, and the pixel (x, y) where it is.
    pub max_abs: (f64, usize, usize),
    /// Mean value of the image and of the reference.
    pub means: (f64, f64),
    /// Non-finite values in the image.
    pub non_finite: usize,
    /// Non-finite values in the reference.
    pub non_finite_reference: usize,
}

/// Compares `a` to the reference `r` (same size required).
pub fn compare(a: &RgbImage, r: &RgbImage) -> Option<ImageDiff> {
    if a.width != r.width || a.height != r.height {
        return None;
    }
    let (mut rel, mut mse, mut abs, mut n) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    let (mut bad_a, mut bad_r) = (0, 0);
    let (mut sum_a, mut sum_r) = (0.0f64, 0.0f64);
    let mut max_abs = (0.0f64, 0, 0);
    for (i, (pa, pr)) in a.pixels.iter().zip(&r.pixels).enumerate() {
        for c in 0..3 {
            let (x, y) = (pa[c] as f64, pr[c] as f64);
            bad_a += !x.is_finite() as usize;
            bad_r += !y.is_finite() as usize;
            if x.is_finite() && y.is_finite() {
                let d = x - y;
                rel += d * d / (y * y + 0.01);
                mse += d * d;
                abs += d.abs();
                sum_a += x;
                sum_r += y;
                if d.abs() > max_abs.0 {
                    max_abs = (d.abs(), i % a.width.max(1), i / a.width.max(1));
                }
                n += 1;
            }
        }
    }
    let n = n.max(1) as f64;
    Some(ImageDiff {
        rel_mse: rel / n,
        mse: mse / n,
        mean_abs: abs / n,
        max_abs,
        means: (sum_a / n, sum_r / n),
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
        assert!((e.mean_abs - 0.1).abs() < 1e-6, "{}", e.mean_abs);
        assert!((e.max_abs.0 - 0.1).abs() < 1e-6 && e.max_abs.1 == 0 && e.max_abs.2 == 0);
        assert!((e.means.0 - 0.6).abs() < 1e-6 && (e.means.1 - 0.5).abs() < 1e-6);
    }
}
