//! What the dome's tests share: a TacTip-like spec and a few pins.

use tacsim_fem::{DomeSpec, Material, PinSite};

/// The calibrated TacTip's dome (R 20 mm, skin 0.66 mm of 1 MPa, gel 0.1 MPa) at `cells`.
pub fn spec(cells: usize) -> DomeSpec {
    DomeSpec {
        outer_radius_mm: 20.0,
        skin_thickness_mm: 0.66,
        skirt_mm: 0.0,
        skin: Material::new(1.0, 0.436).expect("skin"),
        gel: Material::new(0.1, 0.4999).expect("gel"),
        cells,
        skin_layers: if cells > 4 { 2 } else { 1 },
        skin_refinement: 1,
        refined_gel_shells: 0,
    }
}

/// The same dome with the skin's elements `refinement` times finer along the surface.
#[allow(dead_code)] // Not every test file builds a refined skin.
pub fn spec_refined(cells: usize, refinement: usize) -> DomeSpec {
    DomeSpec { skin_refinement: refinement, ..spec(cells) }
}

/// Pins at polar angles from the apex to near the rim, 2.84 mm posts on the inner face.
pub fn pins(patch_radius_mm: f64) -> Vec<PinSite> {
    let (inner, length) = (20.0 - 0.66, 2.84);
    [(0.0f64, 0.0f64), (10.0, 30.0), (20.0, 90.0), (40.0, 200.0), (70.0, 300.0)]
        .iter()
        .map(|&(polar, azimuth)| {
            let (t, p) = (polar.to_radians(), azimuth.to_radians());
            let n = [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
            PinSite { base: n.map(|v| v * inner), tip: n.map(|v| v * (inner - length)), patch_radius_mm }
        })
        .collect()
}
