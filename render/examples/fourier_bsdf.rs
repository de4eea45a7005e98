//! Writes the layerlab-format (`SCATFUN`) BSDF tables that
//! `scenes/parity/fourier.pbrt` uses: no real layerlab file is at hand, so
//! these are computed here from a closed form, a diffuse base under a
//! glossy lobe around the mirror direction (exp(κ(cos γ − 1)), whose cosine
//! series in φ are modified Bessel functions), plus, for the coloured one,
//! diffuse transmission through a boundary of relative index 1.5.
//!
//! ```sh
//! cargo run --release -p farm-render --example fourier_bsdf -- scenes/parity/bsdfs
//! ```

use farm_common::math;
use farm_render::bxdf::FourierTable;
use std::f64::consts::PI;
use std::path::PathBuf;

/// The closed form's parameters, per channel (Y, R, B) where they vary.
struct Layered {
    /// Diffuse reflectance per channel.
    kd: Vec<f64>,
    /// Glossy lobe's weight and sharpness.
    ks: f64,
    kappa: f64,
    /// Diffuse transmittance (same in every channel).
    kt: f64,
}

/// Cosine series of exp(z cos φ) (its coefficients are I₀(z), 2Iₖ(z)), by
/// the midpoint rule, up to the last term above `tol` of the first.
fn bessel_series(z: f64, tol: f64, max: usize) -> Vec<f64> {
    let steps = 1024;
    let mut a = Vec::new();
    for k in 0..max {
        let mut s = 0.0;
        for j in 0..steps {
            let phi = PI * (j as f64 + 0.5) / steps as f64;
            s += math::exp(z * (math::cos(phi) - 1.0)) * math::cos(k as f64 * phi);
        }
        let ak = s / steps as f64 * if k == 0 { 1.0 } else { 2.0 };
        if k > 0 && ak.abs() < tol * a[0] {
            break;
        }
        a.push(ak);
    }
    a
}

impl Layered {
    /// The stored series for (μo, μi): f·|μi| in each channel, concatenated.
    /// pbrt-v3's μi is the cosine of −wi, so reflection is μi·μo < 0.
    fn series(&self, mo: f64, mi: f64) -> Vec<f32> {
        let channels = self.kd.len();
        if mo * mi > 0.0 {
            return (0..channels).map(|_| (self.kt / PI * mi.abs()) as f32).collect();
        }
        let (so, si) = ((1.0 - mo * mo).max(0.0).sqrt(), (1.0 - mi * mi).max(0.0).sqrt());
        // cos γ = sᵢsₒ cos φ − μᵢμₒ; exp(κ(cos γ − 1)) = e^{κ(sᵢsₒ − μᵢμₒ − 1)} e^{κsᵢsₒ(cos φ − 1)}.
        let z = self.kappa * si * so;
        let outer = math::exp(self.kappa * (si * so - mi * mo - 1.0));
        let norm = self.ks * self.kappa / (2.0 * PI * (1.0 - math::exp(-2.0 * self.kappa)));
        let lobe: Vec<f64> = bessel_series(z, 1e-4, 64).iter().map(|a| a * outer * norm).collect();
        let mut out = Vec::with_capacity(channels * lobe.len());
        for kd in &self.kd {
            for (k, a) in lobe.iter().enumerate() {
                let diffuse = if k == 0 { kd / PI } else { 0.0 };
                out.push(((a + diffuse) * mi.abs()) as f32);
            }
        }
        out
    }

    fn write(&self, n: usize, eta: f32) -> Vec<u8> {
        // Chebyshev–Lobatto nodes, dense at the poles as layerlab's are.
        let mu: Vec<f32> =
            (0..n).map(|j| -math::cos(PI * j as f64 / (n - 1) as f64) as f32).collect();
        let mut all = Vec::with_capacity(n * n);
        for &mo in &mu {
            for &mi in &mu {
                all.push(self.series(mo as f64, mi as f64));
            }
        }
        FourierTable::to_bytes(eta, &mu, self.kd.len(), &all)
    }
}

fn main() -> std::io::Result<()> {
    let dir =
        PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "scenes/parity/bsdfs".into()));
    std::fs::create_dir_all(&dir)?;
    let grey = Layered { kd: vec![0.35], ks: 0.6, kappa: 14.0, kt: 0.0 };
    // Y, R, B of a red base.
    let (r, g, b) = (0.65, 0.12, 0.08);
    let y = 0.212671 * r + 0.715160 * g + 0.072169 * b;
    let red = Layered { kd: vec![y, r, b], ks: 0.4, kappa: 24.0, kt: 0.2 };
    for (name, bytes) in
        [("glossy-grey.bsdf", grey.write(24, 1.0)), ("coated-red.bsdf", red.write(24, 1.5))]
    {
        let t = FourierTable::read(&bytes).expect("a table this writes reads back");
        println!(
            "{name}: {} bytes, {} channels, longest series {}",
            bytes.len(),
            t.n_channels,
            t.m_max
        );
        std::fs::write(dir.join(name), bytes)?;
    }
    Ok(())
}
