//! `tacsim validate`: prints the analytic contact cases with their bounds and the
//! grid-refinement study (`tacsim_sim::contact::validate::study` runs them).

use anyhow::Result;
use tacsim_sim::contact::validate::{self, bounds};

/// Runs the cases; returns the text to print and whether every bound holds.
pub fn run(grid: usize, json: bool, convergence: bool) -> Result<(String, bool)> {
    let v = validate::study(grid, convergence)?;
    let pass = v.pass;
    if json {
        return Ok((serde_json::to_string_pretty(&v)? + "\n", pass));
    }
    let ok = |e: f64, b: f64| if e.abs() <= b { "ok" } else { "FAIL" };
    let mut out = format!(
        "grid {g}x{g}, {c:.1} cells across the contact diameter\n\n{:<32} {:>12} {:>10}  {}\n",
        "quantity",
        "error",
        "bound",
        "",
        g = v.grid,
        c = v.cells_across_contact
    );
    let h = &v.hertz;
    let c = &v.cattaneo;
    for (name, e, b) in [
        ("hertz force (rel)", h.force_rel_err, bounds::HERTZ_FORCE),
        ("hertz contact radius (rel)", h.radius_rel_err, bounds::HERTZ_RADIUS),
        ("hertz peak pressure (rel)", h.pmax_rel_err, bounds::HERTZ_PMAX),
        ("cattaneo shift (rel)", c.shift_rel_err, bounds::CATTANEO_SHIFT),
        ("cattaneo stick radius (cells)", c.stick_radius_err_cells, bounds::CATTANEO_STICK_CELLS),
    ] {
        out.push_str(&format!("{name:<32} {e:>12.3e} {b:>10.3e}  {}\n", ok(e, b)));
    }
    out.push_str(&format!(
        "\ncattaneo shift {:.4e} mm (theory {:.4e} mm); run time hertz {:.3} s, cattaneo {:.3} s\n",
        c.shift_mm, c.shift_exact_mm, h.seconds, c.seconds
    ));
    if let (Some(levels), Some(o)) = (&v.convergence, &v.orders) {
        out.push_str(&format!(
            "\n{:>5} {:>9} {:>13} {:>13} {:>15} {:>15} {:>8}\n",
            "grid", "cells/2a", "hertz force", "hertz pmax", "cattaneo shift", "shift (nu=0)", "time s"
        ));
        for l in levels {
            out.push_str(&format!(
                "{:>5} {:>9.1} {:>13.3e} {:>13.3e} {:>15.3e} {:>15.3e} {:>8.2}\n",
                l.grid,
                l.cells_across_contact,
                l.hertz_force_rel_err,
                l.hertz_pmax_rel_err,
                l.cattaneo_shift_rel_err,
                l.cattaneo_nu0_shift_rel_err,
                l.seconds
            ));
        }
        let fmt = |v: &[f64]| v.iter().map(|x| format!("{x:.2}")).collect::<Vec<_>>().join(", ");
        out.push_str(&format!(
            "measured orders: hertz force {}; hertz pmax {}; cattaneo shift (nu=0) {}\n",
            fmt(&o.hertz_force),
            fmt(&o.hertz_pmax),
            fmt(&o.cattaneo_nu0_shift)
        ));
    }
    Ok((out, pass))
}
