//! The built-in stimuli of `shapes/` and dataset recipes of `scenarios/datasets/`, compiled in so
//! that the `tacsim` binary and the Python package run from any directory without the
//! repository. `cargo xtask shapes` regenerates the files; a test keeps this list and the
//! directory in step.

use crate::SimError;
use crate::stimulus::Catalogue;

/// `(file name, contents)` of every file in `shapes/`.
pub const SHAPE_FILES: &[(&str, &str)] = &[
    ("catalogue.toml", include_str!("../../shapes/catalogue.toml")),
    ("clover.obj", include_str!("../../shapes/clover.obj")),
    ("disk.obj", include_str!("../../shapes/disk.obj")),
    ("foil.obj", include_str!("../../shapes/foil.obj")),
    ("spiral-1.obj", include_str!("../../shapes/spiral-1.obj")),
    ("spiral-2.obj", include_str!("../../shapes/spiral-2.obj")),
    ("square.obj", include_str!("../../shapes/square.obj")),
    ("teardrop.obj", include_str!("../../shapes/teardrop.obj")),
];

/// `(name, contents)` of the dataset recipes of `scenarios/datasets/`.
pub const RECIPES: &[(&str, &str)] = &[
    ("edge-2d", include_str!("../../scenarios/datasets/edge-2d.toml")),
    ("paper", include_str!("../../scenarios/datasets/paper.toml")),
    ("quick", include_str!("../../scenarios/datasets/quick.toml")),
    ("study", include_str!("../../scenarios/datasets/study.toml")),
    ("study-quick", include_str!("../../scenarios/datasets/study-quick.toml")),
    ("surface-3d", include_str!("../../scenarios/datasets/surface-3d.toml")),
    ("surface-3d-dome", include_str!("../../scenarios/datasets/surface-3d-dome.toml")),
    ("tilted-surface", include_str!("../../scenarios/datasets/tilted-surface.toml")),
    ("twist", include_str!("../../scenarios/datasets/twist.toml")),
];

/// The built-in catalogue.
pub fn catalogue() -> Result<Catalogue, SimError> {
    let find = |name: &str| SHAPE_FILES.iter().find(|(n, _)| *n == name).map(|(_, text)| *text);
    let toml = find("catalogue.toml").unwrap_or_default();
    Catalogue::parse(toml, "built-in shapes/catalogue.toml", |file| {
        find(file).map(|text| (text.to_owned(), format!("built-in shapes/{file}"))).ok_or_else(|| SimError::Unknown {
            kind: "built-in shape file",
            name: file.to_owned(),
            known: SHAPE_FILES.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "),
        })
    })
}

#[cfg(test)]
mod tests {
    use super::RECIPES;
    use crate::dataset::Recipe;

    /// The default sensor changed body once (the half-space's to the finite-element dome's):
    /// a built-in recipe names its sensor, so that such a change never alters a protocol's
    /// datasets, grids or committed figures unseen. The `explore` recipe (`cargo xtask
    /// explore`, a file) is held to the same.
    #[test]
    fn every_built_in_recipe_names_its_sensor() {
        let explore = ("explore", include_str!("../../scenarios/datasets/explore.toml"));
        for (name, text) in RECIPES.iter().chain([&explore]) {
            let recipe = Recipe::from_toml_str(text, name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(recipe.sensor.is_some(), "scenarios/datasets/{name}.toml names no `sensor`");
        }
    }
}
