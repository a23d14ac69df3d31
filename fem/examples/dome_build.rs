//! Builds a dome and reports its size, the time of each stage, the gel's volume change under a
//! press and the pins' tips at a few polar angles (the mesh-convergence figures of
//! `docs/experiments/fem-dome.md`).
//!
//! `cargo run --release -p tacsim-fem --example dome_build -- [CELLS] [SKIN_LAYERS] [PATCH_MM] [CAP_DEG] [REFINEMENT] [GEL_SHELLS]`
//!
//! `PATCH_MM`: the pins' skin patch radius (default 0, the base alone). With `CAP_DEG`, the response is also condensed onto the outer nodes within that angle of
//! the apex and the default sensor's 331 pins (10 rings 4.536 deg apart), and the time taken
//! reported (`-`: not condensed). `REFINEMENT`: the skin's elements that many times finer than
//! the gel's (`DomeSpec::skin_refinement`, default 1), and with them the gel's outer
//! `GEL_SHELLS` shells (`DomeSpec::refined_gel_shells`, default 0).
//!
//! The press: a Hertz-shaped pressure `p0 sqrt(1 - (theta / 15 deg)^2)`, `p0` = 0.01 MPa, on
//! the outer sphere about the apex. Pins: bases on the skin's inner face, 2.84 mm long, at
//! polar 0, 10, 20, 30, 45 deg in azimuths 90 deg (the y-z plane) and 45 deg.

use std::time::Instant;

use tacsim_fem::{Compliance, Dome, PinSite, SOLVE_BLOCK};

mod support;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let cells = args.get(1).map_or(Ok(10), |s| s.parse())?;
    let skin_layers = args.get(2).map_or(Ok(2), |s| s.parse())?;
    let patch_radius_mm: f64 = args.get(3).map_or(Ok(0.0), |s| s.parse())?;
    let (r, t, pin_length) = support::SIZES_MM;
    let refinement = args.get(5).map_or(Ok(1), |s| s.parse())?;
    let gel_shells = args.get(6).map_or(Ok(0), |s| s.parse())?;
    let spec = support::spec(cells, skin_layers, refinement, gel_shells)?;
    let clock = Instant::now();
    let dome = Dome::build(&spec)?;
    println!(
        "cells {cells}, skin layers {skin_layers}, skin refinement {refinement} with {gel_shells} gel shells: {} nodes, {} elements, {} free dofs, L {} entries; build {:.2} s",
        dome.mesh.nodes.len(),
        dome.mesh.elements.len(),
        dome.stiffness.size(),
        dome.factor.factor_entries(),
        clock.elapsed().as_secs_f64()
    );
    let theta0 = 15f64.to_radians();
    let polar = |x: [f64; 3]| (x[2] / (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()).clamp(-1.0, 1.0).acos();
    let f = dome.pressure_forces(|x| 0.01 * (1.0 - (polar(x) / theta0).powi(2)).max(0.0).sqrt());
    let force: f64 = f.iter().map(|v| v[2]).sum();
    let clock = Instant::now();
    let u = dome.solve(&f);
    println!("press {:.4} N; one solve {:.3} s", -force, clock.elapsed().as_secs_f64());
    let mut block = vec![1.0; dome.stiffness.size() * SOLVE_BLOCK];
    let clock = Instant::now();
    dome.factor.solve_in_place(&mut block);
    println!("{SOLVE_BLOCK} solves in one block {:.3} s", clock.elapsed().as_secs_f64());
    let swept = dome.swept_volume(&u, |c| polar(c) < theta0 * 1.2);
    let gel = dome.gel_volume_change(&u);
    println!("swept {swept:.5} mm^3, gel volume change {gel:.3e} mm^3 ({:.3}%)", 100.0 * gel.abs() / swept);
    let apex = dome.outer_nodes(0.0)[0];
    println!("apex {:?} mm", u[apex].map(|v| (v * 1e5).round() / 1e5));
    for azimuth in [90f64, 45.0] {
        for deg in [0.0f64, 10.0, 20.0, 30.0, 45.0] {
            let (th, ph) = (deg.to_radians(), azimuth.to_radians());
            let n = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
            let base = n.map(|v| v * (r - t));
            let tip = [0, 1, 2].map(|k| base[k] - pin_length * n[k]);
            let d = dome.pin_probe(0, PinSite { base, tip, patch_radius_mm })?.displacement(&u);
            println!("pin azimuth {azimuth} polar {deg}: tip {:?} mm", d.map(|v| (v * 1e5).round() / 1e5));
        }
    }
    if let Some(cap) = args.get(4).filter(|c| *c != "-") {
        let cap: f64 = cap.parse()?;
        let sites = support::rings(patch_radius_mm);
        let clock = Instant::now();
        let c = Compliance::condense(&dome, cap, &sites, |_, _| {})?;
        println!(
            "condensed onto {} surface nodes within {cap} deg and {} pins: {:.1} s ({} MB of tables)",
            c.nodes.len(),
            c.pins,
            clock.elapsed().as_secs_f64(),
            8 * (c.surface.len() + c.pin_table.len()) / 1_000_000
        );
    }
    Ok(())
}
