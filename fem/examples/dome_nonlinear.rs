//! The geometric-nonlinearity check of issue 85: the TacTip-like dome pressed by a rigid flat
//! to 1, 2 and 3 mm, solved as a neo-Hookean solid and with the linear model under the same
//! frictionless penalty contact. Reports, per depth, the flat's force in each, the largest
//! difference of the outer surface's displacement, and the pins' tips (331 pins, the default
//! sensor's rings) in each: the largest difference and the largest motion.
//!
//! With `default` after them, the default sensor's dome (`sim/presets/tactip-331-dome.toml`:
//! skin 1.86 mm, gel 0.0177 MPa) instead of the calibrated TacTip's, and the depths a list
//! (mm, default 0.1,1,2,3). Each depth also gives the pins' gain: the least-squares factor of
//! the linear pins' motion onto the neo-Hookean's, in all three directions and across the
//! image (x, y), and each ring's mean outward and axial motion in both.
//!
//! `cargo run --release -p tacsim-fem --example dome_nonlinear -- [CELLS] [STEP_MM] [SKIN_LAYERS]
//! [calibrated|default] [DEPTHS]` (default 6 0.25 2 calibrated 0.1,1,2,3).

use std::time::Instant;

use tacsim_fem::{Dome, FlatPress, Kinematics, large_displacement};

mod support;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let cells = args.get(1).map_or(Ok(6), |s| s.parse())?;
    let step_mm: f64 = args.get(2).map_or(Ok(0.25), |s| s.parse())?;
    let skin_layers = args.get(3).map_or(Ok(2), |s| s.parse())?;
    let mut spec = support::spec(cells, skin_layers, 1, 0)?;
    let sites = match args.get(4).map(String::as_str) {
        None | Some("calibrated") => support::rings(0.0),
        Some("default") => {
            let (t, pin_length, gel) = support::DEFAULT_DOME;
            spec.skin_thickness_mm = t;
            spec.gel = tacsim_fem::Material::new(gel, spec.gel.poisson)?;
            support::rings_of(t, pin_length, 0.0)
        }
        Some(other) => return Err(format!("the dome must be `calibrated` or `default`, got `{other}`").into()),
    };
    let depths_mm = match args.get(5) {
        None => vec![0.1, 1.0, 2.0, 3.0],
        Some(list) => list.split(',').map(str::parse).collect::<Result<Vec<f64>, _>>()?,
    };
    let dome = Dome::build(&spec)?;
    let probes = dome.pin_probes(&sites)?;
    let press = FlatPress { depths_mm, step_mm, penalty_n_per_mm: 1000.0 };
    let clock = Instant::now();
    let linear = press.run(&dome, Kinematics::Linear, |d, n| eprintln!("linear: {d:.4} mm in {n} iterations"))?;
    println!(
        "{cells} cells, {} free dofs: linear press in {:.1} s",
        dome.stiffness.size(),
        clock.elapsed().as_secs_f64()
    );
    let clock = Instant::now();
    let large =
        press.run(&dome, Kinematics::NeoHookean, |d, n| eprintln!("neo-Hookean: {d:.4} mm in {n} iterations"))?;
    println!("neo-Hookean press in {:.1} s", clock.elapsed().as_secs_f64());
    let outer = dome.outer_nodes(90.0);
    for (a, b) in linear.iter().zip(&large) {
        let surface = outer
            .iter()
            .map(|&n| (0..3).map(|k| (a.displacement[n][k] - b.displacement[n][k]).powi(2)).sum::<f64>().sqrt())
            .fold(0.0f64, f64::max);
        let (mut worst, mut moved, mut worst_pin) = (0.0f64, 0.0f64, 0);
        // Per ring (1 + 6 r pins, the sites' order): the mean radial motion across the image
        // (mm, outward positive) and the mean motion along the axis, linear and neo-Hookean.
        let mut rings = [[0.0f64; 4]; 11];
        // Sums of lin . big and lin . lin, in 3-d and across the image (x, y).
        let mut gain = [0.0f64; 4];
        for (p, probe) in probes.iter().enumerate() {
            let lin = probe.displacement(&a.displacement);
            let big = large_displacement(probe, &dome.mesh, &b.displacement);
            let d = (0..3).map(|k| (lin[k] - big[k]).powi(2)).sum::<f64>().sqrt();
            let ring = (0..=10usize).find(|&r| p < 1 + 3 * r * (r + 1)).unwrap_or(10);
            let base = sites[p].base;
            let across = base[0].hypot(base[1]);
            let outward = |v: [f64; 3]| {
                if across > 0.0 { (v[0] * base[0] + v[1] * base[1]) / across } else { v[0].hypot(v[1]) }
            };
            let count = (6 * ring).max(1) as f64;
            for (slot, v) in [outward(lin), lin[2], outward(big), big[2]].into_iter().enumerate() {
                rings[ring][slot] += v / count;
            }
            for k in 0..3 {
                gain[0] += lin[k] * big[k];
                gain[1] += lin[k] * lin[k];
                if k < 2 {
                    gain[2] += lin[k] * big[k];
                    gain[3] += lin[k] * lin[k];
                }
            }
            if d > worst {
                (worst, worst_pin) = (d, p);
            }
            moved = moved.max(big.iter().map(|v| v * v).sum::<f64>().sqrt());
        }
        println!(
            "depth {:.1} mm: force linear {:.4} N, neo-Hookean {:.4} N ({:+.1}%); surface difference {surface:.4} mm; \
             pins: largest difference {worst:.4} mm (pin {worst_pin}), largest motion {moved:.3} mm, {:.1}%; \
             gain {:.3} (x, y {:.3}); penetration {:.1e} / {:.1e} mm; Newton {} / {} iterations ({} on the \
             linear stiffness)",
            a.depth_mm,
            a.force_n,
            b.force_n,
            100.0 * (b.force_n / a.force_n - 1.0),
            100.0 * worst / moved,
            gain[0] / gain[1],
            gain[2] / gain[3],
            a.penetration_mm,
            b.penetration_mm,
            a.iterations,
            b.iterations,
            b.linear_steps,
        );
        let line = |slot: usize| rings.iter().map(|r| format!("{:+.3}", r[slot])).collect::<Vec<_>>().join(" ");
        println!("  rings 0-10, outward mm: linear {}\n                       neo-Hookean {}", line(0), line(2));
        println!(
            "  rings 0-10, along the axis mm: linear {}\n                              neo-Hookean {}",
            line(1),
            line(3)
        );
    }
    Ok(())
}
