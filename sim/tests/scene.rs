//! Scene queries: surface height by ray cast, objects near a footprint, and the contour's
//! signed distance and tangent, for several objects in arbitrary planar poses.

use std::path::PathBuf;

use tacsim_sim::stimulus::Catalogue;
use tacsim_sim::{ObjectPose, Scene};

fn catalogue() -> Catalogue {
    Catalogue::load_dir(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shapes")).expect("catalogue")
}

#[test]
fn heights_and_edges_of_two_posed_objects() {
    let cat = catalogue();
    let mut scene = Scene::new();
    let disk = scene
        .add(cat.get("disk").expect("disk"), ObjectPose { position_mm: [10.0, 20.0, 0.0], yaw_deg: 30.0 })
        .expect("add disk");
    let square = scene
        .add(cat.get("square").expect("square"), ObjectPose { position_mm: [200.0, 0.0, 5.0], yaw_deg: 45.0 })
        .expect("add square");

    let h = scene.surface_height(10.0, 20.0).expect("over the disk");
    assert_eq!(h.object, disk);
    assert!((h.height_mm - 10.0).abs() < 1e-4, "{h:?}");
    assert!(h.normal[2] > 0.999);
    let h = scene.surface_height(200.0, 60.0).expect("over the square's rotated corner");
    assert_eq!(h.object, square);
    assert!((h.height_mm - 15.0).abs() < 1e-4, "{h:?}");
    assert!(scene.surface_height(100.0, 0.0).is_none(), "between the objects");
    assert!(scene.surface_height(200.0, 66.0).is_none(), "just beyond the corner at 45 * sqrt(2) = 63.6 mm");

    // Disk edge: radius 50 around (10, 20); outward point at 55 mm along 30 deg.
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let e = scene.edge(disk, 10.0 + 55.0 * c, 20.0 + 55.0 * s);
    assert!((e.signed_distance_mm - 5.0).abs() < 1e-3, "{e:?}");
    // Counter-clockwise tangent: the outward normal turned left.
    assert!((e.tangent[0] + s).abs() < 1e-3 && (e.tangent[1] - c).abs() < 1e-3, "{e:?}");
    let inside = scene.edge(disk, 10.0, 20.0);
    assert!((inside.signed_distance_mm + 50.0).abs() < 1e-3);

    // Square rotated by 45 deg: its side's outward normal points along 45 deg.
    let d = 45.0 + 3.0;
    let e = scene.edge(square, 200.0 + d * 45f64.to_radians().cos(), d * 45f64.to_radians().sin());
    assert!((e.signed_distance_mm - 3.0).abs() < 1e-6, "{e:?}");

    assert_eq!(scene.objects_in_box([-60.0, -60.0, 0.0], [0.0, 0.0, 20.0]), vec![disk]);
    assert_eq!(scene.objects_in_box([150.0, -10.0, 0.0], [160.0, 10.0, 20.0]), vec![square]);
    assert!(scene.objects_in_box([100.0, 100.0, 0.0], [120.0, 120.0, 20.0]).is_empty());
    assert_eq!(scene.contour_world(disk)[0].len(), cat.get("disk").expect("disk").contour.loops[0].len());
}

#[test]
fn spiral_gaps_have_no_surface_and_non_finite_poses_are_rejected() {
    let cat = catalogue();
    let spiral = cat.get("spiral-1").expect("spiral");
    let mut scene = Scene::new();
    let id = scene.add(spiral.clone(), ObjectPose::default()).expect("add");
    // Along +x the centre line crosses at r = 10 + 40 k; halfway between turns is empty.
    assert!(scene.surface_height(30.0, 0.0).is_none());
    assert!(scene.surface_height(50.0, 0.0).is_some_and(|h| h.object == id && (h.height_mm - 6.0).abs() < 1e-4));
    let e = scene.add(spiral, ObjectPose { position_mm: [f64::NAN, 0.0, 0.0], yaw_deg: 0.0 }).expect_err("nan");
    assert!(e.to_string().contains("pose"), "{e}");
}
