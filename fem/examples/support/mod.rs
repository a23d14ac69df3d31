//! What the examples share: the TacTip-like dome and the default sensor's pins on it.

use tacsim_fem::{DomeSpec, Material, PinSite, Result};

/// Outer radius, skin thickness and pin length (mm) of the calibrated TacTip.
pub const SIZES_MM: (f64, f64, f64) = (20.0, 0.66, 2.84);

/// Skin thickness and pin length (mm) and the gel's modulus (MPa) of the default sensor's dome
/// (`sim/presets/tactip-331-dome.toml`: the same radius, skin modulus and pins' tips).
#[allow(dead_code)] // not every example reads it
pub const DEFAULT_DOME: (f64, f64, f64) = (1.860534495223869, 1.639465504776131, 0.017677669529663695);

/// The calibrated TacTip's dome (R 20 mm, skin 0.66 mm of 1 MPa / 0.436, gel 0.1 MPa /
/// 0.4999) at `cells`, `skin_layers`, `skin_refinement` and `refined_gel_shells`.
pub fn spec(cells: usize, skin_layers: usize, skin_refinement: usize, refined_gel_shells: usize) -> Result<DomeSpec> {
    let (r, t, _) = SIZES_MM;
    Ok(DomeSpec {
        outer_radius_mm: r,
        skin_thickness_mm: t,
        skirt_mm: 0.0,
        skin: Material::new(1.0, 0.436)?,
        gel: Material::new(0.1, 0.4999)?,
        cells,
        skin_layers,
        skin_refinement,
        refined_gel_shells,
    })
}

/// The default sensor's 331 pins: 10 rings 4.536 deg apart, `6 k` pins on ring `k`, bases on
/// the skin's inner face.
#[allow(dead_code)] // not every example reads the pins
pub fn rings(patch_radius_mm: f64) -> Vec<PinSite> {
    let (_, t, pin_length) = SIZES_MM;
    rings_of(t, pin_length, patch_radius_mm)
}

/// [`rings`] on a skin `t` mm thick with pins `pin_length` mm long.
#[allow(dead_code)] // not every example reads the pins
pub fn rings_of(t: f64, pin_length: f64, patch_radius_mm: f64) -> Vec<PinSite> {
    let (r, _, _) = SIZES_MM;
    let mut sites = Vec::new();
    for ring in 0..=10usize {
        for j in 0..(6 * ring).max(1) {
            let th = (ring as f64 * 4.536_447).to_radians();
            let ph = -0.358f64.to_radians() + std::f64::consts::TAU * j as f64 / (6 * ring).max(1) as f64;
            let n = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
            sites.push(PinSite {
                base: n.map(|v| v * (r - t)),
                tip: n.map(|v| v * (r - t - pin_length)),
                patch_radius_mm,
            });
        }
    }
    sites
}
