//! Builds a dome and reports its size, the time of each stage and a central press's response.
//!
//! `cargo run --release -p tacsim-fem --example dome_build -- [CELLS] [SKIN_LAYERS]`

use std::time::Instant;

use tacsim_fem::{Dome, DomeSpec, Material};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let cells = args.get(1).map_or(Ok(10), |s| s.parse())?;
    let skin_layers = args.get(2).map_or(Ok(2), |s| s.parse())?;
    let spec = DomeSpec {
        outer_radius_mm: 20.0,
        skin_thickness_mm: 0.66,
        skirt_mm: 0.0,
        skin: Material::new(1.0, 0.436)?,
        gel: Material::new(0.1, 0.4999)?,
        cells,
        skin_layers,
    };
    let t = Instant::now();
    let dome = Dome::build(&spec)?;
    let built = t.elapsed().as_secs_f64();
    println!(
        "cells {cells}, skin layers {skin_layers}: {} nodes, {} elements, {} free dofs, {} stored, L {} entries; build {built:.2} s",
        dome.mesh.nodes.len(),
        dome.mesh.elements.len(),
        dome.stiffness.size(),
        dome.stiffness.stored(),
        dome.factor.factor_entries()
    );
    // A 0.05 MPa press over the cap within 15 deg of the apex.
    let cos15 = 15f64.to_radians().cos();
    let r = spec.outer_radius_mm;
    let t = Instant::now();
    let f = dome.pressure_forces(|x| if x[2] >= cos15 * r { 0.05 } else { 0.0 });
    let u = dome.solve(&f);
    println!("one solve {:.3} s", t.elapsed().as_secs_f64());
    let apex = dome.outer_nodes(0.0)[0];
    let swept = dome.swept_volume(&u, |c| c[2] >= cos15 * r);
    let gel = dome.gel_volume_change(&u);
    println!(
        "apex displacement {:?} mm; swept {swept:.4} mm^3, gel volume change {gel:.3e} mm^3 ({:.3}%)",
        u[apex],
        100.0 * gel.abs() / swept
    );
    let base = [0.0, (r - 0.66) * 20f64.to_radians().sin(), (r - 0.66) * 20f64.to_radians().cos()];
    let n = nalgebra_free_normal(base);
    let tip = [base[0] - 2.84 * n[0], base[1] - 2.84 * n[1], base[2] - 2.84 * n[2]];
    let probe = dome.pin_probe(0, base, tip)?;
    println!("pin at 20 deg: tip {:?} mm", probe.displacement(&u));
    Ok(())
}

fn nalgebra_free_normal(p: [f64; 3]) -> [f64; 3] {
    let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    p.map(|v| v / n)
}
