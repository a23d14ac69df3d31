//! `tacsim validate`: the analytic contact cases with their bounds, and the grid-refinement
//! study with measured orders of convergence.

use anyhow::Result;
use serde::Serialize;
use tacsim_sim::contact::validate::{self, CattaneoReport, HertzReport};

/// Bounds every case must meet on the default grid (the acceptance limits).
pub mod bounds {
    /// |relative error| of the Hertz force.
    pub const HERTZ_FORCE: f64 = 0.005;
    /// |relative error| of the Hertz contact radius.
    pub const HERTZ_RADIUS: f64 = 0.01;
    /// |relative error| of the Hertz peak pressure.
    pub const HERTZ_PMAX: f64 = 0.01;
    /// |relative error| of the Cattaneo shift.
    pub const CATTANEO_SHIFT: f64 = 0.002;
    /// Error of the Cattaneo stick radius (cells).
    pub const CATTANEO_STICK_CELLS: f64 = 1.0;
}

/// Grids of the refinement study.
pub const REFINEMENTS: [usize; 4] = [17, 33, 65, 129];

/// One refinement level.
#[derive(Debug, Serialize)]
pub struct Level {
    /// Cells across the grid.
    pub grid: usize,
    /// Cells across the contact diameter.
    pub cells_across_contact: f64,
    /// Hertz force relative error.
    pub hertz_force_rel_err: f64,
    /// Hertz peak-pressure relative error.
    pub hertz_pmax_rel_err: f64,
    /// Cattaneo shift relative error at the reference `nu = 0.42`.
    pub cattaneo_shift_rel_err: f64,
    /// Cattaneo shift relative error at `nu = 0`, where the theory is exact.
    pub cattaneo_nu0_shift_rel_err: f64,
    /// Wall time of the three cases (s).
    pub seconds: f64,
}

/// The whole answer of `tacsim validate --json`.
#[derive(Debug, Serialize)]
pub struct Validation {
    /// Cells across the grid.
    pub grid: usize,
    /// Cells across the contact diameter.
    pub cells_across_contact: f64,
    /// The Hertz case.
    pub hertz: HertzReport,
    /// The Cattaneo-Mindlin case.
    pub cattaneo: CattaneoReport,
    /// Whether every bound holds.
    pub pass: bool,
    /// The refinement study, when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub convergence: Option<Vec<Level>>,
    /// Measured orders between successive levels (`log2(e_n / e_2n)`), per quantity.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orders: Option<Orders>,
}

/// Measured orders of convergence between successive refinement levels.
#[derive(Debug, Serialize)]
pub struct Orders {
    /// Hertz force.
    pub hertz_force: Vec<f64>,
    /// Hertz peak pressure.
    pub hertz_pmax: Vec<f64>,
    /// Cattaneo shift at `nu = 0`.
    pub cattaneo_nu0_shift: Vec<f64>,
}

fn orders(errors: &[f64]) -> Vec<f64> {
    errors.windows(2).map(|w| (w[0].abs() / w[1].abs()).log2()).collect()
}

/// Runs the cases; returns the text to print and whether every bound holds.
pub fn run(grid: usize, json: bool, convergence: bool) -> Result<(String, bool)> {
    anyhow::ensure!(grid >= 5 && grid % 2 == 1, "--grid must be odd and at least 5, got {grid}");
    let hertz = validate::hertz(grid)?;
    let cattaneo = validate::cattaneo(grid)?;
    let pass = hertz.force_rel_err.abs() <= bounds::HERTZ_FORCE
        && hertz.radius_rel_err.abs() <= bounds::HERTZ_RADIUS
        && hertz.pmax_rel_err.abs() <= bounds::HERTZ_PMAX
        && cattaneo.shift_rel_err.abs() <= bounds::CATTANEO_SHIFT
        && cattaneo.stick_radius_err_cells <= bounds::CATTANEO_STICK_CELLS;
    let mut study = None;
    let mut order = None;
    if convergence {
        let mut levels = Vec::new();
        for n in REFINEMENTS {
            let start = std::time::Instant::now();
            let h = validate::hertz(n)?;
            let c = validate::cattaneo(n)?;
            let c0 = validate::cattaneo_with(n, 0.0)?;
            levels.push(Level {
                grid: n,
                cells_across_contact: h.cells_across_contact,
                hertz_force_rel_err: h.force_rel_err,
                hertz_pmax_rel_err: h.pmax_rel_err,
                cattaneo_shift_rel_err: c.shift_rel_err,
                cattaneo_nu0_shift_rel_err: c0.shift_rel_err,
                seconds: start.elapsed().as_secs_f64(),
            });
        }
        order = Some(Orders {
            hertz_force: orders(&levels.iter().map(|l| l.hertz_force_rel_err).collect::<Vec<_>>()),
            hertz_pmax: orders(&levels.iter().map(|l| l.hertz_pmax_rel_err).collect::<Vec<_>>()),
            cattaneo_nu0_shift: orders(&levels.iter().map(|l| l.cattaneo_nu0_shift_rel_err).collect::<Vec<_>>()),
        });
        study = Some(levels);
    }
    let v = Validation {
        grid,
        cells_across_contact: hertz.cells_across_contact,
        hertz,
        cattaneo,
        pass,
        convergence: study,
        orders: order,
    };
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
