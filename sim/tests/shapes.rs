//! The committed stimuli: reproducible from `cargo xtask shapes`, loadable, sized like the
//! lab's shapes, with area and perimeter matching their analytic (or finely generated) values.

use std::path::PathBuf;

use tacsim_sim::stimulus::Catalogue;
use tacsim_sim::stimulus::{builtin_shapes, shape_files};

fn shapes_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shapes")
}

#[test]
fn committed_shapes_equal_the_generator_output() {
    for (name, text) in shape_files().expect("generation succeeds") {
        let committed = std::fs::read_to_string(shapes_dir().join(&name)).expect("committed file exists");
        assert!(committed == text, "shapes/{name} is stale: run `cargo xtask shapes` and commit");
    }
}

#[test]
fn every_shape_loads_with_the_right_area_and_perimeter() {
    let catalogue = Catalogue::load_dir(&shapes_dir()).expect("catalogue loads");
    let specs = builtin_shapes();
    assert!(catalogue.stimuli.len() >= 7);
    for spec in &specs {
        let s = catalogue.get(&spec.entry.name).expect("listed");
        let (area, perimeter) = (s.contour.area_mm2(), s.contour.perimeter_mm());
        let (ref_area, ref_perimeter) = (spec.outline.reference_area(), spec.outline.reference_perimeter());
        // 0.5 mm chords on radii >= 6 mm: chord error < 1e-3 relative; 4-decimal OBJ rounding.
        let (ea, ep) = ((area - ref_area) / ref_area, (perimeter - ref_perimeter) / ref_perimeter);
        println!(
            "{:<9} area {area:9.2} mm2 (ref {ref_area:9.2}, {:+.2e})  perimeter {perimeter:7.2} mm (ref {ref_perimeter:7.2}, {:+.2e})",
            spec.entry.name, ea, ep
        );
        assert!(ea.abs() < 1e-3, "{}: area {area} vs {ref_area}", spec.entry.name);
        assert!(ep.abs() < 1e-3, "{}: perimeter {perimeter} vs {ref_perimeter}", spec.entry.name);
        // Closed prism: volume = top area x height.
        assert!((s.mesh.volume() - area * spec.height_mm).abs() < 1e-6 * s.mesh.volume());
        let e = s.extent_mm();
        let across = e[0].max(e[1]);
        assert!((80.0..=120.0).contains(&across), "{} is {across} mm across", spec.entry.name);
        assert!((s.contour.top_z_mm - spec.height_mm).abs() < 1e-9);
    }
}

#[test]
fn spirals_are_acrylic_with_lower_friction_and_training_shapes_have_contacts() {
    let catalogue = Catalogue::load_dir(&shapes_dir()).expect("catalogue loads");
    let abs = catalogue.get("disk").expect("disk").entry.friction;
    for name in ["spiral-1", "spiral-2"] {
        let s = catalogue.get(name).expect("spiral");
        assert_eq!(s.entry.material, "acrylic");
        assert!(s.entry.friction < abs);
    }
    for name in ["disk", "clover", "teardrop"] {
        let s = catalogue.get(name).expect("training shape");
        let c = s.entry.contact_mm.expect("contact location");
        assert!(s.contour.signed_distance(c).abs() < 1e-2, "{name}: contact point off the edge");
    }
    let e = catalogue.get("ellipse").expect_err("unknown shape");
    assert!(e.to_string().contains("disk"), "lists the known shapes: {e}");
}

#[test]
fn bad_catalogues_are_clear_errors() {
    let obj = std::fs::read_to_string(shapes_dir().join("square.obj")).expect("square");
    let read = |_: &str| Ok((obj.clone(), "square.obj".to_owned()));
    let cases = [
        ("[[shape]]\nname = \"a\"\nfile = \"a.obj\"\nmaterial = \"ABS\"\nfriction = -1.0\n", "shape[0].friction"),
        ("[[shape]]\nname = \"a\"\nfile = \"a.obj\"\nmaterial = \"ABS\"\nfriction = nan\n", "shape[0].friction"),
        ("[[shape]]\nname = \"a\"\nfile = \"a.obj\"\nmaterial = \"ABS\"\nfriction = 0.5\ncolour = 1\n", "colour"),
        ("[[shape]]\nname = \"a\"\nfile = \"a.obj\"\nfriction = 0.5\n", "material"),
        (
            "[[shape]]\nname = \"a\"\nfile = \"a.obj\"\nmaterial = \"ABS\"\nfriction = 0.5\ncontact_mm = [0.0, 0.0]\n",
            "shape[0].contact_mm",
        ),
        ("", "no shapes"),
    ];
    for (text, expect) in cases {
        let e = Catalogue::parse(text, "cat.toml", read).expect_err(expect);
        let msg = e.to_string();
        assert!(msg.contains("cat.toml") && msg.contains(expect), "{expect}: {msg}");
    }
    let missing = Catalogue::load_dir(&shapes_dir().join("no-such-dir")).expect_err("missing dir");
    assert!(missing.to_string().contains("catalogue.toml"), "{missing}");
}
