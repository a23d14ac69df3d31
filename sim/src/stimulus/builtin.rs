//! The built-in stimuli: the planar shapes of the lab's experiments, sized like the 3D-printed
//! (ABS) and laser-cut (acrylic) originals. `cargo xtask shapes` writes them to `shapes/`.
//!
//! Friction coefficients are assumptions until calibrated against sliding recordings:
//! silicone skin on printed ABS 0.5, on smooth acrylic 0.35 (lower, as the paper notes).

use crate::stimulus::catalogue::ShapeEntry;
use crate::stimulus::outline::Outline;

/// Maximum segment length (mm) of the committed OBJ tessellations.
pub const SEGMENT_MM: f64 = 0.5;

/// A built-in shape: outline, extrusion height and catalogue data.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeSpec {
    /// Catalogue entry (name, file, material, friction, contact location).
    pub entry: ShapeEntry,
    /// Planar outline (mm, object frame).
    pub outline: Outline,
    /// Extrusion height (mm).
    pub height_mm: f64,
}

fn spec(
    name: &str,
    material: &str,
    friction: f64,
    height_mm: f64,
    description: &str,
    outline: Outline,
    contact_mm: Option<[f64; 2]>,
) -> ShapeSpec {
    ShapeSpec {
        entry: ShapeEntry {
            name: name.to_owned(),
            file: format!("{name}.obj"),
            material: material.to_owned(),
            friction,
            description: description.to_owned(),
            contact_mm,
        },
        outline,
        height_mm,
    }
}

/// The seven built-in stimuli. Training shapes (disk, clover, teardrop) carry the contact
/// location of the paper's data collection: a point on the edge where the sensor is tapped.
pub fn builtin_shapes() -> Vec<ShapeSpec> {
    const ABS: f64 = 0.5;
    const ACRYLIC: f64 = 0.35;
    let (big, small, dist) = (30.0, 6.0, 62.0);
    // Midpoint of the teardrop's upper straight flank.
    let beta = f64::acos((big - small) / dist);
    let teardrop_contact =
        [0.5 * (big * beta.cos() + dist + small * beta.cos()), 0.5 * (big * beta.sin() + small * beta.sin())];
    vec![
        spec("disk", "ABS", ABS, 10.0, "disk, 100 mm diameter", Outline::Disk { radius_mm: 50.0 }, Some([50.0, 0.0])),
        spec(
            "clover",
            "ABS",
            ABS,
            10.0,
            "four-lobed clover r = 42 + 8 cos(4 theta) mm, 100 mm across",
            Outline::Clover { base_mm: 42.0, amplitude_mm: 8.0, lobes: 4 },
            Some([50.0, 0.0]),
        ),
        spec(
            "teardrop",
            "ABS",
            ABS,
            10.0,
            "teardrop: hull of 30 mm and 6 mm radius circles 62 mm apart, 98 mm long",
            Outline::Teardrop { big_radius_mm: big, small_radius_mm: small, distance_mm: dist },
            Some(teardrop_contact),
        ),
        spec("square", "ABS", ABS, 10.0, "square, 90 mm side, sharp corners", Outline::Square { side_mm: 90.0 }, None),
        spec(
            "foil",
            "ABS",
            ABS,
            10.0,
            "symmetric NACA 0025 aerofoil, 110 mm chord, closed trailing edge",
            Outline::Foil { chord_mm: 110.0, thickness: 0.25 },
            None,
        ),
        spec(
            "spiral-1",
            "acrylic",
            ACRYLIC,
            6.0,
            "acrylic spiral strip, 14 mm wide, pitch 40 mm, 1.25 turns",
            Outline::Spiral { start_radius_mm: 10.0, pitch_mm: 40.0, turns: 1.25, width_mm: 14.0 },
            None,
        ),
        spec(
            "spiral-2",
            "acrylic",
            ACRYLIC,
            6.0,
            "acrylic spiral strip, 12 mm wide, pitch 36 mm, 1.5 turns",
            Outline::Spiral { start_radius_mm: 8.0, pitch_mm: 36.0, turns: 1.5, width_mm: 12.0 },
            None,
        ),
    ]
}
