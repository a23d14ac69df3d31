//! The stimulus catalogue: a TOML file listing each shape's OBJ file, material, friction and
//! (for the training shapes) the contact location used for data collection.
//!
//! ```toml
//! [[shape]]
//! name = "disk"
//! file = "disk.obj"
//! material = "ABS"
//! friction = 0.5
//! description = "disk, 100 mm diameter"
//! contact_mm = [50.0, 0.0]   # optional, a point on the edge (object frame)
//! ```

use std::path::Path;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::error::{Result, SimError};
use crate::stimulus::Contour;
use crate::stimulus::Mesh;

/// Largest friction coefficient accepted.
pub const MAX_FRICTION: f64 = 2.0;
/// Largest edge rounding accepted (mm).
pub const MAX_EDGE_RADIUS_MM: f64 = 10.0;
/// How far (mm) a declared contact location may lie from the shape's edge.
pub const CONTACT_TOLERANCE_MM: f64 = 0.5;

/// One catalogue entry, as written in the TOML file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShapeEntry {
    /// Unique name (`disk`, `clover`, ...).
    pub name: String,
    /// OBJ file, relative to the catalogue.
    pub file: String,
    /// Material name (`ABS`, `acrylic`, ...).
    pub material: String,
    /// Coulomb friction coefficient between the sensor skin and this stimulus.
    pub friction: f64,
    /// One-line description with the main dimensions.
    #[serde(default)]
    pub description: String,
    /// Contact location on the edge used for data collection (mm, object frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_mm: Option<[f64; 2]>,
    /// Radius (mm) of the rounding of the top face's edge (a quarter circle from the top face
    /// down the wall; 0: sharp). The contact engine sees it ([`Stimulus::drop_below_top_mm`]);
    /// the mesh, the ray casts of the renderer and the contour keep the sharp edge.
    #[serde(default, skip_serializing_if = "crate::sensor::is_zero")]
    pub edge_radius_mm: f64,
}

#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CatalogueFile {
    #[serde(default)]
    shape: Vec<ShapeEntry>,
}

/// A loaded stimulus: its entry, mesh and top-face contour.
#[derive(Clone, Debug)]
pub struct Stimulus {
    /// Catalogue entry.
    pub entry: ShapeEntry,
    /// Closed triangle mesh (mm, object frame).
    pub mesh: Mesh,
    /// Top-face contour (mm, object frame).
    pub contour: Contour,
}

impl Stimulus {
    /// This stimulus with the skin-stimulus friction `friction` where one is given (a recipe's
    /// or a scenario's override), else itself.
    pub fn with_friction(self: &Arc<Self>, friction: Option<f64>) -> Arc<Self> {
        self.overridden(friction, |e, f| e.friction = f)
    }

    /// This stimulus with its top face's edge rounded to `radius_mm` where one is given (a
    /// recipe's override), else itself. The radius must lie in `[0, MAX_EDGE_RADIUS_MM]`.
    pub fn with_edge_radius(self: &Arc<Self>, radius_mm: Option<f64>) -> Arc<Self> {
        self.overridden(radius_mm, |e, r| e.edge_radius_mm = r)
    }

    /// Itself without `value`, else a copy whose entry `set` changed.
    fn overridden(self: &Arc<Self>, value: Option<f64>, set: impl FnOnce(&mut ShapeEntry, f64)) -> Arc<Self> {
        match value {
            None => Arc::clone(self),
            Some(v) => {
                let mut s = (**self).clone();
                set(&mut s.entry, v);
                Arc::new(s)
            }
        }
    }

    /// How far (mm) the rounded edge lies below the top face at a top-face point whose
    /// signed distance to the contour is `signed_distance_mm` (negative over the material):
    /// `r - sqrt(r^2 - (r - s)^2)` at `s = -signed_distance_mm < r` inside the edge's radius
    /// `r`, 0 farther in.
    pub fn drop_below_top_mm(&self, signed_distance_mm: f64) -> f64 {
        let r = self.entry.edge_radius_mm;
        let s = -signed_distance_mm;
        if r <= 0.0 || s >= r {
            return 0.0;
        }
        let u = (r - s).min(r);
        r - (r * r - u * u).max(0.0).sqrt()
    }

    /// Name of the stimulus.
    pub fn name(&self) -> &str {
        &self.entry.name
    }

    /// Bounding-box extent `[x, y, z]` (mm).
    pub fn extent_mm(&self) -> [f64; 3] {
        let (lo, hi) = self.mesh.bounds();
        [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]]
    }
}

/// Why the contact point `c` (object frame, mm) is not on the edge of `contour` (shape
/// `name`), or `None` when it lies within [`CONTACT_TOLERANCE_MM`] of it.
pub fn off_the_edge(contour: &Contour, c: [f64; 2], name: &str) -> Option<String> {
    let d = contour.signed_distance(c);
    (d.abs() > CONTACT_TOLERANCE_MM)
        .then(|| format!("{c:?} is {d:.2} mm from the edge of `{name}` (must be within {CONTACT_TOLERANCE_MM} mm)"))
}

/// Checks an edge rounding radius (mm) read from `source_name`'s `field`.
pub fn check_edge_radius(radius_mm: f64, source_name: &str, field: &str) -> Result<()> {
    if radius_mm.is_finite() && (0.0..=MAX_EDGE_RADIUS_MM).contains(&radius_mm) {
        Ok(())
    } else {
        Err(SimError::invalid(
            source_name,
            field,
            format!("must be a finite number in [0, {MAX_EDGE_RADIUS_MM}] mm, got {radius_mm}"),
        ))
    }
}

/// All stimuli of a catalogue.
#[derive(Clone, Debug, Default)]
pub struct Catalogue {
    /// Stimuli in catalogue order.
    pub stimuli: Vec<Arc<Stimulus>>,
}

impl Catalogue {
    /// Parses a catalogue. `read_obj(file)` returns the OBJ text and its display name.
    pub fn parse(
        toml_text: &str,
        source_name: &str,
        mut read_obj: impl FnMut(&str) -> Result<(String, String)>,
    ) -> Result<Self> {
        let file: CatalogueFile = toml::from_str(toml_text)
            .map_err(|e| SimError::Toml { source_name: source_name.to_owned(), message: e.to_string() })?;
        let mut stimuli: Vec<Arc<Stimulus>> = Vec::new();
        for (i, entry) in file.shape.into_iter().enumerate() {
            let field = |f: &str| format!("shape[{i}].{f}");
            if entry.name.trim().is_empty() {
                return Err(SimError::invalid(source_name, field("name"), "must not be empty"));
            }
            if stimuli.iter().any(|s| s.entry.name == entry.name) {
                return Err(SimError::invalid(source_name, field("name"), format!("`{}` appears twice", entry.name)));
            }
            if !(entry.friction.is_finite() && (0.0..=MAX_FRICTION).contains(&entry.friction)) {
                return Err(SimError::invalid(
                    source_name,
                    field("friction"),
                    format!("must be a finite number in [0, {MAX_FRICTION}], got {}", entry.friction),
                ));
            }
            check_edge_radius(entry.edge_radius_mm, source_name, &field("edge_radius_mm"))?;
            let (text, obj_name) = read_obj(&entry.file)?;
            let mesh = Mesh::from_obj_str(&text, &obj_name)?;
            let contour = Contour::from_mesh(&mesh, &obj_name)?;
            if let Some(c) = entry.contact_mm {
                if !c.iter().all(|v| v.is_finite()) {
                    return Err(SimError::invalid(source_name, field("contact_mm"), "must be finite"));
                }
                if let Some(reason) = off_the_edge(&contour, c, &entry.name) {
                    return Err(SimError::invalid(source_name, field("contact_mm"), reason));
                }
            }
            stimuli.push(Arc::new(Stimulus { entry, mesh, contour }));
        }
        if stimuli.is_empty() {
            return Err(SimError::invalid(source_name, "shape", "the catalogue lists no shapes"));
        }
        Ok(Self { stimuli })
    }

    /// Loads `catalogue.toml` and its OBJ files from `dir`.
    pub fn load_dir(dir: &Path) -> Result<Self> {
        let path = dir.join("catalogue.toml");
        let text = std::fs::read_to_string(&path).map_err(|e| SimError::io(&path, "read", e))?;
        Self::parse(&text, &path.display().to_string(), |file| {
            let p = dir.join(file);
            let text = std::fs::read_to_string(&p).map_err(|e| SimError::io(&p, "read", e))?;
            Ok((text, p.display().to_string()))
        })
    }

    /// The stimulus called `name`.
    pub fn get(&self, name: &str) -> Result<Arc<Stimulus>> {
        self.stimuli.iter().find(|s| s.entry.name == name).cloned().ok_or_else(|| SimError::Unknown {
            kind: "shape",
            name: name.to_owned(),
            known: self.names().join(", "),
        })
    }

    /// Names in catalogue order.
    pub fn names(&self) -> Vec<String> {
        self.stimuli.iter().map(|s| s.entry.name.clone()).collect()
    }

    /// Serialises entries back to catalogue TOML.
    pub fn entries_to_toml(entries: &[ShapeEntry]) -> String {
        toml::to_string_pretty(&CatalogueFile { shape: entries.to_vec() }).unwrap_or_default()
    }
}
