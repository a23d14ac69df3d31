//! The pins' response by reciprocity: against a direct solve of point loads, its faces' lookup,
//! determinism and the cache file.

use tacsim_fem::{Dome, DomeSpec, PinResponse, face_shape, response_key};

mod support;

use support::pins;

fn spec() -> DomeSpec {
    support::spec(4)
}

/// A point of the outer sphere at polar angle and azimuth (deg).
fn on_sphere(polar: f64, azimuth: f64) -> [f64; 3] {
    let (t, p) = (polar.to_radians(), azimuth.to_radians());
    [20.0 * t.sin() * p.cos(), 20.0 * t.sin() * p.sin(), 20.0 * t.cos()]
}

/// Loads on the dome: a cluster near the apex, one off it, one near the rim.
fn loads() -> Vec<([f64; 3], [f64; 3])> {
    vec![
        (on_sphere(0.0, 0.0), [0.01, 0.0, -0.3]),
        (on_sphere(2.5, 40.0), [0.0, 0.02, -0.2]),
        (on_sphere(15.0, 130.0), [0.05, -0.01, -0.1]),
        (on_sphere(80.0, 250.0), [-0.02, 0.03, 0.01]),
    ]
}

#[test]
fn pin_response_reproduces_a_direct_solve_of_point_loads() {
    // On the one lattice and with the skin's elements twice finer (its pins read through tied
    // nodes).
    for refinement in [1, 2] {
        reproduces_a_direct_solve(&support::spec_refined(4, refinement));
    }
}

fn reproduces_a_direct_solve(spec: &DomeSpec) {
    let dome = Dome::build(spec).expect("dome");
    let sites = pins(1.0);
    let response = PinResponse::compute(&dome, &sites, |_, _| {}).expect("response");
    let (motions, missed) = response.motions(loads());
    assert_eq!(missed, [0.0; 3]);
    // The same loads as consistent nodal forces on the mesh, solved directly.
    let mut nodal = vec![[0.0; 3]; dome.mesh.nodes.len()];
    let outer = dome.outer_nodes(90.0);
    for (x, f) in loads() {
        let (nodes, n) = response.locate(x).expect("on the hemisphere");
        let total: f64 = n.iter().sum();
        assert!((total - 1.0).abs() < 1e-12, "shape functions sum to {total}");
        for (&k, w) in nodes.iter().zip(n) {
            for c in 0..3 {
                nodal[outer[k as usize]][c] += w * f[c];
            }
        }
    }
    let u = dome.solve(&nodal);
    let probes = dome.pin_probes(&sites).expect("probes");
    let mut largest = 0.0f64;
    for (p, probe) in probes.iter().enumerate() {
        let direct = probe.motion_of(|node, c| u[node][c]);
        let scale = direct[..3].iter().fold(1e-6f64, |m, v| m.max(v.abs()));
        for i in 0..6 {
            let err = (motions[p][i] - direct[i]).abs();
            largest = largest.max(err / scale);
            // The table is stored in f32: 1e-6 of the pin's largest motion.
            assert!(err < 1e-5 * scale, "pin {p} row {i}: {} against {}", motions[p][i], direct[i]);
        }
    }
    eprintln!("largest relative difference {largest:.2e}");
}

#[test]
fn a_load_is_found_on_the_face_that_holds_it() {
    let dome = Dome::build(&spec()).expect("dome");
    let response = PinResponse::compute(&dome, &pins(0.0), |_, _| {}).expect("response");
    // Every face's own centre (l = 1/3 each) is found on a face that maps to the same point.
    for face in response.faces.iter().step_by(7) {
        let x = face.map(|k| response.nodes[k as usize]);
        let n = face_shape([1.0 / 3.0; 3]);
        let mut p = [0.0; 3];
        for k in 0..6 {
            for c in 0..3 {
                p[c] += n[k] * x[k][c];
            }
        }
        let (nodes, w) = response.locate(p).expect("located");
        let mut q = [0.0; 3];
        for (&k, w) in nodes.iter().zip(w) {
            for (qc, xc) in q.iter_mut().zip(response.nodes[k as usize]) {
                *qc += w * xc;
            }
        }
        let gap = (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f64>().sqrt();
        assert!(gap < 1e-9, "face centre {p:?} found at {q:?}");
    }
    // Below the equator: no face.
    assert!(response.locate([0.0, 20.0, -1.0]).is_none());
    let (_, missed) = response.motions([([0.0, 20.0, -1.0], [0.0, 0.0, 1.0])]);
    assert_eq!(missed, [0.0, 0.0, 1.0]);
}

#[test]
fn pin_response_does_not_depend_on_the_thread_count() {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
        pool.install(|| {
            let dome = Dome::build(&spec()).expect("dome");
            PinResponse::compute(&dome, &pins(0.5), |_, _| {}).expect("response")
        })
    };
    let (one, two) = (run(1), run(2));
    let bits = |r: &PinResponse| r.table.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&one), bits(&two));
}

#[test]
fn pin_response_cache_reads_back_what_it_wrote_and_refuses_other_files() {
    let dir = std::env::temp_dir().join(format!("tacsim-fem-pins-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (spec, sites) = (spec(), pins(0.0));
    let built = PinResponse::cached(&dir, &spec, &sites, 0.0, |_, _| {}).expect("built");
    let key = response_key(&spec, &sites, 0.0);
    let path = PinResponse::path_in(&dir, key);
    assert!(path.exists());
    let read = PinResponse::cached(&dir, &spec, &sites, 0.0, |_, _| {}).expect("read");
    assert_eq!((built.key, &built.nodes, &built.faces, built.pins), (read.key, &read.nodes, &read.faces, read.pins));
    assert_eq!(built.table, read.table);
    assert_eq!(built.apex.len(), 9 * built.nodes.len());
    assert_eq!(built.apex, read.apex);
    assert_eq!(built.motions(loads()).0, read.motions(loads()).0);
    let other = PinResponse::load(&path, key ^ 1).expect_err("wrong key");
    assert!(other.to_string().contains("tacsim-pins-") && other.to_string().contains("delete the file"), "{other}");
    let bytes = std::fs::read(&path).expect("read");
    std::fs::write(&path, &bytes[..bytes.len() - 4]).expect("write");
    let cut = PinResponse::load(&path, key).expect_err("truncated");
    assert!(cut.to_string().contains("bytes of tables"), "{cut}");
    // A header whose counts would overflow a usize's product: refused, no panic, nothing
    // allocated for them.
    let start = bytes.iter().position(|&b| b == b'{').expect("the JSON header");
    let len = u64::from_le_bytes(bytes[start - 8..start].try_into().expect("8 bytes")) as usize;
    let header = std::str::from_utf8(&bytes[start..start + len]).expect("JSON");
    let nodes = format!("\"nodes\":{}", read.nodes.len());
    assert!(header.contains(&nodes), "{header}");
    let absurd = header.replace(&nodes, &format!("\"nodes\":{}", usize::MAX / 2));
    let mut forged = bytes[..start - 8].to_vec();
    forged.extend((absurd.len() as u64).to_le_bytes());
    forged.extend(absurd.as_bytes());
    forged.extend(&bytes[start + len..]);
    std::fs::write(&path, &forged).expect("write");
    let huge = PinResponse::load(&path, key).expect_err("absurd counts");
    assert!(huge.to_string().contains("bytes of tables"), "{huge}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The pins' motions (6 rows each) of the dome under a Gaussian patch `exp(-|Y - X|^2 / s^2)`
/// (cut at 3.5 s) of total force `f` centred at `x`, solved directly.
fn patch_motions(dome: &Dome, sites: &[tacsim_fem::PinSite], x: [f64; 3], f: [f64; 3], s: f64) -> Vec<[f64; 6]> {
    let g = |p: [f64; 3]| {
        let d2: f64 = (0..3).map(|k| (p[k] - x[k]).powi(2)).sum();
        if d2 < (3.5 * s).powi(2) { (-d2 / (s * s)).exp() } else { 0.0 }
    };
    let unit = dome.traction_forces(|p, _| [g(p), 0.0, 0.0]);
    let total: f64 = unit.iter().map(|v| v[0]).sum();
    let nodal = dome.traction_forces(|p, _| f.map(|fc| fc * g(p) / total));
    let u = dome.solve(&nodal);
    let probes = dome.pin_probes(sites).expect("probes");
    probes.iter().map(|probe| probe.motion_of(|node, c| u[node][c])).collect()
}

#[test]
fn a_spread_response_is_the_response_to_a_gaussian_patch() {
    let dome = Dome::build(&spec()).expect("dome");
    let sites = pins(0.0);
    let raw = PinResponse::compute(&dome, &sites, |_, _| {}).expect("response");
    let s = 3.0;
    let spread = raw.spread(s).expect("spread");
    // At a node the table's column is that node's patch: the f32 table's rounding. Between
    // nodes the faces interpolate the nodes' patches: measured 0.41% of the largest motion at
    // a face's centre (4 cells, s = 3 mm).
    let node = raw.nodes.iter().copied().find(|x| x[2] > 19.0 && x[0] > 1.0).expect("a node near the apex");
    let face = raw.faces[raw.faces.len() / 3].map(|k| raw.nodes[k as usize]);
    let centre = [0, 1, 2].map(|k| (face[0][k] + face[1][k] + face[2][k]) / 3.0);
    let norm = (centre.iter().map(|v| v * v).sum::<f64>()).sqrt();
    let centre = centre.map(|v| 20.0 * v / norm);
    let f = [0.02, -0.01, -0.3];
    for (x, tolerance) in [(node, 1e-5), (centre, 1e-2)] {
        let (motions, missed) = spread.motions([(x, f)]);
        assert_eq!(missed, [0.0; 3]);
        let direct = patch_motions(&dome, &sites, x, f, s);
        let scale = direct.iter().flat_map(|m| m[..3].iter()).fold(0.0f64, |a, v| a.max(v.abs()));
        let mut largest = 0.0f64;
        for (m, d) in motions.iter().zip(&direct) {
            for i in 0..3 {
                largest = largest.max((m[i] - d[i]).abs() / scale);
            }
        }
        eprintln!("patch at {x:?}: largest difference {largest:.2e} of {scale:.3e} mm");
        assert!(largest < tolerance, "patch at {x:?}: {largest:.2e} of the largest motion");
    }
    assert!(raw.spread(0.0).is_err() && raw.spread(f64::NAN).is_err());
}

/// The surface's response to the apex's patch ([`PinResponse::with_apex`]) is the dome's
/// displacement under that patch solved directly: at the outer nodes, to the `f32` table's
/// rounding, for a force along each axis; `apex_field` reads it where a ray meets the surface.
#[test]
fn the_apex_field_is_the_domes_displacement_under_the_apex_patch() {
    let dome = Dome::build(&spec()).expect("dome");
    let s = 3.0;
    let response = PinResponse::compute(&dome, &pins(0.0), |_, _| {})
        .expect("response")
        .spread(s)
        .expect("spread")
        .with_apex(&dome)
        .expect("apex");
    let apex = [0.0, 0.0, 20.0];
    let g = |p: [f64; 3]| {
        let d2: f64 = (0..3).map(|k| (p[k] - apex[k]).powi(2)).sum();
        if d2 < (3.5 * s).powi(2) { (-d2 / (s * s)).exp() } else { 0.0 }
    };
    let total: f64 = dome.traction_forces(|p, _| [g(p), 0.0, 0.0]).iter().map(|v| v[0]).sum();
    let outer = dome.outer_nodes(90.0);
    for c in 0..3 {
        let nodal = dome.traction_forces(|p, _| {
            let mut f = [0.0; 3];
            f[c] = g(p) / total;
            f
        });
        let u = dome.solve(&nodal);
        let scale = outer.iter().flat_map(|&n| u[n]).fold(0.0f64, |a, v| a.max(v.abs()));
        for (i, &n) in outer.iter().enumerate() {
            let read = response.apex_field(response.nodes[i]).expect("on the hemisphere");
            for k in 0..3 {
                assert!(
                    (read[c][k] - u[n][k]).abs() <= 1e-5 * scale,
                    "force {c}, node {n}: {:?} vs {:?}",
                    read[c],
                    u[n]
                );
            }
        }
    }
}
