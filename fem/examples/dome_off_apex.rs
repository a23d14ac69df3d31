//! How far a load off the apex sees the apex's shell: the dome's outer surface displacement
//! (mm per N) under a 1 N force spread as the far field's Gaussian patch (`s` mm) about a
//! point at polar angle 0, 10, 20, 30 deg, pressing along the surface's inward normal and
//! shearing along the meridian, read at the outer nodes nearest 0, 2, 4, 6 and 8 mm (arc)
//! from the point along the meridian (towards the base) and across it (the great circle square
//! to it). The contact
//! engine takes every load's far field as the apex's (`DomeContact::far_field_radial`): the
//! ratio to the polar-0 column is what that leaves out for a contact that far down the side
//! (a tilted press on a flat surface centres its contact at the polar angle of the tilt).
//!
//! `cargo run --release -p tacsim-fem --example dome_off_apex -- [GEL_MPA] [BASE_MM] [SPREAD_MM]`
//! (defaults: the surface preset `tactip-331-dome`'s gel 0.0177 MPa under the 1 MPa skin, its
//! base 20 mm below the apex, `s` = 2.945 mm, 1.5 faces of the 8-cell mesh on a 20 mm
//! dome); the default mesh `8x2+1`, built here (about 100 s, 3.4 GB).

use nalgebra::Vector3;
use tacsim_fem::{Dome, Material, patch_weight};

mod support;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let gel: f64 = args.get(1).map_or(Ok(0.017_677_669_529_663_695), |s| s.parse())?;
    let base: f64 = args.get(2).map_or(Ok(20.0), |s| s.parse())?;
    let s: f64 = args.get(3).map_or(Ok(2.945), |s| s.parse())?;
    let (r, _, _) = support::SIZES_MM;
    let mut spec = support::spec(8, 2, 2, 1)?;
    spec.gel = Material::new(gel, 0.4999)?;
    spec.skirt_mm = base - r;
    let dome = Dome::build(&spec)?;
    let outer = dome.outer_nodes(90.0);
    let at = |p: Vector3<f64>| -> usize {
        *outer
            .iter()
            .min_by(|&&a, &&b| {
                let (da, db) = (Vector3::from(dome.mesh.nodes[a]) - p, Vector3::from(dome.mesh.nodes[b]) - p);
                da.norm_squared().total_cmp(&db.norm_squared())
            })
            .expect("outer nodes")
    };
    println!("gel {gel} MPa under a 1 MPa skin, base {base} mm below the apex, patch s = {s} mm; mm per N");
    let offsets = [0.0, 2.0, 4.0, 6.0, 8.0];
    for (name, shear) in
        [("pressing (normal displacement)", false), ("shear along the meridian (meridian displacement)", true)]
    {
        println!("{name}");
        println!(
            "{:>9}  {:>44}  {:>44}",
            "polar deg", "along the meridian, 0 / 2 / 4 / 6 / 8 mm", "across the meridian, 2 / 4 / 6 / 8 mm"
        );
        for polar in [0.0f64, 10.0, 20.0, 30.0] {
            let th = polar.to_radians();
            let c = Vector3::new(th.sin(), 0.0, th.cos()) * r;
            let n = c / r;
            let meridian = Vector3::new(th.cos(), 0.0, -th.sin());
            let dir = if shear { meridian } else { -n };
            let forces = dome.traction_forces(|p, _| {
                let w = patch_weight(p, c, s);
                [w * dir.x, w * dir.y, w * dir.z]
            });
            let total: Vector3<f64> = forces.iter().map(|f| Vector3::from(*f)).sum();
            let scale = 1.0 / total.dot(&dir);
            let u = dome.solve(&forces);
            let read = |p: Vector3<f64>, along: Vector3<f64>| -> f64 {
                let k = at(p);
                let x = Vector3::from(dome.mesh.nodes[k]);
                let normal = x / x.norm();
                let v = Vector3::from(u[k]) * scale;
                if shear { v.dot(&along) } else { -v.dot(&normal) }
            };
            let row_m: Vec<String> = offsets
                .iter()
                .map(|&d| {
                    let a = th + d / r;
                    let p = Vector3::new(a.sin(), 0.0, a.cos()) * r;
                    format!("{:.4}", read(p, Vector3::new(a.cos(), 0.0, -a.sin())))
                })
                .collect();
            // Across the meridian: the great circle through the point square to it, along
            // which the meridian's direction stays the same.
            let row_p: Vec<String> = offsets[1..]
                .iter()
                .map(|&d| {
                    let a = d / r;
                    let p = c * a.cos() + Vector3::y() * (r * a.sin());
                    format!("{:.4}", read(p, meridian))
                })
                .collect();
            println!("{polar:>9.0}  {:>44}  {:>44}", row_m.join(" / "), row_p.join(" / "));
        }
    }
    Ok(())
}
