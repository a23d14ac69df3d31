//! Isotropic linear-elastic materials, split into the deviatoric and volumetric parts that the
//! element treats differently (see [`crate::element`]).

use crate::error::{FemError, Result};

/// Largest Poisson's ratio a material may have: at 0.5 the bulk modulus is infinite. The
/// elements do not lock up to it (test `lame_sphere_does_not_lock_at_poisson_0_4999`).
pub const MAX_POISSON: f64 = 0.4999;

/// An isotropic linear-elastic material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Young's modulus `E` (MPa).
    pub youngs_modulus_mpa: f64,
    /// Poisson's ratio `nu`, in `[0, MAX_POISSON]`.
    pub poisson: f64,
}

impl Material {
    /// A checked material: `E > 0` (MPa, at most 1e6), `0 <= nu <= 0.4999`.
    pub fn new(youngs_modulus_mpa: f64, poisson: f64) -> Result<Self> {
        if !(youngs_modulus_mpa > 0.0 && youngs_modulus_mpa <= 1e6) {
            return Err(FemError::Parameter {
                field: "youngs_modulus_mpa",
                value: youngs_modulus_mpa,
                expected: "a Young's modulus in (0, 1e6] MPa",
            });
        }
        if !(0.0..=MAX_POISSON).contains(&poisson) {
            return Err(FemError::Parameter {
                field: "poisson",
                value: poisson,
                expected: "a Poisson's ratio in [0, 0.4999] (0.5 is incompressible: use 0.4999)",
            });
        }
        Ok(Self { youngs_modulus_mpa, poisson })
    }

    /// Shear modulus `mu = E / (2 (1 + nu))` (MPa).
    pub fn shear_modulus_mpa(&self) -> f64 {
        self.youngs_modulus_mpa / (2.0 * (1.0 + self.poisson))
    }

    /// Bulk modulus `kappa = E / (3 (1 - 2 nu))` (MPa).
    pub fn bulk_modulus_mpa(&self) -> f64 {
        self.youngs_modulus_mpa / (3.0 * (1.0 - 2.0 * self.poisson))
    }
}
