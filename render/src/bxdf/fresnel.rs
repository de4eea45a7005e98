//! Fresnel reflectance (pbrt-v3 `FrDielectric`, `FrConductor` and the
//! `Fresnel` classes of `core/reflection.h`).

use farm_common::Spectrum;

/// Fraction of light reflected by a dielectric interface for incident
/// cosine `cos_theta_i` (negative when arriving from inside `eta_t`).
pub fn fr_dielectric(cos_theta_i: f32, eta_i: f32, eta_t: f32) -> f32 {
    let mut cos_theta_i = cos_theta_i.clamp(-1.0, 1.0);
    let (mut eta_i, mut eta_t) = (eta_i, eta_t);
    if cos_theta_i <= 0.0 {
        std::mem::swap(&mut eta_i, &mut eta_t);
        cos_theta_i = cos_theta_i.abs();
    }
    let sin_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt();
    let sin_theta_t = eta_i / eta_t * sin_theta_i;
    if sin_theta_t >= 1.0 {
        return 1.0;
    }
    let cos_theta_t = (1.0 - sin_theta_t * sin_theta_t).max(0.0).sqrt();
    let r_parl = ((eta_t * cos_theta_i) - (eta_i * cos_theta_t))
        / ((eta_t * cos_theta_i) + (eta_i * cos_theta_t));
    let r_perp = ((eta_i * cos_theta_i) - (eta_t * cos_theta_t))
        / ((eta_i * cos_theta_i) + (eta_t * cos_theta_t));
    (r_parl * r_parl + r_perp * r_perp) / 2.0
}

/// Fresnel reflectance of a conductor with complex index `eta_t + i k`
/// seen from a medium of index `eta_i`, per channel.
pub fn fr_conductor(cos_theta_i: f32, eta_i: Spectrum, eta_t: Spectrum, k: Spectrum) -> Spectrum {
    let cos_theta_i = cos_theta_i.clamp(-1.0, 1.0);
    let eta = eta_t / eta_i;
    let etak = k / eta_i;
    let cos2 = cos_theta_i * cos_theta_i;
    let sin2 = 1.0 - cos2;
    let eta2 = eta * eta;
    let etak2 = etak * etak;
    let t0 = eta2 - etak2 - sin2;
    let a2plusb2 = (t0 * t0 + eta2 * etak2 * 4.0).sqrt();
    let t1 = a2plusb2 + cos2;
    let a = ((a2plusb2 + t0) * 0.5).sqrt();
    let t2 = a * (2.0 * cos_theta_i);
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = a2plusb2 * cos2 + Spectrum::splat(sin2 * sin2);
    let t4 = t2 * sin2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    (rp + rs) * 0.5
}

/// A Fresnel term for specular and microfacet lobes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fresnel {
    /// Reflects everything (pbrt-v3 `FresnelNoOp`).
    NoOp,
    /// A dielectric interface (pbrt-v3 `FresnelDielectric`).
    Dielectric {
        /// Index on the outside.
        eta_i: f32,
        /// Index on the inside.
        eta_t: f32,
    },
    /// A conductor (pbrt-v3 `FresnelConductor`).
    Conductor {
        /// Index of the outside medium.
        eta_i: Spectrum,
        /// The conductor's index.
        eta_t: Spectrum,
        /// Its absorption coefficient.
        k: Spectrum,
    },
    /// pbrt-v3's `DisneyFresnel`: a dielectric's Fresnel blended by
    /// `metallic` toward Schlick's from the specular colour `r0`.
    Disney {
        /// Reflectance at normal incidence.
        r0: Spectrum,
        /// Metallic weight.
        metallic: f32,
        /// Index of refraction.
        eta: f32,
    },
}

impl Fresnel {
    /// Reflectance for incident cosine `cos_theta_i`.
    #[inline]
    pub fn evaluate(&self, cos_theta_i: f32) -> Spectrum {
        match *self {
            Fresnel::NoOp => Spectrum::ONE,
            Fresnel::Dielectric { eta_i, eta_t } => {
                Spectrum::splat(fr_dielectric(cos_theta_i, eta_i, eta_t))
            }
            Fresnel::Conductor { eta_i, eta_t, k } => {
                fr_conductor(cos_theta_i.abs(), eta_i, eta_t, k)
            }
            Fresnel::Disney { r0, metallic, eta } => {
                let dielectric = Spectrum::splat(fr_dielectric(cos_theta_i, 1.0, eta));
                let schlick = super::disney::fr_schlick(r0, cos_theta_i);
                dielectric * (1.0 - metallic) + schlick * metallic
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_normal_incidence() {
        let f = fr_dielectric(1.0, 1.0, 1.5);
        assert!((f - 0.04).abs() < 1e-6, "{f}");
        // Same from inside, and total internal reflection at grazing angles.
        assert!((fr_dielectric(-1.0, 1.0, 1.5) - 0.04).abs() < 1e-6);
        assert_eq!(fr_dielectric(-0.1, 1.0, 1.5), 1.0);
        assert!((fr_dielectric(0.0001, 1.0, 1.5) - 1.0).abs() < 1e-2);
    }

    #[test]
    fn conductor_matches_dielectric_without_absorption() {
        let c = fr_conductor(0.7, Spectrum::ONE, Spectrum::splat(1.5), Spectrum::ZERO);
        let d = fr_dielectric(0.7, 1.0, 1.5);
        assert!((c.r - d).abs() < 1e-5, "{c:?} {d}");
        let normal = fr_conductor(1.0, Spectrum::ONE, Spectrum::splat(0.2), Spectrum::splat(3.0));
        let expect = ((0.2f32 - 1.0).powi(2) + 9.0) / ((0.2f32 + 1.0).powi(2) + 9.0);
        assert!((normal.r - expect).abs() < 1e-5, "{normal:?} {expect}");
    }
}
